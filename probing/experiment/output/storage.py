"""Parquet output: atomic files written in large row groups into a run's folder,
provenance metadata, the one JSON writer (strict JSON: NaN and infinities become null), and
the readers of stored files.  The files' layouts with units and their registry live in
:mod:`probing.experiment.output.layouts`, the checks of output paths in
:mod:`probing.experiment.output.output_paths`; both are re-exported here.

Every file's key-value metadata ``probing.units`` resolves its columns' units per channel,
e.g. ``{"z": {"theta_rad": "rad"}, "h_est": {"theta_rad": "rad/deg"}, "lag_s": "s"}``;
``probing.description`` says what the file is.
"""

from __future__ import annotations

import functools
import json
import math
import os
import platform
import subprocess
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

from probing.core import tempfiles
from probing.core.errors import ProbingError
from probing.core.forked import INTERRUPTS
from probing.experiment.output.layouts import (
    CHANNEL_UNIT,
    MANOEUVRE_SCHEMA,
    MONITOR_SCHEMA,
    OUTPUT_FILES,
    PER_DEG,
    PROBING_SCHEMA,
    RESPONSES_SCHEMA,
    RUN_FILES,
    TRUTH_SCHEMA,
    OutputFile,
    field,
    probing_block,
    timeseries_schema,
    units,
)
from probing.experiment.output.output_paths import (
    OutputFileError,
    OutputFolderError,
    OutputPathError,
    check_output_file,
    check_output_folder,
)
from probing.experiment.output.pandas_keys import from_pandas_attrs, stored_text, to_pandas_attrs
from probing.experiment.output.staging import DIGEST_KEY, earlier_files, report_removed

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
    "read_footer",
    "read_schema",
    "read_settled",
    "read_table",
    "strict_json",
    "timeseries_schema",
    "units",
    "versions",
    "write_json_atomic",
    "write_text_atomic",
]

_PROJECT_ROOT = Path(__file__).resolve().parents[3]


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
    return {f"probing.{k}".encode(): stored_text(v).encode() for k, v in items.items()}


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
    write_text_atomic(path, strict_json(payload, indent=None if compact else 1) + "\n")


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` under a temporary name in the same folder, then rename it into place:
    a reader sees the old file or the whole new one, never a part (parents are created)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{tempfiles.writer_tag()}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


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
    pandas_attrs : bool
        Also keep the ``probing.*`` keys in ``PANDAS_ATTRS`` (:mod:`~.pandas_keys`), so a
        file pandas reads and writes again keeps them (a log a user edits).

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
        pandas_attrs: bool = False,
    ) -> None:
        if row_group_rows < 1:
            raise ValueError("row_group_rows must be >= 1")
        names = schema.names
        if len(set(names)) != len(names):
            twice = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(f"{Path(path).name}: column names given twice: {twice}")
        self.path = Path(path)
        self.tmp = self.path.with_name(f".{self.path.name}.{tempfiles.writer_tag()}.tmp")
        self.schema = schema.with_metadata(metadata)
        self.pandas_attrs = pandas_attrs
        self.row_group_rows = int(row_group_rows)
        self._pending: list[pa.Table] = []
        self._pending_rows = 0
        self._writer: pq.ParquetWriter | None = None  # opened with the first row group
        self._late = False  # keys added to a log's schema after its rows began

    def _opened(self) -> pq.ParquetWriter:
        """The Parquet writer, opened on first use with the schema's metadata as it is then
        (and, with ``pandas_attrs``, the same keys in ``PANDAS_ATTRS``)."""
        if self._writer is None:
            schema = self.schema
            if self.pandas_attrs:
                meta = schema.metadata or {}
                schema = schema.with_metadata({**meta, **to_pandas_attrs(meta)})
            strings = [f.name for f in schema if pa.types.is_string(f.type)]
            floats = [f.name for f in schema if pa.types.is_floating(f.type)]
            self._writer = pq.ParquetWriter(
                self.tmp,
                schema,
                compression="zstd",
                use_dictionary=strings or False,
                use_byte_stream_split=floats or False,
            )
        return self._writer

    def write(self, columns: dict[str, Any]) -> None:
        """Append rows (columns of equal length); written out once a row group is full.

        The values are copied: the caller may reuse its arrays right away (Arrow would
        otherwise wrap a numpy array without copying, and buffered rows would change).  A
        column the schema lacks is a ValueError (Arrow would drop it silently).
        """
        names = self.schema.names  # a new list at every look-up
        if unknown := [k for k in columns if k not in names]:
            raise ValueError(f"{self.path.name} has no column {', '.join(map(repr, unknown))}")
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
        self._opened().write_table(table, row_group_size=max(table.num_rows, 1))

    def add_metadata(self, items: dict[bytes, bytes]) -> None:
        """Key-value metadata known after the writer was made.

        Before the first row group is written (a log's trim reading) the items join the
        schema's metadata, which a reader's table keeps (``pq.read_table``, a read and
        write again); after it (a monitor's verdict, known at the end) they go to the
        file's footer only (:func:`read_footer`), except in a log (``pandas_attrs``),
        which is then copied once under the new schema (:meth:`finish`).
        """
        if self._writer is None or self.pandas_attrs:  # a log: in its schema, at the end
            self.schema = self.schema.with_metadata({**(self.schema.metadata or {}), **items})
            self._late = self._writer is not None
        else:
            self._writer.add_key_value_metadata(items)

    def close(self) -> None:
        """Write the buffered rows, finish the file and move it to its final name."""
        self.finish()
        self.commit()

    def finish(self) -> None:
        """Write the buffered rows and finish the file, still under its temporary name."""
        self._flush()
        self._opened().close()  # a file without rows still has its schema
        if self._late:  # keys known after rows were written: copied into a new schema
            self._rewrite()

    def _rewrite(self) -> None:
        """Copy the finished temporary file, row group by row group, under the schema as it
        is now (its keys added late included), and put the copy in its place."""
        self._writer, self._late = None, False
        copy = self.tmp.with_name(f"{self.tmp.name}.copy")
        final, self.tmp = self.tmp, copy
        try:
            source = pq.ParquetFile(final)
            for i in range(source.num_row_groups):
                table = source.read_row_group(i).replace_schema_metadata(self.schema.metadata)
                self._opened().write_table(table, row_group_size=max(table.num_rows, 1))
            self._opened().close()
            os.replace(copy, final)
        finally:
            self.tmp = final
            copy.unlink(missing_ok=True)

    def commit(self) -> None:
        """Move the finished file to its final name."""
        os.replace(self.tmp, self.path)

    def abort(self) -> None:
        """Drop the partial file."""
        self._pending, self._pending_rows = [], 0
        try:
            if self._writer is not None:
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
        extra: dict[bytes, bytes] | None = None,
    ) -> AtomicParquetWriter:
        """A new atomic writer for ``<folder>/<name>``, a file of :data:`OUTPUT_FILES`.

        The file carries the folder's metadata, ``probing.description`` and the
        ``probing.units`` of its columns for these channels, per unit of ``per`` where a
        column is per unit of probe (:func:`units`); ``own_units`` replaces the entries of
        the columns whose unit the schema cannot say alone.  The schema and description
        are the registry's; ``schema`` gives the columns of a file laid out per run
        (``timeseries.parquet``), and a file outside the registry (a test's) names both.
        ``extra``: metadata of this file alone (:func:`metadata`), after the folder's.
        """
        spec = OUTPUT_FILES.get(name)
        schema = schema if schema is not None else spec.schema if spec else None
        description = description or (spec.description if spec else None)
        if schema is None or description is None:
            raise ValueError(f"{name}: not in OUTPUT_FILES, or laid out per run: give schema")
        found = {**units(schema, channels, per), **(own_units or {})}
        meta = {**self.metadata, **metadata(description=description, units=found), **(extra or {})}
        keep = spec is not None and spec.pandas_attrs
        w = AtomicParquetWriter(self.path / name, schema, meta, pandas_attrs=keep)
        self.writers.append(w)
        return w


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

    On any exception the partial files and the folders made here go; earlier files stay whole.
    """
    path = Path(path)
    created = tempfiles.missing_folders(path)
    if not created:
        tempfiles.remove_dead_writers_files(path, ".tmp")
    path.mkdir(parents=True, exist_ok=True)
    folder = OutputFolder(path, metadata)
    try:
        yield folder
        for w in folder.writers:
            w.finish()
        written = {w.path.name for w in folder.writers}
        earlier = earlier_files(path, written, folder.metadata.get(DIGEST_KEY), adds)
        for stale in earlier:
            stale.unlink(missing_ok=True)
        for w in folder.writers:
            w.commit()
    except BaseException:
        with INTERRUPTS.deferred():
            for w in folder.writers:
                w.abort()
            tempfiles.remove_created(created)
        raise
    report_removed(path, earlier, stream)


# ------------------------------------------------------------------ reading
class StoredFileError(ProbingError, ValueError):
    """A stored file that cannot be read (not Parquet, damaged, unreadable); the message
    names it."""


@contextmanager
def _reading(path: Path, data: bytes | None = None) -> Iterator[Any]:
    """What to read, ``path`` or its bytes ``data``; pyarrow's and the system's errors while
    reading it turned into :class:`StoredFileError` naming ``path``."""
    try:
        yield path if data is None else pa.BufferReader(data)
    except (pa.ArrowException, OSError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc).split(". ")[0].strip() or "?"
        raise StoredFileError(f"{path}: cannot be read as Parquet ({reason})") from None


def read_table(
    path: Path, columns: Sequence[str] | None = None, *, data: bytes | None = None
) -> pa.Table:
    """A stored Parquet file (these ``columns``, or all), with its key-value metadata.

    ``read_table(path).to_pandas()`` for a DataFrame: every reader of stored results goes
    through here or :func:`read_schema`, so a damaged file is one error naming it.
    ``data``: the file's bytes, held in memory (:class:`probing.Flight`); ``path`` then
    only names it.

    Raises
    ------
    StoredFileError
        When ``path`` is missing, unreadable or not a Parquet file.
    """
    with _reading(path, data) as source:
        return pq.read_table(source, columns=None if columns is None else list(columns))


def read_schema(path: Path) -> pa.Schema:
    """The schema (with its key-value metadata) of a stored Parquet file.

    Raises
    ------
    StoredFileError
        When ``path`` is missing, unreadable or not a Parquet file.
    """
    with _reading(path):
        return pq.read_schema(path)


def read_footer(path: Path, *, data: bytes | None = None) -> dict[bytes, bytes]:
    """The key-value metadata of a stored Parquet file's footer, with what its writer added
    at the end (a monitor's verdict), and the ``probing.*`` keys pandas kept in
    ``PANDAS_ATTRS`` after a read and write of the file (the footer's own win).
    ``data``: as for :func:`read_table`.

    Raises
    ------
    StoredFileError
        When ``path`` is missing, unreadable or not a Parquet file.
    """
    with _reading(path, data) as source:
        meta = dict(pq.read_metadata(source).metadata or {})
    return {**from_pandas_attrs(meta), **meta}


@dataclass(frozen=True)
class Settled:
    """The settled periods of one channel of a ``probing.parquet`` file.

    Attributes
    ----------
    periods : numpy.ndarray
        Period indices, shape (P,): those >= ``settle_periods`` whose h_est is finite at
        every tap (the rule :func:`probing.experiment.flight.run.run_scenario` averages by).
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
