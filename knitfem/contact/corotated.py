"""Co-rotated friction slip (see :mod:`knitfem.contact.friction`): the slip
of a pair's touching points measured in the master yarn's frame at the pair,
turned with it since the anchor,

    u = P_n [ R_m^T (r - a_s R_s n) - rel0 ],

with its first derivatives (translations and spatial turns of the slots'
frames) and the gradient-weighted second derivatives.  Lengths as the
caller's; rotations in radians.
"""
import numpy as np
from numba import njit

SLOTS = 6


def _geodesic(theta_a, theta_b, tau):
    """Rotations R_A exp(tau psi) (k, 3, 3) between the ends' rotations R_A =
    exp(theta_a) and R_B = exp(theta_b) (rotation vectors (k, 3); psi =
    log(R_A^T R_B): adjacent frames, far below a half turn) and the maps C_A,
    C_B (k, 3, 3) of the ends' spatial turns to the turn of that rotation (phi
    = C_A w_A + C_B w_B, exact).  Interpolating the ends' rotation vectors
    instead jumps where one of them passes a half turn since the anchor (its
    logarithm wraps): seen within one friction round of a 3 x 4 swatch at
    alpha 0.2.  Through quaternions and with J_l^-1 in closed form: scipy's
    matrix logarithm and numpy's batched inverse were a sixth of a 5 x 5
    relaxation."""
    # imported here: knitfem.beam imports this package (its yarn contact)
    from ..beam.rotation import (quat_conjugate, quat_exp, quat_multiply, rotation_matrix,
                                 rotation_vector)
    qa = quat_exp(theta_a)
    psi = rotation_vector(quat_multiply(quat_conjugate(qa), quat_exp(theta_b)))
    RA = rotation_matrix(qa)
    mid = rotation_matrix(quat_multiply(qa, quat_exp(tau[:, None] * psi)))
    C_B = tau[:, None, None] * (RA @ _left_jacobian(tau[:, None] * psi)
                                @ left_jacobian_inverse(psi) @ np.swapaxes(RA, 1, 2))
    return mid, np.eye(3)[None] - C_B, C_B


def _corotation(anchors, r, theta):
    """The co-rotated slip's pieces: lever arm a_s (k,), the slave's and the
    master's rotations at the pair R_s, R_m (k, 3, 3) with their turn maps
    (:func:`_geodesic`, along the slave chord and the master segment), the
    centrelines' relative vector r (k, 3) and m = R_s n (k, 3)."""
    a = anchors
    w = a.rot_weights
    arm_s, arm_m = w[:, 0] + w[:, 1], w[:, 2] + w[:, 3]
    th = theta[a.rot_ends // 2, a.rot_ends % 2]
    R_s, *C_s = _geodesic(th[:, 0], th[:, 1], w[:, 1] / arm_s)
    R_m, *C_m = _geodesic(th[:, 2], th[:, 3], w[:, 3] / arm_m)
    return arm_s, C_s, C_m, R_s, R_m, r, np.einsum("kij,kj->ki", R_s, a.normal)


def corotated_slip(anchors, r, theta):
    """Slip in the master's material frame, P_n [R_m^T (r - a_s R_s n) - rel0],
    and the pieces of :func:`_corotation`."""
    a = anchors
    arm_s, _, _, R_s, R_m, r, m = parts = _corotation(a, r, theta)
    v = np.einsum("kji,kj->ki", R_m, r - arm_s[:, None] * m) - a.rel0
    return v - a.normal * np.sum(a.normal * v, axis=1, keepdims=True), parts


def _left_jacobian(theta):
    """J_l(theta) (k, 3, 3) of SO(3): d exp(theta) = hat(J_l d theta) exp(theta)."""
    t = np.linalg.norm(theta, axis=1)[:, None, None]
    W = hat(theta)
    small = t < 1e-4
    ts = np.where(small, 1.0, t)
    c1 = np.where(small, 0.5 - t * t / 24.0, (1.0 - np.cos(ts)) / ts**2)
    c2 = np.where(small, 1.0 / 6.0 - t * t / 120.0, (ts - np.sin(ts)) / ts**3)
    return np.eye(3) + c1 * W + c2 * (W @ W)


def left_jacobian_inverse(theta):
    """J_l(theta)^-1 (..., 3, 3) of SO(3), closed form: d log(exp(d) exp(theta))
    / d d at d = 0 (theta (..., 3) below a full turn)."""
    t = np.linalg.norm(theta, axis=-1)[..., None, None]
    W = hat(theta)
    small = t < 1e-4
    ts = np.where(small, 1.0, t)
    coef = np.where(small, 1.0 / 12.0 + t * t / 720.0,
                    (1.0 - 0.5 * ts * np.sin(ts) / (1.0 - np.cos(ts))) / ts**2)
    return np.eye(3) - 0.5 * W + coef * (W @ W)


def hat(v):
    """Cross-product matrices (..., 3, 3): hat(v) w = v x w."""
    h = np.zeros(v.shape + (3,))
    h[..., 0, 1], h[..., 0, 2], h[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    h[..., 1, 0], h[..., 2, 0], h[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return h


def corotated_jacobian(anchors, r, theta):
    """Co-rotated slip u (k, 3), du/d(slots) (k, 3, 30) for the slots'
    translations and *spatial* turns of their frames, and the pieces the
    second derivatives need: translations s_a R_m^T, the master's turns
    R_m^T hat(v) C_b with v = r - a_s m, the slave's a_s R_m^T hat(m) C_b
    (the tangent-plane projection left to the callers: gradient and Hessian
    live in the plane)."""
    a = anchors
    u, (arm_s, C_s, C_m, R_s, R_m, r, m) = corotated_slip(a, r, theta)
    k = len(u)
    RmT = np.swapaxes(R_m, 1, 2)
    J = np.zeros((k, 3, 3 * SLOTS + 12))
    J[:, :, :3 * SLOTS] = (a.s[:, None, :, None] * RmT[:, :, None, :]).reshape(k, 3, 3 * SLOTS)
    v = r - arm_s[:, None] * m
    master, slave = RmT @ hat(v), arm_s[:, None, None] * (RmT @ hat(m))
    C = np.stack(C_s + C_m, axis=1)                                   # (k, 4, 3, 3)
    J[:, :, 3 * SLOTS:] = np.concatenate([slave[:, None] @ C[:, :2], master[:, None] @ C[:, 2:]],
                                         axis=1).transpose(0, 2, 1, 3).reshape(k, 3, 12)
    return u, J, (R_m, v, m, arm_s, C)


def corotated_geometric(g3, pieces, s):
    """g3 . d2u (k, 30, 30): the Hessian's part from the turning of the
    master's frame (R_m^T) and of the slave's touching point (R_s n), with
    G = R_m g3: d2(R_m^T v) gives (G v^T + v G^T)/2 - (G.v) I, the turn of m
    likewise times -a_s, the master's turn against the slave's a_s (m G^T -
    (G.m) I), the master's turn against the translations s_a hat(G); mapped
    to the ends' spatial turns by C (what changes C itself, of order the
    frames' relative turn along a segment times |g|, is left out).  Block by
    block in numba: the batched einsums it replaced wrote and re-read a
    (k, 10, 3, 10, 3) array, 0.12 s of CPU a Hessian at 22 915 anchors
    (25 x 35) against 0.03 s: 2-4 % of a step there."""
    R_m, v, m, arm_s, C = pieces
    K = np.zeros((len(g3), 30, 30))
    _geometric_blocks(*(np.ascontiguousarray(a, dtype=float) for a in (R_m, g3, v, m, arm_s, C, s)),
                      K)
    return K


@njit(cache=True)
def _geometric_blocks(R_m, g3, v, m, arm_s, C, s, K):
    """Fill K (k, 30, 30), zero on entry, with :func:`corotated_geometric`'s
    blocks: rows/columns 3 a + i for the six slots' translations, 18 + 3 b + i
    for the four ends' turns (b = 0, 1 the slave's, 2, 3 the master's)."""
    G = np.empty(3)
    phi = np.empty((2, 3, 2, 3))        # (slave, master) turns at the pair
    T = np.empty((3, 3))
    hG = np.empty((3, 3))
    A = np.empty((3, 3))
    for k in range(K.shape[0]):
        for i in range(3):
            G[i] = R_m[k, i, 0] * g3[k, 0] + R_m[k, i, 1] * g3[k, 1] + R_m[k, i, 2] * g3[k, 2]
        Gv = G[0] * v[k, 0] + G[1] * v[k, 1] + G[2] * v[k, 2]
        Gm = G[0] * m[k, 0] + G[1] * m[k, 1] + G[2] * m[k, 2]
        a = arm_s[k]
        for i in range(3):
            for l in range(3):
                d = 1.0 if i == l else 0.0
                phi[0, i, 0, l] = -a * (0.5 * (G[i] * m[k, l] + m[k, i] * G[l]) - Gm * d)
                phi[1, i, 1, l] = 0.5 * (G[i] * v[k, l] + v[k, i] * G[l]) - Gv * d
                phi[1, i, 0, l] = a * (m[k, i] * G[l] - Gm * d)
        for i in range(3):
            for l in range(3):
                phi[0, i, 1, l] = phi[1, l, 0, i]
        for b in range(4):
            sb = b // 2
            for c in range(4):
                sc = c // 2
                for j in range(3):          # T = phi_(sb, sc) C_c
                    for q in range(3):
                        T[j, q] = (phi[sb, j, sc, 0] * C[k, c, 0, q] +
                                   phi[sb, j, sc, 1] * C[k, c, 1, q] +
                                   phi[sb, j, sc, 2] * C[k, c, 2, q])
                for i in range(3):          # C_b^T T
                    for q in range(3):
                        K[k, 18 + 3 * b + i, 18 + 3 * c + q] = (
                            C[k, b, 0, i] * T[0, q] + C[k, b, 1, i] * T[1, q] +
                            C[k, b, 2, i] * T[2, q])
        hG[0, 0], hG[0, 1], hG[0, 2] = 0.0, -G[2], G[1]
        hG[1, 0], hG[1, 1], hG[1, 2] = G[2], 0.0, -G[0]
        hG[2, 0], hG[2, 1], hG[2, 2] = -G[1], G[0], 0.0
        for b in range(2):                  # the master's turns against the translations
            for i in range(3):
                for l in range(3):
                    A[i, l] = (C[k, 2 + b, 0, i] * hG[0, l] + C[k, 2 + b, 1, i] * hG[1, l] +
                               C[k, 2 + b, 2, i] * hG[2, l])
            for slot in range(6):
                w = s[k, slot]
                for i in range(3):
                    for l in range(3):
                        K[k, 24 + 3 * b + i, 3 * slot + l] = A[i, l] * w
                        K[k, 3 * slot + l, 24 + 3 * b + i] = A[i, l] * w
