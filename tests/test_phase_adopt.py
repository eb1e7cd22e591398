"""A finished ``knitfem curl`` run adopted as a point of the beam phase sweep:
reused by --resume instead of relaxed again, and refused (naming what
differs) when its scene, relaxation, grid point or outcome is not the
sweep's, when the point is done already, or while a sweep runs there."""
from dataclasses import asdict
import json
import subprocess

import pytest

from knitfem.scenes import curl as beam_curl
from knitfem.scenes.curl_sweep import adopt_run, curl_point, phase_sweep
from knitfem.scenes.fabric import FabricScene
from knitfem.sweep.engine import task_name
from knitfem.sweep.store import SweepStore, point_key

OPTIONS = {"alpha": 0.2, "friction": 0.3, "elements_per_loop": 32}
ROLLS = {"left": -190.0, "right": -170.0, "top": 110.0, "bottom": 130.0}


def sweep_folder(out, options=OPTIONS, points=({"nw": 5, "nc": 20},)):
    """A started beam sweep (its manifest) with no point finished."""
    store = SweepStore(out)
    store.open(task_name(curl_point), {"model": "beam", "curl": dict(options)}, list(points),
               [point_key(p) for p in points], resume=False)
    store.finish(complete=False)
    return out


def finished_run(folder, nw=5, nc=20, **changes):
    """A run's summary JSON and .vtu as ``knitfem curl --out`` leaves them."""
    folder.mkdir(parents=True, exist_ok=True)
    summary = {"nw": nw, "nc": nc, "model": "beam", "alpha": 0.2, "curl": "double",
               "roll_deg": ROLLS, "edges_touch": False, "converged": True, "stable": True,
               "residual": 5e-9, "relax_s": 1234.5, "error": None,
               "scene": asdict(FabricScene(nw, nc, **OPTIONS))}
    for key, value in changes.items():
        if key in summary["scene"] or key == "new_knob":
            summary["scene"][key] = value
        else:
            summary[key] = value
    path = folder / f"curl_{nw}x{nc}.json"
    path.write_text(json.dumps(summary))
    path.with_suffix(".vtu").write_bytes(b"<VTKFile/>")
    return path


def test_adopted_run_is_reused_not_relaxed_again(tmp_path, monkeypatch):
    out = sweep_folder(tmp_path / "sweep")
    record = adopt_run(out, finished_run(tmp_path / "run"))
    assert record["key"] == "nw=5_nc=20" and record["status"] == "done"
    assert record["elapsed_s"] == 1234.5 and record["worker"].startswith("adopted from")
    assert (out / "points" / "nw=5_nc=20" / "curl.vtu").read_bytes() == b"<VTKFile/>"

    def relaxes(scene, **kw):
        raise AssertionError("the adopted point was relaxed again")

    monkeypatch.setattr(beam_curl, "curl", relaxes)
    rows, sweep = phase_sweep([5], [20], out, model="beam", options=OPTIONS, resume=True,
                              workers=0, progress=False)
    assert sweep.reused == 1 and sweep.complete
    row = rows[0]
    assert row["curl"] == "double" and row["converged"] is True
    assert [row[f"roll_{e}"] for e in ROLLS] == list(ROLLS.values())


@pytest.mark.parametrize("changes, words", [
    ({"friction": 0.05}, "friction: run 0.05, sweep 0.3"),
    ({"elements_per_loop": 24}, "elements_per_loop: run 24, sweep 32"),
    ({"error": "relaxation failed near lam = 0.4"}, "not a relaxed swatch"),
    ({"curl": None}, "not a relaxed swatch"),
    ({"model": "bspline"}, "only beam runs"),
    ({"protocol": {"dlam": 0.3, "dlam_max": 0.5}}, "protocol options"),
    ({"new_knob": 7}, "new_knob.*not FabricScene fields"),
])
def test_a_run_that_is_not_the_sweeps_point_is_refused(tmp_path, changes, words):
    out = sweep_folder(tmp_path / "sweep")
    with pytest.raises(ValueError, match=words):
        adopt_run(out, finished_run(tmp_path / "run", **changes))
    assert not list((out / "points").glob("*.json"))


def test_a_run_older_than_a_scene_field_is_read_with_the_fields_old_behaviour(tmp_path):
    """tail_ties and bindoff_prestretch came after the first runs, each added
    with the earlier behaviour as its default: a run without them is that."""
    path = finished_run(tmp_path / "run")
    summary = json.loads(path.read_text())
    del summary["scene"]["tail_ties"], summary["scene"]["bindoff_prestretch"]
    path.write_text(json.dumps(summary))
    assert adopt_run(sweep_folder(tmp_path / "a"), path)["status"] == "done"
    with pytest.raises(ValueError, match="tail_ties: run 1, sweep 2"):
        adopt_run(sweep_folder(tmp_path / "b", options={**OPTIONS, "tail_ties": 2}), path)


def test_off_grid_runs_and_folders_without_a_sweep_are_refused(tmp_path):
    run = finished_run(tmp_path / "run", nw=10, nc=35)
    with pytest.raises(ValueError, match="no phase sweep"):
        adopt_run(tmp_path / "empty", run)
    out = sweep_folder(tmp_path / "sweep")
    with pytest.raises(ValueError, match="10 x 35 is not on the grid"):
        adopt_run(out, run, nw_values=[5], nc_values=[20])


def test_a_done_point_is_not_overwritten_unless_asked(tmp_path):
    out = sweep_folder(tmp_path / "sweep")
    run = finished_run(tmp_path / "run")
    adopt_run(out, run)
    with pytest.raises(ValueError, match="nw=5_nc=20 is done already"):
        adopt_run(out, run)
    assert adopt_run(out, run, replace=True)["status"] == "done"


def test_adopting_into_a_running_sweep_is_refused(tmp_path):
    """The manifest names the sweep's process: while it lives, it would relax
    the point again and overwrite the adopted record."""
    out = sweep_folder(tmp_path / "sweep")
    manifest = json.loads((out / "sweep.json").read_text())
    run = finished_run(tmp_path / "run")
    other = subprocess.Popen(["sleep", "60"])
    try:
        (out / "sweep.json").write_text(json.dumps(dict(manifest, pid=other.pid)))
        with pytest.raises(ValueError, match=f"process {other.pid}.* is running"):
            adopt_run(out, run)
    finally:
        other.kill()
        other.wait()
    assert adopt_run(out, run)["status"] == "done"          # killed: adopted


def test_a_run_is_adopted_only_with_the_sweeps_relaxation_options(tmp_path):
    """A sweep run with relaxation options (--max-rounds, --settle, ...) takes
    runs made with the same ones, and refuses a run made with the defaults,
    or one whose budget changed on a resume (another path)."""
    out = sweep_folder(tmp_path / "sweep", options={**OPTIONS, "max_rounds": 12, "settle": 2})
    same = finished_run(tmp_path / "same", protocol={"max_rounds": 12, "settle": 2})
    assert adopt_run(out, same)["status"] == "done"
    for name, protocol in (("default", None),
                           ("changed", {"max_rounds": 12, "settle": 2, "budget_changes": [
                               {"lam": 0.8, "option": "max_rounds", "from": None, "to": 12}]})):
        with pytest.raises(ValueError, match=r"the sweep's points with \{'max_rounds': 12, "
                                             r"'settle': 2\}"):
            adopt_run(out, finished_run(tmp_path / name, protocol=protocol), replace=True)
    # a sweep at the defaults (max_rounds 4 named or not) takes a default run
    out = sweep_folder(tmp_path / "plain", options={**OPTIONS, "max_rounds": 4})
    assert adopt_run(out, finished_run(tmp_path / "plain_run"))["status"] == "done"


def _relaxed_stand_in(seen=None):
    """A stand-in for curl(): a double-curled answer written where curl()
    writes it; ``seen`` collects the relaxation options it was given."""
    def relaxed(scene, *, out, relax_options=None, **kw):
        if seen is not None:
            seen.append(relax_options)
        summary = {"nw": scene.nw, "nc": scene.nc, "curl": "double", "converged": True,
                   "stable": True, "error": None, "roll_deg": ROLLS}
        (out / f"curl_{scene.nw}x{scene.nc}.json").write_text(json.dumps(summary))
        (out / f"curl_{scene.nw}x{scene.nc}.vtu").write_text("relaxed")
        return summary
    return relaxed


def test_the_sweeps_relaxation_options_reach_every_points_relaxation(tmp_path, monkeypatch):
    """--reanchor, --max-rounds, --snap-rounds and --settle of the phase study
    go to each point's relaxation (they were parsed and dropped before), the
    defaults as none."""
    seen = []
    monkeypatch.setattr(beam_curl, "curl", _relaxed_stand_in(seen))
    phase_sweep([3], [4], tmp_path / "a", model="beam", workers=0, progress=False,
                options={"max_rounds": 12, "settle": 2, "reanchor": 0.2, "snap_rounds": 8})
    phase_sweep([3], [4], tmp_path / "b", model="beam", workers=0, progress=False,
                options={"max_rounds": 4})
    assert seen == [{"reanchor": 0.2, "max_rounds": 12, "settle": 2}, None]


def test_settle_and_budgets_at_their_defaults_do_not_part_a_run_from_the_sweep(tmp_path):
    """A settled run that ran no settle pass is the same run whatever --settle
    was; a budget at its default named or not is the same budget."""
    out = sweep_folder(tmp_path / "sweep", options={**OPTIONS, "settle": 2})
    plain = finished_run(tmp_path / "plain", friction_settled=True, settle_passes=0)
    assert adopt_run(out, plain)["status"] == "done"
    out = sweep_folder(tmp_path / "default", options=OPTIONS)
    named = finished_run(tmp_path / "named", protocol={"max_rounds": 4, "snap_rounds": 8})
    assert adopt_run(out, named)["status"] == "done"
    unsettled = finished_run(tmp_path / "unsettled", friction_settled=False, settle_passes=0)
    out = sweep_folder(tmp_path / "settling", options={**OPTIONS, "settle": 2})
    with pytest.raises(ValueError, match="protocol options"):
        adopt_run(out, unsettled)


def test_a_sweep_resumes_with_its_budgets_named_at_their_defaults(tmp_path, monkeypatch):
    """--max-rounds 4 (the default) given on a resume is the same sweep."""
    monkeypatch.setattr(beam_curl, "curl", _relaxed_stand_in())
    phase_sweep([3], [4], tmp_path, model="beam", workers=0, progress=False)
    rows, sweep = phase_sweep([3], [4], tmp_path, model="beam", workers=0, progress=False,
                              options={"max_rounds": 4, "settle": 0}, resume=True)
    assert sweep.reused == 1


def test_an_adopted_point_survives_the_next_run_in_its_folder(tmp_path):
    """The study adopts inside a run folder, which removes its last run's outputs
    on entry: an adopted record counted among them was lost to the next run (seen
    on the team VM, 2026-12-07); it belongs to the sweep's store."""
    from knitfem.io.run import RunFolder
    out = sweep_folder(tmp_path / "sweep", points=({"nw": 5, "nc": 20}, {"nw": 5, "nc": 25}))
    with RunFolder(out, "studies/fabric_phase.py", {}, outputs=("phase.csv",)):
        adopt_run(out, finished_run(tmp_path / "run20"))
    with RunFolder(out, "studies/fabric_phase.py", {}, outputs=("phase.csv",)):
        adopt_run(out, finished_run(tmp_path / "run25", nc=25))
    with RunFolder(out, "studies/fabric_phase.py", {}, outputs=("phase.csv",)):
        pass
    for key in ("nw=5_nc=20", "nw=5_nc=25"):
        assert (out / "points" / f"{key}.json").is_file()
        assert {p.name for p in (out / "points" / key).iterdir()} == {"curl.json", "curl.vtu"}
