"""Cross-check of the two independent models on the S-rod (issue 4).

The B-spline yarn model (Kaldor-style, no twist energy) against the
Simo-Reissner beam at GJ/EI = 1e-3: z(c) curves on one plot, a table of the
differences, each model's run time, the B-spline model's convergence with
16, 32 and 64 segments, and the time to relax the S-rod at c/L = 0.6 against
one Newton solve of the beam at the same point.

    python studies/crosscheck_popup.py --out studies/results/crosscheck_popup
"""
import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from knitfem.bspline import relax_dynamic, relax_static  # noqa: E402
from knitfem.io import save_figure, write_json  # noqa: E402
from knitfem.scenes.popup_output import signed_height  # noqa: E402
from knitfem.scenes.srod import SRod, popup  # noqa: E402
from knitfem.scenes.srod_bspline import bspline_popup, max_height, srod_yarn_model  # noqa: E402
from knitfem.solve.continuation import FixedParameter  # noqa: E402
from knitfem.beam.parametric import ParametricProblem  # noqa: E402
from knitfem.solve.newton import NewtonError, newton  # noqa: E402
from knitfem.solve.stability import negative_eigenvalue_count  # noqa: E402

GJ = 1e-3
C = 0.6
BUMP = 0.01          # out-of-plane start: 0.01 L half sine, both models


def relax_point(segments, method):
    """Seconds and max|z|/L to relax the S-rod at c/L = C from the planar
    elastica plus the bump, to a relative residual of 1e-6."""
    srod = SRod()
    model = srod_yarn_model(srod, C, segments)
    q = model.yarns[0].control.copy()
    q[:, 2] += BUMP * srod.length * np.sin(np.pi * np.linspace(0, 1, q.shape[0]))
    y0 = model.reduce(q)
    t = time.perf_counter()
    result = {"static": relax_static, "dynamic": relax_dynamic}[method](model, y0, rtol=1e-6)
    seconds = time.perf_counter() - t
    return seconds, max_height(model.control_points(result.y)) / srod.length, result.iterations


def beam_point(gj):
    """One Newton solve of the beam at c/L = C from the same start (None if
    Newton fails from there)."""
    srod = SRod(gj_over_ei=gj)
    model = srod.model(C)
    problem = ParametricProblem(model)
    state = model.initial_state()
    s = np.linspace(0, 1, state.x.shape[0])
    state.x[:, 2] += BUMP * srod.length * np.sin(np.pi * s)
    t = time.perf_counter()
    try:
        result = newton(FixedParameter(problem, C), state)
    except NewtonError:
        return None
    seconds = time.perf_counter() - t
    _, J, _, _ = problem.evaluate(result.state, C, True)
    return (seconds, float(np.abs(result.state.x[:, 2]).max() / srod.length), result.iterations,
            negative_eigenvalue_count(J))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="studies/results/crosscheck_popup")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    beam = popup(SRod(gj_over_ei=GJ), c_step=0.05)
    beam_23 = popup(SRod(), c_step=0.05)
    yarn = {n: bspline_popup(SRod(), segments=n) for n in (16, 32, 64)}

    rows = []
    z_beam = {round(s.c_over_L, 3): s.max_abs_z_over_L for s in beam.samples}
    for s in yarn[32].samples:
        c = round(s.c_over_L, 3)
        rows.append({"c_over_L": c, "beam": z_beam[c],
                     **{f"bspline_{n}": next(x.max_abs_z_over_L for x in yarn[n].samples
                                             if round(x.c_over_L, 3) == c) for n in yarn},
                     "difference_32": s.max_abs_z_over_L - z_beam[c]})
    print("max|z|/L: beam (GJ/EI = 1e-3, 60 el.) vs B-spline (16, 32, 64 segments)")
    print(" c/L    beam     B16      B32      B64     B32-beam")
    for r in rows:
        print(f" {r['c_over_L']:.2f}  {r['beam']:.5f}  {r['bspline_16']:.5f}  {r['bspline_32']:.5f}"
              f"  {r['bspline_64']:.5f}  {r['difference_32']:+.5f}")
    crit = {"beam_gj_1e-3": beam.critical_c_over_L, "beam_gj_2/3": beam_23.critical_c_over_L,
            **{f"bspline_{n}": yarn[n].critical_c_over_L for n in yarn}}
    times = {"beam_continuation_s": beam.elapsed_s,
             **{f"bspline_{n}_sweep_s": yarn[n].elapsed_s for n in yarn}}
    print("critical c/L:", {k: round(v, 5) for k, v in crit.items()})
    print("run time of the sweep 0.95 -> 0.45:", {k: round(v, 3) for k, v in times.items()})

    point = {}
    for n in (32, 64):
        for method in ("static", "dynamic"):
            reps = [relax_point(n, method) for _ in range(5)]
            point[f"bspline_{n}_{method}"] = {"s": float(np.median([r[0] for r in reps])),
                                              "z_over_L": reps[0][1], "iterations": reps[0][2]}
    for gj in (GJ, 2.0 / 3.0):
        reps = [beam_point(gj) for _ in range(5)]
        if reps[0] is None:
            point[f"beam_newton_gj_{gj:.3g}"] = {"failed": "Newton from planar + bump diverged"}
            continue
        point[f"beam_newton_gj_{gj:.3g}"] = {
            "s": float(np.median([r[0] for r in reps])), "z_over_L": reps[0][1],
            "iterations": reps[0][2], "negative_eigenvalues": reps[0][3]}
    runs = [popup(SRod(gj_over_ei=GJ), c_to=C, c_step=0.05) for _ in range(3)]
    on_branch = runs[0]
    point["beam_continuation_0.95_to_0.6"] = {
        "s": float(np.median([r.elapsed_s for r in runs])),
        "z_over_L": on_branch.samples[-1].max_abs_z_over_L,
        "iterations": sum(p.iterations for _, b in on_branch.branches() for p in b.points)}
    newton_s = point["beam_newton_gj_0.667"]["s"]
    reference = point["beam_continuation_0.95_to_0.6"]["s"]
    print(f"relaxing the S-rod at c/L = {C} to a relative residual of 1e-6, medians "
          "(ratios to the beam's Newton solve at GJ/EI = 2/3 "
          "and to its continuation 0.95 -> 0.6):")
    for k, v in point.items():
        if "failed" in v:
            print(f"  {k:30s} {v['failed']}")
            continue
        print(f"  {k:30s} {v['s']:.3f} s  z/L = {v['z_over_L']:.4f}  ({v['iterations']} it.)"
              f"  {v['s'] / newton_s:6.1f} x  {v['s'] / reference:6.2f} x")

    fig, ax = plt.subplots(figsize=(7, 4.6))
    for name, res, style in (("beam, GJ/EI = 1e-3", beam, "C0-"),
                             ("beam, GJ/EI = 2/3", beam_23, "C0--")):
        pts = [p for p in res.popped[0].points] if res.popped else []
        ax.plot([p.lam for p in res.planar.points if p.lam > res.critical_c_over_L] +
                [p.lam for p in pts],
                [0.0 for p in res.planar.points if p.lam > res.critical_c_over_L] +
                [abs(signed_height(p.state)) / res.srod.length for p in pts], style, label=name)
    for n, marker in ((16, "s"), (32, "o"), (64, "^")):
        ax.plot([s.c_over_L for s in yarn[n].samples],
                [s.max_abs_z_over_L for s in yarn[n].samples],
                marker, color="C3", mfc="none" if n != 32 else "C3", ms=5,
                label=f"B-spline model, {n} segments")
    ax.invert_xaxis()
    ax.set_xlabel("c / L")
    ax.set_ylabel("max |z| / L")
    ax.set_title("S-rod pop-up: beam vs independent B-spline yarn model")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, out / "crosscheck_popup.png")
    write_json(out / "crosscheck_popup.json",
               {"table": rows, "critical_c_over_L": crit, "sweep_times": times,
                "point_c_0.6": point})
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
