"""Benchmark of the beam core (issue 2): error vs elements vs wall time for the
closed-form cases a-c, assembly time from 1e2 to 1e5 elements, Newton
iterations per load step.

    python studies/bench_beam.py --out studies/results/bench_beam

Writes bench_beam.json, bench_beam.md (the tables quoted in README) and
bench_beam.png.  Times are medians of repeated runs after a warm-up (numba
compiles on first use; that one-off cost is reported separately).
"""
import argparse
import json
import time
from pathlib import Path

import numpy as np

from knitfem import Section
from knitfem.verify import cases, closed_form


def median_time(fn, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times)), out


def case_half_circle(n, section=None):
    model = cases.cantilever_end_moment(n, moment=np.pi, section=section)
    steps = model.solve(loads=np.linspace(0.1, 1.0, 10))
    tip = steps[-1].state.x[-1, :2]
    return float(np.linalg.norm(tip - closed_form.end_moment_tip(np.pi))), steps


def case_column(n, section=None):
    crit = cases.critical_load(cases.column(n, "clamped"), (0.8 * 4 * np.pi**2, 1.2 * 4 * np.pi**2))
    return abs(crit.load / (4 * np.pi**2) - 1), None


def column_prebuckling(n, section=None):
    """Newton along the column's fundamental path up to 0.9 of the Euler load."""
    model = cases.column(n, "clamped")
    return None, model.solve(loads=np.linspace(0.09, 0.9, 10) * 4 * np.pi**2)


def case_elastica(n, section=None):
    model = cases.cantilever_tip_load(n, alpha=10.0, section=section)
    steps = model.solve(loads=np.linspace(0.1, 1.0, 10))
    x, d, _ = closed_form.elastica_tip_load(10.0)
    tip = steps[-1].state.x[-1]
    return float(np.hypot(tip[0] - x, -tip[1] - d)), steps


CASES = {"a_half_circle": case_half_circle, "b_clamped_column": case_column,
         "c_elastica_PL2_EI_10": case_elastica}


def cold_start():
    """Seconds for a fresh interpreter to import knitfem and solve one small
    problem with an empty numba cache (the one-off compilation cost)."""
    import os
    import subprocess
    import sys
    import tempfile
    code = ("import numpy as np; from knitfem.verify import cases; "
            "cases.cantilever_tip_load(8).solve(loads=[1.0])")
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True, env=env)
        cold = time.perf_counter() - t
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True, env=env)
        warm = time.perf_counter() - t
    print(f"  first run {cold:.1f} s (compiling), next run {warm:.1f} s (cached)")
    return {"cold_s": cold, "cached_s": warm}


def convergence(sizes, repeat):
    rows = []
    for name, fn in CASES.items():
        for n in sizes:
            t, (err, _) = median_time(lambda: fn(n), repeat)
            rows.append({"case": name, "elements": n, "error": err, "wall_s": t})
            print(f"  {name:22s} n={n:4d}  error {err:.3e}  {1e3 * t:8.1f} ms")
    return rows


def assembly(sizes, repeat):
    from knitfem import BeamModel, Rod
    section = Section.circle(3.0, E=1.0)
    rows = []
    rng = np.random.default_rng(1)
    for n in sizes:
        model = BeamModel()
        rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 105.0, n, section))
        model.clamp(rod, "start")
        state = model.retract(model.initial_state(), 1e-2 * rng.normal(size=6 * (n + 1)))
        free = ~model.fixed
        model.internal_forces(state, free=free)            # pattern + warm-up
        t_res, _ = median_time(lambda: model.internal_forces(state, tangent=False), repeat)
        t_tan, _ = median_time(lambda: model.internal_forces(state, free=free), repeat)
        rows.append({"elements": n, "residual_ms": 1e3 * t_res, "residual_tangent_ms": 1e3 * t_tan,
                     "us_per_element": 1e6 * t_tan / n})
        print(f"  n={n:6d}  residual {1e3 * t_res:8.2f} ms   residual+tangent {1e3 * t_tan:8.2f} ms")
    return rows


def newton_iterations():
    yarn = Section.circle(3.0 / 105.0, E=1.0)       # the S-rod's slenderness, L = 1
    rows = []
    for label, section in (("stiff (EA L^2/EI = 1e8)", None), ("yarn-like (L/d = 35)", yarn)):
        for name, fn in (("a_half_circle", case_half_circle),
                         ("b_clamped_column (to 0.9 P_E)", column_prebuckling),
                         ("c_elastica_PL2_EI_10", case_elastica)):
            if section is not None and name.startswith("b"):
                continue                                  # the column scene is stiff only
            _, steps = fn(64, section)
            its = [s.iterations for s in steps]
            rows.append({"section": label, "case": name, "steps": len(steps),
                         "iterations_per_step": its, "max": max(its),
                         "median": float(np.median(its)),
                         "final_relative_residual": max(s.history[-1] for s in steps),
                         "stopped_at_roundoff_floor": any(s.roundoff_limited for s in steps)})
            print(f"  {label:24s} {name:22s} iterations {its}")
    return rows


def markdown(conv, asm, newton, compile_s):
    lines = ["| case | elements | error | wall time (ms) |", "|---|---:|---:|---:|"]
    lines += [f"| {r['case']} | {r['elements']} | {r['error']:.2e} | {1e3 * r['wall_s']:.1f} |"
              for r in conv]
    lines += ["", "| elements | residual (ms) | residual + tangent (ms) | per element (us) |",
              "|---:|---:|---:|---:|"]
    lines += [f"| {r['elements']:.0e} | {r['residual_ms']:.2f} | {r['residual_tangent_ms']:.2f} | "
              f"{r['us_per_element']:.2f} |" for r in asm]
    lines += ["", "| section | case (64 elements, 10 steps) | Newton iterations per step | "
              "max | final relative residual |", "|---|---|---|---:|---:|"]
    lines += [f"| {r['section']} | {r['case']} | {r['iterations_per_step']} | {r['max']} | "
              f"{r['final_relative_residual']:.1e}"
              f"{' (round-off floor)' if r['stopped_at_roundoff_floor'] else ''} |" for r in newton]
    lines += ["", f"Start-up, import + one small solve in a fresh process: {compile_s['cold_s']:.1f} s "
              f"with an empty numba cache (compilation), {compile_s['cached_s']:.1f} s cached."]
    return "\n".join(lines)


def plot(conv, asm, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for name in CASES:
        rows = [r for r in conv if r["case"] == name]
        n = np.array([r["elements"] for r in rows])
        err = np.array([max(r["error"], 1e-16) for r in rows])
        t = np.array([r["wall_s"] for r in rows])
        axes[0].loglog(n, err, "o-", label=name)
        axes[1].loglog(t, err, "o-", label=name)
    n = np.array([8, 256])
    axes[0].loglog(n, 0.3 * (n / 8.0) ** -2.0, "k:", label="slope -2")
    axes[0].set_xlabel("elements")
    axes[0].set_ylabel("error (length/L or relative load)")
    axes[1].set_xlabel("wall time (s)")
    axes[1].set_ylabel("error")
    axes[0].legend(fontsize=8)
    axes[0].set_title("error vs elements")
    axes[1].set_title("error vs run time")
    n = np.array([r["elements"] for r in asm])
    axes[2].loglog(n, [r["residual_tangent_ms"] for r in asm], "o-", label="residual + tangent")
    axes[2].loglog(n, [r["residual_ms"] for r in asm], "s-", label="residual")
    axes[2].loglog(n, 30 * n / 1e4, "k:", label="linear, 30 ms at 1e4")
    axes[2].set_xlabel("elements")
    axes[2].set_ylabel("ms")
    axes[2].set_title("assembly time (2 cores)")
    axes[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="studies/results/bench_beam")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    compile_s = cold_start()
    case_elastica(8)                                   # warm this process
    print("error vs elements vs wall time")
    conv = convergence([8, 16, 32, 64, 128, 256], repeat=3)
    print("assembly")
    asm = assembly([100, 1000, 10000, 100000], repeat=args.repeat * 2 + 1)
    print("Newton iterations per load step")
    newton = newton_iterations()
    result = {"convergence": conv, "assembly": asm, "newton": newton,
              "startup": compile_s}
    (out / "bench_beam.json").write_text(json.dumps(result, indent=2))
    (out / "bench_beam.md").write_text(markdown(conv, asm, newton, compile_s) + "\n")
    plot(conv, asm, out / "bench_beam.png")
    print(markdown(conv, asm, newton, compile_s))


if __name__ == "__main__":
    main()
