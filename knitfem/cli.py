"""Command line: ``knitfem <command> [options]``.

Commands
  gallery   the beam verification gallery (closed-form checks as plots)
"""
import argparse
import json
import sys


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
    g = sub.add_parser("gallery", help="beam verification gallery: plots, .vtu, render")
    g.add_argument("--out", default="studies/results/gallery", help="output folder")
    g.add_argument("--no-render", action="store_true", help="skip the pyvista renders")
    g.add_argument("--quiet", action="store_true")
    g.set_defaults(run=_gallery)
    return parser


def main(argv=None):
    args = build_parser().parse_args(argv)
    try:
        return args.run(args)
    except ValueError as err:        # bad input: a message, not a traceback
        print(f"knitfem {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
