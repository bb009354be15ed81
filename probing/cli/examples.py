"""``probing examples``: the example scenarios and the docs' examples the package ships,
listed or copied out as the repository lays them out (``scenarios/``, ``examples/``), so that
the commands of the README and docs/ run from the folder they are copied into."""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from pathlib import Path

from probing.cli.common import Subcommands, UsageError, command, out_folder, path_arg


def _shipped() -> dict[str, Path]:
    """The shipped folders by the name they have in the repository (and in a copy)."""
    from probing.data import EXAMPLES, SCENARIOS

    return {"scenarios": SCENARIOS, "examples": EXAMPLES}


def _copy(target: Path) -> None:
    """Copy the shipped folders into ``target`` (new, or an empty folder), all or nothing:
    into a temporary folder beside it, renamed at the end."""
    out_folder(target, "--copy")
    if target.exists() and any(target.iterdir()):
        raise UsageError(f"--copy {target}: is not empty")
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}-", dir=target.parent))
    try:
        for name, folder in _shipped().items():
            ignore = shutil.ignore_patterns("__pycache__")
            shutil.copytree(folder, tmp / name, ignore=ignore)
        if target.exists():
            target.rmdir()
        os.replace(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _cmd_examples(args: argparse.Namespace) -> int:
    shipped = _shipped()
    if args.copy is not None:
        _copy(args.copy)
        print(f"example scenarios and examples copied to {args.copy}")
        return 0
    print(
        f"example scenarios in {shipped['scenarios']} and examples in {shipped['examples']} "
        "(probing examples --copy DIR copies them into DIR/scenarios and DIR/examples):"
    )
    for path in sorted(shipped["scenarios"].rglob("*.toml")):
        print(f"scenarios/{path.relative_to(shipped['scenarios']).as_posix()}")
    examples = shipped["examples"]
    for path in sorted(examples.rglob("*")):
        if path.is_file() and "__pycache__" not in path.parts:
            print(f"examples/{path.relative_to(examples).as_posix()}")
    return 0


def register(sub: Subcommands) -> None:
    """Add ``examples`` to ``sub``."""
    examples = command(
        sub,
        "examples",
        "list the example scenarios and the docs' examples shipped with the package, or "
        "copy them into a folder",
        ["probing examples", "probing examples --copy ~/probing-examples"],
    )
    examples.add_argument(
        "--copy",
        type=path_arg,
        metavar="DIR",
        help="copy them into DIR (new or empty) as DIR/scenarios and DIR/examples",
    )
    examples.set_defaults(func=_cmd_examples)
