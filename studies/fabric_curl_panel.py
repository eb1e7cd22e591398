"""The paper's Fig. 5c analogue: relaxed swatches side by side.

    python studies/fabric_curl_panel.py --runs DIR|JSON [...] --out studies/results/fabric_curl

Reads every ``curl_<nw>x<nc>.json`` (and its ``.vtu``) of ``knitfem curl``
runs in the given folders (or the given summary files), renders each relaxed swatch that lacks them (front
and iso views, tubes coloured by curvature; a run made with ``--no-render``
gets its pictures here) and writes ``OUT/curl_panel.png``: one column per
swatch, ordered by N_w / N_c, titled with its size, curl type, edge rolls and
whether it converged.  Failed runs (no relaxed shape) are listed, not drawn.
"""
import argparse
import json
import shutil
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

VIEWS = ("front", "iso")          # of knitfem.scenes.curl.VIEWS


def finished_runs(folders):
    """(summary, vtu path) of every converged or unconverged-but-relaxed run."""
    runs = []
    for folder in folders:
        folder = Path(folder)
        for path in [folder] if folder.is_file() else sorted(folder.glob("curl_*.json")):
            # (a B-spline run's summary is bspline_<nw>x<nc>.json: give it as a file)
            summary = json.loads(path.read_text())
            vtu = path.with_suffix(".vtu")
            if summary.get("curl") is not None and vtu.exists():
                runs.append((summary, vtu))
            else:
                print(f"{path}: no relaxed shape ({summary.get('error')})")
    return sorted(runs, key=lambda r: r[0]["nw"] / r[0]["nc"])


def render(summary, vtu, out):
    """front and iso PNGs of a run (made once, next to the panel)."""
    import meshio
    from knitfem.scenes.curl import render_views
    name = vtu.stem
    # runs of one size from different folders must not share pictures
    tag = name if vtu.parent.resolve() == out.resolve() else f"{vtu.parent.name}_{name}"
    paths = {view: out / f"{tag}_{view}.png" for view in VIEWS}
    beside = {view: vtu.parent / f"{name}_{view}.png" for view in VIEWS}
    missing = [v for v in VIEWS if not paths[v].exists()]
    if not missing:
        return paths
    if all(beside[v].exists() for v in missing) and vtu.parent.resolve() != out.resolve():
        for v in missing:
            shutil.copy(beside[v], paths[v])
        return paths
    render_views({v: paths[v] for v in missing}, meshio.read(vtu), summary["scene"]["radius"],
                 f"{summary['nw']} x {summary['nc']}: {summary['curl']} curl")
    return paths


def path_name(summary):
    """The homotopy schedule a run took (``knitfem curl --paths`` names), or
    its increments when they are no named schedule."""
    from knitfem.scenes.curl_paths import SCHEDULES
    if "protocol" not in summary:       # summaries before the protocol was kept
        return "not recorded"
    protocol = summary["protocol"] or {}
    steps = {key: protocol.get(key, SCHEDULES["default"][key]) for key in ("dlam", "dlam_max")}
    for name, schedule in SCHEDULES.items():
        if all(np.isclose(schedule[key], steps[key]) for key in steps):
            return name
    return f"dlam {steps['dlam']:g} / {steps['dlam_max']:g}"


def panel(runs, out):
    fig, axes = plt.subplots(2, len(runs), figsize=(4.6 * len(runs), 7.8), squeeze=False)
    for k, (summary, vtu) in enumerate(runs):
        paths = render(summary, vtu, out)
        r = summary["roll_deg"]
        scene = summary["scene"]
        mirrored = " (mirrored)" if scene.get("mirror") else ""
        # a yarn that keeps part of its knitted curvature (--straighten < 1) says so
        if summary.get("model") == "bspline":
            kept = 0.0 if scene.get("knit_natural") == "knitted" else 1.0
            model, how = "B-spline (frictionless)", summary.get("method", "fire")
        else:
            kept = scene.get("straighten", 1.0)
            model, how = f"μ = {scene['friction']:g}", f"path {path_name(summary)}"
        yarn = "" if kept == 1.0 else f", straighten {kept:g}"
        axes[0, k].set_title(f"N_w × N_c = {summary['nw']} × {summary['nc']}{mirrored}, α = "
                             f"{summary['alpha']:g}\n{model}{yarn}, {how}\n"
                             f"{summary['curl']} curl"
                             + ("" if summary["converged"] else " (NOT converged)")
                             + f"\nrolls L/R/T/B {r['left']:.0f}/{r['right']:.0f}/"
                             f"{r['top']:.0f}/{r['bottom']:.0f}°", fontsize=10)
        for row, view in enumerate(VIEWS):
            axes[row, k].imshow(plt.imread(paths[view]))
            axes[row, k].axis("off")
    models = sorted({"B-spline" if s.get("model") == "bspline" else "beam" for s, _ in runs})
    fig.suptitle(f"Relaxed plain-knit swatches ({' and '.join(models)} model)\nedge rolls in "
                 "degrees, positive toward the front (knit face, +z)", fontsize=12)
    fig.tight_layout()
    from knitfem.io.atomic import atomic_path
    with atomic_path(out / "curl_panel.png") as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", nargs="+", required=True, help="folders of knitfem curl runs, or their summary JSONs")
    parser.add_argument("--out", default="studies/results/fabric_curl")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    runs = finished_runs(args.runs)
    if not runs:
        parser.exit(3, "no relaxed swatch in the given folders\n")
    panel(runs, out)
    print(f"wrote {out / 'curl_panel.png'} ({len(runs)} swatches)")


if __name__ == "__main__":
    main()
