"""Curl classification (knitfem.analysis.curl) on synthetic deformed swatches.

The real plain-knit swatch (knit yarn and bind-off) is mapped onto surfaces
whose curl is known in closed form: cylinders about y (side curl) and x
(top/bottom curl), flat strips ending in circular rolls, and a sheet with
both.  A mapping bends the flat coordinate s (x or y, measured from the
middle of the loop centres) and the offset zeta from their mid-plane
isometrically: flat for |s| <= a, beyond it a circle of radius rho toward the
front (+1) or the back (-1).  Every loop whose yarn lies wholly in a circle
is a rotated copy of its flat neighbour, so the centre chords turn by exactly
w/rho (c/rho) there and the rolls are exact to round-off.
"""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from knitfem.analysis import curl_shape, loop_centres, point_courses, swatch_curl
from knitfem.geometry import plain_knit_swatch

W, C, R = 4.0, 3.0, 0.4


@pytest.fixture(scope="module")
def swatch():
    return plain_knit_swatch(9, 13, W, C, R)        # 36 x 39 mm, odd counts: a centre loop


@pytest.fixture(scope="module")
def wide():
    return plain_knit_swatch(15, 13, W, C, R)


def _mid(swatch):
    centres = loop_centres(swatch.points, swatch)
    return centres.reshape(-1, 3).mean(axis=0)


def bend(s, zeta, a, rho, side, only_positive=False):
    """Map the flat coordinate s and offset zeta onto a flat strip |s| <= a
    continued by circles of radius rho bending toward ``side`` (+1 front,
    -1 back); returns (s', z').  only_positive: bend the s > 0 side only."""
    u = np.abs(s)
    phi = np.maximum(u - a, 0.0) / rho
    along = np.minimum(u, a) + rho * np.sin(phi) - side * zeta * np.sin(phi)
    z = side * rho * (1.0 - np.cos(phi)) + zeta * np.cos(phi)
    along = np.sign(s) * along
    if only_positive:
        along, z = np.where(s > 0, along, s), np.where(s > 0, z, zeta)
    return along, z


def deform(swatch, x=None, y=None):
    """All yarn points of ``swatch`` bent along y (x = (a, rho, side)), then
    along x (y = ...); the y bend is applied first, its z then bent with x."""
    p = swatch.points
    mid = _mid(swatch)
    s_x, s_y, zeta = p[:, 0] - mid[0], p[:, 1] - mid[1], p[:, 2] - mid[2]
    if y is not None:
        s_y, zeta = bend(s_y, zeta, *y)
    if x is not None:
        s_x, zeta = bend(s_x, zeta, *x)
    return np.stack([s_x, s_y, zeta], axis=1) + mid


def rigid(points, seed):
    rot = Rotation.random(random_state=seed).as_matrix()
    return points @ rot.T + np.array([31.0, -7.0, 120.0])


def tube_radius(swatch, gap):
    """Radius of a cylinder about x whose circumference is the yarn's height
    (bind-off included) plus ``gap``: the top and bottom yarn extremes end
    ``gap`` apart along the circle (0: the edges meet)."""
    y = swatch.points[:, 1]
    return (y.max() - y.min() + gap) / (2.0 * math.pi)


def centre_circle_radius(centres, axis_point, axis):
    """Distance of the loop centres from a cylinder's axis (the circle their
    centroids lie on: a little inside the bent mid-surface)."""
    d = centres - axis_point
    d -= np.outer(d @ axis, axis)
    return np.linalg.norm(d, axis=1)


def test_loop_centres_are_the_loops_of_the_knitted_swatch(swatch):
    """Flat swatch: centre (k, j) at (j w, k c) (heads at x = j w, courses c
    apart) on one plane; odd courses run right to left but keep their wale
    labels; knit-yarn points and all yarns stacked give the same grid."""
    centres = loop_centres(swatch.points, swatch)
    assert centres.shape == (13, 9, 3)
    k, j = np.meshgrid(np.arange(13), np.arange(9), indexing="ij")
    assert np.allclose(centres[..., 0], j * W, atol=1e-12)
    assert np.allclose(centres[..., 1], k * C, atol=1e-12)
    assert np.ptp(centres[..., 2]) < 1e-12
    assert np.array_equal(loop_centres(swatch.yarns[0].points, swatch), centres)


def test_loop_centres_follow_the_labelled_loops(swatch):
    """Moving the yarn of one loop (course 3, wale 5) moves that centre only."""
    yarn = swatch.yarns[0]
    p = yarn.points.copy()
    seg = np.flatnonzero((yarn.course == 3) & (yarn.wale == 5) & ~yarn.turn)
    inner = np.intersect1d(seg, seg + 1)            # points whose both segments belong to it
    p[inner] += [0.0, 0.0, 2.0]
    moved = loop_centres(p, swatch) - loop_centres(yarn.points, swatch)
    changed = np.argwhere(np.abs(moved[..., 2]) > 1e-12)
    assert changed.tolist() == [[3, 5]]
    assert 1.5 < moved[3, 5, 2] < 2.0                # end segments half moved


def test_point_courses_label_the_bindoff_beyond_the_courses(swatch):
    lab = point_courses(swatch)
    n_knit = len(swatch.yarns[0].points)
    assert lab.shape == (len(swatch.points),)
    assert lab[:n_knit].min() == 0 and lab[:n_knit].max() == 12
    assert set(np.unique(lab[n_knit:])) == {-1, 13}


@pytest.mark.parametrize("n_course", [4, 13])
def test_flat_swatch_is_flat(n_course):
    sw = plain_knit_swatch(9, n_course, W, C, R)
    for shape in (swatch_curl(sw.points, sw), curl_shape(loop_centres(sw.points, sw), W, C, R)):
        assert shape.curl == "flat"
        assert max(abs(v) for v in shape.roll_deg.values()) < 1e-9
        assert abs(shape.curvature_x) < 1e-12 and abs(shape.curvature_y) < 1e-12
        assert shape.height < 1e-12
        # the edge zones are two courses apart even on 4 courses: not touching
        assert not shape.edges_touch and shape.edge_gap > C
        assert shape.loop_aspect == pytest.approx(W / C, rel=1e-12)


def test_edge_zones_keep_two_courses_between_them():
    """However wide the zones are asked to be, two courses separate them: in a
    flat knit the centrelines of courses k and k + 2 come within 3.0 r (the
    contact distance with the default gap), those of k and k + 3 10 r apart."""
    sw = plain_knit_swatch(5, 9, W, C, R)
    shape = swatch_curl(sw.points, sw, edge_zone=0.49)
    assert shape.thresholds["edge_zone_courses"] == 3
    assert not shape.edges_touch and shape.curl == "flat"


def test_cylinder_about_y_is_side_curl_with_the_cylinders_curvature(swatch):
    """Side edges rolled to the back on a cylinder of radius 12 mm (3 w): each
    edge centre, 4 wales from the middle, turns by 16/12 rad to the back.
    The curvature is exactly that of the circle through the loop centroids,
    and 1/R within 1.5 %: the centroids sit inside the mid-surface by about
    <s^2>/(2 R) (<s^2> the loop's second moment along the row, ~0.07 w^2),
    which raises the curvature by 0.4 % here."""
    rho = 12.0
    pts = deform(swatch, x=(0.0, rho, -1))
    shape = swatch_curl(pts, swatch)
    expected = -math.degrees(4 * W / rho)
    assert shape.curl == "side" and not shape.edges_touch and shape.directions_as_paper
    assert shape.roll_deg["left"] == pytest.approx(expected, abs=1e-9)
    assert shape.roll_deg["right"] == pytest.approx(expected, abs=1e-9)
    assert abs(shape.roll_deg["top"]) < 1e-9 and abs(shape.curvature_y) < 1e-12
    mid = _mid(swatch)
    radius = centre_circle_radius(loop_centres(pts, swatch).reshape(-1, 3),
                                  mid - [0.0, 0.0, rho], np.array([0.0, 1.0, 0.0]))
    assert np.ptp(radius) < 1e-9
    assert shape.curvature_x == pytest.approx(-1.0 / radius[0], rel=1e-9)
    assert shape.curvature_x * rho == pytest.approx(-1.0, rel=0.015)
    # rolled to the back, the swatch lies front down on its centre: H = 0
    assert shape.height < 1e-9


def test_open_cylinder_about_x_is_top_bottom_curl_of_known_height(swatch):
    """Top and bottom edges rolled to the front on a cylinder of radius 12 mm,
    the edge rows 6 c from the middle (86 deg), far apart: y-curled only ->
    top_bottom.  Laid front down it rests on the edge rows: H = rho' (1 -
    cos(6 c / rho)), rho' the radius of the centroids' circle.  Curvature:
    1/R within 1.5 % (the centroid offset, <s^2> ~ 0.36 c^2 along a column,
    raises it by 1.1 %)."""
    rho = 12.0
    pts = deform(swatch, y=(0.0, rho, +1))
    shape = swatch_curl(pts, swatch)
    theta = 6 * C / rho
    assert shape.curl == "top_bottom" and not shape.edges_touch and shape.directions_as_paper
    assert shape.roll_deg["top"] == pytest.approx(math.degrees(theta), abs=1e-9)
    assert shape.roll_deg["bottom"] == pytest.approx(math.degrees(theta), abs=1e-9)
    assert abs(shape.roll_deg["left"]) < 1e-9 and abs(shape.curvature_x) < 1e-12
    centres = loop_centres(pts, swatch)
    radius = centre_circle_radius(centres.reshape(-1, 3), _mid(swatch) + [0.0, 0.0, rho],
                                  np.array([1.0, 0.0, 0.0]))
    assert np.ptp(radius) < 1e-9
    assert shape.curvature_y == pytest.approx(1.0 / radius[0], rel=1e-9)
    assert shape.curvature_y * rho == pytest.approx(1.0, rel=0.015)
    assert shape.height == pytest.approx(radius[0] * (1.0 - math.cos(theta)), rel=1e-9)
    assert shape.height_over_width == pytest.approx(shape.height / (9 * W), rel=1e-12)


@pytest.mark.parametrize("use_points", [True, False])
def test_tube_about_x_with_meeting_edges_touches(swatch, use_points):
    """A cylinder about x whose circumference is the yarn's height: the top and
    bottom edges meet -> touching, top_bottom; left open by 3 c they do not
    (still top_bottom: y-curled only).  Both the yarn points and the centre
    grid (continued past its edge rows) see it."""
    def shape(gap):
        pts = deform(swatch, y=(0.0, tube_radius(swatch, gap), +1))
        if use_points:
            return swatch_curl(pts, swatch)
        return curl_shape(loop_centres(pts, swatch), W, C, R)
    closed, open_ = shape(0.0), shape(3 * C)
    assert closed.edges_touch and closed.curl == "top_bottom"
    assert not open_.edges_touch and open_.curl == "top_bottom"
    assert closed.roll_deg["top"] > 140 and closed.curvature_y > 0
    assert closed.thresholds["touch_from"] == ("points" if use_points else "centres")


def test_rolls_meeting_face_to_face_touch(swatch):
    """The paper's top/bottom curl: a flat middle strip, top and bottom edges
    rolled to the front (radius 3 mm, beyond 180 deg) until the rolls press
    on each other; pulled 2.5 mm further apart they do not touch."""
    touching = swatch_curl(deform(swatch, y=(3.5, 3.0, +1)), swatch)
    apart = swatch_curl(deform(swatch, y=(6.0, 3.0, +1)), swatch)
    assert touching.edges_touch and touching.edge_gap < 0 and touching.curl == "top_bottom"
    assert not apart.edges_touch and apart.edge_gap > 2 * R
    assert touching.roll_deg["top"] == pytest.approx(math.degrees((6 * C - 3.5) / 3.0),
                                                     abs=1e-9)
    assert touching.roll_deg["top"] > 180 and touching.directions_as_paper


def test_doubly_curled_sheet_with_edges_apart_is_double(swatch):
    """Side edges rolled back (flat middle 6 mm, radius 6 mm) and top/bottom
    edges rolled front (flat middle 9 mm, radius 5 mm), edges far apart."""
    shape = swatch_curl(deform(swatch, x=(6.0, 6.0, -1), y=(9.0, 5.0, +1)), swatch)
    assert shape.curl == "double" and not shape.edges_touch and shape.directions_as_paper
    assert shape.roll_deg["left"] < -30 and shape.roll_deg["right"] < -30
    assert shape.roll_deg["top"] > 30 and shape.roll_deg["bottom"] > 30
    assert shape.curvature_x < 0 < shape.curvature_y
    # the band columns lie in the flat middle: the top roll is exact
    assert shape.roll_deg["top"] == pytest.approx(math.degrees((6 * C - 9.0) / 5.0), abs=1e-9)
    assert shape.height > 0


def test_doubly_curled_sheet_with_touching_edges_is_top_bottom(swatch):
    shape = swatch_curl(deform(swatch, x=(6.0, 6.0, -1),
                               y=(0.0, tube_radius(swatch, 0.0), +1)), swatch)
    assert shape.roll_deg["left"] < -30 and shape.roll_deg["top"] > 30
    assert shape.edges_touch and shape.curl == "top_bottom"


@pytest.mark.parametrize("turn_deg", [250.0, 400.0])
def test_rolls_beyond_half_and_full_turns(wide, turn_deg):
    """Side edges of a 15-wale swatch rolled to the back by 250 and 400 deg
    (flat middle 6 mm, the edge centres 28 mm from the middle): reported as
    -250 / -400, not wrapped into (-180, 180]."""
    rho = (7 * W - 6.0) / math.radians(turn_deg)
    shape = swatch_curl(deform(wide, x=(6.0, rho, -1)), wide)
    assert shape.roll_deg["left"] == pytest.approx(-turn_deg, abs=1e-9)
    assert shape.roll_deg["right"] == pytest.approx(-turn_deg, abs=1e-9)
    assert shape.curl == "side"


def test_one_sided_roll_is_not_mirrored(swatch):
    """Only the right edge rolled back: left stays near 0 (the centre loop is
    half bent, tilting the centre chord by a few degrees), so equal left and
    right rolls above are measured, not built in."""
    shape = swatch_curl(deform(swatch, x=(0.0, 12.0, -1, True)), swatch)
    assert shape.roll_deg["right"] < -60
    assert abs(shape.roll_deg["left"]) < 10
    assert shape.curl == "side"


SHAPES = {                                      # name: (bends, class)
    "flat": ({}, "flat"),
    "side": ({"x": (0.0, 12.0, -1)}, "side"),
    "tube": ({"y": (0.0, None, +1)}, "top_bottom"),
    "rolls": ({"y": (3.5, 3.0, +1)}, "top_bottom"),
    "double": ({"x": (6.0, 6.0, -1), "y": (9.0, 5.0, +1)}, "double"),
}


@pytest.mark.parametrize("name", SHAPES)
def test_rigid_motion_changes_nothing(swatch, name):
    """The relaxed swatch floats freely: a rotation and translation of the
    whole deformed swatch leaves every measure and the class unchanged."""
    bends, curl = SHAPES[name]
    bends = dict(bends)
    if "y" in bends and bends["y"][1] is None:
        bends["y"] = (0.0, tube_radius(swatch, 0.0), +1)
    pts = deform(swatch, **bends)
    ref = swatch_curl(pts, swatch).as_dict()
    assert ref["curl"] == curl
    for seed in (1, 2):
        moved = swatch_curl(rigid(pts, seed), swatch).as_dict()
        assert moved["curl"] == curl and moved["edges_touch"] == ref["edges_touch"]
        for key in ("left", "right", "top", "bottom"):
            assert moved["roll_deg"][key] == pytest.approx(ref["roll_deg"][key], abs=1e-8)
        for key in ("curvature_x", "curvature_y", "height", "edge_gap", "loop_aspect"):
            assert moved[key] == pytest.approx(ref[key], rel=1e-9, abs=1e-9)


def test_thresholds_are_reported_and_used(swatch):
    """A roll of 76 deg is curled at the default 30 deg, not at 80 deg."""
    pts = deform(swatch, x=(0.0, 12.0, -1))
    assert swatch_curl(pts, swatch).thresholds["roll_deg"] == 30.0
    strict = swatch_curl(pts, swatch, roll_threshold=80.0)
    assert strict.curl == "flat" and strict.thresholds["roll_deg"] == 80.0
    assert strict.thresholds["touch_gap"] == R


@pytest.mark.parametrize("call, name", [
    (lambda sw, cen: curl_shape(cen[:3], W, C, R), "centres"),
    (lambda sw, cen: curl_shape(cen * np.nan, W, C, R), "centres"),
    (lambda sw, cen: curl_shape(cen, -1.0, C, R), "w"),
    (lambda sw, cen: curl_shape(cen, W, C, R, roll_threshold=200), "roll_threshold"),
    (lambda sw, cen: curl_shape(cen, W, C, R, touch_gap=-1), "touch_gap"),
    (lambda sw, cen: curl_shape(cen, W, C, R, points=sw.points), "point_course"),
    (lambda sw, cen: loop_centres(sw.points[:-1], sw), "points"),
])
def test_bad_input_names_the_parameter(swatch, call, name):
    with pytest.raises(ValueError, match=name):
        call(swatch, loop_centres(swatch.points, swatch))
