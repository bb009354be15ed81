"""The references study's table and figure, on made-up flights whose gains are known by
construction: each period's estimate is a known multiple of one response."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from probing.analysis.references import draw, gain_scatter, load_runs, summary_markdown

M, PERIODS, SETTLE = 16, 30, 2
H0 = np.exp(-np.arange(M) / 4.0)


def _point(points: Path, pid: str, gains: np.ndarray, alarms: dict[str, int]) -> None:
    """A flight: period p's estimate is gains[p] * H0 (settled periods on), its monitor rows
    with ``alarms[detector]`` alarmed periods."""
    folder = points / f"point_id={pid}"
    folder.mkdir(parents=True)
    periods = np.repeat(np.arange(PERIODS), M).astype(np.int32)
    taps = np.tile(np.arange(M), PERIODS).astype(np.int32)
    h = (gains[:, None] * H0[None, :]).ravel()
    scenario = {"output": {"channels": ["theta_rad"]}, "probe": {"settle_periods": SETTLE}}
    table = pa.table(
        {
            "channel": ["theta_rad"] * h.size,
            "period": periods,
            "tap": taps,
            "lag_s": taps * 0.01,
            "z": h,
            "zeta": h,
            "h_est": h,
        }
    )
    meta = {b"probing.scenario": json.dumps(scenario).encode()}
    pq.write_table(table.replace_schema_metadata(meta), folder / "probing.parquet")
    rows = [(d, k < alarms.get(d, 0)) for d in ("probing", "trajectory") for k in range(PERIODS)]
    pq.write_table(
        pa.table({"detector": [r[0] for r in rows], "alarm": [r[1] for r in rows]}),
        folder / "monitor.parquet",
    )


@pytest.fixture
def study(tmp_path: Path) -> Path:
    """Two references, two turbulence levels, two seeds: the oracle's gains scatter by
    0.1, the gust's by 0.1 (calm) and 0.4 (light), settled periods; a wild first period."""
    sweep = tmp_path / "references"
    rows = []
    rng = np.random.default_rng(0)
    spread = {("oracle", "none"): 0.1, ("oracle", "light"): 0.1, ("gust", "none"): 0.1}
    spread[("gust", "light")] = 0.4
    for i, ((ref, turb), sd) in enumerate(spread.items()):
        for seed in (1, 2):
            g = rng.normal(0.0, 1.0, PERIODS)
            g = 1.0 + sd * (g - g[SETTLE:].mean()) / g[SETTLE:].std(ddof=1)
            g[0] = 50.0  # unsettled: left out
            pid = f"{i}{seed}"
            _point(sweep / "points", pid, g, {"trajectory": 1 if ref == "gust" else 0})
            rows.append(
                {
                    "point_id": pid,
                    "status": "done",
                    "drift": ref,
                    "disturbance.turbulence": turb,
                    "disturbance.seed": seed,
                }
            )
    rows.append({**rows[-1], "point_id": "failed", "status": "failed"})
    pq.write_table(pa.Table.from_pandas(pd.DataFrame(rows)), sweep / "summary.parquet")
    return tmp_path


def test_the_scatter_is_the_gains_spread_against_the_calm_oracles_response(study):
    runs = load_runs(study)
    assert len(runs) == 8  # the failed point is left out
    got = runs.groupby(["reference", "turbulence"]).gain_scatter.median()
    assert got[("oracle", "none")] == pytest.approx(0.1, rel=1e-9)
    assert got[("gust", "light")] == pytest.approx(0.4, rel=1e-9)


def test_the_table_gives_each_ratio_to_the_oracle_and_the_false_alarms(study):
    text = summary_markdown(load_runs(study))
    assert (
        "| light | gust | flown through the gust its sensors show | 0.400 (0.400-0.400) "
        "| 4.0 | 0 / 2 |" in text
    )
    assert (
        "| none | oracle | upper bound: knows the gusts | 0.100 (0.100-0.100) | 1.0 | 0 / 0 |"
        in text
    )


def test_the_figure_is_drawn(study, tmp_path, monkeypatch):
    """The figure is saved, and reads: its legend (in the upper left, over the dots) lifted
    above them, each flight's dot named (figure_problems)."""
    from probing.analysis import references
    from probing.analysis.figure_checks import figure_problems

    seen = []
    real = references.save_figure

    def check(fig, *args, **kwargs):
        seen.append(figure_problems(fig))
        return real(fig, *args, **kwargs)

    monkeypatch.setattr(references, "save_figure", check)
    (path,) = draw(load_runs(study), tmp_path / "figures")
    assert path.name == "references_scatter.png" and path.stat().st_size > 10_000
    assert seen == [[]]


def test_without_a_calm_oracle_or_a_sweep_it_says_so(tmp_path, study):
    with pytest.raises(FileNotFoundError, match="no references sweep"):
        load_runs(tmp_path / "nothing")
    summary = study / "references" / "summary.parquet"
    df = pd.read_parquet(summary)
    df = df[~((df.drift == "oracle") & (df["disturbance.turbulence"] == "none"))]
    pq.write_table(pa.Table.from_pandas(df), summary)
    with pytest.raises(FileNotFoundError, match="calm-air oracle"):
        load_runs(study)


def test_the_gain_is_the_projection_on_the_response():
    h = np.outer([0.5, 1.0, 1.5], H0)
    assert gain_scatter(h, H0) == pytest.approx(0.5)
    assert gain_scatter(h, 2 * H0) == pytest.approx(0.25)
