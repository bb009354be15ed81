"""The project's errors and the checks of an argument's type and range.

Every error the project raises on purpose derives from :class:`ProbingError`, so one
``except probing.ProbingError`` catches them all; each keeps its builtin base too
(``ValueError`` for bad input, ``RuntimeError`` for a run that fails), so ``except
ValueError`` still catches bad input.  An argument of the Python API refused is an
:class:`ArgumentError` naming the keyword; the checks here (:func:`integer`,
:func:`number`, :func:`choice`, :func:`names`) are the one rule of what an integer, a
number, a choice and a list of names are, for every function that takes them.
"""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Callable
from typing import Any

__all__ = [
    "ArgumentError",
    "ProbingError",
    "choice",
    "integer",
    "is_integer",
    "is_number",
    "names",
    "number",
    "refer",
]


class ProbingError(Exception):
    """The base of every error of the project: bad input (also a ``ValueError``), or a run
    that failed (also a ``RuntimeError``).  Its message is one line, the line the command
    line prints after ``probing: error:``."""


#: An argument named in an :class:`ArgumentError`'s message, between backticks.
_NAMED = re.compile(r"`([A-Za-z_]\w*)`")


class ArgumentError(ProbingError, ValueError):
    """An argument refused: ``argument`` names it (the Python keyword), ``message`` says
    the rule; another argument the message refers to is written between backticks.

    Examples
    --------
    >>> str(ArgumentError("dt_s", "give `dt_s` or `time`, not both"))
    'dt_s: give dt_s or time, not both'
    >>> ArgumentError("dt_s", "give `dt_s` or `time`").line(lambda n: "--" + n)
    '--dt_s: give --dt_s or --time'
    """

    def __init__(self, argument: str, message: str) -> None:
        self.argument, self.message = argument, message
        super().__init__(self.line(str))

    def __reduce__(self) -> tuple[Any, ...]:  # pickled as made (a forked run hands it back)
        return type(self), (self.argument, self.message)

    def line(self, name: Callable[[str], str]) -> str:
        """The one line, each argument written ``name(argument)``: the keyword in Python, its
        option on the command line."""
        return f"{name(self.argument)}: {refer(self.message, name)}"


def refer(text: str, name: Callable[[str], str]) -> str:
    """``text`` with each argument it names between backticks written ``name(argument)``.

    Examples
    --------
    >>> refer("needs `window_periods`", lambda n: "--" + n.replace("_", "-"))
    'needs --window-periods'
    """
    return _NAMED.sub(lambda m: name(m.group(1)), text)


Error = Callable[[str, str], Exception]


def is_integer(value: Any) -> bool:
    """An integer: a Python or numpy integer, not a bool (nor a float, even 7.0)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def is_number(value: Any) -> bool:
    """A real number: a Python or numpy integer or float, not a bool (nor a string)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _range(lo: float | None, hi: float | None, lo_open: bool) -> str:
    parts = []
    if lo is not None:
        parts.append(f"> {lo:g}" if lo_open else f">= {lo:g}")
    if hi is not None:
        parts.append(f"<= {hi:g}")
    return " and ".join(parts)


def integer(
    value: Any,
    name: str,
    *,
    lo: int | None = None,
    hi: int | None = None,
    error: Error = ArgumentError,
) -> int:
    """``value`` as an int, if it is an integer (:func:`is_integer`) from ``lo`` to ``hi``.

    Raises
    ------
    ArgumentError
        (or ``error(name, message)``) naming ``name``, the range and the value.

    Examples
    --------
    >>> import numpy as np
    >>> integer(np.int64(7), "order", lo=2, hi=20)
    7
    >>> integer(7.0, "order", lo=2, hi=20)
    Traceback (most recent call last):
    ...
    probing.core.errors.ArgumentError: order: must be an integer from 2 to 20, got 7.0
    >>> integer(0, "jobs", lo=1)
    Traceback (most recent call last):
    ...
    probing.core.errors.ArgumentError: jobs: must be an integer >= 1, got 0
    """
    if lo is not None and hi is not None:
        allowed = f"an integer from {lo} to {hi}"
    else:
        allowed = f"an integer {_range(lo, hi, False)}".rstrip()
    if not is_integer(value):
        raise error(name, f"must be {allowed}, got {value!r}")
    value = int(value)
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise error(name, f"must be {allowed}, got {value}")
    return value


def number(
    value: Any,
    name: str,
    *,
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    error: Error = ArgumentError,
) -> float:
    """``value`` as a float, if it is a finite number (:func:`is_number`) from ``lo``
    (excluded with ``lo_open``) to ``hi``.

    Raises
    ------
    ArgumentError
        (or ``error(name, message)``) naming ``name``, the range and the value.

    Examples
    --------
    >>> number(2, "bit_duration_s", lo=0, lo_open=True)
    2.0
    >>> number("0.04", "bit_duration_s", lo=0, lo_open=True)
    Traceback (most recent call last):
    ...
    probing.core.errors.ArgumentError: bit_duration_s: must be a number, got '0.04'
    >>> number(-1, "amplitude", lo=0, lo_open=True)
    Traceback (most recent call last):
    ...
    probing.core.errors.ArgumentError: amplitude: must be > 0, got -1
    """
    if not is_number(value):
        raise error(name, f"must be a number, got {value!r}")
    value = float(value)
    ok = math.isfinite(value)
    ok = ok and (lo is None or (value > lo if lo_open else value >= lo))
    ok = ok and (hi is None or value <= hi)
    if not ok:
        bounds = _range(lo, hi, lo_open)
        raise error(name, f"must be {bounds or 'finite'}, got {value:g}")
    return value


def choice(value: Any, name: str, allowed: tuple[str, ...], *, error: Error = ArgumentError) -> str:
    """``value`` if it is one of ``allowed`` (strings).

    Examples
    --------
    >>> choice("foo", "drift", ("detrend", "none"))
    Traceback (most recent call last):
    ...
    probing.core.errors.ArgumentError: drift: must be one of detrend, none; got 'foo'
    """
    if not isinstance(value, str) or value not in allowed:
        raise error(name, f"must be one of {', '.join(allowed)}; got {value!r}")
    return value


def names(value: Any, name: str, *, error: Error = ArgumentError) -> tuple[str, ...]:
    """Column (or channel) names: a list or tuple of strings, or one string (one name, not
    its letters); at least one.

    Examples
    --------
    >>> names("theta_rad", "outputs"), names(["q_rad_s", "theta_rad"], "outputs")
    (('theta_rad',), ('q_rad_s', 'theta_rad'))
    >>> names([1], "outputs")
    Traceback (most recent call last):
    ...
    probing.core.errors.ArgumentError: outputs: must be names (strings), got [1]
    """
    items = (value,) if isinstance(value, str) else value
    if not isinstance(items, list | tuple) or not all(isinstance(n, str) for n in items):
        raise error(name, f"must be names (strings), got {value!r}")
    if not items:
        raise error(name, "must name one at least")
    return tuple(items)
