"""A flight's (or a record's) results in memory: the files a command would write, kept as
their bytes, read as pandas DataFrames with their units and provenance in ``.attrs``, drawn
with :meth:`Flight.plot`, and written with :meth:`Flight.save` byte for byte as the command
line writes them."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from probing.core.errors import ArgumentError, number
from probing.experiment.output.pandas_keys import ATTRS_FILE, stored_text
from probing.experiment.output.staging import staged_output, work_folder
from probing.experiment.output.storage import (
    OUTPUT_FILES,
    RUN_FILES,
    StoredFileError,
    check_output_folder,
    read_footer,
    read_table,
)

if TYPE_CHECKING:  # pandas and matplotlib are imported when a table or figure is asked for
    import pandas as pd
    from matplotlib.figure import Figure

    from probing.experiment.scenario import Scenario

__all__ = ["FIGURE_NAME", "Flight", "attrs_of", "checked_max_lag", "held_files", "truth_files"]

#: The figure ``probing analyze`` draws beside a record's files (``<name>.png``).
FIGURE_NAME = "pulse_response"


def attrs_of(meta: Mapping[bytes, bytes], file: str) -> dict[str, Any]:
    """A DataFrame's ``attrs`` from a stored file's ``probing.*`` key-value metadata.

    Parameters
    ----------
    meta : mapping
        The file's key-value metadata, as :func:`~.storage.read_footer` reads it.
    file : str
        The file's name, kept as ``attrs["file"]``.

    Returns
    -------
    dict
        ``file`` and every ``probing.<key>`` as ``<key>``, JSON values decoded: ``units``
        (column -> unit, or channel -> unit for the columns in the row's channel's unit),
        ``scenario``, ``scenario_toml``, ``versions``, ``git_revision``, ``description``...

    Examples
    --------
    >>> attrs_of({b"probing.units": b'{"lag_s": "s"}', b"probing.drift": b"gust"}, "x.parquet")
    {'file': 'x.parquet', 'drift': 'gust', 'units': {'lag_s': 's'}}
    """
    attrs: dict[str, Any] = {ATTRS_FILE: file}
    for key in sorted(meta):
        if not key.startswith(b"probing."):
            continue
        attrs[key.decode().removeprefix("probing.")] = _decoded(meta[key])
    return attrs


def checked_max_lag(max_lag_s: Any) -> float | None:
    """A figure's last lag, s: None (automatic) or a number > 0 (ArgumentError)."""
    return None if max_lag_s is None else number(max_lag_s, "max_lag_s", lo=0, lo_open=True)


def _decoded(raw: bytes) -> Any:
    """A metadata value: a string is written as itself, anything else as JSON
    (:func:`~probing.experiment.output.pandas_keys.stored_text`).  A number, true, false or
    null is one only if it is stored so (a digest ``"12e4..."`` is a string), so a table's
    ``attrs`` written again by pandas give back the bytes
    (:func:`~probing.experiment.output.pandas_keys.from_pandas_attrs`)."""
    text = raw.decode()
    try:
        value = json.loads(text)
    except ValueError:
        return text
    return value if isinstance(value, dict | list) or stored_text(value) == text else text


def held_files(folder: Path) -> dict[str, bytes]:
    """The bytes of the project's files in ``folder`` (:data:`~.layouts.RUN_FILES`), by name."""
    return {name: (folder / name).read_bytes() for name in RUN_FILES if (folder / name).is_file()}


def truth_files(scn: Scenario) -> dict[str, bytes]:
    """``truth.parquet`` and ``prediction.parquet`` of ``scn`` as ``probing truth`` writes
    them, by name."""
    from probing.experiment.studies.truth import compute_truth

    with work_folder() as tmp:
        compute_truth(scn, tmp)
        return held_files(tmp / scn.name)


class Flight:
    """The results of one flight (:func:`probing.fly`), of a stored run (:func:`probing.read`)
    or of a record (:func:`probing.analyze`), held in memory.

    Each table is the file of the same name as a DataFrame, read on first use; its ``attrs``
    hold the file's units per column, the scenario and the versions (:func:`attrs_of`).

    Parameters
    ----------
    files : mapping
        File name (``probing.parquet``, ...) -> the file's bytes.
    name : str or None
        The run's name: :meth:`save` writes into ``OUT/<name>/``, as ``probing run`` does;
        None (a record) writes into ``OUT`` itself, as ``probing analyze --out OUT`` does.
    scenario : Scenario or None
        The scenario flown (None for a record).
    result : object, optional
        What the run handed back (its trim, steps and wall time; the monitor's result).
    figure_max_lag_s : float, optional
        A record's figure: the last lag drawn, s (None: automatic).
    """

    def __init__(
        self,
        files: Mapping[str, bytes],
        *,
        name: str | None,
        scenario: Scenario | None = None,
        result: Any = None,
        figure_max_lag_s: float | None = None,
    ) -> None:
        self._files = dict(files)
        self._frames: dict[str, pd.DataFrame] = {}
        self.name = name
        self.scenario = scenario
        self.result = result
        self.figure_max_lag_s = checked_max_lag(figure_max_lag_s)

    def __repr__(self) -> str:
        what = self.name or "record"
        return f"<Flight {what}: {', '.join(self.files)}>"

    # ------------------------------------------------------------------ tables
    @property
    def files(self) -> tuple[str, ...]:
        """The names of the files held, in the order :data:`~.layouts.OUTPUT_FILES` lists them."""
        order = list(OUTPUT_FILES)
        return tuple(sorted(self._files, key=lambda n: (order.index(n) if n in order else 99, n)))

    def file_bytes(self, name: str) -> bytes:
        """The bytes of the file ``name`` (KeyError: not held)."""
        return self._files[name]

    def metadata(self, name: str) -> dict[bytes, bytes]:
        """The key-value metadata of the file ``name``, its footer's (what its writer added at
        the end, a monitor's verdict, included), as :func:`~.storage.read_footer` reads it."""
        return read_footer(Path(name), data=self._files[name])

    def table(self, name: str) -> pd.DataFrame | None:
        """The file ``name`` as a DataFrame with :func:`attrs_of` its metadata (None: a file of
        the project's this flight does not hold).  Read once, then kept: change a copy.

        Raises
        ------
        probing.ArgumentError
            ``name`` is none of the project's files (:data:`~.layouts.RUN_FILES`).
        """
        if name not in RUN_FILES:
            raise ArgumentError(
                "name", f"{name!r} is none of the project's files ({', '.join(RUN_FILES)})"
            )
        if name not in self._files:
            return None
        if name not in self._frames:
            frame = read_table(Path(name), data=self._files[name]).to_pandas()
            frame.attrs = attrs_of(self.metadata(name), name)
            self._frames[name] = frame
        return self._frames[name]

    @property
    def estimates(self) -> pd.DataFrame | None:
        """``probing.parquet``: per channel, period and tap the probing output ``z``, its
        model ``zeta`` and the pulse-response estimate ``h_est`` (units in ``.attrs``)."""
        return self.table("probing.parquet")

    @property
    def bounds(self) -> pd.DataFrame | None:
        """``bounds.parquet``: the settled mean of ``h_est`` per channel and tap, with its
        confidence interval ``h_low``..``h_high``."""
        return self.table("bounds.parquet")

    @property
    def timeseries(self) -> pd.DataFrame | None:
        """``timeseries.parquet``: the run step by step (None when not written: a monitored
        flight writes it only with ``timeseries=True``)."""
        return self.table("timeseries.parquet")

    @property
    def monitor(self) -> pd.DataFrame | None:
        """``monitor.parquet``: the change detector after every period (None: not monitored)."""
        return self.table("monitor.parquet")

    @property
    def sensors(self) -> pd.DataFrame | None:
        """``sensors.parquet``: the flight computer's log (a monitored flight's), which
        :func:`probing.replay` reads."""
        return self.table("sensors.parquet")

    def truth(self) -> pd.DataFrame:
        """``truth.parquet``: the single-pulse and linearised pulse responses of the
        scenario, computed on the first call (about as long as the flight), then kept, with
        ``prediction.parquet`` (the probing output they predict): :meth:`save` writes both
        and :meth:`plot` draws the prediction.

        Raises
        ------
        probing.RecordError
            For a record, which has no scenario to simulate.
        """
        if "truth.parquet" not in self._files:
            if self.scenario is None:
                from probing.experiment.recorded.record import RecordError

                raise RecordError("a record has no scenario: its truth cannot be simulated")
            self._files.update(truth_files(self.scenario))
        frame = self.table("truth.parquet")
        assert frame is not None
        return frame

    # ------------------------------------------------------------------ the monitor's footer
    def _footer(self, key: str) -> Any:
        if "monitor.parquet" not in self._files:
            return None
        raw = self.metadata("monitor.parquet").get(f"probing.{key}".encode())
        return None if raw is None else _decoded(raw)

    @property
    def first_alarm_s(self) -> float | None:
        """The end of the first alarmed period, s after the trim (None: no alarm, or not
        monitored)."""
        return self._footer("first_alarm_s")

    @property
    def verdict(self) -> str | None:
        """The monitor's verdict, ``actuator``, ``airframe`` or ``sensor`` (None: no verdict,
        which ``monitor.parquet``'s footer and ``probing monitor`` write ``none``, or not
        monitored)."""
        verdict = self._footer("verdict")
        return None if verdict == "none" else verdict

    @property
    def alarm_detector(self) -> str | None:
        """The detector that alarmed first, ``probing`` or ``trajectory`` (None: none)."""
        return self._footer("alarm_detector")

    # ------------------------------------------------------------------ figure and files
    def plot(self, max_lag_s: float | None = None) -> Figure:
        """The settled estimate per channel with its confidence bounds, and the probing
        output the truth predicts once :meth:`truth` was computed.

        Parameters
        ----------
        max_lag_s : float, optional
            The last lag drawn, s, > 0 (None: the whole period, or zoomed to the response
            when it is short against the period; the figure says which).

        Returns
        -------
        matplotlib.figure.Figure

        Raises
        ------
        probing.ArgumentError
            ``max_lag_s`` not a number > 0.
        probing.StoredFileError
            The flight holds no ``bounds.parquet``.
        """
        from probing.analysis.analyze_plots import bounds_figure

        max_lag_s = checked_max_lag(max_lag_s)
        bounds = self.bounds
        if bounds is None:
            raise StoredFileError(
                f"{self.name}: has no bounds.parquet to draw ({', '.join(self.files)})"
            )
        settle = self.scenario.settle_periods if self.scenario is not None else None
        return bounds_figure(
            bounds,
            self.metadata("bounds.parquet"),
            max_lag_s=max_lag_s if max_lag_s is not None else self.figure_max_lag_s,
            prediction=self.table("prediction.parquet"),
            settle_periods=settle,
        )

    def plot_monitor(self) -> Figure:
        """A monitored flight's detectors period by period against their thresholds, its
        first alarm, and the scenario's fault onset (simulated: for the reader).

        Returns
        -------
        matplotlib.figure.Figure

        Raises
        ------
        probing.StoredFileError
            For a flight that was not monitored (no ``monitor.parquet``).
        """
        from probing.analysis.flight_plots import monitor_figure

        monitor = self.monitor
        if monitor is None:
            raise StoredFileError(
                f"{self.name or 'record'}: was not monitored (no monitor.parquet)"
            )
        fault = self.scenario.fault_section if self.scenario is not None else None
        onset = fault.onset_s if fault is not None else None
        return monitor_figure(monitor, self.first_alarm_s, self._footer("verdict"), onset)

    def save(self, out: str | Path, *, hold_interrupts: bool = False) -> Path:
        """Write the files into ``OUT/<name>/`` (a record's into ``OUT``), with the bytes
        ``probing run``, ``probing monitor`` and ``probing analyze`` write.

        The files are made in a staging folder and moved into place together; the files an
        earlier run left in the folder are removed (one line on stderr names them).

        Parameters
        ----------
        out : path
            The results folder.
        hold_interrupts : bool
            From the move on, ignore Ctrl-C and SIGTERM to the end of the process (the
            command line's rule: an interrupt comes before the files, or not at all).

        Returns
        -------
        pathlib.Path
            The folder written.

        Raises
        ------
        probing.experiment.output.storage.OutputFolderError
            When the folder cannot be written (checked before anything is written).
        """
        out = check_output_folder(out, "out")  # "" refused, not taken as "."
        folder = check_output_folder(out / self.name, "out") if self.name else out
        with staged_output(folder, hold=hold_interrupts) as staging:
            for name in self.files:
                (staging / name).write_bytes(self._files[name])
            if self.name is None and "bounds.parquet" in self._files:
                from probing.analysis.analyze_plots import draw_bounds

                draw_bounds(
                    staging / "bounds.parquet",
                    staging / FIGURE_NAME,
                    max_lag_s=self.figure_max_lag_s,
                )
        return folder
