"""What a probe design measures by flying: the turbulence the reference twin leaves
(:func:`turbulence_residual`, as realisations) and the noise-free reference a design's gain
is measured against (:func:`noise_free_reference`).  :mod:`probing.experiment.design` asks
for them while it searches."""

from __future__ import annotations

from typing import Any

import numpy as np

from probing.experiment.scenario import Scenario

__all__ = ["noise_free_reference", "turbulence_residual"]


def turbulence_residual(scn: Scenario, seeds: int) -> dict[str, np.ndarray]:
    """The turbulence the reference twin does not cancel, as realisations per channel.

    The twin flies the same gusts, so measured - reference holds only what the gusts do to
    the aircraft's response to the probe: a random perturbation of h itself, growing as the
    gusts move the aircraft away from its trim, so neither stationary nor additive, and no
    autocovariance says what it does to one direction of h (the gain's).  It is measured:
    noise-free runs of ``scn`` as long as it is, at ``seeds`` seeds (1000, 1001, ...) in its
    turbulence, minus the same run in calm air, bit samples from the run's start.

    Returns
    -------
    dict
        Channel -> array (seeds, periods x M), the channel's unit.
    """
    from probing.experiment.batch import run_grouped

    base = scn.replace({"disturbance.sensor_noise": {}, "output.drift": "oracle"})
    runs = [base.replace({"disturbance.turbulence": "none", "name": "calm"})]
    runs += [base.replace({"disturbance.seed": 1000 + k, "name": f"gust{k}"}) for k in range(seeds)]
    deviations: list[np.ndarray] = [np.empty(0)] * len(runs)
    for i, outcome in run_grouped(runs, lambda s: s, _deviation):  # one load and trim
        deviations[i] = outcome.get()
    calm, gusts = deviations[0], np.array(deviations[1:])
    bits = (gusts - calm)[:, scn.steps_per_bit - 1 :: scn.steps_per_bit]
    return {channel: bits[:, :, j] for j, channel in enumerate(scn.channels)}


def _deviation(scn: Scenario, aircraft: Any) -> np.ndarray:
    """Measured minus reference of a run, every step, (steps, channels)."""
    import tempfile

    import pandas as pd

    from probing.experiment.run import run_scenario

    with tempfile.TemporaryDirectory(prefix="probing-turbulence-") as tmp:
        result = run_scenario(scn, tmp, progress=False, aircraft=aircraft)  # twin: stored first
        ts = pd.read_parquet(result.out_dir / "timeseries.parquet")
    return np.stack([ts[c] - ts[f"{c}_reference"] for c in scn.channels], axis=1)


def noise_free_reference(scn: Scenario) -> dict[str, np.ndarray]:
    """Mean settled h of a noise-free, calm run of ``scn`` without its nonlinearity: what the
    gain is measured against (the slow modes' bias included, as a baseline flight has it)."""
    import tempfile

    from probing.experiment.run import run_scenario

    bare = scn.replace(
        {
            "name": "design-reference",
            "nonlinearity.type": "none",
            "disturbance.sensor_noise": {},
            "disturbance.turbulence": "none",
        }
    )
    with tempfile.TemporaryDirectory(prefix="probing-design-") as tmp:
        return run_scenario(bare, tmp, progress=False).h_est
