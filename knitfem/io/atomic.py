"""Atomic file writes: a file either has its complete new content or is not touched.

Every file knitfem writes goes through this module.  A writer gets a
temporary path next to the target (same folder, so the final
:func:`os.replace` is an atomic rename on POSIX file systems; a hidden name
ending in the target's suffix, so meshio / matplotlib / VTK pick the format
from it) and the temporary becomes the target only when the writer returned
normally.  An exception (a full disk, an interruption) removes the temporary
and leaves any previous file of that name as it was.

API
---
``with atomic_path(path) as tmp: writer(tmp)``
    any writer that takes a file name (``mesh.write``, ``fig.savefig``,
    ``plotter.screenshot``);
``write_text(path, text)``, ``write_json(path, obj)``, ``write_bytes(path, data)``,
``write_csv(path, header, rows)``, ``save_figure(fig, path)``
    the common cases; :func:`write_json` stores NaN and infinities as ``null``
    (JSON has no NaN) and ends the file with a newline; meshes go through
    :func:`knitfem.io.write_mesh`, renders through :mod:`knitfem.viz.render`;
``with recording() as written: ...``
    collects the paths of every file written atomically inside the block (by
    this thread), in order: a run's manifest lists them
    (:mod:`knitfem.io.run`); ``with unrecorded(): ...`` suspends that;
``check_file_target(path, option)``
    raises :class:`OutputError` unless ``path`` can be written as a regular file
    (not a folder, not a device such as /dev/null or /dev/full, folder
    writable), before any work is done.

Targets that exist and are not regular files are refused: renaming over
``/dev/null`` would replace the device.
"""
from contextlib import contextmanager
import csv
import io
import json
import math
import os
from pathlib import Path
import tempfile
import threading

_local = threading.local()


class OutputError(ValueError):
    """An output path that cannot be written (bad input: exit code 2 on the CLI)."""


def _targets_regular_file(path):
    if path.exists() and not path.is_file():
        kind = "a folder" if path.is_dir() else "not a regular file"
        raise OutputError(f"cannot write {path}: it is {kind}")


@contextmanager
def atomic_path(path):
    """A temporary path in ``path``'s folder that replaces ``path`` on success.

    The folder is created if missing.  Yields the temporary (a ``Path``); the
    writer must create it.  On an exception the temporary is removed and the
    exception propagates."""
    path = Path(path)
    _targets_regular_file(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}",
                                dir=path.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        if not tmp.exists():
            raise OSError(f"the writer of {path} created no file")
        os.chmod(tmp, 0o644)           # mkstemp's 0600 is meant for secrets, not results
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    for written in getattr(_local, "recorders", ()):
        written.append(path)


def write_bytes(path, data):
    """Write ``data`` (bytes) to ``path`` atomically (flushed to disk); returns the path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
    return path


def write_text(path, text):
    """Write ``text`` (UTF-8) to ``path`` atomically; returns the path."""
    return write_bytes(path, text.encode("utf-8"))


def write_csv(path, header, rows):
    """Write a CSV file (``header`` list, ``rows`` lists) atomically; returns the path."""
    buffer = io.StringIO(newline="")
    writer = csv.writer(buffer)
    writer.writerow(header)
    writer.writerows(rows)
    return write_text(path, buffer.getvalue())


def save_figure(fig, path, dpi=130):
    """Save a matplotlib figure atomically and close it; returns the path."""
    import matplotlib.pyplot as plt
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=dpi)
    finally:
        plt.close(fig)
    return Path(path)


def finite_or_none(obj):
    """``obj`` with every non-finite float (NaN, +-inf) replaced by None,
    through dicts, lists and tuples (numpy scalars and arrays become Python
    numbers and lists)."""
    if isinstance(obj, dict):
        return {k: finite_or_none(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite_or_none(v) for v in obj]
    if hasattr(obj, "tolist") and not isinstance(obj, (str, bytes)):    # numpy
        return finite_or_none(obj.tolist())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def write_json(path, obj, indent=2):
    """Write ``obj`` as JSON (non-finite numbers as null) atomically; returns the path."""
    text = json.dumps(finite_or_none(obj), indent=indent, allow_nan=False)
    return write_text(path, text + "\n")


@contextmanager
def recording():
    """Collect the paths written atomically (by this thread) inside the block."""
    written = []
    stack = getattr(_local, "recorders", ())
    _local.recorders = stack + (written,)
    try:
        yield written
    finally:
        _local.recorders = stack


@contextmanager
def unrecorded():
    """Suspend :func:`recording` inside the block (a sweep's point files are
    its own store's, not the enclosing run's)."""
    stack = getattr(_local, "recorders", ())
    _local.recorders = ()
    try:
        yield
    finally:
        _local.recorders = stack


def check_file_target(path, option):
    """Raise :class:`OutputError` naming ``option`` unless ``path`` can be
    written as a regular file: not a folder or device, its folder creatable
    and writable (checked by creating and removing a probe file)."""
    path = Path(path)
    if path.exists() and not path.is_file():
        kind = "a folder" if path.is_dir() else "not a regular file (a device?)"
        raise OutputError(f"{option} {path}: it is {kind}; give a file name")
    check_folder_writable(path.parent, option, what=f"the folder of {option} {path}")


def check_folder_writable(folder, option, what=None):
    """Create ``folder`` if needed and probe it with a temporary file;
    :class:`OutputError` naming ``option`` if that fails."""
    folder = Path(folder)
    what = what or f"{option} {folder}"
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{what}: it exists and is not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".knitfem-probe.", dir=folder)
        os.close(fd)
        os.unlink(probe)
    except OSError as err:
        raise OutputError(f"{what} is not writable: {err.strerror or err}") from None
