"""Figures of merit: the closed-form noise of the estimator against a Monte-Carlo run of the
streaming correlator, and the gain/shape fit against constructed responses."""

from __future__ import annotations

import math

import numpy as np
import pytest

from probing.core.correlator import StreamingCorrelator
from probing.core.metrics import estimator_noise_std, gain_and_shape, predicted_apparent
from probing.core.nonlinearities import Backlash, Deadband, RateLimit
from probing.core.prbs import mls


@pytest.mark.parametrize("order", [4, 6, 8])
def test_estimator_noise_matches_monte_carlo(order: int) -> None:
    ref = mls(order)
    m, a, sigma = ref.size, 0.3, 0.05
    periods = 4000
    corr = StreamingCorrelator(ref, a, keep=2)
    corr.push(np.random.default_rng(order).standard_normal(m * periods) * sigma)
    h = corr.pop_periods().h[1:]  # period 0 reads zeros before the stream
    theory = estimator_noise_std(ref, a, sigma)
    # Sampling error of a standard deviation from ~4000 draws: ~1.1 %; allow 5 sigma.
    assert np.max(np.abs(h.std(axis=0) / theory - 1.0)) < 0.06
    # The DC correction makes it far noisier than the naive sigma / (a sqrt(M)) for long M.
    naive = sigma / (a * math.sqrt(m))
    assert np.sqrt(np.mean(theory**2)) > (2.0 if m > 100 else 1.5) * naive


@pytest.mark.parametrize("order", [3, 5, 7])
def test_estimator_noise_equals_the_correlators_exact_response_to_unit_impulses(order: int):
    """Period 1's h is linear in the 2M samples of periods 0 and 1: h = W u.  Pushing a unit
    impulse at each sample through the streaming correlator gives W column by column, and
    std(h_i) = sigma ||W[i, :]|| exactly; the closed form must agree tap by tap."""
    ref = mls(order)
    m, a, sigma = ref.size, 0.3, 0.05
    w = np.empty((m, 2 * m))
    for k in range(2 * m):
        u = np.zeros(2 * m)
        u[k] = 1.0
        corr = StreamingCorrelator(ref, a, keep=2)
        corr.push(u)
        w[:, k] = corr.pop_periods().h[1]
    exact = sigma * np.linalg.norm(w, axis=1)
    np.testing.assert_allclose(estimator_noise_std(ref, a, sigma), exact, rtol=1e-12)


def test_estimator_noise_scales_linearly() -> None:
    ref = mls(5)
    base = estimator_noise_std(ref, 1.0, 1.0)
    assert np.allclose(estimator_noise_std(ref, 2.0, 3.0), 1.5 * base)


def test_gain_and_shape() -> None:
    t = np.arange(50) * 0.1
    h0 = np.exp(-t) * np.sin(2 * t)
    g, shape = gain_and_shape(0.4 * h0, h0)
    assert g == pytest.approx(0.4) and shape == pytest.approx(0.0, abs=1e-12)
    bump = np.zeros_like(h0)
    bump[3] = 0.1
    bump -= np.dot(bump, h0) / np.dot(h0, h0) * h0  # orthogonal to h0: gain unchanged
    g, shape = gain_and_shape(0.4 * h0 + bump, h0)
    assert g == pytest.approx(0.4)
    assert shape == pytest.approx(np.linalg.norm(bump) / np.linalg.norm(0.4 * h0))


def test_predicted_apparent() -> None:
    assert predicted_apparent(None, 0.01, 0.1) == (1.0, 0.0)
    assert predicted_apparent(Deadband(-0.004, 0.004), 0.01, 0.1) == pytest.approx((0.6, 0.0))
    assert predicted_apparent(Backlash(0.005), 0.01, 0.1) == pytest.approx((0.75, 0.0))
    # Rate limit: 2a/t0 = 0.2 deg/s.
    assert predicted_apparent(RateLimit(0.2), 0.01, 0.1) == (1.0, 0.0)
    assert all(math.isnan(v) for v in predicted_apparent(RateLimit(0.19), 0.01, 0.1))
