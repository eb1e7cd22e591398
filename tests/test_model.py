"""Model assembly, supports, loads, several rods and the global tangent."""
import numpy as np

from knitfem import BeamModel, Rod, Section
from knitfem.beam.rotation import rotate_spatially
from knitfem.verify import cases

SECTION = Section.circle(0.05, E=1e3, nu=0.5)


def two_rod_model():
    model = BeamModel()
    a = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 6, SECTION))
    b = model.add_rod(Rod.arc(0.4, 2.0, 7, SECTION, start=(0, 1, 0), tangent=(0, 0, 1),
                              toward=(1, 0, 0)))
    model.clamp(a, "start")
    model.clamp(b, "start")
    return model, a, b


def test_global_tangent_matches_central_differences_at_a_large_rotation_state(rng,
                                                                              tangent_error):
    """f: two rods, random finite rotations (up to ~3 rad per node), relative
    error of K v against central differences of the residual < 1e-9 (the
    differences' own floor at step 1e-6 is ~1e-10; measured 4e-11 ... 1.1e-10
    over five random states)."""
    model, _, _ = two_rod_model()
    state = model.initial_state()
    n = state.x.shape[0]
    state.x += 0.2 * rng.normal(size=(n, 3))
    state.q = rotate_spatially(state.q, 1.5 * rng.normal(size=(n, 3)))
    assert tangent_error(model, state, 1e-6) < 1e-9


def test_fast_scatter_equals_scikit_fem_coo_assembly(rng):
    model, _, _ = two_rod_model()
    asm = model.assembly
    Ke = rng.normal(size=(asm.elements.shape[1], 12, 12))
    assert abs(asm.scatter(Ke) - asm.coo(Ke).tocsr()).max() < 1e-12
    free = rng.random(asm.n_dofs) > 0.3
    reference = asm.coo(Ke).tocsr()[free][:, free]
    assert abs(asm.scatter(Ke, free) - reference).max() < 1e-12


def test_gravity_load_totals_the_rod_weight():
    section = Section.circle(0.1, E=1.0, density=2.0)
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 3.0, 5, section))
    model.clamp(rod, "start")
    model.gravity((0, 0, -9.81))
    f = model.external_forces().reshape(-1, 6)
    assert np.isclose(f[:, 2].sum(), -9.81 * section.line_density * 3.0, rtol=1e-14)
    assert np.allclose(f[:, 2], f[1, 2] * np.array([0.5, 1, 1, 1, 1, 0.5]))


def test_reactions_balance_the_loads_of_a_deformed_cantilever():
    model = cases.cantilever_tip_load(16, alpha=5.0, section=SECTION)
    end = model.solve(loads=np.linspace(0.25, 1, 4))[-1].state
    R = model.reactions(end, 1.0).reshape(-1, 6)
    F = model.external_forces().reshape(-1, 6)
    scale = np.abs(F).max()
    assert np.allclose(R[0, :3] + F[:, :3].sum(0), 0, atol=1e-8 * scale)
    moment = R[0, 3:] + np.cross(end.x, F[:, :3]).sum(0)   # about the origin
    assert np.allclose(moment, 0, atol=1e-8 * scale)


def test_planar_restriction_gives_the_same_equilibrium_with_half_the_unknowns():
    full = cases.cantilever_tip_load(16, alpha=5.0)
    planar = cases.cantilever_tip_load(16, alpha=5.0)
    planar.restrict_to_plane()
    a = full.solve(loads=[0.5, 1.0])[-1].state
    b = planar.solve(loads=[0.5, 1.0])[-1].state
    assert np.count_nonzero(~planar.fixed) * 2 == np.count_nonzero(~full.fixed)
    assert np.allclose(a.x, b.x, atol=1e-10)


def test_path_independence_closed_cycle_of_end_rotations_returns_to_start():
    """g: drive the end frame through a closed loop of rotations (about x, then
    y, then back along another path); the rod returns to its straight, stress-free
    layout: energy and displacements vanish to round-off."""
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 12, SECTION))
    model.clamp(rod, "start")
    a, b = np.array([0.0, 0.0, 1.2]), np.array([0.9, 0.0, 0.0])

    def path(lam):           # 0 -> a -> a+b -> b -> 0 as lam goes 0 -> 4
        corners = [np.zeros(3), a, a + b, b, np.zeros(3)]
        i = min(int(lam), 3)
        return corners[i] + (lam - i) * (corners[i + 1] - corners[i])

    model.prescribe(rod, "end", rotation=path)
    steps = model.solve(loads=np.linspace(0.25, 4.0, 16))
    assert steps[7].state.x[-1, 1] > 0.1            # it did bend on the way
    end = steps[-1].state
    energy, _, _ = model.internal_forces(end, tangent=False)
    layout = model.initial_state()
    assert energy < 1e-20 and np.allclose(end.x, layout.x, atol=1e-10)


def test_several_disjoint_rods_solve_independently():
    model, a, b = two_rod_model()
    model.force(a, "end", (0, 0.01, 0))
    model.force(b, "end", (0, 0, -0.01))
    both = model.solve(loads=[1.0])[-1].state
    alone = BeamModel()
    r = alone.add_rod(model.rods[a])
    alone.clamp(r, "start")
    alone.force(r, "end", (0, 0.01, 0))
    single = alone.solve(loads=[1.0])[-1].state
    assert np.allclose(both.x[:7], single.x, atol=1e-12)
