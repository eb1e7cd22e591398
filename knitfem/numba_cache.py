"""numba's on-disk cache, keyed by the whole of knitfem's source.

numba drops a function's cached machine code when that function's own file
changes, not when a function it calls from another module does — the callee
is compiled into the caller.  Edit ``contact/master.py`` and the cached
``contact/narrow.py::_all_pairs`` goes on running the old
``critical_points`` (seen on 2026-12-03: a timing that did not move until
``__pycache__`` was cleared).  A silently stale kernel is a wrong answer, so
knitfem's kernels are cached in a folder named by a hash of every knitfem
source file: any change to any of them compiles afresh (~20–60 s, once).

The folder: ``$NUMBA_CACHE_DIR/knitfem-<hash>`` if that variable is set, else
``~/.cache/knitfem/numba-<hash>``.  It goes into ``NUMBA_CACHE_DIR`` too: numba
re-reads its configuration from the environment whenever a ``NUMBA_*``
variable changes (a script setting ``NUMBA_NUM_THREADS`` after importing
knitfem, a test's ``monkeypatch``), and a folder set only in ``numba.config``
was then dropped for every kernel defined afterwards (seen in the test suite,
2026-12-08).
"""
import hashlib
import os
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent


def source_hash(root=PACKAGE):
    """16 hex digits over every ``*.py`` below ``root`` (names and bytes)."""
    digest = hashlib.blake2b(digest_size=8)
    for path in sorted(Path(root).rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def cache_dir(root=PACKAGE, environ=os.environ):
    digest = source_hash(root)
    base = environ.get("NUMBA_CACHE_DIR")
    if base:
        # already this source's folder (set by configure): itself, not a subfolder
        if os.path.basename(os.path.normpath(base)) in (f"knitfem-{digest}", f"numba-{digest}"):
            return base
        return os.path.join(base, f"knitfem-{digest}")
    return os.path.join(os.path.expanduser("~"), ".cache", "knitfem", f"numba-{digest}")


def configure():
    """Point numba's cache at :func:`cache_dir` (before any kernel is
    decorated: numba reads it when a cached function is defined), in
    ``numba.config`` and in ``NUMBA_CACHE_DIR``, so that numba's reloads of
    its configuration keep it."""
    import numba
    folder = cache_dir()
    os.environ["NUMBA_CACHE_DIR"] = folder
    numba.config.CACHE_DIR = folder
