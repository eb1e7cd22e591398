"""The beam model against closed-form and published results (issue 2, a–e)."""
import numpy as np
import pytest

from knitfem.beam import Section
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
