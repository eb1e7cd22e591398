"""Run time against error of a beam curl relaxation (issue 12's plot, beam side).

    python studies/beam_time_vs_error.py --run RUN [--out DIR] [--earlier CSV]

Reads a ``knitfem curl --out RUN`` folder (finished or not): the checkpoint's
increments (homotopy lam, iterations, end residual, relaxation seconds, accepted)
and the path's one .vtu per accepted increment, classifies every increment's
shape with the shared curl analysis and writes ``DIR/time_vs_error_beam_<nw>x<nc>.png``
(edge rolls, and the end residual of each increment, against the summed relaxation
time) and ``.csv`` (one row per increment).  The beam relaxation is a homotopy: its
intermediate shapes are equilibria at lam < 1 (part of the pre-stretch and of the
straightening), not iterates of the final problem, so the rolls show how the answer
forms along the path and the time it takes; the error of the answer itself is the final
increment's residual (and its friction rounds).  A finished run's summary, when
present, adds its final rolls.  A run carried over sessions may have lost the path
.vtu of its early increments; ``--earlier CSV`` (this script's csv from before) fills
those increments' rolls, matched by position and lam.
"""
import argparse
import csv
import json
from dataclasses import asdict
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from knitfem.scenes.curl import increments_of  # noqa: E402

EDGES = ("left", "right", "top", "bottom")


def increments(run):
    data = np.load(run / "checkpoint.npz")
    table = [asdict(inc) for inc in increments_of(data, run / "checkpoint.npz")]
    return json.loads(str(data["scene"])), table


def path_rows(run, scene_dict, table):
    """One row per increment: lam, summed seconds, residual, accepted, rolls."""
    import meshio
    from knitfem.analysis.curl import swatch_curl
    from knitfem.scenes.fabric import FabricScene, build
    _, swatch, _ = build(FabricScene(**scene_dict))
    rows, elapsed, step = [], 0.0, 0
    for inc in table:
        elapsed += inc["seconds"]
        row = {"lam": inc["lam"], "relax_s": elapsed, "residual": inc["residual"],
               "iterations": int(inc["iterations"]), "accepted": bool(inc["accepted"])}
        if inc["accepted"]:
            step += 1
            vtu = run / "path" / f"step_{step:03d}.vtu"
            if vtu.exists():
                shape = swatch_curl(meshio.read(vtu).points, swatch)
                row.update(curl=shape.curl, **{f"roll_{e}": shape.roll_deg[e] for e in EDGES})
        rows.append(row)
    return rows


def fill_from_earlier(rows, earlier):
    """Rolls of increments without a path .vtu, from an earlier csv of the same run."""
    with open(earlier, newline="") as f:
        old = list(csv.DictReader(f))
    for row, prev in zip(rows, old):
        if abs(float(prev["lam"]) - row["lam"]) > 1e-9:
            raise SystemExit(f"--earlier: {earlier} is another path (lam {prev['lam']} where "
                             f"this run has {row['lam']:.6g})")
        if "roll_left" not in row and prev.get("curl"):
            row.update(curl=prev["curl"], **{f"roll_{e}": float(prev[f"roll_{e}"]) for e in EDGES})
    return rows


def plot(rows, summary, png, title):
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
    shaped = [r for r in rows if "roll_left" in r]
    for edge in EDGES:
        ax1.plot([r["relax_s"] for r in shaped], [r[f"roll_{edge}"] for r in shaped], "o-",
                 ms=3, label=edge)
    for r in shaped:
        ax1.annotate(f"{r['lam']:.2f}", (r["relax_s"], r["roll_top"]), fontsize=6,
                     textcoords="offset points", xytext=(0, 4), ha="center")
    if summary and summary.get("roll_deg"):
        t = rows[-1]["relax_s"]
        for edge in EDGES:
            ax1.plot([t], [summary["roll_deg"][edge]], "k*", ms=8)
    ax1.set_ylabel("edge roll (deg, + to the front)\n(labels: homotopy lam)")
    ax1.legend(fontsize=8)
    ax1.set_title(title)
    ok = [r for r in rows if r["accepted"]]
    bad = [r for r in rows if not r["accepted"]]
    ax2.semilogy([r["relax_s"] for r in ok], [max(r["residual"], 1e-16) for r in ok], "o",
                 ms=3, label="increment's end residual")
    if bad:
        ax2.semilogy([r["relax_s"] for r in bad], [max(r["residual"], 1e-16) for r in bad],
                     "rx", label="failed increment")
    ax2.axhline(1e-8, color="grey", ls="--", lw=0.8, label="final tolerance 1e-8")
    ax2.set_xlabel("summed relaxation time (s)")
    ax2.set_ylabel("relative residual")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--run", type=Path, required=True, help="a knitfem curl --out folder")
    p.add_argument("--out", type=Path, default=None, help="default: the run folder")
    p.add_argument("--earlier", type=Path, default=None,
                   help="an earlier csv of this run: rolls of increments whose .vtu is lost")
    args = p.parse_args()
    if not (args.run / "checkpoint.npz").exists():
        p.error(f"--run: {args.run} holds no checkpoint.npz (a knitfem curl --out folder)")
    out = args.out or args.run
    out.mkdir(parents=True, exist_ok=True)
    scene, table = increments(args.run)
    tag = f"{scene['nw']}x{scene['nc']}"
    summary_path = args.run / f"curl_{tag}.json"
    summary = json.loads(summary_path.read_text()) if summary_path.exists() else None
    rows = path_rows(args.run, scene, table)
    if args.earlier:
        rows = fill_from_earlier(rows, args.earlier)
    with open(out / f"time_vs_error_beam_{tag}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["lam", "relax_s", "iterations", "residual", "accepted",
                                          "curl"] + [f"roll_{e}" for e in EDGES], restval="")
        w.writeheader()
        w.writerows(rows)
    state = ("finished" if summary and summary.get("converged") else
             "unfinished" if summary is None else "not converged")
    plot(rows, summary, out / f"time_vs_error_beam_{tag}.png",
         f"beam {tag}, alpha {scene['alpha']}: run time against error ({state})")
    for r in rows:
        rolls = " / ".join(f"{r[f'roll_{e}']:+.0f}" for e in EDGES) if "roll_left" in r else "-"
        print(f"lam {r['lam']:.3f}  {r['relax_s']:8.0f} s  residual {r['residual']:.1e}  "
              f"{'ok  ' if r['accepted'] else 'FAIL'}  {r.get('curl', '-'):>10}  {rolls}")


if __name__ == "__main__":
    main()
