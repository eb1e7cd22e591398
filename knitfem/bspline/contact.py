"""Yarn-yarn penalty contact between B-spline segments (Kaldor et al. 2008).

Contact is sampled at the Gauss points of every segment.  Two samples p, p'
at distance d closer than 2r (r the yarn radius) and far apart along the yarn
(or on different yarns) repel with the energy

    E = k_contact l l' w w' f(d / 2r),   f(x) = 1/x^2 - 2 + x^2   (x < 1), 0 else,

f(1) = f'(1) = 0, so the force is C0 and the energy C1 at first touch, and
f -> infinity as x -> 0 (a barrier).  ``form="smooth"`` uses (1 - x^2)^3 / x^2
instead: the same barrier, and a stiffness that also starts from 0 (energy
C2), which Newton needs (not the paper's law).  The broad phase is a cKDTree over the
samples (pairs within 2r plus a skin, kept until some sample has moved half
the skin: a Verlet list, see :class:`PairCache`).  Optional contact damping
(dynamic relaxation only) resists the relative velocity of each touching
pair: its normal part (approach and separation) and its tangential part
(sliding), each with its own coefficient.  The pair loop is compiled with
numba.  Units: k_contact energy per length^2, damping force per velocity
per length^2.
"""
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy import sparse
from scipy.spatial import cKDTree


FORMS = {"kaldor": 0, "smooth": 1}


@njit(cache=True, inline="always")
def _law(u, smooth):
    """f, df/du, d2f/du2 at u = (d / 2r)^2 < 1: Kaldor's f = 1/u - 2 + u =
    (1 - u)^2 / u (C1 at u = 1: its second derivative jumps from 0 to 2), or
    the smooth variant (1 - u)^3 / u = 1/u - 3 + 3u - u^2 (C2: the same 1/u
    barrier, a continuous stiffness for Newton)."""
    if smooth:
        return 1.0 / u - 3.0 + 3.0 * u - u * u, -1.0 / (u * u) + 3.0 - 2.0 * u, \
            2.0 / (u * u * u) - 2.0
    return 1.0 / u - 2.0 + u, 1.0 - 1.0 / (u * u), 2.0 / (u * u * u)


@dataclass
class ContactLaw:
    stiffness: float                  # k_contact (energy per length^2)
    radius: float                     # yarn radius r (contact below d = 2r)
    exclude: float = None             # skip pairs closer than this along one yarn (default 4r)
    damping: float = 0.0              # normal damping (force per velocity per length^2)
    tangential_damping: float = 0.0   # tangential damping (same units)
    form: str = "kaldor"              # "kaldor" (1 - u)^2 / u or "smooth" (1 - u)^3 / u

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
        if self.form not in FORMS:
            raise ValueError(f"contact form must be one of {tuple(FORMS)}, got {self.form!r}")

    @property
    def smooth(self):
        return FORMS[self.form]

    @property
    def dissipates(self):
        return self.damping > 0 or self.tangential_damping > 0


def candidate_pairs(points, yarn, arclength, law, reach=None, self_contact=None):
    """Index pairs (m, 2) of samples closer than ``reach`` (default 2r),
    dropping pairs on one yarn closer than ``law.exclude`` in arclength
    (neighbours along the yarn), and all pairs on one yarn whose
    ``self_contact`` flag (per yarn) is False."""
    reach = 2.0 * law.radius if reach is None else reach
    pairs = cKDTree(points).query_pairs(reach, output_type="ndarray")
    if pairs.shape[0] == 0:
        return pairs
    a, b = pairs[:, 0], pairs[:, 1]
    same = yarn[a] == yarn[b]
    keep = ~same | (np.abs(arclength[a] - arclength[b]) > law.exclude)
    if self_contact is not None:
        keep &= ~same | np.asarray(self_contact, bool)[yarn[a]]
    pairs = pairs[keep]
    # in sample order, not the tree's: the energy, summed pair by pair, is then a
    # function of the points alone and not of where a Verlet list was built, so a
    # relaxation resumed from a checkpoint repeats an unbroken one bit for bit
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


class PairCache:
    """Verlet list: candidate pairs within 2r + skin, rebuilt only once some
    sample has moved more than skin/2 since the last build (then no pair can
    have come closer than 2r unseen).  ``builds`` counts the rebuilds."""

    def __init__(self, law, yarn, arclength, skin, self_contact=None):
        self.law, self.yarn, self.arclength = law, yarn, arclength
        self.skin = float(skin)
        self.self_contact = self_contact
        self.points = None
        self.pairs = None
        self.builds = 0

    def __call__(self, points):
        if self.points is not None and points.shape == self.points.shape:
            moved = np.max(np.einsum("ij,ij->i", points - self.points, points - self.points))
            if moved <= (0.5 * self.skin) ** 2:
                return self.pairs
        self.pairs = candidate_pairs(points, self.yarn, self.arclength, self.law,
                                     2.0 * self.law.radius + self.skin, self.self_contact)
        self.points = points.copy()
        self.builds += 1
        return self.pairs


@njit(cache=True, inline="always")
def _separation(points, a, b):
    """p_a - p_b and its squared length, without allocating (the kernels' hot loop)."""
    dx = points[a, 0] - points[b, 0]
    dy = points[a, 1] - points[b, 1]
    dz = points[a, 2] - points[b, 2]
    return dx, dy, dz, dx * dx + dy * dy + dz * dz


@njit(cache=True)
def _pair_forces(points, weights, pairs, k, r, smooth, grad):
    energy = 0.0
    active = 0
    reach2 = 4.0 * r * r
    for m in range(pairs.shape[0]):
        a, b = pairs[m, 0], pairs[m, 1]
        dx, dy, dz, d2 = _separation(points, a, b)
        if d2 >= reach2:
            continue
        u = d2 / reach2                                    # (d / 2r)^2
        ww = k * weights[a] * weights[b]
        f, f_u, _ = _law(u, smooth)
        energy += ww * f
        c = 2.0 * ww * f_u / reach2                        # dE/dp_a = c delta
        grad[a, 0] += c * dx
        grad[a, 1] += c * dy
        grad[a, 2] += c * dz
        grad[b, 0] -= c * dx
        grad[b, 1] -= c * dy
        grad[b, 2] -= c * dz
        active += 1
    return energy, active


def contact_energy(points, weights, pairs, law):
    """Energy, gradient (n_samples, 3) with respect to the sample points and
    the number of touching pairs.  weights (n_samples,): l w of each sample."""
    grad = np.zeros_like(points)
    if len(pairs) == 0:
        return 0.0, grad, 0
    E, n = _pair_forces(points, weights, np.asarray(pairs, np.int64), float(law.stiffness),
                        float(law.radius), law.smooth, grad)
    return float(E), grad, int(n)


@njit(cache=True)
def _pair_damping(points, velocities, weights, pairs, r, cn, ct, out):
    reach2 = 4.0 * r * r
    for m in range(pairs.shape[0]):
        a, b = pairs[m, 0], pairs[m, 1]
        dx, dy, dz, d2 = _separation(points, a, b)
        if d2 >= reach2:
            continue
        d = np.sqrt(d2)
        nx, ny, nz = dx / d, dy / d, dz / d
        vx = velocities[a, 0] - velocities[b, 0]
        vy = velocities[a, 1] - velocities[b, 1]
        vz = velocities[a, 2] - velocities[b, 2]
        vn = vx * nx + vy * ny + vz * nz
        ww = -weights[a] * weights[b]
        # on sample a: -ww (cn v_n n + ct (v - v_n n)); equal and opposite on b
        fx = ww * (cn * vn * nx + ct * (vx - vn * nx))
        fy = ww * (cn * vn * ny + ct * (vy - vn * ny))
        fz = ww * (cn * vn * nz + ct * (vz - vn * nz))
        out[a, 0] += fx
        out[a, 1] += fy
        out[a, 2] += fz
        out[b, 0] -= fx
        out[b, 1] -= fy
        out[b, 2] -= fz


def contact_damping(points, velocities, weights, pairs, law):
    """Damping force (n_samples, 3) on the samples: every pair closer than 2r
    resists its relative velocity, along the pair's normal with ``law.damping``
    and across it with ``law.tangential_damping``, both scaled by l w l' w'
    like the contact energy.  Equal and opposite on the two samples, so it
    never drives the yarns: it only dissipates (power <= 0)."""
    out = np.zeros_like(points)
    if len(pairs) == 0 or not law.dissipates:
        return out
    _pair_damping(points, velocities, weights, np.asarray(pairs, np.int64), float(law.radius),
                  float(law.damping), float(law.tangential_damping), out)
    return out


@njit(cache=True)
def _pair_hessians(points, weights, pairs, k, r, smooth, project):
    """3x3 Hessian with respect to p_a - p_b of every pair (zero if apart):
    ww [f_uu (2 delta/R)(2 delta/R)^T + f_u 2/R I], R = (2r)^2."""
    out = np.zeros((pairs.shape[0], 3, 3))
    reach2 = 4.0 * r * r
    for m in range(pairs.shape[0]):
        a, b = pairs[m, 0], pairs[m, 1]
        delta = points[a] - points[b]
        d2 = delta @ delta
        if d2 >= reach2:
            continue
        ww = k * weights[a] * weights[b]
        _, f_u, f_uu = _law(d2 / reach2, smooth)
        g = 2.0 * delta / reach2
        out[m] = ww * f_uu * np.outer(g, g)
        if not project:                      # f_u < 0 (repulsive): dropped when projected
            out[m] += ww * f_u * 2.0 / reach2 * np.eye(3)
    return out


def contact_hessian(points, weights, pairs, law, project=False):
    """Sparse Hessian (3 n_samples, 3 n_samples) of the contact energy with
    respect to the sample points; ``project``: its positive semi-definite part."""
    n = points.shape[0]
    if len(pairs) == 0:
        return sparse.csr_matrix((3 * n, 3 * n))
    pairs = np.asarray(pairs, np.int64)
    # the touching pairs only: zero blocks of a Verlet list's other candidates would
    # enter the sums of duplicate entries, whose rounding then depends on where the
    # list was built (the energy and gradient skip them already)
    delta = points[pairs[:, 0]] - points[pairs[:, 1]]
    pairs = pairs[np.einsum("ij,ij->i", delta, delta) < 4.0 * float(law.radius) ** 2]
    H = _pair_hessians(points, weights, pairs, float(law.stiffness), float(law.radius),
                       law.smooth, bool(project))
    a, b = pairs[:, 0], pairs[:, 1]
    k3 = np.arange(3)
    rows, cols, vals = [], [], []
    for i_node, j_node, sign in ((a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)):
        rows.append((3 * i_node[:, None, None] + k3[None, :, None]) + 0 * k3[None, None, :])
        cols.append((3 * j_node[:, None, None] + k3[None, None, :]) + 0 * k3[None, :, None])
        vals.append(sign * H)
    rows, cols, vals = (np.concatenate([x.ravel() for x in arr]) for arr in (rows, cols, vals))
    return sparse.csr_matrix((vals, (rows, cols)), shape=(3 * n, 3 * n))


def overlap(points, pairs, law):
    """Largest overlap of the yarn tubes, max(2r - d) / 2r over the pairs
    (0 if no pair is closer than 2r)."""
    if len(pairs) == 0:
        return 0.0
    d = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1)
    return float(max(0.0, 1.0 - d.min() / (2.0 * law.radius)))
