"""Many runs, one load and trim per flight condition: runs grouped by their trimmed state.

Runs whose flights trim to the same state (:func:`probing.sim.fork.trim_key`: aircraft and
its files, condition, dt, JSBSim version; not turbulence, seed, probe or nonlinearity) form
a group.  For each group this process loads and trims the aircraft once
(:class:`~probing.sim.fork.TrimmedAircraft`) and forks one child per run; each child steps
its own copy of the trimmed state, so its results are bit-identical to a run that loaded
and trimmed for itself (``tests/experiment/test_batch.py``).  The parent never steps, so its
memory stays flat however many runs a group has.

Reference twins (``drift = "reference"``) that are not in the cache yet are simulated
first, each in a child forked from the same trimmed aircraft, and stored; the runs then read
them from the cache.  A twin that cannot be stored (it diverged, a full disk) is
simulated by the run itself, as without grouping, so a failure is reported exactly as
before.  If the trim fails, every run of the group loads and trims for itself and reports
the failure as it always did.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterator, Sequence
from typing import Any, TypeVar

from probing.core.forked import Outcome, can_fork, forked_map
from probing.experiment.flight.onboard import twin_flight
from probing.experiment.flight.run import flight_key
from probing.experiment.output.storage import batch_of_runs
from probing.experiment.scenario import Scenario
from probing.experiment.scenario.references import REFERENCES
from probing.sim.control import control_power
from probing.sim.flight import Flight
from probing.sim.fork import TrimmedAircraft, trim_key
from probing.sim.twins import store_twin, twin_stored

__all__ = ["chunked_groups", "flight_families", "group_indices", "run_grouped"]

T = TypeVar("T")


def group_indices(scenarios: Sequence[Scenario]) -> list[list[int]]:
    """Indices of ``scenarios`` grouped by trimmed state, in order of first appearance.

    Parameters
    ----------
    scenarios : sequence of Scenario
        Validated scenarios.

    Returns
    -------
    list of list of int
        Each inner list holds the positions of the scenarios that share one trimmed state
        (:func:`probing.sim.fork.trim_key` of their flights), in their original order.
    """
    keys: dict[Flight, str] = {}  # a trim key reads the aircraft's files: once per flight
    groups: dict[str, list[int]] = {}
    for i, scn in enumerate(scenarios):
        flight = scn.flight
        if flight not in keys:
            keys[flight] = trim_key(flight)
        groups.setdefault(keys[flight], []).append(i)
    return list(groups.values())


def flight_families(scenarios: Sequence[Scenario], shares: Sequence[bool]) -> list[list[int]]:
    """Indices of ``scenarios`` grouped into flights, in order of first appearance: those that
    may share a flight (``shares``: monitored flights) and differ only in their reference
    (:func:`probing.experiment.flight.run.flight_key`) fly it once, the first flying, the others
    its companions; every other scenario flies alone.
    """
    families: dict[object, list[int]] = {}
    for i, (scn, share) in enumerate(zip(scenarios, shares, strict=True)):
        key = flight_key(scn) if share else i
        families.setdefault(key, []).append(i)
    return list(families.values())


def chunked_groups(
    scenarios: Sequence[Scenario],
    workers: int,
    largest: int = 64,
    shares: Sequence[bool] | None = None,
) -> list[list[int]]:
    """:func:`group_indices`, large groups cut into chunks that ``workers`` can share.

    A group of n flights (:func:`flight_families` with ``shares``: each flight's scenarios
    stay together, in one chunk) is cut into chunks of at most ceil(n / workers) flights, at
    most ``largest``: every worker gets a part of a single large group, and a finished chunk
    reports its runs (progress) at least every ``largest`` flights.  Each chunk loads and
    trims once.  The chunks are interleaved (flight i goes to chunk i mod chunks): a sweep
    lists its points field by field, so consecutive points cost alike (a study's ``gust``
    flights, which fly a second aircraft, come together), and cut in runs one worker would
    get the costly ones while the other idles at the end.
    """
    families = flight_families(scenarios, shares or [False] * len(scenarios))
    out = []
    for group in group_indices([scenarios[f[0]] for f in families]):
        size = max(1, min(largest, math.ceil(len(group) / max(1, workers))))
        count = math.ceil(len(group) / size)
        out += [[i for k in group[j::count] for i in families[k]] for j in range(count)]
    return out


def _twins_to_store(scenarios: Sequence[Scenario]) -> list[Scenario]:
    """One scenario per distinct reference twin of the group that the cache lacks."""
    seen, todo = set(), []
    for scn in scenarios:
        flight = twin_flight(scn, nominal=False)
        if flight is None:
            continue
        spec = (flight, tuple(scn.channels), scn.total_steps)
        if spec in seen or twin_stored(*spec):
            continue
        seen.add(spec)
        todo.append(scn)
    return todo


def run_grouped(
    items: Sequence[T],
    scenario_of: Callable[[T], Scenario],
    work: Callable[[T, TrimmedAircraft | None], Any],
    *,
    jobs: int = 1,
    prepare: Callable[[list[Scenario], TrimmedAircraft], None] | None = None,
    others: Callable[[T], Sequence[Scenario]] | None = None,
) -> Iterator[tuple[int, Outcome]]:
    """Run ``work(item, aircraft)`` for every item, one load and trim per group.

    Parameters
    ----------
    items : sequence
        What to run; ``scenario_of(item)`` is its scenario.
    scenario_of : callable
        The item's validated scenario.
    work : callable
        ``work(item, aircraft)`` runs in a forked child; ``aircraft`` is the group's
        trimmed aircraft (pass it to :func:`probing.experiment.flight.run.run_scenario`), or None
        where the trim failed or the system cannot fork (the run then loads and trims for
        itself).  Its return value (or exception) must pickle.
    jobs : int
        Children of a group running at once.
    prepare : callable, optional
        ``prepare(scenarios, aircraft)``, called in this process with each group's
        scenarios and trimmed aircraft before its children fork, to compute what they all
        share once (what it caches, they inherit; it may fork copies of ``aircraft``).
    others : callable, optional
        ``others(item)``: the scenarios an item computes besides its own, from its flight
        (:class:`~probing.experiment.flight.run.Companion`): the group readies what
        they fly too.

    Yields
    ------
    (int, Outcome)
        The item's position and what ``work`` returned or raised, as the runs finish.
    """
    with batch_of_runs():
        yield from _run_grouped(items, scenario_of, work, jobs, prepare, others)


def _run_grouped(
    items: Sequence[T],
    scenario_of: Callable[[T], Scenario],
    work: Callable[[T, TrimmedAircraft | None], Any],
    jobs: int,
    prepare: Callable[[list[Scenario], TrimmedAircraft], None] | None,
    others: Callable[[T], Sequence[Scenario]] | None,
) -> Iterator[tuple[int, Outcome]]:
    scenarios = [scenario_of(item) for item in items]
    besides = [list(others(item)) if others else [] for item in items]
    if not can_fork():
        for i, item in enumerate(items):
            try:
                yield i, Outcome(i, work(item, None))
            except Exception as exc:
                yield i, Outcome(i, error=exc)
        return
    for group in group_indices(scenarios):
        members = [s for i in group for s in (scenarios[i], *besides[i])]
        try:
            aircraft: TrimmedAircraft | None = _trimmed(members[0].flight)
        except Exception:  # each run loads and trims itself, and reports the failure as usual
            aircraft = None
        if aircraft is not None:
            for surface in sorted({s.surface for s in members}):
                aircraft.plant.drive(surface)  # calibrated once, undisturbed, before forking
            if any(s.flight.closed_loop for s in members):
                control_power(members[0].flight)  # once, inherited by every child
            for flies in sorted({REFERENCES[s.drift].flies for s in members} - {""}):
                aircraft.add_second(flies == "gust_ready")  # the aircraft a reference flies
            if prepare is not None:
                prepare(members, aircraft)
            twins = _twins_to_store(members)
            for _ in forked_map(functools.partial(_store, aircraft=aircraft), twins, jobs):
                pass  # a twin that could not be stored is simulated by its run
        run = functools.partial(_work, items=items, work=work, aircraft=aircraft)
        for outcome in forked_map(run, group, jobs):
            yield group[outcome.index], outcome


#: The last group's trimmed aircraft.  This process never steps it (its children step their
#: copies), so the next call with the same trimmed state (the next chunk of a large group in
#: a sweep worker) forks from it instead of loading and trimming again.
_LAST: list[TrimmedAircraft] = []


def _trimmed(flight: Flight) -> TrimmedAircraft:
    """The trimmed aircraft of ``flight``: the last one if its trim key is the same."""
    key = trim_key(flight)
    if not (_LAST and _LAST[0].key == key):
        _LAST.clear()  # one aircraft at a time: the old one is freed before the new loads
        _LAST.append(TrimmedAircraft(flight))
    return _LAST[0]


def _work(i: int, items: Sequence[T], work: Callable, aircraft: TrimmedAircraft | None) -> Any:
    return work(items[i], aircraft)


def _store(scn: Scenario, aircraft: TrimmedAircraft) -> None:
    """Simulate and store a scenario's reference twin (in a child)."""
    steps_per_period = scn.period_steps
    flight = twin_flight(scn, nominal=False)
    assert flight is not None
    plant = aircraft.plant_for(flight)
    store_twin(flight, scn.channels, scn.total_steps, steps_per_period, plant)
