"""The sliding baseline (probing.core.baseline) and both detectors on it: which periods the
baseline holds after each period, exactly, and that each test equals a fixed-baseline
detector learned on just those periods (a second computation)."""

from __future__ import annotations

import numpy as np
import pytest

from probing.core.baseline import BaselineWindow
from probing.core.monitor import ChangeDetector, MonitorSettings
from probing.core.trajectory import TrajectoryDetector

B, W, G = 6, 2, 3


def _expected(n: int, window: int = W, gap: int = G) -> list[int]:
    """The baseline after periods 0 .. n - 1 were added: the first B, then the B ending
    ``window + gap`` periods before the latest."""
    end = max(B, n - window - gap)
    return list(range(end - B, end))


def test_the_baseline_holds_the_first_b_then_the_b_ending_window_plus_gap_before():
    b: BaselineWindow[int] = BaselineWindow(B, W, G)
    changed = []
    for p in range(30):
        changed.append(b.add(p))
        assert b.items == (_expected(p + 1) if b.ready else list(range(p + 1)))
    # learned at period B - 1; then the first slide at exactly period B + W + G, not before
    assert changed.index(True) == B - 1
    assert changed[B : B + W + G] == [False] * (W + G)
    assert all(changed[B + W + G :])


def test_without_a_gap_the_baseline_stays_the_first_periods():
    b: BaselineWindow[int] = BaselineWindow(B, W, None)
    assert [b.add(p) for p in range(40)].count(True) == 1
    assert b.items == list(range(B))


def test_a_frozen_baseline_stops_sliding():
    b: BaselineWindow[int] = BaselineWindow(B, W, 0)
    for p in range(12):
        b.add(p)
    held = b.items
    assert held == _expected(12, gap=0)
    b.freeze()
    assert not any(b.add(p) for p in range(12, 40))
    assert b.items == held


@pytest.mark.parametrize(("periods", "window", "gap"), [(0, 1, 0), (1, 0, 0), (1, 1, -1)])
def test_nonsense_sizes_are_refused(periods, window, gap):
    with pytest.raises(ValueError):
        BaselineWindow(periods, window, gap)


def _fixed_statistic(history, baseline_idx, window_idx, m, alpha):
    """A fixed-baseline detector learned on exactly ``baseline_idx`` and tested on the mean
    of ``window_idx``: the statistic the sliding one must give."""
    det = ChangeDetector.from_settings(
        m, MonitorSettings(baseline_periods=len(baseline_idx), window_periods=W, windows=3), alpha
    )
    for i in baseline_idx:
        det.update(history[i])
    d = None
    for i in window_idx:
        d = det.update(history[i])
    return d.statistic


def test_each_probing_test_is_a_fixed_detector_learned_on_the_sliding_periods():
    """A drifting noise level: the sliding detector's statistic at every period equals that of
    a fresh fixed-baseline detector learned on the periods the baseline should hold."""
    rng = np.random.default_rng(4)
    m, alpha = 31, 1e-3
    h0 = np.exp(-np.arange(m) / 5.0)
    history = [h0 + (1 + p / 20) * 0.05 * rng.standard_normal(m) for p in range(40)]
    settings = MonitorSettings(
        baseline_periods=B, window_periods=W, windows=3, baseline_gap_periods=G
    )
    det = ChangeDetector.from_settings(m, settings, alpha)
    for p, h in enumerate(history):
        d = det.update(h)
        if p < B:
            assert np.isnan(d.statistic)
            continue
        window = list(range(max(B, p - W + 1), p + 1))
        expected = _fixed_statistic(history, _expected(p + 1), window, m, alpha)
        assert d.statistic == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_the_probing_baseline_freezes_at_the_first_alarm():
    """A step change: the detector alarms, and from then on every test is against the
    baseline it held at that period, never one that learned the change."""
    rng = np.random.default_rng(5)
    m, alpha = 31, 1e-3
    h0 = np.exp(-np.arange(m) / 5.0)
    history = [h0 * (1.0 if p < 20 else 0.5) + 0.02 * rng.standard_normal(m) for p in range(45)]
    settings = MonitorSettings(
        baseline_periods=B, window_periods=W, windows=3, baseline_gap_periods=0
    )
    det = ChangeDetector.from_settings(m, settings, alpha)
    first = None
    for p, h in enumerate(history):
        d = det.update(h)
        if d.alarm and first is None:
            first = p
    assert first == 20  # the exact first period of the change
    held = [i for i in range(len(history)) if any(history[i] is x[0] for x in det._baseline.items)]
    assert held == _expected(first + 1, gap=0)
    window = [43, 44]
    assert d.statistic == pytest.approx(
        _fixed_statistic(history, held, window, m, alpha), rel=1e-12
    )
    assert d.alarm  # a sliding baseline would have learned the change by now


def test_the_trajectory_detector_slides_and_freezes_the_same_way():
    rng = np.random.default_rng(6)
    features = [
        np.array([0.0, -1.0]) + (1 + p / 10) * 0.1 * rng.standard_normal(2) for p in range(30)
    ]
    features += [np.array([5.0, -1.0]) for _ in range(10)]
    det = TrajectoryDetector(B, 1e-3, gap=G)
    alarms = []
    for p, x in enumerate(features):
        d = det.update(x)
        if p < B:
            continue
        if not alarms:
            fixed = TrajectoryDetector(B, 1e-3)
            for i in _expected(p + 1, window=1):
                fixed.update(features[i])
            assert d.statistic == pytest.approx(fixed.update(x).statistic, rel=1e-12)
        if d.alarm:
            alarms.append(p)
    assert alarms and alarms[0] == 30
    assert alarms == list(range(30, 40))  # frozen: the step is never learned
