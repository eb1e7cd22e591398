"""Newton and load stepping on problems with known answers."""
import numpy as np
import pytest
from scipy import sparse

from knitfem.solve import NewtonError, SteppingError, load_stepping, newton
from knitfem.verify import cases


class Cubic:
    """x^3 + x = b componentwise (root known), sparse diagonal Jacobian."""

    def __init__(self, b):
        self.b = np.asarray(b, float)

    def evaluate(self, x, jacobian=True):
        r = x**3 + x - self.b
        J = sparse.diags(3 * x**2 + 1).tocsr() if jacobian else None
        return r, J, np.linalg.norm(self.b)

    def retract(self, x, dx):
        return x + dx


class Arctan:
    """atan(x) = 0: plain Newton diverges from |x0| > 1.39, a line search saves it."""

    def evaluate(self, x, jacobian=True):
        with np.errstate(over="ignore"):
            return np.arctan(x), (np.diag(1 / (1 + x**2)) if jacobian else None), 1.0

    def retract(self, x, dx):
        return x + dx


def test_newton_converges_quadratically_to_a_known_root():
    b = np.linspace(1, 10, 50)
    result = newton(Cubic(b), np.zeros(50), rtol=1e-14)
    root = result.state
    assert np.allclose(root**3 + root, b, atol=1e-12)
    h = [v for v in result.history if v > 1e-13]         # above round-off
    order = np.log(h[-1]) / np.log(h[-2])
    assert result.iterations <= 12 and order > 1.8        # quadratic: digits double


def test_line_search_rescues_a_diverging_newton_iteration():
    with pytest.raises(NewtonError):
        newton(Arctan(), np.array([3.0]), max_iter=10)
    result = newton(Arctan(), np.array([3.0]), line_search=True)
    assert abs(result.state[0]) < 1e-10


def test_failure_reports_reason_and_keeps_the_last_state():
    with pytest.raises(NewtonError) as err:
        newton(Cubic([1e6]), np.array([0.0]), max_iter=3)
    assert err.value.reason == "max_iterations" and len(err.value.history) == 4
    assert err.value.state[0] > 0 and "no convergence in 3 iterations" in str(err.value)


def test_non_finite_residual_is_reported_not_propagated():
    class Bad(Cubic):
        def evaluate(self, x, jacobian=True):
            r, J, ref = super().evaluate(x, jacobian)
            return r * np.nan, J, ref
    with pytest.raises(NewtonError, match="residual is not finite") as err:
        newton(Bad([1.0]), np.array([0.0]), where="load 0.5")
    assert err.value.reason == "nonfinite" and "at load 0.5" in str(err.value)


def test_singular_jacobian_is_reported():
    class Flat(Cubic):
        def evaluate(self, x, jacobian=True):
            r, _, ref = super().evaluate(x, jacobian)
            return r, (sparse.csr_matrix((1, 1)) if jacobian else None), ref
    with pytest.raises(NewtonError, match="Jacobian is singular") as err:
        newton(Flat([1.0]), np.array([0.5]))
    assert err.value.reason == "singular"


def test_load_stepping_halves_failed_steps_and_reports_what_it_kept():
    steps = load_stepping(lambda lam: Cubic([lam]), np.array([0.0]), [50.0, 100.0], max_iter=5)
    assert 1 < steps[0].substeps < 10 and steps[1].substeps == 1
    assert abs(steps[-1].state[0] ** 3 + steps[-1].state[0] - 100.0) < 1e-8
    with pytest.raises(SteppingError) as err:
        load_stepping(lambda lam: Cubic([lam]), np.array([0.0]), [0.1, 1e9],
                      max_iter=4, max_halvings=2)
    assert len(err.value.steps) == 1 and "failed after 2 halvings" in str(err.value)


def test_beam_newton_needs_few_iterations_per_load_step_for_a_yarn_like_rod():
    """A rod of yarn-like slenderness (EA L^2/EI = 6400) bent to a tip rotation of
    82 degrees in 10 steps: at most 4 Newton iterations per step to a relative
    residual of 1e-10, thanks to the exact position solve after each update;
    without it 12.  Both give the same equilibrium."""
    from knitfem import Section
    section = Section.circle(0.05, E=1.0)
    tips, iterations = [], []
    for relax in (True, False):
        model = cases.cantilever_tip_load(32, alpha=10.0, section=section)
        steps = model.solve(loads=np.linspace(0.1, 1.0, 10), relax_positions=relax)
        assert max(s.history[-1] for s in steps) < 1e-10
        tips.append(steps[-1].state.x[-1])
        iterations.append(max(s.iterations for s in steps))
    assert iterations[0] <= 4 < iterations[1]
    assert np.allclose(tips[0], tips[1], atol=1e-9)
