"""numba's cache is keyed by all of knitfem's source (knitfem.numba_cache):
numba itself drops a cached kernel only when the kernel's own file changes,
so an edit to a callee in another module would leave a stale caller."""
import os

from knitfem import numba_cache


def _tree(root, text):
    (root / "contact").mkdir(parents=True)
    (root / "contact" / "master.py").write_text(text)
    (root / "contact" / "narrow.py").write_text("from .master import f\n")


def test_any_source_change_gives_another_cache_folder(tmp_path):
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    _tree(a, "def f(x):\n    return x\n")
    _tree(b, "def f(x):\n    return x\n")
    _tree(c, "def f(x):\n    return x + 1\n")     # the callee edited, the caller not
    assert numba_cache.source_hash(a) == numba_cache.source_hash(b)
    assert numba_cache.source_hash(a) != numba_cache.source_hash(c)
    assert numba_cache.cache_dir(a, {}) != numba_cache.cache_dir(c, {})


def test_the_folder_follows_numba_cache_dir_and_is_what_numba_uses(tmp_path):
    import numba
    env = {"NUMBA_CACHE_DIR": str(tmp_path)}
    assert numba_cache.cache_dir(environ=env) == os.path.join(
        str(tmp_path), f"knitfem-{numba_cache.source_hash()}")
    assert numba.config.CACHE_DIR == numba_cache.cache_dir()


def test_numba_keeps_the_folder_when_it_reloads_its_configuration(monkeypatch):
    """numba re-reads its configuration from the environment when a NUMBA_*
    variable changes; the folder survives that (it was '' after it, and the
    kernels defined afterwards were cached beside their source), and the
    folder named in NUMBA_CACHE_DIR is taken as it is, not nested again."""
    import numba
    folder = numba_cache.cache_dir()
    # a variable that changes nothing else: NUMBA_NUM_THREADS refuses a
    # new value once numba's thread pool is up (CI, 2026-12-08)
    monkeypatch.setenv("NUMBA_DEBUG_CACHE", "0")
    numba.core.config.reload_config()
    assert numba.config.CACHE_DIR == folder == os.environ["NUMBA_CACHE_DIR"]
    monkeypatch.undo()
    numba.core.config.reload_config()
    assert numba.config.CACHE_DIR == folder
    assert numba_cache.cache_dir(environ={"NUMBA_CACHE_DIR": folder}) == folder
