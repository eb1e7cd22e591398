"""Optional benchmark: knitfem against PyElastica on the S-rod pop-up at c/L = 0.6.

PyElastica (PyPI ``pyelastica``, import ``elastica``) is not a knitfem
dependency; give it its own virtualenv with knitfem installed next to it::

    python3 -m venv /tmp/elastica-venv
    /tmp/elastica-venv/bin/pip install pyelastica      # 1.0.0: numpy 2.4, numba 0.68
    /tmp/elastica-venv/bin/pip install -e .
    NUMBA_CACHE_DIR=/tmp/numba-cache /tmp/elastica-venv/bin/python \\
        studies/bench_pyelastica.py --out studies/results/bench_pyelastica

(NUMBA_CACHE_DIR keeps this environment's compiled kernels out of the
source tree's __pycache__, which the project's own .venv uses.)  Without
PyElastica the script says so and exits with code 3.  About 25 s in all
(--refine with no value skips the 120/240-element runs: about 10 s).

Scene (knitfem's ``SRod`` defaults): naturally straight rod, L = 105 mm,
d = 3 mm, E = 1 MPa, nu = 0.5 (G = E/3, GJ/EI = 2/3), 60 elements, clamped
at (0, 0, 0) and (w, c, 0) with tangent +x at both ends, w = 28.4 mm,
c = 0.6 L; frames untwisted; no gravity.  The planar S is unstable there and
the rod pops out of plane.

* knitfem: static continuation (``knitfem.scenes.srod.popup``) from c/L = 0.95
  down to 0.6, which finds the out-of-plane bifurcation and follows the stable
  popped branch; plus single cold Newton solves at c/L = 0.6 from the planar
  elastica with an out-of-plane bump, to show what one equilibrium costs and
  that Newton alone does not know which equilibrium it lands on.
* PyElastica: damped Cosserat-rod dynamics.  Its rods start straight, so the
  protocol is: straight along +x, the far clamp moved (smooth ramp, both clamp
  frames held) from (L, 0, 0) to (w, c, 0), a small out-of-plane force at
  mid-span during the move so the S can pop, then hold and let the damping
  settle until a static-equilibrium test passes (see ``run_to_equilibrium``).

Writes ``bench_pyelastica.json`` (all numbers), ``bench_pyelastica.png``
(both centrelines, x-z and y-z views) and ``bench_pyelastica.md`` (the table
that is also printed).
"""
import argparse
import math
import platform
import sys
import time
from dataclasses import asdict, dataclass
from importlib import metadata
from pathlib import Path

import numpy as np

try:                                  # optional: the benchmark's only extra dependency
    import elastica as ea
except ImportError:
    ea = None

EXIT_NO_ELASTICA = 3
# PyElastica classes are subclassed below; without elastica they derive from
# object and are never instantiated (main() exits first).
_ConstraintBase = ea.ConstraintBase if ea is not None else object
_NoForces = ea.NoForces if ea is not None else object
_Simulator = ((ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Damping)
              if ea is not None else (object,))


# --------------------------------------------------------------------------- scene

@dataclass
class Scene:
    """The S-rod at one course length; lengths in mm, E in MPa (knitfem's units)."""
    length: float = 105.0         # mm
    diameter: float = 3.0         # mm
    E: float = 1.0                # MPa
    poisson: float = 0.5
    elements: int = 60
    w: float = 28.4               # mm, wale offset of the far clamp
    c_over_L: float = 0.6
    density: float = 1100.0       # kg/m^3, PyElastica only (silicone-like; statics ignore it)

    @property
    def c(self):
        """Course length, mm."""
        return self.c_over_L * self.length


# --------------------------------------------------------------------------- knitfem

def srod_of(scene):
    from knitfem.scenes.srod import SRod

    return SRod(length=scene.length, w=scene.w, diameter=scene.diameter, E=scene.E,
                poisson=scene.poisson, elements=scene.elements)


def knitfem_popup(scene, repeat=1, c_from=None, c_step=0.05):
    """Continuation from c_from down to scene.c_over_L (knitfem's own protocol).

    ``popup`` warms up only the element kernel; its first call in a process
    still compiles (or loads from numba's cache) the rest, so that call is
    reported apart (``first_call_s``) and ``elapsed_s`` is the median of
    ``repeat`` further calls (popup's own ``elapsed_s``, s).  Returns (summary
    dict, centreline (n+1, 3) in mm at c/L = scene.c_over_L).
    """
    from knitfem.scenes.srod import popup
    if c_from is None:
        # from at most 0.95 down in whole steps onto c itself: the answer is
        # a sample at c, not the nearest one on a grid from 0.95
        steps = math.floor((0.95 - scene.c_over_L) / c_step + 1e-9)
        if steps < 1:            # c within a step of 0.95: one shorter step from 0.95
            if scene.c_over_L >= 0.95:
                raise ValueError(f"--c must be below 0.95 (the branch starts there), got "
                                 f"{scene.c_over_L}")
            steps, c_step = 1, 0.95 - scene.c_over_L
        c_from = scene.c_over_L + c_step * steps

    def run():
        return popup(srod_of(scene), c_from=c_from, c_to=scene.c_over_L, c_step=c_step)

    t = time.perf_counter()
    run()
    first = time.perf_counter() - t
    results = [run() for _ in range(repeat)]
    times = [r.elapsed_s for r in results]
    result = results[-1]
    sample = min(result.samples, key=lambda s: abs(s.c_over_L - scene.c_over_L))
    if abs(sample.c_over_L - scene.c_over_L) > 1e-9:
        raise ValueError(f"knitfem's branch has no sample at c/L = {scene.c_over_L} (nearest "
                         f"{sample.c_over_L}): c_from {c_from} and c_step {c_step} miss it")
    summary = {
        "c_from": c_from,
        "protocol": f"popup(SRod(elements={scene.elements}), c_from={c_from}, "
                    f"c_to={scene.c_over_L}, c_step={c_step})",
        "max_abs_z_over_L": sample.max_abs_z_over_L,
        "stable": bool(sample.stable),
        "critical_c_over_L": result.critical_c_over_L,
        "elapsed_s": float(np.median(times)),
        "elapsed_runs_s": times,
        "first_call_s": first,
    }
    return summary, sample.state.x.copy()


def knitfem_short_rod(scene):
    """max|z| (over the true L) of knitfem's rod made one element length h = L/n
    shorter, same clamps (w, c in mm) and element count.

    A diagnostic for PyElastica's first-order mesh error: its clamps hold the
    director of the whole end element and its bending lives at the interior
    nodes' Voronoi domains, so about h/2 at each end never bends; if that is
    the cause, PyElastica at n elements matches this rod, not the rod of length L.
    """
    from knitfem.scenes.srod import popup

    short = Scene(**{**asdict(scene), "length": scene.length * (1.0 - 1.0 / scene.elements)})
    short.c_over_L = scene.c / short.length          # the far clamp stays at c (mm)
    result = popup(srod_of(short), c_from=short.c_over_L + 0.3, c_to=short.c_over_L,
                   c_step=0.05)
    return {"length_mm": short.length,
            "max_abs_z_over_L": result.samples[-1].max_abs_z_over_L * short.length
            / scene.length}


def knitfem_cold_newton(scene, bumps=(0.01, 0.05, 0.1)):
    """One Newton solve at c/L = scene.c_over_L, no continuation.

    Start: the planar elastica joining the clamps (what ``SRod.model`` lays
    out) with z += bump L sin(pi s/L).  Newton converges to whichever
    equilibrium is near, the unstable planar S included, so each attempt
    reports its landing point and its stability (number of negative
    eigenvalues of the tangent).  Time includes building the model.
    """
    from knitfem.beam.parametric import ParametricProblem
    from knitfem.scenes.srod import max_abs_z
    from knitfem.solve.continuation import FixedParameter
    from knitfem.solve.newton import NewtonError, newton
    from knitfem.solve.stability import negative_eigenvalue_count

    srod = srod_of(scene)
    lam = scene.c_over_L
    attempts = []
    for bump in bumps:
        t = time.perf_counter()
        model = srod.model(lam)
        problem = ParametricProblem(model)
        state = model.initial_state()
        state.x[:, 2] += bump * scene.length * np.sin(np.linspace(0.0, np.pi, state.x.shape[0]))
        try:
            res = newton(FixedParameter(problem, lam), state, max_iter=50)
        except NewtonError as err:
            attempts.append({"bump_over_L": bump, "converged": False, "error": str(err),
                             "time_s": time.perf_counter() - t})
            continue
        elapsed = time.perf_counter() - t
        _, J, _, _ = problem.evaluate(res.state, lam, True)      # stability: not timed
        attempts.append({"bump_over_L": bump, "converged": True, "iterations": res.iterations,
                         "time_s": elapsed,
                         "max_abs_z_over_L": max_abs_z(res.state) / scene.length,
                         "negative_eigenvalues": int(negative_eigenvalue_count(J))})
    return attempts


# --------------------------------------------------------------------------- PyElastica

def smoothstep(u):
    """0 -> 1 with zero slope at both ends, and its derivative; u clipped to [0, 1]."""
    u = min(max(u, 0.0), 1.0)
    return u * u * (3.0 - 2.0 * u), 6.0 * u * (1.0 - u)


class MovingClamps(_ConstraintBase):
    """Both ends clamped with their initial (untwisted) frames; the last node
    follows a straight-line smooth ramp from its initial position to ``target``
    over ``ramp_time`` and then stays there.

    PyElastica hands the constrained nodes' and elements' initial values to
    the constructor (``constrained_position_idx=(0, -1)``,
    ``constrained_director_idx=(0, -1)``).  Positions in m, time in s.
    """

    def __init__(self, x_start, x_end, Q_start, Q_end, *, target, ramp_time, **kwargs):
        super().__init__(**kwargs)
        self.x_start, self.x_from = x_start.copy(), x_end.copy()
        self.Q_start, self.Q_end = Q_start.copy(), Q_end.copy()
        self.target = np.asarray(target, dtype=float)
        self.ramp_time = float(ramp_time)

    def end_position(self, time):
        s, ds = smoothstep(time / self.ramp_time)
        move = self.target - self.x_from
        return self.x_from + s * move, ds / self.ramp_time * move

    def constrain_values(self, system, time):
        system.position_collection[..., 0] = self.x_start
        system.position_collection[..., -1] = self.end_position(time)[0]
        system.director_collection[..., 0] = self.Q_start     # frames never turn
        system.director_collection[..., -1] = self.Q_end

    def constrain_rates(self, system, time):
        system.velocity_collection[..., 0] = 0.0
        system.velocity_collection[..., -1] = self.end_position(time)[1]
        system.omega_collection[..., 0] = 0.0
        system.omega_collection[..., -1] = 0.0


class OutOfPlaneNudge(_NoForces):
    """A force ``force`` (N) along +z on the mid node while time < ``until`` (s):
    the imperfection that lets the planar S leave the plane once it is
    unstable.  Switched off before the settling, so it does not bias the
    final equilibrium."""

    def __init__(self, force, until):
        super().__init__()
        self.force, self.until = float(force), float(until)

    def apply_forces(self, system, time=0.0):
        if time < self.until:
            system.external_forces[2, system.n_elems // 2] += self.force


class SRodSimulator(*_Simulator):
    """PyElastica simulator with the modules the S-rod needs."""


@dataclass
class Dynamics:
    """PyElastica run parameters in SI (s, 1/s); see ``build_pyelastica``.

    Statics depend neither on these nor on the density; they set how long the
    settling takes.  Chosen by a small scan at 60 elements (ramp 0.25 or 0.5 s,
    damping 20, 40 or 80 1/s, dt 2e-5 or 4e-5 s): all twelve reach the same
    shape (max|z|/L equal to 1e-7); damping 40 was the fastest, ramp 0.25 s
    would save ~5 %.
    """
    ramp_time: float = 0.5        # s; ~1 bending time T_b, slow enough to stay near-static
    dt: float = 4.0e-5            # s at 60 elements; the axial-wave limit is dx/c = 5.8e-5 s
    damping: float = 40.0         # 1/s; uniform (mass-proportional) damping constant
    nudge: float = 1.0e-3         # nudge force in units of EI/L^2
    check_interval: float = 5e-3  # s of simulated time between equilibrium checks
    force_tol: float = 1.0e-6     # static test: max nodal force / (EI/L^2)
    milestones: tuple = (1e-3, 1e-4, 1e-5)   # looser tolerances also timed on the way
    max_time: float = 20.0        # s of simulated time before giving up
    max_wall: float = 180.0       # s of wall time before giving up

    def for_elements(self, n, reference=60):
        """The same protocol on a finer mesh: dt scales with the element length."""
        return Dynamics(**{**asdict(self), "dt": self.dt * reference / n})


def si(scene):
    """Scene in SI: m, Pa, kg/m^3."""
    mm = 1.0e-3
    E = scene.E * 1.0e6
    return {"L": scene.length * mm, "r": 0.5 * scene.diameter * mm, "E": E,
            "G": E / (2.0 * (1.0 + scene.poisson)), "rho": scene.density,
            "w": scene.w * mm, "c": scene.c * mm,
            "EI": E * math.pi * (scene.diameter * mm)**4 / 64.0}


def bending_time(scene):
    """T_b = L^2 sqrt(rho A / EI), s: the time scale of the rod's slowest motions."""
    p = si(scene)
    A = math.pi * p["r"]**2
    return p["L"]**2 * math.sqrt(p["rho"] * A / p["EI"])


def build_pyelastica(scene, dyn):
    """The straight rod along +x with its clamps, nudge and damping; finalized.

    Directors (PyElastica's are rows of Q, d3 = tangent): d3 = +x,
    d1 = normal = +y, d2 = d3 x d1 = +z, at every element and both clamps, so
    the binormal is +z and the clamp frames are untwisted and equal.
    """
    p = si(scene)
    sim = SRodSimulator()
    rod = ea.CosseratRod.straight_rod(
        scene.elements, start=np.zeros(3), direction=np.array([1.0, 0.0, 0.0]),
        normal=np.array([0.0, 1.0, 0.0]), base_length=p["L"], base_radius=p["r"],
        density=p["rho"], youngs_modulus=p["E"], shear_modulus=p["G"])
    sim.append(rod)
    sim.constrain(rod).using(MovingClamps, constrained_position_idx=(0, -1),
                             constrained_director_idx=(0, -1),
                             target=np.array([p["w"], p["c"], 0.0]), ramp_time=dyn.ramp_time)
    sim.add_forcing_to(rod).using(OutOfPlaneNudge, force=dyn.nudge * p["EI"] / p["L"]**2,
                                  until=dyn.ramp_time)
    # uniform damping: v and omega both decay as exp(-damping t); unconditionally
    # stable (analytical), so it only sets how fast the dynamics settle
    sim.dampen(rod).using(ea.AnalyticalLinearDamper, uniform_damping_constant=dyn.damping,
                          time_step=dyn.dt)
    sim.finalize()
    return sim, rod


def static_residual(rod, scene):
    """Largest out-of-balance force on a free node over EI/L^2 (dimensionless).

    At rest the nodal internal forces (elastic, N) vanish at every free node;
    with the rod moving they equal mass times acceleration (plus damping)."""
    p = si(scene)
    return float(np.max(np.linalg.norm(rod.internal_forces[:, 1:-1], axis=0))
                 / (p["EI"] / p["L"]**2))


def run_to_equilibrium(scene, dyn, log=print):
    """Ramp, hold, and step until static.

    Static test (checked every ``dyn.check_interval`` of simulated time, once
    the ramp and the nudge are over): the largest free-node force imbalance
    is below ``dyn.force_tol`` EI/L^2 at two consecutive checks (one check can
    catch an oscillating residual near a zero).  The wall time at which each
    looser tolerance in ``dyn.milestones`` passed the same test is recorded
    too.  Wall time includes building the simulation.  Returns a dict (times
    in s, max|z| over L) and the centreline (n+1, 3) in mm.
    """
    t0 = time.perf_counter()
    sim, rod = build_pyelastica(scene, dyn)
    stepper = ea.PositionVerlet()
    T_b = bending_time(scene)
    L_m = si(scene)["L"]
    per_check = max(1, round(dyn.check_interval / dyn.dt))
    tols = sorted(set(dyn.milestones) | {dyn.force_tol}, reverse=True)
    passed, milestones, previous = set(), [], math.inf
    t_sim, steps, history, status = 0.0, 0, [], "max_time"
    while t_sim < dyn.max_time:
        for _ in range(per_check):
            t_sim = stepper.step(sim, t_sim, dyn.dt)
        steps += per_check
        if not np.all(np.isfinite(rod.position_collection)):
            status = "diverged"
            break
        residual = static_residual(rod, scene)
        z = float(np.max(np.abs(rod.position_collection[2]))) / L_m
        vmax = float(np.max(np.linalg.norm(rod.velocity_collection, axis=0))) * T_b / L_m
        history.append({"t": float(t_sim), "residual": residual, "v_max": vmax,
                        "max_abs_z_over_L": z})
        settled = max(residual, previous) if t_sim > dyn.ramp_time + dyn.check_interval \
            else math.inf
        previous = residual
        for tol in tols:
            if tol not in passed and settled < tol:
                passed.add(tol)
                milestones.append({"force_tol": tol, "wall_s": time.perf_counter() - t0,
                                   "simulated_s": float(t_sim), "max_abs_z_over_L": z})
        if dyn.force_tol in passed:
            status = "converged"
            break
        if time.perf_counter() - t0 > dyn.max_wall:
            status = "max_wall"
            break
    wall = time.perf_counter() - t0
    x = rod.position_collection.T * 1.0e3                       # m -> mm
    last = history[-1]
    stretch = float(np.max(np.abs(rod.lengths / rod.rest_lengths - 1.0)))
    log(f"PyElastica ({scene.elements} elements): {status} at t = {t_sim:.3f} s "
        f"({steps} steps, {wall:.2f} s wall), residual {last['residual']:.1e} EI/L^2, "
        f"max|z|/L {last['max_abs_z_over_L']:.5f}")
    return {"status": status, "wall_s": wall, "simulated_s": float(t_sim), "steps": steps,
            "dt_s": dyn.dt, "us_per_step": 1e6 * wall / max(steps, 1), "bending_time_s": T_b,
            "final_residual": last["residual"], "final_v_max_T_b_over_L": last["v_max"],
            "max_axial_strain": stretch, "max_abs_z_over_L": last["max_abs_z_over_L"],
            "milestones": milestones, "history": history[::10] + [last]}, x


def warm_up_pyelastica(scene, dyn):
    """A few steps of a throwaway simulation: numba compiles (or loads from its
    cache) PyElastica's kernels here, not inside the timed run."""
    t = time.perf_counter()
    sim, _ = build_pyelastica(scene, dyn)
    stepper, t_sim = ea.PositionVerlet(), 0.0
    for _ in range(3):
        t_sim = stepper.step(sim, t_sim, dyn.dt)
    return time.perf_counter() - t


# --------------------------------------------------------------------------- comparison

def compare(scene, x_kf, x_pe):
    """Node-by-node distance of the centrelines over L, after mirroring knitfem's
    shape in z if needed (z -> -z maps the problem to itself: both popped
    branches are equilibria, and which one a run takes is up to its
    imperfection).  Returns (dict, knitfem centreline as compared)."""
    mid = x_kf.shape[0] // 2
    flip = bool(np.sign(x_kf[mid, 2]) != np.sign(x_pe[mid, 2]))
    x_kf = x_kf * np.array([1.0, 1.0, -1.0 if flip else 1.0])
    d = np.linalg.norm(x_kf - x_pe, axis=1) / scene.length
    return {"knitfem_z_mirrored": flip, "pyelastica_mid_z_sign": int(np.sign(x_pe[mid, 2])),
            "max_node_distance_over_L": float(d.max()),
            "rms_node_distance_over_L": float(np.sqrt(np.mean(d**2)))}, x_kf


def refinement(scene, dyn, levels, log=print):
    """Both codes at finer meshes (same protocols, PyElastica's dt scaled with
    the element length), one run each.  Returns the rows and the finest
    PyElastica centreline (mm)."""
    rows, x_fine = [], None
    for n in levels:
        sc = Scene(**{**asdict(scene), "elements": n})
        kf, _ = knitfem_popup(sc, repeat=1)
        pe, x_fine = run_to_equilibrium(sc, dyn.for_elements(n), log=log)
        rows.append({"elements": n, "knitfem_max_abs_z_over_L": kf["max_abs_z_over_L"],
                     "knitfem_elapsed_s": kf["elapsed_s"],
                     "pyelastica_max_abs_z_over_L": pe["max_abs_z_over_L"],
                     "pyelastica_wall_s": pe["wall_s"], "pyelastica_status": pe["status"]})
    return rows, x_fine


def extrapolate(rows, key, order):
    """Richardson extrapolation h -> 0 from the two finest meshes (element
    counts in ratio r): z + (z - z_coarse) / (r^order - 1); None if < 2 rows."""
    if len(rows) < 2:
        return None
    a, b = rows[-2], rows[-1]
    r = b["elements"] / a["elements"]
    return b[key] + (b[key] - a[key]) / (r**order - 1.0)


def plot(path, scene, x_kf, x_pe, x_fine=None, n_fine=None):
    """Centrelines over L, x-z and y-z views."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    L = scene.length
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.4))
    for ax, (i, name) in zip(axes, [(0, "x"), (1, "y")]):
        ax.plot(x_kf[:, i] / L, x_kf[:, 2] / L, "-", color="C0", lw=2.5,
                label=f"knitfem, {scene.elements} el.")
        ax.plot(x_pe[:, i] / L, x_pe[:, 2] / L, "o", color="C3", ms=3.5, mfc="none",
                label=f"PyElastica, {scene.elements} el.")
        if x_fine is not None:
            ax.plot(x_fine[:, i] / L, x_fine[:, 2] / L, "--", color="C2", lw=1.2,
                    label=f"PyElastica, {n_fine} el.")
        ax.set_xlabel(f"{name} / L")
        ax.set_ylabel("z / L")
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.set_title(f"{name}-z view")
    axes[1].legend(loc="lower center", fontsize=8)
    fig.suptitle(f"S-rod at c/L = {scene.c_over_L}, w/L = {scene.w / L:.3f}: "
                 "popped equilibrium")
    fig.tight_layout()
    from knitfem.io import save_figure
    save_figure(fig, path)


def table(out):
    """The markdown summary (printed and written to bench_pyelastica.md)."""
    sc, kf, pe, cmp_ = out["scene"], out["knitfem"], out["pyelastica"], out["comparison"]
    short = out["knitfem_short_rod"]
    dz = pe["max_abs_z_over_L"] - kf["max_abs_z_over_L"]
    lines = [
        f"S-rod at c/L = {sc['c_over_L']}, w/L = {sc['w'] / sc['length']:.4f}, "
        f"{sc['elements']} elements; pyelastica {out['versions']['pyelastica']}, "
        f"knitfem {out['versions']['knitfem']}",
        "",
        "| solver | protocol | max\\|z\\|/L | wall time (s) |",
        "|---|---|---:|---:|",
        f"| knitfem | continuation c/L {kf.get('c_from', 0.95):.4g} -> {sc['c_over_L']}, "
        f"popup elapsed_s, median of "
        f"{len(kf['elapsed_runs_s'])} | {kf['max_abs_z_over_L']:.5f} | {kf['elapsed_s']:.2f} |",
    ]
    for a in out["knitfem_cold_newton"]:
        if not a["converged"]:
            lines.append(f"| knitfem | one Newton, bump {a['bump_over_L']} L: failed | - | "
                         f"{a['time_s']:.3f} |")
            continue
        where = "stable, popped" if a["negative_eigenvalues"] == 0 else \
            f"unstable: {a['negative_eigenvalues']} neg. eigenvalues"
        lines.append(f"| knitfem | one Newton from planar + {a['bump_over_L']} L bump "
                     f"({a['iterations']} it., {where}) | {a['max_abs_z_over_L']:.5f} | "
                     f"{a['time_s']:.3f} |")
    for m in pe["milestones"][:-1]:
        lines.append(f"| PyElastica | same run, residual < {m['force_tol']:g} EI/L^2 first met "
                     f"({m['simulated_s']:.3f} s simulated) | {m['max_abs_z_over_L']:.5f} | "
                     f"{m['wall_s']:.2f} |")
    lines += [
        f"| PyElastica | damped dynamics to residual < {out['dynamics']['force_tol']:g} EI/L^2 "
        f"({pe['status']}, {pe['simulated_s']:.3f} s simulated, {pe['steps']} steps, median "
        f"of {len(pe['wall_runs_s'])}) | {pe['max_abs_z_over_L']:.5f} | {pe['wall_s']:.2f} |",
        "",
        f"- max|z|/L, PyElastica - knitfem: {dz:+.5f} ({dz / kf['max_abs_z_over_L']:+.2%}); "
        f"centrelines node by node: max {cmp_['max_node_distance_over_L']:.4f} L, "
        f"rms {cmp_['rms_node_distance_over_L']:.4f} L"
        f"{' (knitfem mirrored in z)' if cmp_['knitfem_z_mirrored'] else ''}",
        f"- knitfem with the rod one element shorter (L - h = {short['length_mm']:.2f} mm, "
        f"same clamps): max|z|/L = {short['max_abs_z_over_L']:.5f}, "
        f"near PyElastica's {pe['max_abs_z_over_L']:.5f}: consistent with PyElastica's clamps "
        "holding the whole end element, so that ~h/2 at each end does not bend (its mesh "
        "error is first order, below)",
        f"- wall time, PyElastica / knitfem continuation: "
        f"{pe['wall_s'] / kf['elapsed_s']:.1f}",
    ]
    ref = out.get("refinement")
    if ref:
        lines += ["", "Mesh refinement (one run each):", "",
                  "| elements | knitfem max\\|z\\|/L | PyElastica max\\|z\\|/L | difference | "
                  "knitfem (s) | PyElastica (s) |", "|---:|---:|---:|---:|---:|---:|"]
        base = [{"elements": sc["elements"], "knitfem_max_abs_z_over_L": kf["max_abs_z_over_L"],
                 "pyelastica_max_abs_z_over_L": pe["max_abs_z_over_L"],
                 "knitfem_elapsed_s": kf["elapsed_s"], "pyelastica_wall_s": pe["wall_s"]}]
        for r in base + ref:
            a, b = r["knitfem_max_abs_z_over_L"], r["pyelastica_max_abs_z_over_L"]
            lines.append(f"| {r['elements']} | {a:.5f} | {b:.5f} | {b - a:+.5f} | "
                         f"{r['knitfem_elapsed_s']:.2f} | {r['pyelastica_wall_s']:.2f} |")
        ex = out["extrapolated"]
        if ex["knitfem"] is not None:
            lines.append(f"| h -> 0 (Richardson) | {ex['knitfem']:.5f} (2nd order) | "
                         f"{ex['pyelastica']:.5f} (1st order) | "
                         f"{ex['pyelastica'] - ex['knitfem']:+.5f} | | |")
    return "\n".join(lines)


# --------------------------------------------------------------------------- main

def versions():
    out = {"python": platform.python_version()}
    for name in ("pyelastica", "numpy", "numba", "scipy", "scikit-fem", "knitfem"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def no_elastica():
    print("bench_pyelastica: PyElastica is not installed (import elastica failed).\n"
          "It is an optional dependency of this benchmark only; set up a separate\n"
          "environment, e.g.\n"
          "  python3 -m venv /tmp/elastica-venv\n"
          "  /tmp/elastica-venv/bin/pip install pyelastica\n"
          "  /tmp/elastica-venv/bin/pip install -e .\n"
          "and run this script with /tmp/elastica-venv/bin/python.", file=sys.stderr)
    return EXIT_NO_ELASTICA


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="studies/results/bench_pyelastica", help="output folder")
    ap.add_argument("--c", type=float, default=0.6, help="course length c/L (default 0.6)")
    ap.add_argument("--elements", type=int, default=60, help="elements (default 60)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="timed runs of each code at --elements; medians reported (default 3)")
    ap.add_argument("--refine", type=int, nargs="*", default=[120, 240],
                    help="finer meshes for the refinement study (default 120 240; none: skip)")
    ap.add_argument("--damping", type=float, default=Dynamics.damping, help="1/s")
    ap.add_argument("--dt", type=float, default=Dynamics.dt, help="time step at 60 elements, s")
    ap.add_argument("--force-tol", type=float, default=Dynamics.force_tol,
                    help="static test: max nodal force over EI/L^2 (default 1e-6)")
    args = ap.parse_args(argv)
    if ea is None:
        return no_elastica()

    scene = Scene(c_over_L=args.c, elements=args.elements)
    dyn = Dynamics(damping=args.damping, dt=args.dt, force_tol=args.force_tol)
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)

    print(f"knitfem: continuation at {scene.elements} elements ...", flush=True)
    kf, x_kf = knitfem_popup(scene, repeat=args.repeat)
    cold = knitfem_cold_newton(scene)
    short = knitfem_short_rod(scene)
    print("PyElastica: warm-up (numba) ...", flush=True)
    warm = warm_up_pyelastica(scene, dyn.for_elements(scene.elements))
    runs = [run_to_equilibrium(scene, dyn.for_elements(scene.elements))
            for _ in range(args.repeat)]
    pe, x_pe = runs[-1]
    pe["wall_runs_s"] = [r[0]["wall_s"] for r in runs]
    pe["wall_s"] = float(np.median(pe["wall_runs_s"]))
    pe["warm_up_s"] = warm
    cmp_, x_kf_cmp = compare(scene, x_kf, x_pe)

    out = {"scene": asdict(scene), "dynamics": asdict(dyn), "versions": versions(),
           "knitfem": kf, "knitfem_cold_newton": cold, "knitfem_short_rod": short,
           "pyelastica": pe, "comparison": cmp_}
    x_fine = None
    if args.refine:
        print(f"refinement: {args.refine} elements ...", flush=True)
        out["refinement"], x_fine = refinement(scene, dyn, args.refine)
        rows = [{"elements": scene.elements,
                 "knitfem_max_abs_z_over_L": kf["max_abs_z_over_L"],
                 "pyelastica_max_abs_z_over_L": pe["max_abs_z_over_L"]}] + out["refinement"]
        out["extrapolated"] = {
            "knitfem": extrapolate(rows, "knitfem_max_abs_z_over_L", order=2),
            "pyelastica": extrapolate(rows, "pyelastica_max_abs_z_over_L", order=1)}
        x_fine = x_fine * np.array([1.0, 1.0, np.sign(x_fine[x_fine.shape[0] // 2, 2])
                                    * cmp_["pyelastica_mid_z_sign"]])
    out["centrelines_mm"] = {"knitfem": x_kf.tolist(), "pyelastica": x_pe.tolist()}

    from knitfem.io import write_json, write_text
    write_json(out_dir / "bench_pyelastica.json", out, indent=1)
    plot(out_dir / "bench_pyelastica.png", scene, x_kf_cmp, x_pe, x_fine,
         args.refine[-1] if args.refine else None)
    md = table(out)
    write_text(out_dir / "bench_pyelastica.md", md + "\n")
    print()
    print(md)
    return 0 if pe["status"] == "converged" else 1


if __name__ == "__main__":
    sys.exit(main())
