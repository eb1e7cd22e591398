"""The CLI's ``popup --model bspline``: the beam path's JSON keys, the pop-up
seen on a coarse grid, the progress bar, and torsion options refused."""
import json

import pytest

from knitfem.cli import main

BEAM_KEYS = {"w_over_L", "elements", "gj_over_ei", "critical_c_over_L", "branch", "elapsed_s"}


def test_cli_bspline_popup_writes_the_beam_keys_and_pops_between_0_74_and_0_80(tmp_path, capsys):
    out, js = tmp_path / "run", tmp_path / "popup.json"
    # 16 segments, c/L 0.95 ... 0.55 every 0.1, then bisection: ~3.5 s
    assert main(["popup", "--model", "bspline", "--elements", "16", "--c-to", "0.55",
                 "--c-step", "0.1", "--out", str(out), "--json", str(js), "--no-render"]) == 0
    summary = json.loads(js.read_text())
    assert set(summary) >= BEAM_KEYS and summary["elements"] == 16
    assert summary["gj_over_ei"] == 0.0                      # no twist energy
    branch = summary["branch"]
    assert [round(b["c_over_L"], 2) for b in branch] == [0.95, 0.85, 0.75, 0.65, 0.55]
    assert all(set(b) == {"c_over_L", "max_abs_z_over_L", "stable"} for b in branch)
    for b in branch:
        if b["c_over_L"] > 0.8:
            assert b["max_abs_z_over_L"] < 1e-3, b          # planar S
        if b["c_over_L"] <= 0.65:
            assert b["max_abs_z_over_L"] > 0.1, b           # popped
    assert 0.74 < summary["critical_c_over_L"] < 0.80
    for name in ("branch.csv", "popup.json", "popup_z.png", "shapes/popup.pvd"):
        assert (out / name).exists(), name
    captured = capsys.readouterr()
    assert "B-spline pop-up" in captured.err and "B-spline pop-up" not in captured.out   # bar
    assert "critical c/L" in captured.out


@pytest.mark.parametrize("option", ["--poisson", "--gj-over-ei"])
def test_cli_bspline_refuses_torsion_options(option, capsys):
    assert main(["popup", "--model", "bspline", option, "0.3", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{option} does not apply to --model bspline" in err
    assert "no torsional stiffness" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_cli_beam_still_takes_the_poisson_ratio(capsys):
    """The beam path takes --poisson (and checks its range)."""
    assert main(["popup", "--poisson", "0.8", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err == "knitfem popup: error: --poisson must be a number in (-1, 0.5], got 0.8\n"


def test_a_run_ended_by_its_time_limit_alone_shows_no_step_eta():
    """With no step budget (only --max-time ends a B-spline run) the steps run
    without end and the bar counts them without a percentage or an ETA; a real
    budget keeps both; a run with neither limit is refused, naming max_steps."""
    import itertools
    from knitfem.bspline.relax import progress_bar, step_numbers
    assert progress_bar(False, 50, "FIRE") is None
    unbounded, bounded = progress_bar(True, None, "FIRE"), progress_bar(True, 50, "FIRE")
    try:
        assert unbounded.total is None and bounded.total == 50
    finally:
        unbounded.close()
        bounded.close()
    assert list(itertools.islice(step_numbers(None, 60.0), 3)) == [1, 2, 3]
    assert list(step_numbers(3, 60.0)) == [1, 2, 3]
    with pytest.raises(ValueError, match="max_steps"):
        step_numbers(None, None)


@pytest.mark.parametrize("argv, says", [
    (["--model", "bspline", "--exact-tries", "2"], "--exact-tries does not apply to --model "
     "bspline"),
    (["--exact-tries", "0"], "--exact-tries must be an integer in [1, 8], got 0"),
])
def test_cli_curl_checks_exact_tries(argv, says, capsys):
    assert main(["curl", "--nw", "3", "--nc", "4", *argv, "--quiet", "--no-render"]) == 2
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("argv, says", [
    (["--model", "bspline", "--straighten", "0.5"], "--straighten must be 0 or 1 with --model "
     "bspline"),
    (["--straighten", "1.5"], "--straighten must be a number in [0, 1], got 1.5"),
])
def test_cli_curl_checks_straighten(argv, says, capsys):
    assert main(["curl", "--nw", "3", "--nc", "4", *argv, "--quiet", "--no-render"]) == 2
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
