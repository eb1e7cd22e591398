"""Bad input on the command line: >= 150 cases, each run as its own process,
sorted into correct refusal / result / solver failure / wrong wording /
traceback / hang.  The table with the counts goes into README.

    python studies/bad_input_table.py --out studies/results/bad_input_table [--jobs 2]

A *correct refusal* is exit code 2 with exactly one line on stderr that
starts ``knitfem <command>: error:`` and names the option the case is about;
a *result* is exit code 0 (its JSON, when written, holds no NaN); a *solver
failure* is exit code 3 with one line.  Everything else is a defect: a
refusal with the wrong wording (several lines, or the option not named), a
Python traceback, or a hang (no answer within --timeout seconds).
Writes bad_input_table.md (counts + every case) and bad_input_table.json.
"""
import argparse
from concurrent.futures import ThreadPoolExecutor
import json
import os
from pathlib import Path
import subprocess
import sys
import tempfile
import time

ODD = ["nan", "inf", "-inf", "0", "-1", "1e300", "1e-300", "abc", ""]
POPUP = {"--w-over-L": ["1", "1.5", "0.999999"], "--c-from": ["1", "0.99"],
         "--c-to": ["0.96", "1e-9"], "--c-step": ["1e-7", "2"],
         "--elements": ["3", "2.5", "100000", "1e3"], "--poisson": ["0.8", "-1"],
         "--gj-over-ei": ["1e9", "1e-9"], "--length": ["1e-9", "2e6"],
         "--diameter": ["200", "1e-9", "30"]}
KNIT = {"--nw": ["1000000", "2.5"], "--nc": ["1000000", "0"], "--w": ["1e-6", "1e7"],
        "--c": ["0.1", "100"], "--radius": ["1e-9", "0.6", "0.01"],
        "--points-per-loop": ["7", "1000000"]}
SMALL = {"popup": ["--elements", "8", "--c-to", "0.75", "--c-step", "0.1", "--no-render"],
         "knit": ["--nw", "2", "--nc", "2", "--no-render"], "gallery": ["--no-render"]}


def cases(tmp):
    """(command, option the case is about, argv after the command)."""
    out = []
    for command, table in (("popup", POPUP), ("knit", KNIT)):
        for flag, extra in table.items():
            for value in ODD + extra:
                small = [a for a in SMALL[command]] if flag not in SMALL[command] else []
                out.append((command, flag, [flag, value] + small))
    folder, afile = tmp / "folder", tmp / "file"
    folder.mkdir()
    afile.write_text("x")
    for command in ("popup", "knit", "gallery"):
        targets = [("--out", "/dev/null"), ("--out", "/proc/knitfem/x"), ("--out", str(afile)),
                   ("--out", "/sys/knitfem")]
        if command != "gallery":
            targets += [("--json", "/dev/full"), ("--json", str(folder)),
                        ("--json", "/proc/knitfem/x.json")]
        for flag, target in targets:
            out.append((command, flag, [flag, target] + SMALL[command]))
    out += [
        ("popup", "--relax", ["--relax", "dynamic"] + SMALL["popup"]),
        ("popup", "--poisson", ["--model", "bspline", "--poisson", "0.3"]),
        ("popup", "--gj-over-ei", ["--model", "bspline", "--gj-over-ei", "1"]),
        ("popup", "--gj-over-ei", ["--poisson", "0.3", "--gj-over-ei", "1"] + SMALL["popup"]),
        ("popup", "--c-step", ["--model", "bspline", "--c-step", "0"]),
        ("popup", "--elements", ["--model", "bspline", "--elements", "100000"]),
        ("popup", "--model", ["--model", "rubber"]),
        ("popup", "--c-to", ["--c-from", "0.6", "--c-to", "0.7"]),
        ("popup", "--frob", ["--frob", "1"]),
        ("popup", "--elements", ["--elements"]),
        ("knit", "--c", ["--w", "4", "--radius", "0.4", "--c", "20"]),
        ("knit", "--radius", ["--radius", "0.5", "--w", "4"]),
        ("knit", "--nw", ["--nw", "100000", "--nc", "100000"]),
        ("gallery", "--frob", ["--frob"]),
    ]
    return out


def classify(command, flag, code, err, json_path, elapsed, timed_out):
    lines = err.strip().splitlines()
    if timed_out:
        return "hang"
    if "Traceback" in err:
        return "traceback"
    if code == 0:
        if json_path.exists():
            try:
                json.loads(json_path.read_text(), parse_constant=lambda c: 1 / 0)
            except ZeroDivisionError:
                return "NaN in the result"
        return "result"
    if code == 3 and len(lines) == 1:
        return "solver failure (one line)"
    if code == 2 and len(lines) == 1 and lines[0].startswith(f"knitfem {command}: error:") \
            and flag in lines[0]:
        return "correct refusal"
    return "refusal, wrong wording"


def run_case(case, tmp, timeout, pythonpath=None):
    command, flag, argv = case
    js = Path(tempfile.mkdtemp(dir=tmp)) / "summary.json"
    if command != "gallery" and "--json" not in argv:
        argv = argv + ["--json", str(js)]
    if command == "gallery" and "--out" not in argv:
        argv = argv + ["--out", str(js.parent / "gallery")]
    cmd = [sys.executable, "-m", "knitfem.cli", command, *argv, "--quiet"]
    env = dict(os.environ, OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    if pythonpath:                                 # e.g. an older checkout, for a before/after
        env["PYTHONPATH"] = pythonpath
    t = time.perf_counter()
    try:
        # run from the temporary folder: a current directory holding knitfem/ would come
        # first on sys.path and hide --pythonpath
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env,
                           cwd=tmp)
        code, err, timed_out = p.returncode, p.stderr, False
    except subprocess.TimeoutExpired as e:
        code, err, timed_out = None, (e.stderr or b"").decode() if isinstance(
            e.stderr, bytes) else (e.stderr or ""), True
    elapsed = time.perf_counter() - t
    kind = classify(command, flag, code, err, js, elapsed, timed_out)
    return {"command": command, "option": flag, "argv": argv[:len(argv)], "exit": code,
            "kind": kind, "stderr": err.strip().splitlines()[-1] if err.strip() else "",
            "seconds": round(elapsed, 2)}


ORDER = ["correct refusal", "result", "solver failure (one line)", "refusal, wrong wording",
         "traceback", "NaN in the result", "hang"]


def markdown(rows):
    counts = {k: sum(r["kind"] == k for r in rows) for k in ORDER}
    by_command = {c: {k: sum(r["kind"] == k and r["command"] == c for r in rows) for k in ORDER}
                  for c in ("popup", "knit", "gallery")}
    head = "| outcome | popup | knit | gallery | all |\n|---|---:|---:|---:|---:|\n"
    body = "".join(f"| {k} | {by_command['popup'][k]} | {by_command['knit'][k]} | "
                   f"{by_command['gallery'][k]} | **{counts[k]}** |\n" for k in ORDER)
    total = f"| cases | {sum(by_command['popup'].values())} | {sum(by_command['knit'].values())}" \
            f" | {sum(by_command['gallery'].values())} | **{len(rows)}** |\n"
    cases_md = "\n| command | argv | exit | outcome | last stderr line |\n|---|---|---:|---|---|\n"
    cases_md += "".join(
        f"| {r['command']} | `{' '.join(a for a in r['argv'] if not a.startswith('/tmp'))}` | "
        f"{r['exit']} | {r['kind']} | {r['stderr'][:160].replace('|', '/')} |\n" for r in rows)
    return head + body + total, cases_md


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="studies/results/bad_input_table")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--timeout", type=float, default=120.0)
    parser.add_argument("--pythonpath", default=None,
                        help="run the cases with this PYTHONPATH (e.g. an older knitfem)")
    args = parser.parse_args()
    from knitfem.io import write_json, write_text
    with tempfile.TemporaryDirectory(prefix="knitfem-bad-input-") as tmp:
        tmp = Path(tmp)
        todo = cases(tmp)
        t = time.perf_counter()
        with ThreadPoolExecutor(args.jobs) as pool:
            rows = list(pool.map(lambda c: run_case(c, tmp, args.timeout, args.pythonpath),
                                 todo))
        wall = time.perf_counter() - t
    table, every = markdown(rows)
    out = Path(args.out)
    write_text(out / "bad_input_table.md", f"# CLI bad-input table ({len(rows)} cases, "
               f"{wall:.0f} s)\n\n{table}{every}")
    write_json(out / "bad_input_table.json", {"wall_s": wall, "cases": rows})
    print(table)
    bad = [r for r in rows if r["kind"] not in ORDER[:3]]
    for r in bad:
        print(f"  {r['kind']}: knitfem {r['command']} {' '.join(r['argv'])}: {r['stderr']}")


if __name__ == "__main__":
    main()
