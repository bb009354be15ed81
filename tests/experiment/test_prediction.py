"""The deterministic part of the noise model against JSBSim itself: the expected settled
estimate (bias included) of a noise-free run, and the bias measured on a run 100 periods
longer (:func:`probing.experiment.design.noise.measured_bias`).  The seed-to-seed scatter is checked
against Monte Carlo in ``tests/core/test_noise.py`` and ``tests/sweep/test_noise_sweep.py``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from probing.core.correlator import StreamingCorrelator
from probing.core.noise import cyclic_estimates
from probing.core.prbs import Probe, mls
from probing.experiment.design.noise import measured_bias, predict
from probing.experiment.flight.run import run_scenario
from probing.experiment.output.scatter import scatter_models
from probing.experiment.scenario import Scenario, load_scenario
from probing.sim.linear import LinearResponse

ROOT = Path(__file__).resolve().parents[2]

NONLINEARITIES = {
    "none": {},
    "backlash": {"nonlinearity.type": "backlash", "nonlinearity.width_deg": 0.002},
}


def gtm(estimator: str, nonlinearity: str) -> Scenario:
    """The paper's GTM condition, shortened: M = 127, 6 periods of which 4 settle."""
    return load_scenario(ROOT / "scenarios" / "fig4" / "baseline.toml").replace(
        {
            "probe.order": 7,
            "probe.periods": 6,
            "output.estimator": estimator,
            **NONLINEARITIES[nonlinearity],
        }
    )


def rms(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(v))))


@pytest.mark.jsbsim
@pytest.mark.parametrize("nonlinearity", sorted(NONLINEARITIES))
@pytest.mark.parametrize("estimator", ["streaming", "ac"])
def test_expected_settled_h_is_what_a_noise_free_run_reports(
    tmp_path: Path, estimator: str, nonlinearity: str
) -> None:
    """A noise-free run's settled h is the prediction's h_expected: the slow modes'
    transient included.  Streaming's pitch estimate is almost all transient (its bias is ~100x
    the steady h); it is predicted to 1.5 %, ac's shape to 6 % (docs/noise.md)."""
    scn = gtm(estimator, nonlinearity)
    result = run_scenario(scn, tmp_path, progress=False)
    found = predict(scn)
    tolerance = {"streaming": 0.03, "ac": 0.1}[estimator]
    for channel in ("theta_rad", "q_rad_s") if estimator == "ac" else ("theta_rad",):
        h = result.h_est[channel]
        assert rms(h - found[channel].h_expected) < tolerance * rms(h), channel
        if estimator == "streaming":  # without the transient it would be far off
            assert rms(h - found[channel].h_steady) > 0.9 * rms(h)


@pytest.mark.jsbsim
@pytest.mark.parametrize("nonlinearity", sorted(NONLINEARITIES))
@pytest.mark.parametrize("estimator", ["streaming", "ac"])
def test_predicted_bias_is_measured_on_a_longer_run(estimator: str, nonlinearity: str) -> None:
    """predicted_h_bias against the settled mean minus the steady state of a run 100 periods
    longer, within 15 % where docs/noise.md says it holds on the GTM (measured: 1.07-1.09).
    Streaming's q and cyclic's pitch miss by up to 1.4x and 0.5x here: the linearisation's
    slow-mode error, a common-mode 2e-4 rad/deg, is of the size of those biases."""
    scn = gtm(estimator, nonlinearity)
    measured = measured_bias(scn)
    found = predict(scn)
    for channel in ("theta_rad", "q_rad_s") if estimator == "ac" else ("theta_rad",):
        assert measured[channel] == pytest.approx(found[channel].h_bias, rel=0.15), channel


def estimates(scn: Scenario, y_bits: np.ndarray) -> np.ndarray:
    """Each period's h by the run's own estimators (the correlator, cyclic_estimates), (P, M)."""
    sigma, m = mls(scn.order), scn.bits_per_period
    if scn.estimator == "streaming":
        corr = StreamingCorrelator(sigma, scn.amplitude_deg)
        corr.push(y_bits)
        return corr.pop_periods().h
    return cyclic_estimates(
        y_bits.reshape(-1, m), sigma, scn.amplitude_deg, scn.estimator == "cyclic"
    )[2]


@pytest.mark.parametrize("estimator", ["streaming", "cyclic", "ac"])
def test_deterministic_part_is_the_estimators_on_a_stepped_linear_model(
    estimator: str, toy_linear: LinearResponse, stepped
) -> None:
    """On a made-up linear plant (conftest's toy_linear), predict's
    h_expected, h_steady and gain reference are the run's estimators applied to the plant
    stepped one step at a time: the settled periods of a run from rest, the last period of a
    run 300 periods long, and again the settled periods of the run from rest, backlash
    included (the gain projects on what the run estimates, not on the bare probe's response:
    the backlash's apparent gain a~/a = 0.8 would put it 1.25x off).  The run is long enough
    that predict simulates only the periods before the slow mode has decayed."""
    lin = toy_linear
    scn = load_scenario(ROOT / "scenarios" / "baseline-737.toml").replace(
        {
            "simulation.dt_s": 0.01,
            "probe.order": 5,
            "probe.bit_duration_s": 0.02,
            "probe.amplitude_deg": 0.01,
            "probe.periods": 60,
            "probe.settle_periods": 1,
            "nonlinearity.type": "backlash",
            "nonlinearity.width_deg": 0.004,
            "output.channels": ["theta_rad", "q_rad_s"],
            "output.estimator": estimator,
            "disturbance.sensor_noise": {"theta_rad": 1e-5, "q_rad_s": 1e-5},
        }
    )
    probe = Probe(scn.order, scn.bit_duration_s, scn.amplitude_deg)
    spb, first = scn.steps_per_bit, 1

    def settled_and_last(asked: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        y = stepped(lin, asked)[spb - 1 :: spb]
        per_channel = [estimates(scn, y[:, j]) for j in range(2)]
        return (
            np.stack([h[first : scn.periods].mean(axis=0) for h in per_channel]),
            np.stack([h[-1] for h in per_channel]),
        )

    long = probe.samples(scn.dt_s, 300)
    asked = long[: long.size * scn.periods // 300]
    expected, _ = settled_and_last(scn.build_nonlinearity().apply(asked, scn.dt_s))
    _, steady = settled_and_last(scn.build_nonlinearity().apply(long, scn.dt_s))
    bare, _ = settled_and_last(asked)  # the probe without the backlash: not the reference
    found = predict(scn, linear=lin)
    models = scatter_models(scn)
    for j, channel in enumerate(lin.channels):
        scale = rms(steady[j])
        np.testing.assert_allclose(found[channel].h_expected, expected[j], atol=1e-9 * scale)
        np.testing.assert_allclose(found[channel].h_steady, steady[j], atol=1e-9 * scale)
        assert found[channel].h_bias == pytest.approx(rms(expected[j] - steady[j]), rel=1e-6)
        # the gain's reference is h_expected, the run's own settled estimate (checked above)
        gain = models[channel].gain_std(found[channel].h_expected)
        assert found[channel].gain_stderr == pytest.approx(gain, rel=1e-12)
        assert gain == pytest.approx(models[channel].gain_std(expected[j]), rel=1e-6)
        assert models[channel].gain_std(bare[j]) < 0.9 * gain  # a reference to get right
    assert found["theta_rad"].h_bias > 0.005 * rms(steady[0])  # a bias to get right


@pytest.mark.parametrize("estimator", ["streaming", "cyclic"])
def test_extra_noise_adds_to_the_sensor_noise(estimator: str) -> None:
    """Independent noises' variances add: with sensor noise (1e-4) and a coloured extra
    autocovariance on theta, each tap's variance of the settled h is the sensor noise's alone
    plus the extra's alone (a scenario without sensor noise); q, given no extra, keeps its
    sensor noise only."""
    base = gtm(estimator, "none")
    noisy = base.replace({"disturbance.sensor_noise": {"theta_rad": 1e-4, "q_rad_s": 2e-4}})
    quiet = base.replace({"disturbance.sensor_noise": {}})
    extra = {"theta_rad": np.array([2e-8, 1.5e-8, 1e-8, 0.5e-8])}
    both = scatter_models(noisy, extra)
    sensor = scatter_models(noisy)
    alone = scatter_models(quiet, extra)
    np.testing.assert_allclose(
        both["theta_rad"].h_std() ** 2,
        sensor["theta_rad"].h_std() ** 2 + alone["theta_rad"].h_std() ** 2,
        rtol=1e-9,
    )
    assert rms(sensor["theta_rad"].h_std()) > 0.1 * rms(alone["theta_rad"].h_std())
    np.testing.assert_array_equal(both["q_rad_s"].h_std(), sensor["q_rad_s"].h_std())
