"""The mean pulse-response estimate over a run's settled periods, kept while the run goes
(:class:`SettledMean`), by the rule :func:`probing.experiment.storage.read_settled` reads
them back with."""

from __future__ import annotations

import numpy as np

from probing.experiment.storage import Settled

__all__ = ["SettledMean"]


class SettledMean:
    """Mean of the per-period h over the settled periods, channel by channel.

    A period counts for a channel when it is >= ``settle_periods`` and that channel's h is
    finite at every tap; each channel keeps its own count.

    Parameters
    ----------
    channels : sequence of str
        Channel names, C of them.
    m : int
        Taps per period.
    settle_periods : int
        Periods left out at the start.
    """

    def __init__(
        self,
        channels: tuple[str, ...] | list[str],
        m: int,
        settle_periods: int,
        keep_first: bool = False,
    ):
        self.channels = list(channels)
        self.settle = settle_periods
        self.total = np.zeros((len(self.channels), m))
        self.count = np.zeros(len(self.channels), dtype=np.int64)
        self.kept: list[tuple[int, np.ndarray, np.ndarray]] | None = [] if keep_first else None

    def add(self, periods: np.ndarray, h: np.ndarray, z: np.ndarray | None = None) -> None:
        """Add periods ``periods`` (P,) with estimates ``h`` and probing outputs ``z``
        (P, C, M; ``z`` needed only with ``keep_first``)."""
        settled = np.asarray(periods) >= self.settle
        for p in np.flatnonzero(settled):
            for j in range(len(self.channels)):
                if np.all(np.isfinite(h[p, j])):
                    self.total[j] += h[p, j]
                    self.count[j] += 1
                    if j == 0 and self.kept is not None:
                        self.kept.append((int(periods[p]), z[p, 0].copy(), h[p, 0].copy()))

    def first_channel(self, lag_s: np.ndarray) -> Settled | None:
        """With ``keep_first``: the first channel's settled periods (None otherwise)."""
        if self.kept is None:
            return None
        m = lag_s.size
        return Settled(
            np.array([k[0] for k in self.kept], dtype=np.int64),
            lag_s,
            np.array([k[1] for k in self.kept]).reshape(-1, m),
            np.array([k[2] for k in self.kept]).reshape(-1, m),
        )

    def mean(self) -> dict[str, np.ndarray]:
        """Channel -> mean h (NaN where no period counted)."""
        return {
            c: self.total[j] / self.count[j]
            if self.count[j]
            else np.full_like(self.total[j], np.nan)
            for j, c in enumerate(self.channels)
        }
