"""A time column against its grid (probing.core.time_grid): the first row off it, and how."""

from __future__ import annotations

import numpy as np
import pytest

from probing.core.time_grid import GRID_TOLERANCE, off_grid

DT = 0.01


def grid(n: int, start: float = DT) -> np.ndarray:
    """A flight's time column: the end of each step, as the flight computer writes it."""
    return (np.arange(n) + round(start / DT)) * DT


def test_a_flights_grid_is_on_it() -> None:
    assert off_grid(grid(100_000), DT, DT) is None


@pytest.mark.parametrize(
    ("edit", "row", "reason"),
    [
        (
            lambda t: np.concatenate([t[:110], t[100:]]),
            110,
            "increase at row 110 (1.01 s after 1.1 s)",
        ),
        (
            lambda t: t[[0, 1, 3, 2, *range(4, t.size)]],
            2,
            "uniform at row 2 (it steps by 0.02 s, not",
        ),
        (
            lambda t: np.delete(t, 300),
            300,
            "not uniform at row 300 (it steps by 0.02 s, not 0.01 s)",
        ),
        (lambda t: t[255:], 0, "time at row 0 is 2.56 s, not 0.01 s"),
        (lambda t: t[::-1], 0, "time at row 0 is 10 s, not 0.01 s"),
        (lambda t: np.where(np.arange(t.size) == 7, np.nan, t), 7, "not uniform at row 7"),
    ],
)
def test_the_first_wrong_row_is_named_with_how(edit, row: int, reason: str) -> None:
    """Rows repeated, swapped, dropped, cut from the start, reversed, a NaN."""
    wrong = off_grid(edit(grid(1000)), DT, DT)
    assert wrong is not None and wrong.row == row and reason in wrong.reason, wrong


def test_a_row_is_on_the_grid_up_to_the_tolerance_and_off_past_it() -> None:
    """Both sides of the tolerance, for a row's time (row 0: no step before it) and for a
    step (a row moved moves its step and its place alike)."""
    tol = GRID_TOLERANCE * DT
    for moved in (0, 500):
        for shift, wrong in [(0.9 * tol, False), (-0.9 * tol, False), (1.1 * tol, True)]:
            t = grid(1000)
            t[moved] += shift
            found = off_grid(t, DT, DT)
            assert (found is not None) == wrong, (moved, shift, found)
            if wrong:
                assert found.row == moved


def test_a_slow_drift_is_off_the_grid_where_it_leaves_it() -> None:
    """Each step within the tolerance of the grid's, the time drifting off: named at the
    first row more than the tolerance from its grid point."""
    t = grid(1000) + np.arange(1000) * 0.4 * GRID_TOLERANCE * DT
    wrong = off_grid(t, DT, DT)
    assert wrong is not None and wrong.row == 3 and "time at row 3" in wrong.reason


@pytest.mark.parametrize("cut", [1, 109, 110, 111, 500])
def test_a_column_checked_in_chunks_names_the_same_row(cut: int) -> None:
    """A log read in batches: the second checked with its first row and the row before
    gives what the whole column gives."""
    t = np.concatenate([grid(110), grid(900)[100:]])  # ten rows repeated from row 110 on
    whole = off_grid(t, DT, DT)
    head = off_grid(t[:cut], DT, DT)
    tail = off_grid(t[cut:], DT, DT, first_row=cut, before_s=float(t[cut - 1]))
    assert whole is not None and (head or tail) == whole


def test_a_grid_of_its_own_start_and_step() -> None:
    """A record's grid: its first row's time, its own step (date-times from a clock)."""
    t = 1234.5 + np.arange(400) * 0.05
    assert off_grid(t, 0.05, 1234.5) is None
    wrong = off_grid(t, 0.05, 1234.55)
    assert wrong is not None and wrong.reason == "time at row 0 is 1234.5 s, not 1234.55 s"
