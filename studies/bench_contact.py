"""Benchmark of the yarn-yarn contact (issue 6).

1. Broad + narrow phase time for 1e3, 1e4, 1e5 segments of a plain-knit
   swatch (the real arrangement: interlocking crossings and parallel legs),
   residual only and with the consistent tangent; medians.
2. Newton iterations per load step with contact active in the two-ply
   (two clamped rods turned one full turn about each other).
3. Penetration and iterations against the penalty stiffness over 4 decades:
   crossed beams pushed together, and a yarn pressed onto a parallel yarn by
   the design line load q = EI/r^3 (gap against the law's closed form).

    python studies/bench_contact.py --out studies/results/bench_contact
"""
import argparse
import time
from pathlib import Path

import numpy as np

from knitfem import BeamModel, Rod, Section
from knitfem.contact import PenaltyLaw, SegmentContact
from knitfem.geometry import plain_knit_swatch
from knitfem.io import write_json
from knitfem.verify.cases import yarn_on_yarn

R = 0.4


def knit_segments(target):
    """Segments (x0, x1), yarn ids and midpoint arclengths of a square-ish swatch
    with about ``target`` segments (16 points per loop)."""
    n = max(2, int(round(np.sqrt(target / 16.0))))
    swatch = plain_knit_swatch(n, n, 4.0, 3.0, R, points_per_loop=16, bindoff=False)
    x0, x1, rod, s_mid = [], [], [], []
    for k, yarn in enumerate(swatch.yarns):
        p = yarn.points
        x0.append(p[:-1])
        x1.append(p[1:])
        rod.append(np.full(len(p) - 1, k))
        ds = np.linalg.norm(np.diff(p, axis=0), axis=1)
        s_mid.append(np.cumsum(ds) - 0.5 * ds)
    return (np.concatenate(x0), np.concatenate(x1), np.concatenate(rod),
            np.concatenate(s_mid))


def timing(targets, repeat):
    rows = []
    law = PenaltyLaw.relative(1.0, R)
    for target in targets:
        x0, x1, rod, s_mid = knit_segments(target)
        contact = SegmentContact(law, np.full(len(rod), R), rod, s_mid)
        length = np.linalg.norm(x1 - x0, axis=1)
        row = {"segments": len(rod)}
        for tangent in (False, True):
            contact.evaluate(x0, x1, tangent, length)                 # compile / warm up
            times = []
            for _ in range(repeat):
                t = time.perf_counter()
                *_, report = contact.evaluate(x0, x1, tangent, length)
                times.append(time.perf_counter() - t)
            row["tangent_ms" if tangent else "residual_ms"] = 1e3 * float(np.median(times))
        row["candidate_pairs"], row["active_pairs"] = report.candidates, report.active_pairs
        rows.append(row)
        print(f"  {row['segments']:7d} segments: {report.candidates} candidate pairs, "
              f"{report.active_pairs} active; residual {row['residual_ms']:.1f} ms, "
              f"with tangent {row['tangent_ms']:.1f} ms")
    return rows


def two_ply(factor, steps=25):
    """The two-ply benchmark; returns iterations per step and the final report."""
    section = Section.circle(2 * 0.5, E=1000.0, nu=0.3)
    model = BeamModel()
    rods = [model.add_rod(Rod.straight((0, s * 0.6, 0), (1, 0, 0), 20.0, 40, section))
            for s in (1, -1)]
    for k, s in zip(rods, (1, -1)):
        y0 = s * 0.6
        model.clamp(k, "start")
        model.prescribe(k, "end", rotation=lambda phi: np.array([phi, 0, 0]),
                        displacement=lambda phi, y0=y0: np.array([0, y0 * (np.cos(phi) - 1),
                                                                  y0 * np.sin(phi)]))
    model.contact(factor=factor)
    t = time.perf_counter()
    result = model.solve(loads=np.linspace(2 * np.pi / steps, 2 * np.pi, steps))
    wall = time.perf_counter() - t
    return result, model.contact_report(result[-1].state), wall


def crossed(factor, push=0.25):
    """Two crossed clamped-clamped beams (length 10, d = 1, E = 1e4), one pushed
    onto the other by its supports: penetration against the penalty."""
    section = Section.circle(1.0, E=1e4, nu=0.3)
    model = BeamModel()
    a = model.add_rod(Rod.straight((-5, 0, 0), (1, 0, 0), 10.0, 40, section))
    b = model.add_rod(Rod.straight((0.07, -5.05, 1.06), (0, 1, 0), 10.0, 40, section))
    model.clamp(a, "start")
    model.clamp(a, "end")
    for end in ("start", "end"):
        model.prescribe(b, end, displacement=(0, 0, -push), rotation=(0, 0, 0))
    model.contact(factor=factor)
    steps = model.solve(loads=np.linspace(0.1, 1.0, 10))
    return steps, model.contact_report(steps[-1].state)


def parallel(factor):
    """A yarn lying on a parallel yarn (non-matching meshes), pressed by the
    line load q = EI/r^3: its gap, and the gap where the law carries q."""
    r = 0.5
    q = Section.circle(2 * r, E=1e3, nu=0.3).EI2 / r**3
    model = yarn_on_yarn(q, factor)
    steps = model.solve(loads=np.linspace(0.1, 1.0, 10))
    nodes = model.assembly.node_offset
    gap = steps[-1].state.x[nodes[1]:nodes[2], 2] - 2 * r
    law = model.contact_model.segments.law
    k, g0 = law.k, law.g0
    exact = g0 - np.sqrt(2 * g0 * q / k) if q < k * g0 / 2 else g0 / 2 - q / k
    return gap, exact, [s.iterations for s in steps]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="studies/results/bench_contact")
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print("broad + narrow phase on plain-knit swatches")
    rows = timing([1e3, 1e4, 1e5], args.repeat)

    print("two-ply, one full turn in 25 steps")
    ply = []
    for factor in (10.0, 100.0, 1000.0, 10000.0):
        try:
            steps, report, wall = two_ply(factor)
        except RuntimeError as err:
            ply.append({"factor": factor, "failed": str(err)[:200]})
            print(f"  factor {factor:g}: failed ({str(err)[:80]})")
            continue
        its = [s.iterations for s in steps]
        ply.append({"factor": factor, "iterations_per_step": its, "max": max(its),
                    "median": float(np.median(its)), "substeps": sum(s.substeps for s in steps),
                    "min_gap_over_d": report.min_gap, "penetration_over_d":
                    report.max_penetration_ratio, "active_pairs": report.active_pairs,
                    "total_normal_force": report.total_normal_force, "wall_s": wall})
        print(f"  factor {factor:g} (k = factor EI/r^4): iterations median {np.median(its):.0f},"
              f" max {max(its)}; penetration {report.max_penetration_ratio:.2e} d; "
              f"force {report.total_normal_force:.3g}; {wall:.1f} s")
    print("one two-ply step, relative residual per Newton iteration (factor 100):")
    steps, _, _ = two_ply(100.0)
    history = steps[-1].history
    print("  ", ["%.1e" % h for h in history])

    print("crossed beams pushed together, penetration vs penalty")
    cross = []
    for factor in (10.0, 100.0, 1000.0, 10000.0):
        steps, report = crossed(factor)
        its = [s.iterations for s in steps]
        cross.append({"factor": factor, "penetration_over_d": report.max_penetration_ratio,
                      "min_gap_over_d": report.min_gap, "total_normal_force":
                      report.total_normal_force, "iterations_per_step": its})
        print(f"  factor {factor:g}: penetration {report.max_penetration_ratio:.2e} d, min gap "
              f"{report.min_gap:+.2e} d, force {report.total_normal_force:.4g}, iterations "
              f"median {np.median(its):.0f} max {max(its)}")
    print("yarn pressed onto a parallel yarn by q = EI/r^3, gap vs penalty (d = 1)")
    line = []
    for factor in (10.0, 100.0, 1000.0, 10000.0):
        gap, exact, its = parallel(factor)
        line.append({"factor": factor, "gap_over_d": float(gap.mean()),
                     "gap_spread_over_d": float(np.ptp(gap)), "closed_form_gap_over_d": exact,
                     "penetration_over_d": float(max(0.0, -gap.min())),
                     "iterations_per_step": its})
        print(f"  factor {factor:g}: gap {gap.mean():+.3e} d (closed form {exact:+.3e}, spread "
              f"{np.ptp(gap):.1e}), penetration {max(0.0, -gap.min()):.2e} d, iterations "
              f"median {np.median(its):.0f} max {max(its)}")
    write_json(out / "bench_contact.json",
               {"timing": rows, "two_ply": ply, "crossed": cross, "parallel_line_load": line,
                "two_ply_last_step_history": history})


if __name__ == "__main__":
    main()
