"""Fabric curl phase diagram over (N_w, N_c), with the centre height H and the
relaxed loop aspect w/c against N_w/N_c (paper Fig. 5d, Fig. 2a/2b analogues).

One curl relaxation per swatch size, each a point of the sweep engine
(:mod:`knitfem.sweep`, task :func:`knitfem.scenes.curl_sweep.curl_point`):
persisted as it finishes, ``--resume`` skips finished points, local process
pool (default, ``--workers N``) or a Dask cluster (``--scheduler``), a
progress bar over points.

    python studies/fabric_phase.py --out DIR                       # the issue's 8 x 7 grid
    python studies/fabric_phase.py --nw 5,10 --nc 5,10 --max-time 300 --out DIR
    python studies/fabric_phase.py --out DIR --resume              # after an interruption
    python studies/fabric_phase.py --out DIR --scheduler tcp://host:8786
    python studies/fabric_phase.py --model beam --nw 5 --nc 5 --out DIR
    python studies/fabric_phase.py --model beam --resume --adopt RUN/curl_10x35.json --out DIR
    python studies/fabric_phase.py --out DIR --report              # what DIR holds so far

Models: ``bspline`` (default; the paper's B-spline yarns, FIRE within
``--max-time`` seconds per point and optionally ``--max-steps``: a point out
of time is kept with converged = false and drawn hollow) or ``beam`` (the
beam scene; a relaxation that fails is a failed point with its message).

Writes DIR/phase.csv (one row per point), DIR/phase.json (rows, grid,
options, counts, wall time, points per hour), DIR/phase_diagram.png,
DIR/phase_trends.png (H and w/c vs N_w/N_c), DIR/run.json (complete: true
last) and the sweep's DIR/sweep.json + DIR/points/ (per point: its JSON
record, the relaxed yarns curl.vtu and the model's full summary curl.json).
Exit 0, 3 when a point failed, 2 on bad options, 130 / 143 when interrupted.

A running sweep redraws DIR/report/ after every point it finishes, and
``--report`` relaxes nothing: it draws the points a sweep folder holds so far
(a grid that takes days is run over several sessions) into DIR/report/ —
phase.csv, phase.json, phase_diagram.png, phase_trends.png, the points not run
yet as small grey dots — leaving the sweep's own files alone, so it may run
beside the sweep itself.  The model and scene are the sweep's (sweep.json):
``--model`` or curl options that name others are refused (exit 2).
"""
import argparse
import dataclasses
import os
import sys
import time

from knitfem.io import write_json
from knitfem.io.run import RunFolder
from knitfem.options import Check, Integer, OptionSet, Real, refuse
from knitfem.scenes import curl_command
from knitfem.scenes.curl_sweep import BEAM_OPTIONS, BSPLINE_OPTIONS, MODELS, adopt_run, \
    curl_point, phase_rows, phase_sweep, swatch_size, sweep_constants
from knitfem.scenes.phase_output import counts_text, plot_phase_diagram, plot_phase_trends, \
    point_state, state_counts, write_phase_csv
from knitfem.sweep import add_sweep_options, grid, parse_study, sweep_main

NW = (5, 10, 15, 20, 25, 30, 40, 55)
NC = (5, 10, 15, 20, 25, 30, 35)
SMALLEST = (3, 4)             # (nw, nc): the curl analysis needs 3 wales and 4 courses
LARGEST = 200
OVERHEAD_S = 30.0             # s per B-spline point besides relaxing (build, stability, files)

_BSPLINE = ("model", "bspline")


# the sweep's own words for the round budgets: on ``knitfem curl`` a resume
# may change them, here they are sweep constants (a resume with others is refused)
SWEEP_HELP = {
    "--max-rounds": "beam: friction rounds an increment of every point's relaxation may take "
                    "before it is halved (default 4; twice that at lam = 1)",
    "--snap-rounds": "beam: rounds beyond --max-rounds while each slides the swatch more than "
                     "a yarn radius (default 8)",
    "--settle": "beam: up to this many more passes of the final increment's rounds while a "
                "point's friction has not settled (default 0; a point's checkpoint goes once "
                "it is stored, so it cannot be settled later)",
}


def _curl_specs():
    """The ``knitfem curl`` options that make sense per point (one definition:
    its ranges, its yarn check, its model conditions — beam-only options
    refused with bspline, ``--max-time`` with beam)."""
    return [dataclasses.replace(spec, help=SWEEP_HELP[spec.flag])
            if getattr(spec, "flag", None) in SWEEP_HELP else spec
            for spec in curl_command.OPTIONS.specs
            if (isinstance(spec, Real) and spec.flag not in ("--nw", "--nc"))
            or (isinstance(spec, Check) and spec is not curl_command.RESUME)]


def _counts(flag, text, smallest):
    """A comma-separated list of distinct integers in [smallest, LARGEST]."""
    try:
        values = [int(v) for v in text.split(",")]
    except ValueError:
        values = None
    if not values or any(not smallest <= v <= LARGEST for v in values) \
            or len(set(values)) != len(values):
        refuse(flag, f"must be a comma-separated list of different integers in "
                     f"[{smallest}, {LARGEST}], e.g. 5,10,15", text)
    return values


def _grid(v):
    lo_w, lo_c = SMALLEST
    v.nw = _counts("--nw", v.nw, lo_w) if isinstance(v.nw, str) else v.nw
    v.nc = _counts("--nc", v.nc, lo_c) if isinstance(v.nc, str) else v.nc


OPTIONS = OptionSet(
    *_curl_specs(),
    Integer("--max-steps", None, "[1, 1e+09]", when=(*_BSPLINE, "the beam relaxation has "
            "no step limit"), help="FIRE steps per point (default: none; a step limit "
            "repeats bit for bit, a time limit depends on the load)"),
    Integer("--segments-per-loop", 16, "[8, 64]", when=(*_BSPLINE, "the beam model has "
            "elements, see --elements-per-loop"), help="B-spline segments per loop"),
    Check(_grid),
)


# the options a sweep relaxes with (its constants): --report draws the folder's,
# and refuses these when given by name and not the folder's
SCENE_FLAGS = frozenset([spec.flag for spec in OPTIONS.specs if getattr(spec, "flag", None)]
                        + ["--paths", "--bindoff-prestretch"])


def parse(argv):
    # no abbreviations: --report must see every option given by name (--alp is not --alpha)
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0], allow_abbrev=False)
    add_sweep_options(parser)
    parser.add_argument("--nw", default=",".join(map(str, NW)),
                        help=f"wale counts N_w (default {','.join(map(str, NW))})")
    parser.add_argument("--nc", default=",".join(map(str, NC)),
                        help=f"course counts N_c (default {','.join(map(str, NC))})")
    parser.add_argument("--model", choices=MODELS, default="bspline",
                        help="bspline: the paper's B-spline yarns (default); beam: the "
                             "Simo-Reissner beam scene")
    parser.add_argument("--paths", default=None, metavar="SCHEDULES",
                        help="beam: relax every point along these homotopy schedules "
                             "(default, coarse, fine, thirds; as knitfem curl --paths)")
    parser.add_argument("--bindoff-prestretch", action="store_true", default=None,
                        help="beam: the bind-off's rest length shrinks with the knit's")
    parser.add_argument("--adopt", nargs="+", default=None, metavar="RUN.json",
                        help="beam, with --resume: store these finished `knitfem curl` runs "
                             "(summary JSON, .vtu beside it) as their grid points first, "
                             "each checked to have the sweep's scene")
    parser.add_argument("--order", choices=("size", "grid"), default="size",
                        help="size: the points left start smallest swatch (N_w N_c) first, "
                             "so a grid of days shows most of its diagram early (default; on a "
                             "pool that runs the whole grid at once the largest points come "
                             "last, which may leave a worker idle at the end); grid: in the "
                             "grid's order (the results are the same either way)")
    parser.add_argument("--report", action="store_true",
                        help="relax nothing: draw the points the --out sweep folder holds so "
                             "far into DIR/report/ (may run beside the sweep)")
    args = parse_study("fabric_phase", parser, OPTIONS, argv)
    given = sys.argv[1:] if argv is None else argv
    # --report adds a grid asked for by name to the sweep's own (the defaults add nothing)
    named = [str(a).split("=")[0] for a in given if str(a).startswith("--")]
    args.grid_given = any(flag in ("--nw", "--nc") for flag in named)
    args.model_given = "--model" in named
    if args.report and (args.resume or args.adopt):
        parser.exit(2, "fabric_phase: error: --report reads the folder as it is; it takes no "
                       "--resume or --adopt\n")
    # curl options given by name (--report compares these, and only these, with the folder's)
    keys = [flag[2:].replace("-", "_") for flag in dict.fromkeys(named) if flag in SCENE_FLAGS]
    args.scene_named = {k: parser.get_default(k) for k in keys}
    if args.adopt and not (args.resume and args.model == "beam"):
        parser.exit(2, "fabric_phase: error: --adopt needs --model beam and --resume (without "
                       "--resume the folder's points are removed)\n")
    return args


def curl_options(args):
    """The per-point curl options of ``args`` for its model."""
    keys = BSPLINE_OPTIONS if args.model == "bspline" else BEAM_OPTIONS
    return {k: getattr(args, k) for k in keys if getattr(args, k, None) is not None}


def projection(args):
    """A line on how long the grid may take (B-spline: each point at most
    --max-time plus its overhead; beam: ``knitfem curl``'s estimate); with
    --resume, the points the folder holds done are left out."""
    from knitfem.sweep import SweepStore, point_key, task_name
    params = grid(nw=args.nw, nc=args.nc)
    done = 0
    if args.resume:
        # the sweep's own test first: a folder of another sweep is refused
        # here, before its records are counted as done
        store = SweepStore(args.out)
        store.check_same(task_name(curl_point), sweep_constants(args.model, curl_options(args)))
        finished = store.finished([point_key(p) for p in params], params)
        params = [p for p in params if point_key(p) not in finished]
        done = len(finished)
    points = [(p["nw"], p["nc"]) for p in params]
    head = f"{len(points) + done} points" + (f" ({done} done)" if done else "")
    if not points:
        return f"{head}: nothing left to relax"
    if args.model == "bspline":
        per_point = [args.max_time + OVERHEAD_S] * len(points)
    else:
        per_point = [curl_command.seconds(replace_counts(args, nw, nc)) for nw, nc in points]
    if args.scheduler:
        return f"{head}, about {sum(per_point) / 3600:.3g} worker-hours at most for the rest"
    workers = max(1, args.workers if args.workers is not None else (os.cpu_count() or 1))
    hours = max(sum(per_point) / workers, max(per_point)) / 3600
    rest = " for the rest" if done else ""
    return f"{head}, at most about {hours:.3g} h on {workers} worker(s){rest}"


def replace_counts(args, nw, nc):
    return argparse.Namespace(**{**vars(args), "nw": nw, "nc": nc})


def report(args, quiet=False):
    """Draw what the sweep folder ``args.out`` holds (module docstring); exit 0.
    The points: the sweep's grid (sweep.json), every point stored in the folder
    and, where --nw / --nc were given, that grid too."""
    import json
    from pathlib import Path
    from knitfem.sweep import SweepStore, point_key, task_name
    manifest_path = Path(args.out) / "sweep.json"
    try:                        # read before touching the folder: a mistyped --out stays absent
        manifest = json.loads(manifest_path.read_text())
    except (OSError, ValueError):
        manifest = None
    if manifest is None or manifest.get("task") != task_name(curl_point):
        raise ValueError(f"--report: {args.out} holds no curl sweep (no sweep.json of "
                         f"{task_name(curl_point)})")
    store = SweepStore(args.out)
    model = manifest["constants"]["model"]
    # the folder's model and scene are drawn: a --model or curl option given by
    # name that is not the folder's is refused, never silently ignored
    if getattr(args, "model_given", False) and args.model != model:
        raise ValueError(f"--report: {args.out} holds a {model} sweep, not --model "
                         f"{args.model} (leave --model out: the folder's model is drawn)")
    scene = manifest["constants"].get("curl", {})
    differ = _named_not_held(args, model, scene)
    if differ:
        raise ValueError(f"--report: {args.out} holds a sweep with other curl options "
                         f"({'; '.join(differ)}); leave them out: the folder's are drawn")
    stored = {}
    for path in sorted(store.points_dir.glob("[!.]*.json")):
        record = store.load(path.stem)
        if record is not None and record.get("key") == path.stem:
            stored[path.stem] = record
    points = [p["params"] for p in manifest.get("points", [])]
    points += [r["params"] for r in stored.values()]
    if getattr(args, "grid_given", True):
        points += grid(nw=args.nw, nc=args.nc)
    points = sorted({point_key(p): p for p in points}.values(), key=lambda p: (p["nw"], p["nc"]))

    class Held:                                 # the rows' source, as a SweepResult
        records = [stored.get(point_key(p)) for p in points]
    Held.points = points
    rows = phase_rows(Held, model)
    out = store.out / "report"
    write_phase_csv(rows, out / "phase.csv")
    counts = state_counts(rows)
    done = len(rows) - counts["not run"]
    title = f"{model} curl phase diagram so far ({done} of {len(rows)} points stored)"
    plot_phase_diagram(rows, out / "phase_diagram.png", title=title)
    plot_phase_trends(rows, out / "phase_trends.png",
                      knitted_aspect=scene.get("w", args.w) / scene.get("c", args.c))
    write_json(out / "phase.json", {
        "model": model, "points": points, "curl_options": scene, "rows": rows,
        "counts": counts, "sweep_complete": manifest.get("complete"),
        "report": True})
    if not quiet:
        print(f"{out}: {done} of {len(rows)} points stored: {counts_text(rows)}")
    return 0


def _named_not_held(args, model, held):
    """The curl options given by name whose value is not the folder's
    (``held``: its stored curl options, where a relaxation option at its
    default is left out, as a resume leaves it out, and an option it lacks
    was at its default), as "--flag: given X, folder Y"."""
    named = getattr(args, "scene_named", {})
    given = {k: getattr(args, k) for k in named if getattr(args, k, None) is not None}
    normal = sweep_constants(model, given)["curl"]
    differ = []
    for key, default in named.items():
        mine, theirs = normal.get(key), held.get(key)
        if theirs is None and mine is not None and mine == default:
            theirs = default                    # a folder from before the option: its default
        if mine != theirs:
            differ.append(f"--{key.replace('_', '-')}: given {getattr(args, key)!r}, "
                          f"folder {held.get(key, 'its default')!r}")
    return differ


def redraw(args):
    """The report of the points so far, from inside a run: the sweep's files,
    not the run's outputs (a run folder removes those on its next entry); a
    figure that fails is said on stderr and never stops the study."""
    from knitfem.io.atomic import unrecorded
    try:
        with unrecorded():
            report(args, quiet=True)
    except Exception as err:
        print(f"fabric_phase: report not redrawn: {type(err).__name__}: {err}", file=sys.stderr)


def run(args):
    if args.report:
        return report(args)
    options = curl_options(args)
    run = RunFolder(args.out, "studies/fabric_phase.py", vars(args),
                    outputs=("phase.csv", "phase.json", "phase_diagram.png",
                             "phase_trends.png"))
    if not args.quiet:
        print(projection(args), file=sys.stderr)
    with run:
        for summary in args.adopt or ():
            record = adopt_run(args.out, summary, nw_values=args.nw, nc_values=args.nc)
            print(f"adopted {summary} as {record['key']}", file=sys.stderr)
        if args.adopt:
            redraw(args)
        t = time.perf_counter()
        # the figures so far, redrawn into DIR/report/ as each point finishes
        rows, sweep = phase_sweep(args.nw, args.nc, args.out, model=args.model,
                                  options=options, resume=args.resume, workers=args.workers,
                                  scheduler=args.scheduler, progress=not args.quiet,
                                  on_point=lambda record: report(args, quiet=True),
                                  first=swatch_size if args.order == "size" else None)
        wall = time.perf_counter() - t
        ran = len(rows) - sweep.reused
        if not ran:             # no point finished here: the hook never redrew
            redraw(args)
        write_phase_csv(rows, run.path / "phase.csv")
        plot_phase_diagram(rows, run.path / "phase_diagram.png",
                           title=f"{args.model} curl phase diagram")
        plot_phase_trends(rows, run.path / "phase_trends.png", knitted_aspect=args.w / args.c)
        states = [point_state(r) for r in rows]
        write_json(run.path / "phase.json", {
            "model": args.model, "nw": args.nw, "nc": args.nc, "curl_options": options,
            "rows": rows, "counts": state_counts(rows),
            "wall_s": wall, "points_run": ran, "points_reused": sweep.reused,
            "points_per_hour": 3600.0 * ran / wall if ran and wall > 0 else None,
            "executor": sweep.executor})
    print(f"{len(rows)} points in {wall:.1f} s wall ({sweep.reused} reused, {sweep.executor}): "
          f"{states.count('converged')} converged, {states.count('not converged')} not "
          f"converged, {states.count('failed')} failed")
    for r in rows:
        state = point_state(r)
        what = r["error"] if state == "failed" else f"{r['curl']} ({state})"
        print(f"  {r['nw']:3d} x {r['nc']:3d}: {what}")
    return 3 if "failed" in states else 0


def main(argv=None):
    return sweep_main("fabric_phase", run, parse(argv))


if __name__ == "__main__":
    sys.exit(main())
