"""The estimators and their noise model against independent truths: the streaming correlator's
own response to unit impulses, a closed form derived by hand, the exact inverse of the periodic
probe, and Monte Carlo through the estimators' own code (white and coloured noise)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from probing.core.correlator import StreamingCorrelator
from probing.core.noise import (
    cyclic_estimates,
    estimator_weights,
    noise_model,
    white,
)
from probing.core.prbs import mls
from probing.core.trend import detrend_periodic, window_periods

A = 0.3  # probe amplitude


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def streaming_h(u: np.ndarray, ref: np.ndarray, a: float = A) -> np.ndarray:
    """h of every complete period by the streaming correlator itself, (P, M)."""
    corr = StreamingCorrelator(ref, a)
    corr.push(u)
    return corr.pop_periods().h


def closed_form_std(ref: np.ndarray, a: float, sigma: float) -> np.ndarray:
    """One period's h std of the streaming estimator under white noise, derived by hand:
    in the 2M samples of periods p-1 and p, z of the sample r reads sigma_j at r+1+j, the
    period sum S reads the partial sums s of the sequence, tap i is read at r = i - 1, so
    ||w_r + s||^2 = M + 2 sum_j sigma_j s[r+1+j] + ||s||^2."""
    m = ref.size
    s = np.zeros(2 * m)
    s[1:] = np.convolve(np.ones(m), ref)
    cross = np.correlate(s, ref, mode="valid")
    r_of_tap = (np.arange(m) - 1) % m
    norm2 = m + 2.0 * cross[r_of_tap + 1] + np.dot(s, s)
    return sigma * np.sqrt(norm2) / (a * (m + 1))


# ------------------------------------------------------------------ the estimators
@pytest.mark.parametrize("order", [3, 5, 7])
def test_streaming_weights_are_the_correlators_response_to_unit_impulses(order: int) -> None:
    ref = mls(order)
    m = ref.size
    z_rows, h_rows = estimator_weights(ref, A, "streaming")
    for k in range(2 * m):
        u = np.zeros(2 * m)
        u[k] = 1.0
        corr = StreamingCorrelator(ref, A)
        corr.push(u)
        est = corr.pop_periods()
        np.testing.assert_allclose(est.h[1], h_rows[:, k], rtol=0, atol=1e-12)
        np.testing.assert_allclose(est.z[1], z_rows[:, k], rtol=0, atol=1e-12)


@pytest.mark.parametrize("order", [3, 6, 9])
def test_cyclic_estimators_invert_the_periodic_probe(order: int) -> None:
    """On a periodic output, cyclic = streaming = the folded pulse response; ac = it minus
    sum(h) / (M+1); and the FFT implementation equals the weights."""
    ref = mls(order)
    m = ref.size
    rng = np.random.default_rng(order)
    h = rng.standard_normal(m) * np.exp(-np.arange(m) / (m / 4))
    p = A * np.tile(ref, 3)
    y = np.convolve(np.tile(p, 2), h)[p.size : 2 * p.size]  # periodic: started long before
    periods = y.reshape(3, m)
    z, _, hc = cyclic_estimates(periods, ref, A, dc=True)
    np.testing.assert_allclose(hc, np.tile(h, (3, 1)), atol=1e-12)
    np.testing.assert_allclose(streaming_h(y, ref)[1:], hc[1:], atol=1e-12)
    _, _, hac = cyclic_estimates(periods, ref, A, dc=False)
    np.testing.assert_allclose(hac, np.tile(h - h.sum() / (m + 1), (3, 1)), atol=1e-12)
    for name, est in (("cyclic", hc), ("ac", hac)):
        np.testing.assert_allclose(periods @ estimator_weights(ref, A, name)[1].T, est, atol=1e-12)
    np.testing.assert_allclose(periods @ estimator_weights(ref, A, "ac")[0].T, z, atol=1e-12)


# ------------------------------------------------------------------ white noise, exact
@pytest.mark.parametrize("order", [4, 7, 9])
def test_one_streaming_period_equals_the_closed_form(order: int) -> None:
    ref = mls(order)
    got = noise_model(ref, A, "streaming", 1, white(0.05)).h_std()
    np.testing.assert_allclose(got, closed_form_std(ref, A, 0.05), rtol=1e-10)


@pytest.mark.parametrize("order", [4, 9])
def test_the_cyclic_estimators_cost_sqrt2_and_1_times_the_naive_rule(order: int) -> None:
    """Exactly, tap by tap: cyclic sqrt(2 (M+1)) / (M+1) sigma / a, ac sqrt(M) / (M+1) sigma / a,
    and both divide by sqrt(P) (their periods share no sample)."""
    ref = mls(order)
    m, sigma = ref.size, 0.05
    for periods in (1, 7):
        cyclic = noise_model(ref, A, "cyclic", periods, white(sigma)).h_std()
        ac = noise_model(ref, A, "ac", periods, white(sigma))
        scale = sigma / (A * (m + 1) * math.sqrt(periods))
        np.testing.assert_allclose(cyclic, math.sqrt(2 * (m + 1)) * scale, rtol=1e-12)
        np.testing.assert_allclose(ac.h_std(), math.sqrt(m) * scale, rtol=1e-12)
        np.testing.assert_allclose(ac.z_std(), sigma * math.sqrt(m / periods), rtol=1e-12)
    assert rms(noise_model(mls(9), 1, "streaming", 1, white(1)).h_std()) * math.sqrt(511) > 16


# ------------------------------------------------------------------ Monte Carlo
def ar1(rng: np.random.Generator, shape: tuple[int, int], phi: float) -> np.ndarray:
    """AR(1) noise of unit innovations, started in its stationary distribution."""
    e = rng.standard_normal(shape)
    x = np.empty(shape)
    x[:, 0] = e[:, 0] / math.sqrt(1 - phi**2)
    for k in range(1, shape[1]):
        x[:, k] = phi * x[:, k - 1] + e[:, k]
    return x


def estimates(u: np.ndarray, ref: np.ndarray, estimator: str, periods: int) -> np.ndarray:
    """Mean over the last ``periods`` periods of each realisation, by the estimators' code."""
    m = ref.size
    out = []
    for row in u:
        if estimator == "streaming":
            h = streaming_h(row, ref)
        else:
            h = cyclic_estimates(row.reshape(-1, m), ref, A, dc=estimator == "cyclic")[2]
        out.append(h[-periods:].mean(axis=0))
    return np.array(out)


@pytest.mark.parametrize("estimator", ["streaming", "cyclic", "ac"])
@pytest.mark.parametrize(("phi", "periods"), [(0.0, 1), (0.0, 5), (0.9, 5)])
def test_noise_model_matches_monte_carlo(estimator: str, phi: float, periods: int) -> None:
    """2000 realisations through the estimators themselves; the sampling error of a standard
    deviation from 2000 draws is 1.6 %, of its RMS over 63 taps less: 5 % is > 3 sigma.
    The streaming mean of 5 periods is 2.4x below the independent-periods guess."""
    ref = mls(6)
    m, n_real = ref.size, 2000
    rng = np.random.default_rng(17)
    u = ar1(rng, (n_real, (periods + 1) * m), phi)
    acov = phi ** np.arange((periods + 1) * m) / (1 - phi**2)
    model = noise_model(ref, A, estimator, periods, acov)
    measured = estimates(u, ref, estimator, periods).std(axis=0)
    assert rms(measured) / rms(model.h_std()) == pytest.approx(1.0, abs=0.05)
    assert np.max(np.abs(measured / model.h_std() - 1)) < 0.12  # every tap
    if estimator == "streaming" and periods > 1 and phi == 0:
        independent = noise_model(ref, A, estimator, 1, acov).h_std() / math.sqrt(periods)
        assert rms(independent) > 2 * rms(model.h_std())


def test_gain_std_matches_monte_carlo() -> None:
    ref = mls(6)
    m, periods = ref.size, 4
    h_ref = np.exp(-np.arange(m) / 8.0) - 0.2
    rng = np.random.default_rng(3)
    u = 0.05 * rng.standard_normal((3000, (periods + 1) * m))
    model = noise_model(ref, A, "streaming", periods, white(0.05))
    gains = estimates(u, ref, "streaming", periods) @ h_ref / (h_ref @ h_ref)
    assert gains.std() / model.gain_std(h_ref) == pytest.approx(1.0, abs=0.05)


@pytest.mark.parametrize(("estimator", "order"), [("cyclic", 1), ("streaming", 1), ("ac", 2)])
def test_detrended_weights_match_monte_carlo(estimator: str, order: int) -> None:
    """Drift mode detrend: each period's estimate reads the window of window_periods(order)
    periods ending with its own, detrended by the joint fit (probing.core.trend); a linear
    drift goes exactly, so the scatter is the model's."""
    ref = mls(5)
    m, periods, w = ref.size, 3, window_periods(order)
    rng = np.random.default_rng(5)
    n = (periods + w - 1) * m
    u = rng.standard_normal((3000, n)) + np.linspace(0, 50, n)  # + a drift
    _, h_rows = estimator_weights(ref, A, estimator)
    got = []
    for row in u:
        ends = [(p + w) * m for p in range(periods)]
        windows = [detrend_periodic(row[e - w * m : e], m, order) for e in ends]
        got.append(np.mean([h_rows @ x[-h_rows.shape[1] :] for x in windows], axis=0))
    model = noise_model(ref, A, estimator, periods, white(1.0), detrend_order=order)
    assert rms(np.std(got, axis=0)) / rms(model.h_std()) == pytest.approx(1.0, abs=0.05)


@pytest.mark.parametrize("estimator", ["streaming", "cyclic", "ac"])
def test_sampled_noise_is_the_estimators_on_each_realisation(estimator: str) -> None:
    """Noise given as realisations (turbulence the twin leaves: neither stationary nor
    additive) is the variance over them of the estimators' own settled mean, to rounding,
    for h and for the gain; a growing noise (its level doubling over the run) included, which
    no stationary autocovariance describes."""
    ref = mls(5)
    m, settle, periods = ref.size, 2, 3
    rng = np.random.default_rng(5)
    growth = np.linspace(1.0, 2.0, (settle + periods) * m)
    u = 0.05 * growth * ar1(rng, (40, (settle + periods) * m), 0.8)
    h_ref = np.exp(-np.arange(m) / 6.0)
    model = noise_model(ref, A, estimator, periods, white(0.0)).with_noise(
        white(0.0), u, first=settle
    )
    h = estimates(u, ref, estimator, periods)  # the last `periods`: settle .. settle + 2
    np.testing.assert_allclose(model.h_std(), h.std(axis=0, ddof=1), rtol=1e-9)
    gains = h @ h_ref / (h_ref @ h_ref)
    assert model.gain_std(h_ref) == pytest.approx(gains.std(ddof=1), rel=1e-9)
    with pytest.raises(ValueError, match="do not hold"):
        model.with_noise(white(0.0), u[:, : 4 * m], first=settle).h_std()
