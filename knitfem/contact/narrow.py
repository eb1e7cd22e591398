"""Narrow phase: Gauss-point-to-curve (line-to-line) contact of segment pairs.

Why not closest points between segments: yarns in a knit lie nearly parallel
over long stretches, where the closest-point pair of two segments jumps and
a single point force cannot carry a distributed load (Meier, Popp & Wall
2016).  Here every Gauss point p of a slave segment A (on its chord) is
projected on the master segment B, seen as a smooth curve: the Catmull-Rom
cubic through B's ends and its neighbours' far ends,

    c(t) = sum_k N_k(t) M_k,  M = (x0[prev B], x0[B], x1[B], x1[next B]),

(a yarn end continues straight: a ghost point 2 x0[B] - x1[B] folded into
the shape functions).  Neighbouring master curves join with a continuous
tangent, so the distance to the master yarn has a continuous gradient
everywhere, also where a slave point passes from one master segment to the
next on the concave side of a kink of the polyline: the minimum of two chord
distances would make the force jump there and Newton linear.  With
u = p - c(t*), t* the closest point (local Newton from the chord projection),

    g = |u| - (r_a + r_b),   energy  sum_gauss  w l_A phi(g).

A is the slave of the pair and B, among A's candidate masters, the segment
of smallest gap from p (preferring masters p projects inside, so a point
facing a joint is not counted twice).  Slaves are chosen per yarn (the yarn
with the finer elements, as the non-mortar side of a mortar method), so each
contact is counted once.  Crossings are resolved by the Gauss points near
them: ``per_diameter`` points per yarn diameter along every slave segment.

Derivatives in the 6 points z = (a0, a1, M0..M3), s = ((1-xi), xi, -N(t*)),
F = |u|^2 / 2 (the envelope theorem for the projection):

    grad F = S^T u,   hess F = S^T S - b b^T / (c'.c' - u.c''),
    b = S^T c' + N'(t*) (x) u on the master points

(drop the b term where t* is clamped to an end), chained through d = sqrt(2F)
to phi(g): the tangent is exact, so Newton stays quadratic with contact.

Normal damping (optional, for quasi-static or dynamic increments): a line load
c psi(g) dg/dt resisting the gap rate of each active Gauss point, with
dg/dt = (g - g_prev) / dt, g_prev the gap of the same slave point to the same
master segment at the start of the increment, and psi = phi''/k the
penalty's stiffness ramp (0 at g0, 1 in contact), so the damping fades in
with the contact and the force stays continuous.  It adds
h = c psi (g - g_prev)/dt to phi' and h' = c (psi + psi' (g - g_prev))/dt to
phi'', so the tangent stays exact (and symmetric); it stores no energy.
Compiled with numba: the loop over pairs and Gauss points is the hot spot.
"""
import numpy as np
from numba import njit

MAX_ORDER = 48
SLOTS = 6                    # slave a0, a1; master M0..M3


@njit(cache=True)
def _law(g, k, g0):
    """phi, phi', phi'' of the penalty law (see law.py)."""
    if g >= g0:
        return 0.0, 0.0, 0.0
    if g >= 0.0:
        t = g0 - g
        return k * t**3 / (6.0 * g0), -k * t * t / (2.0 * g0), k * t / g0
    return k * (g0 * g0 / 6.0 - 0.5 * g0 * g + 0.5 * g * g), -k * (0.5 * g0 - g), k


@njit(cache=True)
def _fold(f, has_prev, has_next):
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
def _shape(t, has_prev, has_next, N, dN, ddN):
    """Catmull-Rom shape functions of the four master points and their first
    two derivatives in t."""
    t2, t3 = t * t, t * t * t
    N[0], N[1] = 0.5 * (-t + 2.0 * t2 - t3), 0.5 * (2.0 - 5.0 * t2 + 3.0 * t3)
    N[2], N[3] = 0.5 * (t + 4.0 * t2 - 3.0 * t3), 0.5 * (-t2 + t3)
    dN[0], dN[1] = 0.5 * (-1.0 + 4.0 * t - 3.0 * t2), 0.5 * (-10.0 * t + 9.0 * t2)
    dN[2], dN[3] = 0.5 * (1.0 + 8.0 * t - 9.0 * t2), 0.5 * (-2.0 * t + 3.0 * t2)
    ddN[0], ddN[1] = 0.5 * (4.0 - 6.0 * t), 0.5 * (-10.0 + 18.0 * t)
    ddN[2], ddN[3] = 0.5 * (8.0 - 18.0 * t), 0.5 * (-2.0 + 6.0 * t)
    _fold(N, has_prev, has_next)
    _fold(dN, has_prev, has_next)
    _fold(ddN, has_prev, has_next)


@njit(cache=True)
def _curve(M, f, out):
    """out (3,) = sum_k f[k] M[k]."""
    for j in range(3):
        out[j] = f[0] * M[0, j] + f[1] * M[1, j] + f[2] * M[2, j] + f[3] * M[3, j]


@njit(cache=True)
def _project(p, M, has_prev, has_next, N, dN, ddN, u, c1, c2):
    """Closest point of the master curve to p: t* in [0, 1], whether the
    unconstrained minimum lies beyond an end, and |u|; leaves u = p - c(t*),
    c1 = c'(t*), c2 = c''(t*) and the shape functions at t* in the buffers."""
    e0, e1, e2 = M[2, 0] - M[1, 0], M[2, 1] - M[1, 1], M[2, 2] - M[1, 2]
    t = ((p[0] - M[1, 0]) * e0 + (p[1] - M[1, 1]) * e1 + (p[2] - M[1, 2]) * e2) \
        / (e0 * e0 + e1 * e1 + e2 * e2)
    t = min(max(t, 0.0), 1.0)
    clamped = False
    for _ in range(30):
        _shape(t, has_prev, has_next, N, dN, ddN)
        _curve(M, N, u)
        _curve(M, dN, c1)
        _curve(M, ddN, c2)
        for j in range(3):
            u[j] = p[j] - u[j]
        a = c1[0] * c1[0] + c1[1] * c1[1] + c1[2] * c1[2]
        f = -(u[0] * c1[0] + u[1] * c1[1] + u[2] * c1[2])
        fp = a - (u[0] * c2[0] + u[1] * c2[1] + u[2] * c2[2])
        step = -f / (fp if fp > 0.25 * a else a)
        # a foot at an end up to round-off counts as inside (as for a chord)
        clamped = (t == 0.0 and step < -1e-9) or (t == 1.0 and step > 1e-9)
        new = min(max(t + step, 0.0), 1.0)
        if abs(new - t) <= 1e-14:
            break
        t = new
    d = np.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
    return t, clamped, d


@njit(cache=True)
def _coefficients(x0, x1, prev, nxt):
    """Power-basis coefficients (n, 4, 3) of every master curve,
    c(t) = C0 + C1 t + C2 t^2 + C3 t^3, for the search pass."""
    n = x0.shape[0]
    C = np.empty((n, 4, 3))
    for B in range(n):
        for j in range(3):
            p1, p2 = x0[B, j], x1[B, j]
            p0 = x0[prev[B], j] if prev[B] >= 0 else 2.0 * p1 - p2
            p3 = x1[nxt[B], j] if nxt[B] >= 0 else 2.0 * p2 - p1
            C[B, 0, j] = p1
            C[B, 1, j] = 0.5 * (p2 - p0)
            C[B, 2, j] = 0.5 * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3)
            C[B, 3, j] = 0.5 * (-p0 + 3.0 * p1 - 3.0 * p2 + p3)
    return C


@njit(cache=True)
def _search_distance(px, py, pz, C):
    """Distance from (px, py, pz) to the master curve with coefficients C
    (4, 3) and whether its closest point is clamped to an end: a few Newton
    steps from the chord projection (the distance is stationary in t, so a
    loose t is an accurate distance); scalar arithmetic."""
    ex = C[1, 0] + C[2, 0] + C[3, 0]
    ey = C[1, 1] + C[2, 1] + C[3, 1]
    ez = C[1, 2] + C[2, 2] + C[3, 2]
    t = ((px - C[0, 0]) * ex + (py - C[0, 1]) * ey + (pz - C[0, 2]) * ez) \
        / (ex * ex + ey * ey + ez * ez)
    t = min(max(t, 0.0), 1.0)
    clamped = False
    ux = uy = uz = 0.0
    for _ in range(12):
        ux = px - (C[0, 0] + t * (C[1, 0] + t * (C[2, 0] + t * C[3, 0])))
        uy = py - (C[0, 1] + t * (C[1, 1] + t * (C[2, 1] + t * C[3, 1])))
        uz = pz - (C[0, 2] + t * (C[1, 2] + t * (C[2, 2] + t * C[3, 2])))
        dx = C[1, 0] + t * (2.0 * C[2, 0] + 3.0 * t * C[3, 0])
        dy = C[1, 1] + t * (2.0 * C[2, 1] + 3.0 * t * C[3, 1])
        dz = C[1, 2] + t * (2.0 * C[2, 2] + 3.0 * t * C[3, 2])
        a = dx * dx + dy * dy + dz * dz
        fp = a - (ux * (2.0 * C[2, 0] + 6.0 * t * C[3, 0]) + uy * (2.0 * C[2, 1] + 6.0 * t * C[3, 1])
                  + uz * (2.0 * C[2, 2] + 6.0 * t * C[3, 2]))
        step = (ux * dx + uy * dy + uz * dz) / (fp if fp > 0.25 * a else a)
        clamped = (t == 0.0 and step < -1e-9) or (t == 1.0 and step > 1e-9)
        new = min(max(t + step, 0.0), 1.0)
        if abs(new - t) <= 1e-9:
            break
        t = new
    return np.sqrt(ux * ux + uy * uy + uz * uz), clamped


@njit(cache=True)
def _chord_distance(px, py, pz, b0, b1):
    """Distance from (px, py, pz) to the chord (b0, b1); scalar arithmetic."""
    ex, ey, ez = b1[0] - b0[0], b1[1] - b0[1], b1[2] - b0[2]
    qx, qy, qz = px - b0[0], py - b0[1], pz - b0[2]
    eta = (qx * ex + qy * ey + qz * ez) / (ex * ex + ey * ey + ez * ez)
    eta = min(max(eta, 0.0), 1.0)
    ux, uy, uz = qx - eta * ex, qy - eta * ey, qz - eta * ez
    return np.sqrt(ux * ux + uy * uy + uz * uz)


@njit(cache=True)
def _segment_distance(a0, a1, b0, b1):
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
def _master(B, x0, x1, prev, nxt, M):
    """Fill the master points of segment B; returns (has_prev, has_next)."""
    has_prev, has_next = prev[B] >= 0, nxt[B] >= 0
    for j in range(3):
        M[0, j] = x0[prev[B], j] if has_prev else x0[B, j]
        M[1, j] = x0[B, j]
        M[2, j] = x1[B, j]
        M[3, j] = x1[nxt[B], j] if has_next else x1[B, j]
    return has_prev, has_next


@njit(cache=True)
def _gauss_point(xi, a0, a1, M, has_prev, has_next, R, W, k, g0, tangent, grad, hess, stats,
                 buf, g_prev, c_dt):
    """Energy of the slave Gauss point at xi on (a0, a1) against the master
    curve M, weight W; adds its gradient / tangent into the pair's 18 slots.
    c_dt > 0: normal damping c/dt against the gap g_prev of the increment's start."""
    N, dN, ddN, u, c1, c2, p, s, b, dF = buf
    for j in range(3):
        p[j] = (1.0 - xi) * a0[j] + xi * a1[j]
    t, clamped, d = _project(p, M, has_prev, has_next, N, dN, ddN, u, c1, c2)
    g = d - R
    if g >= g0 or d < 1e-14 * R:
        return 0.0
    phi, dphi, ddphi = _law(g, k, g0)
    if c_dt > 0.0:
        ramp = ddphi / k
        slope = -1.0 / g0 if g >= 0.0 else 0.0
        dphi += c_dt * ramp * (g - g_prev)
        ddphi += c_dt * (ramp + slope * (g - g_prev))
    stats[1] += 1.0
    stats[2] += -W * dphi                          # normal force carried
    s[0], s[1] = 1.0 - xi, xi
    for m in range(4):
        s[2 + m] = -N[m]
    for a in range(SLOTS):
        for j in range(3):
            dF[3 * a + j] = s[a] * u[j]
    for i in range(3 * SLOTS):
        grad[i] += W * dphi * dF[i] / d
    if not tangent:
        return W * phi
    Ftt = (c1[0] * c1[0] + c1[1] * c1[1] + c1[2] * c1[2]) \
        - (u[0] * c2[0] + u[1] * c2[1] + u[2] * c2[2])
    for a in range(SLOTS):
        for j in range(3):
            b[3 * a + j] = s[a] * c1[j] + (dN[a - 2] * u[j] if a >= 2 else 0.0)
    for i in range(3 * SLOTS):
        for j in range(3 * SLOTS):
            hF = s[i // 3] * s[j // 3] if i % 3 == j % 3 else 0.0
            if not clamped:
                hF -= b[i] * b[j] / Ftt
            dd = hF / d - dF[i] * dF[j] / d**3                      # hess of d
            hess[i, j] += W * (ddphi * dF[i] * dF[j] / (d * d) + dphi * dd)
    return W * phi


@njit(cache=True)
def _points(length, diameter, per_diameter, least):
    """Gauss order for a segment of this length: per_diameter points per diameter."""
    n = int(np.ceil(per_diameter * length / diameter))
    return min(max(n, least), MAX_ORDER)


@njit(cache=True)
def _masters_of_slaves(pairs, rank, nseg):
    """CSR of the masters of every slave segment: the slave of a pair is the
    segment of lower ``rank`` (ranks are per yarn, so one yarn is the slave of
    another everywhere and no contact is counted from both sides; within one
    yarn the lower index)."""
    m = pairs.shape[0]
    slave_first = np.empty(m, np.bool_)
    count = np.zeros(nseg + 1, np.int64)
    for n in range(m):
        i, j = pairs[n, 0], pairs[n, 1]
        slave_first[n] = rank[i] < rank[j] or (rank[i] == rank[j] and i < j)
        count[(i if slave_first[n] else j) + 1] += 1
    start = np.cumsum(count)
    fill = start[:-1].copy()
    master = np.empty(m, np.int64)
    index = np.empty(m, np.int64)
    for n in range(m):
        a, b = (pairs[n, 0], pairs[n, 1]) if slave_first[n] else (pairs[n, 1], pairs[n, 0])
        master[fill[a]], index[fill[a]] = b, n
        fill[a] += 1
    return start, master, index


@njit(cache=True)
def _all_pairs(x0, x1, prev, nxt, bulge, radius, length, rank, pairs, XI, WTS, per_diameter,
               least, k, g0, tangent, x0p, x1p, c_dt):
    """Slave Gauss points against their master curves; each slave Gauss point
    interacts with the one master of smallest gap."""
    nseg = x0.shape[0]
    stats = np.array([np.inf, 0.0, 0.0])            # min gap, active points, total force
    seg_gap = np.full(nseg, np.inf)                 # smallest gap seen by each segment
    start, master, index = _masters_of_slaves(pairs, rank, nseg)
    C = _coefficients(x0, x1, prev, nxt)
    # most candidates are out of reach: one segment-segment distance rules them out
    near = np.empty(master.shape[0], np.bool_)
    for A in range(nseg):
        for t in range(start[A], start[A + 1]):
            B = master[t]
            gap = _segment_distance(x0[A], x1[A], x0[B], x1[B]) - radius[A] - radius[B]
            near[t] = gap - bulge[B] < g0
            if not near[t]:
                seg_gap[A] = min(seg_gap[A], gap)
                seg_gap[B] = min(seg_gap[B], gap)
                stats[0] = min(stats[0], gap)
    M = np.empty((4, 3))
    buf = (np.empty(4), np.empty(4), np.empty(4), np.empty(3), np.empty(3), np.empty(3),
           np.empty(3), np.empty(SLOTS), np.empty(3 * SLOTS), np.empty(3 * SLOTS))
    N, dN, ddN, u, c1, c2, p = buf[0], buf[1], buf[2], buf[3], buf[4], buf[5], buf[6]
    # pass 1: the master of every slave Gauss point within reach (no allocation)
    hits_A = np.empty(nseg * MAX_ORDER, np.int64)
    hits_q = np.empty(nseg * MAX_ORDER, np.int64)
    hits_t = np.empty(nseg * MAX_ORDER, np.int64)
    nhits = 0
    for A in range(nseg):
        if start[A] == start[A + 1]:
            continue
        nq = _points(length[A], 2.0 * radius[A], per_diameter, least)
        a0, a1 = x0[A], x1[A]
        for q in range(nq):
            xi = XI[nq, q]
            for j in range(3):
                p[j] = (1.0 - xi) * a0[j] + xi * a1[j]
            best, best_gap, best_inside = -1, np.inf, False
            for t in range(start[A], start[A + 1]):
                if not near[t]:
                    continue
                B = master[t]
                R = radius[A] + radius[B]
                # the curve lies within ``bulge`` of its chord: far masters cost one distance
                gap = _chord_distance(p[0], p[1], p[2], x0[B], x1[B]) - R
                inside = False
                if gap - bulge[B] < g0:
                    d, clamped = _search_distance(p[0], p[1], p[2], C[B])
                    gap, inside = d - R, not clamped
                if (inside and not best_inside) or (inside == best_inside and gap < best_gap):
                    best, best_gap, best_inside = t, gap, inside
            if best_gap < stats[0]:
                stats[0] = best_gap
            if best >= 0:
                seg_gap[A] = min(seg_gap[A], best_gap)
                seg_gap[master[best]] = min(seg_gap[master[best]], best_gap)
            if best_gap < g0:
                hits_A[nhits], hits_q[nhits], hits_t[nhits] = A, q, best
                nhits += 1
    # compact numbering of the (slave, master) pairs that carry force
    slot = np.full(pairs.shape[0], -1, np.int64)
    active = 0
    for h in range(nhits):
        n = index[hits_t[h]]
        if slot[n] < 0:
            slot[n] = active
            active += 1
    used = np.empty((active, 2), np.int64)
    ends = np.empty((active, SLOTS), np.int64)       # segment end 2 i + e of every slot
    grads = np.zeros((active, 3 * SLOTS))
    hess = np.zeros((active if tangent else 1, 3 * SLOTS, 3 * SLOTS))
    for h in range(nhits):
        A, B = hits_A[h], master[hits_t[h]]
        m = slot[index[hits_t[h]]]
        used[m, 0], used[m, 1] = A, B
        ends[m, 0], ends[m, 1] = 2 * A, 2 * A + 1
        ends[m, 2] = 2 * prev[B] if prev[B] >= 0 else 2 * B
        ends[m, 3], ends[m, 4] = 2 * B, 2 * B + 1
        ends[m, 5] = 2 * nxt[B] + 1 if nxt[B] >= 0 else 2 * B + 1
    # pass 2: their energy, gradient and tangent
    energy = 0.0
    Mp = np.empty((4, 3))
    for h in range(nhits):
        A, q, t = hits_A[h], hits_q[h], hits_t[h]
        B, m = master[t], slot[index[t]]
        nq = _points(length[A], 2.0 * radius[A], per_diameter, least)
        xi = XI[nq, q]
        R = radius[A] + radius[B]
        g_prev = 0.0
        if c_dt > 0.0:       # the same slave point against the same master, a step ago
            has_prev, has_next = _master(B, x0p, x1p, prev, nxt, Mp)
            for j in range(3):
                p[j] = (1.0 - xi) * x0p[A, j] + xi * x1p[A, j]
            g_prev = _project(p, Mp, has_prev, has_next, N, dN, ddN, u, c1, c2)[2] - R
        has_prev, has_next = _master(B, x0, x1, prev, nxt, M)
        energy += _gauss_point(xi, x0[A], x1[A], M, has_prev, has_next, R,
                               WTS[nq, q] * length[A], k, g0, tangent, grads[m],
                               hess[m] if tangent else hess[0], stats, buf, g_prev, c_dt)
    return energy, used, ends, grads, hess, stats, seg_gap


def _gauss_table():
    """Row n: the n Gauss-Legendre points and weights on [0, 1]."""
    XI = np.zeros((MAX_ORDER + 1, MAX_ORDER))
    WTS = np.zeros((MAX_ORDER + 1, MAX_ORDER))
    for n in range(1, MAX_ORDER + 1):
        x, w = np.polynomial.legendre.leggauss(n)
        XI[n, :n], WTS[n, :n] = 0.5 * (x + 1.0), 0.5 * w
    return XI, WTS


_XI, _WTS = _gauss_table()


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


def pair_forces(x0, x1, radius, pairs, law, per_diameter=6, least=4, tangent=True,
                length=None, rank=None, previous=None, damping_rate=0.0, prev=None, nxt=None,
                bulges=None):
    """Contact of candidate segment pairs.

    Returns the energy; the (slave, master) pairs that carry force (k, 2); the
    segment ends (k, 6) of each pair's slots, 2 i + e for end e of segment i
    (slave a0, a1, master M0..M3); gradients (k, 18) and Hessians
    (k, 18, 18) in those slots; statistics (min gap, active Gauss points,
    total normal force); and the smallest gap seen by each segment (n,) (inf
    where it had no candidate; exact within the law's reach, the chord
    distance beyond it).

    x0, x1 : (n, 3) segment ends; radius : (n,); length : (n,) arclength each
    segment stands for (default its chord); per_diameter, least : Gauss
    points per yarn diameter and at least per segment (at most 48); rank :
    (n,) slave priority (default all equal: the lower index is the slave);
    previous : (x0, x1) at the start of the increment and damping_rate = c/dt
    (line load per gap change) for normal damping (see the module docstring);
    prev, nxt : (n,) neighbouring segments (default: no neighbours, every
    master a straight chord); bulges : :func:`bulge` of them, if known.
    """
    x0 = np.ascontiguousarray(x0, dtype=float)
    x1 = np.ascontiguousarray(x1, dtype=float)
    n = x0.shape[0]
    length = np.linalg.norm(x1 - x0, axis=1) if length is None else np.asarray(length, float)
    rank = np.zeros(n, np.int64) if rank is None else np.asarray(rank, np.int64)
    prev = np.full(n, -1, np.int64) if prev is None else np.asarray(prev, np.int64)
    nxt = np.full(n, -1, np.int64) if nxt is None else np.asarray(nxt, np.int64)
    pairs = np.ascontiguousarray(pairs, dtype=np.int64)
    damping_rate = float(damping_rate)
    if damping_rate > 0.0:
        x0p, x1p = (np.ascontiguousarray(v, dtype=float) for v in previous)
    else:
        x0p, x1p, damping_rate = x0, x1, 0.0
    energy, used, ends, grads, hess, stats, seg_gap = _all_pairs(
        x0, x1, prev, nxt, bulge(x0, x1, prev, nxt) if bulges is None else bulges,
        np.asarray(radius, float), length, rank,
        pairs, _XI, _WTS, float(per_diameter), int(least), float(law.k), float(law.g0),
        bool(tangent), x0p, x1p, damping_rate)
    return energy, used, ends, grads, (hess if tangent else None), stats, seg_gap
