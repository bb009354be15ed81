"""The JSBSim plant: a trimmed aircraft stepped with an elevator deflection in degrees.

A :class:`Plant` loads an aircraft from its sanitised copy (:mod:`probing.sim.aircraft`),
trims it straight and level, and steps it with an elevator surface deflection given in
degrees.  The command-to-surface mapping of the model's flight-control system is measured
on the model itself (integration suspended) and inverted, so the surface deflection is
exactly the one asked for, whatever the model's scaling.

JSBSim's messages go to a logger of this module (:class:`JSBSimLog`), never to stdout; the
warnings and errors among them are added to the :class:`~probing.sim.errors.TrimError` a
failed trim raises.
"""

from __future__ import annotations

import bisect
import collections
import math
import os
from dataclasses import asdict, dataclass

os.environ.setdefault("JSBSIM_DEBUG", "0")  # no banner on stdout
import jsbsim
import numpy as np

from probing.sim.aircraft import alpha_range_rad, sanitised_root, stock_root
from probing.sim.channels import CHANNELS
from probing.sim.errors import AircraftNotFoundError, DivergenceError, TrimError
from probing.sim.flight import (
    SPEED_KINDS,
    SYMMETRIC_DAMAGE,
    TURBULENCE_SEVERITY,
    Flight,
    check_damage_case,
)

__all__ = [
    "ELEVATOR_CMD",
    "ELEVATOR_POS_DEG",
    "JSBSimLog",
    "Plant",
    "TrimResult",
    "make_plant",
    "trim_flight",
]

ELEVATOR_CMD = "fcs/elevator-cmd-norm"
ELEVATOR_POS_DEG = "fcs/elevator-pos-deg"


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


class Plant:
    """A trimmed JSBSim aircraft stepped with an elevator deflection in degrees.

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
        self._cmd_node = self._pm.get_node(ELEVATOR_CMD)
        self._pos_node = self._pm.get_node(ELEVATOR_POS_DEG)
        self.trim_result: TrimResult | None = None
        self._map_cmd: np.ndarray | None = None
        self._map_deg: np.ndarray | None = None

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
    ) -> TrimResult:
        """Trim, gear up, engines running: straight and level by default (JSBSim's full
        trim), climbing or descending at ``gamma_deg``, or in a steady turn at ``bank_deg``
        (JSBSim's turn trim: the turn rate follows from the bank, g tan(bank) / V, and the
        sideslip is left to the trim).

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
        longitudinal : bool
            JSBSim's longitudinal trim (throttle, pitch trim, alpha) with the lateral state
            left wings level at zero sideslip: for an aircraft whose lateral trim controls
            are gone but that has nothing to trim laterally (a symmetric damage case).

        Returns
        -------
        TrimResult
            The trimmed state; the elevator map is calibrated and turbulence switched on.

        Raises
        ------
        TrimError
            Naming the condition, with JSBSim's own warnings, when JSBSim fails.
        """
        speeds = {"speed_kcas": speed_kcas, "speed_ktas": speed_ktas, "speed_keas": speed_keas}
        speeds["mach"] = mach
        given = {k: v for k, v in speeds.items() if v is not None}
        if len(given) != 1:
            raise ValueError(f"exactly one of {', '.join(SPEED_KINDS)} must be given")
        ((kind, speed),) = given.items()
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
        try:
            if not fdm.run_ic():
                raise TrimError(self._with_log(f"could not initialise {where}"))
            mode = TRIM_LONGITUDINAL if longitudinal else TRIM_FULL
            fdm.do_trim(TRIM_TURN if bank_deg else mode)
        except RuntimeError as exc:  # jsbsim.TrimFailureError and its BaseError kin
            raise TrimError(self._with_log(f"trim failed for {where}: {exc}")) from None
        fdm.set_dt(self.dt_s)
        if fdm["gear/gear-pos-norm"] > 0.0:
            raise TrimError(f"gear still down after trim for {where}")
        self.trim_result = TrimResult(
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
        self._calibrate_elevator()
        self.disturb(self.turbulence, self.seed)
        return self.trim_result

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

    def _surface_deg_at(self, cmd: float) -> float:
        self._cmd_node.set_double_value(cmd)
        self.fdm.run()  # integration suspended: evaluates the FCS only
        return self._pos_node.get_double_value()

    def _calibrate_elevator(self) -> None:
        """Measure elevator-cmd-norm -> elevator-pos-deg on the model's own FCS and keep it.

        The stock models map the (normalised) command to the surface through
        piecewise-linear components (clip, zero-centred aerosurface_scale,
        possibly asymmetric); sampled at their breakpoints the map is exact
        between samples, so its inverse by linear interpolation is exact too.
        """
        fdm = self.fdm
        cmd0 = float(fdm[ELEVATOR_CMD])
        trim = float(fdm["fcs/pitch-trim-cmd-norm"])
        grid = np.linspace(-1.0, 1.0, 401)
        kinks = np.array([-trim, 1.0 - trim, -1.0 - trim, cmd0])
        grid = np.unique(np.concatenate((grid, kinks[np.abs(kinks) <= 1.0])))
        time0 = fdm.get_sim_time()
        fdm.suspend_integration()
        try:
            surface = np.array([self._surface_deg_at(c) for c in grid])
            back = self._surface_deg_at(cmd0)
        finally:
            fdm.resume_integration()
            fdm.set_sim_time(time0)
        if not math.isclose(back, self.trim_result.elevator_deg, rel_tol=0, abs_tol=1e-12):
            raise RuntimeError("elevator calibration changed the trimmed surface position")
        # Keep the strictly monotonic part (clipped ends are flat and cannot be inverted).
        if surface[-1] < surface[0]:
            grid, surface = grid[::-1], surface[::-1]
        keep = np.concatenate(([True], np.diff(surface) > 0))
        self._map_cmd, self._map_deg = grid[keep], surface[keep]
        self._map_cmd_list, self._map_deg_list = self._map_cmd.tolist(), self._map_deg.tolist()

    @property
    def elevator_range_deg(self) -> tuple[float, float]:
        """Surface deflections reachable through the command (deg)."""
        assert self._map_deg is not None, "trim first"
        return float(self._map_deg[0]), float(self._map_deg[-1])

    def elevator_command_clipped(self, surface_deg: float) -> float:
        """The normalised command for one deflection ``surface_deg`` (deg), clipped to the
        range: the same map and the same bits as :meth:`elevator_command` (``numpy.interp``'s
        own formula), for a loop that computes its command one step at a time."""
        xs, ys = self._map_deg_list, self._map_cmd_list  # sorted by surface: its range at the ends
        s = min(max(surface_deg, xs[0]), xs[-1])
        if s == xs[-1]:
            return ys[-1]
        j = bisect.bisect_right(xs, s) - 1  # xs[j] <= s < xs[j + 1]
        slope = (ys[j + 1] - ys[j]) / (xs[j + 1] - xs[j])
        return slope * (s - xs[j]) + ys[j]

    def elevator_command(self, surface_deg: np.ndarray) -> np.ndarray:
        """Normalised commands that put the elevator exactly at ``surface_deg`` (deg)."""
        assert self._map_deg is not None, "trim first"
        surface_deg = np.asarray(surface_deg, dtype=np.float64)
        lo, hi = self.elevator_range_deg
        if surface_deg.size and (surface_deg.min() < lo or surface_deg.max() > hi):
            raise ValueError(
                f"elevator deflection {surface_deg.min():.6g}..{surface_deg.max():.6g} deg is "
                f"outside the model's range {lo:.6g}..{hi:.6g} deg"
            )
        return np.interp(surface_deg, self._map_deg, self._map_cmd)

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
        elevator_deg: np.ndarray | None = None,
    ) -> None:
        """Run ``out.shape[0]`` steps; ``out[k, j]`` is channel j read right after step k.

        Parameters
        ----------
        cmd_norm : numpy.ndarray or None
            Normalised elevator command for each step (written before the step), shape
            ``(n,)``.  None holds the command the plant has (after :meth:`trim`, the
            trimmed one) and writes nothing: the unprobed twin.
        nodes : list
            Property nodes of the channels, from :meth:`channel_nodes`.
        out : numpy.ndarray
            ``(n, len(nodes))`` float64, filled in place (channel units, see :data:`CHANNELS`).
        elevator_deg : numpy.ndarray, optional
            ``(n,)``, receives the realised elevator deflection after each step (deg).

        Notes
        -----
        The per-step work is the command write, ``run()`` and one read per channel; the
        reads are appended to one flat list and copied into ``out`` once, so no array is
        built per step.
        """
        n = out.shape[0]
        fault = self._fault
        if fault is not None and fault[1] < self._steps + n:  # the onset falls in these steps
            j = max(0, fault[1] - self._steps)
            cmds = (None, None) if cmd_norm is None else (cmd_norm[:j], cmd_norm[j:])
            els = (None, None) if elevator_deg is None else (elevator_deg[:j], elevator_deg[j:])
            self._fault = None
            if j:
                self.step(cmds[0], nodes, out[:j], els[0])
            self.damage(fault[0])
            self.step(cmds[1], nodes, out[j:], els[1])
            return
        self._steps += n
        getters = [node.get_double_value for node in nodes]
        if elevator_deg is not None:
            getters.append(self._pos_node.get_double_value)
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
            set_cmd = self._cmd_node.set_double_value
            for c in cmd_norm.tolist():
                set_cmd(c)
                run()
                for get in getters:
                    append(get())
        block = np.array(values, dtype=np.float64).reshape(n, len(getters))
        out[:] = block[:, : len(nodes)]
        if elevator_deg is not None:
            elevator_deg[:] = block[:, -1]

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

    def actuator_pulse_response(self, n_steps: int = 200, height_deg: float = 1e-3) -> np.ndarray:
        """The realised surface after each step for a one-step pulse of the asked deflection,
        per deg asked (1 at step 0 and 0 after for a surface without actuator dynamics; the
        GTM's 5 Hz servo spreads it over about 0.2 s).

        The pulse is small (``height_deg``) so a rate limit does not act.  The plant is
        stepped: use it for nothing else afterwards.
        """
        assert self.trim_result is not None, "trim first"
        surface = np.full(n_steps, self.trim_result.elevator_deg)
        surface[0] += height_deg
        out = np.empty((n_steps, 0))
        realised = np.empty(n_steps)
        self.step(self.elevator_command(surface), [], out, realised)
        return (realised - self.trim_result.elevator_deg) / height_deg

    def elevator_gain_deg_per_norm(self) -> float:
        """Local slope d(surface deg)/d(command norm) at the trimmed command."""
        assert self._map_deg is not None, "trim first"
        cmd0 = self.trim_result.elevator_cmd_norm
        order = np.argsort(self._map_cmd)  # the map is kept sorted by surface, not command
        cmd, deg = self._map_cmd[order], self._map_deg[order]
        i = int(np.clip(np.searchsorted(cmd, cmd0), 1, cmd.size - 1))
        return float((deg[i] - deg[i - 1]) / (cmd[i] - cmd[i - 1]))


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
    angles = {"gamma_deg": flight.gamma_deg, "bank_deg": flight.bank_deg}
    try:
        return plant.trim(flight.altitude_ft, **speed, **angles)
    except TrimError:
        if flight.trimmed_damage not in SYMMETRIC_DAMAGE or flight.bank_deg:
            raise
        return plant.trim(flight.altitude_ft, **speed, **angles, longitudinal=True)
