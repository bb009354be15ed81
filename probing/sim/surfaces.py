"""The surfaces a probe can drive: the one table of what is commanded and what is measured.

A probe enters one control effector of the aircraft (the paper's elevator by default).  Each
surface is commanded through the model's normalised command property and measured at its
position property, in the unit of its name:

* ``elevator``: ``fcs/elevator-cmd-norm`` -> ``fcs/elevator-pos-deg`` (deg, as the model
  reports it: the sign is the model's).
* ``aileron``: ``fcs/aileron-cmd-norm`` -> ``fcs/right-aileron-pos-deg``.  The probed
  deflection is the *right* aileron's; the model moves the left one from the same command
  (mirrored on the GTM and most stock models; some stock models deflect both alike, which
  is their roll model's business, not the probe's).
* ``rudder``: ``fcs/rudder-cmd-norm`` -> ``fcs/rudder-pos-deg`` (deg).
* ``throttle``: every engine's ``fcs/throttle-cmd-norm[i]`` at once -> the first engine's
  ``fcs/throttle-pos-norm`` (normalised lever, 0 idle to 1 full).

No JSBSim is loaded here; :class:`probing.sim.plant.Plant` calibrates and drives them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["DEFAULT_SURFACE", "SERVOS", "SURFACES", "SURFACE_NAMES", "Surface"]


@dataclass(frozen=True)
class Surface:
    """One control effector a probe can drive.

    Attributes
    ----------
    name : str
        ``"elevator"``, ``"aileron"``, ``"rudder"`` or ``"throttle"``.
    command : str
        The JSBSim property of its normalised command; ``[*]`` stands for every engine.
    position : str
        The JSBSim property of its position, in ``unit``.
    unit : str
        ``"deg"`` (a deflection) or ``"norm"`` (the throttle lever).
    command_range : tuple of float
        The normalised command's range.
    trim_command : str or None
        The trim property the model adds to the command (its kinks are calibrated exactly),
        None if there is none.
    linear_input : str
        The input of JSBSim's ``FGLinearization`` that moves it.
    channel : str
        The output channel of its position sensor (:data:`probing.sim.channels.CHANNELS`).
    lateral : bool
        True for the lateral-directional surfaces (their linear model needs the
        lateral-directional states).
    """

    name: str
    command: str
    position: str
    unit: str
    command_range: tuple[float, float]
    trim_command: str | None
    linear_input: str
    channel: str
    lateral: bool = False

    @property
    def position_column(self) -> str:
        """The column of its realised position in ``timeseries.parquet`` (the simulation's,
        no sensor noise): ``<name>_pos_<unit>``, never a channel's name, so that the surface's
        own sensor channel (``elevator_deg``, noise added) can be recorded beside it."""
        return f"{self.name}_pos_{self.unit}"

    def command_properties(self, engines: int) -> list[str]:
        """The properties written with the command (one per engine for ``[*]``)."""
        if self.command.endswith("[*]"):
            return [self.command.replace("[*]", f"[{i}]") for i in range(engines)]
        return [self.command]


SURFACES: dict[str, Surface] = {
    s.name: s
    for s in (
        Surface(
            "elevator",
            "fcs/elevator-cmd-norm",
            "fcs/elevator-pos-deg",
            "deg",
            (-1.0, 1.0),
            "fcs/pitch-trim-cmd-norm",
            "DeCmd",
            "elevator_deg",
        ),
        Surface(
            "aileron",
            "fcs/aileron-cmd-norm",
            "fcs/right-aileron-pos-deg",
            "deg",
            (-1.0, 1.0),
            "fcs/roll-trim-cmd-norm",
            "DaCmd",
            "aileron_deg",
            lateral=True,
        ),
        Surface(
            "rudder",
            "fcs/rudder-cmd-norm",
            "fcs/rudder-pos-deg",
            "deg",
            (-1.0, 1.0),
            "fcs/yaw-trim-cmd-norm",
            "DrCmd",
            "rudder_deg",
            lateral=True,
        ),
        Surface(
            "throttle",
            "fcs/throttle-cmd-norm[*]",
            "fcs/throttle-pos-norm[0]",
            "norm",
            (0.0, 1.0),
            None,
            "ThtlCmd",
            "throttle_norm",
        ),
    )
}
#: The surface names, in table order; the first is the default.
SURFACE_NAMES: tuple[str, ...] = tuple(SURFACES)
DEFAULT_SURFACE = "elevator"


#: The actuators a flight computer knows, for its actuator check
#: (:class:`probing.core.isolation.Servo`): aircraft name -> every surface's first-order
#: servo bandwidth, rad/s.  The GTM's is NASA's GTM_DesignSim's 5 Hz, as its XML flies it
#: (``aircraft/gtm_t2/gtm_t2.xml``, "GTM T2 servos"; tests/sim/test_gtm.py holds the two
#: equal).  An aircraft not named here is taken to put its surface where it is asked.
SERVOS: dict[str, float] = {"gtm_t2": 2.0 * math.pi * 5.0}
