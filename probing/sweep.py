"""Batch sweeps: one base scenario, a grid of changes, run in parallel and resumably.

A sweep file (``scenarios/sweeps/*.toml``, see ``docs/sweeps.md``)::

    name = "backlash-width"
    base = "../baseline-737.toml"          # relative to this file
    [fixed]                                # optional: changes applied to every point
    "probe.periods" = 6
    [grid]                                 # cartesian product of these lists
    "nonlinearity.type" = ["backlash"]
    "nonlinearity.width_deg" = [0.0, 0.0025, 0.005]
    [zip]                                  # optional: lists varied together (equal lengths)
    "probe.amplitude_deg" = [0.005, 0.01]
    "disturbance.sensor_noise.theta_rad" = [1e-5, 2e-5]

Keys are dotted scenario fields.  Every point is validated before anything runs.  A point is
identified by the digest of its fully resolved scenario (named after the sweep), and its
outputs (the files of ``probing run`` plus ``point.json``) appear atomically in
``<out>/<sweep>/points/point_id=<id>/`` (Hive-style, so the points form one dataset, see
:func:`open_dataset`).  The gain of each point is measured against the same scenario without
the nonlinearity, simulated once per distinct reference into ``references/point_id=<id>/``.
Finished runs are never redone or rewritten; a failed run (trim failure, divergence) is
recorded in ``failed/<id>.json`` and the sweep goes on.  ``summary.parquet`` has one row
per point.
"""

from __future__ import annotations

import contextlib
import fcntl
import itertools
import json
import math
import os
import shutil
import sys
import time
import uuid
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from probing.progress import ProgressBar
from probing.scenario import (
    _NAME_RE,
    _SECTIONS,
    Scenario,
    ScenarioError,
    _key,
    load_scenario,
    read_toml,
)
from probing.storage import write_json_atomic

__all__ = [
    "EXECUTORS",
    "Sweep",
    "SweepBusyError",
    "SweepPoint",
    "SweepResult",
    "load_sweep",
    "open_dataset",
    "parse_sweep",
    "read_summary",
    "run_sweep",
    "summarise",
]

EXECUTORS = ("local", "dask")
MAX_POINTS = 100_000
_TOP_KEYS = ("name", "base", "description", "fixed", "grid", "zip")
POINT_FILE = "point.json"


class SweepBusyError(RuntimeError):
    """Another sweep process holds the lock of the output folder."""


# ------------------------------------------------------------------ the sweep file
@dataclass(frozen=True)
class SweepPoint:
    """One point of a sweep.

    Attributes
    ----------
    index : int
        Position in the sweep (grid order, zip rows innermost).
    values : dict
        The varied fields (dotted keys) and their values at this point.
    scenario : Scenario
        The resolved scenario (named after the sweep).
    point_id : str
        ``scenario.digest()``: the point's identity and folder name.
    reference : Scenario
        The same scenario without the nonlinearity (the point itself when it has none).
    reference_id : str
        ``reference.digest()``.
    """

    index: int
    values: dict[str, Any]
    scenario: Scenario
    point_id: str
    reference: Scenario
    reference_id: str

    @property
    def is_own_reference(self) -> bool:
        """True when the point has no nonlinearity (its reference is itself)."""
        return self.point_id == self.reference_id


@dataclass(frozen=True)
class Sweep:
    """A validated sweep: its base scenario and every point."""

    name: str
    source: str
    text: str
    base: Scenario
    fields: tuple[str, ...]
    points: tuple[SweepPoint, ...]
    description: str = ""

    def references(self) -> dict[str, Scenario]:
        """Distinct reference scenarios that are not themselves points, by id."""
        ids = {p.point_id for p in self.points}
        return {p.reference_id: p.reference for p in self.points if p.reference_id not in ids}


def _check_key(table: str, key: str, source: str) -> None:
    parts = key.split(".")
    label = _label(table, key)
    sections = [s for s, allowed in _SECTIONS.items() if allowed is not None]
    if len(parts) < 2 or parts[0] not in sections or not all(parts):
        raise ScenarioError(
            label,
            f"not a dotted scenario field (section.field, sections: {', '.join(sections)})",
            source,
        )
    nested = parts[:2] == ["disturbance", "sensor_noise"] and len(parts) == 3
    if len(parts) > 2 and not nested:
        raise ScenarioError(label, "too many dots: a scenario field is section.field", source)


def _label(table: str, key: str) -> str:
    """``grid["probe.order"]``; keys that could break the one-line message are repr'd."""
    return f'{table}["{key}"]' if key.isprintable() else f"{table}[{key!r}]"


def parse_sweep(data: dict[str, Any], *, path: str | Path, text: str = "") -> Sweep:
    """Validate a parsed sweep file and resolve every point.

    Parameters
    ----------
    data : dict
        The parsed TOML.
    path : path
        The sweep file (``base`` is relative to its folder; also the error prefix).
    text : str
        The file text, kept for provenance.

    Raises
    ------
    ScenarioError
        For the first problem: an unknown key, an empty or mismatched list, a bad base, or a
        point that is not a valid scenario (the message names the point).
    """
    path = Path(path)
    source = str(path)
    for key in data:
        if key not in _TOP_KEYS:
            raise ScenarioError(
                _key(key), f"unknown field; allowed: {', '.join(_TOP_KEYS)}", source
            )
    name = data.get("name")
    if name is None:
        raise ScenarioError(
            "name", "missing (a plain file name, also the output folder name)", source
        )
    if not isinstance(name, str) or not _NAME_RE.match(name) or name in (".", ".."):
        raise ScenarioError(
            "name",
            f"must be a plain file name (letters, digits, '.', '_', '-'), got {name!r}",
            source,
        )
    description = data.get("description", "")
    if not isinstance(description, str):
        raise ScenarioError("description", "must be a string", source)
    base_rel = data.get("base")
    if not isinstance(base_rel, str) or not base_rel:
        raise ScenarioError("base", "missing: a scenario file, relative to the sweep file", source)
    base_path = path.parent / base_rel
    try:
        base = load_scenario(base_path)
    except ScenarioError as exc:
        raise ScenarioError("base", f"{base_rel}: {exc.field}: {exc.message}", source) from None

    tables: dict[str, dict[str, Any]] = {}
    for table in ("fixed", "grid", "zip"):
        value = data.get(table, {})
        if not isinstance(value, dict):
            raise ScenarioError(table, 'must be a table of "section.field" = value(s)', source)
        for key in value:
            _check_key(table, key, source)
        tables[table] = value
    seen: dict[str, str] = {}
    for table, entries in tables.items():
        for key in entries:
            if key in seen:
                raise ScenarioError(_label(table, key), f"already given in [{seen[key]}]", source)
            seen[key] = table
    for table in ("grid", "zip"):
        for key, values in tables[table].items():
            if not isinstance(values, list) or not values:
                raise ScenarioError(
                    _label(table, key), "must be a non-empty list of values", source
                )
    zip_lengths = {len(v) for v in tables["zip"].values()}
    if len(zip_lengths) > 1:
        lengths = ", ".join(f"{k}: {len(v)}" for k, v in tables["zip"].items())
        raise ScenarioError("zip", f"lists must have equal lengths, got {lengths}", source)
    if not tables["grid"] and not tables["zip"]:
        raise ScenarioError(
            "grid", "a sweep needs at least one varied field in [grid] or [zip]", source
        )

    grid_keys = list(tables["grid"])
    zip_keys = list(tables["zip"])
    n_zip = zip_lengths.pop() if zip_keys else 1
    n_points = math.prod(len(v) for v in tables["grid"].values()) * n_zip
    if n_points > MAX_POINTS:
        raise ScenarioError("grid", f"{n_points} points; at most {MAX_POINTS} allowed", source)

    combos = itertools.product(*(tables["grid"][k] for k in grid_keys))
    points: list[SweepPoint] = []
    by_id: dict[str, int] = {}
    for index, (combo, row) in enumerate(itertools.product(combos, range(n_zip))):
        values = dict(zip(grid_keys, combo, strict=True))
        values.update({k: tables["zip"][k][row] for k in zip_keys})
        changes = {**tables["fixed"], **values, "name": name}
        try:
            scn = base.replace(changes)
        except ScenarioError as exc:
            where = ", ".join(f"{k}={v!r}" for k, v in values.items())
            table = seen.get(exc.field)
            label = _label(table, exc.field) if table else exc.field
            raise ScenarioError(label, f"{exc.message} (point {index}: {where})", source) from None
        pid = scn.digest()
        if pid in by_id:
            raise ScenarioError(
                "grid",
                f"points {by_id[pid]} and {index} are the same scenario (repeated value?)",
                source,
            )
        by_id[pid] = index
        ref = scn if scn.nonlinearity == "none" else scn.replace({"nonlinearity.type": "none"})
        points.append(SweepPoint(index, values, scn, pid, ref, ref.digest()))
    return Sweep(
        name=name,
        source=source,
        text=text,
        base=base,
        fields=tuple(grid_keys + zip_keys),
        points=tuple(points),
        description=description,
    )


def load_sweep(path: str | Path) -> Sweep:
    """Read and validate a sweep file (see the module docstring).

    Raises
    ------
    ScenarioError
        With the file name, the field and what is allowed.
    """
    path = Path(path)
    data, text = read_toml(path)
    return parse_sweep(data, path=path, text=text)


# ------------------------------------------------------------------ running one task
@dataclass(frozen=True)
class _Task:
    kind: str  # "point" | "reference"
    run_id: str
    scenario: Scenario
    target: str  # final folder
    failed_file: str


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Send file descriptor 1 to /dev/null (C++ output included) for the duration."""
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def execute_task(task: _Task) -> dict[str, Any]:
    """Run one point or reference into its folder, atomically; never raises for a failed run.

    Returns a record: ``kind``, ``run_id``, ``status`` (``done``, ``failed`` for a trim
    failure or divergence, ``error`` for anything unexpected, ``skipped`` when the folder
    already existed), ``message``, ``wall_s``.
    """
    from probing.plant import DivergenceError, TrimError
    from probing.run import run_scenario

    final = Path(task.target)
    record: dict[str, Any] = {"kind": task.kind, "run_id": task.run_id, "message": ""}
    if (final / POINT_FILE).exists():
        return {**record, "status": "skipped", "wall_s": math.nan}
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = final.parent / f".tmp-{final.name}-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    t0 = time.perf_counter()
    try:
        with _quiet_stdout():  # JSBSim's trim prints to C++ std::cout; the message is kept
            result = run_scenario(task.scenario, final.parent, progress=False, folder=tmp)
    except (TrimError, DivergenceError) as exc:
        status, message = "failed", str(exc)
    except Exception as exc:  # recorded, reported, and the sweep goes on
        status, message = "error", f"{exc.__class__.__name__}: {exc}"
    else:
        wall = time.perf_counter() - t0
        info = {
            "kind": task.kind,
            "point_id": task.run_id,
            "status": "done",
            "wall_s": wall,
            "steps_simulated": result.steps_simulated,
            "scenario": task.scenario.to_dict(),
            # Statistics of the first channel, computed here, in parallel, for the summary.
            "settled": _settled_stats(tmp, task.scenario),
        }
        write_json_atomic(tmp / POINT_FILE, info)
        try:
            os.rename(tmp, final)
        except OSError:  # another worker finished the same run first: keep theirs
            shutil.rmtree(tmp, ignore_errors=True)
        Path(task.failed_file).unlink(missing_ok=True)
        return {**record, "status": "done", "wall_s": wall}
    shutil.rmtree(tmp, ignore_errors=True)
    wall = time.perf_counter() - t0
    write_json_atomic(
        Path(task.failed_file),
        {
            "kind": task.kind,
            "point_id": task.run_id,
            "status": status,
            "message": message,
            "wall_s": wall,
        },
    )
    return {**record, "status": status, "message": message, "wall_s": wall}


# ------------------------------------------------------------------ executors
def _run_local(tasks: list[_Task], jobs: int) -> Iterator[dict[str, Any]]:
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    # Imported once here and inherited by the forked workers (pandas: pyarrow loads it on its
    # first table; the summary needs it anyway).
    import pandas  # noqa: F401
    import pyarrow.parquet  # noqa: F401

    import probing.run  # noqa: F401

    ctx = mp.get_context("fork" if sys.platform.startswith("linux") else "spawn")
    with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
        futures = [pool.submit(execute_task, t) for t in tasks]
        try:
            for fut in as_completed(futures):
                yield fut.result()
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise


def _run_dask(tasks: list[_Task], jobs: int, scheduler: str | None) -> Iterator[dict[str, Any]]:
    import logging

    from distributed import Client, LocalCluster, as_completed

    cluster = None
    if scheduler:
        client = Client(scheduler, timeout="20s")
    else:
        cluster = LocalCluster(
            n_workers=jobs,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )
        client = Client(cluster)
    try:
        futures = client.map(execute_task, tasks, pure=False)
        for fut in as_completed(futures):
            yield fut.result()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


# ------------------------------------------------------------------ orchestration
@dataclass
class SweepResult:
    """What a sweep invocation did."""

    folder: Path
    points: int
    done: int = 0  # computed in this invocation
    skipped: int = 0  # already finished before
    failed: int = 0  # trim failure or divergence (recorded)
    errors: int = 0  # unexpected exceptions (recorded)
    references: int = 0  # reference runs computed in this invocation
    wall_s: float = 0.0
    messages: list[str] = field(default_factory=list)

    def line(self) -> str:
        """The one-line summary printed at the end of a sweep."""
        parts = [
            f"{self.done} done",
            f"{self.skipped} skipped (already done)",
            f"{self.failed} failed",
        ]
        if self.errors:
            parts.append(f"{self.errors} errors")
        return (
            f"{self.folder.name}: {self.points} points: {', '.join(parts)}; "
            f"{self.references} reference runs; {self.wall_s:.1f} s -> "
            f"{self.folder / 'summary.parquet'}"
        )


@contextlib.contextmanager
def _locked(folder: Path) -> Iterator[None]:
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / ".lock", "w") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise SweepBusyError(f"{folder}: another sweep is running on this folder") from None
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _folders(sweep_dir: Path) -> tuple[Path, Path, Path]:
    return sweep_dir / "points", sweep_dir / "references", sweep_dir / "failed"


def _run_folder(base: Path, run_id: str) -> Path:
    return base / f"point_id={run_id}"


def run_sweep(
    sweep: Sweep,
    out: str | Path,
    *,
    jobs: int | None = None,
    executor: str = "local",
    scheduler: str | None = None,
    retry_failed: bool = False,
    progress: bool | None = None,
    stream: TextIO | None = None,
) -> SweepResult:
    """Run the missing runs of a sweep, then write ``<out>/<name>/summary.parquet``.

    Parameters
    ----------
    sweep : Sweep
        A validated sweep.
    out : path
        Results root; the sweep goes to ``out/<sweep.name>/``.
    jobs : int, optional
        Worker processes (default: one per core).  With ``executor="dask"`` and no
        ``scheduler``, the LocalCluster's worker count.
    executor : {"local", "dask"}
        A local process pool, or Dask distributed.
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:8786``); the workers must see
        ``out`` on a shared file system and have this package installed.
    retry_failed : bool
        Run again the points recorded as failed (a trim failure is deterministic, so by
        default they are kept as failed).
    progress : bool, optional
        Progress bar with ETA; default: when ``stream`` is a terminal.
    stream : file, optional
        Where the progress bar goes (default stderr).

    Returns
    -------
    SweepResult
        Counts of the runs done, skipped and failed.

    Raises
    ------
    SweepBusyError
        When another process is running a sweep in the same folder.
    """
    if executor not in EXECUTORS:
        raise ValueError(f"executor must be one of {', '.join(EXECUTORS)}, got {executor!r}")
    jobs = jobs or os.cpu_count() or 1
    t0 = time.perf_counter()
    sweep_dir = Path(out) / sweep.name
    points_dir, refs_dir, failed_dir = _folders(sweep_dir)
    result = SweepResult(folder=sweep_dir, points=len(sweep.points))
    with _locked(sweep_dir):
        for d in (points_dir, refs_dir):
            d.mkdir(parents=True, exist_ok=True)
            for stale in d.glob(".tmp-*"):  # left by a killed run; we hold the lock
                shutil.rmtree(stale, ignore_errors=True)
        write_json_atomic(sweep_dir / "sweep.json", _manifest(sweep))

        tasks: list[_Task] = []
        # References first: they also fill the shared reference-twin cache.
        for rid, scn in sweep.references().items():
            tasks.append(_task("reference", rid, scn, refs_dir, failed_dir))
        for p in sweep.points:
            tasks.append(_task("point", p.point_id, p.scenario, points_dir, failed_dir))
        todo = []
        for t in tasks:
            if (Path(t.target) / POINT_FILE).exists():
                result.skipped += t.kind == "point"
            elif Path(t.failed_file).exists() and not retry_failed:
                result.failed += t.kind == "point"  # recorded by an earlier invocation
            else:
                todo.append(t)

        bar = ProgressBar(len(todo), sweep.name, "runs", stream, progress)
        bar.update(0)
        if todo:
            runner = (
                _run_dask(todo, jobs, scheduler)
                if executor == "dask"
                else _run_local(todo, min(jobs, len(todo)))
            )
            finished = failed = 0
            for rec in runner:
                finished += 1
                if rec["status"] in ("failed", "error"):
                    failed += 1
                    result.messages.append(f"{rec['kind']} {rec['run_id']}: {rec['message']}")
                if rec["kind"] == "point":
                    counter = rec["status"] if rec["status"] != "error" else "errors"
                    setattr(result, counter, getattr(result, counter) + 1)
                elif rec["status"] == "done":
                    result.references += 1
                bar.update(finished, f"{failed} failed")
        summary = summarise(sweep, sweep_dir)
        _write_parquet_atomic(summary, sweep_dir / "summary.parquet", sweep)
    result.wall_s = time.perf_counter() - t0
    return result


def _task(kind: str, run_id: str, scn: Scenario, base: Path, failed_dir: Path) -> _Task:
    return _Task(
        kind=kind,
        run_id=run_id,
        scenario=scn,
        target=str(_run_folder(base, run_id)),
        failed_file=str(failed_dir / f"{run_id}.json"),
    )


def _manifest(sweep: Sweep) -> dict[str, Any]:
    return {
        "name": sweep.name,
        "source": sweep.source,
        "sweep_toml": sweep.text,
        "base": sweep.base.to_dict(),
        "fields": list(sweep.fields),
        "points": [
            {
                "index": p.index,
                "point_id": p.point_id,
                "reference_id": p.reference_id,
                "values": p.values,
            }
            for p in sweep.points
        ],
    }


# ------------------------------------------------------------------ summary
def _settled_h(folder: Path, scn: Scenario, channel: str) -> np.ndarray:
    """Per-period h_est of one channel over the settled periods, shape (P, M)."""
    import pyarrow.parquet as pq

    table = pq.read_table(
        folder / "probing.parquet",
        columns=["period", "tap", "h_est"],
        filters=[("channel", "==", channel), ("period", ">=", scn.settle_periods)],
    )
    order = np.lexsort((table.column("tap").to_numpy(), table.column("period").to_numpy()))
    m = scn.bits_per_period
    h = table.column("h_est").to_numpy()[order].reshape(-1, m)
    return h[np.all(np.isfinite(h), axis=1)]


def _settled_stats(folder: Path, scn: Scenario) -> dict[str, Any]:
    """Mean settled h_est of the first channel, its period-to-period spread, period count.

    ``h_mean`` is stored as a list of floats (exact in JSON); ``h_var`` is the per-tap
    variance over the settled periods (ddof 1), RMS-averaged: sqrt(mean(var)).
    """
    h = _settled_h(folder, scn, scn.channels[0])
    n_p = int(h.shape[0])
    return {
        "channel": scn.channels[0],
        "periods": n_p,
        "h_mean": h.mean(axis=0).tolist() if n_p else None,
        "h_spread": float(np.sqrt(np.mean(h.var(axis=0, ddof=1)))) if n_p > 1 else None,
    }


def _stats(folder: Path, scn: Scenario) -> dict[str, Any]:
    """The settled statistics of a finished run: from point.json, else from its Parquet."""
    info = json.loads((folder / POINT_FILE).read_text())
    return info.get("settled") or _settled_stats(folder, scn)


def summarise(sweep: Sweep, sweep_dir: str | Path) -> Any:
    """One row per point (a pandas DataFrame) from the stored runs; see ``docs/sweeps.md``.

    Columns: ``index``, ``point_id``, the varied fields (dotted names), ``status``
    (``done``, ``failed``, ``error`` or ``missing``), ``message``, ``channel`` (the first
    output channel, which the figures describe), ``predicted_gain`` (a~/a),
    ``predicted_offset_deg`` (b~), ``rate_ratio`` (r / (2a/t0), rate limits only),
    ``measured_gain`` and ``shape_error`` (least-squares fit of the mean settled h_est on the
    reference's), ``h_rms``, ``h_stderr`` (standard error of the mean h_est from the spread
    over the settled periods, RMS over taps), ``h_stderr_naive`` (sigma / (a sqrt(M P))),
    ``h_stderr_theory`` (closed form of the eq. 9 estimator, :func:`estimator_noise_std`),
    ``wall_s``, ``steps_simulated``, ``reference_id``.
    """
    import pandas as pd

    from probing.metrics import estimator_noise_std, gain_and_shape, predicted_apparent
    from probing.prbs import mls
    from probing.run import build_nonlinearity

    sweep_dir = Path(sweep_dir)
    points_dir, refs_dir, failed_dir = _folders(sweep_dir)
    ref_cache: dict[str, np.ndarray | None] = {}
    unit_noise: dict[int, float] = {}  # RMS over taps of the noise std for sigma = a = 1

    def mean_h(run_id: str, scn: Scenario) -> np.ndarray | None:
        if run_id not in ref_cache:
            ref_cache[run_id] = None
            for base in (points_dir, refs_dir):
                folder = _run_folder(base, run_id)
                if (folder / POINT_FILE).exists():
                    h = _stats(folder, scn)["h_mean"]
                    ref_cache[run_id] = None if h is None else np.asarray(h, dtype=float)
                    break
        return ref_cache[run_id]

    rows = []
    for p in sweep.points:
        scn = p.scenario
        channel = scn.channels[0]
        nl = build_nonlinearity(scn)
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
                scn.nl_params["rate_deg_s"] / (2 * scn.amplitude_deg / scn.bit_duration_s)
                if scn.nonlinearity == "rate_limit"
                else math.nan
            ),
            measured_gain=math.nan,
            shape_error=math.nan,
            h_rms=math.nan,
            h_stderr=math.nan,
            h_stderr_naive=math.nan,
            h_stderr_theory=math.nan,
            wall_s=math.nan,
            steps_simulated=0,
            reference_id=p.reference_id,
        )
        folder = _run_folder(points_dir, p.point_id)
        failed_file = failed_dir / f"{p.point_id}.json"
        if (folder / POINT_FILE).exists():
            info = json.loads((folder / POINT_FILE).read_text())
            row.update(
                status="done", wall_s=info["wall_s"], steps_simulated=info["steps_simulated"]
            )
            stats = _stats(folder, scn)
            n_p, m = stats["periods"], scn.bits_per_period
            if n_p:
                h = np.asarray(stats["h_mean"], dtype=float)
                row["h_rms"] = float(np.sqrt(np.mean(h**2)))
                if stats["h_spread"] is not None:
                    row["h_stderr"] = stats["h_spread"] / math.sqrt(n_p)
                sigma = scn.sensor_noise.get(channel, 0.0)
                row["h_stderr_naive"] = sigma / (scn.amplitude_deg * math.sqrt(m * n_p))
                # The closed form is linear in sigma / a: one O(M^2) evaluation per order.
                if scn.order not in unit_noise:
                    unit = estimator_noise_std(mls(scn.order), 1.0, 1.0)
                    unit_noise[scn.order] = float(np.sqrt(np.mean(unit**2)))
                row["h_stderr_theory"] = (
                    sigma / scn.amplitude_deg * unit_noise[scn.order] / math.sqrt(n_p)
                )
                h0 = h if p.is_own_reference else mean_h(p.reference_id, p.reference)
                if h0 is not None and np.dot(h0, h0) > 0:
                    row["measured_gain"], row["shape_error"] = gain_and_shape(h, h0)
        elif failed_file.exists():
            info = json.loads(failed_file.read_text())
            row.update(status=info["status"], message=info["message"], wall_s=info["wall_s"])
        rows.append(row)
    return pd.DataFrame(rows)


def _write_parquet_atomic(df: Any, path: Path, sweep: Sweep) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from probing.storage import provenance

    table = pa.Table.from_pandas(df, preserve_index=False)
    meta = dict(table.schema.metadata or {})
    meta.update(
        provenance(sweep_toml=sweep.text, sweep=sweep.name, base_scenario=sweep.base.to_dict())
    )
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    pq.write_table(table.replace_schema_metadata(meta), tmp)
    os.replace(tmp, path)


def read_summary(sweep_dir: str | Path) -> Any:
    """``summary.parquet`` of a sweep folder as a pandas DataFrame."""
    import pandas as pd

    return pd.read_parquet(Path(sweep_dir) / "summary.parquet")


def open_dataset(sweep_dir: str | Path, table: str = "probing") -> Any:
    """The points' ``probing`` or ``timeseries`` files as one pyarrow dataset.

    The Hive-style folder names add a ``point_id`` column to join with ``summary.parquet``::

        ds = open_dataset("results/sweeps/backlash-width")
        df = ds.to_table(filter=pyarrow.dataset.field("channel") == "theta_rad").to_pandas()
    """
    import pyarrow.dataset as pads

    if table not in ("probing", "timeseries"):
        raise ValueError(f"table must be 'probing' or 'timeseries', got {table!r}")
    points_dir = Path(sweep_dir) / "points"
    files = sorted(str(f) for f in points_dir.glob(f"point_id=*/{table}.parquet"))
    return pads.dataset(
        files, format="parquet", partitioning="hive", partition_base_dir=str(points_dir)
    )
