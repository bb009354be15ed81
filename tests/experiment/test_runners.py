"""The runner table: which runner flies a scenario and which commands it offers."""

from __future__ import annotations

from pathlib import Path

import pytest

from probing.experiment.flight.runners import RUNNERS, runner_of
from probing.experiment.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[2]


def test_each_runner_is_selected_by_a_scenario_section_or_is_the_one_default() -> None:
    sections = {name.removesuffix("_section") for name in Scenario.__dataclass_fields__}
    assert [r.name for r in RUNNERS if r.section is None] == ["steady"]
    assert RUNNERS[-1].section is None  # the default comes last: sections are tried first
    for r in RUNNERS:
        assert r.section is None or r.section in sections, r
        assert "run" in r.commands  # probing run flies every scenario


@pytest.mark.parametrize(
    ("path", "runner"),
    [
        ("scenarios/baseline-737.toml", "steady"),
        ("scenarios/monitor/base.toml", "steady"),
        ("scenarios/simultaneous/shift-737.toml", "simultaneous"),
        ("scenarios/manoeuvres/speed-1kt-s.toml", "manoeuvre"),
    ],
)
def test_the_runner_of_a_committed_scenario(path: str, runner: str) -> None:
    assert runner_of(load_scenario(ROOT / path)).name == runner


def test_a_command_a_runner_does_not_offer_is_refused_with_why() -> None:
    """The steady runner flies every command; the others only run, each saying why."""
    steady = runner_of(load_scenario(ROOT / "scenarios/baseline-737.toml"))
    sim = runner_of(load_scenario(ROOT / "scenarios/simultaneous/shift-737.toml"))
    man = runner_of(load_scenario(ROOT / "scenarios/manoeuvres/speed-1kt-s.toml"))
    assert all(steady.refuses(c) is None for c in ("run", "truth", "monitor", "sweep"))
    assert sim.refuses("run") is None and man.refuses("run") is None
    assert sim.refuses("truth") == (
        "probing truth takes one probed surface; a [simultaneous] scenario is flown by "
        "probing run (its --truth flies each surface alone)"
    )
    assert man.refuses("monitor").startswith("probing monitor flies a steady condition")
