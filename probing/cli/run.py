"""``probing run``, ``truth`` and ``monitor``: one scenario each."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from probing.cli.common import (
    Subcommands,
    UsageError,
    check_run_folder,
    command,
    files_of,
    path_arg,
    scenario_arg,
    simulating,
)


def _tty() -> bool:
    """A progress bar on stderr: when it is a terminal (the API's own default is a notebook)."""
    return sys.stderr.isatty()


def _announce(scn: Any) -> None:
    """Off a terminal (no progress bar), a long flight says before it starts how many steps
    it flies and about how long that takes
    (:func:`probing.experiment.output.progress.long_run_notice`)."""
    from probing.experiment.output.progress import long_run_notice

    notice = None if _tty() else long_run_notice(scn.name, scn.total_steps)
    if notice is not None:
        print(f"probing: note: {notice}", file=sys.stderr, flush=True)


def _cmd_run(args: argparse.Namespace) -> int:
    """``probing run``: ``fly(scn).save(out)`` (:func:`probing.api.fly`), then one line."""
    from probing.experiment.flight.runners import runner_of

    scn = _one_surface(scenario_arg(args.scenario), args.scenario, "run")
    check_run_folder(args.out, scn)
    line = RUN_LINES.get(runner_of(scn).name, _steady_line)

    def job() -> int:
        from probing.api import fly
        from probing.experiment.studies.simultaneous import SeparationError

        _announce(scn)
        try:
            flight = fly(
                scn, progress=_tty(), truth=args.truth, monitor=False, scratch=args.out / scn.name
            )
        except SeparationError as exc:
            raise UsageError(f"{args.scenario}: {exc}") from None
        folder = flight.save(args.out, hold_interrupts=True)
        print(line(scn, flight.result, folder, args.truth))
        return 0

    return simulating(job, str(args.scenario), scn.model)


def _steady_line(scn: Any, result: Any, folder: Path, truth: bool) -> str:
    line = (
        f"{scn.name}: {scn.periods} periods, {result.steps_simulated} steps in "
        f"{result.wall_s:.2f} s -> {folder}"
    )
    return f"{line}\n{scn.name}: ground truth -> {folder / 'truth.parquet'}" if truth else line


def _simultaneous_line(scn: Any, result: Any, folder: Path, truth: bool) -> str:
    """``probing run`` of a ``[simultaneous]`` scenario (``responses.parquet``; with
    ``--truth`` each surface is flown alone too and the measured cross-talk printed)."""
    line = (
        f"{scn.name}: {len(scn.simultaneous.surfaces)} surfaces together "
        f"({scn.simultaneous.design}), {result.steps_simulated} steps in "
        f"{result.wall_s:.2f} s -> {folder}"
    )
    return f"{line}\n{result.table()}" if result.crosstalk else line


def _manoeuvre_line(scn: Any, result: Any, folder: Path, truth: bool) -> str:
    """``probing run`` of a ``[manoeuvre]`` scenario (``manoeuvre.parquet``, the probing
    output period by period with its single-pulse truth, so ``--truth`` adds nothing)."""
    worst = ", ".join(
        f"{c} {100 * e[scn.settle_periods :].max():.1f} %" for c, e in result.errors.items()
    )
    return (
        f"{scn.name}: {scn.periods} periods through a {scn.manoeuvre.hold} manoeuvre, "
        f"{result.steps_simulated} steps in {result.wall_s:.2f} s -> {folder}; "
        f"largest error against the single pulse after settling: {worst}"
    )


#: ``probing run``'s line after each runner's flight but the steady one
#: (:data:`probing.experiment.flight.runners.RUNNERS`, flown by
#: :data:`probing.api.calls.FLIERS`): ``line(scn, result, folder, truth)``.
RUN_LINES: dict[str, Callable[[Any, Any, Path, bool], str]] = {
    "simultaneous": _simultaneous_line,
    "manoeuvre": _manoeuvre_line,
}


def _print_truth(scn: Any, out: Path) -> None:
    from probing.experiment.studies.truth import compute_truth

    print(f"{scn.name}: ground truth -> {compute_truth(scn, out)}")


def _one_surface(scn: Any, path: Path, command: str) -> Any:
    """``scn``, unless its runner does not offer ``command``
    (:meth:`probing.experiment.flight.runners.Runner.refuses`: a [simultaneous] or a [manoeuvre]
    scenario is flown by ``probing run`` only)."""
    from probing.experiment.flight.runners import runner_of

    refusal = runner_of(scn).refuses(command)
    if refusal is not None:
        raise UsageError(f"{path}: {refusal}")
    return scn


def _cmd_truth(args: argparse.Namespace) -> int:
    scn = _one_surface(scenario_arg(args.scenario), args.scenario, "truth")
    check_run_folder(args.out, scn)

    def job() -> int:
        _print_truth(scn, args.out)
        return 0

    return simulating(job, str(args.scenario), scn.model)


def _cmd_monitor(args: argparse.Namespace) -> int:
    from probing.experiment.scenario import ScenarioError

    if args.map is not None:
        if args.scenario is None or args.replay is None:
            raise UsageError("monitor --map: give the scenario and --replay LOG with it")
        return _replay(args)
    if (args.scenario is None) == (args.replay is None):
        raise UsageError("monitor: give a scenario, or --replay LOG (not both)")
    if args.replay is not None:
        return _replay(args)
    scn = _one_surface(scenario_arg(args.scenario), args.scenario, "monitor")
    try:
        scn.monitor_settings()
    except ScenarioError as exc:
        raise UsageError(f"{args.scenario}: {exc}") from None
    check_run_folder(args.out, scn)

    def job() -> int:
        from probing.api import fly

        _announce(scn)
        flight = fly(
            scn,
            progress=_tty(),
            monitor=True,
            timeseries=args.timeseries,
            scratch=args.out / scn.name,
        )
        folder = flight.save(args.out, hold_interrupts=True)
        print(f"{scn.name}: {flight.result.line()} -> {folder / 'monitor.parquet'}")
        return 0

    return simulating(job, str(args.scenario), scn.model)


#: What a log that is not a flight's own needs (``probing monitor --replay`` without a map).
NEEDS_MAP = (
    "a log recorded elsewhere (CSV or Parquet) needs its scenario and --map MAP (docs/formats.md)"
)


def _replay(args: argparse.Namespace) -> int:
    """``probing monitor --replay LOG``: the monitor recomputed from a flight's log
    (:func:`probing.api.replay`)."""
    from probing.api.calls import foreign_table, replay_table, replayed_scenario
    from probing.experiment.flight.monitor import NotAFlightLog, ReplayError
    from probing.experiment.output.storage import StoredFileError

    if args.timeseries:
        raise UsageError("monitor --replay: a log has no timeseries to write")
    given = None
    if args.map is not None:
        given = _one_surface(scenario_arg(args.scenario), args.scenario, "monitor")
    try:
        table = foreign_table(args.replay, given, args.map)
        scn = replayed_scenario(args.replay, table)
    except (ReplayError, StoredFileError) as exc:
        foreign = isinstance(exc, NotAFlightLog) or (
            isinstance(exc, StoredFileError) and args.replay.is_file()
        )
        hint = f"; {NEEDS_MAP}" if foreign and args.map is None else ""
        raise UsageError(f"{exc}{hint}") from None
    check_run_folder(args.out, scn)

    def job() -> int:
        flight = replay_table(args.replay, table, progress=_tty(), scratch=args.out / scn.name)
        folder = flight.save(args.out, hold_interrupts=True)
        print(f"{scn.name} (replayed): {flight.result.line()} -> {folder / 'monitor.parquet'}")
        return 0

    return simulating(job, str(args.replay))


def register(sub: Subcommands) -> None:
    """Add ``run``, ``truth`` and ``monitor`` to ``sub``."""
    run = command(
        sub,
        "run",
        f"simulate a scenario and write {files_of('run')} into OUT/<scenario name>/",
        [
            "probing run scenarios/baseline-737.toml --out results",
            "probing run scenarios/fig4/a_deadband.toml --out results --truth",
        ],
    )
    _scenario_arguments(run)
    run.add_argument("--truth", action="store_true", help=f"also write {files_of('truth')}")
    run.set_defaults(func=_cmd_run)

    truth = command(
        sub,
        "truth",
        "ground truth of a scenario: single-pulse and linearised pulse responses "
        "(truth.parquet) and the probing output they predict (prediction.parquet)",
        ["probing truth scenarios/baseline-737.toml --out results   # beside its run's files"],
    )
    _scenario_arguments(truth)
    truth.set_defaults(func=_cmd_truth)

    monitor = command(
        sub,
        "monitor",
        "fly a scenario probing continuously; after every period a change detector tests "
        f"the estimate: {files_of('monitor')} into OUT/<scenario name>/ (docs/monitoring.md)",
        [
            "probing monitor scenarios/monitor/base.toml --out results",
            "probing monitor --replay results/gtm-monitored/sensors.parquet --out results/replayed",
            "probing monitor examples/foreign-log/scenario.toml --replay results/flight.csv "
            "--map examples/foreign-log/map.toml --out results   # docs/formats.md",
        ],
    )
    monitor.add_argument(
        "scenario", type=path_arg, nargs="?", help="scenario TOML file (docs/scenarios.md)"
    )
    monitor.add_argument(
        "--out", type=path_arg, default=Path("results"), help="results go to OUT/<scenario name>/"
    )
    monitor.add_argument(
        "--replay",
        type=path_arg,
        metavar="LOG",
        help="recompute the monitor from a flight's sensors.parquet alone (no scenario), "
        "or, with --map and a scenario, from a log recorded elsewhere",
    )
    monitor.add_argument(
        "--map",
        type=path_arg,
        metavar="MAP",
        help="a TOML map of a foreign --replay log (CSV or Parquet): the project's columns "
        "-> the file's, unit scale factors, the trim reading (docs/formats.md)",
    )
    monitor.add_argument(
        "--timeseries", action="store_true", help="also write timeseries.parquet (large)"
    )
    monitor.set_defaults(func=_cmd_monitor)


def _scenario_arguments(parser: argparse.ArgumentParser) -> None:
    """The scenario file and the results folder, as run, truth and monitor take them."""
    parser.add_argument("scenario", type=path_arg, help="scenario TOML file (docs/scenarios.md)")
    parser.add_argument(
        "--out", type=path_arg, default=Path("results"), help="results go to OUT/<scenario name>/"
    )
