"""A sweep over seeds and estimators: every point carries the noise model's predictions, and
the seed-to-seed statistics (:mod:`probing.analysis.seeds`) agree with the model and with a direct
computation from the points' files."""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest

from probing.analysis.seeds import seed_statistics, seed_table
from probing.analysis.sweep_plots import classify, load_sweep_data, sweep_figure
from probing.core.noise import noise_model, white
from probing.core.prbs import mls
from probing.sweep import load_sweep, read_summary, run_sweep

DATA = Path(__file__).resolve().parents[1] / "data" / "sweeps"
SEEDS = 20

pytestmark = pytest.mark.jsbsim


@pytest.fixture(scope="module")
def seeds_sweep(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("seeds")
    path = out / "seeds.toml"
    seeds = ", ".join(str(s) for s in range(SEEDS))
    path.write_text(
        f'name = "seeds"\nbase = "{DATA / "base-737-small.toml"}"\n'
        '[fixed]\n"disturbance.sensor_noise" = { theta_rad = 1e-5, q_rad_s = 1e-4 }\n'
        '[grid]\n"output.estimator" = ["streaming", "cyclic", "ac"]\n'
        f'"disturbance.seed" = [{seeds}]\n'
    )
    result = run_sweep(load_sweep(path), out, jobs=2, progress=False)
    assert result.done == 3 * SEEDS
    return out / "seeds"


def test_points_carry_the_noise_models_prediction(seeds_sweep: Path) -> None:
    summary = read_summary(seeds_sweep)
    for estimator in ("streaming", "cyclic", "ac"):
        row = summary[summary["output.estimator"] == estimator].iloc[0]
        # base-737-small: order 5, a = 0.01 deg, 4 periods of which 2 settle
        settled = 2
        model = noise_model(mls(5), 0.01, estimator, settled, white(1e-5))
        rms = float(np.sqrt(np.mean(model.h_std() ** 2)))
        assert row["predicted_h_stderr"] == pytest.approx(rms, rel=1e-9)
        assert row["predicted_z_stderr"] > 0 and row["predicted_gain_stderr"] > 0
        assert math.isfinite(row["predicted_h_bias"])


def test_seed_statistics_agree_with_the_files_and_the_model(seeds_sweep: Path) -> None:
    data = load_sweep_data(seeds_sweep)
    assert classify(data) == "seeds"
    stats = seed_statistics(data)
    assert {(s.label, s.channel) for s in stats} == {
        (f"estimator={e}", c)
        for e in ("streaming", "cyclic", "ac")
        for c in ("theta_rad", "q_rad_s")
    }
    summary = read_summary(seeds_sweep)
    for s in stats:
        assert s.seeds == SEEDS
        # the same standard deviation, computed directly from the points' probing.parquet
        ids = summary.set_index("index").loc[list(s.indices), "point_id"]
        h = []
        for pid in ids:
            df = pd.read_parquet(seeds_sweep / "points" / f"point_id={pid}" / "probing.parquet")
            df = df[(df.channel == s.channel) & (df.period >= 2)]
            h.append(df.groupby("tap").h_est.mean().to_numpy())
        direct = float(np.sqrt(np.mean(np.std(h, axis=0, ddof=1) ** 2)))
        assert s.measured["h_stderr"] == pytest.approx(direct, rel=1e-12)
        # 20 seeds: a standard deviation is known to ~16 %; 0.6..1.4 is 2.5 sigma
        for q in ("h_stderr", "z_stderr", "gain_stderr"):
            assert 0.6 < s.ratio(q) < 1.4, (s.label, s.channel, q, s.ratio(q))
    table = seed_table(stats)
    assert table.count("\n") == 1 + len(stats) and "estimator=ac" in table


def test_seeds_figure_shows_the_statistics(seeds_sweep: Path) -> None:
    data = load_sweep_data(seeds_sweep)
    stats = seed_statistics(data)
    fig = sweep_figure(data)
    ax = fig.axes[0]  # theta_rad, h scatter
    heights = [patch.get_height() for patch in ax.patches]
    theta = [s for s in stats if s.channel == "theta_rad"]
    np.testing.assert_allclose(heights, [s.predicted["h_stderr"] for s in theta])
    (dots,) = [c for c in ax.containers if c.get_label() == "measured"]  # the error bars
    np.testing.assert_allclose(dots.lines[0].get_ydata(), [s.measured["h_stderr"] for s in theta])
    plt.close(fig)
    info = json.loads(next((seeds_sweep / "points").glob("*/point.json")).read_text())
    assert set(info["predicted"]) == {"theta_rad", "q_rad_s"}


@pytest.fixture(scope="module")
def multisine_seeds(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The same seeds with a multisine of the same RMS over 3-12 Hz (harmonics 2 to 7)."""
    out = tmp_path_factory.mktemp("multisine-seeds")
    path = out / "ms.toml"
    seeds = ", ".join(str(s) for s in range(SEEDS))
    path.write_text(
        f'name = "ms"\nbase = "{DATA / "base-737-small.toml"}"\n'
        '[fixed]\n"disturbance.sensor_noise" = { theta_rad = 1e-5, q_rad_s = 1e-4 }\n'
        '"probe.signal" = "multisine"\n"probe.band_hz" = [3.0, 12.0]\n'
        '"output.estimator" = "spectral"\n'
        f'[grid]\n"disturbance.seed" = [{seeds}]\n'
    )
    result = run_sweep(load_sweep(path), out, jobs=2, progress=False)
    assert result.done == SEEDS
    return out / "ms"


def test_a_multisines_noise_is_predicted_by_its_own_weights(multisine_seeds: Path) -> None:
    """The spectral estimator's noise model (its weights: its estimates of unit samples) is
    what the points carry, and what 20 seeds measure."""
    from probing.core.excitation import Excitation
    from probing.core.prbs import Probe

    probe = Probe(5, 0.02, 0.01, Excitation("multisine", (3.0, 12.0)))
    model = noise_model(
        probe.reference(), 0.01, "spectral", 2, white(1e-5), harmonics=probe.harmonics
    )
    row = read_summary(multisine_seeds).iloc[0]
    rms = float(np.sqrt(np.mean(model.h_std() ** 2)))
    assert row["predicted_h_stderr"] == pytest.approx(rms, rel=1e-9)
    for s in seed_statistics(load_sweep_data(multisine_seeds)):
        for q in ("h_stderr", "gain_stderr"):
            assert 0.6 < s.ratio(q) < 1.4, (s.channel, q, s.ratio(q))
