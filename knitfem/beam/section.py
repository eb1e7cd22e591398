"""Cross-section stiffness of a rod, diagonal in the director frame (d1 = tangent).

Any consistent unit system works; the rod studies use mm and MPa (N/mm^2), so
forces come out in N and moments in N mm.
"""
from dataclasses import dataclass
import math

import numpy as np


def check_real(name, value):
    """Return ``float(value)`` or raise ValueError naming the parameter."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None


def check_positive(name, value, *, allow_zero=False):
    """Return ``float(value)`` or raise ValueError naming the parameter and range."""
    v = check_real(name, value)
    ok = v >= 0.0 if allow_zero else v > 0.0
    if not (math.isfinite(v) and ok):
        rng = "[0, inf)" if allow_zero else "(0, inf)"
        raise ValueError(f"{name} must be finite and in {rng}, got {value!r}")
    return v


@dataclass(frozen=True)
class Section:
    """Stiffnesses (EA, GA2, GA3) and (GJ, EI2, EI3) about the directors.

    ``radius`` is the contact/rendering radius; ``line_density`` is mass per
    unit length, used only by gravity.
    """
    EA: float
    GA2: float
    GA3: float
    GJ: float
    EI2: float
    EI3: float
    radius: float = float("nan")
    line_density: float = 0.0

    def __post_init__(self):
        for name in ("EA", "GA2", "GA3", "GJ", "EI2", "EI3"):
            object.__setattr__(self, name, check_positive(name, getattr(self, name)))
        object.__setattr__(self, "line_density",
                           check_positive("line_density", self.line_density, allow_zero=True))
        radius = check_real("radius", self.radius)
        if not (math.isnan(radius) or 0 < radius < math.inf):
            raise ValueError(f"radius must be finite and in (0, inf) (or NaN for 'none'), "
                             f"got {self.radius!r}")
        object.__setattr__(self, "radius", radius)

    @property
    def CN(self):
        """Force stiffnesses (EA, GA2, GA3) as an array (3,)."""
        return np.array([self.EA, self.GA2, self.GA3])

    @property
    def CM(self):
        """Moment stiffnesses (GJ, EI2, EI3) as an array (3,)."""
        return np.array([self.GJ, self.EI2, self.EI3])

    @classmethod
    def circle(cls, diameter, E, nu=0.5, *, gj_over_ei=None, density=0.0):
        """Solid circular section of a homogeneous isotropic rod.

        diameter : length; E : Young's modulus; nu : Poisson ratio in (-1, 0.5],
        giving G = E / (2 (1 + nu)) and GJ/EI = 1/(1 + nu); ``gj_over_ei``
        overrides the torsional stiffness.  Shear areas use Cowper's
        coefficient 6(1+nu)/(7+6nu).  ``density`` is mass per volume.
        """
        d = check_positive("diameter", diameter)
        E = check_positive("E", E)
        nu = check_real("nu (Poisson ratio)", nu)
        if not (-1.0 < nu <= 0.5):
            raise ValueError(f"nu (Poisson ratio) must be in (-1, 0.5], got {nu!r}")
        A = math.pi * d * d / 4.0
        I = math.pi * d**4 / 64.0
        G = E / (2.0 * (1.0 + nu))
        kappa = 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu)
        GJ = G * 2.0 * I
        if gj_over_ei is not None:
            GJ = check_positive("gj_over_ei", gj_over_ei) * E * I
        rho = check_positive("density", density, allow_zero=True)
        return cls(E * A, kappa * G * A, kappa * G * A, GJ, E * I, E * I,
                   radius=d / 2.0, line_density=rho * A)

    @classmethod
    def rectangle(cls, width, height, E, nu=0.0, *, torsion_constant=None,
                  shear_coefficient=5.0 / 6.0, density=0.0):
        """Solid rectangle; d2 along ``width``, d3 along ``height``.

        The Saint-Venant torsion constant defaults to Roark's approximation
        a b^3 (1/3 - 0.21 (b/a)(1 - b^4/(12 a^4))), a >= b (0.1408 for a unit
        square; exact 0.1406); pass ``torsion_constant`` to override it.
        """
        b = check_positive("width", width)
        t = check_positive("height", height)
        E = check_positive("E", E)
        nu = check_real("nu (Poisson ratio)", nu)
        if not (-1.0 < nu <= 0.5):
            raise ValueError(f"nu (Poisson ratio) must be in (-1, 0.5], got {nu!r}")
        G = E / (2.0 * (1.0 + nu))
        A = b * t
        a_, b_ = max(b, t), min(b, t)
        J = a_ * b_**3 * (1.0 / 3.0 - 0.21 * b_ / a_ * (1.0 - b_**4 / (12.0 * a_**4)))
        if torsion_constant is not None:
            J = check_positive("torsion_constant", torsion_constant)
        k = check_positive("shear_coefficient", shear_coefficient)
        rho = check_positive("density", density, allow_zero=True)
        return cls(E * A, k * G * A, k * G * A, G * J,
                   E * b * t**3 / 12.0, E * t * b**3 / 12.0,
                   radius=0.5 * math.hypot(b, t), line_density=rho * A)
