"""``probing examples``: the example scenarios the package ships, listed or copied out."""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from pathlib import Path

from probing.cli.common import Subcommands, UsageError, _out_folder, _path, command


def _copy(target: Path) -> None:
    """Copy the shipped scenarios into ``target`` (new, or an empty folder), all or nothing:
    into a temporary folder beside it, renamed at the end."""
    from probing.data import SCENARIOS

    _out_folder(target, "--copy")
    if target.exists() and any(target.iterdir()):
        raise UsageError(f"--copy {target}: is not empty")
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}-", dir=target.parent))
    try:
        shutil.copytree(
            SCENARIOS, tmp, dirs_exist_ok=True, ignore=shutil.ignore_patterns("__pycache__")
        )
        if target.exists():
            target.rmdir()
        os.replace(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _cmd_examples(args: argparse.Namespace) -> int:
    from probing.data import SCENARIOS

    if args.copy is not None:
        _copy(args.copy)
        print(f"example scenarios copied to {args.copy}")
        return 0
    print(f"example scenarios in {SCENARIOS} (probing examples --copy DIR copies them out):")
    for path in sorted(SCENARIOS.rglob("*.toml")):
        print(path.relative_to(SCENARIOS).as_posix())
    return 0


def register(sub: Subcommands) -> None:
    """Add ``examples`` to ``sub``."""
    examples = command(
        sub,
        "examples",
        "list the example scenarios shipped with the package, or copy them into a folder",
    )
    examples.add_argument(
        "--copy", type=_path, metavar="DIR", help="copy them into DIR (new or empty)"
    )
    examples.set_defaults(func=_cmd_examples)
