"""A run's output folder with its manifest ``run.json``.

``run.json`` says what produced the folder and whether it is whole::

    {"command": "knitfem popup ...", "version": "0.1.0",
     "source": {"commit": "4cc4c97...", "modified": false},
     "parameters": {...}, "files": ["branch.csv", ...],
     "complete": true, "started": "...", "finished": "...", "elapsed_s": 1.2}

Protocol (:class:`RunFolder`, a context manager):

1. ``RunFolder(out, command, parameters, outputs=patterns)`` checks that
   ``out`` is a writable folder (creating it) - call it before computing;
2. entering the block removes stale files: those listed by a previous
   ``run.json`` in the folder and those matching ``outputs`` (glob patterns
   relative to ``out``, the names this command writes), then writes
   ``run.json`` with ``complete: false``;
3. every file written atomically inside the block (:mod:`knitfem.io.atomic`)
   is recorded;
4. leaving the block normally rewrites ``run.json`` last, with the files and
   ``complete: true``; leaving it by an exception or an interruption writes
   ``complete: false``, the files written so far (each of them whole) and
   ``interrupted`` (the reason).

Files that neither a manifest nor ``outputs`` names are never removed.
``source`` is the git commit of the knitfem checkout that ran (``modified``:
tracked files differed from it), null for an installed copy: long relaxations
are resumed across code versions, and "which code made this" must be
answerable from the folder.  A ``--resume``d run (``parameters["resume"]``)
keeps the processes before it in ``earlier`` (their start, end, source and
whether they completed), oldest first.

Use (a command with an ``--out`` option)::

    run = RunFolder(args.out, "knitfem curl", vars(args), outputs=["curl*.vtu"],
                    option="--out")                    # before computing
    ... compute ...
    with run:
        write_json(run.path / "curl.json", summary)
"""
from datetime import datetime, timezone
import functools
import json
from pathlib import Path
import subprocess
import sys
import time

from .atomic import check_folder_writable, recording, write_json

MANIFEST = "run.json"


def _version():
    from .. import __version__
    return __version__


@functools.lru_cache(maxsize=1)
def source():
    """{"commit", "modified"} of the git checkout knitfem runs from, or None."""
    here = Path(__file__).resolve().parents[2]
    try:
        def git(*args):
            return subprocess.run(["git", "-C", str(here), *args], capture_output=True,
                                  text=True, timeout=10, check=True).stdout.strip()
        if Path(git("rev-parse", "--show-toplevel")).resolve() != here:
            return None                 # knitfem installed inside some other repository
        return {"commit": git("rev-parse", "HEAD"),
                "modified": bool(git("status", "--porcelain", "--untracked-files=no"))}
    except (OSError, subprocess.SubprocessError):
        return None


def _now():
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


class RunFolder:
    """See the module docstring.  ``parameters``: JSON-able dict (the
    command's options); ``outputs``: glob patterns of the files the command
    writes (stale ones are removed on entry); ``option``: how the folder was
    given on the command line, for messages; ``remove_listed``: also remove
    the files a previous manifest lists (False where one folder collects the
    outputs of several runs, e.g. swatches of several sizes)."""

    def __init__(self, out, command, parameters, *, outputs=(), option="--out",
                 remove_listed=True):
        self.path = Path(out)
        self.remove_listed = remove_listed
        self.command = command
        self.parameters = {k: v for k, v in parameters.items()
                           if _plain(v) and k not in ("given", "estimates")}
        self.outputs = tuple(outputs)
        self.option = option
        self.files = []
        self.complete = False
        self.earlier = []
        check_folder_writable(self.path, option)

    def stale(self):
        """Files of a previous run in the folder: those its manifest lists and
        those matching ``outputs`` (paths, sorted)."""
        found = set()
        manifest = self.path / MANIFEST
        if manifest.is_file() and self.remove_listed:
            try:
                listed = json.loads(manifest.read_text()).get("files", [])
            except (ValueError, AttributeError):
                listed = []
            for name in listed:
                p = (self.path / name)
                # only inside the folder: a manifest is no licence to delete elsewhere
                if p.is_file() and self.path.resolve() in p.resolve().parents:
                    found.add(p)
        for pattern in self.outputs:
            found.update(p for p in self.path.glob(pattern) if p.is_file())
        found.discard(manifest)
        return sorted(found)

    def _previous(self):
        """The processes a resumed run continues: the folder's manifest's own
        ``earlier`` and that manifest itself."""
        try:
            previous = json.loads((self.path / MANIFEST).read_text())
        except (OSError, ValueError):
            return []
        if not isinstance(previous, dict) or previous.get("command") != self.command:
            return []
        return list(previous.get("earlier", [])) + [
            {key: previous.get(key) for key in ("started", "finished", "source", "complete")}]

    def _manifest(self, **extra):
        record = {"command": self.command, "version": _version(), "source": source(),
                  "parameters": self.parameters,
                  "files": [str(Path(f).relative_to(self.path)) if Path(f).is_relative_to(
                      self.path) else str(f) for f in self.files],
                  "complete": self.complete, "started": self.started}
        if self.earlier:
            record["earlier"] = self.earlier
        record.update(extra)
        return record

    def __enter__(self):
        self.earlier = self._previous() if self.parameters.get("resume") else []
        for p in self.stale():
            p.unlink(missing_ok=True)
        self.started = _now()
        self._t0 = time.perf_counter()
        write_json(self.path / MANIFEST, self._manifest())
        self._recording = recording()
        self.files = self._recording.__enter__()
        return self

    def __exit__(self, kind, error, trace):
        self._recording.__exit__(kind, error, trace)
        self.files = [f for f in self.files if Path(f).name != MANIFEST]
        extra = {"finished": _now(), "elapsed_s": time.perf_counter() - self._t0}
        if kind is None:
            self.complete = True
        else:
            extra["interrupted"] = describe(error)
        try:
            write_json(self.path / MANIFEST, self._manifest(**extra))
        except OSError as err:         # keep the original error; say why the manifest is stale
            print(f"knitfem: could not update {self.path / MANIFEST}: {err}", file=sys.stderr)
            if kind is None:
                raise
        return False


def _plain(value):
    """Whether a parameter is plain data for the manifest (not a function,
    set or object: argparse namespaces carry some)."""
    if isinstance(value, (list, tuple)):
        return all(_plain(v) for v in value)
    if isinstance(value, dict):
        return all(isinstance(k, str) and _plain(v) for k, v in value.items())
    return value is None or isinstance(value, (str, int, float, bool))


def describe(error):
    """A short reason for an incomplete run: the signal's name if a signal
    caused ``error`` (:func:`knitfem.interrupt.interruption`), else the error."""
    from ..interrupt import interruption
    stop = interruption(error)
    if stop is not None:
        return stop.signal_name
    return f"{type(error).__name__}: {error}".strip()
