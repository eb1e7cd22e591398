import numpy as np
import pytest


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


@pytest.fixture
def tangent_error(rng):
    """largest relative error |K v - central difference of f along v| / |K v|
    of a beam model's tangent at ``state`` over three random directions v."""
    def error(model, state, step):
        _, f, K = model.internal_forces(state)
        worst = 0.0
        for _ in range(3):
            v = rng.normal(size=f.shape)
            fp = model.internal_forces(model.retract(state, step * v), tangent=False)[1]
            fm = model.internal_forces(model.retract(state, -step * v), tangent=False)[1]
            Kv = K @ v
            worst = max(worst, np.linalg.norm((fp - fm) / (2 * step) - Kv) / np.linalg.norm(Kv))
        return worst
    return error


# The cross-model check relaxes a swatch with both models (~20 min on one
# core): outside the fast suite, run by `make test-crosscheck`.
def pytest_addoption(parser):
    parser.addoption("--crosscheck", action="store_true", default=False,
                     help="also run the cross-model checks (tests marked crosscheck, minutes each)")


def pytest_configure(config):
    config.addinivalue_line("markers", "crosscheck: both models on one swatch (minutes; "
                                       "run with --crosscheck or `make test-crosscheck`)")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--crosscheck"):
        return
    skip = pytest.mark.skip(reason="cross-model check: run with --crosscheck "
                                   "(make test-crosscheck)")
    for item in items:
        if "crosscheck" in item.keywords:
            item.add_marker(skip)
