"""The ``probing`` command line: ``run``, ``truth``, ``sweep``, ``fig4``, ``plot``, ``design``.

Errors a user can fix (a wrong scenario, a failed trim, a divergence) are
printed as one line on stderr, with exit code 2 for bad input and 1 for a run
that failed; no traceback.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

__all__ = ["main"]


def _error(message: str, code: int) -> int:
    print(f"probing: error: {message}", file=sys.stderr)
    return code


def _simulate(args: argparse.Namespace, job) -> int:
    """Validate the scenario (exit 2), then run ``job(scn)`` (exit 1 on trim failure or
    divergence); ``job`` returns the line to print."""
    from probing.scenario import ScenarioError, load_scenario

    try:
        scn = load_scenario(args.scenario)
    except ScenarioError as exc:
        return _error(str(exc), 2)
    from probing.plant import DivergenceError, TrimError  # heavy imports after validation

    try:
        print(job(scn))
    except (TrimError, DivergenceError) as exc:
        return _error(f"{args.scenario}: {exc}", 1)
    return 0


def _truth_line(scn, out: Path) -> str:
    from probing.truth import compute_truth

    return f"{scn.name}: ground truth -> {compute_truth(scn, out)}"


def _cmd_run(args: argparse.Namespace) -> int:
    def job(scn) -> str:
        from probing.run import run_scenario

        result = run_scenario(scn, args.out, progress=None)
        line = (
            f"{scn.name}: {scn.periods} periods, {result.steps_simulated} steps in "
            f"{result.wall_s:.2f} s -> {result.out_dir}"
        )
        if args.truth:
            _truth_line(scn, args.out)
        return line

    return _simulate(args, job)


def _cmd_truth(args: argparse.Namespace) -> int:
    return _simulate(args, lambda scn: _truth_line(scn, args.out))


def _cmd_sweep(args: argparse.Namespace) -> int:
    from probing.scenario import ScenarioError
    from probing.sweep import load_sweep

    if args.jobs is not None and args.jobs < 1:
        return _error(f"-j/--jobs: must be an integer >= 1, got {args.jobs}", 2)
    if args.scheduler and args.executor != "dask":
        return _error("--scheduler: only with --executor dask", 2)
    try:
        sweep = load_sweep(args.sweep)
    except ScenarioError as exc:
        return _error(str(exc), 2)
    from probing.sweep import SweepBusyError, run_sweep  # heavy imports after validation

    try:
        result = run_sweep(
            sweep,
            args.out,
            jobs=args.jobs,
            executor=args.executor,
            scheduler=args.scheduler,
            retry_failed=args.retry_failed,
        )
    except SweepBusyError as exc:
        return _error(str(exc), 1)
    except OSError as exc:  # e.g. no Dask scheduler at the address
        return _error(f"{args.sweep}: {exc.__class__.__name__}: {exc}", 1)
    for message in result.messages:
        print(f"  {message}", file=sys.stderr)
    print(result.line())
    code = 1 if result.errors else 0
    if args.plot:
        from analysis.sweep_plots import plot_sweep

        for path in plot_sweep(result.folder, args.figures):
            print(f"wrote {path}")
    return code


def _cmd_fig4(args: argparse.Namespace) -> int:
    try:
        from analysis.fig4 import main as fig4_main
    except ImportError:
        print(
            "probing fig4: not yet: the Fig. 4 reproduction lands with issue [3/6]", file=sys.stderr
        )
        return 3
    return fig4_main(args)


def _cmd_plot(args: argparse.Namespace) -> int:
    if args.target == "sweep":
        from analysis.sweep_plots import plot_main as sweep_plot_main

        return sweep_plot_main(args)
    from analysis.fig4 import plot_main

    return plot_main(args)


def _cmd_design(args: argparse.Namespace) -> int:
    from probing.design import main as design_main

    return design_main(args)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for documentation and tests)."""
    parser = argparse.ArgumentParser(prog="probing", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="simulate a scenario and write Parquet")
    run.add_argument("scenario", type=Path, help="scenario TOML file")
    run.add_argument("--out", type=Path, default=Path("results"), help="output folder")
    run.add_argument("--truth", action="store_true", help="also compute the ground truth")
    run.set_defaults(func=_cmd_run)

    truth = sub.add_parser(
        "truth", help="small-signal pulse response by single pulse and linearisation"
    )
    truth.add_argument("scenario", type=Path)
    truth.add_argument("--out", type=Path, default=Path("results"))
    truth.set_defaults(func=_cmd_truth)

    sweep = sub.add_parser(
        "sweep", help="run a sweep file's points in parallel, resumably (see docs/sweeps.md)"
    )
    sweep.add_argument("sweep", type=Path, help="sweep TOML file (scenarios/sweeps/*.toml)")
    sweep.add_argument(
        "--out",
        type=Path,
        default=Path("results/sweeps"),
        help="results root (default %(default)s)",
    )
    sweep.add_argument(
        "-j", "--jobs", type=int, default=None, help="worker processes (default: one per core)"
    )
    sweep.add_argument(
        "--executor", choices=["local", "dask"], default="local", help="local pool or Dask"
    )
    sweep.add_argument(
        "--scheduler", default=None, help="address of an existing Dask scheduler (tcp://...)"
    )
    sweep.add_argument(
        "--retry-failed", action="store_true", help="run again the points recorded as failed"
    )
    sweep.add_argument("--plot", action="store_true", help="draw the sweep's figure afterwards")
    sweep.add_argument("--figures", type=Path, default=Path("figures"), help="figure folder")
    sweep.set_defaults(func=_cmd_sweep)

    fig4 = sub.add_parser("fig4", help="reproduce the paper's Fig. 4")
    fig4.add_argument(
        "--out", type=Path, default=None, help="results folder (default results/<set folder>)"
    )
    fig4.add_argument(
        "--scenarios", type=Path, default=Path("scenarios/fig4"), help="scenario set folder"
    )
    fig4.add_argument("--figures", type=Path, default=Path("figures"), help="figure folder")
    fig4.add_argument("--force", action="store_true", help="simulate even if results are stored")
    fig4.add_argument("--copy-summary", type=Path, default=None, help="also copy summary.md here")
    fig4.set_defaults(func=_cmd_fig4)

    plot = sub.add_parser("plot", help="redraw figures from stored Parquet (no simulation)")
    plot.add_argument("target", choices=["fig4", "sweep"], help="which figure set")
    plot.add_argument(
        "results",
        type=Path,
        help="results folder written by `probing fig4`, or a sweep folder (results/sweeps/NAME)",
    )
    plot.add_argument("--figures", type=Path, default=Path("figures"), help="figure folder")
    plot.add_argument("--copy-summary", type=Path, default=None, help="also copy summary.md here")
    plot.set_defaults(func=_cmd_plot)

    from probing.design import add_arguments as add_design_arguments

    design = sub.add_parser(
        "design", help="recommend order, bit duration and amplitude for a probing experiment"
    )
    add_design_arguments(design)
    design.set_defaults(func=_cmd_design)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``probing`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except KeyboardInterrupt:
        return _error("interrupted", 130)
