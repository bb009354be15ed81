"""The constant that a model-free drift removal leaves in a pulse-response estimate, pinned
with the response's settled tail.

Without a reference that carries the output's baseline, the baseline is removed with the
record's own mean (``drift = "detrend"``, ``none``; ``probing analyze`` without
``--reference``).  The response to the probe's own mean (a +-1 m-sequence sums to -1) cannot
be told from that baseline, so every tap of the estimate is the pulse response less one
constant: h_est[k] = h[k] - c, with c = sum(h) / M for the DC-corrected estimators (the
estimate then sums to zero over the period: the **zero-mean** convention).

The method's own rule is that the period T covers the response's settling, so the last taps
are a known zero: where the tail is flat within its noise, c is the tail's mean with its sign
changed, and subtracting each period's tail mean from that period gives the pulse response
itself (the **settled-tail** convention).  Whether the tail is flat is a test on the periods'
own scatter: each period's tail, less its own mean, averaged over the P periods, must be zero
within noise.  With m_k the mean over periods of tap k of the pinned tail (N taps) and s^2
the pooled period-to-period variance of those taps (sum over the taps of their variances,
over the N - 1 free taps a tail less its mean holds),

    F = sum_k m_k^2 / (N - 1) / (s^2 / P),

which for a flat tail and white noise follows the F distribution with N - 1 and
(N - 1)(P - 1) degrees of freedom.  F spreads its power over every shape a tail can take; a
slow decay is a ramp, which one number tests better: each period's least-squares slope over
the tail, b_p, whose mean over the P periods must be zero within its Student-t interval,
t = mean(b) / (std(b) / sqrt(P)) with P - 1 degrees of freedom.  The tail is taken as
settled where both hold, each at half the false-unsettled budget 1 - ``level`` (F at most
its 1 - (1 - level) / 2 quantile, |t| at most its two-sided one).  A tail that still decays
or rings beyond the noise fails: the record cannot tell the constant, and the estimate
keeps the zero-mean convention.  A tail that is
flat at a value other than zero (a response that never returns, an integrator) cannot be
told from a settled one; the rule's premise is that the response returns to zero within T.
Without noise (a simulation's noise-free run) s^2 is zero and F says nothing: a tail whose
RMS departure from flat is at most :data:`TAIL_FLOOR` of the estimate's peak is flat too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from probing.core.fixedorder import dot, vdot

__all__ = [
    "SETTLED_TAIL",
    "TAIL_FLOOR",
    "TAIL_FRACTION",
    "TAIL_LEVEL",
    "ZERO_MEAN",
    "TailPin",
    "pin_settled_tail",
    "tail_taps",
]

#: The convention of an estimate pinned with its settled tail: the pulse response itself.
SETTLED_TAIL = "settled tail"
#: The convention of an estimate whose tail has not settled: the response less sum(h) / M.
ZERO_MEAN = "zero mean"
#: The share of the period's taps that makes the tail by default (the last quarter).
TAIL_FRACTION = 0.25
#: The quantile of the F distribution below which a tail is taken as flat.
TAIL_LEVEL = 0.99
#: A tail whose RMS departure from flat is at most this share of the peak |h| is flat.
TAIL_FLOOR = 1e-3


def tail_taps(m: int, settled_after_taps: int | None = None) -> int:
    """The number of taps of the tail: from ``settled_after_taps`` to the period's end, by
    default the last :data:`TAIL_FRACTION` of the M taps (at least 3 in either case).

    Raises
    ------
    ValueError
        If the tail would hold fewer than 3 taps or start before tap 1.
    """
    if settled_after_taps is None:
        n = int(np.ceil(TAIL_FRACTION * m))
    else:
        if settled_after_taps < 1:
            raise ValueError(f"the tail must start after tap 0, not at tap {settled_after_taps}")
        n = m - int(settled_after_taps)
    if n < 3:
        raise ValueError(f"a tail of {n} taps of {m} is too short to test (at least 3)")
    return n


@dataclass(frozen=True)
class TailPin:
    """What :func:`pin_settled_tail` found, per channel.

    Attributes
    ----------
    h : numpy.ndarray
        Shape (P, C, M): each period's estimate, less its own tail mean where the channel's
        tail is settled, unchanged elsewhere (unit of h).
    settled : numpy.ndarray
        Shape (C,), bool: the tail is flat within noise (module docstring).
    statistic, threshold : numpy.ndarray, float
        Shape (C,): F of each channel's tail, and the quantile it is held to.
    slope_t, slope_threshold : numpy.ndarray, float
        Shape (C,): t of each channel's tail slope, and the bound of its absolute value.
    constant : numpy.ndarray
        Shape (C,): the constant removed (the mean over periods of the tail means; 0 where
        not settled; unit of h).
    tail_taps : int
        Taps in the tail, from tap M - tail_taps to M - 1.
    """

    h: np.ndarray
    settled: np.ndarray
    statistic: np.ndarray
    threshold: float
    constant: np.ndarray
    tail_taps: int
    slope_t: np.ndarray
    slope_threshold: float

    def conventions(self, channels: list[str]) -> dict[str, str]:
        """Channel -> :data:`SETTLED_TAIL` or :data:`ZERO_MEAN`."""
        return {
            c: SETTLED_TAIL if s else ZERO_MEAN for c, s in zip(channels, self.settled, strict=True)
        }

    def record(self, channels: list[str]) -> dict[str, object]:
        """The tail's test as a file records it: the tail's first tap and length, and per
        channel F, the slope's t, their thresholds (they depend on the periods P) and the
        constant removed."""
        n = len(channels)

        def per(values: object) -> dict[str, float]:
            return dict(zip(channels, np.broadcast_to(values, n).tolist(), strict=True))

        return {
            "from_tap": self.h.shape[2] - self.tail_taps,
            "taps": self.tail_taps,
            "f_statistic": per(self.statistic),
            "f_threshold": per(self.threshold),
            "slope_t": per(self.slope_t),
            "slope_t_threshold": per(self.slope_threshold),
            "constant_removed": per(self.constant),
        }


def pin_settled_tail(h: np.ndarray, n_tail: int, level: float = TAIL_LEVEL) -> TailPin:
    """Pin the constant of zero-mean estimates with their settled tail (module docstring).

    Parameters
    ----------
    h : numpy.ndarray
        Shape (P, C, M), P >= 2: per-period estimates in the zero-mean convention (any unit).
    n_tail : int
        Taps in the tail (:func:`tail_taps`), 3 <= n_tail < M.
    level : float
        One less the false-unsettled probability of a flat tail in white noise, shared by
        the F and the slope's t test (module docstring).

    Returns
    -------
    TailPin

    Examples
    --------
    >>> hh = np.array([1.0, 0.5, 0.25, 0.0, 0.0, 0.0, 0.0])
    >>> rng = np.random.default_rng(0)
    >>> est = hh - hh.sum() / 7 + 1e-6 * rng.standard_normal((4, 1, 7))
    >>> pin = pin_settled_tail(est, 4)
    >>> bool(pin.settled[0]), bool(np.allclose(pin.h.mean(axis=0)[0], hh, atol=1e-5))
    (True, True)
    """
    h = np.asarray(h, dtype=float)
    periods, _, m = h.shape
    if periods < 2:
        raise ValueError(f"a tail's test needs at least 2 periods, got {periods}")
    if not 3 <= n_tail < m:
        raise ValueError(f"a tail of {n_tail} taps of {m}: need 3 <= taps < {m}")
    tail = h[:, :, m - n_tail :]
    own = tail.mean(axis=2, keepdims=True)  # (P, C, 1): each period's tail mean
    flat = tail - own
    mk = flat.mean(axis=0)  # (C, N)
    # (C,): pooled over the tail's taps; the flat tail holds N - 1 free taps per period
    s2 = flat.var(axis=0, ddof=1).sum(axis=1) / (n_tail - 1)
    dfn, dfd = n_tail - 1, (n_tail - 1) * (periods - 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        stat = (mk**2).sum(axis=1) / dfn / (s2 / periods)
    stat = np.where(s2 > 0, stat, np.where((mk**2).sum(axis=1) > 0, np.inf, 0.0))
    miss = (1.0 - level) / 2.0  # each test's share of the false-unsettled budget
    threshold = float(stats.f.ppf(1.0 - miss, dfn, dfd))
    k = np.arange(n_tail) - (n_tail - 1) / 2.0
    slopes = dot(flat, k) / vdot(k, k)  # (P, C): each period's least-squares slope over the tail
    sd = slopes.std(axis=0, ddof=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = slopes.mean(axis=0) / (sd / np.sqrt(periods))
    t = np.where(sd > 0, t, np.where(slopes.mean(axis=0) != 0, np.inf, 0.0))
    t_threshold = float(stats.t.ppf(1.0 - miss / 2.0, periods - 1))
    peak = np.abs(h.mean(axis=0)).max(axis=1)  # (C,)
    rms = np.sqrt((mk**2).mean(axis=1))
    flat_enough = (stat <= threshold) & (np.abs(t) <= t_threshold)
    settled = flat_enough | (rms <= TAIL_FLOOR * peak)
    pinned = np.where(settled[None, :, None], h - own, h)
    constant = np.where(settled, own[:, :, 0].mean(axis=0), 0.0)
    return TailPin(pinned, settled, stat, threshold, constant, n_tail, t, t_threshold)
