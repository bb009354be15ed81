"""A measurement sensor as JSBSim's ``<sensor>`` flight-control component defines it, and
NASA's T2 sensor suite: one registry, :data:`SENSOR_SUITES`.

What JSBSim does
----------------
The numbers below are lines of JSBSim's source at commit 0b688c80 (FGSensor, FGFCSComponent,
FGFCSChannel and FGFCS are unchanged there since tag v1.3.1; the installed engine is 1.3.3,
against which ``tests/sim/test_sensors_jsbsim.py`` checks this module to 1e-12).

* **Order of operations** (``src/models/flight_control/FGSensor.cpp:159-181``,
  ``ProcessSensorSignal``): output = input; then lag, noise, drift, gain, bias, delay,
  fail_low/high, quantize, clip, each only if configured.  So the **gain multiplies the
  noise** as well as the signal, and the bias is added after the gain: the measurement is
  ``scale * (lag(x) + noise_sigma * n) + bias``, then quantised.  This module follows that
  order (no drift, delay, failures or clip).
* **Lag** (``FGSensor.cpp:91-96`` and ``:240-247``): a first-order lag ``lag / (s + lag)``
  discretised with Tustin's rule: ``ca = dt*lag / (2 + dt*lag)``, ``cb = (2 - dt*lag) /
  (2 + dt*lag)``, ``y = ca * (u + u_prev) + y_prev * cb``, with ``u_prev`` the raw input of
  the previous run.  ``dt`` is the component's, taken once when the model is loaded:
  ``FGFCSComponent.cpp:59`` ``dt = fcs->GetChannelDeltaT()``, which is the simulation step
  times the channel's ``execrate`` (``FGFCS.h:569``, set per channel in ``FGFCS.cpp:511-514``
  and ``:174``).
* **Noise** (``FGSensor.cpp:185-203``): ``<noise variation="ABSOLUTE"
  distribution="GAUSSIAN">`` adds ``noise * n`` with ``n`` a standard normal draw
  (``std::normal_distribution<double>`` with default mean 0 and sigma 1,
  ``FGJSBBase.h:93-97``).  The element's value is therefore the 1-sigma amplitude despite
  its C++ name ``noise_variance``.  A draw is taken only when the component runs.
* **Quantisation** (``FGSensor.cpp:66-81`` and ``:229-236``): ``<bits>``, ``<min>``,
  ``<max>`` give the step ``granularity = (max - min) / 2**bits``; the output is clamped to
  [min, max] and *truncated* down to ``min + k * granularity``.  :attr:`SensorSpec.quantum`
  is that step: ``floor(x / quantum) * quantum`` equals JSBSim's output whenever ``min`` is
  a whole number of steps and the signal stays within [min, max] (no clamp here).  Like
  JSBSim's, the quantiser truncates: its error is in ``(-quantum, 0]``, mean ``-quantum/2``.
* **Execution rate** (``src/models/FGFCSChannel.h:75-82`` and ``:117-138``): a channel with
  ``execrate="N"`` starts its frame counter at N; each frame with ``dt != 0`` it resets the
  counter to 0 if it reached N, then increments it, and runs its components when the counter
  is N.  ``run_ic()`` runs with ``dt = 0`` (``FGFDMExec.cpp:636-646``), which leaves the
  counter at N and runs the components; the *first* timed step then sets the counter to 1.
  So after the initial conditions the components run on the N-th, 2N-th, ... step (0-based
  steps N-1, 2N-1, ...), and the properties they write hold their value in between.
* **Initial state** (``FGSensor.cpp:60`` and ``:137-142``): the lag's past input and output
  start at 0.  :meth:`Sensor.reset` starts them instead at the true value, so a sensor put on
  a trimmed flight starts in steady state; ``reset(0.0)`` is JSBSim's start.

What this module adds is only the sample rate in Hz (:attr:`SensorSpec.rate_hz`): it must be
``1 / (N * dt_s)`` for a whole N, the ``execrate`` of a JSBSim channel.

This module loads no JSBSim.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

from probing.core.errors import ProbingError, is_number

__all__ = [
    "FPS_PER_KT",
    "FPS_PER_MPS",
    "SENSOR_SUITES",
    "Sensor",
    "SensorSpec",
    "SensorSpecError",
    "SensorSuite",
]

#: ft/s per knot: 1 kt = 1852 m/h exactly, 1 ft = 0.3048 m exactly.
FPS_PER_KT = 1852.0 / 3600.0 / 0.3048
#: ft/s per m/s.
FPS_PER_MPS = 1.0 / 0.3048

#: The relative tolerance on ``1 / (rate_hz * dt_s)`` being a whole number of steps.
FRAME_RTOL = 1e-9


class SensorSpecError(ProbingError, ValueError):
    """A sensor specification, override or sample rate that cannot be used.

    Attributes
    ----------
    field : str
        The offending field (``"noise_sigma"``), or the unknown channel's name.
    """

    def __init__(self, message: str, field: str) -> None:
        super().__init__(message)
        self.field = field


@dataclass(frozen=True)
class SensorSpec:
    """What a sensor does to the signal it measures, in the unit of its channel.

    Attributes
    ----------
    noise_sigma : float
        White Gaussian noise, 1 sigma, in the channel's unit (JSBSim's ``<noise
        variation="ABSOLUTE" distribution="GAUSSIAN">``).  JSBSim adds it before the gain,
        so the measured noise is ``abs(scale) * noise_sigma``; the two are the same for
        ``scale == 1``.
    bias : float
        Added after the gain, in the channel's unit (``<bias>``).
    scale : float
        Scale factor, not 0 (``<gain>``; JSBSim ignores a gain of 0).
    lag_rad_s : float
        First-order lag ``lag / (s + lag)``, 1/s (JSBSim's ``<lag>``); 0: none.
    rate_hz : float
        Sample rate, Hz; 0: every simulation step.  The output is held between samples.
    quantum : float
        Quantisation step in the channel's unit; 0: none.  JSBSim's ``<quantization>`` gives
        it as ``(max - min) / 2**bits``: the same step, written differently.  Truncating, as
        JSBSim's: ``floor(x / quantum) * quantum``.
    """

    noise_sigma: float = 0.0
    bias: float = 0.0
    scale: float = 1.0
    lag_rad_s: float = 0.0
    rate_hz: float = 0.0
    quantum: float = 0.0

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if not is_number(value):
                raise SensorSpecError(f"sensor {f.name} must be a number, not {value!r}", f.name)
            if not math.isfinite(value):
                raise SensorSpecError(f"sensor {f.name} must be finite, not {value!r}", f.name)
            object.__setattr__(self, f.name, float(value))
        for name in ("noise_sigma", "lag_rad_s", "rate_hz", "quantum"):
            if getattr(self, name) < 0.0:
                raise SensorSpecError(
                    f"sensor {name} must be >= 0, not {getattr(self, name)!r}", name
                )
        if self.scale == 0.0:
            raise SensorSpecError("sensor scale must not be 0", "scale")

    def to_dict(self) -> dict[str, float]:
        """The fields as ``{name: value}``, in declaration order."""
        return dataclasses.asdict(self)

    def replace(self, **changes: float) -> SensorSpec:
        """A copy with ``changes`` applied; :class:`SensorSpecError` for an unknown field or
        a value the checks refuse."""
        known = {f.name for f in dataclasses.fields(self)}
        for name in changes:
            if name not in known:
                raise SensorSpecError(
                    f"unknown sensor field {name!r}; known: {', '.join(sorted(known))}", name
                )
        return dataclasses.replace(self, **changes)


class Sensor:
    """One sensor running on a simulation of step ``dt_s``: JSBSim's ``<sensor>`` in a
    channel of ``execrate`` N, with N = ``1 / (spec.rate_hz * dt_s)`` (1 for ``rate_hz``
    0).

    Parameters
    ----------
    spec : SensorSpec
        What the sensor does.
    dt_s : float
        The simulation step, s.

    Raises
    ------
    SensorSpecError
        (a ValueError) for a sample rate above ``1 / dt_s`` or whose frame is not a whole
        number of steps (within :data:`FRAME_RTOL`, relative), or a ``dt_s`` that is not
        a positive finite number.

    Notes
    -----
    The sensor samples on steps N-1, 2N-1, ... after :meth:`reset` (0-based), where
    JSBSim's channel runs after ``run_ic()``; the lag then advances by ``N * dt_s``.  It
    holds its last output on the other steps.  The sensor starts as after ``reset(0.0)``.

    Examples
    --------
    >>> s = Sensor(SensorSpec(bias=0.5, scale=2.0, rate_hz=50.0), dt_s=0.005)
    >>> s.frame
    4
    >>> s.reset(1.0)
    >>> [s.step(v, 0.0) for v in (2.0, 2.0, 2.0, 2.0, 3.0)]
    [2.5, 2.5, 2.5, 4.5, 4.5]
    """

    def __init__(self, spec: SensorSpec, dt_s: float) -> None:
        if not isinstance(spec, SensorSpec):
            raise TypeError(f"spec must be a SensorSpec, not {type(spec).__name__}")
        if not (math.isfinite(dt_s) and dt_s > 0.0):
            raise SensorSpecError(f"dt_s must be a positive finite number, not {dt_s!r}", "dt_s")
        frame = 1
        if spec.rate_hz > 0.0:
            steps = 1.0 / (spec.rate_hz * dt_s)
            frame = round(steps)
            if frame < 1 or abs(steps - frame) > FRAME_RTOL * steps:
                raise SensorSpecError(
                    f"sensor rate_hz {spec.rate_hz!r} Hz must be 1/(N*dt_s) for a whole "
                    f"N >= 1 with dt_s = {dt_s!r} s (at most {1.0 / dt_s!r} Hz); "
                    f"it gives N = {steps!r} steps per sample",
                    "rate_hz",
                )
        self.spec = spec
        self.dt_s = float(dt_s)
        #: Simulation steps per sample (JSBSim's execrate).
        self.frame: int = frame
        #: The lag's time step, s (JSBSim's channel dt): ``frame * dt_s``.
        self.lag_dt_s: float = self.dt_s * frame
        lag = spec.lag_rad_s
        denom = 2.0 + self.lag_dt_s * lag
        #: Tustin coefficients of the lag (FGSensor.cpp:93-95); unused when lag_rad_s is 0.
        self.ca: float = self.lag_dt_s * lag / denom
        self.cb: float = (2.0 - self.lag_dt_s * lag) / denom
        self._lagged = lag != 0.0
        self._sigma = spec.noise_sigma
        self._scale = spec.scale
        self._bias = spec.bias
        self._quantum = spec.quantum
        self.reset(0.0)

    def reset(self, value: float) -> None:
        """Start in steady state at the true value ``value`` (channel unit).

        The lag's past input and output are ``value``; the held output is what the sensor
        measures of ``value`` without noise: ``scale * value + bias``, quantised; the next
        sample is taken ``frame`` steps on.  (JSBSim starts the lag at 0 instead; the two
        agree for ``value`` 0.)
        """
        value = float(value)
        self._prev_in = value
        self._prev_out = value
        self._count = 0
        held = value * self._scale + self._bias
        if self._quantum:
            held = math.floor(held / self._quantum) * self._quantum
        self._held = held

    @property
    def output(self) -> float:
        """The measurement held now (after :meth:`reset`: the noise-free one of its value)."""
        return self._held

    def step(self, value: float, noise: float) -> float:
        """One simulation step: the measurement of the true value ``value`` after the step.

        Parameters
        ----------
        value : float
            The true signal, channel unit.
        noise : float
            One standard-normal draw, scaled by ``noise_sigma`` here.  Every step takes
            one; only a sampling step's draw is used, the others are discarded.

        Returns
        -------
        float
            The measurement, channel unit: new on a sampling step, else the held one.
        """
        count = self._count + 1
        if count < self.frame:
            self._count = count
            return self._held
        self._count = 0
        x = value
        if self._lagged:
            x = self.ca * (x + self._prev_in) + self._prev_out * self.cb
            self._prev_out = x
            self._prev_in = value
        if self._sigma:
            x = x + self._sigma * noise
        x = x * self._scale
        x = x + self._bias
        if self._quantum:
            x = math.floor(x / self._quantum) * self._quantum
        self._held = x
        return x

    def run(self, values: np.ndarray, noise: np.ndarray) -> np.ndarray:
        """:meth:`step` over a sequence: the same floats, bit for bit, and the same state
        after it.

        Parameters
        ----------
        values : array_like, shape (n,)
            The true signal, one value a step, channel unit.
        noise : array_like, shape (n,)
            One standard-normal draw a step (see :meth:`step`).

        Returns
        -------
        numpy.ndarray, float64, shape (n,)
            The measurements.
        """
        values = np.asarray(values, dtype=np.float64)
        noise = np.asarray(noise, dtype=np.float64)
        if values.ndim != 1 or values.shape != noise.shape:
            raise ValueError(
                f"values and noise must be 1-D of one length, not {values.shape} and {noise.shape}"
            )
        if self.frame == 1 and not self._lagged and values.size:
            # A sample every step and no lag: each step's arithmetic is independent of the
            # others, so numpy does it for all, in :meth:`step`'s order of operations (the
            # same floats: IEEE arithmetic element by element, no fused operations).
            x = values + self._sigma * noise if self._sigma else values.copy()
            x = x * self._scale
            x = x + self._bias
            if self._quantum:
                x = np.floor(x / self._quantum) * self._quantum
            self._held = float(x[-1])
            return x
        step = self.step
        return np.array(
            [step(v, e) for v, e in zip(values.tolist(), noise.tolist(), strict=True)],
            dtype=np.float64,
        )


@dataclass(frozen=True)
class SensorSuite:
    """A set of sensors, one a channel.

    Attributes
    ----------
    name : str
        The suite's key in :data:`SENSOR_SUITES`.
    sensors : Mapping[str, SensorSpec]
        Channel name -> its sensor (read-only).
    source : str
        Where the numbers come from.
    """

    name: str
    sensors: Mapping[str, SensorSpec]
    source: str

    def __post_init__(self) -> None:
        for channel, spec in self.sensors.items():
            if not isinstance(spec, SensorSpec):
                raise TypeError(f"sensor of {channel!r} must be a SensorSpec, not {spec!r}")
        object.__setattr__(self, "sensors", MappingProxyType(dict(self.sensors)))

    def __reduce__(self) -> tuple[Any, tuple[str, dict[str, SensorSpec], str]]:
        """Pickled as its fields (a read-only mapping does not pickle): a scenario with
        sensors crosses to a sweep's worker processes."""
        return (SensorSuite, (self.name, dict(self.sensors), self.source))

    def with_overrides(self, overrides: Mapping[str, Mapping[str, float]]) -> SensorSuite:
        """A copy with per-channel field changes, ``{channel: {field: value}}``.

        Raises
        ------
        SensorSpecError
            For an unknown channel (``.field`` the channel) or field (``.field`` the
            field), naming it, or a value the checks of :class:`SensorSpec` refuse.
        """
        sensors = dict(self.sensors)
        for channel, changes in overrides.items():
            if channel not in sensors:
                raise SensorSpecError(
                    f"sensor suite {self.name!r} has no channel {channel!r}; "
                    f"known: {', '.join(sensors)}",
                    channel,
                )
            try:
                sensors[channel] = sensors[channel].replace(**changes)
            except SensorSpecError as err:
                raise SensorSpecError(f"channel {channel!r}: {err}", err.field) from None
        return SensorSuite(self.name, sensors, self.source)


_NASA_FILE = "NoiseParams_T2.m"
# NASA's T2 numbers (NoiseParams_T2.m, $Id 4852 2013-08-06: Std from T2 flight 3 card 3,
# Bias from flight 3 card 3 wavetrain 18, Scf 1 for every sensor), MIDG INS (not MAG3).
# Each entry: NASA's value and unit beside the converted one.  NASA gives no lag and no
# sample rate: both stay 0 (every step, no lag).
_NASA_T2 = {
    # alpha vane: Std 0.031 deg, Bias 0 deg
    "alpha_rad": SensorSpec(noise_sigma=math.radians(0.031)),
    # beta vane: Std 0.033 deg, Bias 0 deg
    "beta_rad": SensorSpec(noise_sigma=math.radians(0.033)),
    # KTAS: Std 0.06 kt, Bias 0.07 kt
    "vt_fps": SensorSpec(noise_sigma=0.06 * FPS_PER_KT, bias=0.07 * FPS_PER_KT),
    # baro_alt: Std 2.36 ft, Bias 0 ft
    "h_ft": SensorSpec(noise_sigma=2.36),
    # MIDG phi: Std 0.02 deg, Bias 0 deg
    "phi_rad": SensorSpec(noise_sigma=math.radians(0.02)),
    # MIDG theta: Std 0.02 deg, Bias -0.09 deg
    "theta_rad": SensorSpec(noise_sigma=math.radians(0.02), bias=math.radians(-0.09)),
    # MIDG psi: Std 0.02 deg, Bias -0.04 deg
    "psi_rad": SensorSpec(noise_sigma=math.radians(0.02), bias=math.radians(-0.04)),
    # MIDG pdeg: Std 0.5350 deg/s, Bias -0.0057 deg/s
    "p_rad_s": SensorSpec(noise_sigma=math.radians(0.5350), bias=math.radians(-0.0057)),
    # MIDG qdeg: Std 0.4737 deg/s, Bias -0.0115 deg/s
    "q_rad_s": SensorSpec(noise_sigma=math.radians(0.4737), bias=math.radians(-0.0115)),
    # MIDG rdeg: Std 0.3397 deg/s, Bias -0.0286 deg/s
    "r_rad_s": SensorSpec(noise_sigma=math.radians(0.3397), bias=math.radians(-0.0286)),
    # MIDG nxbody: Std 0.0012 g, Bias -0.00034 g
    "nx_g": SensorSpec(noise_sigma=0.0012, bias=-0.00034),
    # MIDG nybody: Std 0.0022 g, Bias 0.00093 g
    "ny_g": SensorSpec(noise_sigma=0.0022, bias=0.00093),
    # MIDG nzbody: Std 0.0068 g, Bias 0.00086 g (sign as NASA's file gives it; the file does
    # not say whether its body-z accelerometer is positive up like JSBSim's Nz)
    "nz_g": SensorSpec(noise_sigma=0.0068, bias=0.00086),
    # surface pots: Std 0.01 deg, Bias 0 deg (one entry in NASA's file for all surfaces)
    "elevator_deg": SensorSpec(noise_sigma=0.01),
    "aileron_deg": SensorSpec(noise_sigma=0.01),
    "rudder_deg": SensorSpec(noise_sigma=0.01),
    # INS velocities: NOT NASA's numbers (NoiseParams_T2.m has none).  Assumed 0.05 m/s,
    # 1 sigma, no bias: a typical GPS-aided INS velocity noise.
    "v_north_fps": SensorSpec(noise_sigma=0.05 * FPS_PER_MPS),
    "v_east_fps": SensorSpec(noise_sigma=0.05 * FPS_PER_MPS),
    "v_down_fps": SensorSpec(noise_sigma=0.05 * FPS_PER_MPS),
}

#: The sensor suites by name.
#:
#: ``nasa_t2``: NASA's T2 sensor noise (Std, 1 sigma) and bias from ``NoiseParams_T2.m``
#: (GTM simulation, MIDG INS for attitude, rates and accelerations), converted to the
#: channels' units (deg -> rad, deg/s -> rad/s, kt -> ft/s; g and ft as given).  NASA's
#: scale factors are all 1; the file gives no lag and no sample rate, so these are 0 (no
#: lag, a sample every step).  The INS velocities' 0.05 m/s is an assumption, not NASA's.
SENSOR_SUITES: dict[str, SensorSuite] = {
    "nasa_t2": SensorSuite(
        name="nasa_t2",
        sensors=_NASA_T2,
        source=(
            f"NASA GTM T2 {_NASA_FILE} ($Id 4852 2013-08-06): Std and Bias of the alpha and "
            "beta vanes, KTAS, baro_alt, the MIDG INS (phi, theta, psi, p, q, r, nx, ny, nz) "
            "and the surface pots, Scf 1; no lag or sample rate given (0 here). "
            "v_north/v_east/v_down_fps: NOT NASA's, an assumed 0.05 m/s (1 sigma, no bias), "
            "a typical GPS-aided INS velocity noise."
        ),
    ),
}
