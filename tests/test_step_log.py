"""studies/step_log.py: the per-round step log of a relaxation (issue 9's speed work)."""
import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "studies"))

from step_log import logged, summary  # noqa: E402

from knitfem.solve.minimize import RelaxationError, Relaxed  # noqa: E402


def fake_minimize(problem, x0, **options):
    """Two full steps and a capped, cut one; fails when ``problem`` says so."""
    history = [(3.0, 1.0, 1e-3, 1.0, "exact", 1.0), (2.0, 0.5, 1e-3, 0.5, "psd", 0.25),
               (1.5, 1e-9, 1e-4, 1.0, "exact", 1.0)]
    if problem == "fail":
        raise RelaxationError("stalled", x0, history[:2])
    return Relaxed(x0, 1.5, 1e-9, 3, True, history)


def test_every_round_is_logged_with_its_steps_and_failures(tmp_path):
    rounds, path = [], tmp_path / "log.json"
    run = logged(fake_minimize, rounds, path)
    assert run("ok", 0.0).converged
    with pytest.raises(RelaxationError):
        run("fail", 0.0)
    stored = json.loads(path.read_text())
    assert [r["steps"] for r in stored["rounds"]] == [3, 2]
    assert [r["converged"] for r in stored["rounds"]] == [True, False]
    assert stored["rounds"][1]["history"][1] == [2.0, 0.5, 1e-3, 0.5, "psd", 0.25]
    assert stored["fields"] == ["energy", "residual", "mu", "t", "hessian", "cap"]


def test_summary_counts_capped_full_cut_and_psd_steps(tmp_path):
    rounds = []
    run = logged(fake_minimize, rounds, tmp_path / "log.json")
    run("ok", 0.0)
    with pytest.raises(RelaxationError):
        run("fail", 0.0)
    table = summary(rounds)
    # round 0: one of three steps capped (at 0.25), two full, one cut, one on the PSD model
    assert "| 0 | 3 | yes |" in table and "| 0.33 (0.25) | 0.67 | 0.33 | 0.33 |" in table
    assert "| 1 | 2 | no |" in table
    assert "2 rounds, 5 steps" in table and "1 unconverged rounds: 2 steps" in table
