"""The three signals on the 737 through no nonlinearity: each within 3 % of JSBSim's
linearised truth over its band, and the same files as the PRBS's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import base_scenario

from probing.core.excitation import band_limited
from probing.experiment.run import run_scenario
from probing.experiment.scenario import parse_scenario
from probing.experiment.truth import compute_truth, predicted_probing

pytestmark = pytest.mark.jsbsim

BAND = [0.2, 10.0]
SIGNALS = {
    "prbs": {},
    "multisine": {"probe.signal": "multisine", "probe.band_hz": BAND},
    "chirp": {"probe.signal": "chirp", "probe.band_hz": BAND},
    "chirp-log": {"probe.signal": "chirp", "probe.band_hz": BAND, "probe.sweep": "log"},
}


def rel_l2(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, tuple[object, Path]]:
    out = tmp_path_factory.mktemp("signals")
    done = {}
    for name, changes in SIGNALS.items():
        scn = parse_scenario(base_scenario(changes, name=name))
        run_scenario(scn, out, progress=False)
        compute_truth(scn, out)
        done[name] = (scn, out / name)
    return done


@pytest.mark.parametrize("name", list(SIGNALS))
def test_each_signal_is_within_3_percent_of_the_linearised_truth_in_its_band(runs, name) -> None:
    """The settled estimate against JSBSim's linearisation (one step's delay, as the PRBS's
    acceptance test takes it), superposed over the signal's own history and estimated by its
    own estimator: that is the linearised truth over the signal's harmonics."""
    scn, folder = runs[name]
    pr = pd.read_parquet(folder / "probing.parquet")
    truth = pd.read_parquet(folder / "truth.parquet")
    h_est = pr[pr.period >= scn.settle_periods].groupby(["channel", "tap"]).h_est.mean()
    for channel in ("theta_rad", "q_rad_s", "alpha_rad"):
        h_lin = truth[truth.channel == channel].h_lin.to_numpy()
        delayed = np.concatenate(([0.0], h_lin[:-1]))
        expected = predicted_probing(scn, {channel: delayed})[channel]
        expected = expected[scn.settle_periods :, 2].mean(axis=0)
        assert rel_l2(h_est[channel].to_numpy(), expected) < 0.03, channel


def test_a_band_estimate_is_the_truths_band_not_the_whole_truth(runs) -> None:
    """q's multisine estimate sits on the band-limited PRBS estimate, and away from the
    whole one: the band is what it recovers."""
    scn, folder = runs["multisine"]
    _, prbs_folder = runs["prbs"]
    read = lambda f: (  # noqa: E731
        pd.read_parquet(f / "probing.parquet")
        .query("channel == 'q_rad_s' and period >= 2")
        .groupby("tap")
        .h_est.mean()
        .to_numpy()
    )
    ms, prbs = read(folder), read(prbs_folder)
    assert rel_l2(ms, band_limited(prbs, scn.probe.harmonics)) < 0.02
    assert rel_l2(ms, prbs) > 0.05


def test_the_same_files_and_rms(runs) -> None:
    """Every signal writes the PRBS's tables with the same columns; the elevator's probe has
    the same RMS (the budget) and the scenario in the metadata names the signal."""
    columns = None
    for name, (scn, folder) in runs.items():
        pr = pd.read_parquet(folder / "probing.parquet")
        columns = columns or list(pr.columns)
        assert list(pr.columns) == columns
        bits = scn.probe.bits(1)
        assert np.sqrt(np.mean(bits**2)) == pytest.approx(0.005, rel=2e-3), name
        assert ('"signal"' in scn.to_json()) == (name != "prbs")
