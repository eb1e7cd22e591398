"""The master side of a contact pair: a segment seen as the Catmull-Rom cubic
through its ends and its neighbours' far ends (a yarn end continues
straight: a ghost point folded into the shape functions), closest points on
it, and the cheap bounds that keep far segments out of the search.

Neighbouring curves join with a continuous tangent, so the distance to the
master yarn has a continuous gradient (see :mod:`knitfem.contact.narrow`).
"""
import numpy as np
from numba import njit


@njit(cache=True)
def fold_ghosts(f, has_prev, has_next):
    """Fold the ghost points of a yarn end (straight continuation) into the inner two."""
    if not has_prev:                     # M0 = 2 M1 - M2
        f[1] += 2.0 * f[0]
        f[2] -= f[0]
        f[0] = 0.0
    if not has_next:                     # M3 = 2 M2 - M1
        f[2] += 2.0 * f[3]
        f[1] -= f[3]
        f[3] = 0.0


@njit(cache=True)
def shape(t, has_prev, has_next, N, dN, ddN):
    """Catmull-Rom shape functions of the four master points and their first
    two derivatives in t."""
    t2, t3 = t * t, t * t * t
    N[0], N[1] = 0.5 * (-t + 2.0 * t2 - t3), 0.5 * (2.0 - 5.0 * t2 + 3.0 * t3)
    N[2], N[3] = 0.5 * (t + 4.0 * t2 - 3.0 * t3), 0.5 * (-t2 + t3)
    dN[0], dN[1] = 0.5 * (-1.0 + 4.0 * t - 3.0 * t2), 0.5 * (-10.0 * t + 9.0 * t2)
    dN[2], dN[3] = 0.5 * (1.0 + 8.0 * t - 9.0 * t2), 0.5 * (-2.0 * t + 3.0 * t2)
    ddN[0], ddN[1] = 0.5 * (4.0 - 6.0 * t), 0.5 * (-10.0 + 18.0 * t)
    ddN[2], ddN[3] = 0.5 * (8.0 - 18.0 * t), 0.5 * (-2.0 + 6.0 * t)
    fold_ghosts(N, has_prev, has_next)
    fold_ghosts(dN, has_prev, has_next)
    fold_ghosts(ddN, has_prev, has_next)


@njit(cache=True)
def combine(M, f, out):
    """out (3,) = sum_k f[k] M[k]."""
    for j in range(3):
        out[j] = f[0] * M[0, j] + f[1] * M[1, j] + f[2] * M[2, j] + f[3] * M[3, j]


@njit(cache=True, inline="always")
def _closest(px, py, pz, C):
    """(t*, clamped, distance) of the point to the cubic c(t) = C0 + C1 t + C2 t^2
    + C3 t^3 on [0, 1]: Newton on F'(t) = 0, F = |p - c|^2 / 2, from the chord
    projection, with a backtracking line search on F (Newton's step where F'' >
    0, else a gradient step): converged until the step vanishes.  Where the
    point is near a centre of curvature F is flat and the old capped step
    (gradient-like whenever F'' < a/4) left t* off by 1e-4 after 30 steps, so
    the contact force was not the derivative of the contact energy (measured:
    0.7 % off, which stalled a relaxing swatch)."""
    ex = C[1, 0] + C[2, 0] + C[3, 0]
    ey = C[1, 1] + C[2, 1] + C[3, 1]
    ez = C[1, 2] + C[2, 2] + C[3, 2]
    t = ((px - C[0, 0]) * ex + (py - C[0, 1]) * ey + (pz - C[0, 2]) * ez) \
        / (ex * ex + ey * ey + ez * ez)
    t = min(max(t, 0.0), 1.0)
    clamped = False
    ux = px - (C[0, 0] + t * (C[1, 0] + t * (C[2, 0] + t * C[3, 0])))
    uy = py - (C[0, 1] + t * (C[1, 1] + t * (C[2, 1] + t * C[3, 1])))
    uz = pz - (C[0, 2] + t * (C[1, 2] + t * (C[2, 2] + t * C[3, 2])))
    F = 0.5 * (ux * ux + uy * uy + uz * uz)
    for _ in range(60):
        dx = C[1, 0] + t * (2.0 * C[2, 0] + 3.0 * t * C[3, 0])
        dy = C[1, 1] + t * (2.0 * C[2, 1] + 3.0 * t * C[3, 1])
        dz = C[1, 2] + t * (2.0 * C[2, 2] + 3.0 * t * C[3, 2])
        a = dx * dx + dy * dy + dz * dz
        g = -(ux * dx + uy * dy + uz * dz)                          # F'(t)
        fp = a - (ux * (2.0 * C[2, 0] + 6.0 * t * C[3, 0])
                  + uy * (2.0 * C[2, 1] + 6.0 * t * C[3, 1])
                  + uz * (2.0 * C[2, 2] + 6.0 * t * C[3, 2]))       # F''(t)
        step = -g / (fp if fp > 1e-9 * a else a)
        # a foot at an end up to round-off counts as inside (as for a chord)
        clamped = (t == 0.0 and step < -1e-9) or (t == 1.0 and step > 1e-9)
        moved = False
        for _ in range(40):
            new = min(max(t + step, 0.0), 1.0)
            if new == t:
                break
            vx = px - (C[0, 0] + new * (C[1, 0] + new * (C[2, 0] + new * C[3, 0])))
            vy = py - (C[0, 1] + new * (C[1, 1] + new * (C[2, 1] + new * C[3, 1])))
            vz = pz - (C[0, 2] + new * (C[1, 2] + new * (C[2, 2] + new * C[3, 2])))
            Fn = 0.5 * (vx * vx + vy * vy + vz * vz)
            # F resolves t only to ~sqrt(eps): tiny (polishing) steps are taken as they are
            if Fn <= F or abs(new - t) < 1e-7:
                t, ux, uy, uz, F, moved = new, vx, vy, vz, Fn, True
                break
            step *= 0.5
        if not moved or abs(step) <= 1e-15:
            break
    return t, clamped, np.sqrt(2.0 * F)


@njit(cache=True)
def power_basis(M, has_prev, has_next, C):
    """Fill C (4, 3) with the power-basis coefficients of the master curve
    with points M (4, 3) (ghost points at a yarn end)."""
    P0, P1, P2, P3 = (M[0], M[1], M[2], M[3]) if has_prev and has_next else \
        (M[0] if has_prev else 2.0 * M[1] - M[2], M[1], M[2],
         M[3] if has_next else 2.0 * M[2] - M[1])
    for j in range(3):
        C[0, j] = P1[j]
        C[1, j] = 0.5 * (P2[j] - P0[j])
        C[2, j] = 0.5 * (2.0 * P0[j] - 5.0 * P1[j] + 4.0 * P2[j] - P3[j])
        C[3, j] = 0.5 * (-P0[j] + 3.0 * P1[j] - 3.0 * P2[j] + P3[j])


@njit(cache=True)
def evaluate(p, M, has_prev, has_next, t, N, dN, ddN, u, c1, c2):
    """|u| at the master parameter t; leaves u = p - c(t), c1 = c'(t),
    c2 = c''(t) and the shape functions at t in the buffers."""
    shape(t, has_prev, has_next, N, dN, ddN)
    combine(M, N, u)
    combine(M, dN, c1)
    combine(M, ddN, c2)
    for j in range(3):
        u[j] = p[j] - u[j]
    return np.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])


@njit(cache=True)
def project(p, M, has_prev, has_next, N, dN, ddN, u, c1, c2):
    """Closest point of the master curve to p: t* in [0, 1], whether the
    unconstrained minimum lies beyond an end, and |u|; leaves u = p - c(t*),
    c1 = c'(t*), c2 = c''(t*) and the shape functions at t* in the buffers."""
    C = np.empty((4, 3))
    power_basis(M, has_prev, has_next, C)
    t, clamped, d = _closest(p[0], p[1], p[2], C)
    d = evaluate(p, M, has_prev, has_next, t, N, dN, ddN, u, c1, c2)
    return t, clamped, d


@njit(cache=True, inline="always")
def _value(D, k, t):
    """Row k of D (a polynomial of degree 5 - k, power basis) at t."""
    v = 0.0
    for i in range(5 - k, -1, -1):
        v = v * t + D[k, i]
    return v


@njit(cache=True)
def _bracketed(D, k, lo, hi, vlo):
    """The root of row k of D on [lo, hi], where it changes sign once (vlo
    its value at lo; 0 counts as positive): Newton kept inside the shrinking
    bracket, bisection where it would leave it."""
    t = 0.5 * (lo + hi)
    for _ in range(200):
        v = _value(D, k, t)
        if v == 0.0:
            return t
        if (v < 0.0) == (vlo < 0.0):
            lo = t
        else:
            hi = t
        dv = _value(D, k + 1, t)
        new = t - v / dv if dv != 0.0 else 0.5 * (lo + hi)
        if not lo < new < hi:
            new = 0.5 * (lo + hi)
        if new == t or hi - lo <= 1e-15:
            return new
        t = new
    return t


@njit(cache=True)
def _squared_distance_floor(p, C, D):
    """A lower bound of |c(t) - p|^2 on [0, 1]: the least Bernstein coefficient
    of that sextic (it lies in their convex hull), from c(0) and row 0 of D
    (its derivative over 2), less 1e-12 of the largest against round-off."""
    f = np.empty(7)
    f[0] = 0.0
    for j in range(3):
        f[0] += (C[0, j] - p[j]) ** 2
    for i in range(6):
        f[i + 1] = 2.0 * D[0, i] / (i + 1)
    low, high = np.inf, 0.0
    for k in range(7):
        b, ck, c6 = 0.0, 1.0, 1.0            # C(k, i), C(6, i)
        for i in range(k + 1):
            if i > 0:
                ck = ck * (k - i + 1) / i
                c6 = c6 * (7 - i) / i
            b += ck / c6 * f[i]
        low, high = min(low, b), max(high, abs(b))
    return low - 1e-12 * high


@njit(cache=True)
def critical_points(p, C, g_start, D, roots, kinds, floor=-1.0):
    """Every critical point of the distance from p to the master curve C
    (4, 3) inside (0, 1]: the roots of F'(t) = (c(t) - p).c'(t), a quintic,
    each isolated exactly between the roots of its derivative (recursively
    down to the linear fourth derivative), so no pair of a minimum and a
    maximum, however close, is missed.  Fills roots and kinds (+1 a minimum,
    -1 a maximum of the distance) in order; returns their count, F'(0) and
    F'(1).  g_start, if finite, is used as F'(0): a point where two master
    curves join is given the same sign on both sides, so a critical point
    there is counted once.  floor > 0: none is sought (count 0) where the
    whole curve is certainly farther than floor from p.  D (6, 6), roots and
    kinds (6,) are scratch."""
    for i in range(6):
        for k in range(6):
            D[k, i] = 0.0
    for j in range(3):
        d0 = C[0, j] - p[j]
        c1, c2, c3 = C[1, j], C[2, j], C[3, j]
        D[0, 0] += d0 * c1
        D[0, 1] += 2.0 * d0 * c2 + c1 * c1
        D[0, 2] += 3.0 * (d0 * c3 + c1 * c2)
        D[0, 3] += 4.0 * c1 * c3 + 2.0 * c2 * c2
        D[0, 4] += 5.0 * c2 * c3
        D[0, 5] += 3.0 * c3 * c3
    for k in range(1, 6):
        for i in range(6 - k):
            D[k, i] = (i + 1) * D[k - 1, i + 1]
    g0 = D[0, 0] if np.isnan(g_start) else g_start
    g1 = _value(D, 0, 1.0)
    if floor > 0.0 and _squared_distance_floor(p, C, D) > floor * floor:
        return 0, g0, g1
    # the linear fourth derivative's root, then each row's roots between those
    # of the row below (on each piece the row is monotone: one root at most)
    count = 0
    if D[4, 1] != 0.0:
        r = -D[4, 0] / D[4, 1]
        if 0.0 < r < 1.0:
            roots[0], count = r, 1
    for k in range(3, -1, -1):
        found = 0
        a, va = 0.0, (g0 if k == 0 else D[k, 0])
        for i in range(count + 1):
            b = roots[i] if i < count else 1.0
            vb = (g1 if k == 0 else _value(D, k, 1.0)) if i == count else _value(D, k, b)
            if (va < 0.0) != (vb < 0.0):
                # in place: roots[found], found <= i, was read already
                kinds[found] = 1 if va < 0.0 else -1
                roots[found] = _bracketed(D, k, a, b, va)
                found += 1
            a, va = b, vb
        count = found
    return count, g0, g1


@njit(cache=True)
def coefficients(x0, x1, prev, nxt):
    """Power-basis coefficients (n, 4, 3) of every master curve,
    c(t) = C0 + C1 t + C2 t^2 + C3 t^3, for the search pass."""
    n = x0.shape[0]
    C = np.empty((n, 4, 3))
    M = np.empty((4, 3))
    for B in range(n):
        has_prev, has_next = gather(B, x0, x1, prev, nxt, M)
        power_basis(M, has_prev, has_next, C[B])
    return C


@njit(cache=True, inline="always")
def chord_distance(px, py, pz, b0, b1):
    """Distance from (px, py, pz) to the chord (b0, b1); scalar arithmetic."""
    ex, ey, ez = b1[0] - b0[0], b1[1] - b0[1], b1[2] - b0[2]
    qx, qy, qz = px - b0[0], py - b0[1], pz - b0[2]
    eta = (qx * ex + qy * ey + qz * ez) / (ex * ex + ey * ey + ez * ez)
    eta = min(max(eta, 0.0), 1.0)
    ux, uy, uz = qx - eta * ex, qy - eta * ey, qz - eta * ez
    return np.sqrt(ux * ux + uy * uy + uz * uz)


@njit(cache=True, inline="always")
def segment_distance(a0, a1, b0, b1):
    """Smallest distance between the segments (a0, a1) and (b0, b1) (the
    clamped closest-point parameters of Ericson, Real-Time Collision
    Detection, 5.1.9); scalar arithmetic."""
    d1x, d1y, d1z = a1[0] - a0[0], a1[1] - a0[1], a1[2] - a0[2]
    d2x, d2y, d2z = b1[0] - b0[0], b1[1] - b0[1], b1[2] - b0[2]
    rx, ry, rz = a0[0] - b0[0], a0[1] - b0[1], a0[2] - b0[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    c = d1x * rx + d1y * ry + d1z * rz
    b = d1x * d2x + d1y * d2y + d1z * d2z
    denom = a * e - b * b
    s = min(max((b * f - c * e) / denom, 0.0), 1.0) if denom > 1e-14 * a * e else 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t, s = 0.0, min(max(-c / a, 0.0), 1.0)
    elif t > 1.0:
        t, s = 1.0, min(max((b - c) / a, 0.0), 1.0)
    ux = rx + s * d1x - t * d2x
    uy = ry + s * d1y - t * d2y
    uz = rz + s * d1z - t * d2z
    return np.sqrt(ux * ux + uy * uy + uz * uz)


@njit(cache=True)
def gather(B, x0, x1, prev, nxt, M):
    """Fill the master points of segment B; returns (has_prev, has_next)."""
    has_prev, has_next = prev[B] >= 0, nxt[B] >= 0
    for j in range(3):
        M[0, j] = x0[prev[B], j] if has_prev else x0[B, j]
        M[1, j] = x0[B, j]
        M[2, j] = x1[B, j]
        M[3, j] = x1[nxt[B], j] if has_next else x1[B, j]
    return has_prev, has_next


def neighbours(x0, x1, rod, s_mid, order=None):
    """prev, next (n,): the adjacent segment along the same rod whose end
    meets this one (-1 at a yarn end or a gap), from the order in arclength
    (``order`` = np.lexsort((s_mid, rod)), if known)."""
    n = x0.shape[0]
    prev, nxt = np.full(n, -1, np.int64), np.full(n, -1, np.int64)
    order = np.lexsort((s_mid, rod)) if order is None else order
    a, b = order[:-1], order[1:]
    h = np.minimum(np.linalg.norm(x1[a] - x0[a], axis=1), np.linalg.norm(x1[b] - x0[b], axis=1))
    joined = (rod[a] == rod[b]) & (np.linalg.norm(x1[a] - x0[b], axis=1) <= 1e-9 * h)
    nxt[a[joined]], prev[b[joined]] = b[joined], a[joined]
    return prev, nxt


def bulge(x0, x1, prev, nxt):
    """How far each master curve strays from its chord at most (n,):
    c(t) - chord(t) = -t(1-t)/2 [(1-t) D1 + t D2], D the second differences
    at the segment's ends (zero at yarn ends), so |.| <= max(|D1|, |D2|)/8."""
    has_prev, has_next = prev >= 0, nxt >= 0
    D1 = np.where(has_prev[:, None], x0[np.where(has_prev, prev, 0)] - 2 * x0 + x1, 0.0)
    D2 = np.where(has_next[:, None], x0 - 2 * x1 + x1[np.where(has_next, nxt, 0)], 0.0)
    return 0.125 * np.maximum(np.linalg.norm(D1, axis=1), np.linalg.norm(D2, axis=1))
