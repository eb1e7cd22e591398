"""Benchmark: FIRE against the paper's dynamic relaxation on B-spline swatches.

Same swatch, same energy, same start (knitted shape, alpha = 0.2): wall time
of each method until its relative residual first falls to each level of
``LEVELS``, at (N_w, N_c) = (10, 35) and (25, 35), each run capped at
``--max-time`` seconds (single-threaded: pin OMP_NUM_THREADS=1
NUMBA_NUM_THREADS=1).  FIRE traces can be taken from the cross-check study
(``--fire-traces DIR``: its ``trace_<nw>x<nc>.csv``) instead of rerunning.
Also: time per energy evaluation and per Hessian at each size.

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python studies/bench_bspline_fabric.py \\
        --out studies/results/bench_bspline_fabric [--max-time 900]

Writes ``bench.md`` / ``bench.json`` and ``residual_vs_time.png``.
"""
import argparse
import csv
import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from knitfem.scenes.curl_bspline import Trace, relax_swatch  # noqa: E402
from knitfem.scenes.swatch_bspline import bspline_swatch, prestretch  # noqa: E402

LEVELS = (3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 1e-5, 1e-6)


def first_time(rows, level):
    """Wall time at which the residual first fell to ``level`` (None if never)."""
    for r in rows:
        if r["residual"] <= level:
            return r["t"]
    return None


def timings(nw, nc, repeats=11):
    """Median seconds of one energy + gradient and of one Hessian at the start."""
    bs = bspline_swatch(nw, nc)
    prestretch(bs, 0.2)
    m = bs.model
    y = m.reduce(m._initial())
    m.reduced_energy(y)
    m.reduced_hessian(y)
    e, h = [], []
    for _ in range(repeats):
        t = time.perf_counter()
        m.reduced_energy(y)
        e.append(time.perf_counter() - t)
    for _ in range(3):
        t = time.perf_counter()
        m.reduced_hessian(y)
        h.append(time.perf_counter() - t)
    return {"dofs": int(y.size), "energy_ms": 1e3 * float(np.median(e)),
            "hessian_s": float(np.median(h))}


def run(nw, nc, method, max_time):
    bs = bspline_swatch(nw, nc)
    prestretch(bs, 0.2)
    trace = Trace(bs, shape_every=1e9)                   # residuals only
    _, info = relax_swatch(bs, method=method, max_time=max_time, newton=False,
                           monitor=trace)
    return trace.rows, info


def read_trace(path):
    with open(path) as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", default="studies/results/bench_bspline_fabric")
    p.add_argument("--sizes", default="10x35,25x35")
    p.add_argument("--max-time", type=float, default=900.0)
    p.add_argument("--fire-traces", default=None)
    args = p.parse_args(argv)
    sizes = args.sizes.split(",")
    if len(sizes) not in (1, 2):
        p.error(f"--sizes: one or two sizes (the figure has two panels), got {args.sizes!r}")
    missing = [s for s in sizes if args.fire_traces
               and not (Path(args.fire_traces) / f"trace_{s}.csv").exists()]
    if missing:
        p.error(f"--fire-traces: no trace_<size>.csv in {args.fire_traces} for {missing} "
                "(leave the option out to run FIRE)")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    results = {}
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, size in zip(axes, sizes):
        nw, nc = (int(v) for v in size.split("x"))
        entry = {"timings": timings(nw, nc)}
        for method in ("fire", "dynamic"):
            source = Path(args.fire_traces or "") / f"trace_{size}.csv"
            if method == "fire" and args.fire_traces and source.exists():
                rows, info = read_trace(source), {"message": f"trace from {source}"}
            else:
                rows, info = run(nw, nc, method, args.max_time)
            entry[method] = {"levels": {f"{lv:g}": first_time(rows, lv) for lv in LEVELS},
                             "final_residual": rows[-1]["residual"] if rows else None,
                             "steps": int(rows[-1]["step"]) if rows else 0,
                             "wall_s": rows[-1]["t"] if rows else None,
                             "message": info.get("message", "")}
            ax.semilogy([r["t"] for r in rows], [r["residual"] for r in rows], lw=0.7,
                        label=method)
        ax.set_title(f"{nw} x {nc}")
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("relative residual")
        ax.legend()
        results[size] = entry
        (out / "bench.json").write_text(json.dumps(results, indent=1))
        print(json.dumps({size: entry}), flush=True)
    fig.tight_layout()
    fig.savefig(out / "residual_vs_time.png", dpi=120)
    lines = ["| size | dofs | energy+gradient (ms) | Hessian (s) | level | FIRE (s) | "
             "dynamic relaxation (s) | ratio |", "|---|---|---|---|---|---|---|---|"]
    for size, e in results.items():
        for lv in LEVELS:
            f, d = e["fire"]["levels"][f"{lv:g}"], e["dynamic"]["levels"][f"{lv:g}"]
            ratio = f"{d / f:.1f}" if f and d else ("> " + f"{args.max_time / f:.0f}"
                                                    if f and not d else "")
            lines.append(f"| {size} | {e['timings']['dofs']} | "
                         f"{e['timings']['energy_ms']:.1f} | {e['timings']['hessian_s']:.2f} | "
                         f"{lv:g} | {'' if f is None else f'{f:.0f}'} | "
                         f"{'' if d is None else f'{d:.0f}'} | {ratio} |")
    (out / "bench.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
