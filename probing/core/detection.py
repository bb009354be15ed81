"""How soon the monitor finds a step change: the probability of an alarm within N periods
of the onset, for the detector's own two tests.

The monitor (:class:`probing.core.monitor.ChangeDetector`) tests, after every period, the
mean of the last W periods' reduced estimates v (K numbers) against a baseline of B
periods, two ways (Hotelling's T^2, and the gain along the baseline's mean v0), and alarms
when twice the smaller p-value is below alpha.  A design that sizes one test for a
detection probability (``probing design --detect-gain-change``) is what a monitor gets if it
looks once, along v0 only.  This module gives what the monitor gets:

* periods v_i = v0 + c_i d + e_i, e_i independent N(0, S) (S: one period's covariance of v),
  d the change, c_i the fraction of period i after the onset: 0 before, 1 - u in the period
  the onset falls in (u uniform over the period), 1 after;
* the baseline's mean is off by e_b ~ N(0, S / B), the same for every test;
* test m (m = 0 .. N - 1, at the end of the m-th period after the one the onset falls in,
  so within N periods of it) takes x = mean of its W periods - v0 - e_b and alarms if
  T^2 = x' S^-1 x / (1/W + 1/B) passes the F quantile of the detector's null at alpha / 2,
  or the gain's Student t passes t_{B-1}(1 - alpha / 4): either p-value below alpha / 2.

The detector learns S from its B baseline periods: each draw learns one too (Bartlett's
decomposition of a Wishart(S, B - 1) matrix), so the power, not only the null, carries it.
The probability is a Monte Carlo mean over a fixed set of draws
(:data:`SAMPLES`, seed 0): deterministic, increasing in the change's size.  In whitened
coordinates (S = L L') only the change's whitened vector L^-1 d and the gain's direction
L' v0 matter.  numpy and scipy only.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.optimize import brentq
from scipy.special import fdtri, stdtrit

from probing.core.fixedorder import cholesky, dot, norm, solve_lower

__all__ = ["SAMPLES", "detection_scale", "detection_within"]

#: Monte Carlo draws: the probability's standard error is at most 0.5 / sqrt(SAMPLES).
SAMPLES = 50_000


@functools.lru_cache(maxsize=8)
def _draws(k: int, window_periods: int, within_periods: int, baseline_periods: int) -> tuple:
    """Fixed draws in whitened coordinates: each test's noise (window mean less the
    baseline's error) ``(samples, N, K)``, each test's changed fraction ``(samples, N)``, and
    the baseline's covariance estimate's lower Cholesky factor times sqrt(B - 1) (Bartlett's
    decomposition of a Wishart(I, B - 1) draw) ``(samples, K, K)``."""
    rng = np.random.default_rng(0)
    w, n = window_periods, within_periods
    e = rng.standard_normal((SAMPLES, n + w - 1, k))  # periods j - W + 1 .. j + N - 1
    total = np.concatenate([np.zeros((SAMPLES, 1, k)), np.cumsum(e, axis=1)], axis=1)
    noise = (total[:, w:] - total[:, :-w]) / w  # test m: periods j + m - W + 1 .. j + m
    noise -= rng.standard_normal((SAMPLES, 1, k)) / math.sqrt(baseline_periods)
    u = rng.random(SAMPLES)
    m = np.arange(n)
    full = np.minimum(m, w)  # whole changed periods in test m's window
    partial = (m < w).astype(float)  # the onset's own period, while in the window
    changed = (full[None, :] + partial[None, :] * (1.0 - u[:, None])) / w
    dof = baseline_periods - 1
    bartlett = np.tril(rng.standard_normal((SAMPLES, k, k)), -1)
    diagonal = np.sqrt(rng.chisquare(dof - np.arange(k), size=(SAMPLES, k)))
    bartlett[:, np.arange(k), np.arange(k)] = diagonal
    for array in (noise, changed, bartlett):
        array.flags.writeable = False
    return noise, changed, bartlett


def _whitened(change: np.ndarray, covariance: np.ndarray, v0: np.ndarray) -> tuple:
    """The change in whitened coordinates, and the gain test's unit direction there."""
    chol = cholesky(np.asarray(covariance, dtype=float))
    delta = solve_lower(chol, np.asarray(change, dtype=float))
    a = dot(chol.T, np.asarray(v0, dtype=float))
    return delta, a / norm(a)


def detection_within(
    change: np.ndarray,
    covariance: np.ndarray,
    v0: np.ndarray,
    false_alarm: float,
    periods: tuple[int, int, int],
) -> float:
    """The probability that the detector alarms within N periods of a step change.

    Parameters
    ----------
    change : numpy.ndarray
        d, the change of one period's reduced estimate, shape (K,).
    covariance : numpy.ndarray
        S, one period's covariance of the reduced estimate, (K, K), positive definite.
    v0 : numpy.ndarray
        The baseline's mean reduced estimate (the gain test's direction), (K,).
    false_alarm : float
        alpha, the detector's false-alarm probability per test.
    periods : (int, int, int)
        (W, B, N): periods averaged into each test, the baseline's, and the periods from
        the onset the alarm must come within.

    Returns
    -------
    float
        The probability (module docstring).

    Examples
    --------
    A 20 % gain drop, three windows of independent unit noise: no detection beyond the
    false alarms when the response is small, always when it is large.

    >>> s, v0 = np.eye(3), np.array([1.0, 0.5, 0.2])
    >>> detection_within(-0.2 * v0, s, v0, 1e-4, (4, 50, 5)) < 0.01
    True
    >>> detection_within(-0.2 * 100 * v0, s, 100 * v0, 1e-4, (4, 50, 5))
    1.0
    """
    w, b, n = periods
    delta, a = _whitened(change, covariance, v0)
    k = delta.size
    noise, changed, bartlett = _draws(k, w, n, b)
    dof = b - 1
    factor = 1.0 / w + 1.0 / b
    t2_limit = dof * k / (dof - k + 1) * float(fdtri(k, dof - k + 1, 1.0 - false_alarm / 2.0))
    gain_limit = float(stdtrit(dof, 1.0 - false_alarm / 4.0))
    x = noise + changed[:, :, None] * delta  # (samples, N, K)
    # the learnt covariance S^ = C C' / dof (whitened): T^2 = dof |C^-1 x|^2 / factor
    y = solve_lower(bartlett, np.swapaxes(x, 1, 2))  # (samples, K, N)
    t2 = dof * np.multiply(y, y).sum(axis=1) / factor
    spread = np.multiply(bartlett, a[None, :, None]).sum(axis=1)  # C' a: a' S^ a = |C' a|^2 / dof
    gain_se = np.sqrt(np.multiply(spread, spread, order="C").sum(axis=-1) / dof * factor)
    gain = np.abs(dot(x, a)) / gain_se[:, None]
    alarm = (t2 > t2_limit) | (gain > gain_limit)
    return float(np.mean(alarm.any(axis=1)))


def detection_scale(
    change: np.ndarray,
    covariance: np.ndarray,
    v0: np.ndarray,
    false_alarm: float,
    periods: tuple[int, int, int],
    probability: float,
) -> float:
    """The factor r by which the change must grow against the noise (r d with S, or d with
    S / r^2: a probe r times louder) to be detected within N periods with ``probability``.

    Raises
    ------
    ValueError
        If ``probability`` is not in (0, 1).

    Examples
    --------
    >>> s, v0 = np.eye(3), np.array([1.0, 0.5, 0.2])
    >>> r = detection_scale(-0.2 * v0, s, v0, 1e-4, (4, 50, 5), 0.9)
    >>> round(detection_within(-0.2 * r * v0, s, v0, 1e-4, (4, 50, 5)), 2)
    0.9
    """
    if not 0.0 < probability < 1.0:
        raise ValueError(f"probability must be in (0, 1), got {probability!r}")
    change = np.asarray(change, dtype=float)

    def excess(r: float) -> float:
        return detection_within(r * change, covariance, v0, false_alarm, periods) - probability

    hi = 1.0
    while excess(hi) < 0.0:
        hi *= 2.0
        if hi > 1e9:
            raise ValueError("that change is not detectable at any size")
    lo = hi / 2.0 if hi > 1.0 else 0.0  # short of it (no change: the false alarms only)
    return float(brentq(excess, lo, hi, xtol=1e-9, rtol=1e-6))
