"""The sweep figures of scatter: a sensor-noise level's measured against predicted standard
error (:func:`plot_noise`), and the scatter over seeds against the noise model
(:func:`plot_seeds`)."""

from __future__ import annotations

import math
from typing import Any

import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np
import pandas as pd

from probing.analysis.seeds import QUANTITIES, has_seeds, seed_statistics
from probing.analysis.sweep_axes import (
    C_FAIL,
    C_MEAS,
    C_THEORY,
    SIGMA,
    short_key,
    status_masks,
    sweep_context,
    sweep_title,
)
from probing.analysis.sweep_data import SweepData
from probing.sim.channels import CHANNELS

__all__ = ["SEED_TITLES", "plot_noise", "plot_seeds"]


# ------------------------------------------------------------------ 3. noise
def _noise_frame(data: SweepData) -> tuple[pd.DataFrame, str]:
    """One row per point, or per group of seeds: the naive rule, the measured and the
    predicted standard error of h, and what "measured" means."""
    df = data.summary
    if not has_seeds(data):
        frame = df.assign(measured=df["h_stderr"], predicted=df["predicted_h_stderr"])
        return frame, "measured: period-to-period spread / √P (not the seed-to-seed error)"
    channel = str(df["channel"].iloc[0])
    by_index = df.set_index("index")
    rows = []
    for s in seed_statistics(data):
        if s.channel == channel:
            first = by_index.loc[s.indices[0]]
            rows.append({**first.to_dict(), "index": s.indices[0], "status": "done",
                         "measured": s.measured["h_stderr"],
                         "predicted": s.predicted["h_stderr"]})  # fmt: skip
    frame = pd.DataFrame(rows) if rows else df.iloc[:0].assign(measured=[], predicted=[])
    seeds = len({v.get("disturbance.seed") for v in data.values.values()})
    return frame, (
        f"measured: standard deviation over the same {seeds} seeds at every point (the "
        f"noise scales as {SIGMA}/a: one draw, sampling error "
        f"{100 / math.sqrt(2 * (seeds - 1)):.0f} %)"
    )


def _reference_lines(
    ax1: Any,
    ax2: Any,
    data: SweepData,
    naive: np.ndarray,
    meas: np.ndarray,
    theory: np.ndarray,
    usable: np.ndarray,
) -> None:
    """The naive rule and the noise model over the usable points, the medians of measured
    over each, and the band of 25 % around the model on the ratio panel."""
    lo, hi = naive[usable].min() / 2, naive[usable].max() * 2
    line = np.array([lo, hi])
    ax1.loglog(line, line, ":", color="0.4", lw=1.0, label=f"y = x: {SIGMA}/(a √(MP))")
    th = usable & np.isfinite(theory) & (theory > 0)
    if th.any():
        order = np.argsort(naive[th])
        ax1.loglog(
            naive[th][order],
            theory[th][order],
            "--",
            color=C_THEORY,
            lw=0.8,
            label=f"noise model, {_estimators(data)} (+)",
        )
    r_naive = np.median(meas[usable] / naive[usable])
    r_theory = np.median(meas[th] / theory[th]) if th.any() else math.nan
    ax1.text(
        0.98,
        0.03,
        f"median measured / naive = {r_naive:.3g}\nmedian measured / noise model = {r_theory:.3f}",
        transform=ax1.transAxes,
        ha="right",
        va="bottom",
        fontsize=7,
        bbox={"fc": "white", "ec": "0.8", "lw": 0.5},
    )
    ax2.axhline(1.0, color=C_THEORY, ls="--", lw=0.8, label="= noise model")
    ax2.axhspan(0.75, 1.25, color="0.92", lw=0, label="within 25 %")
    ratio = meas[th] / theory[th] if th.any() else np.array([1.0])
    ax2.set_ylim(min(0.5, 0.9 * float(np.nanmin(ratio))), max(1.5, 1.1 * float(np.nanmax(ratio))))


def _notes(df: pd.DataFrame, data: SweepData, usable: np.ndarray, channel: str) -> list[str]:
    """What the figure leaves out: failed points, points not run, and points without noise
    on the channel drawn."""
    failed, missing = status_masks(df)
    noise_fields = [f for f in data.varying if f.startswith("disturbance.sensor_noise.")]
    skipped = int(len(df) - usable.sum() - failed.sum() - missing.sum())
    notes = []
    if failed.any():
        notes.append(f"{failed.sum()} failed (trim/divergence) points not shown")
    if missing.any():
        notes.append(f"{missing.sum()} points not run yet")
    if skipped:
        where = ", ".join(short_key(f) for f in noise_fields)
        elsewhere = f"; the varied noise is on {where}" if channel not in where.split(", ") else ""
        notes.append(f"{skipped} points with {SIGMA} = 0 on {channel} not shown{elsewhere}")
    return notes


def plot_noise(data: SweepData) -> Any:
    """Measured against predicted standard error of h, and their ratio, against
    sigma / (a sqrt(M P))."""
    df, meaning = _noise_frame(data)
    naive = df["h_stderr_naive"].to_numpy(dtype=float)
    meas = df["measured"].to_numpy(dtype=float)
    theory = df["predicted"].to_numpy(dtype=float)
    channel = str(df["channel"].iloc[0]) if "channel" in df and len(df) else "?"
    unit = CHANNELS[channel].unit if channel in CHANNELS else "output unit"
    amp_varies = "probe.amplitude_deg" in data.varying
    usable = np.isfinite(naive) & (naive > 0) & np.isfinite(meas) & (meas > 0)

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(7.6, 3.9), constrained_layout=True)
    if amp_varies:
        amps = np.array([data.values[int(i)]["probe.amplitude_deg"] for i in df["index"]])
        groups = [(f"a = {v:g} deg", amps == v) for v in sorted(set(amps.tolist()))]
    else:
        groups = [("measured", np.ones(len(df), dtype=bool))]
    for k, (lab, sel) in enumerate(groups):
        color = f"C{k}" if amp_varies else C_MEAS
        m = sel & usable
        if not m.any():
            continue
        ax1.loglog(naive[m], meas[m], "o", color=color, ms=4.5, label=lab)
        ax1.loglog(naive[m], theory[m], "+", color=color, ms=7, mew=1.0)
        ax2.semilogx(naive[m], meas[m] / theory[m], "o", color=color, ms=4.5, label=lab)
    if usable.any():
        _reference_lines(ax1, ax2, data, naive, meas, theory, usable)
    notes = _notes(df, data, usable, channel)
    if not usable.any():
        ax1.text(
            0.5,
            0.5,
            "no point with a usable standard error",
            transform=ax1.transAxes,
            ha="center",
            va="center",
            color=C_FAIL,
        )
    units = f"({unit})/deg"
    for ax in (ax1, ax2):
        ax.set_xlabel(f"{SIGMA} / (a √(M P))  [{units}]")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax1.set_ylabel(f"standard error of mean h  [{units}]")
    ax1.set_title("standard error of h (o measured, + noise model)", loc="left")
    if ax1.get_legend_handles_labels()[0]:
        legend = ax1.legend(frameon=False, loc="upper left")
        for handle, text in zip(legend.legend_handles, legend.get_texts(), strict=True):
            if text.get_text().startswith("noise model"):  # its points: each group's +
                handle.set_marker("+")
                handle.set_markersize(7)
    ax2.set_ylabel("measured / predicted standard error")
    ax2.set_title("measured over predicted (> 1: spread not from noise)", loc="left")
    if ax2.get_legend_handles_labels()[0]:
        ax2.legend(frameon=False, loc="best")
    context = sweep_context(data) + "".join(f"; {n}" for n in [meaning, *notes])
    fig.suptitle(sweep_title(data, context), fontsize=8, x=0.01, ha="left")
    return fig


def _estimators(data: SweepData) -> str:
    """The estimator(s) of the sweep's points, for labels."""
    names = {s.estimator for i in data.values if (s := data.scenario(i)) is not None}
    return ", ".join(sorted(names)) + " estimator" + ("s" if len(names) > 1 else "")


# ------------------------------------------------------------------ seeds
SEED_TITLES = {
    "h_stderr": "scatter of mean h_est, RMS over taps",
    "z_stderr": "scatter of mean z, RMS over taps",
    "gain_stderr": "scatter of the gain",
}


def plot_seeds(data: SweepData) -> Any:
    """Measured (dots, sampling error bars) against predicted (bars) scatter, per group of
    seeds (columns: h, z, gain; rows: the channels)."""
    stats = seed_statistics(data)
    channels = list(dict.fromkeys(s.channel for s in stats)) or ["?"]
    labels = list(dict.fromkeys(s.label for s in stats))
    fig, axes = plt.subplots(
        len(channels),
        len(QUANTITIES),
        figsize=(2.2 * len(QUANTITIES) + 0.6, 2.3 * len(channels) + 0.9),
        constrained_layout=True,
        squeeze=False,
    )
    x = np.arange(len(labels))
    for row, channel in enumerate(channels):
        unit = CHANNELS[channel].unit if channel in CHANNELS else "?"
        units = {"h_stderr": f"{unit}/deg", "z_stderr": unit, "gain_stderr": "1"}
        mine = {s.label: s for s in stats if s.channel == channel}
        for col, q in enumerate(QUANTITIES):
            ax = axes[row, col]
            meas = np.array([mine[lab].measured[q] if lab in mine else np.nan for lab in labels])
            pred = np.array([mine[lab].predicted[q] if lab in mine else np.nan for lab in labels])
            err = np.array([mine[lab].sampling_error if lab in mine else np.nan for lab in labels])
            ax.bar(x, pred, width=0.6, color="0.85", edgecolor="0.4", label="predicted")
            ax.errorbar(x, meas, yerr=meas * err, fmt="o", color=C_MEAS, ms=4, label="measured")
            for xi, m_, p_ in zip(x, meas, pred, strict=True):
                if np.isfinite(m_) and np.isfinite(p_) and p_ > 0:
                    ax.annotate(f"{m_ / p_:.2f}", (xi, m_), xytext=(0, 5),
                                textcoords="offset points", ha="center", fontsize=6)  # fmt: skip
            positive = np.concatenate([v[np.isfinite(v) & (v > 0)] for v in (meas, pred)])
            if positive.size:
                ax.set_yscale("log")
                ax.set_ylim(positive.min() / 3, positive.max() * 4)
            ax.set_xticks(x, labels, rotation=30, ha="right", fontsize=6)
            ax.set_title(f"{channel}: {SEED_TITLES[q]}", loc="left", fontsize=7)
            ax.set_ylabel(units[q])
    axes[0, 0].legend(frameon=False, loc="lower left", fontsize=6)
    seeds = stats[0].seeds if stats else 0
    line = (
        f"{sweep_context(data)}; {seeds} seeds per group; numbers: measured / predicted; "
        "error bars: sampling error of a standard deviation over the seeds"
    )
    fig.suptitle(sweep_title(data, line), fontsize=8, x=0.01, ha="left")
    return fig
