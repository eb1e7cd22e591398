"""A B-spline fabric relaxation stops and goes on: its FIRE checkpoint holds
everything carried from step to step, so a resumed run repeats an unbroken
one bit for bit, and a checkpoint of another swatch is refused by name."""
import json

import numpy as np
import pytest

from knitfem.bspline.fire import FireState
from knitfem.cli import main
from knitfem.scenes.curl_bspline import bspline_curl

RUN = dict(alpha=0.2, newton=False, max_time=600.0, progress=False)


def _control(folder, name="bspline_4x4"):
    return np.load(folder / f"{name}_control.npy")


def test_a_resumed_relaxation_takes_the_steps_of_an_unbroken_one(tmp_path):
    """300 FIRE steps, stopped, then 300 more from the checkpoint: the same
    control points, bit for bit, as 600 steps in one go (the step counter,
    velocities, masses, step length and FIRE's counters all carried)."""
    whole, parts = tmp_path / "whole", tmp_path / "parts"
    straight = bspline_curl(4, 4, max_steps=600, out=whole, **RUN)
    first = bspline_curl(4, 4, max_steps=300, out=parts, **RUN)
    saved = FireState.from_arrays(np.load(parts / "bspline_4x4_checkpoint.npz"))
    assert saved.step == 300 and first["iterations"] == 300
    assert np.abs(saved.v).max() > 0.0                  # moving: the velocities matter
    second = bspline_curl(4, 4, max_steps=600, out=parts, resume=True, **RUN)
    assert not straight["converged"] and not second["converged"]
    assert np.array_equal(_control(whole), _control(parts))
    assert second["iterations"] == straight["iterations"] == 600
    assert second["resumed_from_step"] == 300 and second["processes"] == 2
    assert straight["processes"] == 1 and straight["resumed_from_step"] is None
    assert second["residual"] == straight["residual"]
    # the relaxation time sums both runs
    assert second["relax_s"] > first["relax_s"]


def test_an_interrupted_relaxation_keeps_its_last_check(tmp_path):
    """An exception inside the relaxation (here from the monitor, as a Ctrl-C
    would arrive) leaves the state of the last check (every 20 steps), and
    the resumed run ends where an unbroken one does."""
    from knitfem.scenes import curl_bspline

    class Stop(Exception):
        pass

    class Monitor:
        def __init__(self, bs):
            pass

        def __call__(self, step, y, residual, E, ke):
            if step == 220:
                raise Stop

    broken, whole = tmp_path / "broken", tmp_path / "whole"
    trace = curl_bspline.Trace
    curl_bspline.Trace = Monitor
    try:
        with pytest.raises(Stop):
            bspline_curl(4, 4, max_steps=400, out=broken, trace=True, **RUN)
    finally:
        curl_bspline.Trace = trace
    # the monitor runs after the check's snapshot: step 220 was kept
    assert FireState.from_arrays(np.load(broken / "bspline_4x4_checkpoint.npz")).step == 220
    bspline_curl(4, 4, max_steps=400, out=broken, resume=True, **RUN)
    bspline_curl(4, 4, max_steps=400, out=whole, **RUN)
    assert np.array_equal(_control(broken), _control(whole))


def test_a_checkpoint_of_another_swatch_is_refused_by_name(tmp_path):
    bspline_curl(4, 4, max_steps=20, out=tmp_path, **RUN)
    other = dict(RUN, alpha=0.1)
    with pytest.raises(ValueError, match=r"other parameters \(alpha: checkpoint 0.2, given 0.1\)"):
        bspline_curl(4, 4, max_steps=40, out=tmp_path, resume=True, **other)


def test_a_fresh_run_removes_a_stale_checkpoint_and_resume_without_one_starts_over(tmp_path):
    bspline_curl(4, 4, max_steps=20, out=tmp_path, **RUN)
    path = tmp_path / "bspline_4x4_checkpoint.npz"
    path.unlink()
    with pytest.warns(UserWarning, match="does not exist; relaxing from the start"):
        result = bspline_curl(4, 4, max_steps=20, out=tmp_path, resume=True, **RUN)
    assert result["resumed_from_step"] is None and result["iterations"] == 20
    with pytest.raises(ValueError, match="resume needs out"):
        bspline_curl(4, 4, max_steps=20, resume=True, **RUN)
    with pytest.raises(ValueError, match="method 'fire'"):
        bspline_curl(4, 4, max_steps=20, out=tmp_path, resume=True, method="dynamic", **RUN)


def test_cli_bspline_resume_goes_on_from_the_checkpoint(tmp_path, capsys):
    """``knitfem curl --model bspline --resume`` (refused before 2026-12-07):
    the second run starts from the first one's last state."""
    out, js = tmp_path / "run", tmp_path / "s.json"
    args = ["curl", "--model", "bspline", "--nw", "4", "--nc", "4", "--max-time", "1",
            "--out", str(out), "--json", str(js), "--no-render", "--quiet"]
    assert main(args) == 3                       # not converged in 1 s: says so
    first = json.loads(js.read_text())
    assert (out / "bspline_4x4_checkpoint.npz").exists()
    assert main(args + ["--resume"]) == 3
    second = json.loads(js.read_text())
    assert second["resumed_from_step"] >= first["iterations"] - 20 > 0
    assert second["processes"] == 2


def test_a_resume_repeats_mass_refreshes_and_a_converged_run_stops_where_it_was(tmp_path):
    """FIRE at the library level, its step allowed up to twice the stable one
    so that it overshoots, cuts and refreshes its masses after every 2 cuts:
    the resumed half, with a fresh model (its Verlet list built at the
    checkpoint, not where the unbroken run built it), refreshes the
    Gershgorin masses (the contact Hessian) and still repeats the unbroken run
    bit for bit; resuming from a converged state returns it at once."""
    from knitfem.bspline.fire import relax_fire
    from knitfem.bspline.relax import RelaxationError
    from knitfem.scenes.swatch_bspline import bspline_swatch, prestretch

    def model():
        bs = bspline_swatch(4, 4)
        prestretch(bs, 0.2)
        return bs.model

    def run(m, **kw):
        saved = []
        with pytest.raises(RelaxationError):
            relax_fire(m, m.reduce(m._initial()), refresh=2, dt_max=2.0,
                       checkpoint=saved.append, **kw)
        return saved[-1]

    whole = run(model(), max_steps=200)
    half = run(model(), max_steps=100)
    assert half.refreshes < whole.refreshes              # a refresh after the resume point
    again = run(model(), max_steps=200, state=half)
    assert again.step == whole.step == 200
    assert np.array_equal(again.y, whole.y) and np.array_equal(again.m, whole.m)
    with pytest.raises(ValueError, match="max_steps must be > 100"):
        relax_fire(model(), None, max_steps=100, state=half)
    m = model()
    done = relax_fire(m, m.reduce(m._initial()), rtol=1.0, max_steps=100)   # at once
    state = FireState(done.y, done.velocity, np.ones_like(done.y), 1.0, 0.1, 0, 0,
                      done.iterations, 0, 0, tuple(done.history))
    resumed = relax_fire(m, None, rtol=1.0, max_steps=100, state=state)
    assert resumed.iterations == done.iterations and np.array_equal(resumed.y, done.y)


def test_energy_gradient_and_hessian_do_not_depend_on_where_the_verlet_list_was_built(rng):
    """At one state, with the candidate-pair list built there or at points up
    to 0.09 mm away (within half the skin: no rebuild), the energy, gradient
    and Hessian are the same bit for bit (the pairs in sample order, the
    Hessian assembled from the touching pairs only)."""
    from knitfem.bspline.fire import relax_fire
    from knitfem.bspline.relax import RelaxationError
    from knitfem.scenes.swatch_bspline import bspline_swatch, prestretch
    bs = bspline_swatch(4, 4)
    prestretch(bs, 0.2)
    m = bs.model
    with pytest.raises(RelaxationError) as err:            # a state with many contacts
        relax_fire(m, m.reduce(m._initial()), max_steps=200)
    y = err.value.y
    pts = m._at_samples(m.control_points(y))
    m._pairs.points = None
    m._pairs(pts)                                          # built at the state itself
    E0, g0, _ = m.reduced_energy(y)
    H0 = m.reduced_hessian(y).toarray()
    differ = 0
    for _ in range(6):
        m._pairs.points = None
        shift = rng.uniform(-1.0, 1.0, pts.shape) * 0.09 / np.sqrt(3.0)
        m._pairs(pts + shift)                              # built elsewhere
        builds = m._pairs.builds
        E, g, _ = m.reduced_energy(y)
        H = m.reduced_hessian(y).toarray()
        assert m._pairs.builds == builds                   # and used: not rebuilt here
        assert E == E0 and np.array_equal(g, g0)
        differ += not np.array_equal(H, H0)
    assert differ == 0


def test_the_residual_aimed_at_rides_in_the_checkpoint_and_older_ones_aim_at_rtol(tmp_path):
    """FireState.target (the residual FIRE aims at after its confirm said
    'not at rest') survives arrays() -> savez -> from_arrays; a checkpoint
    written before the field existed reads as None (aim at rtol)."""
    y = np.arange(6.0)
    state = FireState(y, 0 * y, 1 + y, 0.5, 0.1, 3, 1, 40, 0, 0, (1e-3, 1e-4), 1e-8)
    np.savez(tmp_path / "new.npz", **state.arrays())
    with np.load(tmp_path / "new.npz") as saved:
        loaded = FireState.from_arrays(saved)
        assert loaded.target == 1e-8 and loaded.step == 40 and np.array_equal(loaded.m, state.m)
    old = {k: v for k, v in state.arrays().items() if k != "target"}
    np.savez(tmp_path / "old.npz", **old)
    with np.load(tmp_path / "old.npz") as saved:
        assert FireState.from_arrays(saved).target is None
    none = state._replace(target=None)
    assert FireState.from_arrays(none.arrays()).target is None
