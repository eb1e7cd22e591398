"""Benchmark of the fabric phase sweep: points per hour on a local pool of 2
processes against a Dask ``LocalCluster`` of 2 worker processes (one thread
each), the same B-spline curl points on both, and the full default grid's
projected time for a per-point time limit.

    python studies/bench_fabric_phase.py --out studies/results/fabric_phase_bench

Same work on both executors: each point stops after ``--max-steps`` FIRE
steps (a step limit repeats bit for bit; a time limit would make every point
last max-time whatever the executor), and the rows are checked to be equal.
Timings: wall time of whole sweeps (pool start-up and worker imports
included; the cluster is started before, as an existing cluster would be,
and its start-up is reported apart), ``--repeats`` alternating runs, medians.
Writes DIR/bench.json, DIR/bench.md and the pool run's phase.csv,
phase_diagram.png and phase_trends.png.
"""
import argparse
import os
from pathlib import Path
import statistics
import tempfile
import time

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_v] = "1"                     # workers of both executors inherit it

from knitfem.io import write_json  # noqa: E402
from knitfem.io.atomic import write_text  # noqa: E402
from knitfem.scenes.curl_sweep import phase_sweep  # noqa: E402
from knitfem.scenes.phase_output import plot_phase_diagram, plot_phase_trends, \
    write_phase_csv  # noqa: E402

FULL_GRID = (8, 7)                          # the N_w x N_c grid: 56 points


def sweep(nw, nc, options, executor, cluster):
    with tempfile.TemporaryDirectory(prefix="knitfem-bench-phase-") as out:
        t = time.perf_counter()
        if executor == "pool":
            rows, result = phase_sweep(nw, nc, out, first=None, options=options, workers=2,
                                       progress=False)
        else:
            rows, result = phase_sweep(nw, nc, out, first=None, options=options,
                                       scheduler=cluster.scheduler_address, progress=False)
        wall = time.perf_counter() - t
    assert result.complete, [r["error"] for r in result.failed]
    return rows, wall


def strip(rows):
    return [{k: v for k, v in r.items() if k != "elapsed_s"} for r in rows]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="studies/results/fabric_phase_bench")
    parser.add_argument("--nw", default="3,4")
    parser.add_argument("--nc", default="4,5")
    parser.add_argument("--max-steps", type=int, default=5000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    from distributed import LocalCluster
    nw = [int(v) for v in args.nw.split(",")]
    nc = [int(v) for v in args.nc.split(",")]
    options = {"max_steps": args.max_steps, "max_time": 3600.0}
    n = len(nw) * len(nc)
    out = Path(args.out)
    t = time.perf_counter()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        cluster_start = time.perf_counter() - t
        walls = {"pool": [], "dask": []}
        per_point = {"pool": [], "dask": []}
        busy = {"pool": [], "dask": []}          # the points' own time over 2 workers
        rows = {}
        for _ in range(args.repeats):
            for executor in ("pool", "dask"):
                rows[executor], wall = sweep(nw, nc, options, executor, cluster)
                walls[executor].append(wall)
                per_point[executor] += [r["elapsed_s"] for r in rows[executor]]
                busy[executor].append(sum(r["elapsed_s"] for r in rows[executor]) / 2)
                print(f"{executor}: {n} points in {wall:.1f} s", flush=True)
    same = strip(rows["pool"]) == strip(rows["dask"])
    rate = {k: 3600.0 * n / statistics.median(v) for k, v in walls.items()}
    point_s = {k: statistics.median(v) for k, v in per_point.items()}
    report = {
        "grid": {"nw": nw, "nc": nc}, "points": n, "curl_options": options,
        "repeats": args.repeats, "wall_s": walls, "median_wall_s":
            {k: statistics.median(v) for k, v in walls.items()},
        "points_per_hour": rate, "dask_over_pool_rate": rate["dask"] / rate["pool"],
        "median_point_s": point_s,
        "median_busy_s": {k: statistics.median(v) for k, v in busy.items()}, "rows_equal": same, "cluster_start_s": cluster_start,
        "machine": f"{os.cpu_count()} cores, shared with other jobs (timings pessimistic)",
    }
    write_json(out / "bench.json", report)
    write_phase_csv(rows["pool"], out / "phase.csv")
    plot_phase_diagram(rows["pool"], out / "phase_diagram.png",
                       title=f"bench grid, {args.max_steps} FIRE steps per point (not converged)")
    plot_phase_trends(rows["pool"], out / "phase_trends.png", knitted_aspect=4.0 / 3.0)
    lines = [
        f"# Fabric phase sweep: local pool vs Dask LocalCluster ({n} B-spline points)", "",
        f"Grid N_w {nw} x N_c {nc}, {args.max_steps} FIRE steps per point (same work on both; "
        f"rows equal: {same}), {args.repeats} alternating runs, medians; "
        f"{report['machine']}.", "",
        "| executor | median wall (s) | points / hour | median point (s) | "
        "point time / 2 workers (s) |",
        "|---|---:|---:|---:|---:|"]
    for k, name in (("pool", "local pool, 2 processes"),
                    ("dask", "Dask LocalCluster, 2 workers x 1 thread")):
        lines.append(f"| {name} | {report['median_wall_s'][k]:.1f} | {rate[k]:.0f} | "
                     f"{point_s[k]:.1f} | {report['median_busy_s'][k]:.1f} |")
    lines += ["", f"Dask / pool points per hour: {report['dask_over_pool_rate']:.2f} "
              f"(cluster start-up {cluster_start:.1f} s, not in the Dask walls; the pool is "
              "started by each sweep, its start-up and the workers' imports are in its walls; "
              "the cluster's workers stay warm between sweeps)."]
    write_text(out / "bench.md", "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
