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

from ..contact import PenaltyLaw, SegmentContact, carry_slip, friction_forces
from ..contact.corotated import left_jacobian_inverse
from ..contact.friction import coulomb_excess
from .assembly import DOFS_PER_NODE, block_matrix, block_vector
from .rotation import spatial_turn


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
        self.friction = 0.0                # Coulomb coefficient mu
        self.slip = 0.0                    # stick slip eps (length)
        self.anchors = None                # friction anchors of the current increment
        self.anchor_q = None               # nodal frames (n_nodes, 4) when they were set
        self.corotated = False             # friction's tangent planes turn with the master yarn

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

    def _rot_dofs(self, ends):
        """(m, 12) global rotation dofs of the rotation slots' segment ends."""
        nodes = self.nodes[ends // 2, ends % 2]
        return (DOFS_PER_NODE * nodes[:, :, None] + 3 + np.arange(3)).reshape(-1, 12)

    def _turns(self, q):
        """Rotation vectors (n_nodes, 3) of the frames since the friction
        anchors were set (spatial), and at the segment ends (n_seg, 2, 3)."""
        theta = spatial_turn(q, self.anchor_q)
        return theta, theta[self.nodes]

    def friction_state(self):
        """The friction anchors and their frames, to restore after a failed
        increment (both are replaced, never mutated, by :meth:`anchor_friction`)."""
        return self.anchors, self.anchor_q

    def restore_friction(self, saved):
        self.anchors, self.anchor_q = saved

    def anchor_friction(self, x, q, carry=True):
        """Anchor friction at positions x (n_nodes, 3) and frames q (n_nodes, 4):
        every Gauss point in contact there becomes an anchor with its normal
        force and frame at x; with ``carry`` it keeps the slip it had under the
        previous anchors (clipped to the stick radius), so the friction
        persists across increments and lagged updates (see
        :mod:`knitfem.contact.friction`)."""
        if self.friction <= 0.0:
            self.anchors = None
            return
        a, b = self.nodes[:, 0], self.nodes[:, 1]
        new = self.segments.friction_anchors(x[a], x[b], self.friction, self.length)
        if carry and self.anchors is not None:
            new = carry_slip(new, self.anchors, x[a], x[b], self.slip, self._turns(q)[1],
                             self.corotated)
        self.anchors, self.anchor_q = new, np.array(q, dtype=float)

    def coulomb_excess(self, x, q):
        """Fraction of the friction force above mu times the normal forces at
        x, q (:func:`knitfem.contact.friction.coulomb_excess`): what the
        lagged normal forces leave unsettled in an equilibrium."""
        if self.anchors is None or self.friction <= 0.0:
            return 0.0
        a, b = self.nodes[:, 0], self.nodes[:, 1]
        current = self.segments.friction_anchors(x[a], x[b], self.friction, self.length)
        return coulomb_excess(self.anchors, current, x[a], x[b], self.slip, self._turns(q)[1],
                              self.corotated)

    def blocks(self, x, q=None, tangent=True):
        """Energy and per-block groups [(dofs (m, w), gradients (m, w), Hessians
        (m, w, w) or None, psd)]: contact pairs (w = 18 translations), friction
        anchors (w = 30: 18 translations, 12 rotations; frames q needed; their
        Hessians :class:`knitfem.contact.friction.Factored`);
        ``psd`` says whether every Hessian block is positive semi-definite
        by construction (friction: :func:`knitfem.contact.friction.friction_forces`),
        None for a part the PSD model may leave out (the co-rotated
        friction's geometric part).  The friction groups (``psd`` True or
        None) keep their dofs for a whole round: their assembly keeps its
        CSR pattern (``block_matrix(..., keep_pattern=True)``)."""
        a, b = self.nodes[:, 0], self.nodes[:, 1]
        previous, rate = None, 0.0
        if self.damping > 0.0 and self.rate_reference is not None:
            x_prev, dt = self.rate_reference
            previous, rate = (x_prev[a], x_prev[b]), self.damping / dt
        energy, _, ends, grads, hess, self.report = self.segments.evaluate(
            x[a], x[b], tangent, self.length, previous, rate)
        groups = [(self._dofs(ends), grads, hess, False)]
        if self.anchors is not None and len(self.anchors.ends):
            if q is None:
                raise ValueError("friction needs the frames q (it twists the yarns)")
            theta, ends_theta = self._turns(q)
            Ef, gf, hf = friction_forces(self.anchors, x[a], x[b], self.slip, tangent,
                                         ends_theta, factored=True, corotated=self.corotated)
            # d theta / d(spatial increment) = J_l(theta)^-1: exact gradients for
            # the energy line search, and the Hessian's factors mapped alike
            # (J^T H3 J; what is left out is the gradient times d2 theta, of
            # order |g| |theta|).  With the leading term alone the Hessian was
            # off by 270 % along the 25 x 35's final Newton steps (its soft
            # modes are held by friction): t = 1 was refused and the rounds
            # converged linearly, stalling near 3e-7.  The co-rotated friction
            # differentiates with respect to the spatial turns itself
            if not self.corotated:
                rot_nodes = self.nodes[self.anchors.rot_ends // 2, self.anchors.rot_ends % 2]
                Jinv = left_jacobian_inverse(theta[rot_nodes])            # (k, 4, 3, 3)
                g_rot = gf[:, 18:].reshape(-1, 4, 3)
                gf = np.concatenate([gf[:, :18], np.einsum("kbji,kbj->kbi", Jinv,
                                                           g_rot).reshape(-1, 12)], axis=1)
                if hf is not None:
                    J_rot = np.einsum("kibj,kbjl->kibl", hf.J[:, :, 18:].reshape(-1, 3, 4, 3),
                                      Jinv)
                    hf = hf._replace(J=np.concatenate([hf.J[:, :, :18],
                                                       J_rot.reshape(-1, 3, 12)], axis=2))
            energy += Ef
            dofs = np.concatenate([self._dofs(self.anchors.ends),
                                   self._rot_dofs(self.anchors.rot_ends)], axis=1)
            if hf is not None and hf.G is not None:
                # the co-rotated friction's geometric part: indefinite, in the
                # Hessian but left out of the PSD model (psd None), whose
                # projections of thousands of dense 30 x 30 blocks cost more
                # than the rest of a step (10 x 35: 1.7 s against 0.6 s)
                groups.append((dofs, np.zeros_like(gf), hf.G, None))
                hf = hf._replace(G=None)
            groups.append((dofs, gf, hf, True))
        return energy, groups

    def forces(self, x, tangent=True, free=None, direction=None, q=None):
        """Energy, force vector (n_dofs,), tangent (CSR, free dofs only if
        ``free`` is given) and K @ direction (or None)."""
        energy, groups = self.blocks(x, q, tangent)
        f = np.zeros(self.n_dofs)
        K = Kv = None
        if tangent:
            Kv = np.zeros(self.n_dofs) if direction is not None else None
        for dofs, grads, hess, psd in groups:
            f += block_vector(dofs, grads, self.n_dofs)
            if tangent:
                Kg = block_matrix(dofs, hess, self.n_dofs, free, keep_pattern=psd is not False)
                K = Kg if K is None else K + Kg
                if direction is not None:
                    v = direction[dofs]
                    Kv += block_vector(dofs, hess.apply(v) if hasattr(hess, "J") else
                                       np.einsum("mij,mj->mi", hess, v), self.n_dofs)
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
