"""What only the probe sees: the monitor study's faults, detector by detector.

The monitor runs two detectors side by side, each with its own baseline and threshold
(``probing.experiment.flight.monitor``): the *probing* detector asks whether the pulse
response changed, the *trajectory* detector whether the output left the reference's.  Each
flight's footer keeps each one's first alarm, so each detector's delay is what it would
have been alone.  Per fault, turbulence and probe amplitude of a reference (the realisable
``gust`` by default), :func:`probe_only_table` gives

* each detector's probability of detection within the fault's goal;
* *probe only*: the share of flights the probing detector finds within the goal and the
  trajectory detector does not (the faults a monitor without a probe would miss);
* *delay saved*: over the flights the probing detector finds within the goal, the median of
  the trajectory detector's delay less the probing one's (positive: the probe is first), a
  trajectory detector that never alarms counting as infinitely late (so the median may be
  infinite: "never" in the tables).

This is the project's answer to "why probe at all": a fault the aircraft's trajectory shows
(NASA's damage cases, a stuck elevator) needs no probe; one it does not (a dead band about
the trim, which the autopilot's own motions hardly cross) needs one.  Reads Parquet only
(through :func:`probing.analysis.monitoring.evaluate`'s rows).
"""

from __future__ import annotations

import math

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from probing.analysis.figures import RC
from probing.analysis.monitoring import FAULTS

__all__ = ["probe_only_figure", "probe_only_markdown", "probe_only_table"]


def _saved(probing: pd.Series, trajectory: pd.Series) -> float:
    """The median of trajectory - probing delay (s), a missing trajectory alarm infinite."""
    if probing.empty:
        return math.nan
    return float(np.median(trajectory.fillna(math.inf).to_numpy() - probing.to_numpy()))


def probe_only_table(flights: pd.DataFrame, drift: str = "gust") -> pd.DataFrame:
    """Per fault, turbulence and amplitude of reference ``drift``: flights, each detector's
    probability of detection within the goal, the probe-only share and the median delay
    saved (s and periods; module docstring).

    Examples
    --------
    Three flights of the dead band: the probe finds all three within 5 periods of 2 s, the
    trajectory detector one, later, and two never:

    >>> rows = pd.DataFrame({"fault": ["deadband"] * 3, "drift": ["gust"] * 3,
    ...                      "period_s": [2.0] * 3, "delay_probing_s": [3.0, 4.0, 5.0],
    ...                      "delay_trajectory_s": [7.0, np.nan, np.nan]})
    >>> t = probe_only_table(rows).iloc[0]
    >>> [round(float(t[c]), 3) for c in ("p_probing", "p_trajectory", "probe_only")]
    [1.0, 0.333, 0.667]
    >>> float(t.saved_median_s)
    inf
    """
    out = []
    mine = flights[(flights.drift == drift) & (flights.fault != "none")].copy()
    for column in ("turbulence", "amplitude_deg"):
        if column not in mine:
            mine[column] = np.nan
    keys = ["fault", "turbulence", "amplitude_deg"]
    for (fault, turbulence, amplitude), g in mine.groupby(keys, sort=False, dropna=False):
        spec = FAULTS[fault]
        goal_s = spec.goal_periods * g.period_s
        probing = g.delay_probing_s <= goal_s
        trajectory = g.delay_trajectory_s <= goal_s
        saved = _saved(g.delay_probing_s[probing], g.delay_trajectory_s[probing])
        period_s = float(g.period_s.iloc[0])
        out.append(
            {
                "fault": fault,
                "label": spec.label,
                "turbulence": turbulence,
                "amplitude_deg": amplitude,
                "flights": len(g),
                "goal": f"{spec.goal_probability:g} within {spec.goal_periods} T",
                "p_probing": float(probing.mean()),
                "p_trajectory": float(trajectory.mean()),
                "probe_only": float((probing & ~trajectory).mean()),
                "saved_median_s": saved,
                "saved_median_T": saved / period_s,
            }
        )
    return pd.DataFrame(out)


def _when(seconds: float, periods: float) -> str:
    if math.isnan(seconds):
        return "-"
    if math.isinf(seconds):
        return "never found by the trajectory"
    return f"{seconds:.1f} s ({periods:.1f} T)"


def probe_only_markdown(flights: pd.DataFrame, drift: str = "gust") -> str:
    """The table of :func:`probe_only_table` as a Markdown section (empty without rows)."""
    table = probe_only_table(flights, drift)
    if table.empty:
        return ""
    lines = [
        "",
        f"## What only the probe sees ({drift} reference)",
        "",
        "Each detector alone (each has its own baseline and threshold): the probability of "
        "detection within the fault's goal, the share of flights only the probing detector "
        "finds within it, and over the flights the probing detector finds, the median of the "
        "trajectory detector's delay less the probing one's (`probing.analysis.probe_only`).",
        "",
        "| fault | turbulence | a, deg | flights | goal | probing | trajectory | probe only "
        "| delay saved, median |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in table.to_dict("records"):
        amplitude = "" if pd.isna(r["amplitude_deg"]) else f"{r['amplitude_deg']:g}"
        turbulence = "" if pd.isna(r["turbulence"]) else r["turbulence"]
        lines.append(
            f"| {r['label']} | {turbulence} | {amplitude} | {r['flights']} | {r['goal']} | "
            f"{r['p_probing']:.2f} | {r['p_trajectory']:.2f} | {r['probe_only']:.2f} | "
            f"{_when(r['saved_median_s'], r['saved_median_T'])} |"
        )
    return "\n".join(lines) + "\n"


def probe_only_figure(flights: pd.DataFrame, drift: str = "gust") -> plt.Figure:
    """Per fault, turbulence and amplitude, each detector's probability of detection within
    the goal, side by side; the bar of the flights only the probe finds hatched."""
    table = probe_only_table(flights, drift)
    labels = [
        f"{r.label}"
        + ("" if pd.isna(r.turbulence) else f", {r.turbulence}")
        + ("" if pd.isna(r.amplitude_deg) else f", a = {r.amplitude_deg:g} deg")
        for r in table.itertuples()
    ]
    y = np.arange(len(table))
    with plt.rc_context(RC):
        fig, ax = plt.subplots(figsize=(7.0, 0.28 * len(table) + 1.2))
        ax.barh(y - 0.2, table.p_probing, 0.4, color="C0", label="probing detector")
        ax.barh(y + 0.2, table.p_trajectory, 0.4, color="C7", label="trajectory detector")
        ax.barh(y - 0.2, table.probe_only, 0.4, color="none", edgecolor="k", hatch="///",
                lw=0.4, label="found by the probe only")  # fmt: skip
        ax.set_yticks(y, labels, fontsize=6)
        ax.invert_yaxis()
        ax.set_xlim(0, 1.02)
        ax.set_xlabel("P(detected within the goal's periods), each detector alone")
        ax.set_title(f"What only the probe sees ({drift} reference)", fontsize=8)
        ax.legend(frameon=False, fontsize=6, loc="lower right")
        fig.tight_layout()
    return fig
