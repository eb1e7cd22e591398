"""Pseudo-arclength continuation (Keller) with fold and bifurcation detection,
branch switching and a stability label on every point.

Generic: a *problem* provides

``evaluate(x, lam, jacobian) -> (R, J, R_lam, ref)``
    residual R (n,), Jacobian J = dR/dx (sparse, n x n), R_lam = dR/dlam (n,)
    (J and R_lam None when ``jacobian`` is False) and a reference size of R;
``retract(x, dx, lam) -> x``
    the state reached from x by the increment dx (n,) at parameter lam;

and optionally ``weights`` (n,) (the arclength metric, making unknowns of
different units comparable), ``norm(R)``, ``noise(x)`` (as for Newton),
``state_at(x, lam)`` and ``ordering`` (SuperLU's permc_spec).  Nothing here
knows about beams.

Every point carries its unit tangent (t_x, t_lam) in the weighted norm and
the inertia of sym(J): the number of negative eigenvalues (0 = stable for a
potential problem) and log|det|.  A sign change of t_lam is a fold; a change
of the count without one is a bifurcation.  Events are located by Brent's
method on the arclength (test functions t_lam and the signed determinant) to
|delta lam| <= ``locate_tol``.

Linear algebra: the bordered systems [[J, b], [c^T, d]] are solved by block
elimination with one sparse LU of J for both right-hand sides; where that is
ill-conditioned (at a fold J is singular) the bordered matrix itself is
factorised.
"""
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.optimize import brentq
from scipy.sparse import linalg as splinalg

from .newton import NewtonError, newton
from .stability import inertia, null_vector


@dataclass
class Point:
    state: object
    lam: float
    tx: np.ndarray           # tangent, state part (weighted-unit together with tl)
    tl: float                # tangent, parameter part: dlam/ds
    negative: int = None     # negative eigenvalues of sym(J); None if not computed
    logdet: float = 0.0      # log|det sym(J)|
    s: float = 0.0           # arclength from the branch start
    iterations: int = 0

    @property
    def stable(self):
        return None if self.negative is None else self.negative == 0


@dataclass
class Event:
    kind: str                # "fold" or "bifurcation"
    lam: float
    point: Point             # the located critical point
    index: int               # lies between points[index - 1] and points[index]
    negative_before: int = None
    negative_after: int = None
    null_vector: np.ndarray = None
    bracket: float = 0.0     # width in lam of the final bracket


@dataclass
class Branch:
    points: list = field(default_factory=list)
    events: list = field(default_factory=list)
    status: str = "running"  # "completed", "max_steps"
    message: str = ""

    @property
    def lam(self):
        return np.array([p.lam for p in self.points])


class ContinuationError(RuntimeError):
    """Continuation stopped early; ``branch`` keeps every point traced so far."""

    def __init__(self, message, branch):
        super().__init__(message)
        self.branch = branch

    def __reduce__(self):
        # picklable (process pools hand errors back to the parent)
        return (type(self), (str(self), self.branch))


class Bordered:
    """The system [[J, b], [c^T, d]] with ``solve(rhs)``: block elimination on
    one LU of J, or (J singular, or the Schur complement d - c^T J^-1 b lost to
    cancellation) an LU of the bordered matrix."""

    def __init__(self, J, b, c, d, ordering="COLAMD"):
        self.J, self.b, self.c, self.d = sparse.csc_matrix(J), np.asarray(b), np.asarray(c), d
        self.lu = self.z = self.full = None
        try:
            with np.errstate(all="ignore"):
                self.lu = splinalg.splu(self.J, permc_spec=ordering)
                self.z = self.lu.solve(self.b)
            self.schur = self.d - self.c @ self.z
            scale = abs(self.d) + np.abs(self.c) @ np.abs(self.z)
            if not (np.isfinite(self.schur) and abs(self.schur) > 1e-10 * scale):
                self.lu = None
        except RuntimeError:
            self.lu = None
        if self.lu is None:
            n = self.J.shape[0]
            coo = self.J.tocoo()
            rows = np.concatenate([coo.row, np.arange(n), np.full(n, n), [n]])
            cols = np.concatenate([coo.col, np.full(n, n), np.arange(n), [n]])
            data = np.concatenate([coo.data, self.b, self.c, [self.d]])
            self.full = splinalg.splu(sparse.csc_matrix((data, (rows, cols)), shape=(n + 1, n + 1)),
                                      permc_spec=ordering)

    def solve(self, rhs):
        if self.lu is None:
            return self.full.solve(rhs)
        f, g = rhs[:-1], rhs[-1]
        z1 = self.lu.solve(f)
        y = (g - self.c @ z1) / self.schur
        return np.append(z1 - self.z * y, y)


def _ordering(problem):
    """Column ordering for SuperLU: the problem's hint (e.g. 'NATURAL' for banded
    Jacobians, where it skips the ordering work), else COLAMD."""
    return getattr(problem, "ordering", "COLAMD")


class FixedParameter:
    """The problem at fixed lam, for plain Newton (a natural-parameter solve);
    ``start`` moves a state onto lam if the problem knows how (``state_at``)."""

    def __init__(self, problem, lam):
        self.problem, self.lam = problem, lam
        for name in ("norm", "noise", "correction_norm"):
            if hasattr(problem, name):
                setattr(self, name, getattr(problem, name))

    def start(self, x):
        at = getattr(self.problem, "state_at", None)
        return x if at is None else at(x, self.lam)

    def evaluate(self, x, jacobian=True):
        R, J, _, ref = self.problem.evaluate(x, self.lam, jacobian)
        return R, J, ref

    def retract(self, x, dx):
        return self.problem.retract(x, dx, self.lam)


class _Corrector:
    """Newton on [R(x, lam); <W^2 t_x, delta> + t_lam (lam - lam_p)] = 0, with delta
    the increments accumulated since the predictor (Keller's hyperplane)."""

    def __init__(self, problem, weights, tx, tl, lam_p):
        self.problem, self.tl, self.lam_p = problem, tl, lam_p
        self.row = weights**2 * tx
        norm = getattr(problem, "norm", None)
        self.norm = (lambda r: norm(r[:-1])) if norm else (lambda r: float(np.linalg.norm(r[:-1])))
        if hasattr(problem, "noise"):
            self.noise = lambda y: problem.noise(y[0])
        if hasattr(problem, "correction_norm"):
            self.correction_norm = lambda dy: max(problem.correction_norm(dy[:-1]), abs(dy[-1]))

    def evaluate(self, y, jacobian=True):
        x, lam, delta = y
        R, J, R_lam, ref = self.problem.evaluate(x, lam, jacobian)
        r = np.append(R, self.row @ delta + self.tl * (lam - self.lam_p))
        if not jacobian:
            return r, None, ref
        return r, Bordered(J, R_lam, self.row, self.tl, _ordering(self.problem)), ref

    def retract(self, y, dy):
        x, lam, delta = y
        return (self.problem.retract(x, dy[:-1], lam + dy[-1]), lam + dy[-1], delta + dy[:-1])


class Continuation:
    """Follow a branch of R(x, lam) = 0; see :func:`continuation` for the options."""

    def __init__(self, problem, *, ds=0.01, ds_min=1e-7, ds_max=0.1, lam_range=(-np.inf, np.inf),
                 max_steps=1000, rtol=1e-10, max_iter=10, target_iter=3, max_angle=0.3,
                 stability=True, locate=True, locate_tol=1e-8, progress=None):
        self.problem = problem
        self.ds, self.ds_min, self.ds_max = ds, ds_min, ds_max
        self.lam_range = lam_range
        self.max_steps, self.rtol, self.max_iter = max_steps, rtol, max_iter
        self.target_iter, self.max_angle = target_iter, max_angle
        self.stability, self.locate, self.locate_tol = stability, locate, locate_tol
        self.progress = progress

    # -- building blocks ---------------------------------------------------------------
    def weights(self, n):
        w = getattr(self.problem, "weights", None)
        return np.ones(n) if w is None else np.asarray(w, dtype=float)

    def solve_at(self, x, lam):
        """Newton at fixed lam (start of a branch, landing on a bound)."""
        return newton(FixedParameter(self.problem, lam), x, rtol=self.rtol,
                      max_iter=max(self.max_iter, 25), where=f"lam = {lam:.8g}")

    def point(self, x, lam, tx_ref, tl_ref, s=0.0, iterations=0):
        """A Point at the solution (x, lam): unit tangent from
        [J R_lam; ref^T W^2, ref_l] t = [0; 1] - its last row makes
        <t, ref> = 1 > 0, so it points along the reference by construction -
        and the inertia of sym(J)."""
        w = self.weights(tx_ref.shape[0])
        _, J, R_lam, _ = self.problem.evaluate(x, lam, True)
        rhs = np.zeros(J.shape[0] + 1)
        rhs[-1] = 1.0
        t = Bordered(J, R_lam, w**2 * tx_ref, tl_ref, _ordering(self.problem)).solve(rhs)
        tx, tl = t[:-1], t[-1]
        size = np.sqrt(np.sum((w * tx) ** 2) + tl**2)
        tx, tl = tx / size, tl / size
        negative, logdet = inertia(J) if self.stability else (None, 0.0)
        return Point(x, float(lam), tx, float(tl), negative, logdet, s, iterations)

    def step(self, a, ds, tx=None, tl=None):
        """Predictor from point a along (tx, tl) (default a's tangent) and
        corrector; returns the new Point or raises NewtonError."""
        tx = a.tx if tx is None else tx
        tl = a.tl if tl is None else tl
        w = self.weights(tx.shape[0])
        lam_p = a.lam + ds * tl
        x_p = self.problem.retract(a.state, ds * tx, lam_p)
        result = newton(_Corrector(self.problem, w, tx, tl, lam_p), (x_p, lam_p, np.zeros_like(tx)),
                        rtol=self.rtol, max_iter=self.max_iter, where=f"lam ~ {lam_p:.8g}")
        x, lam, _ = result.state
        return self.point(x, lam, tx, tl, a.s + ds, result.iterations)

    def land(self, a, bound):
        """The branch point at lam = bound next to a: predictor along a's tangent
        to the bound, then Newton at fixed lam.  If Newton fails from there, walk
        half the way along the branch (pseudo-arclength) and try again."""
        for _ in range(20):
            sigma = (bound - a.lam) / a.tl
            guess = self.problem.retract(a.state, sigma * a.tx, bound)
            try:
                end = self.solve_at(guess, bound)
            except NewtonError:
                a = self.step(a, 0.5 * sigma)
                continue
            return self.point(end.state, bound, a.tx, a.tl, a.s + abs(sigma), end.iterations)
        raise NewtonError("max_iterations", f"could not land on lam = {bound:.8g} from the "
                          f"branch point at lam = {a.lam:.8g}", a.state, [])

    def start(self, x0, lam0, direction=1.0, tangent=None):
        """First point: converge at lam0; tangent along ``direction`` in lam,
        or along ``tangent`` = (tx, tl) if given."""
        x = self.solve_at(x0, lam0).state
        if tangent is None:
            n = self.problem.evaluate(x, lam0, False)[0].shape[0]
            tangent = (np.zeros(n), float(np.sign(direction) or 1.0))
        return self.point(x, lam0, *tangent)

    # -- events ---------------------------------------------------------------------------
    def locate_event(self, a, b, index):
        """Brent's method on the arclength between a and b for the zero of the
        test function: t_lam (fold) or the signed determinant (bifurcation).
        When the count of negative eigenvalues changes by an even number in
        one step (two eigenvalues crossing, e.g. on a coarse mesh) the
        determinant keeps its sign: the test function is then the change of
        the count itself (+1 before, -1 after; Brent falls back to bisection)."""
        fold = a.tl * b.tl < 0
        kind = "fold" if fold else "bifurcation"
        even = not fold and (b.negative - a.negative) % 2 == 0

        def test(p):
            if fold:
                return p.tl
            if even:
                return 1.0 if p.negative == a.negative else -1.0
            return (-1.0) ** p.negative * np.exp(np.clip(p.logdet - a.logdet, -700, 700))

        ds = b.s - a.s
        probes = {0.0: a, ds: b}
        values = {}

        def f(sigma):
            sigma = min(max(sigma, 0.0), ds)
            if sigma not in probes:
                probes[sigma] = self.step(a, sigma)
            values[sigma] = test(probes[sigma])
            return values[sigma]

        scale = ds / max(abs(b.lam - a.lam), 1e-300)     # arclength per unit lam
        sigma = brentq(f, 0.0, ds, xtol=0.25 * self.locate_tol * scale, rtol=1e-15)
        critical = probes.get(sigma) or self.step(a, sigma)
        # the tightest pair of evaluated points across which the test function
        # changes sign: the measured location error, in lam
        seen = sorted(values.items())
        bracket = min(abs(probes[s2].lam - probes[s1].lam)
                      for (s1, v1), (s2, v2) in zip(seen, seen[1:]) if v1 * v2 <= 0)
        event = Event(kind, critical.lam, critical, index, a.negative, b.negative, bracket=bracket)
        if kind == "bifurcation":
            _, J, _, _ = self.problem.evaluate(critical.state, critical.lam, True)
            event.null_vector, _ = null_vector(J)
        return event

    # -- the loop -------------------------------------------------------------------------
    def run(self, first):
        branch = Branch([first])
        ds = self.ds
        lo, hi = self.lam_range
        for _ in range(self.max_steps):
            a = branch.points[-1]
            try:
                b, why = self.step(a, ds), ""
            except NewtonError as err:
                b, why = None, str(err)
            if b is not None and ds > self.ds_min:
                angle = float(np.arccos(np.clip(self._dot(a, b), -1.0, 1.0)))
                if angle > self.max_angle:
                    b, why = None, f"the tangent turned by {angle:.2f} rad > max_angle"
            if b is None:
                ds *= 0.5
                if ds < self.ds_min:
                    branch.status = "failed"
                    branch.message = (f"step size fell below ds_min = {self.ds_min:g} at lam = "
                                      f"{a.lam:.8g} after {len(branch.points)} points: {why}")
                    raise ContinuationError(branch.message, branch)
                continue
            if not (lo <= b.lam <= hi):
                b = self.land(a, hi if b.lam > hi else lo)
            self._record(branch, a, b)
            if b.lam in (lo, hi):
                branch.status, branch.message = "completed", f"reached lam = {b.lam:.8g}"
                return branch
            ds = float(np.clip(ds * min(2.0, max(0.5, self.target_iter / max(b.iterations, 1))),
                               self.ds_min, self.ds_max))
        branch.status, branch.message = "max_steps", f"stopped after {self.max_steps} steps"
        return branch

    def _dot(self, a, b):
        w = self.weights(a.tx.shape[0])
        return float(np.sum(w**2 * a.tx * b.tx) + a.tl * b.tl)

    def _record(self, branch, a, b):
        if self.locate and (a.tl * b.tl < 0 or (self.stability and a.negative != b.negative)):
            branch.events.append(self.locate_event(a, b, len(branch.points)))
        branch.points.append(b)
        if self.progress is not None:
            self.progress(b)


def continuation(problem, x0, lam0, *, direction=1.0, tangent=None, **options):
    """Trace the branch of R(x, lam) = 0 through (x0, lam0), first in the
    direction of increasing lam if ``direction`` > 0.

    Options (see :class:`Continuation`): ds, ds_min, ds_max (arclength steps in
    the weighted norm), lam_range (stop on reaching either bound, landing on it
    exactly), max_steps, rtol, max_iter (corrector), target_iter (steps grow
    when the corrector needs fewer iterations), max_angle (largest turn of the
    tangent per step, rad), stability (inertia on every point), locate and
    locate_tol (event location in lam), progress (callback per point).

    Returns a :class:`Branch`; raises :class:`ContinuationError` (with the
    branch so far) when the step size falls below ds_min.
    """
    solver = Continuation(problem, **options)
    return solver.run(solver.start(x0, lam0, direction, tangent))


def switch_branch(problem, event, *, sign=1.0, eps=None, **options):
    """Leave a simple bifurcation point along +/- its null vector and trace the
    new branch.  The first step lands on the hyperplane ``eps`` (default ds)
    away along the null vector, made orthogonal to the old branch tangent;
    then the branch is followed as by :func:`continuation` (same options)."""
    if event.kind != "bifurcation" or event.null_vector is None:
        raise ValueError(f"switch_branch needs a located bifurcation event, got {event.kind!r}")
    solver = Continuation(problem, **options)
    c = event.point
    w = solver.weights(c.tx.shape[0])
    alpha = float(np.sum(w**2 * event.null_vector * c.tx))
    tx, tl = event.null_vector - alpha * c.tx, -alpha * c.tl
    size = np.sqrt(np.sum((w * tx) ** 2) + tl**2)
    tx, tl = sign * tx / size, sign * tl / size
    first = solver.step(c, solver.ds if eps is None else eps, tx, tl)
    first.s = 0.0
    return solver.run(first)
