"""Settle passes: more friction rounds at lam = 1 for an answer whose lagged
friction did not settle (``relax_fabric(settle=N)``, ``knitfem curl --settle``).

The rounds are scripted (each moves every node by a given length and ends at
a given residual), so these test the control logic alone."""
import json

import numpy as np
import pytest

from knitfem.scenes import fabric_relax
from knitfem.scenes.fabric import FabricScene, Homotopy, build
from knitfem.scenes.fabric_rounds import settle_pass_due


@pytest.fixture(scope="module")
def small():
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    return model


def _rounds(monkeypatch, moves, residuals=None, calls=None):
    """Friction rounds moving every node by the next of ``moves`` (radii) and
    ending at the next of ``residuals`` (default 1e-9: converged)."""
    moves = iter(moves)
    residuals = iter(residuals if residuals is not None else [1e-9] * 1000)

    class Result:
        pass

    def scripted(model, state, lam, tol, iterations, progress=None, reanchor=None):
        if calls is not None:
            calls.append(lam)
        r = model.rods[0].section.radius
        result = Result()
        result.state = type(state)(state.x + next(moves) * r, state.q.copy())
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


def test_a_settle_pass_continues_a_finished_unsettled_answer(small, monkeypatch):
    """Entered at lam = 1 with an unsettled final increment, ``settle`` runs
    its rounds again from the answer until one converged round moves nothing
    (one round is enough there: the anchors are the answer's); without it a
    finished run runs no round at all."""
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
    assert eq.iterations == 10
    r = small.rods[0].section.radius
    assert np.allclose(eq.state.x, first.state.x + 0.2 * r)


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


def test_a_settle_pass_without_a_converged_round_leaves_the_answer(small, monkeypatch):
    """A pass whose rounds never converge neither raises nor halves anything:
    the answer before it stands, unsettled (its last round's move), with the
    pass's work recorded as a failed attempt."""
    first = _unsettled_answer(small, monkeypatch)
    _rounds(monkeypatch, [3.0] * 100, residuals=[1.0] * 100)
    contact = small.contact_model
    anchors = contact.friction_state()
    eq = fabric_relax.relax_fabric(small, Homotopy(small, 0.05), first.state, lam=1.0,
                                   increments=first.increments, settle=1)
    assert np.array_equal(eq.state.x, first.state.x)
    assert eq.converged and eq.friction_settled is False
    assert eq.last_round_move == pytest.approx(0.5 * small.rods[0].section.radius)
    assert [inc.accepted for inc in eq.increments] == [True, False]
    assert eq.increments[-1].iterations > 0
    # the answer's friction anchors, not those the failed rounds left behind
    assert contact.friction_state()[0] is anchors[0]


def test_a_settle_pass_killed_half_way_resumes_from_its_partial(small, monkeypatch):
    """A settle pass checkpoints after each round like any increment: its
    partial (target 1, at lam 1) is continued on resume, not dropped because
    lam is already 1."""
    first = _unsettled_answer(small, monkeypatch)
    partials = []

    def checkpoint(state, lam, dlam, increments, partial):
        if partial is not None:
            partials.append(partial)
    _rounds(monkeypatch, [0.4, 0.3, 0.0])
    whole = fabric_relax.relax_fabric(small, Homotopy(small, 0.05), first.state, lam=1.0,
                                      increments=first.increments, settle=1,
                                      checkpoint=checkpoint)
    assert whole.friction_settled is True and _final(whole)[-1].iterations == 3
    killed = partials[1]        # after two rounds
    assert killed.target == 1.0 and killed.rounds == 2
    calls = []
    _rounds(monkeypatch, [0.0], calls=calls)
    resumed = fabric_relax.relax_fabric(small, Homotopy(small, 0.05), killed.state, lam=1.0,
                                        increments=first.increments, partial=killed, settle=1)
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
    assert settle_pass_due([unsettled, failed], 1e-3, 1)       # a failed attempt is no pass
    assert not settle_pass_due([unsettled, unsettled], 1e-3, 1)
    assert not settle_pass_due([inc(0.5, 8, 1e-9, 0.0, 0.0, 1.0, True, 0.5)], 1e-3, 1)
    # an older checkpoint without the move: unknown, no pass
    assert not settle_pass_due([inc(1.0, 8, 1e-9, 0.0, 0.0, 1.0)], 1e-3, 1)


def test_curl_paths_goes_on_with_a_finished_unsettled_path_only_when_asked(tmp_path,
                                                                            monkeypatch):
    """``--paths ... --resume --settle N``: a finished path whose friction did
    not settle is run again (resumed, so only its settle passes run); one that
    settled, or any without --settle, is kept as it is."""
    from knitfem.scenes import curl as curl_module
    from knitfem.scenes import curl_paths as paths_module
    scene = FabricScene(3, 3, elements_per_loop=16)
    ran = []

    def stand_in(scene_, *, out, resume, relax_options, **kwargs):
        ran.append((out.name, resume, relax_options.get("settle")))
        return {"curl": "double", "converged": True, "stable": True, "energy": 1.0,
                "friction_settled": True, "scene": scene_.as_dict(),
                "protocol": relax_options}
    monkeypatch.setattr(curl_module, "curl", stand_in)
    for name, settled in (("default", False), ("thirds", True)):
        folder = tmp_path / f"path_{name}"
        folder.mkdir()
        (folder / "curl_3x3.json").write_text(json.dumps(
            {"curl": "double", "converged": True, "stable": True, "energy": 1.0,
             "friction_settled": settled, "scene": scene.as_dict(),
             "protocol": dict(paths_module.SCHEDULES[name])}))
    paths_module.curl_paths(scene, ["default", "thirds"], out=tmp_path, resume=True)
    assert ran == []
    paths_module.curl_paths(scene, ["default", "thirds"], out=tmp_path, resume=True,
                            relax_options={"settle": 2})
    assert ran == [("path_default", True, 2)]
