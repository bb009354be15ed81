"""``probing excitations``: the PRBS, a multisine and a chirp on one budget through the Fig. 4
nonlinearities (``docs/excitations.md``): runs, tables and figures."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from probing.cli.common import (
    Subcommands,
    UsageError,
    command,
    out_file,
    out_folder,
    path_arg,
    simulating,
)
from probing.cli.fig4 import BOUNDS_HELP


def _cmd_excitations(args: argparse.Namespace) -> int:
    from probing.experiment.scenario import ScenarioError
    from probing.experiment.studies.excitations import planned, run_study

    t_start = time.perf_counter()
    if args.figures is None:
        args.figures = args.out / "figures"
    if args.summary is None:
        args.summary = args.out / "summary.md"
    try:
        runs = planned(args.scenarios, args.out)  # every scenario valid before anything runs
    except ScenarioError as exc:
        raise UsageError(str(exc)) from None
    out_folder(args.out, "--out")
    out_file(args.out / "manifest.json", "--out")
    for r in runs:
        out_folder(r["folder"] / r["scenario"].name, "--out")
    out_folder(args.figures, "--figures")
    out_file(args.summary, "--summary")
    if args.monitor is not None and not any(args.monitor.glob("monitor-*/summary.parquet")):
        raise UsageError(
            f"--monitor: {args.monitor}: no monitor sweep in it (monitor-*/summary.parquet); "
            "fly scenarios/excitations/*.toml with probing sweep first"
        )

    def job() -> int:
        print(f"probing excitations: {args.scenarios} -> {args.out}")
        run_study(args.scenarios, args.out, jobs=args.jobs)
        return _finish(args, t_start)

    return simulating(job, str(args.scenarios))


def _finish(args: argparse.Namespace, t_start: float) -> int:
    from probing.analysis import excitations, excitations_plots
    from probing.experiment.output.storage import StoredFileError

    study = excitations.collect(args.out)
    monitor = None
    if args.monitor is not None:
        from probing.analysis.excitation_monitor import monitor_table

        try:
            monitor = monitor_table(args.monitor)
        except (FileNotFoundError, StoredFileError) as exc:
            raise UsageError(f"--monitor: {exc}") from None
    text = excitations.summary_markdown(study, monitor)
    args.summary.parent.mkdir(parents=True, exist_ok=True)
    args.summary.write_text(text)
    for p in excitations_plots.draw(study, args.figures, bounds=args.bounds):
        print(f"figure -> {p}")
    print(f"summary -> {args.summary}")
    print(f"wall time {time.perf_counter() - t_start:.1f} s")
    return 0


def register(sub: Subcommands) -> None:
    """Add ``excitations`` to ``sub``."""
    exc = command(
        sub,
        "excitations",
        "the PRBS, a multisine and a chirp on one budget through the Fig. 4 nonlinearities, "
        "on the GTM and the 737: runs, tables and figures (docs/excitations.md)",
        [
            "probing excitations -j 2   # into results/excitations/",
            "probing excitations --out results/excitations --monitor results/excitations/monitor "
            "--figures figures --summary docs/excitations_summary.md   # what make excitations "
            "runs",
        ],
    )
    exc.add_argument(
        "--scenarios", type=path_arg, default=Path("scenarios"), help="folder of the Fig. 4 sets"
    )
    exc.add_argument(
        "--out", type=path_arg, default=Path("results/excitations"), help="results folder"
    )
    exc.add_argument(
        "--figures",
        type=path_arg,
        default=None,
        help="figure folder (default: OUT/figures; the committed ones: figures)",
    )
    exc.add_argument(
        "--summary",
        type=path_arg,
        default=None,
        help="the tables, as markdown (default: OUT/summary.md; the committed one: "
        "docs/excitations_summary.md)",
    )
    exc.add_argument(
        "--monitor",
        type=path_arg,
        default=None,
        help="results of the sweeps in scenarios/excitations (their table joins the summary)",
    )
    exc.add_argument("--bounds", action="store_true", help=BOUNDS_HELP)
    exc.add_argument("-j", "--jobs", type=int, default=None, help="runs at once (default: cores)")
    exc.set_defaults(func=_cmd_excitations)
