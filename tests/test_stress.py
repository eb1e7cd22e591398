"""The stress table's fast subset (studies/stress.py, issue 10): one case of
each family and kind solved in-process and sorted against its closed form, and
the classification itself shown to catch wrong answers, false stability
flags, unclear errors and hangs."""
import copy
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "studies"))
import stress  # noqa: E402
import stress_cases  # noqa: E402

HONEST = {"correct", "clear error", "other branch", "flagged"}


def pick(family, **params):
    """The quick grid's case of a family with these parameters."""
    found = [c for c in stress_cases.grid(quick=True) if c["family"] == family and
             all(c[k] == v for k, v in params.items())]
    assert found, (family, params)
    return found[0]


SUBSET = [pick("rollup", Ld=1e4, n=200, steps=10),
          pick("elastica", Ld=1e4, n=200, steps=1),
          pick("parallel", multiplier=1e8),
          pick("crossed", multiplier=1e4),
          pick("column", lam=1.01, steps=1, require_stable=False),
          pick("column", lam=1.01, steps=1, require_stable=True),
          pick("srod", dc=-1e-3, steps=1, require_stable=True)]


@pytest.fixture(scope="module")
def refs():
    return stress_cases.references(SUBSET)


@pytest.fixture(scope="module")
def solved(refs):
    return {c["id"]: stress.run_case(c, refs) for c in SUBSET}


@pytest.mark.parametrize("case", SUBSET, ids=stress.label_of)
def test_fast_subset_gives_no_wrong_answer(case, refs, solved):
    """Every returned step agrees with the closed form (or is an honestly
    flagged unstable equilibrium / the other side of a symmetric bifurcation);
    with require_stable nothing unstable comes back."""
    outcome, detail = stress.classify(case, solved[case["id"]], refs)
    assert outcome in HONEST, detail
    if case.get("require_stable"):
        assert outcome != "flagged", detail


def test_classification_catches_what_it_should(refs, solved):
    """A tip moved by 1e-3 L is wrong; a stability flag contradicting the dense
    eigenvalues is wrong; an unstable step flagged as such is 'flagged'; a bare
    RuntimeError is a traceback; a SteppingError keeping a wrong step is wrong;
    no answer is a hang."""
    case = SUBSET[1]                                  # the elastica: stable, 200 elements
    good = solved[case["id"]]
    assert stress.classify(case, good, refs)[0] == "correct"

    moved = copy.deepcopy(good)
    moved["steps"][-1]["tip"][0] += 1e-3
    assert stress.classify(case, moved, refs)[0] == "wrong"
    moved["steps"][-1]["stable"] = False
    assert stress.classify(case, moved, refs)[0] == "flagged"

    lying = copy.deepcopy(good)
    lying["steps"][-1].update(stable=True, dense_negative=1)
    assert stress.classify(case, lying, refs)[0] == "wrong"

    crash = {"raised": "RuntimeError", "mro": ["RuntimeError", "Exception"],
             "message": "boom", "keeps_steps": False, "steps": []}
    assert stress.classify(case, crash, refs)[0] == "traceback"
    kept = dict(crash, raised="SteppingError", mro=["SteppingError", "NewtonError",
                                                    "RuntimeError"], keeps_steps=True,
                steps=moved["steps"][:1] + [dict(moved["steps"][-1], stable=None)])
    assert stress.classify(case, kept, refs)[0] == "wrong"
    kept["steps"] = good["steps"]
    assert stress.classify(case, kept, refs)[0] == "clear error"
    assert stress.classify(case, {"hang": True, "seconds": 1.0}, refs)[0] == "hang"
