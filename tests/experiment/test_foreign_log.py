"""``probing monitor --replay LOG --map MAP``: a log recorded elsewhere, monitored through the
same replay as a flight's own log.

A monitored flight's own sensors.parquet, written out as a foreign log (renamed columns,
CSV or Parquet, some angles in degrees), gives the replay of the original: bit for bit when
only the names change, to the rounding of deg -> rad when the units do."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from probing.cli import main as cli_main
from probing.experiment.flight.monitor import ReplayError, monitor_scenario, replay_monitor
from probing.experiment.recorded.foreign_log import foreign_log, read_map
from probing.experiment.scenario import load_scenario

pytestmark = pytest.mark.jsbsim

ROOT = Path(__file__).resolve().parents[2]
FOOTER = (b"probing.first_alarm_s", b"probing.verdict", b"probing.detector")
#: The angles the foreign log holds in degrees.
DEGREES = ("theta_rad", "alpha_rad", "phi_rad")


def scenario_text(drift: str) -> str:
    """The study's flight (GTM, light turbulence, closed loop) with NASA's T2 sensors, short
    (as tests/experiment/test_replay.py flies it), with the reference ``drift``."""
    text = (ROOT / "scenarios" / "monitor" / "base.toml").read_text()
    for old, new in [
        ("periods = 100", "periods = 24"),
        ("baseline_periods = 50", "baseline_periods = 14"),
        ('drift = "oracle"', f'drift = "{drift}"'),
    ]:
        assert old in text
        text = text.replace(old, new)
    text = text.replace(text[text.index("sensor_noise = ") : text.index("\n[control]")], "\n")
    return text + '\n[sensors]\nsuite = "nasa_t2"\n'


def fly(out: Path, drift: str) -> dict:
    path = out / f"{drift}.toml"
    path.write_text(scenario_text(drift))
    live = monitor_scenario(load_scenario(path), out / drift / "live", progress=False)
    log = live.out_dir / "sensors.parquet"
    again = replay_monitor(log, out / drift / "replayed", progress=False)
    return {"scenario": path, "log": log, "replayed": again.out_dir}


@pytest.fixture(scope="module")
def flights(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """A flight with the gust reference (most columns read) and one with ``detrend`` (no
    model: the trim reading is the baseline)."""
    out = tmp_path_factory.mktemp("flown")
    return {drift: fly(out, drift) for drift in ("gust", "detrend")}


@pytest.fixture(scope="module")
def flown(flights: dict) -> dict:
    return flights["gust"]


def foreign(log: Path) -> tuple[pd.DataFrame, dict[str, float]]:
    """The own log with every column renamed ``rec.<name>``, and its trim reading."""
    df = pq.read_table(log).to_pandas()
    meta = pq.read_metadata(log).metadata
    trim = json.loads(meta[b"probing.trim_measured"])
    return df.rename(columns={c: f"rec.{c}" for c in df.columns}), trim


def map_text(names: list[str], trim: dict[str, float] | None, degrees=()) -> str:
    lines = ["[columns]"]
    for name in names:
        if name in degrees:
            lines.append(f'{name} = {{ column = "rec.{name}", scale = {math.pi / 180!r} }}')
        else:
            lines.append(f'{name} = "rec.{name}"')
    if trim is None:
        lines += ["", "[trim]", "mean_before_s = 0.05"]
    else:
        lines += ["", "[trim.measured]", *(f"{k} = {v!r}" for k, v in trim.items())]
    return "\n".join(lines) + "\n"


def tables(folder: Path, name: str):
    return pq.read_table(folder / name).to_pandas(), pq.read_metadata(folder / name).metadata


def replay_foreign(flown: dict, log: Path, mapping: str, out: Path) -> Path:
    (out.parent / "map.toml").write_text(mapping)
    scn = load_scenario(flown["scenario"])
    table = foreign_log(log, read_map(out.parent / "map.toml"), scn)
    return replay_monitor(log, out, progress=False, table=table).out_dir


def assert_equal(flown: dict, folder: Path) -> None:
    for name in ("monitor.parquet", "probing.parquet"):
        (a, ma), (b, mb) = tables(flown["replayed"], name), tables(folder, name)
        assert len(a) > 0 and a.equals(b), name
        for key in FOOTER:
            assert ma.get(key) == mb.get(key), (name, key)


@pytest.mark.parametrize("drift", ["gust", "detrend"])
def test_a_renamed_csv_log_is_the_replay_bit_for_bit(
    flights: dict, drift: str, tmp_path: Path
) -> None:
    flown = flights[drift]
    df, trim = foreign(flown["log"])
    csv = tmp_path / "log.csv"
    df.to_csv(csv, index=False, float_format=None)  # repr: floats read back exactly
    names = [c.removeprefix("rec.") for c in df.columns]
    assert_equal(flown, replay_foreign(flown, csv, map_text(names, trim), tmp_path / "o"))


@pytest.mark.parametrize("drift", ["gust", "detrend"])
def test_a_parquet_log_with_the_trim_before_the_probe(
    flights: dict, drift: str, tmp_path: Path
) -> None:
    """Two rows before the probe (time -dt and 0) that read the trim: its mean is the trim
    reading (the baseline of ``detrend``), and they are not replayed."""
    flown = flights[drift]
    df, trim = foreign(flown["log"])
    before = pd.DataFrame({c: [trim.get(c.removeprefix("rec."), 0.0)] * 2 for c in df.columns})
    before["rec.time_s"] = [-0.01, 0.0]
    log = tmp_path / "log.parquet"
    pd.concat([before, df], ignore_index=True).to_parquet(log)
    names = [c.removeprefix("rec.") for c in df.columns]
    assert_equal(flown, replay_foreign(flown, log, map_text(names, None), tmp_path / "o"))


@pytest.mark.parametrize(
    ("before_s", "rows"),
    [(0.025, [-0.02, -0.01, 0.0]), (0.02, [-0.01, 0.0])],
)
def test_the_trim_reading_is_the_mean_of_the_rows_up_to_time_0(
    flown: dict, tmp_path: Path, before_s: float, rows: list[float]
) -> None:
    """``mean_before_s = S`` averages the rows with -S < time <= 0: the row at time 0 (the
    trim, before the first probe step) counts, one exactly S before does not."""
    df, trim = foreign(flown["log"])
    times = [-0.02, -0.01, 0.0]
    # each row before the probe reads the trim plus its own offset: 1, 10, 100 (channel unit)
    offsets = dict(zip(times, [1.0, 10.0, 100.0], strict=True))
    before = pd.DataFrame(
        {c: [trim.get(c.removeprefix("rec."), 0.0) + offsets[t] for t in times] for c in df.columns}
    )
    before["rec.time_s"] = times
    log = tmp_path / "log.parquet"
    pd.concat([before, df], ignore_index=True).to_parquet(log)
    names = [c.removeprefix("rec.") for c in df.columns]
    mapping = map_text(names, None).replace("mean_before_s = 0.05", f"mean_before_s = {before_s}")
    (tmp_path / "map.toml").write_text(mapping)
    table = foreign_log(log, read_map(tmp_path / "map.toml"), load_scenario(flown["scenario"]))
    got = json.loads(table.schema.metadata[b"probing.trim_measured"])
    shift = float(np.mean([offsets[t] for t in rows]))
    assert got == pytest.approx({c: v + shift for c, v in trim.items()}, rel=0, abs=1e-9)


def test_degrees_scaled_to_radians_give_the_replay_to_rounding(flown: dict, tmp_path: Path) -> None:
    """theta, alpha and phi logged in deg and scaled by pi/180: the inputs differ from the
    original by a few units in the last place, the estimates by less than 1e-9 relative."""
    df, trim = foreign(flown["log"])
    for name in DEGREES:
        df[f"rec.{name}"] = np.degrees(df[f"rec.{name}"])
    csv = tmp_path / "log.csv"
    df.to_csv(csv, index=False)
    names = [c.removeprefix("rec.") for c in df.columns]
    folder = replay_foreign(flown, csv, map_text(names, trim, DEGREES), tmp_path / "o")
    for name, keys in [
        ("monitor.parquet", ["statistic", "threshold", "gain_change", "shape_change"]),
        ("probing.parquet", ["z", "zeta", "h_est"]),
    ]:
        a, b = tables(flown["replayed"], name)[0], tables(folder, name)[0]
        assert list(a.columns) == list(b.columns) and len(a) == len(b) > 0
        for key in a.columns:
            if key in keys:
                scale = np.nanmax(np.abs(a[key].to_numpy()))
                np.testing.assert_allclose(b[key], a[key], rtol=0, atol=1e-9 * scale)
            else:
                assert a[key].equals(b[key]), (name, key)


# ------------------------------------------------------------------ refusals
def refused(argv: list[str], tmp_path: Path, capsys, needle: str) -> None:
    out = tmp_path / "out"
    assert cli_main([*argv, "--out", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1, captured.err
    assert needle in captured.err, captured.err
    assert not out.exists()


def small_log(flown: dict, tmp_path: Path, change) -> list[str]:
    """A foreign CSV of the flight, changed by ``change(df)``; the command line to monitor
    it with its map."""
    df, trim = foreign(flown["log"])
    names = [c.removeprefix("rec.") for c in df.columns]
    mapping = map_text(names, trim)
    df, mapping = change(df, mapping)
    df.to_csv(tmp_path / "log.csv", index=False)
    (tmp_path / "map.toml").write_text(mapping)
    return [
        "monitor",
        str(flown["scenario"]),
        "--replay",
        str(tmp_path / "log.csv"),
        "--map",
        str(tmp_path / "map.toml"),
    ]


def _nan(df, m):
    df.loc[100, "rec.theta_rad"] = np.nan
    return df, m


def _backwards(df, m):
    df.loc[50, "rec.time_s"] = df.loc[48, "rec.time_s"]
    return df, m


def _repeated(df, m):
    return pd.concat([df.iloc[:110], df.iloc[100:]]), m


def _half_a_step_late(df, m):
    df["rec.time_s"] += 0.005
    return df, m


def _empty(df, m):
    return df.iloc[:0], m


def _text(df, m):
    df["rec.theta_rad"] = df["rec.theta_rad"].astype(object)
    df.loc[100, "rec.theta_rad"] = "x"
    return df, m


def _mapped_but_absent(df, m):
    return df, m.replace('alpha_rad = "rec.alpha_rad"', 'alpha_rad = "AoA"')


def _required_channel_missing(df, m):
    return df.drop(columns="rec.theta_rad"), m.replace('theta_rad = "rec.theta_rad"\n', "")


def _wrong_probe(df, m):
    df["rec.probe_deg"] = np.roll(df["rec.probe_deg"].to_numpy(), 1)
    return df, m


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        (_nan, "column 'rec.theta_rad' (for theta_rad): no value at row 100"),
        (_backwards, "time does not increase at row 50 (0.49 s after 0.5 s)"),
        (_repeated, "time does not increase at row 110 (1.01 s after 1.1 s)"),
        (_half_a_step_late, "time at row 0 is 0.015 s, not 0.01 s"),
        (_empty, "log.csv: it holds no rows"),
        (_text, "column 'rec.theta_rad' (for theta_rad): text, not numbers"),
        (_mapped_but_absent, "no column 'AoA' (the map's for alpha_rad)"),
        (_required_channel_missing, "no column 'theta_rad', and the map names none for it"),
        (_wrong_probe, "its probe (rec.probe_deg) is not the scenario's from row 0 on"),
    ],
)
def test_a_bad_log_is_one_line_exit_2_and_nothing_written(
    flown: dict, tmp_path: Path, capsys, change, needle: str
) -> None:
    refused(small_log(flown, tmp_path, change), tmp_path, capsys, needle)


def test_a_parquet_log_of_numbers_written_as_text_is_refused(flown: dict, tmp_path: Path) -> None:
    """A Parquet column of text, even text that reads as numbers, is not a column of
    numbers: refused naming it (was read as the numbers)."""
    df, trim = foreign(flown["log"])
    df["rec.theta_rad"] = df["rec.theta_rad"].astype(str)
    df.to_parquet(tmp_path / "log.parquet")
    names = [c.removeprefix("rec.") for c in df.columns]
    with pytest.raises(ReplayError, match=r"'rec\.theta_rad' \(for theta_rad\): text, not numbers"):
        replay_foreign(flown, tmp_path / "log.parquet", map_text(names, trim), tmp_path / "o")
    assert not (tmp_path / "o").exists()


def test_the_command_monitors_a_foreign_log(flown: dict, tmp_path: Path, capsys) -> None:
    argv = small_log(flown, tmp_path, lambda df, m: (df, m))
    assert cli_main([*argv, "--out", str(tmp_path / "out")]) == 0
    assert "(replayed)" in capsys.readouterr().out
    a = tables(flown["replayed"], "monitor.parquet")[0]
    assert a.equals(tables(tmp_path / "out" / "gtm-monitored", "monitor.parquet")[0])


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ('[columns]\nthetta_rad = "x"\n[trim]\nmean_before_s = 1\n', "not a channel"),
        ("[columns]\n[trim]\n", "give measured"),
        (
            '[columns]\ntheta_rad = { column = "x", scale = 0 }\n[trim]\nmean_before_s = 1\n',
            "nonzero factor",
        ),
    ],
)
def test_a_bad_map_is_refused(tmp_path: Path, text: str, needle: str) -> None:
    (tmp_path / "map.toml").write_text(text)
    with pytest.raises(ReplayError, match=needle):
        read_map(tmp_path / "map.toml")


def test_a_map_needs_the_scenario_and_the_log(flown: dict, tmp_path: Path, capsys) -> None:
    (tmp_path / "map.toml").write_text("[trim]\nmean_before_s = 1\n")
    argv = ["monitor", "--replay", str(flown["log"]), "--map", str(tmp_path / "map.toml")]
    refused(argv, tmp_path, capsys, "give the scenario and --replay LOG")


def test_the_shipped_example_maps_every_column_its_scenario_reads() -> None:
    from probing.experiment.flight.onboard import log_columns
    from probing.experiment.scenario.references import realisable_drifts

    example = ROOT / "examples" / "foreign-log"
    how = read_map(example / "map.toml")
    scn = load_scenario(example / "scenario.toml")
    assert scn.drift in realisable_drifts()
    assert {*log_columns(scn), "probe_deg"} <= set(how.columns)
    assert how.columns["theta_rad"].scale == pytest.approx(math.pi / 180)


@pytest.mark.slow
def test_the_docs_recipe_makes_a_flight_csv_the_monitor_replays(tmp_path: Path) -> None:
    """docs/formats.md's three commands (fly the example, convert its log with
    examples/foreign-log/make_flight.py into results/, which git ignores, replay it through
    the map), on the example scenario
    shortened (24 periods, a baseline of 14): the replay's estimates are the flight's own to
    the rounding of the unit conversions, and its alarms the same."""
    import subprocess
    import sys

    example = ROOT / "examples" / "foreign-log"
    doc = " ".join((ROOT / "docs" / "formats.md").read_text().replace("\\\n", " ").split())
    for command in (
        "probing monitor examples/foreign-log/scenario.toml --out results/own",
        "python examples/foreign-log/make_flight.py "
        "results/own/gtm-flight-test/sensors.parquet results/flight.csv",
        "probing monitor examples/foreign-log/scenario.toml --replay results/flight.csv "
        "--map examples/foreign-log/map.toml --out results",
    ):
        assert command in doc, command
    text = (example / "scenario.toml").read_text()
    for old, new in [
        ("periods = 100", "periods = 24"),
        ("baseline_periods = 50", "baseline_periods = 14"),
    ]:
        assert old in text
        text = text.replace(old, new)
    scenario = tmp_path / "scenario.toml"
    scenario.write_text(text)
    assert cli_main(["monitor", str(scenario), "--out", str(tmp_path / "own")]) == 0
    own = tmp_path / "own" / "gtm-flight-test"
    flight = tmp_path / "flight.csv"
    script = [sys.executable, str(example / "make_flight.py"), str(own / "sensors.parquet")]
    subprocess.run([*script, str(flight)], check=True, capture_output=True)
    header = flight.read_text().split("\n", 1)[0].split(",")
    assert {"Time", "ElevProbe_deg", "Theta_deg", "Alt_m"} <= set(header)
    out = tmp_path / "results"
    argv = ["monitor", str(scenario), "--replay", str(flight), "--map", str(example / "map.toml")]
    assert cli_main([*argv, "--out", str(out)]) == 0
    for name in ("probing.parquet", "monitor.parquet"):
        a, b = pd.read_parquet(own / name), pd.read_parquet(out / "gtm-flight-test" / name)
        assert list(a.columns) == list(b.columns) and len(a) == len(b) > 0, name
        for column in a.select_dtypes("number").columns:
            scale = max(float(np.nanmax(np.abs(a[column]))), 1e-300)
            diff = np.nanmax(np.abs(a[column] - b[column])) if len(a) else 0.0
            assert diff <= 1e-6 * scale, (name, column, diff, scale)
