"""The narrow phase's search: which slave Gauss point touches which master
curve, and where.  For every Gauss point of a slave segment, every critical
point of its distance to every stretch of master yarn within reach (runs of
neighbouring candidate master segments): the minima, the maxima between
them and the minima at a stretch's ends (see :mod:`knitfem.contact.narrow`
for why all of them).  A stretch is a run of candidate masters that follow
each other (``nxt``) in increasing segment index: the segments of a yarn
must be numbered along it (as the beam model numbers its elements); numbered
backwards, every segment would be a stretch of its own and a minimum at each
joint in reach counted at both its ends.  Compiled with numba."""
import numpy as np
from numba import njit

from .master import chord_distance, coefficients, critical_points, segment_distance

MAX_ORDER = 48               # Gauss points per slave segment at most


@njit(cache=True)
def gauss_points(length, diameter, per_diameter, least):
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
    # each slave's masters in segment order, so that neighbouring master segments
    # (one stretch of master yarn) follow each other (insertion sort: few per slave)
    for a in range(nseg):
        for t in range(start[a] + 1, start[a + 1]):
            b, n = master[t], index[t]
            u = t - 1
            while u >= start[a] and master[u] > b:
                master[u + 1], index[u + 1] = master[u], index[u]
                u -= 1
            master[u + 1], index[u + 1] = b, n
    return start, master, index


@njit(cache=True)
def candidates_in_reach(x0, x1, bulge, radius, pairs, rank, g0, stats, seg_gap):
    """Each slave's candidate masters (CSR start, master, pair index) and
    whether each is near enough to touch (``near``); the gaps of the others
    go into stats[0] and seg_gap (one segment-segment distance rules most
    candidates out)."""
    nseg = x0.shape[0]
    start, master, index = _masters_of_slaves(pairs, rank, nseg)
    near = np.empty(master.shape[0], np.bool_)
    for A in range(nseg):
        for t in range(start[A], start[A + 1]):
            B = master[t]
            gap = segment_distance(x0[A], x1[A], x0[B], x1[B]) - radius[A] - radius[B]
            near[t] = gap - bulge[B] < g0
            if not near[t]:
                seg_gap[A] = min(seg_gap[A], gap)
                seg_gap[B] = min(seg_gap[B], gap)
                stats[0] = min(stats[0], gap)
    return start, master, index, near


@njit(cache=True)
def _hit(p, C, t, s, kind, A, q, master, radius, g0, stats, seg_gap, hits_A, hits_q, hits_t,
         hits_s, hits_k, nhits):
    """Note the critical point at parameter s of master master[t] as a hit if
    within reach (the gaps of the minima go into the statistics)."""
    B = master[t]
    c = C[B]
    u2 = 0.0
    for j in range(3):
        v = p[j] - (c[0, j] + s * (c[1, j] + s * (c[2, j] + s * c[3, j])))
        u2 += v * v
    gap = np.sqrt(u2) - radius[A] - radius[B]
    if kind > 0:
        stats[0] = min(stats[0], gap)
        seg_gap[A] = min(seg_gap[A], gap)
        seg_gap[B] = min(seg_gap[B], gap)
    if gap >= g0:
        return nhits
    hits_A[nhits], hits_q[nhits], hits_t[nhits] = A, q, t
    hits_s[nhits], hits_k[nhits] = s, kind
    return nhits + 1


@njit(cache=True)
def _grown(hits_A, hits_q, hits_t, hits_s, hits_k):
    """The hit arrays at twice their size."""
    n = hits_A.shape[0]
    out = (np.empty(2 * n, np.int64), np.empty(2 * n, np.int64), np.empty(2 * n, np.int64),
           np.empty(2 * n), np.empty(2 * n, np.int64))
    out[0][:n], out[1][:n], out[2][:n], out[3][:n], out[4][:n] = \
        hits_A, hits_q, hits_t, hits_s, hits_k
    return out


@njit(cache=True)
def critical_hits(x0, x1, prev, nxt, bulge, radius, length, start, master, near, XI,
                  per_diameter, least, g0, stats, seg_gap):
    """Every critical point within reach: slave segment, Gauss index, index
    into ``master``, master parameter, kind (+1 a minimum, -1 a maximum,
    2 a minimum at a stretch's end) and their count; the minima's gaps go
    into stats[0] and seg_gap."""
    nseg = x0.shape[0]
    C = coefficients(x0, x1, prev, nxt)
    p = np.empty(3)
    capacity = 16
    for A in range(nseg):
        capacity += gauss_points(length[A], 2.0 * radius[A], per_diameter, least) * \
            (start[A + 1] - start[A])
    hits_A = np.empty(capacity, np.int64)
    hits_q = np.empty(capacity, np.int64)
    hits_t = np.empty(capacity, np.int64)
    hits_s = np.empty(capacity)                     # master parameter
    hits_k = np.empty(capacity, np.int64)           # +1 minimum, -1 maximum, 2 end minimum
    nhits = 0
    D, roots, kinds = np.empty((6, 6)), np.empty(6), np.empty(6, np.int64)
    for A in range(nseg):
        if start[A] == start[A + 1]:
            continue
        nq = gauss_points(length[A], 2.0 * radius[A], per_diameter, least)
        a0, a1 = x0[A], x1[A]
        for q in range(nq):
            xi = XI[nq, q]
            for j in range(3):
                p[j] = (1.0 - xi) * a0[j] + xi * a1[j]
            last, g_last = -1, 0.0          # the run's last master (list index), F'(1) on it
            for t in range(start[A], start[A + 1] + 1):
                B = master[t] if t < start[A + 1] else -1
                within = False
                if B >= 0 and near[t]:
                    # the curve lies within ``bulge`` of its chord: far masters cost one distance
                    gap = chord_distance(p[0], p[1], p[2], x0[B], x1[B]) - radius[A] - radius[B]
                    within = gap - bulge[B] < g0
                    if not within:
                        seg_gap[A] = min(seg_gap[A], gap)
                        seg_gap[B] = min(seg_gap[B], gap)
                joined = within and last >= 0 and B == nxt[master[last]]
                if last >= 0 and not joined:
                    # the run of master curves ended: a minimum at its end, if any
                    if g_last < 0.0:
                        nhits = _hit(p, C, last, 1.0, 2, A, q, master, radius, g0, stats, seg_gap,
                                     hits_A, hits_q, hits_t, hits_s, hits_k, nhits)
                    last = -1
                if not within:
                    continue
                # where the curve is certainly out of reach and farther than every
                # gap noted for A, B and the swatch, its critical points would change
                # nothing: none are sought (the root isolation was ~90 % of the
                # search at 10 x 35, and the Bernstein bound rules out ~90 % of it)
                floor = radius[A] + radius[B] + max(max(g0, stats[0]),
                                                    max(seg_gap[A], seg_gap[B]))
                count, g_begin, g_last = critical_points(p, C[B], g_last if joined else np.nan,
                                                         D, roots, kinds, floor)
                if not joined and g_begin >= 0.0:
                    nhits = _hit(p, C, t, 0.0, 2, A, q, master, radius, g0, stats, seg_gap,
                                 hits_A, hits_q, hits_t, hits_s, hits_k, nhits)
                for i in range(count):
                    nhits = _hit(p, C, t, roots[i], kinds[i], A, q, master, radius, g0, stats,
                                 seg_gap, hits_A, hits_q, hits_t, hits_s, hits_k, nhits)
                last = t
                if nhits + 8 > hits_A.shape[0]:
                    hits_A, hits_q, hits_t, hits_s, hits_k = _grown(hits_A, hits_q, hits_t,
                                                                    hits_s, hits_k)
    return hits_A, hits_q, hits_t, hits_s, hits_k, nhits
