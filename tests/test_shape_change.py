"""Shape change with rigid motion taken out, and principal extents (closed forms)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from knitfem.analysis.shape_change import principal_extents, shape_change


def _cloud(n=200, seed=0):
    return np.random.default_rng(seed).normal(size=(n, 3)) * [30.0, 10.0, 3.0]


def test_a_rigid_motion_is_no_change_of_shape():
    x = _cloud()
    turn = Rotation.from_rotvec(np.radians(73.0) * np.array([1.0, 2.0, -0.5]) / np.sqrt(5.25))
    change = shape_change(x, turn.apply(x) + [5.0, -7.0, 2.0])
    assert change.max < 1e-9
    assert change.rotation_deg == pytest.approx(73.0, abs=1e-9)
    # the centroid moves by the translation plus the turned centroid's offset
    assert change.shift == pytest.approx(np.linalg.norm(turn.apply(x.mean(0)) - x.mean(0)
                                                        + [5.0, -7.0, 2.0]), rel=1e-12)


def test_a_stretch_is_measured_whatever_the_rigid_motion_on_top():
    # mirrored in each coordinate plane: the cross-covariance of a stretch is then
    # diagonal and positive, so the best rotation is the identity (Kabsch)
    base = _cloud(50)
    x = np.concatenate([base * s for s in ([1, 1, 1], [-1, 1, 1], [1, -1, 1], [1, 1, -1],
                                           [-1, -1, 1], [-1, 1, -1], [1, -1, -1], [-1, -1, -1])])
    stretched = (x - x.mean(0)) * [1.1, 1.0, 1.0] + x.mean(0)
    plain = shape_change(x, stretched)
    turned = shape_change(x, Rotation.from_euler("z", 40, degrees=True).apply(stretched) + 3.0)
    # a 10 % stretch along the longest axis about the centroid: moves 0.1 |x - c|_x
    expected = 0.1 * np.abs(x[:, 0] - x[:, 0].mean())
    assert plain.max == pytest.approx(expected.max(), rel=1e-6)
    assert plain.median == pytest.approx(np.median(expected), rel=1e-6)
    assert turned.median == pytest.approx(plain.median, rel=1e-9)
    assert turned.rotation_deg == pytest.approx(40.0, abs=1e-6)


def test_principal_extents_of_a_turned_box():
    corners = np.array([[i, j, k] for i in (0, 40) for j in (0, 25) for k in (0, 4)], float)
    turned = Rotation.from_euler("xyz", [20, -35, 60], degrees=True).apply(corners) + 9.0
    assert principal_extents(turned) == pytest.approx((40.0, 25.0, 4.0), rel=1e-12)


@pytest.mark.parametrize("bad", [np.zeros((5, 2)), np.full((4, 3), np.nan), np.zeros((2, 3))])
def test_bad_positions_are_refused_by_name(bad):
    with pytest.raises(ValueError, match="x_from"):
        shape_change(bad, np.zeros((5, 3)))


def test_a_friction_round_of_a_free_swatch_is_measured_without_its_rigid_motion():
    """round_move (the fabric relaxation's settle test): node coordinates and
    surface points (frame turn x arm).  A rigid motion of positions *and*
    frames is no move for a free-floating scene, the whole of it for a held
    one; a change of shape or a frame twisted on its own counts in both."""
    from types import SimpleNamespace
    from knitfem.beam.rotation import quat_exp, quat_multiply
    from knitfem.scenes.fabric_rounds import round_move
    rng = np.random.default_rng(3)
    x = _cloud(120)
    q = quat_exp(rng.normal(size=(120, 3)))
    turn = Rotation.from_rotvec([0.3, -0.2, 0.5])
    wxyz = np.roll(turn.as_quat(), 1)
    moved_x = turn.apply(x) + [0.5, 0.1, -0.2]
    moved_q = quat_multiply(np.broadcast_to(wxyz, q.shape), q)
    # the convention checked independently: the frames turned in space by the rotation
    from knitfem.beam.rotation import rotation_matrix
    assert np.allclose(rotation_matrix(moved_q), turn.as_matrix() @ rotation_matrix(q),
                       atol=1e-12)
    old = SimpleNamespace(x=x, q=q)
    rigid = SimpleNamespace(x=moved_x, q=moved_q)
    assert round_move(old, rigid, 0.4, free=True) < 1e-9
    assert round_move(old, rigid, 0.4, free=False) > 1.0
    # one node pushed by 0.01 along y on top of the rigid motion: ~that push
    # (the fit spreads it over the others by ~1/n)
    pushed = moved_x.copy()
    pushed[7, 1] += 0.01
    change = round_move(old, SimpleNamespace(x=pushed, q=moved_q), 0.4, free=True)
    assert change == pytest.approx(0.01, rel=0.02)
    # one frame twisted by 0.05 rad about its own axis: a surface point moves 0.4 x 0.05
    twisted = moved_q.copy()
    twisted[11] = quat_multiply(quat_exp(np.array([[0.0, 0.0, 0.05]])), moved_q[11:12])[0]
    change = round_move(old, SimpleNamespace(x=moved_x, q=twisted), 0.4, free=True)
    assert change == pytest.approx(0.4 * 0.05, rel=1e-6)
