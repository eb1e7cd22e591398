"""The verification scenes: each builds a :class:`BeamModel` of a problem with a
closed-form or published answer.  Used by the tests, the gallery and the
benchmarks, so all three solve the very same problems.

Rods of length L = 1 and bending stiffness EI = 1 unless stated; "stiff"
sections take EA = GA = 1e8 EI / L^2 so that the inextensible, unshearable
closed forms apply to within 1e-7.
"""
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from ..beam import BeamModel, Rod, Section
from ..solve.stability import lowest_eigenvalues
from . import closed_form

STIFF = 1e8


def stiff_section(EI=1.0, GJ=1.0, L=1.0):
    k = STIFF * EI / L**2
    return Section(EA=k, GA2=k, GA3=k, GJ=GJ, EI2=EI, EI3=EI)


def cantilever_end_moment(elements, moment=2 * np.pi, section=None):
    """Cantilever along +x (L = 1), clamped at x = 0, end moment about z with
    M L/EI = ``moment``."""
    section = stiff_section() if section is None else section
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, elements, section))
    model.clamp(rod, "start")
    model.moment(rod, "end", (0.0, 0.0, moment * section.EI3))
    return model


def cantilever_tip_load(elements, alpha=10.0, section=None, L=1.0):
    """Cantilever along +x under a dead tip load -alpha EI/L^2 along y."""
    section = stiff_section(L=L) if section is None else section
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), L, elements, section))
    model.clamp(rod, "start")
    model.force(rod, "end", (0.0, -alpha * section.EI3 / L**2, 0.0))
    return model


def column(elements, ends="clamped"):
    """Column along +x under a unit compressive end force; the loaded end slides
    axially.  ``ends``: 'clamped' (both ends clamped) or 'pinned' (both pinned,
    twist held at the base)."""
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, elements, stiff_section()))
    if ends == "clamped":
        model.clamp(rod, "start")
        model.fix(rod, "end", "uy uz rx ry rz")
    elif ends == "pinned":
        model.fix(rod, "start", "ux uy uz rx")
        model.fix(rod, "end", "uy uz")
    else:
        raise ValueError(f"ends must be 'clamped' or 'pinned', got {ends!r}")
    model.force(rod, "end", (-1.0, 0.0, 0.0))
    return model


def greenhill_shaft(elements, gj=1.0):
    """Shaft along +x clamped at both ends except the twist of the far end,
    which carries a unit axial torque (the end may slide axially)."""
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, elements,
                                     stiff_section(GJ=gj)))
    model.clamp(rod, "start")
    model.fix(rod, "end", "uy uz ry rz")
    model.moment(rod, "end", (1.0, 0.0, 0.0))
    return model


BEND45_SECTION = Section(EA=1e7, GA2=5e6, GA3=5e6, GJ=5e6 / 6.0, EI2=1e7 / 12.0,
                         EI3=1e7 / 12.0)


def bend45(elements):
    """45-degree bend (Bathe & Bolourchi 1979): arc of radius 100 clamped at
    the origin, unit tip load along +z (scale with the load factor)."""
    model = BeamModel()
    rod = model.add_rod(Rod.arc(100.0, np.pi / 4, elements, BEND45_SECTION))
    model.clamp(rod, "start")
    model.force(rod, "end", (0.0, 0.0, 1.0))
    return model


@dataclass
class CriticalLoad:
    load: float          # load factor where the lowest eigenvalue crosses zero
    evaluations: int     # equilibria solved to find it


def critical_load(model, bracket, *, xtol=1e-10):
    """Load factor at which the lowest eigenvalue of the tangent on the
    fundamental (prebuckling) path crosses zero, by Brent's method on
    lambda_min(lam); each evaluation solves the equilibrium at lam by Newton
    from the nearest equilibrium found so far."""
    lo, hi = bracket
    known = {0.0: model.initial_state()}
    count = [0]

    def lowest(lam):
        start_lam = min(known, key=lambda k: abs(k - lam))
        steps = model.solve(loads=[lam], state=known[start_lam], start=start_lam)
        known[lam] = steps[-1].state
        count[0] += 1
        K = model.internal_forces(steps[-1].state, free=~model.fixed)[2]
        return lowest_eigenvalues(K, 1)[0]

    # walk up to the bracket so the fundamental path is followed, not jumped
    for lam in np.linspace(0.0, lo, 5)[1:]:
        lowest(lam)
    load = brentq(lowest, lo, hi, xtol=xtol)
    return CriticalLoad(load, count[0])


def tip_position(model, state, rod=0):
    return state.x[model.node(rod, "end")]


__all__ = ["cantilever_end_moment", "cantilever_tip_load", "column", "greenhill_shaft",
           "bend45", "critical_load", "closed_form", "tip_position", "stiff_section"]


def yarn_on_yarn(line_load, factor=None, diameter=1.0, E=1e3):
    """A yarn (length 9.5, 17 elements) lying on a parallel clamped yarn
    (length 10, 13 elements: non-matching meshes), pressed by a uniform line
    load (its weight under a matching gravity), free only to move down and
    bend; penalty contact with ``factor`` (default the library's).  It starts
    inside the law's reach (gap 0.049 d < g0), so there is no free fall."""
    section = Section.circle(diameter, E=E, nu=0.3, density=1.0)
    model = BeamModel()
    base = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 10.0, 13, section))
    top = model.add_rod(Rod.straight((0.25, 0, diameter * 1.049), (1, 0, 0), 9.5, 17, section))
    for i in range(14):
        model.clamp(base, i)
    for i in range(18):
        model.fix(top, i, "ux uy rx rz")
    model.gravity((0, 0, -line_load / section.line_density))
    model.contact(**({} if factor is None else {"factor": factor}))
    return model


def crossed_beams(push, factor=None, elements=40, E=1e4, diameter=1.0):
    """Beam A along x and beam B along y (length 10), both clamped-clamped, B
    starting above A (gap 0.06, beyond the law's reach) and its ends pushed
    down by ``push``; penalty contact with ``factor`` (default the library's).
    The crossing lies off the nodes of both beams: where a slave Gauss point
    faces a master node exactly, the energy is only C1 in that node (the master
    polyline may kink there) and Newton slows down."""
    section = Section.circle(diameter, E=E, nu=0.3)
    model = BeamModel()
    a = model.add_rod(Rod.straight((-5, 0, 0), (1, 0, 0), 10.0, elements, section))
    b = model.add_rod(Rod.straight((0.07, -5.05, diameter + 0.06), (0, 1, 0), 10.0, elements,
                                   section))
    model.clamp(a, "start")
    model.clamp(a, "end")
    for end in ("start", "end"):
        model.prescribe(b, end, displacement=(0, 0, -push), rotation=(0, 0, 0))
    model.contact(**({} if factor is None else {"factor": factor}))
    return model
