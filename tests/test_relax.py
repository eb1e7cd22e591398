"""Energy minimisation (knitfem.solve.minimize), PSD projection, ties, and the
fabric scene's building blocks (the full relaxation is in test_fabric.py)."""
import numpy as np
import pytest

from knitfem import BeamModel, Rod, Section
from knitfem.beam.energy import EnergyProblem
from knitfem.solve.minimize import RelaxationError, minimize
from knitfem.solve.psd import psd_project
from knitfem.verify import cases, closed_form


def test_psd_projection_equals_the_eigen_decomposition(rng):
    """Jacobi projection = V max(L, 0) V^T from numpy's eigh (1e-12), and PSD
    blocks come back unchanged."""
    A = rng.normal(size=(50, 12, 12))
    A = A + np.swapaxes(A, 1, 2)
    w, V = np.linalg.eigh(A)
    reference = np.einsum("eij,ej,ekj->eik", V, np.maximum(w, 0.0), V)
    assert np.abs(psd_project(A) - reference).max() < 1e-12 * np.abs(A).max()
    S = A @ np.swapaxes(A, 1, 2)
    assert np.abs(psd_project(S) - S).max() < 1e-12 * np.abs(S).max()


def test_minimisation_reaches_the_elastica_from_a_straight_rod():
    """Cantilever P L^2/EI = 10 minimised in one go from the straight rod (no
    load stepping): the tip within 4e-3 L of Bisshopp-Drucker's (64 elements of
    a rod with EA L^2/EI = 6400: extensible) and within 1e-8 L of Newton's
    load-stepped equilibrium of the same model; every accepted step lowered
    the energy."""
    section = Section.circle(0.05, E=1.0)
    model = cases.cantilever_tip_load(64, alpha=10.0, section=section)
    result = minimize(EnergyProblem(model, 1.0), model.initial_state(), tol=1e-10, max_iter=300)
    newton = model.solve(loads=np.linspace(0.1, 1.0, 10))[-1].state
    x, y, _ = closed_form.elastica_tip_load(10.0)
    tip = result.state.x[-1]
    assert abs(tip[0] - x) < 4e-3 and abs(tip[1] + y) < 4e-3
    assert np.abs(tip - newton.x[-1]).max() < 1e-8
    energies = [h[0] for h in result.history]
    assert all(b <= a + 1e-12 * abs(a) for a, b in zip(energies, energies[1:]))


def test_minimisation_refuses_moments_without_a_potential():
    model = cases.cantilever_end_moment(8)
    with pytest.raises(ValueError, match="conservative"):
        EnergyProblem(model, 1.0)


def test_minimisation_reports_a_gradient_that_is_not_the_energys():
    """A problem whose gradient is wrong cannot lower its energy along it:
    RelaxationError, keeping the state, instead of a false convergence."""
    class Wrong:
        def evaluate(self, x, hessian=True):
            E = float(x @ x)
            g = -2.0 * x                          # the wrong sign
            if not hessian:
                return E, g, None, None
            from scipy import sparse
            H = sparse.identity(x.size, format="csr")
            return E, g, H, lambda: H

        def residual(self, g):
            return float(np.linalg.norm(g))

        def retract(self, x, dx):
            return x + dx
    with pytest.raises(RelaxationError) as err:
        minimize(Wrong(), np.ones(3), tol=1e-12, max_iter=100)
    assert np.allclose(err.value.state, np.ones(3))


def test_tie_carries_the_load_as_springs_in_series():
    """Rod A (clamped at x = 0) and rod B (clamped at x = 2.1), A's end tied to
    B's start 0.1 away, a force P along +x at A's end: A's tip moves
    P / (EA/L + k EA/L / (k + EA/L)) (both rods axial springs EA/L, the tie
    k in series with B), to 1e-10."""
    section = Section(EA=100.0, GA2=50.0, GA3=50.0, GJ=1.0, EI2=1.0, EI3=1.0, radius=0.05)
    model = BeamModel()
    a = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 4, section))
    b = model.add_rod(Rod.straight((1.1, 0, 0), (1, 0, 0), 1.0, 4, section))
    k = 37.0
    model.tie(a, "end", b, "start", stiffness=k)
    model.clamp(a, "start")
    model.clamp(b, "end")
    P = 1e-3
    model.force(a, "end", (P, 0, 0))
    step = model.solve(loads=[1.0])[-1]
    EA_L = 100.0
    expected = P / (EA_L + k * EA_L / (k + EA_L))
    assert abs(step.state.x[model.node(a, "end"), 0] - 1.0 - expected) < 1e-10
    assert step.stable


def test_free_body_holds_one_node_and_its_reactions_vanish():
    """A naturally curved rod with no supports but free_body(): it relaxes to
    its natural shape, the held node's reaction is ~0 (1e-8 of the force scale)."""
    section = Section.circle(0.1, E=1.0)
    model = BeamModel()
    model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 16, section,
                               natural_curvature=(0.0, 0.0, 3.0)))
    node = model.free_body()
    step = model.solve(loads=[1.0])[-1]
    reaction = model.reactions(step.state, 1.0).reshape(-1, 6)[node]
    assert np.linalg.norm(reaction) < 1e-8 * model.force_scale()
    gamma, kappa, _ = model.assembly.strains(step.state.x, step.state.q)
    assert np.allclose(kappa[:, 2], 3.0, atol=1e-8)
