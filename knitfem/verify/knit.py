"""Measurements on knit geometry, independent of how it was built.

They read only centreline points (any polylines), so the tests and the knit
study check the swatch itself: clearance between yarn parts, crossings of
two strands in the x-y projection with their over/under from z, and the
closest approach of two strands near a crossing.
"""
import numpy as np
from scipy.spatial import cKDTree


def bend_radii(points):
    """Radius of the circle through each three consecutive points (n-2,)."""
    a, b = points[1:-1] - points[:-2], points[2:] - points[1:-1]
    chord = np.linalg.norm(points[2:] - points[:-2], axis=1)
    area2 = np.linalg.norm(np.cross(a, b), axis=1)
    with np.errstate(divide="ignore"):
        return np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1) * chord / (2.0 * area2)


def clearance(curves, radius, exclude):
    """Smallest centreline distance over 2 radius between points of different
    curves, or of one curve more than ``exclude`` apart in arclength.

    curves : list of (n_k, 3) polylines (sample densely: point pairs, not
    segments, are compared).  Returns (ratio, (curve_a, point_a, curve_b,
    point_b)), ratio inf if nothing is within 3 radii."""
    pts = np.concatenate(curves)
    owner = np.concatenate([np.full(len(c), i) for i, c in enumerate(curves)])
    index = np.concatenate([np.arange(len(c)) for c in curves])
    s = np.concatenate([np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(c, axis=0),
                                                                       axis=1))])
                        for c in curves])
    pairs = cKDTree(pts).query_pairs(3.0 * radius, output_type="ndarray")
    if len(pairs) == 0:
        return np.inf, None
    i, j = pairs[:, 0], pairs[:, 1]
    keep = (owner[i] != owner[j]) | (np.abs(s[i] - s[j]) > exclude)
    i, j = i[keep], j[keep]
    if len(i) == 0:
        return np.inf, None
    dist = np.linalg.norm(pts[i] - pts[j], axis=1)
    m = int(np.argmin(dist))
    return dist[m] / (2.0 * radius), (owner[i[m]], index[i[m]], owner[j[m]], index[j[m]])


def projected_crossings(a, b):
    """Crossings of polylines a (n, 3) and b (m, 3) in the x-y projection.

    Returns (k, 5): position along a (segment index + fraction), along b,
    z_a - z_b at the crossing (> 0: a passes over b, toward +z), x, y;
    sorted along a."""
    p, r = a[:-1, None, :2], (a[1:] - a[:-1])[:, None, :2]
    q, s = b[None, :-1, :2], (b[1:] - b[:-1])[None, :, :2]
    rxs = r[..., 0] * s[..., 1] - r[..., 1] * s[..., 0]
    qp = q - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[..., 0] * s[..., 1] - qp[..., 1] * s[..., 0]) / rxs
        u = (qp[..., 0] * r[..., 1] - qp[..., 1] * r[..., 0]) / rxs
    # half-open parameter ranges count a crossing at a shared vertex once
    hit = (rxs != 0) & (t >= 0) & (t < 1) & (u >= 0) & (u < 1)
    i, j = np.nonzero(hit)
    t, u = t[i, j], u[i, j]
    za = a[i, 2] + t * (a[i + 1, 2] - a[i, 2])
    zb = b[j, 2] + u * (b[j + 1, 2] - b[j, 2])
    xy = a[i, :2] + t[:, None] * (a[i + 1, :2] - a[i, :2])
    out = np.column_stack([i + t, j + u, za - zb, xy])
    return out[np.argsort(out[:, 0])]


def approach_near(a, b, point, reach):
    """Closest distance between the points of a and of b that lie within
    ``reach`` (in the x-y projection) of ``point`` (2,)."""
    na = np.linalg.norm(a[:, :2] - point, axis=1) < reach
    nb = np.linalg.norm(b[:, :2] - point, axis=1) < reach
    return float(cKDTree(b[nb]).query(a[na])[0].min())


def loop_polyline(yarn, course, wale):
    """The points of the loop (course, wale) of a :class:`YarnPath`: its
    segments plus their end points, in yarn order."""
    seg = np.nonzero((yarn.course == course) & (yarn.wale == wale) & ~yarn.turn)[0]
    if len(seg) == 0 or np.any(np.diff(seg) != 1):
        raise ValueError(f"loop (course {course}, wale {wale}) is not one run of segments")
    return yarn.points[seg[0]:seg[-1] + 2]
