"""The fabric scene and its relaxation (knitfem.scenes.fabric, fabric_relax, curl)."""
import json

import numpy as np
import pytest

from knitfem.beam.energy import EnergyProblem
from knitfem.scenes.fabric import FabricScene, Homotopy, build, yarn_axial_strain
from knitfem.scenes import fabric_relax, fabric_rounds

# The scenes here take 16 elements per loop, not the default 32: the tests check
# the mechanics and the protocol, not the resolution (16 per loop locks the
# yarn's sliding at alpha 0.2, README), and 16 keeps them fast -- all but the
# locking test below, which is about the default resolution.


def test_knitted_shape_is_an_equilibrium_at_the_start_of_the_homotopy():
    """At lam = 0 the natural strains are the knitted shape's and the yarns
    start clear of the contact skin: the residual is round-off (below the
    relaxation's tolerance 1e-8 of the force scale; measured 5e-10) and no
    contact carries load; the first homotopy step is far from equilibrium."""
    scene = FabricScene(3, 3, elements_per_loop=16)
    model, swatch, info = build(scene)
    assert info["start_gap_over_d"] >= scene.regularisation
    Homotopy(model, scene.alpha).apply(0.0)
    problem = EnergyProblem(model, 1.0)
    state = model.initial_state()
    assert problem.residual(problem.evaluate(state, False)[1]) < 1e-8
    assert model.contact_report(state).active_pairs == 0
    Homotopy(model, scene.alpha).apply(0.05)
    assert problem.residual(problem.evaluate(state, False)[1]) > 1e-3


def test_yarn_axial_strain_is_the_knitted_length_over_the_shrunk_rest_length():
    """At the knitted shape the strain is 0 at lam = 0 and 1/(1 - alpha) - 1
    once the rest length has shrunk (lam >= the stretch stage's end)."""
    scene = FabricScene(3, 3, elements_per_loop=16, alpha=0.2)
    model, _, _ = build(scene)
    state, homotopy = model.initial_state(), Homotopy(model, scene.alpha)
    homotopy.apply(0.0)
    assert max(map(abs, yarn_axial_strain(model, state))) < 1e-12
    for lam in (0.3, 0.6, 1.0):
        homotopy.apply(lam)
        median, largest = yarn_axial_strain(model, state)
        assert abs(median - 0.25) < 1e-12 and abs(largest - 0.25) < 1e-12


def test_bindoff_prestretch_shrinks_the_helices_rest_length_and_keeps_their_turns():
    """With ``bindoff_prestretch`` the bind-off helices' axial strain at the
    knitted shape is 1/(1 - alpha) - 1 once the stretch stage is over (0
    without: they keep their knitted length), their natural curvature per
    knitted length is the knitted helix's at every lam, and the knit yarn's
    homotopy is the same either way."""
    natural = {}
    for bindoff in (False, True):
        scene = FabricScene(3, 3, elements_per_loop=16, alpha=0.2, bindoff_prestretch=bindoff)
        model, _, _ = build(scene)
        asm, state = model.assembly, model.initial_state()
        helix = asm.rod_of_element != 0
        kappa_knitted = asm.kappa0[helix].copy()
        homotopy = Homotopy.of_scene(model, scene)        # what knitfem curl relaxes along
        for lam in (0.0, 0.15, 0.3, 1.0):
            homotopy.apply(lam)
            gamma = asm.strains(state.x, state.q)[0]
            strain = gamma[helix, 0] / asm.gamma0[helix, 0] - 1.0
            shrink = min(1.0, lam / homotopy.split) * scene.alpha if bindoff else 0.0
            assert np.allclose(strain, 1.0 / (1.0 - shrink) - 1.0, rtol=0, atol=1e-12)
            assert np.array_equal(asm.kappa0[helix], kappa_knitted)
        natural[bindoff] = (asm.gamma0[~helix].copy(), asm.kappa0[~helix].copy())
    assert all(np.array_equal(a, b) for a, b in zip(natural[False], natural[True]))


class _StretchStage:
    """The homotopy's first stage only (the rest length shrinks, the loops keep
    their knitted shape): lam = 1 here is the stage's end."""

    def __init__(self, homotopy):
        self.homotopy = homotopy

    def apply(self, lam):
        self.homotopy.apply(self.homotopy.split * lam)


@pytest.mark.slow
def test_the_default_discretisation_lets_the_yarn_slide_through_its_crossings():
    """At alpha 0.2 the shrinking rest length must drain into the loops (the
    yarn slides through its crossings), not stay in the yarn as strain.  16
    elements per loop lock that sliding: the same 3 x 3 stretch stage ends
    with a median axial strain of 2.3 % and energy 79; 24 per loop 2.7e-5 and
    0.19, 32 (the default) 2.2e-5 and 0.20 (measured 2026-12-03; 5 x 5: 2.4 % /
    218 at 16 against 4.3e-5 / 0.66 at 24).  The
    bound, 0.2 % median, is a tenth of the locked strain and 8 % of the
    1/(1 - alpha) - 1 = 25 % the yarn would hold if nothing slid."""
    scene = FabricScene(3, 3, alpha=0.2)
    model, _, _ = build(scene)
    eq = fabric_relax.relax_fabric(model, _StretchStage(Homotopy(model, scene.alpha)),
                                   tol=1e-3, max_rounds=2)
    assert eq.converged
    median, _ = yarn_axial_strain(model, eq.state)
    assert median < 2e-3, (f"{scene.elements_per_loop} elements per loop keep {median:.2%} "
                           "of the pre-stretch in the yarn: the discretisation locks its sliding")


def _first_steps(scene, iterations=15):
    model, swatch, info = build(scene)
    homotopy = Homotopy(model, scene.alpha)
    homotopy.apply(0.05)
    result, _ = fabric_relax._round(model, model.initial_state(), 0.05, 1e-8, iterations)
    return model, result


def test_scaling_all_stiffnesses_together_leaves_the_shape_unchanged():
    """EI, GJ, EA, the penalty and the ties all scale with the scene's EI, and
    the minimiser is scale-free (Marquardt scaling, relative residual, step
    limit in lengths): the first 15 steps of the relaxation with EI x 7.3 go
    through the same positions (1e-8 mm) and residuals (1e-8 relative)."""
    _, a = _first_steps(FabricScene(3, 3, elements_per_loop=16))
    _, b = _first_steps(FabricScene(3, 3, elements_per_loop=16, EI=7.3))
    assert a.iterations == b.iterations == 15
    assert np.abs(a.state.x - b.state.x).max() < 1e-8
    assert abs(a.residual - b.residual) <= 1e-8 * a.residual


@pytest.fixture(scope="module")
def relaxed_3x4(tmp_path_factory):
    """The smallest swatch the classification takes, relaxed by ``knitfem
    curl``'s own path and increments (alpha = 0.05), with every checkpoint
    kept: after each friction round of an increment under way and after
    each increment.  (Increments of 0.5, used before the shifted Hessian,
    ended this swatch's final rounds unsettled, 5.5 r; its answer depends on
    the path, see README.)"""
    from knitfem.scenes import curl as curl_module
    out = tmp_path_factory.mktemp("curl")
    kept, save = [], curl_module._save_checkpoint

    def keep(path, *args, **kwargs):
        save(path, *args, **kwargs)
        kept.append(path.read_bytes())
    curl_module._save_checkpoint = keep
    try:
        summary = curl_module.curl(SCENE, out=out, render=False, progress=False,
                                   relax_options=RELAX)
    finally:
        curl_module._save_checkpoint = save
    return summary, kept, out


SCENE = FabricScene(3, 4, elements_per_loop=16, alpha=0.05)
RELAX = {}                        # the default increments


def test_small_swatch_relaxes_to_a_converged_stable_equilibrium(relaxed_3x4):
    """Converged (relative residual <= 1e-8 of the fixed force scale), stable
    (no negative eigenvalue of the tangent, LDL^T inertia), every contact
    gap along the path above -5 % of d (no yarn tunnels through another: one
    would show a gap near -d on its way), a curl classified, the lagged
    friction's verdict consistent with its last round's move (not its size:
    the frictional path is chaotic in round-off — 6.9e-4 r with the
    libraries' default threads and 9.4e-4 r on one thread before 2026-12-03,
    2.0e-3 r with d5d78df and 0.34 r after that day's friction speed-ups
    reordered some sums, both on one thread, the rolls 25-85 degrees apart:
    another equilibrium) and
    the held node's reaction ~0: <= 1e-4 of the force scale (measured 3.3e-6
    and 1.9e-6; 1.6 % while
    friction acted at the yarns' surface points, a couple per pair inside
    the penalty skin)."""
    summary, _, out = relaxed_3x4
    assert summary["error"] is None and summary["converged"] and summary["residual"] <= 1e-8
    assert summary["stable"] and summary["negative_eigenvalues"] == 0
    # the scaled tangent's lowest eigenvalue agrees with the inertia
    assert summary["lowest_eigenvalue"] > 0
    assert summary["max_penetration_over_d"] <= 0.05
    assert 0.0 <= summary["penetration_over_d"] <= summary["max_penetration_over_d"]
    assert summary["curl"] in ("flat", "side", "double", "top_bottom")
    move = summary["last_round_move_over_r"]
    assert np.isfinite(move) and summary["friction_settled"] is (move <= 1e-3)
    assert summary["reaction_over_force_scale"] <= 1e-4
    assert 0.0 <= summary["contact_overlap_share"] < 1.0
    assert np.isfinite(list(summary["yarn_axial_strain"].values())).all()
    assert json.loads((out / "curl_3x4.json").read_text())["residual"] == summary["residual"]
    # the roll profile's keys come with the answer (values: test_roll_profile)
    assert set(summary["local_roll_deg"]) == set(summary["roll_deg"])
    assert np.isfinite([*summary["local_roll_deg"].values(), summary["interior_curvature_x"],
                        summary["interior_curvature_y"]]).all()


def _is_partial(blob):
    import io
    return "partial_x" in np.load(io.BytesIO(blob)).files


@pytest.mark.parametrize("when", ["after an increment", "within an increment"])
def test_a_killed_and_resumed_run_ends_where_an_uninterrupted_one_does(relaxed_3x4, tmp_path,
                                                                       when):
    """Resume from a checkpoint as a kill would leave it: the one written
    after the last increment but one (the last increment is resumed with
    its friction anchors and step), or the last one written within the last
    increment (after its last friction round but one: the round's state and
    anchors, the equilibrium's anchors to retry from): the same equilibrium
    (1e-6 of a radius), curl and iteration count."""
    from knitfem.scenes.curl import curl
    summary, kept, out = relaxed_3x4
    whole = [blob for blob in kept if not _is_partial(blob)]
    within = [blob for blob in kept if _is_partial(blob)]
    assert len(whole) == summary["increments"] >= 2 and len(within) >= 2
    blob = whole[-2] if when == "after an increment" else within[-1]
    (tmp_path / "checkpoint.npz").write_bytes(blob)
    # the path the killed run had written
    import io
    import shutil
    done = int(sum(r[6] for r in np.load(io.BytesIO(blob))["increments"]))
    (tmp_path / "path").mkdir()
    for k in range(1, done + 1):
        shutil.copy(out / "path" / f"step_{k:03d}.vtu", tmp_path / "path")
    resumed = curl(SCENE, out=tmp_path, render=False, progress=False, resume=True,
                   relax_options=RELAX)
    assert resumed["converged"] and resumed["increments"] == summary["increments"]
    assert resumed["iterations"] == summary["iterations"]
    # path.pvd lists the whole path, the steps before the kill included
    assert (tmp_path / "path" / "path.pvd").read_text() == (out / "path" / "path.pvd").read_text()
    a = _points(out / "curl_3x4.vtu")
    b = _points(tmp_path / "curl_3x4.vtu")
    assert np.abs(a - b).max() <= 1e-6 * SCENE.radius
    assert resumed["curl"] == summary["curl"]


def _points(path):
    import meshio
    return meshio.read(path).points


def test_a_failed_relaxation_says_so_and_keeps_its_last_equilibrium(tmp_path):
    """A relaxation that runs out of budget (one minimisation step per round)
    is reported as such: ``converged`` False, the error naming where it
    failed, no curl claimed (the half-relaxed shape kept apart, labelled with
    its homotopy lam), and the state written (.vtu, JSON) for inspection."""
    from knitfem.scenes.curl import curl
    summary = curl(FabricScene(3, 4, elements_per_loop=16), out=tmp_path, render=False,
                   progress=False,
                   relax_options=dict(iterations=1, max_rounds=1, dlam_min=0.05))
    assert summary["converged"] is False and summary["curl"] is None
    assert "relaxation failed near homotopy lam" in summary["error"]
    assert summary["last_equilibrium"]["lam"] == 0.0
    assert summary["last_equilibrium"]["curl"] in ("flat", "side", "double", "top_bottom")
    assert summary["friction_settled"] is None and summary["last_round_move_over_r"] is None
    written = json.loads((tmp_path / "curl_3x4.json").read_text())
    assert written["error"] == summary["error"] and (tmp_path / "curl_3x4.vtu").exists()


def test_curl_command_refuses_bad_options_in_one_line(capsys):
    from knitfem.cli import main
    for argv, flag in ((["curl", "--nw", "0"], "--nw"), (["curl", "--alpha", "0.9"], "--alpha"),
                       (["curl", "--radius", "0.6"], "--radius"),
                       (["curl", "--friction", "nan"], "--friction"),
                       (["curl", "--nw", "3", "--nc", "4", "--resume"], "--resume"),
                       (["curl", "--model", "bspline", "--friction-frame", "anchor"],
                        "--friction-frame"),
                       (["curl", "--inflation", "-0.1"], "--inflation"),
                       (["curl", "--radius", "0.45", "--inflation", "0.2"], "--inflation"),
                       (["curl", "--model", "bspline", "--inflation", "0.1"], "--inflation"),
                       (["curl", "--model", "bspline", "--bindoff-prestretch"],
                        "--bindoff-prestretch"),
                       (["curl", "--tail-ties", "0"], "--tail-ties"),
                       (["curl", "--model", "bspline", "--tail-ties", "2"], "--tail-ties"),
                       (["curl", "--reanchor", "0"], "--reanchor"),
                       (["curl", "--model", "bspline", "--reanchor", "0.2"], "--reanchor"),
                       (["curl", "--nw", "55", "--nc", "35"], "--no-limits")):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and flag in err


def test_the_bspline_run_time_is_its_time_limit_not_the_beams():
    """The B-spline relaxation stops at --max-time: its estimate is that plus
    the building and writing, and a refusal names --max-time (the beam's
    estimate of a 25 x 35 is hours, and once refused a 5-minute B-spline run)."""
    import argparse
    from knitfem.scenes.curl_command import OPTIONS, seconds
    from knitfem.options import OptionError

    def values(*flags, **given):
        parser = argparse.ArgumentParser()
        parser.add_argument("--model", default="beam")
        OPTIONS.add_to(parser)
        argv = [f"--{k.replace('_', '-')}={v}" for k, v in given.items()] + list(flags)
        return OPTIONS.validate(parser.parse_args(argv))
    short = values(model="bspline", nw=25, nc=35, max_time=300)
    assert seconds(short) == pytest.approx(300 + 0.1 * 25 * 35)
    assert seconds(values("--no-limits", nw=25, nc=35)) > 3600        # the beam's: hours
    with pytest.raises(OptionError, match="--max-time 3600.*estimated run time"):
        values(model="bspline", nw=25, nc=35, max_time=3600)


def test_a_fixed_inflation_knits_that_geometry_and_a_too_small_one_is_refused():
    """The radius inflation the swatch is knitted with grows as the elements
    per loop fall; a refinement study holds it fixed (``inflation``): the
    automatic choice given back knits the same swatch, a finer
    discretisation takes it and stays clear of the skin, and one that leaves
    chords inside the skin is refused naming the automatic choice."""
    model, _, info = build(FabricScene(3, 4, elements_per_loop=16))
    auto = info["inflation"]
    assert auto > 0.0
    same, _, fixed = build(FabricScene(3, 4, elements_per_loop=16, inflation=auto))
    assert fixed["inflation"] == auto
    assert np.array_equal(same.assembly.initial_positions(), model.assembly.initial_positions())
    scene = FabricScene(3, 4, elements_per_loop=24, inflation=auto)
    finer = build(scene)[2]
    assert finer["inflation"] == auto
    assert finer["start_gap_over_d"] >= 1.02 * scene.regularisation
    with pytest.raises(ValueError, match=rf"inflation 0 leaves .*valid: inflation >= {auto:g}"):
        build(FabricScene(3, 4, elements_per_loop=16, inflation=0.0))


def test_curl_command_runs_the_bspline_model_and_says_it_did_not_converge(tmp_path, capsys):
    """``knitfem curl --model bspline`` (it was an ImportError): a 2 s time
    limit ends the relaxation unconverged, which the exit code (3), the JSON
    and (under --quiet) one line on stderr say; beam-only options are refused."""
    from knitfem.cli import main
    out = tmp_path / "b.json"
    assert main(["curl", "--model", "bspline", "--nw", "3", "--nc", "4", "--max-time", "2",
                 "--rest-tol", "0.5", "--quiet", "--no-render", "--json", str(out),
                 "--out", str(tmp_path / "run")]) == 3
    # the run's manifest lists the options that describe it, not the beam's
    parameters = json.loads((tmp_path / "run" / "run.json").read_text())["parameters"]
    assert parameters["max_time"] == 2.0 and parameters["model"] == "bspline"
    assert not {"friction", "elements_per_loop", "gj_over_ei"} & set(parameters)
    summary = json.loads(out.read_text())
    assert summary["model"] == "bspline" and summary["converged"] is False
    assert "time limit" in summary["message"]
    assert summary["rest_tol"] == parameters["rest_tol"] == 0.5
    assert summary["equilibrium_distance_over_r"] is None or \
        summary["equilibrium_distance_over_r"] > 0
    # --quiet hides the progress, not the failure: one line on stderr
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("knitfem curl: ") and "converged False" in err[-1]
    assert main(["curl", "--model", "bspline", "--nw", "3", "--nc", "4", "--friction", "0.1"]) == 2
    # the rest check is the B-spline's: refused for the beam, and out of range by name
    assert main(["curl", "--nw", "3", "--nc", "4", "--rest-tol", "0.2"]) == 2
    assert main(["curl", "--model", "bspline", "--nw", "3", "--nc", "4", "--rest-tol", "0"]) == 2
    err = capsys.readouterr().err
    assert "--rest-tol does not apply to --model beam" in err and "--rest-tol must be" in err


def test_a_failed_increment_retries_from_the_last_equilibriums_friction_anchors(monkeypatch):
    """The slips carried from round to round belong to the equilibrium they
    were found at: an increment whose rounds re-anchored the friction and then
    failed leaves the anchors (and their frames) of the last accepted
    equilibrium in place, for the retry and for the failure's report."""
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    contact = model.contact_model
    state = model.initial_state()
    contact.anchor_friction(state.x, state.q)
    before = contact.friction_state()

    def failing(model, state, lam, *args, **kwargs):
        moved = state.x + 0.1 * model.rods[0].section.radius
        contact.anchor_friction(moved, state.q)      # what a failed round leaves
        assert contact.friction_state()[0] is not before[0]
        return None, "failed on purpose"
    monkeypatch.setattr(fabric_relax, "_increment", failing)
    with pytest.raises(fabric_relax.FabricRelaxationError, match="failed on purpose"):
        fabric_relax.relax_fabric(model, Homotopy(model, 0.05), state, dlam=0.1, dlam_min=0.06)
    after = contact.friction_state()
    assert after[0] is before[0] and after[1] is before[1]


def test_increments_of_a_tenth_end_on_exactly_one_final_increment(monkeypatch):
    """Ten increments of 0.1 sum to 0.9999999999999999 in floating point: the
    homotopy must still end on one increment at exactly lam = 1, solved to
    ``tol`` (not a round-off increment to path_tol and then another)."""
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    targets = []

    def recording(model, state, lam, tol, *args, **kwargs):
        targets.append((lam, tol))

        class Result:
            pass
        result = Result()
        result.state = state
        return result, fabric_relax.Increment(lam, 1, 0.0, 0.0, np.inf, 0.0)
    monkeypatch.setattr(fabric_relax, "_increment", recording)
    fabric_relax.relax_fabric(model, Homotopy(model, 0.05), dlam=0.1, dlam_max=0.1,
                              tol=1e-8, path_tol=1e-3)
    assert len(targets) == 10
    assert targets[-1] == (1.0, 1e-8)
    assert all(t == 1e-3 for _, t in targets[:-1])


def test_a_failed_attempts_work_is_counted_but_not_its_path(monkeypatch):
    """An increment that failed and was retried smaller cost iterations and
    time: the total counts them (a run's cost is what it ran), the path and
    its penetration are those of the accepted increments."""
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    calls = []

    def first_fails(model, state, lam, *args, **kwargs):
        calls.append(lam)

        class Result:
            pass
        result = Result()
        result.state = state
        if len(calls) == 1:
            return None, "too far", fabric_relax.Increment(lam, 7, np.nan, np.nan, -1.0, 0.0,
                                                           False)
        return result, fabric_relax.Increment(lam, 3, 0.0, 0.0, np.inf, 0.0)
    monkeypatch.setattr(fabric_relax, "_increment", first_fails)
    eq = fabric_relax.relax_fabric(model, Homotopy(model, 0.05), dlam=1.0, dlam_max=0.5)
    assert calls == [1.0, 0.5, 1.0]
    assert eq.iterations == 7 + 3 + 3
    assert [inc.accepted for inc in eq.increments] == [False, True, True]
    assert eq.max_penetration == 0.0


def stretched(x, move):
    """Positions x stretched about their centroid so that the farthest node
    coordinate moves by ``move``: a change of shape of exactly ``move``
    (a translation would be none for the free swatch: round_move)."""
    centred = x - x.mean(axis=0)
    return x + move / np.abs(centred).max() * centred


def _scripted_rounds(monkeypatch, residuals, tol=1e-8, moves=None):
    """Replace a friction round by one that ends at the next of ``residuals``
    (converged when below ``tol``), moving the farthest node coordinate by the
    next of ``moves`` (default: not at all) in a stretch about the centroid, a
    change of shape (the free swatch's rigid motions do not count:
    :func:`~knitfem.scenes.fabric_rounds.round_move`): the increment's control
    logic alone."""
    ends = iter(residuals)
    shifts = iter(moves if moves is not None else [0.0] * len(residuals))

    class Result:
        pass

    def scripted(model, state, lam, tol_, iterations, progress=None, reanchor=None,
                 exact_tries=None):
        result = Result()
        result.state = type(state)(stretched(state.x, next(shifts)), state.q.copy())
        result.iterations, result.energy, result.stopped = 1, 0.0, False
        result.residual = next(ends)
        result.converged = result.residual <= tol
        return result, np.inf
    monkeypatch.setattr(fabric_relax, "_round", scripted)


def _rounds_ending_early(monkeypatch, outcomes, calls):
    """Friction rounds that end as ``outcomes`` say: "stop" (ended early for
    new contacts, 10 steps: only when the increment allows it, otherwise a
    whole unconverged round of 1 step) or a final residual (1 step);
    ``calls`` records each round's ``reanchor``."""
    outcomes = iter(outcomes)

    class Result:
        pass

    def scripted(model, state, lam, tol_, iterations, progress=None, reanchor=None,
                 exact_tries=None):
        calls.append(reanchor)
        outcome = next(outcomes)
        result = Result()
        result.state, result.energy = state, 0.0
        result.stopped = outcome == "stop" and reanchor is not None
        result.iterations = 10 if result.stopped else 1
        result.residual = 1.0 if outcome == "stop" else outcome
        result.converged = result.residual <= tol_
        return result, np.inf
    monkeypatch.setattr(fabric_relax, "_round", scripted)


def test_rounds_ended_for_new_contacts_do_not_count_as_rounds(monkeypatch):
    """A round ended early to anchor the contacts that formed in it is not
    one of the increment's ``max_rounds`` (its steps count in the total, it
    is checkpointed as the round count so far); once such rounds have spent
    ``max_rounds x iterations`` steps, the rest run whole, so an increment
    whose contacts keep forming still ends (here failing on its budget)."""
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    state = model.initial_state()
    calls, saved = [], []
    _rounds_ending_early(monkeypatch, ["stop", "stop", 1e-4], calls)
    result, inc = fabric_relax._increment(model, state, 0.5, 1e-3, 30, 1, np.inf,
                                          on_round=saved.append, reanchor=0.2)
    assert result is not None and result.converged and inc.iterations == 10 + 10 + 1
    assert calls == [0.2, 0.2, 0.2]
    assert [p.rounds for p in saved] == [0, 0] and [p.iterations for p in saved] == [10, 20]
    calls.clear()
    _rounds_ending_early(monkeypatch, ["stop"] * 10, calls)
    result, reason, inc = fabric_relax._increment(model, state, 0.5, 1e-3, 5, 2, np.inf,
                                                  reanchor=0.2)
    assert result is None and "in 2 rounds" in reason
    assert calls == [0.2, None, None] and inc.iterations == 10 + 1 + 1
    calls.clear()
    _rounds_ending_early(monkeypatch, ["stop", 1e-4], calls)   # not asked: rounds run whole
    result, reason, inc = fabric_relax._increment(model, state, 0.5, 1e-3, 5, 1, np.inf)
    assert result is None and calls == [None] and "in 1 rounds" in reason


def test_a_resume_may_raise_the_round_budget_and_records_it(monkeypatch, tmp_path):
    """A snap needs more rounds than the default budget, and halving its
    increment never ends: a resume may change ``max_rounds`` (only it), the
    change is recorded with the lam it was made at and kept by later resumes,
    and the partial increment goes on past its old budget."""
    from knitfem.scenes import curl as curl_module
    scene = FabricScene(3, 3, elements_per_loop=16)
    model, _, _ = build(scene)
    state = model.initial_state()
    partial = fabric_relax.Partial(0.8, state, 4, 800, np.inf, 0.0, ends=(1e-2,) * 4,
                                   moves=(4.0,) * 4)
    path = tmp_path / "checkpoint.npz"
    curl_module._save_checkpoint(path, scene, state, 0.78, 0.02, [], None, partial)
    given = {"max_rounds": 12}
    loaded = curl_module.load_checkpoint(path, scene, model, given)
    kept = curl_module.checkpoint_protocol(np.load(path))
    record = curl_module.resumed_protocol(kept, given, loaded[1])
    assert record == {"max_rounds": 12, "budget_changes": [
        {"lam": 0.78, "option": "max_rounds", "from": None, "to": 12}]}
    # the next checkpoint holds the record; a resume with the same budget adds nothing
    curl_module._save_checkpoint(path, scene, state, 0.79, 0.02, [], None, protocol=record)
    curl_module.load_checkpoint(path, scene, model, given)
    again = curl_module.resumed_protocol(curl_module.checkpoint_protocol(np.load(path)),
                                         given, 0.79)
    assert again == record
    # a path option still refuses, with or without the budget
    for other in ({"reanchor": 0.2}, {"max_rounds": 12, "reanchor": 0.2}):
        with pytest.raises(ValueError, match="another relaxation protocol"):
            curl_module.load_checkpoint(path, scene, model, other)
    # the partial's fifth round runs under the raised budget (it would have failed at 4)
    calls = []
    _rounds_ending_early(monkeypatch, [1e-2, 1e-4], calls)
    result, inc = fabric_relax._increment(model, state, 0.8, 1e-3, 5, 12, np.inf, start=partial)
    assert result is not None and len(calls) == 2 and inc.iterations == 802
    calls.clear()
    _rounds_ending_early(monkeypatch, [1e-4], calls)
    failed = fabric_relax._increment(model, state, 0.8, 1e-3, 5, 4, np.inf, start=partial)
    assert failed[0] is None and calls == []
    # and the failure says the rounds were carrying the swatch far, not hovering
    assert "each of its 4 rounds moved the swatch 4-4 (more than a yarn radius;" in failed[1]
    assert "--max-rounds" in failed[1] and "--snap-rounds" in failed[1]


def test_a_resume_keeps_the_early_rounds_budget_and_refuses_another_protocol(monkeypatch,
                                                                            tmp_path):
    """The steps already spent in rounds ended early survive a checkpoint, so a
    resumed increment does not get a fresh budget of them; a checkpoint made
    under one relaxation protocol refuses to resume under another (the
    protocol decides the path, and at 8 x 8 the curl type)."""
    from knitfem.scenes import curl as curl_module
    scene = FabricScene(3, 3, elements_per_loop=16)
    model, _, _ = build(scene)
    state = model.initial_state()
    partial = fabric_relax.Partial(0.5, state, 1, 30, np.inf, 0.0, ends=(1e-2,), moves=(0.1,),
                                   early=20)
    path = tmp_path / "checkpoint.npz"
    curl_module._save_checkpoint(path, scene, state, 0.4, 0.1, [], None, partial,
                                 protocol={"reanchor": 0.2})
    assert curl_module.load_checkpoint(path, scene, model, {"reanchor": 0.2})[4].early == 20
    for other in (None, {"reanchor": 0.1}):
        with pytest.raises(ValueError, match="another relaxation protocol"):
            curl_module.load_checkpoint(path, scene, model, other)
    calls = []
    _rounds_ending_early(monkeypatch, ["stop", 1e-4], calls)
    spent = fabric_relax.Partial(0.5, state, 0, 10, np.inf, 0.0, early=10)
    result, inc = fabric_relax._increment(model, state, 0.5, 1e-3, 5, 2, np.inf, start=spent,
                                          reanchor=0.2)
    assert result is not None and calls == [None, None] and inc.iterations == 10 + 1 + 1


def test_a_round_ends_once_contacts_have_formed_without_friction():
    """The stop of a re-anchoring round counts the segments touching now
    (gap below the law's reach) that were not touching at the round's start:
    it ends the round only after ``min_steps`` and once more than
    max(4, share x touching at the start) are new."""
    from types import SimpleNamespace
    g0 = 0.04
    contact = SimpleNamespace(segments=SimpleNamespace(law=SimpleNamespace(g0=g0)), report=None)

    def touching(mask):
        gap = np.where(mask, 0.0, g0)
        contact.report = SimpleNamespace(segment_gap=gap)
    stop = fabric_relax._contacts_formed(contact, 0.1, 3)
    start = np.zeros(200, bool)
    start[:100] = True                              # threshold max(4, 10) = 10
    touching(start)
    assert not stop(0, 0.0, 1.0)
    now = start.copy()
    now[100:111] = True                             # 11 new ...
    now[:50] = False                                # ... while 50 came apart
    touching(now)
    assert not stop(2, 0.0, 1.0)                    # before min_steps
    assert stop(3, 0.0, 1.0)
    now[110] = False                                # 10 new: not more than the share
    touching(now)
    assert not stop(4, 0.0, 1.0)
    few = fabric_relax._contacts_formed(contact, 0.1, 1)
    touching(np.zeros(200, bool))
    few(0, 0.0, 1.0)
    one = np.zeros(200, bool)
    one[:4] = True
    touching(one)
    assert not few(1, 0.0, 1.0)                     # at least 4
    one[4] = True
    touching(one)
    assert few(1, 0.0, 1.0)


def test_a_real_round_ends_early_on_the_contacts_that_formed_in_it():
    """On a 3 x 3 swatch tightening onto its crossings (lam = 0.1 from the
    knitted shape, friction on), a re-anchoring round ends early, unconverged
    and ``stopped``, after at least ``min_steps``, with more new touching
    segments than its share; the same round without re-anchoring runs on."""
    scene = FabricScene(3, 3, elements_per_loop=16, alpha=0.05)
    model, _, _ = build(scene)
    Homotopy(model, scene.alpha).apply(0.1)
    state = model.initial_state()
    contact = model.contact_model
    model.contact_report(state)
    before = fabric_relax._touching(contact)
    result, _ = fabric_relax._round(model, state, 0.1, 1e-8, 60, reanchor=0.1, min_steps=5)
    assert result.stopped and not result.converged and 5 <= result.iterations < 60
    model.contact_report(result.state)
    after = fabric_relax._touching(contact)
    assert np.count_nonzero(after & ~before) > max(4, 0.1 * np.count_nonzero(before))
    whole, _ = fabric_relax._round(model, state, 0.1, 1e-8, result.iterations + 5)
    assert not whole.stopped and whole.iterations == result.iterations + 5


def test_final_rounds_go_on_while_they_contract_and_stop_when_they_do_not(monkeypatch):
    """At lam = 1 the lagged friction's rounds are a fixed point: while each
    round ends at half the residual of the one before, rounds beyond
    ``max_rounds`` go on (up to ``extra_rounds``); once they stall the
    increment fails, saying after how many rounds."""
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    state = model.initial_state()
    halving = [10.0 ** -k for k in range(1, 12)]      # converges in round 8
    _scripted_rounds(monkeypatch, halving)
    result, inc = fabric_relax._increment(model, state, 1.0, 1e-8, 5, 4, np.inf,
                                          extra_rounds=8)
    assert result is not None and result.converged and result.residual == 1e-8
    assert inc.iterations == 8
    stalling = [1e-1, 1e-2, 1e-3, 1e-4, 0.9e-4, 1e-9]    # round 5 stalls
    _scripted_rounds(monkeypatch, stalling)
    result, reason, inc = fabric_relax._increment(model, state, 1.0, 1e-8, 5, 4, np.inf,
                                                  extra_rounds=8)
    assert result is None and "in 5 rounds" in reason and not inc.accepted
    _scripted_rounds(monkeypatch, halving)           # no extra rounds on the way
    result, reason, inc = fabric_relax._increment(model, state, 0.5, 1e-8, 5, 4, np.inf)
    assert result is None and "in 4 rounds" in reason


def test_final_rounds_go_on_while_their_moves_halve(monkeypatch, tmp_path):
    """Converged final rounds that still move the swatch (the lagged friction
    nearing its fixed point) go on beyond ``max_rounds`` while each moves at
    most 0.7 times as far as the one before, until one moves less than ``creep``;
    the moves survive a resume; rounds whose moves stall end on the budget."""
    from knitfem.scenes import curl as curl_module
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    state = model.initial_state()
    moves = [0.3 ** k for k in range(1, 20)]          # below 1e-3 in round 6
    _scripted_rounds(monkeypatch, [1e-9] * 19, moves=moves)
    result, inc = fabric_relax._increment(model, state, 1.0, 1e-8, 5, 4, 1e-3, extra_rounds=8)
    assert result is not None and inc.iterations == 6 and abs(inc.moved - moves[5]) < 1e-12
    partial = fabric_relax.Partial(1.0, state, 4, 4, np.inf, 0.0, ends=(1e-9,) * 4,
                                   moves=tuple(moves[:4]))
    path = tmp_path / "checkpoint.npz"
    scene = FabricScene(3, 3, elements_per_loop=16)
    curl_module._save_checkpoint(path, scene, state, 0.9, 0.1, [], None, partial)
    partial = curl_module.load_checkpoint(path, scene, model)[4]
    assert partial.moves == tuple(moves[:4])
    _scripted_rounds(monkeypatch, [1e-9] * 15, moves=moves[4:])
    result, inc = fabric_relax._increment(model, state, 1.0, 1e-8, 5, 4, 1e-3, start=partial,
                                          extra_rounds=8)
    assert result is not None and inc.iterations == 6
    _scripted_rounds(monkeypatch, [1e-9] * 19, moves=[0.1, 0.05, 0.03, 0.025, 0.012, 0.01] * 3)
    result, inc = fabric_relax._increment(model, state, 1.0, 1e-8, 5, 4, 1e-3, extra_rounds=8)
    assert result is not None and inc.iterations == 4 and abs(inc.moved - 0.025) < 1e-12


def test_an_increment_takes_snap_rounds_while_its_rounds_slide_the_swatch():
    """The round budget's decision on recorded sequences (in yarn radii r):
    the 55 x 35's rounds at lam 0.85 (6.1, 6.1, 25 r, unconverged) slide on
    and get snap rounds; rounds hovering near an equilibrium (0.3, 0.5,
    0.4 r) and a single long round do not; the snap budget is a cap."""
    r = 0.4
    slide = [6.1 * r, 6.1 * r, 25 * r, 3.0 * r]
    ends = [1e-2] * 4
    assert fabric_rounds.another_round(4, ends, slide, r, 4, snap_rounds=8)
    assert not fabric_rounds.another_round(4, ends, slide, r, 4)     # the protocol before
    assert not fabric_rounds.another_round(12, ends, slide, r, 4, snap_rounds=8)
    hover = [0.3 * r, 0.5 * r, 0.4 * r, 0.45 * r]
    assert not fabric_rounds.another_round(4, ends, hover, r, 4, snap_rounds=8)
    ended = [6.1 * r, 6.1 * r, 25 * r, 0.5 * r]                       # the slide is over
    assert not fabric_rounds.another_round(4, ends, ended, r, 4, snap_rounds=8)
    assert not fabric_rounds.sliding([25 * r], r)
    assert fabric_rounds.another_round(3, ends, hover, r, 4)          # within the budget


def test_rounds_contract_on_the_recorded_sequences_and_not_on_a_stall():
    """Contracting rounds (each final residual at most half the one before,
    or each move at most 0.7 of the one before) on the sequences recorded in
    fabric_rounds' docstrings: the 25 x 35's final residuals 0.8, 0.26, 2e-3,
    5e-4 and the 3 x 4's moves 1.7, 0.34, 0.082 r contract; a stalled
    residual, a move that grows again, and fewer than three rounds do not."""
    assert fabric_rounds.contracting([0.8, 0.26, 2e-3, 5e-4])
    assert fabric_rounds.contracting([1e-2] * 3, moves=[1.7, 0.34, 0.082])
    assert fabric_rounds.contracting([1e-2] * 3, moves=[1.8, 0.97, 0.39])
    assert not fabric_rounds.contracting([0.8, 0.26, 0.2])                 # stalled
    assert not fabric_rounds.contracting([1e-2] * 3, moves=[1.7, 0.34, 0.5])
    assert not fabric_rounds.contracting([0.8, 0.26], moves=[1.7, 0.34])
    assert not fabric_rounds.contracting([0.0, 0.0, 0.0], moves=[0.0, 0.0, 0.0])


def test_a_sliding_increment_finishes_in_its_snap_rounds_instead_of_halving(monkeypatch):
    """Rounds that each carry the swatch 6 yarn radii, unconverged, then settle
    in round 7: with snap rounds the increment ends there (7 rounds), without
    them it fails after its budget of 4, naming the slide."""
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    r = fabric_rounds.smallest_radius(model)
    state = model.initial_state()
    residuals = [1e-1] * 6 + [1e-9]
    moves = [6.0 * r] * 6 + [0.1 * r]
    _scripted_rounds(monkeypatch, residuals, moves=moves)
    result, inc = fabric_relax._increment(model, state, 0.85, 1e-8, 5, 4, np.inf,
                                          snap_rounds=8)
    assert result is not None and result.converged and inc.iterations == 7
    _scripted_rounds(monkeypatch, residuals, moves=moves)
    result, reason, inc = fabric_relax._increment(model, state, 0.85, 1e-8, 5, 4, np.inf)
    assert result is None and "in 4 rounds" in reason and "a long slide or a snap" in reason
    _scripted_rounds(monkeypatch, [1e-1] * 20, moves=[6.0 * r] * 20)   # a slide without end
    result, reason, inc = fabric_relax._increment(model, state, 0.85, 1e-8, 5, 4, np.inf,
                                                  snap_rounds=3)
    assert result is None and "in 7 rounds" in reason and inc.iterations == 7


def test_a_checkpoint_from_before_snap_rounds_records_their_arrival(tmp_path):
    """A checkpoint written before snap rounds existed ran none (its protocol
    does not name them): a resume under the default records the change from 0
    to 8 at its lam; one written now names its budget, and a resume under the
    same budget records nothing."""
    import json
    from knitfem.scenes import curl as curl_module
    scene = FabricScene(3, 3, elements_per_loop=16)
    model, _, _ = build(scene)
    path = tmp_path / "checkpoint.npz"
    curl_module._save_checkpoint(path, scene, model.initial_state(), 0.6, 0.1, [], None)
    data = dict(np.load(path))
    assert json.loads(str(data["protocol"])) == {"snap_rounds": fabric_rounds.SNAP_ROUNDS}
    assert curl_module.resumed_protocol(curl_module.checkpoint_protocol(np.load(path)),
                                        None, 0.6) == {}
    data["protocol"] = np.array(json.dumps({}))         # as the code before wrote it
    np.savez(path, **data)
    assert curl_module.load_checkpoint(path, scene, model) is not None
    record = curl_module.resumed_protocol(curl_module.checkpoint_protocol(np.load(path)),
                                          None, 0.6)
    assert record == {"budget_changes": [{"lam": 0.6, "option": "snap_rounds", "from": 0,
                                          "to": fabric_rounds.SNAP_ROUNDS}]}


def _contact_rounds(scene):
    """Two friction rounds at lam = 0.1 (40 + 20 minimisation steps): the
    yarns tighten onto their crossings, contacts form and friction anchors."""
    model, _, _ = build(scene)
    Homotopy(model, scene.alpha).apply(0.1)
    first, _ = fabric_relax._round(model, model.initial_state(), 0.1, 1e-8, 40)
    second, _ = fabric_relax._round(model, first.state, 0.1, 1e-8, 20)
    return model, second


def test_the_mirrored_swatch_relaxes_through_the_mirrored_states():
    """Mirror symmetry of the mechanics (beam, contact, ties, friction, the
    held node, the minimiser).  Our swatch itself is not mirror symmetric
    (chiral bind-off helices, both tails at one edge), so left and right
    rolls need not be equal; the test is equivariance instead: the swatch
    knitted from the other side (geometry.mirror_swatch) goes through the
    mirror images of the original's states, contact and friction active.
    Measured 9e-8 mm after 60 steps (1.2e-11 after 15: the line search's
    branches amplify round-off); tolerance 1e-6 r."""
    scene = FabricScene(4, 4, elements_per_loop=16, alpha=0.05)
    model, a = _contact_rounds(scene)
    mirrored, b = _contact_rounds(FabricScene(4, 4, elements_per_loop=16, alpha=0.05, mirror=True))
    assert model.contact_report(a.state).active_pairs > 0
    assert len(model.contact_model.anchors.ends) > 0
    x = model.assembly.initial_positions()[:, 0]
    image = a.state.x * [-1.0, 1.0, 1.0] + [x.min() + x.max(), 0.0, 0.0]
    assert np.abs(image - b.state.x).max() <= 1e-6 * scene.radius


def test_a_checkpoint_from_before_a_scene_field_existed_resumes_with_its_default(tmp_path):
    """Checkpoints name their scene; one written before a field was added
    (its JSON lacks the key) ran with the field's default and resumes as
    such, while one with another value of any field is refused."""
    from knitfem.scenes import curl as curl_module
    scene = FabricScene(3, 4, elements_per_loop=16)
    model, _, _ = build(scene)
    path = tmp_path / "checkpoint.npz"
    curl_module._save_checkpoint(path, scene, model.initial_state(), 0.3, 0.1, [], None)
    data = dict(np.load(path))
    old = json.loads(str(data["scene"]))
    del old["mirror"]
    data["scene"] = json.dumps(old, sort_keys=True)
    np.savez(path, **data)
    state, lam, dlam, _, partial = curl_module.load_checkpoint(path, scene, model)
    assert (lam, dlam, partial) == (0.3, 0.1, None)
    with pytest.raises(ValueError, match=r"--resume: .* other parameters \(mirror: checkpoint "
                                         r"False, given True\)"):
        curl_module.load_checkpoint(path, FabricScene(3, 4, elements_per_loop=16, mirror=True),
                                    model)


def _converged_rounds(monkeypatch, next_state):
    """Script the friction rounds: each converges at once (residual 1e-9) on
    ``next_state(state)``."""
    class Result:
        pass

    def scripted(model, state, lam, tol, iterations, progress=None, reanchor=None,
                 exact_tries=None):
        result = Result()
        result.state = next_state(state)
        result.iterations, result.energy, result.residual, result.converged = 1, 0.0, 1e-9, True
        result.stopped = False
        return result, np.inf
    monkeypatch.setattr(fabric_relax, "_round", scripted)


@pytest.mark.parametrize("move, settled", [(0.0, True), (0.5, False)])
def test_an_answer_whose_friction_did_not_settle_says_so(monkeypatch, move, settled):
    """The final increment ends when a converged round moved nothing (the
    lagged friction at its fixed point) or on its round budget with the last
    round converged: then the answer is an equilibrium for that round's
    anchors only, and it says so (friction_settled False, the last round's
    move) instead of passing for settled."""
    from knitfem.beam.model import BeamState
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    r = model.rods[0].section.radius
    _converged_rounds(monkeypatch, lambda state: BeamState(stretched(state.x, move * r), state.q))
    eq = fabric_relax.relax_fabric(model, Homotopy(model, 0.05), dlam=1.0)
    assert eq.friction_settled is settled
    assert eq.last_round_move == pytest.approx(move * r)
    assert eq.increments[-1].iterations == (2 if settled else 8)
    # a creep: two rounds carry the swatch twice as far as one
    assert eq.two_round_move == pytest.approx(2.0 * move * r, abs=1e-12)


def test_a_round_that_only_moves_the_free_swatch_rigidly_has_settled(monkeypatch):
    """Rounds that turn and shift the whole free-floating swatch (positions and
    frames), as its held node lets them along a near-zero mode, settle the
    friction: the rigid motion is no change of the answer (round_move)."""
    from scipy.spatial.transform import Rotation
    from knitfem.beam.rotation import quat_multiply
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    assert model.free_floating
    turn = Rotation.from_rotvec([0.0, 0.0, 0.01])          # 0.57 deg: ~0.1 mm at the edges

    def turning(state):
        q = quat_multiply(np.broadcast_to(np.roll(turn.as_quat(), 1), state.q.shape), state.q)
        return type(state)(turn.apply(state.x) + [0.05, 0.0, 0.0], q)
    _converged_rounds(monkeypatch, turning)
    eq = fabric_relax.relax_fabric(model, Homotopy(model, 0.05), dlam=1.0)
    assert eq.friction_settled is True and eq.last_round_move < 1e-9
    assert eq.increments[-1].iterations == 2


def test_rounds_that_cycle_between_two_states_are_reported_as_a_cycle(monkeypatch, tmp_path):
    """Rounds alternating between two shapes (each an equilibrium for the other's
    anchors, as the 25 x 35 at alpha 0.3 did) are not settled, and the answer
    says that two rounds apart nothing moved; the two-round move survives a
    checkpoint (an older checkpoint without it reads as not measured)."""
    import itertools
    from knitfem.scenes import curl as curl_module
    from knitfem.scenes.curl_command import _cycle_note
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    r = model.rods[0].section.radius
    a = model.initial_state()
    b = type(a)(stretched(a.x, 0.01 * r), a.q.copy())
    states = itertools.cycle([b, a])
    _converged_rounds(monkeypatch, lambda state: next(states))
    eq = fabric_relax.relax_fabric(model, Homotopy(model, 0.05), a, dlam=1.0)
    assert eq.friction_settled is False and eq.increments[-1].iterations == 8
    assert eq.last_round_move == pytest.approx(0.01 * r) and eq.two_round_move == 0.0
    summary = {"last_round_move_over_r": 0.01, "two_round_move_over_r": 0.0}
    assert "cycle between two states" in _cycle_note(summary)
    assert "a creep" in _cycle_note({"last_round_move_over_r": 0.01, "two_round_move_over_r": 0.02})
    assert "neither" in _cycle_note({"last_round_move_over_r": 0.01, "two_round_move_over_r": 0.01})
    assert _cycle_note({"last_round_move_over_r": 0.01, "two_round_move_over_r": None}) == ""
    path, scene = tmp_path / "checkpoint.npz", FabricScene(3, 3, elements_per_loop=16)
    curl_module._save_checkpoint(path, scene, a, 1.0, 0.1, eq.increments, None)
    kept = curl_module.load_checkpoint(path, scene, model)[3]
    assert kept[-1].cycle == 0.0 and kept[-1].moved == eq.increments[-1].moved
    data = dict(np.load(path))
    assert list(data["increment_fields"]) == list(curl_module.INCREMENT_FIELDS)
    # columns named: read by name, whatever their order
    order = np.arange(len(curl_module.INCREMENT_FIELDS))[::-1]
    np.savez(path, **{**data, "increments": data["increments"][:, order],
                      "increment_fields": data["increment_fields"][order]})
    from dataclasses import astuple
    np.testing.assert_array_equal([astuple(i) for i in curl_module.load_checkpoint(
        path, scene, model)[3]], [astuple(i) for i in kept])
    # a column this code does not know: refused by name, not read into another field
    np.savez(path, **{**data, "increment_fields": np.array(
        [*data["increment_fields"][:-1], "future_column"])})
    with pytest.raises(ValueError, match="future_column"):
        curl_module.load_checkpoint(path, scene, model)
    twice = np.array([*data["increment_fields"][:-1], "lam"])          # a column read twice
    short = {"increments": data["increments"][:, :5]}                   # fewer than the six
    for bad in ({**data, "increment_fields": twice}, short):
        with pytest.raises(ValueError, match="not this code's"):
            curl_module.increments_of(bad)
    # written before the columns were named, and before the two-round move: by position
    data.pop("increment_fields")
    data["increments"] = data["increments"][:, :8]                 # before the column
    np.savez(path, **data)
    old = curl_module.load_checkpoint(path, scene, model)[3]
    assert np.isnan(old[-1].cycle) and old[-1].moved == kept[-1].moved
    data["increments"] = data["increments"][:, :6]                 # before `accepted`
    np.savez(path, **data)
    assert all(inc.accepted for inc in curl_module.load_checkpoint(path, scene, model)[3])


def test_extra_final_rounds_survive_a_resume(monkeypatch, tmp_path):
    """The extra final rounds go on while the rounds' residuals halve: a run
    killed after round 8 (its checkpoint keeps the rounds' residuals) and
    resumed must go on like the uninterrupted one, not fail for want of a
    history and restart the increment smaller."""
    from knitfem.scenes import curl as curl_module
    model, _, _ = build(FabricScene(3, 3, elements_per_loop=16))
    state = model.initial_state()
    residuals = [1e-2 * 0.3 ** k for k in range(20)]      # converged in round 13
    _scripted_rounds(monkeypatch, residuals)
    result, inc = fabric_relax._increment(model, state, 1.0, 1e-8, 5, 8, np.inf,
                                          extra_rounds=8)
    assert result is not None and inc.iterations == 13
    partial = fabric_relax.Partial(1.0, state, 8, 8, np.inf, 0.0, ends=tuple(residuals[:8]))
    path = tmp_path / "checkpoint.npz"
    scene = FabricScene(3, 3, elements_per_loop=16)
    curl_module._save_checkpoint(path, scene, state, 0.9, 0.1, [], None, partial)
    partial = curl_module.load_checkpoint(path, scene, model)[4]
    assert partial.ends == tuple(residuals[:8])
    _scripted_rounds(monkeypatch, residuals[8:])
    result, inc = fabric_relax._increment(model, state, 1.0, 1e-8, 5, 8, np.inf,
                                          start=partial, extra_rounds=8)
    assert result is not None and inc.iterations == 13


def test_a_checkpoint_from_before_the_corotated_friction_resumes_as_fixed_planes(tmp_path):
    """Checkpoints written before the scene had ``corotated_friction`` ran
    with friction in fixed tangent planes: they resume only with
    ``--friction-frame anchor`` (corotated_friction=False), and the default
    options are refused as other parameters instead of silently changing the
    friction half-way."""
    import json as _json
    from knitfem.scenes.curl import _save_checkpoint, load_checkpoint
    old = FabricScene(3, 4, elements_per_loop=16, alpha=0.05, corotated_friction=False)
    model, _, _ = build(old)
    path = tmp_path / "checkpoint.npz"
    _save_checkpoint(path, old, model.initial_state(), 0.0, 0.1, [], model.contact_model)
    data = dict(np.load(path))
    scene = _json.loads(str(data["scene"]))
    del scene["corotated_friction"]
    data["scene"] = _json.dumps(scene, sort_keys=True)
    np.savez(path, **data)
    assert load_checkpoint(path, old, model)[1] == 0.0
    with pytest.raises(ValueError, match="other parameters"):
        load_checkpoint(path, FabricScene(3, 4, elements_per_loop=16, alpha=0.05), model)


def test_exact_tries_is_a_path_option_recorded_only_off_its_default(tmp_path):
    """``--exact-tries`` decides the steps, so the path: a run records it
    (only when it differs from the minimiser's default), its checkpoint
    refuses to resume without it, and it reaches the minimiser of every round."""
    from knitfem.scenes import curl as curl_module
    from knitfem.scenes.curl_command import relax_protocol
    from knitfem.solve.minimize import SHIFTS
    assert relax_protocol(exact_tries=SHIFTS) is None
    assert relax_protocol(exact_tries=2) == {"exact_tries": 2}
    scene = FabricScene(3, 3, elements_per_loop=16)
    model, _, _ = build(scene)
    state = model.initial_state()
    path = tmp_path / "checkpoint.npz"
    curl_module._save_checkpoint(path, scene, state, 0.4, 0.1, [], None,
                                 protocol={"exact_tries": 2})
    curl_module.load_checkpoint(path, scene, model, {"exact_tries": 2})
    for other in (None, {"exact_tries": 3}):
        with pytest.raises(ValueError, match="another relaxation protocol"):
            curl_module.load_checkpoint(path, scene, model, other)
    seen = []
    real = fabric_relax.minimize

    def spy(*args, **options):
        seen.append(options["shifts"])
        return real(*args, **options)
    try:
        fabric_relax.minimize = spy
        Homotopy(model, scene.alpha).apply(0.05)
        fabric_relax._round(model, state, 0.05, 1e-8, 2, exact_tries=1)
        fabric_relax._round(model, state, 0.05, 1e-8, 2)
    finally:
        fabric_relax.minimize = real
    assert seen == [1, SHIFTS]


def test_straighten_sets_how_much_knitted_curvature_the_yarn_loses():
    """``straighten`` scales the bend stage only: at lam = 1 the knit yarn's
    natural curvature is (1 - straighten) x the knitted one (0: it keeps its
    knitted shape), its rest length shrinks by alpha either way, and the
    bind-off keeps its helix; a share outside [0, 1] is refused by name."""
    results = {}
    for share in (1.0, 0.5, 0.0):
        scene = FabricScene(3, 3, elements_per_loop=16, alpha=0.2, straighten=share)
        model, _, _ = build(scene)
        asm = model.assembly
        knit = asm.rod_of_element == 0
        kappa_knitted, gamma_knitted = asm.kappa0.copy(), asm.gamma0.copy()
        Homotopy.of_scene(model, scene).apply(1.0)
        assert np.allclose(asm.kappa0[knit], (1.0 - share) * kappa_knitted[knit], atol=1e-15)
        assert np.allclose(asm.kappa0[~knit], kappa_knitted[~knit], atol=1e-15)
        assert np.allclose(asm.gamma0[knit, 0], 0.8 * gamma_knitted[knit, 0], rtol=1e-12)
        results[share] = asm.kappa0[knit].copy()
    assert np.abs(results[1.0]).max() == 0.0 and np.abs(results[0.0]).max() > 0.1
    with pytest.raises(ValueError, match=r"straighten must be in \[0, 1\]"):
        Homotopy(build(FabricScene(3, 3, elements_per_loop=16))[0], 0.2, straighten=1.5)
