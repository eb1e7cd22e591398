"""Pop-up over a plane of loop shapes: max|z|/L on a (c/L, w/L) grid and the
critical curve c_crit(w/L) (paper Fig. 4c), one continuation per w/L, run in
parallel processes."""
import os
from contextlib import contextmanager
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from dataclasses import dataclass

import numpy as np

from .srod import SRod, popup


@dataclass
class HeatMap:
    w_over_L: np.ndarray          # (nw,)
    c_over_L: np.ndarray          # (nc,) descending
    height: np.ndarray            # (nw, nc) max|z|/L on the stable path; NaN where c is impossible
    stable: np.ndarray            # (nw, nc) bool
    critical: np.ndarray          # (nw,) c_crit/L (NaN: none in range)
    elapsed: np.ndarray           # (nw,) solver seconds per column
    errors: dict                  # w/L -> message, for columns that failed


def _column(w_over_L, c_grid, scene):
    """One w/L: the popup from the largest feasible grid value down."""
    srod = SRod(w=w_over_L * scene.get("length", 105.0), **scene)
    feasible = c_grid[c_grid < 0.985 * srod.c_max / srod.length]
    step = c_grid[0] - c_grid[1]
    try:
        result = popup(srod, feasible[0], c_grid[-1], step)
    except RuntimeError as err:
        # NewtonError / ContinuationError carry states and do not unpickle: sent
        # back as they are they break the whole process pool, losing every column
        raise RuntimeError(f"{type(err).__name__}: {err}") from None
    height = np.full(c_grid.shape, np.nan)
    stable = np.zeros(c_grid.shape, bool)
    offset = c_grid.shape[0] - feasible.shape[0]
    for k, s in enumerate(result.samples):
        height[offset + k] = s.max_abs_z_over_L
        stable[offset + k] = s.stable
    crit = np.nan if result.critical_c_over_L is None else result.critical_c_over_L
    return height, stable, crit, result.elapsed_s


_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                     "NUMBA_NUM_THREADS")


@contextmanager
def _single_threaded_children():
    """Spawned workers inherit the environment: one BLAS / numba thread each,
    as the processes already fill the cores (oversubscribed threads made the
    12 x 23 heat map 2.7x slower on 2 cores)."""
    saved = {k: os.environ.get(k) for k in _THREAD_VARIABLES}
    os.environ.update({k: "1" for k in _THREAD_VARIABLES})
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def heat_map(w_values, c_grid, *, workers=None, progress=True, **scene):
    """Run :func:`popup` for each w/L (processes in parallel, tqdm bar) and
    collect the sampled heights.  ``c_grid`` must be descending and evenly
    spaced; ``scene`` goes to :class:`SRod` (elements, poisson, ...)."""
    w_values = np.asarray(w_values, float)
    c_grid = np.asarray(c_grid, float)
    n = len(w_values)
    out = HeatMap(w_values, c_grid, np.full((n, len(c_grid)), np.nan),
                  np.zeros((n, len(c_grid)), bool), np.full(n, np.nan), np.zeros(n), {})
    workers = workers or os.cpu_count() or 1
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=n, desc="w/L columns", unit="col")
    # spawn, not fork: a forked child inherits numba's thread pool in an unusable state
    with _single_threaded_children(), \
            ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn")) as pool:
        futures = {pool.submit(_column, w, c_grid, scene): i for i, w in enumerate(w_values)}
        for fut in as_completed(futures):
            i = futures[fut]
            try:
                out.height[i], out.stable[i], out.critical[i], out.elapsed[i] = fut.result()
            except (ValueError, RuntimeError) as err:    # keep the other columns
                out.errors[float(w_values[i])] = str(err)
            if bar is not None:
                bar.update()
    if bar is not None:
        bar.close()
    return out
