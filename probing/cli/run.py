"""``probing run``, ``truth`` and ``monitor``: one scenario each."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any

from probing.cli.common import (
    Subcommands,
    UsageError,
    check_run_folder,
    command,
    path_arg,
    scenario_arg,
    simulating,
)


def _cmd_run(args: argparse.Namespace) -> int:
    from probing.experiment.flight.runners import runner_of

    scn = _one_surface(scenario_arg(args.scenario), args.scenario, "run")
    check_run_folder(args.out, scn)
    handler = RUN_HANDLERS.get(runner_of(scn).name)
    if handler is not None:
        return handler(scn, args)

    def job() -> int:
        from probing.experiment.flight.run import run_scenario
        from probing.experiment.studies.truth import TruthFiles

        truth = TruthFiles(scn) if args.truth else None  # one run's files: run and truth
        result = run_scenario(scn, args.out, progress=None, observer=truth)
        print(
            f"{scn.name}: {scn.periods} periods, {result.steps_simulated} steps in "
            f"{result.wall_s:.2f} s -> {result.out_dir}"
        )
        if args.truth:
            print(f"{scn.name}: ground truth -> {result.out_dir / 'truth.parquet'}")
        return 0

    return simulating(job, str(args.scenario), scn.model)


def _run_simultaneous(scn: Any, args: argparse.Namespace) -> int:
    """``probing run`` of a ``[simultaneous]`` scenario: ``responses.parquet``; with
    ``--truth`` each surface is flown alone too and the measured cross-talk printed."""
    from probing.experiment.studies.simultaneous import SeparationError, run_simultaneous

    def job() -> int:
        try:
            result = run_simultaneous(scn, args.out, truth=args.truth, progress=None)
        except SeparationError as exc:
            raise UsageError(f"{args.scenario}: {exc}") from None
        print(
            f"{scn.name}: {len(scn.simultaneous.surfaces)} surfaces together "
            f"({scn.simultaneous.design}), {result.steps_simulated} steps in "
            f"{result.wall_s:.2f} s -> {result.out_dir}"
        )
        if result.crosstalk:
            print(result.table())
        return 0

    return simulating(job, str(args.scenario), scn.model)


def _run_manoeuvre(scn: Any, args: argparse.Namespace) -> int:
    """``probing run`` of a ``[manoeuvre]`` scenario: ``manoeuvre.parquet``, the probing
    output period by period with its single-pulse truth (so ``--truth`` adds nothing)."""
    from probing.experiment.studies.manoeuvre import run_manoeuvre

    def job() -> int:
        result = run_manoeuvre(scn, args.out, progress=None)
        worst = ", ".join(
            f"{c} {100 * e[scn.settle_periods :].max():.1f} %" for c, e in result.errors.items()
        )
        print(
            f"{scn.name}: {scn.periods} periods through a {scn.manoeuvre.hold} manoeuvre, "
            f"{result.steps_simulated} steps in {result.wall_s:.2f} s -> {result.out_dir}; "
            f"largest error against the single pulse after settling: {worst}"
        )
        return 0

    return simulating(job, str(args.scenario), scn.model)


#: ``probing run``'s handler of each runner but the steady one
#: (:data:`probing.experiment.flight.runners.RUNNERS`): ``handler(scn, args)``, the exit code.
RUN_HANDLERS: dict[str, Callable[[Any, argparse.Namespace], int]] = {
    "simultaneous": _run_simultaneous,
    "manoeuvre": _run_manoeuvre,
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
        from probing.experiment.flight.monitor import monitor_scenario

        result = monitor_scenario(scn, args.out, timeseries=args.timeseries)
        print(f"{scn.name}: {result.line()} -> {result.out_dir / 'monitor.parquet'}")
        return 0

    return simulating(job, str(args.scenario), scn.model)


#: What a log that is not a flight's own needs (``probing monitor --replay`` without a map).
NEEDS_MAP = (
    "a log recorded elsewhere (CSV or Parquet) needs its scenario and --map MAP (docs/formats.md)"
)


def _replay(args: argparse.Namespace) -> int:
    """``probing monitor --replay LOG``: the monitor recomputed from a flight's log."""
    from probing.experiment.flight.monitor import (
        NotAFlightLog,
        ReplayError,
        logged_scenario,
        replay_monitor,
    )
    from probing.experiment.output.storage import StoredFileError, read_footer

    if args.timeseries:
        raise UsageError("monitor --replay: a log has no timeseries to write")
    table = None if args.map is None else _foreign(args)
    try:
        meta = read_footer(args.replay) if table is None else table.schema.metadata
        scn, _ = logged_scenario(args.replay, meta, table)
    except (ReplayError, StoredFileError) as exc:
        foreign = isinstance(exc, NotAFlightLog) or (
            isinstance(exc, StoredFileError) and args.replay.is_file()
        )
        hint = f"; {NEEDS_MAP}" if foreign and args.map is None else ""
        raise UsageError(f"{exc}{hint}") from None
    check_run_folder(args.out, scn)

    def job() -> int:
        from probing.experiment.output.staging import staged_output

        folder = args.out / scn.name
        with staged_output(folder) as staging:  # an interrupt at any moment leaves nothing
            result = replay_monitor(args.replay, args.out, table=table, folder=staging)
        print(f"{scn.name} (replayed): {result.line()} -> {folder / 'monitor.parquet'}")
        return 0

    return simulating(job, str(args.replay))


def _foreign(args: argparse.Namespace) -> Any:
    """``--replay LOG --map MAP`` with a scenario: the log recorded elsewhere, translated
    (:func:`probing.experiment.recorded.foreign_log.foreign_log`; UsageError)."""
    from probing.experiment.flight.monitor import ReplayError
    from probing.experiment.recorded.foreign_log import foreign_log, read_map

    scn = _one_surface(scenario_arg(args.scenario), args.scenario, "monitor")
    try:
        return foreign_log(args.replay, read_map(args.map), scn)
    except ReplayError as exc:
        raise UsageError(str(exc)) from None


def register(sub: Subcommands) -> None:
    """Add ``run``, ``truth`` and ``monitor`` to ``sub``."""
    run = command(
        sub, "run", "simulate a scenario and write probing.parquet and timeseries.parquet"
    )
    _scenario_arguments(run)
    run.add_argument(
        "--truth", action="store_true", help="also write truth.parquet and prediction.parquet"
    )
    run.set_defaults(func=_cmd_run)

    truth = command(
        sub,
        "truth",
        "ground truth of a scenario: single-pulse and linearised pulse responses "
        "(truth.parquet) and the probing output they predict (prediction.parquet)",
    )
    _scenario_arguments(truth)
    truth.set_defaults(func=_cmd_truth)

    monitor = command(
        sub,
        "monitor",
        "fly a scenario probing continuously; after every period a change detector writes "
        "monitor.parquet (docs/monitoring.md)",
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
