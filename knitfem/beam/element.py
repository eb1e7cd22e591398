"""Two-node geometrically exact (Simo–Reissner) beam element with constant strains.

Kinematics of an element with nodes A, B, frames R_A, R_B, reference length h:

    psi   = log(R_A^T R_B)                   relative rotation of the two frames
    R_m   = R_A exp(psi / 2)                 geodesic mean (Crisfield–Jelenić triad)
    K     = psi / h                          torsion + curvature   (material)
    Gamma = W(psi)^-1 R_m^T (x_B - x_A) / h  axial + shear strain  (material)
    W     = h/2 (Gamma-Gamma0)·C_N (Gamma-Gamma0) + h/2 (K-K0)·C_M (K-K0)

The frames follow the geodesic R(s) = R_A exp(s psi / h), and positions follow
x' = R(s) Gamma with Gamma constant: the helicoidal (SE(3)) interpolation of
Sonneville, Cardona & Brüls (2014).  Integrating x' over the element gives
x_B - x_A = h R_m W(psi) Gamma with W = n n^T + sinc(theta/2) (I - n n^T),
theta = |psi|, n = psi/theta.  Consequences, each checked by a test:

* every state of constant strain (arc, helix, straight) is represented
  exactly, so an end moment rolls a cantilever into an exact circle;
* strains are constant on the element, so no quadrature is involved and
  there is no shear locking (the midpoint is the element's one point);
* Gamma and K depend on R_A^T R_B and R_A^T (x_B - x_A) only: objective and
  path independent; the buckling error is +(pi h / L_eff)^2 / 12.

In quaternions: with q_B's sign aligned to q_A, p = conj(q_A) ⊗ q_B = (w, v)
gives psi = g(w, |v|^2) v and W^-1 = c I + b v v^T (see
:mod:`knitfem.beam.series`); R_m is the rotation of m = q_A + q_B.  The energy
is differentiated as a function of y = (d = x_B - x_A, m, p) and chained to
the spatial increments R <- exp(hat(theta)) R; the consistent tangent is the
Hessian of the pulled-back energy minus hat(residual)/2 on the rotational
diagonal blocks: symmetric at equilibrium, not symmetrised here.

The per-element arithmetic is compiled with numba (a measured hot loop: the
vectorised numpy version of an earlier kernel took 76 ms at 1e4 elements).
Element dof order: (u_A, theta_A, u_B, theta_B).  Units: any consistent set;
C_N = (EA, GA2, GA3), C_M = (GJ, EI2, EI3).
"""
from collections import namedtuple

import numpy as np
from numba import njit, prange

from .quatalg import (congruence, dot, increment_map, mm, mv, quadratic_form, quat_left,
                      quat_right, relative_quaternion, rotation_matrix, tmv)
from .series import chord_coefficients, log_coefficients

# Scratch arrays of one element, allocated once per chunk of elements: numba
# allocations and reshapes inside the element loop cost more than its arithmetic.
Workspace = namedtuple("Workspace", (
    "qB qAc p m d Gm gamma N Nt nsp S dK gp gA gB gm rA rB e t4 JpA JpB Jpsi Hp HAA HBB"
    " HAB Hmm Hmp QdN Q T44 T43 TA TB Rm M JGm MJG GP DN Hdm Hdp Hdd HdA HdB KAA KBB"
    " KAB CG").split())


@njit(cache=True)
def _workspace():
    return Workspace(
        np.empty(4), np.empty(4), np.empty(4), np.empty(4), np.empty(3), np.empty(3),
        np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3),
        np.empty(4), np.empty(4), np.empty(4), np.empty(4), np.empty(3), np.empty(3),
        np.empty(3), np.empty(4), np.empty((4, 4)), np.empty((4, 4)), np.empty((3, 4)),
        np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4)),
        np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4)),
        np.empty((4, 4)), np.empty((4, 3)), np.empty((4, 3)), np.empty((4, 3)),
        np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 4)), np.empty((3, 4)),
        np.empty((3, 4)), np.empty((3, 4)), np.empty((3, 4)), np.empty((3, 4)),
        np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)),
        np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 4)))


@njit(cache=True)
def _chord_strain_derivative(c_, b_, X, v, out):
    """out (3, 4) = d(M X)/dp at fixed X, M = c I + b v v^T, p = (w, v)."""
    c_w, c_t = c_[1], c_[2]
    b, b_w, b_t = b_[0], b_[1], b_[2]
    xv = X[0] * v[0] + X[1] * v[1] + X[2] * v[2]
    for i in range(3):
        out[i, 0] = c_w * X[i] + b_w * xv * v[i]
        for j in range(3):
            out[i, j + 1] = 2.0 * c_t * X[i] * v[j] + 2.0 * b_t * xv * v[i] * v[j] + b * v[i] * X[j]
        out[i, i + 1] += b * xv


@njit(cache=True)
def _elements(lo, hi, XA, XB, QA, QB, H, G0, K0, CNs, CMs, energies, R, Ks, tangent, ws):
    """Elements lo..hi-1: energies, residuals R (n, 12) and, if tangent, Ks
    (n, 12, 12).  The workspace is unpacked once per chunk: passing it into a
    per-element call cost more than the element's arithmetic."""
    qB, qAc, p, m, d, Gm, gamma = ws.qB, ws.qAc, ws.p, ws.m, ws.d, ws.Gm, ws.gamma
    N, Nt, nsp, S, dK, gp = ws.N, ws.Nt, ws.nsp, ws.S, ws.dK, ws.gp
    gA, gB, gm, rA, rB, e, t4 = ws.gA, ws.gB, ws.gm, ws.rA, ws.rB, ws.e, ws.t4
    Jpsi = ws.Jpsi
    Rm, M = ws.Rm, ws.M
    JpA, JpB = ws.JpA, ws.JpB
    TA, TB = ws.TA, ws.TB
    Hp, Hmm, Hmp, Hdm, Hdp, Hdd = ws.Hp, ws.Hmm, ws.Hmp, ws.Hdm, ws.Hdp, ws.Hdd
    JGm, MJG, GP, DN, CG, Q = ws.JGm, ws.MJG, ws.GP, ws.DN, ws.CG, ws.Q
    HAA, HBB, HAB, T44, T43 = ws.HAA, ws.HBB, ws.HAB, ws.T44, ws.T43
    HdA, HdB, KAA, KBB, KAB = ws.HdA, ws.HdB, ws.KAA, ws.KBB, ws.KAB
    for el in range(lo, hi):
        xA, xB, qA, qB_in, h = XA[el], XB[el], QA[el], QB[el], H[el]
        gamma0, kappa0, CN, CM, res = G0[el], K0[el], CNs[el], CMs[el], R[el]

        # relative rotation p = conj(qA) ⊗ qB with qB's sign aligned
        sign = relative_quaternion(qA, qB_in, p)
        for i in range(4):
            qB[i] = sign * qB_in[i]
            qAc[i] = -qA[i] if i > 0 else qA[i]
            m[i] = qA[i] + qB[i]
        v = p[1:]
        t = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
        g, g_w, g_t, g_ww, g_wt, g_tt = log_coefficients(p[0], t)
        c_, b_ = chord_coefficients(p[0], t)
        c, b = c_[0], b_[0]

        # bending and torsion: K = g v / h
        for k in range(3):
            Jpsi[k, 0] = g_w * v[k]
            for j in range(3):
                Jpsi[k, j + 1] = 2.0 * g_t * v[k] * v[j]
            Jpsi[k, k + 1] += g
            dK[k] = g * v[k] / h - kappa0[k]
            S[k] = CM[k] * dK[k]
        tmv(Jpsi, S, gp)

        # axial and shear: Gamma = M Gm, M = c I + b v v^T, Gm = R_m^T d / h
        nm = dot(m, m)
        rotation_matrix(m, Rm)
        for i in range(3):
            d[i] = xB[i] - xA[i]
        tmv(Rm, d, Gm)
        for i in range(3):
            Gm[i] /= h
            for j in range(3):
                M[i, j] = b * v[i] * v[j]
            M[i, i] += c
        mv(M, Gm, gamma)
        for i in range(3):
            N[i] = CN[i] * (gamma[i] - gamma0[i])
        mv(M, N, Nt)                                   # force conjugate to Gm
        mv(Rm, Nt, nsp)                                # spatial force
        f = dot(d, nsp)
        quadratic_form(d, Nt, ws.QdN)
        mv(ws.QdN, m, t4)
        for i in range(4):
            gm[i] = 2.0 / nm * (t4[i] - f * m[i])
        # d(h N·M Gm)/dp at fixed N, Gm: phi = c (N·Gm) + b (N·v)(Gm·v)
        alpha, beta, gam = dot(N, Gm), dot(N, v), dot(Gm, v)
        gp[0] += h * (c_[1] * alpha + b_[1] * beta * gam)
        for j in range(3):
            gp[j + 1] += h * (2.0 * c_[2] * v[j] * alpha + 2.0 * b_[2] * v[j] * beta * gam
                              + b * (gam * N[j] + beta * Gm[j]))

        # chain rule to qA, qB: p = L(conj qA) qB = R(qB) diag(1,-1,-1,-1) qA, m = qA + qB
        quat_left(qAc, JpB)
        quat_right(qB, JpA)
        for i in range(4):
            for j in range(1, 4):
                JpA[i, j] = -JpA[i, j]
        tmv(JpA, gp, gA)
        tmv(JpB, gp, gB)
        for i in range(4):
            gA[i] += gm[i]
            gB[i] += gm[i]

        # residual on spatial increments
        increment_map(qA, TA)
        increment_map(qB, TB)
        tmv(TA, gA, rA)
        tmv(TB, gB, rB)
        energy = 0.0
        for i in range(3):
            res[i] = -nsp[i]
            res[6 + i] = nsp[i]
            res[3 + i] = rA[i]
            res[9 + i] = rB[i]
            energy += 0.5 * h * ((gamma[i] - gamma0[i]) * N[i] + dK[i] * S[i])
        energies[el] = energy
        if not tangent:
            continue
        K = Ks[el]

        # ---- Hessian in y = (d, m, p) ---------------------------------------------------
        # bending: Jpsi^T C_M/h Jpsi + S·d2psi/dp2
        sv = dot(S, v)
        Hp[0, 0] = g_ww * sv
        for i in range(3):
            cc = g_w * S[i] + 2.0 * g_wt * sv * v[i]
            Hp[0, i + 1] = cc
            Hp[i + 1, 0] = cc
            for j in range(3):
                Hp[i + 1, j + 1] = (2.0 * g_t * (S[i] * v[j] + v[i] * S[j])
                                    + 4.0 * g_tt * sv * v[i] * v[j])
            Hp[i + 1, i + 1] += 2.0 * g_t * sv
        for i in range(4):
            for j in range(4):
                acc = 0.0
                for k in range(3):
                    acc += Jpsi[k, i] * CM[k] / h * Jpsi[k, j]
                Hp[i, j] += acc
        # axial-shear: second derivatives of phi(p) at fixed N, Gm
        c_t, c_ww, c_wt, c_tt = c_[2], c_[3], c_[4], c_[5]
        b_w, b_t, b_ww, b_wt, b_tt = b_[1], b_[2], b_[3], b_[4], b_[5]
        bg = beta * gam
        Hp[0, 0] += h * (c_ww * alpha + b_ww * bg)
        for j in range(3):
            wv = h * (2.0 * c_wt * v[j] * alpha + 2.0 * b_wt * v[j] * bg
                      + b_w * (gam * N[j] + beta * Gm[j]))
            Hp[0, j + 1] += wv
            Hp[j + 1, 0] += wv
            e[j] = gam * N[j] + beta * Gm[j]
        for i in range(3):
            for j in range(3):
                Hp[i + 1, j + 1] += h * ((4.0 * c_tt * alpha + 4.0 * b_tt * bg) * v[i] * v[j]
                                         + 2.0 * b_t * (e[i] * v[j] + v[i] * e[j])
                                         + b * (N[i] * Gm[j] + Gm[i] * N[j]))
            Hp[i + 1, i + 1] += h * (2.0 * c_t * alpha + 2.0 * b_t * bg)
        # derivatives of Gamma: d/dd = M R_m^T / h, d/dm = M JGm, d/dp = GP; DN = d(M N)/dp
        for k in range(3):
            e[0] = e[1] = e[2] = 0.0
            e[k] = 1.0
            quadratic_form(d, e, Q)
            mv(Q, m, t4)
            for j in range(4):
                JGm[k, j] = 2.0 / (nm * h) * (t4[j] - h * Gm[k] * m[j])
            quadratic_form(e, Nt, Q)
            mv(Q, m, t4)
            for j in range(4):
                Hdm[k, j] = 2.0 / (nm) * (t4[j] - nsp[k] * m[j])
        mm(M, JGm, MJG)
        _chord_strain_derivative(c_, b_, Gm, v, GP)
        _chord_strain_derivative(c_, b_, N, v, DN)
        # Gauss–Newton parts through C_N
        for i in range(3):
            for j in range(4):
                CG[i, j] = CN[i] * GP[i, j]
        for i in range(4):
            for j in range(4):
                a1 = 0.0
                a2 = 0.0
                a3 = 0.0
                for k in range(3):
                    a1 += MJG[k, i] * CN[k] * MJG[k, j]
                    a2 += MJG[k, i] * CG[k, j] + JGm[k, i] * DN[k, j]
                    a3 += GP[k, i] * CG[k, j]
                Hmm[i, j] = h * a1 + 2.0 / nm * (ws.QdN[i, j] - m[i] * gm[j] - gm[i] * m[j])
                Hmp[i, j] = h * a2
                Hp[i, j] += h * a3
            Hmm[i, i] -= 2.0 / nm * f
        # rows d: R_m M C_N (M R_m^T/h, M JGm, GP) + R_m (0, ., DN); first R_m M into u3 rows
        for i in range(3):
            for j in range(3):
                acc = 0.0
                for k in range(3):
                    acc += Rm[i, k] * M[k, j]
                Q[i, j] = acc                            # Q[:3, :3] holds R_m M
        for i in range(3):
            for j in range(3):
                acc = 0.0
                for k in range(3):
                    acc += Q[i, k] * CN[k] * Q[j, k]
                Hdd[i, j] = acc / h
            for j in range(4):
                a1 = 0.0
                a2 = 0.0
                for k in range(3):
                    a1 += Q[i, k] * CN[k] * MJG[k, j]
                    a2 += Q[i, k] * CG[k, j] + Rm[i, k] * DN[k, j]
                Hdm[i, j] += a1
                Hdp[i, j] = a2

        # ---- chain to (qA, qB) then to spatial increments --------------------------------
        congruence(JpA, Hp, JpA, T44, HAA)
        congruence(JpB, Hp, JpB, T44, HBB)
        congruence(JpA, Hp, JpB, T44, HAB)
        mm(Hmp, JpA, T44)                              # H_mp dp/dqA
        for i in range(4):
            for j in range(4):
                HAA[i, j] += Hmm[i, j] + T44[i, j] + T44[j, i]
                HAB[i, j] += Hmm[i, j] + T44[j, i]
        mm(Hmp, JpB, T44)                              # H_mp dp/dqB
        for i in range(4):
            for j in range(4):
                HBB[i, j] += Hmm[i, j] + T44[i, j] + T44[j, i]
                HAB[i, j] += T44[i, j]
        quat_right(gp, T44)                            # d2(gp·p)/dqA dqB = R(gp)^T
        for i in range(4):
            for j in range(4):
                HAB[i, j] += T44[j, i]
        for i in range(3):
            for j in range(3):
                a1 = 0.0
                a2 = 0.0
                for k in range(4):
                    a1 += Hdm[i, k] * TA[k, j]
                    a2 += Hdm[i, k] * TB[k, j]
                    for l in range(4):
                        a1 += Hdp[i, l] * JpA[l, k] * TA[k, j]
                        a2 += Hdp[i, l] * JpB[l, k] * TB[k, j]
                HdA[i, j] = a1
                HdB[i, j] = a2
        congruence(TA, HAA, TA, T43, KAA)
        congruence(TB, HBB, TB, T43, KBB)
        congruence(TA, HAB, TB, T43, KAB)
        cA = -0.25 * dot(gA, qA)
        cB = -0.25 * dot(gB, qB)
        for i in range(3):
            for j in range(3):
                K[i, j] = Hdd[i, j]
                K[6 + i, 6 + j] = Hdd[i, j]
                K[i, 6 + j] = -Hdd[i, j]
                K[6 + i, j] = -Hdd[i, j]
                K[i, 3 + j] = -HdA[i, j]
                K[i, 9 + j] = -HdB[i, j]
                K[6 + i, 3 + j] = HdA[i, j]
                K[6 + i, 9 + j] = HdB[i, j]
                K[3 + j, i] = -HdA[i, j]
                K[9 + j, i] = -HdB[i, j]
                K[3 + j, 6 + i] = HdA[i, j]
                K[9 + j, 6 + i] = HdB[i, j]
                K[3 + i, 3 + j] = KAA[i, j]
                K[9 + i, 9 + j] = KBB[i, j]
                K[3 + i, 9 + j] = KAB[i, j]
                K[9 + j, 3 + i] = KAB[i, j]
            K[3 + i, 3 + i] += cA
            K[9 + i, 9 + i] += cB
        # -hat(r)/2 on the rotational diagonal blocks (spatial increments)
        for off in (3, 9):
            r0, r1, r2 = res[off], res[off + 1], res[off + 2]
            K[off + 0, off + 1] += 0.5 * r2
            K[off + 1, off + 0] -= 0.5 * r2
            K[off + 0, off + 2] -= 0.5 * r1
            K[off + 2, off + 0] += 0.5 * r1
            K[off + 1, off + 2] += 0.5 * r0
            K[off + 2, off + 1] -= 0.5 * r0


@njit(cache=True, parallel=True)
def _all_elements(xA, xB, qA, qB, h, gamma0, kappa0, CN, CM, tangent, chunks):
    n = xA.shape[0]
    energy = np.empty(n)
    res = np.empty((n, 12))
    K = np.empty((n if tangent else 1, 12, 12))
    nchunk = min(n, chunks)
    for c in prange(nchunk):
        _elements(c * n // nchunk, (c + 1) * n // nchunk, xA, xB, qA, qB, h, gamma0, kappa0,
                  CN, CM, energy, res, K, tangent, _workspace())
    return energy, res, K


@njit(cache=True)
def _all_elements_serial(xA, xB, qA, qB, h, gamma0, kappa0, CN, CM, tangent):
    """The same loop without threads (a separate function: numba's cache keys
    on the function, so one body cannot be cached both ways)."""
    n = xA.shape[0]
    energy = np.empty(n)
    res = np.empty((n, 12))
    K = np.empty((n if tangent else 1, 12, 12))
    _elements(0, n, xA, xB, qA, qB, h, gamma0, kappa0, CN, CM, energy, res, K, tangent,
              _workspace())
    return energy, res, K


# Threads pay off from a few thousand elements; below, their start-up (~0.3 ms)
# costs more than the loop (60 elements: 0.15 ms serial).
PARALLEL_FROM = 2000


def element_forces(xA, xB, qA, qB, h, gamma0, kappa0, CN, CM, tangent=True):
    """Energy, residual and consistent tangent of every element.

    Parameters
    ----------
    xA, xB : (n, 3) nodal positions.
    qA, qB : (n, 4) nodal unit quaternions (scalar first).
    h : (n,) reference element lengths.
    gamma0, kappa0 : (n, 3) stress-free strains (the rod's natural shape).
    CN, CM : (n, 3) diagonal stiffnesses (EA, GA2, GA3), (GJ, EI2, EI3).

    Returns
    -------
    energy : (n,)
    residual : (n, 12) internal generalised forces, work-conjugate to
        (u_A, theta_A, u_B, theta_B) with spatial rotation increments.
    K : (n, 12, 12) derivative of ``residual`` along the multiplicative update,
        or None when ``tangent`` is False.
    """
    args = [np.ascontiguousarray(a, dtype=np.float64)
            for a in (xA, xB, qA, qB, h, gamma0, kappa0, CN, CM)]
    if args[0].shape[0] >= PARALLEL_FROM:
        energy, res, K = _all_elements(*args, bool(tangent), 64)
    else:
        energy, res, K = _all_elements_serial(*args, bool(tangent))
    return energy, res, (K if tangent else None)


@njit(cache=True)
def _strains(xA, xB, qA, qB, h, gamma, kappa, Rm):
    """Material strains Gamma, K and the midpoint triad R_m of one element."""
    p = np.empty(4)
    m = np.empty(4)
    Gm = np.empty(3)
    sign = relative_quaternion(qA, qB, p)
    t = p[1] ** 2 + p[2] ** 2 + p[3] ** 2
    g = log_coefficients(p[0], t)[0]
    c_, b_ = chord_coefficients(p[0], t)
    for i in range(4):
        m[i] = qA[i] + sign * qB[i]
    rotation_matrix(m, Rm)
    tmv(Rm, xB - xA, Gm)
    vG = (p[1] * Gm[0] + p[2] * Gm[1] + p[3] * Gm[2]) / h
    for i in range(3):
        gamma[i] = c_[0] * Gm[i] / h + b_[0] * vG * p[i + 1]
        kappa[i] = g * p[i + 1] / h


@njit(cache=True)
def _all_strains(xA, xB, qA, qB, h):
    n = xA.shape[0]
    gamma = np.empty((n, 3))
    kappa = np.empty((n, 3))
    frames = np.empty((n, 3, 3))
    for e in range(n):
        _strains(xA[e], xB[e], qA[e], qB[e], h[e], gamma[e], kappa[e], frames[e])
    return gamma, kappa, frames


def element_strains(xA, xB, qA, qB, h):
    """Material strains Gamma (n, 3), K (n, 3) and midpoint triads (n, 3, 3)."""
    args = [np.ascontiguousarray(a, dtype=np.float64) for a in (xA, xB, qA, qB, h)]
    return _all_strains(*args)
