"""The studies that read beam curl runs: the run time against error (rolls
of increments whose path .vtu is lost), the checkpoint report and the
run-time estimate's calibration."""
import csv
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "studies"))
from beam_time_vs_error import EDGES, fill_from_earlier  # noqa: E402
from checkpoint_report import bspline_report, report  # noqa: E402
import runtime_estimate  # noqa: E402


def _write(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["lam", "relax_s", "iterations", "residual", "accepted",
                                          "curl"] + [f"roll_{e}" for e in EDGES], restval="")
        w.writeheader()
        w.writerows(rows)


def test_an_earlier_csv_fills_only_the_rows_without_rolls(tmp_path):
    earlier = tmp_path / "old.csv"
    _write(earlier, [dict(lam=0.1, curl="flat", roll_left=-4, roll_right=-3, roll_top=4, roll_bottom=5),
                     dict(lam=0.25, curl="double", roll_left=-40, roll_right=-41, roll_top=50,
                          roll_bottom=52)])
    rows = [dict(lam=0.1, accepted=True),
            dict(lam=0.25, accepted=True, curl="side", roll_left=-1.0, roll_right=-2.0, roll_top=3.0,
                 roll_bottom=4.0),
            dict(lam=0.4, accepted=True)]
    out = fill_from_earlier(rows, earlier)
    assert out[0]["curl"] == "flat" and out[0]["roll_bottom"] == 5.0
    assert out[1]["curl"] == "side" and out[1]["roll_left"] == -1.0     # measured rows win
    assert "roll_left" not in out[2]                                    # nothing to fill from


def test_an_earlier_csv_of_another_path_is_refused(tmp_path):
    earlier = tmp_path / "old.csv"
    _write(earlier, [dict(lam=0.3, curl="flat", roll_left=0, roll_right=0, roll_top=0, roll_bottom=0)])
    with pytest.raises(SystemExit, match="another path"):
        fill_from_earlier([dict(lam=0.1, accepted=True)], earlier)


def test_the_checkpoint_report_reads_a_partial_increment(tmp_path):
    """A partial state moved rigidly is no change of shape; the rounds' moves are
    given in yarn radii as well."""
    import numpy as np
    from knitfem.beam.model import BeamState
    from knitfem.scenes import curl as curl_module
    from knitfem.scenes import fabric_relax
    from knitfem.scenes.fabric import FabricScene, build
    scene = FabricScene(3, 4, elements_per_loop=16)
    model, _, _ = build(scene)
    state = model.initial_state()
    moved = BeamState(state.x + [1.0, 2.0, 2.0], state.q)
    partial = fabric_relax.Partial(0.8, moved, 2, 400, np.inf, 12.0, ends=(1e-2, 3e-2),
                                   moves=(2.0, 4.0))
    curl_module._save_checkpoint(tmp_path / "checkpoint.npz", scene, state, 0.78, 0.02, [], None,
                                 partial)
    r = report(tmp_path)
    assert r["lam"] == 0.78 and r["partial"]["rounds"] == 2 and r["partial"]["steps"] == 400
    assert r["partial"]["round_moves_over_r"] == pytest.approx([2.0 / scene.radius, 4.0 / scene.radius])
    change = r["partial"]["shape_change"]
    assert change["max"] < 1e-9 and change["shift"] == pytest.approx(3.0)
    assert r["partial"]["shape"]["roll_deg"] == pytest.approx(r["equilibrium"]["roll_deg"])


def _summary(path, nw, nc, relax_s, iterations, corotated=True, error=None, model="beam"):
    import json
    scene = {"nw": nw, "nc": nc, "elements_per_loop": 32, "corotated_friction": corotated}
    path.write_text(json.dumps({"nw": nw, "nc": nc, "model": model, "alpha": 0.2,
                                "scene": scene, "relax_s": relax_s, "iterations": iterations,
                                "failed_increments": 0, "error": error}))


def test_the_runtime_study_compares_each_distinct_finished_run_with_its_estimate(tmp_path):
    """Only finished beam runs with co-rotated friction count, a run copied
    into two folders once; the ratio is measured over the command's own
    estimate, whose two factors multiply back to it."""
    from argparse import Namespace
    from knitfem.scenes import curl_command
    estimate = curl_command.seconds(Namespace(nw=5, nc=5, elements_per_loop=32, model="beam"))
    _summary(tmp_path / "a.json", 5, 5, 2 * estimate, 1000)
    (tmp_path / "copy").mkdir()
    _summary(tmp_path / "copy" / "curl.json", 5, 5, 2 * estimate, 1000)        # adopted copy
    _summary(tmp_path / "planes.json", 5, 5, 100.0, 1000, corotated=False)   # older friction
    _summary(tmp_path / "failed.json", 5, 5, 100.0, 1000, error="relaxation failed")
    _summary(tmp_path / "bspline.json", 5, 5, 100.0, 1000, model="bspline")
    (tmp_path / "other.json").write_text("[1, 2]")
    rows = runtime_estimate.collect([tmp_path])
    assert len(rows) == 1
    row = rows[0]
    assert row["ratio"] == pytest.approx(2.0)
    assert row["estimate_s"] == pytest.approx(estimate)
    factors = (row["iterations"] / row["iterations_model"]) * \
        (row["s_per_dof_iteration"] / curl_command.S_PER_DOF_ITERATION)
    assert factors == pytest.approx(row["ratio"])


def test_the_grid_projection_spreads_its_points_longest_first():
    """Makespan of independent points on workers: longest first, each to the
    first free worker; one worker sums them; never below the longest point."""
    assert runtime_estimate.makespan([6, 5, 4, 3], 2) == 9.0
    assert runtime_estimate.makespan([5, 4, 3, 3, 3], 2) == 10.0     # greedy, not the optimum 9
    assert runtime_estimate.makespan([5, 4, 3], 1) == 12.0
    assert runtime_estimate.makespan([10, 1, 1], 4) == 10.0
    n, worker_h, wall_h, longest_h = runtime_estimate.grid_projection([5, 10], [5], 1.0, 2)
    assert n == 2 and wall_h == pytest.approx(longest_h) and worker_h > wall_h


def test_the_checkpoint_report_reads_a_bspline_run(tmp_path):
    """A B-spline run's FIRE checkpoint: its step, last checked residual, runs,
    and the curl of its state, the same as the run's own summary of it."""
    from knitfem.scenes.curl_bspline import bspline_curl
    summary = bspline_curl(4, 4, max_steps=40, newton=False, max_time=600, out=tmp_path,
                           progress=False)
    r = bspline_report(tmp_path, tmp_path / "bspline_4x4_checkpoint.npz")
    assert r["model"] == "bspline" and (r["nw"], r["nc"], r["alpha"]) == (4, 4, 0.2)
    assert r["step"] == 40 and r["processes"] == 1 and r["relax_s"] > 0
    assert r["residual"] == pytest.approx(summary["history"][-1])
    assert r["state"]["curl"] == summary["curl"]
    assert r["state"]["roll_deg"] == pytest.approx(summary["roll_deg"])
