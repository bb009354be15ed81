"""The project's errors (probing.core.errors): one base class every error of the project
derives from, keeping its builtin base, and the one rule of what an integer, a number, a
choice and a list of names are, for every function that checks its arguments."""

from __future__ import annotations

import importlib
import inspect
import pickle
import pkgutil

import numpy as np
import pytest

import probing
from probing.core.errors import (
    ArgumentError,
    ProbingError,
    choice,
    integer,
    names,
    number,
    refer,
)

#: Errors that are no ProbingError, each with why: none.
INTERNAL: set[str] = set()


def _project_errors() -> dict[str, type[Exception]]:
    """Every exception class defined in a module of the package, by its dotted name."""
    found = {}
    for info in pkgutil.walk_packages(probing.__path__, "probing."):
        if info.name == "probing.__main__":  # runs the command line
            continue
        module = importlib.import_module(info.name)
        for obj in vars(module).values():
            if (
                inspect.isclass(obj)
                and issubclass(obj, Exception)
                and obj.__module__ == module.__name__
            ):
                found[f"{obj.__module__}.{obj.__qualname__}"] = obj
    return found


def test_every_error_of_the_project_is_a_probing_error() -> None:
    errors = _project_errors()
    assert len(errors) > 30 and INTERNAL <= set(errors)
    assert "probing.core.monitor.SettingError" in errors
    assert "probing.experiment.scenario.schema.ScenarioError" in errors
    outside = sorted(n for n, e in errors.items() if not issubclass(e, ProbingError))
    assert outside == sorted(INTERNAL)


def test_every_public_error_is_a_probing_error_and_keeps_its_builtin_base() -> None:
    public = {n: getattr(probing, n) for n in probing.__all__}
    public = {n: e for n, e in public.items() if inspect.isclass(e) and issubclass(e, Exception)}
    assert {"ScenarioError", "TrimError", "ProbingError", "ArgumentError"} <= set(public)
    for name, error in public.items():
        assert issubclass(error, ProbingError), name
    assert probing.ProbingError is ProbingError
    # bad input stays a ValueError, a failed run a RuntimeError
    assert issubclass(probing.ScenarioError, ValueError)
    assert issubclass(probing.ArgumentError, ValueError)
    assert issubclass(probing.TrimError, RuntimeError)
    assert issubclass(probing.DivergenceError, RuntimeError)
    assert issubclass(probing.SweepBusyError, RuntimeError)
    assert issubclass(probing.NoApparentFormError, TypeError)


@pytest.mark.parametrize(
    ("value", "got"),
    [(1, 1), (np.int64(7), 7), (np.uint8(20), 20), (20, 20)],
)
def test_an_integer_is_a_python_or_numpy_integer(value, got) -> None:
    out = integer(value, "order", lo=1, hi=20)
    assert out == got and type(out) is int


@pytest.mark.parametrize(
    ("value", "said"),
    [
        (0, "must be an integer from 1 to 20, got 0"),
        (21, "must be an integer from 1 to 20, got 21"),
        (7.0, "must be an integer from 1 to 20, got 7.0"),
        (True, "must be an integer from 1 to 20, got True"),
        (np.bool_(True), "must be an integer from 1 to 20, got np.True_"),
        ("7", "must be an integer from 1 to 20, got '7'"),
        (None, "must be an integer from 1 to 20, got None"),
    ],
)
def test_anything_else_is_refused_naming_the_argument(value, said) -> None:
    with pytest.raises(ArgumentError) as caught:
        integer(value, "order", lo=1, hi=20)
    assert str(caught.value) == f"order: {said}"
    assert caught.value.argument == "order" and caught.value.message == said


def test_one_sided_ranges_say_their_one_bound() -> None:
    assert integer(1, "jobs", lo=1) == 1
    with pytest.raises(ArgumentError, match=r"^jobs: must be an integer >= 1, got 0$"):
        integer(0, "jobs", lo=1)
    assert integer(-5, "n") == -5


@pytest.mark.parametrize("value", [1, 0.04, np.float32(0.5), np.int64(3), np.float64(1e-9)])
def test_a_number_is_an_int_or_a_float_of_python_or_numpy(value) -> None:
    out = number(value, "bit_duration_s", lo=0, lo_open=True)
    assert out == float(value) and type(out) is float


@pytest.mark.parametrize(
    ("value", "said"),
    [
        ("0.04", "must be a number, got '0.04'"),
        (True, "must be a number, got True"),
        (None, "must be a number, got None"),
        ([1.0], "must be a number, got [1.0]"),
        (0, "must be > 0, got 0"),  # the open bound itself
        (-1, "must be > 0, got -1"),
        (float("inf"), "must be > 0, got inf"),
        (float("nan"), "must be > 0, got nan"),
    ],
)
def test_a_number_out_of_its_range_or_not_a_number_is_refused(value, said) -> None:
    with pytest.raises(ArgumentError) as caught:
        number(value, "bit_duration_s", lo=0, lo_open=True)
    assert caught.value.message == said


def test_closed_bounds_take_their_ends() -> None:
    assert number(0, "x", lo=0, hi=1) == 0.0 and number(1, "x", lo=0, hi=1) == 1.0
    with pytest.raises(ArgumentError, match=r"must be >= 0 and <= 1, got 1\.5"):
        number(1.5, "x", lo=0, hi=1)
    with pytest.raises(ArgumentError, match="must be finite, got inf"):
        number(float("inf"), "x")


def test_an_error_class_of_its_own_is_made_with_the_name_and_the_rule() -> None:
    from probing.experiment.scenario import ScenarioError

    with pytest.raises(ScenarioError) as caught:
        integer(2.5, "probe.order", lo=2, hi=20, error=ScenarioError)
    assert caught.value.field == "probe.order"


def test_choices_and_names() -> None:
    assert choice("none", "drift", ("detrend", "none")) == "none"
    with pytest.raises(ArgumentError, match="must be one of detrend, none; got 'foo'"):
        choice("foo", "drift", ("detrend", "none"))
    with pytest.raises(ArgumentError, match="got 1"):
        choice(1, "drift", ("detrend", "none"))
    assert names("y_rad", "outputs") == ("y_rad",)  # one name, not five letters
    assert names(("a", "b"), "outputs") == ("a", "b")
    for bad in ([], [1], {"a": 1}, None, 3):
        with pytest.raises(ArgumentError, match=r"^outputs: "):
            names(bad, "outputs")


def test_the_arguments_a_message_names_are_written_by_who_says_it() -> None:
    exc = ArgumentError("within_periods", "needs `window_periods` and `detect_gain_change`")
    assert str(exc) == "within_periods: needs window_periods and detect_gain_change"
    flags = exc.line(lambda n: "--" + n.replace("_", "-"))
    assert flags == "--within-periods: needs --window-periods and --detect-gain-change"
    assert refer("no `1x` or ` x`", str.upper) == "no `1x` or ` x`"  # names only


def test_an_argument_error_survives_a_pickle() -> None:
    """A forked run hands its error back pickled."""
    from probing.experiment.design.design_request import DesignInputError

    for exc in (ArgumentError("jobs", "must be >= 1"), DesignInputError("drift", "`x`")):
        again = pickle.loads(pickle.dumps(exc))
        assert type(again) is type(exc) and str(again) == str(exc)
        assert again.argument == exc.argument
