"""Benchmark of the beam core (issue 2): error vs elements vs wall time for the
closed-form cases a-c, assembly time from 1e2 to 1e5 elements, Newton
iterations per load step with the measured round-off floor of the residual, and
that floor vs the axial-to-bending stiffness ratio EA L^2/EI.

    python studies/bench_beam.py --out studies/results/bench_beam
    python studies/bench_beam.py --only newton     # Newton tables only (~5 s)

Writes bench_beam.json, bench_beam.md (the tables quoted in README) and
bench_beam.png (``--only newton`` refreshes the Newton tables in the .json and
.md, keeping the other tables from the previous full run).  Times are medians
of repeated runs after a warm-up (numba compiles on first use; that one-off
cost is reported separately).
"""
import argparse
import json
import time
from pathlib import Path

import numpy as np

from knitfem import Section
from knitfem.io import save_figure, write_json, write_text
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
    return float(np.linalg.norm(tip - closed_form.end_moment_tip(np.pi))), steps, model


def case_column(n):
    crit = cases.critical_load(cases.column(n, "clamped"), (0.8 * 4 * np.pi**2, 1.2 * 4 * np.pi**2))
    return abs(crit.load / (4 * np.pi**2) - 1), None, None


def column_prebuckling(n):
    """Newton along the column's fundamental path up to 0.9 of the Euler load."""
    model = cases.column(n, "clamped")
    return None, model.solve(loads=np.linspace(0.09, 0.9, 10) * 4 * np.pi**2), model


def case_elastica(n, section=None):
    model = cases.cantilever_tip_load(n, alpha=10.0, section=section)
    steps = model.solve(loads=np.linspace(0.1, 1.0, 10))
    x, d, _ = closed_form.elastica_tip_load(10.0)
    tip = steps[-1].state.x[-1]
    return float(np.hypot(tip[0] - x, -tip[1] - d)), steps, model


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
            t, (err, *_) = median_time(lambda: fn(n), repeat)
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
        print(f"  n={n:6d}  residual {1e3 * t_res:8.2f} ms   "
              f"residual+tangent {1e3 * t_tan:8.2f} ms")
    return rows


def residual_and_floor(model, step):
    """Relative residual |r| / ref of a converged step, recomputed at its state, and
    the estimated round-off floor noise / ref there: Newton's own two numbers (the
    weighted residual norm and ``StaticProblem.noise``, both over ``evaluate``'s ref)."""
    problem = model.static_problem(step.load)
    r, _, ref = problem.evaluate(step.state, False)
    return problem.norm(r) / ref, problem.noise(step.state) / ref


def newton_row(steps, model):
    """Iterations per step; the largest relative residual over the steps (the
    first, smallest load, as a rule) and the last step's, each with its floor."""
    its = [s.iterations for s in steps]
    residual, floor = np.array([residual_and_floor(model, s) for s in steps]).T
    worst = int(np.argmax(residual))
    return {"steps": len(steps), "iterations_per_step": its, "max": max(its),
            "median": float(np.median(its)),
            "final_relative_residual": float(residual[worst]),
            "final_relative_residual_floor": float(floor[worst]),
            "stopped_at_roundoff_floor": any(s.roundoff_limited for s in steps),
            "last_step_relative_residual": float(residual[-1]),
            "last_step_roundoff_floor": float(floor[-1]),
            "relative_residual_per_step": residual.tolist(),
            "roundoff_floor_per_step": floor.tolist()}


def newton_iterations():
    yarn = Section.circle(3.0 / 105.0, E=1.0)       # the S-rod's slenderness, L = 1
    rows = []
    for label, section in (("stiff (EA L^2/EI = 1e8)", None), ("yarn-like (L/d = 35)", yarn)):
        runs = [("a_half_circle", lambda: case_half_circle(64, section)),
                ("b_clamped_column (to 0.9 P_E)", lambda: column_prebuckling(64)),
                ("c_elastica_PL2_EI_10", lambda: case_elastica(64, section))]
        for name, run in runs:
            if section is not None and name.startswith("b"):
                continue                                  # the column scene is stiff only
            _, steps, model = run()
            rows.append({"section": label, "case": name, **newton_row(steps, model)})
            print(f"  {label:24s} {name:22s} {summary(rows[-1])}")
    return rows


def summary(row):
    return (f"iterations {row['iterations_per_step']}  last step: residual "
            f"{row['last_step_relative_residual']:.1e}, floor "
            f"{row['last_step_roundoff_floor']:.1e}")


def stiffness_sweep(ratios=(1e2, 1e4, 1e6, 1e8)):
    """Elastica c at 64 elements with EA = GA = ratio EI/L^2 (EI = GJ = 1, L = 1):
    the round-off floor eps EA |x| / h grows with EA while the forces in play
    (P = 10 EI/L^2) do not."""
    rows = []
    for ratio in ratios:
        k = float(ratio)
        section = Section(EA=k, GA2=k, GA3=k, GJ=1.0, EI2=1.0, EI3=1.0)
        err, steps, model = case_elastica(64, section)
        rows.append({"EA_L2_over_EI": k, "tip_error_vs_inextensible": err,
                     **newton_row(steps, model)})
        print(f"  EA L^2/EI = {k:.0e}  {summary(rows[-1])}")
    return rows


def residual_cells(r):
    """'residual (floor)' of the worst and of the last step."""
    return (f"{r['final_relative_residual']:.1e} ({r['final_relative_residual_floor']:.1e}) | "
            f"{r['last_step_relative_residual']:.1e} ({r['last_step_roundoff_floor']:.1e})")


def newton_markdown(newton, sweep):
    """The Newton tables: iterations, relative residual |r|/ref and, in brackets,
    the estimated round-off floor noise/ref of the same state (Newton's target
    is 1e-10; it stops at the floor where that is higher)."""
    header = ("largest relative residual over the steps (floor) | last step (floor)")
    lines = ["Relative residual |r|/ref and, in brackets, its estimated round-off floor "
             "noise/ref at the same state; Newton's target is 1e-10, or the floor where "
             "that is higher.", "",
             f"| section | case (64 elements, 10 steps) | Newton iterations per step | max | "
             f"{header} |", "|---|---|---|---:|---:|---:|"]
    lines += [f"| {r['section']} | {r['case']} | {r['iterations_per_step']} | {r['max']} | "
              f"{residual_cells(r)} |" for r in newton]
    lines += ["", "Elastica c (P L^2/EI = 10, 64 elements, 10 steps), EA = GA = ratio "
              "EI/L^2, EI = GJ = 1:", "",
              f"| EA L^2/EI | iterations per step | {header} | last-step floor / ratio | "
              "tip vs inextensible closed form / L |", "|---:|---|---:|---:|---:|---:|"]
    lines += [f"| {r['EA_L2_over_EI']:.0e} | {r['iterations_per_step']} | {residual_cells(r)} | "
              f"{r['last_step_roundoff_floor'] / r['EA_L2_over_EI']:.1e} | "
              f"{r['tip_error_vs_inextensible']:.1e} |" for r in sweep]
    return lines


def markdown(conv, asm, newton, sweep, compile_s):
    lines = ["| case | elements | error | wall time (ms) |", "|---|---:|---:|---:|"]
    lines += [f"| {r['case']} | {r['elements']} | {r['error']:.2e} | {1e3 * r['wall_s']:.1f} |"
              for r in conv]
    lines += ["", "| elements | residual (ms) | residual + tangent (ms) | per element (us) |",
              "|---:|---:|---:|---:|"]
    lines += [f"| {r['elements']:.0e} | {r['residual_ms']:.2f} | {r['residual_tangent_ms']:.2f} | "
              f"{r['us_per_element']:.2f} |" for r in asm]
    lines += [""] + newton_markdown(newton, sweep)
    lines += ["", "Start-up, import + one small solve in a fresh process: "
              f"{compile_s['cold_s']:.1f} s "
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
    save_figure(fig, path, dpi=120)


def assembly_only(out, repeat):
    """Time the assembly alone (before/after a kernel change); the other tables
    come from the last full run."""
    case_elastica(8)                                   # warm this process (numba)
    print("assembly")
    rows = assembly([100, 1000, 10000, 100000], repeat=repeat)
    if out is not None and (out / "bench_beam.json").exists():
        result = json.loads((out / "bench_beam.json").read_text())
        result["assembly"] = rows
        write(out, result)


def newton_only(out):
    """Refresh the Newton tables; the timing tables come from the last full run."""
    path = out / "bench_beam.json"
    if not path.exists():
        raise SystemExit(f"{path} not found: run the full benchmark once first")
    result = json.loads(path.read_text())
    case_elastica(8)                                   # warm this process (numba)
    print("Newton iterations per load step")
    result["newton"] = newton_iterations()
    print("round-off floor vs EA L^2/EI (elastica c)")
    result["stiffness_sweep"] = stiffness_sweep()
    write(out, result)


def write(out, result):
    md = markdown(result["convergence"], result["assembly"], result["newton"],
                  result["stiffness_sweep"], result["startup"])
    write_json(out / "bench_beam.json", result)
    write_text(out / "bench_beam.md", md + "\n")
    print(md)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="studies/results/bench_beam")
    parser.add_argument("--repeat", type=int, default=5,
                        help="assembly timings: 2 x repeat + 1 runs each, median (the "
                             "convergence table takes 3)")
    parser.add_argument("--only", choices=("all", "newton", "assembly"), default="all",
                        help="'newton' / 'assembly': only those tables (other tables kept "
                             "from the previous run's bench_beam.json)")
    parser.add_argument("--dry-run", action="store_true",
                        help="print the tables, write nothing (e.g. --only assembly to compare)")
    args = parser.parse_args()
    if args.dry_run and args.only != "assembly":
        parser.error("--dry-run only with --only assembly (the other tables are written)")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.only == "newton":
        return newton_only(out)
    if args.only == "assembly":
        return assembly_only(None if args.dry_run else out, args.repeat * 2 + 1)
    compile_s = cold_start()
    case_elastica(8)                                   # warm this process
    print("error vs elements vs wall time")
    conv = convergence([8, 16, 32, 64, 128, 256], repeat=3)
    print("assembly")
    asm = assembly([100, 1000, 10000, 100000], repeat=args.repeat * 2 + 1)
    print("Newton iterations per load step")
    newton = newton_iterations()
    print("round-off floor vs EA L^2/EI (elastica c)")
    sweep = stiffness_sweep()
    write(out, {"convergence": conv, "assembly": asm, "newton": newton,
                "stiffness_sweep": sweep, "startup": compile_s})
    plot(conv, asm, out / "bench_beam.png")


if __name__ == "__main__":
    main()
