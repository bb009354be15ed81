"""Which periods a detector's baseline is: the first B, or the B that slide behind it.

Both detectors (:class:`probing.core.monitor.ChangeDetector`,
:class:`probing.core.trajectory.TrajectoryDetector`) test each new period against a
baseline learned from the flight itself.  A *fixed* baseline is the first B periods after
settling.  What a realisable reference leaves of the turbulence is not stationary over an
hour (its level drifts as the aircraft wanders from its trim), and a fixed baseline then
raises false alarms at a rate that grows with the flight.  A *sliding* baseline follows
that drift: a period enters it ``gap`` periods after it last took part in a test, so the
baseline is always the B periods that end ``gap`` periods before the tested window; an
abrupt change has ``window + gap`` periods to be detected before it starts entering the
baseline.  At the first alarm it freezes (the change must not be learned as the new normal;
the isolation compares against what was before).

Under no change, with independent periods, the baseline and the tested window share no
period, so each test keeps the fixed baseline's exact null distribution.  numpy only.
"""

from __future__ import annotations

import collections
from typing import Generic, TypeVar

__all__ = ["BaselineWindow"]

T = TypeVar("T")


class BaselineWindow(Generic[T]):
    """The periods a detector's baseline holds.

    Parameters
    ----------
    periods : int
        B, the periods the baseline holds (learned once the first B are in).
    window : int
        W, the periods each test averages (the latest W; none of them is in the baseline).
    gap : int or None
        G, the periods between the baseline's last and the tested window's first (from the
        baseline's learning on); None: the baseline stays the first B periods.

    Examples
    --------
    >>> b = BaselineWindow(2, window=1, gap=1)
    >>> [b.add(p) for p in range(5)]
    [False, True, False, False, True]
    >>> b.items
    [1, 2]
    """

    def __init__(self, periods: int, window: int, gap: int | None) -> None:
        if periods < 1 or window < 1 or (gap is not None and gap < 0):
            raise ValueError(f"need periods, window >= 1 and gap >= 0: {periods}, {window}, {gap}")
        self.periods, self.window, self.gap = periods, window, gap
        self._items: collections.deque[T] = collections.deque(maxlen=periods)
        self._trail: collections.deque[T] = collections.deque()  # tested, not yet baseline
        self.frozen = False

    @property
    def ready(self) -> bool:
        """True once the baseline holds its B periods."""
        return len(self._items) == self.periods

    @property
    def items(self) -> list[T]:
        """The baseline's periods, oldest first."""
        return list(self._items)

    def add(self, item: T) -> bool:
        """Add the latest period; True if the baseline's periods changed (learn them anew).

        Until the baseline is ready every period goes into it.  Then, if it slides and is
        not frozen, the period that has now been ``window + gap`` periods out of it enters
        and its oldest leaves.
        """
        if not self.ready:
            self._items.append(item)
            return self.ready
        if self.gap is None or self.frozen:
            return False
        self._trail.append(item)
        if len(self._trail) <= self.window + self.gap:
            return False
        self._items.append(self._trail.popleft())
        return True

    def freeze(self) -> None:
        """Keep the baseline as it is from now on (at a detector's first alarm)."""
        self.frozen = True
