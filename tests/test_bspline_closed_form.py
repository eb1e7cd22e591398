"""B-spline yarn physics against closed forms: a cantilever under its own
weight, the tip-loaded elastica (the beam tests' reference), Euler buckling
seen by the stability check, and the stability of the pop-up's states."""
import numpy as np
import pytest

from knitfem.bspline import BSplineModel, Yarn, curve, relax_newton, stability
from knitfem.verify import closed_form


def cantilever(length, segments, EA, EI, **kwargs):
    pts = np.stack([np.linspace(0, length, 400), np.zeros(400), np.zeros(400)], axis=1)
    model = BSplineModel([Yarn.through(pts, segments, EA, EI, natural="straight",
                                       length=length)], **kwargs)
    model.clamp(0, "start")
    return model


def tip(model, y):
    return curve.evaluate(model.control_points(y), np.array([1.0]))[-1, 0]


def test_cantilever_under_its_own_weight_deflects_q_L4_over_8_EI():
    """Small deflection (1e-4 L): tip w = q L^4 / (8 EI) within 1e-4 relative
    (measured 3e-6 at 16 segments; the rest of the error is geometric
    nonlinearity ~ (w/L)^2 and round-off).  Doubling gravity or the bending
    energy changes it by a factor 2."""
    L, EI, rho, g = 1.0, 2.0, 0.5, 3.2e-3
    model = cantilever(L, 16, 1e4 * EI / L**2, EI, gravity=(0, 0, -g))
    model.rho[:] = rho
    result = relax_newton(model, model.reduce(model._initial()), rtol=1e-11)
    w = -tip(model, result.y)[2]
    assert w / (rho * g * L**4 / (8 * EI)) == pytest.approx(1.0, abs=1e-4)


def test_tip_loaded_elastica_matches_bisshopp_drucker():
    """P L^2 / EI = 10, dead load perpendicular to the undeformed yarn, 32
    segments, EA L^2/EI = 1e6 (extension P/EA = 1e-5): tip within 3e-5 L of
    the elliptic-integral solution the beam tests use (measured 6e-6 L;
    Newton from the straight state in 10 load steps)."""
    L, EI, N = 1.0, 1.0, 32
    model = cantilever(L, N, 1e6 * EI / L**2, EI)
    model.loads.add(0, N, (0.0, -1.0, 0.0))
    y = model.reduce(model._initial())
    for P in np.linspace(1.0, 10.0, 10):
        model.loads.items[0] = (0, float(N), np.array([0.0, -P * EI / L**2, 0.0]))
        y = relax_newton(model, y, rtol=1e-10, max_iter=200).y
    x, deflection, _ = closed_form.elastica_tip_load(10.0)
    r = tip(model, y)
    assert abs(r[0] / L - x) < 3e-5 and abs(-r[1] / L - deflection) < 3e-5


@pytest.mark.parametrize("factor,stable", [(0.99, True), (1.01, False)])
def test_compressed_cantilever_loses_stability_at_the_euler_load(factor, stable):
    """Straight cantilever under a compressive dead tip load P: an equilibrium
    for every P, stable below pi^2 EI / (4 L^2) and unstable above (the
    lowest eigenvalue of the reduced Hessian changes sign within 1 %)."""
    L, EI, N = 1.0, 1.0, 16
    model = cantilever(L, N, 1e4, EI)
    P = factor * np.pi**2 * EI / (4 * L**2)
    model.loads.add(0, N, (-P, 0.0, 0.0))
    # shortened by P/EA, still straight (no transverse force by symmetry)
    y = relax_newton(model, model.reduce(model._initial()), rtol=1e-12).y
    assert np.abs(model.control_points(y)[:, 1:]).max() == 0.0
    is_stable, lowest = stability.stability(model, y)
    assert is_stable == stable and (lowest > 0) == stable


def test_sparse_shift_invert_agrees_with_dense_and_lifts_rigid_motions(monkeypatch):
    """A free naturally helical yarn at rest: six rigid motions at zero energy
    are lifted (not counted as instability); the lowest remaining eigenvalues
    from shift-invert Lanczos equal the dense ones (1e-8 relative)."""
    s = np.linspace(0, 3 * np.pi, 300)
    helix = np.stack([0.3 * s, np.cos(s), np.sin(s)], axis=1)
    model = BSplineModel([Yarn.through(helix, 30, 1e3, 1.0, natural="curved")])
    y = model.reduce(model._initial())
    dense, scale = stability.lowest_eigenvalues(model, y, k=4)
    assert dense[0] > 1e-6 * scale                         # rigid zeros lifted
    plain = np.linalg.eigvalsh(model.reduced_hessian(y).toarray())
    assert np.sum(np.abs(plain) < 1e-8 * scale) == 6       # there were six of them
    monkeypatch.setattr(stability, "DENSE_LIMIT", 10)
    sparse_vals, _ = stability.lowest_eigenvalues(model, y, k=4)
    assert np.allclose(sparse_vals, dense, rtol=1e-8)
    assert stability.stability(model, y)[0]


@pytest.mark.parametrize("c_over_L,stable", [(0.85, True), (0.70, False)])
def test_planar_s_rod_is_stable_above_and_unstable_below_its_pop_up(c_over_L, stable):
    """The planar S relaxed without imperfection stays planar; its stability
    is measured (it pops up near c/L = 0.768 in this model), not assumed."""
    from knitfem.scenes.srod import SRod
    from knitfem.scenes.srod_bspline import srod_yarn_model
    model = srod_yarn_model(SRod(), c_over_L, 32)
    result = relax_newton(model, model.reduce(model._initial()), rtol=1e-9)
    assert np.abs(model.control_points(result.y)[:, 2]).max() < 1e-9      # planar
    assert stability.stability(model, result.y)[0] == stable


def _largest_move(model, a, b):
    Z, _ = model.reduction()
    return np.sqrt(((Z @ (a - b)).reshape(-1, 3) ** 2).sum(axis=1)).max()


def test_newton_distance_is_the_move_still_ahead_and_fire_goes_on_until_it_is_small():
    """A soft cantilever (EA/EI = 1e6 /L^2) sagging under its weight: FIRE
    stopped at relative residual 1e-3 is still 1.3e-4 L from its equilibrium
    (FIRE to 1e-11); the Newton step's largest move says so within 2 %
    (measured 0.2 %).  Asked to confirm rest at 2e-5 L, FIRE goes on towards
    ten times smaller residuals and ends within it."""
    from knitfem.bspline.fire import relax_fire
    from knitfem.scenes.curl_bspline import AtRest
    L, EI = 1.0, 2.0
    model = cantilever(L, 16, 1e6 * EI / L**2, EI, gravity=(0, 0, -2.0))
    model.rho[:] = 0.5
    y0 = model.reduce(model._initial())
    exact = relax_fire(model, y0, rtol=1e-11, max_steps=10**6).y
    early = relax_fire(model, y0, rtol=1e-3, max_steps=10**6)
    ahead = _largest_move(model, early.y, exact)
    assert ahead > 1e-4 * L
    assert stability.equilibrium_distance(model, early.y) == pytest.approx(ahead, rel=0.02)
    asked = []

    class Counted(AtRest):
        def __call__(self, y):
            asked.append(super().__call__(y))
            return asked[-1]
    saved = []
    rest = Counted(model, 2e-5 * L)
    confirmed = relax_fire(model, y0, rtol=1e-3, max_steps=10**6, confirm=rest,
                           checkpoint=saved.append, checkpoint_every=0.0)
    assert _largest_move(model, confirmed.y, exact) < 2e-5 * L
    assert confirmed.residual < 1e-4 and confirmed.iterations > early.iterations
    assert rest.distance <= 2e-5 * L
    # asked once per tenfold smaller residual, not at every step (measured: 2 refusals)
    assert asked[-1] and not any(asked[:-1]) and 2 <= len(asked) <= 4
    # a run resumed after a refusal aims at the tightened residual: bit for bit the same end
    after = next(s for s in saved if s.target is not None and s.step < confirmed.iterations)
    resumed = relax_fire(model, None, rtol=1e-3, max_steps=10**6, state=after,
                         confirm=AtRest(model, 2e-5 * L))
    assert np.array_equal(resumed.y, confirmed.y)


def test_newton_distance_ignores_rigid_motions_of_a_free_body():
    """A free yarn (a 3/4 circle, its own shape as natural state: at rest,
    distance 0) given a small bump out of plane, then carried and turned
    0.3 rad: the Newton step's largest move is the bump's part orthogonal to
    the rigid motions (1 %; to first order exactly that), however far the
    body was carried."""
    from knitfem.bspline.stability import rigid_modes
    t = np.linspace(0, 1.5 * np.pi, 400)
    arc = np.stack([2.0 * np.cos(t), 2.0 * np.sin(t), 0 * t], axis=1)
    model = BSplineModel([Yarn.through(arc, 16, 1e4, 1.0, natural="curved")])
    y = model.reduce(model._initial())
    assert stability.equilibrium_distance(model, y) == 0.0
    q = model.control_points(y)
    bump = 1e-3 * np.sin(np.linspace(0, np.pi, len(q)))[:, None] ** 2 * [0.0, 0.0, 1.0]
    R = rigid_modes(model, y)
    delta = model.reduce(q + bump) - y
    deformation = delta - R @ (R.T @ delta)
    expected = np.sqrt((deformation.reshape(-1, 3) ** 2).sum(axis=1)).max()
    c, s = np.cos(0.3), np.sin(0.3)
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    bumped = q + bump
    centre = bumped.mean(axis=0)
    carried = model.reduce((bumped - centre) @ turn.T + centre + [0.5, -0.2, 0.1])
    assert stability.equilibrium_distance(model, carried) == pytest.approx(expected, rel=0.01)
