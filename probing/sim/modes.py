"""Short period and phugoid as numbers, from the longitudinal eigenvalues.

No JSBSim: what the figures and tables read (:mod:`probing.analysis.gtm_modes`) is light;
:func:`probing.sim.linear.longitudinal_modes` linearises a trimmed plant to get them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["LongitudinalModes"]


@dataclass(frozen=True)
class LongitudinalModes:
    """Short period and phugoid: natural frequencies (rad/s) and damping ratios.

    Attributes
    ----------
    sp_wn, sp_zeta, ph_wn, ph_zeta : float
        Short-period and phugoid natural frequency (rad/s) and damping ratio.
    eigenvalues : tuple of complex
        The four eigenvalues (1/s), largest magnitude first.
    """

    sp_wn: float
    sp_zeta: float
    ph_wn: float
    ph_zeta: float
    eigenvalues: tuple[complex, ...] = ()

    @staticmethod
    def _settling(wn: float, zeta: float) -> float:
        return 4.0 / (zeta * wn) if zeta * wn > 0 else math.inf

    @property
    def short_period_settling_s(self) -> float:
        """4 / (zeta wn) of the short period, s (inf if not stable)."""
        return self._settling(self.sp_wn, self.sp_zeta)

    @property
    def phugoid_settling_s(self) -> float:
        """4 / (zeta wn) of the phugoid, s (inf if not stable)."""
        return self._settling(self.ph_wn, self.ph_zeta)

    @property
    def phugoid_period_s(self) -> float:
        """Damped period of the phugoid, s."""
        return 2 * math.pi / (self.ph_wn * math.sqrt(max(1 - self.ph_zeta**2, 0.0)))

    @classmethod
    def from_eigenvalues(cls, eigs: np.ndarray) -> LongitudinalModes:
        """The modes from the four longitudinal eigenvalues (1/s).

        The two eigenvalues of largest magnitude are the short period, the other two the
        phugoid.  For a pair of real roots the equivalent second-order values are used
        (wn = sqrt(l1 l2), zeta = -(l1 + l2) / (2 wn)).

        Examples
        --------
        >>> m = LongitudinalModes.from_eigenvalues(
        ...     np.array([-2 + 3j, -2 - 3j, -0.01 + 0.2j, -0.01 - 0.2j]))
        >>> round(m.sp_wn**2, 9), round(m.ph_zeta * m.ph_wn, 9)
        (13.0, 0.01)
        """
        order = np.argsort(np.abs(eigs))
        values: list[float] = []
        for pair in (eigs[order[2:]], eigs[order[:2]]):
            wn = math.sqrt(abs(float(np.real(pair[0] * pair[1]))))
            zeta = -float(np.real(pair[0] + pair[1])) / (2 * wn) if wn > 0 else math.nan
            values += [wn, zeta]
        ranked = tuple(complex(e) for e in sorted(eigs, key=abs, reverse=True))
        return cls(*values, eigenvalues=ranked)
