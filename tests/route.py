"""The route of a command through the package: which of ``probing``'s modules it enters, how
often it crosses from one module into another, and how often it goes back into a module it
had already been in.

Run from the repository root (``make setup`` first)::

    .venv/bin/python tests/route.py [--edges] -- run scenarios/fig4/a_deadband.toml

It runs ``probing <arguments>`` in this process (every run in it: ``PROBING_FORK=0``; the
output goes to a temporary folder when the arguments name none with ``--out``) with a
profiler that sees every call of a Python function of the package, and counts the distinct
crossings, caller's module -> callee's module, in the order they first happen (a call through
the standard library or another package counts from the package's frame below it; what runs
while a module is imported is left out: it is how the modules are built, not the route):

- ``modules``: the package's modules entered, the command line's included;
- ``crossings``: the distinct (caller module, callee module) pairs;
- ``returns``: the crossings into a module entered before (crossings - modules + 1: every
  crossing but the first into each module).

A loop that crosses the same pair a million times counts it once: the numbers measure how
the code is laid out, not how long it runs.  ``--edges`` lists the crossings.  Not collected
by pytest (no ``test_`` prefix).
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path
from types import CodeType, FrameType
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "probing"


def _module(code: CodeType) -> str | None:
    """The dotted module of a code object of the package, or None outside it."""
    path = Path(code.co_filename)
    try:
        parts = path.relative_to(PACKAGE).with_suffix("").parts
    except ValueError:
        return None
    names = ["probing", *parts]
    return ".".join(names[:-1] if names[-1] == "__init__" else names)


class Route:
    """The distinct crossings between the package's modules, in first-seen order."""

    def __init__(self) -> None:
        self.edges: dict[tuple[str, str], None] = {}
        self.modules: dict[str, None] = {}

    def profile(self, frame: FrameType, event: str, arg: Any) -> None:
        if event != "call":
            return
        callee = _module(frame.f_code)
        if callee is None or frame.f_code.co_name == "<module>":
            return  # outside the package, or a module's import
        caller_frame = frame.f_back
        caller = None
        while caller_frame is not None and caller is None:
            if caller_frame.f_code.co_name == "<module>":
                return  # called while a module is imported: its layout, not the route
            caller = _module(caller_frame.f_code)
            caller_frame = caller_frame.f_back
        if caller is None:
            self.modules.setdefault(callee)
            return
        self.modules.setdefault(caller)
        if caller != callee:
            self.edges.setdefault((caller, callee))
            self.modules.setdefault(callee)

    def counts(self) -> dict[str, int]:
        modules, crossings = len(self.modules), len(self.edges)
        return {"modules": modules, "crossings": crossings, "returns": crossings - modules + 1}


def trace(argv: list[str]) -> Route:
    """Run ``probing ARGV`` in this process under :class:`Route`'s profiler."""
    os.environ["PROBING_FORK"] = "0"
    from probing.cli import main

    route = Route()
    with tempfile.TemporaryDirectory(prefix="probing-route-") as tmp:
        if argv and argv[0] in ("run", "monitor") and "--out" not in argv:
            argv = [*argv, "--out", tmp]
        sys.setprofile(route.profile)
        try:
            code = main(argv)
        finally:
            sys.setprofile(None)
    if code != 0:
        raise SystemExit(f"probing {' '.join(argv)} ended with exit code {code}")
    return route


def main(args: list[str]) -> int:
    edges = "--edges" in args
    argv = args[args.index("--") + 1 :] if "--" in args else [a for a in args if a != "--edges"]
    route = trace(argv or ["run", "scenarios/fig4/a_deadband.toml"])
    if edges:
        for caller, callee in route.edges:
            print(f"{caller} -> {callee}")
    print(" ".join(f"{k} {v}" for k, v in route.counts().items()))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
