"""The S-rod through the independent B-spline yarn model (Kaldor-style).

Same scene as :mod:`knitfem.scenes.srod` (naturally straight rod clamped at
(0, 0, 0) and (w, c, 0), both tangents +x), same starting shape (the planar
elastica at c_from), but a different mechanics: a uniform cubic B-spline with
stretching and bending energies, no twist (Kaldor's yarns have none, so this
compares with the beam at GJ/EI -> 0), relaxed to a minimum of the energy.

How the critical c/L is found here: relaxation finds stable equilibria only,
so the branch is followed downward in c, each point relaxed from the previous
one plus a small out-of-plane imperfection (``imperfection`` x L, a half sine
along the rod).  While the planar S is stable the imperfection dies out; once
it is unstable the rod pops.  The first grid interval where max|z|/L exceeds
``threshold`` brackets the onset, and bisection in c (relaxing from the last
planar state plus the imperfection) narrows it to ``c_tol``.
"""
from dataclasses import dataclass, field
import sys
import time

import numpy as np

from ..bspline import BSplineModel, Yarn, curve, relax_dynamic, relax_static, stability
from ..geometry import planar_elastica
from ..threads import threads_for
from .srod import SRod

_RELAX = {"static": relax_static, "dynamic": relax_dynamic}


@dataclass
class BSplineSample:
    c_over_L: float
    max_abs_z_over_L: float
    stable: bool                      # measured: lowest eigenvalue of the reduced Hessian
    control: np.ndarray = field(repr=False, default=None)
    iterations: int = 0
    lowest_eigenvalue: float = float("nan")


@dataclass
class BSplinePopup:
    srod: SRod
    segments: int
    method: str
    c_from: float
    c_to: float
    critical_c_over_L: float
    critical_bracket: tuple
    samples: list
    elapsed_s: float
    model: object = field(repr=False, default=None)

    def summary(self):
        return {
            "model": "bspline",
            "w_over_L": self.srod.w / self.srod.length,
            "elements": self.segments,
            "gj_over_ei": 0.0,                       # no twist energy in this model
            "critical_c_over_L": self.critical_c_over_L,
            "critical_bracket": list(self.critical_bracket),
            "branch": [{"c_over_L": s.c_over_L, "max_abs_z_over_L": s.max_abs_z_over_L,
                        "stable": bool(s.stable)} for s in self.samples],
            "relaxation": self.method,
            "elapsed_s": self.elapsed_s,
        }


def srod_yarn_model(srod, c_over_L, segments):
    """The B-spline model of the S-rod bent into the planar elastica at c."""
    L = srod.length
    c = srod.check_c("c", c_over_L) * L
    if int(segments) != segments or segments < 4:
        raise ValueError(f"segments must be an integer >= 4, got {segments!r}")
    points, _ = planar_elastica(L, (srod.w, c), srod.start_angle, srod.end_angle,
                                nodes=20 * segments)
    section = srod.section
    yarn = Yarn.through(points, int(segments), section.EA, section.EI2, natural="straight",
                        length=L, radius=0.5 * srod.diameter)
    model = BSplineModel([yarn])
    model.clamp(0, "start", (0.0, 0.0, 0.0),
                (np.cos(srod.start_angle), np.sin(srod.start_angle), 0))
    model.clamp(0, "end", (srod.w, c, 0.0), (np.cos(srod.end_angle), np.sin(srod.end_angle), 0))
    return model


def max_height(q, samples=9):
    """max |z| of the curve (control points q), sampled on every segment."""
    return float(np.max(np.abs(curve.evaluate(q, np.linspace(0, 1, samples))[..., 2])))


class _Marcher:
    """Relax the model at c from control points q plus the imperfection."""

    def __init__(self, srod, model, method, imperfection, rtol):
        self.srod, self.model, self.rtol = srod, model, rtol
        self.relax = _RELAX[method]
        n = model.yarns[0].control.shape[0]
        self.bump = imperfection * srod.length * np.sin(np.pi * np.linspace(0, 1, n))

    def at(self, c, q):
        L = self.srod.length
        self.model.move_clamp(1, position=(self.srod.w, c * L, 0.0))
        start = q.copy()
        start[:, 2] += self.bump
        result = self.relax(self.model, self.model.reduce(start), rtol=self.rtol)
        q = self.model.control_points(result.y)
        self.last_stability = stability.stability(self.model, result.y)
        return q, max_height(q) / L, result.iterations


def _bisection_steps(width, c_tol):
    """Halvings that take a bracket of ``width`` (c/L) down to ``c_tol``."""
    return int(np.ceil(np.log2(width / c_tol))) if width > c_tol else 0


class _Progress:
    """tqdm bar (stderr) over relaxations: grid samples, then bisection steps;
    does nothing when off."""

    def __init__(self, on, total):
        self.bar = None
        if on:
            from tqdm import tqdm
            self.bar = tqdm(total=total, desc="B-spline pop-up", unit="relax", file=sys.stderr)

    def add(self, steps):
        if self.bar is not None:
            self.bar.total += steps
            self.bar.refresh()

    def step(self, c, z):
        if self.bar is not None:
            self.bar.set_postfix_str(f"c/L={c:.4f} max|z|/L={z:.2e}", refresh=False)
            self.bar.update()

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _sweep(march, grid, q, threshold, bar):
    """Relax at every c of ``grid`` in turn from the previous shape; the samples
    and the last planar (c, q) (None if none)."""
    samples, last_planar = [], None
    for c in grid:
        q, z, its = march.at(c, q)
        stable, lowest = march.last_stability
        samples.append(BSplineSample(float(c), z, stable, q, its, lowest))
        bar.step(c, z)
        if z <= threshold:
            last_planar = (c, q)
    return samples, last_planar


def _bisect(march, samples, last_planar, threshold, c_tol, bar):
    """Critical c/L and its bracket (lo popped, hi planar) narrowed to c_tol,
    or (None, (nan, nan)) when the samples do not bracket a pop-up."""
    popped = [s for s in samples if s.max_abs_z_over_L > threshold]
    if not (popped and last_planar is not None and popped[0].c_over_L < last_planar[0]):
        return None, (np.nan, np.nan)
    hi, q_hi = last_planar                       # planar, stable
    lo = popped[0].c_over_L                      # popped
    bar.add(_bisection_steps(hi - lo, c_tol))    # known only now
    while hi - lo > c_tol:
        mid = 0.5 * (hi + lo)
        q_mid, z, _ = march.at(mid, q_hi)
        bar.step(mid, z)
        if z > threshold:
            lo = mid
        else:
            hi, q_hi = mid, q_mid
    return 0.5 * (hi + lo), (lo, hi)


def bspline_popup(srod, c_from=0.95, c_to=0.45, c_step=0.05, *, segments=32, method="static",
                  imperfection=1e-3, threshold=5e-3, c_tol=2e-3, rtol=1e-6, progress=False,
                  pin_threads=True):
    """Pop-up of ``srod`` in the B-spline model, sampled at c_from, c_from -
    c_step, ... >= c_to; returns a :class:`BSplinePopup`.  progress: a tqdm bar
    on stderr, one tick per relaxation (grid samples, then bisection steps).
    pin_threads: one BLAS and numba thread for this small problem
    (:func:`knitfem.threads.threads_for`)."""
    c_from = srod.check_c("c_from", c_from)
    c_to = srod.check_c("c_to", c_to)
    if not c_to < c_from:
        raise ValueError(f"c_to must be smaller than c_from, got c_from = {c_from}, c_to = {c_to}")
    if method not in _RELAX:
        raise ValueError(f"method must be one of {sorted(_RELAX)}, got {method!r}")
    if not 0 < imperfection < threshold:
        raise ValueError(f"need 0 < imperfection < threshold, got {imperfection}, {threshold}")
    t0 = time.perf_counter()
    model = srod_yarn_model(srod, c_from, segments)          # validates segments
    with threads_for(3 * (segments + 3), pin_threads):
        march = _Marcher(srod, model, method, imperfection, rtol)
        q = model.control_points(model.reduce(model.yarns[0].control))
        grid = c_from - c_step * np.arange(int(np.floor((c_from - c_to) / c_step + 1e-9)) + 1)
        grid = np.round(grid, 12)       # 0.7324, not 0.7323999999999999, in the output
        bar = _Progress(progress, len(grid))
        try:                                    # close the bar also when a relaxation fails
            samples, last_planar = _sweep(march, grid, q, threshold, bar)
            critical, bracket = _bisect(march, samples, last_planar, threshold, c_tol, bar)
        finally:
            bar.close()
    elapsed = time.perf_counter() - t0
    return BSplinePopup(srod, int(segments), method, c_from, c_to, critical, bracket, samples,
                        elapsed, model)
