"""Drift correction of a run's estimates, by ``[output] drift`` and ``estimator``: the
streaming correlator (eqs. 5, 9), the same after detrending each window (drift = "detrend"),
or the cyclic estimators of :mod:`probing.core.noise` (``cyclic``, ``ac``).  Each turns
the measured output, sampled at the end of each bit, into per-period estimates."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from probing.core.correlator import StreamingCorrelator
from probing.core.noise import cyclic_estimates, detrend
from probing.core.prbs import Probe
from probing.experiment.scenario import Scenario

__all__ = ["drift_correction"]


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
    """Drift mode ``detrend`` with the streaming estimator: each period's z windows reach
    back one period, so the bit samples of periods p-1 and p are detrended together
    (least-squares polynomial of ``order``) and correlated afresh; period 0 has no estimate."""

    def __init__(self, probe: Probe, order: int) -> None:
        self.probe, self.order = probe, order
        self.prev: np.ndarray | None = None

    def estimates(self, y_bits: np.ndarray, first: int) -> _Estimates:
        m = self.probe.length
        n_ch = y_bits.shape[1]
        periods, rows = [], []
        for i in range(y_bits.shape[0] // m):
            bits = y_bits[i * m : (i + 1) * m]
            if self.prev is not None:
                window = detrend(np.vstack((self.prev, bits)), self.order)
                per_channel = []
                for j in range(n_ch):
                    fresh = _correlator(self.probe, 2 * m)
                    fresh.push(window[:, j])
                    est = fresh.pop_periods()
                    per_channel.append((est.z[1], est.zeta[1], est.h[1]))
                periods.append(first + i)
                rows.append(per_channel)
            self.prev = bits.copy()
        z, zeta, h = (
            np.array([[e[x] for e in pc] for pc in rows]).reshape(-1, n_ch, m) for x in range(3)
        )
        return _Estimates(np.array(periods, dtype=np.int64), z, zeta, h)


class _Cyclic:
    """Estimators ``cyclic`` and ``ac``: each period from its own samples alone (detrended
    first with drift mode ``detrend``), so every period, period 0 included, has an estimate."""

    def __init__(self, probe: Probe, dc: bool, detrend_order: int | None) -> None:
        self.probe, self.dc, self.detrend_order = probe, dc, detrend_order

    def estimates(self, y_bits: np.ndarray, first: int) -> _Estimates:
        m = self.probe.length
        count = y_bits.shape[0] // m
        y = y_bits.reshape(count, m, -1)  # (P, M, C)
        if self.detrend_order is not None:
            y = np.stack([detrend(period, self.detrend_order) for period in y])
        z, zeta, h = cyclic_estimates(
            np.moveaxis(y, 1, 2), self.probe.reference(), self.probe.amplitude_deg, self.dc
        )  # (P, C, M)
        return _Estimates(np.arange(first, first + count, dtype=np.int64), z, zeta, h)


def drift_correction(scn: Scenario, probe: Probe, push_bits: int) -> object:
    """The object that turns a chunk's deviations into estimates, by estimator and drift."""
    detrend_order = scn.detrend_order if scn.detrends else None
    if scn.estimator != "streaming":
        return _Cyclic(probe, scn.estimator == "cyclic", detrend_order)
    if detrend_order is not None:
        return _Detrended(probe, detrend_order)
    return _Streaming(probe, len(scn.channels), push_bits)
