"""The fabric phase sweep: the real B-spline task end to end on the smallest
swatches, a failed beam relaxation recorded as failed (never as a curl), the
CSV and the markers (a not-converged point hollow), the Dask path and a
killed + resumed study giving the local pool's rows."""
import csv
import json
import math
import os
from pathlib import Path
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from knitfem.scenes import curl_sweep
from knitfem.scenes.curl_sweep import COLUMNS, curl_point, phase_sweep
from knitfem.scenes.phase_output import phase_diagram, phase_trends, point_state, \
    write_phase_csv

ROOT = Path(__file__).resolve().parents[1]
NW, NC = [3, 4], [4]
# a step limit: the same work everywhere.  The time limit is only a guard: it
# also counts the numba compilation of a fresh clone's cold cache, and with two
# relaxations on the 2 cores 120 s ran out at FIRE step 20 (2026-12-03)
STEPS = {"max_steps": 150, "max_time": 900.0}


def records(out):
    """The finished points' records (not the hidden temporaries of atomic writes)."""
    return list((out / "points").glob("[!.]*.json"))


def same_rows(a, b):
    """Rows equal in everything but the wall time."""
    strip = [{k: v for k, v in r.items() if k != "elapsed_s"} for r in a]
    return strip == [{k: v for k, v in r.items() if k != "elapsed_s"} for r in b]


@pytest.fixture(scope="module")
def pool_rows(tmp_path_factory):
    """The 2 x 1 grid on a local pool of 2 processes."""
    rows, sweep = phase_sweep(NW, NC, tmp_path_factory.mktemp("pool"), options=STEPS,
                              workers=2, progress=False)
    assert sweep.executor.startswith("local pool") and sweep.complete
    return rows


def test_curl_point_relaxes_the_smallest_bspline_swatch_end_to_end(tmp_path):
    """3 x 4, 150 FIRE steps: a real relaxation, its shape measured and said
    to be not converged; the files are written; the same work repeats bit for bit."""
    result = curl_point({"nw": 3, "nc": 4, "model": "bspline", "curl": STEPS}, tmp_path)
    assert result["nw"] == 3 and result["model"] == "bspline"
    assert result["converged"] is False and "150 steps" in result["message"]
    assert 1e-6 < result["residual"] < 1.0
    assert result["curl"] in ("side", "double", "top_bottom", "flat")
    assert set(result["roll_deg"]) == {"left", "right", "top", "bottom"}
    # mirror symmetry of the 3-wale swatch: left and right rolls agree
    assert result["roll_deg"]["left"] == pytest.approx(result["roll_deg"]["right"], abs=1e-6)
    # the roll profile is kept with the point (its values: test_roll_profile)
    assert set(result["local_roll_deg"]) == set(result["roll_deg"])
    assert all(math.isfinite(v) for v in result["local_roll_deg"].values())
    assert result["height"] == pytest.approx(result["height_over_width"] * 3 * 4.0, rel=1e-12)
    assert result["loop_aspect"] > 0
    assert {"curl.vtu", "curl.json", "curl_control.npy"} <= {p.name for p in tmp_path.iterdir()}
    again = curl_point({"nw": 3, "nc": 4, "model": "bspline", "curl": STEPS}, tmp_path / "b")
    assert {k: v for k, v in again.items() if k != "relax_s"} == \
        {k: v for k, v in result.items() if k != "relax_s"}


def test_a_failed_beam_relaxation_is_a_failed_point_not_a_curl(tmp_path, monkeypatch):
    """The beam path's curl() returns its last state with an error when the
    relaxation fails, or raises: either way the point fails with the message."""
    from knitfem.scenes import curl as beam_curl
    from knitfem.scenes.fabric_relax import FabricRelaxationError

    def returns_error(scene, **kw):
        return {"curl": "side", "converged": False, "error": "relaxation failed near lam = 0.3"}

    def raises(scene, **kw):
        raise FabricRelaxationError("relaxation failed near lam = 0.1", None, 0.0, [])

    for fake, text in ((returns_error, "lam = 0.3"), (raises, "lam = 0.1")):
        monkeypatch.setattr(beam_curl, "curl", fake)
        rows, sweep = phase_sweep([3], [4], tmp_path / fake.__name__, model="beam",
                                  options={"alpha": 0.2}, workers=0, progress=False)
        assert sweep.records[0]["status"] == "failed"
        assert "FabricRelaxationError" in rows[0]["error"] and text in rows[0]["error"]
        assert rows[0]["curl"] is None and rows[0]["converged"] is False
        assert point_state(rows[0]) == "failed"


def test_a_beam_point_along_several_paths_reports_the_set_of_curls(tmp_path, monkeypatch):
    """With the curl option ``paths`` a beam point is relaxed along each
    schedule (here a stand-in for curl() that writes what it writes): the
    row's curl is the lowest-energy stable path's, ``curl_types`` the set,
    and the point's .vtu that path's equilibrium."""
    import json
    from knitfem.scenes import curl as beam_curl

    def fake(scene, *, out, relax_options=None, **kw):
        coarse = relax_options == {"dlam": 0.3, "dlam_max": 0.5}
        summary = {"nw": scene.nw, "nc": scene.nc, "curl": "double" if coarse else "top_bottom",
                   "energy": 1.0 if coarse else 2.0, "converged": True, "stable": True,
                   "roll_deg": {k: 0.0 for k in ("left", "right", "top", "bottom")},
                   "error": None}
        out.mkdir(parents=True, exist_ok=True)
        (out / "curl_3x4.json").write_text(json.dumps(summary))
        (out / "curl_3x4.vtu").write_text(out.name)
        return summary
    monkeypatch.setattr(beam_curl, "curl", fake)
    rows, sweep = phase_sweep([3], [4], tmp_path, model="beam",
                              options={"paths": "default,coarse"}, workers=0, progress=False)
    assert sweep.records[0]["status"] == "done"
    assert rows[0]["curl"] == "double" and rows[0]["curl_types"] == "double|top_bottom"
    point = next(p for p in (tmp_path / "points").iterdir() if p.is_dir())
    assert (point / "curl.vtu").read_text() == "path_coarse"
    assert json.loads((point / "curl.json").read_text())["path_dependent"] is True


def test_a_killed_beam_point_resumes_from_its_checkpoint(tmp_path, monkeypatch):
    """On a local executor a beam point relaxes in the sweep's lasting
    ``work/<key>/`` folder: killed there (an interruption after its first
    checkpoint), the same sweep with ``resume`` hands curl() that folder
    again with ``resume=True``, so it continues; the folder goes once the
    point is stored, and a sweep started afresh removes a killed one's.
    (Here a stand-in for curl(); a real checkpoint's resume: test_fabric.)"""
    import json
    from knitfem.scenes import curl as beam_curl
    calls = []

    def killed(scene, *, out, resume=False, **kw):
        calls.append((Path(out), resume))
        (Path(out) / "checkpoint.npz").write_text("lam 0.5")
        raise KeyboardInterrupt

    def resumed(scene, *, out, resume=False, **kw):
        calls.append((Path(out), resume))
        calls[-1] += ((Path(out) / "checkpoint.npz").read_text(),)
        summary = {"nw": scene.nw, "nc": scene.nc, "curl": "double", "converged": True,
                   "stable": True, "error": None,
                   "roll_deg": {k: 0.0 for k in ("left", "right", "top", "bottom")}}
        (Path(out) / "curl_3x4.json").write_text(json.dumps(summary))
        (Path(out) / "curl_3x4.vtu").write_text("relaxed")
        return summary
    monkeypatch.setattr(beam_curl, "curl", killed)
    with pytest.raises(KeyboardInterrupt):
        phase_sweep([3], [4], tmp_path, model="beam", workers=0, progress=False)
    work = calls[0][0]
    assert work.parent == tmp_path / "work" and calls[0][1] is True
    assert (work / "checkpoint.npz").is_file() and not records(tmp_path)
    monkeypatch.setattr(beam_curl, "curl", resumed)
    rows, sweep = phase_sweep([3], [4], tmp_path, model="beam", workers=0, progress=False,
                              resume=True)
    assert calls[1] == (work, True, "lam 0.5")
    assert sweep.complete and rows[0]["curl"] == "double" and not work.parent.exists()
    point = next(p for p in (tmp_path / "points").iterdir() if p.is_dir())
    assert (point / "curl.vtu").read_text() == "relaxed"
    (work / "path").mkdir(parents=True)       # as if killed before its removal: a done
    phase_sweep([3], [4], tmp_path, model="beam", workers=0, progress=False, resume=True)
    assert not work.exists() and len(calls) == 2          # point's folder goes on resume
    monkeypatch.setattr(beam_curl, "curl", killed)          # killed again, then afresh
    with pytest.raises(KeyboardInterrupt):
        phase_sweep([3], [4], tmp_path, model="beam", workers=0, progress=False)
    monkeypatch.setattr(beam_curl, "curl", resumed)
    rows, sweep = phase_sweep([3], [4], tmp_path, model="beam", workers=0, progress=False)
    assert "FileNotFoundError" in rows[0]["error"] and calls[3] == (work, True)  # none handed on
    # a failed point keeps its folder (run again, it would continue from there)
    assert work.is_dir() and not (work / "checkpoint.npz").exists()
    from knitfem.io.atomic import OutputError
    stray = tmp_path / "elsewhere"
    (stray / "work").mkdir(parents=True)      # a folder that is not a sweep's is not cleared
    with pytest.raises(OutputError, match="not a knitfem sweep folder"):
        phase_sweep([3], [4], stray, model="beam", workers=0, progress=False)


def test_options_of_the_other_model_are_refused(tmp_path):
    with pytest.raises(ValueError, match=r"\['friction'\] do not apply to model 'bspline'"):
        curl_point({"nw": 3, "nc": 4, "curl": {"friction": 0.3}}, tmp_path)
    with pytest.raises(ValueError, match="model must be one of"):
        curl_point({"nw": 3, "nc": 4, "model": "rod"}, tmp_path)


def synthetic_rows():
    rows = []
    for nw, nc, curl, status, converged in [(5, 10, "side", "done", True),
                                            (25, 10, "double", "done", True),
                                            (55, 10, "top_bottom", "done", True),
                                            (10, 35, "side", "done", False),
                                            (40, 5, None, "failed", False)]:
        row = dict.fromkeys(COLUMNS)
        row.update(nw=nw, nc=nc, nw_over_nc=nw / nc, model="bspline", status=status,
                   curl=curl, converged=converged)
        if status == "done":
            row.update(height=0.1 * nw / nc, loop_aspect=1.3 + 0.01 * nw / nc,
                       roll_left=-45.0, residual=1e-3)
        else:
            row["error"] = "CurlFailed: FabricRelaxationError: relaxation failed, lam = 0.1"
        rows.append(row)
    return rows


def test_phase_csv_has_one_row_per_point_with_empty_cells_for_no_value(tmp_path):
    rows = synthetic_rows()
    write_phase_csv(rows, tmp_path / "phase.csv")
    with open(tmp_path / "phase.csv", newline="") as f:
        read = list(csv.DictReader(f))
    assert list(read[0]) == list(COLUMNS) and len(read) == 5
    assert read[3]["curl"] == "side" and read[3]["converged"] == "False"
    assert read[4]["curl"] == "" and read[4]["height"] == "" and "lam = 0.1" in read[4]["error"]


def test_not_converged_points_are_hollow_and_failed_ones_crosses():
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgba
    rows = synthetic_rows()
    fig, ax = phase_diagram(rows)
    drawn = {c.get_label(): c for c in ax.collections}
    assert set(drawn) == {"side", "double", "top/bottom", "side (not converged)", "failed"}
    for label in ("side", "double", "top/bottom"):                   # converged: filled
        assert drawn[label].get_facecolors()[0][3] == 1.0
    hollow = drawn["side (not converged)"]
    assert hollow.get_facecolors().size == 0 or hollow.get_facecolors()[0][3] == 0.0
    assert np.allclose(hollow.get_edgecolors()[0], to_rgba("0.45"))
    assert hollow.get_offsets().tolist() == [[10, 35]]
    assert drawn["failed"].get_offsets().tolist() == [[40, 5]]
    boundary = [line for line in ax.lines if "N_w/N_c" in line.get_label()][0]
    (x0, x1), (y0, y1) = boundary.get_data()
    assert x0 == y0 == 0 and x1 / y1 == 2.0 and y1 >= 35
    plt.close(fig)
    rows[0]["curl_types"] = "double|top_bottom"         # relaxed along several paths
    fig, ax = phase_diagram(rows)
    ring = [c for c in ax.collections if c.get_label().startswith("path dependent")]
    assert len(ring) == 1 and ring[0].get_offsets().tolist() == [[rows[0]["nw"], rows[0]["nc"]]]
    plt.close(fig)
    rows[0]["curl_types"] = "double"
    fig, ax = phase_diagram(rows)
    assert not [c for c in ax.collections if c.get_label().startswith("path dependent")]
    plt.close(fig)
    fig, (ax_h, ax_a) = phase_trends(rows, knitted_aspect=4 / 3)
    drawn = {c.get_label(): c for c in ax_h.collections}
    assert "failed" not in drawn                                    # no H for a failed point
    assert drawn["side (not converged)"].get_offsets().tolist() == [[10 / 35, 0.1 * 10 / 35]]
    assert not [line for line in ax_h.lines if "Fig. 2 row" in line.get_label()]  # no N_c = 20
    plt.close(fig)
    fig, (ax_h, ax_a) = phase_trends(rows, row_nc=10)       # the row's finished points, joined
    for ax, value in ((ax_h, lambda q: 0.1 * q), (ax_a, lambda q: 1.3 + 0.01 * q)):
        row = [line for line in ax.lines if "Fig. 2 row" in line.get_label()]
        assert len(row) == 1 and row[0].get_label().startswith("$N_c$ = 10")
        x, y = row[0].get_data()
        assert list(x) == [0.5, 2.5, 5.5] and np.allclose(y, [value(q) for q in x])
    plt.close(fig)
    # a grid under way: the points it has not reached are dots, not failures
    pending = dict(rows[0], nw=30, nc=5, status="not run", curl=None, height=None)
    fig, ax = phase_diagram(rows + [pending])
    drawn = {c.get_label(): c for c in ax.collections}
    assert drawn["not run yet"].get_offsets().tolist() == [[30, 5]]
    assert drawn["failed"].get_offsets().tolist() == [[40, 5]]
    assert "1 failed, 1 not run" in ax.get_title()
    plt.close(fig)


def test_dask_local_cluster_gives_the_local_pool_rows(tmp_path, pool_rows):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        rows, sweep = phase_sweep(NW, NC, tmp_path, options=STEPS,
                                  scheduler=cluster.scheduler_address, progress=False)
    assert sweep.executor.startswith("Dask") and sweep.complete
    assert same_rows(rows, pool_rows)


def load_study():
    from importlib import util
    spec = util.spec_from_file_location("fabric_phase", ROOT / "studies" / "fabric_phase.py")
    module = util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def study(out, *extra):
    return [sys.executable, str(ROOT / "studies" / "fabric_phase.py"), "--out", str(out),
            "--nw", "3,4,5", "--nc", "4", "--max-steps", str(STEPS["max_steps"]),
            "--max-time", str(STEPS["max_time"]), "--quiet", *extra]


def test_killed_then_resumed_study_equals_the_uninterrupted_sweep(tmp_path, pool_rows, capsys):
    out = tmp_path / "phase"
    env = dict(os.environ, OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    proc = subprocess.Popen(study(out, "--workers", "0"), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    deadline = time.time() + 120
    while not records(out) and proc.poll() is None:
        assert time.time() < deadline, "no point finished in 120 s"
        time.sleep(0.02)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143, err
    finished = len(records(out))
    assert 1 <= finished < 3 and not (out / "phase.csv").exists()
    assert json.loads((out / "sweep.json").read_text())["complete"] is False
    # --report draws what is there, relaxing nothing and leaving the sweep's files alone
    manifest = (out / "sweep.json").read_text()
    assert load_study().main(study(out, "--report")[2:]) == 0
    held = json.loads((out / "report" / "phase.json").read_text())
    assert held["counts"]["not run"] == 3 - finished and held["sweep_complete"] is False
    assert held["counts"]["not converged"] == finished          # 150 FIRE steps each
    with open(out / "report" / "phase.csv", newline="") as f:
        assert [r["status"] for r in csv.DictReader(f)].count("not run") == 3 - finished
    assert (out / "report" / "phase_diagram.png").stat().st_size > 0
    assert (out / "sweep.json").read_text() == manifest and len(records(out)) == finished
    assert not (out / "phase.csv").exists()
    # without --nw / --nc: the sweep's own grid and what it stored, not the default 8 x 7
    assert load_study().main(["--out", str(out), "--report"]) == 0
    held = json.loads((out / "report" / "phase.json").read_text())
    assert [(p["nw"], p["nc"]) for p in held["points"]] == [(3, 4), (4, 4), (5, 4)]
    assert load_study().main(["--out", str(tmp_path / "none"), "--report"]) == 2   # no sweep
    assert not (tmp_path / "none").exists()                     # and no folder made for it
    # the folder's model and scene are drawn: a --model or curl option naming others is refused
    assert load_study().main(["--out", str(out), "--report", "--model", "beam"]) == 2
    assert load_study().main(study(out, "--report", "--alpha", "0.1")[2:]) == 2
    assert "(--alpha: given 0.1, folder 0.2)" in capsys.readouterr().err
    # only the options named are compared: the folder's --max-time need not be repeated
    assert load_study().main(["--out", str(out), "--report", "--alpha", "0.2"]) == 0
    with pytest.raises(SystemExit):                 # no abbreviations slip past the check
        load_study().parse(["--out", str(out), "--report", "--alp", "0.1"])
    assert (out / "sweep.json").read_text() == manifest and len(records(out)) == finished
    # a resume projects the time of the points left only
    module = load_study()
    line = module.projection(module.parse(study(out, "--workers", "0", "--resume")[2:]))
    assert line.startswith(f"3 points ({finished} done), at most about") and "the rest" in line
    # ... of this sweep: another sweep's records are not counted, its folder is refused
    with pytest.raises(ValueError, match="holds a sweep of .* with constants"):
        module.projection(module.parse(study(out, "--workers", "0", "--resume",
                                             "--alpha", "0.1")[2:]))

    assert load_study().main(study(out, "--workers", "0", "--resume")[2:]) == 0   # in here
    # the sweep redraws its report after each point: the last one drawn holds all three
    drawn = json.loads((out / "report" / "phase.json").read_text())
    assert drawn["counts"]["not converged"] == 3 and drawn["counts"]["not run"] == 0
    result = json.loads((out / "phase.json").read_text())
    assert result["points_reused"] == finished and result["points_run"] == 3 - finished
    rows = result["rows"]
    assert [(r["nw"], r["nc"]) for r in rows] == [(3, 4), (4, 4), (5, 4)]
    assert same_rows(rows[:2], pool_rows)          # the uninterrupted pool's 3 x 4, 4 x 4
    assert json.loads((out / "run.json").read_text())["complete"] is True
    with open(out / "phase.csv", newline="") as f:
        assert len(list(csv.DictReader(f))) == 3
    assert (out / "phase_diagram.png").stat().st_size > 0


@pytest.mark.parametrize("args,message", [
    (["--nw", "5,x"], "--nw must be a comma-separated list of different integers in [3, 200]"),
    (["--nc", "3"], "--nc must be a comma-separated list of different integers in [4, 200]"),
    (["--nc", "5,5"], "--nc must be a comma-separated list"),
    (["--model", "beam", "--nw", "2"], "--nw must be a comma-separated list of different "
                                       "integers in [3, 200]"),
    (["--max-time", "0"], "--max-time must be a number in (0, 1e+06]"),
    (["--model", "beam", "--max-time", "10"], "--max-time does not apply to --model beam"),
    (["--friction", "0.3"], "--friction does not apply to --model bspline"),
    (["--radius", "0.6"], "--radius must be below --w/8"),
    (["--workers", "-1"], "--workers must be an integer in [0, 1024]"),
    (["--model", "beam", "--paths", "default,slow"], "--paths must list distinct schedules"),
    (["--paths", "default"], "--paths applies to --model beam only"),
    (["--bindoff-prestretch"], "--bindoff-prestretch applies to --model beam only"),
    (["--model", "beam", "--adopt", "run.json"], "--adopt needs --model beam and --resume"),
    (["--resume", "--adopt", "run.json"], "--adopt needs --model beam and --resume"),
    (["--report", "--resume"], "--report reads the folder as it is"),
])
def test_bad_options_are_one_line_naming_the_option_exit_2(tmp_path, capsys, args, message):
    with pytest.raises(SystemExit) as stop:
        load_study().parse(["--out", str(tmp_path), *args])
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err, err


def test_rows_of_points_that_did_not_run_say_so():
    class Sweep:
        points = [{"nw": 3, "nc": 4}]
        records = [None]
    row = curl_sweep.phase_rows(Sweep, "bspline")[0]
    assert row["status"] == "not run" and row["curl"] is None and row["model"] == "bspline"
    assert point_state(row) == "not run"


def test_the_study_hands_its_relaxation_options_to_the_points():
    """``fabric_phase.py --model beam --max-rounds 12 --settle 2 ...`` puts them
    in the per-point curl options (before, the parser took them and the
    points never saw them)."""
    module = load_study()
    args = module.parse(["--out", "x", "--model", "beam", "--nw", "5", "--nc", "5",
                         "--max-rounds", "12", "--snap-rounds", "3", "--settle", "2",
                         "--reanchor", "0.2"])
    options = module.curl_options(args)
    assert {k: options[k] for k in ("max_rounds", "snap_rounds", "settle", "reanchor")} == \
        {"max_rounds": 12, "snap_rounds": 3, "settle": 2, "reanchor": 0.2}


def test_every_curl_option_the_study_takes_reaches_some_model():
    """No option is parsed and dropped: each ``knitfem curl`` value option the
    phase study accepts is a per-point option of the beam or the B-spline model."""
    from knitfem.options import Real
    from knitfem.scenes.curl_sweep import BEAM_OPTIONS, BSPLINE_OPTIONS
    module = load_study()
    keys = {spec.flag.lstrip("-").replace("-", "_") for spec in module.OPTIONS.specs
            if isinstance(spec, Real)}
    assert keys and not keys - set(BEAM_OPTIONS) - set(BSPLINE_OPTIONS)


def test_a_scene_option_added_later_keeps_the_stored_sweeps_resumable():
    """``straighten`` came after sweeps were stored: at its old value (1, the
    straight yarn every stored sweep ran with) it is left out of a sweep's
    constants, so those sweeps resume; another value is a constant like any."""
    from knitfem.scenes.curl_sweep import sweep_constants
    stored = {"alpha": 0.2, "tail_ties": 1}
    assert sweep_constants("beam", {**stored, "straighten": 1.0}) == \
        sweep_constants("beam", stored) == {"model": "beam", "curl": stored}
    assert sweep_constants("beam", {**stored, "straighten": 0.0})["curl"]["straighten"] == 0.0
