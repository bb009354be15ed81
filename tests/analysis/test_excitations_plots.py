"""The excitation comparison's figures (``probing excitations``), drawn from a made-up
study: the real study's scenarios (every signal on the GTM and the 737, each Fig. 4
nonlinearity) with made-up estimates, no simulation."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest

from probing.analysis import excitations_plots
from probing.analysis.excitations import CHANNELS, Run, Study
from probing.analysis.figure_checks import figure_problems, hidden_lines, labels_without_unit
from probing.experiment.studies.excitations import planned

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> Study:
    """Each run's settled estimates: four periods of a damped oscillation, a run with a
    nonlinearity at two thirds of its baseline, a little scatter."""
    out = tmp_path_factory.mktemp("excitations")
    rng = np.random.default_rng(0)
    runs = {}
    for r in planned(ROOT / "scenarios", out):
        if r["role"] == "noise":
            continue
        scn = r["scenario"]
        lag = np.arange(scn.bits_per_period) * scn.bit_duration_s
        scale = 1.0 if r["role"] in ("baseline", "f_rate_limit") else 0.67  # (f): untouched
        shape = np.exp(-lag / 0.3) * np.sin(lag / 0.08) * scale
        h = {c: shape + 1e-3 * rng.standard_normal((4, lag.size)) for c in CHANNELS}
        runs[(r["aircraft"], r["signal"], r["role"], r["seed"])] = Run(scn, out, h, h)
    return Study(out, {}, runs)


def test_the_rows_share_one_label_with_its_unit(study: Study) -> None:
    """Each row's y label was taller than the row and ran into the next one's: one label for
    the figure now, with the unit in parentheses, and nothing else over another panel; the
    measured estimate is drawn wide under the theory's dashes, which lie on it."""
    with plt.rc_context(excitations_plots.RC):
        fig = excitations_plots._panel_figure(study, "a_deadband")
    assert figure_problems(fig) == []
    assert hidden_lines(fig) == []  # the theory's dashes lie on the PRBS's estimate
    assert labels_without_unit(fig) == []
    assert {ax.get_xlabel() for ax in fig.axes[-3:]} == {"lag (s)"}
    assert fig.get_supylabel() == "q pulse response (rad/s per deg)"
    plt.close(fig)


def test_the_dead_band_and_relay_figure_names_every_curve(study: Study) -> None:
    """The faint steps of the probe itself were in no legend."""
    with plt.rc_context(excitations_plots.RC):
        fig = excitations_plots._deadband_relay(study)
    assert figure_problems(fig) == []
    plt.close(fig)


def test_three_curves_that_coincide_all_show(study: Study) -> None:
    """A rate limit the signals do not reach: the linear estimate, the measured one and the
    theory are one curve; the linear one is dotted over the others (it was solid under the
    theory's dashes, which hid two thirds of it), each keeps its pixels."""
    with plt.rc_context(excitations_plots.RC):
        fig = excitations_plots._panel_figure(study, "f_rate_limit")
    assert hidden_lines(fig) == []
    plt.close(fig)
