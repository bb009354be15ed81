"""Drift correction of a run's estimates, by ``[output] drift`` and ``estimator``: the
streaming correlator (eqs. 5, 9), the same on each detrended window (drift = "detrend": a
periodic part and a trend fitted together, :mod:`probing.core.trend`), or the cyclic
estimators of :mod:`probing.core.noise` (``cyclic``, ``ac``).  Each turns the measured
output, sampled at the end of each bit, into per-period estimates."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from probing.core.convolution import causal_convolve
from probing.core.correlator import StreamingCorrelator
from probing.core.excitation import SPECTRAL, spectral_estimates
from probing.core.noise import cyclic_estimates
from probing.core.prbs import Probe
from probing.core.trend import detrend_periodic, window_periods
from probing.experiment.scenario import Scenario

__all__ = ["drift_correction", "each_period", "predicted_probing"]


@dataclass
class _Estimates:
    """Per-period estimates of a chunk: ``periods`` (P,), ``z``, ``zeta``, ``h`` (P, C, M)."""

    periods: np.ndarray
    z: np.ndarray
    zeta: np.ndarray
    h: np.ndarray


def _correlator(probe: Probe, push_size: int) -> StreamingCorrelator:
    """A correlator whose FFT block takes one push of ``push_size`` samples in one piece.

    The default block (16 M) suits long pushes; a run pushes one chunk at a time, and a
    block just large enough is ~3x faster per push.
    """
    m = probe.length
    need = max(push_size + m - 1, 2 * m)  # one block per push; the correlator needs >= 2 M
    nfft = 1 << (need - 1).bit_length()  # the smallest power of two >= need
    return StreamingCorrelator(probe.reference(), probe.amplitude_deg, block=nfft)


def each_period(
    probe: Probe, estimator: str, y: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """z, zeta, h of whole periods ``y`` (P, C, M), each from its own samples: ``cyclic``,
    ``ac`` or ``spectral`` (the signal's spectrum over the input's at its harmonics)."""
    ref, a = probe.reference(), probe.amplitude_deg
    if estimator == SPECTRAL:
        return spectral_estimates(y, ref, a, probe.harmonics)
    return cyclic_estimates(y, ref, a, estimator == "cyclic")


class _Streaming:
    """Drift modes ``reference`` and ``none``: the deviation from the twin (or from the
    trimmed output value) streams through one correlator per channel."""

    def __init__(self, probe: Probe, n_channels: int, push_bits: int) -> None:
        self.correlators = [_correlator(probe, push_bits) for _ in range(n_channels)]

    def estimates(self, y_bits: np.ndarray, first: int) -> _Estimates:
        pops = []
        for j, corr in enumerate(self.correlators):
            corr.push(y_bits[:, j])
            pops.append(corr.pop_periods())
        z, zeta, h = (np.stack([getattr(e, x) for e in pops], axis=1) for x in ("z", "zeta", "h"))
        return _Estimates(pops[0].period, z, zeta, h)


class _Detrended:
    """Drift mode ``detrend``: each estimate reads the window of
    :func:`~probing.core.trend.window_periods` periods that ends with its own period, detrended
    by :func:`~probing.core.trend.detrend_periodic` (a periodic part and a trend of ``order``
    fitted together, the trend and the window's mean removed), then estimated afresh from the
    window's last periods (streaming: the last two; cyclic, ac: the last); the first periods,
    whose window is not complete, have no estimate."""

    def __init__(self, probe: Probe, order: int, estimator: str) -> None:
        self.probe, self.order, self.estimator = probe, order, estimator
        self.window = window_periods(order)
        self.prev = np.zeros((0, 0))

    def _estimate(self, window: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(z, zeta, h), each (C, M), of the window's last period."""
        m = self.probe.length
        if self.estimator != "streaming":
            est = each_period(self.probe, self.estimator, window[-m:].T[None])  # (1, C, M)
            return est[0][0], est[1][0], est[2][0]
        rows = []
        for j in range(window.shape[1]):
            fresh = _correlator(self.probe, 2 * m)
            fresh.push(window[-2 * m :, j])
            e = fresh.pop_periods()
            rows.append((e.z[1], e.zeta[1], e.h[1]))
        z, zeta, h = (np.array([r[x] for r in rows]) for x in range(3))
        return z, zeta, h

    def estimates(self, y_bits: np.ndarray, first: int) -> _Estimates:
        m, n_ch = self.probe.length, y_bits.shape[1]
        bits = y_bits[: (y_bits.shape[0] // m) * m]
        history = bits if first == 0 or self.prev.size == 0 else np.vstack((self.prev, bits))
        behind = history.shape[0] // m - bits.shape[0] // m  # periods before this chunk
        periods, out = [], []
        for i in range(bits.shape[0] // m):
            end = (behind + i + 1) * m
            if end < self.window * m:
                continue
            window = detrend_periodic(history[end - self.window * m : end], m, self.order)
            periods.append(first + i)
            out.append(self._estimate(window))
        self.prev = history[-(self.window - 1) * m :].copy()
        z, zeta, h = (np.array([e[x] for e in out]).reshape(-1, n_ch, m) for x in range(3))
        return _Estimates(np.array(periods, dtype=np.int64), z, zeta, h)


class _Cyclic:
    """Estimators ``cyclic``, ``ac`` and ``spectral``: each period from its own samples alone,
    so every period, period 0 included, has an estimate."""

    def __init__(self, probe: Probe, estimator: str) -> None:
        self.probe, self.estimator = probe, estimator

    def estimates(self, y_bits: np.ndarray, first: int) -> _Estimates:
        m = self.probe.length
        count = y_bits.shape[0] // m
        y = y_bits[: count * m].reshape(count, m, -1)  # (P, M, C)
        z, zeta, h = each_period(self.probe, self.estimator, np.moveaxis(y, 1, 2))  # (P, C, M)
        return _Estimates(np.arange(first, first + count, dtype=np.int64), z, zeta, h)


def drift_correction(scn: Scenario, probe: Probe, push_bits: int) -> object:
    """The object that turns a chunk's deviations into estimates, by estimator and drift."""
    if scn.detrends:
        return _Detrended(probe, scn.detrend_order, scn.estimator)
    if scn.estimator != "streaming":
        return _Cyclic(probe, scn.estimator)
    return _Streaming(probe, len(scn.channels), push_bits)


def predicted_probing(scn: Scenario, h_pulse: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Probing output predicted by superposing the single-pulse response over the probe history.

    Returns, per channel, an array (periods, 3, M): z, zeta, h_est per period: the paper's
    streaming correlator for the PRBS, the scenario's estimator for a multisine or a chirp.
    """
    probe = scn.probe
    bits = probe.bits(scn.periods)
    out = {}
    for channel, h in h_pulse.items():
        y = causal_convolve(bits, h)
        if probe.excitation.is_binary:
            corr = StreamingCorrelator(probe.reference(), probe.amplitude_deg)
            corr.push(y)
            est = corr.pop_periods()
            out[channel] = np.stack((est.z, est.zeta, est.h), axis=1)
        else:  # a multisine or a chirp: its own estimator, each period alone
            periods = y.reshape(scn.periods, probe.length)
            out[channel] = np.stack(each_period(probe, scn.estimator, periods), axis=1)
    return out
