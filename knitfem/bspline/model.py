"""A yarn-level model: B-spline yarns, clamps, loads, ties, contact (Kaldor 2008).

Independent of the beam model: it shares only geometry input (centrelines)
and output formats.  Unknowns are *reduced coordinates* y with control points
q = q_bar + Z y: free control points map one to one; a clamp holds the curve's
end point and tangent direction exactly (its curvature stays free, as in a
real clamp) by tying the first three control points to (q_0, s):

    q_2 = q_0 + 2 s t,   q_1 = (6 P - q_0 - q_2) / 4
    =>  r(0) = (q_0 + 4 q_1 + q_2)/6 = P,   r'(0) = (q_2 - q_0)/2 = s t.

The energy (stretching, bending, contact, ties, dead loads: see
:mod:`.energy`, :mod:`.contact`, :mod:`.points`) comes with its exact
gradient and its sparse Hessian.  Units: any consistent set (EA force, EI
force length^2, line density mass per length, contact stiffness energy per
length^2).
"""
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.sparse import linalg as splinalg

from . import curve, energy, points
from .contact import ContactLaw, PairCache, contact_damping, contact_energy, contact_hessian
from .yarn import Yarn, positive

__all__ = ["BSplineModel", "Yarn", "YarnState"]

ROUNDOFF = 10.0 * np.finfo(float).eps     # margin over the round-off of one force term


@dataclass
class _Clamp:
    yarn: int
    end: str                       # "start" or "end"
    position: np.ndarray
    tangent: np.ndarray


class BSplineModel:
    """Yarns + clamps/fixed points + gravity, dead loads and ties at curve
    points + contact, as an energy of the reduced coordinates y.

    contact_skin: width of the Verlet list's skin (default r/2): candidate
    pairs within 2r + skin are kept until a sample has moved skin/2."""

    def __init__(self, yarns, *, contact=None, gravity=None, quadrature=4, contact_skin=None):
        if not yarns:
            raise ValueError("a model needs at least one yarn")
        self.yarns = list(yarns)
        self.quad = energy.Quadrature(quadrature)
        sizes = [y.control.shape[0] for y in self.yarns]
        self.offset = np.concatenate([[0], np.cumsum(sizes)])
        self.n = int(self.offset[-1])
        self.seg = np.concatenate([curve.segment_indices(y.segments, y.closed) + o
                                   for y, o in zip(self.yarns, self.offset)]).astype(np.int64)
        per = [np.full(y.segments, k) for k, y in enumerate(self.yarns)]
        self.yarn_of_segment = np.concatenate(per)
        self.EA = np.concatenate([np.full(y.segments, y.EA) for y in self.yarns])
        self.EI = np.concatenate([np.full(y.segments, y.EI) for y in self.yarns])
        self.rho = np.concatenate([np.full(y.segments, y.line_density) for y in self.yarns])
        # rest speed |r'| at every Gauss point: the initial one for shaped yarns (their
        # segments' rest lengths become its integral), else the segment's rest length
        speed = np.concatenate([
            np.linalg.norm(curve.evaluate(y.control, self.quad.u, y.closed, 1), axis=2)
            if y.shaped else np.repeat(y.rest[:, None], len(self.quad.w), axis=1)
            for y in self.yarns])
        self.speed0 = speed
        self.rest0 = speed @ self.quad.w
        self.rest = self.rest0.copy()
        self.kappa0 = np.concatenate([
            energy.curvature(y.control, curve.segment_indices(y.segments, y.closed), self.quad)
            if y.curved else np.zeros((y.segments, len(self.quad.w))) for y in self.yarns])
        self.tau0 = np.concatenate([
            energy.torsion(y.control, curve.segment_indices(y.segments, y.closed), self.quad)
            if y.curved else np.zeros((y.segments, len(self.quad.w))) for y in self.yarns])
        self.curved = np.concatenate([np.full(y.segments, y.curved) for y in self.yarns])
        # torsion weight, curvature regularisation and the torsion measure's rest value
        # per Gauss point: 1, 0, tau0 on a curved yarn, the smooth forms on a set one
        G = len(self.quad.w)
        self.torsion_weight = np.zeros((len(self.curved), G))
        self.curvature_eps = np.zeros((len(self.curved), G))
        self.torsion_rest = self.tau0.copy()
        bounds = np.cumsum([0] + [y.segments for y in self.yarns])
        for y, i, j in zip(self.yarns, bounds[:-1], bounds[1:]):
            if y.set_yarn:
                self.torsion_weight[i:j], self.curvature_eps[i:j] = energy.set_yarn_terms(
                    self.kappa0[i:j], speed[i:j] * self.quad.w)
                self.torsion_rest[i:j] = energy.curvature_torsion(
                    y.control, curve.segment_indices(y.segments, y.closed), self.quad)
            elif y.curved:
                self.torsion_weight[i:j] = 1.0
        self.contact = contact
        if contact is not None and not isinstance(contact, ContactLaw):
            raise ValueError("contact must be a ContactLaw or None")
        self.gravity = None if gravity is None else np.asarray(gravity, float)
        self.speed = self.speed0.copy()
        self.clamps, self.fixed = [], set()
        self.loads = points.DeadLoads(self)
        self.ties = points.Ties(self)
        self._reduction = None
        self.sampling = points.sampling_matrix(self.seg, self.quad.B, self.n)
        self._pairs = None
        if contact is not None:
            skin = 0.5 * contact.radius if contact_skin is None else positive(
                "contact_skin", contact_skin, allow_zero=True)
            _, _, yarn, s = self.samples(self._initial(), rest=self.rest0)
            self._pairs = PairCache(contact, yarn, s, skin,
                                    [y.self_contact for y in self.yarns])
        # round-off of the gradient at the model's own scales (its initial extent, its
        # shortest segment), not at the current iterate: forces below it are noise
        extent = float(np.abs(self._initial()).max())
        h = float(self.rest0.min())
        self.roundoff = ROUNDOFF * np.sqrt(3 * self.n) * extent / h * float(
            np.max(self.EA + self.EI / h**2))

    # -- constraints -------------------------------------------------------------
    def clamp(self, yarn, end, position=None, tangent=None):
        """Hold the yarn's end point and tangent direction (default: where the
        initial curve has them); the end curvature stays free."""
        if end not in ("start", "end"):
            raise ValueError(f"end must be 'start' or 'end', got {end!r}")
        y = self.yarns[yarn]
        if y.closed or y.segments < 4:
            raise ValueError("clamps need an open yarn of at least 4 segments")
        u = 0.0 if end == "start" else 1.0
        s = 0 if end == "start" else y.segments - 1
        q = y.control[s:s + 4]
        P = curve.basis(np.array([u]))[0] @ q if position is None else np.asarray(position, float)
        t = curve.basis(np.array([u]), 1)[0] @ q if tangent is None else np.asarray(tangent, float)
        self.clamps.append(_Clamp(yarn, end, P, t / np.linalg.norm(t)))
        self._reduction = None

    def fix(self, yarn, index):
        """Hold control point ``index`` of ``yarn`` where it is."""
        n = self.yarns[yarn].control.shape[0]
        if not -n <= index < n:
            raise ValueError(f"index must be in [-{n}, {n - 1}], got {index!r}")
        self.fixed.add(int(self.offset[yarn] + index % n))
        self._reduction = None

    def move_clamp(self, index, position=None, tangent=None):
        """Prescribe a new position/tangent for clamp ``index`` (a move of its support)."""
        c = self.clamps[index]
        if position is not None:
            c.position = np.asarray(position, float)
        if tangent is not None:
            c.tangent = np.asarray(tangent, float) / np.linalg.norm(tangent)
        self._reduction = None

    def _triplet(self, c):
        y = self.yarns[c.yarn]
        o = self.offset[c.yarn]
        if c.end == "start":
            return o + 0, o + 1, o + 2
        m = o + y.control.shape[0]
        return m - 1, m - 2, m - 3          # (the "q0" of the end, q1, q2) counted inward

    def reduction(self):
        """(Z sparse (3n, n_free), q_bar (3n,)) with q = q_bar + Z y."""
        if self._reduction is not None:
            return self._reduction
        tied = {}
        for c in self.clamps:
            i0, i1, i2 = self._triplet(c)
            for i in (i1, i2):
                if i in tied or i in self.fixed:
                    raise ValueError(f"contradictory constraints on control point {i}")
            tied[i1] = tied[i2] = c
        free_points = [i for i in range(self.n) if i not in tied and i not in self.fixed]
        rows, cols, vals = [], [], []
        col = 0
        index = {}
        for i in free_points:
            for k in range(3):
                rows.append(3 * i + k), cols.append(col), vals.append(1.0)
                index[(i, k)] = col
                col += 1
        qbar = np.zeros(3 * self.n)
        for i in self.fixed:
            qbar[3 * i:3 * i + 3] = self._initial()[i]
        for c in self.clamps:
            i0, i1, i2 = self._triplet(c)
            sign = 1.0 if c.end == "start" else -1.0     # tangent points into the yarn at the end
            for k in range(3):                          # q1 and q2 follow q0
                j = index[(i0, k)]
                rows += [3 * i1 + k, 3 * i2 + k]
                cols += [j, j]
                vals += [-0.5, 1.0]
            for k in range(3):                          # ... and the speed s
                rows += [3 * i1 + k, 3 * i2 + k]
                cols += [col, col]
                vals += [-0.5 * sign * c.tangent[k], 2.0 * sign * c.tangent[k]]
            qbar[3 * i1:3 * i1 + 3] = 1.5 * c.position
            col += 1
        Z = sparse.csr_matrix((vals, (rows, cols)), shape=(3 * self.n, col))
        self._reduction = (Z, qbar)
        return self._reduction

    def _initial(self):
        return np.concatenate([y.control for y in self.yarns])

    def reduce(self, q):
        """Reduced coordinates y best matching control points q (n, 3) (least squares)."""
        Z, qbar = self.reduction()
        if not self.clamps and not self.fixed:
            return np.asarray(q, float).ravel().copy()
        return splinalg.lsqr(Z, np.asarray(q, float).ravel() - qbar, atol=1e-15, btol=1e-15)[0]

    def control_points(self, y):
        Z, qbar = self.reduction()
        return (qbar + Z @ y).reshape(-1, 3)

    def prestretch(self, alpha):
        """Shrink every rest length by the factor (1 - alpha) (the paper's alpha)."""
        alpha = float(alpha)
        if not 0.0 <= alpha < 1.0:
            raise ValueError(f"alpha (pre-stretch ratio) must be in [0, 1), got {alpha!r}")
        self.rest = (1.0 - alpha) * self.rest0
        self.speed = (1.0 - alpha) * self.speed0

    # -- energy ----------------------------------------------------------------------
    def samples(self, q, rest=None):
        """Gauss-point positions (S*G, 3), their arclength weights, yarn id and
        arclength along their yarn (of the rest lengths ``rest``, default the
        current ones)."""
        rest = self.rest if rest is None else rest
        pts = self._at_samples(q)
        weights = (rest[:, None] * self.quad.w[None, :]).ravel()
        start = np.concatenate([[0.0], np.cumsum(rest)])[:-1]
        start = start - start[self.offset_segments()[self.yarn_of_segment]]
        arclength = (start[:, None] + rest[:, None] * self.quad.u[None, :]).ravel()
        yarn = np.repeat(self.yarn_of_segment, self.quad.u.shape[0])
        return pts, weights, yarn, arclength

    def offset_segments(self):
        """Index of the first segment of every yarn (n_yarns + 1,)."""
        return np.concatenate([[0], np.cumsum([y.segments for y in self.yarns])])

    def contact_pairs(self, q):
        """Candidate sample pairs (Verlet list) at control points q."""
        return self._pairs(self._at_samples(q))

    def energy(self, q):
        """Total energy, gradient (n, 3), and the summed sizes of the separate
        force contributions (a reference for relative residuals, at least the
        round-off floor :attr:`roundoff`)."""
        return self._forces(q)[:3]

    def energy_parts(self, q):
        """Energy by contribution: stretching, bending, contact, ties, loads (dict)."""
        return self._forces(q, parts=True)[4]

    def _forces(self, q, qdot=None, parts=False):
        """:meth:`energy`, the contact damping force (n, 3) at control-point
        velocities ``qdot`` with a dissipative contact law (else None), from the
        same samples and pairs, and (with ``parts``) the energy by contribution."""
        q = np.ascontiguousarray(q, dtype=float)
        g_len, g_bend = np.zeros_like(q), np.zeros_like(q)
        E_len, E_bend = energy.elastic(q, self.seg, self.speed, self.EA, self.EI, self.kappa0,
                                       self.torsion_rest, self.torsion_weight,
                                       self.curvature_eps, self.quad, g_len, g_bend)
        total, grad = E_len + E_bend, g_len + g_bend
        ref = np.linalg.norm(g_len) + np.linalg.norm(g_bend)
        split = {"stretching": E_len, "bending": E_bend, "contact": 0.0, "ties": 0.0,
                 "loads": 0.0}
        f = self.dead_load()
        if f is not None:
            split["loads"] = -float(np.sum(f * q))
            total += split["loads"]
            grad -= f
            ref += np.linalg.norm(f)
        if self.ties:
            Et, gt = self.ties.energy(q)
            split["ties"] = Et
            total += Et
            grad += gt
            ref += np.linalg.norm(gt)
        damping = None
        if self.contact is not None:
            pts = self._at_samples(q)
            weights = (self.rest[:, None] * self.quad.w[None, :]).ravel()
            pairs = self._pairs(pts)
            Ec, gp, _ = contact_energy(pts, weights, pairs, self.contact)
            if Ec:
                gc = self._to_control_points(gp)
                split["contact"] = Ec
                total += Ec
                grad += gc
                ref += np.linalg.norm(gc)
            if qdot is not None and self.contact.dissipates:
                damping = self._to_control_points(
                    contact_damping(pts, self._at_samples(qdot), weights, pairs, self.contact))
        return total, grad, max(ref, self.roundoff), damping, split

    def dead_load(self):
        """Constant nodal forces (n, 3) of gravity and the dead loads (None if none)."""
        f = None
        if self.gravity is not None:
            f = energy.gravity_force(self.seg, self.rest0, self.rho, self.gravity, self.quad,
                                     self.n)
        if self.loads:
            f = self.loads.force() if f is None else f + self.loads.force()
        return f

    def hessian(self, q, project=False):
        """Sparse Hessian (3n, 3n) of the energy at control points q; ``project``:
        each Gauss point's and each contact pair's positive semi-definite part
        (a convex model of the energy, for Newton steps far from equilibrium)."""
        q = np.ascontiguousarray(q, dtype=float)
        blocks = energy.elastic_hessian(q, self.seg, self.speed, self.EA, self.EI, self.kappa0,
                                        self.torsion_rest, self.torsion_weight,
                                        self.curvature_eps, self.quad, project)
        dof = (3 * self.seg[:, :, None] + np.arange(3)[None, None, :]).reshape(-1, 12)
        rows = np.broadcast_to(dof[:, :, None], blocks.shape).ravel()
        cols = np.broadcast_to(dof[:, None, :], blocks.shape).ravel()
        H = sparse.csr_matrix((blocks.ravel(), (rows, cols)), shape=(3 * self.n, 3 * self.n))
        if self.ties:
            H = H + self.ties.hessian(q, project)
        if self.contact is not None:
            pts = self._at_samples(q)
            weights = (self.rest[:, None] * self.quad.w[None, :]).ravel()
            Hs = contact_hessian(pts, weights, self._pairs(pts), self.contact, project)
            if Hs.nnz:
                H = H + (self.sampling.T @ Hs @ self.sampling)
        return H.tocsr()

    def reduced_hessian(self, y, project=False):
        """Zᵀ H Z: the Hessian with respect to the reduced coordinates."""
        Z, _ = self.reduction()
        H = self.hessian(self.control_points(y), project)
        return H if self._identity() else (Z.T @ H @ Z).tocsr()

    def _identity(self):
        return not self.clamps and not self.fixed

    def _at_samples(self, q):
        """Control-point vectors (n, 3) -> the curve's vectors at the Gauss points (S*G, 3)."""
        return (self.sampling @ np.asarray(q).ravel()).reshape(-1, 3)

    def _to_control_points(self, sample_vectors):
        """Gauss-point forces (S*G, 3) -> the same virtual work on control points (n, 3)."""
        return (self.sampling.T @ sample_vectors.ravel()).reshape(-1, 3)

    def contact_damping(self, y, v):
        """Contact damping force on the reduced coordinates at state y moving
        with velocity v (zero without a dissipative contact law)."""
        return self.reduced_forces(y, v)[3]

    def reduced_forces(self, y, v):
        """:meth:`reduced_energy` at y and the contact damping force on the
        reduced coordinates when moving with velocity v (zeros without a
        dissipative contact law), from one pass over the contact samples."""
        Z, _ = self.reduction()
        qdot = (Z @ v).reshape(-1, 3)          # the clamps hold still while relaxing
        E, g, ref, damping, _ = self._forces(self.control_points(y), qdot)
        fd = np.zeros_like(v) if damping is None else Z.T @ damping.ravel()
        return E, Z.T @ g.ravel(), ref, fd

    def reduced_energy(self, y):
        """Energy, gradient with respect to y, reference force size."""
        Z, _ = self.reduction()
        E, g, ref = self.energy(self.control_points(y))
        return E, (g.ravel() if self._identity() else Z.T @ g.ravel()), ref

    def centrelines(self, q, per_segment=8):
        """Per yarn: points (m, 3), unit tangents (m, 3) and curvature (m,) sampled
        ``per_segment`` times on every segment (for output and pictures)."""
        u = np.linspace(0.0, 1.0, per_segment, endpoint=False)
        out = []
        for y, o in zip(self.yarns, self.offset):
            local = q[o:o + y.control.shape[0]]
            r, a, b = (curve.evaluate(local, u, y.closed, k).reshape(-1, 3) for k in range(3))
            if not y.closed:                        # close the last segment at u = 1
                ends = [curve.evaluate(local, np.array([1.0]), False, k)[-1] for k in range(3)]
                r, a, b = (np.vstack([arr, e]) for arr, e in zip((r, a, b), ends))
            speed = np.linalg.norm(a, axis=1)
            kappa = np.linalg.norm(np.cross(a, b), axis=1) / speed**3
            out.append((r, a / speed[:, None], kappa))
        return out

    def masses(self):
        """Positive lumped masses of the reduced coordinates (n_free,): the
        control points' lumped masses (of the unstretched yarn), summed over
        the points each coordinate moves (weighted by how much)."""
        Z, _ = self.reduction()
        m = energy.lumped_masses(self.seg, self.rest0, self.rho, self.quad, self.n)
        return abs(Z).T @ np.repeat(m, 3)


@dataclass
class YarnState:
    """Control points of every yarn at equilibrium, and how they were reached."""
    control: np.ndarray
    y: np.ndarray = field(repr=False, default=None)
    iterations: int = 0
    residual: float = np.nan
