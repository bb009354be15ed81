"""``bounds.parquet``: per channel and tap, the mean of h_est over the periods used and its
two-sided Student-t interval (:data:`~probing.experiment.layouts.BOUNDS_SCHEMA`), written
by ``probing analyze`` over a record's whole periods and by ``probing run`` over a run's
settled periods, both through :func:`write_bounds`."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from probing.experiment.layouts import BOUNDS_LEVEL, bounds_block
from probing.experiment.settled import SettledMean
from probing.experiment.storage import OutputFolder, metadata, probing_block

__all__ = ["EstimatesFile", "bounds_confidence", "write_bounds", "write_settled_bounds"]


def bounds_confidence(dof: int | dict[str, int]) -> dict[str, object]:
    """The ``probing.confidence`` metadata of a ``bounds.parquet``: level, interval, dof.

    Parameters
    ----------
    dof : int or dict
        Degrees of freedom P - 1 of the interval over P periods; a dict channel -> P - 1
        when the channels' periods differ.

    Returns
    -------
    dict
        ``{"level": BOUNDS_LEVEL, "interval": "Student-t", "dof": dof}``.
    """
    return {"level": BOUNDS_LEVEL, "interval": "Student-t", "dof": dof}


def write_bounds(
    folder: OutputFolder,
    channels: Sequence[str],
    lag_s: np.ndarray,
    bounds: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    dof: int | dict[str, int],
    per: str = "deg",
    own_units: dict[str, Any] | None = None,
) -> Path:
    """Write ``bounds.parquet`` (:data:`~probing.experiment.layouts.BOUNDS_SCHEMA`) into
    ``folder``: it appears with the folder's other files.

    Parameters
    ----------
    folder : OutputFolder
        The open output folder (:func:`output_folder`).
    channels : sequence of str
        Channel names, C of them.
    lag_s : numpy.ndarray
        Lag of each tap (s), shape (M,).
    bounds : tuple of numpy.ndarray
        Mean, low, high and std, each shape (C, M), the unit of ``h_est`` (channel unit per
        unit of probe), as :func:`probing.core.recorded.tap_bounds` returns them at
        :data:`~probing.experiment.layouts.BOUNDS_LEVEL`.
    dof : int or dict
        Degrees of freedom of the interval (:func:`bounds_confidence`), stored in the file's
        ``probing.confidence`` with the level.
    per : str
        The probed surface's unit, which ``h_est`` is per.
    own_units : dict, optional
        The ``probing.units`` entries of the columns in the channels' units, for channels
        that are not the simulation's (a record's columns, ``probing analyze``); without it
        they are the channels' own.

    Returns
    -------
    pathlib.Path
        The file's final path.
    """
    names = list(channels)
    writer = folder.writer(
        "bounds.parquet",
        [] if own_units is not None else names,
        per,
        own_units=own_units,
        extra=metadata(confidence=bounds_confidence(dof)),
    )
    writer.write(bounds_block(names, lag_s, *bounds))
    return writer.path


def write_settled_bounds(
    folder: OutputFolder,
    settled: SettledMean,
    channels: list[str],
    lag_s: np.ndarray,
    per: str = "deg",
) -> Path | None:
    """A run's ``bounds.parquet``: :meth:`SettledMean.bounds` of its settled periods.

    The degrees of freedom are stored as one int when every channel has the same, else per
    channel.  Nothing is written when no channel has 2 settled periods.

    Parameters
    ----------
    folder : OutputFolder
        The run's open output folder.
    settled : SettledMean
        The run's settled periods, kept with ``keep_all``.
    channels : list of str
        The run's channels, C of them.
    lag_s : numpy.ndarray
        Lag of each tap (s), shape (M,).
    per : str
        The probed surface's unit, which ``h_est`` is per.

    Returns
    -------
    pathlib.Path or None
        The file's final path, None when it is not written.
    """
    found = settled.bounds()
    if found is None:
        return None
    bounds, dof = found
    same = set(dof.values())
    return write_bounds(folder, channels, lag_s, bounds, same.pop() if len(same) == 1 else dof, per)


class EstimatesFile:
    """A monitored flight's ``probing.parquet`` rows, chunk by chunk, and at the end its
    ``bounds.parquet`` over the settled periods: what ``probing monitor --replay`` and
    ``probing live`` write, as ``probing run`` does.

    Parameters
    ----------
    outputs : OutputFolder
        The flight's open output folder.
    channels : list of str
        The scenario's channels.
    settle_periods : int
        Periods left out of the bounds at the start.
    lag_s : numpy.ndarray
        Lag of each tap (s), shape (M,).
    per : str
        The probed surface's unit, which ``h_est`` is per.
    """

    def __init__(
        self,
        outputs: OutputFolder,
        channels: list[str],
        settle_periods: int,
        lag_s: np.ndarray,
        per: str = "deg",
    ) -> None:
        self.outputs, self.channels, self.lag_s, self.per = outputs, channels, lag_s, per
        self.writer = outputs.writer("probing.parquet", channels, per)
        self.settled = SettledMean(channels, lag_s.size, settle_periods, keep_all=True)

    def write(self, est: Any) -> None:
        """Add a chunk's estimates (``periods`` (P,), ``z``, ``zeta``, ``h`` (P, C, M))."""
        if est.periods.size:
            self.writer.write(
                probing_block(self.channels, est.periods, self.lag_s, est.z, est.zeta, est.h)
            )
            self.settled.add(est.periods, est.h, est.z)

    def finish(self) -> Path | None:
        """Write ``bounds.parquet`` (:func:`write_settled_bounds`)."""
        return write_settled_bounds(self.outputs, self.settled, self.channels, self.lag_s, self.per)
