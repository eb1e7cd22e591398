"""Penalty beam-to-beam contact (issue 6)."""
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from knitfem import BeamModel, Rod, Section
from knitfem.beam.rotation import rotate_spatially
from knitfem.beam.parametric import ParametricProblem
from knitfem.contact import PenaltyLaw, SegmentContact, brute_force_pairs, candidate_pairs
from knitfem.contact.master import bulge, neighbours
from knitfem.contact.narrow import pair_forces
from knitfem.solve.continuation import continuation
from knitfem.verify.cases import crossed_beams, yarn_on_yarn   # d = 2 R

R = 0.5                                           # yarn radius


def test_penalty_law_is_c1_and_linear_beyond_contact():
    law = PenaltyLaw(k=10.0, g0=0.1)
    g = np.array([0.2, 0.1, 0.05, 0.0, -0.3])
    assert np.allclose(law.force(g), [0, 0, 10 * 0.05**2 / 0.2, 10 * 0.05, 10 * (0.05 + 0.3)])
    e = 1e-7                                       # phi' = -f everywhere, f continuous at 0, g0
    for x in (0.1, 0.05, 0.0, -0.3):
        assert abs(-(law.energy(x + e) - law.energy(x - e)) / (2 * e) - law.force(x)) < 1e-6
    assert abs(law.force(-1e-12) - law.force(1e-12)) < 1e-9


def force_on_rod(rod, which, ends, grads):
    """z-force of the contact gradients (pairs' slots) on the segments of rod ``which``."""
    on = rod[ends // 2] == which                              # (k, 6) slot on that rod
    return float(np.sum(grads.reshape(len(grads), 6, 3)[:, :, 2] * on))


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
    _, _, ends, grads, _, report = contact.evaluate(x0, x1, tangent=False, length=length)
    on_b = force_on_rod(rod, 1, ends, grads)
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


def test_crossed_beams_carry_the_force_of_linear_beam_theory():
    """Crossed clamped-clamped beams, B's supports pushed down by 0.1: the
    contact force F solves h = h0 - push + (C_A + C_B) F(h) with F(h) the
    penalty law integrated across the crossing and C the Timoshenko
    compliances of the beams at the crossing, a^3 b^3/(3 EI L^3) + a b/(GA L);
    within 1.5 % (the rest is geometric stiffening, O((w/d)^2))."""
    push = 0.1
    model = crossed_beams(push=push)
    steps = model.solve(loads=np.linspace(0.25, 1, 4))
    nodes = model.assembly.node_offset
    F_fe = -model.reactions(steps[-1].state, 1.0).reshape(-1, 6)[nodes[1]:nodes[2], 2].sum()
    section, law, L = model.rods[0].section, model.contact_model.segments.law, 10.0

    def compliance(a):
        b = L - a
        return a**3 * b**3 / (3 * section.EI2 * L**3) + a * b / (section.GA2 * L)

    def crossing_force(h):
        return quad(lambda s: law.force(np.hypot(s, h) - 2 * R) * h / np.hypot(s, h), -1, 1,
                    points=[0.0], epsabs=0, epsrel=1e-12, limit=400)[0]

    C = compliance(5.07) + compliance(5.05)             # crossing at x = 0.07, y = 0.05 off centre
    h = brentq(lambda h: h - (2 * R + 0.06 - push + C * crossing_force(h)), 2 * R, 2 * R + 0.06)
    assert F_fe == pytest.approx(crossing_force(h), rel=0.015)
    assert steps[-1].report.active_pairs > 0 and steps[-1].report.total_normal_force > 0


def test_newton_converges_quadratically_with_the_crossing_on_nodes():
    """The crossing exactly on a node of both beams (where a slave point
    passes from one master segment to the next): the last Newton iterations
    of every load step still converge quadratically, log r_k+1 / log r_k >= 1.6."""
    section = Section.circle(2 * R, E=1e4, nu=0.3)
    model = BeamModel()
    a = model.add_rod(Rod.straight((-5, 0, 0), (1, 0, 0), 10.0, 40, section))
    b = model.add_rod(Rod.straight((0, -5, 2 * R + 0.06), (0, 1, 0), 10.0, 40, section))
    model.clamp(a, "start")
    model.clamp(a, "end")
    for end in ("start", "end"):
        model.prescribe(b, end, displacement=(0, 0, -0.2), rotation=(0, 0, 0))
    model.contact()
    assert np.isclose(model.assembly.initial_positions()[model.node(a, 20)], 0).all()
    for step in model.solve(loads=np.linspace(0.25, 1, 4)):
        r = [h for h in step.history if h < 1e-2]
        assert len(r) >= 2 and step.history[-1] <= 1e-10
        assert all(np.log(r1) / np.log(r0) >= 1.6 for r0, r1 in zip(r, r[1:]))


def test_master_curve_keeps_the_force_continuous_across_a_kink():
    """A slave segment slid along the concave side of a master polyline with a
    20 degree kink: as its Gauss points pass from one master segment to the
    next, the force on it changes smoothly (largest change between samples
    < 2x the median); against the bare chords (each chord its own stretch of
    master yarn) it jumps (> 3x: a point facing the kink sees both chords),
    which is what made Newton linear there."""
    th = np.radians(20.0)
    master = np.array([(-3.0, 0, 0), (-2.0, 0, 0), (-1.0, 0, 0), (0.0, 0, 0)]
                      + [(k * np.cos(th), 0.0, -k * np.sin(th)) for k in (1, 2, 3)])
    law = PenaltyLaw(1000.0, 0.05)
    rod = np.array([0] * 6 + [1])
    s_mid, radius = np.r_[np.arange(6) + 0.5, 0.0], np.full(7, R)

    def force(x, smooth):
        x0 = np.vstack([master[:-1], [(x, -1.0, -0.97)]])
        x1 = np.vstack([master[1:], [(x, 1.0, -0.97)]])
        prev, nxt = neighbours(x0, x1, rod, s_mid)
        if not smooth:
            prev[:], nxt[:] = -1, -1
        b = bulge(x0, x1, prev, nxt)
        pairs = candidate_pairs(x0, x1, radius, rod, s_mid, law.g0, 2.0, b)
        _, _, ends, grads, _, _, _ = pair_forces(x0, x1, radius, pairs, law, tangent=False,
                                                 rank=1 - rod, prev=prev, nxt=nxt, bulges=b)
        on_slave = rod[ends // 2] == 1
        return np.sum(grads.reshape(-1, 6, 3) * on_slave[:, :, None], axis=(0, 1))

    xs = np.linspace(-0.3, 0.3, 601)
    for smooth, bound in ((True, lambda j: j.max() < 2 * np.median(j)),
                          (False, lambda j: j.max() > 3 * np.median(j))):
        jumps = np.linalg.norm(np.diff([force(x, smooth) for x in xs], axis=0), axis=1)
        assert bound(jumps)


def test_continuation_follows_the_contact_path():
    """Pseudo-arclength continuation in the push of the crossed beams: the
    branch completes, every point is stable, the corrector needs at most 4
    iterations except where contact begins, the contact force grows along the
    branch and the end state is the load-stepping equilibrium (1e-10 L)."""
    model = crossed_beams(push=0.2)
    branch = continuation(ParametricProblem(model), model.initial_state(), 0.0,
                          lam_range=(0.0, 1.0), ds=0.05, ds_max=0.2)
    assert branch.status == "completed"
    assert all(p.negative == 0 for p in branch.points)
    force = np.array([model.contact_report(p.state).total_normal_force for p in branch.points])
    onset = int(np.argmax(force > 0))
    assert onset > 0 and np.all(np.diff(force[onset:]) > 0)
    assert all(p.iterations <= 4 for p in branch.points[onset + 1:])
    reference = crossed_beams(push=0.2).solve(loads=np.linspace(0.25, 1, 4))[-1].state
    assert np.abs(branch.points[-1].state.x - reference.x).max() < 1e-10 * 10.0


def test_parallel_line_contact_carries_a_uniform_load_without_spikes():
    """A beam lying on a parallel rigid beam (non-matching meshes) under its own
    weight: the contact load equals the weight at every interior node of the
    lying beam (the slave: its elements are shorter) to 1e-6, its end nodes
    take half, and the gap is uniform (1e-9) with no penetration beyond 1 % of d."""
    q = 9.81 * Section.circle(2 * R, E=1e3, nu=0.3, density=1.0).line_density
    model = yarn_on_yarn(q)
    state = model.solve(loads=np.linspace(0.25, 1, 4))[-1].state
    _, fc, _, _ = model.contact_model.forces(state.x, tangent=False)
    nodes = model.assembly.node_offset
    on_top = -fc.reshape(-1, 6)[nodes[1]:nodes[2], 2]     # contact force on the lying beam
    w = q * 9.5 / 17                                       # weight per element
    assert (np.allclose(on_top[1:-1], w, rtol=1e-6)
            and np.allclose(on_top[[0, -1]], w / 2, rtol=1e-6))
    gap = state.x[nodes[1]:nodes[2], 2] - 2 * R
    assert np.ptp(gap) < 1e-9 and -gap.min() < 0.01 * 2 * R
    # the gap is where the law carries the weight per length: f(g) = q
    law = model.contact_model.segments.law
    assert law.force(gap.mean()) == pytest.approx(q, rel=1e-6)


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


def pressed_crossing():
    """Crossed beams (8 elements) with B pressed 0.09 into A, positions and
    frames perturbed at random: a large-rotation state with contact active."""
    model = crossed_beams(push=0.0, elements=8)
    state = model.initial_state()
    nodes = model.assembly.node_offset
    state.x[nodes[1]:nodes[2], 2] -= 0.09
    return model, state


def perturb(state, rng):
    state.x += 0.002 * rng.normal(size=state.x.shape)
    state.q = rotate_spatially(state.q, 0.05 * rng.normal(size=(state.q.shape[0], 3)))


def test_contact_tangent_matches_central_differences(rng, tangent_error):
    """Relative error of K v against central differences of the residual,
    contact active, < 1e-6."""
    model, state = pressed_crossing()
    perturb(state, rng)
    assert tangent_error(model, state, 1e-7) < 1e-6
    assert model.contact_report(state).active_pairs > 0


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
        _, _, ends, grads, _, _ = contact.evaluate(x0, x1, tangent=False, **kw)
        return force_on_rod(rod, 1, ends, grads)

    damping = force_on_b(previous=(p0, p1), damping_rate=c / dt) - force_on_b()
    g, g_prev = h - 2 * R, h_prev - 2 * R
    assert ramp == pytest.approx(min(1.0, (law.g0 - g) / law.g0), abs=1e-12)
    assert damping == pytest.approx(c * ramp * (g - g_prev) / dt * 2.0, rel=1e-12)
    assert force_on_b(previous=(x0, x1), damping_rate=c / dt) == pytest.approx(force_on_b(),
                                                                                 rel=1e-14)


def test_damped_contact_tangent_matches_central_differences(rng, tangent_error):
    """The damping terms keep the tangent exact (relative error < 1e-6)."""
    model, state = pressed_crossing()
    model.contact(damping=20.0)
    previous = state.x + 0.01 * rng.normal(size=state.x.shape)
    perturb(state, rng)
    model.contact_model.rate_reference = (previous, 0.1)
    assert tangent_error(model, state, 1e-7) < 1e-6
    assert model.contact_report(state).active_pairs > 0


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
    """Against a reference written out here: every pair whose segments' bounding
    spheres (midpoint, half length + r + g0/2 + bulge) overlap, minus
    neighbours along one rod."""
    x0 = rng.uniform(0, 10, (n, 3))
    x1 = x0 + rng.normal(scale=0.6, size=(n, 3))
    radius = rng.uniform(0.1, 0.3, n)
    rod = rng.integers(0, 4, n)
    s_mid = rng.uniform(0, 30, n)
    bulges = rng.uniform(0, 0.2, n)
    fast = candidate_pairs(x0, x1, radius, rod, s_mid, 0.05, 1.0, bulges)
    rho = [np.linalg.norm(x1[i] - x0[i]) / 2 + radius[i] + 0.025 + bulges[i] for i in range(n)]
    slow = {(i, j) for i in range(n) for j in range(i + 1, n)
            if np.linalg.norm((x0[i] + x1[i] - x0[j] - x1[j]) / 2) < rho[i] + rho[j]
            and (rod[i] != rod[j] or abs(s_mid[i] - s_mid[j]) > 1.0)}
    assert len(slow) > 0
    assert set(map(tuple, np.sort(fast, axis=1))) == slow
    assert set(map(tuple, np.sort(brute_force_pairs(x0, x1, radius, rod, s_mid, 0.05, 1.0,
                                                    bulges), axis=1))) == slow


def test_kept_candidate_list_returns_exactly_what_a_fresh_search_does(rng):
    """The Verlet list (CandidateList) against candidate_pairs along a random
    walk of the segments, small steps and large jumps, stretching and
    shrinking: the same array at every call (same pairs, same order), the
    tree searched again only when some sphere left its grown sphere."""
    from knitfem.contact.broad import CandidateList
    n = 300
    x0 = rng.uniform(0, 8, (n, 3))
    x1 = x0 + rng.normal(scale=0.5, size=(n, 3))
    radius = rng.uniform(0.1, 0.3, n)
    rod = rng.integers(0, 4, n)
    s_mid = rng.uniform(0, 30, n)
    kept = CandidateList(skin=0.4)
    calls = 0
    for scale in [0.0] + [0.01] * 20 + [0.3, 0.01, 0.01, 1.0] + [0.02] * 10:
        x0 = x0 + rng.normal(scale=scale, size=x0.shape)
        x1 = x1 + rng.normal(scale=scale, size=x1.shape)
        bulges = rng.uniform(0, 0.05, n)
        fresh = candidate_pairs(x0, x1, radius, rod, s_mid, 0.05, 1.0, bulges)
        assert len(fresh) > 0
        assert np.array_equal(kept(x0, x1, radius, rod, s_mid, 0.05, 1.0, bulges), fresh)
        calls += 1
    assert 3 <= kept.searches < calls // 2
    with pytest.raises(ValueError, match="skin must be a positive length"):
        CandidateList(0.0)


def test_scene_without_close_segments_pays_nothing():
    contact = SegmentContact(PenaltyLaw(1.0, 0.01), np.full(2, 0.1), np.array([0, 1]),
                             np.zeros(2))
    energy, pairs, _, grads, hess, report = contact.evaluate(np.array([[0, 0, 0], [0, 0, 5.0]]),
                                                          np.array([[1, 0, 0], [1, 0, 5.0]]))
    assert energy == 0 and len(pairs) == 0 and report.candidates == 0


@pytest.mark.parametrize("call,match", [
    (lambda: PenaltyLaw(-1.0, 0.1), r"penalty k must be finite and in \(0, inf\)"),
    (lambda: PenaltyLaw(1.0, float("nan")), r"penalty g0 must be finite"),
    (lambda: PenaltyLaw.relative(1.0, -0.5), r"radius must be finite and in \(0, inf\)"),
    (lambda: SegmentContact(PenaltyLaw(1.0, 0.1), [-0.1], [0], [0.0]), r"segment radii must be"),
    (lambda: SegmentContact(PenaltyLaw(1.0, 0.1), [0.1, 0.1], [0, 1], [0, 0]).evaluate(
        np.array([[0, 0, np.nan], [1, 1, 1.0]]), np.ones((2, 3))), r"NaN"),
    (lambda: BeamModel().contact(damping=-1.0),
     r"contact damping must be finite and in \[0, inf\)"),
    (lambda: BeamModel().contact(duration=0.0),
     r"contact duration must be finite and in \(0, inf\)"),
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


def test_the_search_skips_only_curves_certainly_beyond_its_floor():
    """The Bernstein floor of |c(t) - p|^2 that lets the search skip a master
    curve's root isolation is a lower bound (against 2 001 samples of random
    cubics and points, to 1e-12), and a skipped curve has no critical point
    nearer than the floor (the full isolation, floor off, finds none)."""
    from knitfem.contact.master import _squared_distance_floor, critical_points
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, 2001)
    D, roots, kinds = np.empty((6, 6)), np.empty(6), np.empty(6, np.int64)
    skipped = 0
    for _ in range(300):
        C = rng.normal(size=(4, 3)) * np.array([[1.0], [1.0], [0.5], [0.3]])
        p = rng.normal(size=3)
        count = critical_points(p, C, np.nan, D, roots, kinds)[0]
        found = roots[:count].copy()
        curve = C[0] + t[:, None] * (C[1] + t[:, None] * (C[2] + t[:, None] * C[3]))
        d2 = np.sum((curve - p) ** 2, axis=1)
        low = _squared_distance_floor(p, C, D)
        assert low <= d2.min() + 1e-12 * d2.max()
        floor = 0.9 * np.sqrt(max(low, 0.0))
        if floor > 0.0:
            assert critical_points(p, C, np.nan, D, roots, kinds, floor)[0] == 0
            skipped += 1
            for s in found:
                c = C[0] + s * (C[1] + s * (C[2] + s * C[3]))
                assert np.linalg.norm(c - p) > floor
    assert skipped > 100
