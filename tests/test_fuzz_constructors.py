"""Property-based fuzzing of the public constructors (hypothesis): any argument
gives an object with finite numbers or a ValueError naming the parameter -
never another exception type or a NaN.  Each example starts from plausible
values and replaces none, one (then the message must name it) or several of
them by odd ones.  Sizes are kept small."""
import math
import resource

from hypothesis import HealthCheck, given, settings, strategies as st
import numpy as np
import pytest

from knitfem import Rod, Section
from knitfem.geometry import plain_knit_swatch
from knitfem.scenes.srod import SRod, popup

FUZZ = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow])
ODD = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                st.sampled_from([0.0, -0.0, -1.0, 1e-300, 1e300, -1e300, 2.5, float("nan"),
                                 float("inf"), "x", "1", None, True, [1.0], ()]),
                st.integers(-10**6, 10**6))
SMALL_ODD = st.one_of(st.sampled_from([0, -1, 2.5, 7.5, float("nan"), float("inf"), "x", "8",
                                        None, True, 1e-300, -0.0]), st.integers(-10, 100))
VEC = st.lists(st.floats(-10, 10), min_size=3, max_size=3)


@pytest.fixture(autouse=True, scope="module")
def address_space_limit():
    """A MemoryError instead of the kernel's OOM killer if a constructor asks for
    too much (the machine is shared): at most 8 GiB of address space beyond
    what the process already maps (earlier tests' thread pools and Dask
    clusters leave several GiB mapped; an absolute 8 GiB failed everything)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    with open("/proc/self/statm") as f:
        mapped = int(f.read().split()[0]) * resource.getpagesize()
    limit = mapped + 8 * 2**30
    resource.setrlimit(resource.RLIMIT_AS, (limit if hard == resource.RLIM_INFINITY
                                            else min(limit, hard), hard))
    yield
    resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


@st.composite
def arguments(draw, plausible, odd_values=ODD):
    """(kwargs, the one odd name or None): plausible values, then 0, 1 or
    several replaced by odd ones."""
    values = {k: draw(s) for k, s in plausible.items()}
    mode = draw(st.sampled_from(["plausible", "one odd", "several odd"]))
    odd = None
    if mode == "one odd":
        odd = draw(st.sampled_from(sorted(values)))
        values[odd] = draw(odd_values)
    elif mode == "several odd":
        for k in sorted(values):
            if draw(st.booleans()):
                values[k] = draw(odd_values)
    return values, odd


def outcome(call, args, names):
    """The object, or None after a one-line ValueError that names a parameter
    (the odd one, when only one was replaced)."""
    kwargs, odd = args
    try:
        return call(**kwargs)

    except ValueError as err:
        text = str(err)
        assert "\n" not in text.strip(), text
        wanted = [names[odd]] if odd is not None else list(names.values())
        assert any(w in text for w in wanted), (kwargs, odd, text)
        return None


def finite(*values):
    return all(np.all(np.isfinite(np.asarray(v, float))) for v in values)


POSITIVE = st.floats(0.1, 10.0)
SECTION_NAMES = {k: k for k in ("EA", "GA2", "GA3", "GJ", "EI2", "EI3", "radius",
                                "line_density")}


@FUZZ
@given(args=arguments({**{k: POSITIVE for k in ("EA", "GA2", "GA3", "GJ", "EI2", "EI3")},
                       "radius": POSITIVE, "line_density": st.floats(0, 1)}))
def test_section_gives_finite_stiffness_or_names_the_parameter(args):
    s = outcome(Section, args, SECTION_NAMES)
    if s is not None:
        assert finite(s.CN, s.CM) and np.all(s.CN > 0) and np.all(s.CM > 0)


@FUZZ
@given(args=arguments({"diameter": POSITIVE, "E": POSITIVE, "nu": st.floats(-0.9, 0.5),
                       "density": st.floats(0, 2)}))
def test_section_circle_gives_finite_stiffness_or_names_the_parameter(args):
    names = {"diameter": "diameter", "E": "E must", "nu": "nu (Poisson", "density": "density"}
    # E d^4 beyond the floating-point range: named through the stiffness it gives
    names = {k: v for k, v in names.items()}
    s = outcome(Section.circle, args, names | {"": "EA"})
    if s is not None:
        assert finite(s.CN, s.CM) and np.all(s.CN > 0) and np.all(s.CM > 0)


SECTION = Section.circle(1.0, E=1.0)


def straight(start, direction, length, elements):
    return Rod.straight(start, direction, length, elements, SECTION)


@FUZZ
@given(args=arguments({"start": VEC, "direction": VEC.filter(lambda v: any(v)),
                       "length": POSITIVE, "elements": st.integers(1, 20)}))
def test_rod_straight_gives_a_finite_rod_or_names_the_parameter(args):
    rod = outcome(straight, args, {k: k for k in ("start", "direction", "length", "elements")})
    if rod is not None:
        assert finite(rod.X, rod.Q, rod.s) and np.allclose(np.linalg.norm(rod.Q, axis=1), 1)


def arc(radius, angle, elements):
    return Rod.arc(radius, angle, elements, SECTION)


@FUZZ
@given(args=arguments({"radius": POSITIVE, "angle": st.floats(0.01, 6.0),
                       "elements": st.integers(2, 20)}))
def test_rod_arc_gives_a_finite_rod_or_names_the_parameter(args):
    rod = outcome(arc, args, {"radius": "radius", "angle": "angle", "elements": "elements"})
    if rod is not None:
        assert finite(rod.X, rod.Q, rod.kappa0)


@settings(max_examples=40, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(args=arguments({"n_wale": st.integers(1, 3), "n_course": st.integers(1, 3),
                       "w": st.floats(2.0, 6.0), "c": st.floats(1.5, 4.0),
                       "radius": st.floats(0.1, 0.5), "points_per_loop": st.integers(8, 24),
                       "bindoff": st.booleans()}, SMALL_ODD))
def test_plain_knit_swatch_gives_finite_yarns_or_names_the_parameter(args):
    kwargs, odd = args
    r, w = kwargs["radius"], kwargs["w"]
    if isinstance(r, float) and isinstance(w, float) and 0 < r < w / 100:
        return     # valid but slow and big (the loop solve grows like (w/r)^2): the CLI checks it
    names = {k: k for k in kwargs} | {"bindoff": "bindoff"}
    swatch = outcome(plain_knit_swatch, args, names)
    if swatch is not None:
        assert all(finite(y.points, y.tangents) for y in swatch.yarns)


@FUZZ
@given(args=arguments({"length": st.floats(50, 200), "w": st.floats(5, 40),
                       "diameter": st.floats(0.5, 5), "E": POSITIVE,
                       "poisson": st.floats(-0.5, 0.5), "elements": st.integers(4, 20),
                       "start_angle": st.floats(-1, 1)}))
def test_srod_gives_a_scene_or_names_the_parameter(args):
    names = {k: k for k in args[0]} | {"E": "E must", "poisson": "Poisson"}
    srod = outcome(SRod, args, names)
    if srod is not None:
        assert math.isfinite(srod.c_max) and 0 < srod.c_max < srod.length
        assert math.isfinite(srod.gj_ei) and srod.gj_ei > 0


SROD = SRod(elements=6)


def srod_popup(c_from, c_to, c_step):
    return popup(SROD, c_from, c_to, c_step)


@settings(max_examples=20, deadline=None, derandomize=True, database=None)
@given(args=arguments({"c_from": st.floats(0.85, 0.95), "c_to": st.floats(0.6, 0.8),
                       "c_step": st.floats(0.05, 0.3)}))
def test_popup_options_give_a_branch_or_name_the_parameter(args):
    kwargs, _ = args
    step = kwargs["c_step"]
    if isinstance(step, (int, float)) and not isinstance(step, bool) and 0 < step < 0.02 and \
            isinstance(kwargs["c_from"], float) and isinstance(kwargs["c_to"], float):
        return                                  # many samples are slow, not wrong
    result = outcome(srod_popup, args, {k: k for k in kwargs})
    if result is not None:
        assert all(math.isfinite(s.max_abs_z_over_L) for s in result.samples)
