"""The penalty law of yarn-yarn contact, on the gap g = distance - (r_a + r_b).

Line load (force per unit length) pushing the two centrelines apart:

    f(g) = 0                              g >= g0
         = k (g0 - g)^2 / (2 g0)          0 <= g < g0     (regularised: C1 at g0)
         = k (g0/2 - g)                   g < 0           (linear: stiffness k)

and the energy per unit length phi(g) = integral_g^g0 f, so phi' = -f and
phi'' = k (g0 - g)/g0 or k: continuous, which is what keeps Newton quadratic.
:func:`penalty` (numba) is the one kernel: the narrow phase calls it per
Gauss point, :class:`PenaltyLaw` evaluates it over arrays.
The stiffness k (force per length^2) is given relative to the yarn's bending
stiffness, k = factor EI / r^4; with the default factor a yarn pressed by a
line load q = EI/r^3 (a strong load: it bends a span of a few r by ~r) sinks
in by (q/k) = r / factor.
"""
from dataclasses import dataclass
import math

from numba import njit, vectorize
import numpy as np

DEFAULT_FACTOR = 100.0        # penetration r/100 at a line load q = EI/r^3 (the tests: < 1 % of d)
DEFAULT_REGULARISATION = 0.05  # g0 as a fraction of r_a + r_b


@njit(cache=True)
def penalty(g, k, g0):
    """phi, phi', phi'' of the law at the gap g (energy per length and its
    derivatives; the line load is -phi')."""
    if g >= g0:
        return 0.0, 0.0, 0.0
    if g >= 0.0:
        t = g0 - g
        return k * t**3 / (6.0 * g0), -k * t * t / (2.0 * g0), k * t / g0
    return k * (g0 * g0 / 6.0 - 0.5 * g0 * g + 0.5 * g * g), -k * (0.5 * g0 - g), k


@vectorize(["float64(float64, float64, float64)"], cache=True)
def _energy(g, k, g0):
    return penalty(g, k, g0)[0]


@vectorize(["float64(float64, float64, float64)"], cache=True)
def _force(g, k, g0):
    return -penalty(g, k, g0)[1]


@dataclass(frozen=True)
class PenaltyLaw:
    """k: penalty stiffness (force / length^2); g0: regularisation gap (length)."""
    k: float
    g0: float

    def __post_init__(self):
        for name in ("k", "g0"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"penalty {name} must be finite and in (0, inf), got {v!r}")

    @classmethod
    def relative(cls, EI, radius, factor=DEFAULT_FACTOR, regularisation=DEFAULT_REGULARISATION):
        """k = factor EI / r^4, g0 = regularisation 2r (r the yarn radius)."""
        for name, v in (("EI", EI), ("radius", radius), ("factor", factor),
                        ("regularisation", regularisation)):
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be finite and in (0, inf), got {v!r}")
        return cls(factor * EI / radius**4, regularisation * 2.0 * radius)

    def force(self, g):
        """Line load f(g) >= 0 (vectorised)."""
        return _force(np.asarray(g, dtype=float), self.k, self.g0)

    def energy(self, g):
        """phi(g), energy per unit length (vectorised)."""
        return _energy(np.asarray(g, dtype=float), self.k, self.g0)
