"""What the flight computer computes from what it recorded: the reference, the deviations,
the per-period estimates.

A flight records, step by step, what its flight computer had: the probe it injected, the
autopilot's commands and every sensor's measurement (``sensors.parquet``, the layout
:func:`probing.experiment.output.layouts.sensors_schema`).  :class:`Onboard` turns that stream,
chunk by chunk, into the per-period pulse-response estimates; a live flight
in this process (:func:`probing.experiment.flight.run.run_scenario`), a live one
(:func:`probing.experiment.flight.live.live_monitor`) and a replay of its log
(:func:`probing.experiment.flight.monitor.replay_monitor`) feed it the same columns through the
same :class:`~probing.experiment.flight.flight_computer.FlightComputer`, so they are one code path.

The reference it subtracts is ``output.drift``'s (``docs/monitoring.md``):

* ``oracle`` and ``reference``: the nominal aircraft through the *same* turbulence
  realisation (a twin that knows the gusts: a simulation-only upper bound);
* ``nominal``: the nominal aircraft in calm air, flying its own autopilot;
* ``gust``: the nominal aircraft in calm air flown through the gust estimated from the
  sensors (:class:`GustSource`);
* ``follow``: the nominal aircraft in calm air flying the recorded commands
  (:class:`FollowSource`);
* ``detrend`` and ``none``: no model; the trim's measurement is the baseline.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from probing.core.gust import GUST_SENSORS, GustEstimator
from probing.core.isolation import (
    KINEMATIC_CHANNELS,
    PitchKinematics,
    Servo,
    actuator_deviation,
)
from probing.core.trajectory import trajectory_features
from probing.experiment.flight.drift import drift_correction
from probing.experiment.output.layouts import AUTOPILOT_COLUMNS
from probing.experiment.scenario import Scenario
from probing.experiment.scenario.references import REFERENCES
from probing.sim.aircraft import aircraft_name
from probing.sim.control import ClosedLoop, control_power
from probing.sim.errors import DivergenceError
from probing.sim.flight import Control, Flight
from probing.sim.gust_twin import GustTwin
from probing.sim.plant import Plant, make_plant
from probing.sim.surfaces import SERVOS
from probing.sim.twins import ReferenceTwin, open_twin

__all__ = [
    "Estimated",
    "FollowSource",
    "GustSource",
    "Onboard",
    "ReferenceLost",
    "ReferenceSource",
    "TwinSource",
    "calm_nominal",
    "isolation_columns",
    "log_columns",
    "open_reference_twin",
    "reference_source",
    "twin_flight",
]


#: The gust twin flies the estimated wind minus its low-pass of this time constant, s: the
#: steady part holds the sensors' biases (NASA's pitch attitude is off by -0.09 deg, a
#: 0.2 ft/s vertical wind at 75 KCAS), which would fly the twin away over minutes.  Long,
#: because what the low-pass takes is a gust the twin does not fly: at 30 s the gust
#: reference's per-period scatter in moderate turbulence was 2.4 times what it is at 300 s
#: (three seeds, 100 periods each; docs/monitoring.md), and the twin's altitude follows the
#: measured one besides (:data:`ALTITUDE_FOLLOW_S`).
STEADY_WIND_TIME_S = 300.0

#: The gust twin's altitude follows the measured one with this time constant, s: a vertical
#: wind of (twin's altitude - measured, the last period's mean) / it is added to the
#: estimate, updated once a probe period (constant within one, where the estimator takes out
#: constants).  Without it the
#: twin, flying the high-passed gust, keeps its trim altitude while the aircraft drifts with
#: the slow vertical gusts (400 ft in 20 minutes of light turbulence at 800 ft), and below
#: 1000 ft the turbulence, and the response to it, change with height.
ALTITUDE_FOLLOW_S = 50.0


class ReferenceLost(DivergenceError):
    """A reference that diverged within a chunk, with what it flew of the chunk before.

    Parameters
    ----------
    message : str
        Why it diverged.
    flown : numpy.ndarray
        ``(rows, channels)``: its outputs for the chunk's whole periods before the one it
        diverged in (none: ``(0, channels)``).
    """

    def __init__(self, message: str, flown: np.ndarray) -> None:
        super().__init__(message)
        self.flown = flown


class ReferenceSource(Protocol):
    """What gives the reference's outputs for a chunk of the recorded stream."""

    def next(self, log: Mapping[str, np.ndarray]) -> np.ndarray:
        """The reference's outputs ``(rows, channels)`` for the chunk's rows; raises
        :class:`ReferenceLost` if it diverges, with the whole periods it flew before."""


class TwinSource:
    """A precomputed twin (:class:`probing.sim.twins.ReferenceTwin`): its next rows."""

    def __init__(self, twin: ReferenceTwin) -> None:
        self.twin = twin

    def next(self, log: Mapping[str, np.ndarray]) -> np.ndarray:
        return self.twin.next(len(log["time_s"]))


class GustSource:
    """``drift = "gust"``: the nominal aircraft in calm air, flown through the gust the
    sensors show (:class:`probing.core.gust.GustEstimator`, :class:`GustTwin`).

    Each step of the twin gets the wind and rotational gusts estimated from the
    measurement after the aircraft's same step (the twin runs one frame behind the
    aircraft), and the aircraft's roll rate measured after the step before.
    """

    def __init__(self, scn: Scenario, plant: Plant | None = None) -> None:
        flight = calm_nominal(scn.flight)
        power = control_power(flight)
        self.channels = len(scn.channels)
        self.twin = GustTwin(flight, scn.control, power, [*scn.channels, "h_ft"], plant)
        self.estimator = GustEstimator(self.twin.span_ft, scn.dt_s, STEADY_WIND_TIME_S)
        self.period_steps = scn.period_steps
        self.follow = 1.0 / ALTITUDE_FOLLOW_S  # 1/s
        self.down = 0.0  # the vertical wind that keeps the twin at the measured altitude
        self.last: np.ndarray | None = None  # the last measured roll rate and bank angle

    def next(self, log: Mapping[str, np.ndarray]) -> np.ndarray:
        measured = {c: log[c] for c in GUST_SENSORS}
        wind, rates = self.estimator.update(measured)
        roll = np.column_stack([log["p_rad_s"], log["phi_rad"]]).astype(float)
        first = roll[:1] if self.last is None else self.last
        before = np.vstack([first, roll[:-1]])  # each step sees the measurement before it
        self.last = roll[-1:]
        height = np.asarray(log["h_ft"], dtype=float)
        out = []
        for start in range(0, len(height), self.period_steps):  # a period at a time
            span = slice(start, start + self.period_steps)
            flown = wind[span].copy()
            flown[:, 2] += self.down
            try:
                y = self.twin.next(flown, rates[span], before[span, 0], before[span, 1])
            except DivergenceError as exc:
                kept = np.vstack(out) if out else np.empty((0, self.channels))
                raise ReferenceLost(str(exc), kept) from None
            # the period's mean difference: the baro altimeter's noise averages out
            self.down = self.follow * float(np.mean(y[:, -1] - height[span]))
            out.append(y[:, : self.channels])
        return np.vstack(out)


def calm_nominal(flight: Flight) -> Flight:
    """The flight a realisable reference model flies: the nominal aircraft in calm air
    (seed 0: in calm air the seed changes nothing, so every seed shares one twin)."""
    return dataclasses.replace(flight.nominal, turbulence="none", seed=0)


class FollowSource:
    """``drift = "follow"``: the nominal aircraft in calm air flying the autopilot's commands
    as the flight computer recorded them (the log's :data:`AUTOPILOT_COLUMNS`), a period at
    a time, its state checked after each.

    Parameters
    ----------
    scn : Scenario
        The flight's scenario.
    plant : Plant, optional
        The nominal aircraft trimmed in calm air (:func:`calm_nominal`) to fly (default: one
        loaded and trimmed here); it is stepped.
    """

    def __init__(self, scn: Scenario, plant: Plant | None = None) -> None:
        plant = plant if plant is not None else make_plant(calm_nominal(scn.flight))
        self.plant = plant
        self.loop = ClosedLoop(plant, Control())  # healthy, its loops open: it replays
        self.nodes = plant.channel_nodes(list(scn.channels))
        self.period_steps = scn.period_steps
        #: Steps flown so far.
        self.steps = 0

    def next(self, log: Mapping[str, np.ndarray]) -> np.ndarray:
        commands = np.column_stack([log[c] for c in AUTOPILOT_COLUMNS])
        out = np.empty((len(commands), len(self.nodes)))
        for start in range(0, len(commands), self.period_steps):
            span = slice(start, start + self.period_steps)
            self.loop.replay(commands[span], self.nodes, out[span])
            self.steps += len(commands[span])
            try:
                self.plant.check_state()
            except DivergenceError as exc:
                message = f"the nominal twin flying our commands: {exc}"
                raise ReferenceLost(message, out[:start]) from None
        return out


#: The sources of the references computed from the log as it comes (``kind = "log"`` in
#: :data:`probing.experiment.scenario.references.REFERENCES`): name -> the class, built with the
#: scenario and a trimmed aircraft to fly if the run has one to spare (else None).
SOURCES: dict[str, Callable[[Scenario, Plant | None], ReferenceSource]] = {
    "gust": lambda scn, plant: GustSource(scn, plant),
    "follow": FollowSource,
}


def reference_source(
    scn: Scenario, twin: ReferenceTwin | None, follower: Plant | None = None
) -> ReferenceSource | None:
    """The reference of ``scn``'s drift mode (:data:`REFERENCES`), computed from the
    recorded stream: the precomputed ``twin`` (:func:`open_reference_twin`), a source of
    :data:`SOURCES` (``follower``: a trimmed nominal aircraft it may fly), or None (the
    references without a model)."""
    kind = REFERENCES[scn.drift].kind
    if kind == "log":
        return SOURCES[scn.drift](scn, follower)
    if kind == "twin":
        assert twin is not None, "a twin reference needs its twin"
        return TwinSource(twin)
    return None


def log_columns(scn: Scenario) -> tuple[str, ...]:
    """The columns of a log that :class:`Onboard` reads for ``scn``: ``time_s``, the
    scenario's channels, what its reference reads (:attr:`Reference.log_columns`: with
    ``follow`` the autopilot's commands, with ``gust`` the sensors its estimate and its twin
    need) and what its isolation checks read (:func:`isolation_columns`)."""
    checks = isolation_columns(scn).values()
    names = ["time_s", *scn.channels, *REFERENCES[scn.drift].log_columns, *sum(checks, ())]
    return tuple(dict.fromkeys(names))


def isolation_columns(scn: Scenario) -> dict[str, tuple[str, ...]]:
    """The isolation checks (:mod:`probing.core.isolation`) the flight computer runs for
    ``scn``, each with the log columns it reads: with a sensor suite only (without one the
    flight is what it was before the checks existed); ``actuator`` where the suite measures
    the probed surface and the autopilot commands it in its unit (the elevator),
    ``kinematics`` where the suite measures pitch attitude, body rates and bank."""
    suite = scn.sensors
    if suite is None:
        return {}
    checks: dict[str, tuple[str, ...]] = {}
    command = f"autopilot_{scn.surface}_{scn.surface_unit}"
    if command in AUTOPILOT_COLUMNS and scn.surface_channel in suite.sensors:
        checks["actuator"] = (scn.surface_channel, command, f"probe_{scn.surface_unit}")
    if all(c in suite.sensors for c in KINEMATIC_CHANNELS):
        checks["kinematics"] = KINEMATIC_CHANNELS
    return checks


def open_reference_twin(
    scn: Scenario, *, nominal: bool = True, use_cache: bool = True
) -> ReferenceTwin | None:
    """The precomputed twin of ``scn``'s drift mode (None if it has none): the nominal
    aircraft in calm air (``nominal``), or the aircraft through the same turbulence
    (``oracle``, ``reference``): the nominal one with ``nominal``, else the flight itself,
    damage and all (``probing run``'s comparison)."""
    flight = twin_flight(scn, nominal=nominal)
    if flight is None:
        return None
    return open_twin(flight, scn.channels, scn.total_steps, use_cache=use_cache)


def twin_flight(scn: Scenario, *, nominal: bool = True) -> Flight | None:
    """The flight of ``scn``'s precomputed twin (:func:`open_reference_twin`), None if it has
    none."""
    reference = REFERENCES[scn.drift]
    if reference.kind != "twin":
        return None
    if not reference.knows_gusts:  # a realisable twin: the nominal aircraft in calm air
        return calm_nominal(scn.flight)
    return scn.flight.nominal if nominal else scn.flight


class Onboard:
    """The recorded stream -> per-period estimates, chunk by chunk.

    Parameters
    ----------
    scn : Scenario
        The flight's scenario (its channels, probe, estimator and drift mode).
    source : ReferenceSource or None
        The reference (:func:`reference_source`); None: the ``baseline``.
    baseline : numpy.ndarray
        ``(channels,)``: what is subtracted without a reference.
    push_bits : int
        Bit samples per chunk (the streaming correlator's block).
    checks : mapping, optional
        The isolation checks to compute, each with the log columns it reads
        (:func:`isolation_columns`; the monitor's, which reads them: none without one).
    """

    def __init__(
        self,
        scn: Scenario,
        source: ReferenceSource | None,
        baseline: np.ndarray,
        push_bits: int,
        checks: Mapping[str, tuple[str, ...]] | None = None,
    ) -> None:
        self.scn, self.source, self.baseline = scn, source, baseline
        self.spb = scn.probe.steps_per_bit(scn.dt_s)
        self.drift = drift_correction(scn, scn.probe, push_bits)
        self.checks = dict(checks or {})
        self.kinematics = PitchKinematics(scn.dt_s) if "kinematics" in self.checks else None
        bandwidth = SERVOS.get(aircraft_name(scn.model))
        self.servo = Servo(bandwidth, scn.dt_s) if bandwidth and "actuator" in self.checks else None

    def estimates(self, log: Mapping[str, np.ndarray], first: int) -> Estimated:
        """A chunk of whole periods from period ``first`` on -> what the flight computer
        makes of it (:class:`Estimated`)."""
        reference, ended = None, None
        if self.source is not None:
            try:
                reference = self.source.next(log)
            except ReferenceLost as exc:  # its whole periods before are estimated
                if not len(exc.flown):
                    raise
                ended, reference = str(exc), exc.flown
                log = {c: np.asarray(v)[: len(reference)] for c, v in log.items()}
        measured = np.column_stack([log[c] for c in self.scn.channels])
        baseline = reference if reference is not None else self.baseline
        deviation = (measured - baseline)[self.spb - 1 :: self.spb]
        est = self.drift.estimates(deviation, first)
        count = deviation.shape[0] // self.scn.probe.length
        whole = np.arange(first, first + count, dtype=np.int64)
        trajectory = (whole, self._features(deviation))
        isolation = {check: (whole, self._features(d)) for check, d in self._isolation(log)}
        return Estimated(est, measured, reference, trajectory, isolation, ended)

    def _features(self, bits: np.ndarray) -> np.ndarray:
        """The whole periods' features ``(P, C, 2)`` of a deviation's bit samples ``(n, C)``
        (:func:`probing.core.trajectory.trajectory_features`)."""
        m = self.scn.probe.length
        count = bits.shape[0] // m
        return trajectory_features(bits[: count * m].reshape(count, m, -1).transpose(0, 2, 1))

    def _isolation(self, log: Mapping[str, np.ndarray]) -> list[tuple[str, np.ndarray]]:
        """Each isolation check's deviation, at the bits ``(n, 1)``."""
        out = []
        for check, columns in self.checks.items():
            values = [np.asarray(log[c], dtype=float) for c in columns]
            if check == "actuator":
                deviation = actuator_deviation(*values, servo=self.servo)
            else:
                assert self.kinematics is not None
                deviation = self.kinematics.update(*values)
            out.append((check, deviation[self.spb - 1 :: self.spb, None]))
        return out


@dataclass
class Estimated:
    """What the flight computer made of a chunk.

    Attributes
    ----------
    estimates : object
        The per-period estimates: ``periods`` (P,), ``z``, ``zeta``, ``h`` (P, C, M).
    measured : numpy.ndarray
        ``(rows, C)``: the measured channels.
    reference : numpy.ndarray or None
        ``(rows, C)``: the reference's outputs (None without one).
    trajectory : (numpy.ndarray, numpy.ndarray)
        Every whole period of the chunk ``(P',)`` and its deviation's features ``(P', C, 2)``
        (:func:`probing.core.trajectory.trajectory_features`): the trajectory detector's.
    isolation : dict
        Isolation check (:func:`isolation_columns`) -> every whole period ``(P',)`` and its
        deviation's features ``(P', 1, 2)`` (empty without a sensor suite).
    ended : str or None
        Why the reference diverged in the chunk, after the periods above (None: it did not).
    """

    estimates: Any
    measured: np.ndarray
    reference: np.ndarray | None
    trajectory: tuple[np.ndarray, np.ndarray]
    isolation: dict[str, tuple[np.ndarray, np.ndarray]] = dataclasses.field(default_factory=dict)
    ended: str | None = None
