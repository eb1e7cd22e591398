"""The beam verification gallery: each closed-form check as a picture.

``knitfem gallery --out DIR`` writes PNG plots, .vtu shapes (with a .pvd per
load history), a tube render and ``summary.json`` with every error.
"""
import json
import time
from pathlib import Path

import numpy as np

from ..io import beam_mesh, save_figure, write_beam_state, write_json, write_series
from ..solve.stability import lowest_eigenvalues
from . import cases, closed_form


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def roll_up(out, plt):
    """End moment 0 -> 2 pi EI/L, 16 elements: shapes and the .vtu series."""
    model = cases.cantilever_end_moment(16, 2 * np.pi)
    loads = np.linspace(0.1, 1.0, 10)
    steps = model.solve(loads=loads)
    fig, ax = plt.subplots(figsize=(5.5, 5))
    files = []
    for s in steps:
        ax.plot(s.state.x[:, 0], s.state.x[:, 1], ".-", lw=1, ms=3,
                label=f"M L/EI = {2 * s.load:.1f}$\\pi$" if s.load in (0.5, 1.0) else None)
        files.append(write_beam_state(out / "rollup" / f"rollup_{s.load:.2f}.vtu", model, s.state))
    write_series(out / "rollup" / "rollup.pvd", files, loads)
    ax.plot([0, 1], [0, 0], "k--", lw=0.8)
    ax.set_aspect("equal")
    ax.set_title("a. Cantilever rolled up by an end moment (16 elements)")
    ax.set_xlabel("x / L")
    ax.set_ylabel("y / L")
    ax.legend(loc="upper right")
    fig.tight_layout()
    save_figure(fig, out / "a_rollup.png")
    return {"tip_distance_from_root_over_L": float(np.linalg.norm(steps[-1].state.x[-1])),
            "newton_iterations_per_step": [s.iterations for s in steps]}, model, steps[-1].state


def column_buckling(out, plt):
    """Lowest eigenvalue of the tangent against the compressive load."""
    fig, ax = plt.subplots(figsize=(6, 4))
    result = {}
    for ends, exact in (("clamped", 4 * np.pi**2), ("pinned", np.pi**2)):
        model = cases.column(32, ends)
        crit = cases.critical_load(model, (0.8 * exact, 1.2 * exact))
        result[ends] = {"critical_load": crit.load, "exact": exact,
                        "relative_error": crit.load / exact - 1}
        loads = np.linspace(0.0, 1.3, 14) * exact
        lows, state = [], model.initial_state()
        for lam in loads:
            state = model.solve(loads=[lam], state=state, start=lam)[-1].state
            K = model.internal_forces(state, free=~model.fixed)[2]
            lows.append(lowest_eigenvalues(K, 1)[0])
        ax.plot(loads / exact, np.array(lows) / max(lows), "o-", ms=3, label=f"{ends} ends")
    ax.axhline(0, color="k", lw=0.8)
    ax.axvline(1, color="k", ls="--", lw=0.8)
    ax.set_xlabel("load / Euler load")
    ax.set_ylabel("lowest eigenvalue of K (normalised)")
    ax.set_title("b. Column buckling from the tangent (32 elements)")
    ax.legend()
    fig.tight_layout()
    save_figure(fig, out / "b_column_buckling.png")
    return result


def elastica(out, plt):
    """Tip of a cantilever under a dead tip load, alpha = P L^2/EI up to 10."""
    model = cases.cantilever_tip_load(64, alpha=10.0)
    loads = np.linspace(0.05, 1.0, 20)
    steps = model.solve(loads=loads)
    tips = np.array([s.state.x[-1] for s in steps])
    alphas = np.linspace(0.05, 10, 200)
    exact = np.array([closed_form.elastica_tip_load(a)[:2] for a in alphas])
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(alphas, 1 - exact[:, 0], "k-", lw=1, label="elliptic integrals: 1 - x/L")
    ax.plot(alphas, exact[:, 1], "k--", lw=1, label="elliptic integrals: deflection/L")
    ax.plot(10 * loads, 1 - tips[:, 0], "o", ms=4, label="knitfem, 64 elements")
    ax.plot(10 * loads, -tips[:, 1], "s", ms=4, label="knitfem, 64 elements")
    ax.set_xlabel("P L$^2$ / EI")
    ax.set_ylabel("tip displacement / L")
    ax.set_title("c. Cantilever elastica under a dead tip load")
    ax.legend()
    fig.tight_layout()
    save_figure(fig, out / "c_elastica.png")
    x, d, _ = closed_form.elastica_tip_load(10.0)
    return {"tip_error_over_L": float(np.hypot(tips[-1, 0] - x, -tips[-1, 1] - d)),
            "newton_iterations_per_step": [s.iterations for s in steps]}


def bend45(out, plt):
    """Tip positions of the 45-degree bend against the published values."""
    loads = np.linspace(50, 600, 12)
    fig, ax = plt.subplots(figsize=(6, 4))
    result = {}
    for n, style in ((8, "o"), (32, "-")):
        model = cases.bend45(n)
        steps = model.solve(loads=loads)
        tips = np.array([cases.tip_position(model, s.state) for s in steps])
        for k, name in enumerate("xyz"):
            ax.plot(loads, tips[:, k], style, ms=4, color=f"C{k}",
                    label=f"{name}, {n} elements" if n == 32 or k == 0 else None)
        result[f"{n}_elements"] = {f"{int(s.load)}": cases.tip_position(model, s.state).tolist()
                                  for s in steps if s.load in (300.0, 450.0, 600.0)}
        if n == 32:
            write_beam_state(out / "bend45_F600.vtu", model, steps[-1].state)
            final = (model, steps[-1].state)
    for F, tip in closed_form.BEND45_SIMO_VU_QUOC_8.items():
        ax.plot([F] * 3, tip, "kx", ms=7, label="Simo & Vu-Quoc 1986" if F == 300 else None)
    ax.set_xlabel("tip load F")
    ax.set_ylabel("tip position")
    ax.set_title("d. 45-degree bend (Bathe & Bolourchi 1979)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, out / "d_bend45.png")
    return result, final


def greenhill():
    """Critical axial torque of the clamped shaft against Greenhill's closed form."""
    crit = cases.critical_load(cases.greenhill_shaft(32), (8.0, 10.0))
    exact = closed_form.greenhill_clamped()
    return {"critical_torque_ML_over_EI": crit.load, "exact": exact,
            "relative_error": crit.load / exact - 1}


def run(out, render=True, log=print):
    """Run every check, write the gallery into ``out``; returns the summary."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    plt = _plt()
    summary, t0 = {}, time.perf_counter()
    log("a. roll-up ...")
    summary["a_rollup"], roll_model, roll_state = roll_up(out, plt)
    log("b. column buckling ...")
    summary["b_column"] = column_buckling(out, plt)
    log("c. elastica ...")
    summary["c_elastica"] = elastica(out, plt)
    log("d. 45-degree bend ...")
    summary["d_bend45"], (bend_model, bend_state) = bend45(out, plt)
    log("e. Greenhill ...")
    summary["e_greenhill"] = greenhill()
    if render:
        from ..viz.render import render_rods
        log("rendering ...")
        render_rods(out / "bend45_F600.png", beam_mesh(bend_model, bend_state), radius=1.5,
                    title="45-degree bend, F = 600 (32 elements)", view=(1.0, -1.4, 0.9))
        render_rods(out / "rollup.png", beam_mesh(roll_model, roll_state), radius=0.02,
                    scalars=None,
                    title="end moment 2 pi EI/L: a full circle", view="xy", camera_up=(0, 1, 0))
    summary["elapsed_s"] = time.perf_counter() - t0
    write_json(out / "summary.json", summary)
    return summary


GALLERY_OUTPUTS = ("a_rollup.png", "b_column_buckling.png", "c_elastica.png", "d_bend45.png",
                   "bend45_F600.png", "bend45_F600.vtu", "rollup.png", "rollup/rollup.pvd",
                   "rollup/rollup_*.vtu", "summary.json")


def add_parser(subparsers):
    """Register ``gallery`` on the CLI's sub-parsers; returns the parser."""
    from ..cli import add_command
    from ..options import OptionSet
    p = add_command(subparsers, "gallery", _run_command, OptionSet(), GALLERY_OUTPUTS,
                    help="beam verification gallery: plots, .vtu, render")
    p.add_argument("--out", default="studies/results/gallery", help="output folder")
    p.add_argument("--no-render", action="store_true", help="skip the pyvista renders")
    p.add_argument("--quiet", action="store_true")
    return p


def _run_command(args):
    from ..cli import run_folder
    with run_folder(args):
        summary = run(args.out, render=not args.no_render,
                      log=(lambda *a: None) if args.quiet else print)
    if not args.quiet:
        print(json.dumps(summary, indent=2))
        print(f"wrote {args.out}")
    return 0
