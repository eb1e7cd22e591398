"""Benchmark of the fabric relaxation's iteration (issue 9): where the time
of one minimisation iteration goes, and how it scales with the swatch.

    python studies/bench_fabric.py --out studies/results/bench_fabric \\
        [--sizes 3x4,5x5,10x10,10x35,25x35] [--repeat 5] [--runs DIR ...]
        [--checkpoint RUN/checkpoint.npz ...]

For each swatch: the scene of ``knitfem curl`` (defaults, alpha 0.2), the
homotopy at lam = 0.1 and ``--warm`` minimisation iterations (so that the
yarns touch: at the knitted start no contact is active), then the median
over ``--repeat`` of: the beam elements (energy, forces, Hessian blocks),
the contact with friction (search, closest points, blocks), the whole
energy + gradient (a line-search trial), the whole energy + gradient +
sparse Hessian, the PSD model of the Hessian (used where it is indefinite)
and the sparse Cholesky factorisation of H + mu D (the solve of one step).
``--checkpoint`` measures instead at the state and friction anchors of a
``knitfem curl`` run's checkpoint (a relaxed swatch carries thousands of
friction anchors, the warm start almost none): the round under way where the
checkpoint has one, else its last equilibrium.  One BLAS / numba thread.
``--sizes ""`` measures checkpoints only.  ``--runs`` adds the wall time and iterations of
finished ``knitfem curl`` runs (their ``curl_*.json``) to the table.  ``--steps N``
(with ``--checkpoint``) also runs N whole iterations of the round a relaxation
would run next (the round under way with its own anchors, or the next
increment's first round, friction anchored at the checkpoint's equilibrium) and reports wall and CPU seconds per
iteration: the line-search trials, the retried factorisations and what is
kept between iterations (broad phase, symbolic analysis) included, which the
per-part medians above cannot show.  Run it with ``PYTHONPATH`` on another
checkout for an A/B of the same iterations.

Writes OUT/bench_fabric.json and OUT/bench_fabric.md.
"""
import argparse
import json
import os
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from scipy import sparse  # noqa: E402

from knitfem.beam.element import element_forces  # noqa: E402
from knitfem.beam.energy import EnergyProblem  # noqa: E402
from knitfem.io import write_json  # noqa: E402
from knitfem.scenes.curl import checkpoint_protocol, load_checkpoint  # noqa: E402
from knitfem.scenes.fabric import FabricScene, Homotopy, build  # noqa: E402
from knitfem.solve.factor import Cholesky, NotPositiveDefinite, cholmod_available  # noqa: E402
from knitfem.solve.minimize import _factor, minimize  # noqa: E402


def median_time(function, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        function()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def measure(nw, nc, repeat, warm, checkpoint=None):
    t = time.perf_counter()
    scene = FabricScene(nw, nc) if checkpoint is None else \
        FabricScene(**json.loads(str(np.load(checkpoint)["scene"])))
    model, _, info = build(scene)
    built = time.perf_counter() - t
    contact = model.contact_model
    problem = EnergyProblem(model, 1.0)
    if checkpoint is None:
        lam = 0.1
        Homotopy.of_scene(model, scene).apply(lam)
        state = model.initial_state()
        contact.anchor_friction(state.x, state.q)
        state = minimize(problem, state, tol=0.0, max_iter=warm, raise_on_failure=False).state
    else:
        # a relaxation's own state and friction anchors (the warm start has
        # hardly any anchors: friction forms as the yarns tighten)
        state, lam = checkpoint_state(checkpoint, scene, model)
        Homotopy.of_scene(model, scene).apply(lam)
    asm = model.assembly
    a, b = asm.elements

    def beam():
        element_forces(state.x[a], state.x[b], state.q[a], state.q[b], asm.h, asm.gamma0,
                       asm.kappa0, asm.CN, asm.CM, True)
    E, g, H, Hp = problem.evaluate(state, True)
    D = np.maximum(np.abs(H.diagonal()), 1e-12 * np.abs(H.diagonal()).max())
    model_psd = Hp()
    row = {
        "nw": scene.nw, "nc": scene.nc, "unknowns": int(info["free_dofs"]), "build_s": built,
        "alpha": scene.alpha, "lam": lam, "from": "checkpoint" if checkpoint else "warm start",
        "active_pairs": int(contact.report.active_pairs),
        "friction_anchors": 0 if contact.anchors is None else int(len(contact.anchors.key)),
        "beam_s": median_time(beam, repeat),
        "contact_s": median_time(lambda: contact.blocks(state.x, state.q, True), repeat),
        "energy_gradient_s": median_time(lambda: problem.evaluate(state, False), repeat),
        "energy_gradient_hessian_s": median_time(lambda: problem.evaluate(state, True), repeat),
        "psd_model_s": median_time(Hp, repeat),
        "hessian_nnz": int(H.nnz),
    }
    matrix = H
    try:
        _factor(H, D, 1e-3)
    except NotPositiveDefinite:             # indefinite even with the damping: the PSD model
        matrix = model_psd
    A = sparse.csc_matrix(matrix + sparse.diags(1e-3 * D))
    for backend in ("qdldl", "cholmod") if cholmod_available() else ("qdldl",):
        row[f"factor_{backend}_s"] = median_time(lambda: Cholesky(A, backend=backend), repeat)
    row["factor_s"] = row.get("factor_cholmod_s", row["factor_qdldl_s"])
    row["iteration_s"] = row["energy_gradient_hessian_s"] + row["factor_s"] + \
        2 * row["energy_gradient_s"]       # a step with two line-search trials
    return row


def checkpoint_state(checkpoint, scene, model):
    """(state, lam) where a run's checkpoint stands, with its friction anchors
    on the contact model: the round under way when there is one (its state,
    target and anchors), else the last equilibrium.  Read with the run's own
    protocol, so the thirds path's and other non-default runs load too."""
    data = np.load(checkpoint)
    state, lam, _, _, partial = load_checkpoint(Path(checkpoint), scene, model,
                                                checkpoint_protocol(data))
    if partial is None:
        return state, lam
    if partial.friction[0] is not None:
        model.contact_model.restore_friction(partial.friction)
    return partial.state, partial.target


def round_steps(checkpoint, steps):
    """N iterations of the next friction round from a checkpoint (see the
    module docstring): wall and CPU seconds per iteration, and the energy
    and residual reached (an A/B of two codes must reach the same)."""
    data = np.load(checkpoint)
    scene = FabricScene(**json.loads(str(data["scene"])))
    model, _, info = build(scene)
    state, lam = checkpoint_state(checkpoint, scene, model)
    under_way = "partial_numbers" in data.files
    if not under_way and lam < 1.0:         # the next increment
        lam = min(1.0, lam + float(data["dlam"]))
    Homotopy.of_scene(model, scene).apply(lam)
    anchors = model.contact_model.anchors, model.contact_model.anchor_q

    def anchor():
        if under_way:           # the round under way keeps its own anchors
            model.contact_model.restore_friction(anchors)
        else:
            model.contact_model.anchor_friction(state.x, state.q)
    anchor()
    problem = EnergyProblem(model, 1.0)
    minimize(problem, state, tol=0.0, max_iter=1, raise_on_failure=False)   # compile, caches
    anchor()
    wall, cpu = time.perf_counter(), time.process_time()
    out = minimize(problem, state, tol=0.0, max_iter=steps, raise_on_failure=False)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    return {"nw": scene.nw, "nc": scene.nc, "unknowns": int(info["free_dofs"]), "lam": lam,
            "steps": out.iterations, "wall_per_step_s": wall / out.iterations,
            "cpu_per_step_s": cpu / out.iterations, "energy": out.energy,
            "residual": out.residual}


def runs_table(folders):
    rows = []
    for folder in folders:
        for path in sorted(Path(folder).glob("curl_*.json")):
            s = json.loads(path.read_text())
            rows.append({k: s.get(k) for k in ("nw", "nc", "alpha", "dofs", "iterations",
                                                "increments", "elapsed_s", "converged",
                                                "residual", "curl")})
    return rows


def markdown(rows, runs):
    lines = ["| swatch | state | unknowns | active pairs | friction anchors | beam | contact | "
             "E + g | E + g + H | PSD model | Cholesky QDLDL | Cholesky CHOLMOD | "
             "one iteration (≈) |", "|---|---|" + "---:|" * 11]
    for r in rows:
        lines.append(f"| {r['nw']} × {r['nc']} | {r['from']}, λ = {r['lam']:.2g} | "
                     f"{r['unknowns']} | {r['active_pairs']} | {r['friction_anchors']} | "
                     + " | ".join(f"{1e3 * r[k]:.1f} ms" if k in r else "–" for k in (
                         "beam_s", "contact_s", "energy_gradient_s", "energy_gradient_hessian_s",
                         "psd_model_s", "factor_qdldl_s", "factor_cholmod_s", "iteration_s"))
                     + " |")
    if runs:
        lines += ["", "| run | α | unknowns | iterations | increments | wall time | converged | "
                  "residual | curl |", "|---|---:|---:|---:|---:|---:|---|---:|---|"]
        for r in runs:
            lines.append(f"| {r['nw']} × {r['nc']} | {r['alpha']} | {r['dofs']} | "
                         f"{r['iterations']} | {r['increments']} | {r['elapsed_s']:.0f} s | "
                         f"{r['converged']} | {r['residual']:.1e} | {r['curl']} |")
    return "\n".join(lines) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="studies/results/bench_fabric")
    parser.add_argument("--sizes", default="3x4,5x5,10x10,10x35,25x35")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--warm", type=int, default=10,
                        help="--sizes: minimisation steps from the knitted shape before timing "
                             "(a --checkpoint is timed at its own state)")
    parser.add_argument("--runs", nargs="*", default=[])
    parser.add_argument("--steps", type=int, default=0,
                        help="with --checkpoint: also time this many iterations of the next "
                             "friction round")
    parser.add_argument("--checkpoint", nargs="*", default=[],
                        help="checkpoint.npz files of knitfem curl runs: measure at their "
                             "state and friction anchors (scene from the checkpoint)")
    args = parser.parse_args()
    if args.steps > 0 and not args.checkpoint:
        parser.error("--steps times a friction round from a checkpoint: give --checkpoint")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    sizes = [tuple(int(v) for v in size.lower().split("x"))
             for size in args.sizes.split(",") if size]
    for nw, nc in sizes:
        rows.append(measure(nw, nc, args.repeat, args.warm))
        print(json.dumps(rows[-1]), flush=True)
    for path in args.checkpoint:
        rows.append(measure(None, None, args.repeat, args.warm, path))
        print(json.dumps(rows[-1]), flush=True)
    steps = []
    for path in args.checkpoint if args.steps > 0 else []:
        steps.append(round_steps(path, args.steps))
        print(json.dumps(steps[-1]), flush=True)
    runs = runs_table(args.runs)
    write_json(out / "bench_fabric.json", {"iteration": rows, "runs": runs, "round_steps": steps})
    text = markdown(rows, runs)
    if steps:
        text += "\n| swatch | λ | unknowns | iterations | wall / iteration | CPU / iteration | " \
                "energy | residual |\n|---|---:|---:|---:|---:|---:|---:|---:|\n" + "".join(
                    f"| {r['nw']} × {r['nc']} | {r['lam']:.3g} | {r['unknowns']} | {r['steps']} | "
                    f"{r['wall_per_step_s']:.3f} s | {r['cpu_per_step_s']:.3f} s | "
                    f"{r['energy']:.8g} | {r['residual']:.3e} |\n" for r in steps)
    (out / "bench_fabric.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
