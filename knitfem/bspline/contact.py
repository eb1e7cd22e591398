"""Yarn-yarn penalty contact between B-spline segments (Kaldor et al. 2008).

Contact is sampled at the Gauss points of every segment.  Two samples p, p'
at distance d closer than 2r (r the yarn radius) and far apart along the yarn
(or on different yarns) repel with the energy

    E = k_contact l l' w w' f(d / 2r),   f(x) = 1/x^2 - 2 + x^2   (x < 1), 0 else,

f(1) = f'(1) = 0, so the force is C0 and the energy C1 at first touch, and
f -> infinity as x -> 0 (a barrier).  The broad phase is a cKDTree over the
samples (pairs within 2r only); a scene without close pairs pays one tree
query.  Optional normal damping acts on the approach velocity of each pair.
"""
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


@dataclass
class ContactLaw:
    stiffness: float                  # k_contact (energy per length^2)
    radius: float                     # yarn radius r (contact below d = 2r)
    exclude: float = None             # skip pairs closer than this along one yarn (default 4r)
    damping: float = 0.0              # normal damping coefficient (force per velocity per length^2)

    def __post_init__(self):
        for name in ("stiffness", "radius"):
            v = float(getattr(self, name))
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"contact {name} must be finite and in (0, inf), got {v!r}")
        if not (np.isfinite(self.damping) and self.damping >= 0):
            raise ValueError(f"contact damping must be finite and in [0, inf), got {self.damping!r}")
        if self.exclude is None:
            self.exclude = 4.0 * self.radius


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
    grad = np.zeros_like(points)
    if pairs.shape[0] == 0:
        return 0.0, grad, 0
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
    for k in range(3):
        grad[:, k] += np.bincount(a, force[:, k], minlength=points.shape[0])
        grad[:, k] -= np.bincount(b, force[:, k], minlength=points.shape[0])
    return energy, grad, int(active.sum())
