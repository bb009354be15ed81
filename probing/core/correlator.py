"""Streaming pulse-compression correlator (eqs. 5, 8 and 9 of Ruschmann & Wu).

The probing output is the sliding correlation of the measured output y with
the unit reference sigma (one +-1 m-sequence period of length M):

    z[k] = sum_{j=0}^{M-1} y[k-M+1+j] * sigma[j]                     (5)

with k counted from the first sample pushed.  For a plant with pulse response
h driven by the cyclic probe a*sigma, starting at sample 0,

    z[k] = a [(M+1) h((k+1) mod M) - sum_j h(j)]                     (8)

so z at sample k of a period estimates tap (k+1) mod M: the last sample of a
period carries tap 0.  The DC-corrected output of eq. (9) adds the sum of z
over one period (which equals a * sum_j h(j)):

    zeta_i = z_i + sum_{period} z = a (M+1) h(i)                      (9)

and the pulse-response estimate is h_i = zeta_i / (a (M+1)).

The implementation is block overlap-add with a precomputed real FFT of the
reference, vectorised over all blocks of a pushed chunk: no per-sample Python
work and memory bounded by the block size, whatever the stream length.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import fft as sfft

__all__ = ["PeriodEstimates", "StreamingCorrelator"]


@dataclass(frozen=True)
class PeriodEstimates:
    """The probing outputs of consecutive complete probe periods, in tap order.

    Attributes
    ----------
    period : numpy.ndarray
        Period indices p, shape (P,); period p covers samples p*M .. p*M + M - 1.
    z : numpy.ndarray
        Probing output (eq. 5) arranged by tap, shape (P, M): ``z[:, i]``
        estimates ``a[(M+1) h(i) - sum h]``.  Output units times probe units.
    zeta : numpy.ndarray
        DC-corrected probing output (eq. 9), ``a (M+1) h(i)``, shape (P, M).
    h : numpy.ndarray
        Pulse-response estimate, output units per probe unit, for a one-bit
        pulse: ``zeta / (a (M+1))``, shape (P, M).
    """

    period: np.ndarray
    z: np.ndarray
    zeta: np.ndarray
    h: np.ndarray

    def __len__(self) -> int:
        return int(self.period.size)


class StreamingCorrelator:
    """Sliding correlation of an output stream with the probe reference.

    Parameters
    ----------
    reference : array_like
        One period sigma of the unit reference (+-1 m-sequence), length M >= 3.
    amplitude : float
        Probe amplitude a (> 0) in input units (deg of surface deflection in
        this project), used to scale the pulse-response estimate.
    keep : int, optional
        How many of the latest complete periods are kept for
        :meth:`pulse_response` averaging (default 16); memory does not grow
        beyond that.
    record : bool, optional
        Keep every completed period until :meth:`pop_periods` takes it
        (default).  With False only the latest ``keep`` periods are kept.
    block : int, optional
        FFT length of the overlap-add blocks; default: the smallest power of
        two >= 16 M.

    Examples
    --------
    >>> from probing.core.prbs import mls
    >>> sigma = mls(5)
    >>> corr = StreamingCorrelator(sigma, amplitude=0.1)
    >>> h = np.zeros(31); h[2] = 1.0
    >>> p = 0.1 * np.tile(sigma, 3)
    >>> y = np.convolve(p, h)[: p.size]
    >>> _ = corr.push(y)
    >>> bool(np.allclose(corr.pulse_response(), h, atol=1e-12))
    True
    """

    def __init__(
        self,
        reference: np.ndarray,
        amplitude: float,
        *,
        keep: int = 16,
        block: int | None = None,
        record: bool = True,
    ) -> None:
        ref = np.asarray(reference, dtype=np.float64)
        if ref.ndim != 1 or ref.size < 3:
            raise ValueError("reference must be a 1-D array of length M >= 3")
        if not np.all(np.isfinite(ref)):
            raise ValueError("reference must be finite")
        if not (np.isfinite(amplitude) and amplitude > 0):
            raise ValueError(f"amplitude must be > 0, got {amplitude}")
        if keep < 1:
            raise ValueError(f"keep must be >= 1, got {keep}")
        m = ref.size
        self.reference = ref
        self.amplitude = float(amplitude)
        self.length = m
        nfft = 1 << int(np.ceil(np.log2(16 * m))) if block is None else int(block)
        if nfft < 2 * m:
            raise ValueError(f"block must be >= 2 M = {2 * m}, got {block}")
        self._nfft = nfft
        self._block_len = nfft - (m - 1)  # input samples per block
        # Correlation with sigma == convolution with sigma reversed.
        self._ref_fft = sfft.rfft(ref[::-1], nfft)
        self._carry = np.zeros(m - 1)  # overlap-add sums owed to the next M-1 samples
        self._seen = 0  # samples pushed so far
        self._period_z = np.empty(m)  # z of the period being filled, time order
        self._keep = keep
        self._record = record
        self._recent_h = np.empty((keep, m))  # ring buffer of the latest h estimates
        self._pending: list[PeriodEstimates] = []
        self._completed = 0

    # ------------------------------------------------------------------ core
    def _correlate(self, y: np.ndarray) -> np.ndarray:
        """z for the samples y, continuing the stream (block overlap-add)."""
        m1 = self.length - 1
        n = y.size
        blk = self._block_len
        nblocks = -(-n // blk)
        if nblocks * blk == n:
            blocks = y.reshape(nblocks, blk)
        else:
            blocks = np.zeros((nblocks, blk))
            blocks.reshape(-1)[:n] = y
        conv = sfft.irfft(sfft.rfft(blocks, self._nfft, axis=1) * self._ref_fft, self._nfft, axis=1)
        out = np.zeros(nblocks * blk + m1)
        out[: nblocks * blk] = conv[:, :blk].reshape(-1)
        # Tail of block b spills into the first M-1 samples of block b+1.
        out[blk : nblocks * blk].reshape(nblocks - 1, blk)[:, :m1] += conv[:-1, blk : blk + m1]
        out[nblocks * blk :] += conv[-1, blk : blk + m1]
        out[:m1] += self._carry
        self._carry = out[n : n + m1].copy()  # partial sums owed to the next samples
        return out[:n]

    def push(self, y: np.ndarray) -> np.ndarray:
        """Feed output samples (one per bit) and get the probing output for each.

        Parameters
        ----------
        y : array_like
            The next samples of the measured output, output units.

        Returns
        -------
        numpy.ndarray
            z for each pushed sample (eq. 5), NaN until M samples have been
            seen.  Completed periods become available through
            :meth:`pop_periods` and :meth:`pulse_response`.
        """
        y = np.asarray(y, dtype=np.float64).reshape(-1)
        n = y.size
        if n == 0:
            return np.empty(0)
        z = self._correlate(y)
        m = self.length
        start = self._seen
        invalid = max(0, min(n, m - 1 - start))
        z[:invalid] = np.nan
        self._collect_periods(z, start)
        self._seen += n
        return z

    def _collect_periods(self, z: np.ndarray, start: int) -> None:
        m = self.length
        n = z.size
        offset = start % m
        pos = 0
        if offset:  # finish the period already begun
            take = min(m - offset, n)
            self._period_z[offset : offset + take] = z[:take]
            pos = take
            if offset + take == m:
                self._finish_periods(start // m, self._period_z[None, :])
        full = (n - pos) // m
        if full:
            self._finish_periods((start + pos) // m, z[pos : pos + full * m].reshape(full, m))
            pos += full * m
        if pos < n:
            self._period_z[: n - pos] = z[pos:]

    def _finish_periods(self, first: int, zp: np.ndarray) -> None:
        """Turn whole periods of z (time order, shape (P, M)) into tap-ordered estimates."""
        count = zp.shape[0]
        zt = np.empty_like(zp)
        zt[:, 0] = zp[:, -1]  # the last sample of a period carries tap 0
        zt[:, 1:] = zp[:, :-1]  # sample j carries tap j+1
        zeta = zt + zp.sum(axis=1, keepdims=True)
        h = zeta / (self.amplitude * (self.length + 1))
        periods = np.arange(first, first + count)
        if self._record:
            self._pending.append(PeriodEstimates(period=periods, z=zt, zeta=zeta, h=h))
        slots = periods[-self._keep :] % self._keep
        self._recent_h[slots] = h[-self._keep :]
        self._completed += count

    # ------------------------------------------------------------- results
    def pop_periods(self) -> PeriodEstimates:
        """The periods completed since the last call, oldest first.

        Empty (zero rows) when none completed; always empty when the correlator
        was made with ``record=False``.
        """
        pending, self._pending = self._pending, []
        if not pending:
            empty = np.empty((0, self.length))
            return PeriodEstimates(np.empty(0, dtype=np.int64), empty, empty, empty)
        if len(pending) == 1:
            return pending[0]
        return PeriodEstimates(
            period=np.concatenate([p.period for p in pending]),
            z=np.concatenate([p.z for p in pending]),
            zeta=np.concatenate([p.zeta for p in pending]),
            h=np.concatenate([p.h for p in pending]),
        )

    def pulse_response(self, average: int = 1) -> np.ndarray:
        """Latest DC-corrected pulse-response estimate.

        Parameters
        ----------
        average : int
            Number of latest complete periods to average (1 .. ``keep``).

        Returns
        -------
        numpy.ndarray
            M taps; tap i estimates h(i), the output i samples after a one-bit
            pulse, in output units per probe unit.  NaN for taps whose z was
            not yet defined (the first period).
        """
        if not self._completed:
            raise RuntimeError("no complete period yet: push at least M samples")
        available = min(self._completed, self._keep)
        if not 1 <= average <= available:
            raise ValueError(f"average must be from 1 to {available}, got {average}")
        last = self._completed - 1
        slots = np.arange(last - average + 1, last + 1) % self._keep
        return self._recent_h[slots].mean(axis=0)
