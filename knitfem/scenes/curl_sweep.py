"""Fabric curl over a grid of swatch sizes (N_w, N_c): the sweep task and its rows.

Each point of the sweep (:mod:`knitfem.sweep`) is one curl relaxation,
:func:`curl_point`, with either model:

* ``"bspline"``: the paper's B-spline yarn model
  (:func:`knitfem.scenes.curl_bspline.bspline_curl`), FIRE within a time
  limit ``max_time`` (s) and optionally a step limit ``max_steps`` (a step
  limit repeats bit for bit, a time limit depends on the machine's load); a
  point that runs out of either is *done* with ``converged: false`` and
  the shape of its last state, which the rows and figures mark as such;
* ``"beam"``: the Simo-Reissner beam scene (:func:`knitfem.scenes.curl.curl`
  of a :class:`~knitfem.scenes.fabric.FabricScene`); a relaxation that fails
  (``FabricRelaxationError``, or an error in the summary) makes the point
  *failed* with the message: its last state is never reported as a curl.
  With the option ``paths`` (e.g. ``"default,coarse"``) each point is relaxed
  along those homotopy schedules (:mod:`knitfem.scenes.curl_paths`): the
  point's curl is the chosen path's, ``curl_types`` the set found.

:func:`phase_rows` flattens the sweep's records into one row per point
(:data:`COLUMNS`), failed and unfinished points included with their
message and no shape.  Units: mm, degrees, seconds.
"""
import contextlib
from pathlib import Path
import shutil
import tempfile

MODELS = ("bspline", "beam")
ROLLS = ("left", "right", "top", "bottom")
COLUMNS = ("nw", "nc", "nw_over_nc", "model", "status", "curl",
           *(f"roll_{k}" for k in ROLLS), "curvature_x", "curvature_y",
           *(f"local_roll_{k}" for k in ROLLS), "height",
           "height_over_width", "loop_aspect", "edges_touch", "converged", "stable",
           "friction_settled", "residual", "curl_types", "elapsed_s", "message", "error")
# curl options of each model (the keys :func:`curl_point` passes on)
BSPLINE_OPTIONS = ("alpha", "w", "c", "radius", "segments_per_loop", "bindoff_stiffness",
                   "ea_over_ei", "max_time", "max_steps", "method", "rtol", "rest_tol")
BEAM_OPTIONS = ("alpha", "w", "c", "radius", "elements_per_loop", "bindoff_stiffness",
                "ea_over_ei", "gj_over_ei", "friction", "inflation", "bindoff_prestretch",
                "tail_ties", "straighten", "paths", "reanchor", "max_rounds", "snap_rounds",
                "settle", "exact_tries")
# what a point keeps of the model's summary (the rest is in its JSON file)
KEPT = ("curl", "roll_deg", "curvature_x", "curvature_y", "local_roll_deg", "height",
        "height_over_width", "loop_aspect", "edges_touch", "converged", "residual", "stable", "dofs",
        "iterations", "max_penetration_over_d", "directions_as_paper", "friction_settled",
        "curl_types", "path_dependent", "chosen_path", "settle_passes")


class CurlFailed(RuntimeError):
    """A relaxation that produced no equilibrium to classify (message only:
    picklable, so it crosses process and cluster boundaries)."""


def _options(options, allowed, model):
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise ValueError(f"curl options {unknown} do not apply to model {model!r} "
                         f"(valid: {', '.join(allowed)})")
    return {k: v for k, v in options.items() if v is not None}


def _bspline(nw, nc, options, out_dir):
    from .curl_bspline import bspline_curl
    from .swatch_bspline import YarnConstants
    options = _options(options, BSPLINE_OPTIONS, "bspline")
    ea = options.pop("ea_over_ei", None)
    constants = YarnConstants() if ea is None else YarnConstants(ea_over_ei=float(ea))
    # a point is one timed run (--max-time): nothing to go on from
    return bspline_curl(nw, nc, constants=constants, out=out_dir, progress=False,
                        name="curl", checkpoint=False, **options)


def _beam(nw, nc, options, out_dir, work_dir=None):
    from .curl import curl
    from .fabric import FabricScene
    from .fabric_relax import FabricRelaxationError
    options = _options(options, BEAM_OPTIONS, "beam")
    paths = options.pop("paths", None)
    # the relaxation's options (a point's checkpoint goes once it is stored,
    # so its settle passes, --settle, run now or never)
    relax = _pop_protocol(options) or None
    scene = FabricScene(nw, nc, **options)
    # in the sweep's lasting folder the relaxation checkpoints, and a killed
    # point resumes from there (engine docstring); else in a temporary one
    with contextlib.ExitStack() as stack:
        if work_dir is None:
            tmp = stack.enter_context(tempfile.TemporaryDirectory(prefix="knitfem-beam-"))
        else:
            tmp = Path(work_dir)
            tmp.mkdir(parents=True, exist_ok=True)
        try:
            if paths is None:
                summary = curl(scene, out=tmp, render=False, progress=False, resume=True,
                               relax_options=relax)
            else:
                from .curl_paths import curl_paths, parse_paths
                names = parse_paths(paths)
                if names is None:
                    raise ValueError(f"curl option paths: unknown or repeated schedule in "
                                     f"{paths!r}")
                summary = curl_paths(scene, names, out=tmp, render=False, progress=False,
                                     resume=True, relax_options=relax)
        except FabricRelaxationError as err:
            raise CurlFailed(f"FabricRelaxationError: {err}") from None
        if summary.get("error") is not None:       # the last state of a failed relaxation
            raise CurlFailed(f"FabricRelaxationError: {summary['error']}")
        name = f"curl_{nw}x{nc}"
        shape = Path(tmp) if paths is None else \
            Path(tmp) / f"path_{summary['chosen_path'] or names[0]}"
        # the equilibrium, not the path's frames (and the combined summary)
        shutil.copy(shape / f"{name}.vtu", Path(out_dir) / "curl.vtu")
        shutil.copy(Path(tmp) / f"{name}.json", Path(out_dir) / "curl.json")
    summary["message"] = ""
    return summary


def curl_point(params, out_dir, work_dir=None):
    """Sweep task: relax the ``params["nw"]`` x ``params["nc"]`` swatch with
    ``params["model"]`` ("bspline" or "beam") and the curl options
    ``params["curl"]`` (dict, keys :data:`BSPLINE_OPTIONS` / :data:`BEAM_OPTIONS`);
    writes ``curl.vtu`` (the relaxed yarns), ``curl.json`` (the model's full
    summary) and, B-spline, ``curl_control.npy`` (its control points) into
    ``out_dir``; a beam relaxation checkpoints into ``work_dir`` when given (a
    folder that outlives a killed sweep: it resumes from there).  Returns the curl, the signed edge rolls (deg), curvatures (1/mm), centre height H (mm) and H/W, relaxed loop aspect w/c,
    converged / residual / stable and the relaxation's message.  Raises
    :class:`CurlFailed` when the beam relaxation fails (the sweep records the
    point as failed)."""
    model = params.get("model", "bspline")
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")
    nw, nc = params["nw"], params["nc"]
    options = dict(params.get("curl", {}))
    summary = (_bspline(nw, nc, options, out_dir) if model == "bspline" else
               _beam(nw, nc, options, out_dir, work_dir))
    return point_result(nw, nc, model, summary)


def point_result(nw, nc, model, summary):
    """What a point keeps of a model's summary (:data:`KEPT`, message, relax_s)."""
    result = {"nw": nw, "nc": nc, "model": model, **{k: summary.get(k) for k in KEPT}}
    result["message"] = summary.get("message", "")
    result["relax_s"] = summary.get("relax_s", summary.get("elapsed_s"))
    return result


def adopt_run(out, summary_path, nw_values=None, nc_values=None, replace=False):
    """Store a finished ``knitfem curl`` beam run (its summary JSON, the .vtu
    beside it) as the point (nw, nc) of the beam phase sweep in ``out``, so
    that ``--resume`` reuses it instead of relaxing the swatch again.

    Refused (ValueError naming what differs) unless ``out`` holds a sweep of
    :func:`curl_point` (its ``sweep.json``) that is not running, the run
    relaxed to a classified equilibrium with the sweep's relaxation options
    (its ``protocol``, usually none, equal to the sweep's), its scene equals the
    sweep's field by field (:meth:`FabricScene.stored`: a field the run
    predates as it behaved then), (nw, nc) is on the grid when ``nw_values``
    / ``nc_values`` are given, and the point is not done already (unless
    ``replace``).  Returns the stored record; its ``worker`` names the file."""
    import json
    from ..io.atomic import finite_or_none, unrecorded
    from ..sweep.store import SweepStore, point_key
    from .fabric import FabricScene
    path = Path(summary_path)
    store = SweepStore(out)
    manifest = _sweep_manifest(store, out)
    summary = json.loads(path.read_text())
    vtu = path.with_suffix(".vtu")
    constants = manifest["constants"]
    if constants.get("model") != "beam" or summary.get("model", "beam") != "beam":
        raise ValueError(f"adopt {path}: only beam runs into a beam sweep (sweep model "
                         f"{constants.get('model')!r}, run model {summary.get('model')!r})")
    if summary.get("error") is not None or summary.get("curl") is None or not vtu.is_file():
        raise ValueError(f"adopt {path}: not a relaxed swatch with its .vtu "
                         f"(error {summary.get('error')!r}, curl {summary.get('curl')!r})")
    options = dict(constants.get("curl", {}))
    wanted = _pop_protocol(options)
    ran = dict(summary.get("protocol") or {})
    if "budget_changes" not in ran:
        ran = _normal_protocol(ran)
    if summary.get("friction_settled") is True and not summary.get("settle_passes"):
        # settle passes run only while the friction has not settled: none ran,
        # so the run is the same whatever --settle was
        wanted.pop("settle", None)
        ran.pop("settle", None)
    if ran != wanted:
        raise ValueError(f"adopt {path}: relaxed with the protocol options "
                         f"{summary.get('protocol') or {}}, the sweep's points with {wanted} "
                         "(--reanchor, --exact-tries, --max-rounds, --snap-rounds, --settle; a "
                         "budget changed on a resume counts too)")
    if options.pop("paths", None) is not None:
        raise ValueError(f"adopt {path}: the sweep relaxes each point along several paths; "
                         "a single run is not such a point")
    nw, nc = summary["nw"], summary["nc"]
    if (nw_values is not None and nw not in nw_values) or \
            (nc_values is not None and nc not in nc_values):
        raise ValueError(f"adopt {path}: {nw} x {nc} is not on the grid (nw {nw_values}, "
                         f"nc {nc_values})")
    try:
        ran = FabricScene.stored(summary.get("scene") or {}).as_dict()
    except ValueError as err:
        raise ValueError(f"adopt {path}: {err}") from None
    expected = FabricScene(nw, nc, **options).as_dict()
    differ = [f"{k}: run {ran[k]!r}, sweep {v!r}" for k, v in expected.items()
              if not _same_value(ran[k], v)]
    if differ:
        raise ValueError(f"adopt {path}: the run's scene is not the sweep's ({'; '.join(differ)})")
    params = {"nw": nw, "nc": nc}
    key = point_key(params)
    old = store.load(key)
    if old and old.get("status") == "done" and not replace:
        raise ValueError(f"adopt {path}: {key} is done already in {out} ({old.get('worker')}); "
                         "pass replace=True to overwrite it")
    record = {"key": key, "params": params, "status": "done",
              "result": finite_or_none(point_result(nw, nc, "beam", dict(summary, message=""))),
              "error": None, "elapsed_s": summary.get("relax_s", summary.get("elapsed_s")),
              "worker": f"adopted from {path}"}
    # the sweep's store, not the enclosing run's outputs: a run folder removes
    # its last run's outputs on entry, which took adopted records with it
    with unrecorded():
        return store.save(record, {"curl.json": path.read_bytes(), "curl.vtu": vtu.read_bytes()})


def _sweep_manifest(store, out):
    """The manifest of the phase sweep in ``out``; ValueError when there is
    none or a sweep is running there (its process alive on this machine)."""
    import os
    import socket
    from ..sweep.engine import task_name
    manifest = store.manifest()
    if manifest is None or manifest.get("task") != task_name(curl_point):
        raise ValueError(f"adopt: {out} holds no phase sweep (no sweep.json of "
                         f"{task_name(curl_point)}); start the sweep there first")
    pid = manifest.get("pid")
    if manifest.get("complete") is False and pid not in (None, os.getpid()) \
            and manifest.get("host") == socket.gethostname():
        try:
            os.kill(pid, 0)
        except OSError:
            return manifest                        # a sweep killed before it finished
        raise ValueError(f"adopt: a sweep (process {pid}) is running in {out}: it would "
                         "relax the point again and overwrite it; stop it first")
    return manifest


def _same_value(a, b):
    """Equal scene values: numbers by value (4 == 4.0), booleans only to booleans."""
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    return a == b


def _row(params, record):
    """One CSV row (dict over COLUMNS) from a sweep record (None: not run)."""
    nw, nc = params["nw"], params["nc"]
    row = dict.fromkeys(COLUMNS)
    row.update(nw=nw, nc=nc, nw_over_nc=nw / nc, converged=False)
    if record is None:
        row.update(status="not run", error="not run (sweep interrupted?)")
        return row
    row.update(status=record["status"], elapsed_s=record.get("elapsed_s"))
    if record["status"] != "done":
        row["error"] = record.get("error") or "failed"
        return row
    r = record["result"]
    row.update({k: r.get(k) for k in COLUMNS if k in r and k != "roll_deg"})
    if r.get("curl_types") is not None:        # several paths: the set, one cell
        row["curl_types"] = "|".join(r["curl_types"])
    for k in ROLLS:
        row[f"roll_{k}"] = (r.get("roll_deg") or {}).get(k)
        # points relaxed before 2026-12-04 have no roll profile: empty cells
        row[f"local_roll_{k}"] = (r.get("local_roll_deg") or {}).get(k)
    row["converged"] = bool(r.get("converged"))
    return row


def phase_rows(sweep, model):
    """Rows (dicts over :data:`COLUMNS`) of a :class:`knitfem.sweep.SweepResult`
    in grid order; ``model`` fills the column of points that did not finish."""
    rows = []
    for params, record in zip(sweep.points, sweep.records):
        row = _row(params, record)
        row["model"] = row["model"] or model
        rows.append(row)
    return rows


def _pop_protocol(options):
    """Take the relaxation options (:data:`~.curl_command.PROTOCOL`) out of
    ``options`` (a dict, changed) and return them as the relaxation sees them:
    those at their defaults left out ({} when none is left)."""
    from .curl_command import PROTOCOL, relax_protocol
    return relax_protocol(**{k: options.pop(k) for k in PROTOCOL if k in options}) or {}


def _normal_protocol(options):
    """``options`` with its relaxation options at their defaults left out
    (:func:`_pop_protocol`): ``--max-rounds 4`` given or not is the same sweep
    (its constants compared on resume)."""
    protocol = _pop_protocol(options)
    return {**options, **protocol}


# scene options added after sweeps were stored, at the value those sweeps ran
# with: left out of the constants, so the stored sweeps resume as they are
ADDED_SCENE_OPTIONS = {"straighten": 1.0}


def sweep_constants(model, options):
    """The constants a phase sweep of ``model`` with the curl ``options``
    stores (and compares on a resume); an option of
    :data:`ADDED_SCENE_OPTIONS` at its old value is left out."""
    options = {k: v for k, v in (options or {}).items()
               if not (k in ADDED_SCENE_OPTIONS and v == ADDED_SCENE_OPTIONS[k])}
    return {"model": model, "curl": _normal_protocol(options)}


def swatch_size(point):
    """Loops in a point's swatch, N_w N_c: what a relaxation's cost grows with."""
    return point["nw"] * point["nc"]


def phase_sweep(nw_values, nc_values, out, *, model="bspline", options=None, resume=False,
                workers=None, scheduler=None, progress=True, on_point=None, first=swatch_size):
    """Run :func:`curl_point` over every (nw, nc) through
    :func:`knitfem.sweep.run_sweep` (persisted in ``out``, resumable, local
    pool or Dask cluster); returns (rows, the SweepResult).  ``options``: the
    model's curl options (the sweep's constants); ``on_point(record)`` and
    ``first`` (default: the smallest swatches first; None: the grid's order)
    as :func:`knitfem.sweep.run_sweep`'s."""
    from ..sweep import grid, run_sweep
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")
    constants = sweep_constants(model, options)
    result = run_sweep(curl_point, grid(nw=list(nw_values), nc=list(nc_values)), out,
                       constants=constants, resume=resume, workers=workers,
                       scheduler=scheduler, progress=progress, desc=f"{model} curls",
                       on_point=on_point, first=first)
    return phase_rows(result, model), result
