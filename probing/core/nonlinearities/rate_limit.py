"""The rate limit, which has no apparent-input form; its bound is eq. (21)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from probing.core.nonlinearities.base import (
    NoApparentFormError,
    Nonlinearity,
    ParameterError,
    as_signal,
    check_amplitude,
    check_dt,
    constant_runs,
)


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
        dt = check_dt(dt)
        x = as_signal(x)
        if x.size == 0:
            return np.empty(0), state
        limit = self.rate * dt  # largest output change per sample
        starts, lengths = constant_runs(x)
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
        a = check_amplitude(amplitude)
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
