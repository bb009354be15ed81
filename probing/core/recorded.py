"""Pulse compression on a recorded probe and outputs: finding the m-sequence in the record,
its bit boundaries and phase, and the per-period estimates with their confidence bounds.

The record holds the probe as injected (two levels, each bit held for ``samples_per_bit``
samples) and the outputs at the same rate.  Each bit's output sample is the one read at
its last sample (end-of-bit sampling, as in a simulated run).  The periods used start where
the sequence is at phase 0 of :func:`probing.core.prbs.mls` (so tap order and period count
are those of a simulated run) and only whole periods are used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from probing.core.errors import ProbingError
from probing.core.noise import cyclic_estimates
from probing.core.prbs import mls

__all__ = ["Alignment", "NotAnMSequence", "align_probe", "period_estimates", "tap_bounds"]

#: Relative tolerance (of the level difference) within which a sample is at a level.
LEVEL_TOLERANCE = 1e-6


class NotAnMSequence(ProbingError, ValueError):
    """The probe column is not the m-sequence of the order and bit duration asked for."""


@dataclass(frozen=True)
class Alignment:
    """Where the m-sequence sits in the record.

    Attributes
    ----------
    amplitude : float
        Half the difference of the probe's two levels (probe unit).
    mid : float
        Mean of the two levels (probe unit).
    sign : int
        +1 if the high level is the +1 of :func:`probing.core.prbs.mls`, -1 if inverted.
    shift_bits : int
        Phase of the record's first whole bit in the sequence: it is bit ``shift_bits`` of
        ``mls(order)``.
    offset_samples : int
        Sample index of the first bit boundary (0 .. samples_per_bit - 1).
    first_sample : int
        Sample index where the first period used starts (sequence phase 0).
    periods : int
        Whole periods used.
    bits : int
        Whole bits in the record.
    """

    amplitude: float
    mid: float
    sign: int
    shift_bits: int
    offset_samples: int
    first_sample: int
    periods: int
    bits: int


def _levels(probe: np.ndarray) -> tuple[float, float, np.ndarray]:
    lo, hi = float(probe.min()), float(probe.max())
    tol = LEVEL_TOLERANCE * (hi - lo)
    high = np.abs(probe - hi) <= tol
    if hi <= lo or not np.all(high | (np.abs(probe - lo) <= tol)):
        raise NotAnMSequence("it does not hold exactly two levels")
    return (hi - lo) / 2.0, (hi + lo) / 2.0, np.where(high, 1.0, -1.0)


def _bit_offset(unit: np.ndarray, spb: int) -> int:
    changes = np.flatnonzero(np.diff(unit)) + 1
    if changes.size == 0:
        raise NotAnMSequence("it never changes level")
    offset = int(changes[0] % spb)
    if np.any((changes - offset) % spb):
        raise NotAnMSequence(f"it changes level between bit boundaries of {spb} samples")
    return offset


def align_probe(probe: np.ndarray, samples_per_bit: int, order: int) -> Alignment:
    """Check that ``probe`` is the m-sequence of ``order`` and find its phase and bits.

    Parameters
    ----------
    probe : numpy.ndarray
        The recorded probe, one value per sample (probe unit, e.g. deg).
    samples_per_bit : int
        Samples per bit, t0 / dt.
    order : int
        Order n of the m-sequence (M = 2**n - 1 bits per period).

    Returns
    -------
    Alignment

    Raises
    ------
    NotAnMSequence
        If the probe has not two levels, changes level off the bit grid, has a bit whose
        samples differ, does not equal +-``mls(order)`` cyclically shifted on every whole bit,
        or holds less than one whole period from phase 0.
    """
    spb, m = int(samples_per_bit), 2**order - 1
    amplitude, mid, unit = _levels(np.asarray(probe, dtype=float))
    offset = _bit_offset(unit, spb)
    n_bits = (unit.size - offset) // spb
    bits = unit[offset : offset + n_bits * spb].reshape(n_bits, spb)[:, 0]
    if n_bits < m:
        raise NotAnMSequence(f"it holds {n_bits} whole bits, fewer than one period ({m})")
    ref = mls(order)
    corr = np.rint(np.fft.irfft(np.fft.rfft(ref) * np.conj(np.fft.rfft(bits[:m])), m))
    shift = int(np.argmax(np.abs(corr)))  # bits[k] = sign * ref[(k + shift) mod M]
    sign = 1 if corr[shift] > 0 else -1
    expected = sign * ref[(np.arange(n_bits) + shift) % m]
    if abs(corr[shift]) != m or not np.array_equal(bits, expected):
        raise NotAnMSequence(f"it is not a cyclic shift of the m-sequence of order {order}")
    first_bit = (m - shift) % m
    periods = (n_bits - first_bit) // m
    if periods < 1:
        raise NotAnMSequence(f"it holds no whole period from the sequence's start ({m} bits)")
    return Alignment(amplitude, mid, sign, shift, offset, offset + first_bit * spb, periods, n_bits)


def period_estimates(
    y_bits: np.ndarray, order: int, sign: int, amplitude: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-period ``z``, ``zeta``, ``h_est`` of whole periods (the ``cyclic`` estimator).

    Parameters
    ----------
    y_bits : numpy.ndarray
        Shape (P M, C): each output's end-of-bit samples from sequence phase 0 (output unit).
    order : int
        Order n of the m-sequence.
    sign : int
        +1, or -1 for a probe whose levels are the inverted sequence.
    amplitude : float
        Probe amplitude a (probe unit).

    Returns
    -------
    z, zeta, h : numpy.ndarray
        Shape (P, C, M): output unit (``z``, ``zeta``), output unit per probe unit (``h``).
    """
    m = 2**order - 1
    periods = y_bits.shape[0] // m
    y = y_bits[: periods * m].reshape(periods, m, -1).transpose(0, 2, 1)
    return cyclic_estimates(y, sign * mls(order), amplitude)


def tap_bounds(
    h: np.ndarray, level: float = 0.95
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Mean over periods and two-sided Student-t confidence bounds of each tap.

    Parameters
    ----------
    h : numpy.ndarray
        Shape (P, ...), P >= 2 per-period estimates.
    level : float
        Confidence level of the interval of the mean, e.g. 0.95.

    Returns
    -------
    mean, low, high, std : numpy.ndarray
        Shape (...): the mean, the bounds mean -+ t_{(1+level)/2, P-1} std / sqrt(P), and the
        period-to-period standard deviation ``std`` (ddof 1); the unit of ``h``.
    """
    periods = h.shape[0]
    if periods < 2:
        raise ValueError(f"bounds need at least 2 periods, got {periods}")
    mean, std = h.mean(axis=0), h.std(axis=0, ddof=1)
    half = stats.t.ppf(0.5 + level / 2.0, periods - 1) * std / np.sqrt(periods)
    return mean, mean - half, mean + half, std
