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

Reported as RMS over the taps.  The gain's standard error is that of the least-squares gain
of the mean settled h against the expected mean settled h of the same run without the
nonlinearity (bias included): the scatter of the gain a sweep or a monitor measures against a
noise-free baseline flown the same way.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from probing.core.forked import can_fork, forked_map
from probing.experiment.scatter import scatter_models
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
    slowest = float(np.max(np.abs(np.linalg.eigvals(lin.a))))
    if slowest >= 1.0:
        return 10**9
    return max(1, math.ceil(math.log(1e-6) / math.log(slowest) / steps_per_period))


def _deterministic(
    scn: Scenario,
    lin: LinearResponse,
    h_rows: np.ndarray,
    step_response: Callable[[int], np.ndarray] | None = None,
    bare: dict[str, np.ndarray] | None = None,
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Per channel: E[mean settled h], its periodic steady state, and E[mean settled h] of
    the bare probe (no nonlinearity: the gain's reference, bias included, as a baseline run
    of the same length measures it).

    Periods after the transient has decayed (:func:`_decay_periods`) are at the steady state:
    only the ones before are simulated, so a long run costs no more than a short one.
    ``step_response(n)``: ``lin.step_response(n)``, possibly remembered by the caller.
    ``bare``: the third result if the caller has it (it is the first result of the same
    scenario without its nonlinearity, to the bit: the probe repeats each period exactly).
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
        steady_h = h_rows @ (np.tile(y_steady, 2) if two else y_steady)
        late = scn.periods - n  # the periods not simulated: at the steady state
        return (h_rows @ per_period + late * steady_h) / (scn.periods - first)

    pulse = (step_response or lin.step_response)(x.size)
    y_rest = lin.respond(q, pulse)[spb - 1 :: spb]  # bit samples
    y_ss = lin.periodic(q[-steps:])[spb - 1 :: spb]  # the last period repeats from then on
    expected, steady = {}, {}
    for j, channel in enumerate(lin.channels):
        expected[channel] = settled_mean(y_rest[:, j], y_ss[:, j])
        steady[channel] = h_rows @ (np.tile(y_ss[:, j], 2) if two else y_ss[:, j])
    if bare is None:
        bare = expected
        if nl:
            y_bare = lin.respond(x, pulse)[spb - 1 :: spb]
            y_bare_ss = lin.periodic(x[:steps])[spb - 1 :: spb]
            bare = {
                channel: settled_mean(y_bare[:, j], y_bare_ss[:, j])
                for j, channel in enumerate(lin.channels)
            }
    return expected, steady, bare


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


_DETERMINISTIC: dict[str, tuple[dict, dict, dict]] = {}


def _deterministic_of(scn: Scenario) -> tuple[dict, dict, dict]:
    """:func:`_deterministic` on the flight's linearisation, remembered per noise-free
    scenario (a sweep over seeds or noise levels computes it once per worker)."""
    key = _noise_free(scn).to_json()
    if key not in _DETERMINISTIC:
        # The bare probe's part is the same for every nonlinearity: from its own entry.
        bare = None
        if scn.nonlinearity != "none":
            bare = _deterministic_of(scn.replace({"nonlinearity.type": "none"}))[0]
        if len(_DETERMINISTIC) >= 64:
            _DETERMINISTIC.clear()
        rows = scatter_models(scn)[scn.channels[0]].h_rows
        lin = linear_model(scn.flight, scn.channels)
        pulse = functools.partial(_step_response, scn.flight, scn.channels)
        _DETERMINISTIC[key] = _deterministic(scn, lin, rows, pulse, bare)
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
        cancel, measured by :func:`probing.experiment.design_runs.turbulence_residual`.
    linear : LinearResponse, optional
        The linearisation to use (default: :func:`linear_model` of the scenario's flight).
    reference : mapping, optional
        Channel -> the noise-free mean settled h the gain is measured against (e.g. from a
        noise-free run without the nonlinearity); default: the linearisation's.

    Returns
    -------
    dict
        Channel -> :class:`ChannelPrediction`.
    """
    models = scatter_models(scn, extra_acov, extra_samples)
    if linear is None:  # the same for every seed and noise level: remembered
        expected, steady, bare = _deterministic_of(scn)
    else:
        expected, steady, bare = _deterministic(scn, linear, models[scn.channels[0]].h_rows)
    out = {}
    for channel, model in models.items():
        h_ref = reference[channel] if reference and channel in reference else bare.get(channel)
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

    from probing.experiment.run import run_scenario

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
