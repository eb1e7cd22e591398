"""Thread pinning for small problems (knitfem.threads)."""
import numba
import pytest
from threadpoolctl import threadpool_info

from knitfem.threads import SMALL_PROBLEM, threads_for


def blas_threads():
    """{library path: threads}; numba's threading layer may add a pool on first
    use, so compare the libraries present before."""
    return {p["filepath"]: p["num_threads"] for p in threadpool_info()}


def same_pools(before):
    now = blas_threads()
    return all(now[k] == v for k, v in before.items())


def test_small_problems_run_on_one_thread_and_restore_the_pools():
    before, numba_before = blas_threads(), numba.get_num_threads()
    with threads_for(SMALL_PROBLEM - 1) as pinned:
        assert pinned and set(blas_threads().values()) == {1}
        assert numba.get_num_threads() == 1
    assert same_pools(before) and numba.get_num_threads() == numba_before
    with pytest.raises(RuntimeError):
        with threads_for(10):
            raise RuntimeError("a failed solve")
    assert same_pools(before) and numba.get_num_threads() == numba_before


def test_large_problems_and_pin_false_keep_their_threads():
    before, numba_before = blas_threads(), numba.get_num_threads()
    for args in ((SMALL_PROBLEM,), (10, False)):
        with threads_for(*args) as pinned:
            assert not pinned
            assert same_pools(before) and numba.get_num_threads() == numba_before
