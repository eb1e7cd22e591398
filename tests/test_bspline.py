"""The B-spline yarn model: exact gradients, rest states, analytic stretching,
contact law, clamps, and the cross-check with the beam model on the S-rod."""
import numpy as np
import pytest

from knitfem.bspline import (BSplineModel, ContactLaw, RelaxationError, Yarn, curve, relax,
                             relax_dynamic, relax_static)
from knitfem.bspline.contact import candidate_pairs, contact_damping, contact_energy


def straight_yarn(length=10.0, segments=8, EA=100.0, EI=1.0, **kw):
    pts = np.stack([np.linspace(0, length, 200), np.zeros(200), np.zeros(200)], axis=1)
    return Yarn.through(pts, segments, EA, EI, natural="straight", length=length, **kw)


def wavy(q, amplitude, axes):
    """Control points q with a half sine of ``amplitude`` added along ``axes``
    (a start away from the straight answer)."""
    q = q.copy()
    bump = amplitude * np.sin(np.pi * np.linspace(0, 1, q.shape[0]))
    for k in axes:
        q[:, k] += bump
    return q


def axial_strain(model, q):
    """|r'|/l - 1 at every Gauss point (S, G): the stretching law's strain."""
    a = curve.evaluate(q, model.quad.u, derivative=1)
    return np.linalg.norm(a, axis=2) / model.rest[:, None] - 1


def clamp_force(model, y, end, e=1e-5):
    """x force on the end clamp, dE/dx of its position (central difference of
    relaxed energies; positive: the yarn pulls the clamp back, tension)."""
    energies = []
    for shift in (e, -e):
        model.move_clamp(1, position=(end[0] + shift, end[1], end[2]))
        energies.append(model.reduced_energy(relax_static(model, y, rtol=1e-7).y)[0])
    model.move_clamp(1, position=end)
    return (energies[0] - energies[1]) / (2 * e)


def test_gradient_matches_central_differences_with_contact_and_gravity(rng):
    s = np.linspace(0, 4 * np.pi, 300)
    helix = np.stack([np.cos(s), np.sin(s), 0.3 * s], axis=1)       # pitch 1.9 < 2 * 2r
    yarns = [Yarn.through(helix, 24, 50.0, 2.0, radius=0.5),
             Yarn.through(helix + [0.4, 0.0, 0.1], 20, 40.0, 1.0, radius=0.5)]
    model = BSplineModel(yarns, contact=ContactLaw(3.0, 0.5), gravity=(0, 0, -1.0))
    q = model._initial() + 0.05 * rng.normal(size=(model.n, 3))
    E, g, _ = model.energy(q)
    pts, w, yarn, sl = model.samples(q)
    assert len(candidate_pairs(pts, yarn, sl, model.contact)) > 0   # contact is active
    for _ in range(3):
        v = rng.normal(size=q.shape)
        e = 1e-6
        fd = (model.energy(q + e * v)[0] - model.energy(q - e * v)[0]) / (2 * e)
        assert abs(fd - np.sum(g * v)) < 1e-6 * max(1.0, abs(fd))


def test_straight_unloaded_yarn_stays_at_rest():
    model = BSplineModel([straight_yarn()])
    model.clamp(0, "start")
    y0 = model.reduce(model.yarns[0].control)
    result = relax_dynamic(model, y0, rtol=1e-5)       # |g| ~ 1e-12: round-off only
    assert result.iterations <= 20 and np.allclose(result.y, y0, atol=1e-12)
    E, g, _ = model.reduced_energy(y0)
    assert abs(E) < 1e-20 and np.linalg.norm(g) < 1e-10 * 100.0        # EA = 100


@pytest.mark.parametrize("relax", [relax_static, relax_dynamic])
def test_pure_stretching_gives_the_analytic_axial_force(relax):
    """Clamped at both ends 10 % apart beyond the rest length, relaxed from a
    wavy start: uniform strain 0.1 to rtol absolute (measured ~0.1 rtol; L-BFGS
    stalls near 3e-8, hence its looser rtol) and clamp force EA * 0.1 to 1e-8
    relative (measured <= 3e-10: the energy error is quadratic in the residual)."""
    L0, EA = 10.0, 100.0
    model = BSplineModel([straight_yarn(L0, 8, EA)])
    model.clamp(0, "start", (0, 0, 0), (1, 0, 0))
    model.clamp(0, "end", (1.1 * L0, 0, 0), (1, 0, 0))
    q0 = wavy(model.yarns[0].control * [1.1, 1, 1], 0.02 * L0, axes=(0, 1))
    rtol = 1e-9 if relax is relax_dynamic else 1e-7
    result = relax(model, model.reduce(q0), rtol=rtol)
    assert result.iterations > 10                # the start is not the answer
    strain = axial_strain(model, model.control_points(result.y))
    assert np.allclose(strain, 0.1, rtol=0, atol=rtol)
    force = clamp_force(model, result.y, (1.1 * L0, 0, 0))
    assert abs(force / (EA * 0.1) - 1) < 1e-8


@pytest.mark.parametrize("relax", [relax_static, relax_dynamic])
def test_prestretch_of_a_yarn_clamped_at_rest_length_gives_the_tension_of_its_alpha(relax):
    """Rest lengths shrunk by (1 - alpha), ends held: strain |r'|/l - 1 =
    1/(1 - alpha) - 1 = 0.25 at alpha = 0.2, a tension EA * 0.25; along the yarn
    to 10 rtol relative (measured ~1e-7 static, ~3e-10 dynamic), at the clamp
    to 1e-8 relative (measured <= 2e-10)."""
    L0, EA, alpha = 10.0, 100.0, 0.2
    model = BSplineModel([straight_yarn(L0, 8, EA)])
    model.clamp(0, "start", (0, 0, 0), (1, 0, 0))
    model.clamp(0, "end", (L0, 0, 0), (1, 0, 0))
    assert model.reduced_energy(model.reduce(model.yarns[0].control))[0] < 1e-20   # at rest
    model.prestretch(alpha)
    q0 = wavy(model.yarns[0].control, 0.02 * L0, axes=(0, 2))
    rtol = 1e-9 if relax is relax_dynamic else 1e-7
    result = relax(model, model.reduce(q0), rtol=rtol)
    tension = EA * (1 / (1 - alpha) - 1)
    N = EA * axial_strain(model, model.control_points(result.y))
    assert np.all(N > 0) and np.allclose(N / tension, 1, rtol=0, atol=10 * rtol)
    force = clamp_force(model, result.y, (L0, 0, 0))
    assert force > 0 and abs(force / tension - 1) < 1e-8      # tensile: pulls the clamps in


def test_contact_is_zero_beyond_2r_and_repulsive_below():
    law = ContactLaw(stiffness=2.0, radius=0.5)
    pts = np.array([[0.0, 0, 0], [0.0, 0, 1.2], [0.0, 0, 0.9]])
    w = np.ones(3)
    E, g, n = contact_energy(pts, w, np.array([[0, 1]]), law)    # d = 1.2 > 2r
    assert E == 0 and n == 0 and not g.any()
    E, g, n = contact_energy(pts, w, np.array([[0, 2]]), law)    # d = 0.9 < 2r
    x = 0.9
    assert n == 1 and np.isclose(E, 2.0 * (1 / x**2 - 2 + x**2))
    assert g[0, 2] > 0 and g[2, 2] < 0                          # -grad pushes them apart
    # C1 at first touch, f(1) = f'(1) = 0: at d = 2r (1 - delta) the energy vanishes like
    # delta^2 and the force like delta (doubling delta: x4 and x2, to 1 %; measured 0.1 %)
    near = {}
    for delta in (1e-3, 2e-3):
        pair = np.array([[0.0, 0, 0], [0.0, 0, 1.0 * (1 - delta)]])      # 2r = 1.0
        E, g, n = contact_energy(pair, np.ones(2), np.array([[0, 1]]), law)
        assert n == 1 and E > 0 and g[1, 2] < 0                  # touching, repulsive
        near[delta] = (E, -g[1, 2])
    assert near[2e-3][0] / near[1e-3][0] == pytest.approx(4.0, rel=1e-2)
    assert near[2e-3][1] / near[1e-3][1] == pytest.approx(2.0, rel=1e-2)


def test_contact_damping_only_dissipates_and_splits_normal_from_tangential(rng):
    pts = rng.uniform(0, 2.0, size=(40, 3))
    vel = rng.normal(size=(40, 3))
    w = rng.uniform(0.5, 1.5, size=40)
    law = ContactLaw(1.0, 0.5, damping=2.0, tangential_damping=0.3)
    pairs = np.array([(i, j) for i in range(40) for j in range(i + 1, 40)])
    f = contact_damping(pts, vel, w, pairs, law)
    assert np.sum(f * vel) < 0                          # dissipates
    assert np.allclose(f.sum(axis=0), 0, atol=1e-12)    # action = reaction
    near = np.linalg.norm(pts[pairs[:, 0]] - pts[pairs[:, 1]], axis=1) < 1.0
    touched = np.unique(pairs[near])
    assert np.all(f[np.setdiff1d(np.arange(40), touched)] == 0)   # nothing beyond 2r
    # one pair: the normal and tangential parts of the relative velocity, each with its coefficient
    p2, v2 = np.array([[0.0, 0, 0], [0.0, 0, 0.8]]), np.array([[1.0, 0, 3.0], [0.0, 0, 0]])
    f2 = contact_damping(p2, v2, np.array([2.0, 0.5]), np.array([[0, 1]]), law)
    assert np.allclose(f2[0], -1.0 * np.array([0.3 * 1.0, 0.0, 2.0 * 3.0]))
    assert np.allclose(f2[1], -f2[0])
    assert not contact_damping(p2, v2, np.ones(2), np.array([[0, 1]]), ContactLaw(1.0, 0.5)).any()


def crossed_yarns(law):
    """Two clamped straight yarns crossing at right angles 1.5 r apart: contact
    pushes them apart and bends both."""
    t = np.linspace(-5, 5, 200)
    a = np.stack([t, np.zeros_like(t), np.zeros_like(t)], axis=1)
    b = np.stack([np.zeros_like(t), t, np.full_like(t, 0.75)], axis=1)
    yarns = [Yarn.through(p, 12, 100.0, 1.0, natural="straight", length=10.0, radius=0.5)
             for p in (a, b)]
    model = BSplineModel(yarns, contact=law)
    for k in (0, 1):
        model.clamp(k, "start")
        model.clamp(k, "end")
    return model


def test_contact_damping_changes_the_path_not_the_equilibrium(rng):
    plain = crossed_yarns(ContactLaw(50.0, 0.5))
    damped = crossed_yarns(ContactLaw(50.0, 0.5, damping=5.0, tangential_damping=5.0))
    y0 = plain.reduce(plain._initial())
    v = rng.normal(size=y0.shape)
    assert np.dot(damped.contact_damping(y0, v), v) < 0            # wired in, dissipative
    assert not plain.contact_damping(y0, v).any()
    # the Kaldor law's Hessian jumps at first touch, so L-BFGS stalls near 5e-7: compare at 1e-6
    reference = relax_static(plain, y0, rtol=1e-6)
    result = relax_dynamic(damped, y0, rtol=1e-6, kinetic=False, damping=0.5)
    q0, q_ref, q = (plain.control_points(y) for y in (y0, reference.y, result.y))
    assert np.abs(q_ref - q0)[:, 2].max() > 0.1                 # contact did bend the yarns
    assert np.abs(q - q_ref).max() < 1e-6 * 10.0                # same state, to 1e-6 L
    assert damped.reduced_energy(result.y)[0] == pytest.approx(reference.energy, rel=1e-8)


def test_clamp_holds_position_and_tangent_exactly_and_leaves_curvature_free(rng):
    model = BSplineModel([straight_yarn()])
    model.clamp(0, "start", (1.0, 2.0, 3.0), (0, 1, 0))
    model.clamp(0, "end", (4.0, 8.0, 3.0), (1, 0, 0))
    q = model.control_points(rng.normal(size=model.reduction()[0].shape[1]))
    r0 = curve.evaluate(q, np.array([0.0]))[0, 0]
    t0 = curve.evaluate(q, np.array([0.0]), derivative=1)[0, 0]
    r1 = curve.evaluate(q, np.array([1.0]))[-1, 0]
    t1 = curve.evaluate(q, np.array([1.0]), derivative=1)[-1, 0]
    assert np.allclose(r0, [1, 2, 3]) and np.allclose(r1, [4, 8, 3])
    assert np.allclose(np.cross(t0, [0, 1, 0]), 0) and np.allclose(np.cross(t1, [1, 0, 0]), 0)
    k0 = curve.evaluate(q, np.array([0.0]), derivative=2)[0, 0]
    assert np.linalg.norm(k0) > 1e-3                            # curvature is not forced to 0


def test_relaxation_failure_keeps_the_last_state():
    model = BSplineModel([straight_yarn()])
    model.clamp(0, "start")
    q = model.yarns[0].control.copy()
    q[:, 1] += 0.5 * np.sin(np.linspace(0, np.pi, q.shape[0]))
    with pytest.raises(RelaxationError, match="did not reach relative residual") as err:
        relax_dynamic(model, model.reduce(q), rtol=1e-12, max_steps=50)
    assert err.value.y.shape == model.reduce(q).shape and len(err.value.history) > 0


@pytest.mark.parametrize("kwargs,match", [
    (dict(EA=-1.0), r"EA must be finite and in \(0, inf\)"),
    (dict(EI=float("nan")), r"EI must be finite"),
])
def test_bad_yarn_input_is_refused(kwargs, match):
    args = dict(EA=1.0, EI=1.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        straight_yarn(**args)


def test_bad_contact_parameters_are_refused():
    with pytest.raises(ValueError, match=r"contact radius must be finite and in \(0, inf\)"):
        ContactLaw(1.0, -0.5)


def test_dynamic_relaxation_recovers_when_its_time_step_turns_unstable():
    """The S-rod at c/L = 0.6 from a 10 % L out-of-plane bump: the stiffness
    grows as the yarn bends, the time step estimated at the start turns
    unstable (this diverged before the energy check), and relaxation goes
    back to its last checkpoint with half the step, reaching the same popped
    state as from a 1 % bump (1e-5 L)."""
    from knitfem.scenes.srod import SRod
    from knitfem.scenes.srod_bspline import max_height, srod_yarn_model
    srod = SRod()
    heights, steps = [], []
    for bump in (0.01, 0.1):
        model = srod_yarn_model(srod, 0.6, 32)
        q = model.yarns[0].control.copy()
        q[:, 2] += bump * srod.length * np.sin(np.pi * np.linspace(0, 1, q.shape[0]))
        y0 = model.reduce(q)
        result = relax_dynamic(model, y0, rtol=1e-6)
        heights.append(max_height(model.control_points(result.y)) / srod.length)
        steps.append((result.time_step, relax.stable_time_step(model, y0, model.masses())))
    assert heights[1] == pytest.approx(heights[0], abs=1e-5)
    assert steps[0][0] == steps[0][1] and steps[1][0] < steps[1][1]     # only the big bump halved
