"""Elastic energies of B-spline yarns and their exact gradients.

Per segment s with rest length l_s, at Gauss points u_g (weights w_g), with
a = r'(u) and b = r''(u) (derivatives in the segment parameter):

    stretching  E_len  = sum  EA/2 (|a|/l - 1)^2 l w          (Kaldor's k_len = EA/2)
    bending     E_bend = sum  EI/2 |a x b|^2 / |a|^5 w         (= EI/2 kappa^2 ds)
    gravity     E_g    = -sum rho_l l g . r(u) w

The yarn has no twist energy (as in Kaldor 2008).  Every function works on all
segments of all yarns at once: ``seg`` (S, 4) holds global control-point
indices, so gradients are scattered with one bincount per component.
Units: any consistent set (EA force, EI force x length^2).
"""
import numpy as np

from .curve import basis


def gauss(points):
    """Gauss-Legendre nodes and weights on [0, 1]."""
    x, w = np.polynomial.legendre.leggauss(points)
    return 0.5 * (x + 1.0), 0.5 * w


class Quadrature:
    """Basis values and derivatives at the Gauss points of one segment."""

    def __init__(self, points=4):
        self.u, self.w = gauss(points)
        self.B, self.dB, self.ddB = (basis(self.u, k) for k in range(3))


def _scatter(seg, coeff_a, dB, coeff_b=None, ddB=None, n=None):
    """sum over Gauss points of coeff_a (S, G, 3) dB (G, 4) [+ coeff_b ddB] into (n, 3)."""
    per_ctrl = np.einsum("sgk,gj->sjk", coeff_a, dB)
    if coeff_b is not None:
        per_ctrl += np.einsum("sgk,gj->sjk", coeff_b, ddB)
    out = np.zeros((n, 3))
    for k in range(3):
        out[:, k] = np.bincount(seg.ravel(), per_ctrl[:, :, k].ravel(), minlength=n)
    return out


def derivatives(q, seg, quad):
    """a = r' and b = r'' at every Gauss point: (S, G, 3) each."""
    local = q[seg]                                                  # (S, 4, 3)
    return (np.einsum("gj,sjk->sgk", quad.dB, local),
            np.einsum("gj,sjk->sgk", quad.ddB, local))


def stretching(q, seg, rest, EA, quad, a=None):
    """Energy and gradient (n, 3) of axial stretching."""
    if a is None:
        a = np.einsum("gj,sjk->sgk", quad.dB, q[seg])
    speed = np.linalg.norm(a, axis=2)                               # (S, G)
    strain = speed / rest[:, None] - 1.0
    w = quad.w[None, :]
    energy = np.sum(0.5 * EA[:, None] * strain**2 * rest[:, None] * w)
    coeff = (EA[:, None] * strain * w / speed)[:, :, None] * a
    return energy, _scatter(seg, coeff, quad.dB, n=q.shape[0])


def bending(q, seg, EI, quad, a=None, b=None):
    """Energy and gradient (n, 3) of isotropic bending, EI/2 kappa^2 ds."""
    if a is None:
        a, b = derivatives(q, seg, quad)
    c = np.cross(a, b)
    c2 = np.einsum("sgk,sgk->sg", c, c)
    na2 = np.einsum("sgk,sgk->sg", a, a)
    na5 = na2**2.5
    k = 0.5 * EI[:, None] * quad.w[None, :]
    energy = np.sum(k * c2 / na5)
    # d|c|^2/da = 2 b x c, d|c|^2/db = 2 c x a, d|a|^-5/da = -5 |a|^-7 a
    coeff_a = (k / na5)[:, :, None] * (2.0 * np.cross(b, c) - (5.0 * c2 / na2)[:, :, None] * a)
    coeff_b = (2.0 * k / na5)[:, :, None] * np.cross(c, a)
    return energy, _scatter(seg, coeff_a, quad.dB, coeff_b, quad.ddB, n=q.shape[0])


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
