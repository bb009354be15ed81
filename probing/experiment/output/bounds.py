"""``bounds.parquet``: per channel and tap, the mean of h_est over the periods used and its
two-sided Student-t interval (:data:`~probing.experiment.output.layouts.BOUNDS_SCHEMA`), written
by ``probing analyze`` over a record's whole periods and by a flight (``probing run``,
``probing monitor --replay``, ``probing live``) over its settled periods, both through
:func:`write_bounds`; a flight writes its ``probing.parquet`` rows beside them through one
:class:`EstimatesFile`."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from probing.core.pinning import ZERO_MEAN, pin_settled_tail, tail_taps
from probing.experiment.output.layouts import BOUNDS_LEVEL, bounds_block
from probing.experiment.output.scatter import settled_model_sd
from probing.experiment.output.settled import SettledMean
from probing.experiment.output.storage import OutputFolder, metadata, probing_block
from probing.experiment.scenario import Scenario

__all__ = [
    "EstimatesFile",
    "bounds_confidence",
    "pins_tail",
    "run_convention",
    "write_bounds",
    "write_settled_bounds",
]


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
    model_sd: np.ndarray | None = None,
    convention: dict[str, Any] | None = None,
) -> Path:
    """Write ``bounds.parquet`` (:data:`~probing.experiment.output.layouts.BOUNDS_SCHEMA`) into
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
        :data:`~probing.experiment.output.layouts.BOUNDS_LEVEL`.
    dof : int or dict
        Degrees of freedom of the interval (:func:`bounds_confidence`), stored in the file's
        ``probing.confidence`` with the level.
    per : str
        The probed surface's unit, which ``h_est`` is per.
    own_units : dict, optional
        The ``probing.units`` entries of the columns in the channels' units, for channels
        that are not the simulation's (a record's columns, ``probing analyze``); without it
        they are the channels' own.
    model_sd : numpy.ndarray, optional
        Shape (C, M): the noise model's standard deviation of the mean per tap; None where
        no model covers the estimate (the column is NaN).
    convention : dict, optional
        The ``probing.convention`` metadata (what h_est is per channel), when the folder's
        own metadata does not hold it.

    Returns
    -------
    pathlib.Path
        The file's final path.
    """
    names = list(channels)
    extra = {"confidence": bounds_confidence(dof)}
    if convention is not None:
        extra["convention"] = convention
    writer = folder.writer(
        "bounds.parquet",
        [] if own_units is not None else names,
        per,
        own_units=own_units,
        extra=metadata(**extra),
    )
    writer.write(bounds_block(names, lag_s, *bounds, model_sd=model_sd))
    return writer.path


def pins_tail(scn: Scenario) -> bool:
    """True where a flight's bounds pin h_est's constant with the settled tail
    (:mod:`probing.core.pinning`): no model carries the baseline (``drift = "detrend"``) and
    the estimator is DC-corrected (not ``ac``, which estimates the response less its mean by
    design)."""
    return scn.detrends and scn.estimator != "ac"


def run_convention(scn: Scenario) -> str:
    """What a flight's h_est is when the tail is not asked: ``reference`` (a twin carries
    the baseline), ``baseline`` (the trim's output is the baseline: ``drift = "none"``),
    ``ac`` (the response less sum(h) / (M + 1)) or ``zero mean`` (detrended)."""
    if scn.estimator == "ac":
        return "ac"
    if scn.detrends:
        return ZERO_MEAN
    return "baseline" if scn.drift == "none" else "reference"


class _TailPins:
    """Pins each channel's settled periods by their tail (a :meth:`SettledMean.bounds`
    transform) and keeps what it found, for the ``probing.convention`` metadata."""

    def __init__(self, channels: list[str], m: int) -> None:
        self.n_tail = tail_taps(m)
        self.conventions = dict.fromkeys(channels, ZERO_MEAN)  # fewer than 2 periods: left so
        self.tail: dict[str, Any] = {"from_tap": m - self.n_tail, "taps": self.n_tail}

    def __call__(self, channel: str, rows: np.ndarray) -> np.ndarray:
        pin = pin_settled_tail(rows[:, None, :], self.n_tail)
        self.conventions.update(pin.conventions([channel]))
        for key, value in pin.record([channel]).items():
            if isinstance(value, dict):
                self.tail.setdefault(key, {}).update(value)
        return pin.h[:, 0]

    def metadata(self) -> dict[str, Any]:
        return {"h_est": self.conventions, "tail": self.tail}


def write_settled_bounds(
    folder: OutputFolder, settled: SettledMean, scn: Scenario, lag_s: np.ndarray
) -> Path | None:
    """A run's ``bounds.parquet``: :meth:`SettledMean.bounds` of its settled periods, and the
    noise model's standard deviation of the mean where it covers the run
    (:func:`probing.experiment.output.scatter.settled_model_sd`).

    The degrees of freedom are stored as one int when every channel has the same, else per
    channel.  Nothing is written when no channel has 2 settled periods.  Where no model
    carries the baseline (:func:`pins_tail`) each channel's settled periods are pinned by
    their settled tail, as ``probing analyze`` pins a record's (the per-period rows of
    ``probing.parquet`` stay in the zero-mean convention); ``probing.convention`` says per
    channel what h_est is.

    Parameters
    ----------
    folder : OutputFolder
        The run's open output folder.
    settled : SettledMean
        The run's settled periods, kept with ``keep_all``.
    scn : Scenario
        The run's scenario: its channels, the probed surface's unit and the noise model.
    lag_s : numpy.ndarray
        Lag of each tap (s), shape (M,).

    Returns
    -------
    pathlib.Path or None
        The file's final path, None when it is not written.
    """
    pins = _TailPins(list(scn.channels), lag_s.size) if pins_tail(scn) else None
    found = settled.bounds(pins)
    if found is None:
        return None
    bounds, dof = found
    same = set(dof.values())
    dof_all = same.pop() if len(same) == 1 else dof
    model_sd = settled_model_sd(scn)
    per = scn.surface_unit
    if pins is not None:
        convention = pins.metadata()
    else:
        convention = {"h_est": dict.fromkeys(scn.channels, run_convention(scn))}
    return write_bounds(
        folder,
        list(scn.channels),
        lag_s,
        bounds,
        dof_all,
        per,
        model_sd=model_sd,
        convention=convention,
    )


class EstimatesFile:
    """A flight's ``probing.parquet`` rows, chunk by chunk, its settled mean, and at the end
    its ``bounds.parquet`` over the settled periods: what ``probing run``, ``probing monitor
    --replay`` and ``probing live`` write.

    Parameters
    ----------
    outputs : OutputFolder
        The flight's open output folder.
    scn : Scenario
        The flight's scenario.
    lag_s : numpy.ndarray
        Lag of each tap (s), shape (M,).
    keep_first : bool
        Keep the first channel's settled periods too (:meth:`SettledMean.first_channel`).
    """

    def __init__(
        self, outputs: OutputFolder, scn: Scenario, lag_s: np.ndarray, keep_first: bool = False
    ) -> None:
        self.outputs, self.scn, self.lag_s = outputs, scn, lag_s
        self.channels = list(scn.channels)
        self.writer = outputs.writer("probing.parquet", self.channels, scn.surface_unit)
        m, settle = lag_s.size, scn.settle_periods
        self.settled = SettledMean(self.channels, m, settle, keep_first, keep_all=True)

    def write(self, est: Any) -> None:
        """Add a chunk's estimates (``periods`` (P,), ``z``, ``zeta``, ``h`` (P, C, M))."""
        if est.periods.size:
            self.writer.write(
                probing_block(self.channels, est.periods, self.lag_s, est.z, est.zeta, est.h)
            )
            self.settled.add(est.periods, est.h, est.z)

    def finish(self) -> Path | None:
        """Write ``bounds.parquet`` (:func:`write_settled_bounds`)."""
        return write_settled_bounds(self.outputs, self.settled, self.scn, self.lag_s)
