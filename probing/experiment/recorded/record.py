"""Recorded data read from a file: named columns of a CSV, Parquet or MATLAB ``.mat`` file,
and the checks of its time base.

A ``.mat`` file is read with :func:`scipy.io.loadmat` (MATLAB v5 to v7.2, not v7.3/HDF5):
each column is a variable holding a vector (a row or a column); structs are not read.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from probing.core.errors import ProbingError
from probing.core.time_grid import GRID_TOLERANCE, off_grid

__all__ = [
    "DRIFTS",
    "FORMATS",
    "RecordError",
    "column_unit",
    "file_sha256",
    "not_numbers",
    "read_columns",
    "sample_step_s",
]

#: File suffix -> format name.
FORMATS = {".csv": "csv", ".parquet": "parquet", ".mat": "mat"}

#: What ``probing analyze`` removes from a record's outputs without a reference column: a
#: periodic part and a linear trend fitted together, or the mean
#: (:mod:`probing.experiment.recorded.analyze`).
DRIFTS = ("detrend", "none")

#: Relative tolerance of a uniform time step (:data:`probing.core.time_grid.GRID_TOLERANCE`).
STEP_TOLERANCE = GRID_TOLERANCE

#: A time column whose name ends so is in another unit than seconds: (unit, per second).
TIME_SUFFIXES = {
    "_ms": ("milliseconds", 1e3),
    "_us": ("microseconds", 1e6),
    "_ns": ("nanoseconds", 1e9),
}

#: A numeric time column starting at or after this many seconds is Unix time (1e8 s is
#: 1973; no record lasts three years), whose float step jitters by ~1e-7 s at today's
#: values, more than :data:`STEP_TOLERANCE` of any sampling step shorter than 0.1 s.
EPOCH_LIKE_S = 1e8


#: A column name's unit suffix -> the unit, longest first (``q_rad_s`` is rad/s, not s).
UNIT_SUFFIXES = (
    ("_rad_s", "rad/s"),
    ("_deg_s", "deg/s"),
    ("_m_s2", "m/s^2"),
    ("_ft_s2", "ft/s^2"),
    ("_m_s", "m/s"),
    ("_ft_s", "ft/s"),
    ("_fps", "ft/s"),
    ("_rad", "rad"),
    ("_deg", "deg"),
    ("_kt", "kt"),
    ("_ft", "ft"),
    ("_m", "m"),
    ("_g", "g"),
    ("_n", "N"),
    ("_pa", "Pa"),
    ("_s", "s"),
)


def column_unit(name: str) -> str | None:
    """The unit a column's name ends with (``theta_rad`` -> ``rad``, ``q_rad_s`` ->
    ``rad/s``; :data:`UNIT_SUFFIXES`), or None when the name states none.

    Examples
    --------
    >>> column_unit("q_rad_s"), column_unit("elevator_deg"), column_unit("y")
    ('rad/s', 'deg', None)
    """
    low = name.lower()
    for suffix, unit in UNIT_SUFFIXES:
        if low.endswith(suffix) and len(low) > len(suffix):
            return unit
    return None


class RecordError(ProbingError, ValueError):
    """A record that cannot be analysed; the message names the file or column and why."""


def not_numbers(values: np.ndarray) -> str | None:
    """What a column holds if not numbers (integers, floats or booleans), in a few words:
    ``"text"``, ``"date-times"``, ``"complex numbers"`` or its type; None if it holds numbers.

    Examples
    --------
    >>> not_numbers(np.array([0.1, 0.2])), not_numbers(np.array(["0.1", "0.2"], dtype=object))
    (None, 'text')
    """
    dtype = np.asarray(values).dtype
    if dtype.kind in "biuf":
        return None
    return _HELD.get(dtype.kind, str(dtype))


#: What a column of a numpy kind holds that is not numbers (:func:`not_numbers`).
_HELD = {
    "O": "text",
    "U": "text",
    "S": "text",
    "M": "date-times",
    "m": "durations",
    "c": "complex numbers",
    "V": "structs",
}


def file_sha256(path: Path) -> str:
    """SHA-256 of the file's bytes, hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _available(path: Path, kind: str) -> dict[str, np.ndarray] | list[str]:
    if kind == "csv":
        import pandas as pd

        return {c: frame for c, frame in pd.read_csv(path).items()}
    if kind == "parquet":
        import pyarrow.parquet as pq

        return pq.read_schema(path).names
    from scipy.io import loadmat

    try:
        variables = loadmat(path)
    except OSError:
        raise
    except Exception as exc:  # a damaged file fails anywhere in scipy's reader, any way
        reason = " ".join(str(exc).split()) or exc.__class__.__name__
        raise ValueError(
            f"not a MAT file of MATLAB v5 to v7.2, or a damaged one: {reason}"
        ) from None
    return {k: v for k, v in variables.items() if not k.startswith("__")}


def read_columns(path: Path, names: list[str], time: str | None = None) -> dict[str, np.ndarray]:
    """The named columns of a CSV, Parquet or ``.mat`` file as float arrays.

    Parameters
    ----------
    path : pathlib.Path
        The file; its suffix says the format (:data:`FORMATS`).
    names : list of str
        Column (or ``.mat`` variable) names.
    time : str or None
        The time column among ``names``, read as seconds (:func:`_seconds`): date-times
        (a Parquet timestamp, ISO text in a CSV) become seconds from the first sample; a
        column named in another unit (:data:`TIME_SUFFIXES`) or holding Unix time
        (:data:`EPOCH_LIKE_S`) is refused, saying what to give instead.

    Returns
    -------
    dict
        Name -> 1-D float64 array; all of one length.

    Raises
    ------
    RecordError
        Unknown file type, unreadable file, no rows, a missing column or one that holds no
        numbers (:func:`not_numbers`: text, even text of numbers), a ``.mat`` variable that
        is not a vector, columns of different lengths, a NaN or infinity.
    """
    kind = FORMATS.get(path.suffix.lower())
    if kind is None:
        raise RecordError(f"{path}: unknown file type (use {', '.join(FORMATS)})")
    try:
        found = _available(path, kind)
        missing = [n for n in names if n not in found]
        if missing:
            have = ", ".join(list(found)[:20])
            raise RecordError(f"{path}: no column {', '.join(missing)} (it has: {have})")
        if kind == "parquet":
            import pyarrow.parquet as pq

            table = pq.read_table(path, columns=names)
            found = {n: table.column(n).to_numpy() for n in names}
        if names and all(np.size(found[n]) == 0 for n in names):
            raise RecordError(f"{path}: it holds no rows")
        out = {
            n: _seconds(path, n, found[n]) if n == time else _numbers(path, n, found[n])
            for n in names
        }
    except RecordError:
        raise
    except (OSError, ValueError, TypeError, NotImplementedError) as exc:
        reason = " ".join(str(exc).split()) or exc.__class__.__name__
        raise RecordError(f"{path}: cannot read it as {kind} ({reason})") from None
    return _checked(path, out)


def _numbers(path: Path, name: str, values: object) -> np.ndarray:
    """A column as floats; RecordError naming it when it does not hold numbers."""
    raw = np.asarray(values)
    held = not_numbers(raw)
    if held is not None:
        raise RecordError(f"{path}: column {name} holds {held}, not numbers")
    return raw.astype(float)


def _seconds(path: Path, name: str, values: object) -> np.ndarray:
    """A time column as seconds (see :func:`read_columns`'s ``time``); RecordError when it
    is not, with what to give instead."""
    raw = np.asarray(values)
    if raw.dtype.kind in "OSU":  # text: date-times, as a CSV holds them
        import pandas as pd

        try:
            raw = pd.DatetimeIndex(pd.to_datetime(pd.Series(raw), format="ISO8601")).as_unit("ns")
        except (ValueError, TypeError):
            raise RecordError(
                f"{path}: time column {name} holds neither numbers nor date-times"
            ) from None
        if raw.tz is not None:
            raw = raw.tz_convert(None)
        raw = raw.to_numpy()
    if raw.dtype.kind == "M":  # date-times: seconds from the first sample
        stamps = raw.astype("datetime64[ns]").reshape(-1)
        missing = np.flatnonzero(np.isnat(stamps))
        if missing.size:
            raise RecordError(f"{path}: time column {name} has no value at row {missing[0]}")
        ns = stamps.view(np.int64)
        return (ns - ns[0]).astype(float) * 1e-9 if ns.size else ns.astype(float)
    seconds = np.asarray(raw, dtype=float)
    instead = "give it in seconds from the record's start, or the sample step with --dt-s"
    for suffix, (unit, per_s) in TIME_SUFFIXES.items():
        if name.endswith(suffix):
            raise RecordError(
                f"{path}: time column {name} looks like {unit} (its name ends in {suffix}): "
                f"{instead} (seconds = {unit} / {per_s:g})"
            )
    first = seconds.reshape(-1)[:1]
    if first.size and np.isfinite(first[0]) and abs(first[0]) >= EPOCH_LIKE_S:
        raise RecordError(
            f"{path}: time column {name} looks like Unix time ({first[0]:.10g} s at the first "
            f"sample; a float's step jitters at that size): {instead}"
        )
    return seconds


def _checked(path: Path, columns: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    for name, col in columns.items():
        if col.ndim > 1 and sorted(col.shape)[:-1] == [1] * (col.ndim - 1):
            col = columns[name] = col.reshape(-1)
        if col.ndim != 1:
            raise RecordError(f"{path}: column {name} is not a vector (shape {col.shape})")
        bad = np.flatnonzero(~np.isfinite(col))
        if bad.size:
            raise RecordError(f"{path}: column {name} has NaN or infinity at row {bad[0]}")
    lengths = {c.size for c in columns.values()}
    if len(lengths) > 1:
        raise RecordError(f"{path}: columns of different lengths {sorted(lengths)}")
    return columns


def sample_step_s(time_s: np.ndarray, where: str) -> float:
    """The time step of a strictly increasing, uniform time column (s).

    The column is the grid of its own step (the median step) from its first row
    (:func:`probing.core.time_grid.off_grid`, to :data:`STEP_TOLERANCE` of the step).

    Raises
    ------
    RecordError
        Fewer than 2 samples, or the first row off that grid: a step that is not positive
        (not monotonic), a step other than the median (a gap), a time that has drifted off.
    """
    if time_s.size < 2:
        raise RecordError(f"{where}: fewer than 2 samples")
    typical = float(np.median(np.diff(time_s)))
    wrong = off_grid(time_s, typical, float(time_s[0]), rtol=STEP_TOLERANCE)
    if wrong is not None:
        raise RecordError(f"{where}: {wrong.reason}")
    return float((time_s[-1] - time_s[0]) / (time_s.size - 1))
