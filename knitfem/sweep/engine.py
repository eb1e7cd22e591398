"""The sweep loop: run a task over a grid of points, persist each point as it finishes.

A *task* is a picklable top-level function ``task(params: dict, out_dir:
pathlib.Path) -> dict``: ``params`` are the point's parameters merged over
the sweep's constants, ``out_dir`` an empty folder for any files of that
point (.vtu, .csv, ...), and the returned dict must be JSON-able (NaN and
infinities are stored as null).  A task that raises marks its point
"failed" (the message is kept, the other points go on; ``--resume`` runs
failed points again).

The task runs in a fresh temporary folder on whichever machine executes it,
with one BLAS and one numba thread; its files come back with its result and
are written, with the point's JSON record last, by this process (so a Dask
cluster needs no shared file system).

A task that takes a ``work_dir`` keyword gets, on a local pool or in this
process, a folder that outlives a killed sweep: ``OUT/work/<key>/``, for its
own checkpoints, so ``--resume`` continues a point where it was killed
instead of starting it again (a 25 x 35 beam relaxation takes longer than
many a session lasts).  It is removed once the point is done (a failed
point keeps it: run again, it continues from its last checkpoint), and with
the sweep's points when a sweep starts without ``--resume``.  On a Dask
cluster (no shared file system) ``work_dir`` is None.
"""
from dataclasses import dataclass, field
import os
from pathlib import Path
import inspect
import shutil
import socket
import sys
import tempfile
import time

from ..io.atomic import unrecorded
from .executors import executor as make_executor
from .store import SweepStore, point_key


def task_name(task):
    """``module:qualname`` of a task (how a sweep folder remembers it)."""
    return f"{task.__module__}:{task.__qualname__}"


def _collect(folder):
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def takes_work_dir(task):
    """Whether ``task`` accepts the ``work_dir`` keyword (module docstring)."""
    try:
        return "work_dir" in inspect.signature(task).parameters
    except (TypeError, ValueError):
        return False


def execute(task, params, work_dir=None):
    """Run ``task`` on one point (in a worker); returns (outcome, files).
    ``work_dir``: the point's lasting folder (module docstring), passed on
    to a task that takes it."""
    from threadpoolctl import threadpool_limits
    from ..io.atomic import finite_or_none
    import json
    import numba
    from ..io.run import source
    # the commit this worker runs, taken before its first point: cached, a
    # first call when a result is written (hours later) would name whatever
    # the checkout holds then
    source()
    threads = numba.get_num_threads()
    numba.set_num_threads(1)                   # per thread: also right in a Dask worker
    with tempfile.TemporaryDirectory(prefix="knitfem-point-") as tmp, \
            threadpool_limits(limits=1):
        t0 = time.perf_counter()
        try:
            extra = {"work_dir": Path(work_dir)} if work_dir is not None else {}
            result = task(dict(params), Path(tmp), **extra)
            if not isinstance(result, dict):
                raise TypeError(f"the task returned {type(result).__name__}, not a dict")
            result = finite_or_none(result)
            json.dumps(result, allow_nan=False)
            outcome = {"status": "done", "result": result, "error": None}
        except Exception as err:                       # the point fails, the sweep goes on
            from ..interrupt import interruption
            if interruption(err) is not None:          # a signal seen inside numba code
                raise
            outcome = {"status": "failed", "result": None,
                       "error": f"{type(err).__name__}: {err}"}
        outcome["elapsed_s"] = time.perf_counter() - t0
        outcome["worker"] = f"{socket.gethostname()}:{os.getpid()}"
        files = _collect(Path(tmp))
    numba.set_num_threads(threads)
    return outcome, files


@dataclass
class SweepResult:
    """Records in grid order (None for a point not finished), and the run's facts."""
    out: Path
    points: list
    records: list
    reused: int = 0
    wall_s: float = 0.0
    executor: str = ""
    failed: list = field(default_factory=list)

    @property
    def complete(self):
        return all(r is not None and r["status"] == "done" for r in self.records)

    def results(self):
        """The tasks' result dicts in grid order (None where not done)."""
        return [r["result"] if r is not None and r["status"] == "done" else None
                for r in self.records]


def grid(**axes):
    """The Cartesian product of the axes as a list of points (dicts), the last
    axis varying fastest: ``grid(nw=[5, 10], nc=[5])`` ->
    ``[{"nw": 5, "nc": 5}, {"nw": 10, "nc": 5}]``... in the order given."""
    points = [{}]
    for name, values in axes.items():
        points = [dict(p, **{name: _plain(v)}) for p in points for v in values]
    return points


def _plain(v):
    return v.item() if hasattr(v, "item") else v


def run_sweep(task, points, out, *, constants=None, resume=False, workers=None,
              scheduler=None, progress=True, desc="points", option="--out", on_point=None,
              first=None):
    """Run ``task`` over ``points`` (list of dicts), persisting each point in
    ``out`` as it finishes; returns a :class:`SweepResult`.

    constants : parameters shared by every point (merged under each point);
    resume : keep the points of a previous run of the same task and constants
        that finished ("done"); without it a previous sweep in ``out`` is
        removed first;
    workers : processes of the local pool (default: cores; 0: this process);
    scheduler : address of a Dask scheduler (``tcp://host:port``) instead;
    progress : a tqdm bar over points (on stderr);
    on_point : called with each point's stored record as it finishes (in this
        process, after the record is on disk): e.g. to redraw figures of the
        points so far.  What it raises is reported on stderr, not fatal.
    first : key(point) -> sortable: the points left are started in its order
        (ties in the given order), e.g. the smallest first so that a sweep of
        days shows most of its points early; the records, the manifest and
        the results keep the order of ``points``.

    An interruption (:mod:`knitfem.interrupt`) or any error stops the workers
    and leaves ``sweep.json`` with ``complete: false``; finished points stay.
    The files are the sweep's own (:class:`SweepStore`): an enclosing
    :class:`knitfem.io.run.RunFolder` does not list them.
    """
    with unrecorded():
        return _run(task, points, out, constants, resume, workers, scheduler, progress, desc,
                    option, on_point, first)


def _run(task, points, out, constants, resume, workers, scheduler, progress, desc, option,
         on_point=None, first=None):
    constants = dict(constants or {})
    points = [{k: _plain(v) for k, v in p.items()} for p in points]
    keys = [point_key(p) for p in points]
    if len(set(keys)) != len(keys):
        raise ValueError("the sweep's points are not all different")
    store = SweepStore(out, option)
    done = store.open(task_name(task), constants, points, keys, resume)
    records = {k: done[k] for k in keys if k in done}
    todo = [(k, p) for k, p in zip(keys, points) if k not in done]
    if first is not None:
        todo.sort(key=lambda item: first(item[1]))         # stable: ties keep their order
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(points), initial=len(records), desc=desc, unit="point")
    t0 = time.perf_counter()
    runner = make_executor(workers, scheduler)
    status = {"complete": False}
    try:
        with runner:
            # a lasting folder per point where the task runs on this file system
            work = store.work_dir if scheduler is None and takes_work_dir(task) else None
            jobs = [(k, execute, (task, {**constants, **p},
                                  None if work is None else str(work / k))) for k, p in todo]
            params = dict(todo)
            for key, (outcome, files) in runner.run(jobs):
                record = store.save({"key": key, "params": params[key], **outcome}, files)
                if work is not None and outcome["status"] == "done":
                    shutil.rmtree(work / key, ignore_errors=True)
                records[key] = record
                if bar is not None:
                    bar.update()
                    if outcome["status"] != "done":
                        bar.write(f"point {key} failed: {outcome['error']}")
                if on_point is not None:
                    try:
                        on_point(record)
                    except Exception as err:        # a figure must not stop a sweep
                        note = f"sweep: after point {key}: {type(err).__name__}: {err}"
                        if bar is not None:
                            bar.write(note, file=sys.stderr)
                        else:
                            print(note, file=sys.stderr)
        status = {"complete": all(records.get(k, {}).get("status") == "done" for k in keys)}
        if work is not None and work.is_dir() and not any(work.iterdir()):
            work.rmdir()
    except BaseException as err:
        from ..io.run import describe
        status = {"complete": False, "interrupted": describe(err)}
        raise
    finally:
        if bar is not None:
            bar.close()
        wall = time.perf_counter() - t0
        store.finish(**status, finished=len(records), reused=len(done), wall_s=wall,
                     executor=runner.name)
    ordered = [records.get(k) for k in keys]
    return SweepResult(Path(out), points, ordered, len(done), wall, runner.name,
                       [r for r in ordered if r is not None and r["status"] != "done"])
