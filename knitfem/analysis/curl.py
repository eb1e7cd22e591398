"""Curl of a deformed plain-knit swatch: mid-surface, edge rolls, curvatures, height, type.

Pure output analysis on yarn centrelines, shared by the beam and the B-spline
models (no mechanics).  Lengths in the swatch's unit (mm), angles in degrees.

Definitions
-----------
Mid-surface: the grid C (n_course, n_wale, 3) of loop centres, each the
material centroid of loop (k, j): the mean of its segment midpoints weighted
by their knitted (reference) lengths, turn-arounds excluded, so it follows
the same yarn whatever the deformation (:func:`loop_centres`).

Body frame: the relaxed swatch floats freely and may have turned, so the
directions come from the swatch itself.  A quadratic surface fitted to the
central block of centres (3 x 3 for odd counts, 4 x 4 for even) gives the
tangents a = dC/dj (along the courses, x) and b = dC/dk (up the wales, y) at
the grid centre (v, u) = ((n_course - 1)/2, (n_wale - 1)/2); e_z = a x b /
|a x b| is the front (the knit face, +z of the knitted swatch), e_x = a/|a|,
e_y = e_z x e_x.

Edge rolls: along a row k, each chord C[k, j+1] - C[k, j] projected on the
(e_x, e_z) plane has the angle theta = atan2(t.e_z, t.e_x), unwrapped along
the row, so it accumulates past 180 deg.  theta at a centre is the mean of
its two chords' angles (half a chord extrapolated at the row ends: exact on a
circle).  roll_right = theta(n_wale - 1) - theta(u) and roll_left = theta(u) -
theta(0) are positive when the edge turns toward the front, so a mirror-
symmetric shape has equal left and right rolls.  Columns likewise in the
(e_y, e_z) plane: roll_top = phi(n_course - 1) - phi(v), roll_bottom = phi(v) -
phi(0).  Each is the median over the central band of rows (columns): those
within n/6 of the centre, the middle third, away from the corners where both
rolls mix.

Curvatures: curvature_x = (theta(n_wale - 1) - theta(0)) / S on each band row,
S its arclength through the centres (each chord lengthened by (delta/2) /
sin(delta/2) for its turning delta: exact on a circle); the median over the
band.  curvature_y likewise on the band columns.  Positive = bending toward
the front.  The paper's side curl (side edges rolled front to back) has
negative left/right rolls and curvature_x; its top/bottom curl (back to
front) positive top/bottom rolls and curvature_y.

Edges touch (the paper's criterion between double and top/bottom curl): the
top and bottom edge zones are the outer m = max(1, floor(edge_zone
n_course)) courses at each side (edge_zone = 1/3), bind-off yarns (courses -1
and n_course) included; at least two courses separate them (in a flat
knit the centrelines of courses k and k + 2 come within 3.0 r, those of k
and k + 3 stay 10 r apart).  With yarn points and their course labels the
zones touch when two of their centreline points are closer than 2 r +
touch_gap (touch_gap = r by default: points ~1.2 r apart along a yarn show
touching yarns up to ~2.2 r apart).  Without points the
mid-surface stands in for the yarn: each column of centres is continued 0.9
loop past its edge row along the circle through its last three centres (the
yarn's heads reach 0.87 c past the edge loop centres), refined four times
bilinearly, and the zones touch when their mid-surfaces come closer than
4 r + touch_gap (4 r: two yarn layers, the thickness of a knit).  That is an
approximation: on synthetic rolls of radius ~c its gap came out up to 5 r
larger than the yarn points' (the loop centroids sit inside a tight roll by
~0.2 c^2/rho, and the bind-off is not represented), within 0.2 r on butting
edges; pass the points whenever they exist.  ``edge_gap`` = smallest
distance - 2 r (points) or - 4 r (centres); ``thresholds["touch_from"]``
says which.

Height: the paper's H (Fig. 2a) is the height of the fabric's centre above
the table.  Its measured trend, small for side curl and growing toward
top/bottom curl, holds for a swatch lying knit face (front) down on the rolls
that turn to the front; on its back a top/bottom-curled swatch would rest on
its centre.  So the table is the facet of the convex hull of the centre grid
that the ray from the centre along e_z meets (the face the swatch rests on
when laid front down under gravity; it carries the centre of mass for the
symmetric shapes), and H is the distance from the centre point (bilinear at
(v, u), inside the hull) to that facet's plane.  H is measured on the mid-
surface: a flat swatch has H = 0 (half the fabric thickness not included).
height_over_width = H / (n_wale w), w the knitted wale length.

Loop aspect (paper Fig. 2b): w/c of the relaxed central loops, the mean
distances between neighbouring centres along the rows and the columns of the
central block.

Classification (paper Sec. 6): an edge pair is curled when the larger
magnitude of its two rolls reaches ``roll_threshold`` (30 deg): x-curled
(left/right), y-curled (top/bottom).  Neither -> "flat"; x only -> "side";
y curled and edges touching -> "top_bottom"; y and x, edges apart ->
"double"; y only -> "top_bottom".  Why 30 deg: loop-scale waviness (a loop
centre shifted by a yarn diameter against its neighbour) tilts a chord by
atan(2 r / w) ~ 11 deg at r/w = 0.1, and the half-chord extrapolation to the
edge can double that (~20 deg); an edge the paper calls curled (Figs. 1a,
5c) is rolled over, a large fraction of a turn.  30 deg, a twelfth of a
turn, sits above the first and well below the second; the studies should
report how close their rolls come to it.  The class uses magnitudes; the
signs are in roll_deg, and ``directions_as_paper`` says whether every
curled pair turns the paper's way (side edges to the back, top/bottom to the
front).
"""
from dataclasses import asdict, dataclass, field
import math

import numpy as np
from scipy.interpolate import RegularGridInterpolator
from scipy.spatial import ConvexHull, QhullError, cKDTree

from .margin import curl_type, curled_pairs

ROLL_THRESHOLD = 30.0        # deg, an edge pair turned further is curled
EDGE_ZONE = 1.0 / 3.0        # fraction of the courses in each edge zone
KNIT_THICKNESS = 4.0         # yarn radii between touching mid-surfaces


@dataclass(frozen=True)
class CurlShape:
    """The curl of a swatch (definitions in the module docstring).

    curl : "side" | "double" | "top_bottom" | "flat"; edges_touch : bool;
    edge_gap : smallest top-bottom distance minus the touching one (length);
    roll_deg : {"left", "right", "top", "bottom"} (deg, + toward the front);
    curvature_x, curvature_y : 1/length, + toward the front; height : H
    (length); height_over_width : H / (n_wale w); loop_w, loop_c : central
    loop spacings (length), loop_aspect = loop_w / loop_c;
    directions_as_paper : every curled edge pair turns the paper's way;
    thresholds : the values the classification used."""
    curl: str
    edges_touch: bool
    edge_gap: float
    roll_deg: dict
    curvature_x: float
    curvature_y: float
    height: float
    height_over_width: float
    loop_w: float
    loop_c: float
    loop_aspect: float
    knitted_aspect: float
    directions_as_paper: bool
    thresholds: dict = field(default_factory=dict)

    def as_dict(self):
        """Plain JSON-ready dict (floats, bools, str)."""
        return asdict(self)


def _knit_points(points, swatch):
    """The knit yarn's (n, 3) points from either its own points or all yarns stacked."""
    p = np.asarray(points, dtype=float)
    n_knit, n_all = len(swatch.yarns[0].points), sum(len(y.points) for y in swatch.yarns)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) not in (n_knit, n_all):
        raise ValueError(f"points must have shape ({n_knit}, 3) (knit yarn) or ({n_all}, 3) "
                         f"(all yarns), got {p.shape}")
    if not np.isfinite(p).all():
        raise ValueError("points must be finite, got NaN or inf")
    return p[:n_knit]


def loop_centres(points, swatch):
    """Loop centres (n_course, n_wale, 3) of a deformed swatch.

    points : (n, 3) deformed knit-yarn points in the order of
        ``swatch.yarns[0].points`` (or all yarns stacked as ``swatch.points``).
    swatch : the :class:`knitfem.geometry.Swatch` they deform.
    Each centre is the material centroid of the loop's segments (midpoints
    weighted by their knitted lengths), turn-arounds excluded."""
    p = _knit_points(points, swatch)
    yarn = swatch.yarns[0]
    weight = np.linalg.norm(np.diff(yarn.points, axis=0), axis=1)
    keep = ~yarn.turn
    loop = yarn.course[keep] * swatch.n_wale + yarn.wale[keep]
    size = swatch.n_course * swatch.n_wale
    total = np.bincount(loop, weights=weight[keep], minlength=size)
    mid = 0.5 * (p[1:] + p[:-1])[keep]
    centre = np.stack([np.bincount(loop, weights=weight[keep] * mid[:, i], minlength=size)
                       for i in range(3)], axis=1) / total[:, None]
    return centre.reshape(swatch.n_course, swatch.n_wale, 3)


def point_courses(swatch):
    """Course label (n,) of every point of ``swatch.points`` (all yarns stacked):
    the label of the segment starting there (the last point: of the last
    segment); -1 and n_course on the bottom and top bind-off."""
    return np.concatenate([np.append(y.course, y.course[-1]) for y in swatch.yarns])


def _positive(name, value):
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be finite and in (0, inf), got {value!r}")
    return v


def centre_grid(centres):
    """``centres`` as a float (n_course >= 4, n_wale >= 3, 3) array of finite
    loop centres, or a ValueError naming it."""
    C = np.asarray(centres, dtype=float)
    if C.ndim != 3 or C.shape[2] != 3 or C.shape[0] < 4 or C.shape[1] < 3:
        raise ValueError("centres must have shape (n_course >= 4, n_wale >= 3, 3), "
                         f"got {C.shape}")
    if not np.isfinite(C).all():
        raise ValueError("centres must be finite, got NaN or inf")
    return C


def chord_arcs(chord, delta):
    """Arc lengths of chords ``chord`` whose ends' tangents differ by ``delta``
    (rad), each lengthened by (delta/2) / sin(delta/2): exact on a circle
    (delta capped at 3 rad, where the correction stops making sense)."""
    return chord / np.sinc(np.minimum(np.abs(delta), 3.0) / (2 * np.pi))


def _central_block(n):
    """Indices within 1.5 of the centre (n - 1)/2: 3 for odd n, 4 for even."""
    i = np.arange(n)
    return i[np.abs(i - 0.5 * (n - 1)) <= 1.5]


def _body_frame(C):
    """(e_x, e_y, e_z) from a quadratic fit of the central block of centres."""
    n_c, n_w = C.shape[:2]
    K, J = np.meshgrid(_central_block(n_c), _central_block(n_w), indexing="ij")
    dk, dj = (K - 0.5 * (n_c - 1)).ravel(), (J - 0.5 * (n_w - 1)).ravel()
    design = np.stack([np.ones_like(dj), dj, dk, dj * dj, dj * dk, dk * dk], axis=1)
    coef = np.linalg.lstsq(design, C[K, J].reshape(-1, 3), rcond=None)[0]
    a, b = coef[1], coef[2]
    normal = np.cross(a, b)
    if np.linalg.norm(normal) <= 1e-12 * np.linalg.norm(a) * np.linalg.norm(b):
        raise ValueError("centres: the central loops are collapsed (no tangent plane)")
    e_z = normal / np.linalg.norm(normal)
    e_x = a / np.linalg.norm(a)
    return e_x, np.cross(e_z, e_x), e_z


def _band(n):
    """Indices of the central band: within n/6 of the centre (the middle third)."""
    i = np.arange(n)
    return i[np.abs(i - 0.5 * (n - 1)) <= n / 6.0]


def _turning(lines, along, normal):
    """Tangent angles of polylines (m, N, 3) in the (along, normal) plane.

    Returns the angles at the N points (m, N) (rad, unwrapped) and at the
    middle index (N - 1)/2 (m,), and the arclengths (m,) through the points
    (chords corrected to circular arcs)."""
    seg = np.diff(lines, axis=1)
    ang = np.unwrap(np.arctan2(seg @ normal, seg @ along), axis=1)
    at = np.empty(lines.shape[:2])
    at[:, 1:-1] = 0.5 * (ang[:, 1:] + ang[:, :-1])
    at[:, 0] = 1.5 * ang[:, 0] - 0.5 * ang[:, 1]
    at[:, -1] = 1.5 * ang[:, -1] - 0.5 * ang[:, -2]
    n = lines.shape[1]
    centre = at[:, n // 2] if n % 2 else ang[:, n // 2 - 1]
    delta = np.diff(at, axis=1)
    arc = chord_arcs(np.linalg.norm(seg, axis=2), delta)
    return at, centre, arc.sum(axis=1)


def _rolls(lines, along, normal):
    """(roll at the start, roll at the end, curvature): medians over the lines."""
    at, centre, length = _turning(lines, along, normal)
    return (float(np.degrees(np.median(centre - at[:, 0]))),
            float(np.degrees(np.median(at[:, -1] - centre))),
            float(np.median((at[:, -1] - at[:, 0]) / length)))


def _edge_zones(n_course, edge_zone):
    m = max(1, int(math.floor(edge_zone * n_course)))
    return min(m, (n_course - 2) // 2)


def _edge_gap_points(points, course, n_course, m, radius):
    bottom, top = points[course < m], points[course >= n_course - m]
    if not len(bottom) or not len(top):
        raise ValueError("point_course has no points in the top or bottom edge zone "
                         f"(courses < {m} and >= {n_course - m})")
    return float(cKDTree(top).query(bottom)[0].min()) - 2.0 * radius


def _continue_rows(C):
    """One more row beyond the last of C (n, m, 3): each column's last chord
    turned once more by its last turning (the circle through the last three
    centres, continued)."""
    a, b = C[-2] - C[-3], C[-1] - C[-2]
    normal = np.cross(a, b)
    sin = np.linalg.norm(normal, axis=1, keepdims=True)
    axis = normal / np.where(sin > 0, sin, 1.0)
    angle = np.arctan2(sin, np.sum(a * b, axis=1, keepdims=True))
    turned = (b * np.cos(angle) + np.cross(axis, b) * np.sin(angle)
              + axis * np.sum(axis * b, axis=1, keepdims=True) * (1.0 - np.cos(angle)))
    return C[-1] + turned


def _edge_gap_centres(C, m, radius, reach=0.9, refine=4):
    """Smallest distance between the top and bottom zones of the mid-surface,
    continued ``reach`` loops past the edge rows and refined bilinearly."""
    n_c, n_w = C.shape[:2]
    ext = np.concatenate([_continue_rows(C[::-1])[None], C, _continue_rows(C)[None]])
    grid = RegularGridInterpolator((np.arange(-1.0, n_c + 1.0), np.arange(n_w)), ext)
    k = np.linspace(-reach, n_c - 1 + reach, refine * (n_c + 1) + 1)
    j = np.linspace(0.0, n_w - 1.0, refine * (n_w - 1) + 1)
    surface = grid(np.stack(np.meshgrid(k, j, indexing="ij"), axis=-1))
    bottom, top = surface[k <= m - 0.5].reshape(-1, 3), surface[k >= n_c - m - 0.5].reshape(-1, 3)
    return float(cKDTree(top).query(bottom)[0].min()) - KNIT_THICKNESS * radius


def _centre_point(C):
    """Bilinear point of the grid at its centre (a convex combination of centres)."""
    n_c, n_w = C.shape[:2]
    ks = sorted({(n_c - 1) // 2, n_c // 2})
    js = sorted({(n_w - 1) // 2, n_w // 2})
    return C[np.ix_(ks, js)].reshape(-1, 3).mean(axis=0)


def _height(C, e_z):
    """Distance from the centre to the hull facet met along the front normal."""
    pts = C.reshape(-1, 3)
    p0 = _centre_point(C)
    try:
        eq = ConvexHull(pts).equations
    except QhullError:                   # flat (coplanar) centres: the plane itself
        return max(0.0, float(((pts - p0) @ e_z).max()))
    facing = eq[:, :3] @ e_z
    up = facing > 1e-12
    depth = -(eq[up, :3] @ p0 + eq[up, 3])          # distance to each facet's plane
    hit = np.argmin(depth / facing[up])             # first facet along the ray
    return max(0.0, float(depth[hit]))


def _loop_spacing(C):
    K, J = _central_block(C.shape[0]), _central_block(C.shape[1])
    block = C[np.ix_(K, J)]
    w = np.linalg.norm(np.diff(block, axis=1), axis=2).mean()
    c = np.linalg.norm(np.diff(block, axis=0), axis=2).mean()
    return float(w), float(c)


def curl_shape(centres, w, c, radius, *, points=None, point_course=None,
               roll_threshold=ROLL_THRESHOLD, touch_gap=None, edge_zone=EDGE_ZONE):
    """Classify and measure the curl of a swatch from its loop centres.

    centres : (n_course, n_wale, 3) loop centres (:func:`loop_centres`), at
        least 4 courses and 3 wales; length unit (mm).
    w, c, radius : knitted wale length, course length and yarn radius (length).
    points, point_course : optional yarn points (n, 3) and their course labels
        (n,) (:func:`point_courses`; -1 / n_course for the bind-off) for
        ``edges_touch``; without them the centre grid is used.
    roll_threshold : deg, an edge pair rolled further is curled (default 30).
    touch_gap : length, largest surface gap that counts as contact (default r).
    edge_zone : fraction of the courses in each edge zone (default 1/3).
    Returns a :class:`CurlShape`; definitions in the module docstring."""
    C = centre_grid(centres)
    w, c, radius = _positive("w", w), _positive("c", c), _positive("radius", radius)
    roll_threshold = _positive("roll_threshold", roll_threshold)
    if roll_threshold >= 180.0:
        raise ValueError(f"roll_threshold must be in (0, 180) deg, got {roll_threshold!r}")
    touch_gap = radius if touch_gap is None else float(touch_gap)
    if not (math.isfinite(touch_gap) and touch_gap >= 0):
        raise ValueError(f"touch_gap must be finite and >= 0, got {touch_gap!r}")
    if not 0.0 < edge_zone < 0.5:
        raise ValueError(f"edge_zone must be in (0, 0.5), got {edge_zone!r}")
    n_course, n_wale = C.shape[:2]

    e_x, e_y, e_z = _body_frame(C)
    left, right, curvature_x = _rolls(C[_band(n_course)], e_x, e_z)
    bottom, top, curvature_y = _rolls(C[:, _band(n_wale)].transpose(1, 0, 2), e_y, e_z)

    m = _edge_zones(n_course, edge_zone)
    if points is not None or point_course is not None:
        if points is None or point_course is None:
            raise ValueError("points and point_course must be given together")
        p = np.asarray(points, dtype=float)
        lab = np.asarray(point_course)
        if p.ndim != 2 or p.shape[1] != 3 or lab.shape != (len(p),):
            raise ValueError(f"points must be (n, 3) and point_course (n,), got {p.shape} "
                             f"and {lab.shape}")
        if not np.isfinite(p).all():
            raise ValueError("points must be finite, got NaN or inf")
        edge_gap, touch_from = _edge_gap_points(p, lab, n_course, m, radius), "points"
    else:
        edge_gap, touch_from = _edge_gap_centres(C, m, radius), "centres"
    edges_touch = bool(edge_gap < touch_gap)

    roll = {"left": left, "right": right, "top": top, "bottom": bottom}
    x_curled, y_curled = curled_pairs(roll, roll_threshold)
    curl = curl_type(roll, edges_touch, roll_threshold)
    as_paper = (not x_curled or left + right < 0) and (not y_curled or top + bottom > 0)

    height = _height(C, e_z)
    loop_w, loop_c = _loop_spacing(C)
    return CurlShape(
        curl=curl, edges_touch=edges_touch, edge_gap=edge_gap,
        roll_deg=roll,
        curvature_x=curvature_x, curvature_y=curvature_y, height=height,
        height_over_width=height / (n_wale * w), loop_w=loop_w, loop_c=loop_c,
        loop_aspect=loop_w / loop_c, knitted_aspect=w / c, directions_as_paper=bool(as_paper),
        thresholds={"roll_deg": roll_threshold, "touch_gap": touch_gap,
                    "edge_zone_courses": m, "touch_from": touch_from})


def swatch_curl(points, swatch, **options):
    """:func:`curl_shape` of a deformed swatch from its yarn points.

    points : (n, 3) the knit yarn's points (``swatch.yarns[0].points`` order)
        or all yarns stacked (``swatch.points`` order; the bind-off then takes
        part in ``edges_touch``).  options : passed to :func:`curl_shape`."""
    knit = _knit_points(points, swatch)
    p = np.asarray(points, dtype=float)
    lab = point_courses(swatch)[:len(p)]
    return curl_shape(loop_centres(knit, swatch), swatch.loop.w, swatch.loop.c,
                      swatch.radius, points=p, point_course=lab, **options)
