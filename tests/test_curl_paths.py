"""One swatch along several homotopy schedules (knitfem.scenes.curl_paths)."""
import json

import pytest

from knitfem.scenes import curl_paths
from knitfem.scenes.fabric import FabricScene


def _summary(curl, energy, converged=True, stable=True):
    return {"curl": curl, "energy": energy, "converged": converged, "stable": stable,
            "roll_deg": {"left": 0.0}, "residual": 1e-9, "error": None}


def test_the_lowest_energy_stable_answer_is_the_swatchs_and_every_curl_type_is_reported():
    names = ["default", "coarse", "fine"]
    summaries = [_summary("top_bottom", 283.9), _summary("double", 284.5),
                 _summary("side", 100.0, converged=False)]       # lowest, but not an answer
    combined = curl_paths.combine(summaries, names)
    assert combined["chosen_path"] == "default" and combined["curl"] == "top_bottom"
    assert combined["curl_types"] == ["double", "top_bottom"] and combined["path_dependent"]
    assert [p["schedule"] for p in combined["paths"]] == names
    assert combined["paths"][1]["dlam"] == curl_paths.SCHEDULES["coarse"]["dlam"]
    assert combined["paths"][2]["curl"] == "side"          # kept, not counted
    one = curl_paths.combine([_summary("double", 2.0), _summary("double", 1.0)],
                             ["default", "coarse"])
    assert one["chosen_path"] == "coarse" and not one["path_dependent"]


def test_no_stable_answer_means_no_curl():
    combined = curl_paths.combine([_summary("double", 1.0, stable=False),
                                   _summary(None, None, converged=False)],
                                  ["default", "coarse"])
    assert combined["curl"] is None and combined["chosen_path"] is None
    assert combined["curl_types"] == [] and not combined["path_dependent"]
    assert "no path ended on a converged, stable equilibrium" in combined["error"]


@pytest.mark.parametrize("text", ["defualt", "default,default", "", ","])
def test_bad_schedule_lists_are_refused(text):
    assert curl_paths.parse_paths(text) is None


def test_curl_command_refuses_bad_paths_in_one_line(capsys):
    from knitfem.cli import main
    for argv in (["curl", "--paths", "default,fast"],
                 ["curl", "--model", "bspline", "--paths", "default"]):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "--paths" in err


def test_each_path_relaxes_into_its_folder_and_a_resume_skips_finished_ones(tmp_path,
                                                                          monkeypatch):
    """``knitfem curl --paths``: each schedule's relaxation (here a stand-in
    for :func:`knitfem.scenes.curl.curl`, whose relax_options pass-through
    the fabric tests run for real) gets its increments and its own folder;
    the combined JSON holds every path's answer; a resume reads finished
    paths back instead of relaxing them again."""
    from knitfem.cli import main
    from knitfem.scenes import curl as curl_module
    calls = []

    def fake_curl(scene, *, out, render, progress, resume, relax_options):
        calls.append((out.name, relax_options, resume))
        summary = {**_summary("double" if out.name == "path_coarse" else "top_bottom",
                              {"path_default": 2.0, "path_coarse": 1.0}[out.name]),
                   "nw": scene.nw, "nc": scene.nc, "friction_settled": True,
                   "scene": scene.as_dict(), "protocol": relax_options}
        out.mkdir(parents=True, exist_ok=True)
        (out / f"curl_{scene.nw}x{scene.nc}.json").write_text(json.dumps(summary))
        return summary
    monkeypatch.setattr(curl_module, "curl", fake_curl)
    argv = ["curl", "--nw", "3", "--nc", "4", "--paths", "default,coarse", "--out",
            str(tmp_path), "--no-render", "--quiet"]
    assert main(argv) == 0
    assert calls == [("path_default", curl_paths.SCHEDULES["default"], False),
                     ("path_coarse", curl_paths.SCHEDULES["coarse"], False)]
    combined = json.loads((tmp_path / "curl_3x4.json").read_text())
    assert combined["curl"] == "double" and combined["chosen_path"] == "coarse"
    assert combined["curl_types"] == ["double", "top_bottom"] and combined["path_dependent"]
    # the coarse path's answer lost: a resume reruns it alone
    (tmp_path / "path_coarse" / "curl_3x4.json").unlink()
    assert main(argv + ["--resume"]) == 0
    assert calls[2:] == [("path_coarse", curl_paths.SCHEDULES["coarse"], True)]
    assert json.loads((tmp_path / "curl_3x4.json").read_text())["paths"] == combined["paths"]
    # a finished path of another scene is refused, as a checkpoint is (not mixed in)
    done = tmp_path / "path_default" / "curl_3x4.json"
    other = json.loads(done.read_text())
    done.write_text(json.dumps({**other, "scene": {**other["scene"], "alpha": 0.1}}))
    with pytest.raises(ValueError, match="path_default.*other parameters"):
        curl_paths.curl_paths(FabricScene(3, 4), ["default", "coarse"], out=tmp_path,
                              render=False, progress=False, resume=True)
    done.write_text(json.dumps({**other, "protocol": curl_paths.SCHEDULES["coarse"]}))
    with pytest.raises(ValueError, match="protocol"):
        curl_paths.curl_paths(FabricScene(3, 4), ["default"], out=tmp_path,
                              render=False, progress=False, resume=True)


def test_thirds_schedule_is_the_measured_protocol_variant(monkeypatch):
    # the README times `--paths thirds` with relax_protocol's variant: one schedule, not two copies
    from pathlib import Path
    import numba
    # the study pins its threads on import (setdefault): here they stay as they
    # are, or numba refuses the next compile in this process (launched with 2, asked 1)
    monkeypatch.setenv("NUMBA_NUM_THREADS", str(numba.config.NUMBA_NUM_THREADS))
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "studies"))
    import relax_protocol
    assert curl_paths.parse_paths("thirds") == ["thirds"]
    assert curl_paths.SCHEDULES["thirds"] == relax_protocol.VARIANTS["thirds"]


def test_a_failed_path_goes_on_from_its_checkpoint_on_resume(tmp_path, monkeypatch):
    """A path whose relaxation failed leaves a summary (its error, its last
    equilibrium's shape): a resume -- typically with a larger --max-rounds --
    continues it from its checkpoint instead of taking the failure as its
    answer; a path that ended on an answer is kept."""
    from knitfem.scenes import curl as curl_module
    calls = []

    def fake_curl(scene, *, out, render, progress, resume, relax_options):
        calls.append((out.name, resume, relax_options.get("max_rounds")))
        return {**_summary("double", 1.0), "scene": scene.as_dict(),
                "protocol": relax_options}
    monkeypatch.setattr(curl_module, "curl", fake_curl)
    scene = FabricScene(3, 4)
    for name, error in (("default", "relaxation failed near homotopy lam = 0.8"),
                        ("coarse", None)):
        folder = tmp_path / f"path_{name}"
        folder.mkdir()
        (folder / "curl_3x4.json").write_text(json.dumps(
            {**_summary(None if error else "double", 1.0), "error": error,
             "converged": error is None, "scene": scene.as_dict(),
             "protocol": curl_paths.SCHEDULES[name]}))
    summary = curl_paths.curl_paths(scene, ["default", "coarse"], out=tmp_path, render=False,
                                    progress=False, resume=True,
                                    relax_options={"max_rounds": 12})
    assert calls == [("path_default", True, 12)]
    assert [r["curl"] for r in summary["paths"]] == ["double", "double"]


def test_friction_options_without_friction_are_noted_not_hidden(tmp_path, monkeypatch, capsys):
    """--reanchor and --friction-frame do nothing at --friction 0: the run goes
    on (a frictionless run made with them resumes with them) and says so."""
    from knitfem.cli import main
    from knitfem.scenes import curl as curl_module

    def fake_curl(scene, *, out, render, progress, resume, relax_options):
        assert scene.friction == 0.0 and relax_options == {"reanchor": 0.2}
        return {**_summary("double", 1.0), "nw": 3, "nc": 4, "friction_settled": True}
    monkeypatch.setattr(curl_module, "curl", fake_curl)
    argv = ["curl", "--nw", "3", "--nc", "4", "--friction", "0", "--reanchor", "0.2",
            "--friction-frame", "anchor", "--out", str(tmp_path), "--no-render", "--quiet"]
    assert main(argv) == 0
    assert "note: --friction-frame and --reanchor did nothing" in capsys.readouterr().err
