"""Property-based fuzzing of the command line (hypothesis): every argument list
gives a result or one line naming the bad option (exit 2) - never a
traceback, a NaN in the output or a hang.  Problems are kept tiny (the
run-time limit is lowered to 2 s, so anything bigger is refused by the
cost check, which is itself a refusal naming the options)."""
import argparse
from contextlib import redirect_stderr, redirect_stdout
import io
import json
import math
import signal

from hypothesis import HealthCheck, given, settings, strategies as st
import pytest

from knitfem import options
from knitfem.cli import main
from knitfem.scenes import knit as knit_command
from knitfem.scenes import curl_command, popup_command

FUZZ = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])
ODD = ["nan", "NaN", "inf", "-inf", "0", "-0", "-1", "1", "2", "0.5", "1e300", "-1e300",
       "1e-300", "1e-7", "3.5", "4", "8", "64", "1e6", "abc", "", " ", "1e", "0x10", "1_0",
       "--quiet", "١"]
VALUES = st.one_of(st.sampled_from(ODD), st.floats(allow_nan=True, allow_infinity=True).map(repr),
                   st.integers(-10**12, 10**12).map(str), st.floats(0.01, 1.0).map(repr))


def near_default(option_set, flag):
    """Values around the option's default (x 0.5 ... 1.5): mostly valid input."""
    spec = next(s for s in option_set.numbers if s.flag == flag)
    default = spec.default if not callable(spec.default) and spec.default is not None else 1.0
    values = st.floats(0.5, 1.5).map(lambda f: f * default)
    return values.map(lambda x: str(max(1, round(x)))) if spec.kind == "an integer" \
        else values.map(repr)


def pairs(option_set, flags):
    """(flag, text) with text odd or near the default, half and half."""
    return st.sampled_from(flags).flatmap(
        lambda f: st.tuples(st.just(f), st.one_of(VALUES, near_default(option_set, f))))


class Hang(Exception):
    pass


def run(argv, seconds=240):
    """main(argv) with stdout / stderr captured and a watchdog (SIGALRM).

    The watchdog catches a hang, not a slow answer: a first call may compile
    numba kernels (~1 min on a loaded 2-core machine tripped the former 60 s)."""
    def alarm(signum, frame):
        raise Hang(f"no answer in {seconds} s: {argv}")
    out, err = io.StringIO(), io.StringIO()
    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    try:
        with redirect_stdout(out), redirect_stderr(err):
            code = main(argv)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(autouse=True)
def small_limits(monkeypatch):
    monkeypatch.setattr(options, "TIME_LIMIT", 2.0)
    monkeypatch.setattr(options, "memory_limit", lambda: 2.0**30)


def own_refusal(option_set, flag, text):
    """The message the option's own range check gives for ``text``, or None."""
    spec = next((s for s in option_set.numbers if s.flag == flag), None)
    if spec is None:
        return None
    try:
        spec.check(spec.parse(text))
    except ValueError as err:
        return str(err) if isinstance(err, options.OptionError) else f"argument {flag}"
    return None


def check_answer(command, code, out, err, json_path=None, flags=()):
    assert "Traceback" not in err and "Traceback" not in out
    assert code in (0, 2, 3), (code, err)
    if code != 0:
        lines = err.strip().splitlines()
        assert len(lines) == 1, err
        assert lines[0].startswith(f"knitfem {command}: "), err
        if code == 2:
            assert any(f in lines[0] for f in flags) or "--" in lines[0] or \
                "argument" in lines[0], err
        return
    if json_path is not None and json_path.exists():
        def no_constant(name):
            raise AssertionError(f"{name} in the JSON output")
        summary = json.loads(json_path.read_text(), parse_constant=no_constant)
        for row in summary.get("branch", []):
            assert math.isfinite(row["max_abs_z_over_L"]), row


POPUP_BASE = ["popup", "--elements", "6", "--c-from", "0.9", "--c-to", "0.8", "--c-step", "0.1",
              "--quiet"]
POPUP_FLAGS = [s.flag for s in popup_command.OPTIONS.numbers]


@FUZZ
@given(pair=pairs(popup_command.OPTIONS, POPUP_FLAGS))
def test_popup_one_option_any_value(pair, tmp_path):
    flag, text = pair
    js = tmp_path / "s.json"
    code, out, err = run(POPUP_BASE + ["--json", str(js), flag, text])
    check_answer("popup", code, out, err, js, [flag])
    expected = own_refusal(popup_command.OPTIONS, flag, text)
    if expected is not None:
        assert code == 2 and flag in err, (flag, text, err)


@FUZZ
@given(chosen=st.lists(pairs(popup_command.OPTIONS, POPUP_FLAGS), max_size=4).map(dict),
       model=st.sampled_from([[], ["--model", "bspline"], ["--relax", "dynamic"],
                              ["--model", "bspline", "--relax", "static"]]))
def test_popup_option_combinations(chosen, model, tmp_path):
    argv = list(POPUP_BASE) + model
    for flag, text in chosen.items():
        argv += [flag, text]
    js = tmp_path / "s.json"
    code, out, err = run(argv + ["--json", str(js)])
    check_answer("popup", code, out, err, js, list(chosen))


KNIT_BASE = ["knit", "--nw", "2", "--nc", "2", "--quiet"]
KNIT_FLAGS = [s.flag for s in knit_command.OPTIONS.numbers]


@FUZZ
@given(chosen=st.lists(pairs(knit_command.OPTIONS, KNIT_FLAGS), min_size=1, max_size=4).map(dict),
       check=st.booleans())
def test_knit_option_combinations(chosen, check, tmp_path):
    argv = list(KNIT_BASE) + (["--check"] if check else [])
    for flag, text in chosen.items():
        argv += [flag, text]
    js = tmp_path / "k.json"
    code, out, err = run(argv + ["--json", str(js)])
    check_answer("knit", code, out, err, js, list(chosen))
    if len(chosen) == 1:
        (flag, text), = chosen.items()
        if own_refusal(knit_command.OPTIONS, flag, text) is not None:
            assert code == 2 and flag in err, (flag, text, err)


CURL_BASE = ["curl", "--nw", "3", "--nc", "4", "--quiet"]
CURL_FLAGS = [s.flag for s in curl_command.OPTIONS.numbers]


@FUZZ
@given(chosen=st.lists(pairs(curl_command.OPTIONS, CURL_FLAGS), min_size=1, max_size=4).map(dict),
       model=st.sampled_from([[], ["--model", "bspline"]]))
def test_curl_option_combinations(chosen, model, tmp_path, monkeypatch):
    """Validation only (a relaxation takes minutes: the run is a stub): every
    combination is accepted or refused in one line naming an option; a lone
    value outside its own range is refused naming that option."""
    monkeypatch.setattr(curl_command, "run", lambda args: 0)
    argv = list(CURL_BASE) + model
    for flag, text in chosen.items():
        argv += [flag, text]
    code, out, err = run(argv, seconds=30)
    check_answer("curl", code, out, err, None, list(chosen))
    if len(chosen) == 1:
        (flag, text), = chosen.items()
        if own_refusal(curl_command.OPTIONS, flag, text) is not None:
            assert code == 2 and flag in err, (flag, text, err)


@settings(max_examples=30, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(command=st.sampled_from(["popup", "knit", "gallery"]),
       target=st.sampled_from(["/dev/null", "/dev/full", "/proc/knitfem/x", "FILE", "DIR",
                               "/sys/knitfem"]),
       option=st.sampled_from(["--out", "--json"]))
def test_unwritable_outputs_are_refused_before_any_work(command, target, option, tmp_path):
    if command == "gallery" and option == "--json":
        option = "--out"
    (tmp_path / "FILE").write_text("x")
    (tmp_path / "DIR").mkdir(exist_ok=True)
    path = str(tmp_path / target) if target in ("FILE", "DIR") else target
    if (option, target) in (("--out", "DIR"), ("--json", "FILE")):
        return                                      # writable: not this test's business
    small = {"popup": POPUP_BASE[1:], "knit": KNIT_BASE[1:], "gallery": []}[command]
    small = small + ["--no-render"]
    code, out, err = run([command, option, path, "--quiet", *small], seconds=20)
    assert code == 2 and err.count("\n") == 1 and f"{option} {path}" in err, err


@settings(max_examples=60, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(argv=st.lists(st.sampled_from(["popup", "knit", "gallery", "curl", "--out", "--quiet",
                                      "--json", "--model", "--elements", "--frob", "-h2", "x",
                                      "1", "--nw", "--no-limits", "--c-step"]), max_size=6))
def test_garbage_argument_lists_get_one_line(argv, monkeypatch, tmp_path):
    """Parsing and checking only: a list that parses runs a stub, not the command
    (in a temporary folder: ``--out x`` creates x)."""
    from knitfem.verify import gallery
    monkeypatch.chdir(tmp_path)
    for module, name in ((popup_command, "run"), (knit_command, "run"),
                         (curl_command, "run"), (gallery, "_run_command")):
        monkeypatch.setattr(module, name, lambda args: 0)
    code, out, err = run(argv, seconds=30)
    assert "Traceback" not in err
    assert code in (0, 2, 3), (argv, code, err)
    if code == 2:
        assert len(err.strip().splitlines()) == 1, (argv, err)


def test_the_fuzzed_options_are_all_the_numeric_ones():
    """Nothing escapes the fuzzer: it draws from each command's OptionSet."""
    for module in (popup_command, knit_command, curl_command):
        parser = argparse.ArgumentParser()
        module.OPTIONS.add_to(parser)
        numeric = {a.option_strings[0] for a in parser._actions
                   if a.type in (float, int) or getattr(a.type, "__self__", None)}
        assert numeric == {s.flag for s in module.OPTIONS.numbers}
