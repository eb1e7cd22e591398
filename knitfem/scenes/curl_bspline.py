"""Fabric curling with the paper's own model: relax a B-spline swatch, classify its curl.

Protocol (paper Sec. 6, scene choices of issue 9, :mod:`.swatch_bspline`):
the knitted swatch (rest length = knitted length), the knit yarn's rest
length shrunk by alpha, then relaxation to a static equilibrium:

* ``method="dynamic"``: the paper's dynamic relaxation, lumped yarn masses,
  mass-proportional damping (k_global), normal and tangential contact
  damping, standing oscillations detected and ended
  (:func:`knitfem.bspline.relax_dynamic`);
* ``method="fire"`` (default): FIRE on the same energy with Gershgorin masses
  (:func:`knitfem.bspline.fire.relax_fire`), the accelerated relaxation.

Either stops when the relative residual |dE/dq| / (sum of the separate force
sizes) is below ``rtol`` (and, dynamic, the kinetic energy below its
criterion); FIRE then also asks the Newton step to the nearest equilibrium
(:func:`knitfem.bspline.stability.equilibrium_distance`) to move no control
point more than ``rest_tol`` yarn radii, and goes on towards ten times smaller
residuals until it does (a relative residual against the stiff stretching
forces can leave a rolling swatch radii from rest).  ``newton=True`` then tries
to finish with Newton to ``newton_rtol`` (kept only if it gets there).  Every
answer says whether it converged; a run that runs out of time returns its last
state with ``converged: false``.
Stability: the lowest eigenvalue of the reduced Hessian with the six rigid
motions lifted (:mod:`knitfem.bspline.stability`).  Curl: the shared output
analysis :func:`knitfem.analysis.curl.swatch_curl` on the deformed yarn points.
Units: mm, g, s; angles in degrees.
"""
from dataclasses import asdict
import json
import time
import warnings

import numpy as np

from ..bspline import RelaxationError, relax_dynamic, relax_newton, stability
from ..bspline.contact import overlap
from ..bspline.fire import FireState, relax_fire
from ..bspline.relax import converged
from ..io.run import source
from .swatch_bspline import YarnConstants, bspline_swatch, prestretch

METHODS = ("fire", "dynamic")


class Trace:
    """A relaxation monitor: wall time, step, relative residual, energy and
    kinetic energy at every check, and the edge rolls (the shared curl
    analysis) every ``shape_every`` seconds; ``rows`` / ``shapes`` lists of dicts."""

    def __init__(self, bswatch, shape_every=15.0):
        self.bs, self.shape_every = bswatch, float(shape_every)
        self.start = time.perf_counter()
        self.rows, self.shapes = [], []
        self._next = 0.0

    def __call__(self, step, y, residual, E, ke):
        t = time.perf_counter() - self.start
        self.rows.append({"t": t, "step": step, "residual": residual, "energy": E, "ke": ke})
        if t >= self._next:
            from ..analysis.curl import swatch_curl
            q = self.bs.model.control_points(y)
            try:
                shape = swatch_curl(self.bs.points(q), self.bs.swatch)
                rolls, curl = {k: float(v) for k, v in shape.roll_deg.items()}, shape.curl
            except ValueError:                   # a shape the analysis cannot read
                rolls, curl = {}, None
            self.shapes.append({"t": t, "step": step, "residual": residual, "curl": curl,
                                **{f"roll_{k}": v for k, v in rolls.items()}})
            self._next = t + self.shape_every


def _check_count(name, value, minimum):
    if isinstance(value, bool) or int(value) != value or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


class AtRest:
    """FIRE's ``confirm``: the Newton step to the nearest equilibrium moves no
    control point more than ``tol`` (mm; inf: no check); ``distance`` keeps
    the last answer (None: the step does not descend, or not measured), ``y``
    the state it was measured at and ``failure`` why it could not be measured
    (then the residual alone decides, as before the check existed)."""

    def __init__(self, model, tol):
        self.model, self.tol = model, float(tol)
        self.y = self.distance = self.failure = None

    def measure(self, y):
        if np.isinf(self.tol):
            return None
        if self.y is None or not np.array_equal(self.y, y):
            self.y = np.array(y, copy=True)
            try:
                self.distance, self.failure = stability.equilibrium_distance(self.model, y), None
            except (RuntimeError, MemoryError, ValueError, np.linalg.LinAlgError) as err:
                # never at the cost of hours of relaxation: say so, decide by the residual
                self.distance, self.failure = None, f"{type(err).__name__}: {err}"
                warnings.warn(f"distance to rest not measured ({self.failure}); the residual "
                              "alone decides")
        return self.distance

    def __call__(self, y):
        distance = self.measure(y)
        if np.isinf(self.tol) or self.failure is not None:
            return True
        return distance is not None and distance <= self.tol


def relax_swatch(bswatch, *, method="fire", rtol=1e-6, max_time=1800.0, max_steps=None,
                 newton=True, newton_rtol=1e-8, newton_steps=50, progress=False, monitor=None,
                 state=None, checkpoint=None, checkpoint_every=600.0, rest_tol=0.1):
    """Relax a prestretched :class:`~.swatch_bspline.BSplineSwatch` from its
    knitted shape; returns (y, info dict: converged, residual, iterations,
    method, history, oscillations, message).  max_steps: a step limit besides
    the time limit (None: none; a step limit repeats bit for bit, a time limit
    depends on the machine's load).  monitor(step, y, residual, E, ke).
    FIRE only: state, a :class:`~knitfem.bspline.fire.FireState` to go on
    from; checkpoint(state) every ``checkpoint_every`` seconds and at the end
    (:func:`~knitfem.bspline.fire.relax_fire`).  rest_tol: the largest move
    to the nearest equilibrium (yarn radii) that counts as at rest (FIRE goes
    on until it holds; reported as ``equilibrium_distance_over_r`` for either
    method, None where the Newton step does not descend or was not measured;
    inf switches the check off)."""
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if method != "fire" and (state is not None or checkpoint is not None):
        raise ValueError(f"checkpoints and resuming need method 'fire', got {method!r} (the "
                         "dynamic relaxation keeps no state to go on from)")
    model = bswatch.model
    radius = bswatch.swatch.radius
    if isinstance(rest_tol, bool) or not (isinstance(rest_tol, (int, float)) and rest_tol > 0):
        raise ValueError(f"rest_tol must be a positive number of yarn radii (inf: no check), "
                         f"got {rest_tol!r}")
    rest = AtRest(model, rest_tol * radius)
    y = model.reduce(model._initial()) if state is None else state.y
    start = time.perf_counter()
    info = {"method": method, "converged": False, "message": "", "oscillations": 0}
    steps = None if max_steps is None else int(max_steps)
    try:
        if method == "fire":
            result = relax_fire(model, y, rtol=rtol, max_steps=steps, max_time=max_time,
                                progress=progress, monitor=monitor, state=state,
                                checkpoint=checkpoint, checkpoint_every=checkpoint_every,
                                confirm=rest)
        else:
            result = relax_dynamic(model, y, rtol=rtol, max_steps=steps, max_time=max_time,
                                   damping=bswatch.constants.damping_rate, kinetic=False,
                                   progress=progress, monitor=monitor)
            info["oscillations"] = result.oscillations
        y, info["iterations"], info["history"] = result.y, result.iterations, result.history
        info["converged"] = True
    except RelaxationError as err:
        y, info["history"], info["message"] = err.y, err.history, str(err)
        info["iterations"] = err.iterations if err.iterations is not None \
            else len(err.history) * 20
    info["relax_s"] = time.perf_counter() - start
    if newton and info["converged"]:
        try:
            polished = relax_newton(model, y, rtol=newton_rtol, max_iter=newton_steps,
                                    progress=progress)
            y = polished.y
            info["newton_iterations"] = polished.iterations
            info["iterations"] += polished.iterations
        except RelaxationError as err:
            info["newton_iterations"] = newton_steps
            info["message"] = f"Newton finish not kept: {err}"
    E, g, ref = model.reduced_energy(y)
    info["residual"] = float(np.linalg.norm(g) / ref)
    at_rest = rest(y)                   # measures the distance (once per state)
    distance = rest.distance
    info["equilibrium_distance_over_r"] = None if distance is None else distance / radius
    small = info["converged"] and converged(g, ref, rtol, model)
    notes = [info["message"]] if info["message"] else []
    if rest.failure is not None:
        notes.append(f"distance to rest not measured ({rest.failure}): the residual alone "
                     "decided")
    elif small and not at_rest:
        # the dynamic relaxation's own criteria held, or a kept Newton finish moved y
        notes.append(f"residual {info['residual']:.1e} reached but not at rest: the Newton "
                     "step to the nearest equilibrium "
                     + ("does not descend" if distance is None else
                        f"moves a control point {distance / radius:.3g} r (rest_tol "
                        f"{rest_tol:g} r)"))
    info["message"] = "; ".join(notes)
    info["rest_tol"] = float(rest_tol)
    info["converged"] = small and at_rest
    # below the round-off floor: the relative residual cannot say more
    info["roundoff_limited"] = bool(np.linalg.norm(g) <= model.roundoff)
    return y, info


def bspline_curl(nw, nc, *, alpha=0.2, w=4.0, c=3.0, radius=0.4, segments_per_loop=16,
                 method="fire", rtol=1e-6, newton=True, max_time=1800.0, max_steps=None,
                 constants=None, bindoff_stiffness=10.0, out=None, name=None, progress=True,
                 trace=False, resume=False, checkpoint=True, checkpoint_every=600.0,
                 rest_tol=0.1, knit_natural="straight"):
    """Curl of an nw x nc plain-knit swatch in the B-spline model: issue 9's
    JSON keys (dict) plus "constants", "energy", "method", "message" and the
    relaxation history.  Fields the model cannot measure are None (here every
    key is measured).  max_time: seconds of relaxation before the last state
    is reported as not converged; max_steps: a step limit as well (None: none;
    reproducible where a time limit is not).  out: a folder for the relaxed centrelines
    (.vtu), control points (.npy) and the summary (JSON), file names
    ``name`` (default ``bspline_<nw>x<nc>``).  trace: also return the relaxation's
    :class:`Trace` rows and shapes under "trace".

    With ``out``, FIRE and ``checkpoint``, the relaxation's state goes to
    ``<name>_checkpoint.npz`` every ``checkpoint_every`` seconds and when it
    ends (however: a limit, an interruption); ``resume=True`` goes on from it
    (the same swatch and constants, else ValueError naming what differs; no
    checkpoint: from the start), bit for bit the steps of an unbroken run.
    Then max_time is this call's, max_steps and "iterations" count from the
    first run's first step and "relax_s" sums every run's relaxation.
    knit_natural: "straight" (the paper's yarn) or "knitted" (its natural
    curvature and torsion those of the knitted shape, pre-stretched all the
    same: the beam's ``straighten`` 0, a yarn set by the knitting)."""
    nw = _check_count("nw", nw, 3)
    nc = _check_count("nc", nc, 4)
    if max_steps is not None:
        max_steps = _check_count("max_steps", max_steps, 1)
    alpha = float(alpha)
    if not (np.isfinite(alpha) and 0.0 <= alpha < 1.0):
        raise ValueError(f"alpha must be in [0, 1), got {alpha!r}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    constants = YarnConstants() if constants is None else constants
    t0 = time.perf_counter()
    source()            # the commit that runs: cached now, not when the answer is written
    bs = _prestretched(nw, nc, w=w, c=c, radius=radius, segments_per_loop=segments_per_loop,
                       constants=constants, bindoff_stiffness=bindoff_stiffness, alpha=alpha,
                       knit_natural=knit_natural)
    scene = {"nw": nw, "nc": nc, "alpha": alpha, "w": float(w), "c": float(c),
             "radius": float(radius), "segments_per_loop": int(segments_per_loop),
             "bindoff_stiffness": float(bindoff_stiffness), "method": method,
             "rtol": float(rtol), "constants": asdict(constants)}
    if knit_natural != "straight":          # the scenes stored before it existed: straight
        scene["knit_natural"] = knit_natural
        # its bending and torsion in smooth forms since 2026-12-08 (energy.set_yarn_terms):
        # a checkpoint of the exact forms is refused by name, not resumed
        scene["knit_forms"] = "smooth"
    monitor = Trace(bs) if trace else None
    name = name or f"bspline_{nw}x{nc}"
    run = _Checkpoints(out if checkpoint else None, name, method, resume, scene)
    y, info = relax_swatch(bs, method=method, rtol=rtol, max_time=max_time,
                           max_steps=max_steps, newton=newton, progress=progress,
                           monitor=monitor, state=run.state, checkpoint=run.save_or_none,
                           checkpoint_every=checkpoint_every, rest_tol=rest_tol)
    summary = summarise(bs, y, info)
    summary["relax_s"] += run.earlier_s
    summary["processes"] = run.processes + 1
    summary["resumed_from_step"] = None if run.state is None else run.state.step
    summary["source"] = source()
    summary["scene"] = scene            # what was relaxed (the set yarn says so: knit_natural)
    summary["elapsed_s"] = time.perf_counter() - t0
    if trace:
        summary["trace"] = {"rows": monitor.rows, "shapes": monitor.shapes}
    if out is not None:
        write_curl(bs, y, summary, out, name)
    return summary


def _prestretched(nw, nc, *, alpha, **swatch):
    """The swatch of :func:`bspline_swatch` with its pre-stretch alpha applied
    (the one recipe of a run and of its checkpoint's scene)."""
    bs = bspline_swatch(nw, nc, **swatch)
    prestretch(bs, alpha)
    return bs


def swatch_of(scene):
    """The prestretched swatch of a checkpoint's ``scene`` (the dict
    :func:`bspline_curl` keeps in ``<name>_checkpoint.npz``)."""
    return _prestretched(scene["nw"], scene["nc"], w=scene["w"], c=scene["c"],
                         radius=scene["radius"], segments_per_loop=scene["segments_per_loop"],
                         constants=YarnConstants(**scene["constants"]),
                         bindoff_stiffness=scene["bindoff_stiffness"], alpha=scene["alpha"],
                         knit_natural=scene.get("knit_natural", "straight"))


def _commit():
    """The git commit knitfem runs from ('' when not known; '+' marks local changes)."""
    made = source()
    return "" if made is None else made["commit"] + ("+" if made["modified"] else "")


class _Checkpoints:
    """The FIRE checkpoint ``<out>/<name>_checkpoint.npz`` of one swatch
    (``scene``: what must match to resume): ``state`` to go on from (None:
    from the start), ``save(state)`` for :func:`relax_fire`, the relaxation
    seconds and the number of the runs before this one."""

    def __init__(self, out, name, method, resume, scene):
        from pathlib import Path
        self.path = Path(out) / f"{name}_checkpoint.npz" if out is not None else None
        self.scene = json.dumps(scene, sort_keys=True)
        self.state, self.earlier_s, self.processes = None, 0.0, 0
        self.start = time.perf_counter()
        if resume and (self.path is None or method != "fire"):
            raise ValueError("resume needs out (the folder holding the checkpoint), checkpoint "
                             f"on and method 'fire' (got out={out!r}, method={method!r})")
        if self.path is None or method != "fire":
            self.path = None
        elif resume and self.path.exists():
            self._load()
        elif resume:
            warnings.warn(f"resume: {self.path} does not exist; relaxing from the start")
        elif self.path.exists():
            self.path.unlink()                 # a stale run's: never resumed by mistake

    def _load(self):
        with np.load(self.path) as saved:
            kept = json.loads(str(saved["scene"]))
            given = json.loads(self.scene)
            if kept != given:
                differ = ", ".join(f"{k}: checkpoint {kept.get(k)!r}, given {given.get(k)!r}"
                                   for k in sorted(set(kept) | set(given))
                                   if kept.get(k) != given.get(k))
                raise ValueError(f"resume: {self.path} holds a run with other parameters "
                                 f"({differ}); remove it or give the same options")
            self.state = FireState.from_arrays(saved)
            self.earlier_s = float(saved["relax_s"])
            self.processes = int(saved["processes"])
            made_by = str(saved["source"]) if "source" in saved.files else ""
            now = _commit()
            if made_by != now:
                # allowed (a fix may be what the resume is for), but not silent
                warnings.warn(f"resume: {self.path} was written by code {made_by or 'unknown'}, "
                              f"this is {now or 'unknown'}: the steps from here are this code's")

    def save(self, state):
        from ..io.atomic import atomic_path
        relax_s = self.earlier_s + time.perf_counter() - self.start
        with atomic_path(self.path) as tmp:
            np.savez(tmp, scene=np.array(self.scene), relax_s=relax_s,
                     processes=self.processes + 1, source=np.array(_commit()),
                     **state.arrays())

    @property
    def save_or_none(self):
        """:meth:`save`, or None where nothing is kept (no out, not FIRE)."""
        return self.save if self.path is not None else None


def bspline_curl_from_options(args):
    """``knitfem curl --model bspline``: :func:`bspline_curl` from the validated
    options (``--max-time``, default 1800 s); writes into ``--out`` when given,
    with its checkpoint, from which ``--resume`` goes on."""
    from .swatch_bspline import YarnConstants
    return bspline_curl(args.nw, args.nc, alpha=args.alpha, w=args.w, c=args.c,
                        radius=args.radius, bindoff_stiffness=args.bindoff_stiffness,
                        constants=YarnConstants(ea_over_ei=float(args.ea_over_ei)),
                        max_time=args.max_time, out=args.out, progress=not args.quiet,
                        resume=getattr(args, "resume", False),
                        rest_tol=getattr(args, "rest_tol", None) or 0.1,
                        knit_natural="knitted" if args.straighten == 0.0 else "straight")


def summarise(bs, y, info):
    """Issue 9's keys for the state y of swatch ``bs`` (relaxation ``info``)."""
    from ..analysis.curl import swatch_curl
    from ..analysis.profile import profile_fields
    model = bs.model
    q = model.control_points(y)
    points = bs.points(q)
    shape = swatch_curl(points, bs.swatch)
    try:
        is_stable, lowest = stability.stability(model, y)
    except Exception as err:              # ARPACK did not converge: not measured, say so
        is_stable, lowest = None, None
        info["message"] += f" (stability not measured: {err})"
    pts = model._at_samples(q)
    return {
        "nw": bs.swatch.n_wale, "nc": bs.swatch.n_course, "model": "bspline",
        "alpha": bs.alpha, "curl": shape.curl, "edges_touch": bool(shape.edges_touch),
        "roll_deg": {k: float(v) for k, v in shape.roll_deg.items()},
        "curvature_x": float(shape.curvature_x), "curvature_y": float(shape.curvature_y),
        **profile_fields(points, bs.swatch),
        "height": float(shape.height), "height_over_width": float(shape.height_over_width),
        "converged": bool(info["converged"]), "residual": info["residual"],
        "equilibrium_distance_over_r": info.get("equilibrium_distance_over_r"),
        "rest_tol": info.get("rest_tol"),
        "stable": is_stable, "lowest_eigenvalue": lowest,
        "max_penetration_over_d": overlap(pts, model.contact_pairs(q), model.contact),
        "dofs": int(y.size), "iterations": int(info["iterations"]),
        "method": info["method"], "message": info["message"],
        "oscillations": info["oscillations"], "roundoff_limited": info["roundoff_limited"],
        "directions_as_paper": bool(shape.directions_as_paper),
        "loop_aspect": float(shape.loop_aspect),
        "energy": {k: float(v) for k, v in model.energy_parts(q).items()},
        "constants": bs.constants.table(bs.swatch.radius),
        "initial_overlap": bs.initial_overlap,
        "relax_s": info["relax_s"],
        "history": [float(h) for h in info["history"]],
    }


def write_curl(bs, y, summary, out, name=None):
    """Write the relaxed yarns (``<name>.vtu``), their control points
    (``<name>_control.npy``, to resume or polish) and the summary
    (``<name>.json``) to folder ``out``; name: default ``bspline_<nw>x<nc>``."""
    from pathlib import Path
    from ..io.atomic import atomic_path, write_json
    from ..io.vtk import curve_mesh, write_mesh
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    model = bs.model
    curves = model.centrelines(model.control_points(y), per_segment=4)
    mesh = curve_mesh([r for r, _, _ in curves],
                      point_data={"curvature": [k for _, _, k in curves],
                                  "yarn": [np.full(len(r), i) for i, (r, _, _) in
                                           enumerate(curves)]})
    name = name or f"bspline_{summary['nw']}x{summary['nc']}"
    write_mesh(out / f"{name}.vtu", mesh)
    with atomic_path(out / f"{name}_control.npy") as tmp:
        np.save(tmp, model.control_points(y))
    write_json(out / f"{name}.json", summary, indent=1)
