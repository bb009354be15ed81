"""The excitation comparison's figures (``docs/excitations.md``), from the stored runs.

* ``excitations_<panel key>.png``: one figure per Fig. 4 nonlinearity: per aircraft (rows)
  and signal (columns), the pitch-rate estimate through the nonlinearity, the same signal's
  linear baseline scaled by the predicted gain, and the theory's estimate;
* ``excitations_deadband_relay.png``: what the paper predicts for a non-binary input: each
  signal through the dead band and the relay of Fig. 4 (a stretch of one period), and the
  gain each harmonic sees, Q_k / P_k, against the PRBS's a~/a.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D

from probing.analysis.excitations import Study, ac, predicted_estimate
from probing.analysis.figures import (
    LW_DASHED_OVER,
    LW_OVER,
    LW_UNDER,
    RC,
    response_unit,
    save_figure,
)
from probing.core.metrics import gain_and_shape, harmonic_ratio
from probing.core.recorded import tap_bounds
from probing.experiment.output.layouts import BOUNDS_LEVEL
from probing.experiment.studies.fig4_set import PANELS

__all__ = ["draw"]

COLOURS = {"prbs": "tab:blue", "multisine": "tab:orange", "chirp": "tab:green"}
CHANNEL = "q_rad_s"
SHOWN_S = 3.0  # lags drawn, s


def _band(ax: Any, periods: np.ndarray, shown: np.ndarray, lag: np.ndarray, colour: str) -> None:
    """Shade the 95 % bounds per tap of the mean of ``periods`` (each without its mean)."""
    _, low, high, _ = tap_bounds(ac(periods), BOUNDS_LEVEL)
    ax.fill_between(lag[shown], low[shown], high[shown], color=colour, alpha=0.25, lw=0)


def _panel_figure(study: Study, key: str, bounds: bool = False) -> Any:
    aircraft, signals = study.aircraft, study.signals
    fig, axes = plt.subplots(
        len(aircraft),
        len(signals),
        figsize=(7.2, 2.1 * len(aircraft)),
        sharex=True,
        layout="constrained",
        squeeze=False,
    )
    for i, craft in enumerate(aircraft):
        for j, signal in enumerate(signals):
            ax = axes[i, j]
            base = study.run(craft, signal, "baseline")
            run = study.run(craft, signal, key)
            scn = run.scenario
            lag = np.arange(scn.bits_per_period) * scn.bit_duration_s
            shown = lag <= SHOWN_S
            h0, h = ac(base.mean(CHANNEL)), ac(run.mean(CHANNEL))
            predicted = ac(predicted_estimate(run, base, CHANNEL))
            g, shape = gain_and_shape(h, h0)
            ax.plot(  # thin and dotted, over the others: where all three coincide (a rate
                # limit the signal does not reach) the theory's dashes show between its dots
                lag[shown],
                h0[shown],
                color="0.45",
                ls=(0, (1.0, 1.5)),
                lw=LW_OVER,
                zorder=2.6,
                label="linear (same signal)",
            )
            ax.plot(  # wide: the theory's dashes lie on it (the PRBS's exactly)
                lag[shown], h[shown], color=COLOURS.get(signal, "k"), lw=LW_UNDER, label="measured"
            )
            ax.plot(
                lag[shown], predicted[shown], "k--", lw=LW_DASHED_OVER, zorder=2.5, label="theory"
            )
            if bounds:
                _band(ax, base.h[CHANNEL], shown, lag, "0.6")
                _band(ax, run.h[CHANNEL], shown, lag, COLOURS.get(signal, "k"))
            ax.set_title(f"{craft}, {signal}\ngain {g:.2f}, shape error {shape:.3f}", loc="left")
            if i == len(aircraft) - 1:
                ax.set_xlabel("lag (s)")
    # one label for the rows: each row's own was taller than the row and ran into the next
    fig.supylabel(f"q pulse response ({response_unit(CHANNEL)})", fontsize=8)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=3, fontsize=7)
    label = study.run(aircraft[0], signals[0], key).scenario
    fig.suptitle(
        f"Fig. 4 panel {PANELS[key]}: {label.nonlinearity_label} "
        f"({label.describe_nonlinearity()}), each estimate without its mean"
    )
    return fig


def _deadband_relay(study: Study) -> Any:
    craft = study.aircraft[0]
    fig, axes = plt.subplots(2, 2, figsize=(7.2, 4.6), layout="constrained")
    for i, key in enumerate(("a_deadband", "c_relay")):
        for signal in study.signals:
            run = study.run(craft, signal, key)
            scn = run.scenario
            probe, nl = scn.probe, scn.build_nonlinearity()
            bits = probe.bits(1)
            q, _ = nl.process(np.tile(bits, 2), scn.dt_s, nl.initial_state())
            q = q[bits.size :]
            n = np.arange(120)
            t = n * scn.bit_duration_s
            colour = COLOURS.get(signal, "k")
            axes[i, 0].step(
                t, bits[n] / scn.amplitude_deg, where="post", color=colour, lw=0.5, alpha=0.5
            )
            axes[i, 0].step(
                t, q[n] / scn.amplitude_deg, where="post", color=colour, lw=1.0, label=signal
            )
            ratio = harmonic_ratio(nl, bits, scn.dt_s)
            k = np.arange(ratio.size) if probe.harmonics is None else probe.harmonics
            k = k[k > 0]
            axes[i, 1].plot(
                k / probe.memory_s, np.abs(ratio[k]), ".", ms=2, color=colour, label=signal
            )
        a_t, _ = nl.apparent(scn.amplitude_deg)
        axes[i, 1].axhline(
            a_t / scn.amplitude_deg, color="k", lw=0.6, ls="--", label="a~/a (eqs. 10-12)"
        )
        axes[i, 0].set_title(
            f"{scn.nonlinearity_label}: probe (faint) and what passes, / a", loc="left"
        )
        axes[i, 1].set_title(
            f"{scn.nonlinearity_label}: gain each harmonic sees, |Q_k / P_k|", loc="left"
        )
        axes[i, 1].set_xscale("log")
        axes[i, 1].set_ylabel("|Q_k / P_k|")
        axes[i, 0].set_ylabel("deflection / a")
    axes[1, 0].set_xlabel("time (s)")
    axes[1, 1].set_xlabel("frequency (Hz)")
    handles = [  # a signal's colour: its steps (left) and its harmonics' gains (right)
        Line2D([], [], color=COLOURS.get(s, "k"), marker=".", ms=3, label=s) for s in study.signals
    ]
    probe = Line2D([], [], color="0.5", lw=0.5, alpha=0.5, label="the probe itself (faint)")
    handles += [probe, *axes[0, 1].get_legend_handles_labels()[0][len(study.signals) :]]
    fig.legend(handles=handles, loc="outside lower center", ncols=5, fontsize=7)
    fig.suptitle(
        "A binary probe keeps its shape through a dead band and a relay; "
        "a multisine and a chirp do not"
    )
    return fig


def draw(study: Study, folder: Path, bounds: bool = False) -> list[Path]:
    """Write every figure into ``folder``; the paths written.  ``bounds``: shade each
    estimate's 95 % bounds per tap over its settled periods in the nonlinearity figures."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    with plt.rc_context(RC):
        for key in PANELS:
            paths += save_figure(_panel_figure(study, key, bounds), folder / f"excitations_{key}")
        paths += save_figure(_deadband_relay(study), folder / "excitations_deadband_relay")
    return paths
