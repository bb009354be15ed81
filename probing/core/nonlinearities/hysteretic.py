"""The laws with memory of their last level: hysteresis relay and backlash."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from probing.core.nonlinearities.base import (
    Nonlinearity,
    ParameterError,
    as_signal,
    check_amplitude,
    check_dt,
    constant_runs,
)


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
        check_dt(dt)
        x = as_signal(x)
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
        a = check_amplitude(amplitude)
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
        check_dt(dt)
        x = as_signal(x)
        y = float(state)
        if x.size == 0:
            return np.empty(0), y
        # Within a run of constant input the output settles on the first sample of
        # the run (clip is idempotent), so the recursion only runs over the runs.
        starts, lengths = constant_runs(x)
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
        a = check_amplitude(amplitude)
        if 2.0 * a > self.width:
            return a - self.width / 2.0, 0.0
        return 0.0, 0.0
