"""The three signals on the 737 through no nonlinearity: each within 3 % of JSBSim's
linearised truth over its band, and the same files as the PRBS's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import base_scenario

from probing.core.excitation import band_limited
from probing.experiment.flight.run import run_scenario
from probing.experiment.scenario import parse_scenario
from probing.experiment.studies.truth import compute_truth, predicted_probing

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
    """The settled estimate against JSBSim's linearisation (stepped as JSBSim steps the
    aircraft, its one step's delay included), superposed over the signal's own history and
    estimated by its own estimator: that is the linearised truth over the signal's harmonics."""
    scn, folder = runs[name]
    pr = pd.read_parquet(folder / "probing.parquet")
    truth = pd.read_parquet(folder / "truth.parquet")
    h_est = pr[pr.period >= scn.settle_periods].groupby(["channel", "tap"]).h_est.mean()
    for channel in ("theta_rad", "q_rad_s", "alpha_rad"):
        h_lin = truth[truth.channel == channel].h_lin.to_numpy()
        expected = predicted_probing(scn, {channel: h_lin})[channel]
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


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Path:
    """``probing excitations`` once, into a temporary folder (about a minute)."""
    from probing.cli import main

    out = tmp_path_factory.mktemp("excitations")
    args = ["excitations", "--out", str(out / "results"), "--figures", str(out / "figures")]
    assert main([*args, "--summary", str(out / "summary.md")]) == 0
    return out


@pytest.mark.slow
def test_the_study_measures_what_the_paper_predicts(study: Path) -> None:
    """Through a dead band, a relay and backlash the PRBS keeps its shape and the others do
    not; every estimate agrees with the periodic theory; the 737's calm estimates are within
    3 % of the linearised truth in their band; the figures are drawn."""
    from probing.analysis.excitations import accuracy_rows, collect, nonlinearity_rows

    data = collect(study / "results")
    nl = nonlinearity_rows(data).set_index(["aircraft", "panel", "signal"])
    for craft in ("gtm", "737"):
        for panel in ("a", "c", "d", "g"):
            assert nl.loc[(craft, panel, "prbs"), "shape_error"] < 1e-3
            assert nl.loc[(craft, panel, "multisine"), "shape_error"] > 0.02
            assert nl.loc[(craft, panel, "chirp"), "shape_error"] > 0.02
        for panel in ("a", "c", "d"):
            for signal in ("prbs", "multisine", "chirp"):
                assert nl.loc[(craft, panel, signal), "theory_error"] < 0.07, (craft, panel, signal)
        # the rate limit below 2a/t0 reaches the PRBS's steps, not the gentler multisine's
        assert nl.loc[(craft, "e", "prbs"), "shape_error"] > 0.02
        assert nl.loc[(craft, "e", "multisine"), "shape_error"] < 1e-9
    acc = accuracy_rows(data).set_index(["aircraft", "signal", "channel"])
    for signal in ("prbs", "multisine", "chirp"):
        for channel in ("theta_rad", "q_rad_s"):
            assert acc.loc[("737", signal, channel), "error_band"] < 0.03
    text = (study / "summary.md").read_text()
    assert "## 737: the Fig. 4 nonlinearities" in text
    assert (study / "figures" / "excitations_deadband_relay.png").stat().st_size > 10_000
    assert len(list((study / "figures").glob("excitations_*.png"))) == 8


@pytest.mark.slow
def test_a_second_run_flies_nothing(study: Path, capsys) -> None:
    from probing.experiment.scenario import load_scenario  # noqa: F401  (the sets are valid)
    from probing.experiment.studies.excitations import run_study

    run_study(Path("scenarios"), study / "results", log=print)
    assert "0 to fly" in capsys.readouterr().out


def test_an_output_folder_that_is_a_file_is_refused(tmp_path: Path, capsys) -> None:
    from probing.cli import main

    (tmp_path / "x").write_text("")
    assert main(["excitations", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--out" in err[0]


@pytest.mark.slow
def test_bounds_shade_each_estimate_in_the_nonlinearity_figures(study: Path) -> None:
    """--bounds: two bands a panel (the linear estimate and the nonlinear one), each the
    95 % bounds of its settled periods; none without it."""
    from matplotlib.collections import PolyCollection

    from probing.analysis.excitations import ac, collect
    from probing.analysis.excitations_plots import CHANNEL, SHOWN_S, _panel_figure
    from probing.core.recorded import tap_bounds

    data = collect(study / "results")
    bands = lambda fig: [  # noqa: E731
        c for ax in fig.axes for c in ax.collections if isinstance(c, PolyCollection)
    ]
    assert bands(_panel_figure(data, "c_relay")) == []
    fig = _panel_figure(data, "c_relay", bounds=True)
    assert len(bands(fig)) == 2 * len(data.aircraft) * len(data.signals)
    run = data.run("737", "multisine", "c_relay")
    _, low, high, _ = tap_bounds(ac(run.h[CHANNEL]), 0.95)
    shown = np.arange(low.size) * run.scenario.bit_duration_s <= SHOWN_S
    band = bands(fig)[2 * (len(data.signals) + 1) + 1].get_paths()[0].vertices[:, 1]
    assert np.isclose(band.min(), min(low[shown].min(), high[shown].min()))
    assert np.isclose(band.max(), max(low[shown].max(), high[shown].max()))


def test_a_monitor_folder_without_sweeps_is_refused_before_anything_runs(
    tmp_path: Path, capsys
) -> None:
    from probing.cli import main

    (tmp_path / "empty").mkdir()
    out = tmp_path / "results"
    assert main(["excitations", "--out", str(out), "--monitor", str(tmp_path / "empty")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--monitor" in err[0] and "no monitor sweep" in err[0]
    assert not out.exists()
