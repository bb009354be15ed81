"""Sweeps: validation before anything runs, results against closed-form gains, resume after a
real kill, Dask against the local pool, failed points, the dataset view."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import types
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from probing.cli import main as cli_main
from probing.experiment.scenario import ScenarioError, load_scenario
from probing.sweep import (
    SweepBusyError,
    load_sweep,
    open_dataset,
    parse_sweep,
    read_summary,
    run_sweep,
)
from probing.sweep.execute import _locked

DATA = Path(__file__).resolve().parents[1] / "data" / "sweeps"
SMALL = DATA / "backlash-small.toml"
BASE = DATA / "base-737-small.toml"
ROOT = Path(__file__).resolve().parents[2]


def write_sweep(tmp_path: Path, body: str, name: str = "s.toml") -> Path:
    path = tmp_path / name
    path.write_text(f'base = "{BASE}"\n' + body)
    return path


# ------------------------------------------------------------------ validation
BAD = {
    "unknown top-level field": ('name = "x"\ncolour = 1\n[grid]\n"probe.order" = [5]\n', "colour"),
    "missing name": ('[grid]\n"probe.order" = [5]\n', "name"),
    "bad name": ('name = "a/b"\n[grid]\n"probe.order" = [5]\n', "name"),
    "grid not a table": ('name = "x"\ngrid = 3\n', "grid"),
    "no varied field": ('name = "x"\n[fixed]\n"probe.order" = 5\n', "grid"),
    "not dotted": ('name = "x"\n[grid]\norder = [5]\n', 'grid["order"]'),
    "unknown section": ('name = "x"\n[grid]\n"plane.order" = [5]\n', 'grid["plane.order"]'),
    "too many dots": ('name = "x"\n[grid]\n"probe.order.x" = [5]\n', 'grid["probe.order.x"]'),
    "empty list": ('name = "x"\n[grid]\n"probe.order" = []\n', 'grid["probe.order"]'),
    "not a list": ('name = "x"\n[grid]\n"probe.order" = 5\n', 'grid["probe.order"]'),
    "zip lengths": (
        'name = "x"\n[zip]\n"probe.order" = [5, 6]\n"probe.periods" = [4]\n',
        "zip",
    ),
    "key twice": (
        'name = "x"\n[grid]\n"probe.order" = [5]\n[zip]\n"probe.order" = [6]\n',
        'zip["probe.order"]',
    ),
    "point out of range": (
        'name = "x"\n[grid]\n"nonlinearity.type" = ["backlash"]\n'
        '"nonlinearity.width_deg" = [0.01, -0.01]\n',
        'grid["nonlinearity.width_deg"]',
    ),
    "unknown scenario field": (
        'name = "x"\n[grid]\n"nonlinearity.type" = ["backlash"]\n"nonlinearity.widht_deg" = [1]\n',
        'grid["nonlinearity.widht_deg"]',
    ),
    "parameter missing at a point": (
        'name = "x"\n[grid]\n"nonlinearity.type" = ["backlash"]\n',
        "nonlinearity.width_deg",
    ),
    "repeated point": ('name = "x"\n[grid]\n"probe.order" = [5, 5]\n', "grid"),
    "order too high": ('name = "x"\n[grid]\n"probe.order" = [5, 21]\n', 'grid["probe.order"]'),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_sweeps_are_refused_naming_the_field(case: str, tmp_path: Path) -> None:
    body, field = BAD[case]
    path = write_sweep(tmp_path, body)
    with pytest.raises(ScenarioError) as info:
        load_sweep(path)
    assert info.value.field == field, str(info.value)
    assert str(path) in str(info.value)


def test_a_scenario_given_as_a_sweep_is_named_a_scenario(tmp_path: Path) -> None:
    """A scenario file is not a sweep: it said "aircraft: unknown field"; it says what the
    file is and what to do with it.  A sweep file with a scenario's section beside its base
    is a sweep with an unknown field, as before."""
    with pytest.raises(ScenarioError) as info:
        load_sweep(BASE)
    assert str(info.value) == (
        f"{BASE}: file: a scenario (it has [aircraft]), not a sweep file: fly it with "
        "probing run, or vary it from a sweep file whose base it is (docs/sweeps.md)"
    )
    path = write_sweep(tmp_path, 'name = "x"\n[aircraft]\nmodel = "737"\n')
    with pytest.raises(ScenarioError, match="aircraft: unknown field"):
        load_sweep(path)


def test_bad_base_is_refused(tmp_path: Path) -> None:
    (tmp_path / "bad.toml").write_text(BASE.read_text().replace("order = 5", "order = 1"))
    path = tmp_path / "s.toml"
    path.write_text('name = "x"\nbase = "bad.toml"\n[grid]\n"probe.periods" = [3]\n')
    with pytest.raises(ScenarioError, match=r"base: bad.toml: probe.order: must be an integer"):
        load_sweep(path)
    path.write_text('name = "x"\nbase = "nowhere.toml"\n[grid]\n"probe.periods" = [3]\n')
    with pytest.raises(ScenarioError, match=r"base: nowhere\.toml: file: does not exist"):
        load_sweep(path)


def test_cli_refuses_a_bad_sweep_with_one_line_exit_2_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_sweep(tmp_path, BAD["point out of range"][0])
    out = tmp_path / "out"
    assert cli_main(["sweep", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("probing: error: ")
    assert 'grid["nonlinearity.width_deg"]' in err and "point 1" in err
    assert not out.exists()
    assert cli_main(["sweep", str(SMALL), "--out", str(out), "-j", "0"]) == 2
    assert cli_main(["sweep", str(SMALL), "--out", str(out), "--scheduler", "tcp://x:1"]) == 2
    assert not out.exists()


def test_points_grid_zip_fixed_and_references(tmp_path: Path) -> None:
    path = write_sweep(
        tmp_path,
        'name = "combo"\n[fixed]\n"probe.periods" = 3\n'
        '[grid]\n"nonlinearity.type" = ["deadband", "none"]\n'
        '[zip]\n"probe.amplitude_deg" = [0.01, 0.02]\n"probe.order" = [5, 6]\n',
    )
    # A deadband needs its limits: refused, naming the missing parameter.
    with pytest.raises(ScenarioError, match=r"nonlinearity\.lower_deg: missing"):
        load_sweep(path)
    path = write_sweep(
        tmp_path,
        'name = "combo"\n[fixed]\n"probe.periods" = 3\n'
        '[grid]\n"nonlinearity.type" = ["backlash"]\n"nonlinearity.width_deg" = [0.0, 0.001]\n'
        '[zip]\n"probe.amplitude_deg" = [0.01, 0.02]\n"probe.order" = [5, 6]\n',
    )
    sweep = load_sweep(path)
    base = load_scenario(BASE)
    assert len(sweep.points) == 4
    assert sweep.fields == (
        "nonlinearity.type",
        "nonlinearity.width_deg",
        "probe.amplitude_deg",
        "probe.order",
    )
    p = sweep.points[3]
    assert p.values["nonlinearity.width_deg"] == 0.001 and p.values["probe.order"] == 6
    assert p.scenario.periods == 3 and p.scenario.amplitude_deg == 0.02
    assert p.scenario.name == "combo" and p.point_id == p.scenario.digest()
    assert p.scenario.replace(name=base.name, **{"probe.periods": 4}).model == base.model
    assert p.reference.nonlinearity == "none" and p.reference.order == 6
    # Two references (one per probe design), shared by the two widths each.
    assert len(sweep.references()) == 2
    assert len({q.point_id for q in sweep.points}) == 4


# ------------------------------------------------------------------ running
def _h_table(folder: Path) -> pd.DataFrame:
    return pq.read_table(folder / "probing.parquet").to_pandas()


def _point_data(sweep_dir: Path) -> dict[str, pd.DataFrame]:
    return {d.name: _h_table(d) for d in sorted((sweep_dir / "points").glob("point_id=*"))}


def _comparable(summary: pd.DataFrame) -> pd.DataFrame:
    return summary.drop(columns=["wall_s", "steps_simulated"])  # how, not what, was computed


def assert_same_results(ours: Path, theirs: Path) -> None:
    """Same summary (but for timing) and bit-identical probing.parquet for every point."""
    pd.testing.assert_frame_equal(
        _comparable(read_summary(ours)), _comparable(read_summary(theirs))
    )
    a, b = _point_data(ours), _point_data(theirs)
    assert a.keys() == b.keys()
    for pid in a:
        pd.testing.assert_frame_equal(a[pid], b[pid])


@pytest.fixture(scope="module")
def reference_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The small sweep run uninterrupted on the local pool with two workers."""
    out = tmp_path_factory.mktemp("uninterrupted")
    result = run_sweep(load_sweep(SMALL), out, jobs=2, progress=False)
    assert (result.done, result.skipped, result.failed, result.errors) == (6, 0, 0, 0)
    assert result.references == 1
    return out / "backlash-small"


@pytest.mark.jsbsim
def test_sweep_gains_match_closed_form(reference_run: Path) -> None:
    summary = read_summary(reference_run)
    assert list(summary["status"]) == ["done"] * 6
    w = summary["nonlinearity.width_deg"].to_numpy()
    a = 0.01
    closed_form = np.clip(1.0 - w / (2 * a), 0.0, None)  # backlash on a +-a square wave
    assert np.allclose(summary["predicted_gain"], closed_form, atol=1e-12)
    ok = closed_form > 0
    assert np.allclose(summary["measured_gain"][ok], closed_form[ok], rtol=1e-3)
    assert np.all(summary["shape_error"][ok] < 1e-3)
    assert np.allclose(summary["h_rms"][~ok], 0.0)
    # Each point folder holds the files of `probing run` and its own scenario's digest.
    for pid in summary["point_id"]:
        folder = reference_run / "points" / f"point_id={pid}"
        assert {"probing.parquet", "timeseries.parquet", "point.json"} <= {
            f.name for f in folder.iterdir()
        }
        meta = pq.read_schema(folder / "probing.parquet").metadata
        assert meta[b"probing.scenario_digest"].decode() == pid
    # The summary carries its provenance.
    meta = pq.read_schema(reference_run / "summary.parquet").metadata
    assert b"probing.sweep_toml" in meta and b"probing.versions" in meta


@pytest.mark.jsbsim
def test_points_are_the_same_bytes_as_runs_on_their_own(reference_run: Path, tmp_path: Path):
    """The sweep forks its points from one trimmed aircraft per chunk; each point's files
    equal, byte for byte, a run that loads and trims for itself."""
    from probing.experiment.flight.run import run_scenario

    for p in load_sweep(SMALL).points:
        alone = run_scenario(p.scenario, tmp_path, progress=False, twin_cache=False).out_dir
        folder = reference_run / "points" / f"point_id={p.point_id}"
        for name in ("probing.parquet", "timeseries.parquet"):
            assert (folder / name).read_bytes() == (alone / name).read_bytes(), name


@pytest.mark.jsbsim
def test_points_form_one_dataset(reference_run: Path) -> None:
    table = open_dataset(reference_run).to_table()
    summary = read_summary(reference_run)
    assert set(table.column("point_id").to_pylist()) == set(summary["point_id"])
    assert table.num_rows == 6 * 2 * 4 * 31  # points x channels x periods x taps
    ts = open_dataset(reference_run, "timeseries").to_table()
    assert ts.num_rows == 6 * 4 * 31 * 2  # points x periods x bits x steps per bit


@pytest.mark.jsbsim
def test_rerun_skips_finished_points_without_rewriting(reference_run: Path, tmp_path: Path) -> None:
    import shutil

    copy = tmp_path / "backlash-small"
    shutil.copytree(reference_run, copy)
    stamps = {f: f.stat().st_mtime_ns for f in copy.glob("points/*/*.parquet")}
    result = run_sweep(load_sweep(SMALL), tmp_path, jobs=2, progress=False)
    assert (result.done, result.skipped, result.references) == (0, 6, 0)
    assert stamps == {f: f.stat().st_mtime_ns for f in copy.glob("points/*/*.parquet")}
    pd.testing.assert_frame_equal(
        _comparable(read_summary(copy)), _comparable(read_summary(reference_run))
    )


def _signal_after_two_points(
    cmd: list[str], points: Path, sig: int
) -> tuple[subprocess.Popen, bytes]:
    """Start ``cmd``; once two points are finished, send ``sig`` to its whole process group
    (the CLI, its workers and their runs, as Ctrl-C in a terminal does); (process, stderr)."""
    proc = subprocess.Popen(
        cmd, cwd=ROOT, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(list(points.glob("point_id=*"))) < 2:
        time.sleep(0.005)
    os.killpg(proc.pid, sig)
    _, err = proc.communicate(timeout=60)
    return proc, err


@pytest.mark.jsbsim
@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT])
def test_resume_after_a_real_kill(sig: int, reference_run: Path, tmp_path: Path) -> None:
    cmd = [sys.executable, "-m", "probing", "sweep", str(SMALL), "--out", str(tmp_path), "-j", "1"]
    points = tmp_path / "backlash-small" / "points"
    proc, _ = _signal_after_two_points(cmd, points, sig)
    if sig == signal.SIGINT:
        assert proc.returncode == 130
    else:
        assert proc.returncode == -signal.SIGKILL
    finished = sorted(points.glob("point_id=*"))
    assert 2 <= len(finished) < 6, "the kill must land mid-sweep"
    for folder in finished:  # nothing half-written is visible
        assert (folder / "point.json").exists()
    stamps = {f: f.stat().st_mtime_ns for f in points.glob("point_id=*/*.parquet")}

    again = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert f"{6 - len(finished)} done, {len(finished)} skipped" in again.stdout
    assert stamps == {f: f.stat().st_mtime_ns for f in stamps}  # finished points untouched
    assert not list(points.glob(".tmp-*"))
    assert_same_results(tmp_path / "backlash-small", reference_run)


@pytest.mark.jsbsim
@pytest.mark.slow
def test_ctrl_c_stops_the_chunks_queued_behind_the_running_one(tmp_path: Path) -> None:
    """Three flight conditions: three chunks of 7 runs, one worker.  The pool's worker must
    not catch the KeyboardInterrupt and go on with the chunk queued behind (it did: all 14
    runs of two chunks finished after a Ctrl-C)."""
    sweep = tmp_path / "three.toml"
    sweep.write_text(
        f'name = "three"\nbase = "{BASE}"\n[grid]\n'
        '"condition.altitude_ft" = [15000, 16000, 17000]\n'
        '"nonlinearity.type" = ["backlash"]\n'
        '"nonlinearity.width_deg" = [0.0, 0.0025, 0.005, 0.0075, 0.01, 0.015]\n'
    )
    cmd = [sys.executable, "-m", "probing", "sweep", str(sweep), "--out", str(tmp_path), "-j", "1"]
    points = tmp_path / "three" / "points"
    proc, err = _signal_after_two_points(cmd, points, signal.SIGINT)
    assert proc.returncode == 130
    assert 2 <= len(list(points.glob("point_id=*"))) < 6  # the first chunk, interrupted
    assert b"Traceback" not in err and b"Exception ignored" not in err
    assert err.decode().strip().splitlines()[-1] == "probing: error: interrupted"


@pytest.mark.jsbsim
@pytest.mark.slow
def test_dask_local_cluster_equals_local_pool(reference_run: Path, tmp_path: Path) -> None:
    """Same results as the local pool, and no warning when Dask's usual port 8787 is taken
    (another cluster, or a notebook's dashboard)."""
    import socket
    import warnings

    with socket.socket() as busy, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            busy.bind(("", 8787))
            busy.listen()
        except OSError:  # someone else holds it already: the same situation
            pass
        result = run_sweep(load_sweep(SMALL), tmp_path, jobs=2, executor="dask", progress=False)
    assert not [str(w.message) for w in caught if "8787" in str(w.message)]
    assert (result.done, result.failed, result.errors) == (6, 0, 0)
    assert_same_results(tmp_path / "backlash-small", reference_run)


@pytest.fixture
def dask_cluster() -> Iterator[Any]:
    """A Dask cluster started apart from the sweep, as a user's would be: a scheduler and two
    single-threaded worker processes, which the sweeps reach by its address only.  Closed
    after each test: its workers are this process's children, which a local pool's
    interruption (another test) kills."""
    import logging

    from distributed import LocalCluster

    cluster = LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        silence_logs=logging.ERROR,
    )
    try:
        yield cluster
    finally:
        cluster.close()


def _sweep_on_scheduler(cluster: Any, path: Path, out: Path) -> tuple[int, dict[str, int]]:
    """``probing sweep PATH -j 1 --executor dask --scheduler ADDRESS``: its exit code, and
    how many chunks (``execute_chunk`` tasks) each of the cluster's workers ran, from the
    scheduler's task stream.  ``-j 1`` is there to show that the chunks are cut for the
    cluster's threads, not for ``-j``."""
    from distributed import Client, get_task_stream

    address = cluster.scheduler_address
    with Client(address) as client:
        client.wait_for_workers(2, timeout=60)
        with get_task_stream(client=client) as stream:
            args = ["sweep", str(path), "--out", str(out), "-j", "1"]
            code = cli_main([*args, "--executor", "dask", "--scheduler", address])
        workers = list(client.scheduler_info()["workers"])
    chunks = dict.fromkeys(workers, 0)
    for task in stream.data:
        if task["key"].startswith("execute_chunk-") and task["status"] == "OK":
            chunks[task["worker"]] += 1
    return code, chunks


@pytest.mark.jsbsim
@pytest.mark.slow
def test_a_sweep_on_a_running_scheduler_spreads_over_its_workers_and_equals_the_local_pool(
    dask_cluster: Any, reference_run: Path, tmp_path: Path
) -> None:
    """The small sweep's 7 runs (6 points and their reference, one trimmed state) are cut
    into 2 chunks for the cluster's 2 threads; each worker runs one."""
    code, chunks = _sweep_on_scheduler(dask_cluster, SMALL, tmp_path)
    assert code == 0
    assert sorted(chunks.values()) == [1, 1], chunks
    assert_same_results(tmp_path / "backlash-small", reference_run)


def _parquet_files(sweep_dir: Path) -> dict[str, pd.DataFrame]:
    return {
        str(p.relative_to(sweep_dir)): pq.read_table(p).to_pandas()
        for p in sorted((sweep_dir / "points").glob("*/*.parquet"))
    }


@pytest.mark.jsbsim
@pytest.mark.slow
def test_a_monitor_sweep_on_a_running_scheduler_equals_one_local_worker(
    dask_cluster: Any, tmp_path: Path
) -> None:
    """Two short monitored flights of the study (GTM, NASA's T2 sensors, the detrend
    reference, an effectiveness fault) on the cluster's two workers, one each: the same
    files, value for value, as on one local worker."""
    path = tmp_path / "mon.toml"
    path.write_text(
        f'name = "mon"\nbase = "{ROOT / "scenarios" / "references" / "base.toml"}"\n'
        'kind = "monitor"\n[fixed]\n"probe.periods" = 64\n"output.drift" = "detrend"\n'
        '"fault.type" = "effectiveness"\n"fault.scale" = 0.5\n"fault.onset_s" = 120.0\n'
        '[zip]\n"disturbance.seed" = [1, 2]\n'
    )
    local = tmp_path / "local"
    assert cli_main(["sweep", str(path), "--out", str(local), "-j", "1"]) == 0
    code, chunks = _sweep_on_scheduler(dask_cluster, path, tmp_path / "dask")
    assert code == 0
    assert sorted(chunks.values()) == [1, 1], chunks
    ours, theirs = _parquet_files(tmp_path / "dask" / "mon"), _parquet_files(local / "mon")
    assert len(ours) == 2 * 4 and ours.keys() == theirs.keys()  # 4 tables per flight
    for name in ours:
        pd.testing.assert_frame_equal(ours[name], theirs[name], check_exact=True, obj=name)
    pd.testing.assert_frame_equal(
        _comparable(read_summary(tmp_path / "dask" / "mon")),
        _comparable(read_summary(local / "mon")),
    )


@pytest.mark.jsbsim
def test_failed_point_is_recorded_and_the_sweep_goes_on(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 180 KCAS clean is below what the 737 model can trim at 15,000 ft.
    path = write_sweep(
        tmp_path,
        'name = "envelope"\n[grid]\n"condition.speed_kcas" = [280, 180]\n'
        '"nonlinearity.type" = ["deadband"]\n"nonlinearity.lower_deg" = [-0.002]\n'
        '"nonlinearity.upper_deg" = [0.002]\n',
    )
    out = tmp_path / "out"
    assert cli_main(["sweep", str(path), "--out", str(out), "-j", "2"]) == 0
    captured = capsys.readouterr()
    assert "2 points: 1 done, 0 skipped (already done), 1 failed" in captured.out
    summary = read_summary(out / "envelope")
    assert list(summary["status"]) == ["done", "failed"]
    assert "trim failed" in summary["message"][1]
    assert summary["measured_gain"][0] == pytest.approx(0.8, rel=1e-3)  # 1 - d/a
    assert np.isnan(summary["measured_gain"][1])
    # A rerun keeps the failure without retrying; --retry-failed tries again, which
    # rewrites the failure record (a retry that did nothing would leave it as it was).
    record = out / "envelope" / "failed" / f"{summary['point_id'][1]}.json"
    stale = {**json.loads(record.read_text()), "message": "written before the retry"}
    record.write_text(json.dumps(stale))
    assert cli_main(["sweep", str(path), "--out", str(out)]) == 0
    assert "0 done, 1 skipped (already done), 1 failed" in capsys.readouterr().out
    assert json.loads(record.read_text())["message"] == "written before the retry"
    assert cli_main(["sweep", str(path), "--out", str(out), "--retry-failed"]) == 0
    assert "0 done, 1 skipped (already done), 1 failed" in capsys.readouterr().out
    assert "trim failed" in json.loads(record.read_text())["message"]


def test_a_second_sweep_on_the_same_folder_is_refused(tmp_path: Path) -> None:
    with _locked(tmp_path / "backlash-small"):
        with pytest.raises(SweepBusyError, match="another sweep is running"):
            run_sweep(load_sweep(SMALL), tmp_path, jobs=1, progress=False)
        assert cli_main(["sweep", str(SMALL), "--out", str(tmp_path)]) == 1


def test_parse_sweep_needs_no_file(tmp_path: Path) -> None:
    data = {"name": "x", "base": str(BASE), "grid": {"probe.periods": [3, 5]}}
    sweep = parse_sweep(data, path=tmp_path / "virtual.toml")
    assert [p.scenario.periods for p in sweep.points] == [3, 5]


PROVIDED = sorted((ROOT / "scenarios" / "sweeps").glob("*.toml"))


def test_provided_sweeps_are_valid_and_named_after_their_files() -> None:
    kinds = set()
    for path in PROVIDED:
        sweep = load_sweep(path)
        assert sweep.name == path.stem
        assert sweep.description
        kinds.update(sweep.fields)
    # The list: each nonlinearity's parameter, noise against amplitude, the envelope.
    for field in (
        "nonlinearity.width_deg",
        "nonlinearity.upper_deg",
        "nonlinearity.high_deg",
        "nonlinearity.upper_threshold_deg",
        "nonlinearity.rate_deg_s",
        "probe.amplitude_deg",
        "condition.altitude_ft",
        "condition.speed_kcas",
        "output.estimator",
        "disturbance.seed",
    ):
        assert field in kinds
    assert len(PROVIDED) == 13


@pytest.mark.jsbsim
def test_summary_from_parquet_equals_summary_from_point_files(
    reference_run: Path, tmp_path: Path
) -> None:
    """The statistics the workers store in point.json equal a fresh read of the Parquet."""
    import json
    import shutil

    from probing.sweep import summarise

    copy = tmp_path / "backlash-small"
    shutil.copytree(reference_run, copy)
    for info_file in copy.glob("*/point_id=*/point.json"):
        info = json.loads(info_file.read_text())
        assert info["settled"]["periods"] == 2
        del info["settled"]
        info_file.write_text(json.dumps(info))
    sweep = load_sweep(SMALL)
    pd.testing.assert_frame_equal(summarise(sweep, copy), summarise(sweep, reference_run))


# ------------------------------------------------------------------ references, resume, lock
def test_reference_is_the_point_without_its_nonlinearity_turbulence_seed_included(
    tmp_path: Path,
) -> None:
    path = write_sweep(
        tmp_path,
        'name = "gusty"\n[fixed]\n"disturbance.turbulence" = "light"\n"disturbance.seed" = 7\n'
        '"output.drift" = "oracle"\n'
        '[grid]\n"nonlinearity.type" = ["backlash"]\n"nonlinearity.width_deg" = [0.001, 0.002]\n',
    )
    for p in load_sweep(path).points:
        expected = p.scenario.replace({"nonlinearity.type": "none"})
        assert p.reference == expected and p.reference_id == expected.digest()
        assert (p.reference.turbulence, p.reference.seed) == ("light", 7)


@pytest.mark.jsbsim
def test_resume_removes_stale_temporary_folders_and_the_lock(
    reference_run: Path, tmp_path: Path
) -> None:
    import shutil

    copy = tmp_path / "backlash-small"
    shutil.copytree(reference_run, copy)
    stale = [copy / "points" / ".tmp-point_id=0123-99-deadbeef", copy / "references" / ".tmp-x"]
    for folder in stale:
        folder.mkdir()
        (folder / "probing.parquet").write_bytes(b"half a file")
    result = run_sweep(load_sweep(SMALL), tmp_path, jobs=1, progress=False)
    assert (result.done, result.skipped) == (0, 6)
    assert not any(folder.exists() for folder in stale)
    assert not (copy / ".lock").exists()


@pytest.mark.jsbsim
def test_naive_standard_error_of_a_noisy_point(tmp_path: Path) -> None:
    """h_stderr_naive = sigma / (a sqrt(M P)), P the settled periods, for the noisy channel."""
    path = write_sweep(
        tmp_path,
        'name = "noisy"\n[grid]\n"disturbance.sensor_noise.theta_rad" = [1e-4]\n'
        '"probe.amplitude_deg" = [0.01, 0.02]\n',
    )
    run_sweep(load_sweep(path), tmp_path / "out", jobs=1, progress=False)
    summary = read_summary(tmp_path / "out" / "noisy")
    m, p = 31, 4 - 2  # base-737-small: order 5, 4 periods of which 2 settle
    for _, row in summary.iterrows():
        a = row["probe.amplitude_deg"]
        assert row["h_stderr_naive"] == pytest.approx(1e-4 / (a * np.sqrt(m * p)), rel=1e-12)
        assert row["h_stderr"] > 0


# ------------------------------------------------------------------ the summary for other tools
@pytest.mark.jsbsim
def test_summary_columns_carry_units(reference_run: Path) -> None:
    schema = pq.read_schema(reference_run / "summary.parquet")
    units = json.loads(schema.metadata[b"probing.units"])
    assert units["h_rms"] == {"theta_rad": "rad/deg"}
    assert units["h_stderr"] == {"theta_rad": "rad/deg"}
    assert units["predicted_offset_deg"] == "deg" and units["wall_s"] == "s"
    assert units["measured_gain"] == "1"
    field = schema.field("predicted_h_stderr")
    assert field.metadata[b"unit"] == b"<channel>/deg" and field.metadata[b"description"]
    assert b"one row per point" in schema.metadata[b"probing.description"]


def _docs_snippet(language: str, heading: str) -> str:
    text = (ROOT / "docs" / "sweeps.md").read_text(encoding="utf-8")
    section = text[text.index(heading) :]
    return section.split(f"```{language}\n", 1)[1].split("```", 1)[0]


@pytest.mark.jsbsim
def test_the_documented_joins_work_in_pandas_and_duckdb(reference_run: Path) -> None:
    import duckdb

    folder = str(reference_run)
    code = _docs_snippet("python", "### Joining").replace("results/sweeps/backlash-width", folder)
    namespace: dict = {}
    exec(compile(code, "docs/sweeps.md", "exec"), namespace)  # our own documentation
    theta = namespace["theta"]
    assert len(theta) == 6 * 4 * 31  # points x periods x taps of the summary's channel
    assert not [c for c in theta.columns if c.endswith(("_x", "_y"))]
    assert set(theta["nonlinearity.width_deg"]) == {0.0, 0.0025, 0.005, 0.0075, 0.01, 0.015}
    sql = _docs_snippet("sql", "### Joining").replace("results/sweeps/backlash-width", folder)
    rows = duckdb.sql(sql).fetchall()
    assert len(rows) == 6 * 4 * 31
    gains = {
        row[0]: row[1]
        for row in duckdb.sql(f"SELECT DISTINCT point_id, measured_gain FROM ({sql})").fetchall()
    }
    summary = read_summary(reference_run)
    assert gains == dict(zip(summary["point_id"], summary["measured_gain"], strict=True))


@pytest.mark.jsbsim
def test_sweep_prints_a_rounded_table_of_what_is_stored_as_computed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli_main(["sweep", str(SMALL), "--out", str(tmp_path), "-j", "2"]) == 0
    out = capsys.readouterr().out
    stored = read_summary(tmp_path / "backlash-small")["predicted_gain"][1]
    assert stored == (0.01 - 0.0025 / 2) / 0.01 == 0.8750000000000001  # a~/a as computed
    row = next(line.split() for line in out.splitlines() if line.startswith("1 "))
    assert row[:5] == ["1", "backlash", "0.0025", "done", "0.875"]
    assert "0.8750000000000001" not in out


@pytest.mark.jsbsim
def test_forked_runs_import_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A chunk imports what its runs need before it forks them: a module imported in a child
    is imported (and compiled, without bytecode files) again in every child."""
    import probing.sweep.execute as execute
    import probing.sweep.tasks as tasks_module

    def recording(tasks, aircraft=None):  # runs in the forked child
        before = set(sys.modules)
        records = run_flight(tasks, aircraft)
        return [{**r, "imported": sorted(set(sys.modules) - before)} for r in records]

    run_flight = tasks_module.execute_flight
    monkeypatch.setattr(tasks_module, "execute_flight", recording)
    sweep = load_sweep(SMALL)
    points_dir, _, failed_dir = execute.sweep_folders(tmp_path / sweep.name)
    tasks = [
        execute._task("point", p.point_id, p.scenario, points_dir, failed_dir)
        for p in sweep.points[:2]
    ]
    records = execute.execute_chunk(tasks)
    assert [r["status"] for r in records] == ["done"] * 2
    assert [r["imported"] for r in records] == [[]] * 2


@pytest.mark.jsbsim
def test_a_retry_that_succeeds_removes_the_old_failure_record(tmp_path: Path) -> None:
    """A point recorded as failed by an earlier invocation, run again and finished: its
    folder holds the point's file and ``failed/`` no longer holds its record (the listing of
    the disk is the truth), so nothing says it failed."""
    import probing.sweep.execute as execute

    sweep = load_sweep(SMALL)
    point = sweep.points[0]
    points_dir, _, failed_dir = execute.sweep_folders(tmp_path / sweep.name)
    task = execute._task("point", point.point_id, point.scenario, points_dir, failed_dir)
    failed_dir.mkdir(parents=True, exist_ok=True)
    record = failed_dir / f"{point.point_id}.json"
    record.write_text(json.dumps({"status": "failed", "message": "trim failed before"}))
    assert execute.execute_task(task)["status"] == "done"
    assert (Path(task.target) / "point.json").exists()
    assert list(failed_dir.iterdir()) == []


@pytest.mark.jsbsim
@pytest.mark.slow
@pytest.mark.parametrize("delay_s", [0.0, 0.2, 0.4, 0.7, 1.0, 1.3, 1.7, 2.2])
def test_ctrl_c_on_two_workers_is_one_line_whenever_it_lands(delay_s: float, tmp_path: Path):
    """Six flight conditions of two points each: twelve chunks for two workers, most of them
    queued when Ctrl-C lands.  The pool's manager thread set an exception on futures the
    interrupted sweep had cancelled (InvalidStateError: CANCELLED, a thread's traceback
    before the one line, in 2 of 4 tries)."""
    sweep = tmp_path / "six.toml"
    sweep.write_text(
        f'name = "six"\nbase = "{BASE}"\n[grid]\n'
        '"condition.altitude_ft" = [14000, 15000, 16000, 17000, 18000, 19000]\n'
        '"nonlinearity.type" = ["backlash"]\n'
        '"nonlinearity.width_deg" = [0.0, 0.005]\n'
        '[fixed]\n"probe.periods" = 1500\n'
    )
    cmd = [sys.executable, "-m", "probing", "sweep", str(sweep), "--out", str(tmp_path), "-j", "2"]
    proc = subprocess.Popen(
        cmd, cwd=ROOT, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    lock = tmp_path / "six" / ".lock"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not lock.exists():
        time.sleep(0.005)
    time.sleep(delay_s)
    os.killpg(proc.pid, signal.SIGINT)  # as Ctrl-C in a terminal: the whole group
    _, err = proc.communicate(timeout=60)
    lines = [line for line in err.decode().splitlines() if not line.startswith("six: ")]
    assert proc.returncode == 130, err.decode()
    assert lines == ["probing: error: interrupted"], err.decode()


def _slow_chunk(tasks: list) -> list:
    time.sleep(0.3)
    return []


def test_an_interrupted_local_pool_sets_nothing_on_a_cancelled_future(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The same race, made certain: the interrupt comes while ten chunks are queued, and the
    workers are killed after it; the pool's thread must not raise."""
    import threading

    from probing.sweep import execute

    errors = []
    monkeypatch.setattr(threading, "excepthook", lambda args: errors.append(args.exc_value))
    monkeypatch.setattr(execute, "execute_chunk", _slow_chunk)
    chunks = execute._Local(2).run([[i] for i in range(12)])
    assert next(chunks) == []
    with pytest.raises(KeyboardInterrupt):
        chunks.throw(KeyboardInterrupt)
    assert errors == []


def test_writing_the_summary_removes_a_killed_writers_half_summary(tmp_path: Path) -> None:
    """A sweep killed while writing summary.parquet left its temporary; the next summary
    written there removes it, and keeps a temporary of a writer that is still alive."""
    from probing.core.tempfiles import writer_tag
    from probing.sweep.summary import write_summary

    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        text=True,
        capture_output=True,
        check=True,
    ).stdout.strip()
    host = writer_tag().split("@", 1)[1]
    stale = tmp_path / f".summary.parquet.{dead}@{host}.tmp"
    live = tmp_path / f".summary.parquet.{os.getppid()}@{host}.tmp"
    stale.write_bytes(b"half")
    live.write_bytes(b"being written")
    write_summary(
        pd.DataFrame({"point_id": ["a"]}), tmp_path / "summary.parquet", load_sweep(SMALL)
    )
    assert not stale.exists() and live.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([live.name, "summary.parquet"])


@pytest.mark.parametrize("tasks", [1, 3])
@pytest.mark.parametrize("outcome", ["done", "failed"])
def test_each_task_of_a_shared_flight_records_its_share_of_the_flights_wall_time(
    tasks: int, outcome: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A flight of 6 s on a fake clock, shared by ``tasks`` monitored points (or flown by
    one): each point's ``point.json`` (or failure record) holds 6 s over the tasks, so the
    shares add up to the flight's wall time and a lone task's is the whole of it."""
    import probing.sweep.execute as execute
    import probing.sweep.tasks as tasks_module
    from probing.sim.errors import DivergenceError

    now = [100.0]
    clock = types.SimpleNamespace(perf_counter=lambda: now[0])
    monkeypatch.setattr(tasks_module, "time", clock)

    def fly(todo, tmps, aircraft):  # the flight: 6 s on the clock, nothing simulated
        now[0] += 6.0
        if outcome == "failed":
            raise DivergenceError("diverged at t = 1 s")
        facts = types.SimpleNamespace(facts=lambda: {"verdict": None})
        return [(types.SimpleNamespace(steps_simulated=10), facts) for _ in todo]

    monkeypatch.setattr(tasks_module, "_fly", fly)
    scn = load_scenario(BASE)
    points_dir, _, failed_dir = execute.sweep_folders(tmp_path / "s")
    todo = [
        execute._task("point", f"{i}", scn, points_dir, failed_dir, monitor=True)
        for i in range(tasks)
    ]
    records = tasks_module.execute_flight(todo)
    assert [r["status"] for r in records] == [outcome] * tasks
    assert [r["wall_s"] for r in records] == [6.0 / tasks] * tasks
    files = [
        Path(t.target) / "point.json" if outcome == "done" else Path(t.failed_file) for t in todo
    ]
    stored = [json.loads(f.read_text())["wall_s"] for f in files]
    assert stored == [6.0 / tasks] * tasks and sum(stored) == pytest.approx(6.0, rel=1e-15)
