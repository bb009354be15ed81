"""The change detector against its own distribution theory, by Monte Carlo on made-up data.

Independent truth: Gaussian periods drawn here, a known gain and offset, and the exact
F distributions of Hotelling's T^2 (the rates the thresholds are set for).
"""

from __future__ import annotations

import numpy as np
import pytest

from probing.core.monitor import ChangeDetector, MonitorSettings, flight_verdict, window_matrix

M = 63
H0 = np.exp(-np.arange(M) / 8.0) * np.sin(np.arange(M) / 3.0 + 0.5)  # a made-up response
SIGMA = 0.05


def _learned(rng: np.random.Generator, baseline: int = 30, **kwargs) -> ChangeDetector:
    det = ChangeDetector(M, baseline, **kwargs)
    for _ in range(baseline):
        assert det.update(H0 + SIGMA * rng.standard_normal(M)).verdict == "none"
    assert not det.learning
    return det


@pytest.mark.parametrize("window", [1, 3])
def test_false_alarms_per_period_are_alpha(window):
    """4000 unchanged periods after 400 baselines: the alarm fraction is alpha (binomial
    3-sigma band), for single periods and for windows of 3 (each test exact for its n)."""
    rng = np.random.default_rng(1)
    alpha, alarms, tests = 0.02, 0, 0
    for _ in range(400):
        det = _learned(rng, alpha=alpha, windows=6, window=window)
        for _ in range(10):
            alarms += det.update(H0 + SIGMA * rng.standard_normal(M)).alarm
            tests += 1
    band = 3 * np.sqrt(alpha * (1 - alpha) / tests)
    assert abs(alarms / tests - alpha) < band, (alarms / tests, alpha)


def test_a_gain_and_offset_keep_the_shape_test_at_its_level_and_the_gain_is_estimated():
    """An actuator-like change (gain 0.8 and an offset on every tap) is called a shape change
    at the shape test's level only; the estimated gain is 0.8 on average."""
    rng = np.random.default_rng(2)
    shape_alpha, calls, n, gains = 0.05, 0, 0, []
    for _ in range(300):
        det = _learned(rng, alpha=0.01, windows=6, shape_alpha=shape_alpha)
        for _ in range(8):
            d = det.update(0.8 * H0 + 0.004 + SIGMA * rng.standard_normal(M))
            calls += d.shape_change > 1.0
            n += 1
            gains.append(d.gain_change)
    assert abs(calls / n - shape_alpha) < 3 * np.sqrt(shape_alpha * (1 - shape_alpha) / n)
    assert np.mean(gains) == pytest.approx(0.8, abs=3 * np.std(gains) / np.sqrt(len(gains)))


def test_a_shape_change_is_airframe_and_a_gain_change_actuator():
    rng = np.random.default_rng(3)
    det = _learned(rng, alpha=1e-4)
    gain = det.update(0.5 * H0 + SIGMA * rng.standard_normal(M))
    assert (
        gain.alarm
        and gain.verdict == "actuator"
        and gain.gain_change == pytest.approx(0.5, abs=0.05)
    )
    slower = np.exp(-np.arange(M) / 16.0) * np.sin(np.arange(M) / 3.0 + 0.5)  # damping halved
    shape = det.update(slower + SIGMA * rng.standard_normal(M))
    assert shape.alarm and shape.verdict == "airframe"


def test_an_exactly_repeating_baseline_does_not_break_the_detector():
    det = ChangeDetector(M, 10, 0.01, windows=4)
    for _ in range(10):
        det.update(H0)
    assert not det.update(H0).alarm  # a floor keeps S invertible
    assert det.update(1.01 * H0).alarm  # and any change is one


def test_unestimated_periods_are_skipped():
    det = ChangeDetector(M, 10, 0.01, windows=4)
    d = det.update(np.full(M, np.nan))
    assert d.verdict == "none" and np.isnan(d.statistic) and det.learning


def test_window_matrix_sums_growing_windows_and_keeps_white_noise_white():
    w = window_matrix(511, 6)
    sizes = (w > 0).sum(axis=1)
    assert sizes.sum() == 511 and np.all(np.diff(sizes) >= 0)
    assert np.allclose(w @ w.T, np.eye(6))
    assert np.all((w > 0).sum(axis=0) == 1)  # every tap in exactly one window


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"windows": 2}, "windows"),
        ({"baseline_periods": 7, "windows": 6}, "baseline_periods"),
        ({"alpha": 0.0}, "alpha"),
        ({"window": 0}, "window"),
    ],
)
def test_bad_settings_are_refused(kwargs, message):
    args = {"m": M, "baseline_periods": 30, "alpha": 0.01} | kwargs
    with pytest.raises(ValueError, match=message):
        ChangeDetector(**args)


def test_alpha_shares_the_rate_out_per_period_and_channel():
    s = MonitorSettings(false_alarms_per_hour=0.36)
    assert s.alpha(period_s=5.0, channels=2) == pytest.approx(0.36 * 5 / 3600 / 2)


def test_flight_verdict_is_the_majority_from_the_first_alarm():
    rows = [(3, "airframe"), (4, "actuator"), (5, "actuator"), (9, "airframe")]
    assert flight_verdict(rows, 3) == "actuator"
    assert flight_verdict(rows, 1) == "airframe"
    assert flight_verdict([(3, "airframe"), (4, "actuator")], 2) == "airframe"  # tie
