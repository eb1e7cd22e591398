"""Plain-knit geometry (issue 5): interlocking, clearance, continuity, exports,
bad input.  Every check measures the generated centrelines (knitfem.verify.knit
reads points only), not the construction's own bookkeeping."""
import math

import meshio
import numpy as np
import pytest
from scipy.spatial import cKDTree

from knitfem import Section
from knitfem.bspline import curve
from knitfem.geometry import (as_rods, bspline_control_points, course_length_range, knit_loop,
                              plain_knit_swatch, swatch_control_points)
from knitfem.io.swatch import swatch_mesh, write_swatch
from knitfem.scenes.knit import knit
from knitfem.verify.knit import (approach_near, bend_radii, clearance, loop_polyline,
                                 projected_crossings)

W, C, R = 4.0, 3.0, 0.4            # mm: a typical relaxed plain knit, w = 5 d, c = 3.75 d
NW, NC = 5, 5


@pytest.fixture(scope="module")
def swatch():
    """5 x 5 with bind-off, 96 points per loop (0.16 mm = 0.4 r apart)."""
    return plain_knit_swatch(NW, NC, W, C, R, points_per_loop=96)


def _sides(crossings, x_mid):
    return crossings[crossings[:, 3] < x_mid], crossings[crossings[:, 3] > x_mid]


def _interlocked(pair):
    """Two crossings of opposite over/under: the strands hook, they cannot be
    lifted apart along z."""
    return len(pair) == 2 and np.sign(pair[0, 2]) == -np.sign(pair[1, 2]) != 0


# -- the measuring tools on curves with known answers -------------------------------------

def test_crossing_and_clearance_tools_on_straight_strands():
    """Two straight strands crossing at (1, 1), z 0.3 apart: one crossing, a over b by
    0.3 (exact); parallel strands 0.5 apart: clearance 0.5/(2r) (exact for points)."""
    a = np.column_stack([np.linspace(0, 2, 5), np.linspace(0, 2, 5), np.full(5, 0.3)])
    b = np.column_stack([np.linspace(0, 2, 7), np.linspace(2, 0, 7), np.zeros(7)])
    x = projected_crossings(a, b)
    assert x.shape[0] == 1 and np.allclose(x[0, 2:], [0.3, 1.0, 1.0])
    assert projected_crossings(a, a + [5.0, 0.0, 0.0]).shape[0] == 0
    line = np.column_stack([np.linspace(0, 1, 11), np.zeros(11), np.zeros(11)])
    ratio, _ = clearance([line, line + [0.0, 0.5, 0.0]], radius=0.2, exclude=2.0)
    assert ratio == pytest.approx(0.5 / 0.4)
    assert np.allclose(bend_radii(np.column_stack([np.cos(np.linspace(0, 1, 9)),
                                                   np.sin(np.linspace(0, 1, 9)),
                                                   np.zeros(9)])), 1.0)


# -- the loop --------------------------------------------------------------------------------

def test_loop_bulge_sits_three_eighths_of_a_wale_out_and_half_a_course_up():
    """The head's widest point is at x = 3w/8, y = c/2 (1e-6 w): the construction that
    leaves w/4 for the two legs of a loop and w/4 for the interlock lens."""
    loop = knit_loop(W, C, R)
    t = np.linspace(0.0, math.pi / 2, 200001)
    p = loop.curve(t)[0]
    i = np.argmax(p[:, 0])
    assert p[i, 0] == pytest.approx(3 * W / 8, abs=1e-6 * W)
    assert p[i, 1] == pytest.approx(C / 2, abs=1e-6 * W)
    assert loop.length > 0 and R < loop.d < 1.1 * R


# -- topology ----------------------------------------------------------------------------------

def test_every_loop_passes_over_the_head_below_and_hooks_behind_its_legs(swatch):
    """Loop (k, j) and loop (k-1, j) cross 4 times in the x-y projection, two on each side
    of the wale, with opposite over/under on each side (interlocked).  The upper crossing
    of each side, on the head of k-1, has course k on top: the knit face is +z.  Loops
    that do not interlock do not cross at all."""
    yarn = swatch.yarns[0]
    for k in range(1, NC):
        for j in range(NW):
            a, b = loop_polyline(yarn, k, j), loop_polyline(yarn, k - 1, j)
            x = projected_crossings(a, b)
            for side in _sides(x, j * W):
                assert _interlocked(side), (k, j, x)
                upper = side[np.argmax(side[:, 4])]
                assert upper[2] > 0, (k, j)          # leg of k in front of the head of k-1
            if k >= 2:
                assert len(projected_crossings(a, loop_polyline(yarn, k - 2, j))) == 0
            if j + 1 < NW:
                assert len(projected_crossings(a, loop_polyline(yarn, k - 1, j + 1))) == 0


def test_bindoff_helices_thread_every_head_on_top_and_every_sinker_below(swatch):
    """The top helix crosses each head of the top course twice with opposite over/under;
    the bottom helix does the same with each inner sinker of course 0 (between wales)."""
    knit, bottom, top = swatch.yarns
    assert bottom.bindoff and top.bindoff and not knit.bindoff
    for j in range(NW):
        x = projected_crossings(top.points, loop_polyline(knit, NC - 1, j))
        assert _interlocked(x), (j, x)
    course0 = knit.points[:np.nonzero(knit.course == 1)[0][0]]
    x = projected_crossings(bottom.points, course0)
    for j in range(NW - 1):
        near = x[np.abs(x[:, 3] - (j + 0.5) * W) < 0.5 * W]
        assert _interlocked(near), (j, near)


# -- clearance -------------------------------------------------------------------------------

def test_yarns_never_interpenetrate(swatch):
    """Centrelines of different yarns, or of one yarn more than 4 r apart along it, stay
    >= 0.95 * 2r apart (point pairs 0.4 r apart along the yarns); every bend is wider than
    the yarn radius."""
    ratio, where = clearance([y.points for y in swatch.yarns], R, exclude=4 * R)
    assert ratio >= 0.95, where
    assert min(np.nanmin(bend_radii(y.points)) for y in swatch.yarns) >= R


def test_yarns_touch_at_the_interlocking_crossings(swatch):
    """At every interlock crossing (knit and bind-off) the two strands come within
    2r (1 + 10 %) of each other, and no closer than 0.95 * 2r."""
    knit, bottom, top = swatch.yarns
    pairs = [(loop_polyline(knit, k, j), loop_polyline(knit, k - 1, j))
             for k in range(1, NC) for j in range(NW)]
    pairs += [(top.points, loop_polyline(knit, NC - 1, j)) for j in range(NW)]
    gaps = []
    for a, b in pairs:
        for row in projected_crossings(a, b):
            gaps.append(approach_near(a, b, row[3:5], 2 * R) / (2 * R))
    assert len(gaps) == 4 * (NC - 1) * NW + 2 * NW
    assert 0.95 <= min(gaps) and max(gaps) <= 1.10, (min(gaps), max(gaps))


@pytest.mark.parametrize("n_wale, n_course, bindoff", [(1, 1, True), (1, 2, False), (2, 1, True),
                                                      (4, 4, True), (4, 4, False)])
def test_small_and_even_swatches_clear_too(n_wale, n_course, bindoff):
    """Single wales and courses, an even course count (the yarn ends on the left) and no
    bind-off: clearance >= 0.95 * 2r as above, the counts as asked."""
    s = plain_knit_swatch(n_wale, n_course, W, C, R, points_per_loop=96, bindoff=bindoff)
    assert len(s.yarns) == (3 if bindoff else 1)
    assert s.loop_lengths.shape == (n_course, n_wale)
    ratio, where = clearance([y.points for y in s.yarns], R, exclude=4 * R)
    assert ratio >= 0.95, where


@pytest.mark.slow
@pytest.mark.parametrize("r_over_w, where", [(0.124, "low"), (0.124, "high"), (0.05, "low"),
                                             (0.01, "low"), (0.1, "one")])
def test_geometry_holds_across_the_valid_range(r_over_w, where):
    """Corners of the valid range (radius up to w/8, c at its bounds): a 3 x 3 swatch still
    interlocks everywhere, clears 0.95 * 2r and bends no tighter than r."""
    w, r = 1.0, r_over_w
    lo, hi = course_length_range(w, r)
    c = {"low": lo, "high": min(hi, 4 * w), "one": w}[where]
    ppl = int(min(4000, max(96, 5 * knit_loop(w, c, r).length / r)))
    s = plain_knit_swatch(3, 3, w, c, r, points_per_loop=ppl)
    ratio, where_ = clearance([y.points for y in s.yarns], r, exclude=4 * r)
    assert ratio >= 0.95, where_
    assert min(np.nanmin(bend_radii(y.points)) for y in s.yarns) >= r
    for k in (1, 2):
        for j in range(3):
            x = projected_crossings(loop_polyline(s.yarns[0], k, j),
                                    loop_polyline(s.yarns[0], k - 1, j))
            assert all(_interlocked(side) for side in _sides(x, j * w))


# -- one serpentine yarn ---------------------------------------------------------------------

def test_one_serpentine_yarn_knits_the_courses_in_alternating_directions(swatch):
    """Yarn 0 visits courses 0, 1, ..., NC-1 in order, even courses left to right, odd
    ones right to left, turning around beyond the last wale (x beyond the sinkers)."""
    knit = swatch.yarns[0]
    assert np.all(np.diff(knit.course) >= 0) and set(knit.course) == set(range(NC))
    for k in range(NC):
        on = (knit.course == k) & ~knit.turn
        dx = np.sum(np.diff(knit.points[:, 0])[on])
        assert dx == pytest.approx((1 if k % 2 == 0 else -1) * NW * W, rel=1e-9)
    turns = knit.points[1:][knit.turn]
    assert np.all((turns[:, 0] >= (NW - 0.5) * W - 1e-9) | (turns[:, 0] <= -0.5 * W + 1e-9))


@pytest.mark.parametrize("yarn", [0, 1, 2])
def test_yarns_are_continuous_in_position_and_tangent(yarn):
    """No gap: every chord is within 25 % of the nominal spacing (loop length / points
    per loop).  No kink: the angle between consecutive chords is O(h) everywhere,
    including at the joins loop|loop and loop|turn-around, where it shrinks ~4x when the
    spacing does from 48 to 192 points per loop (>= 3x required; a kink would not
    shrink); stored tangents agree with central differences to 3 degrees at 96 points
    per loop (the largest, 2.5 degrees, is
    where a turn-around meets a sinker and the curvature flips sign: C1, not C2)."""
    angles = {}
    for ppl in (48, 96, 192):
        s = plain_knit_swatch(4, 3, W, C, R, points_per_loop=ppl)
        y = s.yarns[yarn]
        chord = np.diff(y.points, axis=0)
        length = np.linalg.norm(chord, axis=1)
        nominal = s.yarn_length_per_loop / ppl
        assert np.all(np.abs(length / nominal - 1) < 0.25), (length.min(), length.max())
        u = chord / length[:, None]
        turn = np.degrees(np.arccos(np.clip(np.sum(u[1:] * u[:-1], axis=1), -1, 1)))
        angles[ppl] = turn
        if yarn == 0:
            assert len(y.joins) == (3 * (4 - 1)) + 2 * 2
            angles[ppl, "joins"] = turn[y.joins - 1]
        central = y.points[2:] - y.points[:-2]
        central /= np.linalg.norm(central, axis=1, keepdims=True)
        off = np.degrees(np.arccos(np.clip(np.sum(central * y.tangents[1:-1], axis=1), -1, 1)))
        if ppl == 96:
            assert off.max() < 3.0
    assert angles[48].max() / angles[192].max() > 3.0
    if yarn == 0:
        assert angles[48, "joins"].max() / angles[192, "joins"].max() > 3.0


def test_yarn_length_per_loop_is_reported_and_matches_the_discretised_loops(swatch):
    """Closed-form loop length > 0 (15.6 mm here, ~3.9 w as in relaxed plain knits); the
    96-chord loops are shorter by the chord deficit only (< 0.1 %) and all equal."""
    L = swatch.yarn_length_per_loop
    assert 3.5 * W < L < 4.5 * W
    loops = swatch.loop_lengths
    assert loops.shape == (NC, NW)
    assert np.all(loops < L) and np.all(loops > (1 - 1e-3) * L)
    assert np.ptp(loops) < 1e-9 * L


# -- output and exports ------------------------------------------------------------------------

def test_swatch_mesh_carries_tangents_radius_and_segment_labels(tmp_path):
    """One line cell per segment; point data tangent (unit) and radius; cell data yarn,
    course, wale, bindoff round-trip through a .vtu; the render is a non-blank PNG."""
    s = plain_knit_swatch(2, 2, W, C, R)
    mesh = swatch_mesh(s)
    assert mesh.cells_dict["line"].shape == (len(s.segments), 2)
    assert np.allclose(np.linalg.norm(mesh.point_data["tangent"], axis=1), 1.0)
    paths = write_swatch(s, tmp_path, render=True, window_size=(320, 240))
    back = meshio.read(paths[0])
    assert np.allclose(back.points, s.points)
    assert np.allclose(back.point_data["radius"], R)
    for name, values in (("yarn", s.segment_yarn), ("course", s.segment_course),
                         ("wale", s.segment_wale), ("bindoff", s.segment_bindoff)):
        assert np.array_equal(back.cell_data[name][0], values.astype(int)), name
    assert set(back.cell_data["course"][0]) == {-1, 0, 1, 2}
    pytest.importorskip("pyvista")
    from matplotlib.image import imread
    image = imread(paths[1])
    assert image.shape[:2] == (240, 320) and image[..., :3].std() > 0.05


def test_knit_command_writes_the_swatch_and_a_summary(tmp_path):
    """The body of the proposed ``knitfem knit``: argparse options, .vtu, JSON summary
    with the loop's shape numbers and, with --check, the measured clearance."""
    import json
    from knitfem.cli import main
    out, js = tmp_path / "run", tmp_path / "knit.json"
    assert main(["knit", "--nw", "2", "--nc", "3", "--out", str(out), "--check",
                 "--json", str(js), "--no-render", "--quiet"]) == 0
    summary = json.loads(js.read_text())
    assert (out / "knit_2x3.vtu").exists() and not (out / "knit_2x3.png").exists()
    assert summary["loop"]["yarn_length_per_loop"] == pytest.approx(knit_loop(W, C, R).length)
    assert summary["check"]["interlocked_loop_pairs"] == summary["check"]["loop_pairs"] == 4
    assert summary["check"]["clearance_over_2r"] >= 0.95
    with pytest.raises(ValueError, match="^radius must"):
        knit(2, 2, radius=1.0)
    assert main(["knit", "--nw", "0", "--quiet"]) == 2            # a message, not a traceback


def test_rods_start_naturally_straight_bent_into_the_knit(swatch):
    """One Rod per yarn through the centreline points, naturally straight (zero natural
    curvature, unit stretch), first director along the yarn tangent."""
    rods = as_rods(swatch, Section.circle(2 * R, E=1.0))
    assert len(rods) == 3
    for rod, y in zip(rods, swatch.yarns):
        assert np.array_equal(rod.X, y.points) and rod.n_elements == len(y.points) - 1
        assert np.all(rod.kappa0 == 0) and np.all(rod.gamma0[:, 0] == 1)
        assert rod.length == pytest.approx(y.length)


def test_bspline_fit_reproduces_the_centrelines(swatch):
    """Least-squares uniform cubic B-splines, 24 segments per loop: every centreline point
    is within 0.05 r of the spline (evaluated 40x per segment); the error falls with the
    segment count (16 -> 24 per loop)."""
    errors = {}
    for per in (16, 24):
        worst = 0.0
        for q, y in zip(swatch_control_points(swatch, per), swatch.yarns):
            dense = curve.evaluate(q, np.linspace(0, 1, 40)).reshape(-1, 3)
            worst = max(worst, cKDTree(dense).query(y.points)[0].max() / R)
        errors[per] = worst
    assert errors[24] < 0.05 and errors[16] > errors[24]
    q = bspline_control_points(swatch.yarns[1].points, 10)
    assert q.shape == (13, 3)


# -- bad input ---------------------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, name", [
    ({"n_wale": 0}, "n_wale"), ({"n_wale": 2.5}, "n_wale"), ({"n_wale": True}, "n_wale"),
    ({"n_wale": "3"}, "n_wale"), ({"n_course": -1}, "n_course"),
    ({"n_course": float("nan")}, "n_course"),
    ({"w": float("nan")}, "w"), ({"w": -4.0}, "w"), ({"w": 0.0}, "w"),
    ({"c": float("inf")}, "c"), ({"c": -3.0}, "c"), ({"c": "x"}, "c"),
    ({"radius": 0.0}, "radius"), ({"radius": float("nan")}, "radius"),
    ({"radius": W / 4}, "radius"), ({"radius": W / 8}, "radius"),
    ({"c": 4.9 * R}, "c"), ({"c": 0.41 * W * W / R}, "c"), ({"radius": 0.1, "c": 4.1 * W}, "c"),
    ({"points_per_loop": 4}, "points_per_loop"),
])
def test_bad_input_names_the_parameter_and_its_valid_range(kwargs, name):
    args = {"n_wale": 3, "n_course": 3, "w": W, "c": C, "radius": R} | kwargs
    with pytest.raises(ValueError, match=rf"^{name} must") as err:
        plain_knit_swatch(**args)
    assert any(s in str(err.value) for s in ("(0, inf)", ">=", "<", "in ["))


def test_tail_ties_hold_each_tail_end_or_its_last_points_by_their_two_nearest(swatch):
    """One tie per tail end to the other yarn's nearest point (the default);
    with ``tail_nodes`` n the last n points of each of the six tails, each
    tied to the two nearest points of the other yarn; bad counts refused."""
    from knitfem.geometry.swatch import swatch_ties
    one = swatch_ties(swatch)
    assert len(one) == 6 and len(set(one)) == 6
    knit = swatch.yarns[0].points
    assert {(ya, pa) for ya, pa, _, _ in one} == {
        (0, 0), (0, len(knit) - 1), (1, 0), (1, len(swatch.yarns[1].points) - 1),
        (2, 0), (2, len(swatch.yarns[2].points) - 1)}
    for ya, pa, yb, pb in one:
        d = np.linalg.norm(swatch.yarns[yb].points - swatch.yarns[ya].points[pa], axis=1)
        assert d[pb] == d.min() and yb != ya
    two = swatch_ties(swatch, 2)
    assert len(two) == 24 and len(set(two)) == 24 and set(one) <= set(two)
    for ya, pa, yb, pb in two:
        d = np.linalg.norm(swatch.yarns[yb].points - swatch.yarns[ya].points[pa], axis=1)
        assert d[pb] <= np.partition(d, 1)[1]           # one of the two nearest
    for bad in (0, 5, 1.5, True):
        with pytest.raises(ValueError, match="tail_nodes must be an integer in"):
            swatch_ties(swatch, bad)
