"""Hard input nonlinearities of section III-B of Ruschmann & Wu, and their compensation.

Six nonlinearities act on the probe p before it reaches the plant (Fig. 1 of the
paper).  All values (parameters, input and output) are in the units of the signal
(deg of surface deflection in this project); rates are in signal units per second
and sample intervals ``dt`` in seconds.

============================  ======================================================
class                         law (x input, y output, k sample index)
============================  ======================================================
``Deadband(lower, upper)``    y = x - upper (x > upper), 0 (lower <= x <= upper),
                              x - lower (x < lower)           eq. (13) with erratum
``Saturation(lower, upper)``  y = clip(x, lower, upper)                  eq. (16)
``Relay(threshold, lo, hi)``  y = hi (x > S), lo (x < S), (lo + hi)/2 (x == S)
                                                              eq. (17) with erratum
``HysteresisRelay(...)``      y switches to hi when x > upper_threshold, to lo
                              when x < lower_threshold, holds otherwise; starts lo
``Backlash(width)``           y[k] = clip(y[k-1], x[k] - w/2, x[k] + w/2); y = 0 at
                              rest (gear play of full width w)
``RateLimit(rate)``           y[k] = x[k] if |x[k] - y[k-1]| <= rate dt, else
                              y[k-1] +- rate dt; y = 0 at rest
============================  ======================================================

Every class processes a signal in chunks with an explicit state, scipy style
(``y, state = nl.process(x, dt, state)``): feeding a signal in chunks of any sizes
gives bitwise the same output as one call to :meth:`Nonlinearity.apply`.

The first five nonlinearities turn the two-level probe +-a into another two-level
signal, eq. (10): q = (a~/a) p + b~.  With q(+a) and q(-a) the two output levels
(for the hysteretic ones: after the first input transition of each sign),

    a~ = (q(+a) - q(-a)) / 2,        b~ = (q(+a) + q(-a)) / 2.

:meth:`Nonlinearity.apparent` gives (a~, b~) in closed form, case by case as in
the paper (with the errata of docs/method.md), and :func:`compensate` undoes the effect
on the probing output, eq. (11).  The rate limit has no such form; its admissible
rates follow eq. (21), :meth:`RateLimit.admits`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "NONLINEARITIES",
    "Backlash",
    "Deadband",
    "HysteresisRelay",
    "NoApparentFormError",
    "Nonlinearity",
    "NonlinearityType",
    "Parameter",
    "ParameterError",
    "RateLimit",
    "RateLimitState",
    "Relay",
    "Saturation",
    "build_nonlinearity",
    "compensate",
]


class NoApparentFormError(TypeError):
    """The nonlinearity cannot be written as a scaled and offset probe, eq. (10)."""


class ParameterError(ValueError):
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
def _as_signal(x: ArrayLike) -> np.ndarray:
    """Input signal as a finite 1-D float64 array."""
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"x must be a 1-D signal, got an array of shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("x must be finite (no NaN or inf)")
    return arr


def _check_dt(dt: float) -> float:
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"dt ({dt!r}) must be a finite number of seconds > 0")
    return dt


def _check_amplitude(amplitude: float) -> float:
    a = float(amplitude)
    if not (math.isfinite(a) and a > 0.0):
        raise ValueError(f"amplitude ({amplitude!r}) must be finite and > 0")
    return a


def _runs(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


class _Memoryless(Nonlinearity):
    """A static nonlinearity: y[k] depends on x[k] only; the state is ``None``."""

    def initial_state(self) -> None:
        """Memoryless: the state is ``None``."""
        return None

    def process(self, x: ArrayLike, dt: float, state: Any = None) -> tuple[np.ndarray, None]:
        _check_dt(dt)
        return self._map(_as_signal(x)), None

    @abstractmethod
    def _map(self, x: np.ndarray) -> np.ndarray:
        """The static characteristic, vectorised."""


# ------------------------------------------------------------------------- deadband
@dataclass(frozen=True)
class Deadband(_Memoryless):
    """Deadband from ``lower`` (d-) to ``upper`` (d+), eq. (13) with the erratum.

    Parameters
    ----------
    lower : float
        Lower edge d- <= 0, signal units.
    upper : float
        Upper edge d+ >= 0, signal units.

    Notes
    -----
    y = x - upper for x > upper, 0 for lower <= x <= upper, x - lower for x < lower
    (the printed ``p + d-`` is discontinuous at d-; erratum, docs/method.md).

    Apparent probe (a~, b~) for +-a, the paper's cases (case a, "d+ < -a or d- > a",
    cannot happen since d- <= 0 <= d+):

    ====  ===========================  ================  ============
    case  condition                    a~                b~
    ====  ===========================  ================  ============
    b     d+ = -d- < a                 a - d+            0
    c     d+ != -d-, d+ < a, d- > -a   a - d+/2 + d-/2   -(d+ + d-)/2
    d     d+ >= a, d- > -a             (a + d-)/2        -(a + d-)/2
    e     d+ < a, d- <= -a             (a - d+)/2        (a - d+)/2
    f     d+ >= a, d- <= -a            0                 0
    ====  ===========================  ================  ============

    (The paper writes "d+ != d-" in cases c-e; "d+ != -d-" is meant.)

    The edges d+ = a and d- = -a are put where the output at that level is 0; the
    formulas are continuous there.
    """

    lower: float
    upper: float

    def _validate(self) -> None:
        if self.lower > self.upper:
            raise ParameterError(
                "Deadband", "lower", self.lower, "must be <= {upper}", upper=self.upper
            )
        if self.lower > 0.0:
            raise ParameterError("Deadband", "lower", self.lower, "must be <= 0 (relative to trim)")
        if self.upper < 0.0:
            raise ParameterError("Deadband", "upper", self.upper, "must be >= 0 (relative to trim)")

    def _map(self, x: np.ndarray) -> np.ndarray:
        return np.where(
            x > self.upper, x - self.upper, np.where(x < self.lower, x - self.lower, 0.0)
        )

    def apparent(self, amplitude: float) -> tuple[float, float]:
        a = _check_amplitude(amplitude)
        lo, up = self.lower, self.upper
        if up >= a and lo <= -a:  # f: the probe never leaves the band
            return 0.0, 0.0
        if up < a and lo > -a:
            if up == -lo:  # b: symmetric
                return a - up, 0.0
            # c: asymmetric, both edges inside the probe range, eqs. (14)-(15)
            return a - up / 2.0 + lo / 2.0, -up / 2.0 - lo / 2.0
        if up >= a:  # d: only the negative level gets through (lo > -a)
            return (a + lo) / 2.0, -(a + lo) / 2.0
        # e: only the positive level gets through (up < a, lo <= -a)
        return (a - up) / 2.0, (a - up) / 2.0


# ----------------------------------------------------------------------- saturation
@dataclass(frozen=True)
class Saturation(_Memoryless):
    """Saturation to [``lower``, ``upper``] (U-, U+), eq. (16).

    Parameters
    ----------
    lower : float
        Lower limit U-, signal units.
    upper : float
        Upper limit U+ >= U-, signal units.

    Notes
    -----
    Apparent probe (a~, b~) for +-a, the paper's cases with the erratum on case e:

    ====  ===========================  ===================  ===================
    case  condition                    a~                   b~
    ====  ===========================  ===================  ===================
    a     U- <= -a, U+ >= a            a                    0
    b     U- > -a, U+ < a              (U+ - U-)/2          (U+ + U-)/2
    c     -a < U- <= a, U+ >= a        (a - U-)/2           (a + U-)/2
    d     U- <= -a, -a <= U+ < a       (U+ + a)/2           (U+ - a)/2
    e     U- > a  (resp. U+ < -a)      0                    U-  (resp. U+)
    ====  ===========================  ===================  ===================

    Case e is checked first (the paper prints a~ = a there; the output is constant,
    so a~ = 0: erratum, docs/method.md).
    """

    lower: float
    upper: float

    def _validate(self) -> None:
        if self.lower > self.upper:
            raise ParameterError(
                "Saturation", "lower", self.lower, "must be <= {upper}", upper=self.upper
            )

    def _map(self, x: np.ndarray) -> np.ndarray:
        return np.clip(x, self.lower, self.upper)

    def apparent(self, amplitude: float) -> tuple[float, float]:
        a = _check_amplitude(amplitude)
        lo, up = self.lower, self.upper
        if lo > a:  # e: both levels clipped to U-
            return 0.0, lo
        if up < -a:  # e: both levels clipped to U+
            return 0.0, up
        if lo <= -a and up >= a:  # a: no effect
            return a, 0.0
        if lo > -a and up < a:  # b: both levels clipped
            return (up - lo) / 2.0, (up + lo) / 2.0
        if lo > -a:  # c: negative level clipped to U-
            return (a - lo) / 2.0, (a + lo) / 2.0
        # d: positive level clipped to U+
        return (up + a) / 2.0, (up - a) / 2.0


# ---------------------------------------------------------------------------- relay
@dataclass(frozen=True)
class Relay(_Memoryless):
    """Ideal relay switching at ``threshold`` S between ``low`` and ``high``, eq. (17).

    Parameters
    ----------
    threshold : float
        Switching point S, signal units.
    low : float
        Output l- for x < S, signal units.
    high : float
        Output l+ for x > S, signal units.

    Notes
    -----
    At x == S the output is the midpoint (l+ + l-)/2 (the printed (l+ - l-)/2 is a
    typo: erratum, docs/method.md).  Apparent probe (a~, b~) for +-a:

    ===========  ===================  ====================
    condition    a~                   b~
    ===========  ===================  ====================
    -a < S < a   (l+ - l-)/2          (l+ + l-)/2
    S < -a       0                    l+
    S > a        0                    l-
    S == a       (l+ - l-)/4          (l+ + 3 l-)/4
    S == -a      (l+ - l-)/4          (3 l+ + l-)/4
    ===========  ===================  ====================

    The paper states "S < -a or S > a gives b~ = l- or l+ respectively"; the
    assignment is the other way round: for S < -a both probe levels are above S.
    """

    threshold: float
    low: float
    high: float

    def _validate(self) -> None:
        """Any finite threshold and levels are valid (l- > l+ makes an inverting relay)."""

    def _map(self, x: np.ndarray) -> np.ndarray:
        s = self.threshold
        mid = (self.low + self.high) / 2.0
        return np.where(x > s, self.high, np.where(x < s, self.low, mid))

    def apparent(self, amplitude: float) -> tuple[float, float]:
        a = _check_amplitude(amplitude)
        s, lo, hi = self.threshold, self.low, self.high
        if -a < s < a:
            return (hi - lo) / 2.0, (hi + lo) / 2.0
        if s < -a:
            return 0.0, hi
        if s > a:
            return 0.0, lo
        if s == a:  # q(+a) = midpoint, q(-a) = low
            return (hi - lo) / 4.0, (hi + 3.0 * lo) / 4.0
        # s == -a: q(+a) = high, q(-a) = midpoint
        return (hi - lo) / 4.0, (3.0 * hi + lo) / 4.0


# ---------------------------------------------------------------- hysteresis relay
@dataclass(frozen=True)
class HysteresisRelay(Nonlinearity):
    """Relay with hysteresis (section III-B.4): thresholds S- <= S+, levels l-, l+.

    Parameters
    ----------
    lower_threshold : float
        S-: the output switches to ``low`` when x < S-, signal units.
    upper_threshold : float
        S+ >= S-: the output switches to ``high`` when x > S+, signal units.
    low : float
        Output l-, signal units (also the rest output).
    high : float
        Output l+, signal units.

    Notes
    -----
    Both switching conditions are strict (x > S+, x < S-), as for the ideal relay;
    for S- < x < S+, or x equal to a threshold, the output holds.  With S- == S+
    this is the ideal relay except at x == S exactly, where it holds its output.
    The state is a ``bool`` (True: output high); the rest state is low (False).

    Apparent probe (a~, b~) for +-a, starting low: the output can go high iff
    a > S+ and can come back low iff -a < S-.

    =======================  ===================  ===================
    condition                a~                   b~
    =======================  ===================  ===================
    a > S+ and -a < S-       (l+ - l-)/2          (l+ + l-)/2
    a <= S+                  0                    l-  (never switches)
    a > S+ and -a >= S-      0                    l+  (after the first switch)
    =======================  ===================  ===================

    The paper's "b~ depends on the system's memory" is resolved by the rest state.
    """

    lower_threshold: float
    upper_threshold: float
    low: float
    high: float

    def _validate(self) -> None:
        if self.lower_threshold > self.upper_threshold:
            raise ParameterError(
                "HysteresisRelay",
                "lower_threshold",
                self.lower_threshold,
                "must be <= {upper_threshold}",
                upper_threshold=self.upper_threshold,
            )

    def initial_state(self) -> bool:
        """Rest state: output ``low`` (False)."""
        return False

    def process(self, x: ArrayLike, dt: float, state: bool) -> tuple[np.ndarray, bool]:
        _check_dt(dt)
        x = _as_signal(x)
        if x.size == 0:
            return np.empty(0), bool(state)
        up = x > self.upper_threshold
        down = x < self.lower_threshold  # never together with up, since S- <= S+
        idx = np.where(up | down, np.arange(x.size), -1)
        last = np.maximum.accumulate(idx)  # index of the last switching decision
        is_high = np.where(last >= 0, up[np.maximum(last, 0)], bool(state))
        y = np.where(is_high, self.high, self.low).astype(np.float64)
        return y, bool(is_high[-1])

    def apparent(self, amplitude: float) -> tuple[float, float]:
        a = _check_amplitude(amplitude)
        if not a > self.upper_threshold:  # never reaches high: stays at rest
            return 0.0, self.low
        if not -a < self.lower_threshold:  # switches high once, never back
            return 0.0, self.high
        return (self.high - self.low) / 2.0, (self.high + self.low) / 2.0


# ------------------------------------------------------------------------- backlash
@dataclass(frozen=True)
class Backlash(Nonlinearity):
    """Backlash (gear play) of full gap width ``width`` (b_l), section III-B.5.

    Parameters
    ----------
    width : float
        Full width w >= 0 of the gap, signal units.

    Notes
    -----
    The output (rest value 0) moves only when the input pushes it:
    y[k] = x[k] - w/2 if that exceeds y[k-1], x[k] + w/2 if that is below y[k-1],
    else y[k-1]; i.e. y[k] = clip(y[k-1], x[k] - w/2, x[k] + w/2).  This is what
    JSBSim's ``<actuator>`` ``<hysteresis_width>`` does.  The state is the last
    output (float).

    Apparent probe (a~, b~) for +-a:

    ===========  ===============  ====
    condition    a~               b~
    ===========  ===============  ====
    2a > w       a - w/2          0
    2a <= w      0                0  (the output never leaves 0)
    ===========  ===============  ====
    """

    width: float

    def _validate(self) -> None:
        if self.width < 0.0:
            raise ParameterError("Backlash", "width", self.width, "must be >= 0")

    def initial_state(self) -> float:
        """Rest state: output 0."""
        return 0.0

    def process(self, x: ArrayLike, dt: float, state: float) -> tuple[np.ndarray, float]:
        _check_dt(dt)
        x = _as_signal(x)
        y = float(state)
        if x.size == 0:
            return np.empty(0), y
        # Within a run of constant input the output settles on the first sample of
        # the run (clip is idempotent), so the recursion only runs over the runs.
        starts, lengths = _runs(x)
        half = 0.5 * self.width
        values = x[starts]
        lows = (values - half).tolist()
        highs = (values + half).tolist()
        levels = np.empty(starts.size)
        for r, (lo, hi) in enumerate(zip(lows, highs, strict=True)):
            if y < lo:
                y = lo
            elif y > hi:
                y = hi
            levels[r] = y
        return np.repeat(levels, lengths), y

    def apparent(self, amplitude: float) -> tuple[float, float]:
        a = _check_amplitude(amplitude)
        if 2.0 * a > self.width:
            return a - self.width / 2.0, 0.0
        return 0.0, 0.0


# ----------------------------------------------------------------------- rate limit
class RateLimitState(NamedTuple):
    """State of :class:`RateLimit` between chunks.

    Attributes
    ----------
    output : float
        Last output y[k-1], signal units.
    target : float or None
        Input value of the current constant-input run (None at rest).
    origin : float
        Output at the start of the current ramp, signal units.
    step : float
        Signed output step of the current ramp, signal units per sample.
    index : int
        Samples of the current run processed so far.
    reach : int
        Ramp samples of the current run before the output equals ``target``.
    """

    output: float
    target: float | None
    origin: float
    step: float
    index: int
    reach: int


def _ramp_length(origin: float, target: float, step: float, limit: float) -> int:
    """Smallest m >= 0 with |target - (origin + m*step)| <= limit."""
    dist = abs(target - origin)
    if dist <= limit:
        return 0
    m = max(0, math.ceil(dist / limit) - 1)
    while m > 0 and abs(target - (origin + (m - 1) * step)) <= limit:
        m -= 1
    while abs(target - (origin + m * step)) > limit:
        m += 1
    return m


@dataclass(frozen=True)
class RateLimit(Nonlinearity):
    """Rate saturation: the output follows the input with |dy/dt| <= ``rate``.

    Parameters
    ----------
    rate : float
        Rate limit r_l > 0, signal units per second.

    Notes
    -----
    Discrete law, with y = 0 at rest:
    y[k] = x[k] if |x[k] - y[k-1]| <= rate dt, else y[k-1] + sign(x[k] - y[k-1]) rate dt
    (JSBSim's ``<actuator>`` ``<rate_limit>``).  Within a run of constant input the
    ramp is evaluated in closed form, origin + j * step, from the output at the
    start of the run (the state carries the ramp, so chunking does not change a
    bit); it differs from the sequential sum of steps by rounding only.

    There is no apparent form (10) (:meth:`apparent` raises
    :class:`NoApparentFormError`, a ``TypeError``); the probe passes unchanged iff
    the output can cross 2a within one bit, eq. (21): r_l >= 2a/t0.
    """

    rate: float

    def _validate(self) -> None:
        if not self.rate > 0.0:
            raise ParameterError("RateLimit", "rate", self.rate, "must be > 0")

    def initial_state(self) -> RateLimitState:
        """Rest state: output 0, no ramp in progress."""
        return RateLimitState(output=0.0, target=None, origin=0.0, step=0.0, index=0, reach=0)

    def process(
        self, x: ArrayLike, dt: float, state: RateLimitState
    ) -> tuple[np.ndarray, RateLimitState]:
        dt = _check_dt(dt)
        x = _as_signal(x)
        if x.size == 0:
            return np.empty(0), state
        limit = self.rate * dt  # largest output change per sample
        starts, lengths = _runs(x)
        values = x[starts]
        nruns = starts.size
        origins = np.empty(nruns)
        steps = np.empty(nruns)
        offsets = np.empty(nruns, dtype=np.int64)
        reaches = np.empty(nruns, dtype=np.int64)
        y = float(state.output)
        origin, step, index, reach = state.origin, state.step, state.index, state.reach
        carry_on = (
            state.target is not None
            and float(values[0]) == state.target
            and abs(step) == limit  # same dt: the ramp of the previous chunk continues
        )
        for r, (v, n) in enumerate(zip(values.tolist(), lengths.tolist(), strict=True)):
            if r > 0 or not carry_on:  # a new run: a new ramp from the current output
                origin = y
                step = limit if v > y else -limit
                index = 0
                reach = _ramp_length(origin, v, step, limit)
            origins[r] = origin
            steps[r] = step
            offsets[r] = index
            reaches[r] = reach
            index += n
            y = v if index > reach else origin + index * step
        run = np.repeat(np.arange(nruns), lengths)
        j = offsets[run] + (np.arange(x.size) - starts[run]) + 1  # samples since the origin
        out = np.where(j > reaches[run], values[run], origins[run] + j * steps[run])
        new_state = RateLimitState(
            output=float(out[-1]),
            target=float(values[-1]),
            origin=origin,
            step=step,
            index=index,
            reach=reach,
        )
        return out, new_state

    def apparent(self, amplitude: float) -> tuple[float, float]:
        """Not defined: a rate limit is not a scaled and offset probe.

        Raises
        ------
        NoApparentFormError
            Always (a subclass of ``TypeError``); use :meth:`admits` instead.
        """
        raise NoApparentFormError(
            "RateLimit has no apparent amplitude/offset form (eq. 10); "
            "use RateLimit.admits(amplitude, bit_duration_s) (eq. 21) instead"
        )

    @staticmethod
    def bound(amplitude: float, bit_duration_s: float) -> float:
        """Smallest rate that passes the probe unchanged, eq. (21): 2a / t0.

        Parameters
        ----------
        amplitude : float
            Probe amplitude a > 0, signal units.
        bit_duration_s : float
            Bit duration t0 > 0, s.

        Returns
        -------
        float
            2a/t0, signal units per second.
        """
        a = _check_amplitude(amplitude)
        t0 = float(bit_duration_s)
        if not (math.isfinite(t0) and t0 > 0.0):
            raise ValueError(f"bit_duration_s ({bit_duration_s!r}) must be finite and > 0")
        return 2.0 * a / t0

    def admits(self, amplitude: float, bit_duration_s: float) -> bool:
        """Whether the rate limit lets a full -a to +a transition happen within one bit.

        Parameters
        ----------
        amplitude : float
            Probe amplitude a > 0, signal units.
        bit_duration_s : float
            Bit duration t0 > 0, s.

        Returns
        -------
        bool
            ``rate >= 2a/t0`` (eq. 21).
        """
        return self.rate >= self.bound(amplitude, bit_duration_s)

    def ratio(self, amplitude: float, bit_duration_s: float) -> float:
        """The rate over the bound of eq. (21), r_l / (2a/t0): >= 1 admits the probe.

        Parameters
        ----------
        amplitude : float
            Probe amplitude a > 0, signal units.
        bit_duration_s : float
            Bit duration t0 > 0, s.

        Returns
        -------
        float
            r_l / (2a/t0), dimensionless.
        """
        return self.rate / self.bound(amplitude, bit_duration_s)

    def shortest_bit_s(self, amplitude: float) -> float:
        """The shortest bit duration the rate admits for a probe of ``amplitude``, eq. (21).

        Parameters
        ----------
        amplitude : float
            Probe amplitude a > 0, signal units.

        Returns
        -------
        float
            t0 = 2a / r_l, s: every bit at least this long passes the probe unchanged.
        """
        return self.bound(amplitude, 1.0) / self.rate


# --------------------------------------------------------------------- compensation
def compensate(z: ArrayLike, nonlinearity: Nonlinearity, amplitude: float) -> np.ndarray:
    """Undo a known input nonlinearity on the probing output, eq. (11).

    Through a nonlinearity with apparent probe (a~, b~), one period of the probing
    output is z_bar(k) = a~[(M+1)h(k) - S] + b~ S with S = sum_j h(j), instead of
    z(k) = a[(M+1)h(k) - S].  Summing z_bar over the period gives S (a~ + M b~), so
    S comes from the measurement itself, and z = (a/a~)(z_bar - b~ S).

    Parameters
    ----------
    z : array_like
        One period of the probing output (length M, last axis), or several periods
        stacked (periods x M); output units times probe units.  The operation is
        elementwise apart from the sum over the period, so any cyclic alignment
        of the period (time order or tap order) is fine.
    nonlinearity : Nonlinearity
        The known input nonlinearity (one with an apparent form).
    amplitude : float
        Probe amplitude a > 0, signal units.

    Returns
    -------
    numpy.ndarray
        The probing output without the nonlinearity, same shape as z.

    Raises
    ------
    ValueError
        If a~ == 0 (the probe does not get through: nothing to recover) or
        a~ + M b~ == 0 (the period sum carries no information on S).
    NoApparentFormError
        For a :class:`RateLimit` (a ``TypeError``).
    """
    a = _check_amplitude(amplitude)
    zb = np.asarray(z, dtype=np.float64)
    if zb.ndim < 1 or zb.shape[-1] < 1:
        raise ValueError("z must have at least one sample along its last axis")
    a_t, b_t = nonlinearity.apparent(a)
    if a_t == 0.0:
        raise ValueError(
            f"{nonlinearity!r} gives apparent amplitude a~ = 0 for amplitude {a!r}: "
            "the probe does not get through, nothing to recover"
        )
    m = zb.shape[-1]
    denom = a_t + m * b_t
    if abs(denom) <= 1e-12 * (abs(a_t) + m * abs(b_t)):
        raise ValueError(
            f"a~ + M b~ = 0 for {nonlinearity!r} (a~ = {a_t!r}, b~ = {b_t!r}, M = {m}): "
            "the DC sum of the pulse response cannot be recovered"
        )
    s = np.sum(zb, axis=-1, keepdims=True) / denom  # sum_j h(j)
    return (a / a_t) * (zb - b_t * s)


# ------------------------------------------------------------------------ registry
@dataclass(frozen=True)
class Parameter:
    """One parameter of a nonlinearity type as the project names it.

    Attributes
    ----------
    name : str
        The name with its unit, as in scenario files (``"lower_deg"``).
    argument : str
        The class's argument (``"lower"``).
    unit : str
        ``"deg"`` (surface deflection) or ``"deg/s"``.
    description : str
        What it is, in a few words.
    """

    name: str
    argument: str
    unit: str
    description: str


@dataclass(frozen=True)
class NonlinearityType:
    """A nonlinearity type: its class, parameters (with units) and how to label it.

    Attributes
    ----------
    name : str
        The type as written in scenario files (``"deadband"``).
    label : str
        Human-readable name for titles and tables (``"hysteresis relay"``).
    cls : type or None
        The :class:`Nonlinearity` subclass; None for ``"none"`` (a straight wire).
    parameters : tuple of Parameter
        In the order of the class's arguments.
    describe : callable
        ``describe(values)`` -> the parameters as one short line (values by
        :attr:`Parameter.name`, in their units).
    """

    name: str
    label: str
    cls: type[Nonlinearity] | None
    parameters: tuple[Parameter, ...]
    describe: Callable[[Mapping[str, float]], str]

    @property
    def names(self) -> tuple[str, ...]:
        """The parameter names with units, in order."""
        return tuple(p.name for p in self.parameters)

    def build(self, values: Mapping[str, float]) -> Nonlinearity | None:
        """The nonlinearity with these parameter values (by name with units); None for none.

        Raises
        ------
        KeyError
            For a missing parameter.
        ParameterError
            For an invalid value (a ``ValueError`` naming the class's argument: map it back
            with :meth:`parameter`).
        """
        if self.cls is None:
            return None
        return self.cls(*(values[p.name] for p in self.parameters))

    def parameter(self, argument: str) -> Parameter:
        """The parameter of the class argument ``argument``."""
        return next(p for p in self.parameters if p.argument == argument)


def _deg(name: str, description: str) -> Parameter:
    return Parameter(f"{name}_deg", name, "deg", description)


def _describe_hysteresis(v: Mapping[str, float]) -> str:
    lo_s, up_s = v["lower_threshold_deg"], v["upper_threshold_deg"]
    lo, hi = v["low_deg"], v["high_deg"]
    if lo_s == -up_s and lo == -hi:
        return f"S± = ±{up_s:.4g}, l± = ±{hi:.4g} deg"
    return f"S-, S+ = {lo_s:.4g}, {up_s:.4g}; l-, l+ = {lo:.4g}, {hi:.4g} deg"


#: Every nonlinearity type of the project by its scenario name, ``"none"`` included: the one
#: table that scenario validation, sweeps, figures and summaries read.
NONLINEARITIES: dict[str, NonlinearityType] = {
    t.name: t
    for t in (
        NonlinearityType("none", "none", None, (), lambda v: ""),
        NonlinearityType(
            "deadband",
            "deadband",
            Deadband,
            (_deg("lower", "lower edge d- (<= 0)"), _deg("upper", "upper edge d+ (>= 0)")),
            lambda v: f"d-, d+ = {v['lower_deg']:.4g}, {v['upper_deg']:.4g} deg",
        ),
        NonlinearityType(
            "saturation",
            "saturation",
            Saturation,
            (_deg("lower", "lower limit U-"), _deg("upper", "upper limit U+")),
            lambda v: f"U-, U+ = {v['lower_deg']:.4g}, {v['upper_deg']:.4g} deg",
        ),
        NonlinearityType(
            "relay",
            "relay",
            Relay,
            (
                _deg("threshold", "switching point S"),
                _deg("low", "output l- below S"),
                _deg("high", "output l+ above S"),
            ),
            lambda v: (
                f"S = {v['threshold_deg']:.4g}, l-, l+ = {v['low_deg']:.4g}, "
                f"{v['high_deg']:.4g} deg"
            ),
        ),
        NonlinearityType(
            "hysteresis_relay",
            "hysteresis relay",
            HysteresisRelay,
            (
                _deg("lower_threshold", "S-: switches low below it"),
                _deg("upper_threshold", "S+: switches high above it"),
                _deg("low", "output l- (also at rest)"),
                _deg("high", "output l+"),
            ),
            _describe_hysteresis,
        ),
        NonlinearityType(
            "backlash",
            "backlash",
            Backlash,
            (_deg("width", "full gap width b_l (>= 0)"),),
            lambda v: f"width b_l = {v['width_deg']:.4g} deg",
        ),
        NonlinearityType(
            "rate_limit",
            "rate limit",
            RateLimit,
            (Parameter("rate_deg_s", "rate", "deg/s", "rate limit r_l (> 0)"),),
            lambda v: f"r_l = {v['rate_deg_s']:.4g} deg/s",
        ),
    )
}


def build_nonlinearity(kind: str, values: Mapping[str, float]) -> Nonlinearity | None:
    """The nonlinearity of registered type ``kind`` with these parameter values.

    Parameters
    ----------
    kind : str
        A key of :data:`NONLINEARITIES` (``"none"`` gives None).
    values : mapping
        Parameter name with unit -> value (deg, or deg/s for the rate).

    Returns
    -------
    Nonlinearity or None

    Examples
    --------
    >>> build_nonlinearity("backlash", {"width_deg": 0.0025}).apparent(0.005)
    (0.00375, 0.0)
    """
    return NONLINEARITIES[kind].build(values)
