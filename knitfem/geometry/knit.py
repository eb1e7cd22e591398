"""The plain-knit (stockinette) Ω loop: its closed form and valid sizes.

Coordinates: x along a course (wale spacing ``w``, loop width), y up the
wales (course spacing ``c``, loop height), z out of the fabric.  The knit
face (the V-shaped legs) faces +z, the purl face (loop heads and sinkers)
-z.  Lengths in any unit (mm in the studies).

The loop (:class:`KnitLoop`) is the closed form of Crane (2023, "A simple
parametric model of plain-knit yarns") with the depth reshaped into two
plateaus.  Course k, parameter t (one loop per 2 pi, heads at t = 2 pi j):

    x = u (t + a sin 2t),   y = k c + h cos t,
    z = -d tanh(beta psi) / tanh(beta),  psi = (cos 2t - kappa) / (1 - kappa cos 2t),

with u = w / 2 pi.  How the three shape numbers are chosen:

* a = 1.4858 (roundness) puts the widest point of the head (x' = 0, at t1
  with cos 2 t1 = -1/(2a)) at x = 3w/8.  Two symmetries of stockinette keep
  equal z at mirror points (x -> -x) and at points related by a half turn
  about the middle of each interlock, so those points must be 2r apart in
  plane; with the bulge at 3w/8 the two legs of a loop and the interlock
  lens are both w/4 wide, the most room a wale has: radius < w/8.
* h = c / (2 cos t1) = 0.868 c puts that widest point half a course above
  the loop centre, so the bulges of neighbouring courses pass each other
  exactly at the interlock lens.
* z: -d on the heads and sinkers, +d on the legs, changing sign (psi = 0)
  at the lens (kappa = cos 2 t1) with sharpness beta = 2; d ~ 1.05 r is
  solved so that a leg and the head it passes over are 2r (1 + 2 %) apart:
  the yarns touch at the crossings.

The swatch tiled from these loops is :mod:`.swatch`.
"""
from dataclasses import dataclass
from functools import cached_property
import math

import numpy as np
from scipy.optimize import brentq
from scipy.spatial import cKDTree

BETA = 2.0            # plateau sharpness of the depth profile
TOUCH = 0.02          # target gap at contacts, fraction of the diameter
_FINE = 4096          # samples per loop for arclength integrals and inversion


def _bulge(a):
    """Parameter t1 and x/u of the widest point of a head (x'(t1) = 0)."""
    t1 = 0.5 * math.acos(-1.0 / (2.0 * a))
    return t1, t1 + a * math.sin(2.0 * t1)


ROUNDNESS = brentq(lambda a: _bulge(a)[1] - 0.75 * math.pi, 0.6, 5.0, xtol=1e-14)
T1, _ = _bulge(ROUNDNESS)
KAPPA = math.cos(2.0 * T1)


def _size(name, value):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number in (0, inf), got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be finite and in (0, inf), got {value!r}")
    return v


def course_length_range(w, radius):
    """Valid course lengths (c_min, c_max) for wale length ``w`` and yarn radius.

    The tightest bends must stay wider than the yarn: the head's widest point
    bends with radius 0.56 c^2/w in plane and the head top with 0.46 w^2/c;
    with the depth profile added, c >= max(5 r, 1.4 sqrt(r w)) and
    c <= 0.4 w^2/r keep every bend radius above r (bisection over r/w = 5e-4
    ... 0.12).  c <= 4 w: taller loops are no plain knit (and untested)."""
    return max(5.0 * radius, 1.4 * math.sqrt(radius * w)), min(0.4 * w * w / radius, 4.0 * w)


def check_sizes(w, c, radius):
    """(w, c, radius) as floats, or a ValueError naming the bad one and its range."""
    w, c, radius = _size("w", w), _size("c", c), _size("radius", radius)
    if radius >= w / 8.0:
        raise ValueError(f"radius must be < w/8 = {w / 8.0:.6g}, got {radius:.6g}: at each "
                         "interlock two legs and the two sides of the head they pass "
                         "through sit side by side in one wale (4 diameters per w)")
    lo, hi = course_length_range(w, radius)
    if not lo <= c <= hi:
        raise ValueError(f"c must be in [{lo:.6g}, {hi:.6g}] for w = {w:.6g} and radius = "
                         f"{radius:.6g}, got {c:.6g} (c_min = max(5 r, 1.4 sqrt(r w)) and "
                         "c_max = min(0.4 w^2/r, 4 w): beyond them a bend of the loop is "
                         "tighter than the yarn)")
    return w, c, radius


@dataclass(frozen=True)
class KnitLoop:
    """One Ω loop of a plain knit (see the module docstring for the curve).

    w, c, radius : wale length, course length, yarn radius (length unit);
    a : roundness (x overshoot, dimensionless); h : loop half-height and
    d : depth of the plateaus (length); beta, kappa : sharpness and switch
    point of the depth profile (dimensionless)."""
    w: float
    c: float
    radius: float
    a: float
    h: float
    d: float
    beta: float = BETA
    kappa: float = KAPPA

    @property
    def u(self):
        """x scale w / 2 pi (length per unit of t)."""
        return self.w / (2.0 * math.pi)

    def curve(self, t, course=0):
        """Points (n, 3) and derivatives d/dt (n, 3) of course ``course`` at
        parameters t (n,); head j at t = 2 pi j, sinkers at t = pi + 2 pi j."""
        t = np.asarray(t, dtype=float)
        c2, s2 = np.cos(2.0 * t), np.sin(2.0 * t)
        k = self.kappa
        psi = (c2 - k) / (1.0 - k * c2)
        th = np.tanh(self.beta * psi)
        scale = self.d / math.tanh(self.beta)
        dpsi = (1.0 - k * k) / (1.0 - k * c2) ** 2 * (-2.0 * s2)
        p = np.stack([self.u * (t + self.a * s2), course * self.c + self.h * np.cos(t),
                      -scale * th], axis=1)
        dp = np.stack([self.u * (1.0 + 2.0 * self.a * c2), -self.h * np.sin(t),
                       -scale * self.beta * (1.0 - th * th) * dpsi], axis=1)
        return p, dp

    @cached_property
    def _arclength(self):
        t = np.linspace(-math.pi, math.pi, _FINE + 1)
        speed = np.linalg.norm(self.curve(t)[1], axis=1)
        s = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))])
        return t, s

    @property
    def length(self):
        """Yarn length of one loop (sinker to sinker), same unit as w."""
        return float(self._arclength[1][-1])

    def equal_arclength(self, n):
        """n+1 parameters from -pi to pi splitting one loop into n equal arcs."""
        t, s = self._arclength
        return np.interp(np.linspace(0.0, s[-1], n + 1), s, t)

    @property
    def thickness(self):
        """Fabric thickness 2 (d + r): back of the heads to front of the legs."""
        return 2.0 * (self.d + self.radius)


def _crossing_distance(a, h, d, w, c, radius):
    """Closest approach near a crossing of a leg of course 0 over the head of
    course -1 (the interlock contact) for depth d."""
    probe = KnitLoop(w, c, radius, a, h, d)
    n = max(600, int(probe.length / (0.1 * radius)))         # samples ~r/20 apart
    head = probe.curve(np.linspace(0.0, T1, n), course=-1)[0]
    leg = probe.curve(np.linspace(T1, math.pi - T1, n))[0]
    # the in-plane crossing: the leg point closest in plane to the head
    dist, j = cKDTree(leg[:, :2]).query(head[:, :2])
    i = int(np.argmin(dist))
    # nearest 3D approach within a window around it (leaves out the lens,
    # where both strands change sides at equal depth)
    near = np.arange(n)
    return float(cKDTree(leg[np.abs(near - j[i]) < n // 6]).query(
        head[np.abs(near - i) < n // 6])[0].min())


def knit_loop(w=4.0, c=3.0, radius=0.4):
    """The Ω loop for wale length ``w``, course length ``c`` and yarn ``radius``
    (:class:`KnitLoop`); ValueError outside radius < w/8 and
    :func:`course_length_range`."""
    w, c, radius = check_sizes(w, c, radius)
    a, h = ROUNDNESS, c / (2.0 * math.cos(T1))
    target = 2.0 * radius * (1.0 + TOUCH)
    d = brentq(lambda d: _crossing_distance(a, h, d, w, c, radius) - target, 0.5 * radius,
               4.0 * radius, xtol=1e-6 * radius)
    return KnitLoop(w, c, radius, a, h, d)
