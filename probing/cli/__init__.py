"""The probing command line: run, truth, monitor, sweep, fig4, plot, design, modes, gtm-damage.

Exit codes: 0 success; 2 bad input (a scenario, sweep or option that is refused, an output
folder or file that cannot be written, a Dask scheduler that does not answer), with one line
on stderr (argparse's own errors too) and nothing written: every output folder and file is
checked before any work (:func:`probing.experiment.storage.check_output_folder` and
:func:`~probing.experiment.storage.check_output_file`); 1 a run that failed (trim failure,
divergence), a sweep with failed points or a sweep folder in use by another process; 130
interrupted (Ctrl-C), 143 terminated (SIGTERM), after the same clean-up.
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any, NoReturn

from probing.core.forked import INTERRUPTS

__all__ = ["build_parser", "main"]

#: The top-level help's text; the commands are listed by argparse, from the parser itself.
DESCRIPTION = (
    "Pulse-compression probing of aircraft dynamics through hard input nonlinearities, on JSBSim."
)
EPILOG = """\
exit codes: 0 success; 2 bad input (one line on stderr, nothing written); 1 a run that
failed (trim failure, divergence) or a sweep folder in use; 130 interrupted; 143
terminated (SIGTERM).
See README.md and docs/ for the formats and the method."""


class UsageError(Exception):
    """Bad input found by a command: printed as one line, exit code 2."""


def _error(message: str, code: int) -> int:
    print(f"probing: error: {message}", file=sys.stderr)
    return code


def _out_folder(path: Path, option: str) -> Path:
    """``path`` after :func:`probing.experiment.storage.check_output_folder` (UsageError)."""
    from probing.experiment.storage import OutputPathError, check_output_folder

    try:
        return check_output_folder(path, option)
    except OutputPathError as exc:
        raise UsageError(str(exc)) from None


def _out_file(path: Path, option: str) -> Path:
    """``path`` after :func:`probing.experiment.storage.check_output_file` (UsageError)."""
    from probing.experiment.storage import OutputPathError, check_output_file

    try:
        return check_output_file(path, option)
    except OutputPathError as exc:
        raise UsageError(str(exc)) from None


def _run_folder(out: Path, scn: Any) -> None:
    """``--out`` and the run's own folder in it, ``OUT/<scenario name>`` (UsageError)."""
    _out_folder(out, "--out")
    _out_folder(out / scn.name, "--out")


def _load_scenario(path: Path) -> Any:
    from probing.experiment.scenario import ScenarioError, load_scenario

    try:
        return load_scenario(path)
    except ScenarioError as exc:
        raise UsageError(str(exc)) from None


def _simulating(job: Callable[[], int], where: str) -> int:
    """Run ``job``; a trim failure or divergence is one line and exit code 1."""
    from probing.sim.errors import DivergenceError, TrimError

    try:
        return job()
    except (TrimError, DivergenceError) as exc:
        return _error(f"{where}: {exc}", 1)


# ------------------------------------------------------------------ run, truth
def _cmd_run(args: argparse.Namespace) -> int:
    scn = _load_scenario(args.scenario)
    _run_folder(args.out, scn)
    if scn.simultaneous is not None:
        return _run_simultaneous(scn, args)
    if scn.manoeuvre is not None:
        return _run_manoeuvre(scn, args)

    def job() -> int:
        from probing.experiment.run import run_scenario
        from probing.experiment.truth import TruthFiles

        truth = TruthFiles(scn) if args.truth else None  # one run's files: run and truth
        result = run_scenario(scn, args.out, progress=None, observer=truth)
        print(
            f"{scn.name}: {scn.periods} periods, {result.steps_simulated} steps in "
            f"{result.wall_s:.2f} s -> {result.out_dir}"
        )
        if args.truth:
            print(f"{scn.name}: ground truth -> {result.out_dir / 'truth.parquet'}")
        return 0

    return _simulating(job, str(args.scenario))


def _run_simultaneous(scn: Any, args: argparse.Namespace) -> int:
    """``probing run`` of a ``[simultaneous]`` scenario: ``responses.parquet``; with
    ``--truth`` each surface is flown alone too and the measured cross-talk printed."""
    from probing.experiment.simultaneous import SeparationError, run_simultaneous

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

    return _simulating(job, str(args.scenario))


def _run_manoeuvre(scn: Any, args: argparse.Namespace) -> int:
    """``probing run`` of a ``[manoeuvre]`` scenario: ``manoeuvre.parquet``, the probing
    output period by period with its single-pulse truth (so ``--truth`` adds nothing)."""
    from probing.experiment.manoeuvre import run_manoeuvre

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

    return _simulating(job, str(args.scenario))


def _print_truth(scn: Any, out: Path) -> None:
    from probing.experiment.truth import compute_truth

    print(f"{scn.name}: ground truth -> {compute_truth(scn, out)}")


def _one_surface(scn: Any, path: Path, command: str) -> Any:
    """``scn``, unless it probes several surfaces ([simultaneous]: ``probing run`` flies it)."""
    if scn.simultaneous is not None:
        raise UsageError(
            f"{path}: probing {command} takes one probed surface; a [simultaneous] scenario "
            f"is flown by probing run (its --truth flies each surface alone)"
        )
    if scn.manoeuvre is not None:
        raise UsageError(
            f"{path}: probing {command} flies a steady condition; a [manoeuvre] scenario is "
            f"flown by probing run (with its single-pulse truth along the manoeuvre)"
        )
    return scn


def _cmd_truth(args: argparse.Namespace) -> int:
    scn = _one_surface(_load_scenario(args.scenario), args.scenario, "truth")
    _run_folder(args.out, scn)

    def job() -> int:
        _print_truth(scn, args.out)
        return 0

    return _simulating(job, str(args.scenario))


def _cmd_monitor(args: argparse.Namespace) -> int:
    from probing.experiment.scenario import ScenarioError

    scn = _one_surface(_load_scenario(args.scenario), args.scenario, "monitor")
    try:
        scn.monitor_settings()
    except ScenarioError as exc:
        raise UsageError(f"{args.scenario}: {exc}") from None
    _run_folder(args.out, scn)

    def job() -> int:
        from probing.experiment.monitor import monitor_scenario

        result = monitor_scenario(scn, args.out, timeseries=args.timeseries)
        print(f"{scn.name}: {result.line()} -> {result.run.out_dir / 'monitor.parquet'}")
        return 0

    return _simulating(job, str(args.scenario))


# ------------------------------------------------------------------ sweep
def _cmd_sweep(args: argparse.Namespace) -> int:
    from probing.experiment.scenario import ScenarioError
    from probing.sweep import load_sweep

    if args.jobs is not None and args.jobs < 1:
        raise UsageError(f"-j/--jobs: must be an integer >= 1, got {args.jobs}")
    if args.scheduler and args.executor != "dask":
        raise UsageError("--scheduler: only with --executor dask")
    if not args.connect_timeout_s > 0:
        raise UsageError(f"--connect-timeout-s: must be > 0, got {args.connect_timeout_s:g}")
    try:
        sweep = load_sweep(args.sweep)
    except ScenarioError as exc:
        raise UsageError(str(exc)) from None
    _out_folder(args.out, "--out")
    _out_folder(args.out / sweep.name, "--out")
    figures = args.figures if args.figures is not None else args.out / sweep.name / "figures"
    if args.plot:
        _out_folder(figures, "--figures")
    from probing.sweep import SchedulerError, SweepBusyError, run_sweep

    try:
        result = run_sweep(
            sweep,
            args.out,
            jobs=args.jobs,
            executor=args.executor,
            scheduler=args.scheduler,
            retry_failed=args.retry_failed,
            connect_timeout_s=args.connect_timeout_s,
        )
    except SchedulerError as exc:
        raise UsageError(str(exc)) from None
    except SweepBusyError as exc:
        return _error(str(exc), 1)
    for message in result.messages:
        print(f"  {message}", file=sys.stderr)
    from analysis.tables import sweep_table
    from probing.sweep import read_summary

    print(sweep_table(read_summary(result.folder), sweep.fields))
    print(result.line())
    if args.plot:
        _plot_sweep_folder(result.folder, figures)
    return 1 if result.errors else 0


def _plot_sweep_folder(folder: Path, figures: Path) -> None:
    """Draw a sweep's figure; for a sweep over seeds also print its measured/predicted table."""
    from analysis.seeds import has_seeds, seed_statistics, seed_table
    from analysis.sweep_plots import NotASweepError, load_sweep_data, plot_sweep

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


# ------------------------------------------------------------------ fig4, plot
def _cmd_fig4(args: argparse.Namespace) -> int:
    from probing.experiment.fig4 import load_set, run_set
    from probing.experiment.scenario import ScenarioError

    t_start = time.perf_counter()
    scen_dir = args.scenarios
    try:
        load_set(scen_dir)  # every scenario valid before anything runs
    except ScenarioError as exc:
        raise UsageError(str(exc)) from None
    results = args.out if args.out is not None else Path("results") / scen_dir.resolve().name
    _check_fig4_outputs(results, args)
    _out_file(results / "manifest.json", "--out")
    _check_fig4_runs(scen_dir, results, args.force)
    print(f"probing fig4: {scen_dir} -> {results}")

    def job() -> int:
        run_set(scen_dir, results, force=args.force)
        return _finish_fig4(results, args, t_start)

    return _simulating(job, str(scen_dir))


def _check_fig4_outputs(results: Path, args: argparse.Namespace, option: str = "--out") -> None:
    _out_folder(results, option)
    for name in ("summary.csv", "summary.md"):
        _out_file(results / name, option)
    _out_folder(args.figures, "--figures")
    if args.copy_summary is not None:
        _out_file(args.copy_summary, "--copy-summary")


def _check_fig4_runs(scen_dir: Path, results: Path, force: bool) -> None:
    """Every run folder of the set can be written, and (without ``--force``) every stored
    run that would be reused can be read."""
    from probing.experiment.fig4 import is_stored, planned_runs
    from probing.experiment.scenario import ScenarioError
    from probing.experiment.storage import StoredFileError

    try:
        runs = planned_runs(scen_dir, results)
    except ScenarioError as exc:
        raise UsageError(str(exc)) from None
    for scn, folder in runs:
        _out_folder(folder, "--out")
        if not force:
            try:
                is_stored(folder, scn)
            except StoredFileError as exc:
                raise UsageError(f"{exc}; delete it, or rerun with --force") from None


def _finish_fig4(results: Path, args: argparse.Namespace, t_start: float) -> int:
    from analysis import fig4, fig4_plots
    from probing.experiment.storage import StoredFileError

    try:
        data = fig4.collect(results)
    except (fig4.NotAFig4FolderError, StoredFileError) as exc:
        raise UsageError(str(exc)) from None
    paths = fig4_plots.draw(data, args.figures, data.set_name)
    text = fig4.write_summary(data, results)
    if args.copy_summary is not None:
        shutil.copyfile(results / "summary.md", args.copy_summary)
    print(text)
    for p in paths:
        print(f"figure -> {p}")
    print(f"summary -> {results / 'summary.csv'}, {results / 'summary.md'}")
    print(f"wall time {time.perf_counter() - t_start:.1f} s")
    return 0


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


# ------------------------------------------------------------------ design
def _cmd_design(args: argparse.Namespace) -> int:
    if args.simultaneous is not None:
        return _check_simultaneous(args.simultaneous)
    missing = [o for o in ("aircraft", "altitude_ft", "speed_kcas") if getattr(args, o) is None]
    if missing:
        options = ", ".join("--" + o.replace("_", "-") for o in missing)
        raise UsageError(f"design: {options} required (or --simultaneous SCENARIO)")
    from probing.experiment.design import (
        DesignError,
        DesignInputError,
        DesignRequest,
        recommend,
    )
    from probing.experiment.storage import strict_json

    request = DesignRequest(
        aircraft=args.aircraft,
        altitude_ft=args.altitude_ft,
        speed_kcas=args.speed_kcas,
        dt_s=args.dt_s,
        deadband_deg=tuple(args.deadband_deg) if args.deadband_deg else None,
        saturation_deg=tuple(args.saturation_deg) if args.saturation_deg else None,
        rate_limit_deg_s=args.rate_limit_deg_s,
        noise_sigma=args.noise_sigma,
        turbulence=args.turbulence,
        channel=args.channel,
        estimator=args.estimator,
        target_gain_se=args.target_gain_se,
        detect_gain_change=args.detect_gain_change,
        false_alarm=args.false_alarm,
        detection_probability=args.detection_probability,
        target_h_se=args.target_h_se,
        amplitude_deg=args.amplitude_deg,
        deadband_margin=args.deadband_margin,
        settle_periods=args.settle_periods,
        calibration_seeds=args.calibration_seeds,
    )

    def job() -> int:
        try:
            d, modes, _ = recommend(request)
        except DesignInputError as exc:
            raise UsageError(str(exc)) from None
        except DesignError as exc:
            if args.json:
                print(strict_json({"feasible": False, "reason": str(exc)}, sort_keys=False))
            return _error(f"infeasible: {exc}", 2)
        if args.json:
            payload = {"feasible": True, **asdict(d), "modes": _modes_dict(modes)}
            print(strict_json(payload, indent=2, sort_keys=False))
            return 0
        print(
            f"{args.aircraft} at {args.altitude_ft:g} ft, {args.speed_kcas:g} kcas: short period "
            f"wn = {modes.sp_wn:.3g} rad/s, zeta = {modes.sp_zeta:.3g}; phugoid wn = "
            f"{modes.ph_wn:.3g} rad/s, zeta = {modes.ph_zeta:.3g}"
        )
        print(_design_table(d))
        return 0

    return _simulating(job, f"--aircraft {args.aircraft}")


def _check_simultaneous(path: Path) -> int:
    """``probing design --simultaneous``: the design's memory condition, or its refusal."""
    from probing.experiment.simultaneous import SeparationError, check_separation

    scn = _load_scenario(path)
    if scn.simultaneous is None:
        raise UsageError(f"{path}: has no [simultaneous] section")

    def job() -> int:
        try:
            check = check_separation(scn)
        except SeparationError as exc:
            raise UsageError(f"{path}: {exc}") from None
        if not check.ok:
            raise UsageError(f"{path}: {check.refusal()}")
        layout = check.layout
        print(
            f"{scn.name}: {layout.design} design, {layout.surfaces} surfaces, "
            f"{layout.window_bits} taps each, {layout.total_periods} periods flown"
        )
        print(check.table())
        return 0

    return _simulating(job, str(path))


def _modes_dict(modes: Any) -> dict[str, float]:
    return {k: getattr(modes, k) for k in ("sp_wn", "sp_zeta", "ph_wn", "ph_zeta")}


def _design_table(d: Any) -> str:
    from analysis.tables import fmt
    from probing.sim.channels import unit_of

    unit = unit_of(d.channel)
    rows = [
        ("order", f"{d.order} (M = {d.bits_per_period})", d.reasons["order"]),
        ("bit_duration_s", f"{d.bit_duration_s:g}", d.reasons["bit_duration_s"]),
        ("amplitude_deg", f"{d.amplitude_deg:.4g}", d.reasons["amplitude_deg"]),
        ("estimator", d.estimator, d.reasons["estimator"]),
        ("periods", f"{d.periods} ({d.settle_periods} settling)", d.reasons["periods"]),
    ]
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    lines = [f"{'parameter':<{w0}}  {'value':<{w1}}  reason"]
    lines += [f"{a:<{w0}}  {b:<{w1}}  {c}" for a, b, c in rows]
    lines.append(
        f"predicted on {d.channel} (seed-to-seed): gain se {fmt(d.predicted_gain_stderr, 3)}, "
        f"h se {fmt(d.predicted_h_stderr, 3)} {unit}/deg, z se {fmt(d.predicted_z_stderr, 3)} "
        f"{unit}; bias of h (slow modes) {fmt(d.predicted_h_bias, 3)} {unit}/deg"
    )
    lines += [f"warning: {w}" for w in d.warnings]
    lines += [
        "",
        "scenario (probing design ... --json gives it as scenario_toml):",
        d.scenario_toml,
    ]
    return "\n".join(lines)


# ------------------------------------------------------------------ modes
def _cmd_modes(args: argparse.Namespace) -> int:
    _out_file(args.docs, "--docs")
    _out_file(args.figure.with_name(f"{args.figure.name}.png"), "--figure")

    def job() -> int:
        from analysis import gtm_modes
        from probing.experiment.modes import damage_table, mode_table

        points = mode_table()
        damage = damage_table()
        print(gtm_modes.mode_table(points))
        for p in points:
            if p.modes is not None:
                eigs = ", ".join(f"{e:.4f}" for e in p.modes.eigenvalues)
                print(f"{p.ve_kts:.0f} kt eigenvalues: {eigs}")
        print(gtm_modes.damage_level_table(damage))
        gtm_modes.write_doc(points, args.docs, damage)
        (path,) = gtm_modes.save(points, args.figure)
        print(f"wrote {args.docs} and {path}")
        return 0

    return _simulating(job, "gtm_t2")


def _cmd_gtm_damage(args: argparse.Namespace) -> int:
    _out_folder(args.out, "--out")
    _out_file(args.out / "summary.csv", "--out")
    _out_folder(args.figures, "--figures")

    def job() -> int:
        from analysis import gtm_damage
        from probing.experiment.gtm_damage import run_example6

        run_example6(args.out)
        cases = gtm_damage.load(args.out)
        table = gtm_damage.summary(cases)
        table.to_csv(args.out / "summary.csv", index=False)
        trim = gtm_damage.trim_table(cases)
        trim.to_csv(args.out / "trim.csv", index=False)
        paths = gtm_damage.draw(cases, args.figures)
        print(trim.set_index("trim").T.to_string())
        cols = ["case", "name", "phi_deg_end", "beta_deg_min", "beta_deg_max", "r_deg_s_end"]
        print(table[cols].to_string(index=False))
        for path in paths:
            print(f"figure -> {path}")
        print(f"summary -> {args.out / 'summary.csv'}, trim -> {args.out / 'trim.csv'}")
        return 0

    return _simulating(job, "gtm_t2")


# ------------------------------------------------------------------ parser
class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line, ``probing: error: ...``, exit code 2
    (argparse prints the whole usage first); its subcommands' parsers are of this class."""

    def error(self, message: str) -> NoReturn:
        """Print ``message`` as the command's one-line error and exit with code 2."""
        self.exit(2, f"probing: error: {' '.join(message.split())}\n")


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """States an option's default after its help, unless the help states it already, the
    default is None (nothing to say) or False (a flag that is off)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (
            "(default" in text
            or default is None
            or default is False
            or default == argparse.SUPPRESS
        ):
            return text
        return super()._get_help_string(action)


def _path(text: str) -> Path:
    """A path argument; an empty one (``--out ""``, the current folder) is refused."""
    if not text:
        raise argparse.ArgumentTypeError("empty path")
    return Path(text)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for documentation and tests)."""
    parser = _Parser(
        prog="probing",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(title="commands", dest="command", required=True, metavar="command")

    def command(name: str, text: str) -> argparse.ArgumentParser:
        return sub.add_parser(name, help=text, description=text, formatter_class=_HelpFormatter)

    run = command("run", "simulate a scenario and write probing.parquet and timeseries.parquet")
    _scenario_arguments(run)
    run.add_argument(
        "--truth", action="store_true", help="also write truth.parquet and prediction.parquet"
    )
    run.set_defaults(func=_cmd_run)

    truth = command(
        "truth",
        "ground truth of a scenario: single-pulse and linearised pulse responses "
        "(truth.parquet) and the probing output they predict (prediction.parquet)",
    )
    _scenario_arguments(truth)
    truth.set_defaults(func=_cmd_truth)

    monitor = command(
        "monitor",
        "fly a scenario probing continuously; after every period a change detector writes "
        "monitor.parquet (docs/monitoring.md)",
    )
    _scenario_arguments(monitor)
    monitor.add_argument(
        "--timeseries", action="store_true", help="also write timeseries.parquet (large)"
    )
    monitor.set_defaults(func=_cmd_monitor)

    sweep = command("sweep", "run a sweep file's points in parallel, resumably (docs/sweeps.md)")
    sweep.add_argument("sweep", type=_path, help="sweep TOML file (scenarios/sweeps/*.toml)")
    sweep.add_argument(
        "--out", type=_path, default=Path("results/sweeps"), help="the sweep goes to OUT/<name>/"
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
        type=_path,
        default=None,
        help="figure folder (default: OUT/<name>/figures)",
    )
    sweep.set_defaults(func=_cmd_sweep)

    fig4 = command("fig4", "reproduce the paper's Fig. 4: runs, figures and summary")
    fig4.add_argument(
        "--scenarios", type=_path, default=Path("scenarios/fig4"), help="scenario set folder"
    )
    fig4.add_argument(
        "--out", type=_path, default=None, help="results folder (default: results/<set folder>)"
    )
    fig4.add_argument("--figures", type=_path, default=Path("figures"), help="figure folder")
    fig4.add_argument("--force", action="store_true", help="simulate even if results are stored")
    fig4.add_argument(
        "--copy-summary", type=_path, default=None, help="also copy summary.md to this file"
    )
    fig4.set_defaults(func=_cmd_fig4)

    plot = command(
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

    design = command("design", "recommend order, bit duration and amplitude for an experiment")
    _design_arguments(design)
    design.set_defaults(func=_cmd_design)

    modes = command(
        "modes",
        "trim and linearise the GTM at 800 ft, 60..130 KEAS; write the mode table and figure",
    )
    modes.add_argument("--docs", type=_path, default=Path("docs/gtm.md"), help="page written whole")
    modes.add_argument(
        "--figure", type=_path, default=Path("figures/gtm_modes"), help="figure (without .png)"
    )
    modes.set_defaults(func=_cmd_modes)

    damage = command(
        "gtm-damage",
        "NASA's Example 6: each GTM damage case at 10 s of a 45 deg bank climbing turn",
    )
    damage.add_argument(
        "--out", type=_path, default=Path("results/gtm_damage"), help="time histories, summary"
    )
    damage.add_argument("--figures", type=_path, default=Path("figures"), help="figure folder")
    damage.set_defaults(func=_cmd_gtm_damage)
    return parser


def _scenario_arguments(parser: argparse.ArgumentParser) -> None:
    """The scenario file and the results folder, as run, truth and monitor take them."""
    parser.add_argument("scenario", type=_path, help="scenario TOML file (docs/scenarios.md)")
    parser.add_argument(
        "--out", type=_path, default=Path("results"), help="results go to OUT/<scenario name>/"
    )


def _design_arguments(parser: argparse.ArgumentParser) -> None:
    from probing.core.noise import ESTIMATORS
    from probing.sim.channels import CHANNEL_NAMES
    from probing.sim.flight import TURBULENCE_SEVERITY

    parser.add_argument(
        "--simultaneous",
        type=_path,
        default=None,
        metavar="SCENARIO",
        help="check a scenario's [simultaneous] design from the linearisation (exit 2 if "
        "its surfaces cannot be kept apart) instead of recommending a probe",
    )
    parser.add_argument("--aircraft", help="JSBSim model, e.g. gtm_t2 or 737 (required)")
    parser.add_argument("--altitude-ft", type=float, help="trim altitude (ft) (required)")
    parser.add_argument("--speed-kcas", type=float, help="trim speed (kt CAS) (required)")
    parser.add_argument("--dt-s", type=float, default=0.01, help="simulation step (s)")
    parser.add_argument(
        "--deadband-deg",
        type=float,
        nargs=2,
        metavar=("LOWER", "UPPER"),
        default=None,
        help="deadband edges relative to trim (deg)",
    )
    parser.add_argument(
        "--saturation-deg",
        type=float,
        nargs=2,
        metavar=("LOWER", "UPPER"),
        default=None,
        help="saturation limits relative to trim (deg)",
    )
    parser.add_argument(
        "--rate-limit-deg-s", type=float, default=None, metavar="R", help="rate limit (deg/s)"
    )
    parser.add_argument(
        "--channel", choices=CHANNEL_NAMES, default="theta_rad", help="the output to estimate"
    )
    parser.add_argument(
        "--noise-sigma", type=float, default=0.0, help="sensor noise on the channel (1 sigma)"
    )
    parser.add_argument(
        "--turbulence",
        choices=list(TURBULENCE_SEVERITY),
        default="none",
        help="turbulence level; what the reference twin does not cancel is measured",
    )
    parser.add_argument(
        "--calibration-seeds",
        type=int,
        default=32,
        help="noise-free turbulence runs to measure it on (a std from K of them: 1/sqrt(2(K-1)))",
    )
    parser.add_argument(
        "--estimator",
        choices=list(ESTIMATORS),
        default=None,
        help="the estimator (default: the one with the smallest predicted scatter)",
    )
    target = parser.add_mutually_exclusive_group()
    target.add_argument(
        "--target-gain-se", type=float, default=None, help="standard error of the gain"
    )
    target.add_argument(
        "--detect-gain-change",
        type=float,
        default=None,
        metavar="CHANGE",
        help="a gain change to detect (with --false-alarm and --detection-probability)",
    )
    target.add_argument(
        "--target-h-se",
        type=float,
        default=None,
        help="standard error of h, RMS over taps (channel unit per deg)",
    )
    parser.add_argument(
        "--false-alarm", type=float, default=0.01, help="false-alarm probability (two-sided)"
    )
    parser.add_argument(
        "--detection-probability", type=float, default=0.9, help="detection probability"
    )
    parser.add_argument(
        "--amplitude-deg", type=float, default=0.005, help="amplitude without a deadband (deg)"
    )
    parser.add_argument(
        "--deadband-margin", type=float, default=3.0, help="a >= margin x deadband half width"
    )
    parser.add_argument(
        "--settle-periods", type=int, default=2, help="periods left out before averaging"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the command is, so it cleans up as after Ctrl-C: partial files
    and twins are dropped, child processes ended (exit code 143)."""


def _terminate(signum: int, frame: Any) -> None:
    raise Terminated


def _end_interrupted(code: int) -> NoReturn:
    """End this process at once with ``code`` after an interrupt, its clean-up done.

    Further Ctrl-C and SIGTERM are ignored, the streams flushed, and the interpreter's own
    finalization skipped: it puts back the default action of SIGINT (die by the signal), and
    one noted late there (a process pool's threads held it back) ended the process by SIGINT
    instead of with ``code`` now and then.  What the run wrote or removed is settled by then:
    the exception has passed through every writer's and pool's clean-up.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``probing`` console script.

    ``argv`` None: this process's own command line, which exits with the returned code; once
    interrupted it ends here (:func:`_end_interrupted`).
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    in_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if in_main else None
    stopping = 0
    try:
        with INTERRUPTS:  # no Ctrl-C is lost, wherever it lands (probing.core.forked)
            try:
                code = int(args.func(args))
            except (UsageError, Terminated, KeyboardInterrupt):
                raise
            except Exception:
                INTERRUPTS.check()  # an error the Ctrl-C caused (a pool's broken workers)
                raise
            INTERRUPTS.check()  # one Python dropped where it landed: the user asked to stop
            return code
    except UsageError as exc:
        return _error(str(exc), 2)
    except ValueError as exc:  # a stored file that cannot be read, wherever it is read
        from probing.experiment.storage import StoredFileError

        if isinstance(exc, StoredFileError):
            return _error(str(exc), 2)
        raise
    except Terminated:
        stopping = 143
        return _error("terminated", stopping)
    except KeyboardInterrupt:
        stopping = 130
        return _error("interrupted", stopping)
    finally:
        if stopping and argv is None:  # the process's own command line: it ends here
            _end_interrupted(stopping)
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
