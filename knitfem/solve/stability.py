"""Eigenvalues of a tangent near zero: stability and critical points.

Works on any square (sparse or dense) matrix; only its symmetric part is
used, which at an equilibrium of a conservative problem is the matrix itself.
Congruence (e.g. scaling rotations against translations) changes the values
but not their signs, so zero crossings are unit-independent.
"""
import numpy as np
from scipy import sparse
from scipy.sparse import linalg as splinalg

DENSE_LIMIT = 3000   # below this size a dense eigensolver is fast and exact


def symmetric_part(K):
    return 0.5 * (K + K.T)


def eigenvalues_near_zero(K, k=1):
    """The k eigenvalues of sym(K) of smallest magnitude, sorted ascending
    (dense below DENSE_LIMIT unknowns, shift-invert Lanczos about 0 above)."""
    S = symmetric_part(K)
    n = S.shape[0]
    if n <= DENSE_LIMIT:
        dense = S.toarray() if sparse.issparse(S) else np.asarray(S)
        vals = np.linalg.eigvalsh(dense)
        return np.sort(vals[np.argsort(np.abs(vals))[:k]])
    vals = splinalg.eigsh(sparse.csc_matrix(S), k=k, sigma=0.0, which="LM",
                          return_eigenvectors=False)
    return np.sort(vals)


def lowest_eigenvalues(K, k=1):
    """The k algebraically smallest eigenvalues of sym(K), ascending: the first
    one changes sign where an equilibrium loses stability.  Dense below
    DENSE_LIMIT unknowns; above, Lanczos for the smallest algebraic values."""
    S = symmetric_part(K)
    if S.shape[0] <= DENSE_LIMIT:
        dense = S.toarray() if sparse.issparse(S) else np.asarray(S)
        return np.linalg.eigvalsh(dense)[:k]
    vals = splinalg.eigsh(sparse.csr_matrix(S), k=k, which="SA", return_eigenvectors=False)
    return np.sort(vals)
