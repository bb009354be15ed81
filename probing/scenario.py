"""Scenario files: TOML in, a validated, frozen :class:`Scenario` out.

Every problem is reported as a :class:`ScenarioError` naming the field and
what is allowed, so the command line can print one line and exit 2.  See
``docs/scenarios.md`` for the format.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = [
    "CHANNEL_NAMES",
    "DRIFT_MODES",
    "NONLINEARITY_PARAMS",
    "Scenario",
    "ScenarioError",
    "load_scenario",
    "parse_scenario",
    "read_toml",
]

#: Nonlinearity type -> its parameters (deg, or deg/s for the rate).
NONLINEARITY_PARAMS: dict[str, tuple[str, ...]] = {
    "none": (),
    "deadband": ("lower_deg", "upper_deg"),
    "saturation": ("lower_deg", "upper_deg"),
    "relay": ("threshold_deg", "low_deg", "high_deg"),
    "hysteresis_relay": ("lower_threshold_deg", "upper_threshold_deg", "low_deg", "high_deg"),
    "backlash": ("width_deg",),
    "rate_limit": ("rate_deg_s",),
}
DRIFT_MODES = ("reference", "detrend", "none")
TURBULENCE_LEVELS = ("none", "light", "moderate", "severe")
CHANNEL_NAMES = (
    "theta_rad",
    "q_rad_s",
    "alpha_rad",
    "nz_g",
    "h_ft",
    "vt_fps",
    "gamma_rad",
    "u_fps",
    "w_fps",
)
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,127}$")
_SECTIONS = {
    "name": None,
    "aircraft": {"model"},
    "condition": {"altitude_ft", "speed_kcas", "speed_ktas", "mach"},
    "simulation": {"dt_s"},
    "probe": {"order", "bit_duration_s", "amplitude_deg", "periods", "settle_periods"},
    "nonlinearity": {"type"} | {p for ps in NONLINEARITY_PARAMS.values() for p in ps},
    "output": {"channels", "drift", "detrend_order"},
    "disturbance": {"turbulence", "sensor_noise", "seed"},
}
_REQUIRED = {
    "aircraft": ("model",),
    "condition": ("altitude_ft",),
    "simulation": ("dt_s",),
    "probe": ("order", "bit_duration_s", "amplitude_deg", "periods", "settle_periods"),
    "nonlinearity": ("type",),
    "output": ("channels",),
}


class ScenarioError(ValueError):
    """An invalid scenario: ``field`` names the offending entry."""

    def __init__(self, field: str, message: str, source: str | None = None) -> None:
        self.field = field
        self.message = message
        self.source = source
        where = f"{source}: " if source else ""
        super().__init__(f"{where}{field}: {message}")


@dataclass(frozen=True)
class Scenario:
    """A validated scenario (see ``docs/scenarios.md``); all values in the units of their names."""

    name: str
    model: str
    altitude_ft: float
    speed_kind: str  # "speed_kcas" | "speed_ktas" | "mach"
    speed: float
    dt_s: float
    order: int
    bit_duration_s: float
    amplitude_deg: float
    periods: int
    settle_periods: int
    nonlinearity: str
    nl_params: dict[str, float] = field(default_factory=dict)
    channels: tuple[str, ...] = ("theta_rad",)
    drift: str = "reference"
    detrend_order: int = 1
    turbulence: str = "none"
    sensor_noise: dict[str, float] = field(default_factory=dict)
    seed: int = 0
    text: str = ""  # the scenario as written (TOML), kept for provenance

    # -------------------------------------------------------------- derived
    @property
    def steps_per_bit(self) -> int:
        """Simulation steps per probe bit."""
        return round(self.bit_duration_s / self.dt_s)

    @property
    def bits_per_period(self) -> int:
        """M = 2**order - 1."""
        return 2**self.order - 1

    @property
    def total_steps(self) -> int:
        """Simulation steps of the whole run (one aircraft)."""
        return self.periods * self.bits_per_period * self.steps_per_bit

    def to_dict(self) -> dict[str, Any]:
        """The scenario in its file layout (sections and field names), without ``text``."""
        nl: dict[str, Any] = {"type": self.nonlinearity, **self.nl_params}
        disturbance: dict[str, Any] = {"turbulence": self.turbulence, "seed": self.seed}
        if self.sensor_noise:
            disturbance["sensor_noise"] = dict(self.sensor_noise)
        out: dict[str, Any] = {"channels": list(self.channels), "drift": self.drift}
        if self.drift == "detrend" or self.detrend_order != 1:
            out["detrend_order"] = self.detrend_order
        return {
            "name": self.name,
            "aircraft": {"model": self.model},
            "condition": {"altitude_ft": self.altitude_ft, self.speed_kind: self.speed},
            "simulation": {"dt_s": self.dt_s},
            "probe": {
                "order": self.order,
                "bit_duration_s": self.bit_duration_s,
                "amplitude_deg": self.amplitude_deg,
                "periods": self.periods,
                "settle_periods": self.settle_periods,
            },
            "nonlinearity": nl,
            "output": out,
            "disturbance": disturbance,
        }

    def to_json(self) -> str:
        """Canonical JSON of :meth:`to_dict` (sorted keys), used for hashing and metadata."""
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))

    def digest(self) -> str:
        """Content hash of the resolved scenario (hex, 16 characters)."""
        return hashlib.sha256(self.to_json().encode()).hexdigest()[:16]

    def replace(self, changes: Mapping[str, Any] | None = None, /, **kwargs: Any) -> Scenario:
        """A validated copy with dotted fields changed, e.g. ``{"nonlinearity.type": "none"}``.

        The changes are given as a mapping, as keyword arguments, or both.  A change of
        ``nonlinearity.type`` is applied first, so its parameters may be listed in any order.
        """
        merged = {**(changes or {}), **kwargs}
        data = copy.deepcopy(self.to_dict())
        for key in sorted(merged, key=lambda k: k != "nonlinearity.type"):
            set_dotted(data, key, merged[key])
        return parse_scenario(data)


def set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    """Set ``data["a"]["b"] = value`` for ``key = "a.b"``.

    A new nonlinearity type drops the old parameters; a new speed drops the other speeds.
    """
    parts = key.split(".")
    target = data
    for part in parts[:-1]:
        if not isinstance(target.get(part), dict):
            target[part] = {}
        target = target[part]
    if parts == ["nonlinearity", "type"] and target.get("type") != value:
        target.clear()
    if parts[:1] == ["condition"] and parts[-1] in ("speed_kcas", "speed_ktas", "mach"):
        for other in ("speed_kcas", "speed_ktas", "mach"):
            target.pop(other, None)
    target[parts[-1]] = value


# ------------------------------------------------------------------ checks
def _key(key: str) -> str:
    """A key as written into an error field: quoted if it could break the one-line message."""
    return key if key and key.isprintable() else repr(key)


def _number(
    data: dict, section: str, key: str, *, lo: float, hi: float, lo_open: bool = False
) -> float:
    name = f"{section}.{key}" if section else key
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(name, f"must be a number, got {value!r}")
    value = float(value)
    ok = math.isfinite(value) and (value > lo if lo_open else value >= lo) and value <= hi
    if not ok:
        bound = f"> {lo:g}" if lo_open else f">= {lo:g}"
        raise ScenarioError(name, f"must be {bound} and <= {hi:g}, got {value:g}")
    return value


def _integer(data: dict, section: str, key: str, *, lo: int, hi: int) -> int:
    name = f"{section}.{key}"
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, int):
        raise ScenarioError(name, f"must be an integer from {lo} to {hi}, got {value!r}")
    if not lo <= value <= hi:
        raise ScenarioError(name, f"must be an integer from {lo} to {hi}, got {value}")
    return value


def _choice(data: dict, section: str, key: str, allowed: tuple[str, ...]) -> str:
    value = data[key]
    if not isinstance(value, str) or value not in allowed:
        raise ScenarioError(
            f"{section}.{key}", f"must be one of {', '.join(allowed)}; got {value!r}"
        )
    return value


def _check_keys(data: dict[str, Any]) -> None:
    for key, value in data.items():
        if key not in _SECTIONS:
            raise ScenarioError(_key(key), f"unknown field; allowed: {', '.join(_SECTIONS)}")
        allowed = _SECTIONS[key]
        if allowed is None:
            continue
        if not isinstance(value, dict):
            raise ScenarioError(key, "must be a table (a [section])")
        for sub in value:
            if sub not in allowed:
                raise ScenarioError(
                    f"{key}.{_key(sub)}", f"unknown field; allowed: {', '.join(sorted(allowed))}"
                )
    if "name" not in data:
        raise ScenarioError("name", "missing (a plain file name, also the output folder name)")
    for section, keys in _REQUIRED.items():
        if section not in data:
            raise ScenarioError(section, "missing section")
        for key in keys:
            if key not in data[section]:
                raise ScenarioError(f"{section}.{key}", "missing")


def parse_scenario(data: dict[str, Any], *, text: str = "", source: str | None = None) -> Scenario:
    """Validate a scenario given as a dict (the TOML layout).

    Parameters
    ----------
    data : dict
        Parsed TOML.
    text : str
        The original file text, kept for provenance.
    source : str, optional
        File name, prefixed to error messages.

    Raises
    ------
    ScenarioError
        On the first invalid entry, naming it and what is allowed.
    """
    try:
        return _parse(data, text)
    except ScenarioError as exc:
        if source and exc.source is None:
            raise ScenarioError(exc.field, exc.message, source) from None
        raise


def _parse(data: dict[str, Any], text: str) -> Scenario:
    from probing.plant import AircraftNotFoundError, find_aircraft  # only looks up files

    _check_keys(data)
    name = data["name"]
    if not isinstance(name, str) or not _NAME_RE.match(name) or name in (".", ".."):
        raise ScenarioError(
            "name", f"must be a plain file name (letters, digits, '.', '_', '-'), got {name!r}"
        )
    model = data["aircraft"]["model"]
    if not isinstance(model, str):
        raise ScenarioError("aircraft.model", f"must be a string, got {model!r}")
    try:
        find_aircraft(model)
    except AircraftNotFoundError as exc:
        raise ScenarioError("aircraft.model", str(exc).replace("aircraft.model ", "")) from None

    cond = data["condition"]
    altitude = _number(cond, "condition", "altitude_ft", lo=0, hi=60000, lo_open=True)
    speeds = [k for k in ("speed_kcas", "speed_ktas", "mach") if k in cond]
    if len(speeds) != 1:
        raise ScenarioError("condition", "give exactly one of speed_kcas, speed_ktas, mach")
    kind = speeds[0]
    hi = 5.0 if kind == "mach" else 2000.0
    speed = _number(cond, "condition", kind, lo=0, hi=hi, lo_open=True)

    dt = _number(data["simulation"], "simulation", "dt_s", lo=0, hi=0.1, lo_open=True)

    probe = data["probe"]
    order = _integer(probe, "probe", "order", lo=2, hi=20)
    bit = _number(probe, "probe", "bit_duration_s", lo=0, hi=10, lo_open=True)
    ratio = bit / dt
    if round(ratio) < 1 or not math.isclose(ratio, round(ratio), rel_tol=1e-9, abs_tol=1e-9):
        raise ScenarioError(
            "probe.bit_duration_s",
            f"must be an integer multiple of simulation.dt_s ({dt:g}), got {bit:g}",
        )
    amplitude = _number(probe, "probe", "amplitude_deg", lo=0, hi=10, lo_open=True)
    periods = _integer(probe, "probe", "periods", lo=2, hi=100_000)
    settle = _integer(probe, "probe", "settle_periods", lo=0, hi=periods - 1)

    nl_data = data["nonlinearity"]
    nl_type = _choice(nl_data, "nonlinearity", "type", tuple(NONLINEARITY_PARAMS))
    expected = NONLINEARITY_PARAMS[nl_type]
    for key in nl_data:
        if key != "type" and key not in expected:
            allowed = ", ".join(expected) if expected else "no parameters"
            raise ScenarioError(
                f"nonlinearity.{key}", f"not a parameter of {nl_type} (takes {allowed})"
            )
    params: dict[str, float] = {}
    for key in expected:
        if key not in nl_data:
            raise ScenarioError(f"nonlinearity.{key}", f"missing (required for {nl_type})")
        if key == "rate_deg_s":
            params[key] = _number(nl_data, "nonlinearity", key, lo=0, hi=1e6, lo_open=True)
        elif key == "width_deg":
            params[key] = _number(nl_data, "nonlinearity", key, lo=0, hi=90)
        else:
            params[key] = _number(nl_data, "nonlinearity", key, lo=-90, hi=90)
    _check_nl_order(nl_type, params)

    out = data["output"]
    channels = out["channels"]
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
    drift = _choice(out, "output", "drift", DRIFT_MODES) if "drift" in out else "reference"
    detrend_order = (
        _integer(out, "output", "detrend_order", lo=0, hi=3) if "detrend_order" in out else 1
    )

    dist = data.get("disturbance", {})
    turbulence = (
        _choice(dist, "disturbance", "turbulence", TURBULENCE_LEVELS)
        if "turbulence" in dist
        else "none"
    )
    seed = _integer(dist, "disturbance", "seed", lo=0, hi=2**31 - 1) if "seed" in dist else 0
    noise_in = dist.get("sensor_noise", {})
    if not isinstance(noise_in, dict):
        raise ScenarioError("disturbance.sensor_noise", "must be a table {channel = sigma}")
    noise: dict[str, float] = {}
    for ch in noise_in:
        if ch not in channels:
            raise ScenarioError(
                f"disturbance.sensor_noise.{_key(ch)}",
                f"not an output channel (channels: {', '.join(channels)})",
            )
        noise[ch] = _number(noise_in, "disturbance.sensor_noise", ch, lo=0, hi=1e6)

    return Scenario(
        name=name,
        model=model,
        altitude_ft=altitude,
        speed_kind=kind,
        speed=speed,
        dt_s=dt,
        order=order,
        bit_duration_s=bit,
        amplitude_deg=amplitude,
        periods=periods,
        settle_periods=settle,
        nonlinearity=nl_type,
        nl_params=params,
        channels=tuple(channels),
        drift=drift,
        detrend_order=detrend_order,
        turbulence=turbulence,
        sensor_noise=noise,
        seed=seed,
        text=text,
    )


def _check_nl_order(nl_type: str, p: dict[str, float]) -> None:
    if nl_type in ("deadband", "saturation") and p["lower_deg"] > p["upper_deg"]:
        raise ScenarioError(
            "nonlinearity.lower_deg",
            f"must be <= upper_deg ({p['upper_deg']:g}), got {p['lower_deg']:g}",
        )
    if nl_type == "deadband" and not (p["lower_deg"] <= 0 <= p["upper_deg"]):
        edge = "lower_deg" if p["lower_deg"] > 0 else "upper_deg"
        raise ScenarioError(
            f"nonlinearity.{edge}", "deadband needs lower_deg <= 0 <= upper_deg (relative to trim)"
        )
    if nl_type == "hysteresis_relay" and p["lower_threshold_deg"] > p["upper_threshold_deg"]:
        raise ScenarioError(
            "nonlinearity.lower_threshold_deg",
            f"must be <= upper_threshold_deg ({p['upper_threshold_deg']:g}), "
            f"got {p['lower_threshold_deg']:g}",
        )


def read_toml(path: Path) -> tuple[dict[str, Any], str]:
    """A TOML file's table and text.

    Raises
    ------
    ScenarioError
        Field ``file`` when it cannot be read, ``toml`` when it is not valid TOML.
    """
    source = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError("file", "does not exist", source) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError("file", f"cannot be read ({exc.__class__.__name__})", source) from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError("toml", f"invalid TOML ({exc})", source) from None


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file.

    Raises
    ------
    ScenarioError
        With the file name, the field and what is allowed.
    """
    path = Path(path)
    data, text = read_toml(path)
    source = str(path)
    return parse_scenario(data, text=text, source=source)
