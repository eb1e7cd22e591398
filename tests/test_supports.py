"""Pinned supports (``BeamModel.pin``): the position is held, the frame turns freely."""
import numpy as np
import pytest

from knitfem import BeamModel, Rod, Section
from knitfem.beam.rotation import rotation_vector
from knitfem.verify import cases

L = 1.0


def pinned_column(elements):
    """Column along +x under a unit compressive end force: pinned base (its twist
    held by an extra ``fix`` on the same node), roller top (uy uz only; a pin
    there would take the axial load itself, see below)."""
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), L, elements, cases.stiff_section()))
    model.pin(rod, "start")
    model.fix(rod, "start", "rx")
    model.fix(rod, "end", "uy uz")
    model.force(rod, "end", (-1.0, 0.0, 0.0))
    return model


def simply_supported(elements, far_end, force, section):
    """Beam along +x pinned at x = 0 (twist held there), a pin or a roller at x = L,
    a transverse force -force along y at midspan (``elements`` even)."""
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), L, elements, section))
    model.pin(rod, "start")
    model.fix(rod, "start", "rx")
    if far_end == "pin":
        model.pin(rod, "end")
    else:
        model.fix(rod, "end", "uy uz")
    model.force(rod, elements // 2, (0.0, -force, 0.0))
    return model


def test_pin_and_fix_combine_on_one_node():
    """pin (ux uy uz) and fix rx on one node merge into one support; the same pin
    twice is accepted, a clamp on top of it is refused (each dof takes one support)."""
    model = pinned_column(4)
    assert np.array_equal(model.fixed[:6], [True, True, True, True, False, False])
    assert np.array_equal(model.fixed, cases.column(4, "pinned").fixed)
    with pytest.raises(ValueError, match="contradictory boundary conditions"):
        model.clamp(0, "start")
    again = BeamModel([model.rods[0]])
    assert again.pin(0, "end") == again.pin(0, "end")


def test_pin_at_the_loaded_end_of_a_column_is_refused():
    """A pin holds ux, so it would absorb an axial end force: the column's loaded
    end must be a roller (fix uy uz)."""
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), L, 4, cases.stiff_section()))
    model.pin(rod, "start")
    model.pin(rod, "end")
    model.force(rod, "end", (-1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"supported dof\(s\) \['ux'\]"):
        model.solve()


def test_pinned_column_buckles_at_euler_load():
    """pi^2 EI/L^2 from the tangent's lowest eigenvalue, 32 elements, within 0.5 %
    (discretisation error (pi h/L)^2/12 = 0.08 %)."""
    exact = np.pi**2
    crit = cases.critical_load(pinned_column(32), (0.8 * exact, 1.2 * exact))
    assert abs(crit.load / exact - 1) < 5e-3


@pytest.mark.parametrize("far_end", ["pin", "roller"])
def test_pinned_ends_of_a_simply_supported_beam_turn_by_the_closed_form(far_end):
    """Midspan force F, F L^2/EI = 1.6e-3, 16 elements, L/d = 50 (nu = 0.3).

    End frames turn by -+F L^2/(16 EI) about z within 0.1 %: the section rotation
    of a Timoshenko beam integrates M/EI from midspan, where it vanishes by
    symmetry, so shear does not enter it; the elements' one-point curvature
    integrates the linear moment exactly (measured 2e-12 with the roller).  Pinned
    at both ends the axis must stretch by 0.27 L (F L^2/16 EI)^2: the tension
    N L^2/EI = 1.1e-4 stiffens the beam by N L^2/(pi^2 EI) = 1.1e-5 (measured).
    Midspan deflection F L^3/(48 EI) + F L/(4 kGA) within 1 % (discretisation
    error (h/L)^2 = 0.39 %)."""
    section = Section.circle(L / 50, E=1.0, nu=0.3)
    F = 1.6e-3 * section.EI3 / L**2
    model = simply_supported(16, far_end, F, section)
    end = model.solve(loads=[1.0])[-1].state
    turn = rotation_vector(end.q[[0, -1]])
    exact = F * L**2 / (16 * section.EI3)
    assert np.allclose(turn[:, 2] / exact, [-1.0, 1.0], rtol=0, atol=1e-3)
    assert np.allclose(turn[:, :2], 0.0, atol=1e-12 * exact)
    held = [0, -1] if far_end == "pin" else [0]           # pinned nodes stay put
    assert np.array_equal(end.x[held], model.initial_state().x[held])
    deflection = F * L**3 / (48 * section.EI3) + F * L / (4 * section.GA2)
    assert abs(-end.x[8, 1] / deflection - 1) < 1e-2
