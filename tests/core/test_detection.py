"""The monitor's detection within N periods (probing.core.detection) against closed-form
theory where there is one (one dimension, a long baseline) and against the detector itself
(:class:`probing.core.monitor.ChangeDetector` fed synthetic periods)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import ndtr, stdtrit

from probing.core.detection import SAMPLES, detection_scale, detection_within
from probing.core.monitor import ChangeDetector, MonitorSettings, window_matrix

MC = 3.0 * 0.5 / math.sqrt(SAMPLES)  # three standard errors of the model's own draws


def _closed_form(delta: float, alpha: float, b: int, within: int) -> float:
    """One dimension, W = 1, a baseline long enough to be known: test m sees the onset's
    fraction 1 - u (m = 0) or the whole change (m >= 1), each on its own noise."""
    z = float(stdtrit(b - 1, 1.0 - alpha / 4.0))
    scale = math.sqrt(1.0 + 1.0 / b)

    def p(c: float) -> float:
        return float(ndtr(-z + c * delta / scale) + ndtr(-z - c * delta / scale))

    later = 1.0 - (1.0 - p(1.0)) ** (within - 1)
    return quad(lambda u: 1.0 - (1.0 - p(1.0 - u)) * (1.0 - later), 0.0, 1.0)[0]


@pytest.mark.parametrize("within", [1, 2, 3])
def test_one_dimension_against_the_closed_form(within):
    """The first test sees only the part of the period after the onset; each later one the
    whole change.  N = 1 counts the onset's own period alone, N = 3 two more."""
    one = np.ones(1)
    for delta in (2.0, 4.0, 6.0):
        got = detection_within(delta * one, np.eye(1), one, 1e-3, (1, 100000, within))
        want = _closed_form(delta, 1e-3, 100000, within)
        assert got == pytest.approx(want, abs=MC + 0.002)


def test_the_nth_period_is_the_last_counted():
    """Within N periods: N tests.  One more period adds a test, and the probability."""
    v0 = np.array([1.0, 0.5, 0.2])
    r = detection_scale(-0.2 * v0, np.eye(3) * 0.01, v0, 1e-4, (4, 50, 5), 0.5)
    args = (-0.2 * r * v0, np.eye(3) * 0.01, v0, 1e-4)
    p4, p5, p6 = (detection_within(*args, (4, 50, n)) for n in (4, 5, 6))
    assert p5 == pytest.approx(0.5, abs=2e-3)
    assert p4 < p5 - 0.1
    assert p6 > p5 + 0.05


def _detector_probability(gain: float, trials: int, seed: int) -> tuple[float, float]:
    """The detector's own rate, on periods of an AR(1) tap noise, a step gain change at a
    uniform place within the 6th period after the baseline, alarms counted from that period
    to the 5th after it; and the model's for the same covariance."""
    m, k, w, b, n, alpha = 31, 6, 4, 50, 5, 1e-3
    rng = np.random.default_rng(seed)
    h0 = np.exp(-np.arange(m) / 6.0) * np.sin(np.arange(m) / 3.0 + 0.5)
    lags = np.abs(np.subtract.outer(np.arange(m), np.arange(m)))
    taps = 0.08**2 * 0.6**lags
    chol = np.linalg.cholesky(taps)
    reduce = window_matrix(m, k)
    settings = MonitorSettings(baseline_periods=b, window_periods=w, windows=k)
    dh = (gain - 1.0) * h0
    hits = 0
    for _ in range(trials):
        detector = ChangeDetector(m, settings, alpha)
        u = rng.random()
        onset = b + 5
        found = False
        for i in range(onset + n):
            c = 0.0 if i < onset else (1.0 - u if i == onset else 1.0)
            decision = detector.update(h0 + c * dh + chol @ rng.standard_normal(m))
            found |= i >= onset and decision.alarm
        hits += found
    model = detection_within(reduce @ dh, reduce @ taps @ reduce.T, reduce @ h0, alpha, (w, b, n))
    return hits / trials, model


@pytest.mark.parametrize("gain", [0.8, 0.75])
def test_the_model_is_the_detectors_own_rate(gain):
    """The detector's two tests on its learnt baseline, against the model's draws: within
    three binomial standard errors of 600 flights (plus the model's own)."""
    rate, model = _detector_probability(gain, 600, seed=11)
    assert 0.2 < model < 0.95  # where the comparison has teeth
    assert abs(rate - model) < 3.0 * math.sqrt(model * (1.0 - model) / 600) + MC


def test_the_scale_reaches_the_probability():
    v0 = np.array([1.0, 0.5, 0.2])
    s = np.diag([0.02, 0.01, 0.03])
    r = detection_scale(-0.2 * v0, s, v0, 1e-4, (4, 50, 5), 0.9)
    assert detection_within(-0.2 * r * v0, s, v0, 1e-4, (4, 50, 5)) == pytest.approx(0.9, abs=2e-3)
    # a probe r times louder: the change grows against the noise by r
    louder = detection_within(-0.2 * v0, s / r**2, v0, 1e-4, (4, 50, 5))
    assert louder == pytest.approx(0.9, abs=2e-3)
    with pytest.raises(ValueError, match="probability"):
        detection_scale(-0.2 * v0, s, v0, 1e-4, (4, 50, 5), 1.0)
