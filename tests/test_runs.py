"""Runs that fail cleanly and never lose work: option messages, atomic files,
run.json written last, stale files removed, SIGINT as one line and exit 130."""
import json
import os
from pathlib import Path
import signal
import subprocess
import sys
import time

import pytest

from knitfem.cli import main
from knitfem.io.atomic import atomic_path, write_json, write_text
from knitfem.options import Integer, Interval, OptionError, OptionSet, Real, fmt

SMALL = ["--elements", "8", "--no-render", "--quiet"]


def test_intervals_print_with_six_significant_digits():
    assert str(Interval("(0, 1]")) == "(0, 1]" and 1.0 in Interval("(0, 1]")
    assert 0.0 not in Interval("(0, 1]") and str(Interval("[1e-300, inf)")) == "[1e-300, inf)"
    assert fmt(1e-300) == "1e-300" and fmt(0.27047619047619) == "0.270476" and fmt(60) == "60"


def test_an_option_set_names_the_option_as_typed_and_fills_defaults():
    import argparse
    options = OptionSet(Real("--w-over-L", 0.27, "(0, 1)"), Integer("--elements", 60, "[4, inf)"))
    parser = argparse.ArgumentParser()
    options.add_to(parser)
    args = options.validate(parser.parse_args(["--elements", "8"]))
    assert (args.w_over_L, args.elements, args.given) == (0.27, 8, {"elements"})
    with pytest.raises(OptionError, match=r"^--w-over-L must be a number in \(0, 1\), got -0.2$"):
        options.validate(parser.parse_args(["--w-over-L", "-0.2"]))


def test_a_failed_writer_leaves_the_previous_file_and_no_temporary(tmp_path):
    target = write_text(tmp_path / "a.json", "old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("disk full")
    assert target.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["a.json"]
    write_json(target, {"x": float("nan")})
    assert json.loads(target.read_text()) == {"x": None}


def test_rerun_into_the_same_out_removes_stale_shapes_and_lists_its_files(tmp_path):
    out = tmp_path / "run"
    assert main(["popup", "--c-to", "0.6", "--c-step", "0.1", "--out", str(out)] + SMALL) == 0
    assert main(["popup", "--c-to", "0.8", "--c-step", "0.05", "--out", str(out)] + SMALL) == 0
    shapes = sorted(p.name for p in (out / "shapes").iterdir())
    assert shapes == ["popup.pvd", "popup_c0.8000.vtu", "popup_c0.8500.vtu", "popup_c0.9000.vtu",
                      "popup_c0.9500.vtu"]
    manifest = json.loads((out / "run.json").read_text())
    assert manifest["complete"] is True and manifest["command"] == "knitfem popup"
    assert manifest["parameters"]["c_step"] == 0.05
    on_disk = sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file())
    assert sorted(manifest["files"] + ["run.json"]) == on_disk
    # which code made it: the checkout's commit (the tests run from one)
    repo = Path(__file__).resolve().parents[1]
    head = subprocess.run(["git", "-C", str(repo), "rev-parse", "HEAD"], capture_output=True,
                          text=True)
    if head.returncode == 0:
        assert manifest["source"]["commit"] == head.stdout.strip()
        assert isinstance(manifest["source"]["modified"], bool)
    else:
        assert manifest["source"] is None


def test_knit_keeps_the_other_swatches_of_its_folder(tmp_path):
    for nw in ("2", "3"):
        assert main(["knit", "--nw", nw, "--nc", "2", "--out", str(tmp_path), "--no-render",
                     "--quiet"]) == 0
    assert {p.name for p in tmp_path.glob("*.vtu")} == {"knit_2x2.vtu", "knit_3x2.vtu"}


def test_sigint_prints_one_line_exits_130_and_marks_the_folder_incomplete(tmp_path):
    out = tmp_path / "run"
    env = dict(os.environ, OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    proc = subprocess.Popen([sys.executable, "-m", "knitfem.cli", "popup", "--elements", "3000",
                             "--c-step", "0.002", "--no-limits", "--out", str(out), "--quiet",
                             "--no-render"], stderr=subprocess.PIPE, text=True, env=env)
    deadline = time.time() + 60
    while not (out / "run.json").exists():
        assert proc.poll() is None and time.time() < deadline, "the run did not start"
        time.sleep(0.05)
    time.sleep(1.0)                                 # inside the continuation
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 130, err
    assert err.strip().splitlines() == [
        f"knitfem popup: interrupted by SIGINT; {out}/run.json says complete: false"]
    manifest = json.loads((out / "run.json").read_text())
    assert manifest["complete"] is False and manifest["interrupted"] == "SIGINT"
    assert not [p for p in Path(out).rglob(".*tmp*")]        # no half-written temporaries


def test_a_resumed_run_keeps_the_processes_before_it_in_its_manifest(tmp_path):
    """run.json of a --resume'd run lists the earlier processes (start, end,
    source, complete), oldest first; a fresh run into the folder starts over."""
    from knitfem.io.run import RunFolder

    def run(resume):
        with RunFolder(tmp_path, "knitfem curl", {"resume": resume}) as folder:
            write_text(folder.path / "out.txt", "x")
        return json.loads((tmp_path / "run.json").read_text())
    first = run(False)
    assert "earlier" not in first
    second = run(True)
    third = run(True)
    assert [e["started"] for e in third["earlier"]] == [first["started"], second["started"]]
    assert third["earlier"][0]["complete"] is True
    assert third["earlier"][0]["source"] == first["source"]
    assert "earlier" not in run(False)
