"""Sparse symmetric factorisations with a fill-reducing order.

``LDLt(A)``: A = P L D L^T P^T without pivoting (QDLDL, approximate minimum
degree order).  It gives solves, the inertia of A (Sylvester's law: the signs
of D are the signs of A's eigenvalues, counted) and log|det A|, at the cost of
one sparse factorisation: that is how stability is decided at 1e5+ unknowns,
never with a dense eigensolver.  Without pivoting a strongly indefinite matrix
can lose accuracy; every factorisation checks its own solve on a probe vector
and says so (``reliable``), and callers fall back where it is not.

``Cholesky(A)``: for symmetric positive definite matrices (the modified Newton
systems of energy minimisation).  CHOLMOD (scikit-sparse, supernodal, METIS
order) when it is installed, else LDL^T; ``NotPositiveDefinite`` when A is not.
Measured on a 55 x 35 plain-knit tangent (191 118 unknowns, one thread):
CHOLMOD 1.5 s, QDLDL 6.8 s, SuperLU (MMD on A^T + A, symmetric mode) 5.3 s,
SuperLU with its default COLAMD order 18.6 s.
"""
import numpy as np
from scipy import sparse

try:                                            # optional: the `cholmod` extra
    from sksparse import cholmod as _cholmod
except ImportError:                             # pragma: no cover - depends on the install
    _cholmod = None

import qdldl

PROBE_TOL = 1e-12         # normwise backward error of the probe solve for a usable factorisation
TINY_PIVOT = 1e-13        # pivots below this fraction of the largest count as zero
REORDER = 10              # new patterns factorised in a kept order before ordering afresh (Factorizer)
KEEP_ORDER_NNZ = 2_000_000    # ... for matrices with at least this many entries (below, ordering is cheap)
KEEP_ORDER_GROWTH = 0.05      # ... and at most this share more entries than the ordered one


class NotPositiveDefinite(ArithmeticError):
    """A Cholesky factorisation met a non-positive pivot."""


def _with_diagonal(A):
    """CSC copy of A with every diagonal entry stored (QDLDL needs them)."""
    coo = sparse.coo_matrix(A, dtype=float)
    idx = np.flatnonzero(coo.diagonal() == 0)
    # COO -> CSC sums duplicates and keeps explicit zeros: the diagonal is stored
    A = sparse.csc_matrix((np.concatenate([coo.data, np.zeros(idx.size)]),
                           (np.concatenate([coo.row, idx]), np.concatenate([coo.col, idx]))),
                          shape=coo.shape)
    A.sort_indices()
    return A


def _probe(A, solve):
    """Normwise backward error |A x - b| / (|A| |x| + |b|) (infinity norms) of a
    solve with a fixed pseudo-random right-hand side: ~1e-16 for a stable
    factorisation however ill-conditioned A is (stiff rods: 1e20), large where
    the unpivoted elimination grew."""
    b = np.cos(np.arange(A.shape[0]) * 1.618)
    x = solve(b)
    if not np.all(np.isfinite(x)):
        return np.inf
    norm_A = float(abs(A).sum(axis=1).max())
    return float(np.abs(A @ x - b).max() / (norm_A * np.abs(x).max() + np.abs(b).max()))


class LDLt:
    """LDL^T of a symmetric sparse matrix (full storage), see the module docstring.

    Attributes: ``d`` (n,) pivots, ``negative`` count of negative pivots,
    ``zero`` count of pivots below ``tiny`` relative to the largest,
    ``logdet`` log|det A|, ``reliable`` whether the probe solve met PROBE_TOL.
    """

    def __init__(self, A, *, tiny=TINY_PIVOT):
        A = _with_diagonal(A)
        self.A = A
        self.n = A.shape[0]
        try:
            self._solver = qdldl.Solver(A)
        except (RuntimeError, ValueError) as err:         # structurally singular
            raise np.linalg.LinAlgError(f"LDL^T factorisation failed: {err}") from None
        d = np.asarray(self._solver.factors()[1])
        self.d = d
        scale = np.max(np.abs(d)) if d.size else 1.0
        self.zero = int(np.count_nonzero(np.abs(d) <= tiny * scale))
        self.negative = int(np.count_nonzero(d < 0))
        with np.errstate(divide="ignore"):
            self.logdet = float(np.sum(np.log(np.abs(d))))
        exact = bool(np.all(np.isfinite(d)) and np.all(d != 0))
        self.residual = _probe(A, self.solve) if exact else np.inf
        self.reliable = bool(exact and self.residual <= PROBE_TOL)

    def solve(self, b):
        return np.asarray(self._solver.solve(np.asarray(b, dtype=float)))


class Cholesky:
    """A = L L^T of a symmetric positive definite sparse matrix (see module docstring).

    ``backend`` is 'cholmod' or 'qdldl' (None: CHOLMOD when installed);
    ``refactor``: a CHOLMOD factor of a matrix with A's pattern, refactorised
    in place (see :class:`Factorizer`).  Raises NotPositiveDefinite."""

    def __init__(self, A, *, backend=None, refactor=None):
        if backend not in (None, "cholmod", "qdldl"):
            raise ValueError(f"backend must be 'cholmod', 'qdldl' or None, got {backend!r}")
        if backend == "cholmod" and _cholmod is None:
            raise ValueError("backend 'cholmod' needs scikit-sparse (the `cholmod` extra)")
        A = sparse.csc_matrix(A, dtype=float)
        if _cholmod is not None and backend != "qdldl":
            try:
                if refactor is not None:          # same pattern: in place (Factorizer)
                    refactor.cholesky_inplace(A)
                    self._factor = refactor
                else:
                    self._factor = _cholmod.cholesky(A, ordering_method="default")
            except _cholmod.CholmodNotPositiveDefiniteError as err:
                raise NotPositiveDefinite(str(err)) from None
            # CHOLMOD stops only at a pivot <= 0; a pivot at round-off level (a
            # near-null mode) must count as zero too, as in LDLt: a step along
            # it is round-off amplified (measured: mirror-image relaxations
            # 0.04 mm apart after 60 steps, 1e-7 with the test)
            d = self._factor.D()
            if not (np.all(np.isfinite(d)) and d.min() > TINY_PIVOT * d.max()):
                raise NotPositiveDefinite("a pivot at round-off level (near-singular matrix)")
            self.backend = "cholmod"
            self.solve = self._factor
            return
        ldl = LDLt(A)
        if ldl.negative or ldl.zero:
            raise NotPositiveDefinite(f"{ldl.negative} negative and {ldl.zero} zero pivots")
        self.backend = "qdldl"
        self.solve = ldl.solve


class Factorizer:
    """Cholesky factorisations of a sequence of matrices that often share a
    sparsity pattern (the shifted retries of one modified Newton step, the
    steps of a friction round while no contact forms or ends).  With CHOLMOD
    the factor of the last pattern is refactorised in place (its symbolic
    analysis and storage reused: 10 x 35 swatch, 0.26 s against 0.35-0.44 s
    for a fresh factorisation, CPU time), so **a factorisation returned is
    valid only until the next call**.

    A new pattern is factorised in the fill-reducing order of the last full
    analysis while fewer than ``reorder`` patterns have come since it: the
    matrix permuted into that order, analysed in its natural order.  A rolling
    swatch changes its contact pattern at almost every step (25 x 35: 30
    patterns in 31 factorisations, each adding 18-1 000 entries), and the
    ordering was the largest part of an analysis (0.70 s against 0.13 s to
    permute and 0.07 s to analyse in order, with a factor 0.6 % fuller after
    6 steps).  Only matrices of ``least_nnz`` entries or more: below that the
    ordering costs no more than the permutation (10 x 35 early, 1.8e6
    entries: 37 ms either way; 4 x 4: 1.4 against 2.0 ms, and the whole 4 x 4
    relaxation 10 % slower an iteration in a kept order).  And only while the
    matrix has at most ``growth`` more entries than the one the order was made
    for: a relaxation's first steps bring the yarns into contact (10 x 35 at
    lam 0.34: 1.28e6 entries, then 1.56e6 and 1.87e6), and the order of the
    contact-free start, kept for those couplings, filled the 55 x 35's factor
    past 22 GB (killed by the kernel at its third step; CHOLMOD out of memory
    under a 14 GB limit).  ``reorder=0``
    orders every pattern afresh; then the factors are
    those of :class:`Cholesky` bit for bit (the analysis does not depend on
    the values; tested), also after a refused, not positive definite matrix;
    in a kept order they agree with them to round-off (tested).  A sequence
    of calls gives the same factors however often it is repeated: the order
    depends only on the matrices given since the Factorizer was made."""

    def __init__(self, backend=None, reorder=REORDER, least_nnz=KEEP_ORDER_NNZ,
                 growth=KEEP_ORDER_GROWTH):
        self.backend = backend
        self.reorder, self.least_nnz, self.growth = int(reorder), int(least_nnz), float(growth)
        self._pattern = None
        self._factor = None
        self._order = None          # [permutation, patterns factorised in it since, its nnz]
        self._gather = None         # A.data -> the permuted matrix's data, for this pattern
        self.analyses = 0           # symbolic analyses made
        self.orderings = 0          # of which fill-reducing orderings
        self.factorizations = 0

    def __call__(self, A):
        A = sparse.csc_matrix(A, dtype=float)
        self.factorizations += 1
        if _cholmod is None or self.backend == "qdldl":
            return Cholesky(A, backend=self.backend)
        A.sort_indices()
        pattern = self._pattern
        if pattern is None or not (np.array_equal(pattern[0], A.indptr) and
                                   np.array_equal(pattern[1], A.indices)):
            self._pattern = (A.indptr.copy(), A.indices.copy())
            self.analyses += 1
            if (self._order is None or self._order[1] >= self.reorder or
                    A.nnz < self.least_nnz or A.nnz > (1.0 + self.growth) * self._order[2]):
                self._factor = _cholmod.analyze(A, ordering_method="default")
                self._order, self._gather = [self._factor.P(), 0, A.nnz], None
                self.orderings += 1
            else:
                perm = self._order[0]
                self._gather = _permuted_slots(A, perm)
                self._factor = _cholmod.analyze(_permuted(A, self._gather),
                                                ordering_method="natural")
                self._order[1] += 1
        if self._gather is None:
            return Cholesky(A, backend="cholmod", refactor=self._factor)
        perm = self._order[0]
        chol = Cholesky(_permuted(A, self._gather), backend="cholmod", refactor=self._factor)
        inner = chol.solve

        def solve(b):
            b = np.asarray(b, dtype=float)
            x = np.empty_like(b)
            x[perm] = inner(b[perm])
            return x
        chol.solve = solve
        return chol


def _permuted_slots(A, perm):
    """(slots, indices, indptr): the permuted matrix A[perm][:, perm] (CSC,
    sorted) as a gather of A.data, for every matrix of A's pattern."""
    marks = sparse.csc_matrix((np.arange(1.0, A.nnz + 1.0), A.indices, A.indptr),
                              shape=A.shape)
    B = sparse.csc_matrix(marks[perm][:, perm])
    B.sort_indices()
    if B.nnz != A.nnz:                      # pragma: no cover - scipy kept every entry
        raise RuntimeError("Factorizer: the permuted pattern lost entries")
    return B.data.astype(np.int64) - 1, B.indices, B.indptr


def _permuted(A, gather):
    slots, indices, indptr = gather
    return sparse.csc_matrix((A.data[slots], indices, indptr), shape=A.shape)


def cholmod_available():
    return _cholmod is not None


def inertia(K):
    """(negative eigenvalues of sym(K), log|det sym(K)|), from one sparse LDL^T.

    Falls back to the diagonally scaled matrix, shifted by 1e-12 of its unit
    diagonal, when a pivot vanishes or the solve is not backward stable (a
    singular point: the count is then of eigenvalues below the shift), and
    raises LinAlgError if even that is unreliable."""
    S = sparse.csc_matrix(0.5 * (K + K.T))
    f = LDLt(S)
    if f.reliable:
        return f.negative, f.logdet
    # symmetric diagonal scaling is a congruence (same inertia) that evens out
    # the pivots of stiff/soft rods; a shift of 1e-12 in those units counts a
    # numerically zero eigenvalue as non-negative
    diag = np.abs(S.diagonal())
    diag = np.where(diag > 0, diag, max(float(diag.max(initial=0.0)), 1.0))
    scale = sparse.diags(1.0 / np.sqrt(diag))
    scaled = sparse.csc_matrix(scale @ S @ scale)
    g = LDLt(scaled + 1e-12 * sparse.identity(S.shape[0], format="csc"))
    if not g.reliable:
        raise np.linalg.LinAlgError("inertia: the LDL^T factorisation of the tangent is "
                                    f"unreliable (backward error {g.residual:.1e})")
    return g.negative, g.logdet - float(np.sum(np.log(diag)))
