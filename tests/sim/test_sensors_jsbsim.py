"""probing.core.sensors against JSBSim's own ``<sensor>`` component.

A bare aircraft (the mass of JSBSim's ``tests/tripod.xml``, nothing else) is written into a
temporary root with one ``<system>``: a channel that runs every step and one with
``execrate="4"``, each with sensors reading ``test/input``.  The test sets ``test/input``
before every ``fdm.run()`` and reads each sensor's property after it; :class:`Sensor`
gets the same inputs and must give the same outputs, to 1e-12.  The input starts at 0, so
JSBSim's zero initial lag state is :meth:`Sensor.reset` (0.0) (``run_ic`` runs the channels
once with input 0: lag state 0, output ``bias``).

The step's time is set before the model is loaded: JSBSim computes a sensor's lag
coefficients from the step when it builds the component.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from probing.core.sensors import Sensor, SensorSpec

jsbsim = pytest.importorskip("jsbsim")
pytestmark = pytest.mark.jsbsim

DT_S = 0.005
N_STEPS = 20_000
EXECRATE = 4
LAG = 7.5  # 1/s
#: The quantiser: 10 bits over [0, 8], a step of 8/1024 (an exact binary fraction).
Q_BITS, Q_MIN, Q_MAX = 10, 0.0, 8.0
QUANTUM = (Q_MAX - Q_MIN) / 2**Q_BITS
NOISE = 0.3  # JSBSim's <noise> value: the 1-sigma amplitude of ABSOLUTE GAUSSIAN noise

QUANT_XML = (
    f"<quantization><bits>{Q_BITS}</bits><min>{Q_MIN}</min><max>{Q_MAX}</max></quantization>"
)
NOISE_XML = f'<noise variation="ABSOLUTE" distribution="GAUSSIAN">{NOISE}</noise>'

#: name -> (execrate, the sensor's XML elements, the same sensor as a SensorSpec without noise)
CASES: dict[str, tuple[int, str, SensorSpec]] = {
    "lag": (1, f"<lag>{LAG}</lag>", SensorSpec(lag_rad_s=LAG)),
    "gain_bias": (1, "<gain>2.5</gain><bias>-0.75</bias>", SensorSpec(scale=2.5, bias=-0.75)),
    "lag_gain_bias": (
        1,
        f"<lag>{LAG}</lag><gain>-1.5</gain><bias>0.25</bias>",
        SensorSpec(lag_rad_s=LAG, scale=-1.5, bias=0.25),
    ),
    "quant": (
        1,
        f"<lag>{LAG}</lag><gain>2</gain><bias>3</bias>{QUANT_XML}",
        SensorSpec(lag_rad_s=LAG, scale=2.0, bias=3.0, quantum=QUANTUM),
    ),
    "lag4": (EXECRATE, f"<lag>{LAG}</lag>", SensorSpec(lag_rad_s=LAG, rate_hz=50.0)),
    "lag_gain_bias4": (
        EXECRATE,
        f"<lag>{LAG}</lag><gain>2</gain><bias>0.5</bias>",
        SensorSpec(lag_rad_s=LAG, scale=2.0, bias=0.5, rate_hz=50.0),
    ),
    "quant4": (
        EXECRATE,
        f"<gain>2</gain><bias>3</bias>{QUANT_XML}",
        SensorSpec(scale=2.0, bias=3.0, quantum=QUANTUM, rate_hz=50.0),
    ),
    # the noisy sensor's noise-free twin: JSBSim's output minus this one is its noise alone
    "clean": (1, f"<lag>{LAG}</lag><gain>2</gain><bias>0.5</bias>", SensorSpec()),
    "noisy": (1, f"<lag>{LAG}</lag><gain>2</gain><bias>0.5</bias>{NOISE_XML}", SensorSpec()),
}
CLEAN_SPEC = SensorSpec(lag_rad_s=LAG, scale=2.0, bias=0.5)

AIRCRAFT = """<?xml version="1.0"?>
<fdm_config name="sensortest" version="2.0" release="ALPHA">
  <fileheader/>
  <metrics/>
  <mass_balance>
    <ixx unit="SLUG*FT2"> 1.0 </ixx>
    <iyy unit="SLUG*FT2"> 1.0 </iyy>
    <izz unit="SLUG*FT2"> 1.0 </izz>
    <emptywt unit="LBS"> 3000 </emptywt>
  </mass_balance>
  <ground_reactions/>
  <aerodynamics/>
  <system name="sensor-test">
    <property value="0.0">test/input</property>
{channels}
  </system>
</fdm_config>
"""


def aircraft_xml() -> str:
    channels = []
    for rate in (1, EXECRATE):
        sensors = "".join(
            f'      <sensor name="test/{name}"><input>test/input</input>{xml}</sensor>\n'
            for name, (r, xml, _) in CASES.items()
            if r == rate
        )
        channels.append(
            f'    <channel name="rate{rate}" execrate="{rate}">\n{sensors}    </channel>'
        )
    return AIRCRAFT.format(channels="\n".join(channels))


def test_input() -> np.ndarray:
    """0 for 10 steps, 1 from step 10 (not a multiple of 4: the hold phase shows), -0.7 from
    step 37, then a sine about 0.3 from step 100."""
    u = np.zeros(N_STEPS)
    u[10:37] = 1.0
    u[37:100] = -0.7
    t = np.arange(N_STEPS - 100) * DT_S
    u[100:] = 0.3 + 0.8 * np.sin(2 * math.pi * 1.3 * t)
    return u


test_input.__test__ = False  # type: ignore[attr-defined]  # a helper, not a test


@pytest.fixture(scope="module")
def flown(tmp_path_factory: pytest.TempPathFactory) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The input and every JSBSim sensor's output, one a step after ``run_ic``."""
    root: Path = tmp_path_factory.mktemp("jsbsim_root")
    (root / "aircraft" / "sensortest").mkdir(parents=True)
    (root / "aircraft" / "sensortest" / "sensortest.xml").write_text(aircraft_xml())
    fdm = jsbsim.FGFDMExec(str(root))
    fdm.set_debug_level(0)
    fdm.set_dt(DT_S)  # before loading: the lag's coefficients use the step at load time
    assert fdm.load_model("sensortest")
    fdm["test/input"] = 0.0
    assert fdm.run_ic()
    assert fdm["simulation/dt"] == DT_S
    u = test_input()
    props = [f"test/{name}" for name in CASES]
    out = np.empty((len(props), N_STEPS))
    for k, value in enumerate(u.tolist()):
        fdm["test/input"] = value
        fdm.run()
        for i, p in enumerate(props):
            out[i, k] = fdm[p]
    assert fdm["simulation/sim-time-sec"] == pytest.approx(N_STEPS * DT_S)
    return u, dict(zip(CASES, out, strict=True))


@pytest.mark.parametrize(
    "case", ["lag", "gain_bias", "lag_gain_bias", "quant", "lag4", "lag_gain_bias4", "quant4"]
)
def test_sensor_equals_jsbsims(flown: tuple[np.ndarray, dict[str, np.ndarray]], case: str) -> None:
    u, jsb = flown
    rate, _, spec = CASES[case]
    sensor = Sensor(spec, DT_S)
    assert sensor.frame == rate
    ours = sensor.run(u, np.zeros_like(u))
    theirs = jsb[case]
    scale = np.max(np.abs(theirs))
    np.testing.assert_allclose(ours, theirs, rtol=1e-12, atol=1e-12 * scale)
    # the same steps change the output, the first one after a change of input included
    assert np.array_equal(np.flatnonzero(np.diff(ours)), np.flatnonzero(np.diff(theirs)))


def test_the_first_steps_after_a_change_by_hand(
    flown: tuple[np.ndarray, dict[str, np.ndarray]],
) -> None:
    """Independent of the module: JSBSim's outputs around the step at 10, from its Tustin
    formula written out here; the quarter-rate channel runs on steps 3, 7, 11, ..."""
    _, jsb = flown
    dt4 = EXECRATE * DT_S
    ca4, cb4 = dt4 * LAG / (2 + dt4 * LAG), (2 - dt4 * LAG) / (2 + dt4 * LAG)
    ca1 = DT_S * LAG / (2 + DT_S * LAG)
    assert jsb["lag"][9] == 0.0 and jsb["lag"][10] == pytest.approx(ca1, rel=1e-14)
    lag4 = jsb["lag4"]
    # runs on steps 3 and 7 see an input of 0; step 11 is the first to see the 1 of step 10
    assert np.all(lag4[:11] == 0.0)
    y11 = ca4 * (1.0 + 0.0)
    y15 = ca4 * (1.0 + 1.0) + y11 * cb4
    assert lag4[11] == pytest.approx(y11, rel=1e-14)
    assert np.all(lag4[11:15] == lag4[11]) and lag4[15] == pytest.approx(y15, rel=1e-14)
    changes = np.flatnonzero(np.diff(lag4)) + 1
    assert np.all(changes % EXECRATE == EXECRATE - 1)


def test_noise_statistics_match_jsbsims(
    flown: tuple[np.ndarray, dict[str, np.ndarray]],
) -> None:
    """ABSOLUTE GAUSSIAN noise of 0.3 through a gain of 2: JSBSim's measured noise (its
    noisy sensor minus its noise-free twin) and ours both have sigma 0.6 (the gain follows
    the noise), mean 0."""
    u, jsb = flown
    sigma = 2.0 * NOISE
    np.testing.assert_allclose(
        Sensor(CLEAN_SPEC, DT_S).run(u, np.zeros_like(u)), jsb["clean"], rtol=1e-12, atol=1e-12
    )
    theirs = jsb["noisy"] - jsb["clean"]
    rng = np.random.default_rng(20240611)
    noisy = Sensor(CLEAN_SPEC.replace(noise_sigma=NOISE), DT_S).run(u, rng.standard_normal(u.size))
    ours = noisy - Sensor(CLEAN_SPEC, DT_S).run(u, np.zeros_like(u))
    for d in (theirs, ours):
        assert np.std(d) == pytest.approx(sigma, rel=0.05)
        assert abs(np.mean(d)) < 4 * sigma / math.sqrt(d.size)
    assert np.std(ours) / np.std(theirs) == pytest.approx(1.0, rel=0.05)
