"""What a curl run is doing: a report of its checkpoint, finished or not.

    python studies/checkpoint_report.py --run RUN [--json FILE]

A B-spline run (``knitfem curl --model bspline --out RUN``: its
``bspline_<nw>x<nc>_checkpoint.npz``) reports its FIRE step, residual,
relaxation seconds, processes and the curl of its current state.  A beam run:

Reads ``RUN/checkpoint.npz`` (``knitfem curl --out RUN``; one may be copied out
of a running relaxation, it is written atomically) and prints: the homotopy lam
reached and the protocol (with the round-budget changes of its resumes), every
increment (lam, steps, end residual, seconds, accepted, its last round's move),
and, when an increment is under way, its rounds (end residuals, moves in mm and
in yarn radii) and the shape of its partial state against the last equilibrium:
both states' curl and edge rolls, the shape change with the rigid motion taken
out (:func:`knitfem.analysis.shape_change`) and the principal extents.  Rounds
that each move the swatch yarn radii on while their residuals do not fall are a
long slide or a snap, not hovering: halving the increment will not pass them, more
rounds (``--resume --max-rounds N``) may (README, "A snap near lam 0.8").
"""
import argparse
import json
from pathlib import Path

import numpy as np
from beam_time_vs_error import EDGES, increments


def _shape(x, swatch):
    from knitfem.analysis import principal_extents, swatch_curl
    s = swatch_curl(x, swatch)
    return {"curl": s.curl, "roll_deg": {e: float(s.roll_deg[e]) for e in EDGES},
            "extents": principal_extents(x)}


def report(run):
    """The checkpoint's content as a dict (lengths in the scene's unit, mm)."""
    from knitfem.analysis import shape_change
    from knitfem.scenes.curl import checkpoint_protocol
    from knitfem.scenes.fabric import FabricScene, build
    scene, table = increments(run)
    data = np.load(run / "checkpoint.npz")
    _, swatch, _ = build(FabricScene(**scene))
    out = {"run": str(run), "nw": scene["nw"], "nc": scene["nc"], "alpha": scene["alpha"],
           "lam": float(data["lam"]), "dlam": float(data["dlam"]),
           "protocol": checkpoint_protocol(data),
           "increments": [{k: float(v) for k, v in inc.items()} for inc in table],
           "equilibrium": _shape(data["x"], swatch)}
    if "partial_x" in data.files:
        target, rounds, steps, gap, seconds = map(float, data["partial_numbers"])
        radius = scene["radius"]
        moves = [float(m) for m in data["partial_moves"]] if "partial_moves" in data.files else []
        change = shape_change(data["x"], data["partial_x"])
        out["partial"] = {"target_lam": target, "rounds": int(rounds), "steps": int(steps),
                          "seconds": seconds,
                          "round_end_residuals": [float(e) for e in data["partial_ends"]]
                          if "partial_ends" in data.files else [],
                          "round_moves": moves,
                          "round_moves_over_r": [m / radius for m in moves],
                          "shape": _shape(data["partial_x"], swatch),
                          "shape_change": vars(change)}
    return out


def bspline_report(run, path):
    """A B-spline run's FIRE checkpoint ``path`` as a dict."""
    from knitfem.bspline.fire import FireState
    from knitfem.scenes.curl_bspline import swatch_of
    with np.load(path) as data:
        scene = json.loads(str(data["scene"]))
        state = FireState.from_arrays(data)
        relax_s, processes = float(data["relax_s"]), int(data["processes"])
        source = str(data["source"]) if "source" in data.files else ""
    bs = swatch_of(scene)
    x = bs.points(bs.model.control_points(state.y))
    return {"run": str(run), "model": "bspline", "nw": scene["nw"], "nc": scene["nc"],
            "alpha": scene["alpha"], "step": state.step,
            "residual": state.history[-1] if state.history else None, "rtol": scene["rtol"],
            "relax_s": relax_s, "processes": processes, "source": source or None,
            "mass_refreshes": state.refreshes, "state": _shape(x, bs.swatch)}


def _print_bspline(r):
    rolls = " / ".join(f"{r['state']['roll_deg'][e]:+.0f}" for e in EDGES)
    residual = "not checked yet" if r["residual"] is None else f"{r['residual']:.2e}"
    print(f"{r['run']}: B-spline {r['nw']} x {r['nc']}, alpha {r['alpha']}: FIRE step "
          f"{r['step']}, residual {residual} (tolerance {r['rtol']:.0e}), {r['relax_s']:.0f} s "
          f"of relaxation in {r['processes']} run(s), code {r['source'] or 'unknown'}")
    print(f"  state: {r['state']['curl']}, rolls L/R/T/B {rolls} deg")


def _print(r):
    if r.get("model") == "bspline":
        return _print_bspline(r)
    print(f"{r['run']}: {r['nw']} x {r['nc']}, alpha {r['alpha']}: equilibrium at lam "
          f"{r['lam']:.6g} (next increment {r['dlam']:.4g}); protocol {r['protocol'] or 'default'}")
    for inc in r["increments"]:
        print(f"  lam {inc['lam']:.4f}  {int(inc['iterations']):5d} steps  residual "
              f"{inc['residual']:.1e}  {inc['seconds']:7.0f} s  "
              f"{'ok  ' if inc['accepted'] else 'FAIL'}  last round moved {inc['moved']:.3g}")

    def shape(name, s):
        rolls = " / ".join(f"{s['roll_deg'][e]:+.0f}" for e in EDGES)
        ext = " x ".join(f"{v:.1f}" for v in s["extents"])
        print(f"  {name}: {s['curl']}, rolls L/R/T/B {rolls} deg, principal extents {ext}")
    shape(f"equilibrium lam {r['lam']:.4f}", r["equilibrium"])
    p = r.get("partial")
    if p:
        print(f"  increment to lam {p['target_lam']:.4f} under way: {p['rounds']} rounds, "
              f"{p['steps']} steps, {p['seconds']:.0f} s")
        print("    round end residuals " + ", ".join(f"{e:.2g}" for e in p["round_end_residuals"]))
        print("    round moves (r)     " + ", ".join(f"{m:.3g}" for m in p["round_moves_over_r"]))
        shape("partial state", p["shape"])
        c = p["shape_change"]
        print(f"    shape change since the equilibrium, rigid motion taken out: median "
              f"{c['median']:.3g}, max {c['max']:.3g} (rotation {c['rotation_deg']:.1f} deg, "
              f"centroid {c['shift']:.3g})")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--run", type=Path, required=True,
                   help="a knitfem curl --out folder (beam or bspline)")
    p.add_argument("--json", type=Path, default=None, help="also write the report as JSON")
    args = p.parse_args()
    fire = sorted(args.run.glob("bspline_*_checkpoint.npz"))
    if not fire and not (args.run / "checkpoint.npz").exists():
        p.error(f"--run: {args.run} holds no checkpoint.npz nor bspline_*_checkpoint.npz "
                "(a knitfem curl --out folder)")
    r = bspline_report(args.run, fire[0]) if fire else report(args.run)
    _print(r)
    if args.json:
        args.json.write_text(json.dumps(r, indent=2))


if __name__ == "__main__":
    main()
