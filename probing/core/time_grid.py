"""A log's or a record's time column against its grid: the first row that is not on it.

A flight logs one row per step at the end of the step, ``k dt`` after the trim; a record is
sampled at a uniform step from its first row.  Either way every row's time is on a grid
``start + k step``, and a row reordered, repeated, dropped or moved leaves it: the rows
after it no longer hold what the estimator takes them to hold (a period's samples, a bit's
end).  :func:`off_grid` names the first such row, and how it is off, in one phrase the
callers put in their error: a replayed log (:mod:`probing.experiment.flight.flight_log`),
a log recorded elsewhere (:mod:`probing.experiment.recorded.foreign_log`) and a record
(:func:`probing.experiment.recorded.record.sample_step_s`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["GRID_TOLERANCE", "WrongRow", "off_grid"]

#: Relative tolerance (of the step) within which a row's time, and its step from the row
#: before, are the grid's.
GRID_TOLERANCE = 1e-6


@dataclass(frozen=True)
class WrongRow:
    """The first row of a column that breaks a rule, and how (one phrase naming the row)."""

    row: int
    reason: str


def off_grid(
    time_s: np.ndarray,
    step_s: float,
    start_s: float,
    *,
    first_row: int = 0,
    before_s: float | None = None,
    rtol: float = GRID_TOLERANCE,
) -> WrongRow | None:
    """The first row of ``time_s`` not on the grid ``start_s + k step_s``, or None.

    Row ``i`` of ``time_s`` is row ``k = first_row + i`` of the whole column (a chunk of
    it: ``before_s`` is then the time of the row before the chunk).  A row is wrong if its
    time does not increase over the row before's, if it steps from it by other than
    ``step_s``, or if it is not ``start_s + k step_s``, each to ``rtol * step_s``; a NaN is
    never on the grid.  The first wrong row is named, with the first of these that it
    breaks.

    Parameters
    ----------
    time_s : numpy.ndarray
        The times, s, shape (n,).
    step_s : float
        The grid's step, s (> 0).
    start_s : float
        The grid's time at row 0, s.
    first_row : int
        The row of ``time_s[0]`` in the whole column.
    before_s : float, optional
        The time of the row before ``time_s[0]`` (None: there is none, or it is unknown).
    rtol : float
        Tolerance, relative to ``step_s``.

    Returns
    -------
    WrongRow or None
        The first wrong row (of the whole column) and a phrase saying how it is wrong.

    Examples
    --------
    >>> off_grid(np.array([0.01, 0.02, 0.03]), 0.01, 0.01) is None
    True
    >>> off_grid(np.array([0.01, 0.02, 0.02, 0.03]), 0.01, 0.01).reason
    'time does not increase at row 2 (0.02 s after 0.02 s)'
    """
    t = np.asarray(time_s, dtype=float).reshape(-1)
    tol = rtol * abs(step_s)
    previous = np.empty_like(t)
    previous[:1] = np.nan if before_s is None else before_s
    previous[1:] = t[:-1]
    steps = t - previous
    grid = start_s + (first_row + np.arange(t.size)) * step_s
    has_previous = ~np.isnan(previous)
    back = has_previous & (steps <= 0)
    uneven = has_previous & ~(np.abs(steps - step_s) <= tol)
    off = ~(np.abs(t - grid) <= tol)
    wrong = back | uneven | off
    if not wrong.any():
        return None
    i = int(np.argmax(wrong))
    row = first_row + i
    if back[i]:
        reason = f"time does not increase at row {row} ({t[i]:.10g} s after {previous[i]:.10g} s)"
    elif uneven[i]:
        reason = (
            f"time is not uniform at row {row} (it steps by {steps[i]:.10g} s, not {step_s:.10g} s)"
        )
    else:
        reason = f"time at row {row} is {t[i]:.10g} s, not {grid[i]:.10g} s"
    return WrongRow(row, reason)
