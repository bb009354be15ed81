"""``probing plot``: figures and tables redrawn from stored Parquet, no simulation."""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from probing.cli.common import (
    Subcommands,
    UsageError,
    command,
    listing,
    out_file,
    out_folder,
    path_arg,
)
from probing.cli.fig4 import BOUNDS_HELP, check_fig4_outputs, finish_fig4
from probing.cli.sweep import plot_sweep_folder


def _cmd_plot(args: argparse.Namespace) -> int:
    target = PLOT_TARGETS[args.target]
    if args.bounds and args.target != "fig4":
        raise UsageError(f"--bounds: fig4 only, not {args.target}")
    if args.figures is None:
        args.figures = _default(target.figures, args.results)
    if args.summary is None and target.summary is not None:
        args.summary = _default(target.summary, args.results)
    return target.draw(args)


def _default(text: str, results: Path) -> Path:
    """A default folder or file as the help states it: ``RESULTS/...`` is under RESULTS."""
    if text.startswith("RESULTS/"):
        return results / text.removeprefix("RESULTS/")
    return Path(text)


def _plot_fig4(args: argparse.Namespace) -> int:
    """Fig. 4's figures, and its summary.csv and .md in RESULTS, from the stored runs."""
    check_fig4_outputs(args.results, args, "RESULTS")  # summary.csv and .md go there
    return finish_fig4(args.results, args, time.perf_counter())


def _plot_sweep(args: argparse.Namespace) -> int:
    """A sweep's figure (and a sweep over seeds' table) from its folder."""
    out_folder(args.figures, "--figures")
    plot_sweep_folder(args.results, args.figures)
    return 0


def _plot_monitor(args: argparse.Namespace) -> int:
    """The monitor study's tables and figures from its stored flights."""
    from probing.analysis.monitoring import evaluate, load_study, summary_markdown
    from probing.analysis.monitoring_plots import draw_all
    from probing.analysis.probe_only import probe_only_markdown

    def summary(flights: Any) -> str:
        return summary_markdown(flights) + probe_only_markdown(flights)

    return _plot_study(args, lambda path: evaluate(load_study(path)), summary, draw_all)


def _plot_simultaneous(args: argparse.Namespace) -> int:
    """The simultaneous designs' cross-talk tables and figures from their stored runs."""
    from probing.analysis.simultaneous import draw, load_runs, summary_markdown

    return _plot_study(args, load_runs, summary_markdown, draw)


def _plot_manoeuvres(args: argparse.Namespace) -> int:
    """The manoeuvre study's table and figures from its stored runs."""
    from probing.analysis.manoeuvres import draw, load_runs, summary_markdown

    return _plot_study(args, load_runs, summary_markdown, draw)


def _plot_references(args: argparse.Namespace) -> int:
    """The references study's table and figure from its stored flights."""
    from probing.analysis.references import draw, load_runs, summary_markdown

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
    figures, summary = args.figures, args.summary
    out_folder(figures, "--figures")
    out_file(summary, "--summary")
    from probing.experiment.output.storage import StoredFileError

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


@dataclass(frozen=True)
class PlotTarget:
    """A set of figures and tables ``probing plot TARGET RESULTS`` redraws from stored files.

    ``draw`` checks the outputs, reads RESULTS, draws and prints, and returns the exit code;
    ``args.figures`` and ``args.summary`` are set by then.  ``what`` names the set in the
    command's help, ``results`` says which folder RESULTS is; ``figures`` is the default
    figure folder and ``summary`` the default ``--summary`` file (None: no summary file to
    name), as the help states them (``RESULTS/...``: under RESULTS).
    """

    draw: Callable[[argparse.Namespace], int]
    what: str
    results: str
    figures: str = "RESULTS/figures"
    summary: str | None = None


#: ``probing plot``'s targets, in the order of its help; the parser's choices and help are
#: generated from it, so a new target is one entry here.
PLOT_TARGETS: dict[str, PlotTarget] = {
    "fig4": PlotTarget(
        _plot_fig4, "fig4", "the results folder written by `probing fig4`", figures="figures"
    ),
    "sweep": PlotTarget(_plot_sweep, "a sweep", "a sweep folder (results/sweeps/NAME)"),
    "monitor": PlotTarget(
        _plot_monitor,
        "the monitor study",
        "the study's folder (results/monitor: make monitor)",
        summary="RESULTS/summary.md",
    ),
    "references": PlotTarget(
        _plot_references,
        "the references study",
        "the study's folder (results/references: make references)",
        summary="RESULTS/summary.md",
    ),
    "simultaneous": PlotTarget(
        _plot_simultaneous,
        "the simultaneous study",
        "the study's folder (results/simultaneous: make simultaneous)",
        summary="RESULTS/summary.md",
    ),
    "manoeuvres": PlotTarget(
        _plot_manoeuvres,
        "the manoeuvre study",
        "the study's folder (results/manoeuvres: make manoeuvres)",
        summary="RESULTS/summary.md",
    ),
}


def _defaults(attribute: str) -> str:
    """Each default of a target's ``attribute`` with the targets it is theirs:
    ``figures for fig4; RESULTS/figures for sweep, monitor, ...``."""
    targets: dict[str, list[str]] = {}
    for name, target in PLOT_TARGETS.items():
        value = getattr(target, attribute)
        if value is not None:
            targets.setdefault(value, []).append(name)
    if len(targets) == 1:
        return next(iter(targets))
    return "; ".join(f"{value} for {', '.join(names)}" for value, names in targets.items())


def register(sub: Subcommands) -> None:
    """Add ``plot`` to ``sub``, its targets and their help from :data:`PLOT_TARGETS`."""
    whats = [target.what for target in PLOT_TARGETS.values()]
    plot = command(
        sub,
        "plot",
        f"redraw the figures and tables of {listing(whats, 'or')} from stored Parquet "
        "(no simulation)",
        [
            "probing plot fig4 results/fig4",
            "probing plot sweep results/sweeps/backlash-width   # into its figures/",
            "probing plot monitor results/monitor --figures results/monitor/figures",
        ],
    )
    plot.add_argument("target", choices=list(PLOT_TARGETS), help="which figure set")
    plot.add_argument(
        "results",
        type=path_arg,
        help="the folder read: "
        + "; ".join(f"{name}: {target.results}" for name, target in PLOT_TARGETS.items()),
    )
    plot.add_argument(
        "--figures",
        type=path_arg,
        default=None,
        help=f"figure folder (default: {_defaults('figures')})",
    )
    with_summary = [name for name, target in PLOT_TARGETS.items() if target.summary is not None]
    plot.add_argument(
        "--summary",
        type=path_arg,
        default=None,
        help=f"{', '.join(with_summary)}: write the study's tables to this file "
        f"(default: {_defaults('summary')})",
    )
    plot.add_argument(
        "--copy-summary",
        type=path_arg,
        default=None,
        help="fig4: also copy summary.md to this file",
    )
    plot.add_argument("--bounds", action="store_true", help=f"fig4: {BOUNDS_HELP}")
    plot.set_defaults(func=_cmd_plot)
