"""The files the package ships: the project's aircraft and the example scenarios.

In the repository ``probing/data/aircraft`` and ``probing/data/scenarios`` are links to the
top-level ``aircraft/`` and ``scenarios/``; an installed package holds copies of them (package
data, ``pyproject.toml``), so both are found the same way wherever the package is.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["AIRCRAFT", "SCENARIOS"]

_HERE = Path(__file__).resolve().parent

#: The project's JSBSim aircraft (``gtm_t2``), the real folder behind the link.
AIRCRAFT = (_HERE / "aircraft").resolve()

#: The example scenarios and sweeps (``probing examples`` lists and copies them).
SCENARIOS = (_HERE / "scenarios").resolve()
