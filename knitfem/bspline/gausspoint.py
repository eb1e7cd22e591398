"""The elastic energy density of a yarn at one Gauss point (numba).

In terms of the curve's derivatives in its segment parameter, a = r',
b = r'', d = r''' (d is constant on a cubic segment), with kappa = |a x b| /
|a|^3 and tau = (a x b) . d / |a x b|^2:

    e = EA/2 (|a|/l - 1)^2 l w                      stretching (l: rest speed)
      + EI/2 (kappa - kappa0)^2 |a| w               bending
      + t EI/2 (tau - tau0)^2 |a| w                 torsion (naturally curved yarns; t their
                                                    torsion weight, 0: no torsion term)

with its exact first and second derivatives in (a, b, d).  The bending term
is expanded as kappa^2 |a| - 2 kappa0 kappa |a| + kappa0^2 |a| = |a x b|^2 |a|^-5
- 2 kappa0 |a x b| |a|^-2 + kappa0^2 |a|, each a product of simple factors.

A yarn set in a shape with inflections (the knitted loop) needs a smooth
form, selected by a curvature regularisation ep > 0 (ep = 0: the form
above, exact):

    bending  EI/2 (kappa_ep - kappa0_ep)^2 |a| w,  kappa_ep = sqrt(kappa^2 + ep^2)
    torsion  t EI/2 (kappa^2 tau - t0)^2 |a| w,    kappa^2 tau = (a x b) . d / |a|^6

The exact bending term has a cone at kappa = 0 when kappa0 > 0 (its force
does not vanish there: relaxation chatters across it), and tau = T / |a x
b|^2 is singular where the yarn straightens; both forms above are smooth
everywhere.  t0 is then the rest kappa0^2 tau0 and t carries the scale
(:func:`knitfem.bspline.energy.set_yarn_terms`).
"""
import numpy as np
from numba import njit


@njit(cache=True)
def cross(u, v):
    return np.array([u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                     u[0] * v[1] - u[1] * v[0]])


@njit(cache=True)
def skew(c):
    """[c]x with [c]x v = c x v."""
    out = np.zeros((3, 3))
    out[0, 1], out[0, 2], out[1, 2] = -c[2], c[1], -c[0]
    out[1, 0], out[2, 0], out[2, 1] = c[2], -c[1], c[0]
    return out


@njit(cache=True)
def _sym(u, v):
    return np.outer(u, v) + np.outer(v, u)


@njit(cache=True)
def energy(a, b, d, l, EA, EI, k0, t0, tw, ep, w, hessian, project, H):
    """Energy of one Gauss point and its derivatives with respect to a, b, d:
    returns (e, e_a, e_b, e_d); with ``hessian`` fills H (9, 9) (rows/cols a,
    b, d).  ``project`` replaces H by its positive semi-definite part
    (negative eigenvalues set to 0: compressive stretching, the curvature
    and torsion terms are not convex)."""
    a2 = a @ a
    na = np.sqrt(a2)
    ah = a / na
    strain = na / l - 1.0
    e = 0.5 * EA * strain * strain * l * w
    e_a = EA * strain * w * ah
    e_b = np.zeros(3)
    e_d = np.zeros(3)
    if hessian:
        eye = np.eye(3)
        H[:, :] = 0.0
        H[:3, :3] += EA * w * (np.outer(ah, ah) / l + strain / na * (eye - np.outer(ah, ah)))
    kb = 0.5 * EI * w
    if kb != 0.0:
        c = cross(a, b)
        F = c @ c
        G = a2 ** -2.5
        F_a, F_b = 2.0 * cross(b, c), 2.0 * cross(c, a)
        G_a = -5.0 * a2 ** -3.5 * a
        if hessian:
            F_aa = 2.0 * ((b @ b) * eye - np.outer(b, b))
            F_bb = 2.0 * (a2 * eye - np.outer(a, a))
            F_ab = 2.0 * (np.outer(a, b) - (a @ b) * eye - skew(c))
        # kappa^2 |a| = F G
        e += kb * F * G
        e_a += kb * (F_a * G + F * G_a)
        e_b += kb * F_b * G
        if hessian:
            G_aa = 35.0 * a2 ** -4.5 * np.outer(a, a) - 5.0 * a2 ** -3.5 * eye
            H[:3, :3] += kb * (F_aa * G + _sym(F_a, G_a) + F * G_aa)
            H[:3, 3:6] += kb * (F_ab * G + np.outer(G_a, F_b))
            H[3:6, :3] += kb * (F_ab.T * G + np.outer(F_b, G_a))
            H[3:6, 3:6] += kb * F_bb * G
        ep2 = ep * ep
        if k0 != 0.0 or ep != 0.0:
            # (kappa0^2 + 2 ep^2) |a|: kappa0_ep^2 |a| and the ep^2 |a| of kappa_ep^2 |a|
            k2 = k0 * k0 + 2.0 * ep2
            e += kb * k2 * na
            e_a += kb * k2 * ah
            if hessian:
                H[:3, :3] += kb * k2 * (eye - np.outer(ah, ah)) / na
        # Fe = |a x b|^2 + ep^2 |a|^6 (= F when ep = 0)
        Fe = F + ep2 * a2 * a2 * a2
        Fe_a = F_a + 6.0 * ep2 * a2 * a2 * a
        if hessian and ep != 0.0:
            Fe_aa = F_aa + ep2 * (6.0 * a2 * a2 * eye + 24.0 * a2 * np.outer(a, a))
        elif hessian:
            Fe_aa = F_aa
        P = np.sqrt(Fe)
        if (k0 != 0.0 or ep != 0.0) and P > 1e-14 * a2:
            # -2 kappa0 kappa |a| = -2 kappa0 P Q, P = |a x b|, Q = |a|^-2 (skipped at the
            # cone tip P = 0, where the yarn is straight: a maximum of -P; with ep > 0
            # kappa0 -> kappa0_ep, P = sqrt(Fe) and there is no tip)
            Q = 1.0 / a2
            P_a, P_b = Fe_a / (2.0 * P), F_b / (2.0 * P)
            Q_a = -2.0 * a / (a2 * a2)
            m = -2.0 * kb * np.sqrt(k0 * k0 + ep2)
            e += m * P * Q
            e_a += m * (P_a * Q + P * Q_a)
            e_b += m * P_b * Q
            if hessian:
                P_aa = Fe_aa / (2.0 * P) - np.outer(Fe_a, Fe_a) / (4.0 * P ** 3)
                P_ab = F_ab / (2.0 * P) - np.outer(Fe_a, F_b) / (4.0 * P ** 3)
                P_bb = F_bb / (2.0 * P) - np.outer(F_b, F_b) / (4.0 * P ** 3)
                Q_aa = -2.0 * eye / (a2 * a2) + 8.0 * np.outer(a, a) / (a2 * a2 * a2)
                H[:3, :3] += m * (P_aa * Q + _sym(P_a, Q_a) + P * Q_aa)
                H[:3, 3:6] += m * (P_ab * Q + np.outer(Q_a, P_b))
                H[3:6, :3] += m * (P_ab.T * Q + np.outer(P_b, Q_a))
                H[3:6, 3:6] += m * P_bb * Q
        if tw != 0.0 and (ep != 0.0 or F > 1e-14 * a2 * a2):
            # tw (T / D - t0)^2 |a|, T = (a x b) . d: D = F (tau) or with ep > 0 |a|^6
            # (kappa^2 tau, smooth)
            kt = kb * tw
            T = c @ d
            Tx = np.concatenate((cross(b, d), cross(d, a), c))
            if ep != 0.0:
                D = a2 * a2 * a2
                Dx = np.concatenate((6.0 * a2 * a2 * a, np.zeros(6)))
            else:
                D = F
                Dx = np.concatenate((F_a, F_b, np.zeros(3)))
            nx = np.concatenate((ah, np.zeros(6)))
            f = T / D - t0
            tx = Tx / D - T * Dx / (D * D)
            grad = kt * (2.0 * f * tx * na + f * f * nx)
            e += kt * f * f * na
            e_a += grad[:3]
            e_b += grad[3:6]
            e_d += grad[6:]
            if hessian:
                Txy = np.zeros((9, 9))
                Txy[:3, 3:6] = -skew(d)
                Txy[:3, 6:] = skew(b)
                Txy[3:6, 6:] = -skew(a)
                Txy += Txy.T
                Dxy = np.zeros((9, 9))
                if ep != 0.0:
                    Dxy[:3, :3] = 6.0 * a2 * a2 * eye + 24.0 * a2 * np.outer(a, a)
                else:
                    Dxy[:3, :3] = F_aa
                    Dxy[:3, 3:6] = F_ab
                    Dxy[3:6, :3] = F_ab.T
                    Dxy[3:6, 3:6] = F_bb
                txy = (Txy / D - _sym(Tx, Dx) / (D * D) - T * Dxy / (D * D)
                       + 2.0 * T * np.outer(Dx, Dx) / D ** 3)
                nxy = np.zeros((9, 9))
                nxy[:3, :3] = (eye - np.outer(ah, ah)) / na
                H[:, :] += kt * (2.0 * np.outer(tx, tx) * na + 2.0 * f * txy * na
                                 + 2.0 * f * _sym(tx, nx) + f * f * nxy)
    if hessian and project:
        lam, V = np.linalg.eigh(0.5 * (H + H.T))
        H[:, :] = (V * np.maximum(lam, 0.0)) @ V.T
    return e, e_a, e_b, e_d


# -- the same energy and gradient without the Hessian, on 3-tuples (no heap
# allocation: this is the hot loop of every relaxation step) ----------------------

@njit(cache=True, inline="always")
def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


@njit(cache=True, inline="always")
def _x(u, v):
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


@njit(cache=True, inline="always")
def _axpy(alpha, u, v):
    """alpha u + v."""
    return (alpha * u[0] + v[0], alpha * u[1] + v[1], alpha * u[2] + v[2])


@njit(cache=True)
def gradient(a, b, d, l, EA, EI, k0, t0, tw, ep, w):
    """:func:`energy` without the Hessian, for 3-tuples a, b, d: returns
    (e, e_a, e_b, e_d) with tuple derivatives."""
    zero = (0.0, 0.0, 0.0)
    a2 = _dot(a, a)
    na = np.sqrt(a2)
    strain = na / l - 1.0
    e = 0.5 * EA * strain * strain * l * w
    e_a = _axpy(EA * strain * w / na, a, zero)
    e_b = zero
    e_d = zero
    kb = 0.5 * EI * w
    if kb == 0.0:
        return e, e_a, e_b, e_d
    c = _x(a, b)
    F = _dot(c, c)
    G = a2 ** -2.5
    F_a = _x(b, c)                    # half of dF/da
    F_b = _x(c, a)                    # half of dF/db
    e += kb * F * G
    e_a = _axpy(2.0 * kb * G, F_a, _axpy(-5.0 * kb * F * a2 ** -3.5, a, e_a))
    e_b = _axpy(2.0 * kb * G, F_b, e_b)
    ep2 = ep * ep
    if k0 != 0.0 or ep != 0.0:
        k2 = k0 * k0 + 2.0 * ep2
        e += kb * k2 * na
        e_a = _axpy(kb * k2 / na, a, e_a)
    if k0 != 0.0 or ep != 0.0:
        P = np.sqrt(F + ep2 * a2 * a2 * a2)
        if P > 1e-14 * a2:
            m = -2.0 * kb * np.sqrt(k0 * k0 + ep2)
            Q = 1.0 / a2
            e += m * P * Q
            # P_a = Fe_a / P (Fe_a: half of dFe/da = F_a + 3 ep^2 a2^2 a), Q_a = -2 a / a2^2
            e_a = _axpy(m * Q / P, F_a, _axpy(-2.0 * m * P / (a2 * a2)
                                              + 3.0 * m * Q / P * ep2 * a2 * a2, a, e_a))
            e_b = _axpy(m * Q / P, F_b, e_b)
    if tw != 0.0 and (ep != 0.0 or F > 1e-14 * a2 * a2):
        # tw (T / D - t0)^2 |a|: D = F (tau) or with ep > 0 |a|^6 (kappa^2 tau)
        if ep != 0.0:
            D, D_a, D_b = a2 * a2 * a2, _axpy(3.0 * a2 * a2, a, zero), zero  # halves of D_x
        else:
            D, D_a, D_b = F, F_a, F_b
        kb *= tw
        T = _dot(c, d)
        f = T / D - t0
        # (T/D)_x = T_x / D - T D_x / D^2, T_a = b x d, T_b = d x a, T_d = c, D_x = 2 (D_a, D_b, 0)
        k = 2.0 * kb * f * na
        e += kb * f * f * na
        e_a = _axpy(k / D, _x(b, d), _axpy(-2.0 * k * T / (D * D), D_a,
                                           _axpy(kb * f * f / na, a, e_a)))
        e_b = _axpy(k / D, _x(d, a), _axpy(-2.0 * k * T / (D * D), D_b, e_b))
        e_d = _axpy(k / D, c, e_d)
    return e, e_a, e_b, e_d
