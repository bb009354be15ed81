"""The aircraft's sensors on a plant: what its flight computer measures, step by step.

A :class:`Sensing` is a :class:`probing.core.measuring.SensorBank` (the suite's sensors,
their noise and a sensor fault) that reads, after every simulation step, the true value of
each of its channels from the plant.  The autopilot (:class:`probing.sim.control.ClosedLoop`)
flies on these measurements, and they are what a flight records (``sensors.parquet``):
nothing else of the simulation reaches the flight computer.  A live flight
(:mod:`probing.experiment.flight.live`) measures the separate simulator's true values with
the same bank, seeded alike.
"""

from __future__ import annotations

from probing.core.faults import SensorFault
from probing.core.measuring import SensorBank
from probing.core.sensors import SensorSuite
from probing.sim.plant import Plant

__all__ = ["Sensing"]


class Sensing(SensorBank):
    """The sensors of a suite on a trimmed plant, each started in steady state at its trim.

    Parameters
    ----------
    plant : Plant
        The trimmed (and disturbed) plant the sensors read.
    suite : SensorSuite
        The sensors, channel -> spec; the channels are measured in the suite's order.
    seed : int
        The scenario's seed (the noise comes from its stream
        :data:`probing.core.measuring.SENSOR_STREAM`).
    fault : SensorFault or None
        A fault of one sensor's measurement from its onset step on (:class:`SensorBank`).
    """

    def __init__(
        self, plant: Plant, suite: SensorSuite, seed: int, fault: SensorFault | None = None
    ) -> None:
        nodes = plant.channel_nodes(list(suite.sensors))
        self.getters = [node.get_double_value for node in nodes]
        super().__init__(suite, plant.dt_s, seed, [get() for get in self.getters], fault)
