"""Command line: ``knitfem <command> [options]``.

Commands
  popup     the S-rod pop-up: continuation in c/L, critical point, popped branches
  knit      plain-knit swatch geometry: .vtu, render, summary
  gallery   the beam verification gallery (closed-form checks as plots)
"""
import argparse
import json
import sys
from pathlib import Path

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
    args = build_parser().parse_args(argv)
    if getattr(args, "elements", 0) is None:
        args.elements = 32 if args.model == "bspline" else 60
    try:
        return args.run(args)
    except ValueError as err:        # bad input: a message, not a traceback
        print(f"knitfem {args.command}: error: {err}", file=sys.stderr)
        return 2
    except (NewtonError, ContinuationError, RelaxationError) as err:
        print(f"knitfem {args.command}: the solver failed: {err}", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
