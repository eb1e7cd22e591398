"""Plain-knit (stockinette) yarn paths: the Ω loop and an N_w x N_c swatch.

Coordinates: x along a course (wale spacing ``w``, loop width), y up the
wales (course spacing ``c``, loop height), z out of the fabric.  The knit
face (the V-shaped legs) faces +z, the purl face (loop heads and sinkers)
-z.  Lengths in any unit (mm in the studies).

The loop (:class:`KnitLoop`) is the closed form of Crane (2023, "A simple
parametric model of plain-knit yarns") with the depth reshaped into two
plateaus.  Course k, parameter t (one loop per 2 pi, heads at t = 2 pi j):

    x = u (t + a sin 2t),   y = k c + h cos t,
    z = -d tanh(beta psi) / tanh(beta),  psi = (cos 2t - kappa) / (1 - kappa cos 2t),

with u = w / 2 pi.  How the three shape numbers are chosen:

* a = 1.4858 (roundness) puts the widest point of the head (x' = 0, at t1
  with cos 2 t1 = -1/(2a)) at x = 3w/8.  Two symmetries of stockinette keep
  equal z at mirror points (x -> -x) and at points related by a half turn
  about the middle of each interlock, so those points must be 2r apart in
  plane; with the bulge at 3w/8 the two legs of a loop and the interlock
  lens are both w/4 wide, the most room a wale has: radius < w/8.
* h = c / (2 cos t1) = 0.868 c puts that widest point half a course above
  the loop centre, so the bulges of neighbouring courses pass each other
  exactly at the interlock lens.
* z: -d on the heads and sinkers, +d on the legs, changing sign (psi = 0)
  at the lens (kappa = cos 2 t1) with sharpness beta = 2; d ~ 1.05 r is
  solved so that a leg and the head it passes over are 2r (1 + 2 %) apart:
  the yarns touch at the crossings.

Course k runs +x for even k and -x for odd k; at the row ends a half circle
of diameter c (in the back plane z = -d) turns the yarn up to the next
course, so one serpentine yarn knits the whole swatch.  Loops of course k
pass over the heads of course k-1 at the front (knit face) and hook behind
their legs, as a knit stitch pulled through from the back does.  Bind-off
helices (separate yarns, :mod:`.bindoff`) wrap the heads of the top course
and the sinkers of the bottom course.
"""
import dataclasses
from dataclasses import dataclass
from functools import cached_property
import math

import numpy as np
from scipy.optimize import brentq
from scipy.spatial import cKDTree

BETA = 2.0            # plateau sharpness of the depth profile
TOUCH = 0.02          # target gap at contacts, fraction of the diameter
_FINE = 4096          # samples per loop for arclength integrals and inversion


def _bulge(a):
    """Parameter t1 and x/u of the widest point of a head (x'(t1) = 0)."""
    t1 = 0.5 * math.acos(-1.0 / (2.0 * a))
    return t1, t1 + a * math.sin(2.0 * t1)


ROUNDNESS = brentq(lambda a: _bulge(a)[1] - 0.75 * math.pi, 0.6, 5.0, xtol=1e-14)
T1, _ = _bulge(ROUNDNESS)
KAPPA = math.cos(2.0 * T1)


def _size(name, value):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number in (0, inf), got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be finite and in (0, inf), got {value!r}")
    return v


def _count(name, value, minimum=1):
    ok = not isinstance(value, bool)
    try:
        ok = ok and int(value) == value and int(value) >= minimum
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def course_length_range(w, radius):
    """Valid course lengths (c_min, c_max) for wale length ``w`` and yarn radius.

    The tightest bends must stay wider than the yarn: the head's widest point
    bends with radius 0.56 c^2/w in plane and the head top with 0.46 w^2/c;
    with the depth profile added, c >= max(5 r, 1.4 sqrt(r w)) and
    c <= 0.4 w^2/r keep every bend radius above r (bisection over r/w = 5e-4
    ... 0.12).  c <= 4 w: taller loops are no plain knit (and untested)."""
    return max(5.0 * radius, 1.4 * math.sqrt(radius * w)), min(0.4 * w * w / radius, 4.0 * w)


def check_sizes(w, c, radius):
    """(w, c, radius) as floats, or a ValueError naming the bad one and its range."""
    w, c, radius = _size("w", w), _size("c", c), _size("radius", radius)
    if radius >= w / 8.0:
        raise ValueError(f"radius must be < w/8 = {w / 8.0:.6g}, got {radius:.6g}: at each "
                         "interlock two legs and the two sides of the head they pass "
                         "through sit side by side in one wale (4 diameters per w)")
    lo, hi = course_length_range(w, radius)
    if not lo <= c <= hi:
        raise ValueError(f"c must be in [{lo:.6g}, {hi:.6g}] for w = {w:.6g} and radius = "
                         f"{radius:.6g}, got {c:.6g} (c_min = max(5 r, 1.4 sqrt(r w)) and "
                         "c_max = min(0.4 w^2/r, 4 w): beyond them a bend of the loop is "
                         "tighter than the yarn)")
    return w, c, radius


@dataclass(frozen=True)
class KnitLoop:
    """One Ω loop of a plain knit (see the module docstring for the curve).

    w, c, radius : wale length, course length, yarn radius (length unit);
    a : roundness (x overshoot, dimensionless); h : loop half-height and
    d : depth of the plateaus (length); beta, kappa : sharpness and switch
    point of the depth profile (dimensionless)."""
    w: float
    c: float
    radius: float
    a: float
    h: float
    d: float
    beta: float = BETA
    kappa: float = KAPPA

    @property
    def u(self):
        """x scale w / 2 pi (length per unit of t)."""
        return self.w / (2.0 * math.pi)

    def curve(self, t, course=0):
        """Points (n, 3) and derivatives d/dt (n, 3) of course ``course`` at
        parameters t (n,); head j at t = 2 pi j, sinkers at t = pi + 2 pi j."""
        t = np.asarray(t, dtype=float)
        c2, s2 = np.cos(2.0 * t), np.sin(2.0 * t)
        k = self.kappa
        psi = (c2 - k) / (1.0 - k * c2)
        th = np.tanh(self.beta * psi)
        scale = self.d / math.tanh(self.beta)
        dpsi = (1.0 - k * k) / (1.0 - k * c2) ** 2 * (-2.0 * s2)
        p = np.stack([self.u * (t + self.a * s2), course * self.c + self.h * np.cos(t),
                      -scale * th], axis=1)
        dp = np.stack([self.u * (1.0 + 2.0 * self.a * c2), -self.h * np.sin(t),
                       -scale * self.beta * (1.0 - th * th) * dpsi], axis=1)
        return p, dp

    @cached_property
    def _arclength(self):
        t = np.linspace(-math.pi, math.pi, _FINE + 1)
        speed = np.linalg.norm(self.curve(t)[1], axis=1)
        s = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))])
        return t, s

    @property
    def length(self):
        """Yarn length of one loop (sinker to sinker), same unit as w."""
        return float(self._arclength[1][-1])

    def equal_arclength(self, n):
        """n+1 parameters from -pi to pi splitting one loop into n equal arcs."""
        t, s = self._arclength
        return np.interp(np.linspace(0.0, s[-1], n + 1), s, t)

    @property
    def thickness(self):
        """Fabric thickness 2 (d + r): back of the heads to front of the legs."""
        return 2.0 * (self.d + self.radius)


def _crossing_distance(a, h, d, w, c, radius):
    """Closest approach near a crossing of a leg of course 0 over the head of
    course -1 (the interlock contact) for depth d."""
    probe = KnitLoop(w, c, radius, a, h, d)
    n = max(600, int(probe.length / (0.1 * radius)))         # samples ~r/20 apart
    head = probe.curve(np.linspace(0.0, T1, n), course=-1)[0]
    leg = probe.curve(np.linspace(T1, math.pi - T1, n))[0]
    # the in-plane crossing: the leg point closest in plane to the head
    dist, j = cKDTree(leg[:, :2]).query(head[:, :2])
    i = int(np.argmin(dist))
    # nearest 3D approach within a window around it (leaves out the lens,
    # where both strands change sides at equal depth)
    near = np.arange(n)
    return float(cKDTree(leg[np.abs(near - j[i]) < n // 6]).query(
        head[np.abs(near - i) < n // 6])[0].min())


def knit_loop(w=4.0, c=3.0, radius=0.4):
    """The Ω loop for wale length ``w``, course length ``c`` and yarn ``radius``
    (:class:`KnitLoop`); ValueError outside radius < w/8 and
    :func:`course_length_range`."""
    w, c, radius = check_sizes(w, c, radius)
    a, h = ROUNDNESS, c / (2.0 * math.cos(T1))
    target = 2.0 * radius * (1.0 + TOUCH)
    d = brentq(lambda d: _crossing_distance(a, h, d, w, c, radius) - target, 0.5 * radius,
               4.0 * radius, xtol=1e-6 * radius)
    return KnitLoop(w, c, radius, a, h, d)


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
