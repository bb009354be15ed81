"""The scenario: TOML in, a validated, frozen :class:`Scenario` out.

Every problem is reported as a :class:`ScenarioError` naming the field and
what is allowed, so the command line can print one line and exit 2.  See
``docs/scenarios.md`` for the format.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import json
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from probing.core.excitation import Excitation
from probing.core.faults import FAULTS, FaultType
from probing.core.monitor import MonitorSettings
from probing.core.nonlinearities import NONLINEARITIES, Nonlinearity
from probing.core.prbs import Probe
from probing.core.sensors import SensorSuite
from probing.core.trend import window_periods
from probing.experiment.scenario.flight_sections import (
    ControlSection,
    FaultSection,
    ManoeuvreSection,
    MonitorSection,
    SensorsSection,
    Simultaneous,
)
from probing.experiment.scenario.probe_signal import check_estimator
from probing.experiment.scenario.references import REFERENCES
from probing.experiment.scenario.rules import check_across, check_baseline
from probing.experiment.scenario.schema import (
    ScenarioError,
    check_keys,
    field_label,
)
from probing.experiment.scenario.sections import (
    AircraftSection,
    ConditionSection,
    DisturbanceSection,
    NonlinearitySection,
    OutputSection,
    ProbeSection,
    SimulationSection,
)
from probing.sim.flight import SPEED_KINDS, ActuatorFault, Control, Flight, Manoeuvre
from probing.sim.surfaces import SURFACES

__all__ = [
    "Scenario",
    "check_name",
    "load_scenario",
    "parse_scenario",
    "read_toml",
]

_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,127}$")


@dataclass(frozen=True)
class Scenario:
    """A validated scenario (see ``docs/scenarios.md``): its name, one object per section
    of the file (:mod:`probing.experiment.scenario.sections`; None for an optional section
    the file leaves out), and the file's text; all values in the units of their names.

    A section's field is named ``<table>_section``: the plain names are the flat views
    below (``scn.probe`` is the built :class:`~probing.core.prbs.Probe`, ``scn.sensors`` the
    suite, ``scn.nonlinearity`` the type), which the rest of the code reads.  Change a
    scenario with :meth:`replace` (validated), or by replacing a section object.
    """

    name: str
    aircraft_section: AircraftSection
    condition_section: ConditionSection
    simulation_section: SimulationSection
    probe_section: ProbeSection
    nonlinearity_section: NonlinearitySection
    output_section: OutputSection
    disturbance_section: DisturbanceSection
    fault_section: FaultSection | None = None
    control_section: ControlSection | None = None  # None: open loop
    monitor_section: MonitorSection | None = None  # None: the detector's defaults
    simultaneous_section: Simultaneous | None = None
    manoeuvre_section: ManoeuvreSection | None = None
    # None: the aircraft's state is measured as it is, with disturbance.sensor_noise
    sensors_section: SensorsSection | None = None
    text: str = ""  # the scenario as written (TOML), kept for provenance

    # ---------------------------------------------------------- flat views
    # The sections' fields under the names the rest of the code reads them by, each read
    # from its section.
    # [aircraft], [condition], [simulation]
    @property
    def model(self) -> str:
        return self.aircraft_section.model

    @property
    def altitude_ft(self) -> float:
        return self.condition_section.altitude_ft

    @property
    def speed_kind(self) -> str:
        return self.condition_section.speed_kind

    @property
    def speed(self) -> float:
        return self.condition_section.speed

    @property
    def gamma_deg(self) -> float:
        return self.condition_section.gamma_deg

    @property
    def bank_deg(self) -> float:
        return self.condition_section.bank_deg

    @property
    def dt_s(self) -> float:
        return self.simulation_section.dt_s

    # [probe] (the amplitude in the probed surface's unit: deg, or normalised for the throttle)
    @property
    def surface(self) -> str:
        return self.probe_section.surface

    @property
    def order(self) -> int:
        return self.probe_section.order

    @property
    def bit_duration_s(self) -> float:
        return self.probe_section.bit_duration_s

    @property
    def amplitude_deg(self) -> float:
        return self.probe_section.amplitude_deg

    @property
    def periods(self) -> int:
        return self.probe_section.periods

    @property
    def settle_periods(self) -> int:
        return self.probe_section.settle_periods

    @property
    def excitation(self) -> Excitation:
        return self.probe_section.excitation

    @property
    def probe(self) -> Probe:
        return self.probe_section.probe

    # [nonlinearity]: its type and parameters
    @property
    def nonlinearity(self) -> str:
        return self.nonlinearity_section.type

    @property
    def nl_params(self) -> dict[str, float]:
        return self.nonlinearity_section.params

    # [output]
    @property
    def channels(self) -> tuple[str, ...]:
        return self.output_section.channels

    @property
    def drift(self) -> str:
        return self.output_section.drift

    @property
    def detrend_order(self) -> int:
        return self.output_section.detrend_order

    @property
    def estimator(self) -> str:
        return self.output_section.estimator

    # [disturbance]
    @property
    def turbulence(self) -> str:
        return self.disturbance_section.turbulence

    @property
    def seed(self) -> int:
        return self.disturbance_section.seed

    @property
    def sensor_noise(self) -> dict[str, float]:
        return self.disturbance_section.sensor_noise

    # [fault]: type "none", onset 0 and no values without one
    @property
    def fault_type(self) -> str:
        return self.fault_section.type if self.fault_section else "none"

    @property
    def fault_onset_s(self) -> float:
        return self.fault_section.onset_s if self.fault_section else 0.0

    @property
    def fault_values(self) -> dict[str, Any]:
        return self.fault_section.values if self.fault_section else {}

    # the optional sections' objects: None without the section
    @property
    def control(self) -> Control | None:
        return self.control_section.control if self.control_section else None

    @property
    def monitor(self) -> MonitorSettings | None:
        return self.monitor_section.settings if self.monitor_section else None

    @property
    def simultaneous(self) -> Simultaneous | None:
        return self.simultaneous_section

    @property
    def manoeuvre(self) -> Manoeuvre | None:
        return self.manoeuvre_section.manoeuvre if self.manoeuvre_section else None

    # [sensors]: the suite with its overrides applied (None without the section), and the
    # overrides as written, {channel: {field: value}}
    @property
    def sensors(self) -> SensorSuite | None:
        return self.sensors_section.suite if self.sensors_section else None

    # -------------------------------------------------------------- derived
    @property
    def surface_unit(self) -> str:
        """The unit of the probed surface, of the probe amplitude and of the nonlinearity's
        levels: ``"deg"``, or ``"norm"`` for the throttle."""
        return SURFACES[self.surface].unit

    @property
    def surface_channel(self) -> str:
        """The channel of the probed surface's position sensor (``elevator_deg``, ...)."""
        return SURFACES[self.surface].channel

    @property
    def steps_per_bit(self) -> int:
        """Simulation steps per probe bit (the probe's rule: a whole number)."""
        return self.probe.steps_per_bit(self.dt_s)

    @property
    def bits_per_period(self) -> int:
        """M = 2**order - 1."""
        return self.probe.length

    @property
    def period_s(self) -> float:
        """T = M t0, one probe period in seconds."""
        return self.probe.memory_s

    @property
    def period_steps(self) -> int:
        """Simulation steps of one probe period (the one count of it)."""
        return self.probe_section.period_steps(self.dt_s)

    @property
    def total_steps(self) -> int:
        """Simulation steps of the whole run (one aircraft)."""
        return self.probe_section.total_steps(self.dt_s)

    @property
    def twin_knows_gusts(self) -> bool:
        """True if the twin flies the same gusts as the aircraft (``reference``, ``oracle``):
        a simulation-only upper bound, since no real aircraft knows the gusts it flies
        through.  In calm air every twin is the same aircraft."""
        return REFERENCES[self.drift].knows_gusts

    @property
    def follows(self) -> bool:
        """True if the drift correction subtracts a nominal twin flying the run's own
        autopilot commands (``drift = "follow"``, closed loop only)."""
        return self.drift == "follow"

    @property
    def detrends(self) -> bool:
        """True if the drift correction detrends each period."""
        return self.drift == "detrend"

    @property
    def first_estimated_period(self) -> int:
        """The first period with an estimate: the streaming estimator needs the previous
        period, the cyclic ones do not; detrending reads a window of
        :func:`probing.core.trend.window_periods` periods ending with the period's own."""
        if self.detrends:
            return window_periods(self.detrend_order) - 1
        return 1 if self.estimator == "streaming" else 0

    @property
    def settled_periods(self) -> int:
        """Periods averaged into the settled estimate (when none is lost to a NaN)."""
        return self.periods - max(self.settle_periods, self.first_estimated_period)

    @property
    def flight(self) -> Flight:
        """What the trimmed aircraft depends on: model, condition, dt, turbulence, seed."""
        damage = self.build_fault("plant")  # an airframe fault: NASA's damage case
        return Flight(
            self.model,
            self.altitude_ft,
            self.speed_kind,
            self.speed,
            self.dt_s,
            self.turbulence,
            self.seed,
            gamma_deg=self.gamma_deg,
            bank_deg=self.bank_deg,
            damage_case=damage.case if damage is not None else 0,
            damage_onset_s=damage.onset_s if damage is not None else None,
            control=self.control,
            surface=self.surface,
        )

    @property
    def fault_kind(self) -> FaultType | None:
        """The ``[fault]``'s entry of :data:`probing.core.faults.FAULTS`, or None without one."""
        return FAULTS.get(self.fault_type)

    def _fault_acts(self, place: str) -> bool:
        """True if the scenario has a fault that acts at ``place`` (``FAULT_PLACES``)."""
        kind = self.fault_kind
        return kind is not None and kind.place == place

    def build_fault(self, place: str) -> Any:
        """The fault as ``place`` uses it (the registry's builder), or None if the scenario
        has no fault acting there (``place``: one of ``probing.core.faults.FAULT_PLACES``)."""
        if not self._fault_acts(place):
            return None
        assert self.fault_kind is not None
        return self.fault_kind.build(self.fault_onset_s, self.fault_values)

    @property
    def actuator_fault(self) -> ActuatorFault | None:
        """The probed surface's actuator fault (``effectiveness``, ``stuck``), or None."""
        return self.build_fault("actuator")

    def build_fault_nonlinearity(self) -> Nonlinearity | None:
        """The nonlinearity that appears on the probe path at the onset (parameters in deg,
        deg/s), or None without such a fault."""
        return self.build_fault("probe_path")

    def monitor_settings(self) -> MonitorSettings:
        """The ``[monitor]`` settings (the defaults without the section).

        Raises
        ------
        ScenarioError
            If the defaults leave the run no period to test after the baseline (a given
            section was checked when the scenario was read).
        """
        if self.monitor is not None:
            return self.monitor
        settings = MonitorSettings()
        check_baseline(self, settings, given=None)
        return settings

    @property
    def stepped_one_by_one(self) -> bool:
        """True if the run steps one step at a time (:class:`probing.sim.control.ClosedLoop`):
        an autopilot or an actuator fault acts between the probe and the surface."""
        return self.flight.closed_loop or self._fault_acts("actuator")

    def build_nonlinearity(self) -> Nonlinearity | None:
        """The scenario's nonlinearity (parameters in deg, deg/s), or None for ``none``."""
        return NONLINEARITIES[self.nonlinearity].build(self.nl_params)

    @property
    def nonlinearity_label(self) -> str:
        """The nonlinearity's name for titles (``"hysteresis relay"``)."""
        return NONLINEARITIES[self.nonlinearity].label

    def describe_nonlinearity(self) -> str:
        """The nonlinearity's parameters as one short line (``"width b_l = 0.0025 deg"``)."""
        return NONLINEARITIES[self.nonlinearity].describe(self.nl_params)

    def sections(self) -> dict[str, Any]:
        """The sections the scenario has, by their name in the file, in the file's order."""
        return {
            f.name.removesuffix("_section"): getattr(self, f.name)
            for f in dataclasses.fields(self)
            if f.name.endswith("_section") and getattr(self, f.name) is not None
        }

    def to_dict(self) -> dict[str, Any]:
        """The scenario in its file layout (sections and field names), without ``text``."""
        sections = {name: section.to_dict() for name, section in self.sections().items()}
        return {"name": self.name, **sections}

    def to_json(self) -> str:
        """Canonical JSON of :meth:`to_dict` (sorted keys), used for hashing and metadata."""
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))

    def digest(self) -> str:
        """Content hash of the resolved scenario (hex, 16 characters)."""
        return hashlib.sha256(self.to_json().encode()).hexdigest()[:16]

    def replace(self, changes: Mapping[str, Any] | None = None, /, **kwargs: Any) -> Scenario:
        """A validated copy with dotted fields changed, e.g. ``{"nonlinearity.type": "none"}``.

        The changes are given as a mapping, as keyword arguments, or both.  A change of
        ``nonlinearity.type`` is applied first, so its parameters may be listed in any order.
        A key names one field (``"probe.order"``) or a whole section (``"fault"``, ``"probe"``):
        a section's value, a dict, replaces the section as a whole (the fields it leaves out
        are gone, not kept), as a new ``[section]`` table of the file would; to change some
        fields of a section, name each (``"probe.order"``, ``"probe.periods"``).  Numbers may
        be numpy's (``np.int64(7)`` is an integer, ``np.float64`` a number).

        Raises
        ------
        ScenarioError
            A key that is not a dotted name (a string), or a copy the schema refuses.
        """
        merged = {**(changes or {}), **kwargs}
        for key in merged:
            if not isinstance(key, str) or not key or "" in key.split("."):
                raise ScenarioError(
                    field_label(key) if isinstance(key, str) else repr(key),
                    "a change's key must be a field's dotted name (a string: 'probe.order')",
                )
        data = copy.deepcopy(self.to_dict())
        for key in sorted(merged, key=lambda k: k != "nonlinearity.type"):
            _set_dotted(data, key, merged[key])
        return parse_scenario(data)


def _set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    """Set ``data["a"]["b"] = value`` for ``key = "a.b"``.

    A new nonlinearity type drops the old parameters; a new speed drops the other speeds.
    """
    parts = key.split(".")
    target = data
    for part in parts[:-1]:
        if not isinstance(target.get(part), dict):
            target[part] = {}
        target = target[part]
    if parts == ["nonlinearity", "type"] and target.get("type") != value:
        target.clear()
    if parts[:1] == ["condition"] and parts[-1] in SPEED_KINDS:
        for other in SPEED_KINDS:
            target.pop(other, None)
    target[parts[-1]] = value


def parse_scenario(
    data: dict[str, Any],
    *,
    text: str = "",
    source: str | None = None,
    folder: Path | None = None,
) -> Scenario:
    """Validate a scenario given as a dict (the TOML layout).

    Parameters
    ----------
    data : dict
        Parsed TOML.
    text : str
        The original file text, kept for provenance.
    source : str, optional
        File name, prefixed to error messages.
    folder : pathlib.Path, optional
        The scenario file's folder: a relative ``aircraft.model`` path is taken from there
        (the current folder without one); the scenario keeps it absolute.

    Raises
    ------
    ScenarioError
        On the first invalid entry, naming it and what is allowed.
    """
    try:
        return _parse(data, text, folder)
    except ScenarioError as exc:
        if source and exc.source is None:
            raise ScenarioError(exc.field, exc.message, source) from None
        raise


def check_name(name: Any, source: str | None = None) -> str:
    """A scenario or sweep name: a plain file name, also the output folder's name.

    Raises
    ------
    ScenarioError
        Field ``name``.
    """
    if not isinstance(name, str) or not _NAME_RE.match(name) or name in (".", ".."):
        raise ScenarioError(
            "name",
            f"must be a plain file name (letters, digits, '.', '_', '-'), got {name!r}",
            source,
        )
    return name


def _parse(data: dict[str, Any], text: str, folder: Path | None = None) -> Scenario:
    """The scenario of ``data``: its sections read in file order, then the rules between
    them (so the first error is always the same one)."""
    check_keys(data)
    name = check_name(data["name"])
    aircraft = AircraftSection.parse(data["aircraft"], folder)
    condition = ConditionSection.parse(data["condition"])
    simulation = SimulationSection.parse(data["simulation"])
    dt_s = simulation.dt_s
    probe = ProbeSection.parse(data["probe"], dt_s=dt_s)
    duration_s = probe.total_steps(dt_s) * dt_s
    nonlinearity = NonlinearitySection.parse(data["nonlinearity"])
    output = OutputSection.parse(data["output"])
    # the estimator left out is the probe signal's own
    estimator = check_estimator(probe.excitation, data["output"].get("estimator"))
    output = dataclasses.replace(output, estimator=estimator)
    disturbance = DisturbanceSection.parse(data.get("disturbance", {}))
    fault = data.get("fault")
    control, monitor = data.get("control"), data.get("monitor")
    simultaneous, manoeuvre = data.get("simultaneous"), data.get("manoeuvre")
    sensors = data.get("sensors")
    scn = Scenario(
        name=name,
        aircraft_section=aircraft,
        condition_section=condition,
        simulation_section=simulation,
        probe_section=probe,
        nonlinearity_section=nonlinearity,
        output_section=output,
        disturbance_section=disturbance,
        # an empty [fault] table is no fault
        fault_section=FaultSection.parse(fault, duration_s=duration_s) if fault else None,
        control_section=ControlSection.parse(control) if control is not None else None,
        monitor_section=MonitorSection.parse(monitor) if monitor is not None else None,
        simultaneous_section=(
            Simultaneous.parse(
                simultaneous, surface=probe.surface, amplitude_deg=probe.amplitude_deg
            )
            if simultaneous is not None
            else None
        ),
        manoeuvre_section=(
            ManoeuvreSection.parse(manoeuvre, duration_s=duration_s)
            if manoeuvre is not None
            else None
        ),
        sensors_section=SensorsSection.parse(sensors, dt_s=dt_s) if sensors is not None else None,
        text=text,
    )
    check_across(scn, data)
    return scn


def read_toml(path: Path) -> tuple[dict[str, Any], str]:
    """A TOML file's table and text.

    Raises
    ------
    ScenarioError
        Field ``file`` when it cannot be read, ``toml`` when it is not valid TOML.
    """
    source = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError("file", "does not exist", source) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError("file", f"cannot be read ({exc.__class__.__name__})", source) from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError("toml", f"invalid TOML ({exc})", source) from None


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file.

    Raises
    ------
    ScenarioError
        With the file name, the field and what is allowed.
    """
    path = Path(path)
    data, text = read_toml(path)
    source = str(path)
    return parse_scenario(data, text=text, source=source, folder=path.parent)
