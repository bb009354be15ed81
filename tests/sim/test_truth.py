"""The GTM's two truths, the single pulse and the linearisation stepped as JSBSim steps it,
differ by the simulator's own integration, first order in its step: within 2 % on every
channel at dt = 1 ms; at the scenarios' 10 ms the difference halves with dt
(docs/truth.md).  The servo and the one-step delay are in both."""

from __future__ import annotations

import numpy as np
import pytest

from probing.sim.flight import Flight
from probing.sim.truth import linear_pulse_response, single_pulse_response

pytestmark = pytest.mark.jsbsim

CHANNELS = ("theta_rad", "q_rad_s", "alpha_rad")
T0_S, BITS, A_DEG = 0.01, 511, 0.005  # Fig. 4's bit, memory and amplitude


def gtm(dt_s: float) -> Flight:
    return Flight("gtm_t2", 800.0, "speed_kcas", 75.0, dt_s)


def differences(dt_s: float) -> dict[str, float]:
    spb = round(T0_S / dt_s)
    lin = linear_pulse_response(gtm(dt_s), CHANNELS, T0_S, BITS)
    pulse = single_pulse_response(gtm(dt_s), CHANNELS, A_DEG, spb, BITS)
    return {
        c: float(np.linalg.norm(lin[c] - pulse[c]) / np.linalg.norm(pulse[c])) for c in CHANNELS
    }


def test_gtm_truths_agree_within_two_percent_at_one_millisecond() -> None:
    found = differences(0.001)
    assert all(v < 0.02 for v in found.values()), found


def test_gtm_truths_differ_by_first_order_integration() -> None:
    """10 ms to 5 ms: the difference of q and alpha halves (first order: ratio 2; 1.6-2.4
    allowed for the second-order terms), and is more than 2 % at 10 ms."""
    coarse, fine = differences(0.01), differences(0.005)
    for c in ("q_rad_s", "alpha_rad"):
        assert coarse[c] > 0.02, coarse
        assert 1.6 < coarse[c] / fine[c] < 2.4, (c, coarse[c], fine[c])
