"""Every committed scenario runs through the command it is written for.

A scenario with ``[monitor]`` is flown by ``probing monitor --timeseries``, one with
``[simultaneous]`` by ``probing run --truth`` (as ``make simultaneous`` does), every other
one by ``probing run`` (which writes timeseries.parquet too; a ``[manoeuvre]`` its
manoeuvre.parquet).  Each is shortened to a few
periods (the monitor's baseline to the fewest its detector accepts), which keeps what is
checked: the files are written, and each column is named once.  Sweep files (a ``base``
key) are run by the sweep tests.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest
import tomli_w

from probing.cli import main
from probing.core.monitor import MonitorSettings

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted(
    p.relative_to(ROOT)
    for p in (ROOT / "scenarios").rglob("*.toml")
    if "base" not in tomllib.loads(p.read_text())
)


def _command(data: dict[str, Any]) -> list[str]:
    if "monitor" in data:
        return ["monitor", "--timeseries"]
    if "simultaneous" in data:
        return ["run", "--truth"]
    return ["run"]


def _shortened(data: dict[str, Any]) -> dict[str, Any]:
    """The scenario with as few periods as its command accepts (at most as many as before)."""
    data = {**data, "probe": dict(data["probe"])}
    settle = data["probe"].get("settle_periods", 0)
    extra = 3
    if "monitor" in data:
        mon = data["monitor"] = dict(data["monitor"])
        fewest = mon.get("windows", MonitorSettings().windows) + 2  # what the schema accepts
        mon["baseline_periods"] = min(mon.get("baseline_periods", fewest), fewest)
        extra = mon["baseline_periods"] + mon["window_periods"] + 1
    data["probe"]["periods"] = min(data["probe"]["periods"], settle + extra)
    return data


def test_every_committed_scenario_is_listed() -> None:
    """The list below is the scenarios folder's: fig4 sets, monitors, simultaneous, ..."""
    folders = {p.parent.name for p in SCENARIOS}
    assert {"fig4", "fig4-737", "monitor", "monitor-lateral", "simultaneous"} <= folders
    assert Path("scenarios/monitor/base.toml") in SCENARIOS
    assert Path("scenarios/monitor/stuck.toml") not in SCENARIOS  # a sweep file


@pytest.mark.jsbsim
@pytest.mark.slow
@pytest.mark.parametrize("path", SCENARIOS, ids=[str(p) for p in SCENARIOS])
def test_committed_scenario_runs_through_its_command(path: Path, tmp_path: Path) -> None:
    """Exit 0, the command's files in the run's folder, every Parquet column named once."""
    data = tomllib.loads((ROOT / path).read_text())
    short = tmp_path / path.name
    short.write_text(tomli_w.dumps(_shortened(data)))
    command = _command(data)
    assert main([command[0], str(short), "--out", str(tmp_path / "out"), *command[1:]]) == 0
    folder = tmp_path / "out" / data["name"]
    files = {p.name for p in folder.iterdir()}
    if "simultaneous" in data:
        assert "responses.parquet" in files
    elif "manoeuvre" in data:
        assert "manoeuvre.parquet" in files
    else:
        assert {"probing.parquet", "timeseries.parquet"} <= files
    if "monitor" in data:
        assert "monitor.parquet" in files
    for parquet in folder.glob("*.parquet"):
        names = pq.read_schema(parquet).names
        assert len(names) == len(set(names)), parquet.name
