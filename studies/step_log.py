"""Where a fabric relaxation's steps go: run ``knitfem curl`` with every
minimisation (friction round) logged step by step (issue 9's speed work).

    python studies/step_log.py --log LOG.json [--summary SUMMARY.md] -- curl --nw 10 --nc 35 \\
        --alpha 0.2 --paths thirds --no-limits --no-render --json RUN.json

Everything after ``--`` is a ``knitfem`` command line, run in this process
with :func:`knitfem.solve.minimize.minimize` wrapped: LOG.json gets one record
per round (steps, converged, seconds, and per step the energy, residual,
shift mu, line-search step t (0: rejected), the Hessian used and the move
cap), rewritten after every round so a killed run keeps what it did.
``--summary`` writes the table this script prints: per round its steps and
seconds, the share of steps the move cap shortened (and the median cap of
those), of full steps, of line-search cuts and of steps on the PSD model.
Nothing in the relaxation changes: the same path, step for step.
"""
import argparse
import sys
import time

import numpy as np

import knitfem.scenes.fabric_relax as fabric_relax
from knitfem.io import write_json, write_text
from knitfem.solve import minimize as minimize_module

FIELDS = ("energy", "residual", "mu", "t", "hessian", "cap")


def logged(minimize, sink, path):
    """``minimize`` that appends each call's step history to ``sink`` (and
    writes it to ``path``), failures included."""
    def record(history, converged, start):
        sink.append({"steps": len(history), "converged": bool(converged),
                     "seconds": time.perf_counter() - start,
                     "history": [list(h) for h in history]})
        write_json(path, {"fields": FIELDS, "rounds": sink}, indent=None)

    def wrapped(problem, x0, **options):
        start = time.perf_counter()
        try:
            result = minimize(problem, x0, **options)
        except minimize_module.RelaxationError as err:
            record(err.history, False, start)
            raise
        record(result.history, result.converged, start)
        return result
    return wrapped


def summary(rounds):
    """Markdown table of the rounds (see the module docstring)."""
    lines = ["| round | steps | converged | seconds | capped (median cap) | full | cut | PSD |",
             "|---:|---:|---|---:|---|---:|---:|---:|"]
    every = []
    for k, r in enumerate(rounds):
        h = r["history"]
        every.extend(h)
        if not h:
            continue
        t = np.array([s[3] for s in h])
        cap = np.array([s[5] for s in h])
        psd = np.array([s[4] == "psd" for s in h])
        capped = cap[cap < 1.0]
        lines.append(f"| {k} | {r['steps']} | {'yes' if r['converged'] else 'no'} | "
                     f"{r['seconds']:.0f} | {capped.size / cap.size:.2f} "
                     f"({np.median(capped) if capped.size else 1.0:.2f}) | {np.mean(t == 1.0):.2f} | "
                     f"{np.mean((t > 0) & (t < 1)):.2f} | {psd.mean():.2f} |")
    spent = [r for r in rounds if not r["converged"]]
    lines.append("")
    lines.append(f"{len(rounds)} rounds, {sum(r['steps'] for r in rounds)} steps, "
                 f"{sum(r['seconds'] for r in rounds):.0f} s; {len(spent)} unconverged rounds: "
                 f"{sum(r['steps'] for r in spent)} steps, {sum(r['seconds'] for r in spent):.0f} s")
    return "\n".join(lines) + "\n"


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if "--" not in argv:
        print("step_log.py: give the knitfem command after --", file=sys.stderr)
        return 2
    cut = argv.index("--")
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--log", required=True, help="the per-step log (JSON)")
    parser.add_argument("--summary", help="also write the summary table here (Markdown)")
    args = parser.parse_args(argv[:cut])
    rounds = []
    fabric_relax.minimize = logged(fabric_relax.minimize, rounds, args.log)
    from knitfem.cli import main as knitfem_main
    code = knitfem_main(argv[cut + 1:])
    table = summary(rounds)
    print(table)
    if args.summary:
        write_text(args.summary, table)
    return code


if __name__ == "__main__":
    sys.exit(main())
