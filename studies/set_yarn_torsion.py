"""Does the set yarn's torsion weight decide the B-spline 10 x 35's curl?

    python studies/set_yarn_torsion.py --full-above F --out RUN [--max-time S]

The B-spline set yarn (``knitfem curl --model bspline --straighten 0``) has
its torsion in full only where its rest curvature is at least its mean
(:func:`knitfem.bspline.energy.set_yarn_terms`: 44 % of the 10 x 35's knit
Gauss points), weaker by (kappa0 / mean)^4 below.  This relaxes the same
swatch with the torsion in full down to F x the mean (F 0.25: 94 % of the
points; below 0.25 the Gershgorin masses spread again), through a patched
``set_yarn_terms``, and writes ``RUN/summary.json`` and the checkpoint
(``studies/checkpoint_report.py --run RUN`` reads its shape on the way).
"""
import argparse
import json

import numpy as np

import knitfem.bspline.energy as bspline_energy


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--full-above", type=float, required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--max-time", type=float, default=7000.0)
    args = parser.parse_args()
    if not 0.0 < args.full_above <= 1.0:
        parser.error(f"--full-above must be in (0, 1], got {args.full_above}")
    terms = bspline_energy.set_yarn_terms

    def full_above(kappa0, ds):
        weight, ep = terms(kappa0, ds)
        mean = ep.flat[0] / bspline_energy.SET_YARN_EPS
        return 1.0 / np.maximum(kappa0, args.full_above * mean) ** 4, ep

    bspline_energy.set_yarn_terms = full_above
    from knitfem.scenes.curl_bspline import bspline_curl
    s = bspline_curl(10, 35, alpha=0.2, knit_natural="knitted", max_time=args.max_time,
                     out=args.out, progress=True)
    s["full_above"] = args.full_above
    with open(f"{args.out}/summary.json", "w") as f:
        json.dump({k: v for k, v in s.items() if k != "history"}, f, indent=1, default=str)
    print(s["curl"], s["roll_deg"], s["converged"], s["relax_s"])


if __name__ == "__main__":
    main()
