"""The pulse-response estimators and their noise: exact second moments from their own weights.

Each estimator turns the bit samples u of one probe period (and, for the paper's streaming
form, of the period before) into the probing output z and the pulse-response estimate h, tap
by tap.  All three are linear in u, so each is a matrix of weights, and the seed-to-seed
covariance of their mean over P settled periods follows exactly from those weights and the
autocovariance r(tau) of the noise on u:

    var(mean of P periods, tap i) = 1/P^2 sum_d (P - |d|) sum_tau c_i(tau) r(|d M + tau|)

where c_i is the autocorrelation of tap i's weight row and d the distance between two
periods in periods (windows that overlap, or noise correlated across periods, both count).
White sensor noise of standard deviation sigma is r = [sigma^2].

Noise that is not stationary, or not additive (turbulence the reference twin does not cancel:
the gusts perturb the aircraft's response to the probe, a random change of h itself), has no
autocovariance that says what it does to one direction of h such as the gain's.  It is taken
as realisations instead (``samples``: K noise-free runs' residual bit samples from the run's
start): the estimator's weights applied to each realisation's own settled periods, the
variance over the K realisations (sampling error 1/sqrt(2 (K - 1)) on a standard deviation).

============  ==============================================================================
estimator     what it computes (reference sigma, amplitude a, M = 2^n - 1)
============  ==============================================================================
streaming     the paper's eq. (5) sliding correlation over the last M samples and the eq. (9)
              DC correction zeta = z + sum over the period of z; period p reads periods p-1
              and p.  The correction sums windows that reach into the previous period, so the
              noise of one period's h is about sqrt(M) times the naive sigma / (a sqrt(M))
              (16.6x at M = 511); adjacent periods' errors are strongly anti-correlated, so
              the mean of P periods falls faster than 1/sqrt(P) at first.
cyclic        the cyclic correlation of period p's own M samples, z(i) = sum_j sigma_j
              u[(i + j) mod M], and the same DC correction: the exact inverse of the periodic
              probe.  Same expectation in the periodic steady state; noise sqrt(2 (M+1)) /
              (M+1) * sigma / a, about sqrt(2) x the naive rule; periods independent.
ac            the cyclic correlation without the DC correction: h - sum(h) / (M+1), the
              response's shape and gain without its mean, at the naive rule's noise
              sqrt(M) / (M+1) * sigma / a.
============  ==============================================================================

Why the DC term costs: a +-1 m-sequence sums to -1, so the probe excites the direction
sum(h) (all taps together) M+1 times more weakly than every other direction; estimating it
amplifies the noise in that one direction, which is common to all taps.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from probing.core.excitation import SPECTRAL, spectral_estimates
from probing.core.fixedorder import dot, vdot
from probing.core.trend import detrend_rows, window_periods

__all__ = [
    "ESTIMATORS",
    "ESTIMATOR_NAMES",
    "NoiseModel",
    "cyclic_estimates",
    "estimator_weights",
    "noise_model",
    "white",
]

#: Estimator name -> one line on what it computes.
ESTIMATORS: dict[str, str] = {
    "streaming": "eq. (5) sliding correlation and the eq. (9) DC correction (the paper's)",
    "cyclic": "cyclic correlation of each period's own samples and the DC correction",
    "ac": "cyclic correlation without the DC correction: h minus its mean, for shape and gain",
}


#: Every estimator a scenario may name: the PRBS's correlators and the spectral one of
#: every signal (:func:`probing.core.excitation.spectral_estimates`).
ESTIMATOR_NAMES = (*ESTIMATORS, SPECTRAL)


def _check(reference: np.ndarray, amplitude: float, estimator: str) -> tuple[np.ndarray, float]:
    ref = np.asarray(reference, dtype=float)
    if ref.ndim != 1 or ref.size < 3:
        raise ValueError("reference must be a 1-D array of length M >= 3")
    if not (math.isfinite(amplitude) and amplitude > 0):
        raise ValueError(f"amplitude must be > 0, got {amplitude}")
    if estimator not in ESTIMATOR_NAMES:
        names = ", ".join(ESTIMATOR_NAMES)
        raise ValueError(f"estimator must be one of {names}, got {estimator!r}")
    return ref, float(amplitude)


def estimator_weights(
    reference: np.ndarray,
    amplitude: float,
    estimator: str,
    harmonics: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Weights of one period's z and h (tap order) on the bit samples the period reads.

    Parameters
    ----------
    reference : numpy.ndarray
        The +-1 m-sequence sigma, length M (for ``spectral``, the probe's unit signal).
    amplitude : float
        Probe amplitude a (probe units, deg).
    estimator : str
        A key of :data:`ESTIMATORS`, or ``"spectral"``
        (:func:`probing.core.excitation.spectral_estimates`, a linear map too: its weights
        are its estimates of the unit samples).
    harmonics : numpy.ndarray, optional
        ``spectral``: the excited harmonics (None: all, the PRBS's).

    Returns
    -------
    z_rows, h_rows : numpy.ndarray
        Shape (M, L): ``z = z_rows @ u`` (output units) and ``h = h_rows @ u`` (output units
        per probe unit), with u the L samples read: L = 2M for ``streaming`` (the previous
        period, then the period's own), L = M otherwise.

    Examples
    --------
    >>> from probing.core.prbs import mls
    >>> z, h = estimator_weights(mls(3), 1.0, "cyclic")
    >>> h @ np.tile(0.5, 7)  # a constant output: -c / a on every tap, the eq. (11) offset
    array([-0.5, -0.5, -0.5, -0.5, -0.5, -0.5, -0.5])
    """
    ref, a = _check(reference, amplitude, estimator)
    harm = None if harmonics is None else np.asarray(harmonics).tobytes()
    key = (ref.tobytes(), ref.dtype.str, a, estimator, harm)
    found = _WEIGHTS.get(key)
    if found is None:
        if len(_WEIGHTS) >= 4:
            _WEIGHTS.pop(next(iter(_WEIGHTS)))  # the oldest
        z, h = _weights_of(ref, a, estimator, harmonics)
        z.flags.writeable = h.flags.writeable = False
        found = _WEIGHTS[key] = (z, h)
    return found


#: :func:`estimator_weights` remembered (read-only arrays), at most four: a sweep's points
#: share their probe, and a (M, 2M) pair of M = 511 takes ~15 ms to build, in every forked
#: point again unless its parent built it first.
_WEIGHTS: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}


def _weights_of(
    ref: np.ndarray, a: float, estimator: str, harmonics: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    m = ref.size
    if estimator == SPECTRAL:
        z, _, h = spectral_estimates(np.eye(m), ref, a, harmonics)  # row n: y = e_n
        return z.T, h.T
    if estimator == "streaming":
        # z of tap i is read at sample r = (i - 1) mod M of the period: window r+1 .. r+M of u
        z = np.zeros((m, 2 * m))
        for i in range(m):
            r = (i - 1) % m
            z[i, r + 1 : r + 1 + m] = ref
    else:
        idx = (np.arange(m)[:, None] + np.arange(m)[None, :]) % m  # u[(i + j) mod M]
        z = np.zeros((m, m))
        np.put_along_axis(z, idx, np.broadcast_to(ref, (m, m)), axis=1)
    h = z if estimator == "ac" else z + z.sum(axis=0)  # zeta = z + sum over the period of z
    return z, h / (a * (m + 1))


def cyclic_estimates(
    y: np.ndarray, reference: np.ndarray, amplitude: float, dc: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``cyclic`` (``dc=True``) or ``ac`` (``dc=False``) estimates of whole periods.

    Parameters
    ----------
    y : numpy.ndarray
        Bit samples of whole periods, shape (P, M).
    reference : numpy.ndarray
        The +-1 m-sequence sigma, length M.
    amplitude : float
        Probe amplitude a.
    dc : bool
        Apply the DC correction of eq. (9) within the period (``cyclic``), or not (``ac``).

    Returns
    -------
    z, zeta, h : numpy.ndarray
        Shape (P, M), tap order: the cyclic correlation z(i) = sum_j sigma_j y[(i + j) mod M],
        zeta = z + sum(z) (or z without the correction), h = zeta / (a (M+1)).
    """
    ref, a = _check(reference, amplitude, "cyclic" if dc else "ac")
    y = np.atleast_2d(np.asarray(y, dtype=float))
    m = ref.size
    if y.shape[-1] != m:
        raise ValueError(f"y must hold whole periods of {m} samples, got shape {y.shape}")
    z = np.fft.irfft(np.fft.rfft(y, axis=-1) * np.conj(np.fft.rfft(ref)), m, axis=-1)
    zeta = z + z.sum(axis=-1, keepdims=True) if dc else z
    return z, zeta, zeta / (a * (m + 1))


def white(sigma: float) -> np.ndarray:
    """Autocovariance of white noise of standard deviation ``sigma``: ``[sigma^2]``."""
    return np.array([float(sigma) ** 2])


def _sampled_variance(
    rows: np.ndarray, samples: np.ndarray, m: int, first: int, periods: int
) -> np.ndarray:
    """Variance over realisations of the mean over periods ``first .. first + periods - 1`` of
    ``rows @ u``, period p's window being the ``rows.shape[1]`` samples that end with period
    p (the period itself, and the one before for streaming); ``samples`` (K, n) from the run's
    first sample."""
    rows = np.atleast_2d(rows)
    samples = np.atleast_2d(samples)
    k, n = samples.shape
    back = rows.shape[1] // m  # periods a window reads: 1, or 2 for streaming
    start = first - back + 1
    if start < 0 or (first + periods) * m > n:
        raise ValueError(
            f"samples of {n // m} periods do not hold the windows of periods {first} to "
            f"{first + periods - 1}"
        )
    if k < 2:
        raise ValueError("samples need at least 2 realisations for a variance")
    window_sum = np.concatenate(
        [
            samples[:, (start + j) * m : (start + j + periods) * m]
            .reshape(k, periods, m)
            .sum(axis=1)
            for j in range(back)
        ],
        axis=1,
    )
    return np.var(dot(window_sum, rows.T) / periods, axis=0, ddof=1)


def _variance(rows: np.ndarray, acov: np.ndarray, m: int, periods: int) -> np.ndarray:
    """Variance of the mean over ``periods`` consecutive periods of ``rows @ u`` (module
    docstring), each row's weights shifted by ``m`` samples from one period to the next."""
    rows = np.atleast_2d(rows)
    n_rows, width = rows.shape
    out = np.zeros(n_rows)
    if not np.any(acov):
        return out
    reach = (acov.size + width) // m + 1  # farther periods share no correlated samples
    ds = np.arange(-min(periods - 1, reach), min(periods - 1, reach) + 1)
    if ds.size * (2 * acov.size - 1) < width:  # short correlation: the few lags it meets
        for d in ds:
            for lag in range(-(acov.size - 1), acov.size):
                tau = abs(lag - d * m)  # rows' autocorrelation is even in tau
                if tau < width:
                    c = np.einsum("ij,ij->i", rows[:, : width - tau], rows[:, tau:])
                    out += (periods - abs(d)) * acov[abs(lag)] * c
        return np.maximum(out, 0.0) / periods**2
    nfft = 1 << (2 * width - 1).bit_length()
    spec = np.fft.rfft(rows, nfft, axis=1)
    c = np.fft.irfft(np.abs(spec) ** 2, nfft, axis=1)
    taus = np.arange(-(width - 1), width)
    c = np.concatenate((c[:, nfft - width + 1 :], c[:, :width]), axis=1)  # tau = -(L-1)..L-1
    for d in ds:
        lag = np.abs(d * m + taus)
        r = np.where(lag < acov.size, acov[np.minimum(lag, acov.size - 1)], 0.0)
        out += (periods - abs(d)) * dot(c, r)
    return np.maximum(out, 0.0) / periods**2


@dataclass(frozen=True)
class NoiseModel:
    """Seed-to-seed noise of the mean over P settled periods of one estimator's z and h.

    Build it with :func:`noise_model`.  Standard deviations are per tap, in the output's
    unit (z) and per probe unit (h).  The noise is the stationary part ``acov`` plus, when
    given, realisations ``samples`` (K, n) of further noise on the bit samples from the run's
    first sample, of which the settled periods ``first .. first + periods - 1`` are read.
    """

    estimator: str
    z_rows: np.ndarray
    h_rows: np.ndarray
    m: int
    periods: int
    acov: np.ndarray
    samples: np.ndarray | None = None
    first: int = 0

    def with_noise(
        self, acov: np.ndarray, samples: np.ndarray | None = None, first: int = 0
    ) -> NoiseModel:
        """The same estimator under other noise: autocovariance ``acov`` of the bit samples
        (output units squared), plus realisations ``samples`` (K, n; output units) whose
        settled periods start at period ``first``."""
        acov = np.atleast_1d(np.asarray(acov, dtype=float))
        if samples is not None:
            samples = np.atleast_2d(np.asarray(samples, dtype=float))
        return dataclasses.replace(self, acov=acov, samples=samples, first=int(first))

    def _variance(self, rows: np.ndarray) -> np.ndarray:
        out = _variance(rows, self.acov, self.m, self.periods)
        if self.samples is not None:
            out = out + _sampled_variance(rows, self.samples, self.m, self.first, self.periods)
        return out

    def z_std(self) -> np.ndarray:
        """Standard deviation of each tap of the mean settled z, shape (M,)."""
        return np.sqrt(self._variance(self.z_rows))

    def h_std(self) -> np.ndarray:
        """Standard deviation of each tap of the mean settled h, shape (M,)."""
        return np.sqrt(self._variance(self.h_rows))

    def projection_std(self, v: np.ndarray) -> float:
        """Standard deviation of ``v @ h`` for the mean settled h."""
        row = dot(np.asarray(v, dtype=float), self.h_rows)
        return float(np.sqrt(self._variance(row[None, :])[0]))

    def gain_std(self, h_ref: np.ndarray) -> float:
        """Standard deviation of the least-squares gain <h, h_ref> / <h_ref, h_ref> of the
        mean settled h against a noise-free ``h_ref`` (dimensionless)."""
        h_ref = np.asarray(h_ref, dtype=float)
        return self.projection_std(h_ref) / vdot(h_ref, h_ref)


def noise_model(
    reference: np.ndarray,
    amplitude: float,
    estimator: str,
    periods: int,
    acov: np.ndarray,
    detrend_order: int | None = None,
    harmonics: np.ndarray | None = None,
) -> NoiseModel:
    """The noise of one estimator's mean over ``periods`` settled periods.

    Parameters
    ----------
    reference : numpy.ndarray
        The +-1 m-sequence sigma, length M.
    amplitude : float
        Probe amplitude a (deg).
    estimator : str
        A key of :data:`ESTIMATORS`.
    periods : int
        Settled periods averaged, P >= 1.
    acov : numpy.ndarray
        Autocovariance r(0), r(1), ... of the noise on the bit samples (output units
        squared); :func:`white` for sensor noise.
    detrend_order : int, optional
        Drift mode ``detrend``: each estimate reads the window of
        :func:`probing.core.trend.window_periods` periods ending with its own, detrended by
        :func:`probing.core.trend.detrend_periodic` (a trend of this order fitted together
        with a periodic part, and the mean, removed); the weights become those on the window.
    harmonics : numpy.ndarray, optional
        ``spectral``: the excited harmonics (:func:`estimator_weights`).

    Returns
    -------
    NoiseModel

    Examples
    --------
    >>> from probing.core.prbs import mls
    >>> m = noise_model(mls(9), 1.0, "ac", 4, white(1.0))
    >>> round(float(np.sqrt(np.mean(m.h_std() ** 2)) * np.sqrt(511 * 4)), 4)  # naive rule
    0.998
    """
    if int(periods) < 1:
        raise ValueError(f"periods must be >= 1, got {periods}")
    z, h = estimator_weights(reference, amplitude, estimator, harmonics)
    if detrend_order is not None:  # rows @ D: the estimate of the detrended window
        m = z.shape[0]
        width = window_periods(detrend_order) * m
        pad = ((0, 0), (width - z.shape[1], 0))  # the estimate reads the window's end
        z = detrend_rows(np.pad(z, pad), m, detrend_order)
        h = detrend_rows(np.pad(h, pad), m, detrend_order)
    acov = np.atleast_1d(np.asarray(acov, dtype=float))
    return NoiseModel(estimator, z, h, z.shape[0], int(periods), acov)
