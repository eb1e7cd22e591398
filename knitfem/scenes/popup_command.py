"""``knitfem popup``: its options, their checks and cost estimates, and the run.

    knitfem popup [--model beam|bspline] [--w-over-L 0.2705] [--c-from 0.95]
                  [--c-to 0.45] [--c-step 0.05] [--elements N] [--relax static|dynamic]
                  [--poisson 0.5 | --gj-over-ei X] [--length 105] [--diameter 3]
                  [--out DIR] [--json FILE] [--no-render] [--quiet] [--no-limits]

Cost model (refusals above :data:`knitfem.options.TIME_LIMIT` or half the
memory, ``--no-limits`` to run anyway; constants measured on the loaded
2-core machine: 60 to 3840 elements at c-step 0.05 and 0.005 took
1.3-2.3e-4 s per element and per continuation point or sample):
beam: ``BEAM_S_PER_ELEMENT x elements x (CONTINUATION_STEPS + samples)``
seconds, each step a banded solve plus an inertia count; B-spline:
``BSPLINE_S x segments^2 x (samples + 8)`` seconds (a relaxation costs about
segments^2; 8 bisection steps) and its dense least-squares fit of 20
points per segment, ``8 x 20 s (s + 3)`` bytes.
"""
import math

from ..options import Budget, Check, Integer, OptionSet, Real, fmt, refuse

W_OVER_L = 28.4 / 105.0          # the paper's rod: w = 28.4 mm, L = 105 mm
BEAM_S_PER_ELEMENT = 1.5e-4      # s per element per step or sample (measured 1.3-2.3e-4)
CONTINUATION_STEPS = 50          # points of the three branches, 0.95 -> 0.45: 42-50 measured
BSPLINE_S = 6e-4                 # s per relaxation per segment^2 (32 segments: 0.6 s)
STATE_BYTES = 8 * 7 * 3          # x, q per node, a few copies per stored point


def samples(v):
    """c/L values sampled on the stable path: c_from, c_from - c_step, ... >= c_to."""
    return math.floor((v.c_from - v.c_to) / v.c_step + 1e-9) + 1


def seconds(v):
    if v.model == "bspline":
        return BSPLINE_S * v.elements**2 * (samples(v) + 8)
    return BEAM_S_PER_ELEMENT * v.elements * (CONTINUATION_STEPS + samples(v))


def memory(v):
    if v.model == "bspline":
        return 8.0 * 20 * v.elements * (v.elements + 3) * 2 + 8.0 * v.elements * samples(v) * 3
    return STATE_BYTES * (v.elements + 1) * (CONTINUATION_STEPS + samples(v)) \
        + 8.0 * 6 * (v.elements + 1) * 60          # banded Jacobian and its factor


def _shape(v):
    """The clamps must be closer than the rod is long: w/L and c/L on the circle."""
    hi = math.sqrt(1.0 - v.w_over_L**2)
    if not v.c_from < hi:
        refuse("--c-from", f"must be below sqrt(1 - (w/L)^2) = {fmt(hi)} for --w-over-L "
               f"{fmt(v.w_over_L)} (the clamps cannot be farther apart than L)", v.c_from)
    if not v.c_to < v.c_from:
        refuse("--c-to", f"must be below --c-from {fmt(v.c_from)} (the sweep goes down in c)",
               v.c_to)


def _slender(v):
    ratio = v.length / v.diameter
    if not 5.0 <= ratio <= 1e4:
        refuse("--diameter", f"must make a slender rod, --length/--diameter in [5, 10000] "
               f"(--length {fmt(v.length)}: diameter in [{fmt(v.length / 1e4)}, "
               f"{fmt(v.length / 5)}])", v.diameter)


def _both_torsion(v):
    if "poisson" in v.given and "gj_over_ei" in v.given:
        refuse("--gj-over-ei", "and --poisson both set the torsional stiffness: give one",
               v.gj_over_ei)


def _relax(v):
    if v.relax is not None and v.model != "bspline":
        refuse("--relax", "does not apply to --model beam (only to --model bspline: the beam "
               "path uses continuation)", v.relax)


_NO_TWIST = ("model", "beam", "the bspline model has no torsional stiffness (no twist energy)")

OPTIONS = OptionSet(
    Real("--w-over-L", W_OVER_L, "(0, 1)", help="wale length over rod length (28.4/105)"),
    Real("--c-from", 0.95, "(0, 1)", help="first c/L"),
    Real("--c-to", 0.45, "(0, 1)", help="last c/L"),
    Real("--c-step", 0.05, "(0, 1]", help="sampling of the output in c/L"),
    Integer("--elements", lambda v: 32 if v.model == "bspline" else 60, "[4, inf)",
            help="beam elements (default 60) or B-spline segments (default 32)"),
    Real("--poisson", None, "(-1, 0.5]", when=_NO_TWIST,
         help="beam model: Poisson ratio, GJ/EI = 1/(1+nu) (default 0.5)"),
    Real("--gj-over-ei", None, "[1e-06, 1e+06]", when=_NO_TWIST,
         help="beam model: explicit GJ/EI"),
    Real("--length", 105.0, "[0.001, 1e+06]", help="rod length L, mm"),
    Real("--diameter", 3.0, "(0, 1e+06]", help="rod diameter, mm"),
    Check(_shape), Check(_slender), Check(_both_torsion), Check(_relax),
    Budget("memory", memory, ("--elements", "--c-step")),
    Budget("run time", seconds, ("--elements", "--c-step")),
)

OUTPUTS = ("branch.csv", "branches.csv", "popup.json", "popup_z.png", "popup_c*.png",
           "popup_c*.vtu", "shapes/popup_c*.vtu", "shapes/popup.pvd")


def add_parser(subparsers):
    from ..cli import add_command, add_output_options
    p = add_command(
        subparsers, "popup", run, OPTIONS, OUTPUTS,
        help="S-rod pop-up by continuation in c/L (paper Fig. 4)",
        description="Clamped S-rod (half a knitted loop): continuation in c/L from --c-from "
        "down to --c-to, the out-of-plane bifurcation, both popped branches, and the stable "
        "path sampled every --c-step.")
    p.add_argument("--model", choices=("beam", "bspline"), default="beam",
                   help="beam: Simo-Reissner rod + continuation (default); bspline: the "
                   "independent yarn-level model (no twist energy), relaxed point by point")
    p.add_argument("--relax", choices=("static", "dynamic"), default=None,
                   help="bspline model: L-BFGS (static, default) or dynamic relaxation")
    return add_output_options(p, "folder for CSV, .vtu, plot and render")


def run(args):
    """Run the validated ``popup`` command; exit code 0."""
    from ..cli import run_folder, write_summary
    from . import popup_output
    from .srod import SRod, popup
    srod = SRod(length=args.length, w=args.w_over_L * args.length, diameter=args.diameter,
                poisson=SRod.poisson if args.poisson is None else args.poisson,
                gj_over_ei=args.gj_over_ei, elements=args.elements)
    with run_folder(args):
        if args.model == "bspline":
            from .srod_bspline import bspline_popup
            result = bspline_popup(srod, args.c_from, args.c_to, args.c_step,
                                   segments=args.elements, method=args.relax or "static",
                                   progress=not args.quiet)
            write = popup_output.write_bspline_popup
        else:
            result = popup(srod, args.c_from, args.c_to, args.c_step)
            write = popup_output.write_popup
        summary = result.summary()
        if args.out:
            write(result, args.out, render=not args.no_render)
        write_summary(args, summary, f"critical c/L = {summary['critical_c_over_L']}, "
                      f"elapsed {summary['elapsed_s']:.3f} s; wrote {args.json}")
    return 0
