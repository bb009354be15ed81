"""The settled tail pins the constant a model-free drift removal leaves in h_est.

Truth: a made-up response whose tail is exactly zero, put in the zero-mean convention
(h - sum(h) / M, what the DC-corrected estimators give without a baseline), with white noise
of known level; the F test's false-unsettled rate checked against its level by Monte Carlo."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from probing.core.pinning import (
    SETTLED_TAIL,
    TAIL_FLOOR,
    TAIL_LEVEL,
    ZERO_MEAN,
    pin_settled_tail,
    tail_taps,
)

M = 63


def response(decay: float = 0.7) -> np.ndarray:
    """A response that has settled to zero (to rounding) well within the period."""
    return np.sin(0.9 * np.arange(M)) * decay ** np.arange(M) + 0.3 * decay ** np.arange(M)


def zero_mean(h: np.ndarray) -> np.ndarray:
    return h - h.sum() / M


def test_noise_free_settled_tail_gives_the_response() -> None:
    h = response()
    est = np.tile(zero_mean(h), (3, 1, 1))
    pin = pin_settled_tail(est, tail_taps(M))
    assert pin.settled.tolist() == [True]
    np.testing.assert_allclose(pin.h[:, 0], np.tile(h, (3, 1)), rtol=0, atol=1e-8)  # 0.7^47
    np.testing.assert_allclose(pin.constant, [-h.sum() / M], rtol=1e-6)
    assert pin.conventions(["y"]) == {"y": SETTLED_TAIL}


def test_noisy_settled_tail_within_noise_of_the_response() -> None:
    rng = np.random.default_rng(1)
    h, sigma, periods = response(), 1e-3, 8
    est = zero_mean(h) + sigma * rng.standard_normal((periods, 2, M))
    pin = pin_settled_tail(est, tail_taps(M))
    assert pin.settled.all()
    n = tail_taps(M)
    # each tap's mean: sigma / sqrt(P), plus the tail mean's own noise sigma / sqrt(P N)
    sd = sigma / np.sqrt(periods) * np.sqrt(1 + 1 / n)
    assert np.max(np.abs(pin.h.mean(axis=0) - h)) < 5 * sd
    # without pinning the constant sum(h)/M is 40 sigma of the mean away
    assert abs(h.sum() / M) > 40 * sd


def test_a_tail_still_decaying_is_not_settled_and_left_as_it_is() -> None:
    rng = np.random.default_rng(2)
    h = response(decay=0.97)  # still 0.97^47 = 0.24 of its start at the tail
    est = zero_mean(h) + 1e-4 * rng.standard_normal((6, 1, M))
    pin = pin_settled_tail(est, tail_taps(M))
    assert pin.settled.tolist() == [False]
    assert pin.conventions(["y"]) == {"y": ZERO_MEAN}
    np.testing.assert_array_equal(pin.h, est)
    assert pin.constant.tolist() == [0.0]
    assert pin.statistic[0] > pin.threshold


def test_false_unsettled_rate_is_the_level() -> None:
    """White noise on a settled tail: F or the slope's t exceeds its bound in 1 % of records
    (2000 records: binomial sd 0.22 %, so 0.2-2.0 % holds with 3.6 sd to spare).  The noise
    is well above TAIL_FLOOR of the peak, so the floor does not decide."""
    rng = np.random.default_rng(3)
    est = zero_mean(response()) + 0.1 * rng.standard_normal((2000, 4, 1, M))
    unsettled = np.mean([not pin_settled_tail(e, 16).settled[0] for e in est])
    assert 0.002 < unsettled < 0.020, unsettled


def test_threshold_is_inclusive_and_the_level_quantile() -> None:
    """A tail whose F equals the threshold is settled; a hair above it is not (a tail
    without slope, so that F decides)."""
    n, periods = 16, 4
    rng = np.random.default_rng(4)
    noise = rng.standard_normal((periods, 1, M))
    noise -= noise.mean(axis=0)  # a zero mean over periods: F = 0, before the offset
    base = zero_mean(response())
    dev = np.zeros(M)
    dev[M - n :] = np.tile([1.0, -1.0, -1.0, 1.0], n // 4)  # not flat, but no slope: F alone

    def f_of(c: float) -> float:
        return float(pin_settled_tail(base + noise + c * dev, n).statistic[0])

    threshold = stats.f.ppf(1 - (1 - TAIL_LEVEL) / 2, n - 1, (n - 1) * (periods - 1))
    c_at = np.sqrt(threshold / f_of(1.0))
    pin_at = pin_settled_tail(base + noise + c_at * dev * (1 - 1e-12), n)
    pin_over = pin_settled_tail(base + noise + c_at * dev * (1 + 1e-9), n)
    assert pin_at.threshold == pytest.approx(threshold)
    assert pin_at.settled[0] and not pin_over.settled[0]


def test_noise_free_floor_both_sides() -> None:
    """Without noise a tail counts as flat only within TAIL_FLOOR of the peak."""
    h = response()
    n = tail_taps(M)
    dev = np.zeros(M)
    dev[M - n :: 2], dev[M - n + 1 :: 2] = 1.0, -1.0  # RMS 1 over the tail (n even)
    assert n % 2 == 0
    est0 = np.tile(zero_mean(h), (2, 1, 1))
    peak = np.abs(est0.mean(axis=0)).max()
    inside = est0 + 0.999 * TAIL_FLOOR * peak * dev
    outside = est0 + 1.001 * TAIL_FLOOR * peak * dev
    assert pin_settled_tail(inside, n).settled[0]
    assert not pin_settled_tail(outside, n).settled[0]


@pytest.mark.parametrize(("after", "taps"), [(None, 16), (60, 3), (1, M - 1)])
def test_tail_taps(after: int | None, taps: int) -> None:
    assert tail_taps(M, after) == taps


@pytest.mark.parametrize("after", [0, 61])
def test_tail_taps_refused(after: int) -> None:
    with pytest.raises(ValueError):
        tail_taps(M, after)


def test_a_slow_ramp_the_f_test_passes_is_caught_by_the_slope() -> None:
    """A tail still returning by a ramp just over the slope's bound: F, which spreads its
    power over every shape a tail can take (F ~ t^2 / (N - 1) for a ramp), passes it; the
    slope's t does not.  The noise's mean over the periods is removed, so the ramp alone
    departs from flat."""
    rng = np.random.default_rng(5)
    n, periods = 16, 20
    noise = rng.standard_normal((periods, 1, M))
    noise -= noise.mean(axis=0)
    base = zero_mean(response()) + noise
    k = np.zeros(M)
    k[M - n :] = np.arange(n) - (n - 1) / 2
    unit = pin_settled_tail(base + k, n).slope_t[0]  # t is linear in the ramp's height
    flat = pin_settled_tail(base, n)
    assert flat.settled[0] and abs(flat.slope_t[0]) < 1e-6 and flat.statistic[0] < 1e-12
    pin = pin_settled_tail(base + 1.1 * flat.slope_threshold / unit * k, n)
    assert pin.statistic[0] <= pin.threshold
    assert abs(pin.slope_t[0]) > pin.slope_threshold
    assert not pin.settled[0]


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_the_slope_bound_both_sides(sign: float) -> None:
    """A pure ramp (no other departure) whose t equals the bound is settled; a hair more
    is not, either sign."""
    n, periods = 16, 4
    rng = np.random.default_rng(6)
    noise = rng.standard_normal((periods, 1, M))
    base = zero_mean(response()) + noise
    k = np.zeros(M)
    k[M - n :] = np.arange(n) - (n - 1) / 2

    def t_of(c: float) -> float:
        return float(pin_settled_tail(base + sign * c * k, n).slope_t[0])

    t0, t1 = t_of(0.0), t_of(1.0)
    bound = pin_settled_tail(base, n).slope_threshold
    c_at = (bound - sign * t0) / (sign * (t1 - t0))  # t is linear in c: sign * t reaches bound
    assert c_at > 0
    at = pin_settled_tail(base + sign * c_at * (1 - 1e-9) * k, n)
    over = pin_settled_tail(base + sign * c_at * (1 + 1e-6) * k, n)
    assert at.statistic[0] <= at.threshold and over.statistic[0] <= over.threshold
    assert at.settled[0] and not over.settled[0]


def test_the_constant_removed_is_the_mean_over_periods_of_each_periods_tail_mean() -> None:
    """Each period shifted by its own constant (a flat tail in each, no noise): every period
    loses its own tail mean, and the constant recorded is the mean over the periods of those
    tail means, per channel, computed here from the input (not the first period's)."""
    h, n, periods = response(), tail_taps(M), 4
    shifts = np.array([[0.5, -2.0], [-0.1, 0.4], [0.2, 1.0], [0.0, -0.6]])  # (P, C)
    est = zero_mean(h) + shifts[:, :, None]
    pin = pin_settled_tail(est, n)
    assert pin.settled.tolist() == [True, True]
    by_hand = [np.mean([est[p, c, M - n :].mean() for p in range(periods)]) for c in range(2)]
    assert abs(by_hand[0] - est[0, 0, M - n :].mean()) > 0.1  # the first period's is not it
    np.testing.assert_allclose(pin.constant, by_hand, rtol=1e-12, atol=0)
    np.testing.assert_allclose(pin.constant, -h.sum() / M + shifts.mean(axis=0), atol=1e-8)
    np.testing.assert_allclose(pin.h, np.broadcast_to(h, est.shape), rtol=0, atol=1e-8)
    recorded = pin.record(["theta_rad", "q_rad_s"])["constant_removed"]
    assert recorded == dict(zip(["theta_rad", "q_rad_s"], pin.constant.tolist(), strict=True))
