"""The *trajectory* detector: the measured output left the reference's by more than the
noise allows.

The probing detector (:class:`probing.core.monitor.ChangeDetector`) asks whether the
*pulse response* changed: the paper's method.  An aircraft that is damaged also leaves its
trajectory: its trim moves, and the reference model, which flies the nominal aircraft,
no longer follows it.  That is not the probe's doing (it happens with no probe at all), so
it is a second detector, with its own false-alarm budget, named apart.

Per period and channel it takes the deviation d (the measured output minus the reference's,
sampled at the end of each bit, as the correlator sees it) and two features:

* its mean over the period, m_p;
* the log of its standard deviation about that mean, s_p.

The first ``baseline_periods`` tested periods B (or, with a gap, the B that slide behind the
tested period, frozen at the first alarm: :mod:`probing.core.baseline`) give each feature's
mean and standard deviation; every later period's feature x is tested against the prediction
interval of a new draw, t = (x - mean) / (sd sqrt(1 + 1/B')), Student's t with B' - 1
degrees of freedom, two-sided. B' = B (1 - rho) / (1 + rho) is the baseline's number of
independent periods for a feature whose lag-1 correlation is rho (an AR(1) sequence; rho
from the baseline, clipped to 0..:data:`MAX_CORRELATION`): the deviation of a closed loop
flying on noisy sensors wanders slowly, and its period means are correlated. For independent
Gaussian periods (rho = 0) it is the exact prediction interval. The period's p-value is
twice the smaller of the two (Bonferroni), its ``statistic`` -log10 p, its ``threshold``
-log10 alpha. Each period is tested alone (a feature whose baseline spread is below
:data:`FLOOR` of its mean is scaled by that floor): consecutive periods of a slow drift are
correlated, so alarms come in runs and alarm *events* are fewer than alarmed periods. numpy
and scipy only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import stdtr

from probing.core.baseline import BaselineWindow

__all__ = [
    "FLOOR",
    "MAX_CORRELATION",
    "TrajectoryDecision",
    "TrajectoryDetector",
    "trajectory_features",
]

#: The smallest spread a feature is scaled by, relative to its baseline mean: a flight without
#: noise repeats its features to rounding, which is no spread to test against.
FLOOR = 1e-6


#: The largest lag-1 correlation of a feature the baseline's degrees of freedom allow for.
MAX_CORRELATION = 0.9


def _lag1(x: np.ndarray) -> np.ndarray:
    """The lag-1 autocorrelation of each column of ``x`` (B, k)."""
    with np.errstate(invalid="ignore", divide="ignore"):  # a constant deviation's log 0
        d = x - x.mean(axis=0)
        return (d[1:] * d[:-1]).sum(axis=0) / (d * d).sum(axis=0)


def trajectory_features(deviation: np.ndarray) -> np.ndarray:
    """The two features of whole periods of a deviation.

    Parameters
    ----------
    deviation : numpy.ndarray
        ``(P, C, M)``: each period's M bit samples of each channel's deviation.

    Returns
    -------
    numpy.ndarray
        ``(P, C, 2)``: the mean and the log of the standard deviation about it (natural log;
        -inf for a constant deviation).
    """
    d = np.asarray(deviation, dtype=float)
    mean = d.mean(axis=-1)
    with np.errstate(divide="ignore"):
        spread = np.log(d.std(axis=-1))
    return np.stack([mean, spread], axis=-1)


@dataclass(frozen=True)
class TrajectoryDecision:
    """One period's trajectory test: ``statistic`` (-log10 p, NaN while learning),
    ``threshold`` (-log10 alpha) and ``alarm`` (statistic > threshold)."""

    statistic: float
    threshold: float
    alarm: bool


class TrajectoryDetector:
    """The trajectory test of one channel (see the module's docstring).

    Parameters
    ----------
    baseline_periods : int
        Periods B learned before testing (at least 3: a standard deviation with a degree
        of freedom to spare).
    alpha : float
        False-alarm probability per period, in (0, 1).
    gap : int or None
        None: the baseline is the first B periods; G: the B periods that end G periods
        before the tested one (:class:`probing.core.baseline.BaselineWindow`).
    """

    def __init__(self, baseline_periods: int, alpha: float, gap: int | None = None) -> None:
        if baseline_periods < 3:
            raise ValueError(f"baseline_periods must be >= 3, got {baseline_periods}")
        if not 0.0 < alpha < 1.0:
            raise ValueError(f"alpha must be in (0, 1), got {alpha}")
        self.b, self.alpha = int(baseline_periods), float(alpha)
        self.threshold = -math.log10(alpha)
        self._baseline: BaselineWindow[np.ndarray] = BaselineWindow(self.b, 1, gap)
        self._mean: np.ndarray | None = None
        self._scale: np.ndarray | None = None
        self._dof = np.full(2, float(self.b - 1))  # degrees of freedom, each feature

    @property
    def learning(self) -> bool:
        """True while the baseline is being learned."""
        return self._mean is None

    def _learn(self) -> None:
        base = np.array(self._baseline.items)
        self._mean = base.mean(axis=0)
        with np.errstate(invalid="ignore"):  # a constant deviation's log 0
            spread = base.std(axis=0, ddof=1)
        floor = FLOOR * np.abs(self._mean)  # a deterministic flight's features
        with np.errstate(invalid="ignore"):
            spread = np.where(spread < floor, floor, spread)
        # consecutive periods of a slow excursion are correlated: an AR(1) feature with
        # lag-1 correlation rho has B (1 - rho) / (1 + rho) independent periods
        rho = np.clip(np.nan_to_num(_lag1(base)), 0.0, MAX_CORRELATION)
        self._dof = np.maximum(self.b * (1.0 - rho) / (1.0 + rho) - 1.0, 2.0)
        self._scale = spread * np.sqrt(1.0 + 1.0 / (self._dof + 1.0))

    def update(self, features: np.ndarray) -> TrajectoryDecision:
        """Learn or test one period's features ``(2,)`` (:func:`trajectory_features`)."""
        x = np.asarray(features, dtype=float)
        learning = self._mean is None
        if self._baseline.add(x):
            self._learn()
        if learning:
            return TrajectoryDecision(math.nan, self.threshold, False)
        assert self._scale is not None
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.abs((x - self._mean) / self._scale)
        t = np.where(x == self._mean, 0.0, t)  # unmoved (a constant deviation's -inf too)
        t = np.where(np.isnan(t), np.inf, t)  # moved where the baseline had no spread
        p_one = 2.0 * stdtr(self._dof, -t)  # two-sided, each feature
        p = min(1.0, 2.0 * float(p_one.min()))
        statistic = math.inf if p == 0.0 else -math.log10(p)
        alarm = statistic > self.threshold
        if alarm:
            self._baseline.freeze()
        return TrajectoryDecision(statistic, self.threshold, alarm)
