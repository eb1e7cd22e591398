"""One thread for small problems: BLAS/OpenMP pools (threadpoolctl) and numba.

A small problem (the S-rod pop-up: 366 unknowns) runs thousands of small
dense and sparse operations; a threaded BLAS spends more on waking,
spinning and synchronising its threads than the microseconds of work it
splits, and far more when other processes hold the cores.  Measured on 2
cores (studies/bench_popup.py): the pop-up sweep took 0.9-1.3 s with the
default threads against 0.45 s on one (issue 10), and 3.4-8.4 s against
1.0-1.2 s while other jobs loaded the machine.  Large problems keep their
threads: the beam kernels themselves go parallel from 2000 elements (12 000
unknowns), which is where ``SMALL_PROBLEM`` draws the line.
"""
from contextlib import contextmanager

SMALL_PROBLEM = 12_000      # unknowns; below, one thread is faster


@contextmanager
def threads_for(unknowns, pin=True):
    """Run the block on one BLAS/OpenMP and one numba thread if the problem
    has fewer than ``SMALL_PROBLEM`` unknowns (and ``pin``); yields whether
    it pinned.  The previous limits are restored on exit."""
    if not pin or unknowns >= SMALL_PROBLEM:
        yield False
        return
    import numba
    from threadpoolctl import threadpool_limits
    saved = numba.get_num_threads()
    with threadpool_limits(limits=1):
        numba.set_num_threads(1)
        try:
            yield True
        finally:
            numba.set_num_threads(saved)
