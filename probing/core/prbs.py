"""Maximum-length PRBS probes for pulse-compression probing.

The probe of Ruschmann & Wu is one period sigma(k) of a maximum-length
sequence (m-sequence) of order n, values +-1, length M = 2**n - 1, bit
duration t0, repeated cyclically and scaled by the amplitude a.  The
reference used by the correlator is the same sequence at unit magnitude.

A :class:`Probe` may instead play a multisine or a chirp on the same M bits
(:mod:`probing.core.excitation`): its reference is then that signal at unit
RMS, and the amplitude its RMS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from probing.core.excitation import PRBS, Excitation

__all__ = ["MAX_ORDER", "MIN_ORDER", "Probe", "mls"]

MIN_ORDER = 2
MAX_ORDER = 20

#: Linear recurrence of the m-sequence of each order over GF(2):
#: ``b[k+n] = XOR of b[k+j] for j in RECURRENCE[n]``, i.e. the primitive feedback polynomial
#: x^n + sum_j x^j.  With an all-ones start these give exactly the sequences of
#: :func:`scipy.signal.max_len_seq` with its default taps (checked in the tests), without
#: importing scipy.signal (most of a second at every start-up).
RECURRENCE: dict[int, tuple[int, ...]] = {
    2: (0, 1),
    3: (0, 2),
    4: (0, 3),
    5: (0, 3),
    6: (0, 5),
    7: (0, 6),
    8: (0, 1, 6, 7),
    9: (0, 5),
    10: (0, 7),
    11: (0, 9),
    12: (0, 4, 10, 11),
    13: (0, 8, 11, 12),
    14: (0, 2, 12, 13),
    15: (0, 14),
    16: (0, 4, 13, 15),
    17: (0, 14),
    18: (0, 11),
    19: (0, 14, 17, 18),
    20: (0, 17),
}


@lru_cache(maxsize=32)
def _mls_cached(order: int) -> np.ndarray:
    m = 2**order - 1
    taps = RECURRENCE[order]
    gap = order - max(taps[1:])  # new bits computable at once from the recurrence
    bits = np.zeros(m, dtype=np.uint8)
    bits[:order] = 1
    filled, scale = order, 1
    while filled < m:
        # p(x)^(2^s) = p(x^(2^s)) over GF(2): the same sequence obeys the recurrence with
        # every lag times 2^s, which yields gap * 2^s new bits per vectorised step.
        while filled >= 2 * scale * order:
            scale *= 2
        start = filled - scale * order
        n_new = min(gap * scale, m - filled)
        block = bits[start : start + n_new].copy()
        for j in taps[1:]:
            block ^= bits[start + j * scale : start + j * scale + n_new]
        bits[filled : filled + n_new] = block
        filled += n_new
    seq = 1.0 - 2.0 * bits.astype(np.float64)  # bit 0 -> +1, bit 1 -> -1
    seq.setflags(write=False)
    return seq


def mls(order: int) -> np.ndarray:
    """One period of a maximum-length sequence with values +-1.

    Parameters
    ----------
    order : int
        Order n of the sequence, 2 <= n <= 20.

    Returns
    -------
    numpy.ndarray
        Float array of length M = 2**n - 1 with values +1 and -1.  Its periodic
        autocorrelation is M at lag 0 and -1 at every other lag.

    Notes
    -----
    The sequence is that of :func:`scipy.signal.max_len_seq` with its default
    taps and all-ones initial state (generated here from :data:`RECURRENCE`),
    mapped bit 0 -> +1 and bit 1 -> -1.  It holds
    2**(n-1) values of -1 and 2**(n-1) - 1 values of +1, so its sum is -1.

    Examples
    --------
    >>> mls(3)
    array([-1., -1., -1.,  1., -1.,  1.,  1.])
    """
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)):
        raise ValueError(f"order must be an integer from {MIN_ORDER} to {MAX_ORDER}, got {order!r}")
    if not MIN_ORDER <= order <= MAX_ORDER:
        raise ValueError(f"order must be from {MIN_ORDER} to {MAX_ORDER}, got {order}")
    return _mls_cached(int(order)).copy()


def steps_per_bit(bit_duration_s: float, dt_s: float) -> int:
    """Simulation steps per bit, t0 / dt; raises ValueError unless a whole number >= 1 (to
    1e-9: decimal step sizes are not exact in binary).

    Examples
    --------
    >>> steps_per_bit(0.03, 0.01)
    3
    """
    ratio = bit_duration_s / dt_s
    steps = round(ratio)
    if steps < 1 or not math.isclose(ratio, steps, rel_tol=1e-9, abs_tol=1e-9):
        raise ValueError(
            f"bit_duration_s ({bit_duration_s}) must be an integer multiple "
            f"of the simulation step dt_s ({dt_s})"
        )
    return int(steps)


@dataclass(frozen=True)
class Probe:
    """A cyclic probe: the +-a PRBS, or a multisine or chirp of RMS a on the same bits.

    Parameters
    ----------
    order : int
        PRBS order n (2..20); the period holds M = 2**n - 1 bits.
    bit_duration_s : float
        Bit duration t0 in seconds (> 0).
    amplitude_deg : float
        Probe amplitude a in degrees of surface deflection (> 0): the PRBS's +-a, a
        multisine's or chirp's RMS (the PRBS's RMS is a too).
    excitation : Excitation
        The signal (:class:`probing.core.excitation.Excitation`); the PRBS by default.
    """

    order: int
    bit_duration_s: float
    amplitude_deg: float
    excitation: Excitation = PRBS

    def __post_init__(self) -> None:
        mls(self.order)  # validates the order
        if not (math.isfinite(self.bit_duration_s) and self.bit_duration_s > 0):
            raise ValueError(f"bit_duration_s must be > 0, got {self.bit_duration_s}")
        if not (math.isfinite(self.amplitude_deg) and self.amplitude_deg > 0):
            raise ValueError(f"amplitude_deg must be > 0, got {self.amplitude_deg}")
        if not self.excitation.is_binary:
            self._unit  # noqa: B018 -- validates the band against the period and the bits

    @cached_property
    def _unit(self) -> np.ndarray:
        """One period of the unit signal (read-only), computed once."""
        if self.excitation.is_binary:
            unit = mls(self.order)
        else:
            unit = self.excitation.unit(self.order, self.bit_duration_s)
        unit.setflags(write=False)
        return unit

    @cached_property
    def harmonics(self) -> np.ndarray | None:
        """The harmonics of 1/T the signal excites (read-only), computed once; None for the
        PRBS (all, DC included)."""
        found = self.excitation.harmonics(self.order, self.bit_duration_s)
        if found is not None:
            found.setflags(write=False)
        return found

    @property
    def peak_deg(self) -> float:
        """Largest deflection of the probe, deg: a for the PRBS, a times the crest factor
        otherwise."""
        return self.amplitude_deg * float(np.max(np.abs(self._unit)))

    @property
    def peak_step_rate_deg_s(self) -> float:
        """Largest change between two consecutive bits (the period taken cyclically) over the
        bit duration, deg/s: 2a/t0 for the PRBS, the rate a limiter must pass to keep up
        within one bit (eq. 21's bound)."""
        jumps = np.abs(np.diff(np.append(self._unit, self._unit[0])))
        return self.amplitude_deg * float(np.max(jumps)) / self.bit_duration_s

    @property
    def length(self) -> int:
        """Number of bits M = 2**n - 1 in one period."""
        return 2**self.order - 1

    @property
    def memory_s(self) -> float:
        """Memory length T = M t0 in seconds (the duration of one period)."""
        return self.length * self.bit_duration_s

    def reference(self) -> np.ndarray:
        """One period of the unit reference, one value per bit: the sequence sigma(k) (+-1),
        or the multisine or chirp at unit RMS."""
        return np.array(self._unit)

    def bits(self, periods: int = 1) -> np.ndarray:
        """The probe at the bit rate, a * sigma(k), repeated for ``periods`` periods, in deg."""
        if periods < 0:
            raise ValueError(f"periods must be >= 0, got {periods}")
        return np.tile(self.amplitude_deg * self._unit, periods)

    def steps_per_bit(self, dt_s: float) -> int:
        """Simulation steps per bit, t0 / dt; raises ValueError unless an integer."""
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s must be > 0, got {dt_s}")
        return steps_per_bit(self.bit_duration_s, dt_s)

    def samples(self, dt_s: float, periods: int = 1) -> np.ndarray:
        """The probe at the simulation rate, in deg.

        Parameters
        ----------
        dt_s : float
            Simulation step in seconds; t0 must be an integer multiple of it.
        periods : int
            Number of cyclic repetitions of the sequence.

        Returns
        -------
        numpy.ndarray
            ``periods * M * (t0/dt)`` samples; each bit held for t0/dt steps.
        """
        return np.repeat(self.bits(periods), self.steps_per_bit(dt_s))
