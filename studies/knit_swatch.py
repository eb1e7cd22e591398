"""Study: plain-knit swatch geometry (issue 5), its checks and its build time.

    python studies/knit_swatch.py --nw 10 --nc 35 --out studies/results/knit_swatch
    python studies/knit_swatch.py --meshes meshes --runs 0      # the committed meshes

Writes ``<out>/knit_<nw>x<nc>.vtu`` + ``.png`` and ``<out>/knit_swatch.json``
(loop shape, yarn lengths, measured clearance / interlocks / contact, timings),
then times building + writing (.vtu) a 90 x 30 swatch: median of ``--runs``
runs after a warm-up (target < 2 s; imports and the render not included).
``--meshes DIR`` also writes ``knit_5x5`` and ``knit_10x35`` (.vtu + .png).

Sizes (defaults and committed meshes): w = 4 mm, c = 3 mm, yarn radius 0.4 mm.
With d = 0.8 mm that is w = 5 d and c = 3.75 d, c/w = 0.75: a relaxed plain
knit (Munden's constants give c/w = 3.8/5.0 = 0.76 and a loop length of
about 5 c = 15 mm; the closed form gives 15.6 mm = 19.5 d).  A radius of
0.5 mm would be w/8, the jamming limit of the loop (two legs and two head
sides side by side in one wale), where no clearance is left.
"""
import argparse
import statistics
import tempfile
import time
from pathlib import Path

from knitfem.geometry import plain_knit_swatch
from knitfem.io import write_json
from knitfem.io.swatch import write_swatch
from knitfem.scenes.knit import knit

W, C, RADIUS = 4.0, 3.0, 0.4


def time_build_and_write(n_wale=90, n_course=30, runs=5, **sizes):
    """Wall times (s) of plain_knit_swatch + write .vtu, one warm-up first."""
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(runs + 1):
            t0 = time.perf_counter()
            s = plain_knit_swatch(n_wale, n_course, **sizes)
            write_swatch(s, tmp, render=False)
            if i:
                times.append(time.perf_counter() - t0)
    return times, sum(len(y.points) for y in s.yarns)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--nw", type=int, default=10)
    parser.add_argument("--nc", type=int, default=35)
    parser.add_argument("--w", type=float, default=W)
    parser.add_argument("--c", type=float, default=C)
    parser.add_argument("--radius", type=float, default=RADIUS)
    parser.add_argument("--points-per-loop", type=int, default=32)
    parser.add_argument("--out", default="studies/results/knit_swatch")
    parser.add_argument("--meshes", help="also write knit_5x5 and knit_10x35 here")
    parser.add_argument("--runs", type=int, default=5, help="timing runs of 90 x 30 (0: skip)")
    parser.add_argument("--no-render", action="store_true")
    args = parser.parse_args()
    # the meshes and the timing are knitted like the main swatch
    sizes = {"w": args.w, "c": args.c, "radius": args.radius,
             "points_per_loop": args.points_per_loop}

    summary = knit(args.nw, args.nc, **sizes, out=args.out, render=not args.no_render,
                   check=True)
    loop, chk = summary["loop"], summary["check"]
    print(f"{args.nw} x {args.nc}, w = {args.w}, c = {args.c}, r = {args.radius}: "
          f"a = {loop['roundness_a']:.4f}, h = {loop['half_height_h']:.4f}, "
          f"d = {loop['depth_d']:.4f} (d/r = {loop['depth_d'] / args.radius:.3f}), "
          f"thickness {loop['thickness']:.3f}, yarn per loop {loop['yarn_length_per_loop']:.4f}")
    print(f"  clearance / 2r = {chk['clearance_over_2r']:.4f} (>= 0.95), tightest bend / r = "
          f"{chk['min_bend_radius_over_r']:.3f}, interlocked {chk['interlocked_loop_pairs']}/"
          f"{chk['loop_pairs']}, crossing approach / 2r = "
          f"{chk['crossing_approach_over_2r'][0]:.4f} .. {chk['crossing_approach_over_2r'][1]:.4f}")
    if args.meshes:
        for nw, nc in ((5, 5), (10, 35)):
            paths = write_swatch(plain_knit_swatch(nw, nc, **sizes), args.meshes,
                                 render=not args.no_render)
            print("  wrote", ", ".join(str(p) for p in paths))
    if args.runs > 0:
        times, points = time_build_and_write(runs=args.runs, **sizes)
        med = statistics.median(times)
        summary["bench_90x30"] = {"runs_s": times, "median_s": med, "points": points,
                                  "target_s": 2.0}
        print(f"90 x 30 ({points} points): build + write .vtu, median of {len(times)} runs "
              f"{med:.3f} s (min {min(times):.3f}, max {max(times):.3f}; target < 2 s)")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "knit_swatch.json", summary)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
