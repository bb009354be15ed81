"""Progress on stderr: a tqdm bar with ETA on a terminal, plain lines in a log.

A run draws its bar only on a terminal (a log of a run has nothing to gain from it).  A
sweep also reports on other streams, one line per finished point, so a long sweep in a CI
log or under ``nohup`` shows where it is.  A long run off a terminal says once, before it
starts, how many steps it flies and about how long that takes (:func:`long_run_notice`).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

from tqdm import tqdm

__all__ = [
    "LONG_RUN_S",
    "STEPS_PER_S",
    "Progress",
    "eta_from_walls",
    "long_run_notice",
    "progress_bar",
]

#: Simulation steps a second that :func:`long_run_notice` estimates with.  Measured on one
#: core of a two-core x86-64 machine shared with other work (100-period flights through
#: ``probing.fly``): 28,000 steps/s for the 737 with a reference twin
#: (``scenarios/baseline-737.toml``), 21,000 for the GTM (``scenarios/fig4/a_deadband.toml``),
#: 12,000 for the GTM with NASA's sensors and the gust reference
#: (``scenarios/references/base.toml``); rounded down, so the estimate errs long.
STEPS_PER_S = 10_000

#: A run estimated to take longer than this (s) says so before it starts when it shows no
#: progress bar: 600,000 steps, more than an hour of flight at dt = 0.01 s.  The provided
#: scenarios and a one-hour monitored flight (360,000 steps) stay quiet.
LONG_RUN_S = 60.0

BAR_FORMAT = (
    "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} {unit}, ETA {remaining}{postfix}"
)
#: The bar of items timed one by one on several workers: the ETA is ours, in the postfix.
BAR_FORMAT_WORKERS = "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} {unit}{postfix}"


def eta_from_walls(
    total: int, done: int, wall_sum_s: float, timed: int, workers: int
) -> float | None:
    """Seconds left for items that run ``workers`` at a time, from the items finished so far.

    Parameters
    ----------
    total, done : int
        Items in all, and finished.
    wall_sum_s : float
        Sum of the wall times of the ``timed`` finished items whose time is known, s.
    timed : int
        Finished items with a wall time.
    workers : int
        Items running at once.

    Returns
    -------
    float or None
        The mean wall time of an item times the items left, over the workers; None before
        an item was timed.
    """
    if done >= total:
        return 0.0
    if timed < 1:
        return None
    return wall_sum_s / timed * (total - done) / max(1, workers)


def _duration(seconds: float) -> str:
    """``seconds`` as a person reads it: ``"3 min"``, ``"1 h 25 min"``, ``"2 d 3 h"``."""
    minutes = max(1, round(seconds / 60))
    if minutes < 60:
        return f"{minutes} min"
    hours, minutes = divmod(minutes, 60)
    if hours < 24:
        return f"{hours} h {minutes} min" if minutes else f"{hours} h"
    days, hours = divmod(hours, 24)
    return f"{days} d {hours} h" if hours else f"{days} d"


def long_run_notice(label: str, steps: int, steps_per_s: float | None = None) -> str | None:
    """What a run of ``steps`` simulation steps says before it starts when it shows no
    progress bar (off a terminal), or None when it is not long.

    Parameters
    ----------
    label : str
        The run (its scenario's name).
    steps : int
        Simulation steps it flies.
    steps_per_s : float, optional
        The rate estimated with, steps/s (default :data:`STEPS_PER_S`).

    Returns
    -------
    str or None
        ``"<label>: 51,100,000 steps, about 1 h 25 min (an estimate at 10,000 steps a
        second); no progress bar off a terminal"`` when ``steps / steps_per_s`` is more than
        :data:`LONG_RUN_S`; None otherwise.
    """
    steps_per_s = STEPS_PER_S if steps_per_s is None else steps_per_s
    estimate_s = steps / steps_per_s
    if not estimate_s > LONG_RUN_S:
        return None
    return (
        f"{label}: {steps:,} steps, about {_duration(estimate_s)} (an estimate at "
        f"{steps_per_s:,.0f} steps a second); no progress bar off a terminal"
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
    workers : int, optional
        Items run this many at a time, each timed (:meth:`advance`'s ``wall_s``): the ETA
        is :func:`eta_from_walls`.  Without it, the ETA is the time elapsed per item so
        far, which is right only for items finishing one after another (a run's periods);
        a sweep's runs come back a chunk at a time, and the time to the first chunk over
        one run overstated what was left by the chunk's length (64 runs).
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
        workers: int | None = None,
    ) -> None:
        self.stream = stream or sys.stderr
        self.workers = workers
        self.wall_sum_s, self.timed = 0.0, 0
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
                bar_format=BAR_FORMAT if workers is None else BAR_FORMAT_WORKERS,
                leave=True,
                dynamic_ncols=True,
            )
        )
        if self.lines:
            print(f"{label}: {intro or f'0/{total} {unit}'}", file=self.stream, flush=True)

    def eta_s(self) -> float | None:
        """Seconds left, or None before the first item (with ``workers``: the first timed
        one)."""
        if self.workers is not None:
            return eta_from_walls(self.total, self.done, self.wall_sum_s, self.timed, self.workers)
        if not self.done:
            return None
        elapsed = time.perf_counter() - self.start
        return elapsed / self.done * (self.total - self.done)

    def advance(
        self, n: int = 1, message: str = "", status: str = "", wall_s: float | None = None
    ) -> None:
        """``n`` more items finished; ``status`` is shown after the count (``"1 failed"``),
        ``message`` (what finished) goes into the line written when there is no bar;
        ``wall_s``: the wall time of each of them (s; NaN or None: not known)."""
        self.done += n
        if wall_s is not None and math.isfinite(wall_s):
            self.wall_sum_s += n * wall_s
            self.timed += n
        if self.bar is not None:
            if self.workers is not None:
                eta = self.eta_s()
                shown = [f"ETA {self.bar.format_interval(eta)}" if eta is not None else ""]
                status = ", ".join(x for x in (*shown, status) if x)
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
    workers: int | None = None,
) -> Iterator[Progress]:
    """A :class:`Progress` that is closed on leaving the block."""
    bar = Progress(total, label, unit, stream, enabled, lines=lines, intro=intro, workers=workers)
    try:
        yield bar
    finally:
        bar.close()
