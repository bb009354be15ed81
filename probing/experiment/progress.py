"""Progress on stderr: a tqdm bar with ETA on a terminal, plain lines in a log.

A run draws its bar only on a terminal (a log of a run has nothing to gain from it).  A
sweep also reports on other streams, one line per finished point, so a long sweep in a CI
log or under ``nohup`` shows where it is.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

from tqdm import tqdm

__all__ = ["Progress", "progress_bar"]

BAR_FORMAT = (
    "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} {unit}, ETA {remaining}{postfix}"
)


class Progress:
    """Counts finished items of ``total``; draws a bar on a terminal, else writes lines.

    Parameters
    ----------
    total : int
        Number of items.
    label : str
        What is being done (the bar's description, the lines' prefix).
    unit : str
        What is counted (``periods``, ``runs``).
    stream : file, optional
        Where to report (default stderr).
    enabled : bool, optional
        Force the bar on or off; default: on when ``stream`` is a terminal.
    lines : bool
        When the bar is off, write one line per :meth:`advance` with a message.
    intro : str
        With ``lines``, the first line (default: ``0/<total> <unit>``).
    """

    def __init__(
        self,
        total: int,
        label: str,
        unit: str,
        stream: TextIO | None = None,
        enabled: bool | None = None,
        *,
        lines: bool = False,
        intro: str = "",
    ) -> None:
        self.stream = stream or sys.stderr
        self.total, self.label, self.unit = total, label, unit
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.lines = lines and not self.enabled
        self.done = 0
        self.start = time.perf_counter()
        self.bar = (
            None
            if not self.enabled
            else tqdm(  # tqdm costs ~7 ms even disabled
                total=total,
                desc=label,
                unit=unit,
                file=self.stream,
                bar_format=BAR_FORMAT,
                leave=True,
                dynamic_ncols=True,
            )
        )
        if self.lines:
            print(f"{label}: {intro or f'0/{total} {unit}'}", file=self.stream, flush=True)

    def eta_s(self) -> float | None:
        """Seconds left at the mean rate so far, or None before the first item."""
        if not self.done:
            return None
        elapsed = time.perf_counter() - self.start
        return elapsed / self.done * (self.total - self.done)

    def advance(self, n: int = 1, message: str = "", status: str = "") -> None:
        """``n`` more items finished; ``status`` is shown after the count (``"1 failed"``),
        ``message`` (what finished) goes into the line written when there is no bar."""
        self.done += n
        if self.bar is not None:
            if status:
                self.bar.set_postfix_str(status, refresh=False)
            self.bar.update(n)
        if self.lines:
            eta = self.eta_s()
            parts = [f"{self.done}/{self.total} {self.unit}"]
            if status:
                parts.append(status)
            if eta is not None and self.done < self.total:
                parts.append(f"ETA {eta:.0f} s")
            text = f"{self.label}: {', '.join(parts)}" + (f": {message}" if message else "")
            print(text, file=self.stream, flush=True)

    def close(self) -> None:
        """End the bar (a newline on the terminal)."""
        if self.bar is not None:
            self.bar.close()


@contextmanager
def progress_bar(
    total: int,
    label: str,
    unit: str,
    stream: TextIO | None = None,
    enabled: bool | None = None,
    *,
    lines: bool = False,
    intro: str = "",
) -> Iterator[Progress]:
    """A :class:`Progress` that is closed on leaving the block."""
    bar = Progress(total, label, unit, stream, enabled, lines=lines, intro=intro)
    try:
        yield bar
    finally:
        bar.close()
