"""``probing design``: a recommended probe, or the check of a [simultaneous] design."""

from __future__ import annotations

import argparse
import dataclasses
import sys
import types
import typing
from dataclasses import asdict
from pathlib import Path
from typing import Any

from probing.cli.common import (
    Subcommands,
    UsageError,
    command,
    option_of,
    out_file,
    path_arg,
    print_error,
    scenario_arg,
    simulating,
)


def _cmd_design(args: argparse.Namespace) -> int:
    if args.simultaneous is not None:
        if args.export_probe or args.save_scenario is not None:
            raise UsageError("design --simultaneous: checks a scenario; there is no probe to write")
        return _check_simultaneous(args.simultaneous)
    from probing.api import design
    from probing.experiment.design.design import DesignError, DesignInputError
    from probing.experiment.output.storage import strict_json

    try:
        request = _request(args)
    except DesignInputError as exc:
        raise UsageError(_said(exc)) from None
    _check_exports(args)

    def job() -> int:
        try:
            rec = design(request)
        except DesignInputError as exc:
            raise UsageError(_said(exc)) from None
        except DesignError as exc:
            reason = exc.line(option_of)  # the options it names as the command line's
            if args.json:
                print(strict_json({"feasible": False, "reason": reason}, sort_keys=False))
            return print_error(f"infeasible: {reason}", 2)
        d, modes, scn = rec.design, rec.modes, rec.scenario
        written = _write_exports(args, d, scn)
        if args.json:
            fields = {k: v for k, v in asdict(d).items() if k != "window" or v}  # if found
            payload = {"feasible": True, **fields, "modes": _modes_dict(modes)}
            print(strict_json(payload, indent=2, sort_keys=False))
        else:
            print(
                f"{args.aircraft} at {args.altitude_ft:g} ft, {args.speed_kcas:g} kcas: short "
                f"period wn = {modes.sp_wn:.3g} rad/s, zeta = {modes.sp_zeta:.3g}; phugoid wn = "
                f"{modes.ph_wn:.3g} rad/s, zeta = {modes.ph_zeta:.3g}"
            )
            print(_design_table(d))
        for path in written:  # stdout stays one JSON object with --json
            print(f"wrote {path}", file=sys.stderr if args.json else sys.stdout)
        return 0

    return simulating(job, f"--aircraft {args.aircraft}")


def _check_exports(args: argparse.Namespace) -> None:
    """``--export-probe`` and ``--save-scenario``: writable files of a known kind, checked
    before the design starts (UsageError)."""
    from probing.experiment.design.probe_export import EXPORT_SUFFIXES

    args.export_probe = args.export_probe or []
    for path in args.export_probe:
        out_file(path, "--export-probe")
        if path.suffix not in EXPORT_SUFFIXES:
            raise UsageError(f"--export-probe {path}: the file must end in .csv or .h")
    if args.save_scenario is not None:
        out_file(args.save_scenario, "--save-scenario")
        if args.save_scenario.suffix != ".toml":
            raise UsageError(
                f"--save-scenario {args.save_scenario}: the file must end in .toml (a "
                "scenario file is TOML)"
            )
    paths = [*args.export_probe, *([args.save_scenario] if args.save_scenario else [])]
    if len({p.resolve() for p in paths}) < len(paths):
        raise UsageError("design: one file named twice by --export-probe and --save-scenario")


def _write_exports(args: argparse.Namespace, d: Any, scn: Any) -> list[Path]:
    """Write the designed probe (``--export-probe``) and the scenario (``--save-scenario``);
    the files written, in order."""
    from probing.experiment.design.probe_export import export_probe
    from probing.experiment.output.storage import write_text_atomic

    written = [export_probe(scn, path) for path in args.export_probe]
    if args.save_scenario is not None:
        write_text_atomic(args.save_scenario, d.scenario_toml)
        written.append(args.save_scenario)
    return written


def _check_simultaneous(path: Path) -> int:
    """``probing design --simultaneous``: the design's memory condition, or its refusal
    (:func:`probing.api.check_simultaneous`)."""
    from probing.api import check_simultaneous
    from probing.experiment.scenario import ScenarioError
    from probing.experiment.studies.simultaneous import SeparationError

    scn = scenario_arg(path)

    def job() -> int:
        try:
            check = check_simultaneous(scn)
        except ScenarioError as exc:
            raise UsageError(f"{path}: {exc.message}") from None
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

    return simulating(job, str(path))


def _modes_dict(modes: Any) -> dict[str, float]:
    return {k: getattr(modes, k) for k in ("sp_wn", "sp_zeta", "ph_wn", "ph_zeta")}


def _design_table(d: Any) -> str:
    from probing.analysis.tables import fmt
    from probing.sim.channels import unit_of

    unit = unit_of(d.channel)
    rows = [
        ("order", f"{d.order} (M = {d.bits_per_period})", d.reasons["order"]),
        ("bit_duration_s", f"{d.bit_duration_s:g}", d.reasons["bit_duration_s"]),
        ("amplitude_deg", f"{d.amplitude_deg:.4g}", d.reasons["amplitude_deg"]),
        ("estimator", d.estimator, d.reasons["estimator"]),
        ("drift", d.drift, d.reasons["drift"]),
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
    if d.window:
        w = d.window
        lines.append(
            f"monitor window: one period's gain se {fmt(w['period_gain_stderr'], 3)}; over "
            f"{w['window_periods']} periods against a baseline of {w['baseline_periods']}: "
            f"{fmt(w['window_gain_stderr'], 3)} (target {fmt(w['target_gain_stderr'], 3)}, "
            f"false alarm per test {fmt(w['false_alarm'], 3)})"
        )
    lines += [f"warning: {w}" for w in d.warnings]
    lines += [
        "",
        "scenario (probing design ... --json gives it as scenario_toml):",
        d.scenario_toml,
    ]
    return "\n".join(lines)


def register(sub: Subcommands) -> None:
    """Add ``design`` to ``sub``."""
    design = command(
        sub,
        "design",
        "recommend order, bit duration and amplitude for an experiment",
        [
            "probing design --aircraft 737 --altitude-ft 15000 --speed-kcas 280 "
            "--noise-sigma 1e-5 --detect-gain-change 0.1",
            "probing design --aircraft gtm_t2 --altitude-ft 800 --speed-kcas 75 "
            "--deadband-deg -0.002 0.002 --noise-sigma 1e-5 --target-gain-se 0.01 --json",
        ],
    )
    _design_arguments(design)
    design.set_defaults(func=_cmd_design)


def _request(args: argparse.Namespace) -> Any:
    """The :class:`~probing.experiment.design.design_request.DesignRequest` the options give
    (UsageError naming the required ones missing)."""
    from probing.experiment.design.design_request import DesignRequest

    fields = dataclasses.fields(DesignRequest)
    required = [f.name for f in fields if f.default is dataclasses.MISSING]
    missing = [name for name in required if getattr(args, name) is None]
    if missing:
        options = ", ".join(option_of(name) for name in missing)
        raise UsageError(f"design: {options} required (or --simultaneous SCENARIO)")
    values = {f.name: getattr(args, f.name) for f in fields}
    return DesignRequest(
        **{k: tuple(v) if isinstance(v, list) else v for k, v in values.items()}  # nargs=2
    )


def _said(exc: Any) -> str:
    """A DesignInputError's line with each field it names written as its option (another
    name, a scenario field, as it is)."""
    from probing.experiment.design.design_request import DesignRequest

    fields = {f.name for f in dataclasses.fields(DesignRequest)}
    return str(exc.line(lambda name: option_of(name) if name in fields else name))


def _design_arguments(parser: argparse.ArgumentParser) -> None:
    """``--simultaneous``, an option per DesignRequest field (its default and help from the
    field, :func:`~probing.experiment.design.design_request._option`), and ``--json``."""
    from probing.core.errors import refer
    from probing.experiment.design.design_request import DesignRequest

    parser.add_argument(
        "--simultaneous",
        type=path_arg,
        default=None,
        metavar="SCENARIO",
        help="check a scenario's [simultaneous] design from the linearisation (exit 2 if "
        "its surfaces cannot be kept apart) instead of recommending a probe",
    )
    hints = typing.get_type_hints(DesignRequest)
    groups: dict[str, Any] = {}
    for f in dataclasses.fields(DesignRequest):
        keywords = dict(f.metadata["option"])
        keywords["help"] = refer(keywords["help"], option_of)
        exclusive = keywords.pop("exclusive")
        if exclusive is None:
            where = parser
        else:
            if exclusive not in groups:
                groups[exclusive] = parser.add_mutually_exclusive_group()
            where = groups[exclusive]
        default = None if f.default is dataclasses.MISSING else f.default
        if hints[f.name] is bool:  # a switch
            where.add_argument(option_of(f.name), action="store_true", default=default, **keywords)
            continue
        kind, nargs = _argument_type(hints[f.name])
        if nargs is not None:
            keywords["nargs"] = nargs
        where.add_argument(option_of(f.name), type=kind, default=default, **keywords)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--export-probe",
        type=path_arg,
        action="append",
        default=None,
        metavar="FILE",
        help="write one period of the designed probe for a flight computer: FILE.csv (one "
        "row per bit: time_s, command_<unit> relative to trim) or FILE.h (a C array of +-1, "
        "its generator in comments); give it twice for both (docs/formats.md)",
    )
    parser.add_argument(
        "--save-scenario",
        type=path_arg,
        default=None,
        metavar="FILE",
        help="write the recommended scenario, FILE.toml (probing run FILE flies it)",
    )


def _argument_type(hint: Any) -> tuple[Any, int | None]:
    """The argparse ``type`` and ``nargs`` of a field's type: ``float | None`` is a float,
    ``tuple[float, float] | None`` two of them; a ``str`` is taken as it is (None)."""
    if isinstance(hint, types.UnionType):  # X | None
        (hint,) = [k for k in typing.get_args(hint) if k is not type(None)]
    if typing.get_origin(hint) is tuple:
        items = typing.get_args(hint)
        return items[0], len(items)
    return (None if hint is str else hint), None
