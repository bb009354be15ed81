"""The steady turn at zero sideslip, as NASA's ``trimgtm.m`` trims Example 6: the state a
turn is trimmed in (:class:`TurnState`), both trims of it (:class:`TurnTrim`), and the solve
from JSBSim's own turn trim (:func:`trim_zero_sideslip`), called by
:meth:`probing.sim.plant.Plant.trim` for a turn."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from probing.sim.errors import TrimError
from probing.sim.surfaces import SURFACES

__all__ = ["ACCELERATIONS", "TURN_TRIM_TOLERANCE", "TurnState", "TurnTrim", "trim_zero_sideslip"]


ACCELERATIONS = (
    ("accelerations/udot-ft_sec2", "udot_ft_s2"),
    ("accelerations/vdot-ft_sec2", "vdot_ft_s2"),
    ("accelerations/wdot-ft_sec2", "wdot_ft_s2"),
    ("accelerations/pdot-rad_sec2", "pdot_rad_s2"),
    ("accelerations/qdot-rad_sec2", "qdot_rad_s2"),
    ("accelerations/rdot-rad_sec2", "rdot_rad_s2"),
)
#: The largest acceleration (ft/s^2 or rad/s^2) a zero-sideslip turn trim may leave; JSBSim's
#: own trim stops at 1e-3 ft/s^2 and 1e-4 rad/s^2.
TURN_TRIM_TOLERANCE = 1e-8
#: The model's property that switches NASA's damage cases (``probing.sim.flight``).


@dataclass(frozen=True)
class TurnState:
    """A steady turn as JSBSim has it: attitude, turn rate, controls and the six body-axis
    accelerations (which are zero when it is trimmed).

    Attributes
    ----------
    alpha_deg, beta_deg, phi_deg, theta_deg, gamma_deg : float
        Angle of attack, sideslip, bank, pitch and flight-path angle, deg.
    speed_keas : float
        Equivalent airspeed, kt.
    turn_rate_deg_s : float
        Rate of change of heading, deg/s.
    elevator_deg, aileron_deg, rudder_deg : float
        Surface positions, deg (the aileron is the right one: positive rolls left).
    throttle_norm : float
        Throttle of the first engine (every engine has the same).
    accelerations : dict
        ``udot_ft_s2``, ``vdot_ft_s2``, ``wdot_ft_s2`` (ft/s^2) and ``pdot_rad_s2``,
        ``qdot_rad_s2``, ``rdot_rad_s2`` (rad/s^2): JSBSim's own, read from its properties.
    """

    alpha_deg: float
    beta_deg: float
    phi_deg: float
    theta_deg: float
    gamma_deg: float
    speed_keas: float
    turn_rate_deg_s: float
    elevator_deg: float
    aileron_deg: float
    rudder_deg: float
    throttle_norm: float
    accelerations: dict[str, float]

    @classmethod
    def read(cls, fdm: Any) -> TurnState:
        """The state ``fdm`` is in now."""
        return cls(
            alpha_deg=float(fdm["aero/alpha-deg"]),
            beta_deg=float(fdm["aero/beta-deg"]),
            phi_deg=float(fdm["attitude/phi-deg"]),
            theta_deg=float(fdm["attitude/theta-deg"]),
            gamma_deg=float(fdm["flight-path/gamma-deg"]),
            speed_keas=float(fdm["velocities/ve-kts"]),
            turn_rate_deg_s=math.degrees(fdm["velocities/psidot-rad_sec"]),
            elevator_deg=float(fdm[SURFACES["elevator"].position]),
            aileron_deg=float(fdm[SURFACES["aileron"].position]),
            rudder_deg=float(fdm[SURFACES["rudder"].position]),
            throttle_norm=float(fdm["fcs/throttle-cmd-norm[0]"]),
            accelerations={name: float(fdm[prop]) for prop, name in ACCELERATIONS},
        )

    @property
    def worst_acceleration(self) -> float:
        """The largest of the six accelerations in magnitude (ft/s^2 or rad/s^2)."""
        return max(abs(a) for a in self.accelerations.values())

    def to_dict(self) -> dict[str, Any]:
        """Plain dict, for metadata."""
        return asdict(self)


@dataclass(frozen=True)
class TurnTrim:
    """How a steady turn was trimmed: JSBSim's turn trim (sideslip free), then the same turn
    at zero sideslip, as NASA's ``trimgtm.m`` trims it (:meth:`Plant.trim`).

    Attributes
    ----------
    jsbsim : TurnState
        Where JSBSim's turn trim (FGTrim ``tTurn``) left the aircraft: the start.
    trimmed : TurnState
        The zero-sideslip trim the aircraft is left in.
    evaluations : int
        JSBSim evaluations the solver used.
    """

    jsbsim: TurnState
    trimmed: TurnState
    evaluations: int

    def to_dict(self) -> dict[str, Any]:
        """Plain dict, for metadata."""
        return asdict(self)


def trim_zero_sideslip(
    fdm: Any,
    engines: int,
    where: str,
    explain: Callable[[str], str],
    *,
    gamma_deg: float,
    bank_deg: float,
) -> TurnTrim:
    """From JSBSim's turn trim, the same steady turn at zero sideslip, as NASA's
    ``trimgtm.m`` trims it: the six body-axis accelerations zero at the asked bank,
    flight-path angle and speed with beta = 0, the turn rate free.

    JSBSim's turn trim (FGTrim ``tTurn``) sets the turn rate to g tan(bank) / V and zeroes
    the side acceleration with the sideslip; NASA holds the sideslip at 0 and frees the
    turn rate.  The unknowns here are alpha, the turn rate, the pitch trim, aileron,
    rudder and throttle (every engine alike, as JSBSim's trim sets them); each guess is
    set through JSBSim's initial conditions (attitude, body velocity at beta = 0, the
    body rates of a steady turn at constant bank and pitch) and evaluated with
    ``run_ic`` (time step 0: servos at their commands), the way FGTrim evaluates its
    own; :func:`scipy.optimize.least_squares` zeroes JSBSim's six accelerations.  The
    side force then sets the turn rate, the rudder and aileron the yaw and roll
    balance at beta = 0.  The aircraft is left in the solution.

    Raises
    ------
    TrimError
        If an acceleration is left above :data:`TURN_TRIM_TOLERANCE`, or the state is not
        the asked one (a control at its stop, or one without authority: the rudder
        of damage cases 1 and 2).
    """
    from scipy.optimize import least_squares  # only a turn needs it

    start = TurnState.read(fdm)
    speed_fps = float(fdm["ic/vt-fps"])
    psi_rad = float(fdm["attitude/psi-rad"])
    phi_rad, gamma_rad = math.radians(bank_deg), math.radians(gamma_deg)
    throttles = [f"fcs/throttle-cmd-norm[{i}]" for i in range(engines)]
    controls = ("fcs/pitch-trim-cmd-norm", "fcs/aileron-cmd-norm", "fcs/rudder-cmd-norm")
    accelerations = [fdm.get_property_manager().get_node(prop) for prop, _ in ACCELERATIONS]

    def accelerations_at(x: np.ndarray) -> np.ndarray:
        alpha, turn_rate = float(x[0]), float(x[1])
        # sin(gamma) = cos(alpha) sin(theta) - sin(alpha) cos(phi) cos(theta) at beta = 0
        a, b = math.cos(alpha), math.sin(alpha) * math.cos(phi_rad)
        theta = math.atan2(b, a) + math.asin(math.sin(gamma_rad) / math.hypot(a, b))
        fdm["ic/phi-rad"] = phi_rad  # the attitude first, then the body velocity in it
        fdm["ic/theta-rad"] = theta
        fdm["ic/psi-true-rad"] = psi_rad
        fdm["ic/u-fps"] = speed_fps * math.cos(alpha)
        fdm["ic/v-fps"] = 0.0
        fdm["ic/w-fps"] = speed_fps * math.sin(alpha)
        fdm["ic/p-rad_sec"] = -turn_rate * math.sin(theta)
        fdm["ic/q-rad_sec"] = turn_rate * math.cos(theta) * math.sin(phi_rad)
        fdm["ic/r-rad_sec"] = turn_rate * math.cos(theta) * math.cos(phi_rad)
        for prop, value in zip(controls, x[2:5], strict=True):
            fdm[prop] = float(value)
        for prop in throttles:
            fdm[prop] = float(x[5])
        fdm.run_ic()
        return np.array([node.get_double_value() for node in accelerations])

    x0, lower, upper = _turn_trim_start(fdm, start, controls)
    # Levenberg-Marquardt (MINPACK) rather than the bounded trust-region method: MINPACK
    # does its own linear algebra, so the trim is the same bytes whatever BLAS kernel
    # the processor gets (the bounded method's solves differed in the last digits).  It
    # takes no bounds: the start lies within them and the checks below refuse a
    # solution outside the asked state.
    solution = least_squares(
        accelerations_at,
        np.clip(x0, lower, upper),
        method="lm",
        x_scale=0.01,
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
    )
    accelerations_at(solution.x)  # leave the aircraft at the solution
    trimmed = TurnState.read(fdm)
    _check_turn_trim(trimmed, where, explain, gamma_deg=gamma_deg, bank_deg=bank_deg)
    return TurnTrim(jsbsim=start, trimmed=trimmed, evaluations=int(solution.nfev))


def _check_turn_trim(
    trimmed: TurnState,
    where: str,
    explain: Callable[[str], str],
    *,
    gamma_deg: float,
    bank_deg: float,
) -> None:
    """Refuse a turn trim that left an acceleration or is not the asked state."""
    asked = (
        abs(trimmed.beta_deg) < 1e-9
        and abs(trimmed.phi_deg - bank_deg) < 1e-9
        and abs(trimmed.gamma_deg - gamma_deg) < 1e-9
    )
    if trimmed.worst_acceleration > TURN_TRIM_TOLERANCE or not asked:
        raise TrimError(
            explain(
                f"turn trim at zero sideslip failed for {where}: accelerations "
                + ", ".join(f"{k} {v:.3g}" for k, v in trimmed.accelerations.items())
                + f" at beta_deg = {trimmed.beta_deg:.3g}"
            )
        )


def _turn_trim_start(
    fdm: Any, start: TurnState, controls: tuple[str, ...]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The start of the zero-sideslip turn trim (alpha, turn rate, the controls, throttle
    from JSBSim's turn trim) and its bounds."""
    x0 = np.array(
        [
            math.radians(start.alpha_deg),
            math.radians(start.turn_rate_deg_s),
            *(float(fdm[prop]) for prop in controls),
            start.throttle_norm,
        ]
    )
    # alpha within +-90 deg, the turn rate within +-180 deg/s, the commands within range
    upper = np.array([math.pi / 2, math.pi, 1.0, 1.0, 1.0, 1.0])
    lower = -upper
    lower[-1] = 0.0  # throttle 0..1
    return x0, lower, upper
