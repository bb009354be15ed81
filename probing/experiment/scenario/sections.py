"""The sections of a scenario file: one frozen object per ``[section]`` (those a flight
adds, ``[fault]`` to ``[sensors]``, in :mod:`probing.experiment.scenario.flight_sections`),
each read and checked from its table (``parse``) and written back (``to_dict``, the file's
layout).

A section's ``parse`` checks its own fields; where a field's bounds are the run's (a time
within the run, a bit of whole steps, a sensor sampled at the step), it is given those
facts of the sections before it as keyword arguments.  What relates sections to each other
(a fault's channel must be an output, a loop needs a sensor, ...) is checked once every
section has parsed (:mod:`probing.experiment.scenario.rules`).  Each ``to_dict`` leaves out
what the file may leave out, as the scenario's digest did before the field existed, so
``Section.parse(section.to_dict()) == section``.  None of these imports the scenario.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from probing.core.excitation import PRBS, Excitation
from probing.core.noise import ESTIMATOR_NAMES
from probing.core.nonlinearities import NONLINEARITIES, ParameterError
from probing.core.prbs import MAX_ORDER, MIN_ORDER, Probe, steps_per_bit
from probing.experiment.scenario.probe_signal import parse_excitation, signal_fields
from probing.experiment.scenario.references import REFERENCES
from probing.experiment.scenario.schema import (
    MAX_PERIODS,
    ScenarioError,
    choice,
    field_label,
    integer,
    number,
)
from probing.sim.aircraft import find_aircraft, is_path
from probing.sim.channels import CHANNEL_NAMES
from probing.sim.errors import AircraftNotFoundError
from probing.sim.flight import (
    SPEED_KINDS,
    TURBULENCE_SEVERITY,
)
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACE_NAMES, SURFACES

#: Largest magnitude of a nonlinearity parameter in deg (and of a rate in deg/s / 1e4).
_MAX_DEG, _MAX_DEG_S = 90.0, 1e6
#: Largest probe amplitude in each surface unit: 10 deg, or half the throttle lever.
AMPLITUDE_MAX = {"deg": 10.0, "norm": 0.5}


# ------------------------------------------------------------------ [aircraft]
def resolve_model(model: str, folder: Path | None) -> str:
    """``aircraft.model`` as a scenario keeps it: a plain name as it is, a folder's path made
    absolute from ``folder`` (the file that gives it; None: the current folder)."""
    if not is_path(model):
        return model
    return str(((folder or Path.cwd()) / Path(model).expanduser()).resolve())


@dataclass(frozen=True)
class AircraftSection:
    """The ``[aircraft]`` section: the model, a name among the aircraft files or an aircraft
    folder's absolute path."""

    model: str

    @classmethod
    def parse(cls, table: dict[str, Any], folder: Path | None = None) -> AircraftSection:
        """A model found among the aircraft files, or the path of an aircraft folder,
        relative to ``folder`` (the scenario file's; else the current folder), kept
        absolute."""
        model = table["model"]
        if not isinstance(model, str):
            raise ScenarioError("aircraft.model", f"must be a string, got {model!r}")
        model = resolve_model(model, folder)
        try:
            find_aircraft(model)  # looks at files only: no JSBSim is loaded
        except AircraftNotFoundError as exc:
            raise ScenarioError("aircraft.model", str(exc).replace("aircraft.model ", "")) from None
        return cls(model)

    def to_dict(self) -> dict[str, Any]:
        """The section in its file layout."""
        return {"model": self.model}


# ------------------------------------------------------------------ [condition]
@dataclass(frozen=True)
class ConditionSection:
    """The ``[condition]`` section: altitude (ft), one speed of a kind of
    :data:`probing.sim.flight.SPEED_KINDS`, the trim's flight-path angle (deg, climb
    positive) and the bank of a steady turn (deg, 0: straight)."""

    altitude_ft: float
    speed_kind: str
    speed: float
    gamma_deg: float = 0.0
    bank_deg: float = 0.0

    @classmethod
    def parse(cls, table: dict[str, Any]) -> ConditionSection:
        """Altitude, exactly one speed, flight-path angle and bank."""
        altitude = number(table, "condition", "altitude_ft", lo=0, hi=60000, lo_open=True)
        speeds = [k for k in SPEED_KINDS if k in table]
        if len(speeds) != 1:
            raise ScenarioError("condition", f"give exactly one of {', '.join(SPEED_KINDS)}")
        kind = speeds[0]
        speed = number(table, "condition", kind, lo=0, hi=SPEED_KINDS[kind].upper, lo_open=True)
        gamma = (
            number(table, "condition", "gamma_deg", lo=-30, hi=30) if "gamma_deg" in table else 0.0
        )
        bank = number(table, "condition", "bank_deg", lo=-80, hi=80) if "bank_deg" in table else 0.0
        return cls(altitude, kind, speed, gamma, bank)

    def to_dict(self) -> dict[str, Any]:
        """The section; a straight-and-level trim leaves out its zero flight-path and bank
        angles, so its digest is what it was before they existed."""
        out: dict[str, Any] = {"altitude_ft": self.altitude_ft, self.speed_kind: self.speed}
        if self.gamma_deg:
            out["gamma_deg"] = self.gamma_deg
        if self.bank_deg:
            out["bank_deg"] = self.bank_deg
        return out


# ------------------------------------------------------------------ [simulation]
@dataclass(frozen=True)
class SimulationSection:
    """The ``[simulation]`` section: the simulation step, s."""

    dt_s: float

    @classmethod
    def parse(cls, table: dict[str, Any]) -> SimulationSection:
        """A step above 0 and up to 0.1 s."""
        return cls(number(table, "simulation", "dt_s", lo=0, hi=0.1, lo_open=True))

    def to_dict(self) -> dict[str, Any]:
        """The section in its file layout."""
        return {"dt_s": self.dt_s}


# ------------------------------------------------------------------ [probe]
def _amplitude(table: dict[str, Any], unit: str, surface: str) -> float:
    """The probe amplitude, named with the probed surface's unit (``amplitude_deg``, or
    ``amplitude_norm`` for the throttle): deg up to 10, a throttle lever up to 0.5."""
    key = f"amplitude_{unit}"
    other = "amplitude_norm" if unit == "deg" else "amplitude_deg"
    if other in table:
        raise ScenarioError(
            f"probe.{other}", f"the {surface} is probed in {unit}: give probe.{key} instead"
        )
    if key not in table:
        raise ScenarioError(f"probe.{key}", "missing")
    return number(table, "probe", key, lo=0, hi=AMPLITUDE_MAX[unit], lo_open=True)


@dataclass(frozen=True)
class ProbeSection:
    """The ``[probe]`` section: the probed surface, the PRBS order, the bit duration (s),
    the amplitude (in the surface's unit: deg, or normalised for the throttle, whatever its
    name), the periods flown and those left to settle, and the signal on the bits."""

    surface: str
    order: int
    bit_duration_s: float
    amplitude_deg: float  # in the probed surface's unit: deg, or normalised for the throttle
    periods: int
    settle_periods: int
    excitation: Excitation = PRBS

    @classmethod
    def parse(cls, table: dict[str, Any], *, dt_s: float) -> ProbeSection:
        """Surface, order, bit duration (whole steps of ``dt_s``, s), amplitude, periods and
        signal."""
        surface = (
            choice(table, "probe", "surface", SURFACE_NAMES)
            if "surface" in table
            else DEFAULT_SURFACE
        )
        order = integer(table, "probe", "order", lo=MIN_ORDER, hi=MAX_ORDER)
        bit = number(table, "probe", "bit_duration_s", lo=0, hi=10, lo_open=True)
        try:
            steps_per_bit(bit, dt_s)  # the probe's own rule
        except ValueError:
            raise ScenarioError(
                "probe.bit_duration_s",
                f"must be an integer multiple of simulation.dt_s ({dt_s:g}), got {bit:g}",
            ) from None
        amplitude = _amplitude(table, SURFACES[surface].unit, surface)
        periods = integer(table, "probe", "periods", lo=2, hi=MAX_PERIODS)
        settle = integer(table, "probe", "settle_periods", lo=0, hi=periods - 1)
        excitation = parse_excitation(table, order, bit)
        return cls(surface, order, bit, amplitude, periods, settle, excitation)

    @functools.cached_property
    def probe(self) -> Probe:
        """The probe: order, bit duration and amplitude (in the surface's unit), built once."""
        return Probe(self.order, self.bit_duration_s, self.amplitude_deg, self.excitation)

    def period_steps(self, dt_s: float) -> int:
        """Simulation steps of one probe period at the step ``dt_s`` (s): M bits of
        ``steps_per_bit`` steps each."""
        return self.probe.length * self.probe.steps_per_bit(dt_s)

    def total_steps(self, dt_s: float) -> int:
        """Simulation steps of the whole run at the step ``dt_s`` (s)."""
        return self.periods * self.period_steps(dt_s)

    def to_dict(self) -> dict[str, Any]:
        """The section; the elevator and the PRBS are left out, as the digests were before
        surfaces and other signals existed."""
        return {
            **({"surface": self.surface} if self.surface != DEFAULT_SURFACE else {}),
            "order": self.order,
            "bit_duration_s": self.bit_duration_s,
            f"amplitude_{SURFACES[self.surface].unit}": self.amplitude_deg,
            "periods": self.periods,
            "settle_periods": self.settle_periods,
            **signal_fields(self.excitation),
        }


# ------------------------------------------------------------------ [nonlinearity]
def parse_nonlinearity(
    table: dict[str, Any],
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
    nl_type = choice(table, section, type_key, tuple(NONLINEARITIES))
    kind = NONLINEARITIES[nl_type]
    for key in table:
        if key != type_key and key not in others and key not in kind.names:
            allowed = ", ".join(kind.names) if kind.names else "no parameters"
            raise ScenarioError(
                f"{section}.{field_label(key)}", f"not a parameter of {nl_type} (takes {allowed})"
            )
    params: dict[str, float] = {}
    for p in kind.parameters:
        if p.name not in table:
            raise ScenarioError(f"{section}.{p.name}", f"missing (required for {nl_type})")
        hi = _MAX_DEG_S if p.unit == "deg/s" else _MAX_DEG
        params[p.name] = number(table, section, p.name, lo=-hi, hi=hi)
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


@dataclass(frozen=True)
class NonlinearitySection:
    """The ``[nonlinearity]`` section: a type of
    :data:`probing.core.nonlinearities.NONLINEARITIES` and its parameters (deg, deg/s)."""

    type: str
    params: dict[str, float] = field(default_factory=dict)

    @classmethod
    def parse(cls, table: dict[str, Any]) -> NonlinearitySection:
        """The type and its parameters, checked by building the class."""
        return cls(*parse_nonlinearity(table))

    def to_dict(self) -> dict[str, Any]:
        """The section in its file layout."""
        return {"type": self.type, **self.params}


# ------------------------------------------------------------------ [output]
@dataclass(frozen=True)
class OutputSection:
    """The ``[output]`` section: the channels measured, the drift correction, the detrending
    order and the estimator (the probe signal's own when the file leaves it out: the
    scenario resolves it, :func:`probing.experiment.scenario.rules.check_across`)."""

    channels: tuple[str, ...]
    drift: str = "reference"
    detrend_order: int = 1
    estimator: str = "streaming"

    @classmethod
    def parse(cls, table: dict[str, Any]) -> OutputSection:
        """Channels, drift correction, detrending order, estimator."""
        channels = table["channels"]
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
        references = tuple(REFERENCES)  # read when parsed: a reference added is offered
        drift = choice(table, "output", "drift", references) if "drift" in table else "reference"
        detrend_order = (
            integer(table, "output", "detrend_order", lo=0, hi=3) if "detrend_order" in table else 1
        )
        estimator = (
            choice(table, "output", "estimator", ESTIMATOR_NAMES)
            if "estimator" in table
            else "streaming"
        )
        return cls(tuple(channels), drift, detrend_order, estimator)

    def to_dict(self) -> dict[str, Any]:
        """The section; a detrending order is written for ``detrend`` or when not 1, the
        estimator when not the default ``streaming`` (digests stay as they were)."""
        out: dict[str, Any] = {"channels": list(self.channels), "drift": self.drift}
        if self.drift == "detrend" or self.detrend_order != 1:
            out["detrend_order"] = self.detrend_order
        if self.estimator != "streaming":
            out["estimator"] = self.estimator
        return out


# ------------------------------------------------------------------ [disturbance]
@dataclass(frozen=True)
class DisturbanceSection:
    """The ``[disturbance]`` section: the turbulence level, its seed, and white sensor noise
    per output channel (its sigma, in the channel's unit)."""

    turbulence: str = "none"
    seed: int = 0
    sensor_noise: dict[str, float] = field(default_factory=dict)

    @classmethod
    def parse(cls, table: dict[str, Any]) -> DisturbanceSection:
        """Turbulence, its seed, and sensor noise (whose channels must be outputs:
        :mod:`~probing.experiment.scenario.rules`)."""
        turbulence = (
            choice(table, "disturbance", "turbulence", tuple(TURBULENCE_SEVERITY))
            if "turbulence" in table
            else "none"
        )
        seed = integer(table, "disturbance", "seed", lo=0, hi=2**31 - 1) if "seed" in table else 0
        noise_in = table.get("sensor_noise", {})
        if not isinstance(noise_in, dict):
            raise ScenarioError("disturbance.sensor_noise", "must be a table {channel = sigma}")
        noise = {
            ch: number(noise_in, "disturbance.sensor_noise", ch, lo=0, hi=1e6) for ch in noise_in
        }
        return cls(turbulence, seed, noise)

    def to_dict(self) -> dict[str, Any]:
        """The section; no sensor noise is left out."""
        out: dict[str, Any] = {"turbulence": self.turbulence, "seed": self.seed}
        if self.sensor_noise:
            out["sensor_noise"] = dict(self.sensor_noise)
        return out


# ------------------------------------------------------------------ [fault]
