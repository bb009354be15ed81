"""The isolation checks (probing.core.isolation) against closed-form truth: the kinematic
residual against scipy's first-order filter of the attitude's disagreement, chunk by chunk;
the verdict's window at both ends."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from probing.core.isolation import (
    ISOLATION_CHECKS,
    KINEMATIC_TIME_S,
    PitchKinematics,
    actuator_deviation,
    isolated_verdict,
)

DT = 0.01


def _flight(n: int, seed: int = 0) -> tuple[np.ndarray, ...]:
    """A consistent pitch history: rates measured after each step, the attitude their
    integral (rectangle rule), bank and yaw rate moving."""
    rng = np.random.default_rng(seed)
    q = 0.02 * np.sin(np.arange(n) * 0.013) + 0.001 * rng.standard_normal(n)
    r = 0.01 * np.cos(np.arange(n) * 0.007)
    phi = 0.2 * np.sin(np.arange(n) * 0.003)
    theta = 0.1 + np.cumsum((q * np.cos(phi) - r * np.sin(phi)) * DT)
    return theta, q, r, phi


def _high_passed(x: np.ndarray) -> np.ndarray:
    """x less its first-order low-pass (time constant KINEMATIC_TIME_S, started at x[0])."""
    k = DT / KINEMATIC_TIME_S
    low, _ = lfilter([k], [1.0, -(1.0 - k)], x, zi=[(1.0 - k) * x[0]])
    return x - low


def test_a_consistent_flight_leaves_nothing():
    theta, q, r, phi = _flight(3000)
    assert np.abs(PitchKinematics(DT).update(theta, q, r, phi)).max() < 1e-12


def test_a_sensor_fault_leaves_its_error_high_passed_whatever_the_chunks():
    """The attitude measured with a bias from step 1000 and a scale from step 2000: the
    residual is that error, high-passed, as scipy's filter gives it; in chunks as whole."""
    theta, q, r, phi = _flight(3000, seed=1)
    error = np.zeros_like(theta)
    error[1000:] += 0.005
    error[2000:] += 0.2 * theta[2000:]
    want = _high_passed(error)
    assert abs(want[1000] - 0.005) < 1e-5 and abs(want[999]) < 1e-12
    for size in (3000, 700, 1):
        kinematics = PitchKinematics(DT)
        got = np.concatenate(
            [
                kinematics.update(*(x[i : i + size] for x in (theta + error, q, r, phi)))
                for i in range(0, 3000, size)
            ]
        )
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_the_actuator_deviation_is_position_less_command_less_probe():
    surface, command, probe = np.array([1.0, 2.0]), np.array([0.25, 0.5]), np.array([0.5, -0.5])
    assert actuator_deviation(surface, command, probe).tolist() == [0.25, 2.0]


@pytest.mark.parametrize(
    ("period", "verdict"),
    [(34, "airframe"), (35, "sensor"), (43, "sensor"), (44, "airframe")],
)
def test_the_verdict_looks_from_lookback_before_to_verdict_periods_after(period, verdict):
    """First alarm 40, lookback 5, verdict periods 3: periods 35 to 43 count, 34 and 44 not."""
    assert isolated_verdict(40, {"kinematics": [period]}, 5, 3) == verdict
    actuator = "actuator" if verdict == "sensor" else "airframe"
    assert isolated_verdict(40, {"actuator": [period]}, 5, 3) == actuator


def test_a_sensor_is_named_before_the_actuator_and_both_stand_for_a_verdict():
    assert isolated_verdict(40, {"actuator": [40], "kinematics": [41]}, 5, 3) == "sensor"
    assert set(ISOLATION_CHECKS.values()) == {"actuator", "sensor"}
