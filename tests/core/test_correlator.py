"""The streaming correlator against a direct sliding correlation and known FIR plants."""

import numpy as np
import pytest

from probing.core.correlator import StreamingCorrelator
from probing.core.prbs import mls


def _direct_z(y: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Eq. (5) literally: z[k] = sum_j y[k-M+1+j] sigma[j], NaN for k < M-1."""
    m = sigma.size
    z = np.full(y.size, np.nan)
    for k in range(m - 1, y.size):
        z[k] = np.dot(y[k - m + 1 : k + 1], sigma)
    return z


def _push_in_chunks(corr: StreamingCorrelator, y: np.ndarray, rng) -> np.ndarray:
    parts, i = [], 0
    while i < y.size:
        n = int(rng.integers(1, 3 * corr.length))
        parts.append(corr.push(y[i : i + n]))
        i += n
    return np.concatenate(parts)


@pytest.mark.parametrize("order", [2, 3, 5, 9])
def test_z_matches_direct_sliding_correlation(order: int) -> None:
    rng = np.random.default_rng(order)
    sigma = mls(order)
    y = rng.standard_normal(sigma.size * 7 + 3)
    z = StreamingCorrelator(sigma, amplitude=1.0).push(y)
    expected = _direct_z(y, sigma)
    assert np.array_equal(np.isnan(z), np.isnan(expected))
    scale = np.nanmax(np.abs(expected))
    np.testing.assert_allclose(z, expected, rtol=0, atol=1e-12 * scale)


@pytest.mark.parametrize("order", [3, 6, 9, 11])
def test_chunked_equals_whole(order: int) -> None:
    rng = np.random.default_rng(100 + order)
    sigma = mls(order)
    y = rng.standard_normal(sigma.size * 5 + 17)
    whole = StreamingCorrelator(sigma, 0.3)
    z_whole = whole.push(y)
    chunked = StreamingCorrelator(sigma, 0.3)
    z_chunked = _push_in_chunks(chunked, y, rng)
    assert np.array_equal(np.isnan(z_whole), np.isnan(z_chunked))
    np.testing.assert_allclose(z_chunked, z_whole, rtol=0, atol=1e-12 * np.nanmax(abs(z_whole)))
    a, b = whole.pop_periods(), chunked.pop_periods()
    np.testing.assert_array_equal(a.period, b.period)
    np.testing.assert_allclose(b.h, a.h, rtol=0, atol=1e-12 * np.nanmax(abs(a.h)))


@pytest.mark.parametrize("order", [5, 9])
def test_recovers_fir_pulse_response(order: int) -> None:
    rng = np.random.default_rng(7)
    sigma = mls(order)
    m = sigma.size
    a = 0.005
    # A known M-tap plant with a large DC component (sum h != 0), like pitch.
    h = rng.standard_normal(m) * np.exp(-np.arange(m) / (m / 8)) + 0.3
    probe = a * np.tile(sigma, 4)
    y = np.convolve(probe, h)[: probe.size]  # plant at rest before the first sample
    corr = StreamingCorrelator(sigma, a)
    _push_in_chunks(corr, y, rng)
    est = corr.pop_periods()
    np.testing.assert_array_equal(est.period, [0, 1, 2, 3])
    assert np.all(np.isnan(est.h[0]))  # period 0 is incomplete (z NaN before M samples)
    # Period 1 still correlates outputs of period 0, when the plant was not yet in the
    # cyclic steady state; from period 2 on every window holds steady-state output only.
    assert not np.allclose(est.h[1], h, atol=1e-6)
    for p in (2, 3):
        np.testing.assert_allclose(est.h[p], h, rtol=0, atol=1e-9 * np.max(np.abs(h)))
        # eq. (8): z = a[(M+1) h - sum h]; eq. (9): zeta = a (M+1) h
        np.testing.assert_allclose(est.z[p], a * ((m + 1) * h - h.sum()), atol=1e-9 * a * m)
        np.testing.assert_allclose(est.zeta[p], a * (m + 1) * h, atol=1e-9 * a * m)
    np.testing.assert_allclose(corr.pulse_response(average=2), h, atol=1e-9 * np.max(abs(h)))


def test_tap_alignment_of_a_pure_delay() -> None:
    sigma = mls(6)
    for delay in (0, 1, 5, sigma.size - 1):
        h = np.zeros(sigma.size)
        h[delay] = 2.0
        y = np.convolve(np.tile(sigma, 3), h)[: 3 * sigma.size]
        corr = StreamingCorrelator(sigma, 1.0)
        corr.push(y)
        est = corr.pulse_response()
        assert np.argmax(est) == delay
        np.testing.assert_allclose(est, h, atol=1e-12)


def test_pulse_response_averages_latest_periods() -> None:
    sigma = mls(4)
    corr = StreamingCorrelator(sigma, 1.0, keep=2)
    rng = np.random.default_rng(3)
    corr.push(rng.standard_normal(sigma.size * 4))
    est = corr.pop_periods()
    np.testing.assert_allclose(corr.pulse_response(2), est.h[-2:].mean(axis=0))
    with pytest.raises(ValueError, match="average"):
        corr.pulse_response(3)


def test_no_period_yet_is_an_error() -> None:
    corr = StreamingCorrelator(mls(4), 1.0)
    corr.push(np.ones(5))
    with pytest.raises(RuntimeError, match="no complete period"):
        corr.pulse_response()
    assert len(corr.pop_periods()) == 0


@pytest.mark.parametrize(
    ("reference", "amplitude", "match"),
    [(np.ones(2), 1.0, "reference"), (mls(4), 0.0, "amplitude"), (mls(4), np.nan, "amplitude")],
)
def test_rejects_bad_arguments(reference, amplitude, match) -> None:
    with pytest.raises(ValueError, match=match):
        StreamingCorrelator(reference, amplitude)
