"""``knitfem curl``: its options, their checks and cost estimate, and the run.

    knitfem curl --nw 10 --nc 35 [--model beam|bspline] [--alpha 0.2]
                 [--w 4 --c 3 --radius 0.4] [--elements-per-loop 32]
                 [--gj-over-ei 0.667] [--ea-over-ei 800] [--friction 0.3]
                 [--friction-frame corotated|anchor] [--bindoff-stiffness 10]
                 [--bindoff-prestretch] [--tail-ties 1] [--straighten 1] [--paths default,coarse]
                 [--reanchor SHARE] [--exact-tries 4] [--max-rounds 4] [--snap-rounds 8]
                 [--settle N]
                 [--max-time 1800] [--rest-tol 0.1] [--out DIR]
                 [--json FILE] [--resume] [--no-render] [--quiet] [--no-limits]

Cost model (beam): ``S_PER_DOF_ITERATION x unknowns x ITERATIONS x loops^0.25``
seconds; (bspline) ``--max-time`` plus ``BSPLINE_S_PER_LOOP`` a loop; refused above
the library's time limit unless ``--no-limits``.
Calibrated on the 80 finished beam relaxations on record (co-rotated
friction, 4 x 4 to 25 x 35, 16-48 elements per loop, on the shared 2-core
machine with 0-2 other jobs; ``python studies/runtime_estimate.py``,
2026-12-05): the medians of their seconds per unknown and iteration
(1.45e-5) and of their iterations over ``loops^0.25`` (1 950 at 5 x 5).  So
the estimate is a median: half the runs took longer, the measured / estimated
ratios of 90 % of them within x0.39-x2.7 (x0.31-x5.9 at the extremes):
friction rounds make the iteration count path dependent, a failed increment
costs its rounds, the load of the machine moves the per-iteration cost.
"""
import math
import sys

from ..options import Budget, Check, Integer, OptionSet, Real, fmt, refuse

S_PER_DOF_ITERATION = 1.45e-5     # s per unknown per minimisation iteration (see above)
ITERATIONS = 1950                 # minimisation iterations of a 5 x 5 relaxation


def expected_iterations(loops):
    """Minimisation iterations the cost model expects of a beam relaxation of
    ``loops`` = N_w N_c loops (a number or an array)."""
    return ITERATIONS * (loops / 25.0) ** 0.25


def _bspline(v):
    return getattr(v, "model", "beam") == "bspline"


def unknowns(v):
    """Beam unknowns: 6 per node, elements_per_loop nodes per loop, plus turns and bind-off
    (the bspline model: its 16 segments per loop, as the beam's 16 once were)."""
    per_loop = 16 if _bspline(v) else v.elements_per_loop
    return 6 * per_loop * (v.nw * v.nc + 2 * v.nw + v.nc)


BSPLINE_S_PER_LOOP = 0.1          # building, classifying, writing: 13 s at 10 x 35 (0.04 s)


def seconds(v):
    if _bspline(v):
        # FIRE stops at --max-time; a Newton finish runs only after it converged
        return v.max_time + BSPLINE_S_PER_LOOP * v.nw * v.nc
    paths = getattr(v, "paths", None)
    if paths is not None:                   # one run per schedule (checked before budgets)
        from .curl_paths import parse_paths
        runs = len(parse_paths(paths))
    else:
        runs = 1
    return runs * S_PER_DOF_ITERATION * unknowns(v) * expected_iterations(v.nw * v.nc)


def memory(v):
    # sparse factor: ~60 nonzeros per unknown per sqrt(loops) (measured fill of the
    # knit tangents: 1.5e7 for 1.9e5 unknowns at 55 x 35)
    return 8.0 * 60.0 * unknowns(v) * math.sqrt(v.nw * v.nc) * 2


def _yarn_fits(v):
    if not v.radius < v.w / 8.0:
        refuse("--radius", f"must be below --w/8 = {fmt(v.w / 8.0)} (two legs and a head side "
               "by side in one wale)", v.radius)
    lo, hi = max(5.0 * v.radius, 1.4 * math.sqrt(v.radius * v.w)), \
        min(0.4 * v.w * v.w / v.radius, 4.0 * v.w)
    if not lo <= v.c <= hi:
        refuse("--c", f"must be in [{fmt(lo)}, {fmt(hi)}] for --w {fmt(v.w)} and --radius "
               f"{fmt(v.radius)} (tighter bends than the yarn)", v.c)
    inflation = getattr(v, "inflation", None)
    if inflation is not None and not v.radius * (1.0 + inflation) < v.w / 8.0:
        refuse("--inflation", f"must be below --w/(8 --radius) - 1 = "
               f"{fmt(v.w / (8.0 * v.radius) - 1.0)} (the knitted radius below --w/8)", inflation)


def _resume_needs_out(v):
    if getattr(v, "resume", False) and not getattr(v, "out", None):
        refuse("--resume", "needs --out (the folder holding the checkpoint)", True)


RESUME = Check(_resume_needs_out)     # knitfem curl's own (not a sweep study's --resume)


def _beam_only_flags(v):
    frame = getattr(v, "friction_frame", None)
    if frame is not None and _bspline(v):
        refuse("--friction-frame", "applies to --model beam only (the bspline model is "
               "frictionless)", frame)
    if getattr(v, "bindoff_prestretch", False) and _bspline(v):
        refuse("--bindoff-prestretch", "applies to --model beam only (the bspline bind-off "
               "keeps its knitted length)", True)
    if _bspline(v) and getattr(v, "straighten", 1.0) not in (0.0, 1.0):
        refuse("--straighten", "must be 0 or 1 with --model bspline (its yarn is naturally "
               "straight or has the knitted shape as its natural one)", v.straighten)
    paths = getattr(v, "paths", None)
    if paths is not None:
        from .curl_paths import SCHEDULES, parse_paths
        if _bspline(v):
            refuse("--paths", "applies to --model beam only (the bspline relaxation has no "
                   "homotopy)", paths)
        if parse_paths(paths) is None:
            refuse("--paths", f"must list distinct schedules of {', '.join(SCHEDULES)}, "
                   "comma-separated", paths)

_NO_TWIST = ("model", "beam", "the bspline model has no torsional stiffness (no twist energy)")

OPTIONS = OptionSet(
    # the curl classification needs 3 wales and 4 courses of loop centres
    Integer("--nw", 10, "[3, 200]", help="wales N_w"),
    Integer("--nc", 35, "[4, 200]", help="courses N_c"),
    Real("--alpha", 0.2, "[0, 0.5]", help="pre-stretch ratio: rest length (1 - alpha) x knitted"),
    Real("--w", 4.0, "(0, 1000]", help="wale length (loop width), mm"),
    Real("--c", 3.0, "(0, 1000]", help="course length (loop height), mm"),
    Real("--radius", 0.4, "(0, 1000]", help="yarn radius, mm"),
    Integer("--elements-per-loop", 32, "[8, 64]",
            help="beam elements per loop (16 locks the yarn's sliding: README)",
            when=("model", "beam", "the bspline model has 16 B-spline segments per loop")),
    Real("--gj-over-ei", 2.0 / 3.0, "[1e-06, 100]", when=_NO_TWIST,
         help="torsional over bending stiffness"),
    Real("--ea-over-ei", 800.0, "[1, 1e+06]", help="stretching over bending stiffness, 1/mm^2"),
    Real("--friction", 0.3, "[0, 2]", help="Coulomb friction coefficient between yarns",
         when=("model", "beam", "the bspline model is frictionless, as the paper's")),
    Real("--max-time", 1800.0, "(0, 1e+06]", when=("model", "bspline", "the beam relaxation "
         "runs to convergence or fails"), help="bspline: seconds of relaxation before the "
         "last state is reported as not converged"),
    Real("--rest-tol", 0.1, "(0, 100]", when=("model", "bspline", "the beam relaxation ends "
         "on Newton at a relative residual of 1e-8"), help="bspline: the largest move to the "
         "nearest equilibrium (one Newton step), in yarn radii, that counts as at rest; FIRE "
         "goes on to smaller residuals until it holds (README: 'At rest, not only a small "
         "residual')"),
    Real("--bindoff-stiffness", 10.0, "[0.01, 1000]",
         help="bind-off stiffness relative to the yarn's"),
    Real("--straighten", 1.0, "[0, 1]", help="share of its knitted curvature the knit yarn "
         "loses over the relaxation (1: naturally straight, the paper's yarn; 0: it keeps its "
         "knitted shape as its natural one, pre-stretched all the same: a yarn set by the "
         "knitting; the bspline model takes 0 or 1)"),
    Integer("--tail-ties", 1, "[1, 4]", when=("model", "beam", "the bspline scene ties "
            "each tail at its end"), help="beam: points of each yarn tail tied into the other "
            "yarn (1: its end; n > 1: its last n points, each to the two nearest, holding "
            "the tail's direction)"),
    Real("--inflation", None, "[0, 0.5]", when=("model", "beam", "the bspline swatch is "
         "fitted to the knitted points as they are"),
         help="beam: radius inflation the swatch is knitted with, a fraction (default: the "
         "smallest multiple of 0.02 that keeps every pair outside the contact skin; it grows "
         "as --elements-per-loop falls: give one to hold the knitted geometry fixed)"),
    Real("--reanchor", None, "(0, 10]", when=("model", "beam", "the bspline model is "
         "frictionless"), help="beam: end a friction round early, to anchor the friction of "
         "the contacts formed in it, once the segments that came into contact exceed this "
         "share of those touching at the round's start (and 4; default: rounds run "
         "whole; README: 'Re-anchoring as contacts form')", metavar="SHARE"),
    Integer("--exact-tries", None, "[1, 8]", when=("model", "beam", "the bspline "
            "relaxation takes no Newton steps on its way"), help="beam: shifts of the exact "
            "Hessian (mu, 10 mu, ...) a minimisation step tries before it takes the per-block "
            "positive semi-definite model (default 4; README: 'Fewer shifts of the exact "
            "Hessian'). Part of the path: a resume keeps it"),
    Integer("--max-rounds", None, "[1, 50]", when=("model", "beam", "the bspline "
            "relaxation has no friction rounds"), help="beam: friction rounds an increment "
            "may take before it is halved (default 4; twice that at lam = 1). A resume may "
            "change it (recorded under the summary's protocol, budget_changes): past a snap "
            "the swatch needs more rounds than 4, and halving the increment never ends "
            "(README: 'A snap near lam 0.8')"),
    Integer("--snap-rounds", None, "[0, 50]", when=("model", "beam", "the bspline "
            "relaxation has no friction rounds"), help="beam: rounds an increment may take "
            "beyond --max-rounds while each slides the swatch more than a yarn radius (a snap "
            "under way, which a halved increment would come back to; default 8, 0: halve at "
            "once as before 2026-12-05). A resume may change it (recorded like a --max-rounds change)"),
    Integer("--settle", None, "[0, 20]", when=("model", "beam", "the bspline "
            "relaxation has no friction rounds"), help="beam: up to this many more passes of "
            "the final increment's friction rounds (its budget each) while the friction has "
            "not settled (default 0). With --resume on a finished run whose friction did not "
            "settle, they are all that runs (recorded like a --max-rounds change)"),
    Check(_yarn_fits),
    RESUME,
    Check(_beam_only_flags),
    Budget("memory", memory, ("--nw", "--nc", "--elements-per-loop")),
    Budget("run time", seconds, lambda v: ("--max-time", "--nw", "--nc") if _bspline(v)
           else ("--nw", "--nc", "--elements-per-loop")),
)


def outputs(args):
    """The files of a run (stale ones are removed first); a resumed run keeps its
    checkpoint and the relaxation path written so far."""
    if _bspline(args):
        name = f"bspline_{args.nw}x{args.nc}"
        final = (f"{name}.vtu", f"{name}.json", f"{name}_control.npy")
        return final if args.resume else final + (f"{name}_checkpoint.npz",)
    name = f"curl_{args.nw}x{args.nc}"
    final = (f"{name}.vtu", f"{name}.json", f"{name}_*.png")
    run = ("checkpoint.npz", "path/step_*.vtu", "path/path.pvd")
    if getattr(args, "paths", None) is not None:
        # one folder per schedule; a finished path's answer is what a resume keeps
        run += tuple(f"path_*/{f}" for f in final + run)
    return final if args.resume else final + run


def add_parser(subparsers):
    from ..cli import add_command, add_output_options
    p = add_command(
        subparsers, "curl", run, OPTIONS, outputs, remove_listed=False,
        help="fabric curling: relax a plain-knit swatch and classify its curl (paper Fig. 5c)",
        description="Relax an N_w x N_c plain-knit swatch (beams, contact with friction, tails "
        "tied into the bind-off, pre-stretch) to a static equilibrium and classify its curl: "
        "side, double, top_bottom or flat.")
    p.add_argument("--model", choices=("beam", "bspline"), default="beam",
                   help="beam: Simo-Reissner rods (default); bspline: the paper's own "
                   "yarn-level model")
    p.add_argument("--resume", action="store_true",
                   help="continue from the checkpoint in --out (same options)")
    p.add_argument("--friction-frame", choices=("corotated", "anchor"), default=None,
                   help="beam: the friction forces' tangent planes turn with the master yarn "
                   "within a friction round (corotated, default) or stay those of the round's "
                   "start (anchor: the code before 2026-12-02)")
    p.add_argument("--paths", default=None, metavar="SCHEDULES",
                   help="beam: relax along each of these homotopy schedules (comma-separated: "
                   "default, coarse, fine, thirds) into --out/path_<name>/ and report "
                   "every answer; the swatch's curl is the lowest-energy converged, stable one's, "
                   "curl_types the set (a knit held by friction can land on more than one)")
    p.add_argument("--bindoff-prestretch", action="store_true",
                   help="beam: the bind-off helices' rest length shrinks by --alpha with the "
                   "knit yarn's (they keep their turns); default: they keep their knitted "
                   "length and the knit edge ends narrower than its bind-off")
    return add_output_options(p, "folder: relaxation path, final .vtu, renders, checkpoint")


# the options that go to the relaxation (relax_fabric keywords), not the scene
PROTOCOL = ("reanchor", "max_rounds", "snap_rounds", "settle", "exact_tries")


def relax_protocol(reanchor=None, max_rounds=None, snap_rounds=None, settle=None,
                   exact_tries=None):
    """The relaxation options of a beam run (:data:`PROTOCOL`), those at their
    default left out; None when none is left (a run with the defaults names no
    protocol, and its checkpoints and summary say so)."""
    from ..solve.minimize import SHIFTS
    from .fabric_rounds import MAX_ROUNDS, SNAP_ROUNDS
    protocol = {"reanchor": reanchor} if reanchor is not None else {}
    if exact_tries is not None and exact_tries != SHIFTS:
        protocol["exact_tries"] = exact_tries
    if max_rounds is not None and max_rounds != MAX_ROUNDS:
        protocol["max_rounds"] = max_rounds
    if snap_rounds is not None and snap_rounds != SNAP_ROUNDS:
        protocol["snap_rounds"] = snap_rounds
    if settle:
        protocol["settle"] = settle
    return protocol or None


def protocol_of(args):
    """:func:`relax_protocol` of parsed ``curl`` options."""
    return relax_protocol(**{k: getattr(args, k) for k in PROTOCOL})


def scene_of(args):
    """The beam :class:`~.fabric.FabricScene` of parsed ``curl`` options."""
    from .fabric import FabricScene
    return FabricScene(args.nw, args.nc, w=args.w, c=args.c, radius=args.radius,
                       elements_per_loop=args.elements_per_loop, alpha=args.alpha,
                       ea_over_ei=args.ea_over_ei, gj_over_ei=args.gj_over_ei,
                       bindoff_stiffness=args.bindoff_stiffness, friction=args.friction,
                       inflation=args.inflation, bindoff_prestretch=args.bindoff_prestretch,
                       tail_ties=args.tail_ties, straighten=args.straighten,
                       corotated_friction=(args.friction_frame or "corotated") == "corotated")


def _cycle_note(summary):
    """What the state two rounds before says of an unsettled answer."""
    two = summary.get("two_round_move_over_r")
    if two is None:
        return ""
    last = summary["last_round_move_over_r"]
    if two < 0.5 * last:
        return (f"; two rounds apart it moved {two:.3g} yarn radii: the rounds cycle between "
                "two states, each an equilibrium for the other's friction anchors")
    if two > 1.5 * last:
        return f"; two rounds apart it moved {two:.3g} yarn radii: a creep, not a cycle"
    return f"; two rounds apart it moved {two:.3g} yarn radii: neither a cycle nor a creep"


def run(args):
    """Run the validated ``curl`` command; exit code 0, or 3 when the relaxation failed
    or did not converge (the summary, saying so, is still written)."""
    from ..cli import run_folder, write_summary
    with run_folder(args):
        if args.model == "bspline":
            from .curl_bspline import bspline_curl_from_options
            summary = bspline_curl_from_options(args)
        else:
            from .curl import curl
            scene = scene_of(args)
            protocol = protocol_of(args)
            if args.paths is not None:
                from .curl_paths import curl_paths, parse_paths
                summary = curl_paths(scene, parse_paths(args.paths), out=args.out,
                                     render=not args.no_render, progress=not args.quiet,
                                     resume=args.resume, relax_options=protocol)
            else:
                summary = curl(scene, out=args.out, render=not args.no_render,
                               progress=not args.quiet, resume=args.resume,
                               relax_options=protocol)
        verdict = f"{summary['curl']} curl" if summary["curl"] is not None else \
            f"relaxation failed: {summary['error']}"
        write_summary(args, summary, f"{verdict}, converged {summary['converged']}, "
                      f"stable {summary['stable']}; wrote {args.json}")
    failed = summary.get("error") is not None or not summary["converged"]
    if args.model == "beam" and args.friction == 0.0:
        # accepted (a frictionless run made with them resumes with them), not hidden
        idle = [f for f, v in (("--friction-frame", args.friction_frame),
                               ("--reanchor", args.reanchor)) if v is not None]
        if idle:
            print(f"knitfem curl: note: {' and '.join(idle)} did nothing: without friction "
                  "there are no friction planes nor anchors", file=sys.stderr)
    if summary.get("friction_settled") is False:
        # an equilibrium, but for the last round's lagged friction anchors
        print(f"knitfem curl: the friction did not settle: its last round moved the swatch by "
              f"{summary['last_round_move_over_r']:.3g} yarn radii (rounds budget spent"
              f"{_cycle_note(summary)}); "
              f"another round would move the answer (--resume --settle N runs more passes of "
              f"its rounds, up to N in all: {summary.get('settle_passes', 0)} run so far)",
              file=sys.stderr)
    if failed and args.quiet:            # quiet hides the progress, never a failure
        print(f"knitfem curl: {verdict}, converged {summary['converged']}", file=sys.stderr)
    return 3 if failed else 0
