"""Study (a): the paper's Fig. 4a/4b analogue, w/L = 28.4/105, L = 105 mm.

The stable path is sampled on the paper's c grid (c = 100 -> 50 mm in 5 mm
steps); continuation runs down to c/L = 0.45.  This is the main job of
``make demo``.

    python studies/popup_fig4a.py --out studies/results/popup_fig4a
"""
import argparse

import numpy as np

from knitfem.scenes.popup_output import write_popup
from knitfem.scenes.srod import SRod, popup

L = 105.0
PAPER_C_MM = np.arange(100.0, 49.0, -5.0)        # the experiment's course lengths


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="studies/results/popup_fig4a")
    parser.add_argument("--no-render", action="store_true")
    args = parser.parse_args()
    result = popup(SRod(length=L, w=28.4), c_from=PAPER_C_MM[0] / L, c_to=0.45,
                   c_step=5.0 / L)
    summary = write_popup(result, args.out, render=not args.no_render, marks=PAPER_C_MM / L)
    print(f"critical c/L = {summary['critical_c_over_L']:.6f} "
          f"(c = {summary['critical_c_over_L'] * L:.2f} mm), solver {summary['elapsed_s']:.3f} s")
    for row in summary["branch"]:
        print(f"  c = {row['c_over_L'] * L:6.1f} mm  c/L = {row['c_over_L']:.4f}  "
              f"max|z|/L = {row['max_abs_z_over_L']:.4f}  "
              f"{'stable' if row['stable'] else 'UNSTABLE'}")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
