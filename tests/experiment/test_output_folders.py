"""A run's folder holds one run's files: what an earlier run left there goes when a run
completes into it, and temporaries of a killed writer go on the next run, never a live one's.
"""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from probing.experiment.output.storage import RUN_FILES, metadata, output_folder

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = pa.schema([("x", pa.float64())])


def write(folder: Path, name: str, digest: str = "old") -> None:
    """A Parquet file of the project's kind, of the scenario ``digest``."""
    folder.mkdir(parents=True, exist_ok=True)
    table = pa.table({"x": [1.0]}).replace_schema_metadata(metadata(scenario_digest=digest))
    pq.write_table(table, folder / name)


def digest_of(path: Path) -> str:
    return pq.read_schema(path).metadata[b"probing.scenario_digest"].decode()


def test_a_completed_run_removes_the_files_an_earlier_run_left(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    for name in ("probing.parquet", "truth.parquet", "prediction.parquet", "monitor.parquet"):
        write(folder, name)
    (folder / "notes.txt").write_text("mine")  # not a file the project writes: kept
    stream = io.StringIO()
    with output_folder(folder, metadata(scenario_digest="new"), stream=stream) as out:
        out.writer("probing.parquet", [], schema=SCHEMA, description="new").write({"x": [2.0]})
    assert sorted(p.name for p in folder.iterdir()) == ["notes.txt", "probing.parquet"]
    assert digest_of(folder / "probing.parquet") == "new"
    lines = stream.getvalue().splitlines()
    assert len(lines) == 1, lines
    assert str(folder) in lines[0]
    for name in ("monitor.parquet", "prediction.parquet", "truth.parquet"):
        assert name in lines[0]


def test_a_failed_run_leaves_the_earlier_run_whole(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    for name in ("probing.parquet", "truth.parquet"):
        write(folder, name)
    stream = io.StringIO()
    with (
        pytest.raises(RuntimeError),
        output_folder(folder, metadata(scenario_digest="new"), stream=stream) as out,
    ):
        out.writer("probing.parquet", [], schema=SCHEMA, description="new").write({"x": [2.0]})
        raise RuntimeError("diverged")
    assert sorted(p.name for p in folder.iterdir()) == ["probing.parquet", "truth.parquet"]
    assert digest_of(folder / "probing.parquet") == "old"
    assert stream.getvalue() == ""


def test_files_added_to_a_run_keep_that_run_and_drop_another(tmp_path: Path) -> None:
    """``probing truth`` adds to the run of its scenario; a run of another scenario goes."""
    folder = tmp_path / "run"
    write(folder, "probing.parquet", "same")
    write(folder, "timeseries.parquet", "same")
    write(folder, "monitor.parquet", "other")
    with output_folder(folder, metadata(scenario_digest="same"), adds=True, stream=io.StringIO()):
        pass
    assert sorted(p.name for p in folder.iterdir()) == ["probing.parquet", "timeseries.parquet"]
    with output_folder(folder, metadata(scenario_digest="new"), adds=True, stream=io.StringIO()):
        pass
    assert list(folder.iterdir()) == []


def test_run_files_are_what_the_runners_write() -> None:
    assert set(RUN_FILES) >= {
        "probing.parquet",
        "bounds.parquet",
        "timeseries.parquet",
        "truth.parquet",
        "prediction.parquet",
        "monitor.parquet",
        "responses.parquet",
        "manoeuvre.parquet",
    }


# ------------------------------------------------------------------ the command line
SCENARIO = """\
name = "again"
[aircraft]
model = "737"
[condition]
altitude_ft = 15000
speed_kcas = 280
[simulation]
dt_s = 0.01
[probe]
order = 5
bit_duration_s = 0.02
amplitude_deg = {amplitude}
periods = {periods}
settle_periods = 1
[nonlinearity]
type = "none"
[output]
channels = ["theta_rad"]
drift = "reference"
"""


#: What ``probing run`` writes (without ``--truth``), sorted: two settled periods or more.
RUN_ONLY = ["bounds.parquet", "probing.parquet", "timeseries.parquet"]


def probing(*args: str, cache: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PROBING_TWIN_CACHE": str(cache)}
    return subprocess.run(
        [sys.executable, "-m", "probing", *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
        env=env,
    )


@pytest.mark.jsbsim
def test_a_second_run_of_the_same_name_leaves_one_runs_files(tmp_path: Path) -> None:
    first, second = tmp_path / "first.toml", tmp_path / "second.toml"
    first.write_text(SCENARIO.format(amplitude=0.01, periods=3))
    second.write_text(SCENARIO.format(amplitude=0.02, periods=3))
    out, cache = tmp_path / "out", tmp_path / "cache"
    folder = out / "again"

    res = probing("run", str(first), "--out", str(out), "--truth", cache=cache)
    assert res.returncode == 0, res.stderr
    names = sorted(p.name for p in folder.iterdir())
    assert names == [*RUN_ONLY[:1], "prediction.parquet", *RUN_ONLY[1:], "truth.parquet"]
    assert len({digest_of(folder / n) for n in names}) == 1  # run + truth: one run's files
    assert "earlier run" not in res.stdout + res.stderr

    res = probing("run", str(second), "--out", str(out), cache=cache)
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in folder.iterdir()) == RUN_ONLY
    said = [line for line in (res.stdout + res.stderr).splitlines() if "earlier run" in line]
    assert len(said) == 1 and "truth.parquet" in said[0] and "prediction.parquet" in said[0]

    res = probing("truth", str(second), "--out", str(out), cache=cache)  # adds to the run
    assert res.returncode == 0, res.stderr
    names = sorted(p.name for p in folder.iterdir())
    assert names == [*RUN_ONLY[:1], "prediction.parquet", *RUN_ONLY[1:], "truth.parquet"]
    assert len({digest_of(folder / n) for n in names}) == 1
    assert "earlier run" not in res.stdout + res.stderr

    res = probing("truth", str(first), "--out", str(out), cache=cache)  # another scenario's
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in folder.iterdir()) == ["prediction.parquet", "truth.parquet"]
    assert "earlier run" in res.stdout + res.stderr


# ------------------------------------------------------------------ killed runs
def start_long_run(out: Path, cache: Path, tmp_path: Path) -> subprocess.Popen:
    """``probing run`` of a long scenario, once its temporaries exist in the output folder
    and in the twin cache."""
    path = tmp_path / "long.toml"
    path.write_text(SCENARIO.format(amplitude=0.01, periods=20000))
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PROBING_TWIN_CACHE": str(cache)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "probing", "run", str(path), "--out", str(out)],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (
        list((out / "again").rglob(".probing.parquet.*.tmp")) and list(cache.glob(".*.tmp.npy"))
    ):
        time.sleep(0.02)
    time.sleep(0.5)  # a few chunks into the run
    assert proc.poll() is None, proc.communicate()
    return proc


def temporaries(*folders: Path) -> list[Path]:
    return [p for folder in folders if folder.exists() for p in folder.rglob("*.tmp*")]


@pytest.mark.jsbsim
def test_sigterm_cleans_up_like_an_exception(tmp_path: Path) -> None:
    out, cache = tmp_path / "out", tmp_path / "cache"
    proc = start_long_run(out, cache, tmp_path)
    proc.send_signal(signal.SIGTERM)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 143, stderr
    note, *error = stderr.splitlines()  # a run this long says so first, off a terminal
    assert note.startswith("probing: note: again: 1,240,000 steps, about "), stderr
    assert error == ["probing: error: terminated"] and stdout == ""
    assert temporaries(out, cache) == []
    assert not (out / "again").exists()  # the run created it: nothing is left


@pytest.mark.jsbsim
def test_a_rerun_removes_what_a_killed_run_left(tmp_path: Path) -> None:
    out, cache = tmp_path / "out", tmp_path / "cache"
    proc = start_long_run(out, cache, tmp_path)
    proc.kill()
    proc.communicate(timeout=60)
    left = temporaries(out, cache)
    # the run's work folder with its probing.parquet and timeseries.parquet, and the twin
    kinds = sorted(p.name.split(".")[1] for p in left if p.parent != cache)
    assert kinds == ["probing", "timeseries", "work"] and len(left) == 4, left
    short = tmp_path / "short.toml"
    short.write_text(SCENARIO.format(amplitude=0.01, periods=3))
    res = probing("run", str(short), "--out", str(out), cache=cache)
    assert res.returncode == 0, res.stderr
    assert temporaries(out, cache) == []
    assert sorted(p.name for p in (out / "again").iterdir()) == RUN_ONLY
