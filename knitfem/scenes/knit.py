"""A plain-knit swatch written to disk: the body of ``knitfem knit``.

    knitfem knit --nw 10 --nc 35 [--w 4] [--c 3] [--radius 0.4]
                 [--points-per-loop 32] [--no-bindoff] [--check] [--out DIR]
                 [--json FILE] [--no-render] [--quiet]

:func:`knit` builds the geometry (:func:`knitfem.geometry.plain_knit_swatch`),
optionally measures it (clearance, interlocks, touching) and writes
``knit_<nw>x<nc>.vtu`` (+ ``.png``); it returns a JSON-ready summary.
:func:`add_parser` registers the sub-command on the CLI's sub-parsers.
"""
import json
import time
from pathlib import Path

import numpy as np

from ..geometry import plain_knit_swatch
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


def add_parser(subparsers):
    """Register ``knit`` on an argparse sub-parsers object; returns the parser."""
    p = subparsers.add_parser(
        "knit", help="plain-knit swatch geometry: .vtu, render, summary",
        description="One serpentine yarn knitting an nw x nc stockinette swatch (knit face "
        "+z), bound off top and bottom by helical yarns; writes knit_<nw>x<nc>.vtu and .png.")
    p.add_argument("--nw", type=int, default=10, help="wales (loops per course), default 10")
    p.add_argument("--nc", type=int, default=35, help="courses, default 35")
    p.add_argument("--w", type=float, default=4.0, help="wale length (loop width), mm (4)")
    p.add_argument("--c", type=float, default=3.0, help="course length (loop height), mm (3)")
    p.add_argument("--radius", type=float, default=0.4, help="yarn radius, mm (0.4; < w/8)")
    p.add_argument("--points-per-loop", type=int, default=32, help="centreline points (32)")
    p.add_argument("--no-bindoff", action="store_true", help="leave out the bind-off helices")
    p.add_argument("--check", action="store_true",
                   help="measure clearance, interlocks and contact (slower)")
    p.add_argument("--out", help="folder for the .vtu and .png")
    p.add_argument("--json", help="write the summary JSON to this file")
    p.add_argument("--no-render", action="store_true", help="skip the pyvista render")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(run=run)
    return p


def run(args):
    """Run the parsed ``knit`` sub-command; exit code 0 (ValueError on bad input)."""
    summary = knit(args.nw, args.nc, args.w, args.c, args.radius,
                   points_per_loop=args.points_per_loop, bindoff=not args.no_bindoff,
                   out=args.out, render=not args.no_render, check=args.check)
    text = json.dumps(summary, indent=2)
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(text)
    if not args.quiet:
        print(text if not args.json else f"wrote {args.json}")
    return 0
