"""The probing command line: run, truth, monitor, live, sweep, fig4, plot, design, modes,
gtm-damage, analyze, examples, cache.

Exit codes: 0 success; 2 bad input (a scenario, sweep or option that is refused, an output
folder or file that cannot be written, a Dask scheduler that does not answer, an aircraft
folder of the user's that JSBSim cannot load or trim), with one line on stderr (argparse's
own errors too) and nothing written: every output folder and file is checked before any work
(:func:`probing.experiment.output.storage.check_output_folder` and
:func:`~probing.experiment.output.storage.check_output_file`); 1 a run that failed (trim failure,
divergence, a live flight's simulator lost), a sweep with failed points or a sweep folder in
use by another process; 130 interrupted (Ctrl-C), 143 terminated (SIGTERM), after the same
clean-up; 141 its output went into a pipe the reader had closed (``probing examples |
head``), nothing on stderr.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from collections.abc import Sequence
from typing import Any, NoReturn

from probing import __version__
from probing.cli import (
    analyze,
    cache,
    design,
    examples,
    excitations,
    fig4,
    gtm,
    live,
    plot,
    run,
    sweep,
)
from probing.cli.common import Parser, UsageError, print_error
from probing.core.forked import INTERRUPTS

__all__ = ["build_parser", "main"]

#: The top-level help's text; the commands are listed by argparse, from the parser itself.
DESCRIPTION = (
    "Pulse-compression probing of aircraft dynamics through hard input nonlinearities, on JSBSim."
)
EPILOG = """\
examples:
  probing run scenarios/baseline-737.toml --out results
  probing run --help   # each command's options, with examples

exit codes: 0 success; 2 bad input (one line on stderr, nothing written); 1 a run that
failed (trim failure, divergence, a simulator that died) or a sweep folder in use; 130
interrupted; 143 terminated (SIGTERM); 141 output into a closed pipe.
See README.md and docs/ for the formats and the method."""


#: The command modules, in the order of the top-level help: each adds its commands to the
#: parser (``register``) and runs them (``args.func``).  A new command is a module here.
COMMANDS = (run, live, sweep, fig4, excitations, plot, design, gtm, analyze, examples, cache)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for documentation and tests)."""
    parser = Parser(
        prog="probing",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"probing {__version__}")
    sub = parser.add_subparsers(title="commands", dest="command", required=True, metavar="command")
    for module in COMMANDS:
        module.register(sub)
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the command is, so it cleans up as after Ctrl-C: partial files
    and twins are dropped, child processes ended (exit code 143)."""


def _terminate(signum: int, frame: Any) -> None:
    INTERRUPTS.interrupt(Terminated, frame)  # held while forking or importing, as Ctrl-C


def _end_interrupted(code: int) -> NoReturn:
    """End this process at once with ``code`` after an interrupt, its clean-up done.

    Further Ctrl-C and SIGTERM are ignored, the streams flushed, and the interpreter's own
    finalization skipped: it puts back the default action of SIGINT (die by the signal), and
    one noted late there (a process pool's threads held it back) ended the process by SIGINT
    instead of with ``code`` now and then.  What the run wrote or removed is settled by then:
    the exception has passed through every writer's and pool's clean-up.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


#: The exit code when stdout's reader has closed the pipe: 128 + SIGPIPE, what a shell reports
#: for a program that SIGPIPE ended (``yes | head``), so ``set -o pipefail`` sees the same.
PIPE_CLOSED = 128 + 13


def _stdout_closed() -> int:
    """stdout's reader is gone: point stdout at the null device, so the interpreter's last
    flush raises nothing, and return :data:`PIPE_CLOSED`."""
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, sys.stdout.fileno())
        os.close(null)
    except (OSError, ValueError):  # no file descriptor behind stdout (a test's capture)
        pass
    return PIPE_CLOSED


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``probing`` console script.

    ``argv`` None: this process's own command line, which exits with the returned code; once
    interrupted it ends here (:func:`_end_interrupted`).  Output into a pipe the reader has
    closed ends the command quietly with :data:`PIPE_CLOSED`.
    """
    try:
        try:
            return _main(argv)
        finally:
            sys.stdout.flush()  # what print buffered goes now, where a closed pipe is caught
    except BrokenPipeError:
        return _stdout_closed()


def _main(argv: Sequence[str] | None) -> int:
    # the command line draws into files only (the library leaves a notebook's backend alone)
    os.environ.setdefault("MPLBACKEND", "Agg")
    parser = build_parser()
    args = parser.parse_args(argv)
    in_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if in_main else None
    stopping = 0
    try:
        with INTERRUPTS:  # no Ctrl-C is lost, wherever it lands (probing.core.forked)
            try:
                code = int(args.func(args))
            except (UsageError, Terminated, KeyboardInterrupt):
                raise
            except Exception:
                INTERRUPTS.check()  # an error the Ctrl-C caused (a pool's broken workers)
                raise
            INTERRUPTS.check()  # one Python dropped where it landed: the user asked to stop
            return code
    except UsageError as exc:
        return print_error(str(exc), 2)
    except ValueError as exc:  # a stored file that cannot be read, wherever it is read
        from probing.experiment.output.storage import StoredFileError
        from probing.sim.errors import CacheFolderError

        # a cache folder that is not one, wherever the cache is resolved (probing.sim.aircraft)
        if isinstance(exc, (StoredFileError, CacheFolderError)):
            return print_error(str(exc), 2)
        raise
    except Terminated:
        stopping = 143
        return print_error("terminated", stopping)
    except KeyboardInterrupt:
        stopping = 130
        return print_error("interrupted", stopping)
    finally:
        if stopping and argv is None:  # the process's own command line: it ends here
            _end_interrupted(stopping)
        if argv is not None:  # in-process: the outputs' hold ends with the command
            INTERRUPTS.release()
        if previous is not None:
            INTERRUPTS.restore(signal.SIGTERM, previous)
