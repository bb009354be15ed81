"""Tables printed for people: numbers rounded for reading, stored values left as computed."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

__all__ = ["fmt", "sweep_table"]

#: Summary columns shown after a sweep, in order.
SWEEP_COLUMNS = ("status", "predicted_gain", "measured_gain", "shape_error", "h_stderr")
#: ... after a monitor sweep.
MONITOR_COLUMNS = ("status", "fault_onset_s", "first_alarm_s", "verdict")


def fmt(value: Any, digits: int = 6) -> str:
    """A value for reading: floats to ``digits`` significant digits (``0.8750000000000001``
    prints as ``0.875``), NaN as ``-``, anything else as ``str``."""
    if isinstance(value, float):
        return "-" if math.isnan(value) else f"{value:.{digits}g}"
    return str(value)


def sweep_table(summary: Any, fields: Sequence[str], max_rows: int = 40) -> str:
    """The summary of a sweep as a plain-text table: index, the varied fields (short names),
    status, predicted and measured gain, shape error, standard error of h (a monitor sweep:
    fault onset, first alarm, verdict).

    Parameters
    ----------
    summary : pandas.DataFrame
        ``summary.parquet`` of the sweep.
    fields : sequence of str
        The varied fields (dotted keys), shown by their last part.
    max_rows : int
        Rows shown at most; a last line says how many more are in the file.
    """
    shown = MONITOR_COLUMNS if "first_alarm_s" in summary else SWEEP_COLUMNS
    columns = ["index", *fields, *shown]
    head = ["#", *(f.rsplit(".", 1)[-1] for f in fields), *shown]
    rows = [[fmt(r[c]) for c in columns] for r in summary.head(max_rows).to_dict("records")]
    widths = [max(len(x) for x in col) for col in zip(head, *rows, strict=True)]
    lines = [
        "  ".join(x.rjust(w) for x, w in zip(line, widths, strict=True)) for line in [head, *rows]
    ]
    if len(summary) > max_rows:
        lines.append(f"... {len(summary) - max_rows} more rows in summary.parquet")
    return "\n".join(lines)
