"""Output analysis of deformed yarn centrelines (no mechanics): curl classification."""
from .curl import CurlShape, curl_shape, loop_centres, point_courses, swatch_curl

__all__ = ["CurlShape", "curl_shape", "loop_centres", "point_courses", "swatch_curl"]
