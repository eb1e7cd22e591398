"""A sweep's folder: one JSON record per finished point, written as it finishes.

Layout of ``out``::

    sweep.json                 the manifest: task, constants, points, complete
    points/<key>.json          one record per point (written last, atomically)
    points/<key>/...           the files the task wrote for that point

A record ``{"key", "params", "status": "done" | "failed", "result",
"error", "elapsed_s", "worker"}`` exists only once the point has finished
and its files are in place, so a folder killed at any moment holds whole
records of the finished points and nothing else that counts; ``--resume``
keeps the records whose status is "done" and whose parameters match.
The key of a point is readable (``w_over_L=0.05``; ``nw=10_nc=5``) and
stable: it depends on the point's parameters only, not on its position in
the grid.
"""
import hashlib
import json
import os
from pathlib import Path
import re
import shutil
import socket

from ..io.atomic import OutputError, check_folder_writable, write_bytes, write_json

MANIFEST = "sweep.json"
POINTS = "points"
WORK = "work"


def _text(value):
    return repr(value) if isinstance(value, float) else str(value)


def point_key(point):
    """Folder-safe, readable key of a point (dict of scalars)."""
    readable = "_".join(f"{k}={_text(v)}" for k, v in point.items())
    safe = re.sub(r"[^A-Za-z0-9._=+-]", "-", readable)
    if safe != readable or len(safe) > 96:          # keep keys of different points apart
        digest = hashlib.sha1(json.dumps(point, sort_keys=True).encode()).hexdigest()[:10]
        safe = f"{safe[:80]}-{digest}"
    return safe


def _same(a, b):
    """Equal as stored JSON (tuples and lists alike)."""
    return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


class SweepStore:
    """The on-disk state of one sweep (see the module docstring)."""

    def __init__(self, out, option="--out"):
        self.out = Path(out)
        self.option = option
        self.points_dir = self.out / POINTS
        self.work_dir = self.out / WORK        # tasks' lasting folders (engine docstring)
        check_folder_writable(self.out, option)

    def manifest(self):
        path = self.out / MANIFEST
        if not path.is_file():
            return None
        try:
            return json.loads(path.read_text())
        except ValueError:
            return None

    def open(self, task, constants, points, keys, resume):
        """Start (or with ``resume`` continue) the sweep; returns the records
        of points already done (key -> record).  Without ``resume`` the
        points of a previous sweep in this folder are removed first."""
        old = self.manifest()
        for folder in (self.points_dir, self.work_dir):
            if folder.exists() and old is None:
                raise OutputError(f"{self.option} {self.out}: {folder} exists but no "
                                  f"{MANIFEST}: not a knitfem sweep folder, refusing to "
                                  "overwrite it")
        done = {}
        if resume and old is not None:
            self.check_same(task, constants, old)
            done = self.finished(keys, points)
        elif self.points_dir.exists():
            shutil.rmtree(self.points_dir)
        # a fresh sweep starts every point afresh; a resumed one needs no
        # folders of points already done (killed before their removal)
        if not resume:
            shutil.rmtree(self.work_dir, ignore_errors=True)
        for key in done:
            shutil.rmtree(self.work_dir / key, ignore_errors=True)
        self.points_dir.mkdir(parents=True, exist_ok=True)
        # who writes here: adopting a run into a folder a live sweep writes is refused
        self.header = {"task": task, "constants": constants, "axes": list(points[0]) if points
                       else [], "points": [{"key": k, "params": p} for k, p in zip(keys, points)],
                       "pid": os.getpid(), "host": socket.gethostname()}
        write_json(self.out / MANIFEST, {**self.header, "complete": False})
        return done

    def check_same(self, task, constants, old=None):
        """Refuse (:class:`OutputError`) to resume ``task`` with ``constants``
        where the folder holds another sweep (none held: nothing to refuse);
        ``old``: its manifest, if already read."""
        old = self.manifest() if old is None else old
        if old is not None and (old.get("task") != task
                                or not _same(old.get("constants"), constants)):
            raise OutputError(
                f"--resume: {self.out} holds a sweep of {old.get('task')} with constants "
                f"{json.dumps(old.get('constants'))}, not of {task} with "
                f"{json.dumps(constants)}; choose another {self.option}")

    def finished(self, keys, points):
        """key -> record of the points stored done with exactly these params."""
        done = {}
        for key, point in zip(keys, points):
            record = self.load(key)
            if record and record.get("status") == "done" and _same(record["params"], point):
                done[key] = record
        return done

    def load(self, key):
        path = self.points_dir / f"{key}.json"
        try:
            return json.loads(path.read_text())
        except (OSError, ValueError):
            return None

    def save(self, record, files):
        """Persist one finished point: its files first, its record last;
        returns the record as stored."""
        key = record["key"]
        folder = self.points_dir / key
        if folder.exists():                       # a failed or killed attempt before
            shutil.rmtree(folder)
        for name, data in sorted(files.items()):
            target = (folder / name).resolve()
            if folder.resolve() not in target.parents:
                raise OutputError(f"task file {name!r} points outside its folder")
            write_bytes(target, data)
        record = dict(record, files=sorted(files))
        write_json(self.points_dir / f"{key}.json", record)
        return record

    def finish(self, **status):
        write_json(self.out / MANIFEST, {**self.header, **status})
