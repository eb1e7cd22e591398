"""Pseudo-arclength continuation on problems with known answers."""
import numpy as np
import pytest
from scipy import sparse
from scipy.optimize import minimize_scalar

from knitfem.solve.continuation import Bordered, ContinuationError, continuation, switch_branch
from knitfem.solve.stability import inertia


class Pitchfork:
    """Potential problem E = -lam u1^2/2 + u1^4/4 + u2^2 + u2^4/4: the trivial
    branch loses stability at lam = 0 to the supercritical branches u1 = +-sqrt(lam)."""

    def evaluate(self, x, lam, jacobian=True):
        R = np.array([-lam * x[0] + x[0] ** 3, 2 * x[1] + x[1] ** 3])
        if not jacobian:
            return R, None, None, 1.0
        J = sparse.csr_matrix(np.diag([-lam + 3 * x[0] ** 2, 2 + 3 * x[1] ** 2]))
        return R, J, np.array([-x[0], 0.0]), 1.0

    def retract(self, x, dx, lam):
        return x + dx


class Bratu:
    """-u'' = lam exp(u) on (0, 1), u(0) = u(1) = 0, central differences."""

    def __init__(self, n):
        h = 1.0 / (n + 1)
        self.A = sparse.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)],
                              [-1, 0, 1]).tocsr() / h**2

    def evaluate(self, u, lam, jacobian=True):
        e = np.exp(u)
        R = self.A @ u - lam * e
        ref = max(np.linalg.norm(self.A @ u), np.linalg.norm(lam * e), 1.0)
        if not jacobian:
            return R, None, None, ref
        return R, (self.A - sparse.diags(lam * e)).tocsr(), -e, ref

    def retract(self, u, du, lam):
        return u + du


def test_pitchfork_is_detected_located_and_both_branches_found():
    branch = continuation(Pitchfork(), np.zeros(2), -1.0, ds=0.13, lam_range=(-1, 1))
    assert branch.status == "completed" and branch.points[-1].lam == 1.0
    (event,) = branch.events
    assert event.kind == "bifurcation" and abs(event.lam) <= 1e-8
    assert (event.negative_before, event.negative_after) == (0, 1)
    assert all(p.stable for p in branch.points if p.lam < -1e-6)
    assert not any(p.stable for p in branch.points if p.lam > 1e-6)
    assert abs(abs(event.null_vector[0]) - 1) < 1e-12
    for sign in (1, -1):
        new = switch_branch(Pitchfork(), event, sign=sign, ds=0.05, lam_range=(-1, 1))
        u = np.array([p.state[0] for p in new.points])
        lam = np.array([p.lam for p in new.points])
        assert new.status == "completed" and lam[-1] == 1.0
        assert np.all(np.sign(u) == sign) and np.max(np.abs(u**2 - lam)) < 1e-9
        assert all(p.stable for p in new.points)                 # supercritical


def discrete_bratu_fold(n):
    """Independent reference: maximise lam over the branch parametrised by the
    midpoint value of u (Newton for (u, lam) at fixed u_mid)."""
    problem, mid = Bratu(n), n // 2

    def lam_at(umid):
        def F(y):
            u, lam = y[:-1], y[-1]
            R, J, R_lam, _ = problem.evaluate(u, lam)
            row = np.zeros(n)
            row[mid] = 1.0
            return np.append(R, u[mid] - umid), sparse.bmat(
                [[J, sparse.csr_matrix(R_lam[:, None])], [sparse.csr_matrix(row), None]])
        y = np.append(umid * np.sin(np.pi * np.linspace(0, 1, n + 2)[1:-1]), 3.0)
        for _ in range(50):
            r, A = F(y)
            y = y - sparse.linalg.spsolve(A.tocsc(), r)
            if np.linalg.norm(r) < 1e-12:
                break
        return y[-1]
    best = minimize_scalar(lambda m: -lam_at(m), bounds=(0.5, 2.5), method="bounded",
                           options={"xatol": 1e-10})
    return -best.fun


def test_bratu_turning_point_is_located_to_1e_8():
    branch = continuation(Bratu(100), np.zeros(100), 0.0, ds=0.5, ds_max=1.0,
                          lam_range=(0.0, 4.0), max_steps=60)
    fold = next(e for e in branch.events if e.kind == "fold")
    assert abs(fold.lam - discrete_bratu_fold(100)) <= 1e-8
    assert fold.negative_before == 0 and fold.negative_after == 1
    assert abs(fold.point.tl) < 1e-3


def test_bratu_turning_point_converges_to_3_51383():
    """Second order in h: Richardson extrapolation of n = 200, 400 gives lam* to 1e-5."""
    folds = []
    for n in (200, 400):
        branch = continuation(Bratu(n), np.zeros(n), 0.0, ds=0.5, ds_max=1.0,
                              lam_range=(0.0, 4.0), max_steps=60, stability=False)
        folds.append(next(e.lam for e in branch.events if e.kind == "fold"))
    assert abs(folds[1] + (folds[1] - folds[0]) / 3 - 3.51383) < 1e-5


def test_failure_keeps_the_branch_traced_so_far():
    class Ends(Pitchfork):             # no solution beyond lam = 0.5
        def evaluate(self, x, lam, jacobian=True):
            if lam > 0.5:
                R, J, R_lam, ref = super().evaluate(x, lam, jacobian)
                return R + 1e3, J, R_lam, ref
            return super().evaluate(x, lam, jacobian)
    with pytest.raises(ContinuationError, match="step size fell below ds_min") as err:
        continuation(Ends(), np.zeros(2), -1.0, ds=0.1, ds_min=1e-3, lam_range=(-1, 1))
    lam = err.value.branch.lam
    assert len(lam) > 10 and 0.4 < lam.max() <= 0.5


def test_bordered_solve_survives_a_singular_block():
    J = sparse.csr_matrix(np.diag([1.0, 2.0, 0.0]))            # singular, as at a fold
    A = Bordered(J, np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0]), 0.0)
    x = A.solve(np.array([1.0, 2.0, 3.0, 4.0]))
    dense = np.array([[1, 0, 0, 0], [0, 2, 0, 0], [0, 0, 0, 1], [0, 0, 1, 0.0]])
    assert np.allclose(dense @ x, [1, 2, 3, 4])


def test_inertia_counts_negative_eigenvalues(rng):
    Q, _ = np.linalg.qr(rng.normal(size=(30, 30)))
    vals = np.concatenate([-rng.uniform(0.1, 1, 4), rng.uniform(0.1, 1, 26)])
    K = sparse.csr_matrix(Q @ np.diag(vals) @ Q.T)
    negative, logdet = inertia(K)
    assert negative == 4 and abs(logdet - np.sum(np.log(np.abs(vals)))) < 1e-9
