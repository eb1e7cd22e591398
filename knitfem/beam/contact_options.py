"""The options of beam-beam contact (``BeamModel.contact``), as one value.

A frozen dataclass rather than a positional tuple: the model reads fields by
name, and the checks live with the fields.
"""
from dataclasses import dataclass
import math

from ..contact import DEFAULT_FACTOR, DEFAULT_REGULARISATION, PenaltyLaw


@dataclass(frozen=True)
class ContactOptions:
    """law : a :class:`knitfem.contact.PenaltyLaw`, default k = factor EI/r^4
    of the softest rod, g0 = regularisation (r_a + r_b); exclude : arclength
    below which elements of one rod are neighbours (default 4 r);
    per_diameter : slave Gauss points per yarn diameter; damping : normal
    damping c (line load per gap rate, force time/length^2) during
    ``solve``'s increments, the load path 0 -> 1 taking the pseudo-time
    ``duration``; friction : Coulomb coefficient mu (0: frictionless), slip :
    its stick slip eps, a length (default 1e-3 of the smallest radius; see
    :mod:`knitfem.contact.friction`); corotated : the friction's tangent
    planes turn with the master yarn within a round (else they stay the
    anchor's)."""
    law: PenaltyLaw = None
    factor: float = DEFAULT_FACTOR
    regularisation: float = DEFAULT_REGULARISATION
    exclude: float = None
    per_diameter: float = 6
    damping: float = 0.0
    duration: float = 1.0
    friction: float = 0.0
    slip: float = None
    corotated: bool = False

    def __post_init__(self):
        if self.slip is not None:
            slip = float(self.slip) if isinstance(self.slip, (int, float)) else math.nan
            if not (math.isfinite(slip) and slip > 0):
                raise ValueError(f"contact slip must be finite and in (0, inf), got {self.slip!r}")
        for name, low in (("damping", "[0"), ("duration", "(0"), ("friction", "[0")):
            value = getattr(self, name)
            try:
                value = float(value)
            except (TypeError, ValueError):
                value = math.nan
            if not (math.isfinite(value) and (value > 0 or (value == 0 and low == "[0"))):
                raise ValueError(f"contact {name} must be finite and in {low}, inf), "
                                 f"got {getattr(self, name)!r}")
            object.__setattr__(self, name, value)
        if self.law is not None and not isinstance(self.law, PenaltyLaw):
            raise ValueError(f"contact law must be a knitfem.contact.PenaltyLaw, got "
                             f"{type(self.law).__name__}")
