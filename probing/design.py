"""``probing design``: recommend order n, bit duration t0 and amplitude a for an experiment.

The rules, each printed with the recommendation it produced:

* **Memory**: T = M t0 must cover the pulse response.  The settling time is 4/(zeta wn) of the
  short period of the linearised model at the trim (JSBSim ``FGLinearization``, states Vt,
  alpha, theta, q).  The phugoid is usually much slower; when its settling time exceeds T the
  recommendation says so (its tail folds into the taps, eq. (8); use the drift reference).
* **Amplitude**: a clears the deadband, a >= margin * max(|d-|, d+), and stays inside the
  saturation margins, a <= min(-U-, U+) (both relative to trim).  Without a deadband the
  default amplitude (0.005 deg, the paper's) is used, capped by the saturation.
* **Rate limit**: eq. (21), r_l >= 2a/t0, so t0 >= 2a/r_l, rounded up to a multiple of dt.
* **Periods**: with output noise sigma the standard error of a tap of h is
  sigma / (a sqrt(M P)) for P averaged periods; P is the smallest meeting the target.

Infeasible requests (a deadband that cannot be cleared inside the saturation margin, a
saturation range that does not contain the trim, an order above the maximum) exit with
code 2 and the reason.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import asdict, dataclass, field

import numpy as np

__all__ = [
    "LONG_STATES",
    "Design",
    "DesignError",
    "add_arguments",
    "design",
    "longitudinal_modes",
    "main",
    "settling_times",
]

LONG_STATES = ("Vt", "Alpha", "Theta", "Q")


class DesignError(ValueError):
    """The request cannot be met; the message says why."""


@dataclass
class Design:
    """A recommended probing set-up and the reasons for each value."""

    order: int
    bits_per_period: int
    bit_duration_s: float
    memory_s: float
    amplitude_deg: float
    periods: int
    settle_periods: int
    predicted_se: float
    short_period_settling_s: float
    phugoid_settling_s: float
    reasons: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def longitudinal_modes(eigs: np.ndarray) -> tuple[float, float, float, float]:
    """(sp_wn, sp_zeta, ph_wn, ph_zeta) from the four longitudinal eigenvalues (rad/s).

    The two eigenvalues of largest magnitude are the short period, the other two the
    phugoid.  For a pair of real roots the equivalent second-order values are returned
    (wn = sqrt(l1 l2), zeta = -(l1 + l2) / (2 wn)).
    """
    order = np.argsort(np.abs(eigs))
    out: list[float] = []
    for pair in (eigs[order[2:]], eigs[order[:2]]):
        wn = math.sqrt(abs(float(np.real(pair[0] * pair[1]))))
        zeta = -float(np.real(pair[0] + pair[1])) / (2 * wn) if wn > 0 else math.nan
        out += [wn, zeta]
    return out[0], out[1], out[2], out[3]


def settling_times(
    aircraft: str, altitude_ft: float, speed_kcas: float, dt_s: float
) -> tuple[float, float, dict]:
    """(short-period, phugoid) settling times 4/(zeta wn) in s at the trim, and the modes."""
    from probing.plant import Plant

    plant = Plant(aircraft, dt_s)
    plant.trim(altitude_ft, speed_kcas=speed_kcas)
    lin = plant.linearise()
    names = list(lin["x_names"])
    idx = [names.index(n) for n in LONG_STATES]
    eigs = np.linalg.eigvals(np.asarray(lin["A"])[np.ix_(idx, idx)])
    sp_wn, sp_zeta, ph_wn, ph_zeta = longitudinal_modes(eigs)

    def ts(wn: float, zeta: float) -> float:
        return 4.0 / (zeta * wn) if zeta * wn > 0 else math.inf

    modes = {"sp_wn": sp_wn, "sp_zeta": sp_zeta, "ph_wn": ph_wn, "ph_zeta": ph_zeta}
    return ts(sp_wn, sp_zeta), ts(ph_wn, ph_zeta), modes


def design(
    *,
    short_period_settling_s: float,
    phugoid_settling_s: float,
    dt_s: float = 0.01,
    deadband_deg: tuple[float, float] | None = None,
    saturation_deg: tuple[float, float] | None = None,
    rate_limit_deg_s: float | None = None,
    noise_sigma: float = 0.0,
    target_se: float | None = None,
    default_amplitude_deg: float = 0.005,
    deadband_margin: float = 3.0,
    max_order: int = 16,
    settle_periods: int = 2,
) -> Design:
    """The recommendation from the settling times and the nonlinearity bounds (pure function).

    Raises
    ------
    DesignError
        When no (n, t0, a, P) meets every rule; the message names the conflict.
    """
    reasons: dict[str, str] = {}
    warnings: list[str] = []
    if not (math.isfinite(dt_s) and dt_s > 0):
        raise DesignError(f"dt_s must be > 0, got {dt_s}")
    # ---- amplitude
    sat_room = math.inf
    if saturation_deg is not None:
        lo, up = saturation_deg
        if not lo < 0.0 < up:
            raise DesignError(
                f"saturation [{lo:g}, {up:g}] deg does not contain the trim (0): "
                "the probe cannot get through both ways"
            )
        sat_room = min(-lo, up)
    if deadband_deg is not None:
        lo, up = deadband_deg
        if not lo <= 0.0 <= up:
            raise DesignError(f"deadband [{lo:g}, {up:g}] deg must contain 0 (lower <= 0 <= upper)")
        half = max(-lo, up)
        need = deadband_margin * half
        if half >= sat_room:
            raise DesignError(
                f"deadband (half width {half:g} deg) is wider than the saturation margin "
                f"({sat_room:g} deg): no amplitude clears one and stays inside the other"
            )
        if need > sat_room:
            raise DesignError(
                f"amplitude {need:g} deg (= {deadband_margin:g} x deadband {half:g} deg) "
                f"exceeds the saturation margin {sat_room:g} deg; lower --deadband-margin "
                "or widen the saturation"
            )
        a = min(max(need, default_amplitude_deg), sat_room)
        reasons["amplitude_deg"] = (
            f"clears the deadband: a >= {deadband_margin:g} x {half:g} deg"
            + (f", inside saturation margin {sat_room:g} deg" if saturation_deg else "")
            + f"; apparent a~ = {a - half:.3g} deg for a symmetric band"
        )
    else:
        a = min(default_amplitude_deg, sat_room)
        reasons["amplitude_deg"] = f"default {default_amplitude_deg:g} deg" + (
            f", capped by saturation margin {sat_room:g} deg" if a < default_amplitude_deg else ""
        )
    # ---- bit duration
    steps = 1
    if rate_limit_deg_s is not None:
        if not rate_limit_deg_s > 0:
            raise DesignError(f"rate limit must be > 0 deg/s, got {rate_limit_deg_s}")
        t_min = 2.0 * a / rate_limit_deg_s
        steps = max(1, math.ceil(t_min / dt_s - 1e-9))
        reasons["bit_duration_s"] = (
            f"eq. (21) r_l >= 2a/t0: t0 >= 2a/r_l = {t_min:.4g} s, rounded up to "
            f"{steps} x dt; 2a/t0 = {2 * a / (steps * dt_s):.4g} <= "
            f"r_l = {rate_limit_deg_s:g} deg/s"
        )
    else:
        reasons["bit_duration_s"] = "no rate limit: one simulation step per bit"
    t0 = steps * dt_s
    if math.isfinite(short_period_settling_s) and t0 > short_period_settling_s / 10:
        warnings.append(
            f"t0 = {t0:g} s is longer than a tenth of the short-period settling time "
            f"({short_period_settling_s:.3g} s): the pulse response is coarsely resolved"
        )
    # ---- order
    if not math.isfinite(short_period_settling_s):
        raise DesignError("the short period is not stable at this trim: no finite memory covers it")
    order = 3
    while (2**order - 1) * t0 < short_period_settling_s:
        order += 1
        if order > max_order:
            raise DesignError(
                f"covering {short_period_settling_s:.3g} s with t0 = {t0:g} s needs order > "
                f"{max_order}"
            )
    m = 2**order - 1
    memory = m * t0
    reasons["order"] = (
        f"T = M t0 = {memory:.3g} s >= short-period settling 4/(zeta wn) = "
        f"{short_period_settling_s:.3g} s"
    )
    if phugoid_settling_s > memory:
        warnings.append(
            f"the phugoid (settling {phugoid_settling_s:.3g} s) is not covered by T = "
            f"{memory:.3g} s: its tail folds into the taps (eq. 8); use drift = 'reference'"
        )
    # ---- periods
    if noise_sigma > 0 and target_se is not None:
        if not target_se > 0:
            raise DesignError(f"target standard error must be > 0, got {target_se}")
        p = max(1, math.ceil((noise_sigma / (a * target_se)) ** 2 / m))
        reasons["periods"] = (
            f"sigma / (a sqrt(M P)) <= {target_se:g} needs P = {p} averaged periods, "
            f"plus {settle_periods} settling"
        )
    else:
        p = 4
        reasons["periods"] = (
            f"no noise target: {p} averaged periods, plus {settle_periods} settling"
        )
    se = noise_sigma / (a * math.sqrt(m * p)) if noise_sigma > 0 else 0.0
    return Design(
        order=order,
        bits_per_period=m,
        bit_duration_s=t0,
        memory_s=memory,
        amplitude_deg=a,
        periods=p + settle_periods,
        settle_periods=settle_periods,
        predicted_se=se,
        short_period_settling_s=short_period_settling_s,
        phugoid_settling_s=phugoid_settling_s,
        reasons=reasons,
        warnings=warnings,
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``probing design`` options."""
    parser.add_argument("--aircraft", required=True, help="JSBSim model, e.g. gtm_t2 or 737")
    parser.add_argument("--altitude-ft", type=float, required=True)
    parser.add_argument("--speed-kcas", type=float, required=True)
    parser.add_argument("--dt-s", type=float, default=0.01, help="simulation step (s)")
    parser.add_argument(
        "--deadband-deg", type=float, nargs=2, metavar=("LOWER", "UPPER"), default=None
    )
    parser.add_argument(
        "--saturation-deg",
        type=float,
        nargs=2,
        metavar=("LOWER", "UPPER"),
        default=None,
        help="saturation limits relative to trim (deg)",
    )
    parser.add_argument("--rate-limit-deg-s", type=float, default=None, metavar="R")
    parser.add_argument(
        "--noise-sigma", type=float, default=0.0, help="output noise, theta rad (1 sigma)"
    )
    parser.add_argument(
        "--target-se", type=float, default=None, help="target standard error of h per tap (rad/deg)"
    )
    parser.add_argument("--amplitude-deg", type=float, default=0.005, help="default amplitude")
    parser.add_argument(
        "--deadband-margin", type=float, default=3.0, help="a >= margin x deadband half width"
    )
    parser.add_argument("--json", action="store_true", help="print JSON for scripts")


def _table(d: Design) -> str:
    rows = [
        ("order", f"{d.order} (M = {d.bits_per_period})", d.reasons["order"]),
        ("bit_duration_s", f"{d.bit_duration_s:g}", d.reasons["bit_duration_s"]),
        ("amplitude_deg", f"{d.amplitude_deg:.4g}", d.reasons["amplitude_deg"]),
        (
            "periods",
            f"{d.periods} ({d.settle_periods} settling)",
            d.reasons["periods"] + f"; predicted se {d.predicted_se:.3g} rad/deg",
        ),
    ]
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    lines = [f"{'parameter':<{w0}}  {'value':<{w1}}  reason"]
    lines += [f"{a:<{w0}}  {b:<{w1}}  {c}" for a, b, c in rows]
    lines += [f"warning: {w}" for w in d.warnings]
    return "\n".join(lines)


def main(args: argparse.Namespace) -> int:
    """``probing design``: print the recommendation (exit 2 with the reason if infeasible)."""
    from probing.plant import AircraftNotFoundError, TrimError

    try:
        ts_sp, ts_ph, modes = settling_times(
            args.aircraft, args.altitude_ft, args.speed_kcas, args.dt_s
        )
    except (AircraftNotFoundError, TrimError) as exc:
        print(f"probing design: error: {exc}", file=sys.stderr)
        return 2
    try:
        d = design(
            short_period_settling_s=ts_sp,
            phugoid_settling_s=ts_ph,
            dt_s=args.dt_s,
            deadband_deg=tuple(args.deadband_deg) if args.deadband_deg else None,
            saturation_deg=tuple(args.saturation_deg) if args.saturation_deg else None,
            rate_limit_deg_s=args.rate_limit_deg_s,
            noise_sigma=args.noise_sigma,
            target_se=args.target_se,
            default_amplitude_deg=args.amplitude_deg,
            deadband_margin=args.deadband_margin,
        )
    except DesignError as exc:
        if args.json:
            print(json.dumps({"feasible": False, "reason": str(exc)}))
        print(f"probing design: infeasible: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps({"feasible": True, **asdict(d), "modes": modes}, indent=2))
    else:
        print(
            f"{args.aircraft} at {args.altitude_ft:g} ft, {args.speed_kcas:g} kcas: short period "
            f"wn = {modes['sp_wn']:.3g} rad/s, zeta = {modes['sp_zeta']:.3g}; phugoid wn = "
            f"{modes['ph_wn']:.3g} rad/s, zeta = {modes['ph_zeta']:.3g}"
        )
        print(_table(d))
    return 0
