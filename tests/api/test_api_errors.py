"""What a researcher meets calling the Python API with a wrong argument: the project's typed
error (a :class:`probing.ProbingError`) with one line naming the keyword, never a raw
TypeError, AttributeError or a library's exception, and never a command-line flag; or it
works.  None of these flies: each is refused before anything is simulated or written."""

from __future__ import annotations

import dataclasses
import inspect
import io
import pydoc
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import probing
from probing.api import studies
from probing.experiment.design.design_request import DesignRequest
from probing.sweep import execute

ROOT = Path(__file__).resolve().parents[2]
CSV = ROOT / "examples" / "your-data" / "probe_response.csv"
SWEEP = ROOT / "tests" / "data" / "sweeps" / "backlash-small.toml"
ANALYZE = dict(input="elevator_deg", outputs=["q_rad_s", "theta_rad"], time="time_s", order=7)
ANALYZE = {**ANALYZE, "bit_duration_s": 0.04}
CONDITION = dict(aircraft="gtm_t2", altitude_ft=800, speed_kcas=75)


def _one_line(exc: BaseException) -> str:
    line = str(exc)
    assert "\n" not in line and "--" not in line, line  # a keyword, not a flag
    return line


# ------------------------------------------------------------------ design
@pytest.mark.parametrize(
    ("options", "error", "line"),
    [
        ({"aircraft": "gtm_t2", "altitude_ft": 800}, "DesignInputError", "speed_kcas: required"),
        ({"aircraft": "gtm_t2"}, "DesignInputError", "altitude_ft: required, as is speed_kcas"),
        ({**CONDITION, "json": True}, "DesignInputError", "json: no such option of design"),
        ({**CONDITION, "altitude": 8}, "DesignInputError", "altitude: no such option"),
        (
            {**CONDITION, "deadband_deg": 0.01},
            "DesignInputError",
            "deadband_deg: must be a pair of numbers (lower, upper), got 0.01",
        ),
        (
            {**CONDITION, "deadband_deg": (0.01, 0.02, 0.03)},
            "DesignInputError",
            "deadband_deg: must be a pair",
        ),
        (
            {**CONDITION, "altitude_ft": "800"},
            "DesignInputError",
            "altitude_ft: must be a number, got '800'",
        ),
        (
            {**CONDITION, "settle_periods": 2.0},
            "DesignInputError",
            "settle_periods: must be an integer, got 2.0",
        ),
        ({**CONDITION, "drift": "foo"}, "DesignInputError", "drift: must be one of gust"),
        (
            {**CONDITION, "closed_loop": 1},
            "DesignInputError",
            "closed_loop: must be True or False, got 1",
        ),
        ({**CONDITION, "speed_kcas": -5}, "DesignInputError", "speed_kcas: must be > 0"),
        (
            {**CONDITION, "turbulence": "light"},
            "DesignInputError",
            "drift: gust estimates the gust from the sensors: give sensors SUITE and "
            "closed_loop, or drift oracle",
        ),
        (
            {**CONDITION, "within_periods": 3, "noise_sigma": 1e-5},
            "DesignInputError",
            "within_periods: needs window_periods",
        ),
        (
            {**CONDITION, "calibration_seeds": 1},
            "DesignInputError",
            "calibration_seeds: must be an integer from 2 to 100, got 1",
        ),
    ],
    ids=lambda v: str(v)[:40] if isinstance(v, str) else None,
)
def test_design_refuses_with_the_keyword(options, error, line) -> None:
    with pytest.raises(probing.ProbingError) as caught:
        probing.design(**options)
    assert type(caught.value).__name__ == error
    assert isinstance(caught.value, probing.ArgumentError)
    assert _one_line(caught.value).startswith(line), str(caught.value)


def test_design_takes_numpy_numbers_and_a_list_as_a_pair() -> None:
    req = DesignRequest.of({**CONDITION, "altitude_ft": np.int64(800), "deadband_deg": [-1, 1]})
    assert req.altitude_ft == 800.0 and type(req.altitude_ft) is float
    assert req.deadband_deg == (-1.0, 1.0)
    assert DesignRequest.of({**CONDITION, "settle_periods": np.int32(3)}).settle_periods == 3


def test_design_takes_a_request_or_keywords_not_both() -> None:
    req = DesignRequest(**CONDITION)
    with pytest.raises(probing.ArgumentError, match="not both"):
        probing.design(req, dt_s=0.02)
    with pytest.raises(probing.ArgumentError, match="must be a DesignRequest"):
        probing.design(CONDITION)


def test_help_of_design_lists_every_option_as_a_keyword() -> None:
    """From the one table of options, DesignRequest's fields: the signature, with the
    defaults, and the docstring, with their help (the command line's options too)."""
    fields = dataclasses.fields(DesignRequest)
    params = inspect.signature(probing.design).parameters
    assert list(params) == ["request", *(f.name for f in fields)]
    for f in fields:
        p = params[f.name]
        assert p.kind is inspect.Parameter.KEYWORD_ONLY
        required = f.default is dataclasses.MISSING
        assert p.default is (inspect.Parameter.empty if required else f.default), f.name
    text = pydoc.render_doc(probing.design, renderer=pydoc.plaintext)
    for f in fields:
        assert f"    {f.name} : " in text, f.name
    assert "needs sensors and closed_loop" in text and "--sensors" not in text
    assert "altitude_ft : float\n        trim altitude (ft) (required)" in text


# ------------------------------------------------------------------ analyze
@pytest.mark.parametrize(
    ("change", "line"),
    [
        ({"time": None}, "time: give time (the time column) or dt_s (the sample step)"),
        ({"dt_s": 0.01}, "dt_s: give time or dt_s, not both"),
        ({"bit_duration_s": "0.04"}, "bit_duration_s: must be a number, got '0.04'"),
        ({"order": "7"}, "order: must be an integer from 2 to 20, got '7'"),
        ({"order": 7.0}, "order: must be an integer from 2 to 20, got 7.0"),
        ({"order": True}, "order: must be an integer from 2 to 20, got True"),
        ({"amplitude": -1}, "amplitude: must be > 0, got -1"),
        ({"amplitude": 0}, "amplitude: must be > 0, got 0"),
        ({"drift": "foo"}, "drift: must be one of detrend, none; got 'foo'"),
        ({"settled_after_s": "1"}, "settled_after_s: must be a number, got '1'"),
        ({"max_lag_s": -1}, "max_lag_s: must be > 0, got -1"),
        ({"outputs": []}, "outputs: must name one at least"),
        ({"outputs": [1]}, "outputs: must be names (strings), got [1]"),
        ({"input": 3}, "input: must be a column name (a string), got 3"),
    ],
    ids=lambda v: str(v)[:30],
)
def test_analyze_refuses_an_argument_naming_it(change, line) -> None:
    with pytest.raises(probing.ArgumentError) as caught:
        probing.analyze(CSV, **{**ANALYZE, **change})
    assert _one_line(caught.value) == line


@pytest.fixture(scope="module")
def record() -> probing.Flight:
    """The example record, its order given as numpy's (as JSON read with numpy gives it)
    and its one output as a string: one column, not its letters."""
    return probing.analyze(CSV, **{**ANALYZE, "order": np.int64(7), "outputs": "theta_rad"})


def test_analyze_takes_numpy_integers_and_one_column_as_a_string(record) -> None:
    assert list(record.bounds["channel"].unique()) == ["theta_rad"]
    assert record.bounds.attrs["analysis"]["order"] == 7
    assert record.bounds.attrs["analysis"]["outputs"] == ["theta_rad"]


def test_analyze_of_a_folder_or_a_damaged_mat_file_says_so(tmp_path) -> None:
    with pytest.raises(probing.RecordError, match=r": is a folder, not a record"):
        probing.analyze(tmp_path, **ANALYZE)
    with pytest.raises(probing.RecordError, match=r"none\.csv: no such file$"):
        probing.analyze(tmp_path / "none.csv", **ANALYZE)
    for name, data in (("short.mat", b"MATLAB 5.0"), ("noise.mat", bytes(range(256)) * 2)):
        (tmp_path / name).write_bytes(data)
        with pytest.raises(probing.RecordError, match="cannot read it as mat") as caught:
            probing.analyze(tmp_path / name, **{**ANALYZE, "time": None, "dt_s": 0.01})
        _one_line(caught.value)


# ------------------------------------------------------------------ Scenario.replace
def test_replace_takes_numpy_integers_and_refuses_a_key_that_is_no_name() -> None:
    scn = probing.example("fig4/a_deadband")
    changed = scn.replace({"probe.order": np.int64(7), "probe.amplitude_deg": np.int64(1)})
    assert changed.to_dict()["probe"]["order"] == 7
    assert type(changed.to_dict()["probe"]["order"]) is int
    assert (
        changed.amplitude_deg == 1.0
        and changed.digest() == scn.replace({"probe.order": 7, "probe.amplitude_deg": 1.0}).digest()
    )
    for key in (3, None, "", "probe..order"):
        with pytest.raises(probing.ScenarioError, match="must be a field's dotted name"):
            scn.replace({key: 7})
    with pytest.raises(probing.ScenarioError, match=r"got 7\.0"):
        scn.replace({"probe.order": 7.0})
    monitored = probing.example("references/base").replace({"monitor.window_periods": np.int64(3)})
    assert monitored.to_dict()["monitor"]["window_periods"] == 3  # the [monitor] section too


def test_a_section_given_as_a_dict_replaces_the_whole_section() -> None:
    scn = probing.example("fig4/a_deadband")
    probe = scn.to_dict()["probe"]
    assert scn.replace({"probe": {**probe, "order": 7}}).to_dict()["probe"]["order"] == 7
    with pytest.raises(probing.ScenarioError, match=r"probe\.bit_duration_s: missing"):
        scn.replace({"probe": {"order": 7}})  # not merged into the section
    assert "replaces the section as a whole" in " ".join(scn.replace.__doc__.split())


# ------------------------------------------------------------------ fly_sweep
@pytest.mark.parametrize(
    ("kw", "line"),
    [
        ({"jobs": 0}, "jobs: must be an integer >= 1, got 0"),
        ({"jobs": "2"}, "jobs: must be an integer >= 1, got '2'"),
        ({"jobs": 2.0}, "jobs: must be an integer >= 1, got 2.0"),
        ({"executor": "foo"}, "executor: must be one of local, dask; got 'foo'"),
        ({"scheduler": "tcp://x:1"}, "scheduler: only with executor dask"),
        ({"connect_timeout_s": 0}, "connect_timeout_s: must be > 0, got 0"),
        ({"progress": "bar"}, "progress: must be True, False or 'lines', got 'bar'"),
    ],
    ids=lambda v: str(v)[:30],
)
def test_fly_sweep_refuses_an_argument_before_writing(kw, line, tmp_path) -> None:
    with pytest.raises(probing.ArgumentError) as caught:
        probing.fly_sweep(SWEEP, tmp_path / "out", **kw)
    assert _one_line(caught.value) == line
    assert list(tmp_path.iterdir()) == []


def test_fly_sweep_refuses_an_unwritable_folder(tmp_path) -> None:
    (tmp_path / "a_file").write_text("")
    for out in (tmp_path / "a_file", tmp_path / "a_file" / "below", ""):
        with pytest.raises(probing.OutputPathError) as caught:
            probing.fly_sweep(SWEEP, out)
        assert str(caught.value).startswith("out")
    assert [p.name for p in tmp_path.iterdir()] == ["a_file"]


def test_fly_sweep_draws_no_progress_in_a_script(monkeypatch, tmp_path) -> None:
    asked = []
    monkeypatch.setattr(
        "probing.sweep.run_sweep", lambda *a, **kw: asked.append((kw["progress"], kw["lines"]))
    )
    probing.fly_sweep(SWEEP, tmp_path)
    probing.fly_sweep(SWEEP, tmp_path, progress="lines")
    probing.fly_sweep(SWEEP, tmp_path, progress=True)
    monkeypatch.setattr("probing.api.calls.in_notebook", lambda: True)
    probing.fly_sweep(SWEEP, tmp_path)
    assert asked == [(False, False), (False, True), (True, False), (True, False)]


def test_a_sweep_without_lines_writes_nothing() -> None:
    for lines, said in ((True, "name: 0 runs to do\n"), (False, "")):
        stream = io.StringIO()
        result = execute.SweepResult(folder=Path("x"), points=0)
        execute._execute(None, [], "name", result, False, stream, lines)
        assert stream.getvalue() == said


def test_the_command_line_writes_lines_off_a_terminal(monkeypatch, tmp_path, capsys) -> None:
    from probing.cli import main

    asked = []

    def spy(sweep, out, **kw):
        asked.append(kw["progress"])
        raise probing.SweepBusyError("stop here")

    monkeypatch.setattr(studies, "fly_sweep", spy)
    monkeypatch.setattr("probing.api.fly_sweep", spy)
    assert main(["sweep", str(SWEEP), "--out", str(tmp_path)]) == 1
    assert asked == ["lines"]
    assert main(["sweep", str(SWEEP), "--out", str(tmp_path), "-j", "0"]) == 1  # the spy's
    monkeypatch.undo()
    assert main(["sweep", str(SWEEP), "--out", str(tmp_path), "-j", "0"]) == 2
    assert capsys.readouterr().err.endswith(
        "probing: error: -j/--jobs: must be an integer >= 1, got 0\n"
    )


# ------------------------------------------------------------------ Flight
def test_a_flight_refuses_a_lag_and_a_file_it_cannot_have(record) -> None:
    for bad, said in (
        (-1, "must be > 0, got -1"),
        (0, "must be > 0, got 0"),
        ("x", "must be a number, got 'x'"),
    ):
        with pytest.raises(probing.ArgumentError, match=f"^max_lag_s: {said}"):
            record.plot(max_lag_s=bad)
    with pytest.raises(probing.ArgumentError, match=r"^name: 'nope\.parquet' is none of"):
        record.table("nope.parquet")
    assert record.table("truth.parquet") is None  # one of the project's, not held
    with pytest.raises(probing.RecordError, match="a record has no scenario"):
        record.truth()
    with pytest.raises(probing.StoredFileError, match="was not monitored"):
        record.plot_monitor()


def test_save_refuses_an_empty_path_as_the_command_line_does(record, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(probing.OutputPathError, match=r"^out: empty path$"):
        record.save("")
    assert list(tmp_path.iterdir()) == []


def test_read_says_what_is_wrong_with_the_path(tmp_path) -> None:
    with pytest.raises(probing.StoredFileError, match=r"missing: no such folder$"):
        probing.read(tmp_path / "missing")
    (tmp_path / "probing.parquet").write_text("")
    with pytest.raises(probing.StoredFileError, match=r"is a file, not the folder of a run"):
        probing.read(tmp_path / "probing.parquet")


def _monitor_file(verdict: str) -> bytes:
    table = pa.table({"time_s": [1.0]}).replace_schema_metadata({b"probing.verdict": verdict})
    sink = io.BytesIO()
    pq.write_table(table, sink)
    return sink.getvalue()


@pytest.mark.parametrize(
    ("stored", "verdict"),
    [("none", None), ("actuator", "actuator"), ("airframe", "airframe"), ("sensor", "sensor")],
)
def test_no_verdict_is_none(stored, verdict) -> None:
    """docs/api.md: None where there is none; the file and the command line say "none"."""
    flight = probing.Flight({"monitor.parquet": _monitor_file(stored)}, name="x")
    assert flight.verdict == verdict
    assert probing.Flight({}, name="x").verdict is None
    assert "sensor" in probing.Flight.verdict.__doc__
