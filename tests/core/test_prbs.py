"""Properties of the m-sequence and the probe, checked against their definitions."""

import numpy as np
import pytest

from probing.core.prbs import MAX_ORDER, MIN_ORDER, Probe, mls


def _circular_autocorrelation(seq: np.ndarray) -> np.ndarray:
    # Direct O(M^2)-free definition via rolls for small M, FFT-free for independence.
    m = seq.size
    if m <= 4095:
        return np.array([np.dot(seq, np.roll(seq, lag)) for lag in range(m)])
    spec = np.fft.rfft(seq)
    return np.round(np.fft.irfft(spec * np.conj(spec), m))


@pytest.mark.parametrize("order", range(MIN_ORDER, MAX_ORDER + 1))
def test_mls_is_maximum_length(order: int) -> None:
    seq = mls(order)
    m = 2**order - 1
    assert seq.shape == (m,)
    assert seq.dtype == np.float64
    assert set(np.unique(seq)) == {-1.0, 1.0}
    # Balance: an m-sequence holds 2**(n-1) ones and 2**(n-1)-1 zeros.
    assert abs(seq.sum()) == 1
    acf = _circular_autocorrelation(seq)
    assert acf[0] == m
    assert np.all(acf[1:] == -1)


@pytest.mark.parametrize("order", range(MIN_ORDER, 13))
def test_mls_has_every_nonzero_state(order: int) -> None:
    # Every n-bit window (cyclically) appears exactly once, except all "-1"... i.e. the
    # LFSR visits all 2**n - 1 non-zero states: the defining property of an m-sequence.
    bits = (mls(order) < 0).astype(int)
    m = bits.size
    ext = np.concatenate([bits, bits[: order - 1]])
    words = {tuple(ext[i : i + order]) for i in range(m)}
    assert len(words) == m
    assert tuple([0] * order) not in words


@pytest.mark.parametrize("bad", [1, 21, 0, -3, 2.5, "9", True, None])
def test_mls_rejects_bad_order(bad) -> None:
    with pytest.raises(ValueError, match="order"):
        mls(bad)


def test_probe_quantities() -> None:
    probe = Probe(order=9, bit_duration_s=0.01, amplitude_deg=0.005)
    assert probe.length == 511
    assert probe.memory_s == pytest.approx(5.11)
    np.testing.assert_array_equal(probe.reference(), mls(9))
    bits = probe.bits(3)
    assert bits.size == 3 * 511
    np.testing.assert_array_equal(bits[:511], bits[511:1022])
    np.testing.assert_array_equal(np.abs(bits), 0.005)


def test_probe_samples_hold_each_bit() -> None:
    probe = Probe(order=4, bit_duration_s=0.04, amplitude_deg=0.5)
    x = probe.samples(dt_s=0.01, periods=2)
    assert x.size == 2 * 15 * 4
    held = x.reshape(-1, 4)
    assert np.all(held == held[:, :1])
    np.testing.assert_array_equal(held[:, 0], 0.5 * np.tile(mls(4), 2))
    # One step per bit is the bit sequence itself.
    np.testing.assert_array_equal(Probe(4, 0.01, 0.5).samples(0.01, 2), probe.bits(2))


@pytest.mark.parametrize("dt", [0.003, 0.03, 0.015, 0.0])
def test_probe_rejects_bit_duration_not_multiple_of_dt(dt: float) -> None:
    probe = Probe(order=4, bit_duration_s=0.02, amplitude_deg=0.5)
    with pytest.raises(ValueError, match="dt_s"):
        probe.samples(dt_s=dt)


def test_probe_float_multiple_is_accepted() -> None:
    # 0.03 / 0.01 is 2.9999999999999996 in floating point: still three steps per bit.
    assert Probe(5, 0.03, 1.0).steps_per_bit(0.01) == 3


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"order": 9, "bit_duration_s": 0.0, "amplitude_deg": 1.0}, "bit_duration_s"),
        ({"order": 9, "bit_duration_s": 0.01, "amplitude_deg": -1.0}, "amplitude_deg"),
        ({"order": 9, "bit_duration_s": 0.01, "amplitude_deg": float("nan")}, "amplitude_deg"),
        ({"order": 25, "bit_duration_s": 0.01, "amplitude_deg": 1.0}, "order"),
    ],
)
def test_probe_rejects_bad_parameters(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        Probe(**kwargs)


@pytest.mark.parametrize("order", range(MIN_ORDER, MAX_ORDER + 1))
def test_mls_equals_scipy_max_len_seq(order: int) -> None:
    """Our recurrence generator against SciPy's LFSR (default taps, all-ones state)."""
    from scipy.signal import max_len_seq

    bits, _ = max_len_seq(order)
    np.testing.assert_array_equal(mls(order), 1.0 - 2.0 * bits)
