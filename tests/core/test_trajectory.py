"""The trajectory detector (probing.core.trajectory) against closed-form truth: Student's t
prediction intervals, checked by simulation of Gaussian periods."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from probing.core.trajectory import FLOOR, TrajectoryDetector, trajectory_features


def test_the_features_are_the_mean_and_the_log_spread_of_each_period():
    rng = np.random.default_rng(0)
    d = rng.normal(0.3, 2.0, (5, 2, 255))
    f = trajectory_features(d)
    np.testing.assert_allclose(f[..., 0], d.mean(axis=-1))
    np.testing.assert_allclose(f[..., 1], np.log(d.std(axis=-1)))


def _statistics(detector: TrajectoryDetector, features: np.ndarray) -> np.ndarray:
    return np.array([detector.update(x).statistic for x in features])


def test_the_p_value_is_the_prediction_interval_of_students_t():
    """One feature moved by k baseline standard deviations gives twice (Bonferroni) the
    two-sided t(B - 1) tail of k / sqrt(1 + 1/B), the other feature unmoved."""
    rng = np.random.default_rng(1)
    b = 20
    base = rng.normal(size=(b, 2))
    d = base - base.mean(axis=0)
    assert np.all((d[1:] * d[:-1]).sum(axis=0) <= 0)  # no lag-1 correlation: B' = B
    det = TrajectoryDetector(b, 1e-3)
    assert all(math.isnan(s) for s in _statistics(det, base))
    mean, sd = base.mean(axis=0), base.std(axis=0, ddof=1)
    x = mean + np.array([3.0 * sd[0], 0.0])
    t = 3.0 / math.sqrt(1 + 1 / b)
    p = min(1.0, 2 * 2 * stats.t.sf(t, b - 1))
    assert det.update(x).statistic == pytest.approx(-math.log10(p), rel=1e-9)


@pytest.mark.parametrize("alpha", [0.05, 0.01])
def test_the_false_alarm_rate_holds_for_gaussian_periods(alpha):
    """Over many flights of independent Gaussian periods the fraction of alarmed periods is
    at most alpha (Bonferroni over two features makes it a little less)."""
    rng = np.random.default_rng(2)
    b, tested, flights = 30, 20, 1500
    alarms = 0
    for _ in range(flights):
        det = TrajectoryDetector(b, alpha)
        for x in rng.normal(size=(b + tested, 2)):
            alarms += det.update(x).alarm
    rate = alarms / (flights * tested)
    assert 0.5 * alpha < rate <= 1.1 * alpha


def _ar1(rng: np.random.Generator, rho: float, n: int) -> np.ndarray:
    x = np.empty((n, 2))
    x[0] = rng.normal(size=2)
    for k in range(1, n):
        x[k] = rho * x[k - 1] + math.sqrt(1 - rho**2) * rng.normal(size=2)
    return x


def test_slowly_wandering_features_keep_the_rate_and_would_not_without_the_correction(
    monkeypatch,
):
    """AR(1) features (rho = 0.7, unit variance) tested period by period: with the
    baseline's effective degrees of freedom the alarmed fraction stays near alpha; with
    B - 1 (the correction switched off) it is several times alpha."""
    import probing.core.trajectory as trajectory

    alpha, b, tested, flights = 0.01, 50, 40, 600

    def rate(rng: np.random.Generator) -> float:
        alarms = 0
        for _ in range(flights):
            det = TrajectoryDetector(b, alpha)
            for x in _ar1(rng, 0.7, b + tested):
                alarms += det.update(x).alarm
        return alarms / (flights * tested)

    corrected = rate(np.random.default_rng(7))
    monkeypatch.setattr(trajectory, "MAX_CORRELATION", 0.0)
    naive = rate(np.random.default_rng(7))
    assert corrected <= 1.5 * alpha
    assert naive > 2.0 * alpha


def test_a_step_in_the_mean_is_found_at_once():
    rng = np.random.default_rng(3)
    det = TrajectoryDetector(30, 1e-4)
    for x in rng.normal(size=(30, 2)):
        det.update(x)
    assert not det.update(np.array([0.0, 0.0])).alarm
    assert det.update(np.array([8.0, 0.0])).alarm


def test_a_noise_free_flight_alarms_only_beyond_the_floor():
    """Features that repeat to rounding are scaled by FLOOR of their mean: a change of a few
    ulps is no alarm, a change of many floors is."""
    det = TrajectoryDetector(5, 1e-3)
    x = np.array([0.5, -3.0])
    for _ in range(5):
        det.update(x)
    assert not det.update(x * (1 + 1e-15)).alarm
    assert det.update(x * (1 + 100 * FLOOR)).alarm
    constant = TrajectoryDetector(5, 1e-3)  # a deviation with no spread at all: log 0
    y = np.array([0.5, -np.inf])
    for _ in range(5):
        constant.update(y)
    assert not constant.update(y).alarm


@pytest.mark.parametrize(
    ("b", "alpha", "ok"),
    [(2, 0.1, False), (3, 0.1, True), (5, 0.0, False), (5, 1.0, False), (5, 0.999, True)],
)
def test_its_settings_are_checked(b, alpha, ok):
    if ok:
        TrajectoryDetector(b, alpha)
    else:
        with pytest.raises(ValueError):
            TrajectoryDetector(b, alpha)
