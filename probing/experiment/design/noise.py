"""What a scenario's estimates will be worth, before it runs: scatter and bias, per channel.

Two things move an estimate away from the aircraft's pulse response, and they are kept apart:

* **Scatter** (seed-to-seed): sensor noise, white per bit sample, exact for the estimator in
  use from its own weights (:mod:`probing.core.noise`); whatever a caller adds as a known
  autocovariance; and turbulence, the part the reference twin does not cancel, as measured
  realisations of it (noise-free runs in turbulence minus the calm run): the weights applied
  to each realisation's own settled periods.
* **Bias** (the same for every seed): the run starts from trim, so the slow modes' response
  to the probe (and to the offset b~ of a nonlinearity) is not yet periodic in the settled
  periods.  Computed on JSBSim's linearisation at the trim, with the model's own actuator
  (:class:`probing.sim.linear.LinearResponse`): the settled estimates of the response from
  rest minus those of the periodic steady state.

Reported as RMS over the taps.

**The gain** is the least-squares projection g = <h, r> / <r, r> of the mean settled h on a
noise-free reference r, and its standard error must be that of the projection on the r the
run's gain is measured against: the noise-free estimate of the same run, its nonlinearity
included (what a monitor's baseline learns from the flight, and what a noise-free flight of
the same scenario reports).  The sensor noise n on h is additive and linear in the noise
(n = W u, W the estimator's weights), so g - E[g] = <n, r> / <r, r> exactly and

    std(g) = sqrt(r' Cov(n) r) / (r' r),

which depends on r: for r = k r0, std(g; r) = std(g; r0) / k.  The model used to project on
r0, the expected estimate of the *bare* probe (no nonlinearity).  Behind a symmetric dead band
of half width d the probe is a scaled copy, a~ = a - d, so the run's r is (a~/a) r0 tap for
tap, and the gain's scatter was a/a~ of the prediction: 1/0.6 = 1.67 on the 737 with
d = 0.002 deg and a = 0.005 deg (h's scatter, which projects on nothing, was right).  What
else separates the run's estimate from the linear pulse response (the ``ac`` estimator's mean
removal h - sum(h)/(M+1), the tail beyond one period folded into the taps, eq. 8, the slow
modes' transient in the settled periods, and the transient an offset b~ starts) was already
in r0, which is the estimator's weights applied to the linearisation's response from rest;
the nonlinearity was not.  So r is now E[mean settled h] of the scenario itself
(``h_expected``: the nonlinearity's output through the linearisation from rest, the
estimator's weights on its settled periods), the quantity the run reports without noise.  A
design flies it instead (:func:`probing.experiment.design.design_runs.noise_free_reference`, the
noise-free calm run of the scenario, nonlinearity kept) and passes it as ``reference``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from probing.core.fixedorder import dot, eigvals
from probing.core.forked import can_fork, forked_map
from probing.experiment.output.scatter import scatter_models
from probing.experiment.scenario import Scenario
from probing.sim.flight import Flight
from probing.sim.fork import TrimmedAircraft
from probing.sim.linear import LinearResponse, linear_response
from probing.sim.plant import make_plant

__all__ = ["ChannelPrediction", "linear_model", "measured_bias", "predict"]


@dataclass(frozen=True)
class ChannelPrediction:
    """Predicted quality of one channel's settled estimates.

    Attributes
    ----------
    channel : str
        The channel.
    z_stderr : float
        RMS over taps of the seed-to-seed standard deviation of the mean settled z
        (channel unit).
    h_stderr : float
        The same for h_est (channel unit per deg).
    gain_stderr : float
        Standard deviation of the least-squares gain (dimensionless); NaN without a
        linearised output for the channel.
    h_bias : float
        RMS over taps of E[mean settled h] minus its periodic steady state (channel unit per
        deg); NaN without a linearised output.
    h_steady : numpy.ndarray or None
        The expected steady-state estimate (M,), None without a linearised output.
    h_expected : numpy.ndarray or None
        E[mean settled h] (M,), bias included: what a noise-free run reports; None without
        a linearised output.
    """

    channel: str
    z_stderr: float
    h_stderr: float
    gain_stderr: float
    h_bias: float
    h_steady: np.ndarray | None = None
    h_expected: np.ndarray | None = None

    def to_dict(self) -> dict[str, float]:
        """The four numbers, for JSON."""
        return {
            "z_stderr": self.z_stderr,
            "h_stderr": self.h_stderr,
            "gain_stderr": self.gain_stderr,
            "h_bias": self.h_bias,
        }


def _calm(flight: Flight) -> Flight:
    """The flight in calm air, seed 0: the linearisation at the trim does not depend on
    turbulence or seed (it is taken before either acts), so flights that differ only in
    them share one."""
    return dataclasses.replace(flight, turbulence="none", seed=0)


def linear_model(
    flight: Flight, channels: tuple[str, ...], aircraft: TrimmedAircraft | None = None
) -> LinearResponse:
    """The linearisation of a flight at its trim, in calm air, remembered for the process.

    Parameters
    ----------
    flight : Flight
        The flight; its turbulence and seed do not matter.
    channels : tuple of str
        Output channels.
    aircraft : TrimmedAircraft, optional
        The flight's trimmed aircraft: linearise a forked copy of it instead of loading and
        trimming afresh (the same numbers, one load less).
    """
    key = (_calm(flight), tuple(channels))
    if key not in _LINEAR:
        if len(_LINEAR) >= 16:
            _LINEAR.clear()
        if aircraft is not None and can_fork():
            copy = functools.partial(_linearise_copy, aircraft=aircraft, channels=key[1])
            (outcome,) = forked_map(copy, [key[0]])
            _LINEAR[key] = outcome.get()
        else:
            _LINEAR[key] = linear_response(make_plant(key[0]), key[1], key[0].surface)
    return _LINEAR[key]


_LINEAR: dict[tuple[Flight, tuple[str, ...]], LinearResponse] = {}


def _linearise_copy(
    flight: Flight, aircraft: TrimmedAircraft, channels: tuple[str, ...]
) -> LinearResponse:
    return linear_response(aircraft.plant_for(flight), channels, flight.surface)


def _step_response(flight: Flight, channels: tuple[str, ...], steps: int) -> np.ndarray:
    """:meth:`LinearResponse.step_response` of :func:`linear_model`, remembered: the same for
    every nonlinearity, probe amplitude and seed of a sweep."""
    return _calm_step_response(_calm(flight), tuple(channels), steps)


@functools.lru_cache(maxsize=4)
def _calm_step_response(flight: Flight, channels: tuple[str, ...], steps: int) -> np.ndarray:
    return linear_model(flight, channels).step_response(steps)


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def _decay_periods(lin: LinearResponse, steps_per_period: int) -> int:
    """Periods after which the slowest mode has decayed by 1e-6 (the transient is gone)."""
    slowest = float(np.max(np.abs(eigvals(lin.a))))
    if slowest >= 1.0:
        return 10**9
    return max(1, math.ceil(math.log(1e-6) / math.log(slowest) / steps_per_period))


def _deterministic(
    scn: Scenario,
    lin: LinearResponse,
    h_rows: np.ndarray,
    step_response: Callable[[int], np.ndarray] | None = None,
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Per channel: E[mean settled h] (bias included: what a noise-free run reports, and the
    gain's reference) and its periodic steady state.

    Periods after the transient has decayed (:func:`_decay_periods`) are at the steady state:
    only the ones before are simulated, so a long run costs no more than a short one.
    ``step_response(n)``: ``lin.step_response(n)``, possibly remembered by the caller.
    """
    probe = scn.probe
    m, spb = scn.bits_per_period, scn.steps_per_bit
    steps = m * spb
    two = h_rows.shape[1] == 2 * m
    first = max(scn.settle_periods, scn.first_estimated_period)
    n = min(scn.periods, first + _decay_periods(lin, steps) + 1)
    x = probe.samples(scn.dt_s, n)
    nl = scn.build_nonlinearity()
    q = nl.apply(x, scn.dt_s) if nl else x

    def settled_mean(y_bits: np.ndarray, y_steady: np.ndarray) -> np.ndarray:
        # the estimate is linear: the sum over the simulated settled periods of their windows
        # (each period's own bits, and the previous period's for streaming) is one product
        per_period = y_bits[first * m : n * m].reshape(n - first, m).sum(axis=0)
        if two:
            previous = y_bits[(first - 1) * m : (n - 1) * m].reshape(n - first, m).sum(axis=0)
            per_period = np.concatenate((previous, per_period))
        steady_h = dot(h_rows, np.tile(y_steady, 2) if two else y_steady)
        late = scn.periods - n  # the periods not simulated: at the steady state
        return (dot(h_rows, per_period) + late * steady_h) / (scn.periods - first)

    pulse = (step_response or lin.step_response)(x.size)
    y_rest = lin.respond(q, pulse)[spb - 1 :: spb]  # bit samples
    y_ss = lin.periodic(q[-steps:])[spb - 1 :: spb]  # the last period repeats from then on
    expected, steady = {}, {}
    for j, channel in enumerate(lin.channels):
        expected[channel] = settled_mean(y_rest[:, j], y_ss[:, j])
        steady[channel] = dot(h_rows, np.tile(y_ss[:, j], 2) if two else y_ss[:, j])
    return expected, steady


def _noise_free(scn: Scenario) -> Scenario:
    """What the deterministic part depends on: the scenario without noise, seed and name."""
    return scn.replace(
        {
            "name": "deterministic",
            "disturbance.sensor_noise": {},
            "disturbance.seed": 0,
            "disturbance.turbulence": "none",
        }
    )


_DETERMINISTIC: dict[str, tuple[dict, dict]] = {}


def _deterministic_of(scn: Scenario) -> tuple[dict, dict]:
    """:func:`_deterministic` on the flight's linearisation, remembered per noise-free
    scenario (a sweep over seeds or noise levels computes it once per worker)."""
    key = _noise_free(scn).to_json()
    if key not in _DETERMINISTIC:
        if len(_DETERMINISTIC) >= 64:
            _DETERMINISTIC.clear()
        rows = scatter_models(scn)[scn.channels[0]].h_rows
        lin = linear_model(scn.flight, scn.channels)
        pulse = functools.partial(_step_response, scn.flight, scn.channels)
        _DETERMINISTIC[key] = _deterministic(scn, lin, rows, pulse)
    return _DETERMINISTIC[key]


def predict(
    scn: Scenario,
    *,
    extra_acov: Mapping[str, np.ndarray] | None = None,
    extra_samples: Mapping[str, np.ndarray] | None = None,
    linear: LinearResponse | None = None,
    reference: Mapping[str, np.ndarray] | None = None,
) -> dict[str, ChannelPrediction]:
    """Scatter and bias of every channel's settled estimates for a scenario.

    Parameters
    ----------
    scn : Scenario
        The scenario (its estimator, drift mode, probe, nonlinearity and sensor noise).
    extra_acov : mapping, optional
        Channel -> autocovariance of further stationary noise on the bit samples, added to
        the sensor noise (output units squared).
    extra_samples : mapping, optional
        Channel -> realisations (K, n) of further noise on the bit samples from the run's
        start, at least as long as the run (output units): turbulence the twin does not
        cancel, measured by :func:`probing.experiment.design.design_runs.turbulence_residual`.
    linear : LinearResponse, optional
        The linearisation to use (default: :func:`linear_model` of the scenario's flight).
    reference : mapping, optional
        Channel -> the noise-free mean settled h the gain is measured against (a design's:
        :func:`probing.experiment.design.design_runs.noise_free_reference`, the scenario flown
        without noise, its nonlinearity kept); default: the linearisation's E[mean settled
        h] of the scenario itself, ``h_expected`` (module docstring, "The gain").

    Returns
    -------
    dict
        Channel -> :class:`ChannelPrediction`.
    """
    models = scatter_models(scn, extra_acov, extra_samples)
    if linear is None:  # the same for every seed and noise level: remembered
        expected, steady = _deterministic_of(scn)
    else:
        expected, steady = _deterministic(scn, linear, models[scn.channels[0]].h_rows)
    out = {}
    for channel, model in models.items():
        # the gain projects on what the run estimates without noise (module docstring)
        h_ref = reference[channel] if reference and channel in reference else expected.get(channel)
        gain = model.gain_std(h_ref) if h_ref is not None else math.nan
        bias = _rms(expected[channel] - steady[channel]) if channel in expected else math.nan
        out[channel] = ChannelPrediction(
            channel,
            _rms(model.z_std()),
            _rms(model.h_std()),
            gain,
            bias,
            steady.get(channel),
            expected.get(channel),
        )
    return out


def measured_bias(scn: Scenario, extra_periods: int = 100) -> dict[str, float]:
    """The bias measured on JSBSim itself: a noise-free run ``extra_periods`` longer, the mean
    of its settled periods minus that of its last 10 (the periodic steady state, where the
    aircraft has one), RMS over taps, per channel.  Checks :func:`predict`'s ``h_bias``."""
    import tempfile

    import pandas as pd

    from probing.experiment.flight.run import run_scenario

    long = scn.replace(
        {
            "name": f"{scn.name}-bias",
            "probe.periods": scn.periods + extra_periods,
            "disturbance.sensor_noise": {},
            "disturbance.turbulence": "none",
        }
    )
    with tempfile.TemporaryDirectory(prefix="probing-bias-") as tmp:
        result = run_scenario(long, tmp, progress=False)
        df = pd.read_parquet(result.out_dir / "probing.parquet")
    first = max(scn.settle_periods, scn.first_estimated_period)
    out = {}
    for channel, rows in df.groupby("channel"):
        h = rows.pivot(index="period", columns="tap", values="h_est")
        early = h.loc[first : scn.periods - 1].to_numpy().mean(axis=0)
        late = h.iloc[-10:].to_numpy().mean(axis=0)
        out[str(channel)] = _rms(early - late)
    return out
