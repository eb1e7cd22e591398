"""Where the points of a sweep run: this process, a local process pool, or a Dask cluster.

Each executor is a context manager with ``run(jobs)``: ``jobs`` a list of
``(tag, function, args)``, yielding ``(tag, value)`` as each job finishes, in
any order.  Leaving the block by an exception (an interruption) stops the
work: the pool's worker processes are terminated, the cluster's pending
tasks cancelled.

- :class:`InProcess` (``workers=0``): one after the other, here (debugging).
- :class:`LocalPool` (default): ``workers`` spawned processes, one BLAS /
  numba thread each (the processes fill the cores; oversubscribed threads
  made the 12 x 23 heat map 2.7x slower on 2 cores).  Workers ignore SIGINT
  and exit when the parent dies.
- :class:`DaskCluster`: an existing ``dask.distributed`` scheduler
  (``tcp://host:port``); needs the ``dask`` extra here and knitfem installed
  on every worker.

The function and its arguments travel by pickle: the task must be a
top-level function of an importable module.
"""
from contextlib import contextmanager
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from multiprocessing import get_context
import os

from ..interrupt import worker_signals

THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                    "NUMBA_NUM_THREADS")


@contextmanager
def single_threaded_children():
    """Spawned children inherit the environment: one BLAS / numba thread each."""
    saved = {k: os.environ.get(k) for k in THREAD_VARIABLES}
    os.environ.update({k: "1" for k in THREAD_VARIABLES})
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


class InProcess:
    """Run the jobs one by one in this process."""
    name = "in-process"

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def run(self, jobs):
        for tag, function, args in jobs:
            yield tag, function(*args)


class LocalPool:
    """``workers`` spawned processes (default: the number of cores)."""

    def __init__(self, workers=None):
        self.workers = int(workers or os.cpu_count() or 1)
        self.name = f"local pool of {self.workers} process{'es' if self.workers > 1 else ''}"

    def __enter__(self):
        # spawn, not fork: a forked child inherits numba's thread pool in an unusable state
        with single_threaded_children():
            self.pool = ProcessPoolExecutor(self.workers, mp_context=get_context("spawn"),
                                            initializer=worker_signals, initargs=(os.getpid(),))
        return self

    def run(self, jobs):
        futures = {self.pool.submit(function, *args): tag for tag, function, args in jobs}
        pending = set(futures)
        while pending:
            finished, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in finished:
                yield futures[future], future.result()

    def __exit__(self, kind, error, trace):
        if kind is None:
            self.pool.shutdown(wait=True)
            return False
        self.terminate()
        return False

    def terminate(self):
        """Stop now: cancel what has not started, terminate the workers."""
        processes = list(getattr(self.pool, "_processes", {}).values())
        self.pool.shutdown(wait=False, cancel_futures=True)
        # ProcessPoolExecutor has no public way to stop running work before
        # Python 3.14 (terminate_workers); its process table is the only handle
        for p in processes:
            if p.is_alive():
                p.terminate()
        for p in processes:
            p.join(timeout=5)


class DaskCluster:
    """An existing Dask distributed scheduler at ``address``."""

    def __init__(self, address, timeout=10):
        self.address, self.timeout = address, timeout
        self.name = f"Dask scheduler {address}"

    def __enter__(self):
        try:
            from distributed import Client
        except ImportError:
            raise ValueError("--scheduler needs dask.distributed: pip install 'knitfem[dask]'") \
                from None
        try:
            self.client = Client(self.address, timeout=self.timeout, set_as_default=False)
        except (OSError, TimeoutError) as err:
            raise ValueError(f"--scheduler {self.address}: cannot connect ({err})") from None
        self.futures = []
        return self

    def run(self, jobs):
        from distributed import as_completed
        tags = {}
        for tag, function, args in jobs:
            future = self.client.submit(function, *args, pure=False)
            tags[future.key] = tag
            self.futures.append(future)
        for future in as_completed(self.futures, loop=self.client.loop):
            yield tags[future.key], future.result()

    def __exit__(self, kind, error, trace):
        try:
            if kind is not None and self.futures:
                self.client.cancel(self.futures)
        finally:
            self.client.close()
        return False


def executor(workers=None, scheduler=None):
    """The executor for the CLI options ``--workers N`` / ``--scheduler ADDRESS``."""
    if scheduler:
        return DaskCluster(scheduler)
    if workers == 0:
        return InProcess()
    return LocalPool(workers)
