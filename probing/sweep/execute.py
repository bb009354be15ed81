"""Running a sweep: the local and Dask executors, the folder lock, resume.

Each run (a point, or a shared reference) is computed in a hidden temporary folder and
renamed into ``points/point_id=<id>/`` (``references/...``) when complete; a failed run is
recorded in ``failed/<id>.json`` and the sweep goes on (:mod:`probing.sweep.tasks`).  The
executor is opened *before* anything is written: an unreachable Dask scheduler leaves no
trace.
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import math
import os
import shutil
import signal
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from probing.core.errors import ArgumentError, ProbingError, choice, integer, number
from probing.core.forked import INTERRUPTS, STOPS
from probing.experiment.output.progress import progress_bar
from probing.experiment.output.storage import check_output_folder, write_json_atomic
from probing.experiment.scenario import Scenario
from probing.sweep.spec import POINT_FILE, Sweep, point_folder, sweep_folders
from probing.sweep.summary import summarise, write_summary
from probing.sweep.tasks import Task, execute_chunk, execute_task, import_task_code

__all__ = [
    "EXECUTORS",
    "SchedulerError",
    "SweepBusyError",
    "SweepResult",
    "execute_task",
    "run_sweep",
]

EXECUTORS = ("local", "dask")
LOCK_FILE = ".lock"


class SweepBusyError(ProbingError, RuntimeError):
    """Another sweep process holds the lock of the output folder."""


class SchedulerError(ProbingError, ValueError):
    """The Dask scheduler named by ``--scheduler`` cannot be reached (or the address is bad)."""


# ------------------------------------------------------------------ executors
class _Local:
    """A pool of forked worker processes on this machine."""

    def __init__(self, jobs: int) -> None:
        self.jobs = jobs

    def close(self) -> None:
        """Nothing to release between sweeps."""

    def run(self, chunks: list[list[Task]]) -> Iterator[list[dict[str, Any]]]:
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor, as_completed

        # Imported once here and inherited by the forked workers (pandas: pyarrow loads it on
        # its first table; the summary needs it anyway).
        import pandas  # noqa: F401
        import pyarrow.parquet  # noqa: F401

        import_task_code()
        ctx = mp.get_context("fork" if sys.platform.startswith("linux") else "spawn")
        workers = min(self.jobs, len(chunks))
        with (
            INTERRUPTS as interrupts,
            ProcessPoolExecutor(
                max_workers=workers, mp_context=ctx, initializer=_die_on_ctrl_c
            ) as pool,
        ):
            try:
                # The first submit forks the workers: Ctrl-C is held across it (the workers
                # inherit the block and lift it in _die_on_ctrl_c), else it could land in
                # the library's after-fork hooks, which print a traceback and drop it.
                with interrupts.forked():
                    futures = [pool.submit(execute_chunk, c) for c in chunks]
                for fut in as_completed(futures):
                    records = fut.result()
                    interrupts.check()  # a Ctrl-C that landed where Python drops it
                    yield records
            except BaseException:
                # The queued chunks are cancelled by the pool's own manager thread, which
                # also drops them from its work items.  Cancelling them from here raced
                # with that thread: when it found the workers dead (Ctrl-C ends them too)
                # it set BrokenProcessPool on every work item, a cancelled future among
                # them, and its InvalidStateError printed a thread's traceback.
                pool.shutdown(wait=False, cancel_futures=True)
                # A worker would finish its chunk, and the chunk queued behind it, before
                # the pool shut down: up to 2 x 64 runs after a Ctrl-C.  What they finished
                # is complete on disk; what they were running is left as .tmp-* folders,
                # removed by the next invocation, as after a kill.
                for proc in mp.active_children():
                    proc.kill()
                if interrupts.noted:  # the workers' deaths were the Ctrl-C's
                    raise KeyboardInterrupt from None
                raise


def _die_on_ctrl_c() -> None:
    """Initializer of the local workers: Ctrl-C (and SIGTERM) ends a worker at once, like
    the runs it forks.  Otherwise the pool would catch the KeyboardInterrupt (or the
    exception the command line turns SIGTERM into) in the middle of a chunk and go on with
    the next one queued."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOPS)  # held across the fork (run)


class _Dask:
    """Dask distributed: a LocalCluster of ``jobs`` single-threaded processes, or an existing
    scheduler.  Connects on construction, so a bad address fails before anything is written.
    """

    def __init__(self, jobs: int, scheduler: str | None, timeout_s: float) -> None:
        from distributed import Client, LocalCluster

        self.cluster = None
        if scheduler:
            try:
                self.client = Client(scheduler, timeout=f"{timeout_s}s")
            except (OSError, ValueError, TypeError) as exc:  # refused, timed out, bad address
                reason = str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__
                raise SchedulerError(
                    f"--scheduler {scheduler}: no Dask scheduler answered within "
                    f"{timeout_s:g} s ({reason})"
                ) from None
        else:
            # Port 0: the scheduler's HTTP server (the dashboard, whose link is printed) takes
            # a free port instead of warning that 8787 is busy.
            self.cluster = LocalCluster(
                n_workers=jobs,
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",
                silence_logs=logging.ERROR,
            )
            self.client = Client(self.cluster)
            print(f"Dask dashboard: {self.client.dashboard_link}", file=sys.stderr, flush=True)
        # Chunks are cut so every worker thread gets a part of a large group.
        workers = self.client.scheduler_info()["workers"].values()
        threads = sum(w.get("nthreads", 1) for w in workers)
        self.jobs = max(1, threads or jobs)

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    def run(self, chunks: list[list[Task]]) -> Iterator[list[dict[str, Any]]]:
        from distributed import as_completed

        futures = self.client.map(execute_chunk, chunks, pure=False)
        for fut in as_completed(futures):
            yield fut.result()


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

    def summary(self) -> Any:
        """``summary.parquet``, one row per point, as a pandas DataFrame."""
        from probing.sweep.summary import read_summary

        return read_summary(self.folder)

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
    """Hold the folder's lock file for the block; the file is removed on leaving it.

    The lock is taken without waiting.  Because the file is removed while it is held, a
    process that opened the old file and then got its lock would hold a lock nobody else
    sees: it checks that the file it locked is still the one at the path, else retries.
    """
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / LOCK_FILE
    while True:
        fh = open(path, "a")
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.close()
            raise SweepBusyError(f"{folder}: another sweep is running on this folder") from None
        try:
            same = os.path.samestat(os.fstat(fh.fileno()), os.stat(path))
        except FileNotFoundError:
            same = False
        if same:
            break
        fh.close()  # the file was removed under us: lock the new one
    try:
        yield
    finally:
        path.unlink(missing_ok=True)
        fcntl.flock(fh, fcntl.LOCK_UN)
        fh.close()


def open_executor(
    executor: str, jobs: int, scheduler: str | None = None, timeout_s: float = 10.0
) -> _Local | _Dask:
    """The executor of a sweep, connected (Dask) before the sweep writes anything.

    Raises
    ------
    probing.ArgumentError
        An executor that is none of :data:`EXECUTORS`, a scheduler without Dask.
    SchedulerError
        When ``scheduler`` does not answer within ``timeout_s``.
    """
    choice(executor, "executor", EXECUTORS)
    if scheduler and executor != "dask":
        raise ArgumentError("scheduler", "only with `executor` dask")
    return _Dask(jobs, scheduler, timeout_s) if executor == "dask" else _Local(jobs)


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
    connect_timeout_s: float = 10.0,
    lines: bool = True,
) -> SweepResult:
    """Run the missing runs of a sweep, then write ``<out>/<name>/summary.parquet``.

    Parameters
    ----------
    sweep : Sweep
        A validated sweep.
    out : path
        Results root; the sweep goes to ``out/<sweep.name>/``.
    jobs : int, optional
        Worker processes, >= 1 (default: one per core).  With ``executor="dask"`` and no
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
        Progress bar with ETA; default: when ``stream`` is a terminal.  Otherwise, with
        ``lines``, one line per finished run is written to ``stream``.
    stream : file, optional
        Where progress goes (default stderr).
    connect_timeout_s : float
        How long to wait for ``scheduler`` to answer, s (> 0).
    lines : bool
        Without a bar, one line per finished run (False: nothing).

    Returns
    -------
    SweepResult
        Counts of the runs done, skipped and failed.

    Raises
    ------
    probing.ArgumentError
        ``jobs``, ``executor``, ``scheduler`` or ``connect_timeout_s`` refused (checked
        before anything is written).
    OutputPathError
        ``out`` cannot be written (checked before anything is written).
    SweepBusyError
        When another process is running a sweep in the same folder.
    SchedulerError
        When the Dask scheduler cannot be reached; nothing is written then.
    CacheFolderError
        When the cache cannot be used by workers on this machine
        (:func:`probing.sim.cache.check_cache`); nothing is written then.
    """
    if scheduler is None:  # workers on this machine use its cache: one that cannot be used
        from probing.sim.cache import check_cache  # loads JSBSim: not when a sweep is read

        check_cache()  # is one error here, not an error per point
    jobs = (os.cpu_count() or 1) if jobs is None else integer(jobs, "jobs", lo=1)
    number(connect_timeout_s, "connect_timeout_s", lo=0, lo_open=True)
    check_output_folder(out, "out")
    check_output_folder(Path(out) / sweep.name, "out")
    t0 = time.perf_counter()
    sweep_dir = Path(out) / sweep.name
    points_dir, refs_dir, _ = sweep_folders(sweep_dir)
    result = SweepResult(folder=sweep_dir, points=len(sweep.points))
    pool = open_executor(executor, jobs, scheduler, connect_timeout_s)
    try:
        with _locked(sweep_dir):
            for d in (points_dir, refs_dir):
                d.mkdir(parents=True, exist_ok=True)
                for stale in d.glob(".tmp-*"):  # left by a killed run; we hold the lock
                    shutil.rmtree(stale, ignore_errors=True)
            write_json_atomic(sweep_dir / "sweep.json", _manifest(sweep))
            todo = _pending(sweep, sweep_dir, retry_failed, result)
            _execute(pool, todo, sweep.name, result, progress, stream, lines)
            write_summary(summarise(sweep, sweep_dir), sweep_dir / "summary.parquet", sweep)
    finally:
        pool.close()
    result.wall_s = time.perf_counter() - t0
    return result


def _pending(sweep: Sweep, sweep_dir: Path, retry_failed: bool, result: SweepResult) -> list:
    """The runs still to do, references first (they also fill the shared twin cache);
    counts the points already finished or recorded as failed into ``result``."""
    points_dir, refs_dir, failed_dir = sweep_folders(sweep_dir)
    tasks = [
        _task("reference", rid, scn, refs_dir, failed_dir)
        for rid, scn in sweep.references().items()
    ]
    monitor = sweep.kind == "monitor"
    tasks += [
        _task("point", p.point_id, p.scenario, points_dir, failed_dir, monitor)
        for p in sweep.points
    ]
    todo = []
    for t in tasks:
        if (Path(t.target) / POINT_FILE).exists():
            result.skipped += t.kind == "point"
        elif Path(t.failed_file).exists() and not retry_failed:
            result.failed += t.kind == "point"  # recorded by an earlier invocation
        else:
            todo.append(t)
    return todo


def _execute(
    pool: _Local | _Dask,
    todo: list[Task],
    name: str,
    result: SweepResult,
    progress: bool | None,
    stream: TextIO | None,
    lines: bool = True,
) -> None:
    """Run ``todo`` on the pool, counting into ``result`` and reporting each finished run
    (a bar, or with ``lines`` a line each)."""
    intro = f"{len(todo)} runs to do"
    if result.skipped or result.failed:
        intro += f"; {result.skipped} points already done, {result.failed} recorded as failed"
    if not todo:
        with progress_bar(0, name, "runs", stream, progress, lines=lines, intro=intro):
            return
    from probing.experiment.flight.batch import chunked_groups

    shares = [t.shares for t in todo]  # a study's references of one flight fly it once
    chunks = chunked_groups([t.scenario for t in todo], pool.jobs, shares=shares)
    workers = min(pool.jobs, len(chunks))  # the ETA: runs' wall time over the workers
    with progress_bar(
        len(todo), name, "runs", stream, progress, lines=lines, intro=intro, workers=workers
    ) as bar:
        failed = 0
        records = (r for c in pool.run([[todo[i] for i in c] for c in chunks]) for r in c)
        for rec in records:
            if rec["status"] in ("failed", "error"):
                failed += 1
                result.messages.append(f"{rec['kind']} {rec['run_id']}: {rec['message']}")
            if rec["kind"] == "point":
                counter = rec["status"] if rec["status"] != "error" else "errors"
                setattr(result, counter, getattr(result, counter) + 1)
            elif rec["status"] == "done":
                result.references += 1
            what = f"{rec['kind']} {rec['run_id']} {rec['status']}"
            if math.isfinite(rec["wall_s"]):
                what += f" in {rec['wall_s']:.1f} s"
            bar.advance(1, what, f"{failed} failed", wall_s=rec["wall_s"])


def _task(
    kind: str, run_id: str, scn: Scenario, base: Path, failed_dir: Path, monitor: bool = False
) -> Task:
    return Task(
        kind=kind,
        run_id=run_id,
        scenario=scn,
        target=str(point_folder(base, run_id)),
        failed_file=str(failed_dir / f"{run_id}.json"),
        monitor=monitor,
    )


def _manifest(sweep: Sweep) -> dict[str, Any]:
    return {
        "name": sweep.name,
        "kind": sweep.kind,
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
