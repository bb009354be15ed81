"""Several surfaces probed in one flight, with designs that keep their responses apart.

Correlating one surface's output with another input's m-sequence leaves cross-talk of order
sqrt(M)/M per tap of *that* input's response, summed over its memory: with independent
m-sequences two long roll responses of the same size swamp each other.  Two designs separate
the inputs instead, both with the one m-sequence sigma of the probe:

* ``shift``: every surface is probed all the time, surface i with sigma delayed by
  ``s_i = i W`` bits, ``W = M // k`` for k surfaces.  The cyclic correlation of the output with
  sigma is then the sum of the surfaces' folded pulse responses, each moved to start at its
  own delay, so surface i's response is read from taps ``s_i .. s_i + W - 1``.  Exact for a
  linear aircraft whose responses all die out within W bits; what is left of a response
  after W bits lands in the next surface's window (the memory condition).
* ``multiplex``: the surfaces take turns block by block, each alone for ``settle + periods``
  periods; surface i is estimated from its block's last ``periods`` periods, over all M taps.
  The previous surface's response must have died out within the settle periods.

Everything here works on bit samples (one output per bit, at its end) and is exact
arithmetic on arrays; the flight and the linearisation are :mod:`probing.experiment`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from probing.core.noise import cyclic_estimates

__all__ = ["DESIGNS", "Layout", "memory_bits"]

#: Simultaneous designs -> what they do (the scenario's ``simultaneous.design``).
DESIGNS = {
    "shift": "one m-sequence, surface i delayed by i M/k bits; its response in its own taps",
    "multiplex": "the surfaces take turns block by block, each alone, settle periods between",
}


@dataclass(frozen=True)
class Layout:
    """Who is probed when, and where each surface's response is read.

    Parameters
    ----------
    design : str
        A key of :data:`DESIGNS`.
    surfaces : int
        Number of surfaces k (>= 2).
    length : int
        Bits per period M (odd, 2**n - 1).
    periods : int
        Periods each surface is estimated from.
    settle_periods : int
        Periods left out before them (per block with ``multiplex``).
    """

    design: str
    surfaces: int
    length: int
    periods: int
    settle_periods: int

    def __post_init__(self) -> None:
        if self.design not in DESIGNS:
            raise ValueError(f"design must be one of {', '.join(DESIGNS)}, got {self.design!r}")
        if self.surfaces < 2:
            raise ValueError(f"simultaneous probing needs >= 2 surfaces, got {self.surfaces}")
        if self.design == "shift" and self.length // self.surfaces < 1:
            raise ValueError(f"{self.surfaces} shift windows do not fit in {self.length} bits")

    @property
    def block_periods(self) -> int:
        """Periods of one surface's block (``multiplex``), or of the whole flight (``shift``)."""
        return self.settle_periods + self.periods

    @property
    def total_periods(self) -> int:
        """Periods flown."""
        blocks = self.surfaces if self.design == "multiplex" else 1
        return blocks * self.block_periods

    @property
    def window_bits(self) -> int:
        """Taps of each surface's response: M // k (``shift``) or M (``multiplex``)."""
        return self.length // self.surfaces if self.design == "shift" else self.length

    @property
    def separation_bits(self) -> int:
        """Bits a response must have died out within for the surfaces to stay apart: the
        window (``shift``) or the settle periods before each block (``multiplex``)."""
        if self.design == "shift":
            return self.window_bits
        return self.settle_periods * self.length

    def delay_bits(self, i: int) -> int:
        """The delay of surface i's copy of sigma, bits."""
        return i * self.window_bits if self.design == "shift" else 0

    def inputs(self, reference: np.ndarray) -> np.ndarray:
        """The +-1 / 0 probe of every surface at the bit rate, shape (k, total bits): sigma
        delayed (``shift``) or sigma in the surface's block and 0 elsewhere (``multiplex``)."""
        ref = np.asarray(reference, dtype=float)
        if ref.size != self.length:
            raise ValueError(f"reference has {ref.size} bits, the layout {self.length}")
        total = self.total_periods * self.length
        out = np.zeros((self.surfaces, total))
        for i in range(self.surfaces):
            sequence = np.tile(np.roll(ref, self.delay_bits(i)), self.total_periods)
            if self.design == "multiplex":
                block = self.block_periods * self.length
                out[i, i * block : (i + 1) * block] = sequence[i * block : (i + 1) * block]
            else:
                out[i] = sequence
        return out

    def estimated_periods(self, i: int) -> range:
        """The periods surface i's response is averaged over."""
        first = i * self.block_periods if self.design == "multiplex" else 0
        return range(first + self.settle_periods, first + self.block_periods)

    def responses(
        self, y_bits: np.ndarray, reference: np.ndarray, amplitudes: np.ndarray
    ) -> np.ndarray:
        """Every surface's pulse response from the output's bit samples.

        Parameters
        ----------
        y_bits : numpy.ndarray
            Output deviation at the end of every bit of the flight, shape (total bits, C).
        reference : numpy.ndarray
            The +-1 m-sequence sigma, length M.
        amplitudes : numpy.ndarray
            Each surface's probe amplitude (its unit), shape (k,).

        Returns
        -------
        numpy.ndarray
            Shape (k, C, window bits): the cyclic, DC-corrected estimate averaged over the
            surface's estimated periods, its window of taps, per unit of the surface.
        """
        y = np.asarray(y_bits, dtype=float)
        m = self.length
        if y.ndim != 2 or y.shape[0] != self.total_periods * m:
            raise ValueError(f"y_bits must be ({self.total_periods * m}, C), got {y.shape}")
        periods = y.reshape(self.total_periods, m, -1)
        out = np.empty((self.surfaces, y.shape[1], self.window_bits))
        for i, a in enumerate(np.asarray(amplitudes, dtype=float)):
            mean = periods[list(self.estimated_periods(i))].mean(axis=0)  # (M, C)
            _, _, h = cyclic_estimates(mean.T, reference, a)  # (C, M)
            first = self.delay_bits(i)
            out[i] = h[:, first : first + self.window_bits]
        return out


def memory_bits(response: np.ndarray, floor: float) -> int:
    """Bits until a pulse response stays below ``floor`` for good: the index after the last
    tap whose magnitude reaches it (0 if none does).

    Parameters
    ----------
    response : numpy.ndarray
        Pulse response, one value per bit (output units), long enough to have died out.
    floor : float
        Magnitude that counts as gone (output units, > 0).
    """
    above = np.flatnonzero(np.abs(np.asarray(response, dtype=float)) >= floor)
    return int(above[-1] + 1) if above.size else 0
