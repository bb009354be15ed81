"""Figures of merit: the gain/shape fit against constructed responses, the predicted apparent
input.  (The estimators' noise: tests/core/test_noise.py.)"""

from __future__ import annotations

import math

import numpy as np
import pytest

from probing.core.metrics import gain_and_shape, predicted_apparent
from probing.core.nonlinearities import Backlash, Deadband, RateLimit


def test_gain_and_shape() -> None:
    t = np.arange(50) * 0.1
    h0 = np.exp(-t) * np.sin(2 * t)
    g, shape = gain_and_shape(0.4 * h0, h0)
    assert g == pytest.approx(0.4) and shape == pytest.approx(0.0, abs=1e-12)
    bump = np.zeros_like(h0)
    bump[3] = 0.1
    bump -= np.dot(bump, h0) / np.dot(h0, h0) * h0  # orthogonal to h0: gain unchanged
    g, shape = gain_and_shape(0.4 * h0 + bump, h0)
    assert g == pytest.approx(0.4)
    assert shape == pytest.approx(np.linalg.norm(bump) / np.linalg.norm(0.4 * h0))


def test_predicted_apparent() -> None:
    assert predicted_apparent(None, 0.01, 0.1) == (1.0, 0.0)
    assert predicted_apparent(Deadband(-0.004, 0.004), 0.01, 0.1) == pytest.approx((0.6, 0.0))
    assert predicted_apparent(Backlash(0.005), 0.01, 0.1) == pytest.approx((0.75, 0.0))
    # Rate limit: 2a/t0 = 0.2 deg/s.
    assert predicted_apparent(RateLimit(0.2), 0.01, 0.1) == (1.0, 0.0)
    assert all(math.isnan(v) for v in predicted_apparent(RateLimit(0.19), 0.01, 0.1))
