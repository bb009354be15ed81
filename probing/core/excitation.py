"""The probe's signal: the paper's PRBS, or the multisines and chirps the rest of the field
uses, on the same period and the same bits, and the estimator of each.

Every signal is one period of M = 2**n - 1 values, one per bit, held for the bit duration
t0 (as the PRBS's bits are) and repeated every T = M t0; the probe is the amplitude times
it.  The plant is then, bit sample by bit sample, the circular convolution of the same
pulse response h (the output i bits after a one-bit pulse, M taps folded over the period)
with the signal, whatever the signal, so the three estimate the same h and can be compared
tap for tap.  In the frequency domain, at the harmonics k / T (k = 0 .. M - 1 of the
period's DFT), ``Y_k = H_k U_k``.

=========  ================================================================================
signal     one period, unit RMS (the PRBS: unit amplitude, so RMS 1 too)
=========  ================================================================================
prbs       the m-sequence sigma (+-1, :func:`probing.core.prbs.mls`): every harmonic,
           DC included, at |U_k|^2 = M + 1 (DC: 1); crest factor 1
multisine  equal-amplitude harmonics k_lo .. k_hi of 1/T over ``band_hz``, Schroeder's
           phases refined to a low crest factor (:func:`multisine`)
chirp      a sine sweep over ``band_hz``, linear or logarithmic in frequency, starting at
           zero phase, sampled at the bits (:func:`chirp`)
=========  ================================================================================

The estimator of all three (:func:`spectral_estimates`) is the ratio of the output's
spectrum to the input's at the excited harmonics, ``H_k = Y_k / (a U_k)``, and the pulse
response over those harmonics, ``h_band = IDFT(H_k on the band, 0 elsewhere)``.  For the
PRBS every harmonic is excited and it is the exact inverse of the periodic probe: the
project's ``cyclic`` estimator.  A multisine and a chirp excite their band only, so they
recover :func:`band_limited` (h), the projection of h on their harmonics, not h.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from probing.core.errors import ProbingError

__all__ = [
    "CHIRP_MIN_POWER",
    "MIN_HARMONICS",
    "PRBS",
    "REFINE_ITERATIONS",
    "SIGNALS",
    "SPECTRAL",
    "SWEEPS",
    "BandError",
    "Excitation",
    "band_harmonics",
    "band_limited",
    "chirp",
    "crest_factor",
    "harmonic_mask",
    "multisine",
    "spectral_estimates",
]

#: Signal name -> one line on what it is.
SIGNALS: dict[str, str] = {
    "prbs": "the paper's maximum-length binary sequence (every harmonic, crest factor 1)",
    "multisine": "equal harmonics over a band, Schroeder's phases refined to a low crest factor",
    "chirp": "a sine sweep over a band, repeated every period",
}

#: The estimator of a multisine and a chirp (and, for the PRBS, the same as ``cyclic``):
#: :func:`spectral_estimates`.
SPECTRAL = "spectral"

#: The chirp's sweeps: frequency linear or logarithmic in time.
SWEEPS = ("linear", "log")

#: Fewest harmonics a band must hold: with fewer, a "pulse response over the band" is a
#: couple of sinusoids and says nothing about the shape.
MIN_HARMONICS = 3

#: A chirp must put at least this fraction of its mean in-band power |U_k|^2 on every
#: harmonic of its band; a harmonic it barely excites would divide the noise by nearly zero.
CHIRP_MIN_POWER = 0.05

#: Iterations of the crest-factor refinement of the multisine's phases (fixed: the same
#: phases on every machine).
REFINE_ITERATIONS = 200


class BandError(ProbingError, ValueError):
    """A band that the period and the bit duration cannot carry (one line)."""


def band_harmonics(band_hz: tuple[float, float], order: int, bit_duration_s: float) -> np.ndarray:
    """The harmonics k of 1/T (T = M t0) inside ``band_hz``, both ends included.

    Parameters
    ----------
    band_hz : (float, float)
        Lowest and highest frequency, Hz; 1/T <= low < high <= 1/(2 t0) (the bits' Nyquist).
    order : int
        PRBS order n: M = 2**n - 1 bits per period.
    bit_duration_s : float
        Bit duration t0, s.

    Returns
    -------
    numpy.ndarray
        The harmonic numbers k (int), f_k = k / T, ascending.

    Raises
    ------
    BandError
        A band below the period's first harmonic, above the bits' Nyquist frequency, empty
        or reversed, or holding fewer than :data:`MIN_HARMONICS` harmonics.
    """
    low, high = (float(f) for f in band_hz)
    m = 2**order - 1
    period_s = m * bit_duration_s
    first, nyquist = 1.0 / period_s, 0.5 / bit_duration_s
    if not (math.isfinite(low) and math.isfinite(high) and 0 <= low < high):
        raise BandError(f"band_hz must be [low, high] with 0 <= low < high, got [{low}, {high}]")
    tol = 1e-9
    if low < first * (1 - tol):
        raise BandError(
            f"band_hz starts at {low:g} Hz, below the period's first harmonic 1/T = "
            f"{first:.4g} Hz (T = {period_s:g} s): a periodic signal has nothing there"
        )
    if high > nyquist * (1 + tol):
        raise BandError(
            f"band_hz ends at {high:g} Hz, above the bits' Nyquist frequency 1/(2 t0) = "
            f"{nyquist:g} Hz"
        )
    k = np.arange(math.ceil(low * period_s - tol), math.floor(high * period_s + tol) + 1)
    k = k[(k >= 1) & (k <= (m - 1) // 2)]
    if k.size < MIN_HARMONICS:
        raise BandError(
            f"band_hz [{low:g}, {high:g}] Hz holds {k.size} harmonic(s) of 1/T = {first:.4g} Hz;"
            f" at least {MIN_HARMONICS} are needed: widen the band or lengthen the period"
        )
    return k.astype(np.int64)


def _synthesise(m: int, k: np.ndarray, phases: np.ndarray) -> np.ndarray:
    """One period of sum_k cos(2 pi k n / M + phi_k), n = 0 .. M-1, scaled to unit RMS."""
    spectrum = np.zeros(m // 2 + 1, dtype=complex)
    spectrum[k] = np.exp(1j * phases)
    x = np.fft.irfft(spectrum, m)
    return x / np.sqrt(np.mean(x**2))


def crest_factor(x: np.ndarray) -> float:
    """Peak over RMS of a signal: 1 for a binary one, sqrt(2) for a sinusoid."""
    x = np.asarray(x, dtype=float)
    return float(np.max(np.abs(x)) / np.sqrt(np.mean(x**2)))


def multisine(order: int, harmonics: np.ndarray) -> np.ndarray:
    """One period (M values, unit RMS) of an equal-amplitude multisine on ``harmonics``.

    The phases start as Schroeder's, phi_j = -pi j (j - 1) / K for the j-th of K harmonics,
    and are refined by clipping the signal at a level below its peak and taking the
    clipped signal's phases on the band, the amplitudes kept (the L-infinity iteration of
    Van der Ouderaa, Schoukens and Renneboog, 1988), :data:`REFINE_ITERATIONS` times; the
    phases with the lowest crest factor are kept.  SIDPAC's ``mkmsswp`` starts from the same
    phases and minimises the relative peak factor with a general optimiser; this fixed
    iteration is written out so that the same scenario gives the same bytes everywhere.

    Parameters
    ----------
    order : int
        PRBS order n: M = 2**n - 1 values.
    harmonics : numpy.ndarray
        Harmonic numbers k (1 <= k <= (M-1)/2), e.g. from :func:`band_harmonics`.

    Returns
    -------
    numpy.ndarray
        One period, unit RMS; only the given harmonics are excited (to rounding).
    """
    m = 2**order - 1
    k = np.asarray(harmonics, dtype=np.int64)
    j = np.arange(1, k.size + 1)
    phases = -np.pi * j * (j - 1) / k.size
    x = _synthesise(m, k, phases)
    best, best_cf = x, crest_factor(x)
    for i in range(REFINE_ITERATIONS):
        level = (0.9 + 0.08 * i / REFINE_ITERATIONS) * np.max(np.abs(x))
        clipped = np.clip(x, -level, level)
        phases = np.angle(np.fft.rfft(clipped)[k])
        x = _synthesise(m, k, phases)
        cf = crest_factor(x)
        if cf < best_cf:
            best, best_cf = x, cf
    return best


def chirp(
    order: int, bit_duration_s: float, band_hz: tuple[float, float], sweep: str = "linear"
) -> np.ndarray:
    """One period (M values, unit RMS) of a sine sweep from ``band_hz[0]`` to ``band_hz[1]``.

    The frequency rises over the period, linearly (f(t) = f0 + (f1 - f0) t / T) or
    logarithmically (f(t) = f0 (f1 / f0)^(t / T)), as PX4's and ArduPilot's system
    identification sweeps do; the phase starts at zero, x(t) = sin(2 pi int_0^t f), sampled
    at the start of each bit and held for it.  Repeated every T, the sweep jumps back to
    f0 at each period's start.

    Raises
    ------
    BandError
        The band's own rules (:func:`band_harmonics`), or a harmonic of the band that the
        sweep excites with less than :data:`CHIRP_MIN_POWER` of the band's mean power.
    """
    if sweep not in SWEEPS:
        raise ValueError(f"sweep must be one of {', '.join(SWEEPS)}, got {sweep!r}")
    k = band_harmonics(band_hz, order, bit_duration_s)
    m = 2**order - 1
    period_s = m * bit_duration_s
    f0, f1 = (float(f) for f in band_hz)
    t = np.arange(m) * bit_duration_s
    if sweep == "linear":
        phase = 2 * np.pi * (f0 * t + (f1 - f0) * t**2 / (2 * period_s))
    else:
        rate = math.log(f1 / f0) / period_s if f0 > 0 else math.nan
        if not math.isfinite(rate):
            raise BandError("a logarithmic sweep needs band_hz low > 0")
        phase = 2 * np.pi * f0 * np.expm1(rate * t) / rate
    x = np.sin(phase)
    x = x / np.sqrt(np.mean(x**2))
    power = np.abs(np.fft.rfft(x)[k]) ** 2
    weak = power < CHIRP_MIN_POWER * power.mean()
    if weak.any():
        worst = int(k[np.argmin(power)])
        raise BandError(
            f"the {sweep} chirp over [{f0:g}, {f1:g}] Hz excites {int(weak.sum())} of the "
            f"band's {k.size} harmonics with less than {CHIRP_MIN_POWER:g} of the band's mean "
            f"power (the weakest at {worst / period_s:.4g} Hz): lengthen the period or narrow "
            "the band"
        )
    return x


def harmonic_mask(m: int, harmonics: np.ndarray | None) -> np.ndarray:
    """Which bins of a period's real DFT (``rfft``, M // 2 + 1 of them) an estimator over
    ``harmonics`` keeps: those harmonics, or every bin, DC included, for None (the PRBS)."""
    if harmonics is None:
        return np.ones(m // 2 + 1, dtype=bool)
    keep = np.zeros(m // 2 + 1, dtype=bool)
    keep[np.asarray(harmonics)] = True
    return keep


def band_limited(h: np.ndarray, harmonics: np.ndarray | None) -> np.ndarray:
    """The projection of a pulse response (M taps, last axis, folded over the period) on
    the harmonics ``harmonics`` of 1/T: what a signal exciting only them can recover.
    ``None``: every harmonic (h itself)."""
    h = np.asarray(h, dtype=float)
    if harmonics is None:
        return h.copy()
    m = h.shape[-1]
    keep = harmonic_mask(m, harmonics)
    return np.fft.irfft(np.where(keep, np.fft.rfft(h, axis=-1), 0.0), m, axis=-1)


def spectral_estimates(
    y: np.ndarray, reference: np.ndarray, amplitude: float, harmonics: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each period's pulse response over the excited harmonics, from its own samples.

    Parameters
    ----------
    y : numpy.ndarray
        Bit samples of whole periods, shape (..., M), output units.
    reference : numpy.ndarray
        One period of the unit signal (M values; the probe is ``amplitude`` times it).
    amplitude : float
        Probe amplitude a (> 0), probe units.
    harmonics : numpy.ndarray or None
        The excited harmonics k (1 .. (M-1)/2); None: every harmonic and DC (the PRBS).

    Returns
    -------
    z, zeta, h : numpy.ndarray
        Shape of ``y``, tap order.  ``h = IDFT(Y_k / (a U_k))`` over the harmonics, output
        units per probe unit; ``zeta = a (M+1) h`` and ``z = zeta - a sum(h)``: what the
        paper's correlator gives for this h (eqs. 8, 9), so every estimator's z and h are
        related as the PRBS's are.  For the PRBS, with every harmonic, these are exactly the
        ``cyclic`` estimator's.
    """
    y = np.asarray(y, dtype=float)
    u = np.asarray(reference, dtype=float)
    m = u.size
    if y.shape[-1] != m:
        raise ValueError(f"y must hold whole periods of {m} samples, got shape {y.shape}")
    if not (math.isfinite(amplitude) and amplitude > 0):
        raise ValueError(f"amplitude must be > 0, got {amplitude}")
    spectrum_u = np.fft.rfft(u)
    keep = harmonic_mask(m, harmonics)
    ratio = np.zeros(m // 2 + 1, dtype=complex)
    ratio[keep] = 1.0 / (amplitude * spectrum_u[keep])
    h = np.fft.irfft(np.fft.rfft(y, axis=-1) * ratio, m, axis=-1)
    zeta = amplitude * (m + 1) * h
    z = zeta - amplitude * h.sum(axis=-1, keepdims=True)
    return z, zeta, h


@dataclass(frozen=True)
class Excitation:
    """The probe's signal, as ``[probe]`` names it.

    Parameters
    ----------
    signal : str
        A key of :data:`SIGNALS`.
    band_hz : (float, float) or None
        The band of a multisine or a chirp, Hz; None for the PRBS.
    sweep : str
        The chirp's sweep, ``"linear"`` or ``"log"``.
    """

    signal: str = "prbs"
    band_hz: tuple[float, float] | None = None
    sweep: str = "linear"

    def __post_init__(self) -> None:
        if self.signal not in SIGNALS:
            raise ValueError(f"signal must be one of {', '.join(SIGNALS)}, got {self.signal!r}")
        if (self.band_hz is None) != (self.signal == "prbs"):
            need = f"a {self.signal} needs band_hz"
            raise ValueError("the PRBS has no band" if self.signal == "prbs" else need)
        if self.sweep not in SWEEPS:
            raise ValueError(f"sweep must be one of {', '.join(SWEEPS)}, got {self.sweep!r}")

    @property
    def is_binary(self) -> bool:
        """True for the PRBS, whose two levels every hard nonlinearity keeps (eqs. 10-12)."""
        return self.signal == "prbs"

    def harmonics(self, order: int, bit_duration_s: float) -> np.ndarray | None:
        """The excited harmonics of 1/T; None for the PRBS (all of them, DC included)."""
        if self.band_hz is None:
            return None
        return band_harmonics(self.band_hz, order, bit_duration_s)

    def unit(self, order: int, bit_duration_s: float) -> np.ndarray:
        """One period (M values, unit RMS, read-only) of a multisine or a chirp, computed
        once per signal, order and bit duration in a process (a scenario is read again at
        every change of a sweep's point); the PRBS's is :func:`probing.core.prbs.mls`."""
        if self.signal == "prbs":
            raise ValueError("the PRBS's period is probing.core.prbs.mls(order)")
        return _unit(self, order, bit_duration_s)


@lru_cache(maxsize=32)
def _unit(excitation: Excitation, order: int, bit_duration_s: float) -> np.ndarray:
    """:meth:`Excitation.unit`, remembered."""
    if excitation.signal == "multisine":
        x = multisine(order, band_harmonics(excitation.band_hz, order, bit_duration_s))
    else:
        x = chirp(order, bit_duration_s, excitation.band_hz, excitation.sweep)
    x.setflags(write=False)
    return x


#: The paper's probe: the default signal.
PRBS = Excitation()
