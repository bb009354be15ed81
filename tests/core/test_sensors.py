"""probing.core.sensors: the sensor's arithmetic, its bounds, the suites and NASA's numbers.

The comparison with JSBSim's own ``<sensor>`` is tests/sim/test_sensors_jsbsim.py.
"""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest

from probing.core.sensors import (
    SENSOR_SUITES,
    Sensor,
    SensorSpec,
    SensorSpecError,
    SensorSuite,
)

NASA_FILE = Path("/work/shared/gtm/nasa/NoiseParams_T2.m")
DT_S = 0.005


def random_spec(rng: np.random.Generator) -> SensorSpec:
    return SensorSpec(
        noise_sigma=float(rng.choice([0.0, rng.uniform(0.0, 0.5)])),
        bias=float(rng.uniform(-2, 2)),
        scale=float(rng.choice([-1.0, 1.0]) * rng.uniform(0.2, 3.0)),
        lag_rad_s=float(rng.choice([0.0, rng.uniform(0.1, 150.0)])),
        rate_hz=float(rng.choice([0.0, 200.0, 100.0, 50.0, 40.0, 1.0 / (7 * DT_S)])),
        quantum=float(rng.choice([0.0, rng.uniform(0.001, 0.3)])),
    )


@pytest.mark.parametrize("seed", range(40))
def test_run_is_step_bit_for_bit(seed: int) -> None:
    """Every kind of sensor (40 random specs: with and without lag, noise, quantum, a
    sample every step or fewer)."""
    rng = np.random.default_rng(seed)
    spec = random_spec(rng)
    n = 500
    values = np.cumsum(rng.standard_normal(n)) * 0.1
    noise = rng.standard_normal(n)
    x0 = float(rng.uniform(-1, 1))
    by_run, by_step = Sensor(spec, DT_S), Sensor(spec, DT_S)
    by_run.reset(x0)
    by_step.reset(x0)
    ran = by_run.run(values, noise)
    stepped = np.array(
        [by_step.step(float(v), float(e)) for v, e in zip(values, noise, strict=True)]
    )
    assert ran.dtype == np.float64
    assert np.array_equal(ran, stepped)
    # and the state after: the next steps agree too
    assert by_run.step(0.3, 0.1) == by_step.step(0.3, 0.1)


@pytest.mark.parametrize(
    "spec",
    [
        SensorSpec(),
        SensorSpec(bias=0.5, scale=2.0),
        SensorSpec(lag_rad_s=12.0, bias=-0.1, scale=0.9),
        SensorSpec(lag_rad_s=500.0, rate_hz=40.0, bias=0.2, scale=-1.3),  # cb < 0
    ],
)
def test_reset_starts_in_steady_state(spec: SensorSpec) -> None:
    x = 1.7
    sensor = Sensor(spec, DT_S)
    sensor.reset(x)
    out = sensor.run(np.full(400, x), np.zeros(400))
    assert out == pytest.approx(np.full(400, spec.scale * x + spec.bias), rel=1e-13)


def test_lag_settles_like_a_first_order_lag() -> None:
    """Independent of the Tustin form: the step response of lag/(s + lag) sampled at the
    step times is 1 - exp(-lag t), to the bilinear rule's small error."""
    lag = 4.0
    sensor = Sensor(SensorSpec(lag_rad_s=lag), DT_S)
    out = sensor.run(np.ones(600), np.zeros(600))
    t = (np.arange(600) + 0.5) * DT_S  # Tustin's half-step shift of a step's first sample
    np.testing.assert_allclose(out, 1.0 - np.exp(-lag * t), atol=1e-4)


def test_hold_and_sample_phase() -> None:
    """A frame of 4 steps: samples on steps 3, 7, ... after reset; only their noise
    draws count, and the gain multiplies the noise (JSBSim's order)."""
    spec = SensorSpec(noise_sigma=0.5, scale=2.0, bias=1.0, rate_hz=50.0)
    sensor = Sensor(spec, DT_S)
    assert sensor.frame == 4 and sensor.lag_dt_s == pytest.approx(4 * DT_S)
    values = np.arange(12, dtype=float)
    noise = np.zeros(12)
    noise[[3, 7, 11]] = 1.0
    out = sensor.run(values, noise)
    sampled = 2.0 * (values + 0.5) + 1.0
    expected = [1.0] * 3 + [sampled[3]] * 4 + [sampled[7]] * 4 + [sampled[11]]
    assert out.tolist() == expected
    other = noise.copy()
    other[[0, 1, 2, 4, 5, 6, 8, 9, 10]] = 100.0  # draws on held steps are discarded
    sensor.reset(0.0)
    assert sensor.run(values, other).tolist() == expected


@pytest.mark.parametrize("seed", range(16))
def test_run_without_lag_sampling_every_step_is_step_bit_for_bit(seed: int) -> None:
    """``run``'s vectorised path (no lag, a sample every step, as NASA's T2 sensors): the
    floats of :meth:`Sensor.step`, chunk after chunk, and its state after."""
    rng = np.random.default_rng(100 + seed)
    spec = dataclasses.replace(random_spec(rng), lag_rad_s=0.0, rate_hz=0.0)
    values = np.cumsum(rng.standard_normal(300)) * 0.1
    noise = rng.standard_normal(300)
    by_run, by_step = Sensor(spec, DT_S), Sensor(spec, DT_S)
    ran = np.concatenate(
        [by_run.run(values[:120], noise[:120]), by_run.run(values[120:], noise[120:])]
    )
    stepped = [by_step.step(v, e) for v, e in zip(values.tolist(), noise.tolist(), strict=True)]
    assert ran.tolist() == stepped
    assert by_run.output == by_step.output
    assert by_run.step(0.3, 0.1) == by_step.step(0.3, 0.1)


def test_quantum_truncates_like_jsbsim() -> None:
    sensor = Sensor(SensorSpec(quantum=0.25), DT_S)
    out = sensor.run(np.array([0.0, 0.24, 0.25, 0.26, -0.01, -0.25, 1.99]), np.zeros(7))
    assert out.tolist() == [0.0, 0.0, 0.25, 0.25, -0.25, -0.25, 1.75]


@pytest.mark.parametrize(("rate", "frame"), [(0.0, 1), (200.0, 1), (100.0, 2), (50.0, 4)])
def test_rates_that_divide(rate: float, frame: int) -> None:
    assert Sensor(SensorSpec(rate_hz=rate), DT_S).frame == frame


def test_rate_with_rounding_error_is_accepted() -> None:
    assert Sensor(SensorSpec(rate_hz=1.0 / (3 * DT_S)), DT_S).frame == 3
    assert Sensor(SensorSpec(rate_hz=60.0), 1.0 / 120.0).frame == 2


@pytest.mark.parametrize("rate", [30.0, 75.0, 199.0, 200.0001, 201.0, 1000.0])
def test_rates_that_do_not_divide_or_are_too_fast_are_refused(rate: float) -> None:
    with pytest.raises(ValueError, match=r"rate_hz .* whole N >= 1") as info:
        Sensor(SensorSpec(rate_hz=rate), DT_S)
    assert isinstance(info.value, SensorSpecError) and info.value.field == "rate_hz"


@pytest.mark.parametrize("dt", [0.0, -0.01, math.nan, math.inf])
def test_bad_step_is_refused(dt: float) -> None:
    with pytest.raises(SensorSpecError, match="dt_s"):
        Sensor(SensorSpec(), dt)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("noise_sigma", -0.1),
        ("lag_rad_s", -1.0),
        ("rate_hz", -50.0),
        ("quantum", -0.01),
        ("scale", 0.0),
        ("bias", math.nan),
        ("scale", math.inf),
        ("noise_sigma", True),
        ("bias", "1"),
    ],
)
def test_spec_bounds(field: str, value: object) -> None:
    with pytest.raises(SensorSpecError, match=field) as info:
        SensorSpec(**{field: value})  # type: ignore[arg-type]
    assert info.value.field == field


def test_spec_edges_accepted() -> None:
    spec = SensorSpec(noise_sigma=0.0, scale=-1e-9, lag_rad_s=0.0, rate_hz=0.0, quantum=0.0)
    assert spec.to_dict() == {
        "noise_sigma": 0.0,
        "bias": 0.0,
        "scale": -1e-9,
        "lag_rad_s": 0.0,
        "rate_hz": 0.0,
        "quantum": 0.0,
    }
    assert spec.replace(bias=2).bias == 2.0 and spec.bias == 0.0
    with pytest.raises(SensorSpecError, match="'gain'") as info:
        spec.replace(gain=2.0)
    assert info.value.field == "gain"
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.bias = 1.0  # type: ignore[misc]


def test_run_refuses_misaligned_noise() -> None:
    with pytest.raises(ValueError, match="one length"):
        Sensor(SensorSpec(), DT_S).run(np.zeros(5), np.zeros(4))


def test_overrides() -> None:
    suite = SENSOR_SUITES["nasa_t2"]
    changed = suite.with_overrides({"theta_rad": {"bias": 0.0, "rate_hz": 50.0}})
    assert changed.sensors["theta_rad"].bias == 0.0
    assert changed.sensors["theta_rad"].rate_hz == 50.0
    assert changed.sensors["theta_rad"].noise_sigma == suite.sensors["theta_rad"].noise_sigma
    assert suite.sensors["theta_rad"].bias == math.radians(-0.09)  # the original is kept
    assert {k: v for k, v in changed.sensors.items() if k != "theta_rad"} == {
        k: v for k, v in suite.sensors.items() if k != "theta_rad"
    }
    with pytest.raises(SensorSpecError, match="'tehta_rad'") as info:
        suite.with_overrides({"tehta_rad": {"bias": 0.0}})
    assert info.value.field == "tehta_rad"
    with pytest.raises(SensorSpecError, match=r"'theta_rad'.*'sigma'") as info:
        suite.with_overrides({"theta_rad": {"sigma": 0.0}})
    assert info.value.field == "sigma"
    with pytest.raises(SensorSpecError, match=r"'q_rad_s'.*noise_sigma") as info:
        suite.with_overrides({"q_rad_s": {"noise_sigma": -1.0}})
    assert info.value.field == "noise_sigma"


def test_suite_is_read_only() -> None:
    suite = SensorSuite("x", {"a": SensorSpec(bias=1.0)}, "test")
    with pytest.raises(TypeError):
        suite.sensors["b"] = SensorSpec()  # type: ignore[index]
    with pytest.raises(TypeError):
        SensorSuite("x", {"a": 1.0}, "test")  # type: ignore[dict-item]


# ---- NASA's T2 numbers, read from NASA's file -------------------------------------------

DEG = math.pi / 180.0
KT = 0.514444444444444444 / 0.3048  # ft/s per kt: 1852 m / 3600 s
#: channel -> (NASA's sensor in NoiseParams_T2.m, factor to the channel's unit)
NASA_MAP = {
    "alpha_rad": ("alpha", DEG),
    "beta_rad": ("beta", DEG),
    "vt_fps": ("KTAS", KT),
    "h_ft": ("baro_alt", 1.0),
    "phi_rad": ("MIDG.phi", DEG),
    "theta_rad": ("MIDG.theta", DEG),
    "psi_rad": ("MIDG.psi", DEG),
    "p_rad_s": ("MIDG.pdeg", DEG),
    "q_rad_s": ("MIDG.qdeg", DEG),
    "r_rad_s": ("MIDG.rdeg", DEG),
    "nx_g": ("MIDG.nxbody", 1.0),
    "ny_g": ("MIDG.nybody", 1.0),
    "nz_g": ("MIDG.nzbody", 1.0),
    "elevator_deg": ("pots", 1.0),
    "aileron_deg": ("pots", 1.0),
    "rudder_deg": ("pots", 1.0),
}


@pytest.fixture(scope="module")
def nasa() -> dict[str, float]:
    """``{"MIDG.theta.Bias": -0.09, ...}`` from NASA's file."""
    if not NASA_FILE.exists():
        pytest.skip(f"{NASA_FILE} is absent")
    pattern = re.compile(r"^MWS\.SensorNoise\.([\w.]+)\.(Std|Bias|Scf)\s*=\s*([-+0-9.eE]+)\s*;")
    values = {}
    for line in NASA_FILE.read_text().splitlines():
        m = pattern.match(line.strip())
        if m:
            values[f"{m[1]}.{m[2]}"] = float(m[3])
    assert len(values) > 60
    return values


def test_nasa_spot_values(nasa: dict[str, float]) -> None:
    t2 = SENSOR_SUITES["nasa_t2"].sensors
    assert nasa["MIDG.theta.Bias"] == -0.09
    assert t2["theta_rad"].bias == pytest.approx(-0.09 * math.pi / 180, rel=1e-15)
    assert nasa["KTAS.Std"] == 0.06 and nasa["KTAS.Bias"] == 0.07
    assert t2["vt_fps"].noise_sigma == pytest.approx(0.06 * 1.6878098571011957, rel=1e-15)
    assert t2["vt_fps"].bias == pytest.approx(0.07 * 1.6878098571011957, rel=1e-15)
    assert t2["h_ft"].noise_sigma == nasa["baro_alt.Std"] == 2.36


def test_every_nasa_number(nasa: dict[str, float]) -> None:
    t2 = SENSOR_SUITES["nasa_t2"].sensors
    for channel, (sensor, factor) in NASA_MAP.items():
        spec = t2[channel]
        assert spec.noise_sigma == pytest.approx(nasa[f"{sensor}.Std"] * factor, rel=1e-14)
        assert spec.bias == pytest.approx(nasa[f"{sensor}.Bias"] * factor, rel=1e-14, abs=0)
        assert spec.scale == nasa[f"{sensor}.Scf"] == 1.0
        assert spec.lag_rad_s == spec.rate_hz == spec.quantum == 0.0  # NASA gives none
    # MIDG, not MAG3: their numbers differ
    assert t2["p_rad_s"].bias != pytest.approx(nasa["MAG3.pdeg.Bias"] * DEG)


def test_assumed_ins_velocities_are_marked() -> None:
    suite = SENSOR_SUITES["nasa_t2"]
    assert set(suite.sensors) == {*NASA_MAP, "v_north_fps", "v_east_fps", "v_down_fps"}
    for ch in ("v_north_fps", "v_east_fps", "v_down_fps"):
        assert suite.sensors[ch] == SensorSpec(noise_sigma=0.05 / 0.3048)
    assert "NOT NASA" in suite.source and "0.05 m/s" in suite.source


def test_a_suite_pickles_to_an_equal_suite():
    """Scenarios with sensors cross to a sweep's worker processes by pickle."""
    import pickle

    suite = SENSOR_SUITES["nasa_t2"].with_overrides({"theta_rad": {"bias": 0.5}})
    again = pickle.loads(pickle.dumps(suite))
    assert again == suite and dict(again.sensors) == dict(suite.sensors)
