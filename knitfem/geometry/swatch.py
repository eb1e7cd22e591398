"""A plain-knit swatch tiled from the Ω loop (:mod:`.knit`): one serpentine
yarn, the bind-off helices, the tails' ties and the yarns as rods or B-splines.

Coordinates as in :mod:`.knit` (x along a course, y up the wales, z out of
the knit face; lengths in any unit, mm in the studies).  Course k runs +x for
even k and -x for odd k; at the row ends a half circle of diameter c (in the
back plane z = -d) turns the yarn up to the next course, so one serpentine
yarn knits the whole swatch.  Loops of course k pass over the heads of course
k-1 at the front (knit face) and hook behind their legs, as a knit stitch
pulled through from the back does.  Bind-off helices (separate yarns,
:mod:`.bindoff`) wrap the heads of the top course and the sinkers of the
bottom course.
"""
import dataclasses
from dataclasses import dataclass
import math

import numpy as np

from .knit import KnitLoop, knit_loop


def _count(name, value, minimum=1):
    ok = not isinstance(value, bool)
    try:
        ok = ok and int(value) == value and int(value) >= minimum
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


@dataclass(frozen=True)
class YarnPath:
    """One yarn centreline: points (n, 3), unit tangents (n, 3); per segment
    (n-1,): course index, wale index, turn-around flag; ``joins``: indices of
    the points where two pieces (loops, turn-arounds) meet; ``bindoff``."""
    points: np.ndarray
    tangents: np.ndarray
    course: np.ndarray
    wale: np.ndarray
    turn: np.ndarray
    joins: np.ndarray
    bindoff: bool = False

    @property
    def length(self):
        """Polyline length of the yarn."""
        return float(np.linalg.norm(np.diff(self.points, axis=0), axis=1).sum())


@dataclass(frozen=True)
class Swatch:
    """A plain-knit swatch: the loop, the counts and the yarns (yarn id = index:
    0 the knitted yarn, then the bottom and top bind-off helices if any).

    ``points``, ``tangents`` (n, 3) stack the yarns; ``segments`` (m, 2) index
    them, with ``segment_yarn``, ``segment_course``, ``segment_wale``,
    ``segment_bindoff`` and ``segment_turn`` (m,) alongside."""
    loop: KnitLoop
    n_wale: int
    n_course: int
    yarns: tuple

    @property
    def radius(self):
        return self.loop.radius

    @property
    def yarn_length_per_loop(self):
        """Yarn length of one loop from the closed form (same unit as w)."""
        return self.loop.length

    @property
    def loop_lengths(self):
        """(n_course, n_wale) lengths of the discretised loops (chords: a little
        shorter than :attr:`yarn_length_per_loop`)."""
        y = self.yarns[0]
        seg = np.linalg.norm(np.diff(y.points, axis=0), axis=1)
        keep = ~y.turn
        out = np.zeros((self.n_course, self.n_wale))
        np.add.at(out, (y.course[keep], y.wale[keep]), seg[keep])
        return out

    def _stack(self, per_yarn):
        return np.concatenate([per_yarn(i, y) for i, y in enumerate(self.yarns)])

    @property
    def points(self):
        """All centreline points (n, 3), yarn after yarn."""
        return self._stack(lambda i, y: y.points)

    @property
    def tangents(self):
        return self._stack(lambda i, y: y.tangents)

    @property
    def segments(self):
        """(m, 2) indices into :attr:`points` of every segment."""
        start = np.cumsum([0] + [len(y.points) for y in self.yarns])
        return self._stack(lambda i, y: start[i] + np.stack(
            [np.arange(len(y.points) - 1), np.arange(1, len(y.points))], axis=1))

    @property
    def segment_yarn(self):
        return self._stack(lambda i, y: np.full(len(y.points) - 1, i))

    @property
    def segment_course(self):
        """Course per segment; -1 and n_course for the bottom and top bind-off."""
        return self._stack(lambda i, y: y.course)

    @property
    def segment_wale(self):
        """Wale per segment; -1 on turn-arounds."""
        return self._stack(lambda i, y: y.wale)

    @property
    def segment_bindoff(self):
        return self._stack(lambda i, y: np.full(len(y.points) - 1, y.bindoff))

    @property
    def segment_turn(self):
        return self._stack(lambda i, y: y.turn)


def plain_knit_swatch(n_wale, n_course, w=4.0, c=3.0, radius=0.4, *, points_per_loop=32,
                      bindoff=True):
    """An ``n_wale`` x ``n_course`` stockinette swatch knitted from one yarn.

    w, c, radius : wale length, course length, yarn radius (valid: radius < w/8
        and c in :func:`course_length_range`).
    points_per_loop : centreline points per loop (>= 8), equally spaced in
        arclength; turn-arounds and helices get the same spacing.  The default
        32 (0.49 mm for the default loop, 1.2 r) turns the yarn by at most
        32 degrees between segments; 48 and more resolve the tightest bend.
    bindoff : add the bottom and top bind-off helices (yarns 1 and 2).

    Loop (k, j) runs from sinker to sinker around its head at x = j w,
    y = k c + h; course 0 starts at x = -w/2.  Returns a :class:`Swatch`.
    """
    n_wale = _count("n_wale", n_wale)
    n_course = _count("n_course", n_course)
    ppl = _count("points_per_loop", points_per_loop, minimum=8)
    loop = knit_loop(w, c, radius)
    w, c = loop.w, loop.c
    spacing = loop.length / ppl
    x_left, x_right = -0.5 * w, (n_wale - 0.5) * w
    t_loop = loop.equal_arclength(ppl)[:-1]                        # one loop, no end point
    t_course = (t_loop[None, :] + 2.0 * math.pi * np.arange(n_wale)[:, None]).ravel()
    t_course = np.append(t_course, 2.0 * math.pi * n_wale - math.pi)
    wale_course = np.repeat(np.arange(n_wale), ppl)
    n_turn = max(4, int(round(0.5 * math.pi * c / spacing)))
    theta = np.linspace(-0.5 * math.pi, 0.5 * math.pi, n_turn + 1)

    pts, tans, courses, wales, turns, joins = [], [], [], [], [], []
    count = 0
    for k in range(n_course):
        p, dp = loop.curve(t_course, course=k)
        tg = dp / np.linalg.norm(dp, axis=1, keepdims=True)
        wl = wale_course
        if k % 2:                                     # odd courses knit right to left
            p, tg, wl = p[::-1], -tg[::-1], wl[::-1]
        if k > 0:                                     # first point = end of the turn
            p, tg = p[1:], tg[1:]
        pts.append(p)
        tans.append(tg)
        courses.append(np.full(len(wl), k))
        wales.append(wl)
        turns.append(np.zeros(len(wl), bool))
        joins.extend(count + (np.arange(1, n_wale) * ppl - (1 if k > 0 else 0)))
        count += len(p)
        if k == n_course - 1:
            break
        # turn up to the next course: half circle of diameter c in the back
        # plane, tangent to both sinkers (whose tangents are exactly +-x)
        side = 1.0 if k % 2 == 0 else -1.0
        centre = np.array([x_right if side > 0 else x_left, k * c - loop.h + 0.5 * c, -loop.d])
        p = centre + 0.5 * c * np.stack([side * np.cos(theta), np.sin(theta), 0 * theta], axis=1)
        tg = np.stack([-side * np.sin(theta), np.cos(theta), 0 * theta], axis=1)
        joins.append(count - 1)
        pts.append(p[1:])
        tans.append(tg[1:])
        courses.append(np.full(n_turn, k))
        wales.append(np.full(n_turn, -1))
        turns.append(np.ones(n_turn, bool))
        count += n_turn
        joins.append(count - 1)
    knitted = YarnPath(np.concatenate(pts), np.concatenate(tans), np.concatenate(courses),
                       np.concatenate(wales), np.concatenate(turns), np.array(joins, int))
    yarns = [knitted]
    if bindoff:
        from .bindoff import bindoff_helices
        yarns.extend(bindoff_helices(loop, n_wale, n_course, spacing))
    return Swatch(loop, n_wale, n_course, tuple(yarns))


def mirror_swatch(swatch):
    """The swatch reflected in the plane x = its centre, wales relabelled
    right to left: still a plain knit with the knit face at +z, but knitted
    from the other side (the yarn's tails at the mirrored edges) and with
    bind-off helices of the other hand.  Our swatch is not mirror symmetric
    (the helices are chiral, the tails on one side), so this is how mirror
    symmetry of the mechanics is tested: the mirrored swatch must relax to
    the mirrored shape, its left and right rolls swapped."""
    x = swatch.points[:, 0]
    centre = 0.5 * (x.min() + x.max())
    flip = np.array([-1.0, 1.0, 1.0])

    def mirrored(y):
        wale = np.where(y.wale >= 0, swatch.n_wale - 1 - y.wale, y.wale)
        return dataclasses.replace(y, points=y.points * flip + [2.0 * centre, 0.0, 0.0],
                                   tangents=y.tangents * flip, wale=wale)
    return dataclasses.replace(swatch, yarns=tuple(mirrored(y) for y in swatch.yarns))


def swatch_ties(swatch, tail_nodes=1):
    """Where a knitter weaves the tails in: (yarn_a, point_a, yarn_b, point_b)
    index pairs into the yarns' ``points`` to be held at their distance.  The
    knit yarn's first and last points are tied to the nearest point of the
    bottom and top bind-off, and each bind-off's two ends to the nearest point
    of the knit yarn (so no loop slides off a helix end).  Empty without
    bind-off.

    ``tail_nodes`` > 1: the last ``tail_nodes`` points of every tail, each
    tied to the two nearest points of the other yarn.  A distance tie at one
    point lets the tail pivot about it (a soft swing the relaxation's Newton
    model misses: README); a triangle of ties holds the tail's direction too."""
    if isinstance(tail_nodes, bool) or not isinstance(tail_nodes, (int, np.integer)) \
            or not 1 <= tail_nodes <= 4:
        raise ValueError(f"tail_nodes must be an integer in [1, 4], got {tail_nodes!r}")
    if len(swatch.yarns) < 3:
        return []
    knit = swatch.yarns[0].points

    def nearest(p, points, k=1):
        return np.argsort(np.linalg.norm(points - p, axis=1), kind="stable")[:k]

    ends = [(0, 0, 1), (0, len(knit) - 1, 2)]
    for k in (1, 2):
        ends += [(k, 0, 0), (k, len(swatch.yarns[k].points) - 1, 0)]
    ties = []
    for ya, end, yb in ends:
        inward = 1 if end == 0 else -1
        for j in range(tail_nodes):
            p = end + inward * j
            for q in nearest(swatch.yarns[ya].points[p], swatch.yarns[yb].points,
                             1 if tail_nodes == 1 else 2):
                ties.append((ya, p, yb, int(q)))
    return ties


def as_rods(swatch, section):
    """One naturally straight :class:`knitfem.beam.Rod` per yarn, starting bent
    into the knit (node tangents from the curve, twist-free frames)."""
    from ..beam import Rod                       # geometry stays free of mechanics on import
    names = ["knit", "bindoff_bottom", "bindoff_top"]
    return [Rod.from_centerline(y.points, section, tangents=y.tangents, natural="straight",
                                name=names[i] if i < 3 else f"yarn{i}")
            for i, y in enumerate(swatch.yarns)]


def bspline_control_points(points, segments, closed=False):
    """Control points (segments+3, 3) (open; (segments, 3) closed) of the
    uniform cubic B-spline fitted by least squares to ``points`` (n, 3),
    chord-length parametrised: :func:`knitfem.bspline.curve.fit`."""
    from ..bspline.curve import fit
    return fit(points, segments, closed)


def swatch_control_points(swatch, segments_per_loop=8):
    """B-spline control points of every yarn of ``swatch``, about
    ``segments_per_loop`` segments per loop length of yarn."""
    per = _count("segments_per_loop", segments_per_loop)
    return [bspline_control_points(y.points, max(1, round(per * y.length / swatch.loop.length)))
            for y in swatch.yarns]
