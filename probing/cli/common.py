"""What every command of the command line shares: its one-line errors, the output checks, the
parser's classes and the path argument."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

from probing.core.errors import ArgumentError, ProbingError

#: The subparsers of ``probing``, to which each command module adds its commands.
Subcommands = argparse._SubParsersAction


class UsageError(ProbingError):
    """Bad input found by a command: printed as one line, exit code 2."""


def option_of(name: str, renamed: Mapping[str, str] | None = None) -> str:
    """The command-line option of a Python keyword: ``dt_s`` is ``--dt-s`` (``renamed``: the
    keywords whose option is another, ``{"outputs": "--output"}``)."""
    return (renamed or {}).get(name) or "--" + name.replace("_", "-")


def argument_usage(exc: ArgumentError, renamed: Mapping[str, str] | None = None) -> UsageError:
    """An API's :class:`~probing.core.errors.ArgumentError` as the command line says it: each
    keyword it names written as its option (:func:`option_of`)."""
    return UsageError(exc.line(lambda name: option_of(name, renamed)))


def number_arg(text: str) -> int | float | str:
    """A number as typed (an int, else a float), else the text itself: the Python API it is
    handed to says what it must be (:mod:`probing.core.errors`), once for both."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def print_error(message: str, code: int) -> int:
    print(f"probing: error: {message}", file=sys.stderr)
    return code


def out_folder(path: Path, option: str) -> Path:
    """``path`` after :func:`probing.experiment.output.storage.check_output_folder` (UsageError)."""
    from probing.experiment.output.storage import OutputPathError, check_output_folder

    try:
        return check_output_folder(path, option)
    except OutputPathError as exc:
        raise UsageError(str(exc)) from None


def out_file(path: Path, option: str) -> Path:
    """``path`` after :func:`probing.experiment.output.storage.check_output_file` (UsageError)."""
    from probing.experiment.output.storage import OutputPathError, check_output_file

    try:
        return check_output_file(path, option)
    except OutputPathError as exc:
        raise UsageError(str(exc)) from None


def check_run_folder(out: Path, scn: Any) -> None:
    """``--out`` and the run's own folder in it, ``OUT/<scenario name>`` (UsageError)."""
    out_folder(out, "--out")
    out_folder(out / scn.name, "--out")


def scenario_arg(path: Path) -> Any:
    from probing.experiment.scenario import ScenarioError, load_scenario

    try:
        return load_scenario(path)
    except ScenarioError as exc:
        raise UsageError(str(exc)) from None


def simulating(job: Callable[[], int], where: str, model: str | None = None) -> int:
    """Run ``job``; a trim failure, a divergence or a simulator lost mid-flight is one line
    and exit code 1.

    The cache is checked first (:func:`probing.sim.cache.check_cache`): one that cannot be
    used is bad input, refused before any work.  An aircraft JSBSim cannot load, and a trim
    failure of an aircraft folder of the user's (``model`` a path: the model is the input),
    are one line and exit code 2.
    """
    from probing.sim.aircraft import is_path
    from probing.sim.cache import check_cache
    from probing.sim.errors import (
        AircraftNotFoundError,
        DivergenceError,
        SimulatorLostError,
        TrimError,
    )

    check_cache()
    try:
        return job()
    except AircraftNotFoundError as exc:
        return print_error(f"{where}: {exc}", 2)
    except TrimError as exc:
        return print_error(f"{where}: {exc}", 2 if model is not None and is_path(model) else 1)
    except (DivergenceError, SimulatorLostError) as exc:
        return print_error(f"{where}: {exc}", 1)


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line, ``probing: error: ...``, exit code 2
    (argparse prints the whole usage first); its subcommands' parsers are of this class."""

    def error(self, message: str) -> NoReturn:
        """Print ``message`` as the command's one-line error and exit with code 2."""
        self.exit(2, f"probing: error: {' '.join(message.split())}\n")


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """States an option's default after its help, unless the help states it already, the
    default is None (nothing to say) or False (a flag that is off); an indented line of the
    description or the epilog (an example) is kept as written, the rest wrapped."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        fill = super()._fill_text
        lines = text.splitlines()
        return "\n".join(indent + x if x.startswith(" ") else fill(x, width, indent) for x in lines)

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (
            "(default" in text
            or default is None
            or default is False
            or default == argparse.SUPPRESS
        ):
            return text
        return super()._get_help_string(action)


def path_arg(text: str) -> Path:
    """A path argument; an empty one (``--out ""``, the current folder) is refused."""
    if not text:
        raise argparse.ArgumentTypeError("empty path")
    return Path(text)


def listing(words: Sequence[str], last: str = "and") -> str:
    """``a, b and c`` (``last`` ``"or"``: ``a, b or c``)."""
    words = list(words)
    return f" {last} ".join([", ".join(words[:-1]), words[-1]]) if len(words) > 1 else words[0]


def files_of(kind: str) -> str:
    """The files a flight of ``kind`` writes, as its help names them
    (:data:`probing.experiment.output.layouts.FLIGHT_FILES`): ``a, b and c``."""
    from probing.experiment.output.layouts import FLIGHT_FILES

    return listing(FLIGHT_FILES[kind])


#: The heading of a command's examples at the end of its help.
EXAMPLES = "examples:"


def command(
    sub: Subcommands, name: str, text: str, examples: Sequence[str]
) -> argparse.ArgumentParser:
    """Add the command ``name`` to ``sub``: ``text`` is its line in the top-level help and
    its description, ``examples`` (whole command lines, ``probing <name> ...``, each with an
    optional ``  # comment``) end its help; its options' help states their defaults
    (:class:`_HelpFormatter`)."""
    if not examples:
        raise ValueError(f"probing {name}: a command's help shows at least one example")
    epilog = "\n".join([EXAMPLES, *(f"  {line}" for line in examples)])
    return sub.add_parser(
        name, help=text, description=text, epilog=epilog, formatter_class=_HelpFormatter
    )
