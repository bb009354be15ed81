"""What each reference leaves of the gusts: the references study (``make references``).

Reads the ``references`` sweep (``scenarios/references/references.toml``): monitored GTM
flights without a fault, NASA's T2 sensors, each reference (``output.drift``) in calm air
and in light and moderate turbulence over several seeds.  For every flight it takes the
per-period gain of the pulse-response estimate of the first monitored channel, g_p = h_p .
h_0 / |h_0|^2 over its settled periods, and reports its standard deviation: what one
period's estimate scatters by with that reference.  h_0 is the mean estimate of the calm-air
oracle flights (every twin is the same aircraft there), one response for all, so a residual
that swamps the probe's response shows as a large scatter rather than being normalised by
itself.  The oracle (the
twin that knows the gusts) is the bound; the goal is a realisable reference within 5x of
it.  Reads Parquet only.
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from probing.analysis.figures import lift_legends, save_figure
from probing.core.fixedorder import dot, vdot
from probing.experiment.output.storage import read_footer, read_table

__all__ = [
    "GOAL_RATIO",
    "REFERENCES",
    "draw",
    "gain_scatter",
    "load_runs",
    "summary_markdown",
]

#: The references in the order they are shown, with what each knows.
REFERENCES = {
    "oracle": "upper bound: knows the gusts",
    "gust": "flown through the gust its sensors show",
    "nominal": "calm air, its own autopilot",
    "detrend": "no model",
}
#: The realisable reference's goal: its scatter at most this many times the oracle's.
GOAL_RATIO = 5.0
_TURBULENCE = ("none", "light", "moderate")


def gain_scatter(h: np.ndarray, h0: np.ndarray) -> float:
    """The standard deviation of the per-period gain against the response ``h0``.

    Parameters
    ----------
    h : numpy.ndarray
        ``(P, M)``: the periods' pulse-response estimates.
    h0 : numpy.ndarray
        ``(M,)``: the response the gain is measured against.

    Examples
    --------
    >>> h = np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]])
    >>> round(gain_scatter(h, np.array([2.0, 2.0])), 12)  # gains 0.5, 1, 1.5
    0.5
    """
    gains = dot(h, h0) / vdot(h0, h0)
    return float(gains.std(ddof=1))


def _point(folder: Path) -> dict[str, object]:
    """One flight's settled estimates ``h`` (P, M) of its first channel and its alarms."""
    probing = folder / "probing.parquet"
    scenario = json.loads(read_footer(probing)[b"probing.scenario"])
    channel = scenario["output"]["channels"][0]
    settle = scenario["probe"]["settle_periods"]
    table = read_table(probing, ["channel", "period", "tap", "h_est"]).to_pandas()
    rows = table[(table.channel == channel) & (table.period >= settle)]
    h = rows.sort_values(["period", "tap"]).h_est.to_numpy()
    m = int(rows.tap.max()) + 1
    monitor = read_table(folder / "monitor.parquet", ["detector", "alarm"]).to_pandas()
    alarms = monitor.groupby("detector").alarm.sum()
    return {
        "channel": channel,
        "h": h.reshape(-1, m),
        "probing_alarms": int(alarms.get("probing", 0)),
        "trajectory_alarms": int(alarms.get("trajectory", 0)),
        "periods": int(h.size // m),
    }


def load_runs(results: str | Path) -> pd.DataFrame:
    """Every finished flight of the references sweep under ``results``: its reference,
    turbulence, seed, gain scatter (against the calm oracle flights' mean response) and
    alarmed periods per detector.

    Raises
    ------
    FileNotFoundError
        If ``results`` holds no finished references sweep, or it has no calm oracle flight.
    """
    results = Path(results)
    summaries = sorted(results.glob("references/summary.parquet"))
    if not summaries:
        raise FileNotFoundError(f"{results}: no references sweep (references/summary.parquet)")
    summary = read_table(summaries[0]).to_pandas()
    done = summary[summary.status == "done"]
    if done.empty:
        raise FileNotFoundError(f"{summaries[0]}: no finished flight")
    points = summaries[0].parent / "points"
    rows = []
    for _, s in done.iterrows():
        found = _point(points / f"point_id={s.point_id}")
        rows.append(
            {
                "reference": s["drift"],
                "turbulence": s["disturbance.turbulence"],
                "seed": int(s["disturbance.seed"]),
                **found,
            }
        )
    runs = pd.DataFrame(rows)
    calm = runs[(runs.reference == "oracle") & (runs.turbulence == "none")]
    if calm.empty:
        raise FileNotFoundError(f"{summaries[0]}: no calm-air oracle flight to measure against")
    h0 = np.mean([h.mean(axis=0) for h in calm.h], axis=0)
    runs["gain_scatter"] = [gain_scatter(h, h0) for h in runs.h]
    return runs.drop(columns="h")


def _table(runs: pd.DataFrame) -> pd.DataFrame:
    """Median, min and max scatter per turbulence and reference, and the ratio of the
    medians to the oracle's."""
    g = runs.groupby(["turbulence", "reference"]).gain_scatter
    table = pd.DataFrame({"median": g.median(), "low": g.min(), "high": g.max(), "n": g.size()})
    table = table.reset_index()
    oracle = table[table.reference == "oracle"].set_index("turbulence")["median"]
    table["ratio"] = table["median"] / table.turbulence.map(oracle)
    alarms = runs.groupby(["turbulence", "reference"])[["probing_alarms", "trajectory_alarms"]]
    return table.merge(alarms.sum().reset_index(), on=["turbulence", "reference"])


def summary_markdown(runs: pd.DataFrame) -> str:
    """The study's table: per turbulence and reference the median per-period gain scatter
    (range over seeds), its ratio to the oracle's, and the alarmed periods (none is a
    fault: every one is a false alarm)."""
    table = _table(runs)
    channel = runs.channel.iloc[0]
    flights = runs.groupby(["turbulence", "reference"]).size().max()
    minutes = runs.periods.max() * 2.55 / 60.0
    lines = [
        "# What each reference leaves of the gusts",
        "",
        f"Per-period gain scatter of the {channel} pulse-response estimate against the calm "
        f"oracle flights' mean response, no fault, "
        f"NASA's T2 sensors; median over {flights} seeds (range), and its ratio to the "
        f"oracle's; alarmed periods of each detector over those flights (about "
        f"{minutes:.0f} min each; every alarm is a false alarm).  Written by `probing plot "
        f"references` (`make references`).",
        "",
        "| turbulence | reference | knows | gain scatter | x oracle | false alarms "
        "(probing / trajectory) |",
        "|---|---|---|---|---|---|",
    ]
    for turbulence in [t for t in _TURBULENCE if t in set(table.turbulence)]:
        for reference in [r for r in REFERENCES if r in set(table.reference)]:
            row = table[(table.turbulence == turbulence) & (table.reference == reference)]
            if row.empty:
                continue
            r = row.iloc[0]
            lines.append(
                f"| {turbulence} | {reference} | {REFERENCES[reference]} | "
                f"{r['median']:.3f} ({r['low']:.3f}-{r['high']:.3f}) | {r['ratio']:.1f} | "
                f"{int(r.probing_alarms)} / {int(r.trajectory_alarms)} |"
            )
    return "\n".join(lines) + "\n"


def draw(runs: pd.DataFrame, figures: Path) -> list[Path]:
    """``references_scatter.png``: the gain scatter by reference, grouped by turbulence,
    each flight a dot, the oracle's median times :data:`GOAL_RATIO` a dashed line."""
    table = _table(runs)
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    levels = [t for t in _TURBULENCE if t in set(runs.turbulence)]
    refs = [r for r in REFERENCES if r in set(runs.reference)]
    width = 0.8 / len(refs)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, turbulence in enumerate(levels):
        for j, reference in enumerate(refs):
            x = i + (j - (len(refs) - 1) / 2) * width
            mine = runs[(runs.turbulence == turbulence) & (runs.reference == reference)]
            row = table[(table.turbulence == turbulence) & (table.reference == reference)]
            ax.bar(x, row["median"].iloc[0], width * 0.9, color=colours[j], alpha=0.35)
            ax.plot(np.full(len(mine), x), mine.gain_scatter, ".", color=colours[j])
        oracle = table[(table.turbulence == turbulence) & (table.reference == "oracle")]
        if not oracle.empty:
            goal = GOAL_RATIO * oracle["median"].iloc[0]
            ax.plot([i - 0.45, i + 0.45], [goal, goal], "k--", lw=1)
    for j, reference in enumerate(refs):
        ax.bar(np.nan, np.nan, color=colours[j], alpha=0.35, label=f"{reference}")
    ax.plot([], [], "k--", lw=1, label=f"{GOAL_RATIO:g} x oracle (goal)")
    ax.plot([], [], ".", color="0.3", label="a flight (bar: the median)")
    ax.set_xticks(range(len(levels)), [f"turbulence: {t}" for t in levels])
    ax.set_yscale("log")
    ax.set_ylabel("per-period gain scatter (1 sigma)")
    ax.set_title("What each reference leaves: GTM, 800 ft, 75 KCAS, NASA T2 sensors")
    ax.legend(fontsize=8, ncol=3, loc="upper left")
    ax.grid(True, axis="y", which="both", alpha=0.3)
    lift_legends(fig)  # above the dots where they reach the upper left
    return save_figure(fig, figures / "references_scatter")
