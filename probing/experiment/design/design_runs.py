"""What a probe design measures by flying: what the reference leaves of turbulence and of the
sensors' noise (:func:`turbulence_residual`, as realisations) and the noise-free reference a
design's gain is measured against (:func:`noise_free_reference`).
:mod:`probing.experiment.design.design` asks for them while it searches."""

from __future__ import annotations

from typing import Any

import numpy as np

from probing.experiment.design.design_request import DesignError
from probing.experiment.scenario import Scenario, ScenarioError

__all__ = ["Gusts", "noise_free_reference", "quiet", "turbulence_residual", "with_periods"]


def with_periods(scn: Scenario, periods: int) -> Scenario:
    """``scn`` with ``periods`` settled periods (after its settling periods)."""
    try:
        return scn.replace({"probe.periods": scn.settle_periods + periods})
    except ScenarioError as exc:
        raise DesignError(f"the design is no valid scenario: {exc.field}: {exc.message}") from None


def quiet(scn: Scenario) -> Scenario:
    """``scn`` without sensor noise: no ``disturbance.sensor_noise`` and, with a sensor
    suite, every sensor's ``noise_sigma`` 0 (its lag, sample rate, bias and quantisation
    kept: the same measurement chain, deterministic)."""
    changes: dict[str, Any] = {"disturbance.sensor_noise": {}}
    if scn.sensors is not None:
        changes.update({f"sensors.{c}.noise_sigma": 0.0 for c in scn.sensors.sensors})
    return scn.replace(changes)


def turbulence_residual(scn: Scenario, seeds: int) -> dict[str, np.ndarray]:
    """What the scenario's reference leaves of the turbulence (and of a sensor suite's
    noise), as realisations per channel.

    With the ``oracle`` the twin flies the same gusts, so measured - reference holds only
    what the gusts do to the aircraft's response to the probe: a random perturbation of h
    itself, growing as the gusts move the aircraft away from its trim, so neither stationary
    nor additive, and no autocovariance says what it does to one direction of h (the
    gain's).  A realisable reference (``gust``, ``nominal``) leaves more: the gusts' own
    response, less what its twin reproduces of it; ``detrend`` leaves the gusts' response
    less its trend in each period (the estimator's detrending, in the noise model).  It is
    measured: runs of ``scn`` as long as it is, at ``seeds`` seeds (1000, 1001, ...), in
    its turbulence, with its sensors, autopilot and drift, minus the same run in calm air
    without sensor noise, bit samples from the run's start.  Without a reference column
    (``detrend``) the run's measurement itself is taken.

    ``disturbance.sensor_noise`` (white, added analytically by
    :func:`probing.experiment.output.scatter.scatter_models`) is left out of the runs; a sensor
    suite's noise is kept: it reaches the estimate through the autopilot and the reference,
    so the realisations hold it, and nothing is to be added for it again.

    Returns
    -------
    dict
        Channel -> array (seeds, periods x M), the channel's unit.
    """
    from probing.experiment.flight.batch import run_grouped

    base = scn.replace({"disturbance.sensor_noise": {}})
    runs = [quiet(base).replace({"disturbance.turbulence": "none", "name": "calm"})]
    runs += [base.replace({"disturbance.seed": 1000 + k, "name": f"gust{k}"}) for k in range(seeds)]
    deviations: list[np.ndarray] = [np.empty(0)] * len(runs)
    for i, outcome in run_grouped(runs, lambda s: s, _deviation):  # one load and trim
        deviations[i] = outcome.get()
    calm, gusts = deviations[0], np.array(deviations[1:])
    bits = (gusts - calm)[:, scn.steps_per_bit - 1 :: scn.steps_per_bit]
    return {channel: bits[:, :, j] for j, channel in enumerate(scn.channels)}


def _deviation(scn: Scenario, aircraft: Any) -> np.ndarray:
    """Measured minus reference of a run (the measurement without one), every step,
    (steps, channels)."""
    import tempfile

    import pandas as pd

    from probing.experiment.flight.run import run_scenario

    with tempfile.TemporaryDirectory(prefix="probing-turbulence-") as tmp:
        result = run_scenario(scn, tmp, progress=False, aircraft=aircraft)  # twin: stored first
        ts = pd.read_parquet(result.out_dir / "timeseries.parquet")
    columns = [
        ts[c] - ts[f"{c}_reference"] if f"{c}_reference" in ts else ts[c] for c in scn.channels
    ]
    return np.stack(columns, axis=1)


def noise_free_reference(scn: Scenario) -> dict[str, np.ndarray]:
    """Mean settled h of a noise-free (:func:`quiet`), calm run of ``scn``, its nonlinearity
    kept: what the gain is measured against, the run's own estimate without noise (the
    nonlinearity's apparent gain and offset, the estimator's mean removal, the folded tail
    and the slow modes' transient included, as a monitor's baseline learns it from the
    flight).  Projecting on the response without the nonlinearity put the gain's scatter
    a/a~ off behind a dead band (:mod:`probing.experiment.design.noise`, "The gain")."""
    import tempfile

    from probing.experiment.flight.run import run_scenario

    own = quiet(scn).replace({"name": "design-reference", "disturbance.turbulence": "none"})
    with tempfile.TemporaryDirectory(prefix="probing-design-") as tmp:
        return run_scenario(own, tmp, progress=False).h_est


class Gusts:
    """The residual (:func:`turbulence_residual`) of a design, flown once per length: a
    longer design reflies it as long (the seeds are fixed, so a shorter one is its
    beginning).  ``on``: there is one to fly (turbulence, or a sensor suite's noise)."""

    def __init__(self, seeds: int, on: bool) -> None:
        self.seeds, self.on = seeds, on
        self.samples: dict[str, np.ndarray] = {}
        self.periods = 0

    def of(self, scn: Scenario, periods: int | None = None) -> dict[str, np.ndarray]:
        """Realisations covering ``periods`` (default: all) of ``scn``'s periods."""
        if not self.on:
            return {}
        periods = scn.periods if periods is None else periods
        if periods > self.periods:
            self.samples = turbulence_residual(
                with_periods(scn, periods - scn.settle_periods), self.seeds
            )
            self.periods = periods
        m = scn.bits_per_period
        return {c: x[:, : periods * m] for c, x in self.samples.items()}
