"""forked_map: every call in its own child of the caller's memory, answers and errors back."""

from __future__ import annotations

import os
import signal

import pytest

from probing.core.forked import ChildDiedError, can_fork, forked_map

pytestmark = pytest.mark.skipif(not can_fork(), reason="needs os.fork")

STATE = {"seen": []}


def _mutate_and_report(x: int) -> tuple[int, list[int], int]:
    """Appends to module state (in the child) and reports what it saw."""
    STATE["seen"].append(x)
    return x * x, list(STATE["seen"]), os.getpid()


@pytest.mark.parametrize("jobs", [1, 3])
def test_each_call_starts_from_the_parents_memory(jobs: int) -> None:
    STATE["seen"] = [-1]
    outcomes = {o.index: o for o in forked_map(_mutate_and_report, range(7), jobs)}
    assert sorted(outcomes) == list(range(7))
    pids = set()
    for i, o in outcomes.items():
        square, seen, pid = o.get()
        assert square == i * i
        assert seen == [-1, i]  # no sibling's change, the parent's state as it was
        pids.add(pid)
    assert len(pids) == 7 and os.getpid() not in pids
    assert STATE["seen"] == [-1]  # the parent is untouched


def _fail(x: int) -> None:
    if x == 1:
        raise KeyError(f"point {x}")
    if x == 2:
        os.kill(os.getpid(), signal.SIGKILL)


def test_errors_and_deaths_come_back_per_call() -> None:
    outcomes = {o.index: o for o in forked_map(_fail, range(3), 2)}
    assert outcomes[0].get() is None
    with pytest.raises(KeyError, match="point 1"):
        outcomes[1].get()
    assert isinstance(outcomes[2].error, ChildDiedError)
    assert "signal 9" in str(outcomes[2].error)


def test_an_abandoned_map_leaves_no_child_behind() -> None:
    gen = forked_map(_mutate_and_report, range(6), 3)
    first = next(gen)
    assert first.error is None
    gen.close()  # the caller stops early: the running children are killed and reaped
    with pytest.raises(ChildProcessError):
        os.waitpid(-1, os.WNOHANG)
