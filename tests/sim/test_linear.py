"""LinearResponse's vectorised methods against the model stepped one step at a time
(conftest's ``stepped``), and ZOH discretisation against scipy.signal.cont2discrete."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import cont2discrete

from probing.sim.linear import LinearResponse, zoh


def test_zoh_is_scipys_cont2discrete() -> None:
    rng = np.random.default_rng(3)
    a = rng.normal(size=(4, 4)) - 2 * np.eye(4)
    b = rng.normal(size=(4, 2))
    ad, bd = zoh(a, b, 0.05)
    ref_a, ref_b, *_ = cont2discrete((a, b, np.eye(4), np.zeros((4, 2))), 0.05, "zoh")
    np.testing.assert_allclose(ad, ref_a, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(bd, ref_b, rtol=1e-12, atol=1e-14)


def test_step_response_is_a_pulse_of_the_realised_surface(
    toy_linear: LinearResponse, stepped
) -> None:
    """A one-step pulse with an ideal actuator: 0, then C B + D, then C A^(k-1) B."""
    ideal = LinearResponse(**{**toy_linear.__dict__, "actuator": np.array([1.0])})
    pulse = np.zeros(400)
    pulse[0] = 1.0
    np.testing.assert_allclose(ideal.step_response(400), stepped(ideal, pulse), atol=1e-13)


def test_respond_is_the_stepped_model_from_rest(toy_linear: LinearResponse, stepped) -> None:
    u = np.random.default_rng(5).choice([-1.0, 1.0], size=900) * 0.01
    expected = stepped(toy_linear, u)
    np.testing.assert_allclose(toy_linear.respond(u), expected, atol=1e-12 * np.abs(expected).max())
    longer = toy_linear.step_response(2000)
    np.testing.assert_allclose(
        toy_linear.respond(u, longer), expected, atol=1e-12 * np.abs(expected).max()
    )


@pytest.mark.parametrize("period", [31, 62])
def test_periodic_is_where_the_stepped_model_settles(
    toy_linear: LinearResponse, stepped, period: int
) -> None:
    """The periodic steady state is the last period of a run long enough for the slow mode
    (0.995 per step) to have died out, its first sample included (it reads the period before)."""
    u = np.random.default_rng(period).choice([-1.0, 1.0], size=period)
    run = stepped(toy_linear, np.tile(u, 12000 // period))
    np.testing.assert_allclose(toy_linear.periodic(u), run[-period:], atol=1e-12)
