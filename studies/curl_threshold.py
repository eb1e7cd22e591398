"""How much of each curl type is the threshold's: the type of relaxed swatches
against the roll that calls an edge pair curled (knitfem.analysis.margin).

    python studies/curl_threshold.py --runs RUN.json [...] [--phase phase.csv ...] --out DIR

Reads ``knitfem curl`` summary JSONs (beam or B-spline) and phase CSVs of
``studies/fabric_phase.py`` and writes ``DIR/curl_threshold.png`` (one bar per
swatch over thresholds 0-360 deg, coloured by the type it reads as, the
default 30 deg marked; a second bar from the local rolls where the run has
them) and ``DIR/curl_threshold.md`` (the rolls, the type at 30 deg and the
thresholds that give each type).  The paper's simulated type is given for its
three swatches at N_c = 35 (Fig. 5c); the classification itself is unchanged.
"""
import argparse
import csv
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from knitfem.analysis.curl import ROLL_THRESHOLD  # noqa: E402
from knitfem.analysis.margin import EDGES, curl_type, curl_type_intervals  # noqa: E402

PAPER = {(10, 35): "side", (25, 35): "double", (55, 35): "top_bottom"}   # Fig. 5c
COLOURS = {"side": "tab:orange", "double": "tab:purple", "top_bottom": "tab:blue",
           "flat": "0.85"}
UPPER = 360.0


def _float(v):
    return None if v in (None, "") else float(v)


def from_summary(path):
    """A swatch of a summary JSON, or None (with a line) for a run with no shape."""
    s = json.loads(Path(path).read_text())
    if s.get("curl") is None or not s.get("roll_deg"):
        print(f"{path}: no relaxed shape ({s.get('error')}), left out")
        return None
    scene = s.get("scene") or {}
    label = f"{s['nw']} × {s['nc']}, α {s['alpha']:g}, {s.get('model', 'beam')}"
    if scene.get("friction") is not None:
        label += f", μ {scene['friction']:g}"
    if scene.get("w") and scene.get("c"):
        label += f", w/c {scene['w'] / scene['c']:.3g}"
    return {"label": label, "nw": s["nw"], "nc": s["nc"], "roll": s["roll_deg"],
            "local": s.get("local_roll_deg") or local_rolls(path, s), "touch": bool(s["edges_touch"]),
            "curl": s["curl"], "converged": s.get("converged"), "source": str(path)}


def local_rolls(path, summary):
    """Local rolls of a beam run that predates them in its summary, from its
    .vtu (knitfem.analysis.profile); None without the .vtu."""
    if summary.get("model", "beam") != "beam" or not Path(path).with_suffix(".vtu").exists():
        return None
    from roll_profile import profile_of          # studies/roll_profile.py, beside this file
    return profile_of(path)[1].local_roll_deg


def from_phase(path):
    rows = []
    for r in csv.DictReader(Path(path).open()):
        if r.get("curl") in (None, ""):
            continue
        roll = {e: float(r[f"roll_{e}"]) for e in EDGES}
        local = {e: _float(r.get(f"local_roll_{e}")) for e in EDGES}
        rows.append({"label": f"{r['nw']} × {r['nc']}, {r['model']} (phase)",
                     "nw": int(r["nw"]), "nc": int(r["nc"]), "roll": roll,
                     "local": local if None not in local.values() else None,
                     "touch": r["edges_touch"] == "True", "curl": r["curl"],
                     "converged": r["converged"] == "True", "source": str(path)})
    return rows


def ranges(intervals, kind):
    # intervals narrower than the table's rounding (rolls of round-off size) left out
    got = [f"{lo:.0f}–{hi:.0f}" for lo, hi, k in intervals if k == kind and hi - lo >= 0.5]
    return ", ".join(got) if got else "–"


def table(runs):
    lines = [f"Thresholds (deg) over (0, {UPPER:.0f}] at which each swatch reads as each type "
             f"(the classification's default: {ROLL_THRESHOLD:g}). `local` uses the local "
             "rolls (the edge's turn beyond the interior's even bend).", "",
             f"| swatch | converged | rolls L / R / T / B | edges touch | type at "
             f"{ROLL_THRESHOLD:g}° | side | "
             "double | top/bottom | paper (Fig. 5c) | local: side |", "|---|---|---|---|---|"
             "---|---|---|---|---|"]
    for run in runs:
        iv = curl_type_intervals(run["roll"], run["touch"], UPPER)
        rolls = " / ".join(f"{run['roll'][e]:+.0f}" for e in EDGES)
        local = (ranges(curl_type_intervals(run["local"], run["touch"], UPPER), "side")
                 if run["local"] else "n/a")
        lines.append(f"| {run['label']} | {run['converged']} | {rolls} | {run['touch']} | "
                     f"{curl_type(run['roll'], run['touch'], ROLL_THRESHOLD)} | "
                     f"{ranges(iv, 'side')} | {ranges(iv, 'double')} | "
                     f"{ranges(iv, 'top_bottom')} | {PAPER.get((run['nw'], run['nc']), '')} | "
                     f"{local} |")
    return "\n".join(lines) + "\n"


def figure(runs, path):
    bars = []
    for run in runs:
        bars.append((run["label"], curl_type_intervals(run["roll"], run["touch"], UPPER), 0.8))
        if run["local"]:
            bars.append(("  local rolls", curl_type_intervals(run["local"], run["touch"], UPPER),
                         0.45))
    fig, ax = plt.subplots(figsize=(9, 0.42 * len(bars) + 1.6))
    for k, (_, intervals, height) in enumerate(bars):
        for lo, hi, kind in intervals:
            ax.barh(k, hi - lo, left=lo, height=height, color=COLOURS[kind], edgecolor="none")
    ax.set_yticks(range(len(bars)), [b[0] for b in bars], fontsize=8)
    ax.invert_yaxis()
    ax.axvline(ROLL_THRESHOLD, color="k", ls="--", lw=1)
    ax.set_xlim(0, UPPER)
    ax.set_xlabel("roll threshold (deg): an edge pair rolled further counts as curled")
    for kind, colour in COLOURS.items():
        ax.barh(0, 0, color=colour, label=kind.replace("_", "/"))
    ax.legend(loc="lower right", fontsize=8, ncol=4)
    ax.set_title(f"Curl type against the roll threshold (dashed: the default {ROLL_THRESHOLD:g}°)",
                 fontsize=10)
    fig.tight_layout()
    from knitfem.io.atomic import atomic_path
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", nargs="*", default=[], help="knitfem curl summary JSONs")
    parser.add_argument("--phase", nargs="*", default=[], help="phase.csv files")
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args()
    runs = [r for r in map(from_summary, args.runs) if r is not None] + \
        [r for p in args.phase for r in from_phase(p)]
    if not runs:
        parser.exit(2, "curl_threshold: give --runs or --phase with at least one swatch\n")
    runs.sort(key=lambda r: (r["nw"] / r["nc"], r["nw"], r["label"]))
    args.out.mkdir(parents=True, exist_ok=True)
    figure(runs, args.out / "curl_threshold.png")
    from knitfem.io.atomic import atomic_path
    command = "python studies/curl_threshold.py " + " ".join(
        (["--runs", *args.runs] if args.runs else []) + (["--phase", *args.phase]
                                                         if args.phase else [])
        + ["--out", str(args.out)])
    with atomic_path(args.out / "curl_threshold.md") as tmp:
        Path(tmp).write_text(f"`{command}`\n\n" + table(runs))
    print(f"wrote {args.out / 'curl_threshold.png'} and curl_threshold.md ({len(runs)} swatches)")


if __name__ == "__main__":
    main()
