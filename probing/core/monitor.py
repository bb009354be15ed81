"""Online change detection and isolation on the per-period pulse-response estimate.

The paper's purpose is to detect, period by period, that the small-signal dynamics changed.
Its theory gives isolation too: an input nonlinearity only scales and offsets the probe
(eqs. 10-12), so a change of the estimate that keeps its *shape* (a gain and an offset on the
baseline) points at the actuator side; a change of shape points at the airframe.

:class:`ChangeDetector` works on one channel's per-period estimate h_p (M taps):

1. **Reduction.**  The taps are summed in ``windows`` windows of geometrically growing length
   (early taps, where the fast dynamics live, finely; the tail coarsely), scaled by
   1/sqrt(length): v_p = W h_p, K numbers per period.  Tap noise that is white stays white
   and of equal variance in v.
2. **Baseline.**  The first ``baseline_periods`` periods B give the mean v0 and the sample
   covariance S (B - 1 degrees of freedom): learned from the flight itself, with nothing
   assumed about the noise but that periods are independent and Gaussian.
3. **Detection.**  After every later period, the mean of the last n <= W periods (``window``
   W; n grows to W after the baseline) gives d = mean(v) - v0, tested with Hotelling's T^2
   for a new observation, T^2 = d' S^-1 d / (1/n + 1/B), which under no change is exactly
   (B - 1) K / (B - K) F(K, B - K).  The threshold is that distribution's 1 - alpha point,
   alpha the false-alarm probability per period (a rate per hour times the period length):
   the expected number of alarmed periods per hour is the rate, and alarms of overlapping
   windows come in runs, so alarm *events* are fewer.
4. **Isolation.**  d is fitted as (g - 1) v0 + c u (a gain on the baseline and an offset,
   u = W 1), generalised least squares with S.  The residual's T^2 is the Hotelling
   statistic of a (K - 2)-dimensional part of d, (B - 1)(K - 2) / (B - K + 2)
   F(K - 2, B - K + 2) under an unchanged shape.  ``shape_change`` is it over its
   ``shape_alpha`` threshold: above 1 the shape changed beyond the noise.  An alarmed period
   is ``"airframe"`` if it did, ``"actuator"`` if a gain and offset explain the change.

All of it is exact for independent Gaussian periods (the ``cyclic`` and ``ac`` estimators
with white sensor noise); the streaming estimator's periods overlap and are correlated, so
the false-alarm rate holds only approximately there (``docs/monitoring.md``).
"""

from __future__ import annotations

import collections
import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy.special import fdtri

__all__ = ["ChangeDetector", "Decision", "MonitorSettings", "flight_verdict", "window_matrix"]


def window_matrix(m: int, windows: int) -> np.ndarray:
    """The reduction W (windows x m): tap sums over geometrically growing windows, each
    scaled by 1/sqrt(its length), so white tap noise stays white.

    Examples
    --------
    >>> w = window_matrix(7, 3)
    >>> (w > 0).sum(axis=1)  # taps per window: 1, 2, 4
    array([1, 2, 4])
    >>> np.allclose(w @ w.T, np.eye(3))
    True
    """
    if not 1 <= windows <= m:
        raise ValueError(f"windows must be 1..{m}, got {windows}")
    edges = np.unique(np.round(np.geomspace(1, m + 1, windows + 1)).astype(int) - 1)
    while edges.size < windows + 1:  # short responses: fill with single taps from the start
        gaps = np.setdiff1d(np.arange(m + 1), edges)
        edges = np.sort(np.append(edges, gaps[0]))
    edges[-1] = m
    w = np.zeros((windows, m))
    for k in range(windows):
        lo, hi = edges[k], edges[k + 1]
        w[k, lo:hi] = 1.0 / math.sqrt(hi - lo)
    return w


@dataclass(frozen=True)
class Decision:
    """One period's test.

    Attributes
    ----------
    statistic : float
        Hotelling's T^2 of the change (NaN while the baseline is learned).
    threshold : float
        Its threshold for the false-alarm probability per period.
    alarm : bool
        ``statistic > threshold``.
    gain_change : float
        The estimated scale g of the period against the baseline (1: unchanged).
    shape_change : float
        The shape residual's T^2 over its threshold (> 1: the shape changed).
    verdict : str
        ``"none"`` (no alarm), ``"actuator"`` or ``"airframe"``.
    """

    statistic: float
    threshold: float
    alarm: bool
    gain_change: float
    shape_change: float
    verdict: str


class ChangeDetector:
    """The detector of one channel (see the module docstring).

    Parameters
    ----------
    m : int
        Taps per period.
    baseline_periods : int
        Periods learned before testing (B > windows + 1).
    alpha : float
        False-alarm probability per period (0 < alpha < 1).
    windows : int
        K, the number of tap windows (>= 3: gain, offset and at least one shape direction).
    shape_alpha : float
        Probability that an unchanged shape is called changed.
    window : int
        W, the periods averaged into each test (1: every period alone).
    """

    def __init__(
        self,
        m: int,
        baseline_periods: int,
        alpha: float,
        windows: int = 6,
        shape_alpha: float = 0.01,
        window: int = 1,
    ) -> None:
        if window < 1:
            raise ValueError(f"window must be >= 1, got {window}")
        if windows < 3:
            raise ValueError(f"windows must be >= 3, got {windows}")
        if baseline_periods <= windows + 1:
            raise ValueError(
                f"baseline_periods must exceed windows + 1 ({windows + 1}), got {baseline_periods}"
            )
        for name, p in (("alpha", alpha), ("shape_alpha", shape_alpha)):
            if not 0.0 < p < 1.0:
                raise ValueError(f"{name} must be in (0, 1), got {p}")
        self.w = window_matrix(m, windows)
        self.k, self.b = windows, baseline_periods
        b, k = baseline_periods, windows
        self.threshold = (b - 1) * k / (b - k) * float(fdtri(k, b - k, 1.0 - alpha))
        self.shape_threshold = (
            (b - 1) * (k - 2) / (b - k + 2) * float(fdtri(k - 2, b - k + 2, 1.0 - shape_alpha))
        )
        self._baseline: list[np.ndarray] = []
        self._recent: collections.deque[np.ndarray] = collections.deque(maxlen=window)
        self.v0: np.ndarray | None = None
        self._s_inv: np.ndarray | None = None
        self._x: np.ndarray | None = None
        self._fit: np.ndarray | None = None
        self._residual: np.ndarray | None = None

    @property
    def learning(self) -> bool:
        """True while the baseline is being learned."""
        return self.v0 is None

    def update(self, h: np.ndarray) -> Decision:
        """Add one period's estimate ``h`` (M taps) and test it.

        Periods whose h is not finite (no estimate) are neither learned nor tested.
        """
        h = np.asarray(h, dtype=float)
        if not np.all(np.isfinite(h)):
            return Decision(math.nan, self.threshold, False, math.nan, math.nan, "none")
        v = self.w @ h
        if self.v0 is None:
            self._baseline.append(v)
            if len(self._baseline) == self.b:
                self._learn(np.array(self._baseline))
                self._baseline = []
            return Decision(math.nan, self.threshold, False, math.nan, math.nan, "none")
        self._recent.append(v)
        n = len(self._recent)
        d = np.mean(self._recent, axis=0) - self.v0
        scale = 1.0 / (1.0 / n + 1.0 / self.b)
        t2 = scale * float(d @ self._s_inv @ d)
        beta = self._fit @ d  # (g - 1, offset)
        shape = scale * float(d @ self._residual @ d) / self.shape_threshold
        alarm = t2 > self.threshold
        verdict = ("airframe" if shape > 1.0 else "actuator") if alarm else "none"
        return Decision(t2, self.threshold, alarm, 1.0 + float(beta[0]), shape, verdict)

    def _learn(self, v: np.ndarray) -> None:
        self.v0 = v.mean(axis=0)
        s = np.cov(v, rowvar=False, ddof=1)
        # a floor far below any noise keeps S invertible when the baseline repeats exactly
        s += (1e-12 * np.trace(s) / self.k + 1e-300) * np.eye(self.k)
        s_inv = np.linalg.inv(s)
        x = np.column_stack((self.v0, self.w @ np.ones(self.w.shape[1])))
        xtsx = x.T @ s_inv @ x
        fit = np.linalg.solve(xtsx, x.T @ s_inv)  # GLS: beta = fit @ d
        self._s_inv = s_inv
        self._fit = fit
        self._residual = s_inv - s_inv @ x @ fit  # d' R d = the GLS residual's quadratic form


@dataclass(frozen=True)
class MonitorSettings:
    """The ``[monitor]`` section: how the detector learns and decides.

    Attributes
    ----------
    baseline_periods : int
        Settled periods learned as the baseline before testing.
    false_alarms_per_hour : float
        The false-alarm rate the thresholds are set for, alarms per flight hour (all
        channels together: each gets an equal share).
    windows : int
        Tap windows K of the reduction.
    shape_false_alarm : float
        Probability that an unchanged shape is called changed (the isolation test's level).
    verdict_periods : int
        Alarmed periods, from the first alarm on, whose majority gives the flight's verdict.
    window_periods : int
        Periods averaged into each test (``probing design``'s settled periods for its
        target).
    """

    baseline_periods: int = 50
    false_alarms_per_hour: float = 0.1
    windows: int = 6
    shape_false_alarm: float = 0.01
    verdict_periods: int = 3
    window_periods: int = 1

    def alpha(self, period_s: float, channels: int) -> float:
        """False-alarm probability per period and channel (the rate shared out equally)."""
        return min(0.5, self.false_alarms_per_hour * period_s / 3600.0 / channels)

    def to_dict(self) -> dict[str, float]:
        """Plain values, for metadata."""
        return dataclasses.asdict(self)


def flight_verdict(rows: list[tuple[int, str]], periods: int) -> str:
    """The flight's verdict: the majority of the verdicts of the alarmed rows
    ``(period, verdict)`` in the ``periods`` periods from the first alarm on ("airframe" on a
    tie: the shape was seen to change); ``"none"`` without an alarm.

    Examples
    --------
    >>> flight_verdict([(7, "actuator"), (8, "airframe"), (8, "actuator"), (12, "airframe")], 3)
    'actuator'
    >>> flight_verdict([], 3)
    'none'
    """
    alarmed = [(p, v) for p, v in rows if v != "none"]
    if not alarmed:
        return "none"
    first = min(p for p, _ in alarmed)
    votes = [v for p, v in alarmed if p < first + periods]
    return "actuator" if votes.count("actuator") > votes.count("airframe") else "airframe"
