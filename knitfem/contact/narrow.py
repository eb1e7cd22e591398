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
u = p - c(t*), t* a critical point of the distance (see below),

    g = |u| - (r_a + r_b),   energy  sum_gauss  w l_A phi(g).

A is the slave of the pair.  A's candidate masters, in segment order, form
stretches of master yarn (runs of neighbouring segments).  Along a stretch
the distance |p - c| may have several local minima: where the master yarn
bends around p more tightly than the contact distance (a loop head cradling
the yarn through it, tightened by the pre-stretch) or passes p twice.  Every
minimum pushes, and every maximum between two of them is *subtracted*:

    E_p = sum_minima phi(g) - sum_maxima phi(g)

(half the total variation of phi(g(s)) along the stretch).  Taking the
nearest minimum alone made the energy the larger of two penalties where two
minima tie: a kink on which Newton 2-cycled (a 5 x 5 swatch at alpha 0.2
stalled on one such Gauss point).  With the maxima subtracted the energy is
continuous and so is its gradient, also where a minimum is born or dies with
a maximum (they cancel there; the force changes like the square root of the
distance to that point); far apart, the maximum is out of reach and both
contacts push whole.  The price: near such a merge a maximum within reach
pulls the point toward itself (the overlap of two contacts is counted once);
the force it takes back is reported (``ContactReport.overlap_force``).  The
ends of a stretch count as minima where the distance falls toward them;
every critical point is found exactly
(:func:`knitfem.contact.master.critical_points`).  Slaves are chosen per yarn
(the yarn with the finer elements, as the non-mortar side of a mortar
method), so each contact is counted once.  Crossings are resolved by the
Gauss points near them: ``per_diameter`` points per yarn diameter along
every slave segment.

Derivatives in the 6 points z = (a0, a1, M0..M3), s = ((1-xi), xi, -N(t*)),
F = |u|^2 / 2 (the envelope theorem, at minima and maxima alike):

    grad F = S^T u,   hess F = S^T S - b b^T / (c'.c' - u.c''),
    b = S^T c' + N'(t*) (x) u on the master points

(drop the b term at the end of a stretch), chained through d = sqrt(2F)
to phi(g): the tangent is exact, so Newton stays quadratic with contact.

Normal damping (optional, for quasi-static or dynamic increments): a line load
c psi(g) dg/dt resisting the gap rate of each active Gauss point, with
dg/dt = (g - g_prev) / dt, g_prev the gap of the same slave point to the same
master segment at the start of the increment (its minimum of the distance
nearest the current one, else its closest point: a function of that state
alone; the subtracted maxima are not damped), and psi = phi''/k the
penalty's stiffness ramp (0 at g0, 1 in contact), so the damping fades in
with the contact and the force stays continuous.  It adds
h = c psi (g - g_prev)/dt to phi' and h' = c (psi + psi' (g - g_prev))/dt to
phi'', so the tangent stays exact (and symmetric); it stores no energy.
Compiled with numba: the loop over pairs and Gauss points is the hot spot.
"""
from typing import NamedTuple

import numpy as np
from numba import njit

from .law import penalty
from .master import bulge, critical_points, evaluate, gather, power_basis, project
from .search import MAX_ORDER, candidates_in_reach, critical_hits, gauss_points

SLOTS = 6                    # slave a0, a1; master M0..M3


@njit(cache=True)
def _gauss_point(xi, a0, a1, M, has_prev, has_next, t, kind, R, W, k, g0, tangent, grad, hess,
                 stats, buf, g_prev, c_dt):
    """Energy of the slave Gauss point at xi on (a0, a1) against the master
    curve M at its critical point t of the distance (``kind`` +1 a minimum,
    -1 a maximum: counted negative, 2 a minimum at the end of a run of
    master curves: t fixed), weight W; adds its gradient / tangent into the
    pair's 18 slots.  c_dt > 0: normal damping c/dt against the gap g_prev
    of the increment's start."""
    N, dN, ddN, u, c1, c2, p, s, b, dF = buf
    for j in range(3):
        p[j] = (1.0 - xi) * a0[j] + xi * a1[j]
    d = evaluate(p, M, has_prev, has_next, t, N, dN, ddN, u, c1, c2)
    clamped = kind == 2
    if kind < 0:
        W = -W
    g = d - R
    if g >= g0 or d < 1e-14 * R:
        return 0.0
    phi, dphi, ddphi = penalty(g, k, g0)
    if c_dt > 0.0 and kind > 0:          # the maxima, subtracted, are not damped
        ramp = ddphi / k
        slope = -1.0 / g0 if g >= 0.0 else 0.0
        dphi += c_dt * ramp * (g - g_prev)
        ddphi += c_dt * (ramp + slope * (g - g_prev))
    if kind > 0:
        stats[1] += 1.0
    else:                                          # taken back where two contacts overlap
        stats[3] += W * dphi
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
    # where a minimum and a maximum merge F'' -> 0 and t* moves without bound:
    # the b b^T term is skipped there only at round-off level
    clamped = clamped or abs(Ftt) <= 1e-13 * (c1[0] * c1[0] + c1[1] * c1[1] + c1[2] * c1[2])
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
def _follow(p, M, has_prev, has_next, t, kind, buf, D, roots, kinds):
    """|p - c| of the same contact at the start of the increment (p, M there;
    a function of that state alone): the minimum of that curve nearest the
    current parameter t, its closest point where it has no interior minimum
    (the contact was born since), t itself for the minimum at a stretch's end."""
    N, dN, ddN, u, c1, c2 = buf[0], buf[1], buf[2], buf[3], buf[4], buf[5]
    if kind == 2:
        return evaluate(p, M, has_prev, has_next, t, N, dN, ddN, u, c1, c2)
    C = np.empty((4, 3))
    power_basis(M, has_prev, has_next, C)
    count = critical_points(p, C, np.nan, D, roots, kinds)[0]
    best, s = np.inf, t
    for i in range(count):
        if kinds[i] == 1 and abs(roots[i] - t) < best:
            best, s = abs(roots[i] - t), roots[i]
    if best == np.inf:
        return project(p, M, has_prev, has_next, N, dN, ddN, u, c1, c2)[2]
    return evaluate(p, M, has_prev, has_next, s, N, dN, ddN, u, c1, c2)


@njit(cache=True)
def _all_pairs(x0, x1, prev, nxt, bulge, radius, length, rank, pairs, XI, WTS, per_diameter,
               least, k, g0, tangent, x0p, x1p, c_dt, record):
    """Slave Gauss points against their master curves: every critical point
    of the distance along every stretch of master yarn within reach (minima
    push, maxima are subtracted: see the module docstring)."""
    nseg = x0.shape[0]
    stats = np.array([np.inf, 0.0, 0.0, 0.0])       # min gap, active points, net force, overlap
    seg_gap = np.full(nseg, np.inf)                 # smallest gap seen by each segment
    start, master, index, near = candidates_in_reach(x0, x1, bulge, radius, pairs, rank, g0,
                                                     stats, seg_gap)
    M = np.empty((4, 3))
    buf = (np.empty(4), np.empty(4), np.empty(4), np.empty(3), np.empty(3), np.empty(3),
           np.empty(3), np.empty(SLOTS), np.empty(3 * SLOTS), np.empty(3 * SLOTS))
    N, dN, ddN, u, c1, c2, p = buf[0], buf[1], buf[2], buf[3], buf[4], buf[5], buf[6]
    # pass 1: every critical point of the distance to every stretch within reach
    hits_A, hits_q, hits_t, hits_s, hits_k, nhits = critical_hits(
        x0, x1, prev, nxt, bulge, radius, length, start, master, near, XI, per_diameter, least,
        g0, stats, seg_gap)
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
    D, roots, kinds = np.empty((6, 6)), np.empty(6), np.empty(6, np.int64)
    for h in range(nhits):
        A, q, t = hits_A[h], hits_q[h], hits_t[h]
        B, m = master[t], slot[index[t]]
        nq = gauss_points(length[A], 2.0 * radius[A], per_diameter, least)
        xi = XI[nq, q]
        R = radius[A] + radius[B]
        g_prev = 0.0
        if c_dt > 0.0 and hits_k[h] > 0:    # the same contact, a step ago
            has_prev, has_next = gather(B, x0p, x1p, prev, nxt, Mp)
            for j in range(3):
                p[j] = (1.0 - xi) * x0p[A, j] + xi * x1p[A, j]
            g_prev = _follow(p, Mp, has_prev, has_next, hits_s[h], hits_k[h], buf, D, roots,
                             kinds) - R
        has_prev, has_next = gather(B, x0, x1, prev, nxt, M)
        energy += _gauss_point(xi, x0[A], x1[A], M, has_prev, has_next, hits_s[h], hits_k[h],
                               R, WTS[nq, q] * length[A], k, g0, tangent, grads[m],
                               hess[m] if tangent else hess[0], stats, buf, g_prev, c_dt)
    # optionally, every Gauss point's contact at a minimum of the distance: slave,
    # xi, weight, master, t*, normal, line load (the maxima, subtracted where
    # two contacts overlap, carry no friction of their own)
    n_rec = int(np.sum(hits_k[:nhits] > 0)) if record else 0
    rec_i = np.empty((n_rec, 3), np.int64)
    rec_f = np.empty((n_rec, 7))
    r = 0
    for h in range(nhits if record else 0):
        if hits_k[h] < 0:
            continue
        A, q, t = hits_A[h], hits_q[h], hits_t[h]
        B = master[t]
        nq = gauss_points(length[A], 2.0 * radius[A], per_diameter, least)
        xi = XI[nq, q]
        for j in range(3):
            p[j] = (1.0 - xi) * x0[A, j] + xi * x1[A, j]
        has_prev, has_next = gather(B, x0, x1, prev, nxt, M)
        tq = hits_s[h]
        d = evaluate(p, M, has_prev, has_next, tq, N, dN, ddN, u, c1, c2)
        rec_i[r, 0], rec_i[r, 1], rec_i[r, 2] = A, B, q
        rec_f[r, 0], rec_f[r, 1], rec_f[r, 2] = xi, WTS[nq, q] * length[A], tq
        for j in range(3):
            rec_f[r, 3 + j] = u[j] / d if d > 0.0 else 0.0
        rec_f[r, 6] = -penalty(d - radius[A] - radius[B], k, g0)[1]
        r += 1
    return energy, used, ends, grads, hess, stats, seg_gap, rec_i, rec_f


def _gauss_table():
    """Row n: the n Gauss-Legendre points and weights on [0, 1]."""
    XI = np.zeros((MAX_ORDER + 1, MAX_ORDER))
    WTS = np.zeros((MAX_ORDER + 1, MAX_ORDER))
    for n in range(1, MAX_ORDER + 1):
        x, w = np.polynomial.legendre.leggauss(n)
        XI[n, :n], WTS[n, :n] = 0.5 * (x + 1.0), 0.5 * w
    return XI, WTS


_XI, _WTS = _gauss_table()


class ContactPoints(NamedTuple):
    """Every Gauss point in contact: slave segment, its xi on the chord, its
    weight (quadrature weight x length), master segment, closest parameter t*
    on the master curve, unit normal from the master toward the slave point,
    line load (force per length) pushing them apart, Gauss index on the slave."""
    slave: np.ndarray
    xi: np.ndarray
    weight: np.ndarray
    master: np.ndarray
    t: np.ndarray
    normal: np.ndarray
    load: np.ndarray
    gauss: np.ndarray


def pair_forces(x0, x1, radius, pairs, law, per_diameter=6, least=4, tangent=True,
                length=None, rank=None, previous=None, damping_rate=0.0, prev=None, nxt=None,
                bulges=None, record=False):
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
    record : also return the :class:`ContactPoints` (the anchors of friction);
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
    energy, used, ends, grads, hess, stats, seg_gap, rec_i, rec_f = _all_pairs(
        x0, x1, prev, nxt, bulge(x0, x1, prev, nxt) if bulges is None else bulges,
        np.asarray(radius, float), length, rank,
        pairs, _XI, _WTS, float(per_diameter), int(least), float(law.k), float(law.g0),
        bool(tangent), x0p, x1p, damping_rate, bool(record))
    if record:
        return energy, used, ends, grads, (hess if tangent else None), stats, seg_gap, \
            ContactPoints(rec_i[:, 0], rec_f[:, 0], rec_f[:, 1], rec_i[:, 1], rec_f[:, 2],
                          rec_f[:, 3:6], rec_f[:, 6], rec_i[:, 2])
    return energy, used, ends, grads, (hess if tangent else None), stats, seg_gap
