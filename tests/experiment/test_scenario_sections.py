"""The scenario is made of its sections: one object per ``[section]``, each parsed from its
table and written back unchanged, and nothing else besides the name and the text."""

from __future__ import annotations

import dataclasses
import inspect
import os
import typing
from pathlib import Path
from typing import Any

import pytest

from probing.experiment.scenario import SECTIONS, Scenario, load_scenario, read_toml
from probing.sweep.spec import load_sweep

ROOT = Path(__file__).resolve().parents[2]


def _toml_files() -> list[Path]:
    """Every TOML file under scenarios/ and probing/data/ (whose folders link to scenarios/
    and examples/), each once: scenarios, sweeps and others."""
    return sorted(
        {
            (Path(folder) / name).resolve()
            for top in (ROOT / "scenarios", ROOT / "probing" / "data")
            for folder, _, names in os.walk(top, followlinks=True)
            for name in names
            if name.endswith(".toml")
        }
    )


#: The scenario files (a scenario has a ``[probe]``) and the sweeps (a ``base`` scenario).
SCENARIO_FILES = [p for p in _toml_files() if "probe" in read_toml(p)[0]]
SWEEP_FILES = [p for p in _toml_files() if "base" in read_toml(p)[0]]
#: The file's tables, each a section of the scenario (``name`` is a value).
TABLES = [name for name, keys in SECTIONS.items() if keys is not None]


def _run_facts(scn: Scenario) -> dict[str, Any]:
    """What a section's ``parse`` may be told of the sections before it."""
    return {
        "dt_s": scn.dt_s,
        "duration_s": scn.total_steps * scn.dt_s,
        "surface": scn.surface,
        "amplitude_deg": scn.amplitude_deg,
        "folder": None,
    }


def test_the_files_are_found() -> None:
    names = {p.relative_to(ROOT).as_posix() for p in SCENARIO_FILES}
    assert "scenarios/baseline-737.toml" in names
    assert any(n.startswith("scenarios/manoeuvres/") for n in names)
    assert any(n.startswith("scenarios/simultaneous/") for n in names)
    assert "examples/live/scenario.toml" in names
    assert len(SWEEP_FILES) > 10


def _reads_back(scn: Scenario) -> None:
    """``Section.parse(section.to_dict()) == section`` for each section of ``scn``, and the
    scenario's dict is its sections' dicts."""
    facts = _run_facts(scn)
    sections = scn.sections()
    assert set(sections) <= set(TABLES)
    written = scn.to_dict()
    assert written == {"name": scn.name, **{n: s.to_dict() for n, s in sections.items()}}
    for name, section in sections.items():
        parse = type(section).parse
        given = {k: v for k, v in facts.items() if k in inspect.signature(parse).parameters}
        assert parse(section.to_dict(), **given) == section, name


@pytest.mark.parametrize("path", SCENARIO_FILES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_section_reads_back_what_it_writes(path: Path) -> None:
    _reads_back(load_scenario(path))


@pytest.mark.parametrize("path", SWEEP_FILES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_sweep_point_reads_back_what_it_writes(path: Path) -> None:
    """The sweeps vary what the scenario files leave at their defaults (detrending, sensor
    noise, a climb or a turn, faults, sensors)."""
    for point in load_sweep(path).points:
        _reads_back(point.scenario)
        _reads_back(point.reference)


def test_a_scenario_is_its_name_its_text_and_one_object_per_section() -> None:
    """No section's fields come back as the scenario's own: its fields are exactly the
    name, the text and a ``<table>_section`` for every table of the file, each a frozen
    object that parses itself and writes itself back."""
    fields = [f.name for f in dataclasses.fields(Scenario)]
    assert set(fields) == {"name", "text", *(f"{t}_section" for t in TABLES)}
    hints = typing.get_type_hints(Scenario)
    for table in TABLES:
        kinds = [k for k in typing.get_args(hints[f"{table}_section"]) if k is not type(None)]
        kind = kinds[0] if kinds else hints[f"{table}_section"]
        assert dataclasses.is_dataclass(kind) and kind.__dataclass_params__.frozen, table
        assert inspect.ismethod(kind.parse) and callable(kind.to_dict), table
