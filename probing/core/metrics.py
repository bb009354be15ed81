"""Figures of merit of a pulse-response estimate: gain, shape and the predicted apparent input.

Shared by the Fig. 4 analysis and the sweep summaries; free of JSBSim.
"""

from __future__ import annotations

import math

import numpy as np

from probing.core.excitation import harmonic_mask
from probing.core.fixedorder import vdot
from probing.core.nonlinearities import NoApparentFormError, Nonlinearity, RateLimit

__all__ = ["gain_and_shape", "harmonic_ratio", "predicted_apparent", "through_nonlinearity"]


def gain_and_shape(h: np.ndarray, h0: np.ndarray) -> tuple[float, float]:
    """Least-squares gain of ``h`` against ``h0`` and the shape error that is left.

    Parameters
    ----------
    h, h0 : numpy.ndarray
        Pulse-response estimates of equal length (any common unit).

    Returns
    -------
    gain : float
        g = <h, h0> / <h0, h0> (dimensionless).
    shape_error : float
        ||h - g h0|| / ||g h0|| (dimensionless); ``inf`` when g = 0.
    """
    h, h0 = np.asarray(h, dtype=float), np.asarray(h0, dtype=float)
    g = vdot(h, h0) / vdot(h0, h0)
    if g == 0.0:
        return 0.0, math.inf
    rest, fitted = h - g * h0, g * h0
    return g, math.sqrt(vdot(rest, rest)) / math.sqrt(vdot(fitted, fitted))


def predicted_apparent(
    nonlinearity: Nonlinearity | None, amplitude_deg: float, bit_duration_s: float
) -> tuple[float, float]:
    """Predicted gain a~/a and offset b~ (deg) of the probe after a nonlinearity.

    Parameters
    ----------
    nonlinearity : Nonlinearity or None
        None means a straight wire (gain 1, offset 0).
    amplitude_deg : float
        Probe amplitude a, deg.
    bit_duration_s : float
        Bit duration t0, s (used by the rate limit only).

    Returns
    -------
    gain : float
        a~/a; for a rate limit 1 when it admits the probe (r >= 2a/t0, eq. 21), NaN otherwise
        (the output is then no scaled probe).
    offset_deg : float
        b~, deg (0 for a rate limit that admits the probe, NaN when it does not).
    """
    if nonlinearity is None:
        return 1.0, 0.0
    try:
        a_tilde, b_tilde = nonlinearity.apparent(amplitude_deg)
    except NoApparentFormError:
        assert isinstance(nonlinearity, RateLimit)
        if nonlinearity.admits(amplitude_deg, bit_duration_s):
            return 1.0, 0.0
        return math.nan, math.nan
    return a_tilde / amplitude_deg, b_tilde


def harmonic_ratio(
    nonlinearity: Nonlinearity | None, bits: np.ndarray, dt_s: float, steps_per_bit: int = 1
) -> np.ndarray:
    """What a known input nonlinearity does to each harmonic of a periodic probe:
    ``Q_k / P_k`` over one period's DFT (rfft bins 0 .. M // 2), in the periodic steady state.

    The probe ``bits`` (one period, one value per bit, deg) is held for ``steps_per_bit``
    samples of ``dt_s`` and played for two periods through the nonlinearity (a hysteretic
    one then has its periodic state); the second period's output, read at the last sample of
    each bit, is ``q``.  With one sample per bit (the Fig. 4 set-up) the plant sees exactly
    ``q`` at the bits, so an estimator that divides the output's spectrum by the probe's
    recovers ``H_k Q_k / P_k`` at each harmonic: for the PRBS ``a~/a`` at every harmonic but
    DC (eqs. 10-12); for a multisine or a chirp a gain and a distortion that differ from one
    harmonic to the next.  Harmonics the probe does not excite (``|P_k|`` at rounding) are NaN.
    """
    p = np.asarray(bits, dtype=float)
    if nonlinearity is None:
        q = p
    else:
        x = np.repeat(np.tile(p, 2), steps_per_bit)
        y, _ = nonlinearity.process(x, dt_s, nonlinearity.initial_state())
        q = y[p.size * steps_per_bit :][steps_per_bit - 1 :: steps_per_bit]
    big_p, big_q = np.fft.rfft(p), np.fft.rfft(q)
    excited = np.abs(big_p) > 1e-9 * np.abs(big_p).max()
    return np.where(excited, big_q / np.where(excited, big_p, 1.0), np.nan)


def through_nonlinearity(
    h0: np.ndarray, ratio: np.ndarray, harmonics: np.ndarray | None
) -> np.ndarray:
    """The estimate a nonlinearity of :func:`harmonic_ratio` ``ratio`` leaves of the linear
    estimate ``h0`` (M taps) in the noise-free periodic steady state: ``IDFT(H0_k Q_k / P_k)``
    over the estimator's harmonics (``None``: all, DC included, the PRBS's)."""
    m = h0.shape[-1]
    keep = harmonic_mask(m, harmonics)
    spectrum = np.fft.rfft(h0) * np.where(keep, np.nan_to_num(ratio), 0.0)
    return np.fft.irfft(spectrum, m)
