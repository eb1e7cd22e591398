"""Why a friction round takes its steps: every line-search trial of one round,
replayed from a ``knitfem curl`` checkpoint (issue 9's speed work).

    python studies/round_trials.py --checkpoint RUN/path_thirds/checkpoint.npz \\
        [--steps 200] [--shifts N] --out DIR

The round a relaxation would run next (the round under way with its own
friction anchors, or the next increment's first round) is minimised by the
library's :func:`knitfem.solve.minimize.minimize`, unchanged, for ``--steps``
steps (tolerance ``--tol``, the path's 1e-3 by default); the problem is wrapped
so that every energy evaluation is logged: the largest node move of the trial
against the state it steps from, in yarn radii, and the energy split into the
rods' elastic energy, the ties and the contact (penalty and lagged friction).
Nothing in the minimisation changes: the same steps as the run's.

Writes DIR/round_trials.json (the trials, the step history) and
DIR/round_trials.md: how far the accepted steps moved, how far the refused
full steps would have, and which energy term refused them.
"""
import argparse
import json
import os
import sys
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from knitfem.beam.element import element_forces  # noqa: E402
from knitfem.beam.energy import EnergyProblem  # noqa: E402
from knitfem.io import write_json, write_text  # noqa: E402
from knitfem.scenes.fabric import FabricScene, Homotopy, build  # noqa: E402
from knitfem.solve.minimize import SHIFTS, minimize  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fabric import checkpoint_state  # noqa: E402

PARTS = ("elastic", "ties", "contact")


class TrialLog(EnergyProblem):
    """The total potential, with every line-search trial logged: ``steps`` is
    one list per step (its trials in order, t = 1, 1/2, ...), each trial a
    dict of its largest node move from the state it steps from (in yarn
    radii), its energy and the change of each term (``PARTS``: the rods'
    elastic energy, the ties, the contact's penalty and lagged friction)
    against that state, and ``accepted`` (None: refused, or the last step)."""

    def __init__(self, model, lam=1.0, **options):
        super().__init__(model, lam, **options)
        self.steps, self.base, self._parts = [], None, None
        self._made = {}                     # id -> (state, trial) of the retracted states

    def retract(self, state, dx):
        if state is not self.base:          # a new step: from the accepted trial (or x0)
            made = self._made.get(id(state))
            if made is not None and made[0] is state:
                made[1]["accepted"] = True
                self._parts = made[1]["parts"]
            self.base = state
            self._made = {}
            self.steps.append([])
        new = super().retract(state, dx)
        self._made[id(new)] = (new, None)
        return new

    def evaluate(self, state, hessian=True):
        out = super().evaluate(state, hessian)
        made = self._made.get(id(state))
        if self.base is None and self._parts is None:            # the start
            self._parts = self.parts(state)
        elif made is not None and made[0] is state and made[1] is None:
            parts = self.parts(state)
            radius = 2.0 * self.step                # step = half the smallest radius
            trial = {"move_r": float(np.max(np.linalg.norm(state.x - self.base.x, axis=1))
                                     / radius),
                     "energy": float(out[0]), "parts": parts, "accepted": None,
                     **{f"d_{p}": parts[p] - self._parts[p] for p in PARTS}}
            self._made[id(state)] = (state, trial)
            self.steps[-1].append(trial)
        return out

    def parts(self, state):
        """The energy by term (``PARTS``) at ``state``."""
        asm = self.model.assembly
        a, b = asm.elements
        elastic = element_forces(state.x[a], state.x[b], state.q[a], state.q[b], asm.h,
                                 asm.gamma0, asm.kappa0, asm.CN, asm.CM, False)[0].sum()
        energies, groups = self.groups(state, False)
        # groups() gives the ties' energy first (when there are ties), then the contact's
        names = ["ties"] * any(g[0] == "ties" for g in groups) + ["contact"]
        parts = {"elastic": float(elastic), "ties": 0.0, "contact": 0.0}
        for name, value in zip(names, energies):
            parts[name] += float(value)
        return parts


def trial_round(model, state, steps, tol, shifts=SHIFTS):
    """Minimise ``model``'s potential from ``state`` (its homotopy and friction
    anchors set) for at most ``steps`` steps, every trial logged: a record
    dict (the round's numbers, its step history and its trials per step)."""
    problem = TrialLog(model, 1.0)
    cpu = time.process_time()
    out = minimize(problem, state, tol=tol, max_iter=steps, raise_on_failure=False,
                   shifts=shifts)
    cpu = time.process_time() - cpu
    for trial in (t for step in problem.steps for t in step):
        del trial["parts"]
    return {"shifts": shifts, "steps": out.iterations, "converged": out.converged,
            "energy": out.energy,
            "residual": out.residual, "cpu_s": cpu,
            "history_fields": ["energy", "residual", "mu", "t", "hessian", "cap"],
            "history": [list(h) for h in out.history], "trials": problem.steps}


def replay(checkpoint, steps, tol, shifts=SHIFTS):
    """:func:`trial_round` on the round ``checkpoint`` would run next."""
    data = np.load(checkpoint)
    scene = FabricScene(**json.loads(str(data["scene"])))
    model, _, info = build(scene)
    state, lam = checkpoint_state(checkpoint, scene, model)
    under_way = "partial_numbers" in data.files
    if not under_way and lam < 1.0:
        lam = min(1.0, lam + float(data["dlam"]))
    Homotopy.of_scene(model, scene).apply(lam)
    if not under_way:
        model.contact_model.anchor_friction(state.x, state.q)
    return {"checkpoint": str(checkpoint), "nw": scene.nw, "nc": scene.nc, "lam": lam,
            "under_way": under_way, "unknowns": int(info["free_dofs"]),
            **trial_round(model, state, steps, tol, shifts)}


def _percentiles(values):
    q = np.percentile(values, [10, 50, 90]) if len(values) else [np.nan] * 3
    return " / ".join(f"{v:.3f}" for v in q)


def summarise(record):
    """Markdown summary of a replayed round: the accepted steps' moves, and
    the refused full steps' moves and the term that rose most in each."""
    steps = record["trials"]
    taken = [t["move_r"] for step in steps for t in step if t["accepted"]]
    full = sum(1 for step in steps if step and step[0]["accepted"])
    refused = [step[0] for step in steps if step and not step[0]["accepted"]
               and step is not steps[-1]]
    most = {p: sum(1 for t in refused if max(PARTS, key=lambda q: t[f"d_{q}"]) == p)
            for p in PARTS}
    return "\n".join([
        f"# One friction round replayed: {record['nw']} x {record['nc']} at lam "
        f"{record['lam']:.4g} ({record['unknowns']} unknowns)", "",
        f"{record['steps']} steps ({record['shifts']} tries of the exact Hessian), converged "
        f"{record['converged']}, energy "
        f"{record['energy']:.6g}, residual {record['residual']:.3e}, {record['cpu_s']:.0f} s "
        f"CPU, {sum(len(s) for s in steps)} line-search trials.", "",
        "| accepted steps | at t = 1 | summed move (r) | move per accepted step (r): "
        "10 / 50 / 90 % | refused full steps | their move (r): 10 / 50 / 90 % | term that "
        "rose most: elastic / ties / contact |",
        "|---:|---:|---:|---|---:|---|---|",
        f"| {len(taken)} | {full} | {sum(taken):.1f} | {_percentiles(taken)} | {len(refused)} "
        f"| {_percentiles([t['move_r'] for t in refused])} | "
        + " / ".join(str(most[p]) for p in PARTS) + " |", ""])


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--checkpoint", required=True, help="a knitfem curl run's checkpoint.npz")
    p.add_argument("--steps", type=int, default=200, help="steps of the round (default 200)")
    p.add_argument("--tol", type=float, default=1e-3, help="the round's tolerance (default "
                   "1e-3, the path's)")
    p.add_argument("--shifts", type=int, default=SHIFTS, help="tries of the exact Hessian "
                   f"before the PSD model (default {SHIFTS}, the library's)")
    p.add_argument("--out", required=True)
    args = p.parse_args(argv)
    if args.steps < 1 or args.shifts < 1:
        p.error("--steps and --shifts must be at least 1")
    record = replay(args.checkpoint, args.steps, args.tol, args.shifts)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "round_trials.json", record, indent=None)
    text = summarise(record)
    write_text(out / "round_trials.md", text)
    print(text)
    return record


if __name__ == "__main__":
    main()
