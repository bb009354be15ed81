"""The scenario: TOML in, a validated, frozen :class:`Scenario` out.

Every problem is reported as a :class:`ScenarioError` naming the field and
what is allowed, so the command line can print one line and exit 2.  See
``docs/scenarios.md`` for the format.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import json
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from probing.core.excitation import PRBS, Excitation
from probing.core.faults import FAULTS, FaultType
from probing.core.monitor import MonitorSettings
from probing.core.nonlinearities import NONLINEARITIES, Nonlinearity
from probing.core.prbs import Probe
from probing.core.sensors import SensorSuite
from probing.core.trend import window_periods
from probing.experiment.scenario.probe_signal import check_estimator
from probing.experiment.scenario.schema import (
    GUST_KNOWING_DRIFTS,
    TWIN_DRIFTS,
    ScenarioError,
    Simultaneous,
    check_keys,
    number,
)
from probing.experiment.scenario.sections import (
    check_baseline,
    later_sections,
    parse_aircraft,
    parse_condition,
    parse_disturbance,
    parse_nonlinearity,
    parse_output,
    parse_probe,
)
from probing.sim.flight import SPEED_KINDS, ActuatorFault, Control, Flight, Manoeuvre
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACES

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
    """A validated scenario (see ``docs/scenarios.md``); all values in the units of their names."""

    name: str
    model: str
    altitude_ft: float
    speed_kind: str  # a key of probing.sim.flight.SPEED_KINDS
    speed: float
    dt_s: float
    order: int
    bit_duration_s: float
    amplitude_deg: float  # in the probed surface's unit: deg, or normalised for the throttle
    periods: int
    settle_periods: int
    nonlinearity: str
    nl_params: dict[str, float] = field(default_factory=dict)
    channels: tuple[str, ...] = ("theta_rad",)
    drift: str = "reference"
    detrend_order: int = 1
    estimator: str = "streaming"
    turbulence: str = "none"
    sensor_noise: dict[str, float] = field(default_factory=dict)
    seed: int = 0
    gamma_deg: float = 0.0  # flight-path angle of the trim (climb positive)
    bank_deg: float = 0.0  # bank of a steady turn (0: straight)
    fault_type: str = "none"  # "none" or one of FAULT_TYPES
    fault_onset_s: float = 0.0  # time after the trim when the fault appears, s
    # the fault's own fields as in [fault] (probing.core.faults.FAULTS), validated
    fault_values: dict[str, Any] = field(default_factory=dict)
    control: Control | None = None  # [control]: the autopilot (None: open loop)
    monitor: MonitorSettings | None = None  # [monitor]: the detector's settings
    surface: str = DEFAULT_SURFACE  # the probed surface (probing.sim.surfaces.SURFACES)
    simultaneous: Simultaneous | None = None  # [simultaneous]: more surfaces probed at once
    manoeuvre: Manoeuvre | None = None  # [manoeuvre]: an autopilot reference that moves
    # [sensors]: the suite with its overrides applied (None: the aircraft's state is measured
    # as it is, with disturbance.sensor_noise), and the overrides as written,
    # {channel: {field: value}} (to write the section back)
    sensors: SensorSuite | None = None
    sensor_overrides: dict[str, dict[str, float]] = field(default_factory=dict)
    excitation: Excitation = PRBS  # [probe] signal: the PRBS, a multisine or a chirp
    text: str = ""  # the scenario as written (TOML), kept for provenance

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

    @functools.cached_property
    def probe(self) -> Probe:
        """The probe of ``[probe]``: order, bit duration and amplitude (in the surface's
        unit), built once."""
        return Probe(self.order, self.bit_duration_s, self.amplitude_deg, self.excitation)

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
    def total_steps(self) -> int:
        """Simulation steps of the whole run (one aircraft)."""
        return self.periods * self.bits_per_period * self.steps_per_bit

    @property
    def uses_twin(self) -> bool:
        """True if the drift correction subtracts a precomputed unprobed twin: ``reference``
        and ``oracle`` (the nominal aircraft through the same turbulence realisation) or
        ``nominal`` (the nominal aircraft in calm air, flying its own autopilot).  ``gust``
        is not one: its twin is flown from the sensor stream, through the gust estimated
        from it."""
        return self.drift in TWIN_DRIFTS

    @property
    def twin_knows_gusts(self) -> bool:
        """True if the twin flies the same gusts as the aircraft (``reference``, ``oracle``):
        a simulation-only upper bound, since no real aircraft knows the gusts it flies
        through.  In calm air every twin is the same aircraft."""
        return self.drift in GUST_KNOWING_DRIFTS

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

    def to_dict(self) -> dict[str, Any]:
        """The scenario in its file layout (sections and field names), without ``text``."""
        nl: dict[str, Any] = {"type": self.nonlinearity, **self.nl_params}
        disturbance: dict[str, Any] = {"turbulence": self.turbulence, "seed": self.seed}
        if self.sensor_noise:
            disturbance["sensor_noise"] = dict(self.sensor_noise)
        out: dict[str, Any] = {"channels": list(self.channels), "drift": self.drift}
        if self.detrends or self.detrend_order != 1:
            out["detrend_order"] = self.detrend_order
        if self.estimator != "streaming":  # the default is left out: digests stay as they were
            out["estimator"] = self.estimator
        return {
            "name": self.name,
            "aircraft": {"model": self.model},
            "condition": self._condition(),
            "simulation": {"dt_s": self.dt_s},
            "probe": {
                # the elevator is left out: digests stay as they were before surfaces existed
                **({"surface": self.surface} if self.surface != DEFAULT_SURFACE else {}),
                "order": self.order,
                "bit_duration_s": self.bit_duration_s,
                f"amplitude_{self.surface_unit}": self.amplitude_deg,
                "periods": self.periods,
                "settle_periods": self.settle_periods,
                # the PRBS is left out: digests stay as they were before other signals
                **self._signal(),
            },
            "nonlinearity": nl,
            "output": out,
            "disturbance": disturbance,
            # no [fault] or [control] section without one: digests stay as they were
            **({"fault": self._fault()} if self.fault_type != "none" else {}),
            **({"control": self.control.to_dict()} if self.control is not None else {}),
            **({"monitor": self.monitor.to_dict()} if self.monitor is not None else {}),
            **(
                {"simultaneous": self.simultaneous.to_dict()}
                if self.simultaneous is not None
                else {}
            ),
            **({"manoeuvre": self.manoeuvre.to_dict()} if self.manoeuvre is not None else {}),
            **({"sensors": self._sensors()} if self.sensors is not None else {}),
        }

    def _signal(self) -> dict[str, Any]:
        """``probe.signal`` and its fields; nothing for the PRBS."""
        exc = self.excitation
        if exc.is_binary:
            return {}
        assert exc.band_hz is not None
        out: dict[str, Any] = {"signal": exc.signal, "band_hz": list(exc.band_hz)}
        return {**out, "sweep": exc.sweep} if exc.signal == "chirp" else out

    def _sensors(self) -> dict[str, Any]:
        """The ``[sensors]`` section: the suite's name and the overrides as written."""
        assert self.sensors is not None
        overrides = {ch: dict(values) for ch, values in self.sensor_overrides.items()}
        return {"suite": self.sensors.name, **overrides}

    def _fault(self) -> dict[str, Any]:
        """The ``[fault]`` section."""
        return {"type": self.fault_type, "onset_s": self.fault_onset_s, **self.fault_values}

    def _condition(self) -> dict[str, float]:
        """The ``[condition]`` section; a straight-and-level trim leaves out its zero flight-path
        and bank angles, so its digest is what it was before they existed."""
        out = {"altitude_ft": self.altitude_ft, self.speed_kind: self.speed}
        if self.gamma_deg:
            out["gamma_deg"] = self.gamma_deg
        if self.bank_deg:
            out["bank_deg"] = self.bank_deg
        return out

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
        """
        merged = {**(changes or {}), **kwargs}
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
    """The scenario of ``data``, its sections read in file order (so the first error is
    always the same one)."""
    check_keys(data)
    name = check_name(data["name"])
    model = parse_aircraft(data, folder)
    condition = parse_condition(data["condition"])
    dt = number(data["simulation"], "simulation", "dt_s", lo=0, hi=0.1, lo_open=True)
    probe = parse_probe(data["probe"], dt)
    nl_type, params = parse_nonlinearity(data["nonlinearity"])
    output = parse_output(data["output"])
    output["estimator"] = check_estimator(probe["excitation"], output["estimator"])
    disturbance = parse_disturbance(data.get("disturbance", {}), output["channels"])
    scn = Scenario(
        name=name,
        model=model,
        dt_s=dt,
        nonlinearity=nl_type,
        nl_params=params,
        text=text,
        **condition,
        **probe,
        **output,
        **disturbance,
    )
    return later_sections(data, scn)


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
