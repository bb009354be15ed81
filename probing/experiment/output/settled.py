"""The mean pulse-response estimate over a run's settled periods, kept while the run goes
(:class:`SettledMean`), by the rule :func:`probing.experiment.output.storage.read_settled` reads
them back with; with ``keep_all`` the settled periods themselves, for their per-tap bounds
(:meth:`SettledMean.bounds`)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from probing.core.recorded import tap_bounds
from probing.experiment.output.layouts import BOUNDS_LEVEL
from probing.experiment.output.storage import Settled

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
    keep_first : bool
        Keep the first channel's settled z and h (:meth:`first_channel`).
    keep_all : bool
        Keep every channel's settled h (:meth:`bounds`): C M floats a period.
    """

    def __init__(
        self,
        channels: tuple[str, ...] | list[str],
        m: int,
        settle_periods: int,
        keep_first: bool = False,
        keep_all: bool = False,
    ):
        self.channels = list(channels)
        self.m = m
        self.settle = settle_periods
        self.total = np.zeros((len(self.channels), m))
        self.count = np.zeros(len(self.channels), dtype=np.int64)
        self.kept: list[tuple[int, np.ndarray, np.ndarray]] | None = [] if keep_first else None
        self.all: list[list[np.ndarray]] | None = [[] for _ in self.channels] if keep_all else None

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
                    if self.all is not None:
                        self.all[j].append(h[p, j].copy())

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

    def bounds(
        self, transform: Callable[[str, np.ndarray], np.ndarray] | None = None
    ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], dict[str, int]] | None:
        """With ``keep_all``: each channel's per-tap bounds over its settled periods
        (``transform(channel, rows)``: the rows, shape (P, M), that the bounds are taken of,
        for each channel with at least 2; default the settled h itself).

        :func:`probing.core.recorded.tap_bounds` at
        :data:`~probing.experiment.output.layouts.BOUNDS_LEVEL` of each channel's settled h,
        shape (P, M) in period order (what :func:`probing.experiment.output.storage.read_settled`
        reads back); a channel with fewer than 2 settled periods has NaN bounds.

        Returns
        -------
        tuple or None
            ``((mean, low, high, std), dof)``: the four arrays of shape (C, M), in the unit
            of h (channel unit per unit of probe), and channel -> P - 1 (its degrees of
            freedom; -1 with no period); None without ``keep_all`` or when no channel has 2
            settled periods.
        """
        if self.all is None or self.count.max(initial=0) < 2:
            return None
        out = np.full((4, len(self.channels), self.m), np.nan)
        for j, rows in enumerate(self.all):
            if len(rows) >= 2:
                h = np.array(rows)
                h = h if transform is None else transform(self.channels[j], h)
                out[:, j] = tap_bounds(h, BOUNDS_LEVEL)
        dof = {c: int(self.count[j]) - 1 for j, c in enumerate(self.channels)}
        return (out[0], out[1], out[2], out[3]), dof
