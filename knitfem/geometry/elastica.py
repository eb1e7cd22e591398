"""Planar elastica between two clamps, as a starting shape for rods bent into place.

The tangent angle is a linear ramp between the clamp angles plus a sine
series, theta(u) = theta0 + (theta1 - theta0) u + sum_k a_k sin(k pi u),
u = s / L, which meets both clamp directions exactly; the coefficients
minimise the bending energy integral theta'^2 du subject to the end
position (SLSQP).  That is a Ritz approximation of the inextensible planar
elastica; the beam model then finds the discrete equilibrium from it.
Lengths in any unit; angles in radians from +x.
"""
import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.optimize import minimize

_SAMPLES = 1201   # trapezoid samples of theta(u): the guess needs ~1e-5 L, Newton does the rest


def planar_elastica(length, end, theta0=0.0, theta1=0.0, nodes=61, harmonics=41,
                    symmetric=None):
    """Nodes (nodes, 3) at equal arclength and unit tangents (nodes, 3) of a planar
    curve of ``length`` from the origin (angle ``theta0``) to ``end`` = (x, y)
    (angle ``theta1``).

    ``symmetric``: use odd harmonics only, which gives the point-symmetric S
    when theta0 == theta1 (default: True exactly then).
    """
    L = float(length)
    ex, ey = (float(v) for v in np.asarray(end, dtype=float).reshape(-1)[:2])
    chord = np.hypot(ex, ey)
    if not np.isfinite(L) or L <= 0:
        raise ValueError(f"length must be finite and positive, got {length!r}")
    if not np.isfinite(chord) or chord >= L:
        raise ValueError(f"the clamps are {chord:.6g} apart, which a rod of length {L:.6g} "
                         "cannot span (valid: distance < length)")
    symmetric = (theta0 == theta1) if symmetric is None else symmetric
    u = np.linspace(0.0, 1.0, _SAMPLES)
    k = np.arange(1, harmonics + 1, 2 if symmetric else 1)
    S = np.sin(np.pi * np.outer(u, k))
    ramp = theta0 + (theta1 - theta0) * u

    def theta(a):
        return ramp + S @ a

    def energy(a):                       # (1/2) integral of theta'^2 minus the ramp's constant
        return 0.25 * np.sum((np.pi * k * a) ** 2)

    constraints = [
        {"type": "eq", "fun": lambda a: np.trapezoid(np.cos(theta(a)), u) - ex / L,
         "jac": lambda a: -np.trapezoid(np.sin(theta(a))[:, None] * S, u, axis=0)},
        {"type": "eq", "fun": lambda a: np.trapezoid(np.sin(theta(a)), u) - ey / L,
         "jac": lambda a: np.trapezoid(np.cos(theta(a))[:, None] * S, u, axis=0)},
    ]
    a0 = np.zeros(k.shape[0])
    a0[0] = (np.arctan2(ey, ex) - 0.5 * (theta0 + theta1)) * np.pi / 2   # mean angle ~ chord
    fit = minimize(lambda a: energy(a), a0, jac=lambda a: 0.5 * (np.pi * k) ** 2 * a,
                   constraints=constraints, method="SLSQP",
                   options={"maxiter": 2000, "ftol": 1e-15})
    th = theta(fit.x)
    x = cumulative_trapezoid(np.cos(th), u, initial=0.0) * L
    y = cumulative_trapezoid(np.sin(th), u, initial=0.0) * L
    miss = np.hypot(x[-1] - ex, y[-1] - ey)
    if not fit.success or miss > 1e-6 * L:
        raise ValueError(f"no planar elastica found from angle {theta0:.3g} to {theta1:.3g} "
                         f"reaching ({ex:.6g}, {ey:.6g}) with length {L:.6g} "
                         f"(optimiser: {fit.message}; end missed by {miss:.3g})")
    un = np.linspace(0.0, 1.0, nodes)
    thn = np.interp(un, u, th)
    points = np.stack([np.interp(un, u, x), np.interp(un, u, y), np.zeros(nodes)], axis=1)
    points[-1, :2] = ex, ey
    tangents = np.stack([np.cos(thn), np.sin(thn), np.zeros(nodes)], axis=1)
    return points, tangents
