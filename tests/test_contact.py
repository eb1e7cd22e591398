"""Penalty beam-to-beam contact (issue 6)."""
import numpy as np
import pytest
from scipy.integrate import quad

from knitfem import BeamModel, Rod, Section
from knitfem.beam.rotation import rotate_spatially
from knitfem.contact import PenaltyLaw, SegmentContact, brute_force_pairs, candidate_pairs

R = 0.5                                           # yarn radius


def test_penalty_law_is_c1_and_linear_beyond_contact():
    law = PenaltyLaw(k=10.0, g0=0.1)
    g = np.array([0.2, 0.1, 0.05, 0.0, -0.3])
    assert np.allclose(law.force(g), [0, 0, 10 * 0.05**2 / 0.2, 10 * 0.05, 10 * (0.05 + 0.3)])
    e = 1e-7                                       # phi' = -f everywhere, f continuous at 0, g0
    for x in (0.1, 0.05, 0.0, -0.3):
        assert abs(-(law.energy(x + e) - law.energy(x - e)) / (2 * e) - law.force(x)) < 1e-6
    assert abs(law.force(-1e-12) - law.force(1e-12)) < 1e-9


def crossed_beams(push, elements=40, E=1e4):
    """Beam A along x and beam B along y, both clamped-clamped, B starting
    above A (gap 0.03 d, beyond the law's reach of 0.05 r) and its ends pushed
    down by ``push``.  The crossing lies off the nodes of both beams: where a
    slave Gauss point faces a master node exactly, the energy is only C1 in
    that node (the master polyline may kink there) and Newton slows down."""
    section = Section.circle(2 * R, E=E, nu=0.3)
    model = BeamModel()
    a = model.add_rod(Rod.straight((-5, 0, 0), (1, 0, 0), 10.0, elements, section))
    b = model.add_rod(Rod.straight((0.07, -5.05, 2 * R + 0.06), (0, 1, 0), 10.0, elements,
                                   section))
    model.clamp(a, "start")
    model.clamp(a, "end")
    for end in ("start", "end"):
        model.prescribe(b, end, displacement=(0, 0, -push), rotation=(0, 0, 0))
    model.contact()
    return model


def perpendicular_lines(h, n=40, length=2.0):
    """Two straight perpendicular yarns of n segments, centrelines h apart."""
    s = np.linspace(-length / 2, length / 2, n + 1)
    zero = np.zeros(n)
    a0 = np.stack([s[:-1] + 0.013, zero, zero], 1)
    a1 = np.stack([s[1:] + 0.013, zero, zero], 1)
    b0 = np.stack([zero, s[:-1] + 0.011, zero + h], 1)
    b1 = np.stack([zero, s[1:] + 0.011, zero + h], 1)
    mid = 0.5 * (s[:-1] + s[1:])
    return (np.vstack([a0, b0]), np.vstack([a1, b1]), np.repeat([0, 1], n),
            np.concatenate([mid, mid]))


@pytest.mark.parametrize("h,tol", [(1.04, 3e-4), (1.0, 1e-5), (0.995, 1e-5)])
def test_crossing_force_is_the_penalty_law_integrated_along_the_yarn(h, tol):
    """Rigid crossed yarns at centreline distance h: the force pushing them
    apart is F(h) = int f(sqrt(s^2 + h^2) - 2R) h / sqrt(s^2 + h^2) ds
    (Gauss quadrature of the slave yarn; 3e-4 near first touch, 1e-5 beyond)."""
    x0, x1, rod, s_mid = perpendicular_lines(h)
    law = PenaltyLaw.relative(1.0, R)
    contact = SegmentContact(law, np.full(len(rod), R), rod, s_mid)
    length = np.linalg.norm(x1 - x0, axis=1)
    _, pairs, grads, _, report = contact.evaluate(x0, x1, tangent=False, length=length)
    on_b = sum(g[2] * (rod[i] == 1) + g[5] * (rod[i] == 1) + g[8] * (rod[j] == 1)
               + g[11] * (rod[j] == 1) for (i, j), g in zip(pairs, grads))
    F_law = quad(lambda s: law.force(np.hypot(s, h) - 2 * R) * h / np.hypot(s, h), -1, 1,
                 points=[0.0], epsabs=0, epsrel=1e-12, limit=400)[0]
    assert abs(-on_b / F_law - 1) < tol and report.active_pairs > 0


def test_crossed_beams_pushed_together_are_in_equilibrium():
    """Deformable crossed beams, one pushed onto the other by its supports:
    the reactions of all supports sum to zero (relative 1e-8), the contact
    force equals what the pushed beam's supports apply, and the penetration
    stays below 1 % of the diameter."""
    model = crossed_beams(push=0.2)
    state = model.solve(loads=np.linspace(0.25, 1, 4))[-1].state
    react = model.reactions(state, 1.0).reshape(-1, 6)
    assert np.linalg.norm(react[:, :3].sum(axis=0)) < 1e-8 * np.abs(react[:, 2]).sum()
    _, fc, _, _ = model.contact_model.forces(state.x, tangent=False)
    nodes = model.assembly.node_offset
    on_b = -fc.reshape(-1, 6)[nodes[1]:nodes[2], 2].sum()
    assert on_b > 0 and abs(on_b + react[nodes[1]:nodes[2], 2].sum()) < 1e-8 * on_b
    report = model.contact_report(state)
    assert report.active_pairs > 0 and report.max_penetration < 0.01 * 2 * R


def test_contact_is_written_to_the_vtu(tmp_path):
    """The .vtu of a contact state carries the nodal contact forces (summing
    to what B's supports push with) and per element the smallest gap (the
    report's minimum near the crossing, g0 far from it) and an active flag."""
    import meshio
    from knitfem.io.vtk import write_beam_state
    model = crossed_beams(push=0.2)
    state = model.solve(loads=np.linspace(0.25, 1, 4))[-1].state
    mesh = meshio.read(write_beam_state(tmp_path / "contact.vtu", model, state))
    report = model.contact_report(state)
    nodes = model.assembly.node_offset
    force_on_b = mesh.point_data["contact_force"][nodes[1]:nodes[2], 2].sum()
    push = -model.reactions(state, 1.0).reshape(-1, 6)[nodes[1]:nodes[2], 2].sum()
    assert force_on_b == pytest.approx(push, rel=1e-8)
    assert np.allclose(mesh.point_data["contact_force"].sum(axis=0), 0, atol=1e-8 * push)
    gap, active = mesh.cell_data["contact_gap"][0], mesh.cell_data["contact_active"][0]
    g0 = model.contact_model.segments.law.g0
    assert gap.min() == pytest.approx(report.min_gap, abs=1e-14)
    assert 0 < active.sum() <= 8 and np.all(gap[active == 0] == g0)


def test_parallel_line_contact_carries_a_uniform_load_without_spikes():
    """A beam lying on a parallel rigid beam (non-matching meshes) under its own
    weight: the contact load equals the weight at every interior node of the
    lying beam (the slave: its elements are shorter) to 1e-6, its end nodes
    take half, and the gap is uniform (1e-9) with no penetration beyond 1 % of d."""
    section = Section.circle(2 * R, E=1e3, nu=0.3, density=1.0)
    model = BeamModel()
    base = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 10.0, 13, section))
    # starts inside the law's reach (gap 0.049 < g0 = 0.05): no free fall, no rigid mode
    top = model.add_rod(Rod.straight((0.25, 0, 2 * R + 0.049), (1, 0, 0), 9.5, 17, section))
    for i in range(14):
        model.clamp(base, i)
    for i in range(18):
        model.fix(top, i, "ux uy rx rz")
    model.gravity((0, 0, -9.81))
    model.contact()
    state = model.solve(loads=np.linspace(0.25, 1, 4))[-1].state
    _, fc, _, _ = model.contact_model.forces(state.x, tangent=False)
    nodes = model.assembly.node_offset
    on_top = -fc.reshape(-1, 6)[nodes[1]:nodes[2], 2]     # contact force on the lying beam
    w = 9.81 * section.line_density * 9.5 / 17             # weight per element
    assert np.allclose(on_top[1:-1], w, rtol=1e-6) and np.allclose(on_top[[0, -1]], w / 2, rtol=1e-6)
    gap = state.x[nodes[1]:nodes[2], 2] - 2 * R
    assert np.ptp(gap) < 1e-9 and -gap.min() < 0.01 * 2 * R


def test_two_clamped_rods_twist_into_a_two_ply():
    """The rod-contact benchmark: two parallel rods clamped at one end, their
    other ends turned together by one full turn about the axis.  The ply forms
    (the rods wrap, the contact carries force), no interpenetration beyond 1 %
    of the diameter, Newton converges at every step."""
    section = Section.circle(2 * R, E=1000.0, nu=0.3)
    model = BeamModel()
    rods = [model.add_rod(Rod.straight((0, s * 1.2 * R, 0), (1, 0, 0), 20.0, 40, section))
            for s in (1, -1)]
    for k, s in zip(rods, (1, -1)):
        y0 = s * 1.2 * R
        model.clamp(k, "start")
        model.prescribe(k, "end", rotation=lambda phi: np.array([phi, 0, 0]),
                        displacement=lambda phi, y0=y0: np.array([0, y0 * (np.cos(phi) - 1),
                                                                  y0 * np.sin(phi)]))
    model.contact()
    steps = model.solve(loads=np.linspace(0.25, 2 * np.pi, 25))
    assert all(s.history[-1] <= 1e-10 or s.roundoff_limited for s in steps)
    end = steps[-1].state
    report = model.contact_report(end)
    assert report.active_pairs >= 10 and report.total_normal_force > 0
    assert report.max_penetration <= 0.01 * 2 * R
    mid = [model.node(k, 20) for k in rods]
    d = end.x[mid[0]] - end.x[mid[1]]
    assert abs(abs(np.arctan2(d[2], d[1])) - np.pi) < 0.5    # wound half a turn at mid-span


def test_contact_tangent_matches_central_differences(rng):
    """Relative error of K v against central differences of the residual,
    contact active, < 1e-6."""
    model = crossed_beams(push=0.0, elements=8)
    state = model.initial_state()
    nodes = model.assembly.node_offset
    state.x[nodes[1]:nodes[2], 2] -= 0.09                     # press B into A
    state.x += 0.002 * rng.normal(size=state.x.shape)
    state.q = rotate_spatially(state.q, 0.05 * rng.normal(size=(state.q.shape[0], 3)))
    _, f, K = model.internal_forces(state)
    assert model.contact_model.report.active_pairs > 0
    for _ in range(3):
        v = rng.normal(size=f.shape)
        e = 1e-7
        fp = model.internal_forces(model.retract(state, e * v), tangent=False)[1]
        fm = model.internal_forces(model.retract(state, -e * v), tangent=False)[1]
        assert np.linalg.norm((fp - fm) / (2 * e) - K @ v) < 1e-6 * np.linalg.norm(K @ v)


@pytest.mark.parametrize("h,h_prev,ramp", [(0.99, 0.995, 1.0), (1.025, 1.026, 0.5)])
def test_normal_damping_is_c_times_the_gap_rate(h, h_prev, ramp):
    """Parallel rigid yarns (slave length 2) closing at a uniform gap rate:
    the damping line load is c psi(g) dg/dt with psi = 1 in contact and the
    penalty ramp (g0 - g)/g0 in the regularisation zone (to 1e-12)."""
    n = 8
    s = np.linspace(0.0, 2.0, n + 1)
    a0 = np.stack([s[:-1], 0 * s[:-1], 0 * s[:-1]], 1)
    a1 = np.stack([s[1:], 0 * s[1:], 0 * s[1:]], 1)
    x0, x1 = np.vstack([a0, a0 + [0, 0, h]]), np.vstack([a1, a1 + [0, 0, h]])
    p0, p1 = np.vstack([a0, a0 + [0, 0, h_prev]]), np.vstack([a1, a1 + [0, 0, h_prev]])
    rod, s_mid = np.repeat([0, 1], n), np.tile(0.5 * (s[:-1] + s[1:]), 2)
    law = PenaltyLaw(k=50.0, g0=0.05)
    contact = SegmentContact(law, np.full(2 * n, R), rod, s_mid)
    c, dt = 3.0, 0.5

    def force_on_b(**kw):
        _, pairs, grads, _, _ = contact.evaluate(x0, x1, tangent=False, **kw)
        return sum(g[2] * (rod[i] == 1) + g[5] * (rod[i] == 1) + g[8] * (rod[j] == 1)
                   + g[11] * (rod[j] == 1) for (i, j), g in zip(pairs, grads))

    damping = force_on_b(previous=(p0, p1), damping_rate=c / dt) - force_on_b()
    g, g_prev = h - 2 * R, h_prev - 2 * R
    assert ramp == pytest.approx(min(1.0, (law.g0 - g) / law.g0), abs=1e-12)
    assert damping == pytest.approx(c * ramp * (g - g_prev) / dt * 2.0, rel=1e-12)
    assert force_on_b(previous=(x0, x1), damping_rate=c / dt) == pytest.approx(force_on_b(),
                                                                                 rel=1e-14)


def test_damped_contact_tangent_matches_central_differences(rng):
    """The damping terms keep the tangent exact (relative error < 1e-6)."""
    model = crossed_beams(push=0.0, elements=8)
    model.contact(damping=20.0)
    state = model.initial_state()
    nodes = model.assembly.node_offset
    state.x[nodes[1]:nodes[2], 2] -= 0.09
    previous = state.x + 0.01 * rng.normal(size=state.x.shape)
    state.x += 0.002 * rng.normal(size=state.x.shape)
    state.q = rotate_spatially(state.q, 0.05 * rng.normal(size=(state.q.shape[0], 3)))
    model.contact_model.rate_reference = (previous, 0.1)
    _, f, K = model.internal_forces(state)
    assert model.contact_model.report.active_pairs > 0
    for _ in range(3):
        v = rng.normal(size=f.shape)
        e = 1e-7
        fp = model.internal_forces(model.retract(state, e * v), tangent=False)[1]
        fm = model.internal_forces(model.retract(state, -e * v), tangent=False)[1]
        assert np.linalg.norm((fp - fm) / (2 * e) - K @ v) < 1e-6 * np.linalg.norm(K @ v)


def test_damping_resists_the_push_and_fades_with_slower_loading():
    """Crossed beams pushed together over pseudo-time T with normal damping:
    Newton converges, the supports push harder than without damping in the
    last increment (the damping resists the approach), the excess falls like
    1/T (10x slower loading -> 10x less, within 15 %), and the damping is gone
    after the solve (equilibria and reports see the elastic contact)."""
    loads = np.linspace(0.25, 1, 4)
    push = {}
    for duration in (None, 1.0, 10.0):
        model = crossed_beams(push=0.2)
        if duration is not None:
            model.contact(damping=1e4, duration=duration)
        steps = model.solve(loads=loads)
        assert all(s.history[-1] <= 1e-10 or s.roundoff_limited for s in steps)
        assert model.contact_model.rate_reference is None
        if duration is not None:      # the last increment's damping, to read its reactions
            model.contact_model.rate_reference = (steps[-2].state.x, 0.25 * duration)
        nodes = model.assembly.node_offset
        push[duration] = -model.reactions(steps[-1].state, 1.0).reshape(-1, 6)[
            nodes[1]:nodes[2], 2].sum()
    excess = {T: push[T] - push[None] for T in (1.0, 10.0)}
    assert excess[1.0] > 0 and excess[10.0] > 0
    assert excess[1.0] / excess[10.0] == pytest.approx(10.0, rel=0.15)


@pytest.mark.parametrize("n", [50, 400])
def test_broad_phase_finds_exactly_the_brute_force_candidates(rng, n):
    x0 = rng.uniform(0, 10, (n, 3))
    x1 = x0 + rng.normal(scale=0.6, size=(n, 3))
    radius = rng.uniform(0.1, 0.3, n)
    rod = rng.integers(0, 4, n)
    s_mid = rng.uniform(0, 30, n)
    fast = candidate_pairs(x0, x1, radius, rod, s_mid, 0.05, 1.0)
    slow = brute_force_pairs(x0, x1, radius, rod, s_mid, 0.05, 1.0)
    assert len(slow) > 0
    assert set(map(tuple, np.sort(fast, axis=1))) == set(map(tuple, np.sort(slow, axis=1)))


def test_scene_without_close_segments_pays_nothing():
    contact = SegmentContact(PenaltyLaw(1.0, 0.01), np.full(2, 0.1), np.array([0, 1]),
                             np.zeros(2))
    energy, pairs, grads, hess, report = contact.evaluate(np.array([[0, 0, 0], [0, 0, 5.0]]),
                                                          np.array([[1, 0, 0], [1, 0, 5.0]]))
    assert energy == 0 and len(pairs) == 0 and report.candidates == 0


@pytest.mark.parametrize("call,match", [
    (lambda: PenaltyLaw(-1.0, 0.1), r"penalty k must be finite and in \(0, inf\)"),
    (lambda: PenaltyLaw(1.0, float("nan")), r"penalty g0 must be finite"),
    (lambda: PenaltyLaw.relative(1.0, -0.5), r"radius must be finite and in \(0, inf\)"),
    (lambda: SegmentContact(PenaltyLaw(1.0, 0.1), [-0.1], [0], [0.0]), r"segment radii must be"),
    (lambda: SegmentContact(PenaltyLaw(1.0, 0.1), [0.1, 0.1], [0, 1], [0, 0]).evaluate(
        np.array([[0, 0, np.nan], [1, 1, 1.0]]), np.ones((2, 3))), r"NaN"),
    (lambda: BeamModel().contact(damping=-1.0), r"contact damping must be finite and in \[0, inf\)"),
    (lambda: BeamModel().contact(duration=0.0), r"contact duration must be finite and in \(0, inf\)"),
])
def test_bad_contact_input_is_refused(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_contact_needs_a_section_radius():
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 4,
                                     Section(EA=1, GA2=1, GA3=1, GJ=1, EI2=1, EI3=1)))
    model.clamp(rod, "start")
    model.contact()
    with pytest.raises(ValueError, match="contact needs every rod's section to have a radius"):
        model.solve()
