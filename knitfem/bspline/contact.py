"""Yarn-yarn penalty contact between B-spline segments (Kaldor et al. 2008).

Contact is sampled at the Gauss points of every segment.  Two samples p, p'
at distance d closer than 2r (r the yarn radius) and far apart along the yarn
(or on different yarns) repel with the energy

    E = k_contact l l' w w' f(d / 2r),   f(x) = 1/x^2 - 2 + x^2   (x < 1), 0 else,

f(1) = f'(1) = 0, so the force is C0 and the energy C1 at first touch, and
f -> infinity as x -> 0 (a barrier).  The broad phase is a cKDTree over the
samples (pairs within 2r only); a scene without close pairs pays one tree
query.  Optional contact damping (dynamic relaxation only) resists the
relative velocity of each touching pair: its normal part (approach and
separation) and its tangential part (sliding), each with its own coefficient.
"""
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


@dataclass
class ContactLaw:
    stiffness: float                  # k_contact (energy per length^2)
    radius: float                     # yarn radius r (contact below d = 2r)
    exclude: float = None             # skip pairs closer than this along one yarn (default 4r)
    damping: float = 0.0              # normal damping (force per velocity per length^2)
    tangential_damping: float = 0.0   # tangential damping (same units)

    def __post_init__(self):
        for name in ("stiffness", "radius"):
            v = float(getattr(self, name))
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"contact {name} must be finite and in (0, inf), got {v!r}")
        for name in ("damping", "tangential_damping"):
            v = float(getattr(self, name))
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"contact {name} must be finite and in [0, inf), got {v!r}")
        if self.exclude is None:
            self.exclude = 4.0 * self.radius

    @property
    def dissipates(self):
        return self.damping > 0 or self.tangential_damping > 0


def candidate_pairs(points, yarn, arclength, law):
    """Index pairs (m, 2) of samples closer than 2r, dropping pairs on one yarn
    closer than ``law.exclude`` in arclength (neighbours along the yarn)."""
    pairs = cKDTree(points).query_pairs(2.0 * law.radius, output_type="ndarray")
    if pairs.shape[0] == 0:
        return pairs
    a, b = pairs[:, 0], pairs[:, 1]
    keep = (yarn[a] != yarn[b]) | (np.abs(arclength[a] - arclength[b]) > law.exclude)
    return pairs[keep]


def contact_energy(points, weights, pairs, law):
    """Energy and gradient (n_samples, 3) with respect to the sample points.

    weights (n_samples,): l w of each sample (its share of arclength)."""
    if pairs.shape[0] == 0:
        return 0.0, np.zeros_like(points), 0
    a, b = pairs[:, 0], pairs[:, 1]
    delta = points[a] - points[b]
    d = np.linalg.norm(delta, axis=1)
    x = d / (2.0 * law.radius)
    active = x < 1.0
    a, b, delta, d, x = a[active], b[active], delta[active], d[active], x[active]
    ww = law.stiffness * weights[a] * weights[b]
    energy = float(np.sum(ww * (1.0 / x**2 - 2.0 + x**2)))
    dfdx = -2.0 / x**3 + 2.0 * x
    force = (ww * dfdx / (2.0 * law.radius) / d)[:, None] * delta     # dE/dp_a
    return energy, _action_reaction(a, b, force, points.shape[0]), int(active.sum())


def contact_damping(points, velocities, weights, pairs, law):
    """Damping force (n_samples, 3) on the samples: every pair closer than 2r
    resists its relative velocity, along the pair's normal with ``law.damping``
    and across it with ``law.tangential_damping``, both scaled by l w l' w'
    like the contact energy.  Equal and opposite on the two samples, so it
    never drives the yarns: it only dissipates (power <= 0)."""
    if pairs.shape[0] == 0 or not law.dissipates:
        return np.zeros_like(points)
    a, b = pairs[:, 0], pairs[:, 1]
    delta = points[a] - points[b]
    d = np.linalg.norm(delta, axis=1)
    active = d < 2.0 * law.radius
    a, b, delta, d = a[active], b[active], delta[active], d[active]
    n = delta / d[:, None]
    dv = velocities[a] - velocities[b]
    dv_n = np.sum(dv * n, axis=1)[:, None] * n
    ww = (weights[a] * weights[b])[:, None]
    force = -ww * (law.damping * dv_n + law.tangential_damping * (dv - dv_n))    # on sample a
    return _action_reaction(a, b, force, points.shape[0])


def _action_reaction(a, b, force, n):
    """(n, 3) array holding +force at samples a and -force at samples b."""
    out = np.zeros((n, 3))
    for k in range(3):
        out[:, k] = (np.bincount(a, force[:, k], minlength=n)
                     - np.bincount(b, force[:, k], minlength=n))
    return out
