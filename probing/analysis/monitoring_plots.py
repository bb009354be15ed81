"""The figures of the health-monitoring study (``figures/monitor_*.png``, docs/monitoring.md)."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.lines import Line2D

from probing.analysis.figures import (
    RC,
    legends_in_margins,
    response_unit,
    save_figure,
    text_colour_on,
)
from probing.analysis.monitoring import DRIFT_LABELS, FAULTS, Fault, roc
from probing.analysis.probe_only import probe_only_figure
from probing.experiment.output.storage import read_table
from probing.sim.surfaces import SURFACES

__all__ = [
    "amplitude_figure",
    "detection_figure",
    "draw_all",
    "fault_figure",
    "roc_figure",
    "verdict_figure",
]

#: The references in the order the figures show them, each with its line style: the
#: realisable ones first, the oracle (the bound that knows the gusts) after.
DRIFT_STYLE = {"gust": "-", "nominal": "-.", "follow": "-.", "oracle": ":", "detrend": "--"}


#: Each line style's name, for the legends.
STYLE_NAMES = {"-": "solid", "-.": "dash-dot", ":": "dotted", "--": "dashed"}


def _drifts(flights: pd.DataFrame) -> list[str]:
    """The references the flights have, in :data:`DRIFT_STYLE`'s order."""
    present = set(flights.drift)
    return [d for d in DRIFT_STYLE if d in present]


def _reference(drift: str) -> str:
    """How a panel's title names the reference its flights subtract (the data's own)."""
    return f"reference: {drift}"


def _reference_handles(drifts: list[str]) -> list[Line2D]:
    """A legend's entries for the references, one line style each (in a neutral grey),
    each named as the tables name it (the oracle as the bound)."""
    return [
        Line2D([], [], color="0.3", ls=DRIFT_STYLE[d], label=f"reference: {DRIFT_LABELS[d]}")
        for d in drifts
    ]


def _at_design_amplitude(flights: pd.DataFrame) -> pd.DataFrame:
    """The flights at the turbulence level every fault was flown at (where a study varies
    it) and at the design's probe amplitude where a study varies it: the largest one
    every fault was flown at (the others are the check of which detections are the probe's,
    and a fault's amplitude axis: in the tables and the amplitude figure)."""
    if "turbulence" in flights and flights.turbulence.nunique() > 1:  # a turbulence axis
        common = set.intersection(*(set(g.turbulence) for _, g in flights.groupby("fault")))
        if len(common) == 1:
            flights = flights[flights.turbulence == common.pop()]
    if "amplitude_deg" not in flights or flights.amplitude_deg.isna().all():
        return flights
    swept = flights[flights.amplitude_deg.notna()]  # NaN: the base scenario's amplitude
    per_fault = [set(g.amplitude_deg) for _, g in swept.groupby("fault")]
    common = set.intersection(*per_fault)
    design = max(common) if common else swept.amplitude_deg.max()
    return flights[(flights.amplitude_deg == design) | flights.amplitude_deg.isna()]


def _faults(flights: pd.DataFrame) -> list[str]:
    present = set(flights.fault)
    return [k for k in FAULTS if k in present and FAULTS[k].truth != "none"]


def detection_figure(flights: pd.DataFrame) -> plt.Figure:
    """Probability of detection by n probe periods after the onset, per fault (colour) and
    reference (line style); the legend beside the panel, where it hides no curve."""
    flights = _at_design_amplitude(flights)
    drifts = _drifts(flights)
    with plt.rc_context(RC):
        fig, ax = plt.subplots(figsize=(7.5, 3.6), layout="constrained")
        n = np.linspace(0, 12, 241)
        handles = []
        for i, key in enumerate(_faults(flights)):
            color = f"C{i}"
            for drift in drifts:
                g = flights[(flights.fault == key) & (flights.drift == drift)]
                if not len(g):
                    continue
                periods = g.delay_periods.to_numpy()
                p = [(periods <= x).mean() for x in n]
                ax.plot(n, p, DRIFT_STYLE[drift], color=color)
            handles.append(Line2D([], [], color=color, label=FAULTS[key].label))
        ax.axvline(3, color="0.5", lw=0.6)
        ax.axvline(5, color="0.5", lw=0.6)
        ax.axhline(0.95, color="0.5", lw=0.6, ls=":")
        ax.axhline(0.9, color="0.5", lw=0.6, ls=":")
        ax.set_xlabel("time after the onset (probe periods T)")
        ax.set_ylabel("probability of detection")
        ax.set_ylim(-0.02, 1.02)
        ax.set_title(
            "Detection after the onset: "
            + ", ".join(f"{d} ({STYLE_NAMES[DRIFT_STYLE[d]]})" for d in drifts),
            fontsize=8,
        )
        fig.legend(
            handles=handles + _reference_handles(drifts),
            loc="outside right upper",
            frameon=False,
        )
    return fig


def roc_figure(flights: pd.DataFrame) -> plt.Figure:
    """ROC per fault: detection within the goal's periods against false alarms per hour,
    the threshold (-log10 alpha) scaled by a factor c (alpha to the power c); the dot is the
    monitor's own threshold (c = 1).  One panel per reference; the legend beside them."""
    factors = np.geomspace(0.05, 50, 121)
    flights = _at_design_amplitude(flights)
    drifts = _drifts(flights)
    with plt.rc_context(RC):
        fig, axes = plt.subplots(
            1,
            len(drifts),
            figsize=(3.4 * len(drifts) + 1.6, 3.4),
            sharey=True,
            squeeze=False,
            layout="constrained",
        )
        axes = axes[0]
        handles = {}
        for ax, drift in zip(axes, drifts, strict=True):
            for i, key in enumerate(_faults(flights)):
                fa, pd_ = roc(flights, key, drift, factors)
                if not np.isfinite(fa).any():
                    continue
                ax.plot(np.maximum(fa, 1e-3), pd_, color=f"C{i}")
                one = int(np.argmin(np.abs(factors - 1.0)))
                ax.plot(max(fa[one], 1e-3), pd_[one], "o", color=f"C{i}", ms=3)
                handles[key] = Line2D([], [], color=f"C{i}", label=FAULTS[key].label)
            ax.set_xscale("log")
            ax.axvline(0.1, color="0.5", lw=0.6)
            ax.set_xlabel("false alarms per monitored hour (0: drawn at 1e-3)")
            ax.set_title(_reference(drift))
        axes[0].set_ylabel("probability of detection within the goal")
        dot = Line2D([], [], ls="None", marker="o", ms=3, color="0.3")
        dot.set_label("the monitor's threshold (c = 1)")
        fig.legend(
            handles=[*(handles[k] for k in _faults(flights) if k in handles), dot],
            loc="outside right upper",
            frameon=False,
            fontsize=6,
        )
    return fig


def verdict_figure(flights: pd.DataFrame) -> plt.Figure:
    """The verdicts after the onset per fault (rows) and reference (panels): counts, each
    written in black or white, whichever reads better on its cell."""
    flights = _at_design_amplitude(flights)
    keys = _faults(flights)
    # a sensor column where a sensor fault was flown or a flight was called one
    sensor = "sensor" in {FAULTS[k].truth for k in keys} | set(flights.verdict_after)
    cols = ["actuator", "airframe", *(["sensor"] if sensor else []), "none"]
    drifts = _drifts(flights)
    with plt.rc_context({**RC, "axes.grid": False}):
        fig, axes = plt.subplots(
            1,
            len(drifts),
            figsize=(3.75 * len(drifts), 0.45 * len(keys) + 1.2),
            sharey=True,
            squeeze=False,
            layout="constrained",
        )
        axes = axes[0]
        for ax, drift in zip(axes, drifts, strict=True):
            m = np.zeros((len(keys), len(cols)))
            for i, key in enumerate(keys):
                g = flights[(flights.fault == key) & (flights.drift == drift)]
                for j, c in enumerate(cols):
                    m[i, j] = (g.verdict_after == c).sum()
            image = ax.imshow(m, cmap="Blues", aspect="auto")
            for i in range(len(keys)):
                truth = FAULTS[keys[i]].truth
                for j in range(len(cols)):
                    ax.text(
                        j,
                        i,
                        f"{m[i, j]:.0f}",
                        ha="center",
                        va="center",
                        weight="bold" if cols[j] == truth else "normal",
                        color=text_colour_on(image.to_rgba(m[i, j])),
                    )
            ax.set_xticks(range(len(cols)), cols)
            ax.set_yticks(range(len(keys)), [FAULTS[k].label for k in keys])
            ax.set_title(f"verdicts, {_reference(drift)}\n(the right one in bold)")
    return fig


def fault_figure(flights: pd.DataFrame, key: str) -> plt.Figure:
    """One flight with the fault (the lowest seed, the first reference of
    :data:`DRIFT_STYLE` flown, the design's amplitude): its mean pulse-response estimate
    over the window before the onset and after it, and the test statistic of each
    detector; each panel's legend in a band above its curves."""
    flights = _at_design_amplitude(flights)
    drift = _drifts(flights[flights.fault == key])[0]
    g = flights[(flights.fault == key) & (flights.drift == drift)].sort_values("seed")
    f = g.iloc[0]
    folder = Path(f.folder)
    mon = read_table(folder / "monitor.parquet").to_pandas()
    channel = mon.channel.iloc[0]  # the monitored output (not the surface, an instrument)
    pr = read_table(folder / "probing.parquet").to_pandas()
    pr = pr[pr.channel == channel]
    window = 4
    onset_period = math.floor(f.fault_onset_s / f.period_s)
    before = range(onset_period - window, onset_period)
    after = range(onset_period + 1, onset_period + 1 + window)
    per = SURFACES[f.probe].unit if "probe" in f and f.probe in SURFACES else "deg"
    with plt.rc_context(RC):
        fig, (ax, bx) = plt.subplots(1, 2, figsize=(7.5, 3.2), layout="constrained")
        for periods, label, color in ((before, "before", "C0"), (after, "after", "C3")):
            sel = pr[pr.period.isin(periods)]
            h = sel.groupby("tap").h_est.mean()
            lag = sel.groupby("tap").lag_s.first()
            ax.plot(
                lag, h, color=color, label=f"{label} the onset (periods {periods[0]}-{periods[-1]})"
            )
        ax.set_xlabel("lag (s)")
        ax.set_ylabel(f"h_est of {channel} ({response_unit(channel, per)})")
        ax.set_title(f"{FAULTS[key].label}: pulse-response estimate")
        left = ax.legend(frameon=False, loc="upper center", ncol=1)
        tested = mon[mon.statistic.notna() & (mon.channel == channel)]
        if "detector" not in tested:
            tested = tested.assign(detector="probing")
        for detector, rows in tested.groupby("detector", sort=False):
            stat = np.maximum(rows.statistic, 1e-2)
            bx.semilogy(rows.time_s, stat, ".-", ms=2, lw=0.7, label=f"{detector} detector")
        bx.axhline(tested.threshold.iloc[0], color="C3", lw=0.8, label="threshold")
        bx.axvline(f.fault_onset_s, color="0.3", ls="--", lw=0.8, label="onset")
        bx.set_xlabel("time after the trim (s)")
        bx.set_ylabel("statistic: -log10 p of no change")
        found = (
            f"first alarm {f.delay_s:.1f} s after onset"
            if np.isfinite(f.delay_s)
            else "no alarm after onset"
        )
        bx.set_title(f"seed {f.seed}, {drift} reference: {found}")
        right = bx.legend(frameon=False, loc="upper center", ncol=3)
        legends_in_margins([(ax, left, []), (bx, right, [])])
    return fig


def _amplitude_faults(flights: pd.DataFrame) -> list[str]:
    """The faults flown at more than two probe amplitudes (an amplitude axis)."""
    if "amplitude_deg" not in flights:
        return []
    counts = flights.groupby("fault").amplitude_deg.nunique()
    return [k for k in _faults(flights) if counts.get(k, 0) > 2]


#: The colour of each turbulence level in the amplitude figure.
TURBULENCE_COLOR = {"none": "C0", "light": "C1", "moderate": "C3", "severe": "C4", "": "C7"}


def _delay_median(g: pd.DataFrame) -> float:
    """The median delay in periods, an undetected flight counting as infinitely late."""
    return float(np.median(g.delay_periods.fillna(math.inf)))


def _amplitude_lines(
    ax: plt.Axes, bx: plt.Axes, g: pd.DataFrame, spec: Fault, drift: str, level: str
) -> None:
    """One reference's and turbulence level's lines of the amplitude figure: detection
    within the goal (``ax``, a star where it first reaches the goal) and the median delay
    (``bx``), against the amplitude."""
    within = (g.delay_periods <= spec.goal_periods).astype(float)
    p = within.groupby(g.amplitude_deg).mean()
    med = g.groupby("amplitude_deg").apply(_delay_median, include_groups=False)
    style = dict(color=TURBULENCE_COLOR[level], ms=3)
    label = f"{drift}, {level or 'base'}"
    ax.plot(p.index, p.to_numpy(), DRIFT_STYLE[drift], marker="o", label=label, **style)
    shown = np.minimum(med.to_numpy(), 3 * spec.goal_periods)
    bx.plot(med.index, shown, DRIFT_STYLE[drift], marker="o", **style)
    reached = p[p >= spec.goal_probability]
    if len(reached):
        ax.plot(
            reached.index[0], reached.iloc[0], "*", ms=10, color=style["color"], mec="k", mew=0.4
        )


def amplitude_figure(flights: pd.DataFrame) -> plt.Figure:
    """The headline: per fault flown over an amplitude axis, the probability of detection
    within the goal's periods (left) and the median detection delay (right) against the
    probe's amplitude, one line per reference (style) and turbulence level (colour); a star
    where a line first reaches the goal.  A median delay past the top means most flights
    were never detected."""
    keys = _amplitude_faults(flights)
    drifts = _drifts(flights)
    levels = [t for t in TURBULENCE_COLOR if t in set(flights.turbulence)]
    with plt.rc_context(RC):
        fig, axes = plt.subplots(
            len(keys),
            2,
            figsize=(8.4, 3.5 * len(keys) + 0.6),
            squeeze=False,
            sharex=True,
            layout="constrained",
        )
        for (ax, bx), key in zip(axes, keys, strict=True):
            spec = FAULTS[key]
            for drift in drifts:
                for level in levels:
                    g = flights[
                        (flights.fault == key)
                        & (flights.drift == drift)
                        & (flights.turbulence == level)
                    ]
                    if len(g):
                        _amplitude_lines(ax, bx, g, spec, drift, level)
            ax.axhline(spec.goal_probability, color="0.5", lw=0.6, ls=":")
            bx.axhline(spec.goal_periods, color="0.5", lw=0.6, ls=":")
            ax.set_ylim(-0.02, 1.02)
            bx.set_ylim(0, 3 * spec.goal_periods * 1.02)
            for x in (ax, bx):
                x.set_xscale("log")
                x.set_xlabel("probe amplitude a (deg)")
            ax.set_ylabel(f"P(detected within {spec.goal_periods} T)")
            bx.set_ylabel("median detection delay (T; top: not detected)")
            ax.set_title(
                f"{spec.label}: goal {spec.goal_probability:g} within {spec.goal_periods} T",
                fontsize=8,
            )
            bx.set_title(
                "line: reference (oracle dotted: knows the gusts); colour: turbulence", fontsize=7
            )
        handles, _ = axes[0][0].get_legend_handles_labels()
        star = Line2D([], [], ls="None", marker="*", ms=8, color="0.6", mec="k", mew=0.4)
        star.set_label("where a line first reaches the goal")
        fig.legend(  # under the panels: their curves fill them
            handles=[*handles, star],
            loc="outside lower center",
            ncol=min(len(handles) + 1, 5),
            frameon=False,
            fontsize=6,
        )
    return fig


def draw_all(flights: pd.DataFrame, figures: Path) -> list[Path]:
    """Every figure of the study into ``figures`` (PNG); returns the files."""
    paths = []
    if _amplitude_faults(flights):
        paths += save_figure(amplitude_figure(flights), figures / "monitor_amplitude")
    paths += save_figure(detection_figure(flights), figures / "monitor_detection")
    paths += save_figure(roc_figure(flights), figures / "monitor_roc")
    paths += save_figure(verdict_figure(flights), figures / "monitor_verdicts")
    if "gust" in set(flights.drift):  # the realisable reference's: what only the probe sees
        paths += save_figure(probe_only_figure(flights), figures / "monitor_probe_only")
    for key in _faults(flights):
        paths += save_figure(fault_figure(flights, key), figures / f"monitor_{key}")
    return paths
