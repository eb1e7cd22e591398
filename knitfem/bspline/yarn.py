"""One B-spline yarn: its control points, natural state and constants.

Units: any consistent set (EA force, EI force length^2, line density mass per
length, radius length); the fabric scenes use mm, g, s.
"""
from dataclasses import dataclass

import numpy as np

from . import curve, energy


def positive(name, value, allow_zero=False):
    """float(value), or a ValueError naming ``name`` and its valid range."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        rng = "[0, inf)" if allow_zero else "(0, inf)"
        raise ValueError(f"{name} must be finite and in {rng}, got {value!r}")
    return v


@dataclass
class Yarn:
    """One yarn: control points (N+3, 3) (open) or (N, 3) (closed), rest length
    per segment (N,), stiffnesses, radius and line density.

    curved: the yarn's natural curvature and torsion are those of its initial
    curve (else it is naturally straight); shaped: its natural parametric
    speed too (every point at its initial length, not only every segment);
    self_contact: whether its own samples repel each other (the paper leaves
    it out for the bind-off); set_yarn: a curved yarn whose shape has
    inflections (the knitted loop), its bending and torsion in their smooth
    forms (:func:`knitfem.bspline.energy.set_yarn_terms`)."""
    control: np.ndarray
    rest: np.ndarray
    EA: float
    EI: float
    closed: bool = False
    radius: float = float("nan")
    line_density: float = 1.0
    name: str = "yarn"
    curved: bool = False
    self_contact: bool = True
    shaped: bool = False
    set_yarn: bool = False

    def __post_init__(self):
        self.control = np.asarray(self.control, dtype=float)
        self.rest = np.asarray(self.rest, dtype=float)
        if self.control.ndim != 2 or self.control.shape[1] != 3:
            raise ValueError(f"control points must have shape (n, 3), got {self.control.shape}")
        if not np.all(np.isfinite(self.control)):
            raise ValueError("control points contain NaN or infinite values (valid: finite)")
        if self.segments < 1 or self.rest.shape != (self.segments,):
            raise ValueError(f"rest lengths must have shape ({self.segments},) for "
                             f"{self.control.shape[0]} control points, got {self.rest.shape}")
        if not np.all(np.isfinite(self.rest) & (self.rest > 0)):
            raise ValueError("rest lengths must be finite and in (0, inf)")
        self.EA = positive("EA", self.EA)
        self.EI = positive("EI", self.EI)
        self.line_density = positive("line_density", self.line_density)

    @property
    def segments(self):
        return self.control.shape[0] - (0 if self.closed else 3)

    @classmethod
    def through(cls, points, segments, EA, EI, *, closed=False, natural="shape", length=None,
                **kwargs):
        """A yarn fitted to the centreline ``points`` (n, 3).  natural="shape":
        rest lengths are the fitted segments' lengths (naturally straight);
        "curved": the same and the fitted curve's curvature as natural
        curvature; "straight" with ``length``: equal rest lengths
        length/segments (a straight yarn bent into shape)."""
        q = curve.fit(points, segments, closed)
        if natural in ("shape", "curved"):
            rest = segment_lengths(q, closed)
            kwargs["curved"] = natural == "curved"
            kwargs["shaped"] = True
        elif natural == "straight":
            rest = np.full(segments, positive("length", length) / segments)
        else:
            raise ValueError(f"natural must be 'shape', 'curved' or 'straight', got {natural!r}")
        return cls(q, rest, EA, EI, closed, **kwargs)


def segment_lengths(q, closed=False, points=8):
    """Arclength of every segment of the curve with control points q (Gauss rule)."""
    quad = energy.Quadrature(points)
    a = curve.evaluate(q, quad.u, closed, derivative=1)
    return np.linalg.norm(a, axis=2) @ quad.w
