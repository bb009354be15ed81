"""Figures of merit of a pulse-response estimate: gain, shape and the predicted apparent input.

Shared by the Fig. 4 analysis and the sweep summaries; free of JSBSim.
"""

from __future__ import annotations

import math

import numpy as np

from probing.core.nonlinearities import NoApparentFormError, Nonlinearity, RateLimit

__all__ = ["gain_and_shape", "predicted_apparent"]


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
