"""Narrow phase: Gauss-point-to-segment (line-to-line) contact of segment pairs.

Why not closest points between segments: yarns in a knit lie nearly parallel
over long stretches, where the closest-point pair of two segments jumps and
a single point force cannot carry a distributed load (Meier, Popp & Wall
2016).  Here every Gauss point p of segment A is projected on segment B,

    eta = clamp((p - b0)·e / |e|^2, 0, 1),  u = p - b0 - eta e,  e = b1 - b0,
    g = |u| - (r_a + r_b),   energy  sum_gauss  w l_A phi(g),

where A is the slave of the pair and B, among A's candidate masters, the
segment of smallest gap from p (so a point facing the joint of two master
segments is not counted twice).  Slaves are chosen per yarn (the yarn with
the finer elements, as the non-mortar side of a mortar method), so each
contact is counted once; a uniform pressure gives exactly uniform nodal
forces on the slave.  Crossing yarns are covered too, by the Gauss points near the
crossing: the number of points per segment grows with its length so that
every yarn diameter holds ``per_diameter`` of them, which resolves the short
contact zone of a crossing.  With F = |u|^2/2 and s = ((1-xi), xi,
-(1-eta), -eta), the derivatives in z = (a0, a1, b0, b1) are

    grad F = S^T u,   hess F = S^T S - c c^T / |e|^2   (c = S^T e + E^T u,
                      E^T u = (0, 0, -u, u); drop the c term where eta is clamped)

(the envelope theorem for the projection), chained through d = sqrt(2F) to
phi(g): the tangent is exact, so Newton stays quadratic with contact active.

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
def _project(p, b0, b1):
    """Foot of p on segment (b0, b1): eta (clamped to [0, 1]), whether it was
    clamped, u = p - foot, |u|."""
    e = b1 - b0
    eta = (p - b0) @ e / (e @ e)
    # a foot at a segment end up to round-off counts as inside (see _all_pairs)
    clamped = eta < -1e-9 or eta > 1.0 + 1e-9
    eta = min(max(eta, 0.0), 1.0)
    u = p - b0 - eta * e
    return eta, clamped, u, np.sqrt(u @ u)


@njit(cache=True)
def _gap_to(px, py, pz, b0, b1):
    """Distance from (px, py, pz) to segment (b0, b1) and whether the foot was
    clamped to an end; scalar arithmetic (the search loop must not allocate)."""
    ex, ey, ez = b1[0] - b0[0], b1[1] - b0[1], b1[2] - b0[2]
    qx, qy, qz = px - b0[0], py - b0[1], pz - b0[2]
    eta = (qx * ex + qy * ey + qz * ez) / (ex * ex + ey * ey + ez * ez)
    clamped = eta < -1e-9 or eta > 1.0 + 1e-9
    eta = min(max(eta, 0.0), 1.0)
    ux, uy, uz = qx - eta * ex, qy - eta * ey, qz - eta * ez
    return np.sqrt(ux * ux + uy * uy + uz * uz), clamped


@njit(cache=True)
def _gauss_point(xi, a0, a1, b0, b1, R, W, k, g0, tangent, perm, grad, hess, stats, s, c, dF,
                 g_prev, c_dt):
    """Energy of the Gauss point at xi on A against segment B, weight W; adds
    its gradient / tangent into the pair's slots through ``perm``.  c_dt > 0:
    normal damping c/dt against the gap g_prev at the start of the increment."""
    p = (1.0 - xi) * a0 + xi * a1
    eta, clamped, u, d = _project(p, b0, b1)
    g = d - R
    if g >= g0 or d < 1e-14 * R:
        return 0.0
    e = b1 - b0
    L2 = e @ e
    phi, dphi, ddphi = _law(g, k, g0)
    if c_dt > 0.0:
        ramp = ddphi / k
        slope = -1.0 / g0 if g >= 0.0 else 0.0
        dphi += c_dt * ramp * (g - g_prev)
        ddphi += c_dt * (ramp + slope * (g - g_prev))
    stats[1] += 1.0
    stats[2] += -W * dphi                          # normal force carried
    s[0], s[1], s[2], s[3] = 1.0 - xi, xi, -(1.0 - eta), -eta
    for a in range(4):
        for j in range(3):
            dF[3 * a + j] = s[a] * u[j]
    for j in range(12):
        grad[perm[j]] += W * dphi * dF[j] / d
    if tangent:
        for a in range(4):
            for j in range(3):
                c[3 * a + j] = s[a] * e[j]
        for j in range(3):
            c[6 + j] -= u[j]
            c[9 + j] += u[j]
        for i in range(12):
            for j in range(12):
                hF = s[i // 3] * s[j // 3] if i % 3 == j % 3 else 0.0
                if not clamped:
                    hF -= c[i] * c[j] / L2
                dd = hF / d - dF[i] * dF[j] / d**3                      # hess of d
                hess[perm[i], perm[j]] += W * (ddphi * dF[i] * dF[j] / (d * d) + dphi * dd)
    return W * phi


@njit(cache=True)
def _points(length, diameter, per_diameter, least):
    """Gauss order for a segment of this length: per_diameter points per diameter."""
    n = int(np.ceil(per_diameter * length / diameter))
    return min(max(n, least), MAX_ORDER)


@njit(cache=True)
def _all_pairs(x0, x1, radius, length, rank, pairs, XI, WTS, per_diameter, least, k, g0,
               tangent, x0p, x1p, c_dt):
    """Slave Gauss points against their master segments.  The slave of a pair
    is the segment of lower ``rank`` (ranks are per yarn, so one yarn is the
    slave of another everywhere and no contact is counted from both sides;
    within one yarn the lower index), and each slave Gauss point interacts
    with the one master of smallest gap, so a point facing the joint of two
    master segments is not counted twice either."""
    m = pairs.shape[0]
    nseg = x0.shape[0]
    energy = 0.0
    stats = np.array([np.inf, 0.0, 0.0])            # min gap, active points, total force
    seg_gap = np.full(nseg, np.inf)                 # smallest gap seen by each segment
    direct = np.arange(12)
    swapped = np.concatenate((np.arange(6, 12), np.arange(6)))
    # masters of every slave segment (CSR): master, pair index, slave is pairs[n, 0]
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
            px = (1.0 - xi) * a0[0] + xi * a1[0]
            py = (1.0 - xi) * a0[1] + xi * a1[1]
            pz = (1.0 - xi) * a0[2] + xi * a1[2]
            # prefer masters the point projects inside: across the joint of two
            # collinear master segments that keeps the energy C2 (the vertex
            # distance of a clamped projection only serves kinks and yarn ends)
            best, best_gap, best_inside = -1, np.inf, False
            for t in range(start[A], start[A + 1]):
                B = master[t]
                d, clamped = _gap_to(px, py, pz, x0[B], x1[B])
                gap = d - radius[A] - radius[B]
                inside = not clamped
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
    # compact numbering of the pairs that carry force
    slot = np.full(m, -1, np.int64)
    active = 0
    for h in range(nhits):
        n = index[hits_t[h]]
        if slot[n] < 0:
            slot[n] = active
            active += 1
    used = np.empty(active, np.int64)
    for n in range(m):
        if slot[n] >= 0:
            used[slot[n]] = n
    grads = np.zeros((active, 12))
    hess = np.zeros((active if tangent else 1, 12, 12))
    # pass 2: their energy, gradient and tangent
    s, c, dF = np.empty(4), np.empty(12), np.empty(12)
    for h in range(nhits):
        A, q, t = hits_A[h], hits_q[h], hits_t[h]
        B, n = master[t], index[t]
        nq = _points(length[A], 2.0 * radius[A], per_diameter, least)
        H = hess[slot[n]] if tangent else hess[0]
        xi = XI[nq, q]
        g_prev = 0.0
        if c_dt > 0.0:       # the same slave point against the same master, a step ago
            pp = (1.0 - xi) * x0p[A] + xi * x1p[A]
            g_prev = _gap_to(pp[0], pp[1], pp[2], x0p[B], x1p[B])[0] - radius[A] - radius[B]
        energy += _gauss_point(xi, x0[A], x1[A], x0[B], x1[B], radius[A] + radius[B],
                               WTS[nq, q] * length[A], k, g0, tangent,
                               direct if slave_first[n] else swapped, grads[slot[n]], H, stats,
                               s, c, dF, g_prev, c_dt)
    return energy, used, grads, hess, stats, seg_gap


MAX_ORDER = 48


def _gauss_table():
    """Row n: the n Gauss-Legendre points and weights on [0, 1]."""
    XI = np.zeros((MAX_ORDER + 1, MAX_ORDER))
    WTS = np.zeros((MAX_ORDER + 1, MAX_ORDER))
    for n in range(1, MAX_ORDER + 1):
        x, w = np.polynomial.legendre.leggauss(n)
        XI[n, :n], WTS[n, :n] = 0.5 * (x + 1.0), 0.5 * w
    return XI, WTS


_XI, _WTS = _gauss_table()


def pair_forces(x0, x1, radius, pairs, law, per_diameter=6, least=4, tangent=True,
                length=None, rank=None, previous=None, damping_rate=0.0):
    """Contact energy, the pairs that carry force (k, 2), their gradients
    (k, 12) and Hessians (k, 12, 12) in the slots (x0[i], x1[i], x0[j], x1[j])
    of each pair (i, j), statistics (min gap, active Gauss points, total
    normal force) and the smallest gap seen by each segment (n,) (inf where
    none of its Gauss points, or none facing it, had a candidate).

    x0, x1 : (n, 3) segment ends; radius : (n,); length : (n,) arclength each
    segment stands for (default its chord); per_diameter, least : Gauss
    points per yarn diameter and at least per segment (at most 48); rank :
    (n,) slave priority (default all equal: the lower index is the slave);
    previous : (x0, x1) at the start of the increment and damping_rate = c/dt
    (line load per gap change) for normal damping (see the module docstring).
    """
    x0 = np.ascontiguousarray(x0, dtype=float)
    x1 = np.ascontiguousarray(x1, dtype=float)
    length = np.linalg.norm(x1 - x0, axis=1) if length is None else np.asarray(length, float)
    rank = np.zeros(x0.shape[0], np.int64) if rank is None else np.asarray(rank, np.int64)
    pairs = np.ascontiguousarray(pairs, dtype=np.int64)
    damping_rate = float(damping_rate)
    if damping_rate > 0.0:
        x0p, x1p = (np.ascontiguousarray(v, dtype=float) for v in previous)
    else:
        x0p, x1p, damping_rate = x0, x1, 0.0
    energy, used, grads, hess, stats, seg_gap = _all_pairs(
        x0, x1, np.asarray(radius, float), length, rank, pairs, _XI, _WTS, float(per_diameter),
        int(least), float(law.k), float(law.g0), bool(tangent), x0p, x1p, damping_rate)
    return energy, pairs[used], grads, (hess if tangent else None), stats, seg_gap
