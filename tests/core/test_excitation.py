"""The probe's signals (PRBS, multisine, chirp) and their estimator, against closed-form truth:
made-up FIR systems through scipy's own filter, the m-sequence's own estimator, the band's
rules on both sides of each bound."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps

from probing.core.excitation import (
    CHIRP_MIN_POWER,
    MIN_HARMONICS,
    BandError,
    Excitation,
    band_harmonics,
    band_limited,
    chirp,
    crest_factor,
    multisine,
    spectral_estimates,
)
from probing.core.metrics import harmonic_ratio, through_nonlinearity
from probing.core.noise import cyclic_estimates, estimator_weights, noise_model, white
from probing.core.nonlinearities import Backlash, Deadband, RateLimit
from probing.core.prbs import Probe, mls

ORDER, T0 = 8, 0.02  # M = 255, T = 5.1 s, 1/T = 0.196 Hz, Nyquist 25 Hz
M = 2**ORDER - 1
BAND = (0.5, 8.0)
#: A made-up FIR: a damped oscillation, far shorter than the period.
FIR = np.exp(-np.arange(60) / 8.0) * np.sin(np.arange(60) / 3.0) + 0.3 * (np.arange(60) == 2)


def steady_state(u: np.ndarray, b: np.ndarray, periods: int = 3) -> np.ndarray:
    """The FIR's output over the last of ``periods`` periods of the cyclic input ``u``
    (scipy's filter: a second implementation, not the FFT of the estimator)."""
    y = sps.lfilter(b, [1.0], np.tile(u, periods))
    return y[-u.size :]


def folded(b: np.ndarray, m: int) -> np.ndarray:
    """The FIR's taps folded over a period of m samples."""
    out = np.zeros(m)
    np.add.at(out, np.arange(b.size) % m, b)
    return out


def signals() -> dict[str, tuple[np.ndarray, np.ndarray | None]]:
    k = band_harmonics(BAND, ORDER, T0)
    return {
        "prbs": (mls(ORDER), None),
        "multisine": (multisine(ORDER, k), k),
        "chirp-linear": (chirp(ORDER, T0, BAND, "linear"), k),
        "chirp-log": (chirp(ORDER, T0, BAND, "log"), k),
    }


@pytest.mark.parametrize("name", ["prbs", "multisine", "chirp-linear", "chirp-log"])
def test_each_signal_recovers_the_fir_over_its_band(name: str) -> None:
    """Noise-free periodic steady state: the estimate is the FIR's pulse response projected
    on the signal's harmonics (all of them for the PRBS), to rounding."""
    u, k = signals()[name]
    amplitude = 0.7
    y = steady_state(amplitude * u, FIR)
    _, zeta, h = spectral_estimates(y, u, amplitude, k)
    truth = band_limited(folded(FIR, M), k)
    np.testing.assert_allclose(h, truth, rtol=0, atol=1e-12 * np.abs(truth).max())
    np.testing.assert_allclose(zeta, amplitude * (M + 1) * h, rtol=1e-15)
    if k is None:  # the PRBS recovers the FIR itself
        np.testing.assert_allclose(h, folded(FIR, M), atol=1e-12)
    else:  # a band misses the rest: the FIR is not recovered whole
        assert np.linalg.norm(h - folded(FIR, M)) > 0.05 * np.linalg.norm(FIR)


def test_the_band_projection_is_the_harmonics_of_the_truth() -> None:
    """band_limited keeps exactly the band's DFT bins (checked with a full complex DFT)."""
    k = band_harmonics(BAND, ORDER, T0)
    h = folded(FIR, M)
    spectrum = np.fft.fft(band_limited(h, k))
    full = np.fft.fft(h)
    keep = np.zeros(M, dtype=bool)
    keep[k] = keep[M - k] = True
    np.testing.assert_allclose(spectrum[keep], full[keep], atol=1e-12)
    np.testing.assert_allclose(spectrum[~keep], 0.0, atol=1e-12)


def test_prbs_spectral_is_the_cyclic_estimator() -> None:
    """With every harmonic and DC, the spectral estimator is the paper's cyclic one."""
    rng = np.random.default_rng(3)
    y = rng.normal(size=(4, M))  # any samples: the two are the same linear map
    for a, b in zip(
        spectral_estimates(y, mls(ORDER), 0.3, None),
        cyclic_estimates(y, mls(ORDER), 0.3),
        strict=True,
    ):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)


def test_a_constant_output_leaves_a_band_estimate_at_zero() -> None:
    """A multisine has no DC: a level offset of the output (a trim error) does not enter."""
    u, k = signals()["multisine"]
    _, _, h = spectral_estimates(np.full(M, 3.0), u, 1.0, k)
    np.testing.assert_allclose(h, 0.0, atol=1e-12)


def test_the_multisine_excites_its_band_only_at_unit_rms() -> None:
    u, k = signals()["multisine"]
    power = np.abs(np.fft.rfft(u)) ** 2
    outside = np.ones(power.size, dtype=bool)
    outside[k] = False
    assert np.sqrt(np.mean(u**2)) == pytest.approx(1.0, rel=1e-12)
    assert power[outside].max() < 1e-20 * power[k].min()
    np.testing.assert_allclose(power[k], power[k].mean(), rtol=1e-9)  # equal harmonics


def test_the_refined_multisine_has_a_lower_crest_factor_than_schroeders() -> None:
    """Schroeder's phases, rebuilt here from their formula, against the refined ones."""
    k = band_harmonics(BAND, ORDER, T0)
    j = np.arange(1, k.size + 1)
    n = np.arange(M)
    schroeder = np.cos(2 * np.pi * np.outer(n, k) / M - np.pi * j * (j - 1) / k.size).sum(axis=1)
    refined = multisine(ORDER, k)
    assert crest_factor(refined) < 0.9 * crest_factor(schroeder)
    assert crest_factor(refined) < 1.6
    np.testing.assert_array_equal(refined, multisine(ORDER, k))  # the same bytes every time


def test_crest_factors_of_known_signals() -> None:
    assert crest_factor(mls(ORDER)) == pytest.approx(1.0, abs=1e-3)  # sum -1: RMS just below 1
    t = np.arange(1000) / 1000
    assert crest_factor(np.sin(2 * np.pi * 5 * t)) == pytest.approx(np.sqrt(2), rel=1e-9)


def test_the_chirp_sweeps_its_band() -> None:
    """Zero phase at the start; the linear sweep's zero crossings follow f0 + (f1 - f0) t/T;
    the log sweep dwells longer low (power per harmonic falls with frequency)."""
    lin = chirp(10, 0.01, (0.5, 5.0), "linear")  # M = 1023, T = 10.23 s
    assert lin[0] == 0.0
    assert np.sqrt(np.mean(lin**2)) == pytest.approx(1.0, rel=1e-12)
    period = 1023 * 0.01
    t = np.arange(1023) * 0.01
    phase = 2 * np.pi * (0.5 * t + 4.5 * t**2 / (2 * period))
    expected_crossings = int(np.floor(phase[-1] / np.pi))
    crossings = int(np.sum(np.diff(np.signbit(lin)) != 0))
    assert abs(crossings - expected_crossings) <= 1
    log = chirp(10, 0.01, (0.5, 5.0), "log")
    k = band_harmonics((0.5, 5.0), 10, 0.01)
    p_lin, p_log = (np.abs(np.fft.rfft(x)[k]) ** 2 for x in (lin, log))
    half = k.size // 2
    assert p_log[:half].mean() > 2 * p_log[half:].mean()  # ~ 1/f: 2.5 expected
    assert 0.5 < p_lin[:half].mean() / p_lin[half:].mean() < 2


def test_a_chirp_that_misses_harmonics_is_refused() -> None:
    """A band whose harmonics a short sweep cannot all excite: refused, naming the rule."""
    with pytest.raises(BandError, match=f"less than {CHIRP_MIN_POWER:g}"):
        chirp(6, 0.01, (2.0, 50.0), "linear")  # at Nyquist, sampled at its zeros


class TestTheBand:
    """1/T <= low, high <= 1/(2 t0), at least MIN_HARMONICS harmonics: both sides of each."""

    first = 1 / (M * T0)
    nyquist = 0.5 / T0

    def test_the_first_harmonic_is_the_lowest_low(self) -> None:
        assert band_harmonics((self.first, 1.0), ORDER, T0)[0] == 1
        with pytest.raises(BandError, match="below the period's first harmonic"):
            band_harmonics((self.first * (1 - 1e-6), 1.0), ORDER, T0)

    def test_nyquist_is_the_highest_high(self) -> None:
        assert band_harmonics((1.0, self.nyquist), ORDER, T0)[-1] == (M - 1) // 2
        with pytest.raises(BandError, match="above the bits' Nyquist"):
            band_harmonics((1.0, self.nyquist * (1 + 1e-6)), ORDER, T0)

    def test_fewest_harmonics(self) -> None:
        k = band_harmonics((self.first, MIN_HARMONICS * self.first), ORDER, T0)
        assert k.tolist() == [1, 2, 3]
        with pytest.raises(BandError, match="holds 2 harmonic"):
            band_harmonics((self.first, (MIN_HARMONICS - 0.5) * self.first), ORDER, T0)

    @pytest.mark.parametrize("band", [(2.0, 1.0), (1.0, 1.0), (-1.0, 2.0), (np.nan, 2.0)])
    def test_reversed_empty_or_invalid(self, band: tuple[float, float]) -> None:
        with pytest.raises(BandError):
            band_harmonics(band, ORDER, T0)


class TestProbe:
    def test_the_prbs_is_unchanged(self) -> None:
        probe = Probe(ORDER, T0, 0.2)
        np.testing.assert_array_equal(probe.reference(), mls(ORDER))
        np.testing.assert_array_equal(probe.bits(2), np.tile(0.2 * mls(ORDER), 2))
        assert probe.harmonics is None
        assert probe.peak_deg == 0.2
        assert probe.peak_step_rate_deg_s == pytest.approx(2 * 0.2 / T0, rel=1e-15)

    def test_a_multisine_probe_has_rms_a(self) -> None:
        probe = Probe(ORDER, T0, 0.2, Excitation("multisine", BAND))
        bits = probe.bits(1)
        assert np.sqrt(np.mean(bits**2)) == pytest.approx(0.2, rel=1e-12)
        assert probe.peak_deg == pytest.approx(np.abs(bits).max(), rel=1e-15)
        jumps = np.abs(np.diff(np.append(bits, bits[0])))
        assert probe.peak_step_rate_deg_s == pytest.approx(jumps.max() / T0, rel=1e-12)
        assert probe.peak_step_rate_deg_s < 2 * 0.2 / T0  # gentler on a rate limit than the PRBS
        np.testing.assert_array_equal(probe.samples(T0 / 2, 1), np.repeat(bits, 2))

    def test_a_band_the_bits_cannot_carry_is_refused_when_built(self) -> None:
        with pytest.raises(BandError):
            Probe(ORDER, T0, 0.2, Excitation("chirp", (1.0, 30.0)))

    @pytest.mark.parametrize(
        "kwargs",
        [{"signal": "prbs", "band_hz": (1.0, 2.0)}, {"signal": "chirp"}, {"signal": "square"}],
    )
    def test_an_excitation_without_its_fields_is_refused(self, kwargs: dict) -> None:
        with pytest.raises(ValueError):
            Excitation(**kwargs)


class TestThroughANonlinearity:
    """harmonic_ratio and through_nonlinearity against closed forms."""

    def test_a_wire_passes_every_harmonic(self) -> None:
        u, k = signals()["multisine"]
        ratio = harmonic_ratio(None, 0.3 * u, 0.01)
        np.testing.assert_allclose(ratio[k], 1.0, rtol=1e-12)
        assert np.isnan(ratio[0])  # DC: the multisine has none
        h0 = folded(FIR, M)
        np.testing.assert_allclose(
            through_nonlinearity(h0, ratio, k), band_limited(h0, k), atol=1e-14
        )

    def test_the_prbs_through_a_dead_band_sees_a_tilde_over_a_everywhere_but_dc(self) -> None:
        """Eqs. 10-12: the two levels +-(a - d): every harmonic but DC scaled by a~/a."""
        a, d = 0.3, 0.1
        nl = Deadband(-d, d)
        ratio = harmonic_ratio(nl, a * mls(ORDER), 0.01)
        np.testing.assert_allclose(ratio[1:], (a - d) / a, rtol=1e-12)

    def test_a_multisine_through_a_dead_band_is_distorted(self) -> None:
        """Not one gain: the harmonics see different gains, each equal to the ratio of the
        spectra of the dead band's output (computed here by its own formula) and input."""
        a, d = 0.3, 0.1
        u, k = signals()["multisine"]
        p = a * u
        q = np.where(np.abs(p) > d, p - d * np.sign(p), 0.0)  # the dead band, written out
        ratio = harmonic_ratio(Deadband(-d, d), p, 0.01)
        np.testing.assert_allclose(ratio[k], (np.fft.rfft(q) / np.fft.rfft(p))[k], rtol=1e-10)
        assert np.ptp(np.abs(ratio[k])) > 0.05

    def test_a_hysteretic_nonlinearity_is_read_in_its_periodic_state(self) -> None:
        """Backlash of width b on the PRBS: after the first period the output has the two
        levels +-(a - b/2), the paper's a~ = a - b/2 on every harmonic but DC."""
        a, b = 0.3, 0.2
        ratio = harmonic_ratio(Backlash(b), a * mls(ORDER), 0.01)
        np.testing.assert_allclose(ratio[1:], (a - b / 2) / a, rtol=1e-12)


def test_the_noise_model_of_the_spectral_estimator_is_its_scatter() -> None:
    """Its weights reproduce its estimates, and the model's per-tap scatter for white noise is
    what 4000 noise realisations through the estimator give (to their sampling error)."""
    u, k = signals()["multisine"]
    rng = np.random.default_rng(11)
    y = rng.normal(size=(3, M))
    z_rows, h_rows = estimator_weights(u, 0.5, "spectral", k)
    z, _, h = spectral_estimates(y, u, 0.5, k)
    np.testing.assert_allclose(y @ h_rows.T, h, atol=1e-12)
    np.testing.assert_allclose(y @ z_rows.T, z, atol=1e-10)
    sigma, periods = 0.2, 2
    model = noise_model(u, 0.5, "spectral", periods, white(sigma), harmonics=k)
    noise = rng.normal(scale=sigma, size=(4000, periods, M))
    measured = spectral_estimates(noise, u, 0.5, k)[2].mean(axis=1).std(axis=0)
    ratio = np.sqrt(np.mean(measured**2)) / np.sqrt(np.mean(model.h_std() ** 2))
    assert ratio == pytest.approx(1.0, abs=0.03)


def test_the_ratio_is_the_periodic_state_not_the_start() -> None:
    """A slow rate limit started at rest: the first period differs from the later ones, and
    the ratio is the later ones' (the third of three periods, computed here)."""
    a, dt = 0.3, 0.01
    nl = RateLimit(0.3 * 2 * a / dt)
    p = a * mls(ORDER)
    y, _ = nl.process(np.tile(p, 3), dt, nl.initial_state())
    first, last = y[:M], y[2 * M :]
    assert np.abs(first - last).max() > 0.1 * a
    expected = np.fft.rfft(last) / np.fft.rfft(p)
    np.testing.assert_allclose(harmonic_ratio(nl, p, dt), expected, rtol=1e-10, atol=1e-12)
