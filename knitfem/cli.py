"""Command line: ``knitfem <command> [options]``.

Commands
  popup     the S-rod pop-up: continuation in c/L, critical point, popped branches
  knit      plain-knit swatch geometry: .vtu, render, summary
  gallery   the beam verification gallery (closed-form checks as plots)
  curl      fabric curling: relax a plain-knit swatch, classify its curl
"""
import argparse
import json
import sys
from pathlib import Path

import numpy as np

W_OVER_L = 28.4 / 105.0          # the paper's rod: w = 28.4 mm, L = 105 mm


def _refuse_torsion_options(args):
    """The bspline model has no twist energy: refuse torsion options rather
    than ignore them (given explicitly = not None, the parser's default)."""
    for option, value in (("--poisson", args.poisson), ("--gj-over-ei", args.gj_over_ei)):
        if value is not None:
            raise ValueError(f"{option} does not apply to --model bspline: the bspline model has "
                             f"no torsional stiffness (no twist energy)")


def _popup(args):
    from .scenes import popup_output
    from .scenes.srod import SRod, popup
    if args.model == "bspline":
        _refuse_torsion_options(args)
    poisson = SRod.poisson if args.poisson is None else args.poisson     # 0.5
    srod = SRod(length=args.length, w=args.w_over_L * args.length, diameter=args.diameter,
                poisson=poisson, gj_over_ei=args.gj_over_ei, elements=args.elements)
    if args.model == "bspline":
        from .scenes.srod_bspline import bspline_popup
        result = bspline_popup(srod, args.c_from, args.c_to, args.c_step, segments=args.elements,
                               method=args.relax, progress=not args.quiet)
        write = popup_output.write_bspline_popup
    else:
        result = popup(srod, args.c_from, args.c_to, args.c_step)
        write = popup_output.write_popup
    summary = result.summary()
    if args.out:
        write(result, args.out, render=not args.no_render)
    text = json.dumps(summary, indent=2)
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(text)
    if not args.quiet:
        print(text if not args.json else
              f"critical c/L = {summary['critical_c_over_L']}, "
              f"elapsed {summary['elapsed_s']:.3f} s;"
              f" wrote {args.json}")
    return 0


def _positive_option(name, value, low=0.0, high=np.inf, inclusive=False):
    ok = np.isfinite(value) and (low <= value if inclusive else low < value) and value <= high
    if not ok:
        lo = "[" if inclusive else "("
        raise ValueError(f"{name} must be in {lo}{low:g}, {high:g}], got {value!r}")


def _curl(args):
    from .scenes.curl import curl, scene_from_options
    if args.model == "bspline":
        from .scenes.curl_bspline import bspline_curl_from_options
        summary = bspline_curl_from_options(args)
    else:
        for name, value, low, high, inclusive in (
                ("--nw", args.nw, 1, 200, True), ("--nc", args.nc, 1, 200, True),
                ("--alpha", args.alpha, 0.0, 0.5, True), ("--friction", args.friction, 0.0, 2.0,
                                                           True),
                ("--w", args.w, 0.0, 1e3, False), ("--c", args.c, 0.0, 1e3, False),
                ("--radius", args.radius, 0.0, 1e3, False),
                ("--elements-per-loop", args.elements_per_loop, 8, 64, True),
                ("--gj-over-ei", args.gj_over_ei, 0.0, 100.0, False),
                ("--ea-over-ei", args.ea_over_ei, 0.0, 1e6, False),
                ("--bindoff-stiffness", args.bindoff_stiffness, 0.0, 1e3, False)):
            if value is not None:
                _positive_option(name, value, low, high, inclusive)
        if args.resume and not args.out:
            raise ValueError("--resume needs --out (the folder holding the checkpoint)")
        summary = curl(scene_from_options(args), out=args.out, render=not args.no_render,
                       progress=not args.quiet, resume=args.resume)
    text = json.dumps(summary, indent=2)
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(text)
    if not args.quiet:
        print(text if not args.json else f"{summary['curl']} curl, converged "
              f"{summary['converged']}; wrote {args.json}")
    return 0 if summary.get("error") is None else 3


def _gallery(args):
    from .verify import gallery
    summary = gallery.run(args.out, render=not args.no_render,
                          log=(lambda *a: None) if args.quiet else print)
    if not args.quiet:
        print(json.dumps(summary, indent=2))
        print(f"wrote {args.out}")
    return 0


def build_parser():
    parser = argparse.ArgumentParser(prog="knitfem", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("popup", help="S-rod pop-up by continuation in c/L (paper Fig. 4)",
                       description="Clamped S-rod (half a knitted loop): continuation in c/L from "
                       "--c-from down to --c-to, the out-of-plane bifurcation, both popped "
                       "branches, and the stable path sampled every --c-step.")
    p.add_argument("--w-over-L", dest="w_over_L", type=float, default=W_OVER_L,
                   help=f"wale length over rod length (default {W_OVER_L:.4f} = 28.4/105)")
    p.add_argument("--c-from", type=float, default=0.95, help="first c/L (default 0.95)")
    p.add_argument("--c-to", type=float, default=0.45, help="last c/L (default 0.45)")
    p.add_argument("--c-step", type=float, default=0.05, help="sampling of the output (0.05)")
    p.add_argument("--model", choices=("beam", "bspline"), default="beam",
                   help="beam: Simo-Reissner rod + continuation (default); bspline: the "
                   "independent yarn-level model (no twist energy), relaxed point by point")
    p.add_argument("--elements", type=int, default=None,
                   help="beam elements (default 60) or B-spline segments (default 32)")
    p.add_argument("--relax", choices=("static", "dynamic"), default="static",
                   help="bspline model: L-BFGS (static, default) or dynamic relaxation")
    stiff = p.add_mutually_exclusive_group()
    # default None, not 0.5: --model bspline must tell a given option from the default
    stiff.add_argument("--poisson", type=float, default=None,
                       help="beam model: Poisson ratio, GJ/EI = 1/(1+nu) (default 0.5)")
    stiff.add_argument("--gj-over-ei", type=float, default=None,
                       help="beam model: explicit GJ/EI")
    p.add_argument("--length", type=float, default=105.0, help="rod length L, mm (105)")
    p.add_argument("--diameter", type=float, default=3.0, help="rod diameter, mm (3)")
    p.add_argument("--out", help="folder for CSV, .vtu, plot and render")
    p.add_argument("--json", help="write the summary JSON to this file")
    p.add_argument("--no-render", action="store_true", help="skip the pyvista render")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(run=_popup)

    from .scenes.knit import add_parser as add_knit_parser
    add_knit_parser(sub)

    c = sub.add_parser("curl", help="fabric curling: relax a plain-knit swatch (paper Fig. 5c)",
                       description="Relax an N_w x N_c plain-knit swatch (beams, contact, "
                       "friction, ties, pre-stretch) to a static equilibrium and classify its "
                       "curl: side, double, top_bottom or flat.")
    c.add_argument("--nw", type=int, default=10, help="wales N_w (default 10)")
    c.add_argument("--nc", type=int, default=35, help="courses N_c (default 35)")
    c.add_argument("--model", choices=("beam", "bspline"), default="beam")
    c.add_argument("--alpha", type=float, default=None, help="pre-stretch ratio (0.2)")
    c.add_argument("--w", type=float, default=None, help="wale length, mm (4)")
    c.add_argument("--c", type=float, default=None, help="course length, mm (3)")
    c.add_argument("--radius", type=float, default=None, help="yarn radius, mm (0.4)")
    c.add_argument("--elements-per-loop", type=int, default=None, help="(16)")
    c.add_argument("--gj-over-ei", type=float, default=None, help="torsion/bending (2/3)")
    c.add_argument("--ea-over-ei", type=float, default=None,
                   help="stretching/bending, 1/mm^2 (800)")
    c.add_argument("--friction", type=float, default=None, help="Coulomb coefficient (0.3)")
    c.add_argument("--bindoff-stiffness", type=float, default=None,
                   help="bind-off stiffness / yarn stiffness (10)")
    c.add_argument("--out", help="folder: relaxation path, final .vtu, renders, checkpoint")
    c.add_argument("--json", help="write the summary JSON to this file")
    c.add_argument("--resume", action="store_true", help="continue from --out's checkpoint")
    c.add_argument("--no-render", action="store_true")
    c.add_argument("--quiet", action="store_true")
    c.set_defaults(run=_curl)

    g = sub.add_parser("gallery", help="beam verification gallery: plots, .vtu, render")
    g.add_argument("--out", default="studies/results/gallery", help="output folder")
    g.add_argument("--no-render", action="store_true", help="skip the pyvista renders")
    g.add_argument("--quiet", action="store_true")
    g.set_defaults(run=_gallery)
    return parser


def main(argv=None):
    from .solve import NewtonError
    from .bspline import RelaxationError
    from .solve.continuation import ContinuationError
    from .scenes.fabric_relax import FabricRelaxationError
    args = build_parser().parse_args(argv)
    if getattr(args, "elements", 0) is None:
        args.elements = 32 if args.model == "bspline" else 60
    try:
        return args.run(args)
    except ValueError as err:        # bad input: a message, not a traceback
        print(f"knitfem {args.command}: error: {err}", file=sys.stderr)
        return 2
    except (NewtonError, ContinuationError, RelaxationError, FabricRelaxationError) as err:
        print(f"knitfem {args.command}: the solver failed: {err}", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
