"""Settle passes: more friction rounds at lam = 1 for an answer whose lagged
friction did not settle (``relax_fabric(settle=N)``, ``knitfem curl --settle``).

The rounds are scripted (each re-anchors the friction as a real round does,
then moves every node by a given length and ends at a given residual), so
these test the control logic alone."""
import json

import numpy as np
import pytest

from knitfem.scenes import curl as curl_module
from knitfem.scenes import fabric_relax
from knitfem.scenes.fabric import FabricScene, Homotopy, build
from knitfem.scenes.fabric_rounds import settle_pass_due, settle_passes
from test_fabric import stretched

SCENE = FabricScene(3, 3, elements_per_loop=16)


@pytest.fixture(scope="module")
def small():
    model, _, _ = build(SCENE)
    return model


def _rounds(monkeypatch, moves, residuals=None, calls=None):
    """Friction rounds changing the swatch's shape by the next of ``moves`` (radii) and
    ending at the next of ``residuals`` (default 1e-9: converged)."""
    moves = iter(moves)
    residuals = iter(residuals if residuals is not None else [1e-9] * 1000)

    class Result:
        pass

    def scripted(model, state, lam, tol, iterations, progress=None, reanchor=None,
                 exact_tries=None):
        if calls is not None:
            calls.append(lam)
        model.contact_model.anchor_friction(state.x, state.q)     # as _round does
        r = model.rods[0].section.radius
        result = Result()
        result.state = type(state)(stretched(state.x, next(moves) * r), state.q.copy())
        result.iterations, result.energy, result.stopped = 1, 0.0, False
        result.residual = next(residuals)
        result.converged = result.residual <= tol
        return result, np.inf
    monkeypatch.setattr(fabric_relax, "_round", scripted)


def _unsettled_answer(model, monkeypatch):
    """One increment to lam = 1 whose 8 rounds (the budget) each move 0.5 r."""
    _rounds(monkeypatch, [0.5] * 8)
    eq = fabric_relax.relax_fabric(model, Homotopy(model, 0.05), dlam=1.0)
    assert eq.friction_settled is False and eq.increments[-1].iterations == 8
    return eq


def _final(eq):
    return [inc for inc in eq.increments if inc.accepted and inc.lam == 1.0]


def _saver(path, model):
    """A relax_fabric checkpoint writing ``path`` as ``knitfem curl`` does."""
    def checkpoint(state, lam, dlam, increments, partial):
        curl_module._save_checkpoint(path, SCENE, state, lam, dlam, increments,
                                     model.contact_model, partial)
    return checkpoint


def test_a_settle_pass_continues_a_finished_unsettled_answer(small, monkeypatch):
    """Entered at lam = 1 with an unsettled final increment, ``settle`` runs
    its rounds again from the answer until one converged round moves nothing
    (a pass may end after one round: its anchors are the answer's); without
    it a finished run runs no round at all."""
    first = _unsettled_answer(small, monkeypatch)
    calls = []
    _rounds(monkeypatch, [], calls=calls)
    again = fabric_relax.relax_fabric(small, Homotopy(small, 0.05), first.state, lam=1.0,
                                      increments=first.increments)
    assert calls == [] and again.friction_settled is False
    _rounds(monkeypatch, [0.2, 0.0], calls=calls)
    eq = fabric_relax.relax_fabric(small, Homotopy(small, 0.05), first.state, lam=1.0,
                                   increments=first.increments, settle=3)
    assert calls == [1.0, 1.0]
    assert eq.friction_settled is True and eq.last_round_move == 0.0
    assert [inc.iterations for inc in _final(eq)] == [8, 2]
    assert eq.iterations == 10 and settle_passes(eq.increments) == 1
    r = small.rods[0].section.radius
    assert np.allclose(eq.state.x, stretched(first.state.x, 0.2 * r))
    calls.clear()
    _rounds(monkeypatch, [0.0], calls=calls)      # settled in the pass's first round
    eq = fabric_relax.relax_fabric(small, Homotopy(small, 0.05), first.state, lam=1.0,
                                   increments=first.increments, settle=3)
    assert calls == [1.0] and eq.friction_settled is True


def test_settle_passes_stop_at_their_number_also_across_resumes(small, monkeypatch):
    """Passes that never settle stop after ``settle`` of them; a resume with
    the same number runs none (the passes already run count)."""
    first = _unsettled_answer(small, monkeypatch)
    calls = []
    _rounds(monkeypatch, [0.5] * 100, calls=calls)
    eq = fabric_relax.relax_fabric(small, Homotopy(small, 0.05), first.state, lam=1.0,
                                   increments=first.increments, settle=2)
    assert len(calls) == 2 * 8 and len(_final(eq)) == 3 and eq.friction_settled is False
    calls.clear()
    eq = fabric_relax.relax_fabric(small, Homotopy(small, 0.05), eq.state, lam=1.0,
                                   increments=eq.increments, settle=2)
    assert calls == [] and len(_final(eq)) == 3


def test_a_failed_settle_pass_leaves_the_answer_and_is_not_repeated(small, monkeypatch,
                                                                     tmp_path):
    """A pass whose rounds never converge neither raises nor halves anything:
    the answer before it stands, unsettled (its last round's move), with the
    answer's friction anchors (not the failed rounds'), the pass recorded as
    a failed attempt -- also in the checkpoint, which holds no partial
    increment, so a resume with the same ``settle`` runs nothing more."""
    first = _unsettled_answer(small, monkeypatch)
    contact = small.contact_model
    anchors = contact.friction_state()
    path = tmp_path / "checkpoint.npz"
    _rounds(monkeypatch, [3.0] * 100, residuals=[1.0] * 100)
    eq = fabric_relax.relax_fabric(small, Homotopy(small, 0.05), first.state, lam=1.0,
                                   increments=first.increments, settle=1,
                                   checkpoint=_saver(path, small))
    assert np.array_equal(eq.state.x, first.state.x)
    assert eq.friction_settled is False
    assert eq.last_round_move == pytest.approx(0.5 * small.rods[0].section.radius)
    assert [inc.accepted for inc in eq.increments] == [True, False]
    assert eq.increments[-1].iterations > 0
    assert contact.friction_state()[0] is anchors[0]
    state, lam, dlam, done, partial = curl_module.load_checkpoint(path, SCENE, small)
    assert partial is None and lam == 1.0 and np.array_equal(state.x, first.state.x)
    assert [inc.accepted for inc in done] == [True, False]
    calls = []
    _rounds(monkeypatch, [3.0] * 100, residuals=[1.0] * 100, calls=calls)
    again = fabric_relax.relax_fabric(small, Homotopy(small, 0.05), state, lam=lam,
                                      dlam=dlam, increments=done, settle=1)
    assert calls == [] and again.iterations == eq.iterations


@pytest.mark.parametrize("settle", [1, 0])
def test_a_settle_pass_killed_half_way_resumes_from_its_checkpoint(small, monkeypatch,
                                                                    tmp_path, settle):
    """A settle pass checkpoints after each round like any increment: its
    partial (target 1, at lam 1) comes back from the checkpoint and is
    continued on resume -- also when the resume asks for no more passes (the
    pass under way finishes) -- not dropped because lam is already 1."""
    first = _unsettled_answer(small, monkeypatch)
    _rounds(monkeypatch, [0.4, 0.3, 0.0])
    whole = fabric_relax.relax_fabric(small, Homotopy(small, 0.05), first.state, lam=1.0,
                                      increments=first.increments, settle=1)
    assert whole.friction_settled is True and _final(whole)[-1].iterations == 3
    path = tmp_path / "checkpoint.npz"
    saver = _saver(path, small)
    kills = []

    def killed_after_two_rounds(state, lam, dlam, increments, partial):
        saver(state, lam, dlam, increments, partial)
        if partial is not None and partial.rounds == 2:
            kills.append(partial)
            raise KeyboardInterrupt
    _rounds(monkeypatch, [0.4, 0.3, 0.0])
    with pytest.raises(KeyboardInterrupt):
        fabric_relax.relax_fabric(small, Homotopy(small, 0.05), first.state, lam=1.0,
                                  increments=first.increments, settle=1,
                                  checkpoint=killed_after_two_rounds)
    state, lam, dlam, done, partial = curl_module.load_checkpoint(path, SCENE, small)
    assert lam == 1.0 and partial is not None and partial.target == 1.0 and partial.rounds == 2
    calls = []
    _rounds(monkeypatch, [0.0], calls=calls)
    resumed = fabric_relax.relax_fabric(small, Homotopy(small, 0.05), state, lam=lam,
                                        dlam=dlam, increments=done, partial=partial,
                                        settle=settle)
    assert calls == [1.0]
    assert resumed.friction_settled is True and _final(resumed)[-1].iterations == 3
    assert np.allclose(resumed.state.x, whole.state.x)


def test_settle_pass_due_reads_the_last_accepted_final_increment():
    inc = fabric_relax.Increment
    unsettled = inc(1.0, 8, 1e-9, 0.0, 0.0, 1.0, True, 0.5)
    settled = inc(1.0, 2, 1e-9, 0.0, 0.0, 1.0, True, 0.0)
    failed = inc(1.0, 8, np.nan, np.nan, 0.0, 1.0, False)
    assert settle_pass_due([unsettled], 1e-3, 1)
    assert not settle_pass_due([unsettled], 1e-3, 0)
    assert not settle_pass_due([unsettled, settled], 1e-3, 5)
    # a failed pass counts as one; failed attempts before lam 1 was reached do not
    assert not settle_pass_due([unsettled, failed], 1e-3, 1)
    assert settle_pass_due([unsettled, failed], 1e-3, 2)
    assert settle_passes([failed, unsettled]) == 0 and settle_passes([unsettled, failed]) == 1
    assert not settle_pass_due([unsettled, unsettled], 1e-3, 1)
    assert not settle_pass_due([inc(0.5, 8, 1e-9, 0.0, 0.0, 1.0, True, 0.5)], 1e-3, 1)
    # an older checkpoint without the move: unknown, no pass
    assert not settle_pass_due([inc(1.0, 8, 1e-9, 0.0, 0.0, 1.0)], 1e-3, 1)


def test_curl_paths_goes_on_with_a_finished_unsettled_path_only_when_asked(tmp_path,
                                                                            monkeypatch):
    """``--paths ... --resume --settle N``: a finished path whose friction did
    not settle, with fewer than N passes run, is resumed from its checkpoint
    (so only its passes run); one that settled, that has run its N passes,
    or any without --settle, is kept as it is -- and so is one whose
    checkpoint is gone (with a warning: it would be relaxed from nothing)."""
    from knitfem.scenes import curl_paths as paths_module
    ran = []

    def stand_in(scene_, *, out, resume, relax_options, **kwargs):
        ran.append((out.name, resume, relax_options.get("settle")))
        return {"curl": "double", "converged": True, "stable": True, "energy": 1.0,
                "friction_settled": True, "scene": scene_.as_dict(),
                "protocol": relax_options}
    monkeypatch.setattr(curl_module, "curl", stand_in)
    names = ["default", "thirds", "fine"]
    for name, settled, passes in (("default", False, 0), ("thirds", True, 0),
                                  ("fine", False, 2)):
        folder = tmp_path / f"path_{name}"
        folder.mkdir()
        (folder / "checkpoint.npz").write_bytes(b"")
        (folder / "curl_3x3.json").write_text(json.dumps(
            {"curl": "double", "converged": True, "stable": True, "energy": 1.0,
             "friction_settled": settled, "settle_passes": passes, "scene": SCENE.as_dict(),
             "protocol": dict(paths_module.SCHEDULES[name])}))
    paths_module.curl_paths(SCENE, names, out=tmp_path, resume=True)
    assert ran == []
    summary = paths_module.curl_paths(SCENE, names, out=tmp_path, resume=True,
                                      relax_options={"settle": 2})
    assert ran == [("path_default", True, 2)]
    assert [r["settle_passes"] for r in summary["paths"]] == [None, 0, 2]
    ran.clear()
    (tmp_path / "path_default" / "checkpoint.npz").unlink()
    with pytest.warns(UserWarning, match="path_default has no checkpoint"):
        paths_module.curl_paths(SCENE, names, out=tmp_path, resume=True,
                                relax_options={"settle": 2})
    assert ran == []


def test_settle_passes_get_their_own_times_in_the_path_series():
    """path.pvd's time is the homotopy lam; ParaView lists one dataset per
    time, so the k-th settle pass (again at lam 1) is at time 1 + k."""
    assert curl_module.frame_times([0.1, 0.55, 1.0, 1.0, 1.0]) == [0.1, 0.55, 1.0, 2.0, 3.0]
    assert curl_module.frame_times([0.5, 1.0]) == [0.5, 1.0]


@pytest.mark.parametrize("move", [0.0, 0.5])
def test_a_finished_run_resumed_with_new_budgets_records_a_change_only_if_it_ran(
        tmp_path, monkeypatch, move):
    """Resuming a finished, settled run re-reports its answer and runs
    nothing: a --max-rounds or --settle given then changed nothing, so the
    summary's protocol is the run's own, without a budget change at lam 1.
    An unsettled one runs its settle pass, and the change is recorded."""
    scene = FabricScene(3, 4, elements_per_loop=16)      # the curl analysis needs 4 courses
    model, _, _ = build(scene)
    state = model.initial_state()
    final = fabric_relax.Increment(1.0, 5, 1e-9, 0.0, 0.0, 1.0, True,
                                   move * scene.radius)
    curl_module._save_checkpoint(tmp_path / "checkpoint.npz", scene, state, 1.0, 0.5,
                                 [final], model.contact_model)
    calls = []
    _rounds(monkeypatch, [0.0], calls=calls)
    summary = curl_module.curl(scene, out=tmp_path, render=False, progress=False, resume=True,
                               relax_options={"max_rounds": 12, "settle": 2})
    if move == 0.0:
        assert calls == [] and summary["protocol"] == {} and summary["iterations"] == 5
    else:
        assert calls == [1.0] and summary["settle_passes"] == 1
        changes = summary["protocol"]["budget_changes"]
        assert {(c["option"], c["to"]) for c in changes} == {("max_rounds", 12), ("settle", 2)}
