"""The S-rod: half a knitted loop as a clamped elastic rod (paper Sec. 5, Fig. 4).

A naturally straight rod of length L is clamped at (0, 0, 0) and (w, c, 0), both
clamp tangents in the x-y plane (default +x, the loop's sinker bottom and head
top), frames untwisted.  As the course length c shrinks the planar S pops out
of plane.  Units: mm and MPa (E = 1 MPa for the silicone rod; only ratios of
stiffnesses matter for the shapes).

Protocol: a planar elastica with the rod's length joining the clamps at
c_from (:func:`knitfem.geometry.planar_elastica`, point-symmetric S) is the
starting guess; Newton finds the discrete equilibrium; pseudo-arclength
continuation in lam = c/L follows the planar branch down to c_to, locating
its bifurcations; at the first out-of-plane one the branch is switched along
+/- the null vector onto the popped branches.
"""
from dataclasses import dataclass, field
import math
import time

import numpy as np

from ..beam import BeamModel, Rod, Section
from ..beam.element import element_forces
from ..beam.parametric import ParametricProblem
from ..beam.section import check_positive
from ..geometry import planar_elastica
from ..solve.continuation import Continuation, continuation, switch_branch
from ..solve.stability import negative_eigenvalue_count
from ..threads import threads_for

OUT_OF_PLANE = [2, 3, 4]      # uz, rx, ry
MAX_SAMPLES = 1e6             # samples of the stable path: each is a Newton solve


@dataclass
class SRod:
    """Parameters of the S-rod scene (lengths in mm, E in MPa)."""
    length: float = 105.0
    w: float = 28.4
    diameter: float = 3.0
    E: float = 1.0
    poisson: float = 0.5
    gj_over_ei: float = None
    elements: int = 60
    start_angle: float = 0.0      # clamp tangent directions, rad from +x in the x-y plane
    end_angle: float = 0.0

    def __post_init__(self):
        self.length = check_positive("length", self.length)
        self.w = check_positive("w", self.w)
        if self.w >= self.length:
            raise ValueError(f"w must be smaller than the rod length L = {self.length:g} "
                             f"(valid: 0 < w/L < 1), got w = {self.w:g} "
                             f"(w/L = {self.w / self.length:.4g})")
        self.diameter = check_positive("diameter", self.diameter)
        if isinstance(self.elements, bool) or int(self.elements) != self.elements \
                or self.elements < 4:
            raise ValueError(f"elements must be an integer >= 4, got {self.elements!r}")
        self.elements = int(self.elements)
        for name in ("start_angle", "end_angle"):
            if not math.isfinite(float(getattr(self, name))):
                raise ValueError(f"{name} must be finite (radians), got {getattr(self, name)!r}")
        self.section                          # validates E, poisson, gj_over_ei

    @property
    def section(self):
        return Section.circle(self.diameter, self.E, self.poisson, gj_over_ei=self.gj_over_ei)

    @property
    def gj_ei(self):
        s = self.section
        return s.GJ / s.EI2

    @property
    def c_max(self):
        """Largest course length the clamps allow: sqrt(L^2 - w^2)."""
        return math.sqrt(self.length**2 - self.w**2)

    def check_c(self, name, c_over_L):
        try:
            c = float(c_over_L)
        except (TypeError, ValueError):
            c = math.nan                                  # refused below, by name
        hi = self.c_max / self.length
        if not (math.isfinite(c) and 0.0 < c < hi):
            raise ValueError(f"{name} must be in (0, sqrt(1 - (w/L)^2)) = (0, {hi:.6f}) for "
                             f"w/L = {self.w / self.length:.4f}, got {c_over_L!r}")
        return c

    def model(self, c_over_L):
        """The beam model bent into the planar elastica at c, with lam = c/L as
        its parameter (the far clamp sits at (w, lam L, 0))."""
        c = self.check_c("c", c_over_L) * self.length
        points, tangents = planar_elastica(self.length, (self.w, c), self.start_angle,
                                           self.end_angle, nodes=self.elements + 1)
        rod = Rod.from_centerline(points, self.section, s=np.linspace(0, self.length,
                                                                      self.elements + 1),
                                  tangents=tangents, d3=(0, 0, 1), natural="straight",
                                  name="S-rod")
        model = BeamModel()
        r = model.add_rod(rod)
        model.clamp(r, "start")
        L, c0 = self.length, c
        model.prescribe(r, "end", displacement=lambda lam: np.array([0.0, lam * L - c0, 0.0]),
                        rotation=lambda lam: np.zeros(3))
        return model


@dataclass
class Sample:
    c_over_L: float
    max_abs_z_over_L: float
    stable: bool
    negative: int
    state: object = field(repr=False, default=None)


@dataclass
class PopupResult:
    srod: SRod
    c_from: float
    c_to: float
    critical_c_over_L: float
    planar: object                 # Branch
    popped: list                   # [Branch (+z), Branch (-z)]
    samples: list
    elapsed_s: float
    model: object = field(repr=False, default=None)
    problem: object = field(repr=False, default=None)

    def summary(self):
        return {
            "w_over_L": self.srod.w / self.srod.length,
            "elements": self.srod.elements,
            "gj_over_ei": self.srod.gj_ei,
            "critical_c_over_L": self.critical_c_over_L,
            "branch": [{"c_over_L": s.c_over_L, "max_abs_z_over_L": s.max_abs_z_over_L,
                        "stable": bool(s.stable)} for s in self.samples],
            "events": [{"branch": name, "kind": e.kind, "c_over_L": e.lam,
                        "out_of_plane": bool(out_of_plane(self.problem, e))}
                       for name, br in self.branches() for e in br.events],
            "elapsed_s": self.elapsed_s,
        }

    def state_at(self, c_over_L):
        """Equilibrium on the stable path at c/L (see :func:`stable_state`)."""
        return stable_state(self.problem, self.planar, self.popped, self.critical_c_over_L,
                            c_over_L)

    def branches(self):
        out = [("planar", self.planar)]
        out += [(f"popped (z {'>' if k == 0 else '<'} 0)", b) for k, b in enumerate(self.popped)]
        return out


def out_of_plane(problem, event):
    """Whether a bifurcation's null vector is mostly uz, rx, ry."""
    if event.null_vector is None:
        return False
    v = problem.full(event.null_vector)
    return np.linalg.norm(v[:, OUT_OF_PLANE]) > np.linalg.norm(np.delete(v, OUT_OF_PLANE, 1))


def _mid_height(state):
    return float(state.x[state.x.shape[0] // 2, 2])


def max_abs_z(state):
    return float(np.max(np.abs(state.x[:, 2])))


def warm_up():
    """Compile (or load) the numba kernels before timing."""
    x = np.zeros((1, 3))
    q = np.array([[1.0, 0, 0, 0]])
    one = np.ones((1, 3))
    element_forces(x, x + [1, 0, 0], q, q, np.ones(1), one, 0 * one, one, one)


def popup(srod, c_from=0.95, c_to=0.45, c_step=0.05, *, ds=0.2, progress=None,
          pin_threads=True):
    """Trace the pop-up of ``srod`` as c/L goes from c_from down to c_to.

    Returns a :class:`PopupResult`: the planar branch with its events, both
    popped branches, and the stable path sampled at c_from, c_from - c_step,
    ... (planar above the critical point, popped below).  ``pin_threads``:
    run on one BLAS and numba thread (:func:`knitfem.threads.threads_for`; a
    small problem runs faster so).
    """
    c_from = srod.check_c("c_from", c_from)
    c_to = srod.check_c("c_to", c_to)
    if not c_to < c_from:
        raise ValueError(f"c_to must be smaller than c_from, got c_from = {c_from}, c_to = {c_to}")
    c_step = check_positive("c_step", c_step)
    if (c_from - c_to) / c_step > MAX_SAMPLES:
        raise ValueError(f"c_step must be at least (c_from - c_to) / {MAX_SAMPLES:g} = "
                         f"{(c_from - c_to) / MAX_SAMPLES:.3g}, got {c_step!r}")
    with threads_for(6 * (srod.elements + 1), pin_threads):
        return _popup(srod, c_from, c_to, c_step, ds, progress)


def _popup(srod, c_from, c_to, c_step, ds, progress):
    warm_up()
    t0 = time.perf_counter()
    model = srod.model(c_from)
    problem = ParametricProblem(model)
    options = dict(ds=ds, ds_max=4 * ds, lam_range=(c_to, c_from), progress=progress)
    planar = continuation(problem, model.initial_state(), c_from, direction=-1.0, **options)
    critical = next((e for e in planar.events
                     if e.kind == "bifurcation" and out_of_plane(problem, e)), None)
    popped = []
    if critical is not None:
        for sign in (1.0, -1.0):
            branch = switch_branch(problem, critical, sign=sign, eps=0.25 * ds, **options)
            branch.points.insert(0, critical.point)      # draw it from the bifurcation
            popped.append(branch)
        # z > 0 first: the null vector's sign is arbitrary
        popped.sort(key=lambda b: -_mid_height(b.points[-1].state))
    samples = _sample(problem, planar, popped, critical, c_from, c_to, c_step, srod.length)
    elapsed = time.perf_counter() - t0
    return PopupResult(srod, c_from, c_to, None if critical is None else critical.lam, planar,
                       popped, samples, elapsed, model, problem)


def stable_state(problem, planar, popped, c_crit, c):
    """Equilibrium on the stable path at c/L: the planar branch above the
    critical point, the first popped branch below; Newton at fixed c from the
    nearest continuation point of that branch.

    Below c_crit the bifurcation point itself (the popped branches' first
    point, z = 0) is never the start: Newton at fixed c from there stays on
    the planar branch, unstable below c_crit.  From a popped point, the
    predictor along its tangent lands between the plane and that point (on
    the parabola c_crit - c ~ z^2 of a pitchfork, at (z1^2 + z^2) / 2 z1 > z),
    where Newton converges to the popped state.  Raises RuntimeError if the
    landing still ends in the plane."""
    below = popped and c_crit is not None and c < c_crit
    points = planar.points
    if below:
        points = [p for p in popped[0].points if p.lam < c_crit]
        if not points:
            raise RuntimeError(f"no popped branch point below c_crit/L = {c_crit:.8g} to land "
                               f"at c/L = {c:.8g} from")
    near = min(points, key=lambda p: abs(p.lam - c))
    if near.lam == c:
        return near.state
    state = Continuation(problem).land(near, c).state
    if below and not _off_plane(state):
        raise RuntimeError(f"landing on the popped branch at c/L = {c:.8g} (below c_crit/L = "
                           f"{c_crit:.8g}) from c/L = {near.lam:.8g} fell into the plane")
    return state


def _off_plane(state):
    """Whether a state has left the x-y plane beyond round-off."""
    return max_abs_z(state) > 1e-9 * float(np.max(np.abs(state.x[:, :2])))


def _sample(problem, planar, popped, critical, c_from, c_to, c_step, L):
    """The stable path at c_from, c_from - c_step, ... >= c_to."""
    grid = c_from - c_step * np.arange(int(np.floor((c_from - c_to) / c_step + 1e-9)) + 1)
    grid = np.round(grid, 12)           # 0.7324, not 0.7323999999999999, in the output
    c_crit = None if critical is None else critical.lam
    out = []
    for c in grid:
        state = stable_state(problem, planar, popped, c_crit, c)
        _, J, _, _ = problem.evaluate(state, c, True)
        neg = negative_eigenvalue_count(J)
        out.append(Sample(float(c), max_abs_z(state) / L, neg == 0, neg, state))
    return out
