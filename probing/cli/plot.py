"""``probing plot``: figures and tables redrawn from stored Parquet, no simulation."""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from probing.cli.common import (
    Subcommands,
    UsageError,
    _out_file,
    _out_folder,
    _path,
    command,
)
from probing.cli.fig4 import _check_fig4_outputs, _finish_fig4
from probing.cli.sweep import _plot_sweep_folder


def _cmd_plot(args: argparse.Namespace) -> int:
    if args.target == "monitor":
        return _plot_monitor(args)
    if args.target == "simultaneous":
        return _plot_simultaneous(args)
    if args.target == "manoeuvres":
        return _plot_manoeuvres(args)
    if args.target == "sweep":
        figures = args.figures if args.figures is not None else args.results / "figures"
        _out_folder(figures, "--figures")
        _plot_sweep_folder(args.results, figures)
        return 0
    if args.figures is None:
        args.figures = Path("figures")
    _check_fig4_outputs(args.results, args, "RESULTS")  # summary.csv and .md go there
    return _finish_fig4(args.results, args, time.perf_counter())


def _plot_monitor(args: argparse.Namespace) -> int:
    """The monitor study's tables and figures from its stored flights."""
    from analysis.monitoring import evaluate, load_study, summary_markdown
    from analysis.monitoring_plots import draw_all

    return _plot_study(args, lambda path: evaluate(load_study(path)), summary_markdown, draw_all)


def _plot_simultaneous(args: argparse.Namespace) -> int:
    """The simultaneous designs' cross-talk tables and figures from their stored runs."""
    from analysis.simultaneous import draw, load_runs, summary_markdown

    return _plot_study(args, load_runs, summary_markdown, draw)


def _plot_manoeuvres(args: argparse.Namespace) -> int:
    """The manoeuvre study's table and figures from its stored runs."""
    from analysis.manoeuvres import draw, load_runs, summary_markdown

    return _plot_study(args, load_runs, summary_markdown, draw)


def _plot_study(
    args: argparse.Namespace,
    load: Callable[[Path], Any],
    summarise: Callable[[Any], str],
    draw: Callable[[Any, Path], list[Path]],
) -> int:
    """A study's summary (``--summary``) and figures (``--figures``) from the stored runs in
    RESULTS: ``load`` them (FileNotFoundError: none there), ``summarise`` and ``draw``."""
    if not args.results.is_dir():
        raise UsageError(f"RESULTS: {args.results} is not a folder")
    figures = args.figures if args.figures is not None else args.results / "figures"
    summary = args.summary if args.summary is not None else args.results / "summary.md"
    _out_folder(figures, "--figures")
    _out_file(summary, "--summary")
    from probing.experiment.storage import StoredFileError

    try:
        study = load(args.results)
    except (FileNotFoundError, StoredFileError) as exc:
        raise UsageError(str(exc)) from None
    text = summarise(study)
    summary.write_text(text)
    print(text)
    for path in draw(study, figures):
        print(f"figure -> {path}")
    print(f"summary -> {summary}")
    return 0


def register(sub: Subcommands) -> None:
    """Add ``plot`` to ``sub``."""
    plot = command(
        sub,
        "plot",
        "redraw the figures and tables of fig4, a sweep, or the monitor, simultaneous or "
        "manoeuvre study from stored Parquet (no simulation)",
    )
    plot.add_argument(
        "target",
        choices=["fig4", "sweep", "monitor", "simultaneous", "manoeuvres"],
        help="which figure set",
    )
    plot.add_argument(
        "results",
        type=_path,
        help="results folder written by `probing fig4`, a sweep folder (results/sweeps/NAME), "
        "or a study's folder (results/monitor, results/simultaneous, results/manoeuvres: "
        "make monitor, make simultaneous, make manoeuvres)",
    )
    plot.add_argument(
        "--figures",
        type=_path,
        default=None,
        help="figure folder (default: figures for fig4, RESULTS/figures for a sweep or a study)",
    )
    plot.add_argument(
        "--summary",
        type=_path,
        default=None,
        help="monitor, simultaneous, manoeuvres: write the study's tables to this file "
        "(default: RESULTS/summary.md)",
    )
    plot.add_argument(
        "--copy-summary", type=_path, default=None, help="fig4: also copy summary.md to this file"
    )
    plot.set_defaults(func=_cmd_plot)
