"""The sections of a scenario file, each read and checked: one parser per section.

:mod:`probing.experiment.scenario.scenario` builds the
:class:`~probing.experiment.scenario.Scenario` from them; this module does not import it (a
parser that needs the scenario read so far is given it as ``scn``).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from probing.core.faults import FAULTS
from probing.core.gust import GUST_REFERENCE_SENSORS
from probing.core.monitor import MonitorSettings, SettingError
from probing.core.multiplex import DESIGNS
from probing.core.noise import ESTIMATOR_NAMES
from probing.core.nonlinearities import NONLINEARITIES, ParameterError
from probing.core.prbs import MAX_ORDER, MIN_ORDER, steps_per_bit
from probing.core.sensors import SENSOR_SUITES, Sensor, SensorSpecError, SensorSuite
from probing.experiment.scenario.probe_signal import parse_excitation
from probing.experiment.scenario.schema import (
    DEFAULT_MAX_CROSSTALK,
    DRIFT_MODES,
    GUST_KNOWING_DRIFTS,
    MAX_DEG,
    MAX_DEG_S,
    MAX_PERIODS,
    SENSOR_FIELDS,
    ScenarioError,
    Simultaneous,
    choice,
    field_label,
    instant_in_run,
    integer,
    number,
)
from probing.sim.aircraft import find_aircraft, is_path
from probing.sim.channels import CHANNEL_NAMES
from probing.sim.errors import AircraftNotFoundError
from probing.sim.flight import (
    DAMAGE_CASES,
    DAMAGE_MODEL,
    LOOP_SENSORS,
    MANOEUVRE_HOLDS,
    SPEED_KINDS,
    TURBULENCE_SEVERITY,
    Control,
    Manoeuvre,
)
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACE_NAMES, SURFACES


def _manoeuvre(section: dict[str, Any], scn: Any) -> Manoeuvre:
    """The ``[manoeuvre]`` section: which hold loop's reference ramps, by how much, how fast
    and when; the loop must be closed, and the probe path linear."""
    if "hold" not in section:
        raise ScenarioError("manoeuvre.hold", f"missing (one of {', '.join(MANOEUVRE_HOLDS)})")
    hold = choice(section, "manoeuvre", "hold", tuple(MANOEUVRE_HOLDS))
    unit = MANOEUVRE_HOLDS[hold][0]
    own = {"hold", "start_s", f"change_{unit}", f"rate_{unit}_s"}
    for key in section:
        if key not in own:
            raise ScenarioError(
                f"manoeuvre.{key}", f"not a field of a {hold} manoeuvre: {', '.join(sorted(own))}"
            )
    for key in sorted(own):
        if key not in section:
            raise ScenarioError(f"manoeuvre.{key}", "missing")
    limit = 60.0 if unit == "deg" else 200.0
    change = number(section, "manoeuvre", f"change_{unit}", lo=-limit, hi=limit)
    rate = number(section, "manoeuvre", f"rate_{unit}_s", lo=0, hi=100, lo_open=True)
    duration_s = scn.total_steps * scn.dt_s
    start = instant_in_run(section, "manoeuvre", "start_s", duration_s)
    if scn.control is None or not getattr(scn.control, f"{hold}_hold"):
        raise ScenarioError(
            "manoeuvre.hold", f"a {hold} manoeuvre needs [control] {hold}_hold = true"
        )
    _alone("manoeuvre", scn, ("nonlinearity", "fault", "monitor", "simultaneous"))
    if scn.estimator != "cyclic":
        raise ScenarioError(
            "manoeuvre", 'needs output.estimator = "cyclic": each period is estimated alone'
        )
    return Manoeuvre(hold, change, rate, start)


#: Largest probe amplitude in each surface unit: 10 deg, or half the throttle lever.
AMPLITUDE_MAX = {"deg": 10.0, "norm": 0.5}


def _amplitude(probe: dict[str, Any], unit: str, surface: str) -> float:
    """The probe amplitude, named with the probed surface's unit (``amplitude_deg``, or
    ``amplitude_norm`` for the throttle): deg up to 10, a throttle lever up to 0.5."""
    key = f"amplitude_{unit}"
    other = "amplitude_norm" if unit == "deg" else "amplitude_deg"
    if other in probe:
        raise ScenarioError(
            f"probe.{other}", f"the {surface} is probed in {unit}: give probe.{key} instead"
        )
    if key not in probe:
        raise ScenarioError(f"probe.{key}", "missing")
    return number(probe, "probe", key, lo=0, hi=AMPLITUDE_MAX[unit], lo_open=True)


def _alone(section: str, scn: Any, without: tuple[str, ...]) -> None:
    """``[section]`` is offered on a linear probe path only: none of the sections ``without``
    (``nonlinearity`` counts when its type is not ``none``)."""
    present = {
        "nonlinearity": scn.nonlinearity != "none",
        "fault": scn.fault_type != "none",
        "control": scn.control is not None,
        "monitor": scn.monitor is not None,
        "simultaneous": scn.simultaneous is not None,
    }
    for name in without:
        if present[name]:
            raise ScenarioError(section, f"is offered without [{name}] (a linear probe path)")


def _simultaneous(data: dict[str, Any], scn: Any) -> Simultaneous:
    """The ``[simultaneous]`` section: the surfaces probed besides ``probe.surface``, their
    amplitudes (each in its surface's unit), the design, and what it offers only alone."""
    section = data["simultaneous"]
    for key in ("design", "also_surfaces", "also_amplitudes"):
        if key not in section:
            raise ScenarioError(f"simultaneous.{key}", "missing")
    design = choice(section, "simultaneous", "design", tuple(DESIGNS))
    also, amplitudes = section["also_surfaces"], section["also_amplitudes"]
    surfaces = [scn.surface, *also] if isinstance(also, list) else []
    if (
        not surfaces
        or not also
        or any(s not in SURFACE_NAMES for s in also)
        or len(set(surfaces)) != len(surfaces)
    ):
        raise ScenarioError(
            "simultaneous.also_surfaces",
            f"must be a non-empty list of distinct surfaces from {', '.join(SURFACE_NAMES)}, "
            f"without probe.surface ({scn.surface})",
        )
    if not isinstance(amplitudes, list) or len(amplitudes) != len(also):
        raise ScenarioError(
            "simultaneous.also_amplitudes",
            f"must be a list of {len(also)} amplitude(s), one per surface, in its unit",
        )
    levels = [scn.amplitude_deg]
    for surface, value in zip(also, amplitudes, strict=True):
        hi = AMPLITUDE_MAX[SURFACES[surface].unit]  # each in its surface's unit
        levels.append(
            number(
                {surface: value}, "simultaneous.also_amplitudes", surface, lo=0, hi=hi, lo_open=True
            )
        )
    max_crosstalk = (
        number(section, "simultaneous", "max_crosstalk", lo=0, hi=0.5, lo_open=True)
        if "max_crosstalk" in section
        else DEFAULT_MAX_CROSSTALK
    )
    _alone("simultaneous", scn, ("nonlinearity", "fault", "control", "monitor"))
    if scn.drift not in (*GUST_KNOWING_DRIFTS, "none") or scn.estimator != "cyclic":
        raise ScenarioError(
            "simultaneous",
            'needs output.estimator = "cyclic" and output.drift = "reference", "oracle" or "none"',
        )
    return Simultaneous(design, tuple(surfaces), tuple(levels), max_crosstalk)


def check_baseline(scn: Any, settings: MonitorSettings, given: bool | None) -> None:
    """A monitor's baseline must leave one settled period of the run to test (its bound by
    ``windows`` is :class:`MonitorSettings`' own).  ``given``: the section gave it (True),
    left it to its default (False), or there is no ``[monitor]`` section at all (None)."""
    windows, baseline = settings.windows, settings.baseline_periods
    settled = scn.periods - max(scn.settle_periods, scn.first_estimated_period)
    if baseline < settled:
        return
    what = f"{baseline}" if given else f"the default, {baseline},"
    missing = "" if given is not None else "the scenario has no [monitor] section, and "
    raise ScenarioError(
        "monitor.baseline_periods",
        f"{missing}must be more than windows + 1 ({windows + 1}) and fewer than the run's "
        f"{settled} settled periods; {what} is not",
    )


def _monitor(monitor: dict[str, Any] | None, scn: Any) -> dict[str, Any]:
    """The ``[monitor]`` section: the detector's settings (each checked by
    :class:`MonitorSettings` itself), with a baseline that fits the run and the surface's
    channel among the outputs if it isolates."""
    if monitor is None:
        return {}
    try:
        settings = MonitorSettings(**monitor)
    except SettingError as exc:
        default = "" if exc.field in monitor else " (the default)"
        raise ScenarioError(f"monitor.{exc.field}", f"{exc.message}{default}") from None
    check_baseline(scn, settings, given="baseline_periods" in monitor)
    channel = scn.surface_channel
    if settings.surface and (channel not in scn.channels or len(scn.channels) < 2):
        raise ScenarioError(
            "monitor.surface",
            f"needs {channel} and at least one other channel in output.channels",
        )
    return {"monitor": settings}


def _control(control: dict[str, Any] | None) -> dict[str, Any]:
    """The ``[control]`` section: switches (booleans) and bandwidths, validated."""
    if control is None:
        return {}
    values: dict[str, Any] = {}
    for f in dataclasses.fields(Control):
        if f.name not in control:
            continue
        value = control[f.name]
        if f.type in ("bool", bool):
            if not isinstance(value, bool):
                raise ScenarioError(f"control.{f.name}", f"must be true or false, got {value!r}")
            values[f.name] = value
        elif f.name == "damping":
            values[f.name] = number(control, "control", f.name, lo=0.1, hi=2.0)
        elif f.name == "integral_time_s":
            values[f.name] = number(control, "control", f.name, lo=0, hi=1000)
        else:
            values[f.name] = number(control, "control", f.name, lo=0, hi=50, lo_open=True)
    return {"control": Control(**values)}


def _fault(fault: dict[str, Any] | None, scn: Any) -> dict[str, Any]:
    """The ``[fault]`` section, validated: a type, its own fields and its onset within the run."""
    if not fault:
        return {}
    model, duration_s = scn.model, scn.total_steps * scn.dt_s
    if "type" not in fault:
        raise ScenarioError("fault.type", f"missing (one of {', '.join(FAULTS)})")
    kind = choice(fault, "fault", "type", tuple(FAULTS))
    entry = FAULTS[kind]
    named = [fault.get(f.name) for f in entry.fields if f.kind == "nonlinearity"]
    known = named and isinstance(named[0], str) and named[0] in NONLINEARITIES
    nonlinearity = named[0] if known else None  # an unknown one is refused below
    for key in fault:
        message = entry.not_a_field(key, nonlinearity)
        if message is not None:
            raise ScenarioError(f"fault.{field_label(key)}", message)
    for key in ("onset_s", *entry.names):
        if key not in fault:
            raise ScenarioError(f"fault.{key}", f"missing (required for {kind})")
    onset = instant_in_run(fault, "fault", "onset_s", duration_s)
    values: dict[str, Any] = {}
    for f in entry.fields:
        if f.kind == "number":
            values[f.name] = number(fault, "fault", f.name, lo=f.lo, hi=f.hi)
        elif f.kind == "damage_case":
            values[f.name] = _damage_case(fault, model, kind, f.name)
        elif f.kind == "channel":
            values[f.name] = _output_channel(fault, f.name, scn.channels)
        else:  # a nonlinearity: its type, and its own parameters beside it
            others = ("type", "onset_s", *(n for n in entry.names if n != f.name))
            nl_type, params = parse_nonlinearity(
                fault, section="fault", type_key=f.name, others=others
            )
            if nl_type == "none":
                raise ScenarioError(f"fault.{f.name}", "must name a nonlinearity, not none")
            values.update({f.name: nl_type, **params})
    return {"fault_type": kind, "fault_onset_s": onset, "fault_values": values}


def _output_channel(fault: dict[str, Any], key: str, channels: tuple[str, ...]) -> str:
    """A fault's channel: one of the scenario's output channels (``[output] channels``)."""
    value = fault[key]
    if not isinstance(value, str) or value not in channels:
        raise ScenarioError(
            f"fault.{key}",
            f"must be one of the output channels ({', '.join(channels)}); got {value!r}",
        )
    return value


def _damage_case(fault: dict[str, Any], model: str, kind: str, key: str = "case") -> int:
    """The NASA damage case of a ``gtm_damage`` fault: 1..6 or its name, on the GTM only."""
    if model != DAMAGE_MODEL:
        raise ScenarioError("fault.type", f"{kind} exists for {DAMAGE_MODEL} only, not {model}")
    case = fault[key]
    names = {name: k for k, name in enumerate(DAMAGE_CASES, start=1)}
    if isinstance(case, str) and case in names:
        case = names[case]
    elif isinstance(case, bool) or case not in range(1, len(DAMAGE_CASES) + 1):
        raise ScenarioError(
            f"fault.{key}", f"must be 1..{len(DAMAGE_CASES)} or one of {', '.join(names)}"
        )
    return int(case)


def parse_nonlinearity(
    nl_data: dict[str, Any],
    section: str = "nonlinearity",
    type_key: str = "type",
    others: tuple[str, ...] = (),
) -> tuple[str, dict[str, float]]:
    """A nonlinearity's type and parameters (the ``[nonlinearity]`` section, or the fields of
    a ``nonlinearity`` fault), validated by building the class.

    The schema checks that each parameter is a number within the deflection range
    (|x| <= 90 deg, rates up to 1e6 deg/s); every other rule (signs, the order of the edges)
    is the class's own (:mod:`probing.core.nonlinearities`), whose error names the argument.
    ``others`` are the section's fields that are not the nonlinearity's.
    """
    nl_type = choice(nl_data, section, type_key, tuple(NONLINEARITIES))
    kind = NONLINEARITIES[nl_type]
    for key in nl_data:
        if key != type_key and key not in others and key not in kind.names:
            allowed = ", ".join(kind.names) if kind.names else "no parameters"
            raise ScenarioError(
                f"{section}.{field_label(key)}", f"not a parameter of {nl_type} (takes {allowed})"
            )
    params: dict[str, float] = {}
    for p in kind.parameters:
        if p.name not in nl_data:
            raise ScenarioError(f"{section}.{p.name}", f"missing (required for {nl_type})")
        hi = MAX_DEG_S if p.unit == "deg/s" else MAX_DEG
        params[p.name] = number(nl_data, section, p.name, lo=-hi, hi=hi)
    try:
        kind.build(params)
    except ParameterError as exc:
        param = kind.parameter(exc.argument)
        names = {q.argument: q.name for q in kind.parameters}
        raise ScenarioError(
            f"{section}.{param.name}",
            f"{exc.requirement(names)}, got {params[param.name]:g}",
        ) from None
    return nl_type, params


# ------------------------------------------------------------- the sections, in file order
def resolve_model(model: str, folder: Path | None) -> str:
    """``aircraft.model`` as a scenario keeps it: a plain name as it is, a folder's path made
    absolute from ``folder`` (the file that gives it; None: the current folder)."""
    if not is_path(model):
        return model
    return str(((folder or Path.cwd()) / Path(model).expanduser()).resolve())


def parse_aircraft(data: dict[str, Any], folder: Path | None = None) -> str:
    """The ``[aircraft]`` section: a model found among the aircraft files, or the path of an
    aircraft folder, relative to ``folder`` (the scenario file's; else the current folder),
    returned absolute."""
    model = data["aircraft"]["model"]
    if not isinstance(model, str):
        raise ScenarioError("aircraft.model", f"must be a string, got {model!r}")
    model = resolve_model(model, folder)
    try:
        find_aircraft(model)  # looks at files only: no JSBSim is loaded
    except AircraftNotFoundError as exc:
        raise ScenarioError("aircraft.model", str(exc).replace("aircraft.model ", "")) from None
    return model


def parse_condition(cond: dict[str, Any]) -> dict[str, Any]:
    """The ``[condition]`` section: altitude, exactly one speed, flight-path angle and bank."""
    altitude = number(cond, "condition", "altitude_ft", lo=0, hi=60000, lo_open=True)
    speeds = [k for k in SPEED_KINDS if k in cond]
    if len(speeds) != 1:
        raise ScenarioError("condition", f"give exactly one of {', '.join(SPEED_KINDS)}")
    kind = speeds[0]
    speed = number(cond, "condition", kind, lo=0, hi=SPEED_KINDS[kind].upper, lo_open=True)
    gamma = number(cond, "condition", "gamma_deg", lo=-30, hi=30) if "gamma_deg" in cond else 0.0
    bank = number(cond, "condition", "bank_deg", lo=-80, hi=80) if "bank_deg" in cond else 0.0
    return {
        "altitude_ft": altitude,
        "speed_kind": kind,
        "speed": speed,
        "gamma_deg": gamma,
        "bank_deg": bank,
    }


def parse_probe(probe: dict[str, Any], dt: float) -> dict[str, Any]:
    """The ``[probe]`` section: surface, order, bit duration (whole steps of ``dt``),
    amplitude and periods."""
    surface = (
        choice(probe, "probe", "surface", SURFACE_NAMES) if "surface" in probe else DEFAULT_SURFACE
    )
    order = integer(probe, "probe", "order", lo=MIN_ORDER, hi=MAX_ORDER)
    bit = number(probe, "probe", "bit_duration_s", lo=0, hi=10, lo_open=True)
    try:
        steps_per_bit(bit, dt)  # the probe's own rule
    except ValueError:
        raise ScenarioError(
            "probe.bit_duration_s",
            f"must be an integer multiple of simulation.dt_s ({dt:g}), got {bit:g}",
        ) from None
    amplitude = _amplitude(probe, SURFACES[surface].unit, surface)
    periods = integer(probe, "probe", "periods", lo=2, hi=MAX_PERIODS)
    settle = integer(probe, "probe", "settle_periods", lo=0, hi=periods - 1)
    return {
        "surface": surface,
        "order": order,
        "bit_duration_s": bit,
        "amplitude_deg": amplitude,
        "periods": periods,
        "settle_periods": settle,
        "excitation": parse_excitation(probe, order, bit),
    }


def parse_output(out: dict[str, Any]) -> dict[str, Any]:
    """The ``[output]`` section: channels, drift correction, detrending order, estimator."""
    channels = out["channels"]
    if (
        not isinstance(channels, list)
        or not channels
        or any(not isinstance(c, str) or c not in CHANNEL_NAMES for c in channels)
        or len(set(channels)) != len(channels)
    ):
        raise ScenarioError(
            "output.channels",
            f"must be a non-empty list of distinct names from {', '.join(CHANNEL_NAMES)}",
        )
    drift = choice(out, "output", "drift", DRIFT_MODES) if "drift" in out else "reference"
    detrend_order = (
        integer(out, "output", "detrend_order", lo=0, hi=3) if "detrend_order" in out else 1
    )
    estimator = (
        choice(out, "output", "estimator", ESTIMATOR_NAMES)
        if "estimator" in out
        else None  # the signal's own (check_estimator)
    )
    return {
        "channels": tuple(channels),
        "drift": drift,
        "detrend_order": detrend_order,
        "estimator": estimator,
    }


def parse_disturbance(dist: dict[str, Any], channels: tuple[str, ...]) -> dict[str, Any]:
    """The ``[disturbance]`` section: turbulence, its seed, and sensor noise on output
    channels."""
    turbulence = (
        choice(dist, "disturbance", "turbulence", tuple(TURBULENCE_SEVERITY))
        if "turbulence" in dist
        else "none"
    )
    seed = integer(dist, "disturbance", "seed", lo=0, hi=2**31 - 1) if "seed" in dist else 0
    noise_in = dist.get("sensor_noise", {})
    if not isinstance(noise_in, dict):
        raise ScenarioError("disturbance.sensor_noise", "must be a table {channel = sigma}")
    noise: dict[str, float] = {}
    for ch in noise_in:
        if ch not in channels:
            raise ScenarioError(
                f"disturbance.sensor_noise.{field_label(ch)}",
                f"not an output channel (channels: {', '.join(channels)})",
            )
        noise[ch] = number(noise_in, "disturbance.sensor_noise", ch, lo=0, hi=1e6)
    return {"turbulence": turbulence, "sensor_noise": noise, "seed": seed}


def _sensors(section: dict[str, Any], scn: Any) -> dict[str, Any]:
    """The ``[sensors]`` section: a suite of :data:`probing.core.sensors.SENSOR_SUITES` and,
    per channel, a table of :class:`~probing.core.sensors.SensorSpec` fields that override
    the suite's; then what it asks of the rest of the scenario (``docs/scenarios.md``)."""
    if "suite" not in section:
        raise ScenarioError("sensors.suite", f"missing (one of {', '.join(SENSOR_SUITES)})")
    name = choice(section, "sensors", "suite", tuple(SENSOR_SUITES))
    suite: SensorSuite = SENSOR_SUITES[name]
    overrides: dict[str, dict[str, float]] = {}
    for channel, table in section.items():
        if channel == "suite":
            continue
        label = f"sensors.{field_label(channel)}"
        if channel not in suite.sensors:
            raise ScenarioError(
                label, f"not a sensor of the {name} suite (it has {', '.join(suite.sensors)})"
            )
        if not isinstance(table, dict):
            raise ScenarioError(
                label, f"must be a table of sensor fields ({', '.join(SENSOR_FIELDS)})"
            )
        values: dict[str, float] = {}
        for key, value in table.items():
            where = f"{label}.{field_label(key)}"
            if key not in SENSOR_FIELDS:
                raise ScenarioError(
                    where, f"not a sensor field (fields: {', '.join(SENSOR_FIELDS)})"
                )
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ScenarioError(where, f"must be a number, got {value!r}")
            values[key] = float(value)
        try:  # the sensor's own checks, and its sample rate against the step
            Sensor(suite.sensors[channel].replace(**values), scn.dt_s)
        except SensorSpecError as exc:
            raise ScenarioError(f"{label}.{exc.field}", str(exc)) from None
        if values:  # an empty table changes nothing, and is not written back
            overrides[channel] = values
    resolved = suite.with_overrides(overrides)
    _sensors_fit(scn, resolved)
    return {"sensors": resolved, "sensor_overrides": overrides}


def _sensors_fit(scn: Any, suite: SensorSuite) -> None:
    """What ``[sensors]`` asks of the rest of the scenario: no other sensor noise, a sensor
    for every output channel and every channel a switched-on autopilot loop flies on, and
    neither ``[simultaneous]`` nor ``[manoeuvre]`` (not yet)."""
    if scn.sensor_noise:
        raise ScenarioError(
            "disturbance.sensor_noise",
            "the sensors' noise comes from [sensors]; drop disturbance.sensor_noise",
        )
    missing = [c for c in scn.channels if c not in suite.sensors]
    if missing:
        raise ScenarioError(
            "output.channels",
            f"{', '.join(missing)}: no sensor in the {suite.name} suite, and an aircraft "
            "measures only what its sensors do",
        )
    control = scn.control
    for loop, channels in LOOP_SENSORS.items():
        lacking = [c for c in channels if c not in suite.sensors]
        if control is not None and getattr(control, loop) and lacking:
            raise ScenarioError(
                f"control.{loop}",
                f"flies on {', '.join(channels)}; the {suite.name} suite has no sensor of "
                f"{', '.join(lacking)}",
            )
    for other in ("simultaneous", "manoeuvre"):
        if getattr(scn, other) is not None:
            raise ScenarioError("sensors", f"not yet supported with [{other}]")


def _check_drift(scn: Any) -> None:
    """The drift modes' needs that the sections above cannot check alone: ``reference``
    only in calm air, ``gust`` with a suite that has every gust channel and a pitch hold."""
    if scn.drift == "reference" and scn.turbulence != "none":
        raise ScenarioError(
            "output.drift",
            '"reference" is a twin that flies the same gusts as the aircraft, which no real '
            'aircraft knows; with turbulence say "oracle" (that upper bound) or a realisable '
            'reference: "nominal", "gust" or "detrend"',
        )
    if scn.drift != "gust":
        return
    if scn.sensors is None:
        raise ScenarioError(
            "output.drift", '"gust" estimates the gust from the sensors: it needs [sensors]'
        )
    lacking = [c for c in GUST_REFERENCE_SENSORS if c not in scn.sensors.sensors]
    if lacking:
        raise ScenarioError(
            "output.drift",
            f'"gust" needs a sensor of every channel of {", ".join(GUST_REFERENCE_SENSORS)}; '
            f"the {scn.sensors.name} suite has none of {', '.join(lacking)}",
        )
    if scn.control is None or not scn.control.pitch_hold:
        raise ScenarioError(
            "output.drift",
            '"gust" needs [control] pitch_hold = true (its twin flies its own autopilot)',
        )


def later_sections(data: dict[str, Any], scn: Any) -> Any:
    """``scn`` (the scenario of the sections above) with the sections that depend on it:
    ``[fault]``, ``[control]``, ``[monitor]``, ``[simultaneous]``, ``[manoeuvre]`` and
    ``[sensors]``, and the drift modes' rules."""
    changes = {
        **_fault(data.get("fault"), scn),
        **_control(data.get("control")),
    }
    if scn.drift == "follow" and not (changes.get("control") and changes["control"].active):
        raise ScenarioError(
            "output.drift", "follow needs an autopilot ([control] with a loop switched on)"
        )
    if changes:
        scn = dataclasses.replace(scn, **changes)
    monitor = _monitor(data.get("monitor"), scn)
    scn = dataclasses.replace(scn, **monitor) if monitor else scn
    if "simultaneous" in data:
        scn = dataclasses.replace(scn, simultaneous=_simultaneous(data, scn))
    if "manoeuvre" in data:
        scn = dataclasses.replace(scn, manoeuvre=_manoeuvre(data["manoeuvre"], scn))
    if "sensors" in data:
        scn = dataclasses.replace(scn, **_sensors(data["sensors"], scn))
    _check_drift(scn)
    return scn
