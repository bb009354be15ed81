"""The output channels: the one table of what can be measured, in which unit, from where.

Every channel name carries its unit (``theta_rad``).  The table gives the JSBSim property a
channel is read from, its unit (the unit of the channel's probing output z and zeta; h_est
is in that unit per deg of probe), a description, and the output of JSBSim's
``FGLinearization`` that matches it, if any.
"""

from __future__ import annotations

from collections.abc import KeysView
from dataclasses import dataclass

__all__ = ["CHANNELS", "CHANNEL_NAMES", "Channel", "unit_of"]


@dataclass(frozen=True)
class Channel:
    """One output channel.

    Attributes
    ----------
    name : str
        The name with its unit (``"theta_rad"``).
    prop : str
        The JSBSim property it is read from.
    unit : str
        Its unit (``"rad"``).
    description : str
        What it is.
    linear_output : str or None
        The matching output name of ``FGLinearization`` (``"Theta"``), or None.
    """

    name: str
    prop: str
    unit: str
    description: str
    linear_output: str | None = None


CHANNELS: dict[str, Channel] = {
    c.name: c
    for c in (
        Channel("theta_rad", "attitude/theta-rad", "rad", "pitch angle", "Theta"),
        Channel("q_rad_s", "velocities/q-rad_sec", "rad/s", "body pitch rate", "Q"),
        Channel("alpha_rad", "aero/alpha-rad", "rad", "angle of attack", "Alpha"),
        Channel("nz_g", "accelerations/Nz", "g", "normal load factor"),
        Channel("h_ft", "position/h-sl-ft", "ft", "altitude above sea level"),
        Channel("vt_fps", "velocities/vt-fps", "ft/s", "true airspeed", "Vt"),
        Channel("gamma_rad", "flight-path/gamma-rad", "rad", "flight-path angle"),
        Channel("u_fps", "velocities/u-fps", "ft/s", "body x velocity"),
        Channel("w_fps", "velocities/w-fps", "ft/s", "body z velocity"),
        Channel("elevator_deg", "fcs/elevator-pos-deg", "deg", "elevator deflection (its sensor)"),
        Channel("p_rad_s", "velocities/p-rad_sec", "rad/s", "body roll rate", "P"),
        Channel("r_rad_s", "velocities/r-rad_sec", "rad/s", "body yaw rate", "R"),
        Channel("phi_rad", "attitude/phi-rad", "rad", "bank angle", "Phi"),
        Channel("beta_rad", "aero/beta-rad", "rad", "sideslip angle", "Beta"),
        Channel("ny_g", "accelerations/Ny", "g", "lateral load factor"),
        Channel(
            "aileron_deg",
            "fcs/right-aileron-pos-deg",
            "deg",
            "right aileron deflection (its sensor)",
        ),
        Channel("rudder_deg", "fcs/rudder-pos-deg", "deg", "rudder deflection (its sensor)"),
        Channel(
            "throttle_norm", "fcs/throttle-pos-norm[0]", "1", "first engine's throttle (sensor)"
        ),
        Channel("psi_rad", "attitude/psi-rad", "rad", "heading (true)"),
        Channel("nx_g", "accelerations/Nx", "g", "longitudinal load factor"),
        Channel("v_north_fps", "velocities/v-north-fps", "ft/s", "INS velocity north"),
        Channel("v_east_fps", "velocities/v-east-fps", "ft/s", "INS velocity east"),
        Channel("v_down_fps", "velocities/v-down-fps", "ft/s", "INS velocity down"),
    )
}

#: The channel names, in table order: a view of :data:`CHANNELS`, not a copy, so a channel
#: added to the table is a name here too (the scenario's ``[output] channels`` are checked
#: against it; ``docs/architecture.md``, "How to add a sensor channel").
CHANNEL_NAMES: KeysView[str] = CHANNELS.keys()


def unit_of(channel: str) -> str:
    """The unit of a channel (``"rad"`` for ``theta_rad``); KeyError for an unknown name."""
    return CHANNELS[channel].unit
