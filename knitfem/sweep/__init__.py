"""Resumable parameter sweeps on a local process pool or a Dask cluster.

A sweep runs one *task* over a grid of points.  The task is a picklable
top-level function::

    def task(params: dict, out_dir: pathlib.Path) -> dict: ...

``params`` holds the point's parameters over the sweep's constants, the
task may write files into ``out_dir`` (an empty folder), and it returns a
JSON-able dict.  Every finished point is persisted at once
(``OUT/points/<key>.json`` plus ``OUT/points/<key>/`` with its files,
:mod:`knitfem.sweep.store`), so a killed sweep loses only the points that
were running, and ``resume=True`` (``--resume``) skips the finished ones.

Executors (:mod:`knitfem.sweep.executors`): a local pool of spawned
processes with one BLAS / numba thread each (default, ``--workers N``;
``--workers 0`` runs in this process) or an existing Dask distributed
cluster (``--scheduler tcp://host:port``; the ``dask`` extra), the same task
function for both.

Plugging in a new study (e.g. the fabric phase diagram over (N_w, N_c))::

    # knitfem/scenes/<study>.py: the task, importable by the workers
    def curl_point(params, out_dir):
        result = curl(params["nw"], params["nc"], **params["curl"])   # one relaxation
        write_mesh(out_dir / "curl.vtu", ...)                           # optional files
        return {"curl": result.kind, "height": result.height, ...}

    # studies/<study>.py: parse options, then
    parser = argparse.ArgumentParser(...)
    add_sweep_options(parser)                   # --out --workers --scheduler --resume --quiet
    args = parse_study("study", parser, OPTIONS)   # + SWEEP_OPTIONS: one line, exit 2
    result = run_sweep(curl_point, grid(nw=[5, 10], nc=[5, 10]), args.out,
                       constants={"curl": {...}}, resume=args.resume,
                       workers=args.workers, scheduler=args.scheduler,
                       progress=not args.quiet)
    rows = [dict(r["params"], **r["result"]) for r in result.records if r and r["status"] == "done"]

and end ``main`` with ``return sweep_main("study", run, args)``
(:func:`sweep_main`: SIGINT / SIGTERM stop the workers and exit 130 / 143, a
bad ``--resume`` is one line and exit 2; see ``studies/fabric_phase.py``).
"""
import re

from ..options import Check, Integer, OptionError, OptionSet, refuse
from .engine import SweepResult, execute, grid, run_sweep, task_name
from .executors import DaskCluster, InProcess, LocalPool, executor
from .store import SweepStore, point_key

_ADDRESS = re.compile(r"^([a-z]+://)?[^\s/:]+:\d{1,5}$")


def _check_scheduler(values):
    address = getattr(values, "scheduler", None)
    if address is None:
        return
    if not _ADDRESS.match(address):
        refuse("--scheduler", "must be a Dask scheduler address such as tcp://10.0.0.1:8786",
               address)
    if "workers" in values.given:
        refuse("--workers", "applies to the local pool; the Dask cluster has its own workers "
               "(leave out --workers with --scheduler)", values.workers)


SWEEP_OPTIONS = OptionSet(
    Integer("--workers", None, "[0, 1024]",
            help="local worker processes, one BLAS/numba thread each (default: the number "
                 "of cores; 0: run in this process)"),
    Check(_check_scheduler),
)


def parse_study(name, parser, options, argv=None):
    """Add ``options`` (an OptionSet) to ``parser`` (which has
    :func:`add_sweep_options`), parse ``argv`` and validate them and
    ``SWEEP_OPTIONS``; a bad value: one line ``<name>: error: ...``, exit 2."""
    options.add_to(parser)
    args = parser.parse_args(argv)
    try:
        options.validate(args)
        SWEEP_OPTIONS.validate(args)
    except OptionError as err:
        parser.exit(2, f"{name}: error: {err}\n")
    return args


def sweep_main(name, run, args, what="points"):
    """The body of a sweep study's ``main``: ``run(args)`` (-> exit code) with
    SIGINT / SIGTERM as an orderly stop.  A ValueError (e.g. ``--resume`` on
    another sweep) is one line ``<name>: error: ...``, exit 2; an interruption
    one line saying where the finished ``what`` are, exit 130 / 143."""
    import sys
    from ..interrupt import interruptible, interruption
    with interruptible():
        try:
            return run(args)
        except ValueError as err:
            print(f"{name}: error: {err}", file=sys.stderr)
            return 2
        except BaseException as err:
            stop = interruption(err)
            if stop is None:
                raise
            print(f"{name}: interrupted by {stop.signal_name}; finished {what} are in "
                  f"{args.out}/points (run again with --resume)", file=sys.stderr)
            return stop.exit_code


def add_sweep_options(parser, out_default=None):
    """Add ``--out``, ``--workers``, ``--scheduler``, ``--resume`` and
    ``--quiet`` to an argparse parser (validate with ``SWEEP_OPTIONS``)."""
    parser.add_argument("--out", default=out_default, required=out_default is None,
                        help="output folder (points/ holds one record per finished point)")
    SWEEP_OPTIONS.add_to(parser)
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="run on an existing Dask cluster, e.g. tcp://10.0.0.1:8786 "
                             "(instead of the local pool)")
    parser.add_argument("--resume", action="store_true",
                        help="keep the finished points of a previous run in --out")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    return parser


__all__ = ["DaskCluster", "InProcess", "LocalPool", "SWEEP_OPTIONS", "SweepResult",
           "SweepStore", "add_sweep_options", "execute", "executor", "grid", "parse_study",
           "point_key",
           "run_sweep", "sweep_main", "task_name"]
