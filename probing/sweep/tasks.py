"""Running a sweep's runs: a task per point or reference, a flight per task or per family of
tasks, a chunk of flights per worker.

Each run is computed in a hidden temporary folder and renamed into
``points/point_id=<id>/`` (``references/...``) when complete; a failed run is recorded in
``failed/<id>.json``.  The monitored points of a sweep that differ only in their reference
(``output.drift``: a study's ``gust``, ``detrend`` and ``oracle`` of one seed, fault and
amplitude) fly the aircraft once: the first flies, the others read its flight with their own
flight computers (:class:`probing.experiment.flight.run.Companion`), and each point's files are
those it would have had flown alone (``tests/sweep/test_flight_families.py``).
"""

from __future__ import annotations

import math
import os
import shutil
import time
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from probing.experiment.output.storage import write_json_atomic
from probing.experiment.scenario import Scenario
from probing.sweep.spec import POINT_FILE
from probing.sweep.summary import predictions, settled_stats

if TYPE_CHECKING:  # the sim layer loads JSBSim: only where runs are executed
    from probing.sim.fork import TrimmedAircraft

__all__ = ["Task", "execute_chunk", "execute_flight", "execute_task", "import_task_code"]


@dataclass(frozen=True)
class Task:
    """One run of a sweep: a point or a shared reference, and where it goes."""

    kind: str  # "point" | "reference"
    run_id: str
    scenario: Scenario
    target: str  # final folder
    failed_file: str
    monitor: bool = False  # a monitored flight (probing monitor) instead of a run

    @property
    def shares(self) -> bool:
        """True if it may share its flight with the points that differ only in their
        reference (a monitored point)."""
        return self.monitor and self.kind == "point"


def execute_task(task: Task, aircraft: TrimmedAircraft | None = None) -> dict[str, Any]:
    """Run one point or reference into its folder (:func:`execute_flight` of one task)."""
    return execute_flight([task], aircraft)[0]


def execute_flight(
    tasks: list[Task], aircraft: TrimmedAircraft | None = None
) -> list[dict[str, Any]]:
    """Run tasks that are one flight (one task, or monitored points that differ only in their
    reference) into their folders, atomically; never raises for a failed run.

    ``aircraft``: the trimmed aircraft of the tasks' chunk, in a child forked from its owner
    (:func:`execute_chunk`); None loads and trims.  Returns a record per task: ``kind``,
    ``run_id``, ``status`` (``done``, ``failed`` for a trim failure or divergence, ``error``
    for anything unexpected, ``skipped`` when the folder already existed), ``message``,
    ``wall_s`` (its share of the flight's wall time: the flight's over its tasks).
    """
    from probing.sim.errors import DivergenceError, TrimError

    records = {t.run_id: {"kind": t.kind, "run_id": t.run_id, "message": ""} for t in tasks}
    todo = [t for t in tasks if not (Path(t.target) / POINT_FILE).exists()]
    for t in tasks:
        if t not in todo:
            records[t.run_id].update(status="skipped", wall_s=math.nan)
    if not todo:
        return list(records.values())
    tmps = []
    for t in todo:
        final = Path(t.target)
        final.parent.mkdir(parents=True, exist_ok=True)
        tmps.append(final.parent / f".tmp-{final.name}-{os.getpid()}-{uuid.uuid4().hex[:8]}")
    t0 = time.perf_counter()
    flown = None
    try:
        flown = _fly(todo, tmps, aircraft)
    except (TrimError, DivergenceError) as exc:
        status, message = "failed", str(exc)
    except Exception as exc:  # recorded, reported, and the sweep goes on
        status, message = "error", f"{exc.__class__.__name__}: {exc}"
    wall = (time.perf_counter() - t0) / len(todo)  # each task's share of the flight's
    if flown is not None:
        for t, tmp, (result, monitored) in zip(todo, tmps, flown, strict=True):
            _store_done(t, tmp, result, monitored, wall)
            records[t.run_id].update(status="done", wall_s=wall)
        return list(records.values())
    for t, tmp in zip(todo, tmps, strict=True):
        shutil.rmtree(tmp, ignore_errors=True)
        failed = {"kind": t.kind, "point_id": t.run_id, "status": status, "message": message}
        write_json_atomic(Path(t.failed_file), {**failed, "wall_s": wall})
        records[t.run_id].update(status=status, message=message, wall_s=wall)
    return list(records.values())


def _fly(
    tasks: list[Task], tmps: list[Path], aircraft: TrimmedAircraft | None
) -> list[tuple[Any, Any]]:
    """Fly the tasks' flight into ``tmps``: each task's run result, and its monitor's (or
    None)."""
    from probing.experiment.flight.monitor import monitor_flight
    from probing.experiment.flight.run import run_scenario

    if tasks[0].monitor:
        scenarios = [t.scenario for t in tasks]
        return [(m.run, m) for m in monitor_flight(scenarios, tmps, aircraft=aircraft)]
    (task,), (tmp,) = tasks, tmps
    result = run_scenario(
        task.scenario,
        tmp.parent,
        progress=False,
        folder=tmp,
        aircraft=aircraft,
        keep_settled=True,
    )
    return [(result, None)]


def _store_done(task: Task, tmp: Path, result: Any, monitored: Any, wall: float) -> None:
    """Write a finished run's ``point.json``, move its folder into place, clear its failure."""
    info = {
        "kind": task.kind,
        "point_id": task.run_id,
        "status": "done",
        "wall_s": wall,
        "steps_simulated": result.steps_simulated,
        "scenario": task.scenario.to_dict(),
    }
    if monitored is not None:
        info["monitor"] = monitored.facts()
    else:
        # Statistics of the first channel, computed here, in parallel, for the summary.
        info["settled"] = settled_stats(tmp, task.scenario, result.settled)
        info["predicted"] = predictions(task.scenario) if task.kind == "point" else {}
    write_json_atomic(tmp / POINT_FILE, info, compact=True)
    try:
        os.rename(tmp, task.target)
    except OSError:  # another worker finished the same run first: keep theirs
        shutil.rmtree(tmp, ignore_errors=True)
    Path(task.failed_file).unlink(missing_ok=True)


def execute_chunk(tasks: list[Task]) -> list[dict[str, Any]]:
    """Run tasks that share one trimmed state: one load and trim, one forked child per flight
    (:func:`probing.experiment.flight.batch.flight_families`).

    The records of :func:`execute_flight`.  A child that ended without records (killed)
    gives an ``error`` record per task and no ``failed/`` file, so its runs are tried again
    by the next invocation.
    """
    from probing.experiment.flight.batch import flight_families, run_grouped

    import_task_code()

    records: list[dict[str, Any]] = []
    todo = []
    for task in tasks:
        if (Path(task.target) / POINT_FILE).exists():  # another worker finished it: no fork
            records.append(execute_task(task))
        else:
            todo.append(task)
    families = flight_families([t.scenario for t in todo], [t.shares for t in todo])
    flights = [[todo[i] for i in f] for f in families]
    outcomes = run_grouped(
        flights,
        _scenario_of,
        execute_flight,
        prepare=_shared_predictions,
        others=_companions_of,
    )
    for i, outcome in outcomes:
        if outcome.error is None:
            records += outcome.value
            continue
        message = f"{outcome.error.__class__.__name__}: {outcome.error}"
        records += [
            {"kind": t.kind, "run_id": t.run_id, "message": message}
            | {"status": "error", "wall_s": math.nan}
            for t in flights[i]
        ]
    return records


def import_task_code() -> None:
    """Import what :func:`execute_flight` imports when it runs, here, before the runs fork: a
    module imported in a forked child is imported (and, without bytecode files, compiled)
    again in every child, ~8 ms a run for the monitor alone."""
    import probing.experiment.design.noise
    import probing.experiment.flight.monitor
    import probing.experiment.flight.run
    import probing.sim.errors  # noqa: F401


def _scenario_of(flight: list[Task]) -> Scenario:
    return flight[0].scenario


def _companions_of(flight: list[Task]) -> list[Scenario]:
    return [t.scenario for t in flight[1:]]


def _shared_predictions(scenarios: list[Scenario], aircraft: TrimmedAircraft) -> None:
    """Compute, before the chunk's children fork, what their predictions share: the
    linearisation at the trim (of a copy of the chunk's trimmed aircraft) and its step
    response; each child would otherwise compute them again."""
    from probing.experiment.design.noise import linear_model

    first = scenarios[0]
    try:
        linear_model(first.flight, first.channels, aircraft)
    except Exception:  # recorded by each point's prediction, as without the warm-up
        return
    predictions(first)
