"""Study (b): max|z|/L over c/L in [0.40, 0.95] x w/L in [0.05, 0.50] with the
critical curve c_crit(w/L) (paper Fig. 4c analogue); one continuation per
w/L, in parallel over all cores, with a progress bar.

    python studies/popup_heatmap.py --out studies/results/popup_heatmap
"""
import argparse
import json
import time
from pathlib import Path

import numpy as np

from knitfem.scenes.popup_output import plot_heat_map
from knitfem.scenes.popup_sweep import heat_map


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="studies/results/popup_heatmap")
    parser.add_argument("--nw", type=int, default=12, help="w/L values (default 12)")
    parser.add_argument("--dc", type=float, default=0.025, help="c/L step (default 0.025: 23)")
    parser.add_argument("--elements", type=int, default=60)
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    w = np.linspace(0.05, 0.50, args.nw)
    c = np.round(0.95 - args.dc * np.arange(int(round(0.55 / args.dc)) + 1), 10)
    t = time.perf_counter()
    hm = heat_map(w, c, elements=args.elements)
    wall = time.perf_counter() - t
    plot_heat_map(hm, out / "popup_heatmap.png")
    data = {"w_over_L": w.tolist(), "c_over_L": c.tolist(),
            "max_abs_z_over_L": np.where(np.isfinite(hm.height), hm.height, None).tolist(),
            "stable": hm.stable.tolist(), "critical_c_over_L": hm.critical.tolist(),
            "solver_s_per_column": hm.elapsed.tolist(), "wall_s": wall, "errors": hm.errors,
            "elements": args.elements}
    (out / "popup_heatmap.json").write_text(json.dumps(data, indent=1))
    print(f"{len(w)} x {len(c)} grid in {wall:.1f} s wall; c_crit/L by w/L:")
    for wi, ci in zip(w, hm.critical):
        print(f"  w/L = {wi:.4f}  c_crit/L = {ci:.5f}")
    if hm.errors:
        print("failed columns:", hm.errors)


if __name__ == "__main__":
    main()
