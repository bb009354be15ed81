"""Figures of merit of a pulse-response estimate: gain, shape, predictions and noise theory.

Shared by the Fig. 4 analysis and the sweep summaries; free of JSBSim.
"""

from __future__ import annotations

import math

import numpy as np

from probing.core.nonlinearities import NoApparentFormError, Nonlinearity, RateLimit

__all__ = ["estimator_noise_std", "gain_and_shape", "predicted_apparent"]


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
    g = float(np.dot(h, h0) / np.dot(h0, h0))
    if g == 0.0:
        return 0.0, math.inf
    return g, float(np.linalg.norm(h - g * h0) / np.linalg.norm(g * h0))


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


def estimator_noise_std(reference: np.ndarray, amplitude: float, sigma: float) -> np.ndarray:
    """Standard deviation of each tap of one period's pulse-response estimate under white noise.

    Closed form for the estimator of :class:`probing.correlator.StreamingCorrelator`
    (eqs. 5 and 9), written out here independently of it.  In the coordinates of the
    2M samples u of periods p-1 and p, the sliding output at sample r of period p is
    ``z_r = sum_j sigma_j u[r+1+j]`` (weight row w_r), the period sum is
    ``S = sum_r z_r`` (weights s = sum_r w_r, partial sums of the m-sequence), tap i is
    read at r = i - 1 (tap 0 at r = M - 1), and ``h_i = (z_r + S) / (a (M+1))``.  With
    white measurement noise of standard deviation ``sigma``::

        std(h_i) = sigma * ||w_r + s|| / (a (M+1))
        ||w_r + s||^2 = M + 2 sum_j sigma_j s[r+1+j] + ||s||^2

    The ``||s||`` term (the DC correction of eq. 9) dominates: ``||s||^2`` grows like M^2
    (partial sums of the m-sequence), so the estimate is noisier than the naive
    sigma / (a sqrt(M)) of the uncorrected correlation by a factor of order sqrt(M) that
    depends on the sequence: 3.8 at M = 31, 14 at M = 127, 16.6 at M = 511.

    Parameters
    ----------
    reference : numpy.ndarray
        The +-1 m-sequence sigma, length M.
    amplitude : float
        Probe amplitude a (probe units, e.g. deg).
    sigma : float
        Standard deviation of the white noise on the output (output units).

    Returns
    -------
    numpy.ndarray
        Per-tap standard deviation of h (output units per probe unit), shape (M,), tap order.
        Average P independent periods to divide it by sqrt(P).
    """
    ref = np.asarray(reference, dtype=float)
    m = ref.size
    s = np.zeros(2 * m)
    s[1:] = np.convolve(np.ones(m), ref)  # s[n] = sum of sigma_j over 0 <= n-1-j <= M-1
    cross = np.correlate(s, ref, mode="valid")  # cross[r+1] = sum_j sigma_j s[r+1+j]
    r_of_tap = (np.arange(m) - 1) % m
    norm2 = m + 2.0 * cross[r_of_tap + 1] + np.dot(s, s)
    return sigma * np.sqrt(norm2) / (amplitude * (m + 1))
