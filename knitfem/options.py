"""Declarative command-line options, validated before any work is done.

A command lists its numeric options once; the list adds them to an argparse
parser and checks the parsed values: finite, in range, options that apply
only with another option's value, cross-option rules, and cost estimates
(run time, memory) against limits that ``--no-limits`` lifts.  Every refusal
is one :class:`OptionError` line naming the option as typed on the command
line, its valid range (6 significant digits) and the value given; the CLI
prints it and exits with code 2.

API
---
``Real(flag, default, interval, help=...)``, ``Integer(...)``
    a number option; ``interval`` as written in mathematics: ``"(0, 1]"``,
    ``"[4, inf)"``; ``default`` a value or a function of the other values
    (e.g. elements: 60 for the beam, 32 for the B-spline); ``when=(dest,
    value[, reason])`` refuses the option when given while ``dest`` differs
    from ``value`` (``--poisson`` only with ``--model beam``).
``Check(function)``
    a cross-option rule: ``function(values)`` raises :class:`OptionError`
    (use :func:`refuse`) or returns None; ``values`` has every option by its
    dest, defaults filled in.
``Budget(what, estimate, options, limit=None)``
    ``estimate(values)`` -> seconds (``what="run time"``) or bytes
    (``what="memory"``); above ``limit`` (a number or a function of the
    values; default :data:`TIME_LIMIT` or :func:`memory_limit`) the run is
    refused naming ``options`` (a tuple of flags, or a function of the values
    giving one) and the estimate, unless ``--no-limits`` was given.
``OptionSet(*specs)``
    ``.add_to(parser)`` (adds the options and, if there are budgets,
    ``--no-limits``); ``.validate(args)`` fills defaults in ``args`` and raises
    the first :class:`OptionError` (ranges in the listed order, then checks,
    then budgets); it leaves ``args.given`` (dests given on the command line)
    and ``args.estimates`` (what -> estimated cost); ``OptionSet.notice(args)``
    is a line to print before a run estimated above ``NOTICE`` seconds.

A new command's options are a few lines (the ``curl`` command, say)::

    def _yarn_fits(v):
        if not v.radius < v.w / 8:
            refuse("--radius", f"must be below --w/8 = {fmt(v.w / 8)}", v.radius)

    CURL = OptionSet(
        Integer("--nw", 10, "[2, inf)", help="wales"), Integer("--nc", 10, "[2, inf)"),
        Real("--alpha", 1.0, "(0, 2]", help="yarn pre-stretch ratio"),
        Real("--radius", 0.4, "(0, inf)", help="yarn radius, mm"), ...,
        Check(_yarn_fits),
        Budget("run time", lambda v: 2e-4 * v.nw * v.nc * v.elements_per_loop ** 1.5,
               ("--nw", "--nc", "--elements-per-loop")))

    # knitfem/cli.py's build_parser registers the command:
    p = add_command(subparsers, "curl", run, CURL, outputs=("curl*.vtu", "curl.json"))
    add_output_options(p, "folder for the relaxed swatch")   # --out --json --no-render --quiet
    # main() then validates (exit 2 on OptionError), checks --out / --json and calls run(args);
    # run() computes inside ``with run_folder(args):`` (run.json, stale files, interruption)

Output options (``--out``, ``--json``) are checked by
:func:`check_outputs`; run folders and atomic writes are in
:mod:`knitfem.io.run` and :mod:`knitfem.io.atomic`.
"""
from dataclasses import dataclass
import math
import os
import re

TIME_LIMIT = 600.0                  # s: longer estimated runs need --no-limits
NOTICE = 30.0                       # s: runs estimated longer say so before starting
OVERRIDE = "--no-limits"


def memory_limit():
    """Half the machine's physical memory (bytes), 8 GiB if unknown."""
    try:
        return 0.5 * os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 8.0 * 2**30


class OptionError(ValueError):
    """A bad option value; ``option`` is the flag as typed (``--w-over-L``)."""

    def __init__(self, option, message):
        super().__init__(message)
        self.option = option

    def __reduce__(self):
        return (type(self), (self.option, str(self)))


def fmt(x):
    """A number with 6 significant digits (1e-300 stays 1e-300, 0.2705 0.2705)."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return repr(x)
    if isinstance(x, int):
        return str(x)
    return f"{x:.6g}"


def refuse(option, requirement, value):
    """Raise ``OptionError``: "<option> <requirement>, got <value>"."""
    raise OptionError(option, f"{option} {requirement}, got {fmt(value)}")


_INTERVAL = re.compile(r"^\s*([\[(])\s*([^,]+?)\s*,\s*([^,]+?)\s*([\])])\s*$")


@dataclass(frozen=True)
class Interval:
    """A real interval parsed from its usual notation, e.g. ``"(0, 1]"``."""
    text: str

    def __post_init__(self):
        m = _INTERVAL.match(self.text)
        if not m:
            raise ValueError(f"interval must look like '(0, 1]', got {self.text!r}")
        lo, hi = float(m.group(2)), float(m.group(3))
        object.__setattr__(self, "bounds", (lo, hi, m.group(1) == "[", m.group(4) == "]"))

    def __contains__(self, x):
        lo, hi, lo_in, hi_in = self.bounds
        return (lo < x or (lo_in and x == lo)) and (x < hi or (hi_in and x == hi))

    def __str__(self):
        lo, hi, lo_in, hi_in = self.bounds
        return f"{'[' if lo_in else '('}{fmt(lo)}, {fmt(hi)}{']' if hi_in else ')'}"


@dataclass(frozen=True)
class Real:
    """A real-valued option: finite and in ``interval``."""
    flag: str
    default: object
    interval: str = "(-inf, inf)"
    help: str = ""
    when: tuple = None                # (dest, value[, reason]): the option applies only then
    metavar: str = None
    kind = "a number"
    type = float                      # argparse's converter (its name shows in its messages)

    @property
    def dest(self):
        return self.flag.lstrip("-").replace("-", "_")

    def parse(self, text):
        return self.type(text)

    def add_to(self, parser):
        default = self.default if not callable(self.default) else None
        shown = f" (default {fmt(default)}; " if default is not None else " ("
        shown += f"valid {Interval(self.interval)})"
        parser.add_argument(self.flag, dest=self.dest, type=self.type, default=None,
                            metavar=self.metavar, help=f"{self.help}{shown}")

    def check(self, value):
        interval = Interval(self.interval)
        if not (math.isfinite(value) and value in interval):
            refuse(self.flag, f"must be {self.kind} in {interval}", value)


@dataclass(frozen=True)
class Integer(Real):
    """An integer option in ``interval``."""
    interval: str = "[1, inf)"
    kind = "an integer"
    type = int


@dataclass(frozen=True)
class Check:
    """A rule over several options: ``function(values)`` raises OptionError."""
    function: object

    def run(self, values):
        self.function(values)


def _amount(what, x):
    if what == "memory":
        for unit, size in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
            if x >= size:
                return f"{x / size:.3g} {unit}"
        return f"{x:.0f} B"
    if x >= 3600:
        return f"{x / 3600:.3g} h"
    if x >= 60:
        return f"{x / 60:.3g} min"
    return f"{x:.3g} s"


@dataclass(frozen=True)
class Budget:
    """An estimated cost (``what``: "run time" in s or "memory" in bytes)
    that must stay below ``limit`` unless ``--no-limits`` is given."""
    what: str
    estimate: object
    options: object = ()              # flags, or a function of the values giving them
    limit: object = None              # default: TIME_LIMIT or memory_limit(), read when run

    def run(self, values):
        cost = float(self.estimate(values))
        limit = self.limit(values) if callable(self.limit) else self.limit
        if limit is None:
            limit = memory_limit() if self.what == "memory" else TIME_LIMIT
        limit = float(limit)
        values.estimates[self.what] = cost
        if cost > limit and not getattr(values, "no_limits", False):
            # the options the cost grows with may depend on the run (a model's own)
            options = self.options(values) if callable(self.options) else self.options
            named = ", ".join(f"{o} {fmt(getattr(values, _dest(o)))}" for o in options)
            raise OptionError(options[0] if options else OVERRIDE,
                              f"{named}: estimated {self.what} {_amount(self.what, cost)} "
                              f"exceeds the limit of {_amount(self.what, limit)}; make the "
                              f"problem smaller or pass {OVERRIDE} to run anyway")


def _dest(flag):
    return flag.lstrip("-").replace("-", "_")


def _applies(spec, args):
    """Whether a number option applies to ``args`` (its ``when`` holds, if any)."""
    return spec.when is None or getattr(args, spec.when[0], None) == spec.when[1]


class OptionSet:
    """The validated options of one command (see the module docstring)."""

    def __init__(self, *specs):
        self.specs = specs

    @property
    def numbers(self):
        return [s for s in self.specs if isinstance(s, Real)]

    def add_to(self, parser):
        for spec in self.numbers:
            spec.add_to(parser)
        if any(isinstance(s, Budget) for s in self.specs):
            parser.add_argument(OVERRIDE, dest="no_limits", action="store_true",
                                help="run even when the estimated run time or memory is above "
                                     "the limits")
        return parser

    def validate(self, args):
        """Fill defaults into ``args`` and check every rule; raises OptionError."""
        given = {s.dest for s in self.numbers if getattr(args, s.dest, None) is not None}
        for spec in self.numbers:          # plain defaults first: callable ones may use them
            if spec.dest not in given and not callable(spec.default):
                setattr(args, spec.dest, spec.default)
        for spec in self.numbers:
            if spec.dest not in given and callable(spec.default):
                setattr(args, spec.dest, spec.default(args))
        args.given = given
        for spec in self.numbers:
            if spec.dest in given and not _applies(spec, args):
                dest, value, *why = spec.when
                actual, flag = getattr(args, dest), "--" + dest.replace("_", "-")
                raise OptionError(spec.flag, f"{spec.flag} does not apply to {flag} "
                                  f"{actual} (only to {flag} {value})"
                                  + (f": {why[0]}" if why else ""))
            value = getattr(args, spec.dest)
            if value is not None:
                spec.check(value)
        for spec in self.specs:
            if isinstance(spec, Check):
                spec.run(args)
        args.estimates = {}
        for spec in self.specs:
            if isinstance(spec, Budget):
                spec.run(args)
        return args

    def inapplicable(self, args):
        """Dests of the options that do not apply to ``args`` (their ``when``
        fails): they keep a default for the estimates but describe no run."""
        return {s.dest for s in self.numbers if not _applies(s, args)}

    @staticmethod
    def notice(args):
        """A line announcing a long run (estimated run time above NOTICE), or None."""
        cost = getattr(args, "estimates", {}).get("run time", 0.0)
        return f"estimated run time {_amount('run time', cost)}" if cost > NOTICE else None


def check_outputs(args, folders=("out",), files=("json",)):
    """Check the output options of ``args`` before any work: folders (``--out``)
    are created and probed, files (``--json``) must be regular files in a
    writable folder.  Raises :class:`knitfem.io.atomic.OutputError` (a
    ValueError) naming the option."""
    from .io.atomic import check_file_target, check_folder_writable
    for dest in folders:
        value = getattr(args, dest, None)
        if value:
            check_folder_writable(value, f"--{dest.replace('_', '-')}")
    for dest in files:
        value = getattr(args, dest, None)
        if value:
            check_file_target(value, f"--{dest.replace('_', '-')}")
