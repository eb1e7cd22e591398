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
