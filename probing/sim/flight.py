"""What a trimmed aircraft depends on: the flight condition, the step and the disturbances.

A :class:`Flight` is all :func:`probing.sim.plant.make_plant` needs; the experiment layer
builds one from a scenario (:attr:`probing.experiment.scenario.Scenario.flight`).  No JSBSim
is loaded here.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

# ACTUATOR_FAULTS and ActuatorFault are re-exported: the autopilot's
from probing.core.faults import ACTUATOR_FAULTS, ActuatorFault, onset_step
from probing.core.sensors import FPS_PER_KT
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACES

__all__ = [
    "ACTUATOR_FAULTS",
    "DAMAGE_CASES",
    "DAMAGE_MODEL",
    "LOOP_SENSORS",
    "MANOEUVRE_HOLDS",
    "SPEED_KINDS",
    "SYMMETRIC_DAMAGE",
    "TURBULENCE_SEVERITY",
    "TURBULENCE_WIND_20FT_KT",
    "ActuatorFault",
    "Control",
    "Flight",
    "Manoeuvre",
    "SpeedKind",
    "TrimResult",
    "check_damage_case",
    "disturbance_properties",
    "one_speed",
]

#: The model with NASA's damage cases, and the cases in NASA's order (``damage/case`` 1..6).
DAMAGE_MODEL = "gtm_t2"
DAMAGE_CASES = (
    "rudder off",
    "vertical tail off",
    "left outboard flap off",
    "left wing tip (25 %) off",
    "left elevator off",
    "left stabilizer off",
)
#: The damage cases that leave the aircraft mirror-symmetric (rudder, vertical tail).
SYMMETRIC_DAMAGE = (1, 2)


def check_damage_case(model: str, case: int, need_model: bool = False) -> None:
    """Raise ValueError unless ``case`` is 0 (none) or one of NASA's cases on the model that
    has them; with ``need_model`` the model must have them even for case 0 (a plant asked to
    set its damage property)."""
    if (case or need_model) and model != DAMAGE_MODEL:
        raise ValueError(f"damage cases exist for {DAMAGE_MODEL} only, not {model}")
    if case not in range(len(DAMAGE_CASES) + 1):
        raise ValueError(f"damage case must be 0..{len(DAMAGE_CASES)}, got {case!r}")


@dataclass(frozen=True)
class Control:
    """The autopilot of a closed-loop flight (:mod:`probing.sim.control`): which loops hold
    their trimmed value, and how fast.

    Each loop places the closed-loop poles of a second-order model of its axis (the
    aircraft's control power at the trim times the command, ``docs/control.md``); its gains
    follow from the bandwidth and the aircraft, so one set of defaults suits a sub-scale
    model and a transport alike.

    Attributes
    ----------
    pitch_hold : bool
        Elevator holds the trimmed pitch attitude (PID on theta, rate damping on q).
    bank_hold : bool
        Aileron holds the trimmed bank angle (wings level after a straight trim).
    speed_hold : bool
        Throttle holds the trimmed true airspeed (PI).
    pitch_bandwidth_rad_s, bank_bandwidth_rad_s, speed_bandwidth_rad_s : float
        Natural frequency of each loop, rad/s.
    damping : float
        Damping ratio of the pitch and bank loops.
    integral_time_s : float
        Integral time of every loop, s (the integrator's gain is the proportional gain over
        it); 0 switches the integrators off.
    """

    pitch_hold: bool = False
    bank_hold: bool = False
    speed_hold: bool = False
    pitch_bandwidth_rad_s: float = 4.0
    bank_bandwidth_rad_s: float = 1.5
    speed_bandwidth_rad_s: float = 0.2
    damping: float = 0.8
    integral_time_s: float = 3.0

    @property
    def active(self) -> bool:
        """True if any loop is closed."""
        return self.pitch_hold or self.bank_hold or self.speed_hold

    def to_dict(self) -> dict[str, Any]:
        """Plain values, for keys and metadata."""
        return asdict(self)


#: The sensors each autopilot loop flies on: a ``[control]`` switch -> the output channels
#: it reads (``probing.sim.control``).  With ``[sensors]`` each must have a sensor.
LOOP_SENSORS: dict[str, tuple[str, ...]] = {
    "pitch_hold": ("theta_rad", "q_rad_s"),
    "bank_hold": ("phi_rad", "p_rad_s"),
    "speed_hold": ("vt_fps",),
}


#: The autopilot loops a manoeuvre moves the reference of -> (unit of change and rate, the
#: factor to the loop's own unit: rad for pitch and bank, ft/s of true airspeed for speed,
#: the output channel the loop holds, in that unit).
MANOEUVRE_HOLDS: dict[str, tuple[str, float, str]] = {
    "pitch": ("deg", math.pi / 180.0, "theta_rad"),
    "bank": ("deg", math.pi / 180.0, "phi_rad"),
    "speed": ("kt", 1852.0 / 0.3048 / 3600.0, "vt_fps"),
}


@dataclass(frozen=True)
class Manoeuvre:
    """A manoeuvre flown by the autopilot: the reference of one hold loop ramps from its
    trimmed value by ``change`` at ``rate``, starting ``start_s`` after the trim, then holds.

    Attributes
    ----------
    hold : str
        ``"pitch"`` (attitude), ``"bank"`` or ``"speed"`` (true airspeed); a key of
        :data:`MANOEUVRE_HOLDS`.
    change : float
        The reference's change, deg (pitch, bank) or kt (speed); its sign is the direction.
    rate : float
        How fast the reference moves, deg/s or kt/s (> 0).
    start_s : float
        Time after the trim the ramp starts, s.
    """

    hold: str
    change: float
    rate: float
    start_s: float

    def __post_init__(self) -> None:
        if self.hold not in MANOEUVRE_HOLDS:
            raise ValueError(f"hold must be one of {', '.join(MANOEUVRE_HOLDS)}")
        if not self.rate > 0:
            raise ValueError("rate must be > 0")

    @property
    def unit(self) -> str:
        """``"deg"`` or ``"kt"``: the unit of :attr:`change` (and of :attr:`rate` per s)."""
        return MANOEUVRE_HOLDS[self.hold][0]

    @property
    def duration_s(self) -> float:
        """How long the ramp lasts, s."""
        return abs(self.change) / self.rate

    def offset(self, time_s: np.ndarray) -> np.ndarray:
        """The reference's offset from its trimmed value at ``time_s`` (s after the trim), in
        :attr:`unit`."""
        ramp = np.clip((np.asarray(time_s, dtype=float) - self.start_s) * self.rate, 0.0, None)
        return np.sign(self.change) * np.minimum(ramp, abs(self.change))

    @property
    def channel(self) -> str:
        """The output channel the moved loop holds (``theta_rad``, ``phi_rad``, ``vt_fps``)."""
        return MANOEUVRE_HOLDS[self.hold][2]

    def in_unit(self, value: float) -> float:
        """``value`` of :attr:`channel` (rad or ft/s) in :attr:`unit` (deg or kt)."""
        return value / MANOEUVRE_HOLDS[self.hold][1]

    def offsets(self, first_step: int, n: int, dt_s: float) -> np.ndarray:
        """The offsets of the three loops' references (pitch rad, bank rad, speed ft/s) for
        steps ``first_step .. first_step + n - 1``, as the autopilot reads them before each
        step (at t = step dt), shape (n, 3)."""
        out = np.zeros((n, 3))
        column = list(MANOEUVRE_HOLDS).index(self.hold)
        factor = MANOEUVRE_HOLDS[self.hold][1]
        out[:, column] = self.offset((first_step + np.arange(n)) * dt_s) * factor
        return out

    def to_dict(self) -> dict[str, Any]:
        """The ``[manoeuvre]`` section's fields."""
        u = self.unit
        return {
            "hold": self.hold,
            f"change_{u}": self.change,
            f"rate_{u}_s": self.rate,
            "start_s": self.start_s,
        }


@dataclass(frozen=True)
class SpeedKind:
    """One way of giving the trim speed.

    Attributes
    ----------
    name : str
        The field name with its unit (``"speed_kcas"``).
    ic_property : str
        The JSBSim initial-condition property it sets.
    unit : str
        For labels (``"kt CAS"``).
    upper : float
        Largest value accepted (knots, or Mach).
    """

    name: str
    ic_property: str
    unit: str
    upper: float


#: The speed kinds a trim accepts, by field name.
SPEED_KINDS: dict[str, SpeedKind] = {
    k.name: k
    for k in (
        SpeedKind("speed_kcas", "ic/vc-kts", "kt CAS", 2000.0),
        SpeedKind("speed_ktas", "ic/vt-kts", "kt TAS", 2000.0),
        SpeedKind("speed_keas", "ic/ve-kts", "kt EAS", 2000.0),
        SpeedKind("mach", "ic/mach", "Mach", 5.0),
    )
}

#: Turbulence level -> JSBSim MIL-F-8785C/MIL-HDBK-1797 probability-of-exceedance severity
#: (``atmosphere/turbulence/milspec/severity``; 3 = moderate, 5 = severe in JSBSim's table):
#: the intensity above 2000 ft.
TURBULENCE_SEVERITY: dict[str, int] = {"none": 0, "light": 2, "moderate": 4, "severe": 6}

#: Turbulence level -> the wind speed 20 ft above ground that sets the intensity below
#: 1000 ft (MIL-F-8785C 3.7.2.1: 15, 30 and 45 kt for light, moderate and severe; JSBSim's
#: ``windspeed_at_20ft_AGL-fps``, sigma_w = 0.1 W20), interpolated between 1000 and 2000 ft.
#: Below 1000 ft JSBSim ignores the severity: without this table every level is the same.
TURBULENCE_WIND_20FT_KT: dict[str, float] = {
    "none": 0.0,
    "light": 15.0,
    "moderate": 30.0,
    "severe": 45.0,
}
if TURBULENCE_WIND_20FT_KT.keys() != TURBULENCE_SEVERITY.keys():  # one set of levels
    raise AssertionError("turbulence levels differ between the two tables")

#: JSBSim's turbulence model type for MIL-F-8785C / MIL-HDBK-1797 Dryden (``ttMilspec``).
TURB_TYPE_MILSPEC = 3


def disturbance_properties(turbulence: str, seed: int) -> dict[str, float]:
    """The property writes that seed JSBSim's random generators and switch ``turbulence``
    on, in the order they are written: what :meth:`probing.sim.plant.Plant.disturb` writes
    after the trim, and what a client of a separate JSBSim process sends it.

    Parameters
    ----------
    turbulence : str
        A key of :data:`TURBULENCE_SEVERITY` (``"none"`` writes the seeds only).
    seed : int
        Seed of JSBSim's random generators (``simulation/randomseed`` and the turbulence's
        ``atmosphere/randomseed``).

    Returns
    -------
    dict of str to float
        ``{property: value}`` in write order; the wind 20 ft above ground in ft/s.

    Raises
    ------
    ValueError
        If ``turbulence`` is not a level.
    """
    if turbulence not in TURBULENCE_SEVERITY:
        raise ValueError(f"turbulence must be one of {sorted(TURBULENCE_SEVERITY)}")
    writes = {"simulation/randomseed": float(int(seed)), "atmosphere/randomseed": float(int(seed))}
    if turbulence != "none":
        writes["atmosphere/turb-type"] = float(TURB_TYPE_MILSPEC)
        writes["atmosphere/turbulence/milspec/severity"] = float(TURBULENCE_SEVERITY[turbulence])
        writes["atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps"] = (
            TURBULENCE_WIND_20FT_KT[turbulence] * FPS_PER_KT
        )
    return writes


@dataclass(frozen=True)
class Flight:
    """An aircraft at a trim condition, stepped with ``dt_s``, in some turbulence.

    Attributes
    ----------
    model : str
        Aircraft name (project ``aircraft/`` first, then JSBSim's stock models).
    altitude_ft : float
        Trim altitude above sea level, ft.
    speed_kind : str
        A key of :data:`SPEED_KINDS`.
    speed : float
        The trim speed in that kind's unit.
    dt_s : float
        Integration step, s.
    turbulence : str
        A key of :data:`TURBULENCE_SEVERITY` (switched on after trim).
    seed : int
        Seed of JSBSim's random generators (turbulence).
    damage_case : int
        NASA's damage case (:data:`DAMAGE_CASES`, ``gtm_t2`` only); 0 (the default)
        undamaged.  Without ``damage_onset_s`` the aircraft is trimmed with it.
    damage_onset_s : float or None
        Time after the trim (s) from which ``damage_case`` acts: the aircraft is trimmed
        undamaged and the case switched on in flight (a fault).
    gamma_deg, bank_deg : float
        Flight-path angle (climb positive) and bank of a steady turn of the trim, deg; both
        0 (the default) trims straight and level.
    control : Control or None
        The autopilot engaged after the trim (None: open loop, every control held at its
        trim value).  It does not change the trim, only what follows it.
    surface : str
        The surface a probe drives (:data:`probing.sim.surfaces.SURFACES`), the elevator by
        default.  It does not change the trim either; in closed loop the autopilot's command
        of that surface passes through the probe path.
    """

    model: str
    altitude_ft: float
    speed_kind: str
    speed: float
    dt_s: float
    turbulence: str = "none"
    seed: int = 0
    damage_case: int = 0
    gamma_deg: float = 0.0
    bank_deg: float = 0.0
    damage_onset_s: float | None = None
    control: Control | None = None
    surface: str = DEFAULT_SURFACE

    def __post_init__(self) -> None:
        if self.surface not in SURFACES:
            raise ValueError(f"surface must be one of {', '.join(SURFACES)}")
        if self.speed_kind not in SPEED_KINDS:
            raise ValueError(f"speed_kind must be one of {', '.join(SPEED_KINDS)}")
        if self.turbulence not in TURBULENCE_SEVERITY:
            raise ValueError(f"turbulence must be one of {', '.join(TURBULENCE_SEVERITY)}")
        check_damage_case(self.model, self.damage_case)
        if self.damage_onset_s is not None and (not self.damage_case or self.damage_onset_s < 0):
            raise ValueError("a damage onset needs a damage case and a time >= 0")

    @property
    def trimmed_damage(self) -> int:
        """The damage case the aircraft is trimmed with (0 when it comes in flight)."""
        return self.damage_case if self.damage_onset_s is None else 0

    @property
    def damage_onset_step(self) -> int | None:
        """The step that starts at the damage's onset, the first damaged (None: no damage
        comes in flight), counted from the trim; the one count of it for every world."""
        if self.damage_onset_s is None:
            return None
        return onset_step(self.damage_onset_s, self.dt_s)

    @property
    def condition(self) -> str:
        """``"737 at altitude_ft = 15000, speed_kcas = 280"``, for messages."""
        return (
            f"{self.model} at altitude_ft = {self.altitude_ft:g}, "
            f"{self.speed_kind} = {self.speed:g}"
        )

    @property
    def closed_loop(self) -> bool:
        """True if the autopilot closes a loop after the trim."""
        return self.control is not None and self.control.active

    @property
    def nominal(self) -> Flight:
        """The same flight without the damage that comes in flight: what a monitor's
        reference model flies."""
        if self.damage_onset_s is None:
            return self
        return dataclasses.replace(self, damage_case=0, damage_onset_s=None)

    def to_dict(self) -> dict[str, Any]:
        """Plain values, for keys and metadata."""
        return asdict(self)


def one_speed(
    speed_kcas: float | None,
    speed_ktas: float | None,
    speed_keas: float | None,
    mach: float | None,
) -> tuple[str, float]:
    """The one speed given (to :meth:`probing.sim.plant.Plant.trim`): its kind and value;
    ValueError unless exactly one is given."""
    speeds = {"speed_kcas": speed_kcas, "speed_ktas": speed_ktas, "speed_keas": speed_keas}
    speeds["mach"] = mach
    given = {k: v for k, v in speeds.items() if v is not None}
    if len(given) != 1:
        raise ValueError(f"exactly one of {', '.join(SPEED_KINDS)} must be given")
    ((kind, speed),) = given.items()
    return kind, speed


@dataclass(frozen=True)
class TrimResult:
    """The trimmed state (angles in deg) and the JSBSim trim that found it."""

    altitude_ft: float
    speed_kcas: float
    speed_keas: float
    speed_ktas: float
    mach: float
    alpha_deg: float
    theta_deg: float
    elevator_deg: float
    elevator_cmd_norm: float
    pitch_trim_cmd_norm: float
    throttle_norm: float
    mode: str = "full"  # JSBSim's trim used: "full", "longitudinal" or "turn"

    def to_dict(self) -> dict[str, float]:
        """Plain dict, for metadata."""
        return asdict(self)
