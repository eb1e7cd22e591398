"""Roll profiles (knitfem.analysis.profile) on the synthetic bent swatches of
test_curl_analysis: a cylinder turns evenly (no local roll), a flat sheet with
rolled edges turns only at its edges (the local roll is the whole roll), and a
gently bent sheet with rolled edges splits into the two, each known in closed
form."""
import math

import numpy as np
import pytest

from knitfem.analysis import swatch_curl
from knitfem.analysis.profile import roll_profile, swatch_roll_profile

from test_curl_analysis import W, deform, wide  # noqa: F401  (fixture)


def test_cylinder_turns_evenly_with_no_local_roll(wide):  # noqa: F811
    """Rows on a cylinder of radius 15 mm: the interior slope is the
    curvature of the centroids' circle, the profile a straight line through it
    and the local rolls 0 to round-off; the rolls are all bulk."""
    pts = deform(wide, x=(0.0, 15.0, -1))
    profile, shape = swatch_roll_profile(pts, wide), swatch_curl(pts, wide)
    assert profile.interior_curvature_x == pytest.approx(shape.curvature_x, rel=1e-9)
    assert all(abs(profile.local_roll_deg[e]) < 1e-9 for e in profile.local_roll_deg)
    assert np.degrees(profile.interior_curvature_x * profile.s_x) == pytest.approx(
        profile.theta, abs=1e-9)
    # theta is relative to the centre: the left edge's angle is minus its roll
    assert -profile.theta[0] == pytest.approx(shape.roll_deg["left"], abs=1e-9)


def test_flat_middle_with_rolled_edges_is_all_local_roll(wide):  # noqa: F811
    """15 wales, flat for |x| <= 18.5 mm, rolled to the back beyond on radius
    5 mm: the interior (centres within 15/4 wales of the centre, to 12 mm) and
    the chords to its neighbours (loops to 18 mm) lie flat, so the interior
    slope is 0 and each edge's local roll its whole roll, about (28 - 18.5)/5
    rad."""
    pts = deform(wide, x=(18.5, 5.0, -1))
    profile, shape = swatch_roll_profile(pts, wide), swatch_curl(pts, wide)
    assert abs(profile.interior_curvature_x) < 1e-12
    for edge in ("left", "right"):
        assert profile.local_roll_deg[edge] == pytest.approx(shape.roll_deg[edge], abs=1e-9)
        assert shape.roll_deg[edge] < -math.degrees(2 * W / 5.0)   # more than two loops' turn
    assert abs(profile.local_roll_deg["top"]) < 1e-9


def test_bent_sheet_with_rolled_edges_splits_into_bulk_and_local(wide):  # noqa: F811
    """The same rolled edges on a sheet bent gently along y (radius 60 mm, to
    the front): the columns' interior slope is 1/60 per mm within the
    centroid offset (1.5 %), the top/bottom local rolls 0 (even bending only),
    while the classification's top/bottom rolls are that bend's 6 courses x
    3 mm / 60 mm (17.2 deg: all bulk), and the side edges' local rolls within
    0.01 deg of the unbent sheet's (the band's off-centre rows are tilted by
    the y bend, which foreshortens their projected turning: 8e-4 deg
    measured)."""
    flat = swatch_roll_profile(deform(wide, x=(18.5, 5.0, -1)), wide)
    bent = swatch_roll_profile(deform(wide, x=(18.5, 5.0, -1), y=(0.0, 60.0, +1)), wide)
    assert bent.interior_curvature_y * 60.0 == pytest.approx(1.0, rel=0.015)
    assert abs(bent.local_roll_deg["top"]) < 1e-6 and abs(bent.local_roll_deg["bottom"]) < 1e-6
    for edge in ("left", "right"):
        assert bent.local_roll_deg[edge] == pytest.approx(flat.local_roll_deg[edge], abs=0.01)
    shape = swatch_curl(deform(wide, x=(18.5, 5.0, -1), y=(0.0, 60.0, +1)), wide)
    assert shape.roll_deg["top"] == pytest.approx(math.degrees(6 * 3.0 / 60.0), rel=0.015)


@pytest.mark.parametrize("centres, word", [(np.zeros((3, 5, 3)), "shape"),
                                           (np.full((5, 5, 3), np.nan), "finite")])
def test_bad_centres_name_the_parameter(centres, word):
    with pytest.raises(ValueError, match=f"centres must .*{word}"):
        roll_profile(centres)
