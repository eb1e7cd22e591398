"""studies/fabric_sensitivity.py --resume: a finished value is kept only if it
was relaxed with the options asked for now (before, any finished summary was
reused, so ``--resume -- --friction 0.5`` mixed old-friction rows into the
new table)."""
import json
import sys
from importlib import util
from pathlib import Path

import pytest

from knitfem.scenes.fabric import FabricScene

ROOT = Path(__file__).resolve().parents[1]


def load():
    spec = util.spec_from_file_location("fabric_sensitivity",
                                        ROOT / "studies" / "fabric_sensitivity.py")
    module = util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def command(folder, *extra):
    return [sys.executable, "-m", "knitfem", "curl", "--nw", "5", "--nc", "5", "--alpha", "0.2",
            "--no-render", "--no-limits", "--quiet", "--out", str(folder), *extra]


def finished(folder, protocol=None, **changes):
    folder.mkdir(parents=True, exist_ok=True)
    summary = {"nw": 5, "nc": 5, "curl": "double", "friction_settled": True,
               "scene": FabricScene(5, 5, alpha=0.2).as_dict(), "protocol": protocol or {}}
    summary.update(changes)
    path = folder / "curl_5x5.json"
    path.write_text(json.dumps(summary))
    return path


def test_a_finished_value_is_reused_only_with_the_same_options(tmp_path):
    module = load()
    path = finished(tmp_path / "alpha=0.2")
    assert module.finished_level(path, command(path.parent))["curl"] == "double"
    # a round budget may differ, as on any resume
    assert module.finished_level(path, command(path.parent, "--max-rounds", "12"))
    with pytest.raises(SystemExit, match="friction: checkpoint 0.3, given 0.5"):
        module.finished_level(path, command(path.parent, "--friction", "0.5"))
    with pytest.raises(SystemExit, match="another relaxation protocol"):
        module.finished_level(path, command(path.parent, "--reanchor", "0.2"))


def test_an_unsettled_value_goes_on_when_settle_passes_are_asked_for(tmp_path):
    module = load()
    path = finished(tmp_path / "alpha=0.2", friction_settled=False, settle_passes=0)
    with pytest.warns(UserWarning, match="has no checkpoint to continue"):
        assert module.finished_level(path, command(path.parent, "--settle", "2")) is not None
    (path.parent / "checkpoint.npz").write_bytes(b"")       # it can go on from there
    assert module.finished_level(path, command(path.parent, "--settle", "2")) is None
    assert module.finished_level(path, command(path.parent)) is not None


def test_failed_values_and_paths_runs_go_back_to_knitfem_curl(tmp_path):
    """A failed value resumes (a raised --max-rounds may get it through); a
    --paths value is checked path by path by knitfem curl --resume itself."""
    module = load()
    path = finished(tmp_path / "alpha=0.2", error="relaxation failed near homotopy lam = 0.8")
    assert module.finished_level(path, command(path.parent, "--max-rounds", "12")) is None
    path = finished(tmp_path / "alpha=0.3", protocol={"dlam": 0.1, "dlam_max": 0.25})
    assert module.finished_level(path, command(path.parent, "--paths", "default")) is None
