"""Which part failed: the actuator, a sensor or the airframe, from what the flight
computer knows of its own loop and what the aircraft measures.

The probing and trajectory detectors say *that* something changed.  Two checks on the
recorded stream say *where*, each a deviation that no airframe change and no gust can move:

* **Actuator** (``"actuator"``): the surface's measured position (NASA's T2 potentiometers,
  0.01 deg) less where the nominal actuator would have put it, the autopilot's command plus
  the probe through the actuator's known dynamics (:class:`Servo`: the GTM's 5 Hz servos).
  The nominal actuator leaves the potentiometer's noise and a constant (the trim).  A lost
  effectiveness, a stuck surface, a dead band or backlash on the probe path or a rate limit
  all move it, whatever the airframe and the loop do.  Without the servo's dynamics the
  deviation would carry the servo's lag of every command, 0.17 deg rms on the GTM against
  0.01 deg of noise: the probe's own bits, and the autopilot's answer to an airframe change,
  which then looked like an actuator fault.
* **Kinematics** (``"kinematics"``): the measured pitch attitude less its integral from the
  measured body rates and bank, theta' = q cos(phi) - r sin(phi), high-passed at
  :data:`KINEMATIC_TIME_S` (the gyros' biases integrate to a drift).  Any airframe obeys it;
  a biased, scaled or stuck attitude or rate sensor breaks it.

Each is a deviation with a per-period mean and spread, tested against its own baseline as
the trajectory detector tests an output's (:class:`probing.core.trajectory.
TrajectoryDetector`).  :func:`isolated_verdict` turns their alarms around a flight's first
alarm into its verdict.  numpy only.
"""

from __future__ import annotations

from collections.abc import Collection

import numpy as np

from probing.core.gust import HighPass, LowPass

__all__ = [
    "DETECTORS",
    "ISOLATION_CHECKS",
    "KINEMATIC_CHANNELS",
    "KINEMATIC_TIME_S",
    "PitchKinematics",
    "Servo",
    "actuator_deviation",
    "isolated_verdict",
]

#: The detectors a monitor runs, in the order of their rows (``monitor.parquet``'s
#: ``detector``): the paper's, on the pulse response, and the trajectory's, on the
#: deviation.  They raise the flight's alarms; the checks below only isolate.
DETECTORS = ("probing", "trajectory")

#: The checks, in the order of their rows in ``monitor.parquet`` (its ``detector``), and
#: the verdict each stands for when it alarms.
ISOLATION_CHECKS = {"actuator": "actuator", "kinematics": "sensor"}

#: The measured channels the kinematic check reads.
KINEMATIC_CHANNELS = ("theta_rad", "q_rad_s", "r_rad_s", "phi_rad")

#: The kinematic residual's high-pass, s: the gyros' biases (NASA's T2: 0.01-0.03 deg/s)
#: integrate to a drift it removes; its noise (the rate gyros' white noise, integrated) stays
#: at about 0.0047 deg sqrt(T / 2 dt) = 0.07 deg for a 0.01 s step.
KINEMATIC_TIME_S = 5.0


class Servo:
    """The nominal actuator between a surface's command and its position, as the flight
    computer models it: first order, stepped as the GTM's own servo is (forward Euler at the
    frame rate, y_k = y_(k-1) + dt w (u_k - y_(k-1))), chunk by chunk (its state carries
    over), started at rest at its first command.  Its rate (300 deg/s) and position limits
    are left out: the nominal flight is far from them.

    Parameters
    ----------
    bandwidth_rad_s : float
        w, rad/s (the GTM's: 2 pi 5 Hz).
    dt_s : float
        The step, s.

    Examples
    --------
    A step of 1 deg at a 0.01 s step and 5 Hz moves 0.314 deg in the first step:

    >>> s = Servo(2 * np.pi * 5, 0.01)
    >>> [round(float(y), 4) for y in s.update(np.array([0.0, 1.0, 1.0]))]
    [0.0, 0.3142, 0.5296]
    """

    def __init__(self, bandwidth_rad_s: float, dt_s: float) -> None:
        self.lag = LowPass(1.0 / float(bandwidth_rad_s), dt_s)

    def update(self, command: np.ndarray) -> np.ndarray:
        """The positions after each of the next steps (the command's unit)."""
        return self.lag.update(command)


def actuator_deviation(
    surface: np.ndarray, command: np.ndarray, probe: np.ndarray, servo: Servo | None = None
) -> np.ndarray:
    """The surface's measured position less where the nominal actuator would have put it:
    the autopilot's command plus the probe, through ``servo`` (None: a surface that goes
    where it is asked); their unit.  A constant and noise while the actuator is well.

    Examples
    --------
    >>> actuator_deviation(np.array([-0.6, -0.2]), np.array([0.0, 0.0]), np.array([-0.2, 0.2]))
    array([-0.4, -0.4])
    """
    asked = np.asarray(command, dtype=float) + probe
    if servo is not None:
        asked = servo.update(asked)
    return np.asarray(surface, dtype=float) - asked


class PitchKinematics:
    """The measured pitch attitude less its integral from the measured rates, high-passed,
    chunk by chunk (the integral's and the filter's state carry over).

    Parameters
    ----------
    dt_s : float
        The step, s.
    time_s : float
        The high-pass's time constant, s (:data:`KINEMATIC_TIME_S`).
    """

    def __init__(self, dt_s: float, time_s: float = KINEMATIC_TIME_S) -> None:
        self.dt_s = float(dt_s)
        self.high_pass = HighPass(time_s, dt_s)
        self._theta: float | None = None  # the integral, rad (None: start at the measurement)

    def update(
        self, theta: np.ndarray, q: np.ndarray, r: np.ndarray, phi: np.ndarray
    ) -> np.ndarray:
        """The next steps' residual, rad: each step's attitude less the integral, which
        advances by the rate measured after that step (rectangle rule), started at the first
        attitude measured (where it starts is a constant, which the high-pass, started at
        the first residual, takes out).

        Examples
        --------
        A consistent aircraft (pitching at 0.01 rad/s, wings level) leaves nothing; an
        attitude sensor off by 0.01 rad from the third step on leaves a step, which the
        high-pass then lets decay:

        >>> k = PitchKinematics(0.01)
        >>> t = np.arange(6) * 0.01
        >>> theta, q, zero = 0.1 + 0.01 * t, np.full(6, 0.01), np.zeros(6)
        >>> bool(np.allclose(k.update(theta, q, zero, zero), 0.0))
        True
        >>> k = PitchKinematics(0.01)
        >>> e = k.update(theta + np.r_[0, 0, 0.01, 0.01, 0.01, 0.01], q, zero, zero)
        >>> [round(float(x), 6) for x in e[1:4]]
        [0.0, 0.00998, 0.00996]
        """
        theta = np.asarray(theta, dtype=float)
        rate = np.asarray(q, dtype=float) * np.cos(phi) - np.asarray(r, dtype=float) * np.sin(phi)
        start = theta[0] if self._theta is None else self._theta  # a constant: high-passed
        integral = start + np.cumsum(rate * self.dt_s)
        self._theta = float(integral[-1])
        return self.high_pass.update(theta - integral)


def isolated_verdict(
    first_alarm: int | None,
    alarms: dict[str, Collection[int]],
    lookback: int,
    verdict_periods: int,
) -> str:
    """A flight's verdict from its isolation checks' alarmed periods.

    Parameters
    ----------
    first_alarm : int or None
        The flight's first alarmed period (either detector; None: no alarm).
    alarms : dict
        Check (a key of :data:`ISOLATION_CHECKS`) -> its alarmed periods.
    lookback : int
        Periods before the first alarm that may hold the onset (the test's window and the
        period before it).
    verdict_periods : int
        Periods after the first alarm the verdict waits for.

    Returns
    -------
    str
        ``"none"`` without an alarm; ``"sensor"`` if the kinematic check alarmed in the
        periods from ``first_alarm - lookback`` to ``first_alarm + verdict_periods``; else
        ``"actuator"`` if the actuator check did; else ``"airframe"``: neither the sensors
        nor the actuator moved, so the change is the airframe's.

    Examples
    --------
    >>> isolated_verdict(40, {"actuator": [43], "kinematics": []}, 5, 3)
    'actuator'
    >>> isolated_verdict(40, {"actuator": [44], "kinematics": [34]}, 5, 3)
    'airframe'
    >>> isolated_verdict(40, {"actuator": [41], "kinematics": [35]}, 5, 3)
    'sensor'
    >>> isolated_verdict(None, {"actuator": [41], "kinematics": [35]}, 5, 3)
    'none'
    """
    if first_alarm is None:
        return "none"
    span = range(first_alarm - lookback, first_alarm + verdict_periods + 1)
    for check in ("kinematics", "actuator"):
        if any(p in span for p in alarms.get(check, ())):
            return ISOLATION_CHECKS[check]
    return "airframe"
