"""Cross-check of the fabric curl: the paper's own B-spline model against the beam path.

For each swatch size (N_w, N_c) the B-spline model relaxes the prestretched
swatch (:func:`knitfem.scenes.curl_bspline.bspline_curl`, FIRE, at most
``--max-time`` seconds, single-threaded) and the shared curl analysis
classifies it.  The beam column comes from ``--beam-json DIR`` (files
``beam_<nw>x<nc>*.json`` written by ``knitfem curl --json``, refused unless
relaxed at ``--alpha``) when it holds the size, else from running
``knitfem.scenes.curl`` here (``--no-beam`` skips that: the column is then a
note).  Also the run time
against error on the first size: roll angles and residual against wall time.

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python studies/crosscheck_fabric.py \\
        --out studies/results/crosscheck_fabric [--sizes 10x35,25x35,55x35] [--max-time 1800]

Writes ``crosscheck.md`` / ``crosscheck.csv`` (the table), ``bspline_<nw>x<nc>.json``
(every B-spline key, history and trace), ``.vtu`` of the relaxed yarns,
``trace_<nw>x<nc>.csv``, ``time_vs_error_<nw>x<nc>.png`` and ``shape_<nw>x<nc>.png``
(top and side views of the relaxed yarns).
"""
import argparse
import csv
import glob
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from knitfem.scenes.curl_bspline import bspline_curl  # noqa: E402
from knitfem.scenes.swatch_bspline import YarnConstants  # noqa: E402

COLUMNS = ["model", "nw", "nc", "curl", "roll_left", "roll_right", "roll_top", "roll_bottom",
           "curvature_x", "curvature_y", "height_over_width", "converged", "residual",
           "max_penetration_over_d", "dofs", "elapsed_s", "note"]


def beam_column(nw, nc, alpha, beam_json, run_beam=True):
    """The beam path's result at (nw, nc): list of dicts (GJ/EI = 1e-3, the
    like-for-like comparison, and the beam's default), or a one-item list
    with only a note."""
    rows = []
    if beam_json:
        for path in sorted(glob.glob(str(Path(beam_json) / f"beam_{nw}x{nc}*.json"))):
            result = json.loads(Path(path).read_text())
            if result.get("alpha") != alpha:
                raise SystemExit(f"crosscheck_fabric: --beam-json {path} was relaxed at alpha "
                                 f"{result.get('alpha')}, the B-spline column at {alpha}")
            result["note"] = f"from {Path(path).name}"
            rows.append(result)
        if rows:
            return rows
    try:
        from knitfem.scenes.curl import curl                     # the lead's knitfem curl
        from knitfem.scenes.fabric import FabricScene
    except ImportError:
        return [{"model": "beam", "nw": nw, "nc": nc,
                 "note": "beam path not available here (knitfem.scenes.curl not importable, "
                         "no --beam-json): to be filled by `knitfem curl`"}]
    if not run_beam:
        return [{"model": "beam", "nw": nw, "nc": nc,
                 "note": "beam column not run here (--no-beam): `knitfem curl --nw "
                         f"{nw} --nc {nc} --gj-over-ei 1e-3 --json ...`, then --beam-json"}]
    for gj in (1e-3, None):
        scene = FabricScene(nw, nc, alpha=alpha) if gj is None else FabricScene(
            nw, nc, alpha=alpha, gj_over_ei=gj)
        try:
            result = curl(scene, render=False, progress=False)
            result["note"] = f"knitfem.scenes.curl, GJ/EI = {scene.gj_over_ei:g}"
        except Exception as err:                                # report, do not hide
            result = {"model": "beam", "nw": nw, "nc": nc,
                      "note": f"knitfem.scenes.curl failed: {err}"[:200]}
        rows.append(result)
    return rows


def flat(result):
    """One table row from a result dict (issue 9's keys)."""
    rolls = result.get("roll_deg") or {}
    row = {k: result.get(k) for k in COLUMNS}
    for side in ("left", "right", "top", "bottom"):
        row[f"roll_{side}"] = rolls.get(side)
    if result.get("model") == "bspline" and not row.get("note"):
        row["note"] = result.get("message", "")[:120]
    return row


def fmt(v):
    if isinstance(v, float):
        return f"{v:.3g}"
    return "" if v is None else str(v)


def write_trace(result, out, tag):
    trace = result.get("trace")
    if not trace:
        return
    with open(out / f"trace_{tag}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["t", "step", "residual", "energy", "ke"])
        w.writeheader()
        w.writerows(trace["rows"])
    shapes = trace["shapes"]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
    for side in ("left", "right", "top", "bottom"):
        pts = [(s["t"], s[f"roll_{side}"]) for s in shapes if f"roll_{side}" in s]
        if pts:
            ax1.plot(*zip(*pts), label=side)
    ax1.set_ylabel("edge roll (deg, + to the front)")
    ax1.legend()
    ax1.set_title(f"B-spline {tag}: run time against error ({result['method']})")
    rows = trace["rows"]
    ax2.semilogy([r["t"] for r in rows], [r["residual"] for r in rows], lw=0.6)
    ax2.set_xlabel("wall time (s)")
    ax2.set_ylabel("relative residual")
    fig.tight_layout()
    fig.savefig(out / f"time_vs_error_{tag}.png", dpi=120)
    plt.close(fig)


def plot_shape(vtu, png, title):
    """Top and side views of the relaxed yarns (knit yarn blue, bind-off red)."""
    import meshio
    import numpy as np
    mesh = meshio.read(vtu)
    pts, yarn = mesh.points, mesh.point_data["yarn"]
    fig = plt.figure(figsize=(10, 5))
    for i, (elev, azim) in enumerate(((90, -90), (0, -90))):
        ax = fig.add_subplot(1, 2, i + 1, projection="3d")
        for k in np.unique(yarn):
            ax.plot(*pts[yarn == k].T, lw=0.5, color="C0" if k == 0 else "C3")
        centre, half = pts.mean(axis=0), np.ptp(pts, axis=0).max() / 2
        for set_lim, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
            set_lim(c - half, c + half)
        ax.view_init(elev, azim)
        ax.set_title(f"{title} ({'top' if i == 0 else 'side'})")
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", default="studies/results/crosscheck_fabric")
    p.add_argument("--sizes", default="10x35,25x35,55x35")
    p.add_argument("--alpha", type=float, default=0.2)
    p.add_argument("--max-time", type=float, default=None, help="s per size (default 1800)")
    p.add_argument("--method", default=None, choices=("fire", "dynamic"),
                   help="B-spline relaxation (default fire)")
    p.add_argument("--k-contact", type=float, default=None,
                   help="contact stiffness g/s^2 (default: YarnConstants')")
    p.add_argument("--beam-json", default=None,
                   help="folder of beam_<nw>x<nc>*.json from `knitfem curl --json`")
    p.add_argument("--no-beam", action="store_true",
                   help="do not run the beam path here (it takes long); leave a note")
    p.add_argument("--tag", default="", help="suffix of the output names")
    p.add_argument("--table-only", action="store_true",
                   help="rebuild the table from the bspline_<size><tag>.json already in --out")
    args = p.parse_args(argv)
    relaxing = {"--max-time": args.max_time, "--method": args.method,
                "--k-contact": args.k_contact}
    if args.table_only and any(v is not None for v in relaxing.values()):
        given = ", ".join(k for k, v in relaxing.items() if v is not None)
        p.error(f"--table-only relaxes nothing: {given} would do nothing")
    args.max_time = 1800.0 if args.max_time is None else args.max_time
    args.method = args.method or "fire"
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.table_only:
        rows = []
        for size in args.sizes.split(","):
            nw, nc = (int(v) for v in size.lower().split("x"))
            path = out / f"bspline_{nw}x{nc}{args.tag}.json"
            if path.exists():
                rows.append(flat(json.loads(path.read_text())))
                rows.extend(flat(r) for r in beam_column(nw, nc, args.alpha, args.beam_json,
                                                         False))
        write_table(rows, out, args.tag)
        return rows
    constants = YarnConstants() if args.k_contact is None else YarnConstants(
        k_contact=args.k_contact)
    rows = []
    for size in args.sizes.split(","):
        nw, nc = (int(v) for v in size.lower().split("x"))
        tag = f"{nw}x{nc}{args.tag}"
        result = bspline_curl(nw, nc, alpha=args.alpha, method=args.method,
                              max_time=args.max_time, constants=constants, out=out,
                              name=f"bspline_{tag}", progress=False, trace=True)
        (out / f"bspline_{tag}.json").write_text(json.dumps(result, indent=1))
        write_trace(result, out, tag)
        plot_shape(out / f"bspline_{tag}.vtu", out / f"shape_{tag}.png",
                   f"B-spline {nw} x {nc}: {result['curl']}")
        rows.append(flat(result))
        rows.extend(flat(r) for r in beam_column(nw, nc, args.alpha, args.beam_json,
                                                 not args.no_beam))
        print(json.dumps({k: result[k] for k in ("nw", "nc", "curl", "roll_deg", "converged",
                                                 "residual", "elapsed_s")}), flush=True)
        write_table(rows, out, args.tag)
    return rows


def write_table(rows, out, tag=""):
    with open(out / f"crosscheck{tag}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join(fmt(r.get(k)) for k in COLUMNS) + " |" for r in rows]
    (out / f"crosscheck{tag}.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
