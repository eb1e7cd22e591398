"""Yarn-yarn contact for the beam model: its elements as contact segments.

Each element is a segment (x_A, x_B) with the radius of its rod's section and
its reference length as integration measure (contact energy per unit
reference length, so its derivatives involve positions only).  The pair
gradients and tangents of :mod:`knitfem.contact` land on the translational
dofs of the six nodes of a pair (two on the slave, four shaping the
master curve); the matrix is built per call (its pattern
changes with the active pairs) and added to the structural tangent.

Normal damping (``damping`` c > 0) acts only while an increment is being
solved: the load stepping sets ``rate_reference`` = (positions at the start
of the increment, its pseudo-time dt) and clears it afterwards, so
equilibria, continuation and reports see the elastic contact alone.  A
regularised friction law would use the same reference (slip of the slave
point along the master over dt).
"""
import numpy as np
from scipy import sparse

from ..contact import PenaltyLaw, SegmentContact
from .assembly import DOFS_PER_NODE


class BeamContact:
    """Contact among all elements of a model's rods (self-contact included,
    minus neighbours closer than ``exclude`` along a rod)."""

    def __init__(self, assembly, law, exclude=None, per_diameter=6, damping=0.0):
        radius = np.array([r.section.radius for r in assembly.rods])[assembly.rod_of_element]
        if not np.all(np.isfinite(radius)):
            raise ValueError("contact needs every rod's section to have a radius "
                             "(Section(radius=...) or Section.circle)")
        s_mid = np.concatenate([0.5 * (r.s[:-1] + r.s[1:]) for r in assembly.rods])
        self.segments = SegmentContact(law, radius, assembly.rod_of_element, s_mid, exclude,
                                       per_diameter)
        self.nodes = assembly.elements.T
        self.length = assembly.h
        self.n_dofs = assembly.n_dofs
        self.report = None
        self.damping = float(damping)      # line load per gap rate (force time / length^2)
        self.rate_reference = None         # (positions (n_nodes, 3), dt) during an increment

    def noise(self, size):
        """Round-off level of the contact forces for coordinates of magnitude
        ``size`` (a fixed scale): the gap of every active Gauss point carries an
        error ~eps size, which the penalty turns into k eps size per unit
        length (summed over the contact length of the last evaluation)."""
        if self.report is None or self.report.active_pairs == 0:
            return 0.0
        active_length = self.report.active_pairs * float(self.length.max())
        return float(self.segments.law.k * np.finfo(float).eps * size
                     * np.sqrt(active_length * self.length.max()))

    def _dofs(self, ends):
        """(m, 18) global dofs of the slots, from their segment ends (2 i + e)."""
        nodes = self.nodes[ends // 2, ends % 2]
        return (DOFS_PER_NODE * nodes[:, :, None] + np.arange(3)).reshape(-1, 18)

    def forces(self, x, tangent=True, free=None, direction=None):
        """Energy, force vector (n_dofs,), tangent (CSR, free dofs only if
        ``free`` is given) and K @ direction (or None)."""
        a, b = self.nodes[:, 0], self.nodes[:, 1]
        previous, rate = None, 0.0
        if self.damping > 0.0 and self.rate_reference is not None:
            x_prev, dt = self.rate_reference
            previous, rate = (x_prev[a], x_prev[b]), self.damping / dt
        energy, _, ends, grads, hess, self.report = self.segments.evaluate(
            x[a], x[b], tangent, self.length, previous, rate)
        dofs = self._dofs(ends)
        f = np.bincount(dofs.ravel(), grads.ravel(), minlength=self.n_dofs)
        K = Kv = None
        if tangent:
            rows = np.broadcast_to(dofs[:, :, None], hess.shape).ravel()
            cols = np.broadcast_to(dofs[:, None, :], hess.shape).ravel()
            n = self.n_dofs
            if free is not None:
                index = np.cumsum(free) - 1
                index[~free] = -1
                rows, cols = index[rows], index[cols]
                keep = (rows >= 0) & (cols >= 0)
                rows, cols, data, n = rows[keep], cols[keep], hess.ravel()[keep], int(free.sum())
            else:
                data = hess.ravel()
            K = sparse.csr_matrix((data, (rows, cols)), shape=(n, n))
            if direction is not None:
                Kv = np.bincount(dofs.ravel(), np.einsum("mij,mj->mi", hess,
                                                         direction[dofs]).ravel(),
                                 minlength=self.n_dofs)
        return energy, f, K, Kv


def default_law(rods, factor, regularisation):
    """Penalty relative to the softest rod: k = factor EI_min / r_min^4."""
    radii = np.array([r.section.radius for r in rods])
    if not np.all(np.isfinite(radii)):
        raise ValueError("contact needs every rod's section to have a radius "
                         "(Section(radius=...) or Section.circle)")
    EI = min(min(r.section.EI2, r.section.EI3) for r in rods)
    radius = float(radii.min())
    return PenaltyLaw.relative(EI, radius, factor, regularisation)
