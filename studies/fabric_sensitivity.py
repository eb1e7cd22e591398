"""The beam fabric curl against one parameter: convergence in elements per loop,
sensitivity to alpha or to the loop aspect (issue 9, must-show 2).

    python studies/fabric_sensitivity.py --nw 5 --nc 5 --vary elements-per-loop \
        --values 16,24,32 --out DIR [--resume] [-- other knitfem curl options]
    python studies/fabric_sensitivity.py --nw 10 --nc 10 --vary alpha --values 0.1,0.2,0.3 ...
    python studies/fabric_sensitivity.py --nw 10 --nc 10 --vary c --values 2.5,3,3.5 ...

Runs ``knitfem curl --<vary> <value>`` once per value (one process each, one thread,
``--no-render``), each in ``OUT/<vary>=<value>/``; ``--resume`` keeps the finished values
and resumes an interrupted one from its checkpoint (a finished value relaxed with other
``knitfem curl`` options is refused, not mixed into the table; one whose friction did not
settle goes on when ``-- --settle N`` asks for passes).  Writes ``OUT/table.md`` (one row per
value: curl, rolls, curvatures, residual, stability, friction settled, reaction, path
penetration, iterations, relaxation time) and ``OUT/sensitivity.png`` (the four edge rolls
against the value).  For ``elements-per-loop`` the issue's criterion — the two finest
levels give the same curl and roll angles within 5 degrees — is checked on the table's
last line.
"""
import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

EDGES = ("left", "right", "top", "bottom")
VARY = {"elements-per-loop": int, "alpha": float, "w": float, "c": float, "radius": float,
        "ea-over-ei": float, "gj-over-ei": float, "friction": float,
        "bindoff-stiffness": float, "inflation": float}
ROLL_TOLERANCE_DEG = 5.0          # the criterion between the two finest levels


def finished_level(summary, cmd):
    """The answer already in ``summary`` (a path) if it was relaxed with the
    scene and relaxation options of ``cmd`` (a ``knitfem curl`` command line),
    and None when settle passes it asks for are due; SystemExit naming what
    differs otherwise (kept, it would put another swatch's row in the table)."""
    from knitfem.cli import build_parser
    from knitfem.scenes.curl import check_same_run
    from knitfem.scenes.curl_command import protocol_of, scene_of
    from knitfem.scenes.curl_paths import settle_due
    from knitfem.scenes.fabric import FabricScene
    parsed = build_parser().parse_args(cmd[3:])
    finished = json.loads(summary.read_text())
    if parsed.paths is not None or finished.get("error") is not None:
        # knitfem curl --resume checks and reuses each finished path itself;
        # a failed value goes on from its checkpoint (a raised budget may pass)
        return None
    try:
        parsed.options.validate(parsed)           # fills in the defaults
        check_same_run(summary, FabricScene.stored(finished.get("scene") or {}),
                       finished.get("protocol"), scene_of(parsed), protocol_of(parsed))
    except ValueError as err:
        raise SystemExit(f"fabric_sensitivity: {err}") from None
    return None if settle_due(finished, parsed.settle, summary.parent) else finished


def run_level(args, level, extra):
    from knitfem.cli import build_parser
    folder = args.out / f"{args.vary}={level}"
    summary = folder / f"curl_{args.nw}x{args.nc}.json"
    cmd = [sys.executable, "-m", "knitfem", "curl", "--nw", str(args.nw), "--nc", str(args.nc),
           f"--{args.vary}", str(level), "--no-render",
           "--no-limits", "--quiet", "--out", str(folder), *extra]
    if args.resume and summary.exists():
        finished = finished_level(summary, cmd)
        if finished is not None:
            return finished
    if args.resume and ((folder / "checkpoint.npz").exists()
                        or build_parser().parse_args(cmd[3:]).paths is not None):
        cmd.append("--resume")
    env = dict(os.environ, OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1")
    print(" ".join(cmd[1:]), flush=True)
    done = subprocess.run(cmd, env=env)
    if not summary.exists():
        raise SystemExit(f"--{args.vary} {level}: knitfem curl exited {done.returncode} without "
                         f"a summary in {folder}")
    return json.loads(summary.read_text())


def row(level, s):
    if s.get("curl") is None:
        return f"| {level} | {s.get('dofs', '')} | failed: {s.get('error')} |" + " |" * 9
    rolls = " / ".join(f"{s['roll_deg'][e]:+.1f}" for e in EDGES)
    touch = " (edges touch)" if s.get("edges_touch") else ""
    return (f"| {level} | {s['dofs']} | {s['curl']}{touch} | {rolls} | "
            f"{s['curvature_x']:+.3f}, {s['curvature_y']:+.3f} | {s['residual']:.1e} | "
            f"{'stable' if s['stable'] else 'UNSTABLE'} | "
            f"{'yes' if s.get('friction_settled') else 'no'} | "
            f"{s['reaction_over_force_scale']:.1e} | {100 * s['max_penetration_over_d']:.1f} % | "
            f"{s['iterations']} | {s['relax_s']:.0f} s |")


def verdict(levels, summaries):
    (l1, a), (l2, b) = list(zip(levels, summaries))[-2:]
    if a.get("curl") is None or b.get("curl") is None:
        return f"{l1} -> {l2}: a level failed; no verdict."
    worst = max(abs(a["roll_deg"][e] - b["roll_deg"][e]) for e in EDGES)
    same = a["curl"] == b["curl"]
    ok = same and worst <= ROLL_TOLERANCE_DEG
    return (f"{l1} -> {l2} elements per loop: curl {'the same' if same else 'differs'}, "
            f"largest roll change {worst:.1f} deg (criterion {ROLL_TOLERANCE_DEG:.0f}): "
            f"**{'met' if ok else 'not met'}**.")


def figure(levels, summaries, path, title, vary):
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    for edge in EDGES:
        pts = [(l, s["roll_deg"][edge]) for l, s in zip(levels, summaries) if s.get("curl")]
        if pts:
            ax.plot(*zip(*pts), "o-", label=edge)
    ax.set_xlabel(vary)
    ax.set_ylabel("edge roll (deg, + toward the knit face)")
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nw", type=int, default=5)
    p.add_argument("--nc", type=int, default=5)
    p.add_argument("--vary", default="elements-per-loop", choices=VARY)
    p.add_argument("--values", default="16,24,32")
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--resume", action="store_true")
    args, extra = p.parse_known_args()
    extra = [a for a in extra if a != "--"]
    try:
        levels = sorted(VARY[args.vary](v) for v in args.values.split(","))
    except ValueError:
        p.error(f"--values: comma-separated {VARY[args.vary].__name__}s, got {args.values!r}")
    if len(levels) < 2:
        p.error("--values: at least two values")
    if any(a.split("=")[0] == f"--{args.vary}" for a in extra):
        p.error(f"--{args.vary} is the varied option; give its values with --values")
    args.out.mkdir(parents=True, exist_ok=True)
    summaries = [run_level(args, level, extra) for level in levels]
    title = f"{args.nw} x {args.nc}" + (" " + " ".join(extra) if extra else "")
    lines = [f"# {title}: {args.vary}", "",
             f"`python studies/fabric_sensitivity.py --nw {args.nw} --nc {args.nc} --vary "
             f"{args.vary} --values {args.values} --out {args.out}"
             + (" -- " + " ".join(extra) if extra else "") + "`; one thread per value.", "",
             f"| {args.vary} | unknowns | curl | rolls L / R / T / B (deg) | "
             "kappa_x, kappa_y (1/mm) | residual | stability | friction settled | reaction / "
             "force scale | path penetration | iterations | relaxation |",
             "|---:|---:|---|---|---|---:|---|---|---:|---:|---:|---:|"]
    lines += [row(l, s) for l, s in zip(levels, summaries)]
    if args.vary == "elements-per-loop":
        lines += ["", verdict(levels, summaries)]
    (args.out / "table.md").write_text("\n".join(lines + [""]))
    figure(levels, summaries, args.out / "sensitivity.png", title, args.vary)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
