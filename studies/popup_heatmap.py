"""Study (b): max|z|/L over c/L in [0.40, 0.95] x w/L in [0.05, 0.50] with the
critical curve c_crit(w/L) (paper Fig. 4c analogue); one continuation per
w/L column, each a point of the sweep engine (:mod:`knitfem.sweep`): persisted
as it finishes, ``--resume`` skips finished columns, local process pool
(default) or a Dask cluster (``--scheduler``), progress bar over columns.

    python studies/popup_heatmap.py --out studies/results/popup_heatmap
    python studies/popup_heatmap.py --out DIR --resume              # after an interruption
    python studies/popup_heatmap.py --out DIR --scheduler tcp://host:8786

Writes DIR/popup_heatmap.json, DIR/popup_heatmap.png, DIR/run.json (complete:
true last) and the sweep's DIR/sweep.json + DIR/points/.  SIGINT / SIGTERM:
one line, workers terminated, exit 130 / 143, finished columns kept.
"""
import argparse
import sys
import time

import numpy as np

from knitfem.io import write_json
from knitfem.io.run import RunFolder
from knitfem.options import Integer, OptionSet, Real
from knitfem.scenes.popup_output import plot_heat_map
from knitfem.scenes.popup_sweep import heat_map
from knitfem.sweep import add_sweep_options, parse_study, sweep_main

OPTIONS = OptionSet(
    Integer("--nw", 12, "[1, 1000]", help="w/L values in [0.05, 0.50]"),
    Real("--dc", 0.025, "[0.001, 0.55]", help="c/L step (0.025: 23 values in [0.40, 0.95])"),
    Integer("--elements", 60, "[4, 5000]", help="beam elements per column"),
)


def parse(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_sweep_options(parser, out_default="studies/results/popup_heatmap")
    return parse_study("popup_heatmap", parser, OPTIONS, argv)


def run(args):
    w = np.linspace(0.05, 0.50, args.nw)
    c = np.round(0.95 - args.dc * np.arange(int(round(0.55 / args.dc)) + 1), 10)
    run = RunFolder(args.out, "studies/popup_heatmap.py", vars(args),
                    outputs=("popup_heatmap.json", "popup_heatmap.png"))
    with run:
        t = time.perf_counter()
        hm = heat_map(w, c, out=args.out, resume=args.resume, workers=args.workers,
                      scheduler=args.scheduler, progress=not args.quiet, elements=args.elements)
        wall = time.perf_counter() - t
        plot_heat_map(hm, run.path / "popup_heatmap.png")
        write_json(run.path / "popup_heatmap.json", {
            "w_over_L": w, "c_over_L": c, "max_abs_z_over_L": hm.height,
            "stable": hm.stable, "critical_c_over_L": hm.critical,
            "solver_s_per_column": hm.elapsed, "wall_s": wall, "errors": hm.errors,
            "elements": args.elements, "columns_reused": hm.sweep.reused,
            "executor": hm.sweep.executor})
    print(f"{len(w)} x {len(c)} grid in {wall:.1f} s wall ({hm.sweep.reused} columns reused, "
          f"{hm.sweep.executor}); c_crit/L by w/L:")
    for wi, ci in zip(w, hm.critical):
        print(f"  w/L = {wi:.4f}  c_crit/L = {ci:.5f}")
    if hm.errors:
        print("failed columns:", hm.errors)
    return 0 if not hm.errors else 3


def main(argv=None):
    return sweep_main("popup_heatmap", run, parse(argv), what="columns")


if __name__ == "__main__":
    sys.exit(main())
