"""Drift removal without a model: a periodic part and a slow trend fitted together.

A record driven by a periodic probe is, in the periodic steady state, a periodic part
p[n mod N] (the probe's response, any constant included) plus drift.  Fitting a polynomial
to each period on its own (the earlier ``detrend``) takes away whatever of the response
looks like the polynomial over one period.  Here the trend is fitted across periods, in the
same least-squares problem as a free periodic part:

    y[n] = p[n mod N] + sum_{k=1..K} c_k (n / L)^k,    n = 0 .. L - 1,

so only what cannot be periodic (the part of each trend term orthogonal to the periodic
subspace) decides the c_k; the whole fitted trend is then subtracted.  The trend is zero
at the record's first sample: the constant stays in the periodic part (it cannot be told
from the response's own mean, the DC direction of the probe).  A periodic signal plus a
polynomial trend of order <= K is recovered exactly, to rounding.

Without a model (drift mode ``detrend``, ``probing analyze`` without a reference column)
the record's offset is not known either: :func:`detrend_periodic` removes the mean as well,
i.e. it fits y[n] = p[n mod N] + c_0 + sum_k c_k (n / L)^k with the periodic part's mean
fixed at zero and subtracts c_0 and the trend.  The offset cannot be told from the probe's
response to its own mean (a +-1 m-sequence sums to -1), so the DC-corrected estimate is then
h - sum(h) / M on every tap, in the periodic steady state.
"""

from __future__ import annotations

import numpy as np

from probing.core.fixedorder import dot, lstsq, pinv

__all__ = [
    "detrend_matrix",
    "detrend_periodic",
    "detrend_rows",
    "periodic_trend_basis",
    "remove_periodic_trend",
    "trend_projector",
    "window_periods",
]


def periodic_trend_basis(length: int, period: int, order: int) -> tuple[np.ndarray, np.ndarray]:
    """The trend terms and their parts orthogonal to every N-periodic signal.

    Parameters
    ----------
    length : int
        Samples L, a whole number of periods.
    period : int
        Period N in samples.
    order : int
        Polynomial order K >= 0 of the trend (0: no trend).

    Returns
    -------
    trend, orthogonal : numpy.ndarray
        Shape (L, K): column k-1 is (n / L)^k, and the same less its mean over the periods at
        each phase (its projection on the periodic signals).

    Raises
    ------
    ValueError
        If L is not a whole number of periods, or holds fewer than K + 1 of them (the
        trend could not be told from the periodic part).
    """
    if period < 1 or length % period:
        raise ValueError(f"length {length} is not a whole number of periods of {period}")
    periods = length // period
    if order < 0 or (order > 0 and periods < order + 1):
        raise ValueError(f"a trend of order {order} needs >= {order + 1} periods, got {periods}")
    t = np.arange(length, dtype=float) / length
    trend = t[:, None] ** np.arange(1, order + 1)[None, :]
    phase_mean = trend.reshape(periods, period, order).mean(axis=0)
    return trend, trend - np.tile(phase_mean, (periods, 1))


def trend_projector(length: int, period: int, order: int) -> np.ndarray:
    """The linear map y -> the fitted trend, so that the detrended record is ``y - T @ y``.

    Returns
    -------
    numpy.ndarray
        Shape (L, L): ``trend @ pinv(orthogonal)`` of :func:`periodic_trend_basis` (the
        c_k depend on y through the orthogonal parts only), every sum in a fixed order
        (:mod:`probing.core.fixedorder`).
    """
    trend, orth = periodic_trend_basis(length, period, order)
    if order == 0:
        return np.zeros((length, length))
    return dot(trend, pinv(orth))


def remove_periodic_trend(y: np.ndarray, period: int, order: int = 1) -> np.ndarray:
    """Subtract the trend fitted together with a free periodic part (module docstring).

    Parameters
    ----------
    y : numpy.ndarray
        Shape (L,) or (L, C): a whole number of periods of N samples, in any unit.
    period : int
        Period N in samples.
    order : int
        Polynomial order K of the trend (0 returns ``y`` unchanged).

    Returns
    -------
    numpy.ndarray
        ``y`` less the fitted trend, same shape and unit; the trend is zero at sample 0.

    Examples
    --------
    >>> p = np.array([1.0, -2.0, 0.5])
    >>> y = np.tile(p, 4) + 0.3 * np.arange(12)
    >>> np.allclose(remove_periodic_trend(y, 3), np.tile(p, 4))
    True
    """
    y = np.asarray(y, dtype=float)
    trend, orth = periodic_trend_basis(y.shape[0], period, order)
    if order == 0:
        return y.copy()
    return y - dot(trend, lstsq(orth, y))


def window_periods(order: int) -> int:
    """Periods a detrended estimate reads: the joint fit of a trend of ``order`` needs
    order + 1 of them, and at least 2 (the streaming estimator reads the period before)."""
    return max(2, int(order) + 1)


def detrend_periodic(y: np.ndarray, period: int, order: int = 1) -> np.ndarray:
    """The drift mode ``detrend``: the jointly fitted trend and the mean removed (module
    docstring); shape and unit of ``y`` ((L,) or (L, C), L a whole number of periods).

    Examples
    --------
    >>> p = np.array([1.0, -2.0, 0.5])
    >>> y = np.tile(p, 4) + 3.0 + 0.3 * np.arange(12)
    >>> np.allclose(detrend_periodic(y, 3), np.tile(p - p.mean(), 4))
    True
    """
    out = remove_periodic_trend(y, period, order)
    return out - out.mean(axis=0)


def detrend_rows(rows: np.ndarray, period: int, order: int) -> np.ndarray:
    """``rows @ D``, D the linear map of :func:`detrend_periodic` (``detrend_periodic(y) ==
    D @ y``): the weights of an estimate that reads the detrended record, for weights
    ``rows`` (R, L) on the record.

    D = (I - J)(I - T), J the averaging matrix and T = trend pinv(orthogonal) the fitted
    trend (:func:`trend_projector`), applied in its factors: O(R L K) instead of the
    O(R L^2) of a product with D.

    Returns
    -------
    numpy.ndarray
        Shape (R, L), the unit of ``rows``.
    """
    rows = np.atleast_2d(np.asarray(rows, dtype=float))
    length = rows.shape[1]
    trend, orth = periodic_trend_basis(length, period, order)
    if order == 0:
        kept, column_mean = rows, np.full(length, 1.0 / length)
    else:
        fit = pinv(orth)  # (K, L): the trend's coefficients of a record
        kept = rows - dot(dot(rows, trend), fit)  # rows @ (I - T)
        column_mean = (1.0 - dot(trend.sum(axis=0), fit)) / length  # of I - T, over its rows
    return kept - rows.sum(axis=1)[:, None] * column_mean[None, :]


def detrend_matrix(length: int, period: int, order: int) -> np.ndarray:
    """The linear map of :func:`detrend_periodic`: ``detrend_periodic(y) == D @ y``.

    Returns
    -------
    numpy.ndarray
        Shape (L, L), dimensionless: (I - J)(I - T) with J the averaging matrix and T
        :func:`trend_projector` (:func:`detrend_rows` of the identity).
    """
    return detrend_rows(np.eye(length), period, order)
