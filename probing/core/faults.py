"""The fault types of a scenario's ``[fault]`` section: one registry, :data:`FAULTS`.

Each entry says everything the rest of the project needs of a fault type:

* its **fields** besides ``type`` and ``onset_s``, with their units and bounds
  (:class:`FaultField`); the scenario parses, validates and writes the section from them;
* its **class** for scoring (:data:`FAULT_CLASSES`: ``actuator``, ``airframe``, ``sensor``),
  the verdict of the monitor that is right for it;
* its **place**, where it acts (:data:`FAULT_PLACES`): on the probe path after the
  scenario's nonlinearity, on the probed surface's actuator, in the plant (the airframe),
  or on a measured output channel; the simulation dispatches on it;
* its **builder**: the fault's values -> the object the place uses (a nonlinearity, an
  :class:`ActuatorFault`, an :class:`AirframeDamage`, a :class:`SensorFault` such as
  :class:`SensorBias`).

Adding a fault type is adding an entry (``docs/architecture.md``, "How to add a fault
type").  This module loads no JSBSim: a scenario is validated without it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from probing.core.nonlinearities import NONLINEARITIES

__all__ = [
    "ACTUATOR_FAULTS",
    "FAULTS",
    "FAULT_CLASSES",
    "FAULT_PLACES",
    "FIELD_KINDS",
    "ActuatorFault",
    "AirframeDamage",
    "FaultField",
    "FaultType",
    "SensorBias",
    "SensorFault",
    "SensorScale",
    "SensorStuck",
    "apply_sensor_fault",
    "onset_step",
    "sweep_fields",
]

#: The verdicts a fault can call for: the monitor's isolation is right when it names this.
FAULT_CLASSES = ("actuator", "airframe", "sensor")
#: Where a fault acts: on the probe path (after ``[nonlinearity]``), on the probed surface's
#: actuator, in the plant (the airframe the reference twin of ``probing run`` flies too), on
#: a measured output channel (what the aircraft measures, never its reference).
FAULT_PLACES = ("probe_path", "actuator", "plant", "sensor")
#: What a field holds: a ``number`` within its bounds, in its unit; a ``damage_case``
#: (NASA's case 1..6 or its name, GTM only); a ``nonlinearity`` type (not ``none``) with
#: that type's own parameters beside it in the section; a ``channel``, one of the
#: scenario's output channels (``[output] channels``).
FIELD_KINDS = ("number", "damage_case", "nonlinearity", "channel")


def onset_step(onset_s: float, dt_s: float) -> int:
    """The index of the first step a fault acts in: the step that starts at ``onset_s`` (s,
    after the trim), with steps of ``dt_s`` (s) counted from 0 at the trim."""
    return round(onset_s / dt_s)


@dataclass(frozen=True)
class FaultField:
    """One field of a fault type, besides ``type`` and ``onset_s``.

    Attributes
    ----------
    name : str
        The field's name in ``[fault]``.
    kind : str
        One of :data:`FIELD_KINDS`.
    unit : str
        Its unit (``"-"`` for none; ``"channel"`` for one in the unit of the fault's channel).
    lo, hi : float
        Inclusive bounds of a ``number``.
    description : str
        One line for the documentation.
    """

    name: str
    kind: str
    unit: str = "-"
    lo: float = -math.inf
    hi: float = math.inf
    description: str = ""


@dataclass(frozen=True)
class FaultType:
    """One fault type of ``[fault]``.

    Attributes
    ----------
    name : str
        Its ``type`` in ``[fault]``.
    fault_class : str
        One of :data:`FAULT_CLASSES`: the verdict that is right for it.
    place : str
        One of :data:`FAULT_PLACES`: where it acts.
    fields : tuple of FaultField
        Its fields besides ``type`` and ``onset_s``, all required, in the order they are
        checked.
    description : str
        One line for the documentation.
    builder : callable
        ``builder(onset_s, values)``: the object the place uses, from the validated values of
        :attr:`fields` (a ``nonlinearity`` field brings its type's parameters along).
    """

    name: str
    fault_class: str
    place: str
    fields: tuple[FaultField, ...]
    description: str
    builder: Callable[[float, Mapping[str, Any]], Any]

    @property
    def names(self) -> tuple[str, ...]:
        """The names of its fields (without a nonlinearity's parameters)."""
        return tuple(f.name for f in self.fields)

    @property
    def takes_nonlinearity(self) -> bool:
        """True if one of its fields names a nonlinearity, whose parameters come along."""
        return any(f.kind == "nonlinearity" for f in self.fields)

    def takes(self, nonlinearity: str | None = None) -> tuple[str, ...]:
        """The fields a ``[fault]`` of this type takes besides ``type``, sorted: ``onset_s``,
        its own, and with a nonlinearity field the parameters of ``nonlinearity`` (of every
        nonlinearity while it is not known)."""
        params: set[str] = set()
        if self.takes_nonlinearity:
            kinds = [NONLINEARITIES[nonlinearity]] if nonlinearity else NONLINEARITIES.values()
            params = {n for t in kinds for n in t.names}
        return tuple(sorted({"onset_s", *self.names, *params}))

    def not_a_field(self, name: str, nonlinearity: str | None = None) -> str | None:
        """The one message for a field ``name`` this type does not take (:meth:`takes`), or
        None if it takes it: ``not a field of a stuck fault (takes onset_s)``, ``not a field
        of a backlash nonlinearity fault (takes nonlinearity, onset_s, width_deg)``."""
        if name == "type" or name in self.takes(nonlinearity):
            return None
        which = f"{nonlinearity} " if nonlinearity else ""
        takes = ", ".join(self.takes(nonlinearity))
        return f"not a field of a {which}{self.name} fault (takes {takes})"

    def build(self, onset_s: float, values: Mapping[str, Any]) -> Any:
        """The fault as its place uses it (see :attr:`builder`); ``onset_s`` in s."""
        return self.builder(onset_s, values)


#: Actuator faults that act on the surface the probe drives, from an onset on.
ACTUATOR_FAULTS = ("effectiveness", "stuck")


@dataclass(frozen=True)
class ActuatorFault:
    """A fault of the probed surface's actuator, from ``onset_s`` after the trim on.

    Attributes
    ----------
    kind : str
        ``"effectiveness"``: the surface's motion about its trimmed position is scaled by
        ``scale`` (an actuator that lost authority, a partial jam); ``"stuck"``: the surface
        holds the position it has at the onset.
    onset_s : float
        Time after the trim, s.
    scale : float
        The scale of ``"effectiveness"`` (1 for ``"stuck"``).
    """

    kind: str
    onset_s: float
    scale: float = 1.0

    def __post_init__(self) -> None:
        if self.kind not in ACTUATOR_FAULTS:
            raise ValueError(f"kind must be one of {', '.join(ACTUATOR_FAULTS)}")
        if self.onset_s < 0:
            raise ValueError("onset_s must be >= 0")

    def position(self, asked: float, trim: float, held: float) -> float:
        """The surface's position from the onset on, in its unit: ``asked`` is what the
        autopilot and the probe ask for, ``trim`` the trimmed position, ``held`` the position
        the surface had at the onset."""
        if self.kind == "stuck":
            return held
        return trim + self.scale * (asked - trim)


@dataclass(frozen=True)
class AirframeDamage:
    """NASA's damage case ``case`` (1..6) of the GTM, from ``onset_s`` (s after the trim) on."""

    case: int
    onset_s: float


@dataclass(frozen=True)
class SensorBias:
    """An offset on one measured output channel from the step that starts at ``onset_s`` on.

    Attributes
    ----------
    channel : str
        The output channel (``theta_rad``, ...).
    bias : float
        The offset, in the channel's unit.
    onset_s : float
        Time after the trim, s.
    """

    channel: str
    bias: float
    onset_s: float

    def measure(self, value: float, step: int, onset: int) -> float:
        """One measurement of the channel after step ``step``, the fault acting from step
        ``onset`` (:func:`onset_step` of :attr:`onset_s`) on (:class:`SensorFault`)."""
        return value + self.bias if step >= onset else value


@dataclass(frozen=True)
class SensorScale:
    """A scale-factor error of one measured output channel from the step that starts at
    ``onset_s`` on: the measurement is ``scale`` times what the sensor gives.

    Attributes
    ----------
    channel : str
        The output channel (``theta_rad``, ...).
    scale : float
        The factor (dimensionless; 1: none).
    onset_s : float
        Time after the trim, s.
    """

    channel: str
    scale: float
    onset_s: float

    def measure(self, value: float, step: int, onset: int) -> float:
        """One measurement of the channel after step ``step`` (:class:`SensorFault`)."""
        return self.scale * value if step >= onset else value


@dataclass
class SensorStuck:
    """One measured output channel stuck from the step that starts at ``onset_s`` on: every
    measurement from the onset step on is the one of the step before it.

    Attributes
    ----------
    channel : str
        The output channel (``theta_rad``, ...).
    onset_s : float
        Time after the trim, s.
    """

    channel: str
    onset_s: float
    held: float | None = dataclasses.field(default=None, compare=False, repr=False)

    def measure(self, value: float, step: int, onset: int) -> float:
        """One measurement of the channel after step ``step`` (:class:`SensorFault`): it
        sees every step once, in order, so it keeps the last healthy measurement."""
        if step < onset:
            self.held = value
            return value
        if self.held is None:  # stuck from the first step: at the first measurement
            self.held = value
        return self.held


class SensorFault(Protocol):
    """What a world asks of a sensor fault (place ``sensor``): the hook a new kind of sensor
    fault implements (:class:`SensorBias` is one; ``docs/architecture.md``, "How to add a
    fault type").

    A world that measures step by step (:meth:`probing.sim.world.JSBSimWorld.fly` with a
    sensor suite, :class:`probing.experiment.flight.live.SocketWorld`) calls :meth:`measure` after
    each step with the channel's measurement; one that measures a block of steps at once
    (:class:`probing.core.measuring.ChannelNoise`) calls it through :func:`apply_sensor_fault`,
    row by row in order.  Either way the fault sees each step once, in order, so it may keep
    a state (a sensor stuck at its value at the onset, say).
    """

    @property
    def channel(self) -> str:
        """The output channel it acts on (``theta_rad``, ...)."""

    @property
    def onset_s(self) -> float:
        """Its onset, s after the trim."""

    def measure(self, value: float, step: int, onset: int) -> float:
        """The measurement of :attr:`channel` after step ``step`` (``value`` in the
        channel's unit, as the sensor gives it), the fault acting from step ``onset``
        (:func:`onset_step` of :attr:`onset_s`) on."""


def apply_sensor_fault(
    fault: SensorFault,
    measured: np.ndarray,
    channels: tuple[str, ...],
    first_step: int,
    dt_s: float,
) -> None:
    """A sensor fault on a block: its :meth:`~SensorFault.measure` of each row of ``measured``
    (steps, channels), in place, in order; row ``i`` holds the output after step
    ``first_step + i`` (``dt_s`` in s).  Call it for consecutive blocks, in order."""
    j, onset = channels.index(fault.channel), onset_step(fault.onset_s, dt_s)
    column = measured[:, j].tolist()
    measure = fault.measure
    measured[:, j] = [measure(v, first_step + i, onset) for i, v in enumerate(column)]


def _probe_path(onset_s: float, values: Mapping[str, Any]) -> Any:
    """The nonlinearity that appears on the probe path (the run applies it from the onset)."""
    params = {k: v for k, v in values.items() if k != "nonlinearity"}
    return NONLINEARITIES[values["nonlinearity"]].build(params)


#: Fault type -> everything about it (``docs/scenarios.md``, ``[fault]``).
FAULTS: dict[str, FaultType] = {
    "gtm_damage": FaultType(
        "gtm_damage",
        "airframe",
        "plant",
        (FaultField("case", "damage_case", description="NASA's damage case, 1..6 or its name"),),
        "NASA's damage case of the GTM acts from the onset step on",
        lambda onset_s, v: AirframeDamage(int(v["case"]), onset_s),
    ),
    "nonlinearity": FaultType(
        "nonlinearity",
        "actuator",
        "probe_path",
        (
            FaultField(
                "nonlinearity",
                "nonlinearity",
                description="a type of [nonlinearity] (not none), with its own parameters",
            ),
        ),
        "a nonlinearity appears on the probe path, after [nonlinearity]",
        _probe_path,
    ),
    "effectiveness": FaultType(
        "effectiveness",
        "actuator",
        "actuator",
        (FaultField("scale", "number", "-", 0.0, 2.0, "scale of the surface's motion"),),
        "the probed surface's motion about its trim is scaled",
        lambda onset_s, v: ActuatorFault("effectiveness", onset_s, float(v["scale"])),
    ),
    "stuck": FaultType(
        "stuck",
        "actuator",
        "actuator",
        (),
        "the probed surface holds its position at the onset",
        lambda onset_s, v: ActuatorFault("stuck", onset_s),
    ),
    "sensor_bias": FaultType(
        "sensor_bias",
        "sensor",
        "sensor",
        (
            FaultField("channel", "channel", description="the measured output channel"),
            FaultField("bias", "number", "channel", -1e6, 1e6, "the offset, in the channel's unit"),
        ),
        "an offset on one measured channel (the reference does not see it)",
        lambda onset_s, v: SensorBias(str(v["channel"]), float(v["bias"]), onset_s),
    ),
    "sensor_scale": FaultType(
        "sensor_scale",
        "sensor",
        "sensor",
        (
            FaultField("channel", "channel", description="the measured output channel"),
            FaultField("scale", "number", "-", 0.0, 10.0, "the measurement's scale factor"),
        ),
        "one measured channel is scaled (a sensor's scale-factor error)",
        lambda onset_s, v: SensorScale(str(v["channel"]), float(v["scale"]), onset_s),
    ),
    "sensor_stuck": FaultType(
        "sensor_stuck",
        "sensor",
        "sensor",
        (FaultField("channel", "channel", description="the measured output channel"),),
        "one measured channel holds its last measurement before the onset",
        lambda onset_s, v: SensorStuck(str(v["channel"]), onset_s),
    ),
}


def sweep_fields(kind: str, values: Mapping[str, Any]) -> dict[str, Any]:
    """A sweep's dotted ``fault.*`` entries for a fault of type ``kind`` (``fault.type``
    first, then ``values`` in their order), as the study generators write them.

    Raises
    ------
    KeyError
        If ``kind`` is not a fault type.
    ValueError
        If a value is not one of the type's fields (:meth:`FaultType.not_a_field`; a
        nonlinearity's parameters are checked when the sweep is read, with the rest of the
        scenario).
    """
    entry = FAULTS[kind]
    for name in values:
        message = entry.not_a_field(name)
        if message is not None:
            raise ValueError(f"fault.{name}: {message}")
    return {"fault.type": kind, **{f"fault.{k}": v for k, v in values.items()}}
