"""Finding the m-sequence in a recorded probe (probing.core.recorded)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from probing.core.prbs import mls
from probing.core.recorded import NotAnMSequence, align_probe, tap_bounds


def _record(seq: np.ndarray, shift: int, spb: int, lead: int, bits: int) -> np.ndarray:
    m = seq.size
    k = (np.arange(bits) + shift) % m
    return np.concatenate([np.full(lead, seq[(shift - 1) % m]), np.repeat(seq[k], spb)])


@pytest.mark.parametrize("shift", [0, 1, 17, 126])
def test_project_sequence_any_shift_and_offset(shift: int) -> None:
    seq = 3.0 + 0.25 * mls(7)
    al = align_probe(_record(seq, shift, 3, 2, 3 * 127 + 50), 3, 7)
    assert (al.shift_bits, al.sign, al.offset_samples) == (shift, 1, 2)
    assert al.amplitude == pytest.approx(0.25) and al.mid == pytest.approx(3.0)
    assert al.first_sample == 2 + 3 * ((127 - shift) % 127)
    assert al.periods == (3 * 127 + 50 - (127 - shift) % 127) // 127


def test_scipy_sequence_is_the_inverted_project_sequence() -> None:
    bits = signal.max_len_seq(8)[0]
    al = align_probe(np.repeat(np.tile(2.0 * bits - 1.0, 3), 1), 1, 8)
    assert (al.sign, al.shift_bits) == (-1, 0)
    al = align_probe(np.tile(1.0 - 2.0 * bits, 3), 1, 8)
    assert (al.sign, al.shift_bits) == (1, 0)


@pytest.mark.parametrize(
    ("probe", "spb", "order", "why"),
    [
        (np.tile(mls(7), 3), 1, 8, "cyclic shift"),
        (np.tile(mls(7), 3), 2, 7, "bit boundaries"),
        (np.repeat(np.tile(mls(7), 3), 2), 3, 7, "bit boundaries"),
        (np.r_[np.tile(mls(7), 3), 0.0], 1, 7, "two levels"),
        (np.ones(400), 1, 7, "two levels"),
        (np.r_[mls(7)[50:], mls(7)[:100]], 1, 7, "no whole period"),
        (np.random.default_rng(0).choice([-1.0, 1.0], 600), 1, 7, "cyclic shift"),
    ],
)
def test_not_an_msequence(probe: np.ndarray, spb: int, order: int, why: str) -> None:
    with pytest.raises(NotAnMSequence, match=why):
        align_probe(probe, spb, order)


def test_one_flipped_bit_is_refused() -> None:
    probe = np.tile(mls(7), 3)
    probe[200] *= -1
    with pytest.raises(NotAnMSequence, match="cyclic shift"):
        align_probe(probe, 1, 7)


def test_bounds_student_t() -> None:
    h = np.array([[1.0, 2.0], [3.0, 2.0], [2.0, 2.0]])
    mean, low, high, std = tap_bounds(h, 0.95)
    np.testing.assert_allclose(mean, [2.0, 2.0])
    np.testing.assert_allclose(std, [1.0, 0.0])
    np.testing.assert_allclose(high - mean, [4.302652729749464 / np.sqrt(3), 0.0])
    np.testing.assert_allclose(mean - low, high - mean)
