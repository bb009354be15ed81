"""The JSBSim plant: a trimmed aircraft stepped with a surface position (deg, or a normalised
throttle).

A :class:`Plant` loads an aircraft from its sanitised copy (:mod:`probing.sim.aircraft`),
trims it, and steps it with the position of one surface (:mod:`probing.sim.surfaces`) in
the surface's unit, through the model's own command-to-position map, measured and inverted
(:mod:`probing.sim.drive`).  A turn is trimmed at zero sideslip (:mod:`probing.sim.turn_trim`).
JSBSim's messages go to :class:`~probing.sim.jsbsim_log.JSBSimLog`, never to stdout; its
warnings and errors are added to the :class:`~probing.sim.errors.TrimError` a trim raises.
"""

from __future__ import annotations

import functools
import math
import os

os.environ.setdefault("JSBSIM_DEBUG", "0")  # no banner on stdout
import jsbsim
import numpy as np

from probing.core.forked import can_fork, forked_map
from probing.sim import aircraft as aircraft_files
from probing.sim.aircraft import alpha_range_rad, sanitised_root, stock_root
from probing.sim.channels import CHANNELS
from probing.sim.drive import SurfaceDrive, calibrate
from probing.sim.errors import AircraftNotFoundError, DivergenceError, TrimError
from probing.sim.flight import (
    DAMAGE_MODEL,
    SPEED_KINDS,
    SYMMETRIC_DAMAGE,
    TURBULENCE_SEVERITY,
    Flight,
    TrimResult,
    check_damage_case,
    disturbance_properties,
    one_speed,
)
from probing.sim.jsbsim_log import JSBSimLog
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACES, Surface
from probing.sim.turn_trim import TurnState, TurnTrim, trim_zero_sideslip

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


#: JSBSim's trim modes (FGTrim): longitudinal, full, and the turn (bank set, turn rate from it).
TRIM_LONGITUDINAL, TRIM_FULL, TRIM_TURN = 0, 1, 5
DAMAGE_PROPERTY = "damage/case"


class Plant:
    """A trimmed JSBSim aircraft stepped with a surface position (:meth:`drive`).

    Parameters
    ----------
    model : str
        Aircraft name or folder path (:func:`probing.sim.aircraft.find_aircraft`).
    dt_s : float
        Integration step in seconds.
    turbulence : str
        ``"none"``, ``"light"``, ``"moderate"`` or ``"severe"`` (JSBSim's
        MIL-spec Dryden model, switched on after trim).
    seed : int
        Seed of JSBSim's random generator (turbulence).
    gust_inputs : bool
        Load the gust-ready copy of the aircraft (:func:`probing.sim.aircraft.sanitised_root`).
    calibrates_in_place : bool
        A copy made to calibrate a surface on (:meth:`drive`): it calibrates itself.
    """

    def __init__(
        self,
        model: str,
        dt_s: float,
        *,
        turbulence: str = "none",
        seed: int = 0,
        gust_inputs: bool = False,
        calibrates_in_place: bool = False,
    ) -> None:
        if turbulence not in TURBULENCE_SEVERITY:
            raise ValueError(f"turbulence must be one of {sorted(TURBULENCE_SEVERITY)}")
        self.model = model
        self.dt_s = float(dt_s)
        self.turbulence = turbulence
        self.seed = int(seed)
        #: Whether the model takes gust inputs (:func:`probing.sim.aircraft.sanitised_root`).
        self.gust_inputs = bool(gust_inputs)
        self._steps = 0  # steps run since the trim (for a scheduled damage onset)
        self._fault: tuple[int, int] | None = None  # (damage case, step index of its onset)
        root = sanitised_root(model, gust_inputs=gust_inputs)
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
        if not fdm.load_model(aircraft_files.aircraft_name(model)):
            raise AircraftNotFoundError(aircraft_files.not_loaded(model, root, self.log.take()))
        fdm.set_dt(self.dt_s)
        self.fdm = fdm
        self._alpha_range = alpha_range_rad(aircraft_files.model_file(root, model))
        self._pm = fdm.get_property_manager()
        self.trim_result: TrimResult | None = None
        self.turn_trim: TurnTrim | None = None  # how the last trim found its turn, if a turn
        self._drives: dict[str, SurfaceDrive] = {}
        self._in_place = calibrates_in_place

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
        kind, speed = one_speed(speed_kcas, speed_ktas, speed_keas, mach)
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
        self.drive(DEFAULT_SURFACE)  # on copies (the trimmed state untouched), before the
        self.drive(surface)  # gusts and forks, so every copy of this plant has the maps
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
        """The steady turn at zero sideslip from JSBSim's turn trim
        (:func:`probing.sim.turn_trim.trim_zero_sideslip`); the aircraft is left in it."""
        return trim_zero_sideslip(
            self.fdm,
            self.engine_count(),
            where,
            self._with_log,
            gamma_deg=gamma_deg,
            bank_deg=bank_deg,
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
        flown (:meth:`probing.sim.world.JSBSimWorld.fly`) from now (the step that starts at
        the onset is the first damaged)."""
        self._steps = 0
        self._fault = None
        if flight.damage_onset_step is not None:
            self._fault = (flight.damage_case, flight.damage_onset_step)

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
        itself (:meth:`probing.sim.world.JSBSimWorld.fly`)."""
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
        steps exactly as an aircraft loaded and trimmed with these values.  The writes, in
        order, are :func:`probing.sim.flight.disturbance_properties`' (a client of a separate
        JSBSim process sends it the same ones).

        Parameters
        ----------
        turbulence : str
            ``"none"``, ``"light"``, ``"moderate"`` or ``"severe"`` (JSBSim's MIL-spec
            Dryden model).
        seed : int
            Seed of JSBSim's random generators.
        """
        writes = disturbance_properties(turbulence, seed)  # refuses an unknown level
        self.turbulence, self.seed = turbulence, int(seed)
        fdm = self.fdm
        for name, value in writes.items():
            fdm[name] = value

    def _with_log(self, message: str) -> str:
        """``message`` with JSBSim's warnings and errors since the last call appended."""
        log = self.log.take()
        return f"{message} (JSBSim: {log})" if log else message

    def drive(self, surface: str = DEFAULT_SURFACE) -> SurfaceDrive:
        """The surface ``surface`` (:data:`~probing.sim.surfaces.SURFACES`) driven by its
        position: calibrated on first use after the trim (the elevator's, and the one
        :meth:`trim` is given, right after it, before turbulence is switched on).

        Calibrated on a copy (:meth:`_calibrated_on_a_copy`), so this plant steps as the trim
        left it.  Call it for a new surface before the plant is disturbed or forked, so that
        every copy gets the same map without calibrating again.

        Raises
        ------
        ValueError
            If the model has no such surface (a property missing) or no command moves it.
        """
        assert self.trim_result is not None, "trim first"
        if surface not in self._drives:
            if surface not in SURFACES:
                raise ValueError(f"surface must be one of {', '.join(SURFACES)}, got {surface!r}")
            if self._in_place:
                self._drives[surface] = self._calibrate(SURFACES[surface])
            else:
                self._drives[surface] = self._calibrated_on_a_copy(SURFACES[surface])
        return self._drives[surface]

    def _calibrated_on_a_copy(self, surface: Surface) -> SurfaceDrive:
        """:meth:`_calibrate` on a copy (a forked child, or the aircraft loaded and trimmed
        afresh): evaluating the model at other commands leaves JSBSim's derived values behind
        (Nz from the last frame's forces, the integrators' past derivatives), and this plant
        must step as the trim left it (in place, the 737's first step had q = 5.6e-5 rad/s)."""
        if can_fork():
            calibrate = functools.partial(_calibration, plant=self)
            (outcome,) = forked_map(calibrate, [surface.name])
            found = outcome.get()
        else:
            copy = Plant(self.model, self.dt_s, calibrates_in_place=True)
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
        """Measure ``surface``'s command -> position on the model's own FCS
        (:func:`probing.sim.drive.calibrate`)."""
        return calibrate(self.fdm, surface, *self._nodes_of(surface), self.model)

    # ----------------------------------------------------------------- step
    def channel_nodes(self, channels: list[str]) -> list:
        """Cached property nodes for output channels (see :data:`CHANNELS`)."""
        unknown = [c for c in channels if c not in CHANNELS]
        if unknown:
            raise ValueError(f"unknown channel(s) {unknown}; allowed: {sorted(CHANNELS)}")
        return [self._pm.get_node(CHANNELS[c].prop) for c in channels]

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


def _calibration(surface: str, plant: Plant) -> tuple[float, float, np.ndarray, np.ndarray]:
    """The trimmed position and command and the map of ``surface`` on ``plant`` (calibrated
    in place: call it on a copy)."""
    drive = plant._calibrate(SURFACES[surface])
    return drive.trim_position, drive.trim_command, drive.map_cmd, drive.map_pos


def make_plant(flight: Flight, *, gust_inputs: bool = False) -> Plant:
    """A plant for a flight (model, dt, turbulence, seed), trimmed at its condition
    (``gust_inputs``: the gust-ready copy of the aircraft, :func:`sanitised_root`)."""
    plant = Plant(
        flight.model,
        flight.dt_s,
        turbulence=flight.turbulence,
        seed=flight.seed,
        gust_inputs=gust_inputs,
    )
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
