"""The beam model against closed-form and published results (issue 2, a–e)."""
import numpy as np
import pytest

from knitfem.beam import BeamModel, Rod, Section
from knitfem.verify import cases, closed_form


def test_end_moment_rolls_cantilever_into_full_circle():
    """a: M = 2 pi EI/L, 16 elements: the tip returns to the root within 1e-6 L,
    its frame turned by 2 pi (quaternion -q, no singularity)."""
    model = cases.cantilever_end_moment(16, moment=2 * np.pi)
    steps = model.solve(loads=np.linspace(0.1, 1.0, 10))
    end = steps[-1].state
    assert np.linalg.norm(end.x[-1]) < 1e-6
    assert np.allclose(end.frames[-1], np.eye(3), atol=1e-9)
    assert np.allclose(end.q[-1], [-1, 0, 0, 0], atol=1e-9)


@pytest.mark.parametrize("moment", [np.pi, 0.5 * np.pi])
def test_end_moment_bends_cantilever_into_exact_arc(moment):
    """a: half (and quarter) circle: constant-strain states are exact for the
    helicoidal element, so every node lies on the exact arc.  Tolerance 1e-6 L:
    Newton stops at the round-off floor of the stiff section (EA L^2/EI = 1e8,
    relative residual ~1e-6); a midpoint-chord element is off by ~1e-3 L here."""
    model = cases.cantilever_end_moment(16, moment=moment)
    end = model.solve(loads=np.linspace(0.25, 1.0, 4))[-1].state
    s = np.linspace(0.0, 1.0, 17)
    exact = np.stack([np.sin(moment * s) / moment, (1 - np.cos(moment * s)) / moment], 1)
    assert np.max(np.abs(end.x[:, :2] - exact)) < 1e-6
    assert np.allclose(end.x[-1, :2], closed_form.end_moment_tip(moment), atol=1e-6)


@pytest.mark.parametrize("ends,exact,tol", [("clamped", 4 * np.pi**2, 5e-3),
                                           ("pinned", np.pi**2, 5e-3)])
def test_column_buckles_at_euler_load(ends, exact, tol):
    """b: critical load from the tangent's lowest eigenvalue, 32 elements, within
    0.5 % (discretisation error (pi h/L_eff)^2/12: 0.32 % clamped, 0.08 % pinned)."""
    crit = cases.critical_load(cases.column(32, ends), (0.8 * exact, 1.2 * exact))
    assert abs(crit.load / exact - 1) < tol


def test_column_buckling_load_converges_at_second_order():
    errors = [cases.critical_load(cases.column(n, "pinned"), (8, 12)).load / np.pi**2 - 1
              for n in (8, 16)]
    assert 3.8 < errors[0] / errors[1] < 4.2


def test_cantilever_elastica_under_tip_load_matches_elliptic_integrals():
    """c: P L^2/EI = 10, 64 elements: tip within 1e-4 L of Bisshopp–Drucker."""
    model = cases.cantilever_tip_load(64, alpha=10.0)
    end = model.solve(loads=np.linspace(0.1, 1.0, 10))[-1].state
    x, deflection, rotation = closed_form.elastica_tip_load(10.0)
    assert abs(x - 0.44500) < 1e-5 and abs(deflection - 0.81061) < 1e-5   # published values
    tip = end.x[-1]
    assert np.hypot(tip[0] - x, -tip[1] - deflection) < 1e-4


@pytest.fixture(scope="module")
def bend45_tips():
    tips = {}
    for n in (8, 32):
        model = cases.bend45(n)
        steps = model.solve(loads=[300.0, 450.0, 600.0])
        tips[n] = {s.load: cases.tip_position(model, s.state) for s in steps}
    return tips


@pytest.mark.parametrize("load", [300.0, 450.0, 600.0])
def test_45_degree_bend_matches_published_tip_positions(bend45_tips, load):
    """d: Bathe & Bolourchi 1979.  8 elements vs Simo & Vu-Quoc 1986 (8 one-point
    elements): within 0.15 (0.15 % of the radius).  32 elements vs the converged
    solution of the rod equations: within 0.015."""
    tip8, tip32 = bend45_tips[8][load], bend45_tips[32][load]
    assert np.max(np.abs(tip8 - closed_form.BEND45_SIMO_VU_QUOC_8[load])) < 0.15
    assert np.max(np.abs(tip32 - closed_form.BEND45_CONVERGED[load])) < 0.015


@pytest.mark.slow
def test_45_degree_bend_reference_is_the_rod_equations():
    """The tabulated converged values are reproduced by shooting the rod ODEs."""
    s = cases.BEND45_SECTION
    tip = closed_form.arc_tip_under_dead_load((0, 0, 600.0), 100.0, np.pi / 4, s.CN, s.CM)
    assert np.allclose(tip, closed_form.BEND45_CONVERGED[600.0], atol=1e-3)


def test_greenhill_torque_destabilises_clamped_shaft():
    """e: M L / EI = 2 x 4.4934 (tan x = x), 32 elements: within 0.1 %."""
    assert abs(closed_form.greenhill_clamped() - 2 * 4.4934) < 1e-4
    crit = cases.critical_load(cases.greenhill_shaft(32), (8.0, 10.0))
    assert abs(crit.load / closed_form.greenhill_clamped() - 1) < 1e-3


@pytest.mark.parametrize("slenderness", [10.0, 100.0, 1000.0])
def test_no_shear_locking_up_to_slenderness_1000(slenderness):
    """Tip deflection under a small tip load vs Timoshenko's closed form, 32
    elements, within 0.2 % from L/d = 10 to 1000 (a locking element loses
    orders of magnitude at L/d = 1000).  P L^2/EI = 1e-2: deflection 3e-3 L,
    nonlinear effects ~1e-5, still well above the force round-off of EA/h."""
    L = 1.0
    section = Section.circle(L / slenderness, E=1.0, nu=0.3)
    P = 1e-2 * section.EI3 / L**2
    model = cases.cantilever_tip_load(32, alpha=P * L**2 / section.EI3, section=section, L=L)
    end = model.solve(loads=[1.0])[-1].state
    exact = closed_form.timoshenko_cantilever_tip(P, L, section.EI3, section.GA2)
    assert abs(-end.x[-1, 1] / exact - 1) < 2e-3


# -- natural (intrinsic) curvature and twist ------------------------------------------------
# Stress-free shapes are constant-strain states, exact for the helicoidal element.  EA L^2/EI
# = 1e4 keeps the round-off floor of the residual at ~1e-11 EI/L (the relaxed shape carries no
# axial force, so it does not depend on EA).
NATURAL = Section(EA=1e4, GA2=1e4, GA3=1e4, GJ=0.7, EI2=1.0, EI3=1.0)


def natural_cantilever(elements, natural_curvature):
    """Rod of length 1 laid out straight along +x (d2 = y, d3 = z), clamped at
    x = 0, with natural (twist, k2, k3) = ``natural_curvature``."""
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, elements, NATURAL,
                                     natural_curvature=natural_curvature))
    model.clamp(rod, "start")
    return model


def relax(model):
    """Equilibrium of an unloaded model: its residual is measured against the
    bending force scale EI/L^2 (there is no load to compare with), so Newton
    converges to 1e-10 of it or to the round-off floor, after iterating."""
    step = model.solve(loads=[1.0])[-1]
    assert step.iterations >= 1 and (step.history[-1] <= 1e-10 or step.roundoff_limited)
    return step.state


def arc_nodes(curvature, s):
    """(x, y) of points at arclengths s on an arc from the origin along +x with
    signed curvature about +z (closed_form.end_moment_tip scaled to length s)."""
    return np.array([si * closed_form.end_moment_tip(curvature * si) for si in s])


@pytest.mark.parametrize("director", [1, 2])
def test_naturally_curved_rod_relaxes_to_its_circle(director):
    """Natural curvature 3 pi/2 about d2 (bends toward -z) or d3 (toward +y), laid
    out straight, clamped, free: three quarters of a circle of radius 2/(3 pi),
    every node within 1e-8 L of the exact arc (measured 2e-12 and 6e-12)."""
    k = 1.5 * np.pi
    end = relax(natural_cantilever(16, np.eye(3)[director] * k))
    s = np.linspace(0.0, 1.0, 17)
    sign = -1.0 if director == 1 else 1.0              # about d2 = y, x turns toward -z
    exact = arc_nodes(k, s) * [1.0, sign]
    planar = end.x[:, [0, 2]] if director == 1 else end.x[:, :2]
    assert np.max(np.abs(planar - exact)) < 1e-8
    assert np.max(np.abs(end.x[:, 2 if director == 2 else 1])) < 1e-12


@pytest.mark.parametrize("twist", [2.5, 7.0])
def test_naturally_twisted_rod_untwists_about_a_straight_axis(twist):
    """Natural twist tau L = 2.5 and 7 (beyond 2 pi), laid out untwisted,
    clamped, free: each frame turns by tau s about the axis, within 1e-10 rad
    at every node (measured 6e-15); the axis stays on x within 1e-12 L."""
    end = relax(natural_cantilever(16, (twist, 0.0, 0.0)))
    s = np.linspace(0.0, 1.0, 17)
    d2 = end.frames[:, :, 1]
    turn = np.arctan2(d2[:, 2], d2[:, 1])
    error = np.angle(np.exp(1j * (turn - twist * s)))   # wrapped to (-pi, pi]
    assert np.max(np.abs(error)) < 1e-10
    assert np.allclose(end.frames[:, :, 0], [1, 0, 0], atol=1e-12)
    assert np.allclose(end.x, np.c_[s, np.zeros((17, 2))], rtol=0, atol=1e-12)


@pytest.mark.parametrize("moment", [0.5 * np.pi, -0.5 * np.pi])
def test_end_moment_adds_to_natural_curvature(moment):
    """Natural curvature pi/2 about d3 plus an end moment M about z, M L/EI =
    +-pi/2: an arc of curvature kappa0 + M/EI (a half circle, or straight again),
    every node within 1e-8 L (measured 5e-12)."""
    model = natural_cantilever(16, (0.0, 0.0, 0.5 * np.pi))
    model.moment(0, "end", (0.0, 0.0, moment * NATURAL.EI3))
    end = model.solve(loads=[0.5, 1.0])[-1].state
    s = np.linspace(0.0, 1.0, 17)
    assert np.max(np.abs(end.x[:, :2] - arc_nodes(0.5 * np.pi + moment, s))) < 1e-8
    assert np.max(np.abs(end.x[:, 2])) < 1e-12
