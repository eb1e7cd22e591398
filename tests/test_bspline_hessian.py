"""The B-spline model's Hessian, natural curvature, dead loads and ties."""
import numpy as np
import pytest

from knitfem.bspline import BSplineModel, ContactLaw, Yarn, relax_newton
from knitfem.bspline.energy import curvature
from knitfem.bspline.energy import set_yarn_terms


def helix_pair(curved=False, form="kaldor"):
    """Two helices wound into each other (contact active), one of them
    naturally curved, gravity, a dead load and a tie between them."""
    s = np.linspace(0, 4 * np.pi, 300)
    helix = np.stack([np.cos(s), np.sin(s), 0.3 * s], axis=1)
    yarns = [Yarn.through(helix, 24, 50.0, 2.0, radius=0.5,
                          natural="curved" if curved else "shape"),
             Yarn.through(helix + [0.4, 0.0, 0.1], 20, 40.0, 1.0, radius=0.5)]
    model = BSplineModel(yarns, contact=ContactLaw(3.0, 0.5, form=form), gravity=(0, 0, -1.0))
    model.loads.add(1, 20.0, (0.3, -0.2, 0.5))
    model.ties.add(0, 0.0, 1, 0.5, 7.0)
    return model


@pytest.mark.parametrize("curved,form", [(False, "kaldor"), (True, "kaldor"), (True, "smooth")])
def test_hessian_matches_central_differences_of_the_gradient(rng, curved, form):
    """Exact Hessian (stretching, bending with and without natural curvature,
    contact in both forms, a tie) against central differences of the exact
    gradient: 1e-6 relative (measured ~1e-9)."""
    model = helix_pair(curved, form)
    q = model._initial() + 0.05 * rng.normal(size=(model.n, 3))
    assert model.energy_parts(q)["contact"] > 0 and model.energy_parts(q)["ties"] > 0
    H = model.hessian(q)
    assert abs(H - H.T).max() < 1e-10 * abs(H).max()                  # symmetric
    for _ in range(3):
        v = rng.normal(size=q.shape)
        e = 1e-6
        fd = (model.energy(q + e * v)[1] - model.energy(q - e * v)[1]) / (2 * e)
        Hv = (H @ v.ravel()).reshape(-1, 3)
        assert np.linalg.norm(fd - Hv) < 1e-6 * np.linalg.norm(Hv)


def set_wave(segments=32):
    """A yarn set in a wave with inflections (its curvature 0 at two points
    and small around them), as the knitted loop is."""
    x = np.linspace(0, 4 * np.pi, 400)
    wave = np.stack([x, np.sin(x), 0.2 * np.cos(0.5 * x)], axis=1)
    return BSplineModel([Yarn.through(wave, segments, 50.0, 2.0, natural="curved",
                                      set_yarn=True)])


def test_set_yarn_gradient_and_hessian_match_central_differences(rng):
    """The smooth forms of a set yarn (regularised curvature, kappa^2 tau)
    against central differences: gradient 1e-6, Hessian 1e-6 relative."""
    model = set_wave()
    assert model.curvature_eps.min() > 0 and model.torsion_weight.min() > 0
    q = model._initial() + 0.05 * rng.normal(size=(model.n, 3))
    E, g, _ = model.energy(q)
    H = model.hessian(q)
    assert abs(H - H.T).max() < 1e-10 * abs(H).max()
    for _ in range(3):
        v = rng.normal(size=q.shape)
        e = 1e-6
        fd = (model.energy(q + e * v)[0] - model.energy(q - e * v)[0]) / (2 * e)
        assert abs(fd - np.sum(g * v)) < 1e-6 * max(1.0, abs(fd))
        fd = (model.energy(q + e * v)[1] - model.energy(q - e * v)[1]) / (2 * e)
        Hv = (H @ v.ravel()).reshape(-1, 3)
        assert np.linalg.norm(fd - Hv) < 1e-6 * np.linalg.norm(Hv)


def test_set_yarn_is_at_rest_in_its_shape_and_smooth_where_it_straightens(rng):
    """Its shape has no energy and no force (round-off); pulled straight, its
    force is continuous across the straight line (the change of the gradient
    between +-h shrinks with h), where the exact form's jumps (the cone of
    the unsigned curvature at kappa = 0: O(1) whatever h)."""
    model = set_wave()
    q0 = model._initial()
    E, g, ref = model.energy(q0)
    assert abs(E) < 1e-12 and np.linalg.norm(g) <= model.roundoff
    line = np.stack([np.linspace(0, 4 * np.pi, model.n), np.zeros(model.n),
                     np.zeros(model.n)], axis=1)
    v = np.zeros_like(line)
    v[:, 1] = rng.normal(size=model.n)

    def jump(h):
        return np.linalg.norm(model.energy(line + h * v)[1] - model.energy(line - h * v)[1])

    smooth = [jump(h) for h in (1e-4, 1e-6)]
    assert smooth[1] < 0.02 * smooth[0]                    # O(h): ~100 x smaller
    model.curvature_eps[:] = 0.0                           # the exact form
    model.torsion_weight[:] = 0.0
    model.torsion_rest[:] = 0.0
    exact = [jump(h) for h in (1e-4, 1e-6)]
    assert exact[1] > 0.5 * exact[0] and exact[1] > 1e3 * smooth[1]


def test_set_yarn_terms_follow_the_rest_bending():
    """weight 1 / max(kappa0, mean)^4, ep 0.1 mean; a straight rest shape is
    refused (a set yarn needs a bent one)."""
    k0 = np.array([[0.0, 0.5, 1.0, 2.0]])
    ds = np.ones_like(k0)
    weight, ep = set_yarn_terms(k0, ds)
    mean = k0.mean()
    assert np.allclose(weight, 1.0 / np.maximum(k0, mean) ** 4)
    assert np.allclose(ep, 0.1 * mean)
    with pytest.raises(ValueError, match="bent rest shape"):
        set_yarn_terms(np.zeros((2, 4)), np.ones((2, 4)))


@pytest.mark.parametrize("form", ["kaldor", "smooth"])
def test_gradient_with_natural_curvature_matches_central_differences(rng, form):
    model = helix_pair(curved=True, form=form)
    q = model._initial() + 0.05 * rng.normal(size=(model.n, 3))
    E, g, _ = model.energy(q)
    for _ in range(3):
        v = rng.normal(size=q.shape)
        e = 1e-6
        fd = (model.energy(q + e * v)[0] - model.energy(q - e * v)[0]) / (2 * e)
        assert abs(fd - np.sum(g * v)) < 1e-6 * max(1.0, abs(fd))


def test_projected_hessian_is_positive_semidefinite(rng):
    model = helix_pair(curved=True)
    q = model._initial() + 0.1 * rng.normal(size=(model.n, 3))
    exact = np.linalg.eigvalsh(model.hessian(q).toarray())[0]          # 150 unknowns: dense
    projected = np.linalg.eigvalsh(model.hessian(q, project=True).toarray())[0]
    scale = abs(model.hessian(q)).max()
    assert exact < -1e-3 * scale                     # the exact one is indefinite here
    assert projected > -1e-10 * scale


def test_naturally_curved_yarn_is_at_rest_in_its_shape_and_returns_to_its_curvature(rng):
    """A 3/4 circle with natural curvature 1/R: zero energy and force in its
    initial shape; clamped at one end and pushed out of shape, it relaxes back
    to curvature 1/R everywhere (1e-4 relative; measured ~1e-6)."""
    R = 2.0
    t = np.linspace(0, 1.5 * np.pi, 400)
    arc = np.stack([R * np.cos(t), R * np.sin(t), 0 * t], axis=1)
    yarn = Yarn.through(arc, 16, 1e4, 1.0, natural="curved")
    model = BSplineModel([yarn])
    kappa0 = model.kappa0
    assert np.allclose(kappa0, 1 / R, rtol=1e-2)         # the least-squares fit: 0.7 % off
    E, g, ref = model.energy(model._initial())
    assert abs(E) < 1e-12 and np.linalg.norm(g) < model.roundoff     # round-off only
    model.clamp(0, "start")
    q = model._initial().copy()
    q[:, 2] += 0.2 * np.sin(np.linspace(0, np.pi, q.shape[0])) ** 2
    # at rest all forces vanish, so the residual is measured against EI/h^2
    result = relax_newton(model, model.reduce(q), rtol=1e-10, atol=1e-10 / model.rest.min()**2)
    kappa = curvature(model.control_points(result.y), model.seg, model.quad)
    assert np.abs(kappa - kappa0).max() < 1e-4 / R


def test_tie_holds_two_points_at_their_initial_distance():
    """A straight yarn pulled at its tip by a dead load P along the tie
    direction, tied to a clamped yarn: the tie stretches by P / K (1e-8)."""
    pts = np.stack([np.linspace(0, 5, 50), np.zeros(50), np.zeros(50)], axis=1)
    yarns = [Yarn.through(pts, 8, 1e3, 1.0), Yarn.through(pts + [0, 1.0, 0], 8, 1e3, 1.0)]
    model = BSplineModel(yarns)
    model.clamp(0, "start")
    model.clamp(0, "end")
    model.ties.add(0, 4.0, 1, 4.0, 50.0)             # midpoints, 1.0 apart along y
    model.loads.add(1, 4.0, (0.0, 2.0, 0.0))
    result = relax_newton(model, model.reduce(model._initial()), rtol=1e-10)
    d, ext = model.ties.stretch(model.control_points(result.y))
    assert ext[0] == pytest.approx(2.0 / 50.0, rel=1e-8)


@pytest.mark.parametrize("kwargs,match", [
    (dict(yarn=3, t=0.0), r"yarn must be an integer in \[0, 1\]"),
    (dict(yarn=0, t=9.5), r"curve parameter t must be in \[0, 8\]"),
])
def test_bad_curve_points_are_refused(kwargs, match):
    pts = np.stack([np.linspace(0, 5, 50), np.zeros(50), np.zeros(50)], axis=1)
    model = BSplineModel([Yarn.through(pts, 8, 1e3, 1.0), Yarn.through(pts + 1, 8, 1e3, 1.0)])
    with pytest.raises(ValueError, match=match):
        model.loads.add(kwargs["yarn"], kwargs["t"], (1.0, 0, 0))


def test_naturally_helical_yarn_returns_to_its_helix():
    """A helix with its curvature and torsion as natural state, clamped at one
    end and drawn out 30 % along its axis, relaxes back to the same helix up to a turn
    about the clamp's tangent (a twist-free yarn has no roll): all distances
    between control points as before, 1e-6 of its length (curvature alone
    would leave a whole family of coils at no energy: without the torsion
    term this start ends 0.08 L away, measured)."""
    s = np.linspace(0, 3 * np.pi, 400)
    helix = np.stack([0.3 * s, np.cos(s), np.sin(s)], axis=1)
    model = BSplineModel([Yarn.through(helix, 24, 1e3, 1.0, natural="curved")])
    model.clamp(0, "start")
    q0 = model._initial()
    q = q0 * [1.3, 1.0, 1.0]
    result = relax_newton(model, model.reduce(q), rtol=1e-10, atol=1e-10 / model.rest.min()**2)
    length = model.rest.sum()
    q1 = model.control_points(result.y)
    distances = [np.linalg.norm(p[:, None] - p[None], axis=2) for p in (q0, q1)]
    assert np.abs(distances[1] - distances[0]).max() < 1e-6 * length


def test_set_yarn_bending_is_the_regularised_curvature_difference(rng):
    """One Gauss point: the smooth bending energy is EI/2 (kappa_ep -
    kappa0_ep)^2 |a| w for any kappa0, kappa0 = 0 included (0 where kappa =
    kappa0), and ep = 0 gives the exact EI/2 (kappa - kappa0)^2 |a| w."""
    from knitfem.bspline import gausspoint
    H = np.zeros((9, 9))
    for _ in range(5):
        a, b, d = rng.normal(size=(3, 3))
        kappa = np.linalg.norm(np.cross(a, b)) / np.linalg.norm(a) ** 3
        na = np.linalg.norm(a)
        for k0 in (0.0, 0.3 * kappa, kappa, 2.0 * kappa):
            for ep in (0.0, 0.5 * kappa):
                want = 0.5 * 2.0 * (np.hypot(kappa, ep) - np.hypot(k0, ep)) ** 2 * na * 0.7
                for e in (gausspoint.energy(a, b, d, 1.0, 0.0, 2.0, k0, 0.0, 0.0, ep, 0.7,
                                            False, False, H)[0],
                          gausspoint.gradient(a, b, d, 1.0, 0.0, 2.0, k0, 0.0, 0.0, ep, 0.7)[0]):
                    assert e == pytest.approx(want, rel=1e-9, abs=1e-12 * kappa ** 2 * na)
