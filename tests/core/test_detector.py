"""The change detector against its own distribution theory, by Monte Carlo on made-up data.

Independent truth: Gaussian periods drawn here, a known gain and offset, and the exact
F distributions of Hotelling's T^2 (the rates the thresholds are set for).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from probing.core.monitor import (
    ChangeDetector,
    MonitorSettings,
    SettingError,
    flight_verdict,
    window_matrix,
)

M = 63
H0 = np.exp(-np.arange(M) / 8.0) * np.sin(np.arange(M) / 3.0 + 0.5)  # a made-up response
SIGMA = 0.05


def _detector(alpha: float, **settings) -> ChangeDetector:
    """A detector of M taps with ``alpha`` per period and the ``[monitor]`` ``settings``
    (the defaults otherwise)."""
    return ChangeDetector.from_settings(M, MonitorSettings(**settings), alpha)


def _learned(
    rng: np.random.Generator, alpha: float, baseline: int = 30, **kwargs
) -> ChangeDetector:
    det = _detector(alpha, baseline_periods=baseline, **kwargs)
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
        det = _learned(rng, alpha, windows=6, window_periods=window)
        for _ in range(10):
            alarms += det.update(H0 + SIGMA * rng.standard_normal(M)).alarm
            tests += 1
    band = 3 * np.sqrt(alpha * (1 - alpha) / tests)
    assert abs(alarms / tests - alpha) < band, (alarms / tests, alpha)


@pytest.mark.parametrize("window", [1, 2])
def test_each_test_alone_is_exact_even_on_a_short_baseline(window):
    """A baseline of 8 periods, K = 3: each test's p-value falls below 0.05 in 5 % of the
    periods under no change (one test per detector: they are independent), where reading
    the baseline's mean and covariance as exact (no 1/B, no t and F tails) would not."""
    rng = np.random.default_rng(7)
    below = np.zeros(2)
    tests = 6000
    for _ in range(tests):
        det = _learned(rng, 0.01, baseline=8, windows=3, window_periods=window)
        mean = np.mean([H0 + SIGMA * rng.standard_normal(M) for _ in range(window)], axis=0)
        below += np.array(det._p_values(det.w @ mean, window)) < 0.05
    band = 3 * np.sqrt(0.05 * 0.95 / tests)
    np.testing.assert_allclose(below / tests, 0.05, atol=band)


def test_a_gain_and_offset_keep_the_shape_test_at_its_level_and_the_gain_is_estimated():
    """An actuator-like change (gain 0.8 and an offset on every tap) is called a shape change
    at the shape test's level only, one decision per detector (on the three periods after its
    first alarm); the estimated gain is 0.8 on average."""
    rng = np.random.default_rng(2)
    shape_alpha, calls, n, gains = 0.05, 0, 0, []
    for _ in range(1000):
        det = _learned(rng, 0.2, windows=6, shape_false_alarm=shape_alpha, verdict_periods=3)
        while not det.isolated:
            d = det.update(0.8 * H0 + 0.004 + SIGMA * rng.standard_normal(M))
            gains.append(d.gain_change)
        calls += d.shape_change > 1.0
        n += 1
    assert abs(calls / n - shape_alpha) < 3 * np.sqrt(shape_alpha * (1 - shape_alpha) / n)
    assert np.mean(gains) == pytest.approx(0.8, abs=3 * np.std(gains) / np.sqrt(len(gains)))


def test_a_shape_change_is_airframe_and_a_gain_change_actuator():
    rng = np.random.default_rng(3)
    det = _learned(rng, 1e-4)
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
    det = _detector(0.01, baseline_periods=10, windows=4)
    for _ in range(10):
        det.update(H0)
    assert not det.update(H0).alarm  # a floor keeps S invertible
    assert det.update(1.01 * H0).alarm  # and any change is one


def test_unestimated_periods_are_skipped():
    det = _detector(0.01, baseline_periods=10, windows=4)
    d = det.update(np.full(M, np.nan))
    assert d.verdict == "none" and np.isnan(d.statistic) and det.learning


def test_window_matrix_sums_growing_windows_and_keeps_white_noise_white():
    w = window_matrix(511, 6)
    sizes = (w > 0).sum(axis=1)
    assert sizes.sum() == 511 and np.all(np.diff(sizes) >= 0)
    assert np.allclose(w @ w.T, np.eye(6))
    assert np.all((w > 0).sum(axis=0) == 1)  # every tap in exactly one window


@pytest.mark.parametrize("alpha", [0.0, 1.0, -0.1])
def test_an_alpha_outside_zero_to_one_is_refused(alpha):
    """alpha, computed from the rate and not a setting, is the detector's one check."""
    with pytest.raises(ValueError, match="alpha"):
        _detector(alpha)


def test_an_alpha_just_below_one_is_accepted():
    assert _detector(0.999).learning


def test_alpha_shares_the_rate_out_per_period_and_channel():
    s = MonitorSettings(false_alarms_per_hour=0.36)
    assert s.alpha(period_s=5.0, channels=2) == pytest.approx(0.36 * 5 / 3600 / 2)


def test_flight_verdict_is_the_majority_of_the_channels_that_alarmed():
    assert flight_verdict(["actuator", "actuator", "airframe", "none"]) == "actuator"
    assert flight_verdict(["airframe", "actuator"]) == "airframe"  # tie
    assert flight_verdict(["none", "none"]) == "none"


# ------------------------------------------------------------------ isolation with the surface
def _closed_loop(
    p: np.ndarray, actuator: float, controller: float
) -> tuple[np.ndarray, np.ndarray]:
    """Periodic responses to the probe of a made-up closed loop: surface s = A (probe - C y),
    output y = P s; per frequency H_s = A / (1 + P A C), H_y = P H_s."""
    pk = np.fft.rfft(p)
    hs = actuator / (1.0 + pk * actuator * controller)
    return np.fft.irfft(pk * hs, n=M), np.fft.irfft(hs, n=M)


SLOW = np.exp(-np.arange(M) / 16.0) * np.sin(np.arange(M) / 3.0 + 0.5)  # damping halved


def _isolating(
    rng: np.random.Generator, alpha: float, baseline: int = 40, sigma: float = SIGMA, **kwargs
) -> ChangeDetector:
    det = _detector(alpha, baseline_periods=baseline, surface=True, **kwargs)
    y, s = _closed_loop(H0, 1.0, 0.3)
    for _ in range(baseline):
        det.update(y + sigma * rng.standard_normal(M), s + sigma * rng.standard_normal(M))
    return det


def test_with_the_surface_a_weaker_actuator_in_closed_loop_is_an_actuator_fault():
    """Half the actuator's effectiveness inside the loop changes the closed loop's shape:
    the gain-and-offset rule calls it airframe, the surface's rule actuator (P unchanged);
    an airframe change (damping halved) is airframe either way."""
    rng = np.random.default_rng(5)
    sigma = SIGMA / 5  # the closed loop hides much of an airframe change: a quieter sensor
    weak_y, weak_s = _closed_loop(H0, 0.5, 0.3)
    slow_y, slow_s = _closed_loop(SLOW, 1.0, 0.3)
    shape_only = _detector(1e-4, baseline_periods=40)
    y, _ = _closed_loop(H0, 1.0, 0.3)
    for _ in range(40):
        shape_only.update(y + sigma * rng.standard_normal(M))
    assert shape_only.update(weak_y + sigma * rng.standard_normal(M)).verdict == "airframe"
    verdicts = {"weak": [], "slow": []}
    for _ in range(20):
        det = _isolating(rng, 1e-4, sigma=sigma)
        noise = sigma * rng.standard_normal((2, M))
        verdicts["weak"].append(det.update(weak_y + noise[0], weak_s + noise[1]).verdict)
        det = _isolating(rng, 1e-4, sigma=sigma)
        verdicts["slow"].append(det.update(slow_y + noise[0], slow_s + noise[1]).verdict)
    assert verdicts["weak"].count("actuator") >= 19
    assert verdicts["slow"].count("airframe") == 20
    # a stuck surface answers the probe no more, and nothing then reaches the airframe
    det = _isolating(rng, 1e-4, sigma=sigma)
    stuck = det.update(sigma * rng.standard_normal(M), sigma * rng.standard_normal(M))
    assert stuck.alarm and stuck.verdict == "actuator"


def test_the_surface_test_keeps_its_level_under_an_actuator_change():
    """A weaker actuator (0.7) with the airframe unchanged: called airframe at about the
    shape test's level, one decision per detector (P0 is fitted from the baseline itself: a
    little above it)."""
    rng = np.random.default_rng(6)
    shape_alpha, calls, n = 0.05, 0, 0
    y, s = _closed_loop(H0, 0.7, 0.3)
    for _ in range(800):
        det = _isolating(rng, 0.2, shape_false_alarm=shape_alpha, verdict_periods=3)
        while not det.isolated:
            d = det.update(y + SIGMA * rng.standard_normal(M), s + SIGMA * rng.standard_normal(M))
        calls += d.shape_change > 1.0
        n += 1
    assert shape_alpha * 0.6 < calls / n < shape_alpha * 1.6, calls / n


def test_a_surface_detector_needs_the_surface():
    det = _detector(0.01, baseline_periods=10, windows=4, surface=True)
    with pytest.raises(ValueError, match="surface"):
        det.update(H0)


# ------------------------------------------------------------------ isolation: which periods
def test_isolation_rests_on_exactly_the_periods_after_the_first_alarm():
    """``isolation_periods`` = 3: the alarmed period (a gain change, 0.5) is left out, the
    next three (the same gain change) are the verdict's, and a fourth period with a changed
    shape (damping halved) changes neither the shape statistic (to the bit) nor the verdict.
    Truth: what was fed, period by period (a gain change keeps the shape, eqs. 10-12)."""
    rng = np.random.default_rng(11)
    sigma = SIGMA / 5
    det = _detector(1e-4, baseline_periods=30, verdict_periods=3)
    for _ in range(30):
        det.update(H0 + sigma * rng.standard_normal(M))
    first = det.update(0.5 * H0 + sigma * rng.standard_normal(M))
    assert first.alarm and not det.isolated
    decided = []
    for i in range(3):
        decided.append(det.update(0.5 * H0 + sigma * rng.standard_normal(M)))
        assert det.isolated == (i == 2), i  # isolated with the third, not before
    assert all(d.alarm for d in decided) and decided[-1].verdict == "actuator"
    later = det.update(SLOW + sigma * rng.standard_normal(M))
    assert later.alarm
    assert later.shape_change == decided[-1].shape_change  # the same three periods
    assert later.verdict == "actuator"
    # the fourth period alone is a shape change: had it been averaged in, it would show
    alone = _detector(1e-4, baseline_periods=30, verdict_periods=3)
    for _ in range(30):
        alone.update(H0 + sigma * rng.standard_normal(M))
    assert alone.update(SLOW + sigma * rng.standard_normal(M)).verdict == "airframe"


def test_isolation_leaves_out_the_alarmed_period_itself():
    """``isolation_periods`` = 1: a shape change (damping halved) raises the first alarm; the
    period after it, a pure gain change (0.5), is the one the verdict rests on: actuator,
    the shape statistic that of the gain-changed period alone."""
    rng = np.random.default_rng(12)
    sigma = SIGMA / 5
    det = _detector(1e-4, baseline_periods=30, verdict_periods=1)
    for _ in range(30):
        det.update(H0 + sigma * rng.standard_normal(M))
    onset = det.update(SLOW + sigma * rng.standard_normal(M))
    assert onset.alarm and onset.verdict == "airframe" and not det.isolated
    after = det.update(0.5 * H0 + sigma * rng.standard_normal(M))
    assert det.isolated and after.alarm and after.verdict == "actuator"
    assert after.shape_change < 1.0


def _surface_detector(rng: np.random.Generator, shape_alpha: float) -> tuple:
    """A surface-isolating detector learned on 40 periods; the baseline's reduced surface
    responses, computed here (mean and covariance by numpy)."""
    baseline, windows = 40, 6
    det = _detector(
        1e-3,
        baseline_periods=baseline,
        windows=windows,
        shape_false_alarm=shape_alpha,
        surface=True,
    )
    y, s = _closed_loop(H0, 1.0, 0.3)
    ss = s + SIGMA * rng.standard_normal((baseline, M))
    for row in ss:
        det.update(y + SIGMA * rng.standard_normal(M), row)
    v = ss @ window_matrix(M, windows).T
    s0, cov = v.mean(axis=0), np.cov(v, rowvar=False, ddof=1)
    se = math.sqrt(s0 @ cov @ s0) / (s0 @ s0)  # the gain's standard error, one period
    return det, ss.mean(axis=0), se, baseline


@pytest.mark.parametrize(
    ("t_ratio", "lost"),
    [
        ("between", True),  # |t| between the one- and the two-sided quantile: still lost
        (0.98, True),  # just inside the two-sided interval
        (1.02, False),  # just outside it: the surface answers
    ],
)
def test_a_surface_is_lost_inside_the_two_sided_t_interval_of_zero(t_ratio, lost):
    """A period whose surface response is c x the baseline's mean (its gain c exactly): lost
    (nothing reaches the airframe, shape statistic 0) while |c| / se < t(1 - shape_alpha / 2,
    B - 1), the two-sided quantile from scipy, and not lost beyond it; se from the baseline's
    own scatter, computed here.  Between the one-sided and the two-sided quantile it is
    lost."""
    from scipy.stats import t

    shape_alpha = 0.1
    rng = np.random.default_rng(13)
    det, s_mean, se, baseline = _surface_detector(rng, shape_alpha)
    one_sided = t.ppf(1 - shape_alpha, baseline - 1)
    two_sided = t.ppf(1 - shape_alpha / 2, baseline - 1)
    ratio = (one_sided + two_sided) / 2 / two_sided if t_ratio == "between" else t_ratio
    c = ratio * two_sided * se
    y, _ = _closed_loop(H0, 1.0, 0.3)
    d = det.update(y, c * s_mean)
    assert (d.shape_change == 0.0) == lost, (c / se, one_sided, two_sided, d.shape_change)


@pytest.mark.parametrize(
    ("settings", "field"),
    [
        ({"windows": 2}, "windows"),  # gain, offset and one shape direction need 3
        ({"windows": 3, "baseline_periods": 5}, None),
        ({"windows": 64, "baseline_periods": 66}, None),
        ({"windows": 65, "baseline_periods": 67}, "windows"),
        ({"windows": 3, "baseline_periods": 4}, "baseline_periods"),  # == windows + 1
        ({"windows": 6, "baseline_periods": 7}, "baseline_periods"),
        ({"windows": 6, "baseline_periods": 8}, None),  # the least: windows + 2
        ({"baseline_periods": 0}, "baseline_periods"),
        ({"false_alarms_per_hour": 0.0}, "false_alarms_per_hour"),
        ({"false_alarms_per_hour": -1}, "false_alarms_per_hour"),
        ({"false_alarms_per_hour": 1e-12}, None),
        ({"false_alarms_per_hour": 1e6}, None),
        ({"false_alarms_per_hour": 1.000001e6}, "false_alarms_per_hour"),
        ({"false_alarms_per_hour": math.inf}, "false_alarms_per_hour"),
        ({"false_alarms_per_hour": math.nan}, "false_alarms_per_hour"),
        ({"shape_false_alarm": 0.0}, "shape_false_alarm"),
        ({"shape_false_alarm": 1e-12}, None),
        ({"shape_false_alarm": 0.5}, None),
        ({"shape_false_alarm": 0.5000001}, "shape_false_alarm"),
        ({"verdict_periods": 0}, "verdict_periods"),
        ({"verdict_periods": 1}, None),
        ({"verdict_periods": 1000}, None),
        ({"verdict_periods": 1001}, "verdict_periods"),
        ({"window_periods": 0}, "window_periods"),
        ({"window_periods": 1}, None),
        ({"window_periods": 1000}, None),
        ({"window_periods": 1001}, "window_periods"),
        ({"baseline_gap_periods": -1}, "baseline_gap_periods"),
        ({"baseline_gap_periods": 0}, None),
        ({"baseline_gap_periods": 100000}, None),
        ({"baseline_gap_periods": 100001}, "baseline_gap_periods"),
        ({"baseline_gap_periods": None}, None),
    ],
)
def test_each_setting_on_either_side_of_its_bounds(settings, field):
    """Each bound lives in MonitorSettings: the value on its edge (or the least above an
    open one) is accepted, the next one out refused with a SettingError naming the field."""
    if field is None:
        made = MonitorSettings(**settings)
        assert all(getattr(made, k) == v for k, v in settings.items())
    else:
        with pytest.raises(SettingError) as info:
            MonitorSettings(**settings)
        assert info.value.field == field
        assert isinstance(info.value, ValueError)
        assert str(info.value).startswith(f"{field}: must be ")
        assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("settings", "field"),
    [
        ({"windows": True}, "windows"),
        ({"baseline_periods": True}, "baseline_periods"),
        ({"verdict_periods": False}, "verdict_periods"),
        ({"window_periods": 2.0}, "window_periods"),
        ({"windows": "6"}, "windows"),
        ({"false_alarms_per_hour": True}, "false_alarms_per_hour"),
        ({"shape_false_alarm": "0.01"}, "shape_false_alarm"),
        ({"surface": 1}, "surface"),
        ({"surface": "true"}, "surface"),
        ({"baseline_gap_periods": True}, "baseline_gap_periods"),
        ({"baseline_gap_periods": 5.0}, "baseline_gap_periods"),
    ],
)
def test_a_setting_of_the_wrong_kind_is_refused(settings, field):
    """Integers are ints (a bool or a float is not one), numbers are not bools or strings,
    surface is a bool."""
    with pytest.raises(SettingError) as info:
        MonitorSettings(**settings)
    assert info.value.field == field


def test_the_messages_say_what_is_allowed_and_what_was_given():
    cases = {
        "windows": ({"windows": 2}, "must be an integer from 3 to 64, got 2"),
        "baseline_periods": (
            {"windows": 6, "baseline_periods": 7},
            "must be more than windows + 1 (7), got 7",
        ),
        "shape_false_alarm": ({"shape_false_alarm": 0.6}, "must be > 0 and <= 0.5, got 0.6"),
        "surface": ({"surface": "yes"}, "must be true or false, got 'yes'"),
    }
    for field, (settings, message) in cases.items():
        with pytest.raises(SettingError) as info:
            MonitorSettings(**settings)
        assert (info.value.field, info.value.message) == (field, message)


def test_numbers_are_kept_as_floats():
    """A whole rate (TOML's ``1``) is the float 1.0, as the metadata has always had it."""
    made = MonitorSettings(false_alarms_per_hour=1)
    assert type(made.false_alarms_per_hour) is float and made.false_alarms_per_hour == 1.0


def test_numpy_integers_are_integers_and_kept_as_ints():
    """A setting computed with numpy (``np.int64(4)``, what a loop over ``np.arange`` gives)
    is an integer as Scenario.replace's other sections take it, kept as a Python int (the
    metadata's JSON); a bool still is none, and the bounds hold as for an int."""
    import json

    made = MonitorSettings(window_periods=np.int64(4), false_alarms_per_hour=np.float64(0.2))
    assert type(made.window_periods) is int and made.window_periods == 4
    assert json.dumps(made.to_dict())
    with pytest.raises(SettingError, match="must be an integer from 3 to 64, got 2"):
        MonitorSettings(windows=np.int64(2))
    with pytest.raises(SettingError, match=r"must be an integer from 1 to 1000, got np\.True_"):
        MonitorSettings(window_periods=np.bool_(True))


def test_the_false_alarm_probability_per_period_is_capped_at_a_half():
    """A rate that would give more than 0.5 per period is capped there (a test at alpha above
    a half would alarm more often than not); exactly 0.5 is kept."""
    assert MonitorSettings(false_alarms_per_hour=3600.0).alpha(1.0, 2) == 0.5
    assert MonitorSettings(false_alarms_per_hour=3600.0).alpha(1.0, 1) == 0.5
    assert MonitorSettings(false_alarms_per_hour=3600.0).alpha(1.0, 4) == 0.25


def test_from_settings_gives_each_setting_to_its_detector_parameter() -> None:
    """Every [monitor] setting reaches the detector parameter of its meaning (distinct
    values, so a swap or a dropped one fails)."""
    from probing.core.monitor import ChangeDetector, MonitorSettings

    settings = MonitorSettings(
        baseline_periods=17,
        false_alarms_per_hour=3.0,
        windows=5,
        shape_false_alarm=0.02,
        verdict_periods=4,
        window_periods=2,
        surface=True,
        baseline_gap_periods=7,
    )
    d = ChangeDetector.from_settings(31, settings, alpha=0.003)
    assert (d._baseline.periods, d._baseline.window, d._baseline.gap) == (17, 2, 7)
    assert (d.m, d.b, d.k, d.alpha) == (31, 17, 5, 0.003)
    assert (d.shape_alpha, d.surface, d.isolation_periods) == (0.02, True, 4)
    assert d._recent.maxlen == 2  # the periods averaged into each test


# --- estimates without an offset (drift mode "detrend") -------------------------------------


def _zero_sum_periods(rng: np.random.Generator, n: int, gain: float = 1.0) -> list[np.ndarray]:
    """``n`` periods of H0 with noise, each less its own mean (what ``detrend`` leaves): every
    period's taps sum to zero, to rounding."""
    periods = []
    for _ in range(n):
        h = gain * H0 + SIGMA * rng.standard_normal(M)
        periods.append(h - h.mean())
    return periods


def _decisions(periods: list[np.ndarray], surfaces: list[np.ndarray] | None) -> np.ndarray:
    det = _detector(1e-3, baseline_periods=20, surface=surfaces is not None)
    pairs = zip(periods, surfaces or periods, strict=True)
    rows = [det.update(h, None if surfaces is None else s) for h, s in pairs]
    return np.array([(d.statistic, d.gain_change, d.shape_change) for d in rows[20:]])


@pytest.mark.parametrize("surface", [False, True])
def test_the_last_bits_of_detrended_estimates_do_not_move_the_decisions(surface):
    """Estimates whose taps sum to zero, and the same with every tap moved in its last bits
    (1e-15 of itself, what another BLAS kernel's sums do): statistic, gain and shape agree
    to 1e-9, isolated with the surface or without.  Tested in the full K windows, the
    baseline's covariance is singular along the offset: here they moved by 3e-5, in the
    study's damage-case-5 flight the gain by 0.2."""
    rng = np.random.default_rng(11)
    periods = _zero_sum_periods(rng, 20) + _zero_sum_periods(rng, 8, gain=1.3)
    surfaces = _zero_sum_periods(rng, 28) if surface else None
    wobble = np.random.default_rng(12)

    def moved(xs):
        return None if xs is None else [x * (1.0 + 1e-15 * wobble.standard_normal(M)) for x in xs]

    a, b = _decisions(periods, surfaces), _decisions(moved(periods), moved(surfaces))
    assert np.all(np.isfinite(a))
    np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-9)


def test_detrended_estimates_are_hotellings_test_in_the_directions_without_the_offset():
    """The detector on zero-sum estimates against an independent computation: the reduced
    periods projected on scipy's null space of the offset direction u = W 1, numpy's
    covariance and inverse, Hotelling's T^2 and the gain's t test with K - 1 dimensions;
    the gain change is the GLS fit of v0 alone."""
    from scipy.linalg import null_space
    from scipy.stats import f, t

    rng = np.random.default_rng(13)
    b, k = 20, 6
    baseline = _zero_sum_periods(rng, b)
    tested = _zero_sum_periods(rng, 1, gain=1.2)[0]
    det = _detector(1e-3, baseline_periods=b, windows=k)
    for h in baseline:
        det.update(h)
    got = det.update(tested)

    w = window_matrix(M, k)
    q = null_space((w @ np.ones(M))[None, :])  # (K, K - 1)
    v = np.array(baseline) @ w.T @ q
    v0, s = v.mean(axis=0), np.cov(v, rowvar=False)
    d = tested @ w.T @ q - v0
    t2 = d @ np.linalg.inv(s) @ d / (1 + 1 / b)
    dims = k - 1
    p_t2 = f.sf(t2 * (b - dims) / ((b - 1) * dims), dims, b - dims)
    g = v0 @ (d + v0) / (v0 @ v0)
    se = np.sqrt(v0 @ s @ v0 / (v0 @ v0) ** 2 * (1 + 1 / b))
    p_gain = 2 * t.sf(abs(g - 1) / se, b - 1)
    statistic = -np.log10(min(1.0, 2 * min(p_t2, p_gain)))
    gls = (v0 @ np.linalg.solve(s, d)) / (v0 @ np.linalg.solve(s, v0))
    assert got.statistic == pytest.approx(statistic, rel=1e-9)
    assert got.gain_change == pytest.approx(1 + gls, rel=1e-9)


@pytest.mark.parametrize(("fraction", "dims"), [(0.9, 5), (1.1, 6)])
def test_a_baseline_is_without_an_offset_up_to_its_zero_sum_tolerance(fraction, dims):
    """Periods whose taps sum to 0.9 of the tolerance (1e-9 of the sum of their magnitudes)
    are learned in K - 1 directions; at 1.1 of it, in all K."""
    from probing.core import monitor

    rng = np.random.default_rng(14)
    det = _detector(1e-3, baseline_periods=20, windows=6)
    for h in _zero_sum_periods(rng, 20):
        h = h + fraction * monitor._ZERO_SUM * np.abs(h).sum() / M  # sum: fraction x tol
        det.update(h)
    assert det._v.k == dims
