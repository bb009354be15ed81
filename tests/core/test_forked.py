"""forked_map: every call in its own child of the caller's memory, answers and errors back."""

from __future__ import annotations

import os
import signal
from pathlib import Path

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


def _children() -> set[int]:
    """This process's children, reaped or not (Linux's /proc), by pid."""
    mine = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:  # ended meanwhile
            continue
        if int(fields[1]) == os.getpid():
            mine.add(int(stat.parent.name))
    return mine


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux's /proc")
def test_an_abandoned_map_leaves_no_child_behind() -> None:
    """Its own children only: an earlier test's (a subprocess still ending) may be there."""
    before = _children()
    gen = forked_map(_mutate_and_report, range(6), 3)
    first = next(gen)
    assert first.error is None
    assert _children() - before  # the map's, running
    gen.close()  # the caller stops early: the running children are killed and reaped
    assert _children() - before == set()


# A script that forks slowly: an after-fork hook (as ``logging`` registers one) sleeps at
# the first fork, so a Ctrl-C lands inside the hook, where Python would print and drop the
# KeyboardInterrupt (the other 19 forks go at full speed: the map runs one child at a time).
SLOW_FORKS = """
import os, sys, time
from pathlib import Path
from probing.core.forked import forked_map

where, side = Path(sys.argv[1]), sys.argv[2]
def hook():
    first = not any(where.glob(f"{side}-hook-*"))
    (where / f"{side}-hook-{os.getpid()}").touch()
    if first:
        time.sleep(0.5)
if side == "parent":
    os.register_at_fork(after_in_parent=hook)
else:
    os.register_at_fork(after_in_child=hook)

def run(i):
    (where / f"ran-{i}").touch()
    return i

try:
    for o in forked_map(run, range(20), 1):
        print(o.index, type(o.error).__name__ if o.error else "ok", flush=True)
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(130)
"""


def _slow_forks(tmp_path, side: str):
    import subprocess
    import sys
    import time

    proc = subprocess.Popen(
        [sys.executable, "-c", SLOW_FORKS, str(tmp_path), side],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 30
    while not (hooked := list(tmp_path.glob(f"{side}-hook-*"))) and time.monotonic() < deadline:
        time.sleep(0.005)
    assert hooked, "the script never forked"
    return proc, int(hooked[0].name.rsplit("-", 1)[1])


def test_ctrl_c_during_a_fork_stops_the_map(tmp_path) -> None:
    """Interrupted inside the parent's after-fork hook: the map must stop (and kill the child
    it just forked), not go on forking all 20 with a printed 'Exception ignored'."""
    proc, pid = _slow_forks(tmp_path, "parent")
    os.kill(pid, signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 130, (out, err)
    assert "Exception ignored" not in err
    assert len(list(tmp_path.glob("ran-*"))) <= 1  # the child being forked, at most


def test_ctrl_c_to_a_child_being_forked_ends_that_child(tmp_path) -> None:
    """Interrupted inside the child's after-fork hook, before it could install the default
    action: the child must die of the signal, not run its call."""
    proc, pid = _slow_forks(tmp_path, "child")
    os.kill(pid, signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert out.splitlines()[0] == "0 ChildDiedError"
    assert not (tmp_path / "ran-0").exists()
    assert len(list(tmp_path.glob("ran-*"))) == 19
    assert "Exception ignored" not in err


class _Frame:
    """A stand-in for the frame a signal handler is given: its file and its caller."""

    def __init__(self, filename: str, back: _Frame | None = None) -> None:
        self.f_code = type("Code", (), {"co_filename": filename})()
        self.f_back = back


def test_a_ctrl_c_inside_an_import_is_noted_and_raised_at_the_next_check() -> None:
    """Python drops a KeyboardInterrupt raised in the import system's callbacks: inside an
    import (anywhere up the stack) the handler only notes it, check() raises it; outside,
    it raises at once; leaving the outermost block forgets it."""
    from probing.core.forked import Interrupts

    interrupts = Interrupts()
    with interrupts:
        in_import = _Frame("/x/module.py", _Frame("<frozen importlib._bootstrap>"))
        interrupts._handler(signal.SIGINT, in_import)  # no raise
        assert interrupts.noted
        with pytest.raises(KeyboardInterrupt):
            interrupts.check()
        with pytest.raises(KeyboardInterrupt):
            interrupts._handler(signal.SIGINT, _Frame("/x/module.py"))
    with interrupts:
        assert not interrupts.noted
        interrupts.check()  # nothing noted: no raise


def test_a_ctrl_c_noted_while_forking_replaces_the_error_it_caused() -> None:
    """A Ctrl-C noted inside forked() (it ended a pool's workers) is raised at the end of the
    block in place of the error it caused there (BrokenProcessPool); nested blocks raise it
    only at the outermost end."""
    from probing.core.forked import Interrupts

    interrupts = Interrupts()
    with interrupts, pytest.raises(KeyboardInterrupt):
        with interrupts.forked():
            with interrupts.forked():
                interrupts._handler(signal.SIGINT, None)  # noted, not raised: forking
            raise RuntimeError("the pool broke")
    with interrupts:
        interrupts._handler(signal.SIGINT, _Frame("<frozen importlib._bootstrap>"))
        with pytest.raises(KeyboardInterrupt), interrupts.forked():  # noted before: no fork
            raise AssertionError("forked although a Ctrl-C was noted")


def test_a_sigterm_inside_an_import_is_held_as_its_own_kind() -> None:
    """The command line's SIGTERM (a KeyboardInterrupt subclass) lands in an import: noted,
    not raised there (Python would turn it into another error), and check() raises that same
    kind; outside any block it raises at once, as before."""
    from probing.core.forked import Interrupts

    class Stop(KeyboardInterrupt):
        pass

    interrupts = Interrupts()
    with pytest.raises(Stop):
        interrupts.interrupt(Stop, _Frame("<frozen importlib._bootstrap>"))  # not active
    with interrupts:
        interrupts.interrupt(Stop, _Frame("/x/pandas.py", _Frame("<frozen importlib._bootstrap>")))
        assert interrupts.noted is Stop
        interrupts.interrupt(KeyboardInterrupt, _Frame("<frozen importlib._bootstrap>"))
        assert interrupts.noted is Stop  # the first one is kept
        with pytest.raises(Stop):
            interrupts.check()
