"""Benchmark of the S-rod pop-up (issue 3): the whole sweep at 60 elements
(solver time, critical point accuracy), the heat map wall time on all cores.

    python studies/bench_popup.py --out studies/results/bench_popup

Timing: ``elapsed_s`` of :func:`knitfem.scenes.srod.popup` (solver wall time,
after imports and the numba warm-up), median of repeated runs, with the
threads pinned to one (the default, :func:`knitfem.threads.threads_for`) and
with the libraries' default thread pools (``pin_threads=False``), the two
interleaved so that a change in the machine's load hits both alike.  Run it
without OMP_NUM_THREADS / OPENBLAS_NUM_THREADS set, or "default" is pinned too.
"""
import argparse
import time
from pathlib import Path

import numpy as np

from knitfem.io import write_json
from knitfem.scenes.popup_sweep import heat_map
from knitfem.scenes.srod import SRod, popup


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="studies/results/bench_popup")
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    popup(SRod())                       # first call in the process: caches, imports
    popup(SRod(), pin_threads=False)
    runs = {"pinned": [], "default_threads": []}
    for _ in range(args.repeat):
        runs["pinned"].append(popup(SRod()))
        runs["default_threads"].append(popup(SRod(), pin_threads=False))
    times = {k: np.array([r.elapsed_s for r in v]) for k, v in runs.items()}
    r = runs["pinned"][0]
    event = r.planar.events[0]
    sweep = {"elements": 60, "repeat": args.repeat,
             "critical_c_over_L": r.critical_c_over_L, "location_bracket": event.bracket,
             "continuation_points": {n: len(b.points) for n, b in r.branches()},
             "corrector_iterations": int(sum(p.iterations for _, b in r.branches()
                                             for p in b.points)),
             "default_over_pinned": float(np.median(times["default_threads"])
                                          / np.median(times["pinned"]))}
    for key, t in times.items():
        sweep[key] = {"elapsed_s_median": float(np.median(t)), "elapsed_s_min": float(t.min()),
                      "elapsed_s_max": float(t.max())}
        print(f"sweep c/L 0.95 -> 0.45, 60 elements, {key.replace('_', ' ')}: median "
              f"{np.median(t):.3f} s (min {t.min():.3f}, max {t.max():.3f})")
    print(f"default threads / pinned = {sweep['default_over_pinned']:.2f}; c_crit/L = "
          f"{r.critical_c_over_L:.9f} located to {event.bracket:.1e}")

    w = np.linspace(0.05, 0.50, 12)
    c = np.round(0.95 - 0.025 * np.arange(23), 10)
    t = time.perf_counter()
    hm = heat_map(w, c, progress=False)
    wall = time.perf_counter() - t
    heat = {"grid": [len(w), len(c)], "wall_s": wall, "solver_s_sum": float(hm.elapsed.sum()),
            "errors": hm.errors}
    print(f"heat map {len(w)} x {len(c)}: {wall:.1f} s wall on all cores "
          f"(solver time summed over columns {hm.elapsed.sum():.1f} s)")
    write_json(out / "bench_popup.json", {"sweep": sweep, "heat_map": heat})


if __name__ == "__main__":
    main()
