"""Curves only: planar elastica guesses, the Ω loop, fabric tiling (no mechanics)."""
from .elastica import planar_elastica
from .knit import KnitLoop, course_length_range, knit_loop
from .swatch import (Swatch, YarnPath, as_rods, bspline_control_points, mirror_swatch,
                     plain_knit_swatch, swatch_control_points, swatch_ties)

__all__ = ["planar_elastica", "KnitLoop", "Swatch", "YarnPath", "as_rods",
           "bspline_control_points", "course_length_range", "knit_loop", "mirror_swatch",
           "plain_knit_swatch", "swatch_control_points", "swatch_ties"]
