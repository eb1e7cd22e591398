"""h: bad input raises ValueError naming the parameter and its valid range."""
import numpy as np
import pytest

from knitfem import BeamModel, Rod, Section

SECTION = Section.circle(0.05, E=1e3)


@pytest.mark.parametrize("kwargs,match", [
    (dict(EA=-1.0, GA2=1, GA3=1, GJ=1, EI2=1, EI3=1), r"EA must be finite and in \(0, inf\)"),
    (dict(EA=1, GA2=1, GA3=1, GJ=0.0, EI2=1, EI3=1), r"GJ must be finite and in \(0, inf\)"),
    (dict(EA=1, GA2=1, GA3=1, GJ=1, EI2=np.nan, EI3=1), r"EI2 must be finite"),
    (dict(EA=1, GA2=1, GA3=1, GJ=1, EI2=1, EI3=1, line_density=-2), r"line_density .*\[0, inf\)"),
])
def test_section_rejects_nonpositive_or_nan_stiffness(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Section(**kwargs)


@pytest.mark.parametrize("call,match", [
    (lambda: Section.circle(-3.0, E=1.0), r"diameter must be finite and in \(0, inf\)"),
    (lambda: Section.circle(3.0, E=1.0, nu=0.7), r"nu \(Poisson ratio\) must be in \(-1, 0.5\]"),
    (lambda: Section.circle(3.0, E="soft"), r"E must be a real number"),
    (lambda: Section.circle(3.0, E=1.0, gj_over_ei=-1), r"gj_over_ei must be finite and in"),
])
def test_section_constructors_name_the_bad_parameter(call, match):
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.parametrize("call,match", [
    (lambda: Rod.straight((0, 0, 0), (1, 0, 0), -1.0, 4, SECTION),
     r"length must be finite and in \(0, inf\)"),
    (lambda: Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 0, SECTION),
     r"elements must be an integer in \[1, 10000000\]"),
    (lambda: Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 1.9832502212658972e+16, SECTION),
     r"elements must be an integer in \[1, 10000000\], got 1.98"),
    (lambda: Rod.straight((0, 0, np.nan), (1, 0, 0), 1.0, 4, SECTION), r"start must be finite"),
    (lambda: Rod.straight((0, 0, 0), (0, 0, 0), 1.0, 4, SECTION), r"direction must be a non-zero"),
    (lambda: Rod.from_centerline([[0, 0, 0], [1, np.nan, 0]], SECTION), r"points contains NaN"),
    (lambda: Rod.from_centerline([[0, 0], [1, 0]], SECTION), r"points must have shape \(n, 3\)"),
    (lambda: Rod.from_centerline([[0, 0, 0], [0, 0, 0]], SECTION), r"zero-length element"),
    (lambda: Rod.from_centerline([[0, 0, 0], [1, 0, 0]], SECTION, natural="bent"),
     r"natural must be"),
    (lambda: Rod.arc(-1.0, 1.0, 4, SECTION), r"radius must be finite and in \(0, inf\)"),
    (lambda: Rod.arc(1e200, 1.0, 4, SECTION), r"radius must be in \(0, 1e\+100\], got 1e\+200"),
    (lambda: Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 4, "steel"),
     r"section must be a knitfem Section"),
])
def test_rod_rejects_bad_geometry(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_rod_rejects_mismatched_array_shapes():
    rod = Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 4, SECTION)
    with pytest.raises(ValueError, match=r"kappa0 must have shape \(4, 3\)"):
        Rod(rod.s, rod.X, rod.Q, SECTION, rod.gamma0, np.zeros((5, 3)))
    with pytest.raises(ValueError, match=r"Q \(frames\) must be unit quaternions"):
        Rod(rod.s, rod.X, 2 * rod.Q, SECTION, rod.gamma0, rod.kappa0)


def model_with_rod():
    model = BeamModel()
    rod = model.add_rod(Rod.straight((0, 0, 0), (1, 0, 0), 1.0, 4, SECTION))
    return model, rod


def test_contradictory_supports_are_refused():
    model, rod = model_with_rod()
    model.clamp(rod, "end")
    with pytest.raises(ValueError, match=r"contradictory boundary conditions .* 'prescribe'"):
        model.prescribe(rod, "end", displacement=(0.1, 0, 0))
    model.clamp(rod, "end")                     # the same support twice is harmless


def test_load_on_a_supported_dof_is_refused():
    model, rod = model_with_rod()
    model.clamp(rod, "start")
    model.force(rod, "start", (1.0, 0, 0))
    with pytest.raises(ValueError, match=r"load acts on supported dof\(s\) \['ux'\]"):
        model.solve()


def test_unsupported_rod_is_refused_before_solving():
    model, rod = model_with_rod()
    model.force(rod, "end", (0, 1.0, 0))
    with pytest.raises(ValueError, match=r"rod 0 has no support"):
        model.solve()


@pytest.mark.parametrize("call,match", [
    (lambda m, r: m.clamp(r, "middle"), r"at must be 'start', 'end' or a node index in \[-5, 4\]"),
    (lambda m, r: m.clamp(3, "end"), r"rod must be an index in \[0, 0\]"),
    (lambda m, r: m.fix(r, "end", "uz wx"), r"dofs must be names from"),
    (lambda m, r: m.force(r, "end", (1.0, np.nan, 0)), r"force must be 3 finite numbers"),
    (lambda m, r: m.prescribe(r, "end"), r"prescribe needs displacement and/or rotation"),
])
def test_model_calls_name_the_bad_argument(call, match):
    model, rod = model_with_rod()
    with pytest.raises(ValueError, match=match):
        call(model, rod)


def test_planar_restriction_refuses_a_3d_layout():
    model = BeamModel()
    model.add_rod(Rod.straight((0, 0, 0), (1, 0, 1), 1.0, 4, SECTION))
    with pytest.raises(ValueError, match=r"restrict_to_plane: the layout is not in a plane"):
        model.restrict_to_plane()
