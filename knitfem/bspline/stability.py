"""Stability of B-spline equilibria: the lowest eigenvalue of the reduced Hessian.

A free body (no clamp, no fixed point) has six rigid motions at zero
energy; they are not instabilities, so they are lifted out of the way: the
eigenproblem is solved for H + beta R R^T, R an orthonormal basis of the
rigid motions of the control points (a curve moves rigidly with its control
points), beta the largest diagonal entry of H.  Above ``DENSE_LIMIT``
unknowns: shift-invert Lanczos (ARPACK) about a slightly negative shift,
with (H - sigma I)^-1 from one sparse LU and the rank-6 lift by Woodbury's
formula, so no dense matrix is ever formed; below it, a dense eigensolver.
"""
import numpy as np
from scipy import sparse
from scipy.sparse import linalg as splinalg

DENSE_LIMIT = 2000
ZERO = 1e-9            # |lambda| below ZERO x max|diag H|: round-off, counted as stable


def rigid_modes(model, y):
    """Orthonormal (n_free, 6) basis of rigid motions of a free model at y
    (None when clamps or fixed points hold it)."""
    if model.clamps or model.fixed:
        return None
    q = model.control_points(y)
    x = q - q.mean(axis=0)
    modes = []
    for k in range(3):
        t = np.zeros_like(q)
        t[:, k] = 1.0
        modes.append(t.ravel())
        w = np.zeros(3)
        w[k] = 1.0
        modes.append(np.cross(w, x).ravel())
    # a straight yarn does not move under a turn about its own axis: drop what vanishes
    U, S, _ = np.linalg.svd(np.stack(modes, axis=1), full_matrices=False)
    return U[:, S > 1e-10 * S.max()]


def lowest_eigenvalues(model, y, k=6):
    """The k lowest eigenvalues of the reduced Hessian at y, rigid motions of a
    free body excluded (ascending), and the scale max|diag H| they compare with."""
    H = model.reduced_hessian(y).tocsc()
    n = H.shape[0]
    R = rigid_modes(model, y)
    scale = float(np.abs(H.diagonal()).max())
    beta = scale
    if n <= DENSE_LIMIT:
        A = H.toarray()
        if R is not None:
            A += beta * R @ R.T
        return np.linalg.eigvalsh(0.5 * (A + A.T))[:k], scale
    sigma = -1e-6 * scale
    lu = splinalg.splu((H - sigma * sparse.identity(n, format="csc")).tocsc(),
                       permc_spec="COLAMD")
    if R is None:
        op = splinalg.LinearOperator((n, n), matvec=lu.solve, dtype=float)
        A = H
    else:
        AinvR = lu.solve(R)
        small = np.linalg.inv(np.eye(R.shape[1]) / beta + R.T @ AinvR)

        def solve(x):
            z = lu.solve(x)
            return z - AinvR @ (small @ (R.T @ z))
        op = splinalg.LinearOperator((n, n), matvec=solve, dtype=float)
        A = splinalg.LinearOperator((n, n), matvec=lambda x: H @ x + beta * R @ (R.T @ x),
                                    dtype=float)
    vals = splinalg.eigsh(A, k=min(k, n - 2), sigma=sigma, OPinv=op, which="LM",
                          return_eigenvectors=False)
    return np.sort(vals), scale


def stability(model, y):
    """(stable, lowest eigenvalue): stable when no eigenvalue of the reduced
    Hessian (rigid motions of a free body excluded) is below -ZERO x max|diag H|."""
    vals, scale = lowest_eigenvalues(model, y, k=1 if model.reduction()[0].shape[1] <= DENSE_LIMIT
                                     else 6)
    lowest = float(vals[0])
    return bool(lowest >= -ZERO * scale), lowest
