"""Pop-up over a plane of loop shapes: max|z|/L on a (c/L, w/L) grid and the
critical curve c_crit(w/L) (paper Fig. 4c), one continuation per w/L.

Each w/L column is a task of the sweep engine (:mod:`knitfem.sweep`):
persisted as it finishes, resumable, run on a local process pool (one
BLAS / numba thread per worker) or a Dask cluster.
"""
from dataclasses import dataclass
import tempfile

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
    errors: dict                  # w/L -> message, for columns that failed or did not run
    sweep: object = None          # the knitfem.sweep.SweepResult


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


def popup_column(params, out_dir):
    """Sweep task: the pop-up along ``params["c_over_L"]`` (descending, even
    steps) at ``params["w_over_L"]``; ``params["scene"]``: :class:`SRod`
    options (elements, poisson, ...).  Returns max|z|/L (null where c is
    impossible), stability per c, c_crit/L (null: none in range) and the
    solver's seconds."""
    c_grid = np.asarray(params["c_over_L"], float)
    height, stable, crit, elapsed = _column(float(params["w_over_L"]), c_grid,
                                            dict(params.get("scene", {})))
    return {"max_abs_z_over_L": height.tolist(), "stable": stable.tolist(),
            "critical_c_over_L": crit, "solver_s": elapsed}


def heat_map(w_values, c_grid, *, out=None, resume=False, workers=None, scheduler=None,
             progress=True, **scene):
    """Run :func:`popup_column` for each w/L through :func:`knitfem.sweep.run_sweep`
    and collect the sampled heights.  ``c_grid`` must be descending and evenly
    spaced; ``scene`` goes to :class:`SRod` (elements, poisson, ...).  ``out``:
    the sweep folder (default a temporary one); ``resume``, ``workers``,
    ``scheduler``: as for :func:`knitfem.sweep.run_sweep`."""
    from ..sweep import grid, run_sweep
    w_values = np.asarray(w_values, float)
    c_grid = np.asarray(c_grid, float)
    constants = {"c_over_L": c_grid.tolist(), "scene": scene}
    with tempfile.TemporaryDirectory(prefix="knitfem-heatmap-") as tmp:
        result = run_sweep(popup_column, grid(w_over_L=w_values), out or tmp,
                           constants=constants, resume=resume, workers=workers,
                           scheduler=scheduler, progress=progress, desc="w/L columns")
    n = len(w_values)
    hm = HeatMap(w_values, c_grid, np.full((n, len(c_grid)), np.nan),
                 np.zeros((n, len(c_grid)), bool), np.full(n, np.nan), np.zeros(n), {}, result)
    for i, record in enumerate(result.records):
        if record is None or record["status"] != "done":
            hm.errors[float(w_values[i])] = "not run" if record is None else record["error"]
            continue
        r = record["result"]
        hm.height[i] = [np.nan if z is None else z for z in r["max_abs_z_over_L"]]
        hm.stable[i] = r["stable"]
        hm.critical[i] = np.nan if r["critical_c_over_L"] is None else r["critical_c_over_L"]
        hm.elapsed[i] = r["solver_s"]
    return hm
