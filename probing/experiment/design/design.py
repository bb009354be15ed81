"""``probing design``: recommend a probing experiment that keeps its promise on precision.

The rules, each printed with the value it produced:

* **Memory**: T = M t0 covers the short period's settling 4/(zeta wn) from JSBSim's
  linearisation at the trim.  The phugoid is usually far slower: its tail folds into the taps
  (eq. 8) and its transient biases the settled estimates, which is predicted and reported
  (``predicted_h_bias``).
* **Amplitude**: a clears the deadband (a >= margin x its half width), stays inside the
  saturation margins (a <= min(-U-, U+)), trim +- a stays inside the elevator's range, and
  a is no more than a scenario takes (10 deg); when no a does all of it, the refusal says
  which bound the dead band runs into (:func:`~.design_reasons.no_amplitude`).
* **Bit duration**: eq. (21), r_l >= 2a/t0, so t0 >= 2a/r_l, rounded up to a multiple of dt.
* **Estimator**: the one with the smallest predicted scatter of the target (the gain: ``ac``,
  which leaves out the DC direction the probe hardly excites; h: ``cyclic``), unless given.
* **Periods**: the fewest whose predicted seed-to-seed scatter (the exact noise model of
  :mod:`probing.experiment.design.noise`: sensor noise, plus the turbulence the reference twin does
  not cancel, taken from ``--calibration-seeds`` noise-free runs as long as the design
  itself) meets the target, after the settling periods.

The target is a standard error of the gain (``--target-gain-se``), a gain change to detect
at a false-alarm and a detection probability (``--detect-gain-change``: the gain's standard
error must be at most change / (z(1 - alpha/2) + z(1 - beta)), against a baseline known
without noise), or a standard error of h (``--target-h-se``).

The request is validated by the scenario schema itself (:class:`DesignRequest`), and the
recommendation is a scenario, validated the same way, so a design no scenario can hold (more
periods than the schema allows) is infeasible: exit code 2 with the reason.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from probing.core.detection import detection_scale
from probing.core.fixedorder import dot
from probing.core.monitor import MonitorSettings, window_matrix
from probing.core.noise import NoiseModel
from probing.core.nonlinearities import RateLimit
from probing.experiment.design.design_reasons import (
    CANDIDATES,
    LARGEST_AMPLITUDE,
    SATURATION,
    SURFACE_RANGE,
    no_amplitude,
    notes,
    said,
    too_tight,
)
from probing.experiment.design.design_request import (
    DesignError,
    DesignInputError,
    DesignRequest,
    detectable_stderr,
)
from probing.experiment.design.design_runs import (
    Gusts,
    noise_free_reference,
    turbulence_residual,
    with_periods,
)
from probing.experiment.design.design_window import (
    WindowDesign,
    period_covariance,
    period_gain_std,
    smallest_amplitude,
    window_dict,
)
from probing.experiment.design.noise import ChannelPrediction, predict
from probing.experiment.output.scatter import scatter_models
from probing.experiment.scenario import AMPLITUDE_MAX, MAX_PERIODS, Scenario, ScenarioError
from probing.sim.linear import LongitudinalModes, longitudinal_modes
from probing.sim.plant import make_plant

__all__ = [
    "Design",
    "DesignError",
    "DesignInputError",
    "DesignRequest",
    "ProbeShape",
    "detectable_stderr",
    "fewest_periods",
    "probe_shape",
    "recommend",
    "turbulence_residual",
]


@dataclass
class ProbeShape:
    """Order, bit duration and amplitude, with the reasons and warnings of the rules."""

    order: int
    bit_duration_s: float
    amplitude_deg: float
    reasons: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    @property
    def bits_per_period(self) -> int:
        """M = 2**order - 1."""
        return 2**self.order - 1

    @property
    def memory_s(self) -> float:
        """T = M t0, s."""
        return self.bits_per_period * self.bit_duration_s


@dataclass
class Design:
    """A recommended probing set-up, its predicted quality and the reasons for each value."""

    order: int
    bits_per_period: int
    bit_duration_s: float
    memory_s: float
    amplitude_deg: float
    periods: int
    settle_periods: int
    estimator: str
    drift: str  # the scenario's reference (output.drift)
    channel: str
    predicted_gain_stderr: float
    predicted_h_stderr: float
    predicted_z_stderr: float
    predicted_h_bias: float
    short_period_settling_s: float
    phugoid_settling_s: float
    scenario_toml: str
    reasons: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    estimators: dict[str, float] = field(default_factory=dict)
    window: dict[str, Any] = field(default_factory=dict)  # --window-periods: what it found


def fewest_periods(scatter: Callable[[int], float], target: float, max_periods: int) -> int:
    """The fewest settled periods P in 1..``max_periods`` with ``scatter(P) <= target``.

    ``scatter`` must fall with P (the mean of more periods).  Raises DesignError when even
    ``max_periods`` do not meet the target.

    Examples
    --------
    >>> fewest_periods(lambda p: 1 / p**0.5, 0.1, 1000)
    100
    """
    if scatter(max_periods) > target:
        raise DesignError(
            f"{max_periods} settled periods give {scatter(max_periods):.3g}, more than the "
            f"target {target:.3g}"
        )
    lo, hi = 1, max_periods  # scatter(hi) <= target
    if scatter(lo) <= target:
        return lo
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if scatter(mid) <= target:
            hi = mid
        else:
            lo = mid
    return hi


def _amplitude_room(
    r: DesignRequest, surface_room_deg: tuple[float, float] | None
) -> tuple[float, str]:
    """How far the amplitude may go (deg) and what limits it (for the messages): the
    saturation margin, the elevator's range about trim, the largest amplitude a scenario
    takes (``AMPLITUDE_MAX``), the first of the smallest."""
    limits = {SATURATION: math.inf}
    if r.saturation_deg is not None:
        lo, up = r.saturation_deg
        if not lo < 0.0 < up:
            raise DesignError(
                f"saturation [{lo:g}, {up:g}] deg does not contain the trim (0): "
                "the probe cannot get through both ways"
            )
        limits[SATURATION] = min(-lo, up)
    if surface_room_deg is not None:
        limits[SURFACE_RANGE] = min(surface_room_deg)
    limits[LARGEST_AMPLITUDE] = AMPLITUDE_MAX["deg"]
    limit = min(limits, key=limits.__getitem__)
    return limits[limit], limit


def _amplitude(
    r: DesignRequest, surface_room_deg: tuple[float, float] | None, reasons: dict[str, str]
) -> float:
    """The amplitude a (deg) by the amplitude rule; its reason goes into ``reasons``."""
    room, limit = _amplitude_room(r, surface_room_deg)
    if r.deadband_deg is not None:
        lo, up = r.deadband_deg
        half = max(-lo, up)
        need = r.deadband_margin * half
        if half >= room or need > room:
            raise DesignError(no_amplitude(r, half, room, limit))
        a = min(max(need, r.amplitude_deg), room)
        reasons["amplitude_deg"] = (
            f"clears the deadband: a >= {r.deadband_margin:g} x {half:g} deg"
            + f", inside the {limit} {room:g} deg"
            + f"; apparent a~ = {a - half:.3g} deg for a symmetric band"
        )
    else:
        a = min(r.amplitude_deg, room)
        reasons["amplitude_deg"] = f"default {r.amplitude_deg:g} deg" + (
            f", capped by the {limit} {room:g} deg" if a < r.amplitude_deg else ""
        )
    return a


def _bit_duration(r: DesignRequest, a: float, reasons: dict[str, str]) -> float:
    """The bit duration t0 (s) by eq. (21); its reason goes into ``reasons``."""
    steps = 1
    if r.rate_limit_deg_s is not None:
        t_min = RateLimit(r.rate_limit_deg_s).shortest_bit_s(a)
        steps = max(1, math.ceil(t_min / r.dt_s - 1e-9))
        reasons["bit_duration_s"] = (
            f"eq. (21) r_l >= 2a/t0: t0 >= 2a/r_l = {t_min:.4g} s, rounded up to "
            f"{steps} x dt; 2a/t0 = {RateLimit.bound(a, steps * r.dt_s):.4g} <= "
            f"r_l = {r.rate_limit_deg_s:g} deg/s"
        )
    else:
        reasons["bit_duration_s"] = "no rate limit: one simulation step per bit"
    return steps * r.dt_s


def _order(t0: float, short_period_settling_s: float, max_order: int) -> int:
    """The smallest order from 3 whose period M t0 covers the short period's settling."""
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
    return order


def probe_shape(
    request: DesignRequest,
    *,
    short_period_settling_s: float,
    phugoid_settling_s: float,
    surface_room_deg: tuple[float, float] | None = None,
    max_order: int = 16,
) -> ProbeShape:
    """Order, bit duration and amplitude by the rules of the module docstring (pure).

    ``surface_room_deg`` is how far the elevator can move below and above its trim (deg);
    ``request`` holds values :meth:`DesignRequest.validate` accepts.

    Raises
    ------
    DesignError
        When no amplitude, bit duration or order meets every rule; the message names the
        conflict.
    """
    r = request
    reasons: dict[str, str] = {}
    warnings: list[str] = []
    a = _amplitude(r, surface_room_deg, reasons)
    t0 = _bit_duration(r, a, reasons)
    if math.isfinite(short_period_settling_s) and t0 > short_period_settling_s / 10:
        warnings.append(
            f"t0 = {t0:g} s is longer than a tenth of the short-period settling time "
            f"({short_period_settling_s:.3g} s): the pulse response is coarsely resolved"
        )
    order = _order(t0, short_period_settling_s, max_order)
    shape = ProbeShape(order, t0, a, reasons, warnings)
    reasons["order"] = (
        f"T = M t0 = {shape.memory_s:.3g} s >= short-period settling 4/(zeta wn) = "
        f"{short_period_settling_s:.3g} s"
    )
    if phugoid_settling_s > shape.memory_s:
        warnings.append(
            f"the phugoid (settling {phugoid_settling_s:.3g} s) is not covered by T = "
            f"{shape.memory_s:.3g} s: its tail folds into the taps (eq. 8) and its transient "
            "biases the settled estimates (predicted_h_bias)"
        )
    return shape


def recommend(request: DesignRequest) -> tuple[Design, LongitudinalModes, Scenario]:
    """Validate the request, trim and linearise the aircraft, apply the rules, predict.

    Returns
    -------
    Design
        The recommendation, its predictions and reasons.
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
        When no design meets every rule or the target, or the design is no valid scenario.
    """
    base = request.validate()
    plant = make_plant(base.flight)
    drive = plant.drive()
    lo, hi = drive.range
    trim = drive.trim_position
    room = (trim - lo, hi - trim)
    modes = longitudinal_modes(plant)
    shape = probe_shape(
        request,
        short_period_settling_s=modes.short_period_settling_s,
        phugoid_settling_s=modes.phugoid_settling_s,
        surface_room_deg=room,
    )
    scn = _scenario(request, base, shape, request.estimator or "streaming", 1)
    # the residual is measured in turbulence, and with sensors whose noise the loop carries
    gusts = Gusts(request.calibration_seeds, scn.turbulence != "none" or scn.sensors is not None)
    target = request.target
    estimator, scores = _estimator(request, scn, gusts, target)
    scn = _scenario(request, base, shape, estimator, 4)
    window = None
    if request.window_periods is not None:
        shape, window = _window(request, base, shape, scn, gusts, modes, room)
        scn = window.scenario
    reference = noise_free_reference(scn)
    pred = predict(scn, extra_samples=gusts.of(scn), reference=reference)[request.channel]
    if target is not None and window is None:
        scn, reference, pred = _meet(request, shape, scn, reference, gusts, target)
    reasons, warnings = said(request, shape, scn, window, (estimator, scores), pred, gusts)
    if request.closed_loop:  # the linearisation is the open loop's: no bias of the loop's h
        pred = replace(pred, h_bias=math.nan)
    design = Design(
        order=shape.order,
        bits_per_period=shape.bits_per_period,
        bit_duration_s=shape.bit_duration_s,
        memory_s=shape.memory_s,
        amplitude_deg=shape.amplitude_deg,
        periods=scn.periods,
        settle_periods=scn.settle_periods,
        estimator=estimator,
        drift=scn.drift,
        channel=request.channel,
        predicted_gain_stderr=pred.gain_stderr,
        predicted_h_stderr=pred.h_stderr,
        predicted_z_stderr=pred.z_stderr,
        predicted_h_bias=pred.h_bias,
        short_period_settling_s=modes.short_period_settling_s,
        phugoid_settling_s=modes.phugoid_settling_s,
        scenario_toml=_toml(scn, request),
        reasons=reasons,
        warnings=warnings + notes(request, pred),
        estimators=scores,
        window=window_dict(request, window),
    )
    return design, modes, scn


# ------------------------------------------------------------------ helpers of recommend
def _window(
    request: DesignRequest,
    base: Scenario,
    shape: ProbeShape,
    scn: Scenario,
    gusts: Gusts,
    modes: LongitudinalModes,
    surface_room: tuple[float, float],
) -> tuple[ProbeShape, WindowDesign]:
    """``--window-periods``: the smallest amplitude whose gain standard error over a window
    of W periods against a baseline of B meets the target (:mod:`design_window`), on a
    design of B + W settled periods; the residual is flown at each amplitude tried (and
    kept in ``gusts`` for the prediction); ``surface_room``: deg below and above trim."""
    w, b = request.window_periods or 1, request.baseline_periods
    shapes = {shape.amplitude_deg: shape}

    def build(amplitude_deg: float) -> Scenario:
        found = probe_shape(
            replace(request, amplitude_deg=amplitude_deg),
            short_period_settling_s=modes.short_period_settling_s,
            phugoid_settling_s=modes.phugoid_settling_s,
            surface_room_deg=surface_room,
        )
        shapes[found.amplitude_deg] = found
        return _scenario(request, base, found, scn.estimator, b + w)

    flown: dict[float, dict[str, np.ndarray]] = {}

    def sigma_of(design: Scenario) -> float:
        samples = turbulence_residual(design, gusts.seeds) if gusts.on else {}
        flown[design.amplitude_deg] = samples
        h_ref = noise_free_reference(design)[request.channel]
        return period_gain_std(design, samples, h_ref, request.channel)

    goal = request.gain_goal(scn.period_s)
    room = _amplitude_room(request, surface_room)
    factor_of = None
    if request.within_periods is not None:
        reduce = window_matrix(scn.bits_per_period, MonitorSettings().windows)
        alpha = request.false_alarm_of(scn.period_s)
        periods = (w, b, request.within_periods)

        def factor_of(design: Scenario, sigma: float) -> float:
            cov = period_covariance(design, flown[design.amplitude_deg], request.channel, reduce)
            v0 = dot(reduce, noise_free_reference(design)[request.channel])
            change = -request.detect_gain_change * v0  # a drop: the test is two-sided
            return detection_scale(change, cov, v0, alpha, periods, request.detection_probability)

    found = smallest_amplitude(
        with_periods(scn, b + w), build, sigma_of, goal, (w, b), room, factor_of
    )
    gusts.samples, gusts.periods = flown[found.amplitude_deg], found.scenario.periods
    return shapes[found.amplitude_deg], found


def _scenario(
    request: DesignRequest, base: Scenario, shape: ProbeShape, estimator: str, periods: int
) -> Scenario:
    """The scenario of a probe shape (the first nonlinearity asked about, if any)."""
    changes: dict[str, Any] = {
        "probe.order": shape.order,
        "probe.bit_duration_s": shape.bit_duration_s,
        "probe.amplitude_deg": shape.amplitude_deg,
        "probe.periods": request.settle_periods + periods,
        "output.estimator": estimator,
    }
    nonlinearities = request.nonlinearities()
    if nonlinearities:
        changes.update({f"nonlinearity.{k}": v for k, v in nonlinearities[0][1].items()})
    try:
        return base.replace(changes)
    except ScenarioError as exc:
        raise DesignError(f"the design is no valid scenario: {exc.field}: {exc.message}") from None


def _score(p: ChannelPrediction, kind: str) -> float:
    return p.gain_stderr if kind == "gain" else p.h_stderr


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


#: Candidates in the order of their scatter under white sensor noise (docs/noise.md, "The
#: three estimators"), the preferred first on a tie; without any noise the first is taken.
def _estimator(
    request: DesignRequest, scn: Scenario, gusts: Gusts, target: tuple[str, float] | None
) -> tuple[str, dict[str, float]]:
    """The estimator with the smallest predicted scatter of the target, one settled period
    each (``ac`` does not estimate h itself, so it is no candidate for an h target)."""
    kind = target[0] if target else "gain"
    scores = {}
    for name in CANDIDATES[kind]:
        candidate = replace(scn, output_section=replace(scn.output_section, estimator=name))
        found = predict(candidate, extra_samples=gusts.of(candidate))[request.channel]
        scores[name] = _score(found, kind)
    if request.estimator is not None:
        return request.estimator, scores
    if request.noiseless:  # every scatter is 0: the least under sensor noise
        return CANDIDATES[kind][0], scores
    finite = [k for k in CANDIDATES[kind] if math.isfinite(scores[k])]
    if not finite:
        return CANDIDATES[kind][0], scores
    return min(finite, key=lambda k: (scores[k], CANDIDATES[kind].index(k))), scores


def _meet(
    request: DesignRequest,
    shape: ProbeShape,
    scn: Scenario,
    reference: dict[str, np.ndarray],
    gusts: Gusts,
    target: tuple[str, float],
) -> tuple[Scenario, dict[str, np.ndarray], ChannelPrediction]:
    """The fewest settled periods that meet the target, with the gain's reference and the
    turbulence residual flown as long (the slow-mode bias, hence the direction the gain
    projects on, and the turbulence residual, which grows as the gusts move the aircraft,
    both depend on the length): search with them, fly them at the length found, search
    again, until the length no longer moves; then lengthen until the prediction meets the
    target.  Beyond the turbulence flown, the search takes its variance to fall as 1/P."""
    kind, goal = target
    channel = request.channel
    limit = MAX_PERIODS - request.settle_periods

    def variance(model: NoiseModel, h_ref: np.ndarray) -> float:
        if kind == "gain":
            return model.gain_std(h_ref) ** 2
        return float(np.mean(model.h_std() ** 2))

    def scatter(p: int, h_ref: np.ndarray) -> float:
        flown = gusts.periods - scn.settle_periods  # settled periods the turbulence covers
        if not gusts.on or p <= flown:
            at_p = with_periods(scn, p)
            return math.sqrt(variance(scatter_models(at_p, None, gusts.of(at_p))[channel], h_ref))
        at_flown = with_periods(scn, flown)
        total = variance(scatter_models(at_flown, None, gusts.of(at_flown))[channel], h_ref)
        turbulence = max(total - variance(scatter_models(at_flown)[channel], h_ref), 0.0)
        sensor = variance(scatter_models(with_periods(scn, p))[channel], h_ref)
        return math.sqrt(sensor + turbulence * flown / p)

    tried: set[int] = set()
    while True:
        try:
            h_ref = reference[channel]
            periods = fewest_periods(lambda p, h_ref=h_ref: scatter(p, h_ref), goal, limit)
        except DesignError as exc:
            raise DesignError(too_tight(request, shape, kind, goal, exc)) from None
        done = periods in tried or periods == scn.settled_periods
        tried.add(periods)
        scn = with_periods(scn, periods)
        reference = noise_free_reference(scn)
        pred = predict(scn, extra_samples=gusts.of(scn), reference=reference)[channel]
        if done or len(tried) >= 6:
            break
    while _score(pred, kind) > goal and scn.settled_periods < limit:
        grow = (_score(pred, kind) / goal) ** 2
        periods = min(limit, max(scn.settled_periods + 1, math.ceil(scn.settled_periods * grow)))
        scn = with_periods(scn, periods)
        reference = noise_free_reference(scn)
        pred = predict(scn, extra_samples=gusts.of(scn), reference=reference)[channel]
    return scn, reference, pred


def _toml(scn: Scenario, request: DesignRequest) -> str:
    """The scenario as a file ``probing run`` accepts as is."""
    import tomli_w

    header = (
        f"# probing design --aircraft {request.aircraft} --altitude-ft {request.altitude_ft:g} "
        f"--speed-kcas {request.speed_kcas:g} ...\n"
    )
    return header + tomli_w.dumps(scn.to_dict())
