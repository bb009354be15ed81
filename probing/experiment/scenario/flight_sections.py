"""The sections a flight adds to the steady probe: ``[fault]``, ``[control]``, ``[monitor]``,
``[simultaneous]``, ``[manoeuvre]`` and ``[sensors]``, each read and checked from its table
(``parse``) and written back (``to_dict``), as :mod:`probing.experiment.scenario.sections`'
are.  None of these imports the scenario.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from probing.core.errors import is_number
from probing.core.faults import FAULTS
from probing.core.monitor import MonitorSettings, SettingError
from probing.core.multiplex import DESIGNS
from probing.core.nonlinearities import NONLINEARITIES
from probing.core.sensors import SENSOR_SUITES, Sensor, SensorSpecError, SensorSuite
from probing.experiment.scenario.schema import (
    DEFAULT_MAX_CROSSTALK,
    SENSOR_FIELDS,
    ScenarioError,
    choice,
    field_label,
    instant_in_run,
    number,
)
from probing.experiment.scenario.sections import AMPLITUDE_MAX, parse_nonlinearity
from probing.sim.flight import (
    DAMAGE_CASES,
    MANOEUVRE_HOLDS,
    Control,
    Manoeuvre,
)
from probing.sim.surfaces import SURFACE_NAMES, SURFACES


def _damage_case(table: dict[str, Any], key: str) -> int:
    """The NASA damage case of a ``gtm_damage`` fault: 1..6 or its name (on the GTM only:
    :mod:`~probing.experiment.scenario.rules`)."""
    case = table[key]
    names = {name: k for k, name in enumerate(DAMAGE_CASES, start=1)}
    if isinstance(case, str) and case in names:
        case = names[case]
    elif isinstance(case, bool) or case not in range(1, len(DAMAGE_CASES) + 1):
        raise ScenarioError(
            f"fault.{key}", f"must be 1..{len(DAMAGE_CASES)} or one of {', '.join(names)}"
        )
    return int(case)


@dataclass(frozen=True)
class FaultSection:
    """The ``[fault]`` section: a type of :data:`probing.core.faults.FAULTS`, its onset (s
    after the trim) and its own fields as the file writes them, validated."""

    type: str
    onset_s: float
    values: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def parse(cls, table: dict[str, Any], *, duration_s: float) -> FaultSection:
        """A type, its own fields and its onset within the run (``duration_s``, s); a
        channel is checked against the outputs, a damage case against the model, by
        :mod:`~probing.experiment.scenario.rules`."""
        if "type" not in table:
            raise ScenarioError("fault.type", f"missing (one of {', '.join(FAULTS)})")
        kind = choice(table, "fault", "type", tuple(FAULTS))
        entry = FAULTS[kind]
        named = [table.get(f.name) for f in entry.fields if f.kind == "nonlinearity"]
        known = named and isinstance(named[0], str) and named[0] in NONLINEARITIES
        nonlinearity = named[0] if known else None  # an unknown one is refused below
        for key in table:
            message = entry.not_a_field(key, nonlinearity)
            if message is not None:
                raise ScenarioError(f"fault.{field_label(key)}", message)
        for key in ("onset_s", *entry.names):
            if key not in table:
                raise ScenarioError(f"fault.{key}", f"missing (required for {kind})")
        onset = instant_in_run(table, "fault", "onset_s", duration_s)
        values: dict[str, Any] = {}
        for f in entry.fields:
            if f.kind == "number":
                values[f.name] = number(table, "fault", f.name, lo=f.lo, hi=f.hi)
            elif f.kind == "damage_case":
                values[f.name] = _damage_case(table, f.name)
            elif f.kind == "channel":
                values[f.name] = table[f.name]
            else:  # a nonlinearity: its type, and its own parameters beside it
                others = ("type", "onset_s", *(n for n in entry.names if n != f.name))
                nl_type, params = parse_nonlinearity(
                    table, section="fault", type_key=f.name, others=others
                )
                if nl_type == "none":
                    raise ScenarioError(f"fault.{f.name}", "must name a nonlinearity, not none")
                values.update({f.name: nl_type, **params})
        return cls(kind, onset, values)

    def to_dict(self) -> dict[str, Any]:
        """The section in its file layout."""
        return {"type": self.type, "onset_s": self.onset_s, **self.values}


# ------------------------------------------------------------------ [control]
@dataclass(frozen=True)
class ControlSection:
    """The ``[control]`` section: the autopilot (:class:`probing.sim.flight.Control`)."""

    control: Control

    @classmethod
    def parse(cls, table: dict[str, Any]) -> ControlSection:
        """Switches (booleans) and bandwidths, validated."""
        values: dict[str, Any] = {}
        for f in dataclasses.fields(Control):
            if f.name not in table:
                continue
            value = table[f.name]
            if f.type in ("bool", bool):
                if not isinstance(value, bool):
                    raise ScenarioError(
                        f"control.{f.name}", f"must be true or false, got {value!r}"
                    )
                values[f.name] = value
            elif f.name == "damping":
                values[f.name] = number(table, "control", f.name, lo=0.1, hi=2.0)
            elif f.name == "integral_time_s":
                values[f.name] = number(table, "control", f.name, lo=0, hi=1000)
            else:
                values[f.name] = number(table, "control", f.name, lo=0, hi=50, lo_open=True)
        return cls(Control(**values))

    def to_dict(self) -> dict[str, Any]:
        """The section in its file layout."""
        return self.control.to_dict()


# ------------------------------------------------------------------ [monitor]
@dataclass(frozen=True)
class MonitorSection:
    """The ``[monitor]`` section: the detector's settings
    (:class:`probing.core.monitor.MonitorSettings`)."""

    settings: MonitorSettings

    @classmethod
    def parse(cls, table: dict[str, Any]) -> MonitorSection:
        """The settings, each checked by :class:`MonitorSettings` itself (their fit to the
        run: :mod:`~probing.experiment.scenario.rules`)."""
        try:
            return cls(MonitorSettings(**table))
        except SettingError as exc:
            default = "" if exc.field in table else " (the default)"
            raise ScenarioError(f"monitor.{exc.field}", f"{exc.message}{default}") from None

    def to_dict(self) -> dict[str, Any]:
        """The section in its file layout."""
        return self.settings.to_dict()


# ------------------------------------------------------------------ [simultaneous]
@dataclass(frozen=True)
class Simultaneous:
    """The ``[simultaneous]`` section: several surfaces probed in one flight.

    Attributes
    ----------
    design : str
        A key of :data:`probing.core.multiplex.DESIGNS`.
    surfaces : tuple of str
        Every probed surface, ``probe.surface`` first.
    amplitudes : tuple of float
        Their probe amplitudes, each in its surface's unit (deg, or normalised).
    max_crosstalk : float
        The design is refused if the linearisation leaves more cross-talk than this fraction
        of the largest response of a channel (its memory condition).
    """

    design: str
    surfaces: tuple[str, ...]
    amplitudes: tuple[float, ...]
    max_crosstalk: float = DEFAULT_MAX_CROSSTALK

    @classmethod
    def parse(cls, table: dict[str, Any], *, surface: str, amplitude_deg: float) -> Simultaneous:
        """The surfaces probed besides ``surface`` (``probe.surface``, whose amplitude is
        ``amplitude_deg`` in its unit), their amplitudes (each in its surface's unit) and
        the design."""
        for key in ("design", "also_surfaces", "also_amplitudes"):
            if key not in table:
                raise ScenarioError(f"simultaneous.{key}", "missing")
        design = choice(table, "simultaneous", "design", tuple(DESIGNS))
        also, amplitudes = table["also_surfaces"], table["also_amplitudes"]
        surfaces = [surface, *also] if isinstance(also, list) else []
        if (
            not surfaces
            or not also
            or any(s not in SURFACE_NAMES for s in also)
            or len(set(surfaces)) != len(surfaces)
        ):
            raise ScenarioError(
                "simultaneous.also_surfaces",
                f"must be a non-empty list of distinct surfaces from {', '.join(SURFACE_NAMES)}"
                f", without probe.surface ({surface})",
            )
        if not isinstance(amplitudes, list) or len(amplitudes) != len(also):
            raise ScenarioError(
                "simultaneous.also_amplitudes",
                f"must be a list of {len(also)} amplitude(s), one per surface, in its unit",
            )
        levels = [amplitude_deg]
        for other, value in zip(also, amplitudes, strict=True):
            hi = AMPLITUDE_MAX[SURFACES[other].unit]  # each in its surface's unit
            levels.append(
                number(
                    {other: value}, "simultaneous.also_amplitudes", other, lo=0, hi=hi, lo_open=True
                )
            )
        max_crosstalk = (
            number(table, "simultaneous", "max_crosstalk", lo=0, hi=0.5, lo_open=True)
            if "max_crosstalk" in table
            else DEFAULT_MAX_CROSSTALK
        )
        return cls(design, tuple(surfaces), tuple(levels), max_crosstalk)

    def to_dict(self) -> dict[str, Any]:
        """The section in its file layout."""
        return {
            "design": self.design,
            "also_surfaces": list(self.surfaces[1:]),
            "also_amplitudes": list(self.amplitudes[1:]),
            "max_crosstalk": self.max_crosstalk,
        }


# ------------------------------------------------------------------ [manoeuvre]
@dataclass(frozen=True)
class ManoeuvreSection:
    """The ``[manoeuvre]`` section: an autopilot reference that moves
    (:class:`probing.sim.flight.Manoeuvre`)."""

    manoeuvre: Manoeuvre

    @classmethod
    def parse(cls, table: dict[str, Any], *, duration_s: float) -> ManoeuvreSection:
        """Which hold loop's reference ramps, by how much, how fast, and when (within the
        run, ``duration_s``, s)."""
        if "hold" not in table:
            raise ScenarioError("manoeuvre.hold", f"missing (one of {', '.join(MANOEUVRE_HOLDS)})")
        hold = choice(table, "manoeuvre", "hold", tuple(MANOEUVRE_HOLDS))
        unit = MANOEUVRE_HOLDS[hold][0]
        own = {"hold", "start_s", f"change_{unit}", f"rate_{unit}_s"}
        for key in table:
            if key not in own:
                raise ScenarioError(
                    f"manoeuvre.{key}",
                    f"not a field of a {hold} manoeuvre: {', '.join(sorted(own))}",
                )
        for key in sorted(own):
            if key not in table:
                raise ScenarioError(f"manoeuvre.{key}", "missing")
        limit = 60.0 if unit == "deg" else 200.0
        change = number(table, "manoeuvre", f"change_{unit}", lo=-limit, hi=limit)
        rate = number(table, "manoeuvre", f"rate_{unit}_s", lo=0, hi=100, lo_open=True)
        start = instant_in_run(table, "manoeuvre", "start_s", duration_s)
        return cls(Manoeuvre(hold, change, rate, start))

    def to_dict(self) -> dict[str, Any]:
        """The section in its file layout."""
        return self.manoeuvre.to_dict()


# ------------------------------------------------------------------ [sensors]
@dataclass(frozen=True)
class SensorsSection:
    """The ``[sensors]`` section: a suite of :data:`probing.core.sensors.SENSOR_SUITES` with
    its overrides applied, and the overrides as written, ``{channel: {field: value}}``."""

    suite: SensorSuite
    overrides: dict[str, dict[str, float]] = field(default_factory=dict)

    @classmethod
    def parse(cls, table: dict[str, Any], *, dt_s: float) -> SensorsSection:
        """A suite and, per channel, a table of :class:`~probing.core.sensors.SensorSpec`
        fields that override the suite's, each sensor checked at the step ``dt_s`` (s)."""
        if "suite" not in table:
            raise ScenarioError("sensors.suite", f"missing (one of {', '.join(SENSOR_SUITES)})")
        name = choice(table, "sensors", "suite", tuple(SENSOR_SUITES))
        suite: SensorSuite = SENSOR_SUITES[name]
        overrides: dict[str, dict[str, float]] = {}
        for channel, values_in in table.items():
            if channel == "suite":
                continue
            label = f"sensors.{field_label(channel)}"
            if channel not in suite.sensors:
                raise ScenarioError(
                    label, f"not a sensor of the {name} suite (it has {', '.join(suite.sensors)})"
                )
            if not isinstance(values_in, dict):
                raise ScenarioError(
                    label, f"must be a table of sensor fields ({', '.join(SENSOR_FIELDS)})"
                )
            values: dict[str, float] = {}
            for key, value in values_in.items():
                where = f"{label}.{field_label(key)}"
                if key not in SENSOR_FIELDS:
                    raise ScenarioError(
                        where, f"not a sensor field (fields: {', '.join(SENSOR_FIELDS)})"
                    )
                if not is_number(value):
                    raise ScenarioError(where, f"must be a number, got {value!r}")
                values[key] = float(value)
            try:  # the sensor's own checks, and its sample rate against the step
                Sensor(suite.sensors[channel].replace(**values), dt_s)
            except SensorSpecError as exc:
                raise ScenarioError(f"{label}.{exc.field}", str(exc)) from None
            if values:  # an empty table changes nothing, and is not written back
                overrides[channel] = values
        return cls(suite.with_overrides(overrides), overrides)

    def to_dict(self) -> dict[str, Any]:
        """The suite's name and the overrides as written."""
        return {"suite": self.suite.name, **{ch: dict(v) for ch, v in self.overrides.items()}}
