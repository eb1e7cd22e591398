"""Stability of B-spline equilibria: the lowest eigenvalue of the reduced Hessian.

A free body (no clamp, no fixed point) has six rigid motions at zero
energy; they are not instabilities, so they are lifted out of the way: the
eigenproblem is solved for H + beta R R^T, R an orthonormal basis of the
rigid motions of the control points (a curve moves rigidly with its control
points), beta the largest diagonal entry of H.  Above ``DENSE_LIMIT``
unknowns: shift-invert Lanczos (ARPACK) about a slightly negative shift,
with (H - sigma I)^-1 from one sparse LU and the rank-6 lift by Woodbury's
formula, so no dense matrix is ever formed; below it, a dense eigensolver.
The same lifted solve gives the Newton step to the nearest equilibrium
(:func:`equilibrium_distance`): how far a relaxed state still is from rest.
"""
import numpy as np
from scipy import sparse
from scipy.sparse import linalg as splinalg

from .relax import largest_move

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


def _lifted_inverse(H, R, beta, shift):
    """x -> (H - shift I + beta R R^T)^-1 x from one sparse LU of H - shift I
    (COLAMD) and the rank-6 lift by Woodbury's formula (no dense matrix)."""
    n = H.shape[0]
    lu = splinalg.splu((H - shift * sparse.identity(n, format="csc")).tocsc(),
                       permc_spec="COLAMD")
    if R is None:
        return lu.solve
    AinvR = lu.solve(R)
    small = np.linalg.inv(np.eye(R.shape[1]) / beta + R.T @ AinvR)

    def solve(x):
        z = lu.solve(x)
        return z - AinvR @ (small @ (R.T @ z))
    return solve


def _lifted(H, R, beta):
    """x -> (H + beta R R^T) x: the Hessian with the rigid motions R lifted."""
    return (lambda x: H @ x) if R is None else (lambda x: H @ x + beta * (R @ (R.T @ x)))


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
    op = splinalg.LinearOperator((n, n), matvec=_lifted_inverse(H, R, beta, sigma), dtype=float)
    A = H if R is None else splinalg.LinearOperator((n, n), matvec=_lifted(H, R, beta),
                                                    dtype=float)
    vals = splinalg.eigsh(A, k=min(k, n - 2), sigma=sigma, OPinv=op, which="LM",
                          return_eigenvectors=False)
    return np.sort(vals), scale


def equilibrium_distance(model, y, refine=2):
    """How far the equilibrium is from y, by one Newton step d = -H^-1 g
    (rigid motions of a free body lifted out): the largest control-point move
    of d (length, the model's units); 0 where the force is below the model's
    round-off floor; None where d does not descend (then the state is not near
    a minimum; whether H is definite is :func:`stability`'s to say).

    Near a minimum the residual alone does not say this: a relative residual of
    1e-6 against the stiff stretching forces can leave a soft mode (a swatch
    rolling, yarn sliding) far from rest.  The quadratic model is exact to
    second order, so the estimate is the remaining move where it is small.
    The LU carries a tiny shift (the rigid null space of a free body would
    make it singular); ``refine`` steps of iterative refinement against the
    unshifted lifted Hessian take the shift's bias out of the soft modes."""
    _, g, _ = model.reduced_energy(y)
    if np.linalg.norm(g) <= getattr(model, "roundoff", 0.0):
        return 0.0                  # no force above round-off: nothing to measure
    H = model.reduced_hessian(y).tocsc()
    scale = float(np.abs(H.diagonal()).max())
    R = rigid_modes(model, y)
    solve = _lifted_inverse(H, R, scale, -1e-12 * scale)
    lifted = _lifted(H, R, scale)
    d = -solve(g)
    for _ in range(refine):
        d += solve(-g - lifted(d))
    if not np.all(np.isfinite(d)) or g @ d >= 0.0:
        return None
    return largest_move(model.reduction()[0], d)


def stability(model, y):
    """(stable, lowest eigenvalue): stable when no eigenvalue of the reduced
    Hessian (rigid motions of a free body excluded) is below -ZERO x max|diag H|."""
    vals, scale = lowest_eigenvalues(model, y, k=1 if model.reduction()[0].shape[1] <= DENSE_LIMIT
                                     else 6)
    lowest = float(vals[0])
    return bool(lowest >= -ZERO * scale), lowest
