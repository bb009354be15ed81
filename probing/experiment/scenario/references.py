"""The references a flight computer subtracts before it estimates (``output.drift``): one
table, from which the scenario's checks, the live flight's and the replay's admissions, and
the log's columns follow.  Loads no simulator; the sources that compute a reference from the
log are :data:`probing.experiment.flight.onboard.SOURCES` (docs/architecture.md, "How to add a
reference").
"""

from __future__ import annotations

from dataclasses import dataclass

from probing.core.gust import GUST_SENSORS
from probing.sim.autopilot import COMMAND_COLUMNS

__all__ = [
    "DRIFT_MODES",
    "REFERENCES",
    "REFERENCE_FIELDS",
    "REFERENCE_KINDS",
    "Reference",
    "realisable_drifts",
]

#: What a reference is: ``twin`` (a precomputed twin's outputs, step by step), ``log`` (computed
#: from the flight computer's log as it comes, by a source of
#: :data:`probing.experiment.flight.onboard.SOURCES`), ``trend`` (no model: the trim's measurement
#: and a trend fitted with the periodic part) and ``baseline`` (no model: the trim's
#: measurement).
REFERENCE_KINDS = ("twin", "log", "trend", "baseline")


@dataclass(frozen=True)
class Reference:
    """One value of ``output.drift``.

    Attributes
    ----------
    name : str
        Its value in ``output.drift``.
    kind : str
        One of :data:`REFERENCE_KINDS`.
    knows_gusts : bool
        True if it flies the same turbulence realisation as the aircraft: a simulation-only
        upper bound (the ``oracle``), which no flight computer can compute, so neither a live
        flight nor a log recorded elsewhere can use it.
    log_columns : tuple of str
        The columns of the log it reads besides ``time_s`` and the scenario's channels.
    description : str
        One line, for messages and docs.
    flies : str
        The trimmed nominal aircraft a ``log`` reference flies, if any: ``"plain"`` (the
        model as loaded) or ``"gust_ready"`` (the copy with gust inputs,
        :func:`probing.sim.aircraft.sanitised_root`); a run with a trimmed aircraft to spare
        forks it instead of loading and trimming one (:class:`probing.sim.fork.TrimmedAircraft`).
    """

    name: str
    kind: str
    knows_gusts: bool = False
    log_columns: tuple[str, ...] = ()
    description: str = ""
    flies: str = ""

    def __post_init__(self) -> None:
        if self.kind not in REFERENCE_KINDS:
            raise ValueError(f"reference kind must be one of {REFERENCE_KINDS}, got {self.kind}")
        if self.flies not in ("", "plain", "gust_ready"):
            raise ValueError(f"flies must be '', 'plain' or 'gust_ready', got {self.flies!r}")

    @property
    def realisable(self) -> bool:
        """True if a flight computer can compute it from what the aircraft measures."""
        return not self.knows_gusts


#: ``output.drift`` -> the reference (``docs/scenarios.md``, ``docs/monitoring.md``).
REFERENCES: dict[str, Reference] = {
    r.name: r
    for r in (
        Reference(
            "reference",
            "twin",
            knows_gusts=True,
            description="the same aircraft through the same turbulence, unprobed (simulation only)",
        ),
        Reference(
            "follow",
            "log",
            log_columns=COMMAND_COLUMNS,
            description="the nominal aircraft in calm air flying the autopilot's recorded commands",
            flies="plain",
        ),
        Reference("detrend", "trend", description="no model: the trim and a fitted trend"),
        Reference("none", "baseline", description="no model: the trim's measurement"),
        Reference(
            "oracle",
            "twin",
            knows_gusts=True,
            description="the nominal aircraft through the same turbulence (simulation only)",
        ),
        Reference(
            "nominal",
            "twin",
            description="the nominal aircraft in calm air, flying its own autopilot",
        ),
        Reference(
            "gust",
            "log",
            log_columns=(*GUST_SENSORS, "p_rad_s", "phi_rad", "h_ft"),
            description="the nominal aircraft in calm air flown through the gust the sensors show",
            flies="gust_ready",
        ),
    )
}

#: The fields of ``[output]`` that choose the reference and set it: the flight computer's
#: estimates read them, the flight does not, so scenarios that differ only in them fly the same
#: flight (:func:`probing.experiment.flight.run.flight_key`).
REFERENCE_FIELDS = ("drift", "detrend_order")

#: ``output.drift``'s values, in the table's order.
DRIFT_MODES = tuple(REFERENCES)


def realisable_drifts() -> tuple[str, ...]:
    """The references a flight computer can compute, read from :data:`REFERENCES` now (so a
    reference added to the table is offered at once)."""
    return tuple(n for n, r in REFERENCES.items() if r.realisable)
