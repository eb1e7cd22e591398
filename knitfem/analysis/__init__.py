"""Output analysis of deformed yarn centrelines (no mechanics): curl classification and
roll profiles, and how far a classification is from changing."""
from .curl import CurlShape, curl_shape, loop_centres, point_courses, swatch_curl
from .margin import curl_type, curl_type_intervals, threshold_range
from .profile import RollProfile, profile_fields, roll_profile, swatch_roll_profile

__all__ = ["CurlShape", "curl_shape", "loop_centres", "point_courses", "swatch_curl",
           "RollProfile", "profile_fields", "roll_profile", "swatch_roll_profile",
           "curl_type", "curl_type_intervals", "threshold_range"]
