"""The summary of a sweep: one row per point, with units, and the points as one dataset.

``summary.parquet`` joins with the points' files (:func:`open_dataset`) on ``point_id`` and
``channel``: the summary's statistics describe that channel (the first output channel).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from probing.core.fixedorder import vdot
from probing.core.metrics import gain_and_shape, predicted_apparent
from probing.core.nonlinearities import RateLimit
from probing.core.tempfiles import remove_dead_writers_files, writer_tag
from probing.experiment.output.storage import (
    PER_DEG,
    Settled,
    metadata,
    provenance,
    read_settled,
    units,
)
from probing.experiment.scenario import Scenario
from probing.sweep.spec import POINT_FILE, Sweep, SweepPoint, point_folder, sweep_folders

__all__ = [
    "SUMMARY_COLUMNS",
    "open_dataset",
    "predictions",
    "read_summary",
    "settled_stats",
    "summarise",
    "write_summary",
]

#: Summary columns with a unit or a meaning worth stating: name -> (unit, description).  A
#: unit ``<channel>/deg`` is that of the row's ``channel`` per deg of probe.
SUMMARY_COLUMNS: dict[str, tuple[str, str]] = {
    "index": ("1", "position of the point in the sweep"),
    "point_id": ("", "digest of the point's scenario; join key with the points' files"),
    "status": ("", "done, failed (trim failure or divergence), error or missing"),
    "message": ("", "why the run failed"),
    "channel": ("", "the channel the statistics describe; join key with the points' files"),
    "predicted_gain": ("1", "a~/a of the nonlinearity, eq. (10)"),
    "predicted_offset_deg": ("deg", "b~ of the nonlinearity, eq. (10)"),
    "rate_ratio": ("1", "r_l / (2a/t0), eq. (21) (rate limits only)"),
    "measured_gain": ("1", "least-squares gain of the mean settled h_est on the reference's"),
    "shape_error": ("1", "||h - g h0|| / ||g h0||"),
    "h_rms": (PER_DEG, "RMS over taps of the mean settled h_est"),
    "h_stderr": (
        PER_DEG,
        "period-to-period spread of h_est / sqrt(P), RMS over taps (not the seed-to-seed error)",
    ),
    "h_stderr_naive": (PER_DEG, "sigma / (a sqrt(M P))"),
    "predicted_z_stderr": ("<channel>", "seed-to-seed std of the mean settled z, RMS over taps"),
    "predicted_h_stderr": (PER_DEG, "seed-to-seed std of the mean settled h_est, RMS over taps"),
    "predicted_gain_stderr": (
        "1",
        "seed-to-seed std of the least-squares gain on the point's own noise-free estimate "
        "(measured_gain's, on the reference's, is predicted_gain times it)",
    ),
    "predicted_h_bias": (PER_DEG, "the slow modes' transient in the settled h_est, RMS over taps"),
    "wall_s": ("s", "wall time of the point's run (its share of a flight it shared)"),
    "steps_simulated": (
        "1",
        "JSBSim steps the point's run simulated (a shared flight's aircraft: on its flown point)",
    ),
    "reference_id": ("", "point_id of the run without the nonlinearity"),
    # monitor sweeps (probing monitor's points)
    "fault_type": ("", "the point's [fault] type, none without one"),
    "fault_onset_s": ("s", "time after the trim when the fault appears (NaN without one)"),
    "drift": ("", "the point's reference (output.drift: oracle, gust, nominal, detrend, ...)"),
    "first_alarm_s": ("s", "end of the first alarmed period, after the trim (NaN: no alarm)"),
    "first_alarm_period": ("1", "the first alarmed period (-1: no alarm)"),
    "alarm_detector": ("", "the detector that alarmed first: probing, trajectory, or empty"),
    "first_probing_alarm_s": ("s", "the probing detector's first alarm (NaN: none)"),
    "first_trajectory_alarm_s": ("s", "the trajectory detector's first alarm (NaN: none)"),
    "verdict": ("", "the monitor's verdict: none, actuator or airframe"),
    "alpha_per_period": ("1", "false-alarm probability per period and channel"),
    "period_s": ("s", "probe period T = M t0"),
    "flight_s": ("s", "length of the flight as asked"),
    "ended": ("", "why a monitored flight ended early (a divergence), empty if it did not"),
}


def settled_stats(folder: Path, scn: Scenario, settled: Settled | None = None) -> dict[str, Any]:
    """Mean settled h_est and z of the first channel, h's period-to-period spread, the count.

    ``h_mean`` and ``z_mean`` are stored as lists of floats (exact in JSON); ``h_spread`` is
    the per-tap variance over the settled periods (ddof 1), RMS-averaged: sqrt(mean(var)).
    ``settled``: the run's own (``RunResult.settled``); None reads them from the folder's
    ``probing.parquet``.
    """
    channel = scn.channels[0]
    if settled is None:
        path = folder / "probing.parquet"
        settled = read_settled(path, channel, scn.settle_periods, scn.bits_per_period)
    h = settled.h
    n_p = int(h.shape[0])
    return {
        "channel": channel,
        "periods": n_p,
        "h_mean": h.mean(axis=0).tolist() if n_p else None,
        "z_mean": settled.z.mean(axis=0).tolist() if n_p else None,
        "h_spread": float(np.sqrt(np.mean(h.var(axis=0, ddof=1)))) if n_p > 1 else None,
    }


def predictions(scn: Scenario) -> dict[str, Any]:
    """The noise model's predictions for every channel
    (:func:`probing.experiment.design.noise.predict`):
    the four numbers and the expected steady-state h (a list), for point.json; a prediction
    that cannot be made (no linearised trim) is recorded as its error."""
    from probing.experiment.design.noise import predict  # the linearisation: JSBSim

    try:
        found = predict(scn)
    except Exception as exc:  # a point's prediction must not fail its run
        return {"error": f"{exc.__class__.__name__}: {exc}"}
    return {
        channel: {
            **p.to_dict(),
            "h_steady": None if p.h_steady is None else p.h_steady.tolist(),
        }
        for channel, p in found.items()
    }


def _number(value: Any) -> float:
    """A JSON number, or NaN for null (JSON has no NaN: the JSON writer stores null)."""
    return math.nan if value is None else float(value)


def _stats(folder: Path, scn: Scenario) -> dict[str, Any]:
    """The settled statistics of a finished run: from point.json, else from its Parquet."""
    info = json.loads((folder / POINT_FILE).read_text())
    return info.get("settled") or settled_stats(folder, scn)


def summarise(sweep: Sweep, sweep_dir: str | Path) -> Any:
    """One row per point (a pandas DataFrame) from the stored runs; see ``docs/sweeps.md``.

    Columns: ``index``, ``point_id``, the varied fields (dotted names), ``status``
    (``done``, ``failed``, ``error`` or ``missing``), ``message``, ``channel`` (the first
    output channel, which the figures describe), ``predicted_gain`` (a~/a),
    ``predicted_offset_deg`` (b~), ``rate_ratio`` (r / (2a/t0), rate limits only),
    ``measured_gain`` and ``shape_error`` (least-squares fit of the mean settled h_est on the
    reference's), ``h_rms``, ``h_stderr`` (the spread over the settled periods / sqrt(P), RMS
    over taps), ``h_stderr_naive`` (sigma / (a sqrt(M P))), the noise model's
    ``predicted_z_stderr``, ``predicted_h_stderr``, ``predicted_gain_stderr`` and
    ``predicted_h_bias`` (:mod:`probing.experiment.design.noise`), ``wall_s``,
    ``steps_simulated``, ``reference_id``.
    """
    import pandas as pd

    if sweep.kind == "monitor":
        return pd.DataFrame(_monitor_rows(sweep, Path(sweep_dir)))
    sweep_dir = Path(sweep_dir)
    points_dir, refs_dir, failed_dir = sweep_folders(sweep_dir)
    ref_cache: dict[str, np.ndarray | None] = {}

    def mean_h(run_id: str, scn: Scenario) -> np.ndarray | None:
        if run_id not in ref_cache:
            ref_cache[run_id] = None
            for base in (points_dir, refs_dir):
                folder = point_folder(base, run_id)
                if (folder / POINT_FILE).exists():
                    h = _stats(folder, scn)["h_mean"]
                    ref_cache[run_id] = None if h is None else np.asarray(h, dtype=float)
                    break
        return ref_cache[run_id]

    rows = []
    for p in sweep.points:
        row = _blank_row(sweep, p)
        folder = point_folder(points_dir, p.point_id)
        failed_file = failed_dir / f"{p.point_id}.json"
        if (folder / POINT_FILE).exists():
            _fill_done_row(row, folder, p, mean_h)
        elif failed_file.exists():
            info = json.loads(failed_file.read_text())
            row.update(status=info["status"], message=info["message"], wall_s=info["wall_s"])
        rows.append(row)
    return pd.DataFrame(rows)


def _blank_row(sweep: Sweep, p: SweepPoint) -> dict[str, Any]:
    """A point's row before its run is read: its values, predictions and ``missing``."""
    scn = p.scenario
    channel = scn.channels[0]
    nl = scn.build_nonlinearity()
    gain_pred, offset_pred = predicted_apparent(nl, scn.amplitude_deg, scn.bit_duration_s)
    row: dict[str, Any] = {"index": p.index, "point_id": p.point_id}
    row.update({k: p.values[k] for k in sweep.fields})
    row.update(
        status="missing",
        message="",
        channel=channel,
        predicted_gain=gain_pred,
        predicted_offset_deg=offset_pred,
        rate_ratio=(
            nl.ratio(scn.amplitude_deg, scn.bit_duration_s)
            if isinstance(nl, RateLimit)
            else math.nan
        ),
        measured_gain=math.nan,
        shape_error=math.nan,
        h_rms=math.nan,
        h_stderr=math.nan,
        h_stderr_naive=math.nan,
        predicted_z_stderr=math.nan,
        predicted_h_stderr=math.nan,
        predicted_gain_stderr=math.nan,
        predicted_h_bias=math.nan,
        wall_s=math.nan,
        steps_simulated=0,
        reference_id=p.reference_id,
    )
    return row


def _fill_done_row(
    row: dict[str, Any],
    folder: Path,
    p: SweepPoint,
    mean_h: Callable[[str, Scenario], np.ndarray | None],
) -> None:
    """Fill a finished point's row from its run folder (``mean_h`` gives a reference's h)."""
    scn = p.scenario
    channel = row["channel"]
    info = json.loads((folder / POINT_FILE).read_text())
    row.update(status="done", wall_s=info["wall_s"], steps_simulated=info["steps_simulated"])
    stats = _stats(folder, scn)
    predicted = info.get("predicted", {}).get(channel) or {}
    for key in ("z_stderr", "h_stderr", "gain_stderr", "h_bias"):
        row[f"predicted_{key}"] = _number(predicted.get(key))
    n_p, m = stats["periods"], scn.bits_per_period
    if n_p:
        h = np.asarray(stats["h_mean"], dtype=float)
        row["h_rms"] = float(np.sqrt(np.mean(h**2)))
        if stats["h_spread"] is not None:
            row["h_stderr"] = stats["h_spread"] / math.sqrt(n_p)
        sigma = scn.sensor_noise.get(channel, 0.0)
        row["h_stderr_naive"] = sigma / (scn.amplitude_deg * math.sqrt(m * n_p))
        h0 = h if p.is_own_reference else mean_h(p.reference_id, p.reference)
        if h0 is not None and vdot(h0, h0) > 0:
            row["measured_gain"], row["shape_error"] = gain_and_shape(h, h0)


def _monitor_rows(sweep: Sweep, sweep_dir: Path) -> list[dict[str, Any]]:
    """A monitor sweep's summary: per point its fault, drift and what the monitor found."""
    points_dir, _, failed_dir = sweep_folders(sweep_dir)
    rows = []
    for p in sweep.points:
        scn = p.scenario
        row: dict[str, Any] = {"index": p.index, "point_id": p.point_id}
        row.update({k: p.values[k] for k in sweep.fields})
        row.update(
            status="missing",
            message="",
            channel=scn.channels[0],
            fault_type=scn.fault_type,
            fault_onset_s=scn.fault_onset_s if scn.fault_type != "none" else math.nan,
            drift=scn.drift,
            first_alarm_s=math.nan,
            first_alarm_period=-1,
            alarm_detector="",
            first_probing_alarm_s=math.nan,
            first_trajectory_alarm_s=math.nan,
            verdict="",
            alpha_per_period=math.nan,
            period_s=scn.period_s,
            flight_s=scn.total_steps * scn.dt_s,
            ended="",
            wall_s=math.nan,
            steps_simulated=0,
        )
        folder = point_folder(points_dir, p.point_id)
        failed_file = failed_dir / f"{p.point_id}.json"
        if (folder / POINT_FILE).exists():
            info = json.loads((folder / POINT_FILE).read_text())
            found = info["monitor"]
            row.update(
                status="done",
                wall_s=info["wall_s"],
                steps_simulated=info["steps_simulated"],
                first_alarm_s=_number(found["first_alarm_s"]),
                first_alarm_period=-1
                if found["first_alarm_period"] is None
                else found["first_alarm_period"],
                alarm_detector=found.get("alarm_detector") or "",
                first_probing_alarm_s=_number(found.get("first_probing_alarm_s")),
                first_trajectory_alarm_s=_number(found.get("first_trajectory_alarm_s")),
                verdict=found["verdict"],
                alpha_per_period=_number(found["alpha_per_period"]),
                ended=found.get("ended") or "",
            )
        elif failed_file.exists():
            info = json.loads(failed_file.read_text())
            row.update(status=info["status"], message=info["message"], wall_s=info["wall_s"])
        rows.append(row)
    return rows


def write_summary(df: Any, path: Path, sweep: Sweep) -> None:
    """Write the summary atomically, with units and descriptions per column (field
    metadata), ``probing.units`` per channel, the sweep file and the versions."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=False)
    fields = []
    for f in table.schema:
        unit, text = SUMMARY_COLUMNS.get(f.name, ("", "a varied field of the sweep"))
        fields.append(f.with_metadata({"unit": unit, "description": text}))
    schema = pa.schema(fields, metadata=table.schema.metadata)
    channels = sorted(set(df["channel"])) if "channel" in df and len(df) else []
    meta = dict(schema.metadata or {})
    meta.update(
        provenance(sweep_toml=sweep.text, sweep=sweep.name, base_scenario=sweep.base.to_dict())
    )
    meta.update(
        metadata(
            description="one row per point of the sweep: predicted and measured gain, shape "
            "error, noise of the estimate, status",
            units=units(schema, channels),
        )
    )
    remove_dead_writers_files(path.parent, ".tmp")  # a killed sweep's half-written summary
    tmp = path.with_name(f".{path.name}.{writer_tag()}.tmp")
    pq.write_table(table.cast(schema).replace_schema_metadata(meta), tmp)
    os.replace(tmp, path)


def read_summary(sweep_dir: str | Path) -> Any:
    """``summary.parquet`` of a sweep folder as a pandas DataFrame."""
    import pandas as pd

    return pd.read_parquet(Path(sweep_dir) / "summary.parquet")


def open_dataset(sweep_dir: str | Path, table: str = "probing") -> Any:
    """The points' ``probing``, ``timeseries`` or ``monitor`` files as one pyarrow dataset.

    The Hive-style folder names add a ``point_id`` column to join with ``summary.parquet``
    (on ``point_id`` and ``channel`` for the ``probing`` files)::

        ds = open_dataset("results/sweeps/backlash-width")
        df = ds.to_table(filter=pyarrow.dataset.field("channel") == "theta_rad").to_pandas()
        joined = read_summary("results/sweeps/backlash-width").merge(
            df, on=["point_id", "channel"])
    """
    import pyarrow.dataset as pads

    if table not in ("probing", "timeseries", "monitor"):
        raise ValueError(f"table must be 'probing', 'timeseries' or 'monitor', got {table!r}")
    points_dir = Path(sweep_dir) / "points"
    files = sorted(str(f) for f in points_dir.glob(f"point_id=*/{table}.parquet"))
    return pads.dataset(
        files, format="parquet", partitioning="hive", partition_base_dir=str(points_dir)
    )
