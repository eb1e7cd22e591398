"""Command line: ``knitfem <command> [options]``.

Commands
  popup     the S-rod pop-up: continuation in c/L, critical point, popped branches
  knit      plain-knit swatch geometry: .vtu, render, summary
  gallery   the beam verification gallery (closed-form checks as plots)
  curl      fabric curling: relax a plain-knit swatch, classify its curl

Every command checks its options (:mod:`knitfem.options`) and output paths
before any work; errors are one line naming the option, exit code 2.  Exit
codes: 0 done, 1 an output could not be written during the run, 2 bad
input, 3 the solver failed, 130 / 143 interrupted by SIGINT / SIGTERM
(:mod:`knitfem.interrupt`; the ``--out`` folder's ``run.json`` then says
``complete: false``).
"""
import argparse
from contextlib import nullcontext
import json
from pathlib import Path
import sys

from .options import OptionError, check_outputs


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage block): ``prog: error: message``."""

    def error(self, message):
        raise OptionError(None, message)


def add_command(subparsers, name, run, options, outputs=(), remove_listed=True, **kw):
    """A sub-command: its parser (``kw`` as for ``add_parser``) with the
    numeric options of ``options`` (a :class:`knitfem.options.OptionSet`,
    validated by :func:`main` before ``run(args)`` is called) and ``outputs``,
    the glob patterns of its ``--out`` files, or a function of the options
    returning them (stale ones are removed at the start of a run;
    ``remove_listed``: also the files a previous ``run.json`` lists)."""
    parser = subparsers.add_parser(name, **kw)
    options.add_to(parser)
    parser.set_defaults(run=run, options=options, outputs=outputs, remove_listed=remove_listed)
    return parser


def add_output_options(parser, out_help):
    """``--out DIR`` (``out_help``), ``--json FILE``, ``--no-render``, ``--quiet``:
    the output options every command shares (checked by :func:`main`)."""
    parser.add_argument("--out", help=f"{out_help} (+ run.json)")
    parser.add_argument("--json", help="write the summary JSON to this file")
    parser.add_argument("--no-render", action="store_true", help="skip the pyvista render")
    parser.add_argument("--quiet", action="store_true")
    return parser


def run_folder(args):
    """The :class:`knitfem.io.run.RunFolder` of ``--out`` (a no-op context
    without it): enter it before computing, write the files inside."""
    if not getattr(args, "out", None):
        return nullcontext()
    from .io.run import RunFolder
    outputs = args.outputs(args) if callable(args.outputs) else args.outputs
    options = getattr(args, "options", None)
    skip = {"outputs", "remove_listed"} | (options.inapplicable(args) if options else set())
    parameters = {k: v for k, v in vars(args).items() if k not in skip}
    return RunFolder(args.out, f"knitfem {args.command}", parameters, outputs=outputs,
                     remove_listed=args.remove_listed)


def write_summary(args, summary, line):
    """``--json FILE``: write the summary there (atomically) and print ``line``;
    else print the JSON (unless ``--quiet``)."""
    text = json.dumps(summary, indent=2)
    if args.json:
        from .io.atomic import write_json
        write_json(args.json, summary)
    if not args.quiet:
        print(line if args.json else text)


def build_parser():
    from .scenes import curl_command
    from .scenes import knit as knit_command
    from .scenes import popup_command
    from .verify import gallery
    parser = Parser(prog="knitfem", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for module in (popup_command, knit_command, curl_command, gallery):
        module.add_parser(sub)
    return parser


def _incomplete(manifest):
    try:
        return json.loads(manifest.read_text())["complete"] is False
    except (OSError, ValueError, KeyError, TypeError):
        return False


def _fail(name, message, code):
    print(f"knitfem{' ' + name if name else ''}: {message}", file=sys.stderr)
    return code


def main(argv=None):
    """Parse, validate, run; returns the exit code (see the module docstring)."""
    from .bspline import RelaxationError
    from .interrupt import interruptible, interruption
    from .solve import NewtonError
    from .solve.continuation import ContinuationError
    from .scenes.fabric_relax import FabricRelaxationError
    argv = sys.argv[1:] if argv is None else [str(a) for a in argv]
    name = next((a for a in argv if not a.startswith("-")), None)     # for messages
    with interruptible():
        try:
            try:
                args = build_parser().parse_args(argv)
            except SystemExit as done:                   # --help
                return int(done.code or 0)
            name = args.command
            args.options.validate(args)
            check_outputs(args)
            notice = args.options.notice(args)
            if notice and not getattr(args, "quiet", False):
                print(f"knitfem {name}: {notice}", file=sys.stderr)
            return args.run(args)
        except ValueError as err:        # bad input: a message, not a traceback
            return _fail(name, f"error: {err}", 2)
        except (NewtonError, ContinuationError, RelaxationError, FabricRelaxationError) as err:
            return _fail(name, f"the solver failed: {err}", 3)
        except OSError as err:
            return _fail(name, f"could not write {err.filename or ''}: "
                         f"{err.strerror or err}".replace(":  ", ": "), 1)
        except BaseException as err:
            stop = interruption(err)
            if stop is None:
                raise
            folder = getattr(locals().get("args"), "out", None)
            marked = folder and _incomplete(Path(folder) / "run.json")
            where = f"; {folder}/run.json says complete: false" if marked else ""
            return _fail(name, f"interrupted by {stop.signal_name}{where}", stop.exit_code)


if __name__ == "__main__":
    sys.exit(main())
