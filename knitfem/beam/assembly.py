"""All rods of a model on one scikit-fem ``MeshLine`` in arclength, 6 dofs per node.

The mesh coordinate is the reference arclength (rods laid end to end with a
gap, disconnected); positions and rotations are fields on it.  scikit-fem
supplies the mesh, the P1 vector basis (dof numbering: node-wise interleaved,
``(ux, uy, uz, rx, ry, rz)``), the one-point midpoint quadrature and its
weights (the element lengths), line loads as a ``LinearForm``, and the sparse
format (``COOData``).  Element residuals and tangents come from
:mod:`knitfem.beam.element`; they are scattered into a CSR matrix whose
sparsity pattern is computed once.
"""
import numpy as np
from scipy import sparse
from skfem import Basis, ElementLineP1, ElementVector, LinearForm, MeshLine1
from skfem.assembly.form.coo_data import COOData

from .element import element_forces, element_strains

MIDPOINT_RULE = (np.array([[0.5]]), np.array([1.0]))   # reduced integration
DOFS_PER_NODE = 6


@LinearForm
def line_load(v, w):
    """Work of a force per unit length ``w.f`` (3, nel, nq) on the translations."""
    return w.f[0] * v[0] + w.f[1] * v[1] + w.f[2] * v[2]


class RodAssembly:
    """Connectivity and element data of several disjoint rods.

    Attributes: ``node_offset[k]`` first global node of rod k, ``elements``
    (2, nel) node pairs, ``h`` (nel,) element lengths, ``gamma0``/``kappa0``/
    ``CN``/``CM`` (nel, 3) per element, ``element_dofs`` (12, nel).
    """

    def __init__(self, rods):
        if len(rods) == 0:
            raise ValueError("a model needs at least one rod")
        self.rods = list(rods)
        sizes = [r.s.shape[0] for r in self.rods]
        self.node_offset = np.concatenate([[0], np.cumsum(sizes)])
        self.n_nodes = int(self.node_offset[-1])
        self.n_dofs = DOFS_PER_NODE * self.n_nodes
        coords, conn, shift = [], [], 0.0
        for r, off in zip(self.rods, self.node_offset):
            coords.append(r.s - r.s[0] + shift)
            shift = coords[-1][-1] + 1.0
            i = np.arange(r.n_elements) + off
            conn.append(np.stack([i, i + 1]))
        self.mesh = MeshLine1(np.concatenate(coords)[None, :], np.concatenate(conn, axis=1))
        self.basis = Basis(self.mesh, ElementVector(ElementLineP1(), DOFS_PER_NODE),
                           quadrature=MIDPOINT_RULE)
        self.elements = self.mesh.t
        self.element_dofs = self.basis.element_dofs
        self.h = self.basis.dx[:, 0].copy()
        self.gamma0 = np.concatenate([r.gamma0 for r in self.rods])
        self.kappa0 = np.concatenate([r.kappa0 for r in self.rods])
        self.CN = np.concatenate([np.tile(r.section.CN, (r.n_elements, 1)) for r in self.rods])
        self.CM = np.concatenate([np.tile(r.section.CM, (r.n_elements, 1)) for r in self.rods])
        self.rod_of_element = np.concatenate(
            [np.full(r.n_elements, k) for k, r in enumerate(self.rods)])
        self._patterns = {}

    def initial_positions(self):
        return np.concatenate([r.X for r in self.rods])

    def initial_rotations(self):
        return np.concatenate([r.Q for r in self.rods])

    # -- element evaluation -------------------------------------------------------
    def element_arrays(self, x, q):
        a, b = self.elements
        return x[a], x[b], q[a], q[b]

    def force_noise(self, size):
        """Round-off level of the assembled internal forces (the norm weighted as
        in BeamModel.residual_weights) for coordinates of magnitude ``size`` (a
        fixed scale of the problem, not the current iterate).  Two sources per
        element: chords x_B - x_A carry an absolute error ~eps size, which C_N / h
        turns into a force error; unit quaternions carry ~eps in rotation, which
        C_M / h turns into a moment error, weighed by 1/h in the norm.  The chord
        term dominates slender rods; the moment term thick, finely meshed ones
        (L/d = 2 with 2000 elements: 16x).  Measured floors on the verification
        cases lie between 0.35 and 0.9 of this estimate with size = the largest
        coordinate."""
        chords = self.CN.max(axis=1) * float(size) / self.h
        turns = self.CM.max(axis=1) / self.h**2
        return float(np.finfo(float).eps * np.sqrt(np.sum(chords**2 + turns**2)))

    def strains(self, x, q):
        """Gamma, K (nel, 3) and midpoint triads (nel, 3, 3) of a configuration."""
        return element_strains(*self.element_arrays(x, q), self.h)

    def forces(self, x, q, tangent=True, free=None, direction=None):
        """Internal energy, internal force vector (n_dofs,) and tangent (CSR).

        x : (n_nodes, 3) positions; q : (n_nodes, 4) unit quaternions.
        free : optional boolean mask (n_dofs,); the tangent is then returned
        for the free dofs only (rows and columns), built without slicing.
        direction : optional (n_dofs,); then K @ direction (all dofs) is
        returned as a fourth value, summed element by element.
        """
        energy, res, Ke = element_forces(*self.element_arrays(x, q), self.h, self.gamma0,
                                         self.kappa0, self.CN, self.CM, tangent)
        dofs = self.element_dofs.T
        f = np.bincount(dofs.ravel(), weights=res.ravel(), minlength=self.n_dofs)
        K = self.scatter(Ke, free) if tangent else None
        if direction is None:
            return float(energy.sum()), f, K
        Kv = np.einsum("eij,ej->ei", Ke, direction[dofs])
        return float(energy.sum()), f, K, np.bincount(dofs.ravel(), weights=Kv.ravel(),
                                                      minlength=self.n_dofs)

    # -- sparse assembly --------------------------------------------------------------
    def coo(self, Ke):
        """Element matrices (nel, 12, 12) as scikit-fem ``COOData`` (the reference path)."""
        dofs = self.element_dofs.T
        rows = np.broadcast_to(dofs[:, :, None], Ke.shape).ravel()
        cols = np.broadcast_to(dofs[:, None, :], Ke.shape).ravel()
        return COOData(np.stack([rows, cols]), Ke.ravel(), (self.n_dofs, self.n_dofs), None)

    def _pattern(self, free):
        """CSR structure and the slot of every element-matrix entry in it;
        entries in a fixed row or column go to a spare slot that is dropped."""
        key = None if free is None else np.asarray(free, bool).tobytes()
        if key not in self._patterns:
            index, n = _numbering(free, self.n_dofs)
            self._patterns[key] = csr_pattern(index[self.element_dofs.T], n)
        return self._patterns[key]

    def scatter(self, Ke, free=None):
        """CSR matrix of element matrices (nel, 12, 12), optionally restricted to
        the ``free`` dofs; the sparsity pattern is computed once per mask."""
        return scatter_blocks(self._pattern(free), Ke)

    def distributed_load(self, force_per_length):
        """Consistent nodal forces (n_dofs,) of a force per unit length per rod.

        force_per_length : (n_rods, 3); with one-point quadrature each node of an
        element receives f h / 2, exact for loads uniform on the element.
        """
        f = np.asarray(force_per_length, dtype=float)[self.rod_of_element]   # (nel, 3)
        return line_load.assemble(self.basis, f=f.T[:, :, None])


def csr_pattern(dofs, n):
    """CSR structure (indices, indptr) of per-block matrices at ``dofs`` (m, k)
    (numbered among n unknowns, -1 where fixed) and the slot of every block
    entry in it, (slots, indices, indptr, n); entries in a fixed row or column
    go to a spare slot that is dropped."""
    keep = ((dofs[:, :, None] >= 0) & (dofs[:, None, :] >= 0)).ravel()
    flat = (dofs[:, :, None].astype(np.int64) * n + dofs[:, None, :]).ravel()
    unique, slot = np.unique(flat[keep], return_inverse=True)
    slots = np.full(flat.shape[0], unique.shape[0])
    slots[keep] = slot
    indptr = np.searchsorted(unique // n, np.arange(n + 1))
    return slots, unique % n, indptr, n


def scatter_blocks(pattern, blocks):
    """CSR matrix of per-block matrices (m, k, k) in a :func:`csr_pattern`."""
    slots, indices, indptr, n = pattern
    data = np.bincount(slots, weights=np.ravel(blocks), minlength=indices.shape[0] + 1)
    return sparse.csr_matrix((data[:-1], indices, indptr), shape=(n, n))


# kept CSR patterns of block_matrix(..., keep_pattern=True), by their dofs
# (friction anchors keep theirs for a whole round); only their speed depends
# on this cache, not their arithmetic: a pattern is the same built or kept
_PATTERNS = {}
_PATTERN_LIMIT = 8


def _kept(dofs, n_dofs, free, mirror=False):
    """The kept pattern of these dofs, and with ``mirror`` its
    :func:`mirror_slots` (computed once, kept with the pattern)."""
    key = (n_dofs, dofs.shape, dofs.tobytes(), None if free is None else free.tobytes())
    if key not in _PATTERNS:
        while len(_PATTERNS) >= _PATTERN_LIMIT:
            del _PATTERNS[next(iter(_PATTERNS))]
        index, n = _numbering(free, n_dofs)
        _PATTERNS[key] = [csr_pattern(index[dofs], n), None]
    entry = _PATTERNS[key]
    if mirror and entry[1] is None:
        _, indices, indptr, n = entry[0]
        entry[1] = mirror_slots(indices, indptr, n)
    return entry


def mirror_slots(indices, indptr, n):
    """Where the mirror (j, i) of every entry (i, j) of a structurally
    symmetric CSR pattern (sorted indices) sits in its data."""
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr))
    return np.searchsorted(rows * n + indices, indices.astype(np.int64) * n + rows)


def block_vector(dofs, values, n_dofs):
    """Sum of per-block vectors values (m, k) into a vector (n_dofs,) at dofs (m, k)."""
    return np.bincount(dofs.ravel(), np.ravel(values), minlength=n_dofs)


def _free_numbering(free):
    """Index of every dof among the ``free`` ones (-1 where fixed) and their count."""
    index = np.cumsum(free) - 1
    index[~free] = -1
    return index, int(np.count_nonzero(free))


def _numbering(free, n_dofs):
    """:func:`_free_numbering` of a mask, or all n_dofs in order when ``free`` is None."""
    if free is None:
        return np.arange(n_dofs), n_dofs
    return _free_numbering(np.asarray(free, bool))


def _factored_matrix(dofs, blocks, n_dofs, free):
    """block_matrix of :class:`knitfem.contact.friction.Factored` blocks:
    G^T W G with G (m r, n) the factors J scattered to the dofs (their
    structural zeros dropped) and W block-diagonal H, by sparse products."""
    J, H = blocks.J, blocks.H
    m, r, w = J.shape
    n = n_dofs
    cols = np.broadcast_to(dofs[:, None, :], J.shape).ravel()
    rows = np.broadcast_to(np.arange(m * r).reshape(m, r, 1), J.shape).ravel()
    data = J.ravel()
    keep = data != 0.0
    if free is not None:
        index, n = _free_numbering(free)
        cols = index[cols]
        keep &= cols >= 0
    G = sparse.csr_matrix((data[keep], (rows[keep], cols[keep])), shape=(m * r, n))
    W = sparse.bsr_matrix((H, np.arange(m), np.arange(m + 1)), shape=(m * r, m * r))
    return (G.T @ (W @ G)).tocsr()


def block_matrix(dofs, blocks, n_dofs, free=None, keep_pattern=False, symmetrize=False):
    """CSR matrix of per-block matrices blocks (m, k, k) at dofs (m, k) (duplicates
    summed), restricted to the ``free`` dofs (mask (n_dofs,)) if given.  For terms
    whose pattern may change between calls (contact pairs, friction anchors,
    ties).  ``blocks`` may also be :class:`knitfem.contact.friction.Factored`
    (J^T H J per block).  ``keep_pattern``: for blocks whose dofs stay the same
    over many calls (friction anchors within a round), the CSR pattern is kept
    by the dofs and the blocks are scattered into it (Factored: its dense
    blocks, 4 x faster than the products); the arithmetic depends on the flag
    only, never on what was kept before (a resumed run repeats its path).
    ``symmetrize`` (with ``keep_pattern``): the symmetric part of the sum,
    taken on the assembled entries (one gather through the pattern's
    mirror) instead of block by block (10 x 35: 77 ms for the transposed
    copy of 5 635 friction blocks of 30 x 30, more than their scatter)."""
    if keep_pattern:
        dense = blocks.dense() if hasattr(blocks, "J") else blocks
        pattern, mirror = _kept(dofs, n_dofs, free, symmetrize)
        K = scatter_blocks(pattern, dense)
        if symmetrize:
            K.data = 0.5 * (K.data + K.data[mirror])
        return K
    if symmetrize:
        raise ValueError("block_matrix: symmetrize needs keep_pattern")
    if hasattr(blocks, "J"):
        K = _factored_matrix(dofs, blocks, n_dofs, free)
        extra = getattr(blocks, "G", None)
        return K if extra is None else K + block_matrix(dofs, extra, n_dofs, free)
    rows = np.broadcast_to(dofs[:, :, None], blocks.shape).ravel()
    cols = np.broadcast_to(dofs[:, None, :], blocks.shape).ravel()
    data, n = np.ravel(blocks), n_dofs
    # exact zeros dropped: structural zeros cost a sort into CSR for nothing
    keep = data != 0.0
    if free is not None:
        index, n = _free_numbering(free)
        rows, cols = index[rows], index[cols]
        keep &= (rows >= 0) & (cols >= 0)
    rows, cols, data = rows[keep], cols[keep], data[keep]
    return sparse.csr_matrix((data, (rows, cols)), shape=(n, n))
