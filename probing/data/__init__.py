"""The files the package ships: the project's aircraft, the example scenarios and the
examples the docs follow (a live flight, a foreign log's map, a recorded CSV).

In the repository ``probing/data/aircraft``, ``probing/data/scenarios`` and
``probing/data/examples`` are links to the top-level ``aircraft/``, ``scenarios/`` and
``examples/``; an installed package holds copies of them (package data, ``pyproject.toml``),
so all three are found the same way wherever the package is.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["AIRCRAFT", "EXAMPLES", "SCENARIOS"]

_HERE = Path(__file__).resolve().parent

#: The project's JSBSim aircraft (``gtm_t2``), the real folder behind the link.
AIRCRAFT = (_HERE / "aircraft").resolve()

#: The example scenarios and sweeps (``probing examples`` lists and copies them).
SCENARIOS = (_HERE / "scenarios").resolve()

#: The examples docs/live.md, docs/formats.md and docs/analyze.md follow (``probing examples``
#: lists and copies them beside the scenarios).
EXAMPLES = (_HERE / "examples").resolve()
