"""Output analysis of deformed yarn centrelines (no mechanics): curl classification and
roll profiles, how far a classification is from changing, and how far a shape changed
with rigid motion taken out."""
from .curl import CurlShape, curl_shape, loop_centres, point_courses, swatch_curl
from .margin import curl_type, curl_type_intervals, threshold_range
from .profile import RollProfile, profile_fields, roll_profile, swatch_roll_profile
from .shape_change import ShapeChange, principal_extents, shape_change

__all__ = ["CurlShape", "curl_shape", "loop_centres", "point_courses", "swatch_curl",
           "RollProfile", "profile_fields", "roll_profile", "swatch_roll_profile",
           "curl_type", "curl_type_intervals", "threshold_range",
           "ShapeChange", "principal_extents", "shape_change"]
