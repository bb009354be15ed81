"""Simultaneous designs on a made-up linear system whose pulse responses are known exactly."""

from __future__ import annotations

import numpy as np
import pytest

from probing.core.convolution import causal_convolve
from probing.core.multiplex import Layout, memory_bits
from probing.core.prbs import mls

ORDER = 7
M = 2**ORDER - 1


def _flight(layout: Layout, pulses: np.ndarray, amplitudes: np.ndarray) -> np.ndarray:
    """Bit samples of the outputs: every surface's input through its pulse responses, summed.
    pulses: (k, C, L) per unit of the surface."""
    inputs = layout.inputs(mls(ORDER)) * amplitudes[:, None]
    y = np.zeros((inputs.shape[1], pulses.shape[1]))
    for u, per_channel in zip(inputs, pulses, strict=True):
        for c, h in enumerate(per_channel):
            y[:, c] += causal_convolve(u, h)
    return y


def test_shift_windows_recover_each_surface_exactly() -> None:
    rng = np.random.default_rng(1)
    layout = Layout("shift", 3, M, periods=2, settle_periods=1)
    w = layout.window_bits
    assert w == M // 3 == 42
    pulses = np.zeros((3, 2, w))
    pulses[:, :, : w - 1] = rng.normal(size=(3, 2, w - 1))  # each dies out inside its window
    amplitudes = np.array([0.5, 2.0, 0.01])
    found = layout.responses(_flight(layout, pulses, amplitudes), mls(ORDER), amplitudes)
    np.testing.assert_allclose(found, pulses, atol=1e-10)


def test_shift_a_tail_past_the_window_lands_in_the_next_surface() -> None:
    """Surface 0's response at tap W + 3 is read as surface 1's tap 3, scaled a0 / a1."""
    layout = Layout("shift", 2, M, periods=1, settle_periods=1)
    w = layout.window_bits
    pulses = np.zeros((2, 1, w + 4))
    pulses[0, 0, 0] = 1.0
    pulses[0, 0, w + 3] = 0.1
    pulses[1, 0, 1] = -0.5
    amplitudes = np.array([2.0, 1.0])
    found = layout.responses(_flight(layout, pulses, amplitudes), mls(ORDER), amplitudes)
    assert found[1, 0, 3] == pytest.approx(0.1 * 2.0 / 1.0, abs=1e-12)
    assert found[1, 0, 1] == pytest.approx(-0.5, abs=1e-12)
    assert found[0, 0, 0] == pytest.approx(1.0, abs=1e-12)
    assert np.abs(found[0, 0, 1:]).max() < 1e-12  # the tail left surface 0's window


def test_multiplex_blocks_take_turns_and_settle() -> None:
    rng = np.random.default_rng(2)
    layout = Layout("multiplex", 2, M, periods=2, settle_periods=1)
    assert layout.total_periods == 6 and layout.window_bits == M
    inputs = layout.inputs(mls(ORDER))
    assert not inputs[0, 3 * M :].any() and not inputs[1, : 3 * M].any()  # one at a time
    assert list(layout.estimated_periods(1)) == [4, 5]
    pulses = rng.normal(size=(2, 1, M)) * np.exp(-np.arange(M) / 10.0)  # gone within a period
    amplitudes = np.array([1.0, 3.0])
    found = layout.responses(_flight(layout, pulses, amplitudes), mls(ORDER), amplitudes)
    np.testing.assert_allclose(found, pulses, atol=1e-10)


def test_memory_bits() -> None:
    h = 0.5 ** np.arange(20)
    assert memory_bits(h, 0.01) == 7  # 0.5**6 = 0.0156 is the last at or above 0.01
    assert memory_bits(-h, 0.01) == 7
    assert memory_bits(h, 2.0) == 0


@pytest.mark.parametrize(
    ("design", "surfaces", "match"),
    [("independent", 2, "design must be"), ("shift", 1, ">= 2 surfaces")],
)
def test_layout_refuses(design: str, surfaces: int, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        Layout(design, surfaces, M, 2, 1)
