"""``probing design``: a recommended probe, or the check of a [simultaneous] design."""

from __future__ import annotations

import argparse
from dataclasses import asdict
from pathlib import Path
from typing import Any

from probing.cli.common import (
    Subcommands,
    UsageError,
    _error,
    _load_scenario,
    _path,
    _simulating,
    command,
)


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


def register(sub: Subcommands) -> None:
    """Add ``design`` to ``sub``."""
    design = command(sub, "design", "recommend order, bit duration and amplitude for an experiment")
    _design_arguments(design)
    design.set_defaults(func=_cmd_design)


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
