"""A one-line progress bar with ETA, drawn only on a terminal."""

from __future__ import annotations

import math
import sys
import time
from typing import TextIO

__all__ = ["ProgressBar"]


class ProgressBar:
    """``label [#####     ] done/total unit, extra, ETA s`` on one line.

    Parameters
    ----------
    total : int
        Number of items.
    label : str
        Text before the bar.
    unit : str
        What is counted (e.g. ``periods``, ``runs``).
    stream : file, optional
        Where to draw (default stderr).
    enabled : bool, optional
        Force on or off; default: on when ``stream`` is a terminal.
    """

    def __init__(
        self,
        total: int,
        label: str,
        unit: str,
        stream: TextIO | None = None,
        enabled: bool | None = None,
    ) -> None:
        self.total, self.label, self.unit = total, label, unit
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.start = time.perf_counter()

    def update(self, done: int, extra: str = "") -> None:
        """Redraw with ``done`` items finished; ``extra`` is shown after the count."""
        if not self.enabled or self.total == 0:
            return
        frac = done / self.total
        elapsed = time.perf_counter() - self.start
        eta = elapsed / frac - elapsed if frac > 0 else math.nan
        bar = "#" * int(30 * frac)
        extra = f", {extra}" if extra else ""
        self.stream.write(
            f"\r{self.label} [{bar:<30}] {done}/{self.total} {self.unit}{extra}, ETA {eta:5.1f} s"
        )
        if done == self.total:
            self.stream.write("\n")
        self.stream.flush()
