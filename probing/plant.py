"""The JSBSim plant: the only module of the project that imports jsbsim.

A :class:`Plant` loads an aircraft from a *sanitised* copy (every top-level
``<input>`` and ``<output>`` directive removed, so no model opens a network
socket or writes a log file of its own), trims it straight and level, and
steps it with an elevator surface deflection given in degrees.  The
command-to-surface mapping of the model's flight-control system is measured
on the model itself (integration suspended) and inverted, so the surface
deflection is exactly the one asked for, whatever the model's scaling.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import shutil
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

os.environ.setdefault("JSBSIM_DEBUG", "0")  # no banner on stdout
import jsbsim
import numpy as np

if TYPE_CHECKING:
    from probing.scenario import Scenario

__all__ = [
    "CHANNELS",
    "TURBULENCE_SEVERITY",
    "AircraftNotFoundError",
    "DivergenceError",
    "Plant",
    "TrimError",
    "TrimResult",
    "aircraft_digest",
    "cache_dir",
    "find_aircraft",
    "jsbsim_version",
    "make_plant",
]

#: Output channels: name (with unit) -> JSBSim property.
CHANNELS: dict[str, str] = {
    "theta_rad": "attitude/theta-rad",
    "q_rad_s": "velocities/q-rad_sec",
    "alpha_rad": "aero/alpha-rad",
    "nz_g": "accelerations/Nz",
    "h_ft": "position/h-sl-ft",
    "vt_fps": "velocities/vt-fps",
    "gamma_rad": "flight-path/gamma-rad",
    "u_fps": "velocities/u-fps",
    "w_fps": "velocities/w-fps",
}

#: Turbulence level -> JSBSim MIL-F-8785C/MIL-HDBK-1797 probability-of-exceedance severity
#: (``atmosphere/turbulence/milspec/severity``; 3 = moderate, 5 = severe in JSBSim's table).
TURBULENCE_SEVERITY: dict[str, int] = {"none": 0, "light": 2, "moderate": 4, "severe": 6}

PROJECT_AIRCRAFT = Path(__file__).resolve().parent.parent / "aircraft"
ELEVATOR_CMD = "fcs/elevator-cmd-norm"
ELEVATOR_POS_DEG = "fcs/elevator-pos-deg"


class AircraftNotFoundError(ValueError):
    """The aircraft is neither in the project's ``aircraft/`` nor among JSBSim's."""


class TrimError(RuntimeError):
    """JSBSim could not trim the aircraft at the requested condition."""


class DivergenceError(RuntimeError):
    """The simulation left the region where its results mean anything."""


def jsbsim_version() -> str:
    """The version of the JSBSim Python package in use."""
    return str(jsbsim.__version__)


def _stock_root() -> Path:
    return Path(jsbsim.get_default_root_dir())


def find_aircraft(model: str) -> Path:
    """Folder of an aircraft: the project's ``aircraft/`` first, then JSBSim's stock models.

    Parameters
    ----------
    model : str
        Aircraft name, a plain folder name (e.g. ``"737"``).

    Returns
    -------
    pathlib.Path
        The folder holding ``<model>.xml``.
    """
    if not model or Path(model).name != model or model.startswith("."):
        raise AircraftNotFoundError(f"aircraft.model must be a plain name, got {model!r}")
    for base in (PROJECT_AIRCRAFT, _stock_root() / "aircraft"):
        folder = base / model
        if (folder / f"{model}.xml").is_file():
            return folder
    raise AircraftNotFoundError(
        f"aircraft.model {model!r} is not in {PROJECT_AIRCRAFT} nor in JSBSim's aircraft"
    )


def cache_dir() -> Path:
    """The project's cache root: ``$PROBING_CACHE``, else ``$XDG_CACHE_HOME/probing``.

    ``$XDG_CACHE_HOME`` defaults to ``~/.cache``.  Sanitised aircraft live in
    ``<root>/jsbsim-root``, reference twins (:mod:`probing.twins`) in ``<root>/twins``.
    """
    env = os.environ.get("PROBING_CACHE")
    if env:
        return Path(env)
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "probing"


def _sanitise(xml_path: Path, out_path: Path) -> None:
    """Copy an aircraft XML without its top-level <input>/<output> directives."""
    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    tree = ET.parse(xml_path, parser=parser)
    root = tree.getroot()
    for element in list(root):
        if element.tag in ("input", "output"):
            root.remove(element)
    tree.write(out_path, encoding="utf-8", xml_declaration=True)


#: aircraft folder -> (names, sizes and modification times of its files, their digest)
_DIGESTS: dict[Path, tuple[tuple, str]] = {}


def aircraft_digest(model: str) -> str:
    """SHA-256 (hex) over the relative names and contents of every file of the aircraft folder.

    The folder is the one :func:`find_aircraft` picks, i.e. the files the plant loads
    (before sanitising).  Engines and systems taken from JSBSim's own folders are covered
    by the JSBSim version, not by this digest.  The digest is remembered for the process
    while no file's name, size or modification time changes.
    """
    folder = find_aircraft(model)
    files = sorted(p for p in folder.rglob("*") if p.is_file())
    stamp = tuple((str(p.relative_to(folder)), *_size_mtime(p)) for p in files)
    known = _DIGESTS.get(folder)
    if known is not None and known[0] == stamp:
        return known[1]
    digest = hashlib.sha256()
    for path in files:
        digest.update(str(path.relative_to(folder)).encode())
        digest.update(path.read_bytes())
    _DIGESTS[folder] = (stamp, digest.hexdigest())
    return digest.hexdigest()


def _size_mtime(path: Path) -> tuple[int, int]:
    st = path.stat()
    return st.st_size, st.st_mtime_ns


def sanitised_root(model: str) -> Path:
    """A JSBSim root folder holding a sanitised copy of the aircraft (cached, made atomically)."""
    folder = find_aircraft(model)
    root = cache_dir() / "jsbsim-root" / f"{model}-{aircraft_digest(model)[:16]}"
    if (root / "aircraft" / model / f"{model}.xml").is_file():
        return root
    root.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{model}-", dir=root.parent))
    try:
        target = tmp / "aircraft" / model
        shutil.copytree(folder, target)
        for xml in target.rglob("*.xml"):
            _sanitise(xml, xml)
        os.replace(tmp, root)
    except OSError:
        shutil.rmtree(tmp, ignore_errors=True)
        if not (root / "aircraft" / model / f"{model}.xml").is_file():
            raise
    return root


@dataclass(frozen=True)
class TrimResult:
    """The trimmed straight-and-level state (angles in deg)."""

    altitude_ft: float
    speed_kcas: float
    speed_ktas: float
    mach: float
    alpha_deg: float
    theta_deg: float
    elevator_deg: float
    elevator_cmd_norm: float
    pitch_trim_cmd_norm: float
    throttle_norm: float

    def to_dict(self) -> dict[str, float]:
        """Plain dict, for metadata."""
        return asdict(self)


@functools.lru_cache(maxsize=32)
def _alpha_range_rad(xml_path: Path) -> tuple[float, float]:
    """Alpha range covered by every aerodynamic table indexed by alpha (rad).

    Memoised: the sanitised copy lives in a folder named after the aircraft's digest, so a
    path always holds the same content.
    """
    lo, hi = -math.inf, math.inf
    root = ET.parse(xml_path).getroot()
    aero = root.find("aerodynamics")
    if aero is None:
        return (-math.radians(30), math.radians(30))
    for table in aero.iter("table"):
        variables = table.findall("independentVar")
        row = [v for v in variables if v.get("lookup", "row") == "row"]
        if not row or row[0].text is None:
            continue
        name = row[0].text.strip()
        if name not in ("aero/alpha-rad", "aero/alpha-deg"):
            continue
        data = table.find("tableData")
        if data is None or data.text is None:
            continue
        lines = [ln.split() for ln in data.text.strip().splitlines() if ln.strip()]
        if len(variables) > 1:
            lines = lines[1:]  # first line holds the column breakpoints
        keys = [float(ln[0]) for ln in lines if ln]
        if not keys:
            continue
        scale = math.pi / 180 if name.endswith("deg") else 1.0
        lo, hi = max(lo, min(keys) * scale), min(hi, max(keys) * scale)
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo >= hi:
        return (-math.radians(30), math.radians(30))
    return (lo, hi)


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
        root = sanitised_root(model)
        stock = _stock_root()
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
        self._alpha_range = _alpha_range_rad(root / "aircraft" / model / f"{model}.xml")
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
        mach: float | None = None,
    ) -> TrimResult:
        """Trim straight and level, gear up, engines running.

        Exactly one of ``speed_kcas``, ``speed_ktas``, ``mach`` is given.
        Raises :class:`TrimError` naming the condition when JSBSim fails.
        """
        speeds = {"speed_kcas": speed_kcas, "speed_ktas": speed_ktas, "mach": mach}
        given = {k: v for k, v in speeds.items() if v is not None}
        if len(given) != 1:
            raise ValueError("exactly one of speed_kcas, speed_ktas, mach must be given")
        fdm = self.fdm
        fdm["ic/h-sl-ft"] = altitude_ft
        if speed_kcas is not None:
            fdm["ic/vc-kts"] = speed_kcas
        elif speed_ktas is not None:
            fdm["ic/vt-kts"] = speed_ktas
        else:
            fdm["ic/mach"] = mach
        fdm["ic/gamma-deg"] = 0.0
        fdm["ic/beta-deg"] = 0.0
        fdm["ic/phi-deg"] = 0.0
        fdm["gear/gear-cmd-norm"] = 0.0
        fdm["propulsion/set-running"] = -1
        condition = ", ".join(f"{k} = {v:g}" for k, v in given.items())
        where = f"{self.model} at altitude_ft = {altitude_ft:g}, {condition}"
        try:
            if not fdm.run_ic():
                raise TrimError(f"could not initialise {where}")
            fdm.do_trim(1)
        except jsbsim.TrimFailureError as exc:
            raise TrimError(f"trim failed for {where}: {exc}") from None
        except RuntimeError as exc:  # jsbsim raises BaseError subclasses of RuntimeError
            raise TrimError(f"trim failed for {where}: {exc}") from None
        fdm.set_dt(self.dt_s)
        if fdm["gear/gear-pos-norm"] > 0.0:
            raise TrimError(f"gear still down after trim for {where}")
        self.trim_result = TrimResult(
            altitude_ft=float(fdm["position/h-sl-ft"]),
            speed_kcas=float(fdm["velocities/vc-kts"]),
            speed_ktas=float(fdm["velocities/vtrue-kts"]),
            mach=float(fdm["velocities/mach"]),
            alpha_deg=float(fdm["aero/alpha-deg"]),
            theta_deg=float(fdm["attitude/theta-deg"]),
            elevator_deg=float(fdm[ELEVATOR_POS_DEG]),
            elevator_cmd_norm=float(fdm[ELEVATOR_CMD]),
            pitch_trim_cmd_norm=float(fdm["fcs/pitch-trim-cmd-norm"]),
            throttle_norm=float(fdm["fcs/throttle-cmd-norm[0]"]),
        )
        self._calibrate_elevator()
        if self.turbulence != "none":
            fdm["atmosphere/turb-type"] = 3  # ttMilspec: MIL-F-8785C / MIL-HDBK-1797 Dryden
            fdm["atmosphere/turbulence/milspec/severity"] = TURBULENCE_SEVERITY[self.turbulence]
            fdm["atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps"] = 15.0
        return self.trim_result

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

    @property
    def elevator_range_deg(self) -> tuple[float, float]:
        """Surface deflections reachable through the command (deg)."""
        assert self._map_deg is not None, "trim first"
        return float(self._map_deg[0]), float(self._map_deg[-1])

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
        return [self._pm.get_node(CHANNELS[c]) for c in channels]

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

    def elevator_gain_deg_per_norm(self) -> float:
        """Local slope d(surface deg)/d(command norm) at the trimmed command."""
        assert self._map_deg is not None, "trim first"
        cmd0 = self.trim_result.elevator_cmd_norm
        order = np.argsort(self._map_cmd)  # the map is kept sorted by surface, not command
        cmd, deg = self._map_cmd[order], self._map_deg[order]
        i = int(np.clip(np.searchsorted(cmd, cmd0), 1, cmd.size - 1))
        return float((deg[i] - deg[i - 1]) / (cmd[i] - cmd[i - 1]))


def make_plant(scn: Scenario) -> Plant:
    """A plant for a scenario (model, dt, turbulence, seed), trimmed at its condition."""
    plant = Plant(scn.model, scn.dt_s, turbulence=scn.turbulence, seed=scn.seed)
    plant.trim(scn.altitude_ft, **{scn.speed_kind: scn.speed})
    return plant
