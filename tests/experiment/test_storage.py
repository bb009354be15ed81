"""The files of a run for other tools: every column says its unit, every file says what it is."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from probing.experiment.flight.run import run_scenario
from probing.experiment.output.storage import (
    MONITOR_SCHEMA,
    AtomicParquetWriter,
    metadata,
    output_folder,
)
from probing.experiment.scenario import load_scenario
from probing.experiment.studies.truth import compute_truth

ROOT = Path(__file__).resolve().parents[2]
FILES = (
    "probing.parquet",
    "bounds.parquet",
    "timeseries.parquet",
    "truth.parquet",
    "prediction.parquet",
)


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    scn = load_scenario(ROOT / "scenarios" / "baseline-737.toml").replace(
        {"probe.order": 5, "probe.periods": 3, "probe.settle_periods": 1}
    )
    out = tmp_path_factory.mktemp("storage")
    run_scenario(scn, out, progress=False)
    compute_truth(scn, out)
    return out / scn.name


@pytest.mark.jsbsim
@pytest.mark.parametrize("name", FILES)
def test_every_column_has_a_unit_and_a_description(run_folder: Path, name: str) -> None:
    schema = pq.read_schema(run_folder / name)
    for field in schema:
        meta = field.metadata or {}
        assert b"unit" in meta and meta[b"description"], (name, field.name)
    assert schema.metadata[b"probing.description"]


@pytest.mark.jsbsim
def test_units_resolve_per_channel(run_folder: Path) -> None:
    schema = pq.read_schema(run_folder / "probing.parquet")
    units = json.loads(schema.metadata[b"probing.units"])
    assert units["lag_s"] == "s"
    assert (
        units["z"]
        == units["zeta"]
        == {
            "theta_rad": "rad",
            "q_rad_s": "rad/s",
            "alpha_rad": "rad",
            "nz_g": "g",
        }
    )
    assert units["h_est"]["q_rad_s"] == "rad/s/deg" and units["h_est"]["theta_rad"] == "rad/deg"
    assert schema.field("h_est").metadata[b"unit"] == b"<channel>/deg"
    ts = json.loads(pq.read_schema(run_folder / "timeseries.parquet").metadata[b"probing.units"])
    assert ts["nz_g"] == ts["nz_g_reference"] == "g" and ts["elevator_pos_deg"] == "deg"
    truth = json.loads(pq.read_schema(run_folder / "truth.parquet").metadata[b"probing.units"])
    assert truth["h_lin"]["alpha_rad"] == "rad/deg"


@pytest.mark.jsbsim
def test_prediction_says_what_it_is(run_folder: Path) -> None:
    meta = pq.read_schema(run_folder / "prediction.parquet").metadata
    text = meta[b"probing.description"].decode()
    assert text.startswith("predicted probing output") and "probing.parquet" in text
    assert (
        meta[b"probing.scenario_digest"]
        == pq.read_schema(run_folder / "probing.parquet").metadata[b"probing.scenario_digest"]
    )


@pytest.mark.parametrize("surface", ["elevator", "aileron", "rudder", "throttle"])
def test_timeseries_has_each_column_once_with_every_channel_and_surface(surface: str) -> None:
    """The surface's realised position and its own sensor channel are two columns: every
    channel measured, with reference and autopilot columns, names no column twice (the
    monitor's scenarios measure elevator_deg while probing the elevator)."""
    from probing.experiment.output.storage import timeseries_schema
    from probing.sim.channels import CHANNELS
    from probing.sim.surfaces import SURFACES

    schema = timeseries_schema(list(CHANNELS), reference=True, control=True, surface=surface)
    assert len(set(schema.names)) == len(schema.names)
    s = SURFACES[surface]
    assert {s.position_column, s.channel} <= set(schema.names)
    assert schema.field(s.position_column).metadata[b"unit"] == s.unit.encode()


def test_a_writer_refuses_a_schema_that_names_a_column_twice(tmp_path: Path) -> None:
    """A schema with a repeated column name is refused before any file is opened."""
    import pyarrow as pa

    from probing.experiment.output.storage import AtomicParquetWriter

    schema = pa.schema([("a_deg", pa.float64()), ("a_deg", pa.float64())])
    with pytest.raises(ValueError, match=r"given twice: \['a_deg'\]"):
        AtomicParquetWriter(tmp_path / "x.parquet", schema, {})
    assert list(tmp_path.iterdir()) == []


def test_a_writer_refuses_a_column_its_schema_does_not_have(tmp_path: Path) -> None:
    """Rows with a column the schema lacks are an error naming it, not a column dropped (as
    Arrow's table of a mapping and a schema drops it); rows without one of its columns are
    one too; the file is not written."""
    import pyarrow as pa

    from probing.experiment.output.storage import AtomicParquetWriter

    schema = pa.schema([("a_deg", pa.float64()), ("b_deg", pa.float64())])
    w = AtomicParquetWriter(tmp_path / "x.parquet", schema, {})
    with pytest.raises(ValueError, match=r"x.parquet has no column 'c_deg'"):
        w.write({"a_deg": [1.0], "b_deg": [2.0], "c_deg": [3.0]})
    with pytest.raises(KeyError, match="b_deg"):
        w.write({"a_deg": [1.0]})
    w.write({"a_deg": [1.0], "b_deg": [2.0]})  # the schema's columns: written
    w.abort()
    assert list(tmp_path.iterdir()) == []


def _monitor_rows(n: int) -> dict:
    """``n`` made-up rows of the monitor's layout."""
    return {
        "period": list(range(n)),
        "time_s": [float(p + 1) for p in range(n)],
        "channel": ["theta_rad"] * n,
        "detector": ["probing"] * n,
        "statistic": [0.5] * n,
        "threshold": [4.0] * n,
        "alarm": [False] * n,
        "gain_change": [1.0] * n,
        "shape_change": [0.1] * n,
        "verdict": ["none"] * n,
    }


@pytest.mark.parametrize("exists", [True, False])
def test_a_failed_run_leaves_nothing_half_written(tmp_path: Path, exists: bool) -> None:
    """Two files written (one past a full row group), then the run fails: the folder, whether
    it was there before (it stays, empty: not even a hidden partial file) or created by the
    run (removed), holds nothing; the error propagates.  The listing of the disk is the
    truth."""
    path = tmp_path / "out" / "run"
    if exists:
        path.mkdir(parents=True)
    with pytest.raises(RuntimeError, match="diverged"):
        with output_folder(path, metadata(scenario="x")) as folder:
            for name in ("monitor.parquet", "other.parquet"):
                w = folder.writer(name, ["theta_rad"], schema=MONITOR_SCHEMA, description="made up")
                w.row_group_rows = 4
                w.write(_monitor_rows(6))
            assert len(list(path.iterdir())) == 2  # the partial files are on disk
            raise RuntimeError("diverged")
    if exists:
        assert list(path.iterdir()) == []
    else:
        assert not (tmp_path / "out").exists()
    assert list(tmp_path.iterdir()) == ([tmp_path / "out"] if exists else [])


def test_a_finished_run_has_its_files_and_no_partial_one(tmp_path: Path) -> None:
    """The same writes without a failure: the two files under their names, with every row,
    and no hidden temporary file."""
    path = tmp_path / "run"
    with output_folder(path, metadata(scenario="x")) as folder:
        for name in ("monitor.parquet", "other.parquet"):
            w = folder.writer(name, ["theta_rad"], schema=MONITOR_SCHEMA, description="made up")
            w.write(_monitor_rows(6))
    assert sorted(p.name for p in path.iterdir()) == ["monitor.parquet", "other.parquet"]
    assert pq.read_table(path / "monitor.parquet").num_rows == 6


@pytest.mark.parametrize(("writes", "groups"), [((4, 2), [4, 2]), ((3, 3), [6]), ((5,), [5])])
def test_a_row_group_is_written_once_it_is_full(
    tmp_path: Path, writes: tuple[int, ...], groups: list[int]
) -> None:
    """Row groups of 4 rows: a write that fills one exactly (4) goes out as a row group at
    once, one that does not waits for the next; the file's own row groups (Parquet's
    metadata) say which.  A row group of 0 rows is refused."""
    path = tmp_path / "f.parquet"
    w = AtomicParquetWriter(path, MONITOR_SCHEMA, metadata(scenario="x"), row_group_rows=4)
    for n in writes:
        w.write(_monitor_rows(n))
    w.close()
    meta = pq.read_metadata(path)
    assert [meta.row_group(i).num_rows for i in range(meta.num_row_groups)] == groups
    AtomicParquetWriter(tmp_path / "g.parquet", MONITOR_SCHEMA, {}, row_group_rows=1).abort()
    with pytest.raises(ValueError, match="row_group_rows"):
        AtomicParquetWriter(tmp_path / "h.parquet", MONITOR_SCHEMA, {}, row_group_rows=0)


def test_check_output_file_refuses_what_cannot_be_a_written_file(tmp_path: Path) -> None:
    from probing.experiment.output.storage import OutputFileError, check_output_file

    (tmp_path / "a-file").write_text("mine")
    (tmp_path / "a-folder").mkdir()
    assert check_output_file(tmp_path / "a-file", "--x") == tmp_path / "a-file"  # replaced
    assert check_output_file(tmp_path / "new" / "deeper.md", "--x") == (
        tmp_path / "new" / "deeper.md"
    )
    for path, reason in [
        ("", "--x: empty path"),
        (tmp_path / "a-folder", "is a folder, not a file"),
        (tmp_path / "a-file" / "s.md", "is below a file"),
    ]:
        with pytest.raises(OutputFileError, match=reason):
            check_output_file(path, "--x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file", "a-folder"]


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="no /proc here")
def test_an_output_folder_in_proc_says_why_it_cannot_be_written() -> None:
    """``--out /proc/x`` said "cannot write in /proc (No such file or directory)", though
    /proc exists: the reason is that its file system takes nothing new there."""
    from probing.experiment.output.storage import OutputFolderError, check_output_folder

    with pytest.raises(OutputFolderError) as exc:
        check_output_folder("/proc/probing-out", "--out")
    assert str(exc.value) == (
        "--out /proc/probing-out: cannot write in /proc "
        "(its file system takes no new files or folders there)"
    )


def test_a_stored_file_that_is_not_parquet_is_named(tmp_path: Path) -> None:
    from probing.experiment.output.storage import StoredFileError, read_schema, read_settled

    bad = tmp_path / "probing.parquet"
    bad.write_bytes(b"garbage" * 20)
    for read in (lambda: read_schema(bad), lambda: read_settled(bad, "theta_rad", 0, 4)):
        with pytest.raises(StoredFileError, match=re.escape(str(bad))):
            read()
    with pytest.raises(StoredFileError, match=r"missing\.parquet"):
        read_schema(tmp_path / "missing.parquet")


@pytest.mark.jsbsim
def test_each_file_of_a_run_is_laid_out_and_described_as_the_registry_says(
    run_folder: Path,
) -> None:
    """Every file a run (with its truth) writes is an OUTPUT_FILES entry: its description is
    the entry's and its columns the entry's schema (timeseries: laid out per run)."""
    from probing.experiment.output.storage import OUTPUT_FILES

    names = sorted(p.name for p in run_folder.glob("*.parquet"))
    assert names == sorted(
        [
            "probing.parquet",
            "bounds.parquet",
            "timeseries.parquet",
            "truth.parquet",
            "prediction.parquet",
        ]
    )
    for name in names:
        schema = pq.read_schema(run_folder / name)
        entry = OUTPUT_FILES[name]
        assert schema.metadata[b"probing.description"].decode() == entry.description
        if entry.schema is not None:
            assert schema.names == entry.schema.names, name


def test_a_file_outside_the_registry_needs_its_schema_and_description(tmp_path: Path) -> None:
    """A name the registry does not know, or the per-run timeseries without its schema, is
    refused before any file is opened."""
    with output_folder(tmp_path / "run", metadata(scenario="x")) as folder:
        for name in ("other.parquet", "timeseries.parquet"):
            with pytest.raises(ValueError, match="give schema"):
                folder.writer(name, ["theta_rad"])
    assert not (tmp_path / "run").exists() or list((tmp_path / "run").iterdir()) == []


@pytest.mark.parametrize("rows", [3, 5000])
def test_a_logs_keys_added_early_or_late_survive_a_read_and_write(tmp_path: Path, rows) -> None:
    """sensors.parquet's keys, added before its rows (the trim reading) or after them (the
    flight ended: known at its end, after row groups were written), are in the schema's
    metadata: pyarrow's read_table/write_table and pandas' read_parquet/to_parquet keep
    them, and read_footer reads them back."""
    import pandas as pd
    import pyarrow as pa

    from probing.experiment.output.layouts import sensors_schema
    from probing.experiment.output.storage import output_folder, read_footer

    schema = sensors_schema(["theta_rad"], False)
    with output_folder(tmp_path / "run", {b"probing.scenario": b"{}"}) as folder:
        w = folder.writer("sensors.parquet", ["theta_rad"], schema=schema)
        w.row_group_rows = 1000
        w.add_metadata({b"probing.trim_measured": b'{"theta_rad": 0.1}'})
        w.write({n: [float(i) for i in range(rows)] for n in schema.names})
        w.add_metadata({b"probing.ended": b"diverged"})
    log = tmp_path / "run" / "sensors.parquet"
    pq.write_table(pq.read_table(log), tmp_path / "arrow.parquet")
    pd.read_parquet(log).to_parquet(tmp_path / "pandas.parquet")
    for path in (log, tmp_path / "arrow.parquet", tmp_path / "pandas.parquet"):
        meta = read_footer(path)
        assert meta[b"probing.trim_measured"] == b'{"theta_rad": 0.1}', path
        assert meta[b"probing.ended"] == b"diverged", path
        assert meta[b"probing.scenario"] == b"{}", path
    assert pq.read_table(log).num_rows == rows
    assert pq.read_table(log).equals(pa.Table.from_pandas(pd.read_parquet(log)).cast(schema))


@pytest.mark.parametrize(
    "digest", ["0a1b2c3d4e5f6a7b", "1234567812345678", "12345e6712345678", "null", "true"]
)
def test_a_flights_table_written_by_pandas_gives_back_the_files_keys(tmp_path, digest) -> None:
    """A Flight's table carries the keys decoded and without their prefix (attrs_of): what
    pandas writes of them is read back as the bytes the file held, whatever a value looks
    like (a digest of digits and one e is not a number)."""
    import pandas as pd

    from probing.api.flight import attrs_of
    from probing.experiment.output.storage import metadata, read_footer

    meta = metadata(
        scenario={"name": "x", "probe": {"order": 9, "amplitude_deg": 0.005}},
        scenario_digest=digest,
        trim_measured={"theta_rad": 0.1, "q_rad_s": float("nan")},
        first_alarm_s=None,
        drift="gust",
    )
    frame = pd.DataFrame({"time_s": [0.0, 0.01]})
    frame.attrs = attrs_of(meta, "sensors.parquet")
    assert frame.attrs["scenario"]["probe"]["order"] == 9  # decoded, without the prefix
    if digest == "12345e6712345678":  # not the number 1.2345e71: written back otherwise
        assert frame.attrs["scenario_digest"] == digest
    frame.to_parquet(tmp_path / "edited.parquet")
    back = read_footer(tmp_path / "edited.parquet")
    assert {k: back[k] for k in meta} == meta
    assert b"probing.file" not in back  # the table's own key, not the file's
