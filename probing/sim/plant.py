"""The JSBSim plant: a trimmed aircraft stepped with a surface position (deg, or a normalised
throttle).

A :class:`Plant` loads an aircraft from its sanitised copy (:mod:`probing.sim.aircraft`),
trims it, and steps it with the position of one surface (:mod:`probing.sim.surfaces`: the
elevator by default, the aileron, rudder or throttle) given in the surface's unit.  The
command-to-position mapping of the model's flight-control system is measured on the model
itself (integration suspended) and inverted (:class:`SurfaceDrive`), so the surface is
exactly where it is asked to be, whatever the model's scaling.

JSBSim's messages go to a logger of this module (:class:`JSBSimLog`), never to stdout; the
warnings and errors among them are added to the :class:`~probing.sim.errors.TrimError` a
failed trim raises.
"""

from __future__ import annotations

import bisect
import collections
import functools
import math
import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

os.environ.setdefault("JSBSIM_DEBUG", "0")  # no banner on stdout
import jsbsim
import numpy as np

from probing.core.forked import can_fork, forked_map
from probing.sim.aircraft import alpha_range_rad, sanitised_root, stock_root
from probing.sim.channels import CHANNELS
from probing.sim.errors import AircraftNotFoundError, DivergenceError, TrimError
from probing.sim.flight import (
    DAMAGE_MODEL,
    SPEED_KINDS,
    SYMMETRIC_DAMAGE,
    TURBULENCE_SEVERITY,
    Flight,
    check_damage_case,
)
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACES, Surface

__all__ = [
    "ELEVATOR_CMD",
    "ELEVATOR_POS_DEG",
    "JSBSimLog",
    "Plant",
    "SurfaceDrive",
    "TrimResult",
    "TurnState",
    "TurnTrim",
    "make_plant",
    "trim_flight",
]

ELEVATOR_CMD = SURFACES["elevator"].command
ELEVATOR_POS_DEG = SURFACES["elevator"].position


class JSBSimLog(jsbsim.FGLogger):
    """JSBSim's log records, kept instead of printed: nothing of JSBSim reaches stdout.

    Records below ``WARN`` (debug chatter, reports JSBSim would print on stdout) are
    dropped; the latest ``keep`` warnings and errors are kept for error messages.
    """

    def __init__(self, keep: int = 20) -> None:
        super().__init__()
        self._level = jsbsim.LogLevel.BULK
        self._parts: list[str] = []
        self.records: collections.deque[str] = collections.deque(maxlen=keep)

    def set_level(self, level: jsbsim.LogLevel) -> None:
        self._level, self._parts = level, []

    def file_location(self, filename: str, line: int) -> None:
        pass

    def message(self, message: str) -> None:
        self._parts.append(message)

    def format(self, format: jsbsim.LogFormat) -> None:
        pass

    def flush(self) -> None:
        if jsbsim.LogLevel.WARN <= self._level <= jsbsim.LogLevel.FATAL:
            text = " ".join("".join(self._parts).split())
            if text:
                self.records.append(text)
        self._parts = []

    def take(self) -> str:
        """The kept records as one line (``"; "``-joined), and forget them."""
        text = "; ".join(self.records)
        self.records.clear()
        return text


#: JSBSim's trim modes (FGTrim): longitudinal, full, and the turn (bank set, turn rate from it).
TRIM_LONGITUDINAL, TRIM_FULL, TRIM_TURN = 0, 1, 5
#: JSBSim's body-axis accelerations, the six a trim zeroes: (property, name with its unit).
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
DAMAGE_PROPERTY = "damage/case"


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
    def read(cls, fdm: jsbsim.FGFDMExec) -> TurnState:
        """The state ``fdm`` is in now."""
        return cls(
            alpha_deg=float(fdm["aero/alpha-deg"]),
            beta_deg=float(fdm["aero/beta-deg"]),
            phi_deg=float(fdm["attitude/phi-deg"]),
            theta_deg=float(fdm["attitude/theta-deg"]),
            gamma_deg=float(fdm["flight-path/gamma-deg"]),
            speed_keas=float(fdm["velocities/ve-kts"]),
            turn_rate_deg_s=math.degrees(fdm["velocities/psidot-rad_sec"]),
            elevator_deg=float(fdm[ELEVATOR_POS_DEG]),
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


class SurfaceDrive:
    """One surface of a trimmed plant, driven by its position: the model's command-to-position
    map, measured on the model's own flight-control system and inverted.

    The stock models map the (normalised) command to the surface through piecewise-linear
    components (clip, zero-centred aerosurface_scale, possibly asymmetric, a trim added);
    sampled at their breakpoints the map is exact between samples, so its inverse by linear
    interpolation is exact too.  Only the strictly monotonic part is kept (clipped ends are
    flat and cannot be inverted).

    Attributes
    ----------
    surface : Surface
        What is driven (:data:`probing.sim.surfaces.SURFACES`).
    trim_position : float
        The position at the trim, in the surface's unit.
    trim_command : float
        The normalised command at the trim.
    """

    def __init__(
        self,
        surface: Surface,
        nodes: list,
        pos_node: object,
        trim_position: float,
        trim_command: float,
        map_cmd: np.ndarray,
        map_pos: np.ndarray,
    ) -> None:
        self.surface = surface
        self.nodes = nodes
        self.pos_node = pos_node
        self.trim_position = trim_position
        self.trim_command = trim_command
        self.map_cmd, self.map_pos = map_cmd, map_pos  # sorted by position
        self._cmd_list, self._pos_list = map_cmd.tolist(), map_pos.tolist()
        order = np.argsort(map_cmd)
        self._cmd_sorted, self._pos_by_cmd = map_cmd[order], map_pos[order]
        self._by_cmd = (self._cmd_sorted.tolist(), self._pos_by_cmd.tolist())
        if len(nodes) == 1:
            self.set = nodes[0].set_double_value  # the one write of a step
        else:
            setters = [n.set_double_value for n in nodes]

            def set_all(value: float) -> None:
                for write in setters:
                    write(value)

            self.set = set_all

    @property
    def range(self) -> tuple[float, float]:
        """Positions reachable through the command (the surface's unit)."""
        return float(self.map_pos[0]), float(self.map_pos[-1])

    def command(self, position: np.ndarray) -> np.ndarray:
        """Normalised commands that put the surface exactly at ``position`` (its unit).

        Raises
        ------
        ValueError
            If a position is outside :attr:`range`.
        """
        position = np.asarray(position, dtype=np.float64)
        lo, hi = self.range
        if position.size and (position.min() < lo or position.max() > hi):
            what = "deflection" if self.surface.unit == "deg" else "position"
            raise ValueError(
                f"{self.surface.name} {what} {position.min():.6g}..{position.max():.6g} "
                f"{self.surface.unit} is outside the model's range {lo:.6g}..{hi:.6g} "
                f"{self.surface.unit}"
            )
        return np.interp(position, self.map_pos, self.map_cmd)

    def command_clipped(self, position: float) -> float:
        """The normalised command for one ``position``, clipped to the range: the same map
        and the same bits as :meth:`command` (``numpy.interp``'s own formula), for a loop
        that computes its command one step at a time."""
        return _interp_clipped(position, self._pos_list, self._cmd_list)

    def position_of(self, command: float) -> float:
        """The position the model gives a normalised ``command`` (the forward map; beyond the
        invertible part, the position at its end), for a loop that commands the surface
        one step at a time in normalised units."""
        return _interp_clipped(command, *self._by_cmd)

    def gain_per_norm(self) -> float:
        """Local slope d(position)/d(command) at the trimmed command (unit per unit command)."""
        cmd, pos = self._cmd_sorted, self._pos_by_cmd  # the map is kept sorted by position
        i = int(np.clip(np.searchsorted(cmd, self.trim_command), 1, cmd.size - 1))
        return float((pos[i] - pos[i - 1]) / (cmd[i] - cmd[i - 1]))


def _interp_clipped(x: float, xs: list[float], ys: list[float]) -> float:
    """Piecewise-linear ``ys`` over increasing ``xs`` at one ``x``, clipped to the ends:
    ``numpy.interp``'s own formula, for one value at a time without building an array."""
    s = min(max(x, xs[0]), xs[-1])
    if s == xs[-1]:
        return ys[-1]
    j = bisect.bisect_right(xs, s) - 1  # xs[j] <= s < xs[j + 1]
    slope = (ys[j + 1] - ys[j]) / (xs[j + 1] - xs[j])
    return slope * (s - xs[j]) + ys[j]


class Plant:
    """A trimmed JSBSim aircraft stepped with a surface position (:meth:`drive`).

    Parameters
    ----------
    model : str
        Aircraft name (project ``aircraft/`` first, then JSBSim's stock models).
    dt_s : float
        Integration step in seconds.
    turbulence : str
        ``"none"``, ``"light"``, ``"moderate"`` or ``"severe"`` (JSBSim's
        MIL-spec Dryden model, switched on after trim).
    seed : int
        Seed of JSBSim's random generator (turbulence).
    """

    def __init__(self, model: str, dt_s: float, *, turbulence: str = "none", seed: int = 0) -> None:
        if turbulence not in TURBULENCE_SEVERITY:
            raise ValueError(f"turbulence must be one of {sorted(TURBULENCE_SEVERITY)}")
        self.model = model
        self.dt_s = float(dt_s)
        self.turbulence = turbulence
        self.seed = int(seed)
        self._steps = 0  # steps run since the trim (for a scheduled damage onset)
        self._fault: tuple[int, int] | None = None  # (damage case, step index of its onset)
        root = sanitised_root(model)
        stock = stock_root()
        self.log = JSBSimLog()
        jsbsim.set_logger(self.log)  # this thread's JSBSim instances log here, not to stdout
        fdm = jsbsim.FGFDMExec(str(root))
        fdm.set_debug_level(0)
        fdm.set_engine_path(str(stock / "engine"))
        fdm.set_systems_path(str(stock / "systems"))
        fdm.disable_output()
        fdm["simulation/randomseed"] = self.seed
        fdm["atmosphere/randomseed"] = self.seed  # the turbulence generator; set before loading
        fdm.set_dt(self.dt_s)  # before loading: FCS components keep the dt they were built with
        if not fdm.load_model(model):
            raise AircraftNotFoundError(f"JSBSim could not load aircraft {model!r}")
        fdm.set_dt(self.dt_s)
        self.fdm = fdm
        self._alpha_range = alpha_range_rad(root / "aircraft" / model / f"{model}.xml")
        self._pm = fdm.get_property_manager()
        self.trim_result: TrimResult | None = None
        self.turn_trim: TurnTrim | None = None  # how the last trim found its turn, if a turn
        self._drives: dict[str, SurfaceDrive] = {}

    # ----------------------------------------------------------------- trim
    def trim(
        self,
        altitude_ft: float,
        *,
        speed_kcas: float | None = None,
        speed_ktas: float | None = None,
        speed_keas: float | None = None,
        mach: float | None = None,
        gamma_deg: float = 0.0,
        bank_deg: float = 0.0,
        longitudinal: bool = False,
        surface: str = DEFAULT_SURFACE,
    ) -> TrimResult:
        """Trim, gear up, engines running: straight and level by default (JSBSim's full
        trim), climbing or descending at ``gamma_deg``, or in a steady turn at ``bank_deg``
        at zero sideslip, as NASA's ``trimgtm.m`` trims one (:meth:`_trim_zero_sideslip`:
        JSBSim's turn trim, which leaves the sideslip free, then the six accelerations
        zeroed at beta = 0 with the turn rate free; :attr:`turn_trim` says how).

        Parameters
        ----------
        altitude_ft : float
            Altitude above sea level, ft.
        speed_kcas, speed_ktas, speed_keas : float, optional
            Calibrated, true or equivalent airspeed, kt.
        mach : float, optional
            Mach number.  Exactly one of the four speeds is given.
        gamma_deg : float
            Flight-path angle, deg (positive climbing).
        bank_deg : float
            Bank angle of a steady turn, deg (positive right wing down); 0 flies straight.
            The turn is trimmed at zero sideslip; its rate is what the forces then give.
        longitudinal : bool
            JSBSim's longitudinal trim (throttle, pitch trim, alpha) with the lateral state
            left wings level at zero sideslip: for an aircraft whose lateral trim controls
            are gone but that has nothing to trim laterally (a symmetric damage case).
        surface : str
            A surface to calibrate besides the elevator (:meth:`drive`), before turbulence
            is switched on: the one a probe will drive.

        Returns
        -------
        TrimResult
            The trimmed state; the elevator map is calibrated and turbulence switched on.

        Raises
        ------
        TrimError
            Naming the condition, with JSBSim's own warnings, when JSBSim fails, or when
            a turn cannot be trimmed at zero sideslip (no rudder, a control at its stop).
        """
        self._trim_args = {
            "altitude_ft": altitude_ft,
            "speed_kcas": speed_kcas,
            "speed_ktas": speed_ktas,
            "speed_keas": speed_keas,
            "mach": mach,
            "gamma_deg": gamma_deg,
            "bank_deg": bank_deg,
            "longitudinal": longitudinal,
        }
        kind, speed = _one_speed(speed_kcas, speed_ktas, speed_keas, mach)
        fdm = self.fdm
        jsbsim.set_logger(self.log)
        self.log.take()
        fdm["ic/h-sl-ft"] = altitude_ft
        fdm[SPEED_KINDS[kind].ic_property] = speed
        fdm["ic/gamma-deg"] = gamma_deg
        fdm["ic/beta-deg"] = 0.0
        fdm["ic/phi-deg"] = bank_deg
        fdm["gear/gear-cmd-norm"] = 0.0
        fdm["propulsion/set-running"] = -1
        where = f"{self.model} at altitude_ft = {altitude_ft:g}, {kind} = {speed:g}"
        if gamma_deg or bank_deg:
            where += f", gamma_deg = {gamma_deg:g}, bank_deg = {bank_deg:g}"
        self._jsbsim_trim(where, bank_deg=bank_deg, longitudinal=longitudinal)
        self.turn_trim = None
        if bank_deg:
            self.turn_trim = self._trim_zero_sideslip(where, gamma_deg=gamma_deg, bank_deg=bank_deg)
        fdm.set_dt(self.dt_s)
        if fdm["gear/gear-pos-norm"] > 0.0:
            raise TrimError(f"gear still down after trim for {where}")
        self.trim_result = self._trimmed_state(bank_deg=bank_deg, longitudinal=longitudinal)
        self._drives = {}
        self.drive(DEFAULT_SURFACE)  # calibrated right after the trim, as it always was
        self.drive(surface)  # before the gusts: its calibration steps the FCS
        self.disturb(self.turbulence, self.seed)
        return self.trim_result

    def _jsbsim_trim(self, where: str, *, bank_deg: float, longitudinal: bool) -> None:
        """Run the initial conditions and JSBSim's trim (turn, longitudinal or full)."""
        fdm = self.fdm
        try:
            if not fdm.run_ic():
                raise TrimError(self._with_log(f"could not initialise {where}"))
            mode = TRIM_LONGITUDINAL if longitudinal else TRIM_FULL
            fdm.do_trim(TRIM_TURN if bank_deg else mode)
        except RuntimeError as exc:  # jsbsim.TrimFailureError and its BaseError kin
            raise TrimError(self._with_log(f"trim failed for {where}: {exc}")) from None

    def _trimmed_state(self, *, bank_deg: float, longitudinal: bool) -> TrimResult:
        """The trimmed state, read from JSBSim."""
        fdm = self.fdm
        return TrimResult(
            altitude_ft=float(fdm["position/h-sl-ft"]),
            speed_kcas=float(fdm["velocities/vc-kts"]),
            speed_keas=float(fdm["velocities/ve-kts"]),
            speed_ktas=float(fdm["velocities/vtrue-kts"]),
            mach=float(fdm["velocities/mach"]),
            alpha_deg=float(fdm["aero/alpha-deg"]),
            theta_deg=float(fdm["attitude/theta-deg"]),
            elevator_deg=float(fdm[ELEVATOR_POS_DEG]),
            elevator_cmd_norm=float(fdm[ELEVATOR_CMD]),
            pitch_trim_cmd_norm=float(fdm["fcs/pitch-trim-cmd-norm"]),
            throttle_norm=float(fdm["fcs/throttle-cmd-norm[0]"]),
            mode="turn" if bank_deg else ("longitudinal" if longitudinal else "full"),
        )

    def _trim_zero_sideslip(self, where: str, *, gamma_deg: float, bank_deg: float) -> TurnTrim:
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

        fdm = self.fdm
        start = TurnState.read(fdm)
        speed_fps = float(fdm["ic/vt-fps"])
        psi_rad = float(fdm["attitude/psi-rad"])
        phi_rad, gamma_rad = math.radians(bank_deg), math.radians(gamma_deg)
        throttles = [f"fcs/throttle-cmd-norm[{i}]" for i in range(self.engine_count())]
        controls = ("fcs/pitch-trim-cmd-norm", "fcs/aileron-cmd-norm", "fcs/rudder-cmd-norm")
        accelerations = [self._pm.get_node(prop) for prop, _ in ACCELERATIONS]

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
        self._check_turn_trim(trimmed, where, gamma_deg=gamma_deg, bank_deg=bank_deg)
        return TurnTrim(jsbsim=start, trimmed=trimmed, evaluations=int(solution.nfev))

    def _check_turn_trim(
        self, trimmed: TurnState, where: str, *, gamma_deg: float, bank_deg: float
    ) -> None:
        """Refuse a turn trim that left an acceleration or is not the asked state."""
        asked = (
            abs(trimmed.beta_deg) < 1e-9
            and abs(trimmed.phi_deg - bank_deg) < 1e-9
            and abs(trimmed.gamma_deg - gamma_deg) < 1e-9
        )
        if trimmed.worst_acceleration > TURN_TRIM_TOLERANCE or not asked:
            raise TrimError(
                self._with_log(
                    f"turn trim at zero sideslip failed for {where}: accelerations "
                    + ", ".join(f"{k} {v:.3g}" for k, v in trimmed.accelerations.items())
                    + f" at beta_deg = {trimmed.beta_deg:.3g}"
                )
            )

    def damage(self, case: int) -> None:
        """Switch a damage case on (0: none), effective from the next step: NASA's GTM cases
        (``aircraft/gtm_t2/README.md``, "Damage cases"), through the model's ``damage/case``.

        Raises
        ------
        ValueError
            If the model has no damage cases, or ``case`` is not one of them.
        """
        check_damage_case(self.model, case, need_model=True)
        self.fdm[DAMAGE_PROPERTY] = float(case)

    def schedule(self, flight: Flight) -> None:
        """After the trim: switch ``flight``'s damage case on at its onset, counted in steps
        of :meth:`step` from now (the step that starts at the onset is the first damaged)."""
        self._steps = 0
        self._fault = None
        if flight.damage_onset_s is not None:
            self._fault = (flight.damage_case, round(flight.damage_onset_s / self.dt_s))

    @property
    def steps_run(self) -> int:
        """Steps run since the trim (or the last :meth:`schedule`)."""
        return self._steps

    @property
    def damage_onset_step(self) -> int | None:
        """The step index at which a scheduled damage case is still to be switched on, None
        if there is none pending."""
        return self._fault[1] if self._fault is not None else None

    def start_scheduled_damage(self) -> None:
        """Switch the scheduled damage case on now (effective from the next step) and clear
        it: what :meth:`step` does at the onset step, for a loop that steps the aircraft
        itself (:class:`probing.sim.control.ClosedLoop`)."""
        if self._fault is None:
            raise ValueError("no damage is scheduled")
        case = self._fault[0]
        self._fault = None
        self.damage(case)

    def count_steps(self, n: int) -> None:
        """Count ``n`` steps run by a loop that steps the aircraft itself (the onset of a
        scheduled damage is counted in these steps too)."""
        self._steps += n

    def disturb(self, turbulence: str, seed: int) -> None:
        """Seed JSBSim's random generators and switch turbulence on: what follows the trim.

        The trim does not depend on either (turbulence is off while trimming and the trim
        draws no random number), so one trimmed aircraft serves flights that differ only
        in them: a copy of it (a forked process, :mod:`probing.sim.fork`) disturbed here
        steps exactly as an aircraft loaded and trimmed with these values.

        Parameters
        ----------
        turbulence : str
            ``"none"``, ``"light"``, ``"moderate"`` or ``"severe"`` (JSBSim's MIL-spec
            Dryden model).
        seed : int
            Seed of JSBSim's random generators.
        """
        if turbulence not in TURBULENCE_SEVERITY:
            raise ValueError(f"turbulence must be one of {sorted(TURBULENCE_SEVERITY)}")
        fdm = self.fdm
        self.turbulence, self.seed = turbulence, int(seed)
        fdm["simulation/randomseed"] = self.seed
        fdm["atmosphere/randomseed"] = self.seed
        if turbulence != "none":
            fdm["atmosphere/turb-type"] = 3  # ttMilspec: MIL-F-8785C / MIL-HDBK-1797 Dryden
            fdm["atmosphere/turbulence/milspec/severity"] = TURBULENCE_SEVERITY[turbulence]
            fdm["atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps"] = 15.0

    def _with_log(self, message: str) -> str:
        """``message`` with JSBSim's warnings and errors since the last call appended."""
        log = self.log.take()
        return f"{message} (JSBSim: {log})" if log else message

    def drive(self, surface: str = DEFAULT_SURFACE) -> SurfaceDrive:
        """The surface ``surface`` (:data:`~probing.sim.surfaces.SURFACES`) driven by its
        position: calibrated on first use after the trim (the elevator's, and the one
        :meth:`trim` is given, right after it, before turbulence is switched on).

        The calibration evaluates the flight-control system with integration suspended and
        puts the command back, so the surface ends where the trim left it (checked).  Call
        it for a new surface before the plant is disturbed or forked, so that every copy
        steps from the same state.

        Raises
        ------
        ValueError
            If the model has no such surface (a property missing) or no command moves it.
        """
        assert self.trim_result is not None, "trim first"
        if surface not in self._drives:
            if surface not in SURFACES:
                raise ValueError(f"surface must be one of {', '.join(SURFACES)}, got {surface!r}")
            if surface == DEFAULT_SURFACE:
                self._drives[surface] = self._calibrate(SURFACES[surface])
            else:
                self._drives[surface] = self._calibrated_on_a_copy(SURFACES[surface])
        return self._drives[surface]

    def _calibrated_on_a_copy(self, surface: Surface) -> SurfaceDrive:
        """:meth:`_calibrate` run on an identical copy of this plant, the map handed back:
        evaluating the FCS at other commands moves component states (filters, dampers) by
        rounding, and this plant must step exactly as if no other surface had been
        calibrated (the elevator's calibration, done in place right after every trim since
        the first run, is part of the trimmed state).  The copy is a forked child, or, where
        the system cannot fork, the same aircraft loaded and trimmed afresh."""
        if can_fork():
            calibrate = functools.partial(_calibration, plant=self)
            (outcome,) = forked_map(calibrate, [surface.name])
            found = outcome.get()
        else:
            copy = Plant(self.model, self.dt_s)
            if self.model == DAMAGE_MODEL:
                copy.fdm[DAMAGE_PROPERTY] = self.fdm[DAMAGE_PROPERTY]
            copy.trim(**self._trim_args)
            found = _calibration(surface.name, copy)
        return SurfaceDrive(surface, *self._nodes_of(surface), *found)

    def engine_count(self) -> int:
        """Engines of the model (throttle commands ``fcs/throttle-cmd-norm[i]``)."""
        n = 0
        while self._pm.hasNode(f"fcs/throttle-cmd-norm[{n}]"):
            n += 1
        return n

    def _nodes_of(self, surface: Surface) -> tuple[list, object]:
        """The property nodes a surface is commanded through, and its position's.

        Raises
        ------
        ValueError
            If the model lacks one of them.
        """
        pm = self._pm
        props = surface.command_properties(self.engine_count())
        missing = [p for p in (*props, surface.position) if not pm.hasNode(p)]
        if missing or not props:
            raise ValueError(f"{self.model} has no {surface.name} ({', '.join(missing)})")
        return [pm.get_node(p) for p in props], pm.get_node(surface.position)

    def _calibrate(self, surface: Surface) -> SurfaceDrive:
        """Measure ``surface``'s command -> position on the model's own FCS (see
        :class:`SurfaceDrive`)."""
        fdm, pm = self.fdm, self._pm
        nodes, pos_node = self._nodes_of(surface)
        cmd0 = nodes[0].get_double_value()
        pos0 = pos_node.get_double_value()
        lo, hi = surface.command_range
        grid = np.linspace(lo, hi, 401)
        kinks = [cmd0]
        if surface.trim_command is not None and pm.hasNode(surface.trim_command):
            trim = float(fdm[surface.trim_command])
            kinks = [-trim, 1.0 - trim, -1.0 - trim, cmd0]
        kinks = np.array(kinks)
        grid = np.unique(np.concatenate((grid, kinks[(kinks >= lo) & (kinks <= hi)])))
        setters = [n.set_double_value for n in nodes]
        get_pos, run = pos_node.get_double_value, fdm.run

        def position_at(cmd: float) -> float:
            for write in setters:
                write(cmd)
            run()  # integration suspended: evaluates the FCS only
            return get_pos()

        time0 = fdm.get_sim_time()
        fdm.suspend_integration()
        try:
            position = np.array([position_at(c) for c in grid])
            back = position_at(cmd0)
        finally:
            fdm.resume_integration()
            fdm.set_sim_time(time0)
        if not math.isclose(back, pos0, rel_tol=0, abs_tol=1e-12):
            raise RuntimeError(f"{surface.name} calibration changed the trimmed position")
        if position[-1] < position[0]:
            grid, position = grid[::-1], position[::-1]
        keep = np.concatenate(([True], np.diff(position) > 0))
        if keep.sum() < 2:
            raise ValueError(f"no command moves the {surface.name} of {self.model}")
        return SurfaceDrive(surface, nodes, pos_node, pos0, cmd0, grid[keep], position[keep])

    # ----------------------------------------------------------------- step
    def channel_nodes(self, channels: list[str]) -> list:
        """Cached property nodes for output channels (see :data:`CHANNELS`)."""
        unknown = [c for c in channels if c not in CHANNELS]
        if unknown:
            raise ValueError(f"unknown channel(s) {unknown}; allowed: {sorted(CHANNELS)}")
        return [self._pm.get_node(CHANNELS[c].prop) for c in channels]

    def step(
        self,
        cmd_norm: np.ndarray | None,
        nodes: list,
        out: np.ndarray,
        position: np.ndarray | None = None,
        drive: SurfaceDrive | None = None,
    ) -> None:
        """Run ``out.shape[0]`` steps; ``out[k, j]`` is channel j read right after step k.

        Parameters
        ----------
        cmd_norm : numpy.ndarray or None
            Normalised command of the driven surface for each step (written before the
            step), shape ``(n,)``.  None holds the commands the plant has (after
            :meth:`trim`, the trimmed ones) and writes nothing: the unprobed twin.
        nodes : list
            Property nodes of the channels, from :meth:`channel_nodes`.
        out : numpy.ndarray
            ``(n, len(nodes))`` float64, filled in place (channel units, see :data:`CHANNELS`).
        position : numpy.ndarray, optional
            ``(n,)``, receives the driven surface's realised position after each step (its
            unit).
        drive : SurfaceDrive, optional
            The surface the commands drive (:meth:`drive`); default the elevator.

        Notes
        -----
        The per-step work is the command write, ``run()`` and one read per channel; the
        reads are appended to one flat list and copied into ``out`` once, so no array is
        built per step.
        """
        n = out.shape[0]
        drive = drive or self.drive()
        fault = self._fault
        if fault is not None and fault[1] < self._steps + n:  # the onset falls in these steps
            j = max(0, fault[1] - self._steps)
            cmds = (None, None) if cmd_norm is None else (cmd_norm[:j], cmd_norm[j:])
            els = (None, None) if position is None else (position[:j], position[j:])
            if j:
                self._fault = None  # not in the steps before it
                self.step(cmds[0], nodes, out[:j], els[0], drive)
                self._fault = fault
            self.start_scheduled_damage()
            self.step(cmds[1], nodes, out[j:], els[1], drive)
            return
        self._steps += n
        getters = [node.get_double_value for node in nodes]
        if position is not None:
            getters.append(drive.pos_node.get_double_value)
        run = self.fdm.run
        values: list[float] = []
        append = values.append
        if cmd_norm is None:
            for _ in range(n):
                run()
                for get in getters:
                    append(get())
        else:
            if len(cmd_norm) != n:
                raise ValueError(f"{len(cmd_norm)} commands for {n} output rows")
            set_cmd = drive.set
            for c in cmd_norm.tolist():
                set_cmd(c)
                run()
                for get in getters:
                    append(get())
        block = np.array(values, dtype=np.float64).reshape(n, len(getters))
        out[:] = block[:, : len(nodes)]
        if position is not None:
            position[:] = block[:, -1]

    def step_surfaces(
        self, commands: np.ndarray, drives: Sequence[SurfaceDrive], nodes: list, out: np.ndarray
    ) -> None:
        """Run ``out.shape[0]`` steps driving several surfaces at once: before step k,
        ``commands[k, i]`` (normalised) is written to ``drives[i]``; ``out[k, j]`` is channel j
        read after it.  :meth:`step` drives one surface; this is the simultaneous probe's.

        Raises
        ------
        ValueError
            If the shapes disagree, or a damage onset is pending (not offered here).
        """
        n = out.shape[0]
        if commands.shape != (n, len(drives)):
            raise ValueError(f"commands {commands.shape} for {n} steps of {len(drives)} surfaces")
        if self._fault is not None:
            raise ValueError("a damage onset is not offered with several surfaces driven")
        self._steps += n
        getters = [node.get_double_value for node in nodes]
        setters = [d.set for d in drives]
        run = self.fdm.run
        values: list[float] = []
        append = values.append
        for row in commands.tolist():
            for write, c in zip(setters, row, strict=True):
                write(c)
            run()
            for get in getters:
                append(get())
        out[:] = np.array(values, dtype=np.float64).reshape(n, len(nodes))

    def check_state(self) -> None:
        """Raise :class:`DivergenceError` if the aircraft left the meaningful region."""
        fdm = self.fdm
        alpha = fdm["aero/alpha-rad"]
        theta = fdm["attitude/theta-rad"]
        t = fdm.get_sim_time()
        if not (math.isfinite(alpha) and math.isfinite(theta)):
            raise DivergenceError(f"simulation diverged (NaN) at t = {t:.2f} s")
        if fdm["position/h-agl-ft"] <= 0.0:
            raise DivergenceError(f"aircraft hit the ground at t = {t:.2f} s")
        lo, hi = self._alpha_range
        if not lo <= alpha <= hi:
            raise DivergenceError(
                f"alpha = {math.degrees(alpha):.2f} deg left the model's tables "
                f"({math.degrees(lo):.1f}..{math.degrees(hi):.1f} deg) at t = {t:.2f} s"
            )

    # -------------------------------------------------------- linearisation
    def linearise(self) -> dict[str, np.ndarray | list[str]]:
        """JSBSim's FGLinearization at the current (trimmed) state.

        Returns the continuous-time A, B, C, D and the state/input/output
        names.  JSBSim leaves dt at 0 afterwards; it is set back here.
        """
        jsbsim.set_logger(self.log)
        lin = jsbsim.FGLinearization(self.fdm)
        result = {
            "A": np.array(lin.system_matrix),
            "B": np.array(lin.input_matrix),
            "C": np.array(lin.output_matrix),
            "D": np.array(lin.feedforward_matrix),
            "x_names": list(lin.x_names),
            "u_names": list(lin.u_names),
            "y_names": list(lin.y_names),
            "x_units": list(lin.x_units),
            "u_units": list(lin.u_units),
        }
        self.fdm.set_dt(self.dt_s)
        return result

    def actuator_pulse_response(
        self, n_steps: int = 200, height: float = 1e-3, surface: str = DEFAULT_SURFACE
    ) -> np.ndarray:
        """The realised surface after each step for a one-step pulse of the asked position,
        per unit asked (1 at step 0 and 0 after for a surface without actuator dynamics; the
        GTM's 5 Hz servos spread it over about 0.2 s).

        The pulse is small (``height``, in the surface's unit) so a rate limit does not act.
        The plant is stepped: use it for nothing else afterwards.
        """
        drive = self.drive(surface)
        position = np.full(n_steps, drive.trim_position)
        position[0] += height
        out = np.empty((n_steps, 0))
        realised = np.empty(n_steps)
        self.step(drive.command(position), [], out, realised, drive)
        return (realised - drive.trim_position) / height


def _calibration(surface: str, plant: Plant) -> tuple[float, float, np.ndarray, np.ndarray]:
    """The trimmed position and command and the map of ``surface`` on ``plant`` (calibrated
    in place: call it on a copy)."""
    drive = plant._calibrate(SURFACES[surface])
    return drive.trim_position, drive.trim_command, drive.map_cmd, drive.map_pos


def make_plant(flight: Flight) -> Plant:
    """A plant for a flight (model, dt, turbulence, seed), trimmed at its condition."""
    plant = Plant(flight.model, flight.dt_s, turbulence=flight.turbulence, seed=flight.seed)
    trim_flight(plant, flight)
    plant.schedule(flight)
    return plant


def trim_flight(plant: Plant, flight: Flight) -> TrimResult:
    """Trim ``plant`` at the flight's condition, with the damage case it is trimmed with
    (:attr:`Flight.trimmed_damage`): level, climbing or in a steady turn.  JSBSim's full trim
    fails when a control has no authority left (the rudder
    in the symmetric damage cases, which leave nothing to trim laterally): the longitudinal
    trim is used there."""
    if flight.trimmed_damage:
        plant.damage(flight.trimmed_damage)
    speed = {flight.speed_kind: flight.speed}
    angles = {
        "gamma_deg": flight.gamma_deg,
        "bank_deg": flight.bank_deg,
        "surface": flight.surface,
    }
    try:
        return plant.trim(flight.altitude_ft, **speed, **angles)
    except TrimError:
        if flight.trimmed_damage not in SYMMETRIC_DAMAGE or flight.bank_deg:
            raise
        return plant.trim(flight.altitude_ft, **speed, **angles, longitudinal=True)


def _one_speed(
    speed_kcas: float | None,
    speed_ktas: float | None,
    speed_keas: float | None,
    mach: float | None,
) -> tuple[str, float]:
    """The one speed given to :meth:`Plant.trim`: its kind and value."""
    speeds = {"speed_kcas": speed_kcas, "speed_ktas": speed_ktas, "speed_keas": speed_keas}
    speeds["mach"] = mach
    given = {k: v for k, v in speeds.items() if v is not None}
    if len(given) != 1:
        raise ValueError(f"exactly one of {', '.join(SPEED_KINDS)} must be given")
    ((kind, speed),) = given.items()
    return kind, speed


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
