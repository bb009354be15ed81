"""The rules that span a scenario's sections, checked in one place once every section has
parsed (:mod:`probing.experiment.scenario.sections`): a sensor noise's or a fault's channel
must be an output, a damage case needs its aircraft, ``follow`` an autopilot, a monitor a
baseline that fits the run, ``[simultaneous]`` and ``[manoeuvre]`` a linear probe path,
``[sensors]`` a sensor for every channel measured or flown on, and each drift mode what it
reads.  This module does not import the scenario: it is given it as ``scn``."""

from __future__ import annotations

from typing import Any

from probing.core.gust import GUST_REFERENCE_SENSORS
from probing.core.monitor import MonitorSettings
from probing.core.sensors import SensorSuite
from probing.experiment.scenario.references import REFERENCES
from probing.experiment.scenario.schema import ScenarioError, field_label
from probing.sim.flight import DAMAGE_MODEL, LOOP_SENSORS


def check_across(scn: Any, data: dict[str, Any]) -> None:
    """Every rule between sections, in the order of the sections they end in; ``data`` is
    the file's table (a monitor's baseline is judged by whether the file gave it).

    Raises
    ------
    ScenarioError
        On the first rule broken, naming the field and why.
    """
    _check_sensor_noise(scn)
    _check_fault(scn)
    if scn.drift == "follow" and not (scn.control is not None and scn.control.active):
        raise ScenarioError(
            "output.drift", "follow needs an autopilot ([control] with a loop switched on)"
        )
    if scn.monitor is not None:
        _check_monitor(scn, scn.monitor, "baseline_periods" in data.get("monitor", {}))
    if scn.simultaneous is not None:
        _check_simultaneous(scn)
    if scn.manoeuvre is not None:
        _check_manoeuvre(scn)
    if scn.sensors is not None:
        _check_sensors(scn, scn.sensors)
    _check_drift(scn)


def _check_sensor_noise(scn: Any) -> None:
    """``disturbance.sensor_noise`` is on output channels only."""
    for ch in scn.sensor_noise:
        if ch not in scn.channels:
            raise ScenarioError(
                f"disturbance.sensor_noise.{field_label(ch)}",
                f"not an output channel (channels: {', '.join(scn.channels)})",
            )


def _check_fault(scn: Any) -> None:
    """A fault's damage case exists on the GTM only; its channel is an output channel."""
    kind = scn.fault_kind
    if kind is None:
        return
    for f in kind.fields:
        if f.kind == "damage_case" and scn.model != DAMAGE_MODEL:
            raise ScenarioError(
                "fault.type", f"{scn.fault_type} exists for {DAMAGE_MODEL} only, not {scn.model}"
            )
        value = scn.fault_values.get(f.name)
        if f.kind == "channel" and (not isinstance(value, str) or value not in scn.channels):
            raise ScenarioError(
                f"fault.{f.name}",
                f"must be one of the output channels ({', '.join(scn.channels)}); got {value!r}",
            )


def check_baseline(scn: Any, settings: MonitorSettings, given: bool | None) -> None:
    """A monitor's baseline must leave one settled period of the run to test (its bound by
    ``windows`` is :class:`MonitorSettings`' own).  ``given``: the section gave it (True),
    left it to its default (False), or there is no ``[monitor]`` section at all (None)."""
    windows, baseline = settings.windows, settings.baseline_periods
    if baseline < scn.settled_periods:
        return
    what = f"{baseline}" if given else f"the default, {baseline},"
    missing = "" if given is not None else "the scenario has no [monitor] section, and "
    raise ScenarioError(
        "monitor.baseline_periods",
        f"{missing}must be more than windows + 1 ({windows + 1}) and fewer than the run's "
        f"{scn.settled_periods} settled periods; {what} is not",
    )


def _check_monitor(scn: Any, settings: MonitorSettings, given: bool) -> None:
    """A baseline that fits the run, and the surface's channel among the outputs if the
    monitor isolates."""
    check_baseline(scn, settings, given=given)
    channel = scn.surface_channel
    if settings.surface and (channel not in scn.channels or len(scn.channels) < 2):
        raise ScenarioError(
            "monitor.surface",
            f"needs {channel} and at least one other channel in output.channels",
        )


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


def _check_simultaneous(scn: Any) -> None:
    """``[simultaneous]`` alone on a linear path, with the cyclic estimator and a drift
    correction it offers."""
    _alone("simultaneous", scn, ("nonlinearity", "fault", "control", "monitor"))
    offered = REFERENCES[scn.drift].knows_gusts or scn.drift == "none"
    if not offered or scn.estimator != "cyclic":
        raise ScenarioError(
            "simultaneous",
            'needs output.estimator = "cyclic" and output.drift = "reference", "oracle" or "none"',
        )


def _check_manoeuvre(scn: Any) -> None:
    """``[manoeuvre]``: its hold loop closed, a linear probe path, the cyclic estimator."""
    hold = scn.manoeuvre.hold
    if scn.control is None or not getattr(scn.control, f"{hold}_hold"):
        raise ScenarioError(
            "manoeuvre.hold", f"a {hold} manoeuvre needs [control] {hold}_hold = true"
        )
    _alone("manoeuvre", scn, ("nonlinearity", "fault", "monitor", "simultaneous"))
    if scn.estimator != "cyclic":
        raise ScenarioError(
            "manoeuvre", 'needs output.estimator = "cyclic": each period is estimated alone'
        )


def _check_sensors(scn: Any, suite: SensorSuite) -> None:
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
    """The drift modes' needs: ``reference`` only in calm air, ``gust`` with a suite that
    has every gust channel and a pitch hold."""
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
