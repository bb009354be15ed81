"""The joint fit of a periodic part and a trend (probing.core.trend) against the closed form."""

from __future__ import annotations

import numpy as np
import pytest

from probing.core.trend import periodic_trend_basis, remove_periodic_trend, trend_projector


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
