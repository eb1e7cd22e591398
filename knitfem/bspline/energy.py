"""Elastic energies of B-spline yarns, their exact gradients and Hessians.

Per segment s, at Gauss points u_g (weights w_g), with a = r'(u), b = r''(u)
(derivatives in the segment parameter), kappa = |a x b| / |a|^3 the
curvature and tau the torsion (density: :mod:`.gausspoint`):

    stretching  E_len  = sum  EA/2 (|a|/l_g - 1)^2 l_g w          (Kaldor's k_len = EA/2)
    bending     E_bend = sum  EI/2 (kappa - kappa0)^2 |a| w      (= EI/2 (kappa - kappa0)^2 ds)
                       + sum  t EI/2 (tau - tau0)^2 |a| w       (naturally curved yarns only)
    gravity     E_g    = -sum rho_l l g . r(u) w

l_g is the rest speed at the Gauss point: the segment's rest length l_s for
a naturally straight yarn (Kaldor's form), the initial |r'| for a yarn whose
natural state is its initial curve (a fitted spline's speed varies along a
segment: with l_s there, the natural shape would not be at rest).  With
kappa0 = 0 the bending energy is Kaldor's EI/2 |a x b|^2 / |a|^5 w.  A
naturally curved yarn (the bind-off helix) has its initial curvature kappa0
and torsion tau0 as rest state: a curve is fixed up to rigid motion by its
curvature and torsion, so the helix is the only shape without energy
(curvature alone would leave a family of constant-curvature curves, down to
a tight coil, at no energy).  No twist of a material frame (Kaldor's yarns
have none); the torsion stiffness is taken equal to EI.  Everything runs
over all segments of all yarns at once: ``seg`` (S, 4) holds global
control-point indices; the loops are compiled with numba (dynamic
relaxation calls them 1e4-1e5 times).  Units: any consistent set (EA force,
EI force x length^2, kappa0 and tau0 1/length).
"""
import numpy as np
from numba import njit

from . import gausspoint
from .curve import basis

B3 = np.array([-1.0, 3.0, -3.0, 1.0])     # r''' = sum_j B3_j q_j on every cubic segment


def gauss(points):
    """Gauss-Legendre nodes and weights on [0, 1]."""
    x, w = np.polynomial.legendre.leggauss(points)
    return 0.5 * (x + 1.0), 0.5 * w


class Quadrature:
    """Basis values and derivatives at the Gauss points of one segment."""

    def __init__(self, points=4):
        self.u, self.w = gauss(points)
        self.B, self.dB, self.ddB = (basis(self.u, k) for k in range(3))


def derivatives(q, seg, quad):
    """a = r' and b = r'' at every Gauss point: (S, G, 3) each."""
    local = q[seg]                                                  # (S, 4, 3)
    return (np.einsum("gj,sjk->sgk", quad.dB, local),
            np.einsum("gj,sjk->sgk", quad.ddB, local))


def curvature(q, seg, quad):
    """Curvature |a x b| / |a|^3 at every Gauss point (S, G)."""
    a, b = derivatives(q, seg, quad)
    return np.linalg.norm(np.cross(a, b), axis=2) / np.linalg.norm(a, axis=2) ** 3


def _torsion_parts(q, seg, quad):
    """|a|^2, |a x b|^2 and T = (a x b) . d at every Gauss point (S, G)."""
    a, b = derivatives(q, seg, quad)
    d = np.broadcast_to(np.einsum("j,sjk->sk", B3, q[seg])[:, None, :], a.shape)
    c = np.cross(a, b)
    return (np.einsum("sgk,sgk->sg", a, a), np.einsum("sgk,sgk->sg", c, c),
            np.einsum("sgk,sgk->sg", c, d))


def torsion(q, seg, quad):
    """Torsion (a x b) . d / |a x b|^2 (d the third derivative) at every Gauss
    point (S, G), 0 where the curve is straight."""
    a2, F, T = _torsion_parts(q, seg, quad)
    straight = F <= 1e-14 * a2 ** 2
    return np.where(straight, 0.0, T / np.where(straight, 1.0, F))


def curvature_torsion(q, seg, quad):
    """kappa^2 tau = (a x b) . d / |a|^6 at every Gauss point (S, G): the
    torsion measure of a set yarn (:mod:`.gausspoint`), smooth where the
    curve straightens."""
    a2, _, T = _torsion_parts(q, seg, quad)
    return T / a2 ** 3


SET_YARN_EPS = 0.1     # curvature regularisation of a set yarn, x its mean rest curvature


def set_yarn_terms(kappa0, ds):
    """The scales of a yarn set in its initial shape, its bending and torsion
    in their smooth forms (:mod:`.gausspoint`, ep > 0): (torsion weight, ep),
    each (S, G).  kappa_mean: the rest curvature averaged over the yarn's
    length (ds (S, G): arclength per Gauss point); ep = 0.1 kappa_mean;
    weight 1 / max(kappa0, kappa_mean)^4, so that near rest the torsion
    term is min(1, (kappa0 / kappa_mean)^4) EI/2 (tau - tau0)^2 (+ its
    coupling to the curvature).

    Why: a yarn without a material frame has torsion only as the turning
    rate of its binormal, defined only as far as it is bent (turning the
    bending plane of a rod bent to kappa0 costs ~ EI kappa0^2 per radian^2);
    kappa^2 tau = (a x b) . d / |a|^6 (a, b, d: the curve's first three
    derivatives) is smooth where tau is not.
    The exact forms failed on the knitted yarn (2026-12-08): unweighted
    torsion made its less bent stretches up to 1000 x stiffer (28 % of the
    10 x 35's knit control points > 10 x the median Gershgorin mass, FIRE's
    step), and the curvature's cone at kappa = 0 held the largest forces of
    a 4 x 4 that FIRE could not bring below residual 0.99 in 300 s: Gauss
    points with kappa 1e-5 against kappa0 0.05-0.1."""
    kappa0 = np.asarray(kappa0, float)
    mean = float(np.sum(kappa0 * ds) / np.sum(ds))
    if not mean > 0:
        raise ValueError("a set yarn needs a bent rest shape (its mean curvature is 0)")
    weight = 1.0 / np.maximum(kappa0, mean) ** 4
    return weight, np.full_like(kappa0, SET_YARN_EPS * mean)


@njit(cache=True)
def _local(q, seg, s, g, dB, ddB, B3):
    """a = r', b = r'', d = r''' of segment s at Gauss point g."""
    a = np.zeros(3)
    b = np.zeros(3)
    d = np.zeros(3)
    for j in range(4):
        a += dB[g, j] * q[seg[s, j]]
        b += ddB[g, j] * q[seg[s, j]]
        d += B3[j] * q[seg[s, j]]
    return a, b, d


@njit(cache=True, inline="always")
def _combine(c, q, i0, i1, i2, i3):
    """sum_j c_j q_{i_j} as a 3-tuple (no allocation)."""
    return (c[0] * q[i0, 0] + c[1] * q[i1, 0] + c[2] * q[i2, 0] + c[3] * q[i3, 0],
            c[0] * q[i0, 1] + c[1] * q[i1, 1] + c[2] * q[i2, 1] + c[3] * q[i3, 1],
            c[0] * q[i0, 2] + c[1] * q[i1, 2] + c[2] * q[i2, 2] + c[3] * q[i3, 2])


@njit(cache=True)
def _elastic(q, seg, rest, EA, EI, kappa0, tau0, torsion_weight, eps, dB, ddB, w, B3, g_stretch,
             g_bend, e_stretch, e_bend):
    for s in range(seg.shape[0]):
        i0, i1, i2, i3 = seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3]
        d = _combine(B3, q, i0, i1, i2, i3)
        for g in range(w.shape[0]):
            a = _combine(dB[g], q, i0, i1, i2, i3)
            b = _combine(ddB[g], q, i0, i1, i2, i3)
            e, e_a, e_b, e_d = gausspoint.gradient(a, b, d, rest[s, g], EA[s], 0.0, 0.0, 0.0,
                                                   0.0, 0.0, w[g])
            e_stretch[s] += e
            for j in range(4):
                for k in range(3):
                    g_stretch[seg[s, j], k] += dB[g, j] * e_a[k]
            e, e_a, e_b, e_d = gausspoint.gradient(a, b, d, rest[s, g], 0.0, EI[s],
                                                   kappa0[s, g], tau0[s, g],
                                                   torsion_weight[s, g], eps[s, g], w[g])
            e_bend[s] += e
            for j in range(4):
                for k in range(3):
                    g_bend[seg[s, j], k] += (dB[g, j] * e_a[k] + ddB[g, j] * e_b[k]
                                             + B3[j] * e_d[k])


def elastic(q, seg, rest, EA, EI, kappa0, tau0, torsion_weight, eps, quad, g_stretch, g_bend):
    """Stretching and bending energies (returned separately); their gradients
    are added to ``g_stretch`` and ``g_bend`` (n, 3).

    q (n, 3) control points; seg (S, 4); rest (S, G) rest speeds |r'| at the
    Gauss points; EA, EI (S,); kappa0, tau0 (S, G) natural curvature and
    torsion; torsion_weight (S, G): the torsion term's weight t (0: off);
    eps (S, G): curvature regularisation (0: exact; > 0: the smooth form of a
    set yarn, :mod:`.gausspoint`, with tau0 holding kappa0^2 tau0).
    (Energies are summed per segment, then pairwise by numpy: a running sum
    over 1e5 Gauss points would lose the small energy changes near rest.)"""
    e_stretch, e_bend = np.zeros(seg.shape[0]), np.zeros(seg.shape[0])
    _elastic(q, seg, rest, EA, EI, kappa0, tau0, torsion_weight, eps, quad.dB, quad.ddB, quad.w,
             B3, g_stretch, g_bend, e_stretch, e_bend)
    return float(np.sum(e_stretch)), float(np.sum(e_bend))


@njit(cache=True)
def _hessian(q, seg, rest, EA, EI, kappa0, tau0, torsion_weight, eps, dB, ddB, w, B3, project):
    S = seg.shape[0]
    out = np.zeros((S, 12, 12))
    H = np.zeros((9, 9))
    C = np.zeros((3, 4))
    for s in range(S):
        for g in range(w.shape[0]):
            a, b, d = _local(q, seg, s, g, dB, ddB, B3)
            gausspoint.energy(a, b, d, rest[s, g], EA[s], EI[s], kappa0[s, g], tau0[s, g],
                              torsion_weight[s, g], eps[s, g], w[g], True, project, H)
            C[0], C[1], C[2] = dB[g], ddB[g], B3
            for j in range(4):
                for k in range(4):
                    for x in range(3):
                        for y in range(3):
                            out[s, 3 * j:3 * j + 3, 3 * k:3 * k + 3] += (
                                C[x, j] * C[y, k] * H[3 * x:3 * x + 3, 3 * y:3 * y + 3])
    return out


def elastic_hessian(q, seg, rest, EA, EI, kappa0, tau0, torsion_weight, eps, quad, project):
    """Per-segment Hessian blocks (S, 12, 12) of the elastic energy with
    respect to the segment's 4 control points (x, y, z each); ``project``:
    positive semi-definite part per Gauss point."""
    return _hessian(q, seg, rest, EA, EI, kappa0, tau0, torsion_weight, eps, quad.dB, quad.ddB,
                    quad.w, B3, bool(project))


def gravity_force(seg, rest, line_density, g, quad, n):
    """Consistent nodal forces (n, 3) of gravity on the control points (constant)."""
    weight = (line_density * rest)[:, None] * quad.w[None, :]       # (S, G)
    per_ctrl = np.einsum("sg,gj->sj", weight, quad.B)
    share = np.bincount(seg.ravel(), per_ctrl.ravel(), minlength=n)
    return share[:, None] * np.asarray(g, dtype=float)[None, :]


def lumped_masses(seg, rest, line_density, quad, n):
    """Row sums of the consistent mass matrix: mass per control point (n,)."""
    weight = (line_density * rest)[:, None] * quad.w[None, :]
    return np.bincount(seg.ravel(), np.einsum("sg,gj->sj", weight, quad.B).ravel(), minlength=n)
