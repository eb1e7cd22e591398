"""Where a relaxed swatch turns: roll profiles of ``knitfem curl`` answers.

    python studies/roll_profile.py --runs RUN.json [RUN.json ...] --out DIR

For each run's summary JSON (its .vtu beside it) the tangent angle of the
central band of rows and of columns against the arclength from the centre
(knitfem.analysis.profile), the line fitted to the interior and each edge's
**local roll** (its roll minus that line's turning).  It separates an edge
rolled over (the paper's curl) from a swatch bending evenly along its length,
which also adds to the end rolls.  Writes ``DIR/roll_profile.png`` (two panels
per run: along the rows, x; up the columns, y) and ``DIR/roll_profile.md``
(rolls, local rolls, interior and classification curvatures).
"""
import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

EDGES = ("left", "right", "top", "bottom")


def named(summaries, paths):
    """Row names: size and alpha, with the run's folder when those repeat."""
    base = [f"{s['nw']} × {s['nc']}, α {s['alpha']:g}" for s in summaries]
    return [f"{b} ({Path(p).parent.name})" if base.count(b) > 1 else b
            for b, p in zip(base, paths)]


def profile_of(summary_path):
    """(summary, RollProfile) of one run."""
    import meshio
    from knitfem.analysis.profile import swatch_roll_profile
    from knitfem.scenes.fabric import FabricScene, build
    summary = json.loads(Path(summary_path).read_text())
    if summary.get("model", "beam") != "beam" or summary.get("curl") is None:
        raise SystemExit(f"{summary_path}: not a relaxed beam swatch")
    _, swatch, _ = build(FabricScene(**summary["scene"]))
    points = meshio.read(Path(summary_path).with_suffix(".vtu")).points
    return summary, swatch_roll_profile(points, swatch)


def plot(results, names, png):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for k, ((summary, p), name) in enumerate(zip(results, names)):
        colour = plt.cm.tab20(k % 20)
        for ax, s, angle, line in ((axes[0], p.s_x, p.theta, p.theta_fit),
                                   (axes[1], p.s_y, p.phi, p.phi_fit)):
            ax.plot(s, angle, "o-", ms=3, color=colour, label=f"{name}: {summary['curl']}")
            ax.plot(s, line, "--", lw=0.8, color=colour)
    axes[0].set(xlabel="arclength from the centre along the rows, x (mm)",
                ylabel="tangent angle relative to the centre (deg, + to the front)",
                title="rows (side edges at the ends)")
    axes[1].set(xlabel="arclength from the centre up the columns, y (mm)",
                title="columns (bottom and top edges at the ends)")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle("Roll profiles (dashed: the line fitted to the middle half; an edge's local "
                 "roll is its distance from it)", fontsize=10)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def table(results, names):
    rows = ["| run | curl | rolls L / R / T / B (deg) | local rolls L / R / T / B (deg) | "
            "κ_x, κ_y classification (1/mm) | κ_x, κ_y interior (1/mm) |",
            "|---|---|---|---|---|---|"]
    for (summary, p), name in zip(results, names):
        r, loc = summary["roll_deg"], p.local_roll_deg
        rows.append(f"| {name} | {summary['curl']} | " + " / ".join(f"{r[e]:+.0f}" for e in EDGES)
                    + " | " + " / ".join(f"{loc[e]:+.0f}" for e in EDGES)
                    + f" | {summary['curvature_x']:+.3f}, {summary['curvature_y']:+.3f} | "
                    f"{p.interior_curvature_x:+.3f}, {p.interior_curvature_y:+.3f} |")
    return "\n".join(rows) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", nargs="+", required=True, help="curl summary JSON files")
    parser.add_argument("--out", required=True, help="output folder")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    results = [profile_of(path) for path in args.runs]
    names = named([summary for summary, _ in results], args.runs)
    plot(results, names, out / "roll_profile.png")
    text = table(results, names)
    (out / "roll_profile.md").write_text(f"`python studies/roll_profile.py --runs "
                                         f"{' '.join(args.runs)} --out {args.out}`\n\n" + text)
    print(text, end="")


if __name__ == "__main__":
    main()
