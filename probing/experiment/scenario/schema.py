"""The scenario file's schema and the checks of one value: which sections and fields there
are (:data:`SECTIONS`), :class:`ScenarioError`, and the number, integer, choice and time
checks every section's parser uses (:mod:`probing.experiment.scenario.sections`)."""

from __future__ import annotations

import dataclasses
from typing import Any

from probing.core.errors import ProbingError
from probing.core.errors import integer as checked_integer
from probing.core.errors import number as checked_number
from probing.core.faults import FAULTS
from probing.core.monitor import MonitorSettings
from probing.core.nonlinearities import NONLINEARITIES
from probing.core.sensors import SensorSpec
from probing.sim.channels import CHANNEL_NAMES
from probing.sim.flight import (
    SPEED_KINDS,
    Control,
)

#: Most periods a scenario may ask for.
MAX_PERIODS = 100_000
#: Section -> its fields (None: a top-level value).
SECTIONS: dict[str, set[str] | None] = {
    "name": None,
    "aircraft": {"model"},
    "condition": {"altitude_ft", *SPEED_KINDS, "gamma_deg", "bank_deg"},
    "simulation": {"dt_s"},
    "probe": {
        "surface",
        "order",
        "bit_duration_s",
        "amplitude_deg",
        "amplitude_norm",
        "periods",
        "settle_periods",
        "signal",
        "band_hz",
        "sweep",
    },
    "nonlinearity": {"type"} | {n for t in NONLINEARITIES.values() for n in t.names},
    "output": {"channels", "drift", "detrend_order", "estimator"},
    "disturbance": {"turbulence", "sensor_noise", "seed"},
    "fault": {"type", "onset_s"}
    | {n for t in FAULTS.values() for n in t.names}
    | {n for t in NONLINEARITIES.values() for n in t.names},
    "control": {f.name for f in dataclasses.fields(Control)},
    "monitor": {f.name for f in dataclasses.fields(MonitorSettings)},
    "simultaneous": {"design", "also_surfaces", "also_amplitudes", "max_crosstalk"},
    "manoeuvre": {"hold", "start_s", "change_deg", "rate_deg_s", "change_kt", "rate_kt_s"},
    # a suite, and per channel a table of SensorSpec fields (checked by the section's parser)
    "sensors": {"suite", *CHANNEL_NAMES},
}
#: Fields of a ``[sensors.<channel>]`` table: :class:`probing.core.sensors.SensorSpec`'s.
SENSOR_FIELDS = tuple(f.name for f in dataclasses.fields(SensorSpec))
#: Sections whose keys their own parser checks (the message then names what is allowed there:
#: a fault's by its type, :meth:`probing.core.faults.FaultType.not_a_field`).
_OWN_KEYS = {"sensors", "fault"}
#: Fault types of the ``[fault]`` section, from the registry :data:`probing.core.faults.FAULTS`.
FAULT_TYPES = tuple(FAULTS)
_REQUIRED = {
    "aircraft": ("model",),
    "condition": ("altitude_ft",),
    "simulation": ("dt_s",),
    "probe": ("order", "bit_duration_s", "periods", "settle_periods"),  # and the amplitude
    "nonlinearity": ("type",),
    "output": ("channels",),
}


class ScenarioError(ProbingError, ValueError):
    """An invalid scenario: ``field`` names the offending entry."""

    def __init__(self, field: str, message: str, source: str | None = None) -> None:
        self.field = field
        self.message = message
        self.source = source
        where = f"{source}: " if source else ""
        super().__init__(f"{where}{field}: {message}")


#: Largest cross-talk a simultaneous design may be predicted to leave, as a fraction of the
#: largest response in the channel (``simultaneous.max_crosstalk``'s default).
DEFAULT_MAX_CROSSTALK = 0.02


# ------------------------------------------------------------------ checks
def field_label(key: str) -> str:
    """A key as written into an error field: quoted if it could break the one-line message."""
    return key if key and key.isprintable() else repr(key)


def number(
    data: dict, section: str, key: str, *, lo: float, hi: float, lo_open: bool = False
) -> float:
    """``data[key]`` as a float in the range (:func:`probing.core.errors.number`: a Python or
    numpy int or float); ScenarioError naming ``section.key``."""
    name = f"{section}.{key}" if section else key
    return checked_number(data[key], name, lo=lo, hi=hi, lo_open=lo_open, error=ScenarioError)


def instant_in_run(data: dict, section: str, key: str, duration_s: float) -> float:
    """A time after trim (s) at which something starts: from 0 up to, not at, the run's end
    (a fault or a manoeuvre starting as the run ends would never act)."""
    value = number(data, section, key, lo=0, hi=duration_s)
    if value >= duration_s:
        raise ScenarioError(f"{section}.{key}", f"must be before the run ends ({duration_s:g} s)")
    return value


def integer(data: dict, section: str, key: str, *, lo: int, hi: int) -> int:
    """``data[key]`` as an int from ``lo`` to ``hi`` (:func:`probing.core.errors.integer`:
    a Python or numpy integer, not a bool or a float); ScenarioError naming ``section.key``."""
    return checked_integer(data[key], f"{section}.{key}", lo=lo, hi=hi, error=ScenarioError)


def choice(data: dict, section: str, key: str, allowed: tuple[str, ...]) -> str:
    value = data[key]
    if not isinstance(value, str) or value not in allowed:
        raise ScenarioError(
            f"{section}.{key}", f"must be one of {', '.join(allowed)}; got {value!r}"
        )
    return value


def check_keys(data: dict[str, Any]) -> None:
    for key, value in data.items():
        if key not in SECTIONS:
            raise ScenarioError(field_label(key), f"unknown field; allowed: {', '.join(SECTIONS)}")
        allowed = SECTIONS[key]
        if allowed is None:
            continue
        if not isinstance(value, dict):
            raise ScenarioError(key, "must be a table (a [section])")
        if key in _OWN_KEYS:
            continue
        for sub in value:
            if sub not in allowed:
                raise ScenarioError(
                    f"{key}.{field_label(sub)}",
                    f"unknown field; allowed: {', '.join(sorted(allowed))}",
                )
    if "name" not in data:
        raise ScenarioError("name", "missing (a plain file name, also the output folder name)")
    for section, keys in _REQUIRED.items():
        if section not in data:
            raise ScenarioError(section, "missing section")
        for key in keys:
            if key not in data[section]:
                raise ScenarioError(f"{section}.{key}", "missing")
