"""A yarn-level model: B-spline yarns, clamps, gravity, contact (Kaldor 2008).

Independent of the beam model: it shares only geometry input (centrelines)
and output formats.  Unknowns are *reduced coordinates* y with control points
q = q_bar + Z y: free control points map one to one; a clamp holds the curve's
end point and tangent direction exactly (its curvature stays free, as in a
real clamp) by tying the first three control points to (q_0, s):

    q_2 = q_0 + 2 s t,   q_1 = (6 P - q_0 - q_2) / 4
    =>  r(0) = (q_0 + 4 q_1 + q_2)/6 = P,   r'(0) = (q_2 - q_0)/2 = s t.

Units: any consistent set (EA force, EI force length^2, line density mass per
length, contact stiffness energy per length^2).
"""
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.sparse import linalg as splinalg

from . import curve, energy
from .contact import ContactLaw, candidate_pairs, contact_damping, contact_energy


def _positive(name, value, allow_zero=False):
    v = float(value)
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        rng = "[0, inf)" if allow_zero else "(0, inf)"
        raise ValueError(f"{name} must be finite and in {rng}, got {value!r}")
    return v


@dataclass
class Yarn:
    """One yarn: control points (N+3, 3) (open) or (N, 3) (closed), rest length
    per segment (N,), stiffnesses, radius and line density."""
    control: np.ndarray
    rest: np.ndarray
    EA: float
    EI: float
    closed: bool = False
    radius: float = float("nan")
    line_density: float = 1.0
    name: str = "yarn"

    def __post_init__(self):
        self.control = np.asarray(self.control, dtype=float)
        self.rest = np.asarray(self.rest, dtype=float)
        if self.control.ndim != 2 or self.control.shape[1] != 3:
            raise ValueError(f"control points must have shape (n, 3), got {self.control.shape}")
        if not np.all(np.isfinite(self.control)):
            raise ValueError("control points contain NaN or infinite values (valid: finite)")
        if self.segments < 1 or self.rest.shape != (self.segments,):
            raise ValueError(f"rest lengths must have shape ({self.segments},) for "
                             f"{self.control.shape[0]} control points, got {self.rest.shape}")
        if not np.all(np.isfinite(self.rest) & (self.rest > 0)):
            raise ValueError("rest lengths must be finite and in (0, inf)")
        self.EA = _positive("EA", self.EA)
        self.EI = _positive("EI", self.EI)
        self.line_density = _positive("line_density", self.line_density)

    @property
    def segments(self):
        return self.control.shape[0] - (0 if self.closed else 3)

    @classmethod
    def through(cls, points, segments, EA, EI, *, closed=False, natural="shape", length=None,
                **kwargs):
        """A yarn fitted to the centreline ``points`` (n, 3).  natural="shape": rest
        lengths are the fitted segments' lengths; "straight" with ``length``:
        equal rest lengths length/segments (a straight yarn bent into shape)."""
        q = curve.fit(points, segments, closed)
        if natural == "shape":
            quad = energy.Quadrature(8)
            a = curve.evaluate(q, quad.u, closed, derivative=1)
            rest = np.linalg.norm(a, axis=2) @ quad.w
        elif natural == "straight":
            rest = np.full(segments, _positive("length", length) / segments)
        else:
            raise ValueError(f"natural must be 'shape' or 'straight', got {natural!r}")
        return cls(q, rest, EA, EI, closed, **kwargs)


@dataclass
class _Clamp:
    yarn: int
    end: str                       # "start" or "end"
    position: np.ndarray
    tangent: np.ndarray


class BSplineModel:
    """Yarns + clamps/fixed points + gravity + contact, as an energy of y."""

    def __init__(self, yarns, *, contact=None, gravity=None, quadrature=4):
        if not yarns:
            raise ValueError("a model needs at least one yarn")
        self.yarns = list(yarns)
        self.quad = energy.Quadrature(quadrature)
        sizes = [y.control.shape[0] for y in self.yarns]
        self.offset = np.concatenate([[0], np.cumsum(sizes)])
        self.n = int(self.offset[-1])
        self.seg = np.concatenate([curve.segment_indices(y.segments, y.closed) + o
                                   for y, o in zip(self.yarns, self.offset)])
        self.rest0 = np.concatenate([y.rest for y in self.yarns])
        self.rest = self.rest0.copy()
        per = [np.full(y.segments, k) for k, y in enumerate(self.yarns)]
        self.yarn_of_segment = np.concatenate(per)
        self.EA = np.concatenate([np.full(y.segments, y.EA) for y in self.yarns])
        self.EI = np.concatenate([np.full(y.segments, y.EI) for y in self.yarns])
        self.rho = np.concatenate([np.full(y.segments, y.line_density) for y in self.yarns])
        self.contact = contact
        if contact is not None and not isinstance(contact, ContactLaw):
            raise ValueError("contact must be a ContactLaw or None")
        self.gravity = None if gravity is None else np.asarray(gravity, float)
        self.clamps, self.fixed = [], set()
        self._reduction = None

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

    # -- energy ----------------------------------------------------------------------
    def samples(self, q):
        """Gauss-point positions (S*G, 3), their arclength weights, yarn id, arclength."""
        pts = self._at_samples(q)
        weights = (self.rest[:, None] * self.quad.w[None, :]).ravel()
        start = np.concatenate([[0.0], np.cumsum(self.rest)])[:-1]
        arclength = (start[:, None] + self.rest[:, None] * self.quad.u[None, :]).ravel()
        yarn = np.repeat(self.yarn_of_segment, self.quad.u.shape[0])
        return pts, weights, yarn, arclength

    def energy(self, q):
        """Total energy, gradient (n, 3), and the summed sizes of the separate
        force contributions (a reference for relative residuals, at least the
        force of an axial strain of 1e-9)."""
        return self._forces(q)[:3]

    def _forces(self, q, qdot=None):
        """:meth:`energy` and, with control-point velocities ``qdot`` and a
        dissipative contact law, the contact damping force (n, 3) from the same
        samples and pairs (else None)."""
        a, b = energy.derivatives(q, self.seg, self.quad)
        E1, g1 = energy.stretching(q, self.seg, self.rest, self.EA, self.quad, a)
        E2, g2 = energy.bending(q, self.seg, self.EI, self.quad, a, b)
        total, grad = E1 + E2, g1 + g2
        ref = np.linalg.norm(g1) + np.linalg.norm(g2)
        damping = None
        if self.gravity is not None:
            f = energy.gravity_force(self.seg, self.rest, self.rho, self.gravity, self.quad, self.n)
            total -= np.sum(f * q)
            grad = grad - f
            ref += np.linalg.norm(f)
        if self.contact is not None:
            pts, weights, yarn, s = self.samples(q)
            pairs = candidate_pairs(pts, yarn, s, self.contact)
            Ec, gp, _ = contact_energy(pts, weights, pairs, self.contact)
            if Ec:
                gc = self._to_control_points(gp)
                total += Ec
                grad = grad + gc
                ref += np.linalg.norm(gc)
            if qdot is not None and self.contact.dissipates:
                damping = self._to_control_points(
                    contact_damping(pts, self._at_samples(qdot), weights, pairs, self.contact))
        # forces below an axial strain of 1e-9 are noise: a floor for unloaded states
        return total, grad, max(ref, 1e-9 * float(self.EA.max())), damping

    def _at_samples(self, q):
        """Control-point vectors (n, 3) -> the curve's vectors at the Gauss points (S*G, 3)."""
        return np.einsum("gj,sjk->sgk", self.quad.B, q[self.seg]).reshape(-1, 3)

    def _to_control_points(self, sample_vectors):
        """Gauss-point forces (S*G, 3) -> the same virtual work on control points (n, 3)."""
        per = np.einsum("gj,sgk->sjk", self.quad.B, sample_vectors.reshape(len(self.seg), -1, 3))
        out = np.zeros((self.n, 3))
        for k in range(3):
            out[:, k] = np.bincount(self.seg.ravel(), per[:, :, k].ravel(), minlength=self.n)
        return out

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
        E, g, ref, damping = self._forces(self.control_points(y), qdot)
        fd = np.zeros_like(v) if damping is None else Z.T @ damping.ravel()
        return E, Z.T @ g.ravel(), ref, fd

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

    def reduced_energy(self, y):
        """Energy, gradient with respect to y, reference force size."""
        Z, _ = self.reduction()
        E, g, ref = self.energy(self.control_points(y))
        return E, Z.T @ g.ravel(), ref

    def masses(self):
        """Positive lumped masses of the reduced coordinates (n_free,): the
        control points' lumped masses, summed over the points each coordinate
        moves (weighted by how much)."""
        Z, _ = self.reduction()
        m = energy.lumped_masses(self.seg, self.rest, self.rho, self.quad, self.n)
        return abs(Z).T @ np.repeat(m, 3)


@dataclass
class YarnState:
    """Control points of every yarn at equilibrium, and how they were reached."""
    control: np.ndarray
    y: np.ndarray = field(repr=False, default=None)
    iterations: int = 0
    residual: float = np.nan
