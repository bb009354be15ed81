"""The memoryless laws: dead band, saturation and relay, eqs. (13)-(17)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from probing.core.nonlinearities.base import (
    MemorylessBase,
    ParameterError,
    check_amplitude,
)


# ------------------------------------------------------------------------- deadband
@dataclass(frozen=True)
class Deadband(MemorylessBase):
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
        a = check_amplitude(amplitude)
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
class Saturation(MemorylessBase):
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
        a = check_amplitude(amplitude)
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
class Relay(MemorylessBase):
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
        a = check_amplitude(amplitude)
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
