"""Section stiffnesses from geometry and material (closed forms)."""
import numpy as np
import pytest

from knitfem import Section


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.5])
def test_circle_section_follows_the_textbook_formulas(nu):
    d, E = 3.0, 2.0
    s = Section.circle(d, E, nu)
    A, I = np.pi * d**2 / 4, np.pi * d**4 / 64
    assert np.isclose(s.EA, E * A) and np.isclose(s.EI2, E * I) and np.isclose(s.EI3, E * I)
    assert np.isclose(s.GJ / s.EI2, 1 / (1 + nu))                   # J = 2 I, G = E/(2(1+nu))
    assert np.isclose(s.GA2, 6 * (1 + nu) / (7 + 6 * nu) * E / (2 * (1 + nu)) * A)   # Cowper
    assert s.radius == d / 2
    assert np.isclose(Section.circle(d, E, nu, gj_over_ei=0.25).GJ, 0.25 * E * I)


def test_rectangle_section_bends_about_the_right_axes_and_twists_like_saint_venant():
    s = Section.rectangle(width=2.0, height=1.0, E=12.0, nu=0.0)
    assert np.isclose(s.EI2, 12.0 * 2.0 * 1.0**3 / 12)             # about d2 (along the width)
    assert np.isclose(s.EI3, 12.0 * 1.0 * 2.0**3 / 12)
    square = Section.rectangle(1.0, 1.0, E=1.0, nu=0.0)
    assert abs(square.GJ / 0.5 - 0.1406) < 0.001                   # Saint-Venant: 0.1406 a^4
