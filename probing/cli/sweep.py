"""``probing sweep``: a sweep file's points, in parallel and resumably."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from probing.cli.common import (
    Subcommands,
    UsageError,
    argument_usage,
    command,
    out_folder,
    path_arg,
    print_error,
)


def _cmd_sweep(args: argparse.Namespace) -> int:
    from probing.experiment.scenario import ScenarioError
    from probing.sweep import load_sweep

    try:
        sweep = load_sweep(args.sweep)
    except ScenarioError as exc:
        raise UsageError(str(exc)) from None
    out_folder(args.out, "--out")
    out_folder(args.out / sweep.name, "--out")
    figures = args.figures if args.figures is not None else args.out / sweep.name / "figures"
    if args.plot:
        out_folder(figures, "--figures")
    from probing.api import fly_sweep
    from probing.core.errors import ArgumentError
    from probing.sweep import SchedulerError, SweepBusyError

    try:
        result = fly_sweep(
            sweep,
            args.out,
            jobs=args.jobs,
            executor=args.executor,
            scheduler=args.scheduler,
            retry_failed=args.retry_failed,
            progress=True if sys.stderr.isatty() else "lines",
            connect_timeout_s=args.connect_timeout_s,
        )
    except ArgumentError as exc:
        raise argument_usage(exc, {"jobs": "-j/--jobs"}) from None
    except SchedulerError as exc:
        raise UsageError(str(exc)) from None
    except SweepBusyError as exc:
        return print_error(str(exc), 1)
    for message in result.messages:
        print(f"  {message}", file=sys.stderr)
    from probing.analysis.tables import sweep_table

    print(sweep_table(result.summary(), sweep.fields))
    print(result.line())
    if args.plot:
        plot_sweep_folder(result.folder, figures)
    return 1 if result.errors else 0


def plot_sweep_folder(folder: Path, figures: Path) -> None:
    """Draw a sweep's figure; for a sweep over seeds also print its measured/predicted table."""
    from probing.analysis.seeds import has_seeds, seed_statistics, seed_table
    from probing.analysis.sweep_plots import NotASweepError, load_sweep_data, plot_sweep

    try:
        paths = plot_sweep(folder, figures)
    except NotASweepError as exc:
        raise UsageError(str(exc)) from None
    for path in paths:
        print(f"wrote {path}")
    data = load_sweep_data(folder)
    if has_seeds(data):
        print("seed-to-seed scatter, measured / predicted (ratio):")
        print(seed_table(seed_statistics(data)))


def register(sub: Subcommands) -> None:
    """Add ``sweep`` to ``sub``."""
    sweep = command(
        sub,
        "sweep",
        "run a sweep file's points in parallel, resumably (docs/sweeps.md)",
        [
            "probing sweep scenarios/sweeps/backlash-width.toml --out results/sweeps -j 2",
            "probing sweep scenarios/sweeps/flight-grid.toml --executor dask",
        ],
    )
    sweep.add_argument("sweep", type=path_arg, help="sweep TOML file (scenarios/sweeps/*.toml)")
    sweep.add_argument(
        "--out", type=path_arg, default=Path("results/sweeps"), help="the sweep goes to OUT/<name>/"
    )
    sweep.add_argument(
        "-j", "--jobs", type=int, default=None, help="worker processes (default: one per core)"
    )
    sweep.add_argument(
        "--executor", choices=["local", "dask"], default="local", help="local pool or Dask"
    )
    sweep.add_argument(
        "--scheduler",
        default=None,
        help="address of an existing Dask scheduler (tcp://host:8786); without it, "
        "--executor dask starts a LocalCluster",
    )
    sweep.add_argument(
        "--connect-timeout-s",
        type=float,
        default=10.0,
        help="how long to wait for --scheduler before giving up (exit 2)",
    )
    sweep.add_argument(
        "--retry-failed", action="store_true", help="run again the points recorded as failed"
    )
    sweep.add_argument("--plot", action="store_true", help="draw the sweep's figure afterwards")
    sweep.add_argument(
        "--figures",
        type=path_arg,
        default=None,
        help="figure folder (default: OUT/<name>/figures)",
    )
    sweep.set_defaults(func=_cmd_sweep)
