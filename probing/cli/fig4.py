"""``probing fig4``: the paper's Fig. 4, its runs, figures and summary."""

from __future__ import annotations

import argparse
import shutil
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

#: The help of ``--bounds`` (``probing fig4`` and ``probing plot fig4``).
BOUNDS_HELP = (
    "shade each estimate's 95%% confidence bounds over its settled periods (Student-t, "
    "per tap) in the panel and compensated figures"
)


def _cmd_fig4(args: argparse.Namespace) -> int:
    from probing.experiment.scenario import ScenarioError
    from probing.experiment.studies.fig4 import load_set, run_set

    t_start = time.perf_counter()
    scen_dir = args.scenarios
    try:
        load_set(scen_dir)  # every scenario valid before anything runs
    except ScenarioError as exc:
        raise UsageError(str(exc)) from None
    results = args.out if args.out is not None else Path("results") / scen_dir.resolve().name
    check_fig4_outputs(results, args)
    out_file(results / "manifest.json", "--out")
    _check_fig4_runs(scen_dir, results, args.force)

    def job() -> int:
        print(f"probing fig4: {scen_dir} -> {results}")
        run_set(scen_dir, results, force=args.force)
        return finish_fig4(results, args, t_start)

    return simulating(job, str(scen_dir))


def check_fig4_outputs(results: Path, args: argparse.Namespace, option: str = "--out") -> None:
    out_folder(results, option)
    for name in ("summary.csv", "summary.md"):
        out_file(results / name, option)
    out_folder(args.figures, "--figures")
    if args.copy_summary is not None:
        out_file(args.copy_summary, "--copy-summary")


def _check_fig4_runs(scen_dir: Path, results: Path, force: bool) -> None:
    """Every run folder of the set can be written, and (without ``--force``) every stored
    run that would be reused can be read."""
    from probing.experiment.output.storage import StoredFileError
    from probing.experiment.scenario import ScenarioError
    from probing.experiment.studies.fig4 import is_stored, planned_runs

    try:
        runs = planned_runs(scen_dir, results)
    except ScenarioError as exc:
        raise UsageError(str(exc)) from None
    for scn, folder in runs:
        out_folder(folder, "--out")
        if not force:
            try:
                is_stored(folder, scn)
            except StoredFileError as exc:
                raise UsageError(f"{exc}; delete it, or rerun with --force") from None


def finish_fig4(results: Path, args: argparse.Namespace, t_start: float) -> int:
    from probing.analysis import fig4, fig4_plots
    from probing.experiment.output.storage import StoredFileError

    try:
        data = fig4.collect(results)
    except (fig4.NotAFig4FolderError, StoredFileError) as exc:
        raise UsageError(str(exc)) from None
    paths = fig4_plots.draw(data, args.figures, data.set_name, bounds=args.bounds)
    text = fig4.write_summary(data, results)
    if args.copy_summary is not None:
        shutil.copyfile(results / "summary.md", args.copy_summary)
    print(text)
    for p in paths:
        print(f"figure -> {p}")
    print(f"summary -> {results / 'summary.csv'}, {results / 'summary.md'}")
    print(f"wall time {time.perf_counter() - t_start:.1f} s")
    return 0


def register(sub: Subcommands) -> None:
    """Add ``fig4`` to ``sub``."""
    fig4 = command(
        sub,
        "fig4",
        "reproduce the paper's Fig. 4: runs, figures and summary",
        [
            "probing fig4   # what make fig4 runs: results/fig4 and figures/",
            "probing fig4 --scenarios scenarios/fig4-737 --bounds",
        ],
    )
    fig4.add_argument(
        "--scenarios", type=path_arg, default=Path("scenarios/fig4"), help="scenario set folder"
    )
    fig4.add_argument(
        "--out", type=path_arg, default=None, help="results folder (default: results/<set folder>)"
    )
    fig4.add_argument("--figures", type=path_arg, default=Path("figures"), help="figure folder")
    fig4.add_argument("--force", action="store_true", help="simulate even if results are stored")
    fig4.add_argument(
        "--copy-summary", type=path_arg, default=None, help="also copy summary.md to this file"
    )
    fig4.add_argument("--bounds", action="store_true", help=BOUNDS_HELP)
    fig4.set_defaults(func=_cmd_fig4)
