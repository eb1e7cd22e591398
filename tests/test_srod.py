"""The S-rod pop-up (paper Fig. 4): planar branch, critical point, popped branches."""
import numpy as np
import pytest

from knitfem.beam.parametric import ParametricProblem
from knitfem.scenes.srod import SRod, out_of_plane, popup


@pytest.fixture(scope="module")
def result():
    return popup(SRod(elements=60))


def test_planar_branch_stays_exactly_planar_before_the_critical_point(result):
    L = result.srod.length
    before = [p for p in result.planar.points if p.lam > result.critical_c_over_L]
    assert len(before) > 5
    assert max(np.abs(p.state.x[:, 2]).max() for p in before) <= 1e-10 * L
    assert all(p.stable for p in before)


def test_critical_point_comes_from_the_generic_detector(result):
    """The first event on the planar branch is an out-of-plane simple
    bifurcation (inertia 0 -> 1), located in lam = c/L to 1e-8; it is not a
    threshold on z (z is exactly zero on the planar branch)."""
    event = result.planar.events[0]
    assert event.kind == "bifurcation" and out_of_plane(result.problem, event)
    assert (event.negative_before, event.negative_after) == (0, 1)
    assert 0 < event.bracket <= 1e-8 and event.lam == result.critical_c_over_L
    assert 0.70 < result.critical_c_over_L < 0.76      # paper: pop-up below c/L ~ 0.7


def test_popped_branches_are_stable_mirror_images(result):
    plus, minus = result.popped
    for branch, sign in ((plus, 1), (minus, -1)):
        assert branch.status == "completed" and branch.points[-1].lam == result.c_to
        assert branch.points[0] is result.planar.events[0].point      # starts at the fork
        assert all(p.stable for p in branch.points[1:])
        z_mid = np.array([p.state.x[len(p.state.x) // 2, 2] for p in branch.points[1:]])
        assert np.all(np.sign(z_mid) == sign)
    a, b = plus.points[-1].state.x, minus.points[-1].state.x
    assert np.allclose(a[:, :2], b[:, :2], atol=1e-8) and np.allclose(a[:, 2], -b[:, 2], atol=1e-8)


def test_sampled_path_is_planar_then_popped_and_stable(result):
    z = {round(s.c_over_L, 6): s.max_abs_z_over_L for s in result.samples}
    assert [round(s.c_over_L, 2) for s in result.samples] == \
        [0.95, 0.9, 0.85, 0.8, 0.75, 0.7, 0.65, 0.6, 0.55, 0.5, 0.45]
    assert all(s.stable for s in result.samples)
    assert z[0.75] == 0.0 and z[0.7] > 0.05
    heights = [s.max_abs_z_over_L for s in result.samples if s.c_over_L < result.critical_c_over_L]
    assert np.all(np.diff(heights) > 0)                      # grows as c shrinks


def test_critical_course_length_converges_under_refinement():
    """Successive differences of c_crit/L shrink at least 3x per doubling (15..120)."""
    crit = [popup(SRod(elements=n), c_to=0.6).critical_c_over_L for n in (15, 30, 60, 120)]
    d = np.abs(np.diff(crit))
    assert np.all(d[:-1] / d[1:] >= 3.0)


def test_continuation_tangent_derivative_in_c_is_exact():
    """dR/dlam from the supports' velocity matches central differences."""
    model = SRod(elements=12).model(0.9)
    problem = ParametricProblem(model)
    state = model.initial_state()
    _, _, R_lam, _ = problem.evaluate(state, 0.9)
    e = 1e-6
    fd = (problem.evaluate(problem.state_at(state, 0.9 + e), 0.9 + e, False)[0]
          - problem.evaluate(problem.state_at(state, 0.9 - e), 0.9 - e, False)[0]) / (2 * e)
    assert np.linalg.norm(fd - R_lam) < 1e-6 * np.linalg.norm(R_lam)


@pytest.mark.parametrize("kwargs,match", [
    (dict(w=110.0), r"w must be smaller than the rod length L = 105 \(valid: 0 < w/L < 1\)"),
    (dict(w=-1.0), r"w must be finite and in \(0, inf\)"),
    (dict(elements=3), r"elements must be an integer >= 4"),
    (dict(length=float("nan")), r"length must be finite"),
    (dict(diameter=0.0), r"diameter must be finite and in \(0, inf\)"),
    (dict(poisson=0.8), r"nu \(Poisson ratio\) must be in"),
])
def test_bad_scene_parameters_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SRod(**kwargs)


@pytest.mark.parametrize("c_from,c_to,match", [
    (0.99, 0.45, r"c_from must be in \(0, sqrt\(1 - \(w/L\)\^2\)\) = \(0, 0.962727\)"),
    (0.95, 0.0, r"c_to must be in \(0, "),
    (0.5, 0.7, r"c_to must be smaller than c_from"),
    (float("nan"), 0.5, r"c_from must be in"),
])
def test_impossible_clamp_geometry_is_refused(c_from, c_to, match):
    with pytest.raises(ValueError, match=match):
        popup(SRod(elements=8), c_from=c_from, c_to=c_to)


def test_bspline_model_agrees_with_the_beam_without_torsional_stiffness():
    """Cross-check of two independent models (issue 4): the B-spline yarn model
    has no twist energy, so it is compared with the beam at GJ/EI = 1e-3:
    max|z|/L at c/L = 0.7, 0.6, 0.5 within 0.02, critical c/L within 0.01."""
    from knitfem.scenes.srod_bspline import bspline_popup
    beam = popup(SRod(gj_over_ei=1e-3), c_from=0.8, c_to=0.5, c_step=0.1)
    yarn = bspline_popup(SRod(), c_from=0.8, c_to=0.5, c_step=0.1, segments=32)
    z_beam = {round(s.c_over_L, 2): s.max_abs_z_over_L for s in beam.samples}
    z_yarn = {round(s.c_over_L, 2): s.max_abs_z_over_L for s in yarn.samples}
    for c in (0.7, 0.6, 0.5):
        assert abs(z_beam[c] - z_yarn[c]) < 0.02, (c, z_beam[c], z_yarn[c])
    assert abs(beam.critical_c_over_L - yarn.critical_c_over_L) < 0.01
    lo, hi = yarn.critical_bracket
    assert hi - lo <= 2e-3 and z_yarn[0.8] < 1e-4


def test_sampling_just_below_the_critical_point_lands_on_the_popped_branch():
    """Issue 10, case 4: samples a few 1e-4 below c_crit used to land from the
    bifurcation point and stay in the (unstable) plane.  Now every sample
    below c_crit is popped (z > 0) and stable, and the heights follow the
    normal form of a supercritical pitchfork, z^2 / (c_crit - c) constant
    (within 2 % over the first 6e-4 below c_crit; measured 0.04 %)."""
    result = popup(SRod(), c_from=0.733, c_to=0.730, c_step=1e-4)
    c_crit = result.critical_c_over_L
    below = [s for s in result.samples if s.c_over_L < c_crit]
    assert len(below) >= 25
    assert all(s.stable and s.max_abs_z_over_L > 0 for s in below)
    assert all(s.stable and s.max_abs_z_over_L == 0 for s in result.samples
               if s.c_over_L > c_crit)
    near = [s for s in below if c_crit - s.c_over_L < 6e-4]
    ratio = [s.max_abs_z_over_L**2 / (c_crit - s.c_over_L) for s in near]
    assert len(near) >= 5 and np.ptp(ratio) < 0.02 * np.mean(ratio)
    state = result.state_at(c_crit - 1e-4)
    _, J, _, _ = result.problem.evaluate(state, c_crit - 1e-4, True)
    from knitfem.solve.stability import negative_eigenvalue_count
    assert np.abs(state.x[:, 2]).max() > 0.004 * result.srod.length
    assert negative_eigenvalue_count(J) == 0


def test_popup_runs_small_problems_on_one_thread():
    """Issue 10, case 7: the sweep pins BLAS (threadpoolctl) and numba to one
    thread while it runs (seen from inside, through the progress callback),
    and restores the pools afterwards; pin_threads=False leaves them."""
    import numba
    from threadpoolctl import threadpool_info
    def pools():
        return {p["filepath"]: p["num_threads"] for p in threadpool_info()}

    before, seen = pools(), []

    def look(point):
        seen.append((pools(), numba.get_num_threads()))

    popup(SRod(elements=12), c_from=0.8, c_to=0.75, c_step=0.05, progress=look)
    assert seen and all(set(blas.values()) == {1} and nb == 1 for blas, nb in seen)
    assert all(pools()[k] == v for k, v in before.items())
    seen.clear()
    popup(SRod(elements=12), c_from=0.8, c_to=0.75, c_step=0.05, progress=look,
          pin_threads=False)
    assert seen and all(blas[k] == v for blas, _ in seen for k, v in before.items())
