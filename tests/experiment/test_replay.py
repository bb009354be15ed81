"""A monitored flight's log (sensors.parquet) and its replay: the monitor computed from the
log alone equals the live flight's bit for bit, really reads the sensors it says it reads,
and never sees the simulated atmosphere."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import interrupt_when

from probing.core.sensors import SENSOR_SUITES
from probing.experiment.flight.monitor import ReplayError, monitor_scenario, replay_monitor
from probing.experiment.output.layouts import AUTOPILOT_COLUMNS
from probing.experiment.scenario import load_scenario
from probing.sim import plant as plant_module

pytestmark = pytest.mark.jsbsim

ROOT = Path(__file__).resolve().parents[2]
FOOTER = (b"probing.first_alarm_s", b"probing.verdict", b"probing.detector")


def _scenario(drift: str, **changes):
    """The study's flight (GTM, light turbulence, closed loop), NASA's T2 sensors, short."""
    base = load_scenario(ROOT / "scenarios" / "monitor" / "base.toml")
    return base.replace(
        {
            "probe.periods": 24,
            "monitor.baseline_periods": 14,
            "output.drift": drift,
            "disturbance.sensor_noise": {},
            "sensors": {"suite": "nasa_t2"},
            **changes,
        }
    )


@pytest.fixture(scope="module")
def flights(tmp_path_factory):
    out = tmp_path_factory.mktemp("live")
    return {d: monitor_scenario(_scenario(d), out / d, progress=False) for d in ("gust", "nominal")}


def _tables(folder: Path, name: str):
    return pq.read_table(folder / name).to_pandas(), pq.read_metadata(folder / name).metadata


@pytest.mark.parametrize("drift", ["gust", "nominal"])
def test_the_replay_of_a_log_is_the_live_monitor_bit_for_bit(flights, tmp_path, drift):
    live = flights[drift]
    again = replay_monitor(live.out_dir / "sensors.parquet", tmp_path, progress=False)
    for name in ("monitor.parquet", "probing.parquet", "bounds.parquet"):
        (a, ma), (b, mb) = _tables(live.out_dir, name), _tables(again.out_dir, name)
        assert len(a) > 0 and a.equals(b), name
        for key in FOOTER:
            assert ma.get(key) == mb.get(key), (name, key)
    assert (again.first_alarm_s, again.verdict) == (live.first_alarm_s, live.verdict)


def test_the_gust_reference_reads_the_alpha_vane(flights, tmp_path):
    """Replayed with the recorded alpha vane perturbed, the estimates change: the reference
    is computed from the log's air data, not from anything else."""
    log = flights["gust"].out_dir / "sensors.parquet"
    table, meta = pq.read_table(log), pq.read_metadata(log).metadata
    alpha = table.column("alpha_rad").to_numpy()
    bumped = alpha + np.radians(0.2) * np.sin(np.arange(alpha.size) / 40.0)
    column = table.schema.get_field_index("alpha_rad")
    table = table.set_column(column, "alpha_rad", pa.array(bumped))
    pq.write_table(table.replace_schema_metadata(meta), tmp_path / "perturbed.parquet")
    again = replay_monitor(tmp_path / "perturbed.parquet", tmp_path / "out", progress=False)
    a = _tables(flights["gust"].out_dir, "probing.parquet")[0]
    b = _tables(again.out_dir, "probing.parquet")[0]
    theta = (a.channel == "theta_rad").to_numpy()
    h_live, h_bumped = a.h_est.to_numpy()[theta], b.h_est.to_numpy()[theta]
    assert np.abs(h_live - h_bumped).max() > 0.1 * np.abs(h_live).max()


def test_a_realisable_replay_builds_no_turbulent_aircraft(flights, tmp_path, monkeypatch):
    """No path from the simulated atmosphere: replaying a gust or nominal log, every aircraft
    that is built flies in calm air."""
    seen = []
    disturb = plant_module.Plant.disturb

    def spy(self, turbulence, seed):
        seen.append(turbulence)
        return disturb(self, turbulence, seed)

    monkeypatch.setattr(plant_module.Plant, "disturb", spy)
    for drift in ("gust", "nominal"):
        replay_monitor(flights[drift].out_dir / "sensors.parquet", tmp_path / drift, progress=False)
    assert seen and set(seen) == {"none"}


def test_the_log_holds_what_the_flight_computer_had_and_nothing_else(flights):
    log = flights["gust"].out_dir / "sensors.parquet"
    names = pq.read_schema(log).names
    suite = list(SENSOR_SUITES["nasa_t2"].sensors)
    assert names == ["time_s", "probe_deg", *AUTOPILOT_COLUMNS, *suite]
    table = pq.read_table(log)
    dt = np.diff(table.column("time_s").to_numpy())
    np.testing.assert_allclose(dt, 0.01, rtol=1e-9)
    assert table.num_rows == 24 * 255


def test_a_follow_log_replays_bit_for_bit_from_its_recorded_commands(tmp_path):
    """drift = "follow": the flight computer flies its nominal model on the autopilot's
    commands it recorded, so a replay of the log (which holds them) gives the same tables."""
    scn = _scenario("follow", **{"disturbance.turbulence": "none"})
    live = monitor_scenario(scn, tmp_path / "live", progress=False)
    again = replay_monitor(live.out_dir / "sensors.parquet", tmp_path / "again", progress=False)
    for name in ("monitor.parquet", "probing.parquet", "bounds.parquet"):
        a, b = _tables(live.out_dir, name)[0], _tables(again.out_dir, name)[0]
        assert len(a) > 0 and a.equals(b), name


def test_a_follow_log_without_the_autopilots_commands_is_refused(tmp_path):
    scn = _scenario("follow", **{"disturbance.turbulence": "none"})
    live = monitor_scenario(scn, tmp_path / "live", progress=False)
    log = pq.read_table(live.out_dir / "sensors.parquet")
    cut = log.drop(list(AUTOPILOT_COLUMNS)).replace_schema_metadata(log.schema.metadata)
    pq.write_table(cut, tmp_path / "cut.parquet")
    with pytest.raises(ReplayError, match="autopilot_elevator_deg"):
        replay_monitor(tmp_path / "cut.parquet", tmp_path / "again", progress=False)


def _probing(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "probing", *args], capture_output=True, text=True, cwd=cwd
    )


def test_the_command_replays_and_refuses_in_one_line(flights, tmp_path):
    log = flights["nominal"].out_dir / "sensors.parquet"
    ok = _probing("monitor", "--replay", str(log), "--out", str(tmp_path / "r"), cwd=tmp_path)
    assert ok.returncode == 0, ok.stderr
    assert "(replayed)" in ok.stdout
    assert (tmp_path / "r" / "gtm-monitored" / "monitor.parquet").is_file()
    scenario = ROOT / "scenarios" / "monitor" / "base.toml"
    not_a_log = tmp_path / "x.parquet"
    pq.write_table(pa.table({"a": [1.0]}), not_a_log)
    for args in (
        ("monitor",),
        ("monitor", str(scenario), "--replay", str(log)),
        ("monitor", "--replay", str(not_a_log)),
        ("monitor", "--replay", str(tmp_path / "missing.parquet")),
        ("monitor", "--replay", str(log), "--timeseries"),
    ):
        bad = _probing(*args, "--out", str(tmp_path / "bad"), cwd=tmp_path)
        assert bad.returncode == 2, (args, bad.stderr)
        assert len(bad.stderr.strip().splitlines()) == 1, (args, bad.stderr)
        assert not (tmp_path / "bad").exists()


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_foreign_log_without_map_is_told_to_give_one(tmp_path, capsys, suffix):
    """A log recorded elsewhere (a CSV, or a Parquet file without a flight's metadata),
    replayed without --map: one line that names --map, exit 2, nothing written."""
    from probing.cli import main as cli_main

    log = tmp_path / f"flight{suffix}"
    if suffix == ".csv":
        log.write_text("t,q\n0,0.1\n0.01,0.2\n")
    else:
        pq.write_table(pa.table({"t": [0.0, 0.01], "q": [0.1, 0.2]}), log)
    capsys.readouterr()
    assert cli_main(["monitor", "--replay", str(log), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(f"probing: error: {log}"), err
    assert "--map" in err[0] and "docs/formats.md" in err[0], err
    assert not (tmp_path / "out").exists()


def _pyarrow_round_trip(log: Path, to: Path) -> None:
    pq.write_table(pq.read_table(log), to)


def _pandas_round_trip(log: Path, to: Path) -> None:
    import pandas as pd

    pd.read_parquet(log).to_parquet(to)


@pytest.mark.parametrize("round_trip", [_pyarrow_round_trip, _pandas_round_trip])
def test_a_log_read_and_written_again_replays_the_same(flights, tmp_path, round_trip):
    """A user's edit reads the log and writes it again (pyarrow's read_table/write_table,
    pandas' read_parquet/to_parquet): every key the replay needs survives, and the replay's
    tables equal the flight's."""
    live = flights["nominal"]
    copy = tmp_path / "edited.parquet"
    round_trip(live.out_dir / "sensors.parquet", copy)
    again = replay_monitor(copy, tmp_path / "out", progress=False)
    for name in ("monitor.parquet", "probing.parquet", "bounds.parquet"):
        a, b = _tables(live.out_dir, name)[0], _tables(again.out_dir, name)[0]
        assert len(a) > 0 and a.equals(b), name
    assert (again.first_alarm_s, again.verdict) == (live.first_alarm_s, live.verdict)


@pytest.mark.parametrize(
    "key", [b"probing.scenario", b"probing.scenario_digest", b"probing.trim_measured"]
)
def test_a_log_without_a_key_names_it(flights, tmp_path, key):
    log = flights["nominal"].out_dir / "sensors.parquet"
    table = pq.read_table(log)
    meta = {k: v for k, v in (table.schema.metadata or {}).items() if k != key}
    attrs = json.loads(meta.pop(b"PANDAS_ATTRS"))  # the copy pandas keeps: without it too
    del attrs[key.decode()]
    meta[b"PANDAS_ATTRS"] = json.dumps(attrs).encode()
    pq.write_table(table.replace_schema_metadata(meta), tmp_path / "cut.parquet")
    with pytest.raises(ReplayError, match=f"no metadata {key.decode()}"):
        replay_monitor(tmp_path / "cut.parquet", tmp_path / "out", progress=False)


def _null_at(table: pa.Table, column: str, row: int) -> pa.Table:
    values = table.column(column).to_pylist()
    values[row] = None
    return table.set_column(table.schema.get_field_index(column), column, pa.array(values))


def _nan_at(table: pa.Table, column: str, row: int) -> pa.Table:
    values = table.column(column).to_numpy().copy()
    values[row] = np.nan
    return table.set_column(table.schema.get_field_index(column), column, pa.array(values))


def _text(table: pa.Table, column: str) -> pa.Table:
    index = table.schema.get_field_index(column)
    return table.set_column(index, column, table.column(column).cast(pa.string()))


@pytest.mark.parametrize(
    ("drift", "spoil", "needle"),
    [
        ("nominal", lambda t: _null_at(t, "theta_rad", 100), "theta_rad has no value at row 100"),
        ("gust", lambda t: _nan_at(t, "alpha_rad", 200), "column alpha_rad has NaN at row 200"),
        ("nominal", lambda t: _nan_at(t, "time_s", 0), "column time_s has NaN at row 0"),
        ("gust", lambda t: t.drop_columns(["alpha_rad"]), "no column alpha_rad"),
        ("nominal", lambda t: pa.concat_tables([t.slice(0, 110), t.slice(100)]), "row 110 (1.01 s"),
        ("nominal", lambda t: _text(t, "theta_rad"), "column theta_rad holds string, not double"),
    ],
)  # fmt: skip
def test_a_spoilt_log_is_one_line_exit_2_nothing_written(
    flights, tmp_path, capsys, drift, spoil, needle
):
    """A value missing (null, NaN) or a column dropped, rows repeated, a column of text: one
    line naming the file, the column (and the row), exit 2, nothing written; was ArrowInvalid,
    IndexError or KeyError, an alarm the flight never had, or ArrowInvalid."""
    from probing.cli import main as cli_main

    log = flights[drift].out_dir / "sensors.parquet"
    table = pq.read_table(log)
    spoilt = tmp_path / "spoilt.parquet"
    pq.write_table(spoil(table).replace_schema_metadata(table.schema.metadata), spoilt)
    capsys.readouterr()
    assert cli_main(["monitor", "--replay", str(spoilt), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(f"probing: error: {spoilt}: "), err
    assert needle in err[0], err
    assert not (tmp_path / "out").exists()


def _duplicated(df):
    """Ten rows logged twice: time goes back at the first repeated row."""
    return pd.concat([df.iloc[:110], df.iloc[100:]])


def _a_period_more(df):
    """A period appended on the flight's grid, its probe the scenario's: more than it flew."""
    more = df.iloc[:255].assign(time_s=np.arange(6121, 6376) * 0.01)
    return pd.concat([df, more], ignore_index=True)


def _one_probe_value_off(df):
    probe = df.probe_deg.to_numpy().copy()
    probe[3000] *= 1.01
    return df.assign(probe_deg=probe)


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (lambda d: d.sample(frac=1, random_state=0), "time at row 0 is 28.5 s, not 0.01 s"),
        (_duplicated, "time does not increase at row 110 (1.01 s after 1.1 s)"),
        (lambda d: d.iloc[255:], "time at row 0 is 2.56 s, not 0.01 s"),
        (lambda d: d.iloc[:0], "it holds no rows"),
        (lambda d: d.iloc[:1], "1 row, not whole probe periods of 255 steps"),
        (lambda d: d.iloc[:-1], "6119 rows, not whole probe periods of 255 steps"),
        (_a_period_more, "6375 rows, more than its scenario's 24 periods (6120 steps)"),
        (lambda d: d.assign(theta_rad=d.theta_rad.astype(str)), "column theta_rad holds"),
        (
            lambda d: d.assign(theta_rad=d.theta_rad.astype("f4")),
            "theta_rad holds float, not double",
        ),
        (
            lambda d: d.assign(probe_deg=-d.probe_deg),
            "(probe_deg) is not the scenario's from row 0 on",
        ),
        (_one_probe_value_off, "its probe (probe_deg) is not the scenario's from row 3000 on"),
        (lambda d: d.drop(columns="probe_deg"), "no column probe_deg"),
    ],
)
def test_a_log_edited_into_another_flights_is_refused_in_one_line(flights, tmp_path, edit, needle):
    """A log edited with pandas (as a user would: read_parquet, edit, to_parquet) so that it
    is not the flight's: rows reordered, repeated, cut or added, a column of another type,
    another probe or none.  probing.replay raises ReplayError, one line naming the file and
    the first wrong row or column, and writes nothing; was accepted (a different estimate, an
    alarm the flight never had, an empty result), or a traceback."""
    import probing

    log = flights["nominal"].out_dir / "sensors.parquet"
    df = pd.read_parquet(log)
    edited = edit(df)
    edited.attrs = df.attrs  # pandas keeps the keys there: the edited log is still a log
    path = tmp_path / "edited.parquet"
    edited.to_parquet(path)
    with pytest.raises(ReplayError) as err:
        probing.replay(path, scratch=tmp_path / "scratch")
    line = str(err.value)
    assert line.startswith(f"{path}: ") and "\n" not in line and needle in line, line
    assert not (tmp_path / "scratch").exists()


REPLAY_FILES = ["bounds.parquet", "monitor.parquet", "probing.parquet"]


@pytest.mark.slow
@pytest.mark.parametrize("delay_s", [-1.0, 0.0, 0.1, 0.3, 0.6, 1.0, 1.5, 2.5])
def test_an_interrupted_replay_leaves_nothing(flights, tmp_path, delay_s):
    """Ctrl-C at any moment of a replay (``delay_s`` after its folder appears; -1: once a file
    appears in it): exit 130 and no folder, or it had finished (0) with its three tables."""
    log = flights["nominal"].out_dir / "sensors.parquet"
    out = tmp_path / "r"
    cmd = [sys.executable, "-m", "probing", "monitor", "--replay", str(log), "--out", str(out)]
    folder = out / "gtm-monitored"
    proc = interrupt_when(cmd, folder, delay_s)
    err = proc.stderr
    assert "Traceback" not in err, err
    if proc.returncode == 130:
        assert err.splitlines()[-1] == "probing: error: interrupted"
        assert not out.exists(), sorted(p.name for p in out.rglob("*"))
    else:
        assert proc.returncode == 0, err
        assert sorted(p.name for p in folder.iterdir()) == REPLAY_FILES
