"""Scenario files: TOML in, a validated, frozen :class:`Scenario` out.

Every problem is reported as a :class:`ScenarioError` naming the field and
what is allowed, so the command line can print one line and exit 2.  See
``docs/scenarios.md`` for the format.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import hashlib
import json
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from probing.core.faults import FAULTS, FaultType, onset_step
from probing.core.monitor import MonitorSettings
from probing.core.multiplex import DESIGNS
from probing.core.noise import ESTIMATORS
from probing.core.nonlinearities import NONLINEARITIES, Nonlinearity, ParameterError
from probing.core.prbs import MAX_ORDER, MIN_ORDER, Probe, steps_per_bit
from probing.sim.aircraft import find_aircraft
from probing.sim.channels import CHANNEL_NAMES
from probing.sim.errors import AircraftNotFoundError
from probing.sim.flight import (
    DAMAGE_CASES,
    DAMAGE_MODEL,
    MANOEUVRE_HOLDS,
    SPEED_KINDS,
    TURBULENCE_SEVERITY,
    ActuatorFault,
    Control,
    Flight,
    Manoeuvre,
)
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACE_NAMES, SURFACES

__all__ = [
    "DRIFT_MODES",
    "MAX_PERIODS",
    "SECTIONS",
    "Scenario",
    "ScenarioError",
    "check_name",
    "field_label",
    "load_scenario",
    "parse_scenario",
    "read_toml",
]

DRIFT_MODES = ("reference", "follow", "detrend", "none")
#: Most periods a scenario may ask for.
MAX_PERIODS = 100_000
#: Largest magnitude of a nonlinearity parameter in deg (and of a rate in deg/s / 1e4).
_MAX_DEG, _MAX_DEG_S = 90.0, 1e6
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,127}$")
#: Section -> its fields (None: a top-level value).
SECTIONS: dict[str, set[str] | None] = {
    "name": None,
    "aircraft": {"model"},
    "condition": {"altitude_ft", *SPEED_KINDS, "gamma_deg", "bank_deg"},
    "simulation": {"dt_s"},
    "probe": {
        "surface",
        "order",
        "bit_duration_s",
        "amplitude_deg",
        "amplitude_norm",
        "periods",
        "settle_periods",
    },
    "nonlinearity": {"type"} | {n for t in NONLINEARITIES.values() for n in t.names},
    "output": {"channels", "drift", "detrend_order", "estimator"},
    "disturbance": {"turbulence", "sensor_noise", "seed"},
    "fault": {"type", "onset_s"}
    | {n for t in FAULTS.values() for n in t.names}
    | {n for t in NONLINEARITIES.values() for n in t.names},
    "control": {f.name for f in dataclasses.fields(Control)},
    "monitor": {f.name for f in dataclasses.fields(MonitorSettings)},
    "simultaneous": {"design", "also_surfaces", "also_amplitudes", "max_crosstalk"},
    "manoeuvre": {"hold", "start_s", "change_deg", "rate_deg_s", "change_kt", "rate_kt_s"},
}
#: Fault types of the ``[fault]`` section, from the registry :data:`probing.core.faults.FAULTS`.
FAULT_TYPES = tuple(FAULTS)
_REQUIRED = {
    "aircraft": ("model",),
    "condition": ("altitude_ft",),
    "simulation": ("dt_s",),
    "probe": ("order", "bit_duration_s", "periods", "settle_periods"),  # and the amplitude
    "nonlinearity": ("type",),
    "output": ("channels",),
}


class ScenarioError(ValueError):
    """An invalid scenario: ``field`` names the offending entry."""

    def __init__(self, field: str, message: str, source: str | None = None) -> None:
        self.field = field
        self.message = message
        self.source = source
        where = f"{source}: " if source else ""
        super().__init__(f"{where}{field}: {message}")


#: Largest cross-talk a simultaneous design may be predicted to leave, as a fraction of the
#: largest response in the channel (``simultaneous.max_crosstalk``'s default).
DEFAULT_MAX_CROSSTALK = 0.02


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

    def to_dict(self) -> dict[str, Any]:
        """The section in its file layout."""
        return {
            "design": self.design,
            "also_surfaces": list(self.surfaces[1:]),
            "also_amplitudes": list(self.amplitudes[1:]),
            "max_crosstalk": self.max_crosstalk,
        }


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
        return Probe(self.order, self.bit_duration_s, self.amplitude_deg)

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
        """True if the drift correction subtracts an unprobed reference twin."""
        return self.drift == "reference"

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
        """The first period with an estimate: the streaming estimator (and detrending, which
        reads the period before) needs the previous period; the cyclic ones do not."""
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
    def fault_onset_step(self) -> int:
        """The first step the fault acts in (the step that starts at ``fault_onset_s``)."""
        return onset_step(self.fault_onset_s, self.dt_s)

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
        _check_baseline(self, settings.windows, settings.baseline_periods, given=None)
        return settings

    @property
    def stepped_one_by_one(self) -> bool:
        """True if the run steps one step at a time (:class:`probing.sim.control.ClosedLoop`):
        an autopilot or an actuator fault acts between the probe and the surface."""
        return self.flight.closed_loop or self.actuator_fault is not None

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
        }

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


# ------------------------------------------------------------------ checks
def field_label(key: str) -> str:
    """A key as written into an error field: quoted if it could break the one-line message."""
    return key if key and key.isprintable() else repr(key)


def _number(
    data: dict, section: str, key: str, *, lo: float, hi: float, lo_open: bool = False
) -> float:
    name = f"{section}.{key}" if section else key
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(name, f"must be a number, got {value!r}")
    value = float(value)
    ok = math.isfinite(value) and (value > lo if lo_open else value >= lo) and value <= hi
    if not ok:
        bound = f"> {lo:g}" if lo_open else f">= {lo:g}"
        raise ScenarioError(name, f"must be {bound} and <= {hi:g}, got {value:g}")
    return value


def _instant_in_run(data: dict, section: str, key: str, duration_s: float) -> float:
    """A time after trim (s) at which something starts: from 0 up to, not at, the run's end
    (a fault or a manoeuvre starting as the run ends would never act)."""
    value = _number(data, section, key, lo=0, hi=duration_s)
    if value >= duration_s:
        raise ScenarioError(f"{section}.{key}", f"must be before the run ends ({duration_s:g} s)")
    return value


def _integer(data: dict, section: str, key: str, *, lo: int, hi: int) -> int:
    name = f"{section}.{key}"
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, int):
        raise ScenarioError(name, f"must be an integer from {lo} to {hi}, got {value!r}")
    if not lo <= value <= hi:
        raise ScenarioError(name, f"must be an integer from {lo} to {hi}, got {value}")
    return value


def _choice(data: dict, section: str, key: str, allowed: tuple[str, ...]) -> str:
    value = data[key]
    if not isinstance(value, str) or value not in allowed:
        raise ScenarioError(
            f"{section}.{key}", f"must be one of {', '.join(allowed)}; got {value!r}"
        )
    return value


def _check_keys(data: dict[str, Any]) -> None:
    for key, value in data.items():
        if key not in SECTIONS:
            raise ScenarioError(field_label(key), f"unknown field; allowed: {', '.join(SECTIONS)}")
        allowed = SECTIONS[key]
        if allowed is None:
            continue
        if not isinstance(value, dict):
            raise ScenarioError(key, "must be a table (a [section])")
        for sub in value:
            if sub not in allowed:
                raise ScenarioError(
                    f"{key}.{field_label(sub)}",
                    f"unknown field; allowed: {', '.join(sorted(allowed))}",
                )
    if "name" not in data:
        raise ScenarioError("name", "missing (a plain file name, also the output folder name)")
    for section, keys in _REQUIRED.items():
        if section not in data:
            raise ScenarioError(section, "missing section")
        for key in keys:
            if key not in data[section]:
                raise ScenarioError(f"{section}.{key}", "missing")


def parse_scenario(data: dict[str, Any], *, text: str = "", source: str | None = None) -> Scenario:
    """Validate a scenario given as a dict (the TOML layout).

    Parameters
    ----------
    data : dict
        Parsed TOML.
    text : str
        The original file text, kept for provenance.
    source : str, optional
        File name, prefixed to error messages.

    Raises
    ------
    ScenarioError
        On the first invalid entry, naming it and what is allowed.
    """
    try:
        return _parse(data, text)
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


def _parse(data: dict[str, Any], text: str) -> Scenario:
    _check_keys(data)
    name = check_name(data["name"])
    model = data["aircraft"]["model"]
    if not isinstance(model, str):
        raise ScenarioError("aircraft.model", f"must be a string, got {model!r}")
    try:
        find_aircraft(model)  # looks at files only: no JSBSim is loaded
    except AircraftNotFoundError as exc:
        raise ScenarioError("aircraft.model", str(exc).replace("aircraft.model ", "")) from None

    cond = data["condition"]
    altitude = _number(cond, "condition", "altitude_ft", lo=0, hi=60000, lo_open=True)
    speeds = [k for k in SPEED_KINDS if k in cond]
    if len(speeds) != 1:
        raise ScenarioError("condition", f"give exactly one of {', '.join(SPEED_KINDS)}")
    kind = speeds[0]
    speed = _number(cond, "condition", kind, lo=0, hi=SPEED_KINDS[kind].upper, lo_open=True)
    gamma = _number(cond, "condition", "gamma_deg", lo=-30, hi=30) if "gamma_deg" in cond else 0.0
    bank = _number(cond, "condition", "bank_deg", lo=-80, hi=80) if "bank_deg" in cond else 0.0

    dt = _number(data["simulation"], "simulation", "dt_s", lo=0, hi=0.1, lo_open=True)

    probe = data["probe"]
    surface = (
        _choice(probe, "probe", "surface", SURFACE_NAMES) if "surface" in probe else DEFAULT_SURFACE
    )
    order = _integer(probe, "probe", "order", lo=MIN_ORDER, hi=MAX_ORDER)
    bit = _number(probe, "probe", "bit_duration_s", lo=0, hi=10, lo_open=True)
    try:
        steps_per_bit(bit, dt)  # the probe's own rule
    except ValueError:
        raise ScenarioError(
            "probe.bit_duration_s",
            f"must be an integer multiple of simulation.dt_s ({dt:g}), got {bit:g}",
        ) from None
    amplitude = _amplitude(probe, SURFACES[surface].unit, surface)
    periods = _integer(probe, "probe", "periods", lo=2, hi=MAX_PERIODS)
    settle = _integer(probe, "probe", "settle_periods", lo=0, hi=periods - 1)

    nl_type, params = _nonlinearity(data["nonlinearity"])

    out = data["output"]
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
    drift = _choice(out, "output", "drift", DRIFT_MODES) if "drift" in out else "reference"
    detrend_order = (
        _integer(out, "output", "detrend_order", lo=0, hi=3) if "detrend_order" in out else 1
    )
    estimator = (
        _choice(out, "output", "estimator", tuple(ESTIMATORS))
        if "estimator" in out
        else "streaming"
    )

    dist = data.get("disturbance", {})
    turbulence = (
        _choice(dist, "disturbance", "turbulence", tuple(TURBULENCE_SEVERITY))
        if "turbulence" in dist
        else "none"
    )
    seed = _integer(dist, "disturbance", "seed", lo=0, hi=2**31 - 1) if "seed" in dist else 0
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
        noise[ch] = _number(noise_in, "disturbance.sensor_noise", ch, lo=0, hi=1e6)

    scn = Scenario(
        name=name,
        model=model,
        altitude_ft=altitude,
        speed_kind=kind,
        speed=speed,
        dt_s=dt,
        order=order,
        bit_duration_s=bit,
        amplitude_deg=amplitude,
        periods=periods,
        settle_periods=settle,
        nonlinearity=nl_type,
        nl_params=params,
        channels=tuple(channels),
        drift=drift,
        detrend_order=detrend_order,
        estimator=estimator,
        turbulence=turbulence,
        sensor_noise=noise,
        seed=seed,
        gamma_deg=gamma,
        bank_deg=bank,
        surface=surface,
        text=text,
    )
    changes = {
        **_fault(data.get("fault"), scn),
        **_control(data.get("control")),
    }
    if drift == "follow" and not (changes.get("control") and changes["control"].active):
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
    return scn


def _manoeuvre(section: dict[str, Any], scn: Scenario) -> Manoeuvre:
    """The ``[manoeuvre]`` section: which hold loop's reference ramps, by how much, how fast
    and when; the loop must be closed, and the probe path linear."""
    if "hold" not in section:
        raise ScenarioError("manoeuvre.hold", f"missing (one of {', '.join(MANOEUVRE_HOLDS)})")
    hold = _choice(section, "manoeuvre", "hold", tuple(MANOEUVRE_HOLDS))
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
    change = _number(section, "manoeuvre", f"change_{unit}", lo=-limit, hi=limit)
    rate = _number(section, "manoeuvre", f"rate_{unit}_s", lo=0, hi=100, lo_open=True)
    duration_s = scn.total_steps * scn.dt_s
    start = _instant_in_run(section, "manoeuvre", "start_s", duration_s)
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
    return _number(probe, "probe", key, lo=0, hi=AMPLITUDE_MAX[unit], lo_open=True)


def _alone(section: str, scn: Scenario, without: tuple[str, ...]) -> None:
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


def _simultaneous(data: dict[str, Any], scn: Scenario) -> Simultaneous:
    """The ``[simultaneous]`` section: the surfaces probed besides ``probe.surface``, their
    amplitudes (each in its surface's unit), the design, and what it offers only alone."""
    section = data["simultaneous"]
    for key in ("design", "also_surfaces", "also_amplitudes"):
        if key not in section:
            raise ScenarioError(f"simultaneous.{key}", "missing")
    design = _choice(section, "simultaneous", "design", tuple(DESIGNS))
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
            _number(
                {surface: value}, "simultaneous.also_amplitudes", surface, lo=0, hi=hi, lo_open=True
            )
        )
    max_crosstalk = (
        _number(section, "simultaneous", "max_crosstalk", lo=0, hi=0.5, lo_open=True)
        if "max_crosstalk" in section
        else DEFAULT_MAX_CROSSTALK
    )
    _alone("simultaneous", scn, ("nonlinearity", "fault", "control", "monitor"))
    if scn.drift not in ("reference", "none") or scn.estimator != "cyclic":
        raise ScenarioError(
            "simultaneous",
            'needs output.estimator = "cyclic" and output.drift = "reference" or "none"',
        )
    return Simultaneous(design, tuple(surfaces), tuple(levels), max_crosstalk)


def _check_baseline(scn: Scenario, windows: int, baseline: int, given: bool | None) -> None:
    """A monitor's baseline must exceed ``windows + 1`` periods and leave one settled period
    of the run to test.  ``given``: the section gave it (True), left it to its default
    (False), or there is no ``[monitor]`` section at all (None)."""
    settled = scn.periods - max(scn.settle_periods, scn.first_estimated_period)
    if windows + 2 <= baseline < settled:
        return
    what = f"{baseline}" if given else f"the default, {baseline},"
    missing = "" if given is not None else "the scenario has no [monitor] section, and "
    raise ScenarioError(
        "monitor.baseline_periods",
        f"{missing}must be more than windows + 1 ({windows + 1}) and fewer than the run's "
        f"{settled} settled periods; {what} is not",
    )


def _monitor(monitor: dict[str, Any] | None, scn: Scenario) -> dict[str, Any]:
    """The ``[monitor]`` section: the detector's settings, with a baseline that fits the run."""
    if monitor is None:
        return {}
    defaults = MonitorSettings()
    values: dict[str, Any] = {}
    if "windows" in monitor:
        values["windows"] = _integer(monitor, "monitor", "windows", lo=3, hi=64)
    windows = values.get("windows", defaults.windows)
    if "baseline_periods" in monitor:
        values["baseline_periods"] = _integer(
            monitor, "monitor", "baseline_periods", lo=1, hi=MAX_PERIODS
        )
    given = "baseline_periods" in monitor
    _check_baseline(scn, windows, values.get("baseline_periods", defaults.baseline_periods), given)
    if "false_alarms_per_hour" in monitor:
        values["false_alarms_per_hour"] = _number(
            monitor, "monitor", "false_alarms_per_hour", lo=0, hi=1e6, lo_open=True
        )
    if "shape_false_alarm" in monitor:
        values["shape_false_alarm"] = _number(
            monitor, "monitor", "shape_false_alarm", lo=0, hi=0.5, lo_open=True
        )
    for key in ("verdict_periods", "window_periods"):
        if key in monitor:
            values[key] = _integer(monitor, "monitor", key, lo=1, hi=1000)
    if "surface" in monitor:
        if not isinstance(monitor["surface"], bool):
            raise ScenarioError(
                "monitor.surface", f"must be true or false, got {monitor['surface']!r}"
            )
        channel = scn.surface_channel
        if monitor["surface"] and (channel not in scn.channels or len(scn.channels) < 2):
            raise ScenarioError(
                "monitor.surface",
                f"needs {channel} and at least one other channel in output.channels",
            )
        values["surface"] = monitor["surface"]
    return {"monitor": MonitorSettings(**values)}


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
            values[f.name] = _number(control, "control", f.name, lo=0.1, hi=2.0)
        elif f.name == "integral_time_s":
            values[f.name] = _number(control, "control", f.name, lo=0, hi=1000)
        else:
            values[f.name] = _number(control, "control", f.name, lo=0, hi=50, lo_open=True)
    return {"control": Control(**values)}


def _fault(fault: dict[str, Any] | None, scn: Scenario) -> dict[str, Any]:
    """The ``[fault]`` section, validated: a type, its own fields and its onset within the run."""
    if not fault:
        return {}
    model, duration_s = scn.model, scn.total_steps * scn.dt_s
    if "type" not in fault:
        raise ScenarioError("fault.type", f"missing (one of {', '.join(FAULTS)})")
    kind = _choice(fault, "fault", "type", tuple(FAULTS))
    entry = FAULTS[kind]
    own = {"type", "onset_s", *entry.names}
    for key in fault:
        if key not in own and not entry.takes_nonlinearity:  # its parameters are checked below
            raise ScenarioError(
                f"fault.{field_label(key)}",
                f"not a field of a {kind} fault (takes {', '.join(sorted(own - {'type'}))})",
            )
    for key in ("onset_s", *entry.names):
        if key not in fault:
            raise ScenarioError(f"fault.{key}", f"missing (required for {kind})")
    onset = _instant_in_run(fault, "fault", "onset_s", duration_s)
    values: dict[str, Any] = {}
    for f in entry.fields:
        if f.kind == "number":
            values[f.name] = _number(fault, "fault", f.name, lo=f.lo, hi=f.hi)
        elif f.kind == "damage_case":
            values[f.name] = _damage_case(fault, model, kind, f.name)
        elif f.kind == "channel":
            values[f.name] = _output_channel(fault, f.name, scn.channels)
        else:  # a nonlinearity: its type, and its own parameters beside it
            others = ("type", "onset_s", *(n for n in entry.names if n != f.name))
            nl_type, params = _nonlinearity(fault, section="fault", type_key=f.name, others=others)
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


def _nonlinearity(
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
    nl_type = _choice(nl_data, section, type_key, tuple(NONLINEARITIES))
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
        hi = _MAX_DEG_S if p.unit == "deg/s" else _MAX_DEG
        params[p.name] = _number(nl_data, section, p.name, lo=-hi, hi=hi)
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
    return parse_scenario(data, text=text, source=source)
