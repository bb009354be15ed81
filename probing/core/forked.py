"""Calls in forked children: each child starts from this process's memory as it is now.

:func:`forked_map` runs a function on many arguments, each in a child forked from the
calling process, up to ``jobs`` at a time, and hands back what each returned or raised.
The standard library cannot do this: a ``ProcessPoolExecutor`` reuses its workers (a second
task would see the first one's changes), and refuses ``max_tasks_per_child`` with the
``fork`` start method.  Uses: runs that step their own copy of one trimmed aircraft
(:mod:`probing.sim.fork`), figures drawn side by side from data loaded once.

Only POSIX systems fork; elsewhere :func:`can_fork` is False and callers run in-process.
"""

from __future__ import annotations

import contextlib
import gc
import os
import pickle
import selectors
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any

from probing.core.errors import ProbingError

__all__ = [
    "INTERRUPTS",
    "STOPS",
    "ChildDiedError",
    "Interrupts",
    "Outcome",
    "can_fork",
    "forked_map",
]


class ChildDiedError(ProbingError, RuntimeError):
    """A forked child ended without handing back a result (killed, or crashed in C)."""


def can_fork() -> bool:
    """True where runs may be forked: POSIX ``os.fork`` exists and ``$PROBING_FORK`` is not
    ``0`` (set it to run everything in one process: debugging, profiling, and the
    same-run baseline of ``make bench``)."""
    if os.environ.get("PROBING_FORK", "1") == "0":
        return False
    return hasattr(os, "fork") and sys.platform != "win32"


@dataclass(frozen=True)
class Outcome:
    """What a child handed back: ``value`` if ``error`` is None, else the exception raised."""

    index: int
    value: Any = None
    error: BaseException | None = None

    def get(self) -> Any:
        """The value, or raise the child's exception."""
        if self.error is not None:
            raise self.error
        return self.value


def _child(fn: Callable[[Any], Any], arg: Any, fd: int) -> None:
    """Body of a forked child: run, send the pickled outcome, leave without clean-up."""
    code = 0
    try:
        try:
            payload = pickle.dumps((fn(arg), None))
        except BaseException as exc:  # handed to the parent, which raises it there
            try:
                payload = pickle.dumps((None, exc))
            except Exception:  # an exception that does not pickle: its text does
                payload = pickle.dumps((None, RuntimeError(f"{type(exc).__name__}: {exc}")))
        with os.fdopen(fd, "wb") as pipe:
            pipe.write(payload)
        sys.stdout.flush()
        sys.stderr.flush()
    except BaseException:
        code = 1
    finally:
        os._exit(code)  # no atexit handlers, no flushing of buffers copied from the parent


#: The signals that stop a run: Ctrl-C and SIGTERM.
STOPS = frozenset({signal.SIGINT, signal.SIGTERM})


class Interrupts:
    """Ctrl-C noted for as long as this is active, so that none is lost: one per process,
    :data:`INTERRUPTS`, entered by whatever needs it (the command line for a whole command,
    :func:`forked_map`, a sweep's pool), nested freely.

    Python runs signal handlers at the next bytecode, wherever that is: inside the
    library's after-fork hooks (``logging`` has one), an import (a lock's weakref callback,
    a class's ``__set_name__``) or any callback whose exceptions Python ignores, the
    KeyboardInterrupt is printed and *discarded* or turned into another error, and the
    caller would go on as if nothing happened.  While this is active (in the main thread,
    with Python's default SIGINT handler in place when first entered) the handler notes
    every Ctrl-C: it raises at once outside :meth:`forked` and imports; :meth:`check` and the end of
    :meth:`forked` raise a noted one again wherever the first was lost, and
    :attr:`noted` tells an error that the Ctrl-C caused from any other.
    """

    def __init__(self) -> None:
        self.depth = 0
        self.deferring = 0
        #: The interrupt noted (its exception class: KeyboardInterrupt, or the caller's
        #: subclass for SIGTERM), None without one.
        self.noted: type[KeyboardInterrupt] | None = None
        self.previous: Any = None
        #: The handlers before :meth:`hold_to_the_end` (signal -> handler), None when not
        #: holding.
        self.held: dict[int, Any] | None = None

    def __enter__(self) -> Interrupts:
        if self.depth == 0:
            self.noted = None
            in_main = threading.current_thread() is threading.main_thread()
            if in_main and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
                self.previous = signal.signal(signal.SIGINT, self._handler)
        self.depth += 1
        return self

    def __exit__(self, *exc: object) -> None:
        self.depth -= 1
        if self.depth == 0 and self.previous is not None:
            if threading.current_thread() is threading.main_thread():
                self.restore(signal.SIGINT, self.previous)
            self.previous = None

    def _handler(self, signum: int, frame: Any) -> None:
        self.interrupt(KeyboardInterrupt, frame)

    def interrupt(self, kind: type[KeyboardInterrupt], frame: Any) -> None:
        """A signal handler's body: note the interrupt ``kind`` (a KeyboardInterrupt class)
        and raise it at once, unless it landed while deferred (:meth:`deferred`) or inside an
        import (where Python would drop it or turn it into another error) and this is
        active: then the next :meth:`check` (or the end of the deferral) raises it.  The
        command line's SIGTERM handler comes here too."""
        if self.depth == 0:
            raise kind
        self.noted = self.noted or kind
        if not self.deferring and not _importing(frame):
            raise kind

    def check(self) -> None:
        """Raise the noted interrupt (KeyboardInterrupt, or the SIGTERM's subclass), perhaps
        lost where it landed."""
        if self.noted:
            raise self.noted

    def hold_to_the_end(self) -> None:
        """From here to the end of the process, Ctrl-C and SIGTERM are ignored: a command
        that moves its outputs into place calls this first, so that an interrupt either
        comes before (nothing written, exit 130) or is not acted on (the outputs whole, the
        command's own exit code).  One noted before is raised here.  Ignored, not blocked:
        a signal to the process may land in any of its threads.  :meth:`restore` keeps a
        handler put back meanwhile for :meth:`release`, which ends the hold (a command run
        in-process, a test's).  In the main thread only (elsewhere nothing is held)."""
        if self.held is None and threading.current_thread() is threading.main_thread():
            self.held = {s: signal.signal(s, signal.SIG_IGN) for s in sorted(STOPS)}
        self.check()

    def restore(self, signum: int, handler: Any) -> None:
        """Put ``handler`` back for ``signum``; while held, once the hold is released."""
        if self.held is not None:
            self.held[signum] = handler
        else:
            signal.signal(signum, handler)

    def release(self) -> None:
        """End :meth:`hold_to_the_end`'s hold: the handlers before it (or put back since)."""
        if self.held is not None:
            held, self.held = self.held, None
            for signum, handler in held.items():
                signal.signal(signum, handler)

    @contextlib.contextmanager
    def forked(self) -> Iterator[None]:
        """Around forking processes and registering them: Ctrl-C and SIGTERM are blocked in
        this thread, so a new process inherits the block (it lifts it once it has set its own
        handlers), and a Ctrl-C noted before or meanwhile is raised when the block ends, also
        in place of an error it caused there (a process pool whose workers it ended)."""
        self.check()
        with self.deferred():
            yield

    @contextlib.contextmanager
    def deferred(self) -> Iterator[None]:
        """Ctrl-C and SIGTERM deferred to the end of the block: blocked in this thread, and
        only noted if they land in another (a library's thread pool); one noted meanwhile is
        raised when the block ends (at the outermost, when nested), also in place of an
        error it caused there.  Around what must not stop half-way: :meth:`forked`, the
        removal of a command's unfinished files
        (:mod:`probing.experiment.output.staging`)."""
        with self:  # active, so that a Ctrl-C meanwhile is noted, not raised
            self.deferring += 1
            held = signal.pthread_sigmask(signal.SIG_BLOCK, STOPS)
            try:
                yield
            finally:
                signal.pthread_sigmask(signal.SIG_SETMASK, held)  # a pending one is noted
                self.deferring -= 1
                if self.noted and not self.deferring:
                    raise self.noted


def _importing(frame: Any) -> bool:
    """Whether ``frame`` runs inside an import, where a KeyboardInterrupt would be printed
    and dropped by one of the import system's callbacks, or turned into another error."""
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


#: The process's one :class:`Interrupts`.
INTERRUPTS = Interrupts()


def _start(fn: Callable[[Any], Any], arg: Any) -> tuple[int, int]:
    """Fork a child running ``fn(arg)``; (pid, read end of its pipe).

    SIGINT and SIGTERM are blocked in this thread across the fork, so the child cannot take
    one before it has set the default action (die at once, no traceback; the parent may
    turn SIGTERM into an exception, as the command line does); one that arrived meanwhile
    is delivered when the child unblocks it, and to this process after the fork.
    """
    read, write = os.pipe()
    sys.stdout.flush()  # what the parent buffered must not be written twice
    sys.stderr.flush()
    held = signal.pthread_sigmask(signal.SIG_BLOCK, STOPS)
    gc.freeze()  # the child's collector then leaves the parent's objects (and pages) alone
    pid = os.fork()
    if pid == 0:  # the child
        os.close(read)
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the parent's handler, if any
        signal.pthread_sigmask(signal.SIG_UNBLOCK, STOPS)  # also if the parent held them
        _child(fn, arg, write)
    gc.unfreeze()
    os.close(write)
    signal.pthread_sigmask(signal.SIG_SETMASK, held)
    return pid, read


def forked_map(fn: Callable[[Any], Any], args: Iterable[Any], jobs: int = 1) -> Iterator[Outcome]:
    """``fn(arg)`` for each argument, each in a child forked from this process.

    Parameters
    ----------
    fn : callable
        Runs in the child; its return value (or exception) must pickle.
    args : iterable
        One child per item, started in order.
    jobs : int
        Children running at once (>= 1).

    Yields
    ------
    Outcome
        One per argument, as the children finish (``index`` is the argument's position).

    Notes
    -----
    A child that dies without answering (killed by a signal, a crash in C) gives an
    :class:`Outcome` whose error is :class:`ChildDiedError`.  If the caller stops early
    (an exception, Ctrl-C, ``close()``), the children still running are killed and reaped.
    """
    pending = iter(enumerate(args))
    running: dict[int, tuple[int, int, bytearray]] = {}  # fd -> (index, pid, data)
    selector = selectors.DefaultSelector()
    exiting: list[int] = []  # children that answered and are still tearing down
    with INTERRUPTS as interrupts:
        try:
            while True:
                while len(running) < max(1, jobs):
                    item = next(pending, None)
                    if item is None:
                        break
                    index, arg = item
                    with interrupts.forked():
                        pid, fd = _start(fn, arg)
                        running[fd] = (index, pid, bytearray())
                        selector.register(fd, selectors.EVENT_READ)
                if not running:
                    return
                for key, _ in selector.select():
                    fd = key.fd
                    chunk = os.read(fd, 1 << 20)
                    if chunk:
                        running[fd][2].extend(chunk)
                        continue
                    index, pid, data = running.pop(fd)
                    selector.unregister(fd)
                    os.close(fd)
                    outcome = _finish(index, pid, bytes(data), exiting)
                    _reap(exiting)
                    interrupts.check()  # a child ended by the Ctrl-C is not its outcome
                    yield outcome
        finally:
            for pid in exiting:  # answered, and ending: wait for them
                _wait(pid)
            for fd, (_, pid, _) in running.items():
                try:
                    os.kill(pid, signal.SIGKILL)
                    os.waitpid(pid, 0)
                except OSError:
                    pass
                selector.unregister(fd)
                os.close(fd)
            selector.close()


def _finish(index: int, pid: int, data: bytes, exiting: list[int]) -> Outcome:
    """Unpickle the child's answer; a child that answered is reaped later (its memory takes
    ~10 ms to tear down, time the next child can use), one that did not is waited for."""
    if data:
        exiting.append(pid)
        try:
            value, error = pickle.loads(data)
        except Exception as exc:
            return Outcome(index, error=ChildDiedError(f"unreadable answer from a child: {exc}"))
        return Outcome(index, value, error)
    status = _wait(pid)
    if os.WIFSIGNALED(status):
        why = f"killed by signal {os.WTERMSIG(status)}"
    else:
        why = f"exit status {os.waitstatus_to_exitcode(status)}"
    return Outcome(index, error=ChildDiedError(f"a forked run ended without an answer ({why})"))


def _wait(pid: int) -> int:
    """Reap a child; its wait status (0 if it was reaped already)."""
    try:
        return os.waitpid(pid, 0)[1]
    except ChildProcessError:
        return 0


def _reap(exiting: list[int]) -> None:
    """Reap the children of ``exiting`` that have ended, without waiting."""
    for pid in list(exiting):
        try:
            done, _ = os.waitpid(pid, os.WNOHANG)
        except ChildProcessError:
            done = pid
        if done:
            exiting.remove(pid)
