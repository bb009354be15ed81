"""The base of the hard nonlinearities: their errors, the chunked-processing contract
(:class:`Nonlinearity`) and the helpers every law shares.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import fields
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from probing.core.errors import ProbingError


class NoApparentFormError(ProbingError, TypeError):
    """The nonlinearity cannot be written as a scaled and offset probe, eq. (10)."""


class ParameterError(ProbingError, ValueError):
    """An invalid parameter of a nonlinearity.

    Parameters
    ----------
    owner : str
        The class name (``"Deadband"``).
    argument : str
        The offending argument (``"lower"``).
    value : object
        Its value.
    rule : str
        What is required, e.g. ``"must be >= 0"``; other arguments it refers to are written
        ``{name}`` and given as keyword arguments with their values.
    **refs : float
        Values of the arguments named in ``rule``.

    Examples
    --------
    >>> str(ParameterError("Deadband", "lower", 0.2, "must be <= {upper}", upper=0.1))
    'Deadband: lower (0.2) must be <= upper (0.1)'
    >>> ParameterError("Deadband", "lower", 0.2, "must be <= {upper}", upper=0.1).requirement(
    ...     {"upper": "upper_deg"})
    'must be <= upper_deg (0.1)'
    """

    def __init__(self, owner: str, argument: str, value: object, rule: str, **refs: float):
        self.owner, self.argument, self.value, self.rule, self.refs = (
            owner,
            argument,
            value,
            rule,
            refs,
        )
        super().__init__(f"{owner}: {argument} ({value!r}) {self.requirement()}")

    def requirement(self, names: Mapping[str, str] | None = None) -> str:
        """The rule, with the arguments it refers to renamed by ``names`` (e.g. to units)."""
        names = names or {}
        return self.rule.format(**{k: f"{names.get(k, k)} ({v!r})" for k, v in self.refs.items()})


# --------------------------------------------------------------------------- helpers
def as_signal(x: ArrayLike) -> np.ndarray:
    """Input signal as a finite 1-D float64 array."""
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"x must be a 1-D signal, got an array of shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("x must be finite (no NaN or inf)")
    return arr


def check_dt(dt: float) -> float:
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"dt ({dt!r}) must be a finite number of seconds > 0")
    return dt


def check_amplitude(amplitude: float) -> float:
    a = float(amplitude)
    if not (math.isfinite(a) and a > 0.0):
        raise ValueError(f"amplitude ({amplitude!r}) must be finite and > 0")
    return a


def constant_runs(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start indices and lengths of the runs of equal consecutive values of x (non-empty)."""
    starts = np.concatenate(([0], np.flatnonzero(x[1:] != x[:-1]) + 1))
    lengths = np.diff(np.append(starts, x.size))
    return starts, lengths


# ------------------------------------------------------------------------ base class
class Nonlinearity(ABC):
    """A hard nonlinearity acting sample by sample on the probing input.

    Subclasses are frozen dataclasses; their parameters are coerced to ``float``
    and validated on construction (``ValueError`` naming the argument).
    """

    def __post_init__(self) -> None:
        name = type(self).__name__
        for f in fields(self):  # type: ignore[arg-type]
            raw = getattr(self, f.name)
            try:
                value = float(raw)
            except (TypeError, ValueError):
                raise ParameterError(name, f.name, raw, "must be a real number") from None
            if not math.isfinite(value):
                raise ParameterError(name, f.name, raw, "must be finite")
            object.__setattr__(self, f.name, value)
        self._validate()

    @abstractmethod
    def _validate(self) -> None:
        """Class-specific parameter checks, after coercion to finite floats."""

    @abstractmethod
    def initial_state(self) -> Any:
        """The rest state, to start :meth:`process` with."""

    @abstractmethod
    def process(self, x: ArrayLike, dt: float, state: Any) -> tuple[np.ndarray, Any]:
        """Process one chunk of the input signal.

        Parameters
        ----------
        x : array_like
            1-D chunk of the input signal, signal units, one value per sample;
            must be finite.
        dt : float
            Sample interval, s (> 0).  Only :class:`RateLimit` depends on it.
        state : object
            State returned by the previous call, or :meth:`initial_state`.

        Returns
        -------
        y : numpy.ndarray
            Output chunk (float64, same length as x), signal units.
        state : object
            State to pass with the next chunk.
        """

    def apply(self, x: ArrayLike, dt: float) -> np.ndarray:
        """Process a whole signal from the rest state.

        Parameters
        ----------
        x : array_like
            1-D input signal, signal units.
        dt : float
            Sample interval, s.

        Returns
        -------
        numpy.ndarray
            Output signal, float64, signal units.
        """
        return self.process(x, dt, self.initial_state())[0]

    @abstractmethod
    def apparent(self, amplitude: float) -> tuple[float, float]:
        """Apparent amplitude and offset (a~, b~) of eq. (10) for the probe +-amplitude.

        Parameters
        ----------
        amplitude : float
            Probe amplitude a > 0, signal units; the probe takes the values +a, -a.

        Returns
        -------
        a_tilde, b_tilde : float
            Apparent amplitude and offset, signal units:
            a~ = (q(+a) - q(-a))/2 and b~ = (q(+a) + q(-a))/2 where q(+-a) are the
            steady output levels (after the first transition of each sign).
        """


class MemorylessBase(Nonlinearity):
    """A static nonlinearity: y[k] depends on x[k] only; the state is ``None``."""

    def initial_state(self) -> None:
        """Memoryless: the state is ``None``."""
        return None

    def process(self, x: ArrayLike, dt: float, state: Any = None) -> tuple[np.ndarray, None]:
        check_dt(dt)
        return self._map(as_signal(x)), None

    @abstractmethod
    def _map(self, x: np.ndarray) -> np.ndarray:
        """The static characteristic, vectorised."""
