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
criterion); ``newton=True`` then tries to finish with Newton to ``newton_rtol``
(kept only if it gets there).  Every answer says whether it converged; a
run that runs out of time returns its last state with ``converged: false``.
Stability: the lowest eigenvalue of the reduced Hessian with the six rigid
motions lifted (:mod:`knitfem.bspline.stability`).  Curl: the shared output
analysis :func:`knitfem.analysis.curl.swatch_curl` on the deformed yarn points.
Units: mm, g, s; angles in degrees.
"""
import time

import numpy as np

from ..bspline import RelaxationError, relax_dynamic, relax_newton, stability
from ..bspline.contact import overlap
from ..bspline.fire import relax_fire
from ..bspline.relax import converged
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


def relax_swatch(bswatch, *, method="fire", rtol=1e-6, max_time=1800.0, max_steps=None,
                 newton=True, newton_rtol=1e-8, newton_steps=50, progress=False, monitor=None):
    """Relax a prestretched :class:`~.swatch_bspline.BSplineSwatch` from its
    knitted shape; returns (y, info dict: converged, residual, iterations,
    method, history, oscillations, message).  max_steps: a step limit besides
    the time limit (None: none; a step limit repeats bit for bit, a time limit
    depends on the machine's load).  monitor(step, y, residual, E, ke)."""
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    model = bswatch.model
    y = model.reduce(model._initial())
    start = time.perf_counter()
    info = {"method": method, "converged": False, "message": "", "oscillations": 0}
    steps = None if max_steps is None else int(max_steps)
    try:
        if method == "fire":
            result = relax_fire(model, y, rtol=rtol, max_steps=steps, max_time=max_time,
                                progress=progress, monitor=monitor)
        else:
            result = relax_dynamic(model, y, rtol=rtol, max_steps=steps, max_time=max_time,
                                   damping=bswatch.constants.damping_rate, kinetic=False,
                                   progress=progress, monitor=monitor)
            info["oscillations"] = result.oscillations
        y, info["iterations"], info["history"] = result.y, result.iterations, result.history
        info["converged"] = True
    except RelaxationError as err:
        y, info["history"], info["message"] = err.y, err.history, str(err)
        info["iterations"] = len(err.history) * 20
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
    info["converged"] = info["converged"] and converged(g, ref, rtol, model)
    # below the round-off floor: the relative residual cannot say more
    info["roundoff_limited"] = bool(np.linalg.norm(g) <= model.roundoff)
    return y, info


def bspline_curl(nw, nc, *, alpha=0.2, w=4.0, c=3.0, radius=0.4, segments_per_loop=16,
                 method="fire", rtol=1e-6, newton=True, max_time=1800.0, max_steps=None,
                 constants=None,
                 bindoff_stiffness=10.0, out=None, name=None, progress=True, trace=False):
    """Curl of an nw x nc plain-knit swatch in the B-spline model: issue 9's
    JSON keys (dict) plus "constants", "energy", "method", "message" and the
    relaxation history.  Fields the model cannot measure are None (here every
    key is measured).  max_time: seconds of relaxation before the last state
    is reported as not converged; max_steps: a step limit as well (None: none;
    reproducible where a time limit is not).  out: a folder for the relaxed centrelines
    (.vtu), control points (.npy) and the summary (JSON), file names
    ``name`` (default ``bspline_<nw>x<nc>``).  trace: also return the relaxation's
    :class:`Trace` rows and shapes under "trace"."""
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
    bs = bspline_swatch(nw, nc, w=w, c=c, radius=radius, segments_per_loop=segments_per_loop,
                        constants=constants, bindoff_stiffness=bindoff_stiffness)
    prestretch(bs, alpha)
    monitor = Trace(bs) if trace else None
    y, info = relax_swatch(bs, method=method, rtol=rtol, max_time=max_time,
                           max_steps=max_steps, newton=newton, progress=progress,
                           monitor=monitor)
    summary = summarise(bs, y, info)
    summary["elapsed_s"] = time.perf_counter() - t0
    if trace:
        summary["trace"] = {"rows": monitor.rows, "shapes": monitor.shapes}
    if out is not None:
        write_curl(bs, y, summary, out, name)
    return summary


def bspline_curl_from_options(args):
    """``knitfem curl --model bspline``: :func:`bspline_curl` from the validated
    options (``--max-time``, default 1800 s); writes into ``--out`` when given."""
    from .swatch_bspline import YarnConstants
    return bspline_curl(args.nw, args.nc, alpha=args.alpha, w=args.w, c=args.c,
                        radius=args.radius, bindoff_stiffness=args.bindoff_stiffness,
                        constants=YarnConstants(ea_over_ei=float(args.ea_over_ei)),
                        max_time=args.max_time, out=args.out, progress=not args.quiet)


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
    import json
    from pathlib import Path
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
    np.save(out / f"{name}_control.npy", model.control_points(y))
    (out / f"{name}.json").write_text(json.dumps(summary, indent=1))
