"""Which energy term breaks Newton's model in a stalled friction round (a probe of issue 9).

    python studies/newton_model_error.py --checkpoint RUN/checkpoint.npz [--steps 30]
                                         [--samples 6] [--out DIR]

Loads a ``knitfem curl`` checkpoint (the increment under way when it has one: its
target lam, state and friction anchors), re-anchors the friction as a new round
would, runs ``--steps`` steps of that round's minimisation (:func:`knitfem.solve.
minimize.minimize`) and, at ``--samples`` of the states it passed, takes one
Newton step dx = -(H + mu D)^-1 g (mu the smallest of 1e-5, 1e-4, ... that makes
it positive definite; capped like the minimiser's step, no line search) and
splits what the step did by energy term -- the rods' elements ("beam"), "ties",
normal "contact" and "friction":

    model error of a term = |f(x + dx) - f(x) - H dx|   (its own f and H),

in the residual's weighted norm over the fixed force scale (so comparable with
the relative residual), and the node where it is largest.  A term whose
model error is of the size of its force change is what the quadratic model
does not see over the step (contacts appearing or going deep, stick turning
to slip); the minimiser then cuts the step or lands at a larger residual.
Writes ``DIR/model_error_<nw>x<nc>.csv`` and ``.md``; prints the table.  The
step is the minimiser's exact-Hessian step (its PSD-model fallback is not used).
"""
import argparse
import csv
from pathlib import Path

import numpy as np
from scipy import sparse

from knitfem.beam.assembly import block_matrix
from knitfem.beam.element import element_forces
from knitfem.beam.energy import EnergyProblem, symmetric_part
from knitfem.scenes.curl import checkpoint_scene, load_checkpoint
from knitfem.scenes.fabric import Homotopy, build
from knitfem.solve.factor import Cholesky, NotPositiveDefinite
from knitfem.solve.minimize import RelaxationError, minimize


class _Recording(EnergyProblem):
    """An energy problem that keeps every state evaluated with its Hessian:
    the minimiser does that once per accepted step."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.states = []

    def evaluate(self, state, hessian=True):
        if hessian:
            self.states.append(state)
        return super().evaluate(state, hessian)


def term_forces(problem, state):
    """{term: (force (n_dofs,), Hessian on the free dofs)} of the problem at state."""
    model = problem.model
    asm = model.assembly
    a, b = asm.elements
    _, res, Ke = element_forces(state.x[a], state.x[b], state.q[a], state.q[b], asm.h,
                                asm.gamma0, asm.kappa0, asm.CN, asm.CM, True)
    terms = {"beam": (np.bincount(asm.element_dofs.T.ravel(), res.ravel(), asm.n_dofs),
                      asm.scatter(symmetric_part(Ke), problem.free))}
    for name, dofs, fe, Kb, _ in EnergyProblem.groups(problem, state, True)[1]:
        f = np.bincount(dofs.ravel(), np.ravel(fe), minlength=asm.n_dofs)
        K = block_matrix(dofs, symmetric_part(Kb), asm.n_dofs, problem.free)
        if name in terms:           # the co-rotated friction's geometric part
            f, K = f + terms[name][0], K + terms[name][1]
        terms[name] = (f, K)
    return terms


def newton_step(problem, state):
    """(E, g, H, dx, mu, cap): the minimiser's Newton step at state, without line search."""
    E, g, H, _ = EnergyProblem.evaluate(problem, state, True)
    D = np.abs(H.diagonal())
    D = np.maximum(D, 1e-12 * max(D.max(), 1e-300))
    mu = 1e-5
    while True:
        try:
            dx = -Cholesky(sparse.csc_matrix(H + sparse.diags(mu * D))).solve(g)
            break
        except NotPositiveDefinite:
            mu *= 10.0
    cap = min(1.0, float(problem.step_limit(state, dx)))
    return E, g, H, dx * cap, mu, cap


def node_name(model, free_index):
    """'rod name node k' of a free dof index."""
    asm = model.assembly
    node = int(np.flatnonzero(~model.fixed)[free_index]) // 6
    rod = int(np.searchsorted(asm.node_offset, node, side="right") - 1)
    return f"{model.rods[rod].name} {node - asm.node_offset[rod]}"


def probe(checkpoint, steps, samples):
    scene = checkpoint_scene(np.load(checkpoint))
    model, _, _ = build(scene)
    loaded = load_checkpoint(Path(checkpoint), scene, model)
    state, lam, _, _, partial = loaded
    homotopy = Homotopy.of_scene(model, scene)
    contact = model.contact_model
    if partial is not None:
        lam, state = partial.target, partial.state
        if contact is not None:
            contact.restore_friction(partial.friction)
    homotopy.apply(lam)
    if contact is not None:
        contact.anchor_friction(state.x, state.q)
    problem = _Recording(model, 1.0)
    try:
        minimize(problem, state, tol=0.0, max_iter=steps, raise_on_failure=False)
    except RelaxationError as err:     # a stall: sample the states it passed
        print(f"the round stalled after {len(problem.states)} states: {err}")
    weight = problem.weight
    rows = []
    picks = np.unique(np.linspace(0, len(problem.states) - 1, samples).round().astype(int))
    for k in picks:
        x = problem.states[k]
        E, g, H, dx, mu, cap = newton_step(problem, x)
        x1 = problem.retract(x, dx)
        E1, g1 = EnergyProblem.evaluate(problem, x1, False)[:2]
        before, after = term_forces(problem, x), term_forces(problem, x1)
        for name, (f0, H0) in before.items():
            change = (after[name][0] - f0)[problem.free]
            error = (change - H0 @ dx) * weight
            rows.append({"lam": lam, "step": int(k), "residual": problem.residual(g),
                         "residual_after": problem.residual(g1), "mu": mu, "cap": cap,
                         "energy_change": E1 - E, "predicted": float(g @ dx + 0.5 * dx @ (H @ dx)),
                         "term": name,
                         "force_change": float(np.linalg.norm(change * weight) / problem.ref),
                         "model_error": float(np.linalg.norm(error) / problem.ref),
                         "worst": node_name(model, int(np.argmax(np.abs(error))))})
    return scene, rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--checkpoint", required=True, type=Path)
    parser.add_argument("--steps", type=int, default=30)
    parser.add_argument("--samples", type=int, default=6)
    parser.add_argument("--out", type=Path, default=Path("studies/results/newton_model_error"))
    args = parser.parse_args(argv)
    if not args.checkpoint.exists():
        parser.error(f"--checkpoint: {args.checkpoint} does not exist")
    if args.steps < 0 or args.samples < 1:
        parser.error("--steps must be >= 0 and --samples >= 1")
    scene, rows = probe(args.checkpoint, args.steps, args.samples)
    args.out.mkdir(parents=True, exist_ok=True)
    stem = f"model_error_{scene.nw}x{scene.nc}"
    with open(args.out / f"{stem}.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = [f"# Newton model error by term, {scene.nw} x {scene.nc}, alpha {scene.alpha}, "
             f"lam {rows[0]['lam']:.4g}", "",
             "| step | residual -> after the step | dE (predicted) | term | force change | "
             "model error | worst at |", "|---:|---|---|---|---:|---:|---|"]
    for r in rows:
        lines.append(f"| {r['step']} | {r['residual']:.3g} -> {r['residual_after']:.3g} | "
                     f"{r['energy_change']:.3g} ({r['predicted']:.3g}) | {r['term']} | "
                     f"{r['force_change']:.3g} | {r['model_error']:.3g} | {r['worst']} |")
    text = "\n".join(lines) + "\n"
    (args.out / f"{stem}.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
