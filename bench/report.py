"""The report of ``make bench``: a section's rows and text, the table of sections, the page.

Each section is a module of ``bench`` with ``run(args) -> dict`` (measures; the dict is
stored in ``results/bench/bench.json``) and ``render(dict) -> Rendered`` (rows of the
summary table at the top, and markdown details).  :class:`Section` names the module, which
is imported only when the section runs or renders, so a child process started by one
section (``python -m bench --child-flight``) imports no other section's code.
"""

from __future__ import annotations

import argparse
import importlib
import os
import platform
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType

from probing.sim.aircraft import jsbsim_version


@dataclass
class Row:
    """One line of the summary table: a measured figure against its same-run baseline."""

    quantity: str
    value: str
    baseline: str = ""
    ratio: str = ""
    target: str = ""
    met: bool | None = None


@dataclass
class Rendered:
    """A section's contribution to the report."""

    rows: list[Row] = field(default_factory=list)
    details: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class Section:
    """A benchmark: the module ``bench.<module>``, with ``run(args) -> dict`` (stored in
    bench.json) and ``render(dict) -> Rendered``."""

    key: str
    title: str
    module: str

    def load(self) -> ModuleType:
        """The section's module, imported now."""
        return importlib.import_module(f"bench.{self.module}")

    def run(self, args: argparse.Namespace) -> dict:
        """Measure: the section's JSON-able results."""
        return self.load().run(args)

    def render(self, results: dict) -> Rendered:
        """The section's rows and text from its results."""
        return self.load().render(results)


def machine() -> str:
    """CPU model, cores, OS, Python and JSBSim versions (no host name, no date)."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.machine()}, "
        f"Python {platform.python_version()}, JSBSim {jsbsim_version()}"
    )


def render(sections: list[Section], results: dict[str, dict], command: str, wall_s: float) -> str:
    """The page (docs/benchmarks.md): the summary table, then each section's details."""
    rendered = {s.key: s.render(results[s.key]) for s in sections if s.key in results}
    lines = [
        "# Benchmarks",
        "",
        "Reproduce with `make bench` (that is `.venv/bin/python -m bench`; "
        "`python -m bench --quick` is a smoke run that writes no docs).",
        f"This report: `{command}`, {wall_s:.0f} s, on {machine()}.",
        "Every figure is compared with a baseline measured in the same run; medians of "
        "repeats. Raw numbers: `results/bench/bench.json`.",
        "",
        "| quantity | measured | same-run baseline | ratio | target | met |",
        "|---|---|---|---|---|---|",
    ]
    for r in rendered.values():
        for row in r.rows:
            met = "" if row.met is None else ("yes" if row.met else "**no**")
            lines.append(
                f"| {row.quantity} | {row.value} | {row.baseline} | {row.ratio} | "
                f"{row.target} | {met} |"
            )
    lines.append("")
    for r in rendered.values():
        lines += r.details
    return "\n".join(lines)
