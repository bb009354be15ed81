"""The sensors between a world and the flight computer: what the computer measures of the
true values a world reports, one implementation for every world.

A :class:`SensorBank` is a sensor suite (:data:`probing.core.sensors.SENSOR_SUITES`), each
channel's :class:`~probing.core.sensors.Sensor` (noise, bias, scale factor, lag, sample rate)
started in steady state at its trim, with a sensor fault from its onset step on; the noise
comes from one stream of the scenario's seed.  A :class:`ChannelNoise` is the measurement
without a suite: white noise (``disturbance.sensor_noise``) and the sensor fault.  JSBSim in
this process (:class:`probing.sim.sensing.Sensing`, read by
:class:`probing.sim.world.JSBSimWorld`'s step loop) and JSBSim in a separate process
(:class:`probing.experiment.flight.live.SocketWorld`) measure through them, seeded alike.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from probing.core.faults import SensorFault, apply_sensor_fault, onset_step
from probing.core.sensors import Sensor, SensorSuite

__all__ = ["SENSOR_STREAM", "ChannelNoise", "SensorBank"]

#: The sensors' noise stream: ``numpy.random.default_rng([seed, SENSOR_STREAM])``, apart from
#: the scenario seed's other uses (JSBSim's turbulence, ``disturbance.sensor_noise``).
SENSOR_STREAM = 1


class SensorBank:
    """The sensors of a suite, each started in steady state at its true trim value: what
    they measure of true values handed in (a plant in this process, or a simulator elsewhere).

    Parameters
    ----------
    suite : SensorSuite
        The sensors, channel -> spec; the channels are measured in the suite's order.
    dt_s : float
        The simulation step, s.
    seed : int
        The scenario's seed (the noise comes from stream :data:`SENSOR_STREAM` of it).
    trim : list of float
        The true value of each channel at the trim, in the suite's order.
    fault : SensorFault or None
        A fault of one sensor's measurement from its onset step on (a
        :class:`~probing.core.faults.SensorBias`, ...; the autopilot flies on it too): its
        ``measure`` after every step, applied by the world that steps the sensors.
    """

    def __init__(
        self,
        suite: SensorSuite,
        dt_s: float,
        seed: int,
        trim: list[float],
        fault: SensorFault | None = None,
    ) -> None:
        self.channels: tuple[str, ...] = tuple(suite.sensors)
        self.sensors = [Sensor(suite.sensors[c], dt_s) for c in self.channels]
        for sensor, value in zip(self.sensors, trim, strict=True):
            sensor.reset(value)
        #: The latest measurement of each channel (at the start: the trim's, noise-free); the
        #: loop updates it in place after every step.
        self.current: list[float] = [s.output for s in self.sensors]
        self.rng = np.random.default_rng([int(seed), SENSOR_STREAM])
        #: The columns someone reads step by step (a loop of the autopilot, through
        #: :meth:`probing.sim.world.JSBSimWorld.reader`): a world measures these after every
        #: step and the others after a block of steps at once (:meth:`complete`).
        self.live: set[int] = set()
        #: The sensor fault, the column it acts on and its onset step (None: no fault).
        self.fault = fault
        self.fault_channel: int | None = None
        self.fault_onset = -1
        if fault is not None:
            if fault.channel not in self.channels:
                raise ValueError(f"the sensor fault's channel {fault.channel} has no sensor")
            self.fault_channel = self.channels.index(fault.channel)
            self.fault_onset = onset_step(fault.onset_s, dt_s)

    def index(self, channel: str) -> int:
        """The column of ``channel`` in the measurements (ValueError if not measured)."""
        if channel not in self.channels:
            raise ValueError(f"no sensor measures {channel}")
        return self.channels.index(channel)

    def draws(self, n: int) -> np.ndarray:
        """The next ``n`` steps' standard-normal draws ``(n, sensors)``, one per sensor and
        step."""
        return self.rng.standard_normal((n, len(self.sensors)))

    def noise(self, n: int) -> list[list[float]]:
        """:meth:`draws` as lists, a row a step."""
        return self.draws(n).tolist()

    def complete(
        self,
        true: np.ndarray,
        draws: np.ndarray,
        stepped: dict[int, list[float]],
    ) -> np.ndarray:
        """The block's measurements ``(n, sensors)``: the columns in ``stepped`` as they were
        measured step by step, every other column's sensor run over its true values (the
        same floats as step by step, :meth:`probing.core.sensors.Sensor.run`); a sensor
        fault is the caller's.

        Parameters
        ----------
        true : numpy.ndarray
            ``(n, sensors)``: the true values after each step, channel units.
        draws : numpy.ndarray
            ``(n, sensors)``: the block's :meth:`draws`.
        stepped : dict
            Column -> its measurements, already made step by step (:attr:`live`).
        """
        n = true.shape[0]
        out = np.empty((n, len(self.sensors)))
        for j, sensor in enumerate(self.sensors):
            if j in stepped:
                out[:, j] = stepped[j]
                continue
            out[:, j] = sensor.run(true[:, j], draws[:, j])
        return out

    def measure(self, true: np.ndarray) -> np.ndarray:
        """The measurements ``(n, sensors)`` of the next ``n`` steps' true values ``true``
        ``(n, sensors)``, as a plant's loop measures them step by step."""
        noise = self.noise(true.shape[0])
        steps = [s.step for s in self.sensors]
        rows = [
            [st(v, e) for st, v, e in zip(steps, row, draws, strict=True)]
            for row, draws in zip(true.tolist(), noise, strict=True)
        ]
        if rows:
            self.current[:] = rows[-1]
        return np.array(rows, dtype=np.float64).reshape(true.shape)


class ChannelNoise:
    """The world's measurement without a sensor suite: each channel's true value with white
    noise (``disturbance.sensor_noise``) and a sensor fault from its onset on (its
    ``measure`` of every row, :func:`~probing.core.faults.apply_sensor_fault`).

    Parameters
    ----------
    channels : sequence of str
        The measured channels, in order.
    sigma : sequence of float
        Each channel's noise standard deviation, its unit.
    seed : int
        The scenario's seed (``numpy.random.default_rng(seed)``).
    fault : SensorFault or None
        A fault of one channel's measurement from its onset on.
    dt_s : float
        The step, s.
    """

    def __init__(
        self,
        channels: Sequence[str],
        sigma: Sequence[float],
        seed: int,
        fault: SensorFault | None,
        dt_s: float,
    ) -> None:
        self.channels, self.fault, self.dt_s = tuple(channels), fault, float(dt_s)
        self.sigma = np.asarray(sigma, dtype=np.float64)
        self.rng = np.random.default_rng(seed)

    def measure(self, true: np.ndarray, first_step: int) -> np.ndarray:
        """The measurements ``(rows, channels)`` of the true values ``true`` of the steps from
        ``first_step`` on (call it for consecutive blocks, in order)."""
        rows, n_ch = true.shape
        measured = true + self.rng.standard_normal((rows, n_ch)) * self.sigma
        if self.fault is not None:
            apply_sensor_fault(self.fault, measured, self.channels, first_step, self.dt_s)
        return measured
