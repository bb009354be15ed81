"""The joint fit of a periodic part and a trend (probing.core.trend) against the closed form."""

from __future__ import annotations

import numpy as np
import pytest

from probing.core.trend import (
    detrend_matrix,
    detrend_periodic,
    detrend_rows,
    periodic_trend_basis,
    remove_periodic_trend,
    trend_projector,
    window_periods,
)


def _old_per_period_fit(y: np.ndarray, period: int, order: int) -> np.ndarray:
    """The earlier detrend: a least-squares polynomial removed from each period on its own."""
    basis = np.vander(np.linspace(-1.0, 1.0, period), order + 1)
    out = []
    for chunk in y.reshape(-1, period):
        coef, *_ = np.linalg.lstsq(basis, chunk, rcond=None)
        out.append(chunk - basis @ coef)
    return np.concatenate(out)


def test_periodic_plus_linear_trend_is_recovered_exactly() -> None:
    """y = p[n mod N] + c0 + c1 n: the trend c1 n goes, the periodic part and the constant
    stay, to rounding; the per-period fit takes a large part of p with it."""
    rng = np.random.default_rng(3)
    period, periods = 31, 5
    p = rng.standard_normal(period)
    n = np.arange(period * periods)
    y = np.tile(p, periods) + 0.7 - 0.013 * n
    got = remove_periodic_trend(y, period, 1)
    np.testing.assert_allclose(got, np.tile(p, periods) + 0.7, rtol=0, atol=1e-12)
    old = _old_per_period_fit(y, period, 1)
    assert np.linalg.norm(old - np.tile(p, periods)) > 0.1 * np.linalg.norm(p) * np.sqrt(periods)


@pytest.mark.parametrize("order", [1, 2, 3])
def test_polynomial_trends_of_each_order(order: int) -> None:
    period, periods = 16, order + 2
    p = np.sin(np.arange(period))
    t = np.arange(period * periods) / (period * periods)
    trend = sum(c * t**k for k, c in zip(range(1, order + 1), (2.0, -3.0, 5.0), strict=False))
    y = np.column_stack([np.tile(p, periods) + trend, np.tile(2 * p, periods) - trend])
    got = remove_periodic_trend(y, period, order)
    np.testing.assert_allclose(got[:, 0], np.tile(p, periods), atol=1e-10)
    np.testing.assert_allclose(got[:, 1], np.tile(2 * p, periods), atol=1e-10)


def test_projector_is_the_same_map() -> None:
    rng = np.random.default_rng(4)
    y = rng.standard_normal(4 * 7)
    got = y - trend_projector(y.size, 7, 2) @ y
    np.testing.assert_allclose(got, remove_periodic_trend(y, 7, 2), atol=1e-12)


def test_purely_periodic_record_is_untouched() -> None:
    y = np.tile(np.arange(5.0), 3)
    np.testing.assert_allclose(remove_periodic_trend(y, 5, 1), y, atol=1e-12)
    np.testing.assert_array_equal(remove_periodic_trend(y, 5, 0), y)


@pytest.mark.parametrize(("length", "period", "order"), [(10, 3, 1), (5, 5, 1), (10, 5, 2)])
def test_refused(length: int, period: int, order: int) -> None:
    with pytest.raises(ValueError):
        periodic_trend_basis(length, period, order)


@pytest.mark.parametrize("order", [0, 1, 2])
def test_detrend_matrix_is_detrend_periodic(order: int) -> None:
    """The noise model's weights (detrend_matrix) and the runs' detrending are one map."""
    rng = np.random.default_rng(6)
    y = rng.standard_normal((3 * 9, 2))
    np.testing.assert_allclose(
        detrend_matrix(27, 9, order) @ y, detrend_periodic(y, 9, order), atol=1e-12
    )
    assert window_periods(order) == max(2, order + 1)


def test_made_up_system_old_detrend_against_joint_fit() -> None:
    """A second-order system whose pulse response is far shorter than the period (M = 255,
    one sample per bit, no noise), with and without a linear drift: the earlier per-period
    polynomial (the cyclic estimators' detrend) is 22 % off the true pulse response; the joint
    fit per window (drift mode detrend) leaves exactly the constant sum(h) / M (12.7 %), the
    shape exact; the whole-record fit with the trend alone removed is exact (docs/method.md,
    "Drift")."""
    from scipy import signal

    from probing.core.noise import cyclic_estimates
    from probing.core.prbs import mls

    m, periods = 255, 6
    b, a, _ = signal.cont2discrete(([1.0], [1.0, 0.5, 0.25]), 1.0)
    h = signal.lfilter(np.ravel(b), a, np.r_[1.0, np.zeros(m - 1)])
    y0 = signal.lfilter(np.ravel(b), a, np.tile(mls(8), periods + 2))[2 * m :]

    def err(est: np.ndarray) -> float:
        return float(np.linalg.norm(est - h) / np.linalg.norm(h))

    for drift in (0.0, 1e-3):
        y = y0 + drift * np.arange(y0.size)
        old = _old_per_period_fit(y[m:], m, 1).reshape(periods - 1, m)  # the cyclic path
        new = np.stack([detrend_periodic(y[(p - 1) * m : (p + 1) * m], m, 1)[m:]
                        for p in range(1, periods)])  # fmt: skip
        whole = remove_periodic_trend(y, m, 1).reshape(periods, m)
        h_old, h_new, h_whole = (cyclic_estimates(x, mls(8), 1.0)[2].mean(axis=0)
                                 for x in (old, new, whole))  # fmt: skip
        assert err(h_old) == pytest.approx(0.224, abs=0.002)
        assert err(h_new) == pytest.approx(0.127, abs=0.002)
        np.testing.assert_allclose(h_new, h - h.sum() / m, atol=1e-12)
        assert err(h_whole) < 1e-12


@pytest.mark.parametrize("order", [0, 1, 3])
def test_detrend_rows_is_the_product_with_the_detrend_map(order: int) -> None:
    """Weights on the detrended record, from the map's factors, equal the weights times D =
    (I - J)(I - T) built here with numpy's pseudo-inverse (an independent construction)."""
    length, period = 36, 9
    trend, orth = periodic_trend_basis(length, period, order)
    t = trend @ np.linalg.pinv(orth) if order else np.zeros((length, length))
    d = np.eye(length) - t
    d = d - d.mean(axis=0, keepdims=True)
    rows = np.random.default_rng(order).standard_normal((5, length))
    np.testing.assert_allclose(detrend_rows(rows, period, order), rows @ d, atol=1e-13)
