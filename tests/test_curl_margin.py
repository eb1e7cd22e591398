"""The curl type against the roll threshold (knitfem.analysis.margin): the
intervals tile (0, upper], change only at an edge pair's larger roll, and at
every threshold agree with the classification of the synthetic sheets of
test_curl_analysis (a cylinder about y, a doubly curled sheet)."""
import pytest

from knitfem.analysis import curl_type, curl_type_intervals, swatch_curl, threshold_range
from knitfem.geometry import plain_knit_swatch

from test_curl_analysis import deform

W, C, R = 4.0, 3.0, 0.4


def test_tube_with_flared_ends_reads_double_then_side_then_flat():
    """The 10 x 35 at alpha 0.2 (README): side pair -343 deg, top/bottom +106."""
    roll = {"left": -343.0, "right": -337.0, "top": 104.0, "bottom": 106.0}
    assert curl_type_intervals(roll, False) == [(0.0, 106.0, "double"),
                                               (106.0, 343.0, "side"), (343.0, 360.0, "flat")]
    assert threshold_range(roll, False, "side") == [(106.0, 343.0)]
    assert threshold_range(roll, False, "top_bottom") == []


def test_touching_edges_make_top_bottom_at_every_threshold_below_the_roll():
    roll = {"left": -232.0, "right": -237.0, "top": 587.0, "bottom": 630.0}
    assert curl_type_intervals(roll, True) == [(0.0, 360.0, "top_bottom")]
    assert curl_type_intervals(roll, True, upper=700.0) == [(0.0, 630.0, "top_bottom"),
                                                           (630.0, 700.0, "flat")]


@pytest.mark.parametrize("roll, touch", [
    ({"left": -10.0, "right": 5.0, "top": 3.0, "bottom": -2.0}, False),
    ({"left": 40.0, "right": -90.0, "top": 90.0, "bottom": 0.0}, False),   # equal pair rolls
    ({"left": 0.0, "right": 0.0, "top": 0.0, "bottom": 0.0}, True),
    ({"left": -500.0, "right": 1.0, "top": 20.0, "bottom": -35.0}, True),
])
def test_intervals_tile_the_range_and_match_the_rule(roll, touch):
    intervals = curl_type_intervals(roll, touch)
    assert intervals[0][0] == 0.0 and intervals[-1][1] == 360.0
    for (_, high, kind), (low, _, nxt) in zip(intervals, intervals[1:]):
        assert high == low and kind != nxt          # contiguous, merged
    for low, high, kind in intervals:
        for t in (low + 1e-9, 0.5 * (low + high), high):
            assert curl_type(roll, touch, t) == kind


@pytest.mark.parametrize("bends", [{"x": (0.0, 12.0, -1)},
                                   {"x": (6.0, 6.0, -1), "y": (9.0, 5.0, +1)}])
def test_agrees_with_the_classification_of_synthetic_sheets(bends):
    swatch = plain_knit_swatch(9, 13, W, C, R)
    pts = deform(swatch, **bends)
    shape = swatch_curl(pts, swatch)
    intervals = curl_type_intervals(shape.roll_deg, shape.edges_touch)
    # on a roll: curled (>=); curl_shape takes thresholds in (0, 180)
    exact = [abs(v) for v in shape.roll_deg.values() if 1e-6 < abs(v) < 180.0]
    assert exact
    for threshold in (5.0, 30.0, 60.0, 90.0, 100.0, 150.0, *exact):
        expect = swatch_curl(pts, swatch, roll_threshold=threshold).curl
        got = [k for lo, hi, k in intervals if lo < threshold <= hi]
        assert got == [expect], threshold


@pytest.mark.parametrize("roll, upper, name", [
    ({"left": 1.0, "right": 1.0, "top": 1.0}, 360.0, "roll_deg must give a number"),
    ({"left": None, "right": 1.0, "top": 1.0, "bottom": 1.0}, 360.0, "roll_deg must give"),
    ({"left": float("nan"), "right": 1.0, "top": 1.0, "bottom": 1.0}, 360.0,
     "roll_deg must be finite"),
    ({"left": 1.0, "right": 1.0, "top": 1.0, "bottom": 1.0}, -5.0, "upper"),
])
def test_bad_input_names_the_parameter(roll, upper, name):
    with pytest.raises(ValueError, match=name):
        curl_type_intervals(roll, False, upper)


def test_a_nan_roll_is_refused_whichever_edge_holds_it():
    """max() with a NaN depends on the order: refused, not a type either way."""
    for roll in ({"left": float("nan"), "right": 50.0, "top": 0.0, "bottom": 0.0},
                 {"left": 50.0, "right": float("nan"), "top": 0.0, "bottom": 0.0}):
        with pytest.raises(ValueError, match="roll_deg must be finite"):
            curl_type(roll, False, 30.0)


def test_an_unknown_type_is_refused():
    with pytest.raises(ValueError, match="kind must be one of"):
        threshold_range({"left": 1.0, "right": 1.0, "top": 1.0, "bottom": 1.0}, False,
                        "top/bottom")
