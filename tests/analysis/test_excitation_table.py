"""The excitation comparison's accuracy table from a small made-up study (no simulation): the
gain's scatter over the noisy seeds is their sample standard deviation."""

from __future__ import annotations

import statistics
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from probing.analysis.excitations import CHANNELS, Run, Study, accuracy_rows
from probing.experiment.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[2]
#: The noisy seeds' gains against the noise-free baseline.
GAINS = {1: 0.9, 2: 1.0, 3: 1.2}


def _run(scn: Scenario, folder: Path, gain: float) -> Run:
    """A run whose settled h of every channel is ``gain`` times a made-up response, with the
    files the accuracy table reads (the linearised truth and the single-pulse prediction)."""
    m, periods = scn.bits_per_period, scn.periods - scn.settle_periods
    h0 = 1e-3 * np.sin(np.arange(m) / 3.0) * np.exp(-np.arange(m) / 10.0)
    folder.mkdir()
    pd.DataFrame(
        [{"channel": c, "tap": k, "h_lin": h0[k]} for c in CHANNELS for k in range(m)]
    ).to_parquet(folder / "truth.parquet")
    pd.DataFrame(
        [
            {"channel": c, "period": p, "tap": k, "lag_s": k * scn.dt_s, "z": h0[k], "h_est": h0[k]}
            for c in CHANNELS
            for p in range(scn.periods)
            for k in range(m)
        ]
    ).to_parquet(folder / "prediction.parquet")
    h = {c: np.tile(gain * h0, (periods, 1)) for c in CHANNELS}
    return Run(scn, folder, h, h)


def test_the_gain_scatter_over_seeds_is_the_sample_standard_deviation(tmp_path: Path) -> None:
    """Three seeds with gains 0.9, 1.0 and 1.2: the scatter is their sample (n - 1)
    standard deviation, 0.153, not the population one, 0.125."""
    scn = load_scenario(ROOT / "scenarios" / "fig4-737" / "baseline.toml").replace(
        {"probe.order": 5}
    )
    runs = {("737", "prbs", "baseline", 0): _run(scn, tmp_path / "baseline", 1.0)}
    for seed, gain in GAINS.items():
        runs["737", "prbs", "noise", seed] = _run(scn, tmp_path / f"noise{seed}", gain)
    rows = accuracy_rows(Study(tmp_path, {}, runs))
    expected = statistics.stdev(GAINS.values())
    assert list(rows.channel) == list(CHANNELS)
    assert list(rows.seeds) == [3, 3]
    np.testing.assert_allclose(rows.gain_sd_seeds, expected, rtol=1e-9)
    assert expected == pytest.approx(0.1528, abs=1e-4)
