"""Eigenvalues of a tangent near zero: stability and critical points.

Works on any square (sparse or dense) matrix; only its symmetric part is
used, which at an equilibrium of a conservative problem is the matrix itself.
Congruence (e.g. scaling rotations against translations) changes the values
but not their signs, so zero crossings and inertia are unit-independent.

Small matrices (up to DENSE_LIMIT unknowns) use a dense eigensolver; larger
ones never do: their inertia comes from one sparse LDL^T
(:mod:`knitfem.solve.factor`) and their lowest eigenvalues from shift-invert
Lanczos about a shift below the spectrum, found by inertia counts, with the
same factorisation as the inverse operator (plain Lanczos for the smallest
algebraic eigenvalues does not converge on stiff rod tangents: a 6144-unknown
cantilever made ARPACK give up).
"""
import numpy as np
from scipy import sparse
from scipy.sparse import linalg as splinalg

from .factor import LDLt, inertia as _inertia

DENSE_LIMIT = 3000   # below this size a dense eigensolver is fast and exact


def symmetric_part(K):
    return 0.5 * (K + K.T)


def _dense(S):
    return S.toarray() if sparse.issparse(S) else np.asarray(S)


def _count_below(S, sigma):
    """(eigenvalues of S below sigma, the LDL^T of S - sigma I): Sylvester."""
    f = LDLt(S - sigma * sparse.identity(S.shape[0], format="csc"))
    return (f.negative if f.reliable else None), f


def _shift_below(S):
    """A shift sigma <= 0 with no eigenvalue of S below it and the LDL^T of
    S - sigma I.  sigma = 0 when S has no negative eigenvalue; otherwise within
    a factor 2 of the lowest eigenvalue (so shift-invert converges), found by
    bisection on log|sigma| with inertia counts (about a dozen factorisations)."""
    count, f = _count_below(S, 0.0)
    if count == 0 and f.zero == 0:
        return 0.0, f
    norm = float(abs(S).sum(axis=1).max()) or 1.0      # no eigenvalue below -norm
    lo, hi = -18.0, 0.5               # log10(shift / norm): count > 0 at lo, == 0 at hi
    found = None
    for _ in range(40):
        if hi - lo <= np.log10(2.0):
            break
        mid = 0.5 * (lo + hi)
        count, g = _count_below(S, -norm * 10.0**mid)
        if count == 0:
            hi, found = mid, g
        else:
            lo = mid
    if found is None:
        count, found = _count_below(S, -norm * 10.0**hi)
        if count != 0:
            raise np.linalg.LinAlgError("lowest_eigenvalues: no shift below the spectrum found")
    return -norm * 10.0**hi, found


def lowest_eigenvalues(K, k=1):
    """The k algebraically smallest eigenvalues of sym(K), ascending: the first
    one changes sign where an equilibrium loses stability."""
    S = symmetric_part(K)
    if S.shape[0] <= DENSE_LIMIT:
        return np.linalg.eigvalsh(_dense(S))[:k]
    S = sparse.csc_matrix(S)
    sigma, f = _shift_below(S)
    op = splinalg.LinearOperator(S.shape, matvec=f.solve, dtype=float)
    vals = splinalg.eigsh(S, k=k, sigma=sigma, OPinv=op, which="LM",
                          return_eigenvectors=False)
    return np.sort(vals)


def null_vector(K):
    """Unit eigenvector of sym(K) for its eigenvalue of smallest magnitude,
    and that eigenvalue (the direction a bifurcating branch leaves along)."""
    S = symmetric_part(K)
    if S.shape[0] <= DENSE_LIMIT:
        vals, vecs = np.linalg.eigh(_dense(S))
        i = int(np.argmin(np.abs(vals)))
        return vecs[:, i], float(vals[i])
    S = sparse.csc_matrix(S)
    # shift-invert about a point a little off zero: S itself is (nearly) singular here
    scale = float(abs(S).max()) or 1.0
    sigma = 1e-10 * scale
    f = LDLt(S - sigma * sparse.identity(S.shape[0], format="csc"))
    op = splinalg.LinearOperator(S.shape, matvec=f.solve, dtype=float)
    vals, vecs = splinalg.eigsh(S, k=1, sigma=sigma, OPinv=op, which="LM")
    return vecs[:, 0], float(vals[0])


def inertia(K):
    """(number of negative eigenvalues of sym(K), log|det sym(K)|): Sylvester's
    law on one sparse LDL^T with a fill-reducing order (see
    :func:`knitfem.solve.factor.inertia`); dense below DENSE_LIMIT when the
    factorisation is unreliable.  The log-determinant is a smooth test function
    for locating where an eigenvalue crosses zero."""
    try:
        return _inertia(K)
    except np.linalg.LinAlgError:
        if K.shape[0] > DENSE_LIMIT:
            raise
    vals = np.linalg.eigvalsh(_dense(symmetric_part(K)))
    with np.errstate(divide="ignore"):
        return int(np.count_nonzero(vals < 0)), float(np.sum(np.log(np.abs(vals))))


def negative_eigenvalue_count(K):
    """Number of negative eigenvalues of sym(K) (the index of an equilibrium)."""
    return inertia(K)[0]


def lowest_scaled_eigenvalue(H):
    """Lowest eigenvalue of the tangent scaled by its diagonal, D^-1/2 H D^-1/2
    (dimensionless: forces and moments mixed; > 0 exactly when H is positive
    definite, by congruence)."""
    d = np.sqrt(np.maximum(np.abs(H.diagonal()), 1e-300))
    S = sparse.diags(1.0 / d) @ H @ sparse.diags(1.0 / d)
    return float(lowest_eigenvalues(S, 1)[0])
