"""causal_convolve against scipy.signal.fftconvolve (the implementation it replaces)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import fftconvolve

from probing.core.convolution import causal_convolve


@pytest.mark.parametrize(("n", "k"), [(1000, 300), (1000, 5000), (7, 7), (1, 4), (513, 1)])
def test_it_is_the_head_of_the_full_convolution(n: int, k: int) -> None:
    rng = np.random.default_rng(n + k)
    u, kernel = rng.normal(size=n), rng.normal(size=(k, 3))
    got = causal_convolve(u, kernel)
    assert got.shape == (n, 3)
    for j in range(3):
        expected = fftconvolve(u, kernel[:, j])[:n]
        np.testing.assert_allclose(got[:, j], expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    np.testing.assert_allclose(causal_convolve(u, kernel[:, 0]), got[:, 0], rtol=0, atol=1e-12)


def test_a_delayed_impulse_delays_the_input() -> None:
    u = np.arange(1.0, 9.0)
    kernel = np.zeros(3)
    kernel[2] = 2.0
    np.testing.assert_allclose(causal_convolve(u, kernel), np.r_[0.0, 0.0, 2 * u[:-2]], atol=1e-12)


def test_empty_input_gives_empty_output() -> None:
    assert causal_convolve(np.zeros(0), np.ones((4, 2))).shape == (0, 2)
