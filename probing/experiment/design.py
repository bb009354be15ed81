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

The request is validated by the scenario schema itself (:class:`DesignRequest`): every value a
scenario would refuse is refused here, naming the option.  The recommendation is a scenario,
validated the same way, so a design that no scenario can hold (more periods than the schema
allows) is infeasible.  Infeasible requests exit with code 2 and the reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from probing.core.nonlinearities import RateLimit
from probing.experiment.scenario import Scenario, ScenarioError, parse_scenario
from probing.sim.linear import LongitudinalModes, longitudinal_modes
from probing.sim.plant import make_plant

__all__ = [
    "Design",
    "DesignError",
    "DesignInputError",
    "DesignRequest",
    "design",
    "recommend",
]


class DesignError(ValueError):
    """The request cannot be met; the message says why."""


class DesignInputError(ValueError):
    """An invalid request: ``option`` names the command-line option, ``message`` the rule."""

    def __init__(self, option: str, message: str) -> None:
        self.option, self.message = option, message
        super().__init__(f"{option}: {message}")


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


#: Scenario field -> the ``probing design`` option that sets it.
_OPTIONS = {
    "name": "--aircraft",
    "aircraft.model": "--aircraft",
    "condition.altitude_ft": "--altitude-ft",
    "condition.speed_kcas": "--speed-kcas",
    "simulation.dt_s": "--dt-s",
    "probe.amplitude_deg": "--amplitude-deg",
    "disturbance.sensor_noise.theta_rad": "--noise-sigma",
}


@dataclass(frozen=True)
class DesignRequest:
    """What ``probing design`` is asked: the aircraft, the condition and the nonlinearities.

    Attributes are in the units of their names; ``noise_sigma`` is the output noise of
    theta (rad, 1 sigma), ``target_se`` the wanted standard error of a tap of h (rad/deg).
    """

    aircraft: str
    altitude_ft: float
    speed_kcas: float
    dt_s: float = 0.01
    deadband_deg: tuple[float, float] | None = None
    saturation_deg: tuple[float, float] | None = None
    rate_limit_deg_s: float | None = None
    noise_sigma: float = 0.0
    target_se: float | None = None
    amplitude_deg: float = 0.005
    deadband_margin: float = 3.0

    def base(self) -> dict[str, Any]:
        """The request as a scenario (file layout): probe placeholders, no nonlinearity."""
        return {
            "name": "design",
            "aircraft": {"model": self.aircraft},
            "condition": {"altitude_ft": self.altitude_ft, "speed_kcas": self.speed_kcas},
            "simulation": {"dt_s": self.dt_s},
            "probe": {
                "order": 9,
                "bit_duration_s": self.dt_s,
                "amplitude_deg": self.amplitude_deg,
                "periods": 3,
                "settle_periods": 2,
            },
            "nonlinearity": {"type": "none"},
            "output": {"channels": ["theta_rad"], "drift": "reference"},
            "disturbance": {"sensor_noise": {"theta_rad": self.noise_sigma}},
        }

    def validate(self) -> Scenario:
        """Check every value as the scenario schema does; the base scenario.

        Raises
        ------
        DesignInputError
            Naming the option and the rule, for the first invalid value.
        """
        try:
            scn = parse_scenario(self.base())
        except ScenarioError as exc:
            option = _OPTIONS.get(exc.field, exc.field)
            raise DesignInputError(option, exc.message) from None
        nonlinearities = (
            ("--deadband-deg", "deadband", ("lower_deg", "upper_deg"), self.deadband_deg),
            ("--saturation-deg", "saturation", ("lower_deg", "upper_deg"), self.saturation_deg),
            ("--rate-limit-deg-s", "rate_limit", ("rate_deg_s",), self._rate()),
        )
        for option, kind, names, values in nonlinearities:
            if values is None:
                continue
            change = {"nonlinearity.type": kind}
            change.update({f"nonlinearity.{n}": v for n, v in zip(names, values, strict=True)})
            try:
                scn.replace(change)
            except ScenarioError as exc:
                raise DesignInputError(option, f"{exc.field}: {exc.message}") from None
        for option, value in (
            ("--target-se", self.target_se),
            ("--deadband-margin", self.deadband_margin),
        ):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise DesignInputError(option, f"must be a number > 0, got {value:g}")
        return scn

    def _rate(self) -> tuple[float] | None:
        return None if self.rate_limit_deg_s is None else (self.rate_limit_deg_s,)


def design(
    request: DesignRequest,
    *,
    short_period_settling_s: float,
    phugoid_settling_s: float,
    max_order: int = 16,
    settle_periods: int = 2,
) -> Design:
    """The recommendation from the settling times and the request's bounds (pure function).

    ``request`` holds values as :meth:`DesignRequest.validate` accepts them; the rules here
    are the design's own (a saturation must contain the trim, a deadband must be cleared
    inside it, ...).

    Raises
    ------
    DesignError
        When no (n, t0, a, P) meets every rule; the message names the conflict.
    """
    r = request
    reasons: dict[str, str] = {}
    warnings: list[str] = []
    # ---- amplitude
    sat_room = math.inf
    if r.saturation_deg is not None:
        lo, up = r.saturation_deg
        if not lo < 0.0 < up:
            raise DesignError(
                f"saturation [{lo:g}, {up:g}] deg does not contain the trim (0): "
                "the probe cannot get through both ways"
            )
        sat_room = min(-lo, up)
    if r.deadband_deg is not None:
        lo, up = r.deadband_deg
        half = max(-lo, up)
        need = r.deadband_margin * half
        if half >= sat_room:
            raise DesignError(
                f"deadband (half width {half:g} deg) is wider than the saturation margin "
                f"({sat_room:g} deg): no amplitude clears one and stays inside the other"
            )
        if need > sat_room:
            raise DesignError(
                f"amplitude {need:g} deg (= {r.deadband_margin:g} x deadband {half:g} deg) "
                f"exceeds the saturation margin {sat_room:g} deg; lower --deadband-margin "
                "or widen the saturation"
            )
        a = min(max(need, r.amplitude_deg), sat_room)
        reasons["amplitude_deg"] = (
            f"clears the deadband: a >= {r.deadband_margin:g} x {half:g} deg"
            + (f", inside saturation margin {sat_room:g} deg" if r.saturation_deg else "")
            + f"; apparent a~ = {a - half:.3g} deg for a symmetric band"
        )
    else:
        a = min(r.amplitude_deg, sat_room)
        reasons["amplitude_deg"] = f"default {r.amplitude_deg:g} deg" + (
            f", capped by saturation margin {sat_room:g} deg" if a < r.amplitude_deg else ""
        )
    # ---- bit duration
    steps = 1
    if r.rate_limit_deg_s is not None:
        rate = RateLimit(r.rate_limit_deg_s)
        t_min = rate.shortest_bit_s(a)
        steps = max(1, math.ceil(t_min / r.dt_s - 1e-9))
        reasons["bit_duration_s"] = (
            f"eq. (21) r_l >= 2a/t0: t0 >= 2a/r_l = {t_min:.4g} s, rounded up to "
            f"{steps} x dt; 2a/t0 = {RateLimit.bound(a, steps * r.dt_s):.4g} <= "
            f"r_l = {r.rate_limit_deg_s:g} deg/s"
        )
    else:
        reasons["bit_duration_s"] = "no rate limit: one simulation step per bit"
    t0 = steps * r.dt_s
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
    if r.noise_sigma > 0 and r.target_se is not None:
        p = max(1, math.ceil((r.noise_sigma / (a * r.target_se)) ** 2 / m))
        reasons["periods"] = (
            f"sigma / (a sqrt(M P)) <= {r.target_se:g} needs P = {p} averaged periods, "
            f"plus {settle_periods} settling"
        )
    else:
        p = 4
        reasons["periods"] = (
            f"no noise target: {p} averaged periods, plus {settle_periods} settling"
        )
    se = r.noise_sigma / (a * math.sqrt(m * p)) if r.noise_sigma > 0 else 0.0
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


def recommend(request: DesignRequest) -> tuple[Design, LongitudinalModes, Scenario]:
    """Validate the request, trim and linearise the aircraft, apply the rules.

    Returns
    -------
    Design
        The recommendation and its reasons.
    LongitudinalModes
        The modes at the trim.
    Scenario
        The recommended scenario (named ``design``), validated by the schema.

    Raises
    ------
    DesignInputError
        For a value the scenario schema refuses (naming the option).
    probing.sim.errors.TrimError
        When the aircraft cannot be trimmed at the condition.
    DesignError
        When no design meets every rule, or the design is no valid scenario.
    """
    base = request.validate()
    modes = longitudinal_modes(make_plant(base.flight))
    d = design(
        request,
        short_period_settling_s=modes.short_period_settling_s,
        phugoid_settling_s=modes.phugoid_settling_s,
    )
    try:
        scn = base.replace(
            {
                "probe.order": d.order,
                "probe.bit_duration_s": d.bit_duration_s,
                "probe.amplitude_deg": d.amplitude_deg,
                "probe.periods": d.periods,
                "probe.settle_periods": d.settle_periods,
            }
        )
    except ScenarioError as exc:
        raise DesignError(
            f"the design is no valid scenario: {exc.field}: {exc.message} "
            f"({d.reasons.get(exc.field.removeprefix('probe.'), '')})"
        ) from None
    return d, modes, scn
