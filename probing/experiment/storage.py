"""Parquet output: the files' layouts with units, atomic files written in large row groups,
provenance metadata, the checks of output folders and files, the one JSON writer (strict
JSON: NaN and infinities become null), and the readers of stored files.

Every column carries field metadata ``unit`` and ``description``; a unit written
``<channel>`` (or ``<channel>/deg``) is the unit of the row's channel (per deg of probe), and
every file's key-value metadata ``probing.units`` resolves them per channel, e.g.
``{"z": {"theta_rad": "rad"}, "h_est": {"theta_rad": "rad/deg"}, "lag_s": "s"}``.
``probing.description`` says what the file is.
"""

from __future__ import annotations

import functools
import json
import math
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import uuid
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from importlib import metadata as importlib_metadata
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from probing.core.tempfiles import remove_dead_writers_files, writer_tag
from probing.sim.channels import unit_of
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACES

__all__ = [
    "CHANNEL_UNIT",
    "MANOEUVRE_SCHEMA",
    "MONITOR_SCHEMA",
    "OUTPUT_FILES",
    "PER_DEG",
    "PROBING_SCHEMA",
    "RESPONSES_SCHEMA",
    "ROW_GROUP_ROWS",
    "RUN_FILES",
    "TRUTH_SCHEMA",
    "AtomicParquetWriter",
    "OutputFile",
    "OutputFileError",
    "OutputFolder",
    "OutputFolderError",
    "OutputPathError",
    "Settled",
    "StoredFileError",
    "check_output_file",
    "check_output_folder",
    "field",
    "git_revision",
    "metadata",
    "output_folder",
    "probing_block",
    "provenance",
    "read_schema",
    "read_settled",
    "read_table",
    "strict_json",
    "timeseries_schema",
    "units",
    "versions",
    "write_json_atomic",
]

_PROJECT_ROOT = Path(__file__).resolve().parents[2]


@functools.cache
def _package_versions() -> tuple[tuple[str, str], ...]:
    out = [("python", platform.python_version())]
    for name in ("probing", "jsbsim", "numpy", "scipy", "pandas", "pyarrow"):
        try:
            out.append((name, importlib_metadata.version(name)))
        except importlib_metadata.PackageNotFoundError:
            out.append((name, "unknown"))
    return tuple(out)


def versions() -> dict[str, str]:
    """Versions of Python and of the packages that shape the numbers (looked up once)."""
    return dict(_package_versions())


_BATCH_REVISION: list[str] = []  # set while a batch of runs shares one look-up


@contextmanager
def batch_of_runs() -> Iterator[None]:
    """Prepare this process for many runs in children forked from it.

    Inside the block the git revision is looked up once (two ``git`` calls, ~20 ms, are
    otherwise made by every run), and what writing and reading a run's files imports
    lazily (``pyarrow.compute``, pandas through it, ``pyarrow.dataset``: ~0.4 s) is
    imported now, so each forked child inherits it instead of importing it again.
    """
    pa.array([0]).take(pa.array([0]))  # the lazy imports of probing_block
    import pyarrow.dataset  # noqa: F401  (imported by pq.read_table, e.g. read_settled)

    versions()
    _BATCH_REVISION.append(git_revision())
    try:
        yield
    finally:
        _BATCH_REVISION.pop()


def git_revision() -> str:
    """The project's git revision (with ``-dirty`` for uncommitted changes), or ``unknown``."""
    if _BATCH_REVISION:
        return _BATCH_REVISION[-1]
    try:
        rev = subprocess.run(
            ["git", "-C", str(_PROJECT_ROOT), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(_PROJECT_ROOT), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return f"{rev}-dirty" if dirty else rev


def metadata(**items: Any) -> dict[bytes, bytes]:
    """Parquet key-value metadata: ``probing.<key>`` -> text (JSON for non-strings)."""
    return {
        f"probing.{k}".encode(): (
            v if isinstance(v, str) else json.dumps(v, sort_keys=True)
        ).encode()
        for k, v in items.items()
    }


def provenance(**items: Any) -> dict[bytes, bytes]:
    """:func:`metadata` of ``items`` with the package versions and the git revision."""
    return metadata(versions=versions(), git_revision=git_revision(), **items)


#: Rows buffered before a row group is written: large groups keep the per-group cost of
#: Parquet (page headers, statistics, compression set-up) negligible, and the buffer small
#: (~0.5 MB per float64 column).
ROW_GROUP_ROWS = 65536


def _finite(value: Any) -> Any:
    """``value`` with every NaN or infinite float (in dicts, lists, tuples) replaced by None."""
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


def strict_json(payload: Any, indent: int | None = None, sort_keys: bool = True) -> str:
    """``payload`` as strict JSON text: NaN and infinities are written ``null`` (JSON has
    neither; Python's bare ``NaN`` is refused by strict parsers), anything
    JSON cannot hold written as its ``str``.

    Parameters
    ----------
    payload : object
        Dicts, lists, tuples, strings, numbers, booleans and None.
    indent : int, optional
        Indentation; None writes one line.
    sort_keys : bool
        Keys in sorted order (else in the dicts' order).

    Returns
    -------
    str
        The JSON text (no trailing newline).
    """
    return json.dumps(
        _finite(payload), indent=indent, sort_keys=sort_keys, default=str, allow_nan=False
    )


def write_json_atomic(path: Path, payload: Any, compact: bool = False) -> None:
    """Write ``payload`` as strict JSON (:func:`strict_json`: NaN is null) under a temporary
    name, then rename it into place.

    A reader sees the old file or the whole new one, never a part (parents are created).
    ``compact``: one line, no indentation (Python's C encoder then writes it, about twice
    as fast: for files written per run that hold long lists of floats).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{writer_tag()}.{uuid.uuid4().hex[:8]}.tmp")
    tmp.write_text(strict_json(payload, indent=None if compact else 1) + "\n")
    os.replace(tmp, path)


class AtomicParquetWriter:
    """Write a Parquet file under a temporary name in large row groups; rename on :meth:`close`.

    Parameters
    ----------
    path : pathlib.Path
        Final file name.
    schema : pyarrow.Schema
        Columns of the file.
    metadata : dict
        Key-value metadata stored in the file's schema.
    row_group_rows : int
        Rows buffered before they are written as one row group (the last group of the file
        holds the rest).  Memory stays bounded by this many rows whatever the file's length.

    Notes
    -----
    Only string columns are dictionary-encoded: the float columns hold (nearly) unique
    values, for which building a dictionary is wasted time.  Float columns use the
    BYTE_STREAM_SPLIT encoding, which makes them compress ~20 % smaller under zstd at
    the same cost.
    """

    def __init__(
        self,
        path: Path,
        schema: pa.Schema,
        metadata: dict[bytes, bytes],
        row_group_rows: int = ROW_GROUP_ROWS,
    ) -> None:
        if row_group_rows < 1:
            raise ValueError("row_group_rows must be >= 1")
        names = schema.names
        if len(set(names)) != len(names):
            twice = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(f"{Path(path).name}: column names given twice: {twice}")
        self.path = Path(path)
        self.tmp = self.path.with_name(f".{self.path.name}.{writer_tag()}.tmp")
        self.schema = schema.with_metadata(metadata)
        self.row_group_rows = int(row_group_rows)
        self._pending: list[pa.Table] = []
        self._pending_rows = 0
        strings = [f.name for f in schema if pa.types.is_string(f.type)]
        floats = [f.name for f in schema if pa.types.is_floating(f.type)]
        self._writer = pq.ParquetWriter(
            self.tmp,
            self.schema,
            compression="zstd",
            use_dictionary=strings or False,
            use_byte_stream_split=floats or False,
        )

    def write(self, columns: dict[str, Any]) -> None:
        """Append rows (columns of equal length); written out once a row group is full.

        The values are copied: the caller may reuse its arrays right away (Arrow would
        otherwise wrap a numpy array without copying, and buffered rows would change).
        """
        columns = {k: np.array(v) if isinstance(v, np.ndarray) else v for k, v in columns.items()}
        table = pa.table(columns, schema=self.schema)
        self._pending.append(table)
        self._pending_rows += table.num_rows
        if self._pending_rows >= self.row_group_rows:
            self._flush()

    def _flush(self) -> None:
        if not self._pending:
            return
        table = pa.concat_tables(self._pending)
        self._pending, self._pending_rows = [], 0
        self._writer.write_table(table, row_group_size=max(table.num_rows, 1))

    def add_metadata(self, items: dict[bytes, bytes]) -> None:
        """Key-value metadata known only at the end (a monitor's verdict), added to the
        file's footer before it is closed."""
        self._writer.add_key_value_metadata(items)

    def close(self) -> None:
        """Write the buffered rows, finish the file and move it to its final name."""
        self.finish()
        self.commit()

    def finish(self) -> None:
        """Write the buffered rows and finish the file, still under its temporary name."""
        self._flush()
        self._writer.close()

    def commit(self) -> None:
        """Move the finished file to its final name."""
        os.replace(self.tmp, self.path)

    def abort(self) -> None:
        """Drop the partial file."""
        self._pending, self._pending_rows = [], 0
        try:
            self._writer.close()
        finally:
            self.tmp.unlink(missing_ok=True)


class OutputFolder:
    """The Parquet files of one run's output folder, opened through :func:`output_folder`."""

    def __init__(self, path: Path, metadata: dict[bytes, bytes]) -> None:
        self.path = path
        self.metadata = metadata
        self.writers: list[AtomicParquetWriter] = []

    def writer(
        self,
        name: str,
        channels: Sequence[str],
        per: str = "deg",
        own_units: dict[str, Any] | None = None,
        schema: pa.Schema | None = None,
        description: str | None = None,
    ) -> AtomicParquetWriter:
        """A new atomic writer for ``<folder>/<name>``, a file of :data:`OUTPUT_FILES`.

        The file carries the folder's metadata, ``probing.description`` and the
        ``probing.units`` of its columns for these channels, per unit of ``per`` where a
        column is per unit of probe (:func:`units`); ``own_units`` replaces the entries of
        the columns whose unit the schema cannot say alone.  The schema and description
        are the registry's; ``schema`` gives the columns of a file laid out per run
        (``timeseries.parquet``), and a file outside the registry (a test's) names both.
        """
        spec = OUTPUT_FILES.get(name)
        schema = schema if schema is not None else spec.schema if spec else None
        description = description or (spec.description if spec else None)
        if schema is None or description is None:
            raise ValueError(f"{name}: not in OUTPUT_FILES, or laid out per run: give schema")
        found = {**units(schema, channels, per), **(own_units or {})}
        meta = {**self.metadata, **metadata(description=description, units=found)}
        w = AtomicParquetWriter(self.path / name, schema, meta)
        self.writers.append(w)
        return w


_DIGEST_KEY = b"probing.scenario_digest"


def _scenario_digest(path: Path) -> bytes | None:
    """The scenario digest a Parquet file of the project carries (None: none, unreadable)."""
    try:
        return (pq.read_schema(path).metadata or {}).get(_DIGEST_KEY)
    except (OSError, pa.ArrowException):
        return None


def _earlier_files(folder: OutputFolder, adds: bool) -> list[Path]:
    """The files of an earlier run in ``folder`` that the files being written replace:
    those of :data:`RUN_FILES` not written now (with ``adds``, only those of another
    scenario than the folder's metadata names)."""
    written = {w.path.name for w in folder.writers}
    digest = folder.metadata.get(_DIGEST_KEY)
    earlier = []
    for name in RUN_FILES:
        path = folder.path / name
        if name in written or not path.is_file():
            continue
        if adds and digest is not None and _scenario_digest(path) == digest:
            continue  # the run these files are added to
        earlier.append(path)
    return earlier


@contextmanager
def output_folder(
    path: Path,
    metadata: dict[bytes, bytes],
    *,
    adds: bool = False,
    stream: TextIO | None = None,
) -> Iterator[OutputFolder]:
    """Create ``path`` (and parents) and hand out writers; all files appear together at the end.

    On success every writer's file is finished, then the files an earlier run left in the
    folder (those of :data:`RUN_FILES` not written now) are removed and the new files
    renamed into place, in that order: the folder then holds this run's files only, and
    one line on ``stream`` (default stderr) names what was removed.  ``adds``: the files
    are added to the run of the same scenario (``probing truth``), whose files stay; those
    of another scenario go.  Temporaries a killed writer left in the folder are removed
    on entry (:func:`probing.core.tempfiles.remove_dead_writers_files`).

    On any exception every partial file is dropped and the folders this call created are
    removed, so a failed run leaves nothing behind, and an earlier run's files stay whole.
    """
    path = Path(path)
    created = [p for p in (*reversed(path.parents), path) if not p.exists()]
    if not created:
        remove_dead_writers_files(path, ".tmp")
    path.mkdir(parents=True, exist_ok=True)
    folder = OutputFolder(path, metadata)
    try:
        yield folder
        for w in folder.writers:
            w.finish()
        earlier = _earlier_files(folder, adds)
        for stale in earlier:
            stale.unlink(missing_ok=True)
        for w in folder.writers:
            w.commit()
    except BaseException:
        for w in folder.writers:
            w.abort()
        for p in reversed(created):
            shutil.rmtree(p, ignore_errors=True)
        raise
    if earlier:
        names = ", ".join(p.name for p in earlier)
        print(
            f"{path}: removed the files of an earlier run: {names}",
            file=stream or sys.stderr,
            flush=True,
        )


# ------------------------------------------------------------------ layouts with units
CHANNEL_UNIT = "<channel>"  # placeholder: the unit of the row's channel
PER_DEG = "<channel>/deg"  # ... per deg of probe


def field(name: str, dtype: pa.DataType, unit: str, description: str) -> pa.Field:
    """A Parquet column with its unit and description as field metadata."""
    return pa.field(name, dtype, metadata={"unit": unit, "description": description})


PROBING_SCHEMA = pa.schema(
    [
        field("channel", pa.string(), "", "output channel (its name carries its unit)"),
        field("period", pa.int32(), "1", "probe period p, counted from the first probe sample"),
        field("tap", pa.int32(), "1", "tap i: the response i bits after a one-bit pulse"),
        field("lag_s", pa.float64(), "s", "lag of the tap, i t0"),
        field("z", pa.float64(), CHANNEL_UNIT, "probing output, eq. (5), in tap order"),
        field("zeta", pa.float64(), CHANNEL_UNIT, "DC-corrected probing output, eq. (9)"),
        field("h_est", pa.float64(), PER_DEG, "pulse-response estimate zeta / (a (M+1))"),
    ]
)

MONITOR_SCHEMA = pa.schema(
    [
        field("period", pa.int32(), "1", "probe period p, counted from the first probe sample"),
        field("time_s", pa.float64(), "s", "time after trim at the end of the period"),
        field("channel", pa.string(), "", "output channel (its name carries its unit)"),
        field("statistic", pa.float64(), "1", "-log10 p of no change (NaN: baseline)"),
        field("threshold", pa.float64(), "1", "-log10 of the false-alarm probability"),
        field("alarm", pa.bool_(), "", "statistic > threshold"),
        field("gain_change", pa.float64(), "1", "estimated scale of h against the baseline"),
        field("shape_change", pa.float64(), "1", "airframe test over its threshold"),
        field("verdict", pa.string(), "", "none, actuator (gain and offset) or airframe"),
    ]
)

TRUTH_SCHEMA = pa.schema(
    [
        field("channel", pa.string(), "", "output channel (its name carries its unit)"),
        field("tap", pa.int32(), "1", "bits after the pulse"),
        field("lag_s", pa.float64(), "s", "time after the pulse, tap t0"),
        field("h_pulse", pa.float64(), PER_DEG, "single one-bit pulse on a trimmed twin"),
        field("h_lin", pa.float64(), PER_DEG, "FGLinearization, ZOH at t0 (NaN: no output)"),
    ]
)


def timeseries_schema(
    channels: list[str], reference: bool, control: bool = False, surface: str = DEFAULT_SURFACE
) -> pa.Schema:
    """``timeseries.parquet``: one row per simulation step; channels in their own units; the
    probe, its nonlinearity's output and the probed surface's realised position in the
    surface's unit (``probe_deg``, ``nl_out_deg``, ``elevator_pos_deg``; ``_norm`` and
    ``throttle_pos_norm`` for the throttle; the surface's sensor channel, ``elevator_deg``,
    is a channel like any other); with ``control``, the autopilot's command of the probed
    surface too."""
    s = SURFACES[surface]
    u = s.unit
    fields = [
        field("time_s", pa.float64(), "s", "time after trim, at the end of the step"),
        field(f"probe_{u}", pa.float64(), u, "probe a sigma, relative to trim"),
        field(f"nl_out_{u}", pa.float64(), u, "probe after the nonlinearity"),
        field(s.position_column, pa.float64(), u, f"realised {s.name} position (no noise)"),
    ]
    if control:
        fields.append(
            field(f"control_{u}", pa.float64(), u, f"the autopilot's {s.name} command, from trim")
        )
    fields += [
        field(c, pa.float64(), unit_of(c), "measured (sensor noise added)") for c in channels
    ]
    if reference:
        fields += [
            field(f"{c}_reference", pa.float64(), unit_of(c), "unprobed twin") for c in channels
        ]
    return pa.schema(fields)


MANOEUVRE_SCHEMA = pa.schema(
    [
        field("channel", pa.string(), "", "output channel (its name carries its unit)"),
        field("period", pa.int32(), "1", "probe period p, counted from the first probe sample"),
        field("time_mid_s", pa.float64(), "s", "time after trim at the middle of the period"),
        field("reference", pa.float64(), "<manoeuvre>", "the hold's reference change there"),
        field(
            "achieved",
            pa.float64(),
            "<manoeuvre>",
            "the twin's change there (pitch, bank: deg; speed: kt true)",
        ),
        field("tap", pa.int32(), "1", "tap i: the response i bits after a one-bit pulse"),
        field("lag_s", pa.float64(), "s", "lag of the tap, i t0"),
        field("h_est", pa.float64(), PER_DEG, "the period's own cyclic estimate"),
        field(
            "h_pulse",
            pa.float64(),
            PER_DEG,
            "single pulse on the twin at mid-period, folded onto one period",
        ),
    ]
)

RESPONSES_SCHEMA = pa.schema(
    [
        field("surface", pa.string(), "", "probed surface (its unit: deg, or norm)"),
        field("channel", pa.string(), "", "output channel (its name carries its unit)"),
        field("tap", pa.int32(), "1", "bits after the surface's pulse"),
        field("lag_s", pa.float64(), "s", "lag of the tap, tap t0"),
        field("h_est", pa.float64(), "<channel>/<surface>", "the surfaces probed together"),
        field("h_alone", pa.float64(), "<channel>/<surface>", "this surface probed alone"),
        field("h_lin", pa.float64(), "<channel>/<surface>", "the linearisation, alone"),
    ]
)


@dataclass(frozen=True)
class OutputFile:
    """A file of a run's folder: its layout and what it holds.

    Attributes
    ----------
    name : str
        The file name in the run's folder.
    description : str
        Stored as the file's ``probing.description``.
    schema : pyarrow.Schema or None
        Its columns with their units; None for a file laid out per run (its writer builds
        the schema: ``timeseries.parquet``'s columns are the run's channels).
    """

    name: str
    description: str
    schema: pa.Schema | None


#: Every file a run writes into its folder: the one place a file's name, layout and
#: description live (:meth:`OutputFolder.writer` reads it; adding a file is one entry).
OUTPUT_FILES: dict[str, OutputFile] = {
    f.name: f
    for f in (
        OutputFile(
            "probing.parquet",
            "probing output z (eq. 5), its DC-corrected form zeta (eq. 9) and the "
            "pulse-response estimate h_est, one row per channel, period and tap",
            PROBING_SCHEMA,
        ),
        OutputFile(
            "timeseries.parquet",
            "the run step by step: probe, nonlinearity output, realised surface, measured "
            "outputs (sensor noise added) and the unprobed twin's outputs",
            None,
        ),
        OutputFile(
            "truth.parquet",
            "ground truth: h_pulse, one-bit pulse of amplitude a on a trimmed twin minus an "
            "unprobed twin, over a; h_lin, JSBSim's FGLinearization discretised with "
            "zero-order hold at t0; both sampled at the end of each bit, over the whole run",
            TRUTH_SCHEMA,
        ),
        OutputFile(
            "prediction.parquet",
            "predicted probing output: h_pulse superposed over the run's probe history and "
            "passed through the same correlator; compare row by row with probing.parquet",
            PROBING_SCHEMA,
        ),
        OutputFile(
            "monitor.parquet",
            "change detection after every probe period, one row per period and monitored "
            "channel: -log10 p of no change of the period's pulse-response estimate against "
            "the flight's own baseline (Hotelling T^2 and the gain), its threshold for the "
            "false-alarm rate, the gain against the baseline and the airframe test",
            MONITOR_SCHEMA,
        ),
        OutputFile(
            "responses.parquet",
            "each probed surface's pulse response, probed together, alone and on the "
            "linearisation, over the surface's window of taps",
            RESPONSES_SCHEMA,
        ),
        OutputFile(
            "manoeuvre.parquet",
            "the probing output's pulse response period by period along the manoeuvre, "
            "and a single pulse on the unprobed twin at each period's middle",
            MANOEUVRE_SCHEMA,
        ),
    )
}

#: The files the project writes into a run's folder (:data:`OUTPUT_FILES`).  A run that
#: completes into a folder removes those of them it did not write (an earlier run's), so the
#: folder holds the files of one run only.
RUN_FILES = tuple(OUTPUT_FILES)


def units(schema: pa.Schema, channels: Sequence[str], per: str = "deg") -> dict[str, Any]:
    """The ``probing.units`` map of a file: column -> unit, or channel -> unit for the columns
    in the unit of the row's channel; ``per``: the probed surface's unit, which a column per
    deg of probe (:data:`PER_DEG`) is per (``"norm"`` for the throttle)."""
    out: dict[str, Any] = {}
    for f in schema:
        unit = (f.metadata or {}).get(b"unit", b"").decode()
        if unit in (CHANNEL_UNIT, PER_DEG):
            suffix = unit.removeprefix(CHANNEL_UNIT).replace("deg", per)
            out[f.name] = {c: unit_of(c) + suffix for c in channels}
        elif unit:
            out[f.name] = unit
    return out


def probing_block(
    channels: list[str],
    periods: np.ndarray,
    lag_s: np.ndarray,
    z: np.ndarray,
    zeta: np.ndarray,
    h: np.ndarray,
) -> dict[str, object]:
    """Periods of several channels in the layout of :data:`PROBING_SCHEMA`.

    Parameters
    ----------
    channels : list of str
        Channel names, C of them.
    periods : numpy.ndarray
        Period indices, shape (P,).
    lag_s : numpy.ndarray
        Lag of each tap (s), shape (M,).
    z, zeta, h : numpy.ndarray
        Shape (P, C, M), in the units of :data:`PROBING_SCHEMA`'s columns.

    Returns
    -------
    dict
        Columns with the rows ordered by period, then channel, then tap.
    """
    n_p, n_c, m = z.shape
    names = pa.array(channels, pa.string())
    return {
        "channel": names.take(pa.array(np.tile(np.repeat(np.arange(n_c), m), n_p))),
        "period": np.repeat(np.asarray(periods, dtype=np.int32), n_c * m),
        "tap": np.tile(np.arange(m, dtype=np.int32), n_p * n_c),
        "lag_s": np.tile(lag_s, n_p * n_c),
        "z": z.reshape(-1),
        "zeta": zeta.reshape(-1),
        "h_est": h.reshape(-1),
    }


# ------------------------------------------------------------------ reading
class StoredFileError(ValueError):
    """A stored file that cannot be read (not Parquet, damaged, unreadable); the message
    names it."""


@contextmanager
def _reading(path: Path) -> Iterator[None]:
    """Turn pyarrow's and the system's errors while reading ``path`` into
    :class:`StoredFileError` naming the file."""
    try:
        yield
    except (pa.ArrowException, OSError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc).split(". ")[0].strip() or "?"
        raise StoredFileError(f"{path}: cannot be read as Parquet ({reason})") from None


def read_table(path: Path, columns: Sequence[str] | None = None) -> pa.Table:
    """A stored Parquet file (these ``columns``, or all), with its key-value metadata.

    ``read_table(path).to_pandas()`` for a DataFrame: every reader of stored results goes
    through here or :func:`read_schema`, so a damaged file is one error naming it.

    Raises
    ------
    StoredFileError
        When ``path`` is missing, unreadable or not a Parquet file.
    """
    with _reading(path):
        return pq.read_table(path, columns=None if columns is None else list(columns))


def read_schema(path: Path) -> pa.Schema:
    """The schema (with its key-value metadata) of a stored Parquet file.

    Raises
    ------
    StoredFileError
        When ``path`` is missing, unreadable or not a Parquet file.
    """
    with _reading(path):
        return pq.read_schema(path)


@dataclass(frozen=True)
class Settled:
    """The settled periods of one channel of a ``probing.parquet`` file.

    Attributes
    ----------
    periods : numpy.ndarray
        Period indices, shape (P,): those >= ``settle_periods`` whose h_est is finite at
        every tap (the rule :func:`probing.experiment.run.run_scenario` averages by).
    lag_s : numpy.ndarray
        Lag of each tap, s, shape (M,).
    z, h : numpy.ndarray
        Probing output (channel unit) and pulse-response estimate (channel unit per deg),
        shape (P, M), tap order.
    """

    periods: np.ndarray
    lag_s: np.ndarray
    z: np.ndarray
    h: np.ndarray


def read_settled(path: Path, channel: str, settle_periods: int, m: int) -> Settled:
    """Read the settled periods of one channel from a ``probing.parquet`` (or prediction) file.

    Parameters
    ----------
    path : pathlib.Path
        The Parquet file.
    channel : str
        The channel.
    settle_periods : int
        Periods to leave out at the start.
    m : int
        Taps per period, M.

    Returns
    -------
    Settled

    Raises
    ------
    StoredFileError
        When ``path`` is missing, unreadable or not a Parquet file of this layout.
    """
    with _reading(path):
        table = pq.read_table(
            path,
            columns=["period", "tap", "lag_s", "z", "h_est"],
            filters=[("channel", "==", channel), ("period", ">=", settle_periods)],
        )
    order = np.lexsort((table.column("tap").to_numpy(), table.column("period").to_numpy()))
    z, h = (table.column(c).to_numpy()[order].reshape(-1, m) for c in ("z", "h_est"))
    periods = table.column("period").to_numpy()[order].reshape(-1, m)[:, 0]
    lag_s = table.column("lag_s").to_numpy()[order][:m]
    keep = np.all(np.isfinite(h), axis=1)
    return Settled(periods[keep], lag_s, z[keep], h[keep])


# ------------------------------------------------------------------ output paths
class OutputPathError(ValueError):
    """An output path that cannot be written; the message names the option and says why."""


class OutputFolderError(OutputPathError):
    """An output path that cannot be a folder we write into."""


class OutputFileError(OutputPathError):
    """An output path that cannot be a file we write."""


def _not_empty(path: str | Path, option: str, error: type[OutputPathError]) -> Path:
    """``Path(path)``; an empty string (which ``Path`` would make the current folder) is
    refused."""
    if isinstance(path, str) and not path:
        raise error(f"{option}: empty path")
    return Path(path)


def _writable_ancestor(path: Path, start: Path, option: str, error: type[OutputPathError]) -> Path:
    """The nearest existing of ``start`` and its ancestors, which must be a folder we can
    create something in (a probe folder is created there and removed at once); ``path`` is
    the output path the message names."""
    existing = start
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise error(f"{option} {path}: is below a file ({existing})")
    try:
        probe = Path(tempfile.mkdtemp(prefix=".probing-write-test-", dir=existing))
    except OSError as exc:
        reason = exc.strerror or exc.__class__.__name__
        raise error(f"{option} {path}: cannot write in {existing} ({reason})") from None
    probe.rmdir()
    return existing


def check_output_folder(path: str | Path, option: str) -> Path:
    """Refuse, before any work, an output folder that cannot be created or written.

    Nothing is left behind: a probe folder is created in the nearest existing ancestor and
    removed at once.

    Parameters
    ----------
    path : path
        The folder (it may not exist yet).
    option : str
        The command-line option that named it, for the message (``"--out"``).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    OutputFolderError
        When ``path`` is empty, ``path`` or an ancestor is a file, or the nearest existing
        ancestor does not let us create a folder in it.
    """
    path = _not_empty(path, option, OutputFolderError)
    if path.exists() and not path.is_dir():
        raise OutputFolderError(f"{option} {path}: is a file, not a folder")
    _writable_ancestor(path, path, option, OutputFolderError)
    return path


def check_output_file(path: str | Path, option: str) -> Path:
    """Refuse, before any work, an output file that cannot be written (the folder
    :func:`check_output_folder`'s counterpart: one rule for every output file).

    Nothing is left behind: the file is not created; a probe folder is created in the
    nearest existing ancestor of its folder and removed at once.

    Parameters
    ----------
    path : path
        The file (it may not exist yet; an existing file is replaced).
    option : str
        The command-line option that named it, for the message (``"--copy-summary"``).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    OutputFileError
        When ``path`` is empty or a folder, an ancestor is a file, the nearest existing
        ancestor does not let us create anything in it, or ``path`` is a file we may not
        write.
    """
    path = _not_empty(path, option, OutputFileError)
    if path.is_dir():
        raise OutputFileError(f"{option} {path}: is a folder, not a file")
    if path.exists() and not os.access(path, os.W_OK):
        raise OutputFileError(f"{option} {path}: cannot write it (permission denied)")
    _writable_ancestor(path, path.parent, option, OutputFileError)
    return path
