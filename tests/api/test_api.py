"""The public Python API (docs/api.md): ``probing.load/example/fly/read/analyze/replay`` and
the :class:`probing.Flight` they return.  Its files are the command line's, byte for byte
(the command line is a thin layer over it), its tables are those files with their units
and provenance in ``.attrs``, and its errors are the project's typed ones with the lines
the command line prints."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import probing
from probing.analysis.analyze_plots import PREDICTION_LABEL
from probing.api import calls
from probing.cli import main
from probing.experiment.studies import truth as truth_module

pytestmark = pytest.mark.jsbsim

ROOT = Path(__file__).resolve().parents[2]
FIG4 = sorted((ROOT / "scenarios" / "fig4").glob("*.toml"))
CSV = ROOT / "examples" / "your-data" / "probe_response.csv"
ANALYZE = dict(
    input="elevator_deg",
    outputs=["q_rad_s", "theta_rad"],
    time="time_s",
    order=7,
    bit_duration_s=0.04,
)


def _same_files(a: Path, b: Path) -> list[str]:
    """The names of the files in ``a``, after checking ``b`` holds the same names and bytes."""
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    for name in names:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    return names


def _short(scn: probing.Scenario, periods: int = 3) -> probing.Scenario:
    return scn.replace({"probe.periods": periods, "probe.settle_periods": 1})


# ------------------------------------------------------------------ the top of the package
def test_the_api_is_at_the_top_of_the_package_and_listed() -> None:
    import probing.api

    assert set(probing.api.__all__) == set(probing.API)
    assert set(probing.API) <= set(probing.__all__)
    for name in probing.__all__:
        assert getattr(probing, name) is not None, name
    assert probing.fly is calls.fly and probing.Flight is probing.api.Flight
    assert {"fly", "load", "read"} <= set(dir(probing))
    with pytest.raises(AttributeError, match="no attribute 'flyy'"):
        probing.flyy  # noqa: B018
    assert (ROOT / "probing" / "py.typed").is_file()


def test_load_example_and_replace_give_checked_scenarios() -> None:
    scn = probing.example("fig4/a_deadband")
    assert scn == probing.load(ROOT / "scenarios" / "fig4" / "a_deadband.toml")
    assert probing.example("fig4/a_deadband.toml") == scn
    louder = scn.replace({"probe.amplitude_deg": 0.01})
    assert louder.amplitude_deg == 0.01 and scn.amplitude_deg == 0.005
    with pytest.raises(probing.ScenarioError, match=r"probe\.amplitude_deg"):
        scn.replace({"probe.amplitude_deg": -1})
    with pytest.raises(probing.ScenarioError, match="no example scenario 'fig4/nothing'"):
        probing.example("fig4/nothing")
    with pytest.raises(probing.ScenarioError, match="no example"):
        probing.example("../pyproject")  # only the shipped scenarios


def test_a_bad_scenario_raises_the_line_the_command_line_prints(tmp_path, capsys) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text((FIG4[0]).read_text().replace("amplitude_deg = 0.005", "amplitude_deg = -1"))
    with pytest.raises(probing.ScenarioError) as caught:
        probing.load(bad)
    assert main(["run", str(bad), "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == f"probing: error: {caught.value}\n"


# ------------------------------------------------------------------ fly and save
@pytest.mark.slow
@pytest.mark.parametrize("path", FIG4, ids=[p.stem for p in FIG4])
def test_a_saved_flight_is_probing_run_byte_for_byte(path, tmp_path, capsys) -> None:
    """The Fig. 4 set: ``probing run`` and ``fly(...).save(...)`` write the same bytes, and
    ``probing.read`` of either gives the flight's tables."""
    assert main(["run", str(path), "--out", str(tmp_path / "cli")]) == 0
    flight = probing.fly(probing.load(path))
    folder = flight.save(tmp_path / "api")
    assert folder == tmp_path / "api" / flight.name
    names = _same_files(tmp_path / "cli" / flight.name, folder)
    assert names == ["bounds.parquet", "probing.parquet", "timeseries.parquet"]
    stored = probing.read(tmp_path / "cli" / flight.name)
    assert stored.name == flight.name and stored.scenario == flight.scenario
    for table in ("estimates", "bounds", "timeseries"):
        pd.testing.assert_frame_equal(getattr(stored, table), getattr(flight, table))
        assert getattr(stored, table).attrs == getattr(flight, table).attrs
    assert capsys.readouterr().err == ""  # no progress bar in a script by default


def test_fly_writes_nothing_and_save_checks_its_folder_first(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)  # TMPDIR read again
    flight = probing.fly(_short(probing.example("fig4/a_deadband")))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tmp"]
    assert list((tmp_path / "tmp").iterdir()) == []  # its temporary folder is gone
    (tmp_path / "a_file").write_text("")
    with pytest.raises(probing.OutputPathError, match="a_file"):
        flight.save(tmp_path / "a_file")
    with pytest.raises(probing.OutputPathError):
        flight.save(tmp_path / "a_file" / "below")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file", "tmp"]


def test_tables_carry_units_and_provenance() -> None:
    scn = _short(probing.example("fig4/a_deadband"))
    flight = probing.fly(scn)
    est = flight.estimates
    assert list(est.columns) == ["channel", "period", "tap", "lag_s", "z", "zeta", "h_est"]
    assert est.attrs["units"]["h_est"] == {"theta_rad": "rad/deg", "q_rad_s": "rad/s/deg"}
    assert est.attrs["units"]["lag_s"] == "s"
    assert est.attrs["scenario"] == scn.to_dict()
    assert est.attrs["scenario_digest"] == scn.digest()
    assert est.attrs["versions"]["jsbsim"] == "1.3.3"
    assert est.attrs["file"] == "probing.parquet"
    meta = pq.read_metadata(pa.BufferReader(flight.file_bytes("probing.parquet"))).metadata
    assert json.loads(meta[b"probing.units"]) == est.attrs["units"]
    assert flight.timeseries.attrs["units"]["time_s"] == "s"
    assert flight.monitor is None and flight.verdict is None and flight.first_alarm_s is None
    assert flight.truth is not None and "truth.parquet" not in flight.files
    assert flight.estimates is est  # read once, then kept
    assert probing.fly(scn, timeseries=False).timeseries is None


def test_truth_is_computed_once_and_saved_as_probing_truth_writes_it(
    tmp_path, monkeypatch, capsys
) -> None:
    scn_path = tmp_path / "short.toml"
    scn_path.write_text(
        FIG4[0]
        .read_text()
        .replace("periods = 8", "periods = 3")
        .replace("settle_periods = 2", "settle_periods = 1")
    )
    flight = probing.fly(probing.load(scn_path))
    computed = []
    real = truth_module.compute_truth
    monkeypatch.setattr(
        truth_module, "compute_truth", lambda s, out: computed.append(1) or real(s, out)
    )
    first = flight.truth()
    assert flight.truth() is first and computed == [1]
    assert set(first["channel"]) == {"theta_rad", "q_rad_s"}
    assert first.attrs["units"]["h_pulse"]["theta_rad"] == "rad/deg"
    flight.save(tmp_path / "api")
    for args in (["run", str(scn_path)], ["truth", str(scn_path)]):
        assert main([*args, "--out", str(tmp_path / "cli")]) == 0
    names = _same_files(tmp_path / "cli" / flight.name, tmp_path / "api" / flight.name)
    assert "truth.parquet" in names and "prediction.parquet" in names


def test_fly_with_truth_is_probing_run_truth(tmp_path) -> None:
    path = ROOT / "scenarios" / "baseline-737.toml"
    scn = _short(probing.load(path), 2)
    scn_path = tmp_path / "b.toml"
    import tomli_w

    scn_path.write_text(tomli_w.dumps(scn.to_dict()))
    assert main(["run", str(scn_path), "--out", str(tmp_path / "cli"), "--truth"]) == 0
    flight = probing.fly(probing.load(scn_path), truth=True)
    assert "truth.parquet" in flight.files
    _same_files(tmp_path / "cli" / flight.name, flight.save(tmp_path / "api"))


# ------------------------------------------------------------------ the figure
def test_plot_draws_each_channel_with_its_bounds_and_the_truth_once_computed() -> None:
    flight = probing.fly(_short(probing.example("fig4/a_deadband"), 4))
    before = plt.get_fignums()
    fig = flight.plot()
    assert plt.get_fignums() == before  # not pyplot's: a notebook shows it once
    assert [ax.get_title(loc="left").split(" ")[0] for ax in fig.axes] == ["theta_rad", "q_rad_s"]
    labels = [line.get_label() for line in fig.axes[0].lines]
    assert PREDICTION_LABEL not in labels
    flight.truth()
    fig = flight.plot(max_lag_s=2.0)
    ax = fig.axes[1]
    (truth_line,) = [x for x in ax.lines if x.get_label() == PREDICTION_LABEL]
    pred = flight.table("prediction.parquet")
    q = pred[(pred.channel == "q_rad_s") & (pred.period >= 1)].sort_values(["period", "tap"])
    expected = q["h_est"].to_numpy().reshape(-1, 511).mean(axis=0)
    assert (truth_line.get_ydata() == expected).all()
    assert ax.get_xlim() == (0.0, 2.0)


# ------------------------------------------------------------------ progress
def test_progress_is_off_in_a_script_and_on_in_a_notebook(capsys, monkeypatch) -> None:
    scn = _short(probing.example("fig4/a_deadband"), 2)
    probing.fly(scn)
    assert capsys.readouterr().err == ""
    probing.fly(scn, progress=True)
    assert "periods" in capsys.readouterr().err
    monkeypatch.setattr(calls, "in_notebook", lambda: True)
    probing.fly(scn)
    assert "fig4-a-deadband" in capsys.readouterr().err


def testin_notebook_asks_ipython_for_a_kernel(monkeypatch) -> None:
    fake = type(sys)("IPython")
    monkeypatch.setitem(sys.modules, "IPython", fake)
    fake.get_ipython = lambda: None
    assert calls.in_notebook() is False
    fake.get_ipython = lambda: type("Terminal", (), {})()
    assert calls.in_notebook() is False
    fake.get_ipython = lambda: type("Kernel", (), {"kernel": object()})()
    assert calls.in_notebook() is True


# ------------------------------------------------------------------ the command line is a layer
def test_probing_run_and_monitor_are_fly_then_save(tmp_path, monkeypatch, capsys) -> None:
    flown = []
    real = calls.fly

    def spy(scn, **kw):
        flown.append(kw)
        return real(_short(scn), **kw)

    monkeypatch.setattr(probing.api, "fly", spy)
    assert main(["run", str(FIG4[0]), "--out", str(tmp_path)]) == 0
    scratch = tmp_path / "fig4-a-deadband"  # a run killed outright leaves its work there
    assert flown == [{"progress": False, "truth": False, "monitor": False, "scratch": scratch}]
    stored = probing.read(tmp_path / "fig4-a-deadband")
    assert stored.estimates["period"].max() == 2  # the spy's three periods were saved
    assert "-> " + str(tmp_path / "fig4-a-deadband") in capsys.readouterr().out


# ------------------------------------------------------------------ a monitored flight
def _monitored() -> probing.Scenario:
    """The study's closed-loop flight on NASA's T2 sensors, gust reference, an elevator
    losing half its effectiveness at 40 s, short."""
    return probing.load(ROOT / "scenarios" / "monitor" / "base.toml").replace(
        {
            "probe.periods": 24,
            "monitor.baseline_periods": 12,
            "output.drift": "gust",
            "disturbance.sensor_noise": {},
            "sensors": {"suite": "nasa_t2"},
            "fault": {"type": "effectiveness", "scale": 0.5, "onset_s": 40.0},
        }
    )


@pytest.fixture(scope="module")
def monitored(tmp_path_factory):
    folder = tmp_path_factory.mktemp("monitored")
    scn_path = folder / "m.toml"
    import tomli_w

    scn_path.write_text(tomli_w.dumps(_monitored().to_dict()))
    return scn_path, probing.fly(probing.load(scn_path))


@pytest.mark.slow
def test_a_monitored_flight_is_probing_monitor_byte_for_byte(monitored, tmp_path) -> None:
    scn_path, flight = monitored
    assert main(["monitor", str(scn_path), "--out", str(tmp_path / "cli")]) == 0
    names = _same_files(tmp_path / "cli" / flight.name, flight.save(tmp_path / "api"))
    assert names == ["bounds.parquet", "monitor.parquet", "probing.parquet", "sensors.parquet"]
    meta = pq.read_metadata(tmp_path / "cli" / flight.name / "monitor.parquet").metadata
    assert (flight.verdict or "none") == meta[b"probing.verdict"].decode()
    assert flight.first_alarm_s == json.loads(meta[b"probing.first_alarm_s"])
    assert flight.first_alarm_s is not None and flight.first_alarm_s > 40.0
    assert flight.alarm_detector in ("probing", "trajectory")
    detected = flight.monitor[flight.monitor.detector.isin(["probing", "trajectory"])]
    first = detected[detected["alarm"]]["time_s"].min()
    assert first == pytest.approx(flight.first_alarm_s, abs=1e-9)
    assert flight.result.first_alarm_s == flight.first_alarm_s


@pytest.mark.slow
def test_replay_of_a_flights_log_is_its_monitor(monitored, tmp_path) -> None:
    _, flight = monitored
    flight.save(tmp_path)
    again = probing.replay(tmp_path / flight.name / "sensors.parquet")
    assert again.name == flight.name and again.scenario.digest() == flight.scenario.digest()
    pd.testing.assert_frame_equal(again.monitor, flight.monitor)
    pd.testing.assert_frame_equal(again.estimates, flight.estimates)
    assert (again.verdict, again.first_alarm_s) == (flight.verdict, flight.first_alarm_s)
    with pytest.raises(probing.ReplayError, match=r"not the sensors\.parquet"):
        probing.replay(tmp_path / flight.name / "probing.parquet")


@pytest.mark.slow
def test_an_edited_sensors_table_replays(monitored, tmp_path) -> None:
    """docs/monitoring.md: an edited log replays.  A Flight's table carries its keys decoded
    and without their prefix; written by pandas, they are read back as the file's: the
    columns the replay does not read dropped, it is the flight's monitor; one it reads
    dropped, a ReplayError names it."""
    from probing.experiment.flight.onboard import log_columns

    _, flight = monitored
    sensors = flight.sensors
    needed = log_columns(flight.scenario)
    unread = [c for c in sensors.columns if c not in needed]
    assert unread and "scenario" in sensors.attrs  # decoded, no "probing." prefix
    sensors.drop(columns=unread).to_parquet(tmp_path / "edited.parquet")
    again = probing.replay(tmp_path / "edited.parquet")
    pd.testing.assert_frame_equal(again.monitor, flight.monitor)
    assert (again.verdict, again.first_alarm_s) == (flight.verdict, flight.first_alarm_s)
    sensors.drop(columns=["q_rad_s"]).to_parquet(tmp_path / "cut.parquet")
    with pytest.raises(probing.ReplayError, match=r"cut\.parquet: no column q_rad_s$"):
        probing.replay(tmp_path / "cut.parquet")


def test_fly_refuses_to_monitor_what_its_runner_does_not(tmp_path) -> None:
    simultaneous = sorted((ROOT / "scenarios" / "simultaneous").glob("*.toml"))[0]
    with pytest.raises(probing.ScenarioError, match="probing monitor"):
        probing.fly(simultaneous, monitor=True)


# ------------------------------------------------------------------ a record
def test_analyze_is_probing_analyze_byte_for_byte(tmp_path, capsys) -> None:
    cli = tmp_path / "cli"
    args = ["analyze", str(CSV), "--input", "elevator_deg", "--output", "q_rad_s", "theta_rad"]
    args += ["--time", "time_s", "--order", "7", "--bit-duration-s", "0.04", "--out", str(cli)]
    assert main(args) == 0
    rec = probing.analyze(CSV, **ANALYZE)
    assert rec.name is None and rec.scenario is None
    assert rec.save(tmp_path / "api") == tmp_path / "api"
    names = _same_files(cli, tmp_path / "api")
    assert names == ["bounds.parquet", "probing.parquet", "pulse_response.png"]
    assert rec.bounds.attrs["units"]["h_est"]["q_rad_s"] == "rad/s/deg"
    assert rec.bounds.attrs["input"]["file"] == CSV.name
    stored = probing.read(cli)
    assert stored.name is None
    pd.testing.assert_frame_equal(stored.bounds, rec.bounds)
    assert len(rec.plot().axes) == 2
    with pytest.raises(ValueError, match="a record has no scenario"):
        rec.truth()


def test_analyze_and_read_raise_the_projects_errors(tmp_path) -> None:
    with pytest.raises(probing.RecordError, match="no such file"):
        probing.analyze(tmp_path / "none.csv", **ANALYZE)
    with pytest.raises(probing.RecordError, match="nothing"):
        probing.analyze(CSV, **{**ANALYZE, "input": "nothing"})
    with pytest.raises(probing.StoredFileError, match="no such folder"):
        probing.read(tmp_path / "missing")
    with pytest.raises(probing.StoredFileError, match="holds none of"):
        probing.read(tmp_path)
    (tmp_path / "probing.parquet").write_text("not parquet")
    with pytest.raises(probing.StoredFileError, match="cannot be read as Parquet"):
        probing.read(tmp_path)
