"""How good is ``knitfem curl``'s run-time estimate?  Every beam relaxation on
record against the estimate it would have been given, and what that says of a
whole phase grid (issues 9 and 13).

    python studies/runtime_estimate.py [--roots studies/results] --out DIR
        [--nw 5,10,15,20,25,30,40,55 --nc 5,10,15,20,25,30,35 --workers 2]

Reads every ``knitfem curl`` summary JSON (beam, co-rotated friction: the
default since 2026-12-03; finished, not failed) under the roots and compares
its measured relaxation time ``relax_s`` (summed over the processes of a
resumed run) with ``knitfem.scenes.curl_command.seconds``, split into its two
factors: iterations (model ``ITERATIONS x (loops / 25)^0.25``) and seconds per
unknown and iteration (model ``S_PER_DOF_ITERATION``).  The runs were made on
the shared 2-core VM with 0-2 other jobs beside them, so the per-iteration
cost scatters with the load as well as with the swatch.

Writes ``DIR/runtime_estimate.csv`` (one row per run), ``DIR/runtime_estimate.md``
(the table, the medians and ranges of measured / estimated, the grid's
projection) and ``DIR/runtime_estimate.png`` (measured against estimated time,
log-log; iterations against loops with the model's curve).  The projection
of the grid: each point's estimate times the median measured / estimated
ratio of the runs, the points spread over ``--workers`` (longest first).
"""
import argparse
import csv
import heapq
import json
from argparse import Namespace
from pathlib import Path

import numpy as np

from knitfem.scenes import curl_command

FIELDS = ("source", "nw", "nc", "elements_per_loop", "alpha", "unknowns", "iterations",
          "failed_increments", "relax_s", "estimate_s", "ratio", "iterations_model",
          "s_per_dof_iteration")


def summary_of(path):
    """The beam run a JSON holds (a ``knitfem curl`` summary), or None."""
    try:
        s = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(s, dict) or s.get("model", "beam") != "beam":
        return None
    scene = s.get("scene")
    if not isinstance(scene, dict) or not scene.get("corotated_friction"):
        return None
    if s.get("error") is not None or not s.get("relax_s") or not s.get("iterations"):
        return None
    return s


def record(path, s):
    """One row: the run's measured time and iterations against the estimate's."""
    scene = s["scene"]
    v = Namespace(nw=s["nw"], nc=s["nc"], elements_per_loop=scene["elements_per_loop"],
                  model="beam")
    unknowns = curl_command.unknowns(v)
    estimate = curl_command.seconds(v)
    return {"source": str(path), "nw": v.nw, "nc": v.nc,
            "elements_per_loop": v.elements_per_loop, "alpha": s["alpha"],
            "unknowns": unknowns, "iterations": int(s["iterations"]),
            "failed_increments": s.get("failed_increments"),
            "relax_s": float(s["relax_s"]), "estimate_s": estimate,
            "ratio": float(s["relax_s"]) / estimate,
            "iterations_model": curl_command.expected_iterations(v.nw * v.nc),
            "s_per_dof_iteration": float(s["relax_s"]) / (unknowns * int(s["iterations"]))}


def collect(roots):
    """Rows of every distinct run under ``roots`` (a run copied into two
    folders, e.g. adopted into a sweep, counts once: same swatch, iterations
    and time)."""
    rows, seen = [], set()
    for root in roots:
        for path in sorted(Path(root).rglob("*.json")):
            s = summary_of(path)
            if s is None:
                continue
            row = record(path, s)
            key = (row["nw"], row["nc"], row["elements_per_loop"], row["alpha"],
                   row["iterations"], round(row["relax_s"], 3))
            if key not in seen:
                seen.add(key)
                rows.append(row)
    return rows


def spread(ratios):
    """(median, min, max) of the ratios."""
    r = np.asarray(ratios, float)
    return float(np.median(r)), float(r.min()), float(r.max())


def makespan(seconds, workers):
    """Wall time of independent tasks on ``workers`` (longest first, each to
    the first free worker)."""
    free = [0.0] * max(1, workers)
    for t in sorted(seconds, reverse=True):
        heapq.heappush(free, heapq.heappop(free) + t)
    return max(free)


def grid_projection(nw_values, nc_values, ratio, workers, elements_per_loop=32):
    """(points, worker-hours, wall hours on ``workers``, the longest point in
    hours) of the grid, each point's estimate scaled by ``ratio``."""
    times = [ratio * curl_command.seconds(Namespace(nw=nw, nc=nc, model="beam",
                                                    elements_per_loop=elements_per_loop))
             for nw in nw_values for nc in nc_values]
    return len(times), sum(times) / 3600, makespan(times, workers) / 3600, max(times) / 3600


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.6))
    est = np.array([r["estimate_s"] for r in rows])
    meas = np.array([r["relax_s"] for r in rows])
    loops = np.array([r["nw"] * r["nc"] for r in rows])
    its = np.array([r["iterations"] for r in rows])
    epl = np.array([r["elements_per_loop"] for r in rows])
    for e in sorted(set(epl)):
        m = epl == e
        a.loglog(est[m], meas[m], "o", label=f"{e} elements per loop")
        b.semilogx(loops[m], its[m], "o", label=f"{e} elements per loop")
    lo, hi = min(est.min(), meas.min()) / 2, max(est.max(), meas.max()) * 2
    a.loglog([lo, hi], [lo, hi], "k-", lw=0.8, label="measured = estimated")
    for f in (0.5, 2.0):
        a.loglog([lo, hi], [f * lo, f * hi], "k:", lw=0.6)
    a.set_xlabel("estimated run time (s)")
    a.set_ylabel("measured relaxation time (s)")
    a.set_title("knitfem curl's estimate (dotted: x0.5, x2)")
    a.legend(fontsize=8)
    x = np.geomspace(loops.min(), loops.max(), 50)
    b.semilogx(x, curl_command.expected_iterations(x), "k-", lw=0.8,
               label="model: ITERATIONS (loops/25)^0.25")
    b.set_xlabel("loops N_w N_c")
    b.set_ylabel("minimisation iterations (failed attempts included)")
    b.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def report(rows, projection, args):
    ratio = spread([r["ratio"] for r in rows])
    its = spread([r["iterations"] / r["iterations_model"] for r in rows])
    cost = spread([r["s_per_dof_iteration"] / curl_command.S_PER_DOF_ITERATION for r in rows])
    lines = [
        f"{len(rows)} beam relaxations (co-rotated friction, finished) under "
        f"{', '.join(map(str, args.roots))}.",
        "",
        "| factor | median | min | max |", "|---|---:|---:|---:|",
        "| run time, measured / estimated | %.2f | %.2f | %.2f |" % ratio,
        "| iterations, measured / model | %.2f | %.2f | %.2f |" % its,
        "| s per unknown and iteration, measured / model | %.2f | %.2f | %.2f |" % cost,
        "",
        "| swatch | elements per loop | alpha | unknowns | iterations (failed incr.) | "
        "relaxation | estimate | ratio | source |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in sorted(rows, key=lambda r: (r["nw"] * r["nc"], r["elements_per_loop"], r["alpha"])):
        lines.append(f"| {r['nw']} × {r['nc']} | {r['elements_per_loop']} | {r['alpha']:g} | "
                     f"{r['unknowns']} | {r['iterations']} ({r['failed_increments']}) | "
                     f"{r['relax_s']:.0f} s | {r['estimate_s']:.0f} s | {r['ratio']:.2f} | "
                     f"`{r['source']}` |")
    n, worker_h, wall_h, longest_h = projection
    lines += ["", f"Grid N_w {args.nw} x N_c {args.nc} ({n} points, 32 elements per loop), "
              f"each point's estimate x the median ratio {ratio[0]:.2f}: {worker_h:.0f} "
              f"worker-hours, {wall_h:.0f} h on {args.workers} worker(s) (the longest point "
              f"{longest_h:.1f} h)."]
    return "\n".join(lines) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--roots", nargs="+", type=Path, default=[Path("studies/results")])
    parser.add_argument("--out", type=Path, default=Path("studies/results/runtime_estimate"))
    parser.add_argument("--nw", default="5,10,15,20,25,30,40,55")
    parser.add_argument("--nc", default="5,10,15,20,25,30,35")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    rows = collect(args.roots)
    if not rows:
        parser.error(f"--roots: no finished beam relaxation (co-rotated friction) under "
                     f"{args.roots}")
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "runtime_estimate.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    nw = [int(v) for v in args.nw.split(",")]
    nc = [int(v) for v in args.nc.split(",")]
    ratio = spread([r["ratio"] for r in rows])[0]
    text = report(rows, grid_projection(nw, nc, ratio, args.workers), args)
    (args.out / "runtime_estimate.md").write_text(text)
    plot(rows, args.out / "runtime_estimate.png")
    print(text)


if __name__ == "__main__":
    main()
