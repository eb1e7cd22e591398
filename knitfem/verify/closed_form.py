"""Closed-form and published reference results the beam model is checked against.

Lengths are fractions of the rod length L unless stated; loads are in the
dimensionless forms the literature uses (P L^2 / EI, M L / EI).
"""
import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc


def end_moment_tip(moment_over_ei_per_l):
    """Tip (x, y)/L of an inextensible, unshearable cantilever along +x under an
    end moment M about +z, m = M L / EI: an arc of curvature m / L."""
    m = float(moment_over_ei_per_l)
    if m == 0:
        return np.array([1.0, 0.0])
    return np.array([np.sin(m) / m, (1.0 - np.cos(m)) / m])


def elastica_tip_load(alpha):
    """Inextensible cantilever elastica under a dead tip load perpendicular to its
    undeformed axis, alpha = P L^2 / EI (Bisshopp & Drucker 1945).

    Returns (x_tip/L, deflection/L, tip rotation in rad)."""
    a = float(alpha)
    if a <= 0:
        raise ValueError(f"alpha = P L^2/EI must be positive, got {alpha!r}")

    def k2_phi(theta):
        k2 = 0.5 * (1.0 + np.sin(theta))
        return k2, np.arcsin(1.0 / np.sqrt(2.0 * k2))

    def mismatch(theta):
        k2, phi = k2_phi(theta)
        return ellipk(k2) - ellipkinc(phi, k2) - np.sqrt(a)

    theta = brentq(mismatch, 1e-12, 0.5 * np.pi - 1e-13, xtol=1e-15)
    k2, phi = k2_phi(theta)
    deflection = 1.0 - 2.0 / np.sqrt(a) * (ellipe(k2) - ellipeinc(phi, k2))
    return np.sqrt(2.0 * np.sin(theta) / a), deflection, theta


def extensible_elastica_tip(alpha, EA, GA, EI=1.0):
    """Tip (x, y) of a cantilever (L = 1, along +x) under a dead tip force
    -alpha EI along y, extensible (EA) and shearable (GA): the planar rod
    equations shot on the root moment to 1e-12, on the branch nearest the
    inextensible elastica (Bisshopp & Drucker).  Reference of the stress table
    (studies/stress_cases.py) and of the thick-rod tests."""
    P = alpha * EI
    F = np.array([0.0, -P])

    def rhs(_, y):
        th, m = y[2], y[3]
        c, s = np.cos(th), np.sin(th)
        N, V = F[0] * c + F[1] * s, -F[0] * s + F[1] * c
        dx = (1 + N / EA) * np.array([c, s]) + V / GA * np.array([-s, c])
        return [dx[0], dx[1], m / EI, -(dx[0] * F[1] - dx[1] * F[0])]

    def shoot(m0):
        return solve_ivp(rhs, [0, 1], [0, 0, 0, m0], rtol=1e-12, atol=1e-13,
                         method="DOP853").y[:, -1]

    x0, _, _ = elastica_tip_load(alpha)
    guess = -P * x0                      # root moment of the inextensible elastica
    for width in (0.1, 0.2, 0.4):       # the nearest bracket: thick rods stretch and shear
        lo, hi = sorted((guess * (1 - width), guess * (1 + width)))
        if shoot(lo)[3] * shoot(hi)[3] < 0:
            break
    else:
        raise ValueError(f"no root moment within 40 % of the elastica's (alpha = {alpha}, "
                         f"EA = {EA}, GA = {GA}): the rod is too soft for this reference")
    m0 = brentq(lambda m: shoot(m)[3], lo, hi, xtol=1e-14, rtol=1e-14)
    return shoot(m0)[:2]


def greenhill_clamped():
    """Critical axial torque of a clamped-clamped shaft, M L / EI = 2 x, with x the
    first positive root of tan x = x (Greenhill 1883; Ziegler 1977)."""
    x = brentq(lambda t: np.tan(t) - t, np.pi + 1e-9, 1.5 * np.pi - 1e-9, xtol=1e-15)
    return 2.0 * x


def timoshenko_cantilever_tip(P, L, EI, kGA):
    """Small tip deflection of a Timoshenko cantilever under a tip load P."""
    return P * L**3 / (3.0 * EI) + P * L / kGA


# Tip positions of the 45-degree bend (Bathe & Bolourchi 1979): arc of radius
# 100 from (0, 0, 0) along +x bending toward +y, unit square section, E = 1e7,
# G = 5e6, J = 1/6 (polar, as in most codes), dead tip load F along +z.
BEND45_SIMO_VU_QUOC_8 = {   # Simo & Vu-Quoc 1986, Ex. 7.5, 8 one-point elements
    300.0: (58.84, 22.33, 40.08),
    450.0: (52.32, 18.62, 48.39),
    600.0: (47.23, 15.79, 53.37),
}
BEND45_CONVERGED = {        # shooting solution of the Kirchhoff–Love-Cosserat ODEs
    300.0: (58.779, 22.245, 40.192),   # (agrees with AeroBeams.jl, 16 elements:
    450.0: (52.239, 18.508, 48.503),   #  (47.166, 15.712, 53.458) at F = 600)
    600.0: (47.150, 15.685, 53.475),
}


def arc_tip_under_dead_load(force, radius, angle, CN, CM):
    """Tip position of a clamped circular arc (start (0,0,0), tangent +x, bending
    toward +y) under a dead tip force, from the Simo–Reissner rod equations
    integrated to tolerance 1e-12 and shot on the unknown root moment.

    Discretisation-free reference for the 45-degree bend.  CN = (EA, GA2, GA3),
    CM = (GJ, EI2, EI3).
    """
    from scipy.optimize import fsolve

    F = np.asarray(force, dtype=float)
    CN, CM = np.asarray(CN, float), np.asarray(CM, float)
    kappa0 = np.array([0.0, 0.0, 1.0 / radius])
    length = radius * angle

    def rhs(_, y):
        R = y[3:12].reshape(3, 3)
        gamma = np.array([1.0, 0.0, 0.0]) + R.T @ F / CN        # n(s) = F everywhere
        kappa = kappa0 + R.T @ y[12:15] / CM
        dx = R @ gamma
        k = kappa
        dR = R @ np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        return np.concatenate([dx, dR.ravel(), -np.cross(dx, F)])

    def shoot(m0):
        y0 = np.concatenate([np.zeros(3), np.eye(3).ravel(), m0])
        return solve_ivp(rhs, [0.0, length], y0, rtol=1e-12, atol=1e-12, method="DOP853")

    tip0 = radius * np.array([np.sin(angle), 1.0 - np.cos(angle), 0.0])
    m0 = fsolve(lambda m: shoot(m).y[12:15, -1], np.cross(tip0, F), xtol=1e-13)
    return shoot(m0).y[0:3, -1]
