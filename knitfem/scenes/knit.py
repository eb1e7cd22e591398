"""A plain-knit swatch written to disk: the body of ``knitfem knit``.

    knitfem knit --nw 10 --nc 35 [--w 4] [--c 3] [--radius 0.4]
                 [--points-per-loop 32] [--no-bindoff] [--check] [--out DIR]
                 [--json FILE] [--no-render] [--quiet]

:func:`knit` builds the geometry (:func:`knitfem.geometry.plain_knit_swatch`),
optionally measures it (clearance, interlocks, touching) and writes
``knit_<nw>x<nc>.vtu`` (+ ``.png``); it returns a JSON-ready summary.
:func:`add_parser` registers the sub-command on the CLI's sub-parsers, with
its options checked (:data:`OPTIONS`) and its cost estimated before any
work (:func:`seconds`, :func:`memory`; constants measured on the 2-core
machine).
"""
import time
from pathlib import Path

import numpy as np

from ..geometry import plain_knit_swatch
from ..geometry.knit import course_length_range
from ..options import Budget, Check, Integer, OptionSet, Real, fmt, refuse
from ..verify.knit import approach_near, bend_radii, clearance, loop_polyline, projected_crossings


def measure(swatch):
    """Clearance (min centreline distance / 2r away from neighbours within 4 r
    along a yarn), tightest bend / r, interlocked loop pairs (opposite
    over/under on both sides of each wale) and the closest approach / 2r at
    the interlock crossings."""
    r, w = swatch.radius, swatch.loop.w
    ratio, _ = clearance([y.points for y in swatch.yarns], r, exclude=4.0 * r)
    knit = swatch.yarns[0]
    locked, approach = 0, []
    for k in range(1, swatch.n_course):
        for j in range(swatch.n_wale):
            a, b = loop_polyline(knit, k, j), loop_polyline(knit, k - 1, j)
            x = projected_crossings(a, b)
            sides = (x[x[:, 3] < j * w], x[x[:, 3] > j * w])
            locked += all(len(s) == 2 and s[0, 2] * s[1, 2] < 0 for s in sides)
            approach += [approach_near(a, b, row[3:5], 2.0 * r) / (2.0 * r) for row in x]
    return {"clearance_over_2r": float(ratio),
            "min_bend_radius_over_r": float(min(np.nanmin(bend_radii(y.points))
                                                for y in swatch.yarns) / r),
            "interlocked_loop_pairs": int(locked),
            "loop_pairs": (swatch.n_course - 1) * swatch.n_wale,
            "crossing_approach_over_2r": [float(min(approach, default=np.nan)),
                                          float(max(approach, default=np.nan))]}


def knit(n_wale, n_course, w=4.0, c=3.0, radius=0.4, *, points_per_loop=32, bindoff=True,
         out=None, render=True, check=False, name=None):
    """Build the swatch, write it to ``out`` (if given) and return a summary:
    sizes, the loop's shape numbers, yarn lengths, point counts, files, the
    wall times to build, to write the .vtu and to render (without imports),
    and with ``check`` :func:`measure` (on the swatch resampled r/4 apart)."""
    t0 = time.perf_counter()
    s = plain_knit_swatch(n_wale, n_course, w, c, radius, points_per_loop=points_per_loop,
                          bindoff=bindoff)
    built = time.perf_counter() - t0
    loop = s.loop
    summary = {"n_wale": s.n_wale, "n_course": s.n_course, "w": loop.w, "c": loop.c,
               "radius": loop.radius, "points_per_loop": points_per_loop, "bindoff": bindoff,
               "loop": {"roundness_a": loop.a, "half_height_h": loop.h, "depth_d": loop.d,
                        "thickness": loop.thickness,
                        "yarn_length_per_loop": s.yarn_length_per_loop},
               "yarn_lengths": [y.length for y in s.yarns],
               "points": int(sum(len(y.points) for y in s.yarns)),
               "build_s": built}
    if out is not None:
        from ..io import write_mesh
        from ..io.swatch import render_swatch, swatch_mesh
        name = name or f"knit_{s.n_wale}x{s.n_course}"
        t1 = time.perf_counter()
        mesh = swatch_mesh(s)
        paths = [write_mesh(Path(out) / f"{name}.vtu", mesh)]
        summary["write_s"] = time.perf_counter() - t1
        if render:
            t2 = time.perf_counter()
            paths.append(render_swatch(s, Path(out) / f"{name}.png", mesh=mesh))
            summary["render_s"] = time.perf_counter() - t2
        summary["files"] = [str(p) for p in paths]
    if check:       # on the same swatch sampled r/4 apart: point pairs then miss < 1e-3 r
        dense = max(points_per_loop, int(np.ceil(4.0 * loop.length / loop.radius)))
        summary["check"] = measure(plain_knit_swatch(n_wale, n_course, w, c, radius,
                                                     points_per_loop=dense, bindoff=bindoff))
        summary["check"]["points_per_loop"] = dense
    return summary


def _sizes(v):
    """radius < w/8 and c in the course-length range of (w, radius)."""
    if not v.radius < v.w / 8.0:
        refuse("--radius", f"must be below --w/8 = {fmt(v.w / 8.0)} (two legs and two "
               f"interlocks share a wale)", v.radius)
    lo, hi = course_length_range(v.w, v.radius)
    if not lo <= v.c <= hi:
        refuse("--c", f"must be in [{fmt(lo)}, {fmt(hi)}] for --w {fmt(v.w)} and --radius "
               f"{fmt(v.radius)} (max(5 r, 1.4 sqrt(r w)) <= c <= min(0.4 w^2/r, 4 w))", v.c)


def _loop_samples(v):
    """Samples of the loop's interlock solve (:func:`knit_loop`): loop length / (r/10)."""
    return max(600.0, (2.0 * v.w + 3.0 * v.c) / (0.1 * v.radius))


def _points(v):
    """Centreline points: loops, turn-arounds and bind-off (and --check's dense copy)."""
    n = v.points_per_loop * (v.nw * v.nc + v.nc + (0 if v.no_bindoff else 2 * v.nw))
    if v.check:
        n *= 1.0 + max(1.0, 4.0 * (2.0 * v.w + 3.0 * v.c) / v.radius / v.points_per_loop)
    return n


def seconds(v):
    """The loop solve (5 root-finding steps, each growing like the square of
    its samples: measured 17 s at r = 0.004, w = 4), building and writing
    the points, rendering, and --check's per-loop measurements."""
    t = LOOP_S * _loop_samples(v) ** 2 + POINT_S * _points(v)
    if not v.no_render and v.out:
        t += 5.0 + RENDER_S * _points(v)
    if v.check:
        t += CHECK_S * v.nw * v.nc
    return t


def memory(v):
    per_point = 300.0 + (1e4 if v.out and not v.no_render else 0.0)   # render: 24-sided tubes
    return 400.0 * _loop_samples(v) + per_point * _points(v)


LOOP_S, POINT_S, RENDER_S, CHECK_S = 1.5e-8, 3e-6, 1e-4, 2e-3

OPTIONS = OptionSet(
    Integer("--nw", 10, "[1, inf)", help="wales (loops per course)"),
    Integer("--nc", 35, "[1, inf)", help="courses"),
    Real("--w", 4.0, "(0, 1e+06]", help="wale length (loop width), mm"),
    Real("--c", 3.0, "(0, 1e+06]", help="course length (loop height), mm"),
    Real("--radius", 0.4, "(0, 1e+06]", help="yarn radius, mm (< w/8)"),
    Integer("--points-per-loop", 32, "[8, inf)", help="centreline points per loop"),
    Check(_sizes),
    Budget("memory", memory, ("--nw", "--nc", "--points-per-loop", "--radius")),
    Budget("run time", seconds, ("--nw", "--nc", "--points-per-loop", "--radius")),
)


def _outputs(args):
    """The files of this swatch only: one folder may collect several sizes."""
    name = f"knit_{args.nw}x{args.nc}"
    return (f"{name}.vtu", f"{name}.png")


def add_parser(subparsers):
    """Register ``knit`` on the CLI's sub-parsers; returns the parser."""
    from ..cli import add_command, add_output_options
    p = add_command(
        subparsers, "knit", run, OPTIONS, _outputs, remove_listed=False,
        help="plain-knit swatch geometry: .vtu, render, summary",
        description="One serpentine yarn knitting an nw x nc stockinette swatch (knit face "
        "+z), bound off top and bottom by helical yarns; writes knit_<nw>x<nc>.vtu and .png.")
    p.add_argument("--no-bindoff", action="store_true", help="leave out the bind-off helices")
    p.add_argument("--check", action="store_true",
                   help="measure clearance, interlocks and contact (slower)")
    return add_output_options(p, "folder for the .vtu and .png")


def run(args):
    """Run the validated ``knit`` sub-command; exit code 0."""
    from ..cli import run_folder, write_summary
    with run_folder(args):
        summary = knit(args.nw, args.nc, args.w, args.c, args.radius,
                       points_per_loop=args.points_per_loop, bindoff=not args.no_bindoff,
                       out=args.out, render=not args.no_render, check=args.check)
        write_summary(args, summary, f"wrote {args.json}")
    return 0
