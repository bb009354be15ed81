"""The noise model of a scenario's settled estimates (:mod:`probing.core.noise`) with the
scenario's probe, estimator, drift mode and sensor noise: no simulation.  Kept apart from
:mod:`probing.experiment.design.noise` (the bias and the linearisation, which fly the aircraft) so
that a run can put the model's prediction beside its own scatter."""

from __future__ import annotations

import functools
from collections.abc import Mapping

import numpy as np

from probing.core.noise import NoiseModel, noise_model, white
from probing.core.prbs import Probe
from probing.experiment.scenario import Scenario

__all__ = ["model_covers", "scatter_models", "settled_model_sd"]


def scatter_models(
    scn: Scenario,
    extra_acov: Mapping[str, np.ndarray] | None = None,
    extra_samples: Mapping[str, np.ndarray] | None = None,
) -> dict[str, NoiseModel]:
    """The seed-to-seed noise of every channel's settled estimates (no simulation): sensor
    noise plus ``extra_acov`` (channel -> autocovariance of stationary noise on the bit
    samples) plus ``extra_samples`` (channel -> realisations (K, n) of further noise on the bit
    samples from the run's start, e.g.
    :func:`probing.experiment.design.design_runs.turbulence_residual`)
    through the scenario's estimator and drift mode."""
    detrend_order = scn.detrend_order if scn.detrends else None
    estimator = _estimator_model(scn.probe, scn.estimator, scn.settled_periods, detrend_order)
    first = max(scn.settle_periods, scn.first_estimated_period)
    out: dict[str, NoiseModel] = {}
    for channel in scn.channels:
        acov = white(scn.sensor_noise.get(channel, 0.0))
        if extra_acov and channel in extra_acov:
            extra = np.asarray(extra_acov[channel], dtype=float)
            acov = np.pad(acov, (0, max(0, extra.size - acov.size)))
            acov[: extra.size] += extra
        samples = extra_samples.get(channel) if extra_samples else None
        # the weights are the same for every channel
        out[channel] = estimator.with_noise(acov, samples, first)
    return out


def model_covers(scn: Scenario) -> bool:
    """True if the noise model covers a run's scatter: additive white sensor noise
    (``disturbance.sensor_noise``) on an open-loop flight in calm air without a sensor suite.
    Turbulence, an autopilot (the noise enters its loop) and a suite's filtered sensors are
    noise the model does not describe."""
    return scn.turbulence == "none" and scn.sensors is None and not scn.stepped_one_by_one


def settled_model_sd(scn: Scenario) -> np.ndarray | None:
    """The noise model's standard deviation of each channel's settled mean per tap, shape
    (C, M) (channel unit per probe unit), where :func:`model_covers` the run; None otherwise."""
    if not model_covers(scn) or scn.settled_periods < 1:
        return None
    models = scatter_models(scn)
    return np.array([models[c].h_std() for c in scn.channels])


@functools.lru_cache(maxsize=32)
def _estimator_model(
    probe: Probe, estimator: str, periods: int, detrend_order: int | None
) -> NoiseModel:
    """The estimator's weights (noise-free model), remembered: the same for every point of a
    sweep over nonlinearities, seeds or noise levels."""
    return noise_model(
        probe.reference(),
        probe.amplitude_deg,
        estimator,
        periods,
        white(0.0),
        detrend_order,
        probe.harmonics,
    )
