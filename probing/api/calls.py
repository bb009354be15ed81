"""The public Python API: load a scenario, fly it, read stored results, analyze a record,
replay a flight's log.  The command line is a thin layer over these functions.

Each returns a :class:`~probing.api.flight.Flight`, whose files are made by the same code
the commands run, into a private temporary folder that is removed once their bytes are
read: nothing is left on disk unless :meth:`Flight.save` is asked (the twin cache, shared
with the command line, excepted).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from probing.api.flight import Flight, checked_max_lag, held_files
from probing.experiment.output.layouts import RUN_FILES
from probing.experiment.output.staging import work_folder
from probing.experiment.output.storage import StoredFileError, read_footer
from probing.experiment.scenario import Scenario, ScenarioError, load_scenario, parse_scenario

__all__ = [
    "FLIERS",
    "Flying",
    "analyze",
    "example",
    "example_path",
    "fly",
    "foreign_table",
    "load",
    "read",
    "replay",
    "replay_table",
    "replayed_scenario",
    "stored_scenario",
]


def load(path: str | Path | Mapping[str, Any]) -> Scenario:
    """Read and check a scenario file (docs/scenarios.md), or a dict laid out like one.

    Parameters
    ----------
    path : path or mapping
        A scenario TOML file, or its tables as a dict (``{"name": ..., "aircraft":
        {"model": "737"}, ...}``).

    Returns
    -------
    Scenario
        Frozen; :meth:`Scenario.replace` gives a changed, checked copy.

    Raises
    ------
    ScenarioError
        Naming the file, the field and what is allowed (the line ``probing run`` prints).

    Examples
    --------
    >>> import probing
    >>> scn = probing.load(probing.example_path("fig4/a_deadband"))
    >>> scn.name, scn.amplitude_deg
    ('fig4-a-deadband', 0.005)
    >>> probing.load({"name": "x"})
    Traceback (most recent call last):
    ...
    probing.experiment.scenario.schema.ScenarioError: aircraft: missing section
    """
    if isinstance(path, Mapping):
        return parse_scenario(dict(path))
    return load_scenario(path)


def example_path(name: str) -> Path:
    """The file of a shipped example scenario, by its name under ``scenarios/`` without
    ``.toml`` (``probing examples`` lists them).

    Raises
    ------
    ScenarioError
        Field ``example`` when no shipped scenario has that name.
    """
    from probing.data import SCENARIOS

    path = SCENARIOS / f"{name.removesuffix('.toml')}.toml"
    if not path.is_file() or SCENARIOS not in path.resolve().parents:
        raise ScenarioError(
            "example", f"no example scenario {name!r} (probing examples lists them)"
        )
    return path


def example(name: str) -> Scenario:
    """A shipped example scenario, by its name under ``scenarios/`` without ``.toml``.

    Examples
    --------
    >>> import probing
    >>> probing.example("fig4/a_deadband").nonlinearity
    'deadband'
    """
    return load(example_path(name))


def in_notebook() -> bool:
    """Whether this is a Jupyter kernel (where a progress bar is drawn by default)."""
    shell = getattr(sys.modules.get("IPython"), "get_ipython", lambda: None)()
    return shell is not None and hasattr(shell, "kernel")


def fly(
    scenario: Scenario | str | Path,
    *,
    progress: bool | None = None,
    truth: bool = False,
    monitor: bool | None = None,
    timeseries: bool | None = None,
    twin_cache: bool = True,
    scratch: str | Path | None = None,
) -> Flight:
    """Fly a scenario in memory: what ``probing run`` (or ``probing monitor``) writes,
    held by the returned flight.

    Parameters
    ----------
    scenario : Scenario or path
        The scenario, or its file.
    progress : bool, optional
        A progress bar on stderr; default: in a Jupyter notebook only.
    truth : bool
        Also compute the ground truth as the run goes (``probing run --truth``; otherwise
        :meth:`Flight.truth` computes it on demand, as ``probing truth`` does).
    monitor : bool, optional
        Fly with the change detector (``probing monitor``); default: when the scenario has a
        ``[monitor]`` section.
    timeseries : bool, optional
        Keep ``timeseries.parquet``; default: for a run, not for a monitored flight (large).
    twin_cache : bool
        Read and store a ``reference`` twin in the twin cache (the results are the same).
    scratch : path, optional
        Where the files are made before they are read into memory, in a folder removed at
        the end (default: the system's temporary folder).  The command line gives the
        run's own folder, whose next run removes what a run killed outright left there.

    Returns
    -------
    Flight

    Raises
    ------
    ScenarioError
        A scenario this flight cannot take (a runner that does not monitor, too short a
        monitored flight).
    probing.sim.errors.TrimError, probing.sim.errors.DivergenceError
        The aircraft does not trim, or diverges (a monitored flight keeps its periods
        before a divergence instead).

    Examples
    --------
    >>> import probing
    >>> scn = probing.example("fig4/a_deadband")
    >>> flight = probing.fly(scn.replace({"probe.periods": 3, "probe.settle_periods": 1}))
    >>> flight.bounds.attrs["units"]["h_est"]
    {'q_rad_s': 'rad/s/deg', 'theta_rad': 'rad/deg'}
    >>> len(flight.bounds), flight.bounds.columns[:4].tolist()
    (1022, ['channel', 'tap', 'lag_s', 'h_est'])
    """
    from probing.experiment.flight.runners import runner_of

    scn = scenario if isinstance(scenario, Scenario) else load(scenario)
    runner = runner_of(scn)
    monitored = scn.monitor_section is not None if monitor is None else monitor
    if monitored:
        refusal = runner.refuses("monitor")
        if refusal is not None:
            raise ScenarioError(runner.section or "monitor", refusal, scn.name)
        scn.monitor_settings()  # a flight too short for the baseline: refused before flying
    bar = in_notebook() if progress is None else progress
    with work_folder(None if scratch is None else Path(scratch)) as tmp:
        result = _fly_into(scn, tmp, runner.name, monitored, bar, truth, timeseries, twin_cache)
        files = held_files(tmp / scn.name)
    return Flight(files, name=scn.name, scenario=scn, result=result)


def _fly_into(
    scn: Scenario,
    out: Path,
    runner: str,
    monitored: bool,
    progress: bool,
    truth: bool,
    timeseries: bool | None,
    twin_cache: bool,
) -> Any:
    """The command's flight of ``scn`` into ``out/<name>/``; what it hands back."""
    if monitored:  # the steady runner's (the others refuse probing monitor)
        from probing.experiment.flight.monitor import monitor_scenario

        return monitor_scenario(
            scn, out, progress=progress, twin_cache=twin_cache, timeseries=bool(timeseries)
        )
    how = Flying(progress=progress, truth=truth, timeseries=timeseries, twin_cache=twin_cache)
    return FLIERS[runner](scn, out, how)


@dataclass(frozen=True)
class Flying:
    """How :func:`fly` was asked to fly (a runner's flier takes what applies to it)."""

    progress: bool
    truth: bool
    timeseries: bool | None
    twin_cache: bool


def _fly_steady(scn: Scenario, out: Path, how: Flying) -> Any:
    from probing.experiment.flight.run import run_scenario
    from probing.experiment.studies.truth import TruthFiles

    return run_scenario(
        scn,
        out,
        progress=how.progress,
        twin_cache=how.twin_cache,
        observer=TruthFiles(scn) if how.truth else None,
        timeseries=how.timeseries is not False,
    )


def _fly_simultaneous(scn: Scenario, out: Path, how: Flying) -> Any:
    from probing.experiment.studies.simultaneous import run_simultaneous

    return run_simultaneous(
        scn, out, truth=how.truth, progress=how.progress, twin_cache=how.twin_cache
    )


def _fly_manoeuvre(scn: Scenario, out: Path, how: Flying) -> Any:
    from probing.experiment.studies.manoeuvre import run_manoeuvre

    return run_manoeuvre(scn, out, progress=how.progress)


#: Each runner's flight (:data:`probing.experiment.flight.runners.RUNNERS`):
#: ``flier(scn, out, how)`` writes the run's files into ``out/<name>/`` and returns what
#: the runner hands back.  A new runner is an entry here (docs/architecture.md).
FLIERS: dict[str, Callable[[Scenario, Path, Flying], Any]] = {
    "steady": _fly_steady,
    "simultaneous": _fly_simultaneous,
    "manoeuvre": _fly_manoeuvre,
}


def read(path: str | Path) -> Flight:
    """A stored run's folder (``probing run``, ``monitor``, ``analyze``, a sweep point's) as
    a flight: the same tables, and :meth:`Flight.save` copies it byte for byte.

    Raises
    ------
    StoredFileError
        When ``path`` does not exist, is not a folder, holds none of the project's files,
        or one of them is not Parquet.
    """
    folder = Path(path)
    if not folder.exists():
        raise StoredFileError(f"{folder}: no such folder")
    if not folder.is_dir():
        raise StoredFileError(f"{folder}: is a file, not the folder of a run")
    files = held_files(folder)
    if not files:
        raise StoredFileError(f"{folder}: holds none of {', '.join(RUN_FILES)}")
    meta = read_footer(folder / next(iter(files)))
    scn = stored_scenario(meta)
    analyzed = b"probing.input" in meta
    name = None if analyzed else scn.name if scn is not None else folder.name
    return Flight(files, name=name, scenario=scn)


def stored_scenario(meta: dict[bytes, bytes]) -> Scenario | None:
    """The scenario a stored file was written with (None: none, or one this version of the
    project no longer reads)."""
    import json

    raw = meta.get(b"probing.scenario")
    if raw is None:
        return None
    text = meta.get(b"probing.scenario_toml", b"").decode()
    try:
        return parse_scenario(json.loads(raw), text=text)
    except (ScenarioError, ValueError):
        return None


def analyze(
    file: str | Path,
    *,
    input: str,
    outputs: str | Sequence[str],
    order: int,
    bit_duration_s: float,
    time: str | None = None,
    dt_s: float | None = None,
    amplitude: float | None = None,
    drift: str = "detrend",
    reference: str | None = None,
    settled_after_s: float | None = None,
    max_lag_s: float | None = None,
    scratch: str | Path | None = None,
) -> Flight:
    """Pulse compression on a recorded file (``probing analyze``; docs/analyze.md).

    Parameters
    ----------
    file : path
        The record: CSV, Parquet or MATLAB ``.mat``.
    input : str
        The probe's column, as injected.
    outputs : str or sequence of str
        The measured outputs' columns (a string: one column).
    order : int
        The m-sequence's order n (M = 2**n - 1).
    bit_duration_s : float
        The bit duration t0, s.
    time, dt_s : str or float
        The time column (s, uniform step), or the sample step (s): one of them.
    amplitude : float, optional
        The probe's amplitude in its unit (default: half its two levels' difference).
    drift : {"detrend", "none"}
        Without ``reference``: a periodic part and a linear trend fitted together, or the
        mean removed.
    reference : str, optional
        A column subtracted from each output instead.
    settled_after_s : float, optional
        Without ``reference``: the lag (s) from which the response has settled.
    max_lag_s : float, optional
        The figure's last lag, s (:meth:`Flight.plot`, and the figure :meth:`Flight.save`
        draws as ``probing analyze`` does).
    scratch : path, optional
        As for :func:`fly`.

    Returns
    -------
    Flight
        A record's flight: ``estimates`` and ``bounds`` (no scenario).

    Raises
    ------
    probing.experiment.recorded.record.RecordError
        The file cannot be read or holds no rows, a column or the probe is not what it
        should be (a column of text, a time column off its grid: the first wrong row named).
    probing.ArgumentError
        An argument of the wrong type or out of its range, named (``order=7.0``,
        ``bit_duration_s="0.04"``, ``drift="foo"``), checked before the file is read.
    """
    from probing.experiment.recorded.analyze import AnalysisRequest, write_analysis
    from probing.experiment.recorded.analyze import analyze as analyze_record
    from probing.experiment.recorded.record import RecordError

    max_lag_s = checked_max_lag(max_lag_s)
    path = Path(file)
    if path.is_dir():
        raise RecordError(f"{path}: is a folder, not a record (a .csv, .parquet or .mat file)")
    if not path.is_file():
        raise RecordError(f"{path}: no such file")
    req = AnalysisRequest(
        path=path,
        input=input,
        outputs=outputs,
        order=order,
        bit_duration_s=bit_duration_s,
        time=time,
        dt_s=dt_s,
        amplitude=amplitude,
        drift=drift,
        reference=reference,
        settled_after_s=settled_after_s,
    )
    result = analyze_record(req)
    with work_folder(None if scratch is None else Path(scratch)) as tmp:
        write_analysis(result, tmp)
        files = held_files(tmp)
    return Flight(files, name=None, result=result, figure_max_lag_s=max_lag_s)


def replay(
    log: str | Path,
    *,
    scenario: Scenario | str | Path | None = None,
    map: str | Path | None = None,
    progress: bool | None = None,
    scratch: str | Path | None = None,
) -> Flight:
    """The monitor recomputed from a flight's log (``probing monitor --replay``).

    Parameters
    ----------
    log : path
        A monitored flight's ``sensors.parquet``; or, with ``scenario`` and ``map``, a log
        recorded elsewhere (CSV or Parquet, docs/formats.md).
    scenario : Scenario or path, optional
        With ``map``: the scenario the foreign log was flown with.
    map : path, optional
        The TOML map of a foreign log's columns, units and trim reading.
    progress : bool, optional
        A progress bar on stderr; default: in a Jupyter notebook only.
    scratch : path, optional
        As for :func:`fly`.

    Returns
    -------
    Flight
        ``monitor.parquet`` and ``probing.parquet``, equal bit for bit to the flight's.

    Raises
    ------
    probing.experiment.flight.monitor.ReplayError
        Not a monitored flight's log, a column or key missing, a bad map; or a log that is
        not its flight's (a column of another type, time off the flight's grid, another
        probe, not whole periods: :mod:`probing.experiment.flight.flight_log`), naming the
        first wrong column or row; checked before anything is written.
    StoredFileError
        The log cannot be read.
    """
    table = foreign_table(log, scenario, map)
    return replay_table(log, table, progress=progress, scratch=scratch)


def replay_table(
    log: str | Path,
    table: Any,
    *,
    progress: bool | None = None,
    scratch: str | Path | None = None,
) -> Flight:
    """:func:`replay` of a log, or of a foreign log already translated (``table``, from
    :func:`foreign_table`; None: the log is a flight's own)."""
    from probing.experiment.flight.monitor import replay_monitor

    bar = in_notebook() if progress is None else progress
    with work_folder(None if scratch is None else Path(scratch)) as tmp:
        result = replay_monitor(log, tmp, table=table, progress=bar)
        files = held_files(result.out_dir)
    scn = stored_scenario(read_footer(Path("monitor.parquet"), data=files["monitor.parquet"]))
    return Flight(files, name=result.out_dir.name, scenario=scn, result=result)


def foreign_table(log: str | Path, scenario: Scenario | str | Path | None, map: Any) -> Any:
    """A log recorded elsewhere, translated by its ``map`` for ``scenario`` (None without a
    map: the log is a flight's own)."""
    if map is None:
        return None
    from probing.experiment.flight.monitor import ReplayError
    from probing.experiment.recorded.foreign_log import foreign_log, read_map

    if scenario is None:
        raise ReplayError(f"{log}: a log recorded elsewhere needs its scenario with its map")
    scn = scenario if isinstance(scenario, Scenario) else load(scenario)
    return foreign_log(log, read_map(map), scn)


def replayed_scenario(log: str | Path, table: Any = None) -> Scenario:
    """The scenario a log was flown with (ReplayError, StoredFileError)."""
    from probing.experiment.flight.monitor import logged_scenario

    meta = read_footer(Path(log)) if table is None else dict(table.schema.metadata or {})
    return logged_scenario(Path(log), meta, table)[0]
