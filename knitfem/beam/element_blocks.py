"""The blocks of the element kernel (numba): strains, stresses and residual,
Hessian and its chain rule; see :mod:`knitfem.beam.element` for the
mechanics.  One element per call, writing into a preallocated workspace.

Compiled without numba's reference counting (``_nrt=False``: nothing here
allocates) and inlined into the element loop (``inline="always"``), except
:func:`hessian_y`, which numba's inliner refuses and whose arithmetic dwarfs
the call: passing ~40 arrays with reference counting per element cost more
than the element's arithmetic (measured: the split kernel with counted calls
took 1.4x the residual and 1.2x the tangent time of the single function it
replaced; as written here it takes 0.7-0.8x and 1.0x: ``element_forces`` on
1000-20000 elements, best of interleaved runs; ``studies/bench_beam.py --only
assembly --dry-run`` times the assembly).
"""
from collections import namedtuple

import numpy as np
from numba import njit

from .dense import congruence, dot, mm, mv, tmv
from .rotation import (increment_map, quadratic_form, quat_left_into, quat_right_into,
                       relative_quaternion, rotation_matrix_into)
from .series import chord_coefficients, log_coefficients

# Scratch arrays of one element, allocated once per chunk of elements: numba
# allocations and reshapes inside the element loop cost more than its arithmetic.
Workspace = namedtuple("Workspace", (
    "qB qAc p m d Gm gamma kappa N Nt nsp S dK gp gA gB gm rA rB e t4 JpA JpB Jpsi Hp HAA HBB"
    " HAB Hmm Hmp QdN Q T44 T43 TA TB Rm M JGm MJG GP DN Hdm Hdp Hdd HdA HdB KAA KBB"
    " KAB CG").split())


@njit(cache=True)
def workspace():
    return Workspace(
        np.empty(4), np.empty(4), np.empty(4), np.empty(4), np.empty(3), np.empty(3),
        np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3),
        np.empty(4), np.empty(4), np.empty(4), np.empty(4), np.empty(3), np.empty(3),
        np.empty(3), np.empty(4), np.empty((4, 4)), np.empty((4, 4)), np.empty((3, 4)),
        np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4)),
        np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4)),
        np.empty((4, 4)), np.empty((4, 3)), np.empty((4, 3)), np.empty((4, 3)),
        np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 4)), np.empty((3, 4)),
        np.empty((3, 4)), np.empty((3, 4)), np.empty((3, 4)), np.empty((3, 4)),
        np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)),
        np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 4)))


@njit(cache=True, _nrt=False)
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


@njit(cache=True, _nrt=False, inline="always")
def kinematics(xA, xB, qA, qB_in, h, qB, p, m, d, Rm, Gm, M, gamma, kappa):
    """Strains of one element (the one copy of the kinematics): qB's sign
    aligned to qA, p = conj(qA) ⊗ qB, m = qA + qB and its triad R_m,
    d = x_B - x_A, Gm = R_m^T d / h, M = W^-1 = c I + b v v^T,
    Gamma = M Gm (into ``gamma``) and K = g v / h (into ``kappa``).
    Returns the series coefficients of g and (c, b) and |m|^2."""
    sign = relative_quaternion(qA, qB_in, p)
    for i in range(4):
        qB[i] = sign * qB_in[i]
        m[i] = qA[i] + qB[i]
    v = p[1:]
    t = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
    lg = log_coefficients(p[0], t)
    c_, b_ = chord_coefficients(p[0], t)
    rotation_matrix_into(m, Rm)
    for i in range(3):
        d[i] = xB[i] - xA[i]
    tmv(Rm, d, Gm)
    for i in range(3):
        Gm[i] /= h
        kappa[i] = lg[0] * v[i] / h
        for j in range(3):
            M[i, j] = b_[0] * v[i] * v[j]
        M[i, i] += c_[0]
    mv(M, Gm, gamma)
    return lg, c_, b_, dot(m, m)


@njit(cache=True, _nrt=False, inline="always")
def stresses(h, v, lg, c_, b_, nm, m, d, Rm, Gm, M, gamma, gamma0, kappa, kappa0, CN, CM,
              N, S, dK, Nt, nsp, Jpsi, gp, gm, QdN, t4):
    """Stress resultants N = C_N (Gamma - Gamma0), S = C_M (K - K0) and the
    gradient of the energy in y = (d, m, p): spatial force ``nsp`` (the d
    part), ``gm`` and ``gp``.  Returns the energy, f = d·nsp and the scalars
    alpha = N·Gm, beta = N·v, gam = Gm·v the Hessian reuses."""
    g, g_w, g_t = lg[0], lg[1], lg[2]
    # bending and torsion: K = g v / h, dK/dp = Jpsi / h
    for k in range(3):
        Jpsi[k, 0] = g_w * v[k]
        for j in range(3):
            Jpsi[k, j + 1] = 2.0 * g_t * v[k] * v[j]
        Jpsi[k, k + 1] += g
        dK[k] = kappa[k] - kappa0[k]
        S[k] = CM[k] * dK[k]
    tmv(Jpsi, S, gp)
    # axial and shear: Gamma = M Gm
    energy = 0.0
    for i in range(3):
        N[i] = CN[i] * (gamma[i] - gamma0[i])
        energy += 0.5 * h * ((gamma[i] - gamma0[i]) * N[i] + dK[i] * S[i])
    mv(M, N, Nt)                                   # force conjugate to Gm
    mv(Rm, Nt, nsp)                                # spatial force
    f = dot(d, nsp)
    quadratic_form(d, Nt, QdN)
    mv(QdN, m, t4)
    for i in range(4):
        gm[i] = 2.0 / nm * (t4[i] - f * m[i])
    # d(h N·M Gm)/dp at fixed N, Gm: phi = c (N·Gm) + b (N·v)(Gm·v)
    alpha, beta, gam = dot(N, Gm), dot(N, v), dot(Gm, v)
    gp[0] += h * (c_[1] * alpha + b_[1] * beta * gam)
    for j in range(3):
        gp[j + 1] += h * (2.0 * c_[2] * v[j] * alpha + 2.0 * b_[2] * v[j] * beta * gam
                          + b_[0] * (gam * N[j] + beta * Gm[j]))
    return energy, f, alpha, beta, gam


@njit(cache=True, _nrt=False, inline="always")
def residual(qA, qB, qAc, gp, gm, nsp, JpA, JpB, gA, gB, TA, TB, rA, rB, res):
    """Chain the gradient to (qA, qB) - p = L(conj qA) qB = R(qB) diag(1,-1,-1,-1)
    qA, m = qA + qB - and to the spatial increments: the residual (12,)."""
    quat_left_into(qAc, JpB)
    quat_right_into(qB, JpA)
    for i in range(4):
        for j in range(1, 4):
            JpA[i, j] = -JpA[i, j]
    tmv(JpA, gp, gA)
    tmv(JpB, gp, gB)
    for i in range(4):
        gA[i] += gm[i]
        gB[i] += gm[i]
    increment_map(qA, TA)
    increment_map(qB, TB)
    tmv(TA, gA, rA)
    tmv(TB, gB, rB)
    for i in range(3):
        res[i] = -nsp[i]
        res[6 + i] = nsp[i]
        res[3 + i] = rA[i]
        res[9 + i] = rB[i]


@njit(cache=True, _nrt=False)
def hessian_y(h, v, lg, c_, b_, nm, m, d, Gm, M, Rm, N, S, Nt, nsp, gm, f, alpha, beta, gam,
               CN, CM, Jpsi, QdN, t4, e, Q, Hp, Hmm, Hmp, Hdm, Hdp, Hdd, JGm, MJG, GP, DN, CG):
    """The Hessian of the element energy in y = (d, m, p): blocks Hdd, Hdm,
    Hdp, Hmm, Hmp, Hp."""
    g_w, g_t, g_ww, g_wt, g_tt = lg[1], lg[2], lg[3], lg[4], lg[5]
    b = b_[0]
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
            Hmm[i, j] = h * a1 + 2.0 / nm * (QdN[i, j] - m[i] * gm[j] - gm[i] * m[j])
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


@njit(cache=True, _nrt=False, inline="always")
def tangent_matrix(qA, qB, gA, gB, gp, res, Hp, Hmm, Hmp, Hdm, Hdp, Hdd, JpA, JpB, TA, TB, T44, T43,
             HAA, HBB, HAB, HdA, HdB, KAA, KBB, KAB, K):
    """Chain the Hessian in y to (qA, qB), then to the spatial increments; K (12, 12)."""
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
    quat_right_into(gp, T44)                       # d2(gp·p)/dqA dqB = R(gp)^T
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
