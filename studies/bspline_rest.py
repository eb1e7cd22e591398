"""How far from rest a B-spline relaxation is when its residual says 'done':
the Newton-step estimate (knitfem.bspline.stability.equilibrium_distance)
against the move FIRE still makes.

    python studies/bspline_rest.py [--nw 4 --nc 4 --alpha 0.2] [--out DIR]
    python studies/bspline_rest.py --checkpoint RUN/bspline_25x35_checkpoint.npz

Swatch mode: FIRE (no rest check) to relative residuals 1e-5, 1e-6, 1e-7 and
1e-9 in turn, each stage going on from the last state (velocities reset);
for each stopping state the estimate and the largest control-point move to
the 1e-9 state, in yarn radii, and the edge rolls.  Checkpoint mode: the
estimate and the six lowest eigenvalues at a FIRE
checkpoint of ``knitfem curl --model bspline --out RUN``.  Writes
``DIR/bspline_rest_<nw>x<nc>.json`` (swatch mode) and prints a table.
"""
import argparse
import json
import time
from pathlib import Path

import numpy as np

from knitfem.analysis.curl import swatch_curl
from knitfem.bspline.fire import FireState, relax_fire
from knitfem.bspline.relax import largest_move
from knitfem.bspline.stability import equilibrium_distance, lowest_eigenvalues, stability
from knitfem.scenes.curl_bspline import swatch_of
from knitfem.scenes.swatch_bspline import bspline_swatch, prestretch

STAGES = (1e-5, 1e-6, 1e-7, 1e-9)


def swatch_mode(args):
    bs = bspline_swatch(args.nw, args.nc)
    prestretch(bs, args.alpha)
    model, r = bs.model, bs.swatch.radius
    y, rows, start = model.reduce(model._initial()), [], time.perf_counter()
    for rtol in STAGES:
        y = relax_fire(model, y, rtol=rtol, max_steps=None, max_time=args.max_time).y
        shape = swatch_curl(bs.points(model.control_points(y)), bs.swatch)
        distance = equilibrium_distance(model, y)
        rows.append({"rtol": rtol, "estimate_over_r": None if distance is None else distance / r,
                     "stable": stability(model, y)[0], "curl": shape.curl,
                     "roll_deg": {k: float(v) for k, v in shape.roll_deg.items()},
                     "wall_s": time.perf_counter() - start, "y": y})
    print(f"{args.nw} x {args.nc}, alpha {args.alpha}: stop at -> estimate / actual move to the "
          f"{STAGES[-1]:.0e} state (yarn radii), rolls L/R/T/B")
    for row in rows:
        row["actual_over_r"] = largest_move(model.reduction()[0], row.pop("y") - y) / r
        est = row["estimate_over_r"]
        print(f"  {row['rtol']:.0e}: {'-' if est is None else f'{est:.4g}'} / "
              f"{row['actual_over_r']:.4g}, stable {row['stable']}, " +
              " / ".join(f"{row['roll_deg'][k]:+.1f}" for k in ("left", "right", "top", "bottom")))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / f"bspline_rest_{args.nw}x{args.nc}.json").write_text(json.dumps(
        {"nw": args.nw, "nc": args.nc, "alpha": args.alpha, "stages": rows}, indent=1))


def checkpoint_mode(args):
    with np.load(args.checkpoint) as saved:
        scene = json.loads(str(saved["scene"]))
        state = FireState.from_arrays(saved)
    bs = swatch_of(scene)
    model, r = bs.model, scene["radius"]
    E, g, ref = model.reduced_energy(state.y)
    distance = equilibrium_distance(model, state.y)
    vals, scale = lowest_eigenvalues(model, state.y, k=6)
    print(f"{args.checkpoint}: step {state.step}, residual {np.linalg.norm(g) / ref:.2e}, "
          f"Newton-step estimate {'-' if distance is None else f'{distance / r:.3g}'} r; "
          f"lowest eigenvalues {', '.join(f'{v:.2e}' for v in vals)} (max |diag H| {scale:.2e})")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nw", type=int, default=4)
    p.add_argument("--nc", type=int, default=4)
    p.add_argument("--alpha", type=float, default=0.2)
    p.add_argument("--max-time", type=float, default=1800.0)
    p.add_argument("--checkpoint")
    p.add_argument("--out", default="studies/results/bspline_rest")
    args = p.parse_args()
    checkpoint_mode(args) if args.checkpoint else swatch_mode(args)


if __name__ == "__main__":
    main()
