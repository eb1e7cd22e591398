"""Eigenvalues of a tangent near zero: stability and critical points.

Works on any square (sparse or dense) matrix; only its symmetric part is
used, which at an equilibrium of a conservative problem is the matrix itself.
Congruence (e.g. scaling rotations against translations) changes the values
but not their signs, so zero crossings and inertia are unit-independent.
"""
import numpy as np
from scipy import sparse
from scipy.sparse import linalg as splinalg

DENSE_LIMIT = 3000   # below this size a dense eigensolver is fast and exact


def symmetric_part(K):
    return 0.5 * (K + K.T)


def _dense(S):
    return S.toarray() if sparse.issparse(S) else np.asarray(S)


def lowest_eigenvalues(K, k=1):
    """The k algebraically smallest eigenvalues of sym(K), ascending: the first
    one changes sign where an equilibrium loses stability.  Dense below
    DENSE_LIMIT unknowns; above, Lanczos for the smallest algebraic values."""
    S = symmetric_part(K)
    if S.shape[0] <= DENSE_LIMIT:
        return np.linalg.eigvalsh(_dense(S))[:k]
    vals = splinalg.eigsh(sparse.csr_matrix(S), k=k, which="SA", return_eigenvectors=False)
    return np.sort(vals)


def null_vector(K):
    """Unit eigenvector of sym(K) for its eigenvalue of smallest magnitude,
    and that eigenvalue (the direction a bifurcating branch leaves along)."""
    S = symmetric_part(K)
    if S.shape[0] <= DENSE_LIMIT:
        vals, vecs = np.linalg.eigh(_dense(S))
        i = int(np.argmin(np.abs(vals)))
        return vecs[:, i], float(vals[i])
    vals, vecs = splinalg.eigsh(sparse.csc_matrix(S), k=1, sigma=0.0, which="LM")
    return vecs[:, 0], float(vals[0])


def inertia(K):
    """(number of negative eigenvalues of sym(K), log|det sym(K)|).

    Sylvester's law on an LDL^T factorisation: sparse LU with the natural
    order and no pivoting has U's diagonal = D.  If SuperLU had to pivot (or
    met a zero pivot) a dense eigensolver decides.  The log-determinant is a
    smooth test function for locating where an eigenvalue crosses zero.
    """
    S = sparse.csc_matrix(symmetric_part(K))
    n = S.shape[0]
    try:
        lu = splinalg.splu(S, permc_spec="NATURAL", diag_pivot_thresh=0.0,
                           options=dict(SymmetricMode=True))
        d = lu.U.diagonal()
        if np.array_equal(lu.perm_r, np.arange(n)) and np.all(np.isfinite(d)) and np.all(d != 0):
            return int(np.count_nonzero(d < 0)), float(np.sum(np.log(np.abs(d))))
    except RuntimeError:
        pass
    vals = np.linalg.eigvalsh(S.toarray())
    with np.errstate(divide="ignore"):
        return int(np.count_nonzero(vals < 0)), float(np.sum(np.log(np.abs(vals))))


def negative_eigenvalue_count(K):
    """Number of negative eigenvalues of sym(K) (the index of an equilibrium)."""
    return inertia(K)[0]
