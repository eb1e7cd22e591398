"""The sweep engine: a killed and resumed heat map equals an uninterrupted one,
SIGTERM stops the workers, the Dask path gives the local pool's numbers, and
the store keeps whole records only."""
import json
import os
from pathlib import Path
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from knitfem.scenes.popup_sweep import heat_map, popup_column
from knitfem.sweep import grid, point_key, run_sweep

ROOT = Path(__file__).resolve().parents[1]
W = np.linspace(0.05, 0.50, 6)
C = np.round(0.95 - 0.05 * np.arange(12), 10)          # 0.95 ... 0.40
SCENE = {"elements": 16}


@pytest.fixture(scope="module")
def pool_heat_map(tmp_path_factory):
    """The 6 x 12 heat map on the local pool, uninterrupted."""
    return heat_map(W, C, out=tmp_path_factory.mktemp("pool"), workers=2, progress=False,
                    **SCENE)


def children(pid):
    """Pids of the live child processes of ``pid`` (from /proc)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid and fields[0] != "Z":
            found.append(int(stat.parent.name))
    return found


def alive(pid):
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def study(out, *extra):
    return [sys.executable, str(ROOT / "studies" / "popup_heatmap.py"), "--out", str(out),
            "--nw", "6", "--dc", "0.05", "--elements", "16", "--workers", "1", "--quiet",
            *extra]


def test_sigterm_mid_sweep_then_resume_equals_the_uninterrupted_heat_map(tmp_path,
                                                                         pool_heat_map):
    out = tmp_path / "hm"
    env = dict(os.environ, OMP_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    proc = subprocess.Popen(study(out), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=env)
    deadline = time.time() + 120
    while len(list((out / "points").glob("[!.]*.json"))) < 2 and proc.poll() is None:
        assert time.time() < deadline, "no point finished in 120 s"
        time.sleep(0.02)
    workers = children(proc.pid)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    finished = len(list((out / "points").glob("[!.]*.json")))
    assert proc.returncode == 143, err
    assert len(err.strip().splitlines()) == 1 and "interrupted by SIGTERM" in err, err
    assert 2 <= finished < len(W), "the kill should land mid-sweep"
    time.sleep(1.0)
    assert workers and not [p for p in workers if alive(p)], "worker processes left running"
    run = json.loads((out / "run.json").read_text())
    sweep = json.loads((out / "sweep.json").read_text())
    assert run["complete"] is False and run["interrupted"] == "SIGTERM"
    assert sweep["complete"] is False and not (out / "popup_heatmap.json").exists()

    resume = study(out, "--resume")
    resume[resume.index("--workers") + 1] = "0"         # in its own process: no spawn needed
    done = subprocess.run(resume, capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    result = json.loads((out / "popup_heatmap.json").read_text())
    assert result["columns_reused"] == finished
    assert json.loads((out / "run.json").read_text())["complete"] is True
    height = np.array(result["max_abs_z_over_L"], dtype=float)         # null -> nan
    assert np.array_equal(height, pool_heat_map.height, equal_nan=True)
    assert np.array_equal(result["critical_c_over_L"], pool_heat_map.critical)
    assert np.array_equal(result["stable"], pool_heat_map.stable)


def test_dask_local_cluster_gives_the_local_pool_results(tmp_path, pool_heat_map):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        hm = heat_map(W[:3], C, out=tmp_path, scheduler=cluster.scheduler_address,
                      progress=False, **SCENE)
    assert hm.sweep.executor.startswith("Dask") and not hm.errors
    # the same numbers up to summation order: in-process Dask threads share one
    # process's BLAS / numba thread settings, the pool's workers do not (a
    # bitwise comparison failed once in ~5 full runs)
    assert np.allclose(hm.height, pool_heat_map.height[:3], rtol=1e-9, atol=1e-12,
                       equal_nan=True)
    assert np.allclose(hm.critical, pool_heat_map.critical[:3], rtol=1e-9, atol=1e-12,
                       equal_nan=True)


def test_resume_skips_done_points_and_reruns_failed_ones(tmp_path):
    points = grid(w_over_L=[0.2, 1.5])                  # w/L = 1.5: no such rod, fails
    constants = {"c_over_L": [0.9, 0.8], "scene": SCENE}
    first = run_sweep(popup_column, points, tmp_path, constants=constants, workers=0,
                      progress=False)
    assert [r["status"] for r in first.records] == ["done", "failed"]
    assert "w must be smaller than the rod length" in first.records[1]["error"]
    again = run_sweep(popup_column, points, tmp_path, constants=constants, workers=0,
                      progress=False, resume=True)
    assert again.reused == 1 and again.records[0] == first.records[0]
    with pytest.raises(ValueError, match="holds a sweep of .* with constants"):
        run_sweep(popup_column, points, tmp_path, constants={**constants, "scene": {}},
                  workers=0, progress=False, resume=True)


def test_on_point_sees_every_stored_record_and_cannot_stop_the_sweep(tmp_path, capsys):
    points = grid(w_over_L=[0.2, 1.5])                  # the second fails
    constants = {"c_over_L": [0.9, 0.8], "scene": SCENE}
    seen = []

    def on_point(record):
        seen.append((record["key"], (tmp_path / "points" / f"{record['key']}.json").is_file()))
        raise RuntimeError("figure broke")
    result = run_sweep(popup_column, points, tmp_path, constants=constants, workers=0,
                       progress=False, on_point=on_point)
    assert [r["status"] for r in result.records] == ["done", "failed"]
    assert seen == [(point_key(p), True) for p in points]     # on disk before the hook
    err = capsys.readouterr().err
    assert err.count("RuntimeError: figure broke") == 2 and point_key(points[0]) in err


def test_point_keys_are_readable_stable_and_distinct():
    assert point_key({"nw": 10, "nc": 5}) == "nw=10_nc=5"
    assert point_key({"w_over_L": 0.05}) == "w_over_L=0.05"
    assert point_key({"a": "x/y"}) != point_key({"a": "x-y"})
    assert len(point_key({"a": "b" * 500})) < 100


def _started(params, out_dir):
    """A task that says when it ran (a counter that only grows)."""
    return {"ns": time.perf_counter_ns()}


def test_first_orders_the_points_left_but_not_the_results(tmp_path):
    points = grid(nw=[30, 5, 10, 20], nc=[20, 5])          # 5 x 20 and 20 x 5 tie
    seen = []
    result = run_sweep(_started, points, tmp_path, workers=0, progress=False,
                       first=lambda p: p["nw"] * p["nc"],
                       on_point=lambda record: seen.append(tuple(record["params"].values())))
    sizes = [nw * nc for nw, nc in seen]
    assert sizes == sorted(sizes) and seen[:4] == [(5, 5), (10, 5), (5, 20), (20, 5)]
    assert [r["params"] for r in result.records] == points                # results: grid order
    ran = [r["result"]["ns"] for r in result.records]
    assert [points[i] for i in np.argsort(ran)] == [dict(nw=a, nc=b) for a, b in seen]
    manifest = json.loads((tmp_path / "sweep.json").read_text())
    assert [p["params"] for p in manifest["points"]] == points
    # without it, the given order
    seen.clear()
    run_sweep(_started, points, tmp_path / "plain", workers=0, progress=False,
              on_point=lambda record: seen.append(tuple(record["params"].values())))
    assert seen == [tuple(p.values()) for p in points]


def test_a_worker_records_its_commit_before_the_point_runs():
    """The commit a result names is cached in the worker before its first
    point starts, not when the result is written hours later (the checkout
    may have moved on by then while the process runs its old code)."""
    from knitfem.io.run import source
    from knitfem.sweep.engine import execute
    source.cache_clear()
    seen = {}

    def task(params, tmp):
        seen["cached"] = source.cache_info().currsize
        return {"x": params["x"]}

    outcome, _ = execute(task, {"x": 1.0})
    assert outcome["status"] == "done" and seen["cached"] == 1
