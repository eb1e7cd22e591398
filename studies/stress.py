"""The stress table (issue 10): slender rods, stiff contact and imperfect
structures near critical points, each case solved with the library's
defaults in a watched worker process and sorted into

* correct - every step the solve returns (and every step an error keeps)
  agrees with the closed form within the family's tolerance
  (studies/stress_cases.py), and its stability flag, where the library gives
  one, agrees with dense eigenvalues of the tangent;
* clear error - NewtonError / SteppingError / ValueError whose message says
  what failed, keeping the converged steps (all of them correct);
* other branch - a stable equilibrium of the right size on the side of a
  (near-)symmetric bifurcation that the imperfection does not pick: not the
  loading path, though not garbage either;
* flagged - a returned step is not the right answer but its ``stable`` flag
  says False (an unstable equilibrium reported as such: honest, not correct);
* wrong - any other returned or kept step that disagrees with the reference,
  or a stability flag that contradicts the dense eigenvalues (target 0);
* traceback - any other exception, or the worker process died;
* hang - no answer within the case's time limit (worker killed and restarted);
* n/a - the case asks for an option the code under test does not have.

    python studies/stress.py --out studies/results/stress --readme       # 188 cases, ~11 min
    python studies/stress.py --out /tmp/before-run --pythonpath /tmp/before --label before
    python studies/stress.py --quick ...                                  # 38 cases, ~30 s

(times measured on the shared 2-core machine with OMP_NUM_THREADS=1
NUMBA_NUM_THREADS=1, wall clock of the whole command; the largest cases,
20 000 elements x 10 steps and 2000 x 100, take 20-40 s each).

Writes OUT/stress_<label>.json (every case and step) and OUT/stress_<label>.md;
``--readme`` puts the counts (with those of a ``stress_before.json`` next to
it) into README.md between the stress-table markers.  Worker processes run on
one BLAS / numba thread.
"""
import argparse
import json
import os
from pathlib import Path
import select
import subprocess
import sys
import tempfile
import time
import traceback

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import stress_cases  # noqa: E402

OUTCOMES = ["correct", "clear error", "other branch", "flagged", "wrong", "traceback", "hang",
            "n/a"]
FAMILIES = ["rollup", "elastica", "parallel", "crossed", "column", "srod"]
CLEAR = {"NewtonError", "SteppingError", "ValueError"}
THREADS = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "NUMBA_NUM_THREADS": "1"}

# -- worker: runs cases read from stdin, one JSON line per case back ------------------


def run_case(case, refs):
    """Solve one case with the library under test; the raw measurements."""
    import inspect
    from knitfem.solve import stepping
    options = {}
    if case.get("require_stable"):
        if "require_stable" not in inspect.signature(stepping.load_stepping).parameters:
            return {"skipped": "require_stable is not an option of this version"}
        options["require_stable"] = True
    from knitfem.verify import cases
    if case["family"] == "crossed" and not hasattr(cases, "crossed_beams"):
        return {"skipped": "knitfem.verify.cases.crossed_beams is not in this version"}
    model, loads, start = stress_cases.build(case, refs)
    if loads is None:
        loads = [(k + 1) / case["steps"] for k in range(case["steps"])]
    try:
        steps = model.solve(loads=loads, start=start, **options)
    except Exception as err:
        kept = getattr(err, "steps", None)
        return {"raised": type(err).__name__,
                "mro": [c.__name__ for c in type(err).__mro__],
                "message": str(err), "traceback": traceback.format_exc(limit=8),
                "keeps_steps": kept is not None,
                "steps": [stress_cases.measure(case, model, s) for s in (kept or [])]}
    return {"steps": [stress_cases.measure(case, model, s) for s in steps]}


def warm_up():
    """One tiny beam and one tiny contact solve, so that numba compiles (or loads its
    cache) before the first timed case: a cold compile of an older checkout on a
    busy machine took over 120 s and counted as a hang."""
    from knitfem.verify import cases
    try:
        cases.cantilever_end_moment(2).solve()
        cases.yarn_on_yarn(1.0).solve()
    except Exception:           # noqa: BLE001 - the cases themselves will report it
        traceback.print_exc()


def worker():
    channel = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)                                      # library output goes to stderr
    import knitfem
    warm_up()
    channel.write(json.dumps({"knitfem": knitfem.__file__}) + "\n")
    channel.flush()
    for line in sys.stdin:
        job = json.loads(line)
        t = time.perf_counter()
        try:
            result = run_case(job["case"], job["refs"])
        except Exception as err:                       # building or measuring failed
            result = {"raised": type(err).__name__, "mro": [c.__name__ for c in
                                                            type(err).__mro__],
                      "message": str(err), "traceback": traceback.format_exc(limit=8),
                      "keeps_steps": False, "steps": [], "harness": True}
        result["seconds"] = round(time.perf_counter() - t, 3)
        channel.write(json.dumps(result, default=float) + "\n")
        channel.flush()

# -- parent: a watched worker process -----------------------------------------------------


class Worker:
    """One worker process; ``run`` kills and replaces it when a case overruns."""

    def __init__(self, pythonpath, log):
        self.pythonpath, self.log, self.proc, self.knitfem = pythonpath, log, None, None

    def start(self):
        env = dict(os.environ, **THREADS)
        env["PYTHONPATH"] = os.pathsep.join(p for p in (self.pythonpath, str(HERE)) if p)
        # run from a scratch folder: a current directory holding knitfem/ would shadow it
        self.proc = subprocess.Popen([sys.executable, str(HERE / "stress.py"), "--worker"],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=self.log, env=env, cwd=tempfile.gettempdir(),
                                     text=True, bufsize=1)
        self.knitfem = json.loads(self._read(900.0))["knitfem"]     # import + warm-up

    def _read(self, timeout):
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        if not ready:
            return None
        return self.proc.stdout.readline() or ""

    def stop(self):
        if self.proc is not None:
            self.proc.kill()
            self.proc.wait()
            self.proc = None

    def run(self, case, refs, timeout):
        if self.proc is None:
            self.start()
        t = time.perf_counter()
        self.proc.stdin.write(json.dumps({"case": case, "refs": refs}) + "\n")
        self.proc.stdin.flush()
        line = self._read(timeout)
        if line is None:
            self.stop()
            return {"hang": True, "seconds": round(time.perf_counter() - t, 1)}
        if line == "":
            code = self.proc.wait()
            self.proc = None
            return {"died": code, "seconds": round(time.perf_counter() - t, 1)}
        return json.loads(line)

# -- classification -------------------------------------------------------------------------


def check_steps(case, steps, refs):
    """(worst verdict over the steps: 'correct' / 'other branch' / 'flagged' /
    'wrong', [(kind, detail)])."""
    worst, details = "correct", []
    for m in steps:
        kind, detail = stress_cases.verdict(case, m, refs)
        flag, dense = m.get("stable"), m.get("dense_negative")
        if flag is not None and dense is not None and flag != (dense == 0):
            kind, detail = "wrong", detail + f"; stable={flag} but {dense} negative eigenvalue(s)"
        elif kind == "other branch" and (flag is False or (dense or 0) > 0):
            kind = "flagged" if flag is False else "wrong"      # an unstable state there
        elif kind == "wrong" and flag is False:
            kind = "flagged"
        if OUTCOMES.index(kind) > OUTCOMES.index(worst):
            worst = kind
        details.append((kind, detail))
    return worst, details


def classify(case, result, refs):
    if result.get("hang"):
        return "hang", f"no answer in {result['seconds']} s"
    if "died" in result:
        return "traceback", f"worker died (exit {result['died']})"
    if "skipped" in result:
        return "n/a", result["skipped"]
    worst, details = check_steps(case, result["steps"], refs)
    bad = [d for kind, d in details if kind == worst]
    last = details[-1][1] if details else "no step"
    if "raised" in result:
        message = result["message"].strip()
        clear = (CLEAR & set(result["mro"])) and message and not result.get("harness") and \
            (result["keeps_steps"] or "ValueError" in result["mro"])
        if not clear:
            return "traceback", f"{result['raised']}: {message[:200]}"
        if worst == "wrong":
            return "wrong", f"kept a wrong step: {bad[0]}"
        return "clear error", f"{result['raised']}: {message[:200]} ({len(details)} steps kept)"
    if worst != "correct":
        return worst, bad[0]
    return "correct", last


def label_of(case):
    keys = [k for k in case if k not in ("family", "id")]
    return ", ".join(f"{k}={case[k]:g}" if isinstance(case[k], float) else f"{k}={case[k]}"
                     for k in keys)


def counts(rows):
    return {f: {o: sum(r["outcome"] == o for r in rows if r["family"] == f) for o in OUTCOMES}
            for f in FAMILIES}


def table(rows, before=None):
    """Markdown counts: outcome x family (+ all), and the before column if given."""
    c = counts(rows)
    head = "| outcome | " + " | ".join(FAMILIES) + " | all |" + (" before |" if before else "")
    out = [head, "|---" * (len(FAMILIES) + 2 + bool(before)) + "|"]
    cb = counts(before) if before else None
    for o in OUTCOMES:
        line = f"| {o} | " + " | ".join(str(c[f][o]) for f in FAMILIES) + \
            f" | **{sum(c[f][o] for f in FAMILIES)}** |"
        if before:
            line += f" {sum(cb[f][o] for f in FAMILIES)} |"
        out.append(line)
    out.append("| cases | " + " | ".join(str(sum(c[f].values())) for f in FAMILIES) +
               f" | **{len(rows)}** |" + (f" {len(before)} |" if before else ""))
    return "\n".join(out) + "\n"


def markdown(rows, label, wall, knitfem_path):
    lines = [f"# Stress table ({label}: {len(rows)} cases, {wall:.0f} s, knitfem from "
             f"`{knitfem_path}`)\n", table(rows), "\n| id | family | case | outcome | s | detail |",
             "|---:|---|---|---|---:|---|"]
    for r in rows:
        lines.append(f"| {r['id']} | {r['family']} | {r['case']} | {r['outcome']} | "
                     f"{r['seconds']} | {r['detail'][:220].replace('|', '/')} |")
    return "\n".join(lines) + "\n"


README_BEGIN, README_END = "<!-- stress-table -->", "<!-- /stress-table -->"


def update_readme(readme, after, before):
    text = readme.read_text()
    if README_BEGIN not in text:
        raise SystemExit(f"stress: README has no {README_BEGIN} ... {README_END} block")
    head, rest = text.split(README_BEGIN, 1)
    _, tail = rest.split(README_END, 1)
    readme.write_text(head + README_BEGIN + "\n" + table(after, before) + README_END + tail)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="studies/results/stress")
    parser.add_argument("--label", default="after", help="name of this run (file names)")
    parser.add_argument("--pythonpath", default=None,
                        help="knitfem to test (e.g. an older checkout); default the installed one")
    parser.add_argument("--quick", action="store_true", help="the small subset pytest runs")
    parser.add_argument("--only", default=None, help="comma-separated families")
    parser.add_argument("--timeout-scale", type=float, default=1.0)
    parser.add_argument("--readme", action="store_true", help="write the counts into README.md")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        return worker()
    unknown = sorted(set((args.only or "").split(",")) - set(FAMILIES) - {""})
    if args.only is not None and (unknown or not args.only.strip(",")):
        parser.error(f"--only: unknown families {unknown or [args.only]}; valid: "
                     f"{','.join(FAMILIES)}")
    from knitfem.io import write_json, write_text
    todo = stress_cases.grid(args.quick)
    if args.only:
        todo = [c for c in todo if c["family"] in args.only.split(",")]
    out = Path(args.out)
    t0 = time.perf_counter()
    refs = stress_cases.references(todo)
    rows = []
    with tempfile.TemporaryFile("w+") as log:
        w = Worker(args.pythonpath and str(Path(args.pythonpath).resolve()), log)
        try:
            for case in todo:
                result = w.run(case, refs, stress_cases.time_limit(case) * args.timeout_scale)
                outcome, detail = classify(case, result, refs)
                rows.append(dict(id=case["id"], family=case["family"], case=label_of(case),
                                 params=case, outcome=outcome, detail=detail,
                                 seconds=result.get("seconds"), result=result))
                print(f"{case['id']:4d} {case['family']:9s} {label_of(case):60s} "
                      f"{outcome:12s} {result.get('seconds')} s  {detail[:110]}", flush=True)
        finally:
            w.stop()
    wall = time.perf_counter() - t0
    write_json(out / f"stress_{args.label}.json", {"label": args.label, "knitfem": w.knitfem,
                                                   "wall_s": wall, "refs": refs, "cases": rows})
    write_text(out / f"stress_{args.label}.md", markdown(rows, args.label, wall, w.knitfem))
    print(table(rows))
    if args.readme:
        before_file = out / "stress_before.json"
        before = json.loads(before_file.read_text())["cases"] if before_file.exists() else None
        update_readme(HERE.parent / "README.md", rows, before)
    return rows


if __name__ == "__main__":
    main()
