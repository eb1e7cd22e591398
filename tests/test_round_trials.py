"""studies/round_trials.py: every line-search trial of a friction round (issue 9's speed work)."""
import os
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "studies"))

# the study, a script, sets one-thread NUMBA_/BLAS variables when imported; in
# this process they would make numba reload its configuration at the next
# compilation and drop knitfem's cache folder (tests/test_numba_cache.py)
_environ = dict(os.environ)
from round_trials import PARTS, summarise, trial_round  # noqa: E402
os.environ.clear()
os.environ.update(_environ)

from knitfem.scenes.fabric import FabricScene, Homotopy, build  # noqa: E402


@pytest.fixture(scope="module")
def record():
    """The first 25 steps of a 3 x 3 swatch's first increment (lam 0.05): the
    yarns come into contact, so some full steps are refused."""
    scene = FabricScene(3, 3, elements_per_loop=16)
    model, _, _ = build(scene)
    Homotopy(model, scene.alpha).apply(0.05)
    return trial_round(model, model.initial_state(), 25, 1e-8)


def test_trials_follow_the_line_search_of_every_step(record):
    """One list of trials per step; a step accepted at t = 2^-k tried k + 1
    states, the last accepted; the trials' energies and moves are those of
    the minimiser's path (the accepted energy is the next step's)."""
    history, steps = record["history"], record["trials"]
    assert len(steps) == len(history) == record["steps"] == 25
    for k, (h, trials) in enumerate(zip(history, steps)):
        t = h[3]
        assert t > 0                                     # nothing refused outright here
        assert len(trials) == int(round(np.log2(1.0 / t))) + 1
        assert all(not x["accepted"] for x in trials[:-1])
        assert trials[-1]["energy"] == pytest.approx(h[0], rel=1e-12)   # E after the step
        if k + 1 < len(steps):
            assert trials[-1]["accepted"]
        moves = [x["move_r"] for x in trials]
        assert all(b == pytest.approx(a / 2, rel=1e-6) for a, b in zip(moves, moves[1:]))
        assert 0 < moves[0] <= 0.5 + 1e-9                # the step limit: half a radius
    assert any(len(trials) > 1 for trials in steps)


def test_the_energy_split_adds_up_to_the_energy_change(record):
    """The terms' changes (elastic, ties, contact) sum to the trial's energy
    change: there is no external load in the swatch."""
    start = None
    for h, trials in zip(record["history"], record["trials"]):
        for x in trials:
            if start is not None:
                assert sum(x[f"d_{p}"] for p in PARTS) == pytest.approx(x["energy"] - start,
                                                                        abs=1e-9 * abs(start))
        start = h[0]


def test_summary_counts_the_accepted_and_refused_full_steps(record):
    text = summarise({"nw": 3, "nc": 3, "lam": 0.05, "unknowns": 0, **record})
    refused = sum(1 for trials in record["trials"][:-1] if len(trials) > 1)
    row = text.strip().splitlines()[-1].split("|")
    assert int(row[1]) == 24 and int(row[5]) == refused
    assert int(row[2]) == 24 - refused
