"""Tests of probing.nonlinearities against independent truths.

Truths used: hand-derived closed forms (ramps, steps, the backlash parallelogram),
JSBSim's own flight-control components (an independent C++ implementation), the
paper's printed Fig. 4 values, and numerical two-level measurements through
``apply()`` for the closed-form apparent amplitudes.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import max_len_seq

from probing.core.nonlinearities import (
    Backlash,
    Deadband,
    HysteresisRelay,
    NoApparentFormError,
    Nonlinearity,
    RateLimit,
    Relay,
    Saturation,
    compensate,
)

DT = 0.01  # s


# ------------------------------------------------------------------- test signals
def _prbs_like(rng: np.random.Generator, n: int, max_run: int = 12) -> np.ndarray:
    """Piecewise-constant signal: random levels in [-1, 1] held for 1..max_run samples."""
    out = np.empty(0)
    while out.size < n:
        run = rng.integers(1, max_run + 1)
        out = np.concatenate((out, np.full(run, rng.uniform(-1.0, 1.0))))
    return out[:n]


def _smooth(rng: np.random.Generator, n: int) -> np.ndarray:
    """Sum of a few random sines, amplitude about 1."""
    t = np.arange(n) * DT
    freqs = rng.uniform(0.2, 3.0, size=4)
    phases = rng.uniform(0.0, 2.0 * np.pi, size=4)
    amps = rng.uniform(0.1, 0.4, size=4)
    return np.sum(amps[:, None] * np.sin(2 * np.pi * freqs[:, None] * t + phases[:, None]), axis=0)


N_CHUNK_TEST = 700
SIGNALS = {
    "prbs": _prbs_like(np.random.default_rng(1), N_CHUNK_TEST),
    "smooth": _smooth(np.random.default_rng(2), N_CHUNK_TEST),
}

ALL_NONLINEARITIES = [
    pytest.param(Deadband(-0.1, 0.3), id="deadband"),
    pytest.param(Saturation(-0.4, 0.25), id="saturation"),
    pytest.param(Relay(0.1, -0.5, 0.8), id="relay"),
    pytest.param(HysteresisRelay(-0.2, 0.3, -0.5, 0.8), id="hysteresis-relay"),
    pytest.param(Backlash(0.35), id="backlash"),
    pytest.param(RateLimit(3.0), id="rate-limit"),  # 0.03 per sample: long ramps
]


# ------------------------------------------------------- 1. chunked equals whole
def _chunked(nl: Nonlinearity, x: np.ndarray, cuts: list[int], dt: float = DT) -> np.ndarray:
    bounds = [0, *sorted(cuts), x.size]
    state = nl.initial_state()
    parts = []
    for lo, hi in itertools.pairwise(bounds):
        y, state = nl.process(x[lo:hi], dt, state)  # empty chunks included
        parts.append(y)
    return np.concatenate(parts)


@pytest.mark.parametrize("kind", sorted(SIGNALS))
@pytest.mark.parametrize("nl", ALL_NONLINEARITIES)
@settings(max_examples=40, deadline=None)
@given(cuts=st.lists(st.integers(0, N_CHUNK_TEST), max_size=15))
def test_chunked_equals_whole_hypothesis(nl, kind, cuts):
    x = SIGNALS[kind]
    whole = nl.apply(x, DT)
    assert whole.dtype == np.float64 and whole.shape == x.shape
    assert np.array_equal(_chunked(nl, x, cuts), whole)


@pytest.mark.parametrize("nl", ALL_NONLINEARITIES)
def test_chunked_equals_whole_seeded(nl):
    rng = np.random.default_rng(12345)
    x = np.concatenate((_prbs_like(rng, 3000, max_run=40), _smooth(rng, 1000)))
    whole = nl.apply(x, DT)
    for _ in range(50):
        cuts = rng.integers(0, x.size + 1, size=rng.integers(1, 40)).tolist()
        assert np.array_equal(_chunked(nl, x, cuts), whole)
    # one sample at a time: the plain sample-by-sample recursion
    assert np.array_equal(_chunked(nl, x[:800], list(range(1, 800))), whole[:800])


# ------------------------------------------------------------ 2. closed forms
def test_deadband_ramp():
    x = np.arange(-64, 65) / 32.0  # exact binary values from -2 to 2
    lower, upper = -0.25, 0.75
    expected = [v - upper if v > upper else (v - lower if v < lower else 0.0) for v in x]
    y = Deadband(lower, upper).apply(x, DT)
    assert np.array_equal(y, expected)
    # continuity at the edges, slope 1 outside the band
    assert y[x == upper][0] == 0.0 and y[x == lower][0] == 0.0
    assert np.all(np.diff(y[x >= upper]) == 1 / 32.0)
    assert np.all(np.diff(y[x <= lower]) == 1 / 32.0)


def test_saturation_values():
    x = np.array([-3.0, -0.5, -0.4, 0.0, 0.1, 0.25, 0.3, 2.0])
    y = Saturation(-0.4, 0.25).apply(x, DT)
    assert np.array_equal(y, [-0.4, -0.4, -0.4, 0.0, 0.1, 0.25, 0.25, 0.25])


def test_relay_threshold_midpoint():
    y = Relay(0.5, -1.0, 3.0).apply([0.4, 0.5, 0.6, 0.5, -7.0], DT)
    assert np.array_equal(y, [-1.0, 1.0, 3.0, 1.0, -1.0])  # midpoint (l+ + l-)/2 = 1


def test_hysteresis_relay_sequence():
    nl = HysteresisRelay(-0.5, 0.5, -1.0, 2.0)
    x = [0.0, 0.5, 0.6, 0.0, -0.5, -0.4, -0.6, 0.4, 0.5, 0.51]
    # strict switching: at a threshold exactly the output holds
    expected = [-1, -1, 2, 2, 2, 2, -1, -1, -1, 2]
    assert np.array_equal(nl.apply(x, DT), expected)


def test_hysteresis_relay_equal_thresholds_is_relay_off_threshold():
    x = SIGNALS["smooth"]
    assert not np.any(x == 0.2)
    assert np.array_equal(
        HysteresisRelay(0.2, 0.2, -1.0, 1.0).apply(x, DT), Relay(0.2, -1.0, 1.0).apply(x, DT)
    )


@pytest.mark.parametrize("target", [1.0, 0.9, -0.6])
def test_rate_limit_step_is_ramp(target):
    rate, dt = 32.0, 1.0 / 128.0  # 0.25 per sample, exact in binary
    x = np.full(12, target)
    y = RateLimit(rate).apply(x, dt)
    n_ramp = math.ceil(abs(target) / 0.25)  # the sample index where the target is reached
    ramp = math.copysign(0.25, target) * np.arange(1, n_ramp)
    assert np.array_equal(y[: n_ramp - 1], ramp)
    assert np.all(y[n_ramp - 1 :] == target)
    assert np.all(np.abs(np.diff(np.concatenate(([0.0], y)))) <= 0.25)


def test_rate_limit_reversal_and_fast_rate():
    rate, dt = 32.0, 1.0 / 128.0
    x = np.concatenate((np.full(3, 1.0), np.full(6, -0.5)))
    y = RateLimit(rate).apply(x, dt)
    assert np.array_equal(y, [0.25, 0.5, 0.75, 0.5, 0.25, 0.0, -0.25, -0.5, -0.5])
    # a rate far above anything the signal needs changes nothing
    z = SIGNALS["prbs"]
    assert np.array_equal(RateLimit(1e9).apply(z, DT), z)


def test_backlash_triangle_parallelogram():
    amp, w = 1.0, 0.5
    up = np.arange(-64, 65) / 64.0  # -1 .. 1, exact
    period = np.concatenate((up[1:], up[::-1][1:]))  # from -1 (excl.) up to 1 and down to -1
    x = np.concatenate((up[64:], up[::-1][1:], np.tile(period, 3)))  # 0 -> 1 -> -1, 3 cycles
    y = Backlash(w).apply(x, DT)
    # First quarter from rest: the output starts moving once x exceeds w/2.
    first = x[:65]
    assert np.array_equal(y[:65], np.maximum(0.0, first - w / 2))
    # Periodic part: the parallelogram with corners (+-1, +-(1 - w/2)), (+-(1 - w), ...).
    xs, ys = x[65:], y[65:]
    rising = np.concatenate(([False], np.diff(xs) > 0))
    falling = np.concatenate(([True], np.diff(xs) < 0))  # xs[0] continues the descent
    top, bottom = amp - w / 2, -amp + w / 2
    assert np.array_equal(ys[rising], np.maximum(bottom, xs[rising] - w / 2))
    assert np.array_equal(ys[falling], np.minimum(top, xs[falling] + w / 2))
    assert ys.max() == top and ys.min() == bottom


def test_backlash_zero_width_is_identity():
    x = SIGNALS["smooth"]
    assert np.array_equal(Backlash(0.0).apply(x, DT), x)


def test_rest_states():
    assert Backlash(0.3).apply([0.1, -0.1, 0.15], DT).tolist() == [0.0, 0.0, 0.0]
    assert HysteresisRelay(-0.3, 0.3, 5.0, 7.0).apply([0.0, 0.2], DT).tolist() == [5.0, 5.0]
    assert RateLimit(1.0).apply([0.0, 0.0], DT).tolist() == [0.0, 0.0]


def test_bad_signal_and_dt():
    with pytest.raises(ValueError, match="finite"):
        Backlash(0.1).apply([0.0, np.nan], DT)
    with pytest.raises(ValueError, match="1-D"):
        Saturation(-1, 1).apply(np.zeros((2, 2)), DT)
    with pytest.raises(ValueError, match="dt"):
        RateLimit(1.0).apply([0.0, 1.0], 0.0)


# ------------------------------------------------------------- 3. JSBSim oracle
JSB_DT = 0.01
JSB_DEADBAND_WIDTH = 0.4
JSB_RATE = 7.5  # 0.075 per step
JSB_HYSTERESIS_WIDTH = 0.6
JSB_SWITCH = (0.1, -0.25, 0.75)  # threshold, low (default), high (input GT threshold)
JSB_CLIP = (-0.3, 0.2)

_JSB_AIRCRAFT = """<?xml version="1.0"?>
<fdm_config name="nltest" version="2.0" release="ALPHA">
  <metrics>
    <wingarea unit="FT2">1</wingarea> <wingspan unit="FT">1</wingspan>
    <chord unit="FT">1</chord>
    <location name="AERORP" unit="IN"><x>0</x><y>0</y><z>0</z></location>
    <location name="EYEPOINT" unit="IN"><x>0</x><y>0</y><z>0</z></location>
    <location name="VRP" unit="IN"><x>0</x><y>0</y><z>0</z></location>
  </metrics>
  <mass_balance>
    <ixx unit="SLUG*FT2">10</ixx> <iyy unit="SLUG*FT2">10</iyy> <izz unit="SLUG*FT2">10</izz>
    <emptywt unit="LBS">100</emptywt>
    <location name="CG" unit="IN"><x>0</x><y>0</y><z>0</z></location>
  </mass_balance>
  <ground_reactions/>
  <propulsion/>
  <aerodynamics>
    <axis name="DRAG"><function name="aero/coefficient/CD"><value>0</value></function></axis>
  </aerodynamics>
  <system name="nonlinearities">
    <property value="0">test/input</property>
    <channel name="nonlinearities">
      <deadband name="test/deadband">
        <input>test/input</input> <width>{db}</width> <output>test/out-deadband</output>
      </deadband>
      <actuator name="test/rate-limit">
        <input>test/input</input> <rate_limit>{rate}</rate_limit>
        <output>test/out-rate-limit</output>
      </actuator>
      <actuator name="test/backlash">
        <input>test/input</input> <hysteresis_width>{hyst}</hysteresis_width>
        <output>test/out-backlash</output>
      </actuator>
      <switch name="test/relay">
        <default value="{low}"/>
        <test value="{high}">test/input GT {threshold}</test>
        <output>test/out-relay</output>
      </switch>
      <pure_gain name="test/saturation">
        <input>test/input</input> <gain>1.0</gain>
        <clipto><min>{cmin}</min><max>{cmax}</max></clipto>
        <output>test/out-saturation</output>
      </pure_gain>
    </channel>
  </system>
</fdm_config>
"""

_JSB_OUTPUTS = ("deadband", "rate-limit", "backlash", "relay", "saturation")


def _jsbsim_signal() -> np.ndarray:
    rng = np.random.default_rng(2024)
    x = np.concatenate((_prbs_like(rng, 1200, max_run=25), _smooth(rng, 600)))
    x[0] = 0.9  # a nonzero first input: the rate limit must act from the first step
    assert not np.any(x == JSB_SWITCH[0])  # the switch has no midpoint
    return x


@pytest.fixture(scope="module")
def jsbsim_run(tmp_path_factory):
    """Feed one signal through JSBSim's components, one value per step."""
    jsbsim = pytest.importorskip("jsbsim")
    root = tmp_path_factory.mktemp("jsbsim_root")
    acdir = root / "aircraft" / "nltest"
    acdir.mkdir(parents=True)
    threshold, low, high = JSB_SWITCH
    (acdir / "nltest.xml").write_text(
        _JSB_AIRCRAFT.format(
            db=JSB_DEADBAND_WIDTH,
            rate=JSB_RATE,
            hyst=JSB_HYSTERESIS_WIDTH,
            low=low,
            high=high,
            threshold=threshold,
            cmin=JSB_CLIP[0],
            cmax=JSB_CLIP[1],
        )
    )
    fdm = jsbsim.FGFDMExec(str(root))
    fdm.set_debug_level(0)
    # FCS components cache the channel dt when the model is loaded: set dt first.
    fdm.set_dt(JSB_DT)
    assert fdm.load_model("nltest")
    fdm["ic/h-sl-ft"] = 10000.0
    assert fdm.run_ic()
    x = _jsbsim_signal()
    out = {name: np.empty(x.size) for name in _JSB_OUTPUTS}
    for k, v in enumerate(x):
        fdm["test/input"] = float(v)
        fdm.run()
        for name in _JSB_OUTPUTS:
            out[name][k] = fdm[f"test/out-{name}"]
    return x, out


@pytest.mark.jsbsim
def test_jsbsim_deadband(jsbsim_run):
    x, out = jsbsim_run
    half = JSB_DEADBAND_WIDTH / 2
    ours = Deadband(-half, half).apply(x, JSB_DT)
    # Same sample: a property set before run() is seen by the component in that step.
    assert np.array_equal(out["deadband"], ours)
    assert np.count_nonzero(ours) > 100 and np.count_nonzero(ours == 0) > 100


@pytest.mark.jsbsim
def test_jsbsim_saturation(jsbsim_run):
    x, out = jsbsim_run
    ours = Saturation(*JSB_CLIP).apply(x, JSB_DT)
    assert np.array_equal(out["saturation"], ours)
    # the comparison is sensitive to a one-step shift
    assert not np.allclose(out["saturation"][1:], ours[:-1])


@pytest.mark.jsbsim
def test_jsbsim_relay(jsbsim_run):
    x, out = jsbsim_run
    assert np.array_equal(out["relay"], Relay(*JSB_SWITCH).apply(x, JSB_DT))


@pytest.mark.jsbsim
def test_jsbsim_backlash(jsbsim_run):
    x, out = jsbsim_run
    ours = Backlash(JSB_HYSTERESIS_WIDTH).apply(x, JSB_DT)
    assert np.array_equal(out["backlash"], ours)
    # the play is really exercised: the output holds while the input moves
    held = (np.diff(ours) == 0) & (np.diff(x) != 0)
    assert np.count_nonzero(held) > 100


@pytest.mark.jsbsim
def test_jsbsim_rate_limit(jsbsim_run):
    x, out = jsbsim_run
    ours = RateLimit(JSB_RATE).apply(x, JSB_DT)
    # JSBSim sums the steps one by one, we evaluate a ramp in closed form: rounding only.
    np.testing.assert_allclose(out["rate-limit"], ours, rtol=0, atol=1e-12)
    assert out["rate-limit"][0] == pytest.approx(JSB_RATE * JSB_DT)  # limited from step 1
    steps = np.abs(np.diff(ours))
    assert np.count_nonzero(np.isclose(steps, JSB_RATE * JSB_DT)) > 100  # ramps happen


# ----------------------------------------- 4. apparent() vs two-level measurement
A = 1.0
_RUNS = [3, 4, 2, 1, 5, 2, 3, 1, 1, 4, 2, 2]  # starts at +a, then -a, +a, ...


def _measure(nl: Nonlinearity, a: float) -> tuple[float, float]:
    """(a~, b~) measured through apply() with a +-a two-level probe."""
    levels = [a if i % 2 == 0 else -a for i in range(len(_RUNS))]
    x = np.concatenate([np.full(n, v) for n, v in zip(_RUNS, levels, strict=True)])
    y = nl.apply(x, DT)
    first_down = np.flatnonzero((x[:-1] > 0) & (x[1:] < 0))[0] + 1
    first_up = np.flatnonzero((x[:-1] < 0) & (x[1:] > 0))[0] + 1
    settled = max(first_down, first_up)
    q_plus = y[settled:][x[settled:] > 0]
    q_minus = y[settled:][x[settled:] < 0]
    assert q_plus.size and q_minus.size
    assert np.ptp(q_plus) == 0 and np.ptp(q_minus) == 0, "not a two-level output"
    return (q_plus[0] - q_minus[0]) / 2, (q_plus[0] + q_minus[0]) / 2


# Deadband case a ("d+ < -a or d- > a") cannot happen: the class enforces
# d- <= 0 <= d+, so d+ >= 0 > -a and d- <= 0 < a.
APPARENT_CASES = [
    pytest.param(Deadband(-0.25, 0.25), id="deadband-b-symmetric"),
    pytest.param(Deadband(0.0, 0.0), id="deadband-b-zero-width"),
    pytest.param(Deadband(-0.1, 0.3), id="deadband-c"),
    pytest.param(Deadband(-0.2, 1.5), id="deadband-d"),
    pytest.param(Deadband(-0.2, 1.0), id="deadband-d-edge-upper-eq-a"),
    pytest.param(Deadband(-1.5, 0.2), id="deadband-e"),
    pytest.param(Deadband(-1.0, 0.2), id="deadband-e-edge-lower-eq-minus-a"),
    pytest.param(Deadband(-1.5, 2.0), id="deadband-f"),
    pytest.param(Saturation(-2.0, 3.0), id="saturation-a"),
    pytest.param(Saturation(-0.3, 0.6), id="saturation-b"),
    pytest.param(Saturation(-0.4, 2.0), id="saturation-c"),
    pytest.param(Saturation(-2.0, 0.5), id="saturation-d"),
    pytest.param(Saturation(-2.0, 0.0), id="saturation-d-fig4b"),
    pytest.param(Saturation(-1.0, 1.0), id="saturation-a-edges"),
    pytest.param(Saturation(1.5, 2.0), id="saturation-e-above"),
    pytest.param(Saturation(-3.0, -1.5), id="saturation-e-below"),
    pytest.param(Saturation(0.2, 0.2), id="saturation-b-degenerate"),
    pytest.param(Relay(0.3, -0.5, 2.0), id="relay-inside"),
    pytest.param(Relay(-0.9, -0.5, 2.0), id="relay-inside-negative"),
    pytest.param(Relay(1.5, -0.5, 2.0), id="relay-above"),
    pytest.param(Relay(-1.5, -0.5, 2.0), id="relay-below"),
    pytest.param(Relay(1.0, -0.5, 2.0), id="relay-at-plus-a"),
    pytest.param(Relay(-1.0, -0.5, 2.0), id="relay-at-minus-a"),
    pytest.param(HysteresisRelay(-0.3, 0.5, -1.0, 2.0), id="hysteresis-inside"),
    pytest.param(HysteresisRelay(-0.3, 1.5, -1.0, 2.0), id="hysteresis-upper-outside"),
    pytest.param(HysteresisRelay(-1.5, 0.5, -1.0, 2.0), id="hysteresis-lower-outside"),
    pytest.param(HysteresisRelay(-1.5, 1.5, -1.0, 2.0), id="hysteresis-both-outside"),
    pytest.param(HysteresisRelay(1.2, 1.5, -1.0, 2.0), id="hysteresis-both-above"),
    pytest.param(HysteresisRelay(-1.5, -1.2, -1.0, 2.0), id="hysteresis-both-below"),
    pytest.param(HysteresisRelay(-0.3, 1.0, -1.0, 2.0), id="hysteresis-upper-eq-a"),
    pytest.param(HysteresisRelay(-1.0, 0.3, -1.0, 2.0), id="hysteresis-lower-eq-minus-a"),
    pytest.param(Backlash(0.5), id="backlash-w-lt-2a"),
    pytest.param(Backlash(2.0), id="backlash-w-eq-2a"),
    pytest.param(Backlash(3.0), id="backlash-w-gt-2a"),
    pytest.param(Backlash(0.0), id="backlash-zero"),
]


@pytest.mark.parametrize("amplitude", [A, 0.5 * A])
@pytest.mark.parametrize("nl", APPARENT_CASES)
def test_apparent_matches_measurement(nl, amplitude):
    a_meas, b_meas = _measure(nl, amplitude)
    a_t, b_t = nl.apparent(amplitude)
    assert a_t == pytest.approx(a_meas, rel=1e-12, abs=1e-15)
    assert b_t == pytest.approx(b_meas, rel=1e-12, abs=1e-15)


@pytest.mark.parametrize(
    ("nl", "expected"),
    [
        # Fig. 4a: symmetric deadband d+ = -d- = a/3 gives a~ = 2a/3, b~ = 0
        pytest.param(Deadband(-0.5 / 3, 0.5 / 3), (0.5 * 2 / 3, 0.0), id="fig4a-deadband"),
        # Fig. 4b: U+ = 0, U- < -a gives a~ = a/2, b~ = -a/2
        pytest.param(Saturation(-1.0, 0.0), (0.25, -0.25), id="fig4b-saturation"),
        # docs/fig4.md: backlash b_l = a/2 gives a~ = 3a/4
        pytest.param(Backlash(0.25), (0.375, 0.0), id="notes-backlash"),
        # docs/fig4.md: relay levels +-a/2 about S = 0
        pytest.param(Relay(0.0, -0.25, 0.25), (0.25, 0.0), id="notes-relay"),
        # eqs. (14)-(15) with d+ = 0.2, d- = -0.1
        pytest.param(Deadband(-0.1, 0.2), (0.5 - 0.1 - 0.05, -0.05), id="eq14-15"),
    ],
)
def test_apparent_paper_values(nl, expected):
    assert nl.apparent(0.5) == pytest.approx(expected, rel=1e-12, abs=1e-15)


def test_rate_limit_has_no_apparent_form():
    nl = RateLimit(1.0)
    with pytest.raises(TypeError, match="apparent"):
        nl.apparent(0.5)
    with pytest.raises(NoApparentFormError):
        nl.apparent(0.5)


def test_rate_limit_bound():
    a, t0 = 0.005, 0.010  # the paper's Fig. 4 probe: 2a/t0 = 1 deg/s
    assert RateLimit.bound(a, t0) == pytest.approx(1.0)
    assert RateLimit(1.0).admits(a, t0)
    assert not RateLimit(0.99).admits(a, t0)
    assert RateLimit(2.0).admits(a, t0)


def test_rate_limit_at_bound_passes_probe_within_one_bit():
    """At r_l = 2a/t0 the output reaches the new level by the end of each bit."""
    a, samples_per_bit = 0.5, 4
    t0 = samples_per_bit * DT
    sigma = 2.0 * max_len_seq(5)[0] - 1.0
    x = np.repeat(a * np.tile(sigma, 2), samples_per_bit)
    end_of_bit = np.arange(samples_per_bit - 1, x.size, samples_per_bit)
    y_ok = RateLimit(RateLimit.bound(a, t0)).apply(x, DT)
    np.testing.assert_allclose(y_ok[end_of_bit], x[end_of_bit], rtol=0, atol=1e-12)
    y_slow = RateLimit(0.9 * RateLimit.bound(a, t0)).apply(x, DT)
    assert np.max(np.abs(y_slow[end_of_bit] - x[end_of_bit])) > 0.05


# ---------------------------------------------------------------- 5. compensation
def _mseq(order: int) -> np.ndarray:
    """+-1 m-sequence of length 2**order - 1 (scipy's LFSR)."""
    return 2.0 * max_len_seq(order)[0] - 1.0


def _fir(m: int) -> np.ndarray:
    k = np.arange(m)
    return 0.8**k * np.cos(0.3 * k) + 0.02  # nonzero DC sum


def _correlate_period(y: np.ndarray, sigma: np.ndarray, start: int) -> np.ndarray:
    """z[k] = sum_j y[k-M+1+j] sigma[j] for k = start .. start+M-1 (eq. 5)."""
    m = sigma.size
    return np.array([y[k - m + 1 : k + 1] @ sigma for k in range(start, start + m)])


@pytest.fixture(scope="module", params=[5, 7], ids=["M31", "M127"])
def probe_setup(request):
    sigma = _mseq(request.param)
    m = sigma.size
    h = _fir(m)
    a = 0.5
    p1 = a * sigma
    # ideal: cyclic convolution and cyclic correlation over one period
    y_cyc = np.array([sum(h[j] * p1[(k - j) % m] for j in range(m)) for k in range(m)])
    z_ideal = np.array(
        [sum(y_cyc[(k - m + 1 + j) % m] * sigma[j] for j in range(m)) for k in range(m)]
    )
    # the harness agrees with eq. (8), with tap (k+1) mod M at sample k
    s = h.sum()
    assert abs(s) > 0.1
    np.testing.assert_allclose(z_ideal, a * ((m + 1) * np.roll(h, -1) - s), rtol=0, atol=1e-12)
    return sigma, h, a, z_ideal


COMPENSATION_CASES = [
    pytest.param(Deadband(-0.1, 0.2), id="deadband-c"),
    pytest.param(Deadband(-0.2, 0.7), id="deadband-d"),
    pytest.param(Deadband(-0.6, 0.1), id="deadband-e"),
    pytest.param(Saturation(-0.3, 0.2), id="saturation-b"),
    pytest.param(Saturation(-1.0, 0.0), id="saturation-d-fig4b"),
    pytest.param(Saturation(-0.1, 1.0), id="saturation-c"),
    pytest.param(Relay(0.1, -0.2, 0.9), id="relay"),
    pytest.param(HysteresisRelay(-0.2, 0.3, -0.4, 0.6), id="hysteresis-relay"),
    pytest.param(Backlash(0.4), id="backlash"),
]


@pytest.mark.parametrize("nl", COMPENSATION_CASES)
def test_compensation_recovers_linear_output(nl, probe_setup):
    sigma, h, a, z_ideal = probe_setup
    m = sigma.size
    periods = 5
    p = a * np.tile(sigma, periods)
    q = nl.apply(p, DT)
    y = np.convolve(q, h)[: p.size]  # plant from rest
    z3 = _correlate_period(y, sigma, 3 * m)  # settled periods
    z4 = _correlate_period(y, sigma, 4 * m)
    a_t, b_t = nl.apparent(a)
    assert not np.allclose(z3, z_ideal, rtol=1e-3)  # the nonlinearity does change z
    scale = np.max(np.abs(z_ideal))
    np.testing.assert_allclose(compensate(z3, nl, a), z_ideal, rtol=0, atol=1e-9 * scale)
    both = compensate(np.stack((z3, z4)), nl, a)
    assert both.shape == (2, m)
    np.testing.assert_allclose(both, np.stack((z_ideal, z_ideal)), rtol=0, atol=1e-9 * scale)
    if b_t != 0.0:  # plain rescaling by a/a~ is not enough when there is an offset
        assert not np.allclose(z3 * a / a_t, z_ideal, rtol=0, atol=1e-6 * scale)


def test_compensate_rejects_zero_apparent_amplitude():
    z = np.ones(31)
    with pytest.raises(ValueError, match="a~ = 0"):
        compensate(z, Deadband(-1.0, 1.0), 0.5)  # probe inside the band
    with pytest.raises(ValueError, match="a~ = 0"):
        compensate(z, Relay(0.7, -1.0, 1.0), 0.5)
    with pytest.raises(ValueError, match="a~ = 0"):
        compensate(z, Backlash(1.0), 0.5)


def test_compensate_rejects_singular_period_sum():
    # a~ = 1.5, b~ = -0.5 and M = 3: a~ + M b~ = 0
    nl = Relay(0.0, -2.0, 1.0)
    assert nl.apparent(1.0) == (1.5, -0.5)
    with pytest.raises(ValueError, match=r"a~ \+ M b~ = 0"):
        compensate(np.array([1.0, 2.0, 3.0]), nl, 1.0)


def test_compensate_rate_limit_is_type_error():
    with pytest.raises(TypeError):
        compensate(np.ones(7), RateLimit(1.0), 0.5)


# ----------------------------------------------------------- 6. invalid parameters
nan, inf = float("nan"), float("inf")


@pytest.mark.parametrize(
    ("factory", "pattern"),
    [
        pytest.param(
            lambda: Deadband(0.2, 0.1),
            r"Deadband: lower \(0.2\) must be <= upper \(0.1\)",
            id="deadband-lower-gt-upper",
        ),
        pytest.param(lambda: Deadband(0.1, 0.3), r"Deadband: lower \(", id="deadband-lower-pos"),
        pytest.param(lambda: Deadband(-0.3, -0.1), r"Deadband: upper \(", id="deadband-upper-neg"),
        pytest.param(lambda: Deadband(nan, 0.1), r"Deadband: lower \(nan", id="deadband-nan"),
        pytest.param(lambda: Deadband(-0.1, inf), r"Deadband: upper \(inf", id="deadband-inf"),
        pytest.param(lambda: Saturation(1.0, 0.0), r"Saturation: lower \(", id="sat-order"),
        pytest.param(lambda: Saturation(nan, 1.0), r"Saturation: lower \(", id="sat-nan-lower"),
        pytest.param(lambda: Saturation(0.0, nan), r"Saturation: upper \(", id="sat-nan-upper"),
        pytest.param(lambda: Saturation(-inf, 1.0), r"Saturation: lower \(", id="sat-inf"),
        pytest.param(lambda: Relay(nan, 0.0, 1.0), r"Relay: threshold \(", id="relay-nan-s"),
        pytest.param(lambda: Relay(0.0, inf, 1.0), r"Relay: low \(", id="relay-inf-low"),
        pytest.param(lambda: Relay(0.0, 0.0, nan), r"Relay: high \(", id="relay-nan-high"),
        pytest.param(
            lambda: HysteresisRelay(0.5, 0.1, 0.0, 1.0),
            r"HysteresisRelay: lower_threshold \(0.5\) must be <= upper_threshold \(0.1\)",
            id="hyst-order",
        ),
        pytest.param(
            lambda: HysteresisRelay(0.0, nan, 0.0, 1.0),
            r"HysteresisRelay: upper_threshold \(",
            id="hyst-nan-upper",
        ),
        pytest.param(
            lambda: HysteresisRelay(0.0, 0.1, nan, 1.0),
            r"HysteresisRelay: low \(",
            id="hyst-nan-low",
        ),
        pytest.param(lambda: Backlash(-0.1), r"Backlash: width \(-0.1\)", id="backlash-neg"),
        pytest.param(lambda: Backlash(nan), r"Backlash: width \(nan", id="backlash-nan"),
        pytest.param(lambda: RateLimit(0.0), r"RateLimit: rate \(0.0\)", id="rate-zero"),
        pytest.param(lambda: RateLimit(-1.0), r"RateLimit: rate \(", id="rate-neg"),
        pytest.param(lambda: RateLimit(nan), r"RateLimit: rate \(nan", id="rate-nan"),
        pytest.param(lambda: RateLimit(inf), r"RateLimit: rate \(inf", id="rate-inf"),
    ],
)
def test_invalid_parameters(factory, pattern):
    with pytest.raises(ValueError, match=pattern):
        factory()


@pytest.mark.parametrize("bad", [0.0, -1.0, nan, inf])
def test_invalid_amplitude(bad):
    with pytest.raises(ValueError, match="amplitude"):
        Saturation(-1.0, 1.0).apparent(bad)
    with pytest.raises(ValueError):
        RateLimit.bound(bad, 0.01)


def test_frozen_and_float_parameters():
    nl = Deadband(-1, 2)
    assert isinstance(nl.lower, float) and nl.lower == -1.0
    with pytest.raises(AttributeError):
        nl.lower = 0.0  # type: ignore[misc]
