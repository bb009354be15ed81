"""``probing examples``: the shipped scenarios and examples listed, and copied out all or
nothing, laid out as in the repository (``scenarios/``, ``examples/``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from probing.cli import main as cli_main
from probing.data import AIRCRAFT, EXAMPLES, SCENARIOS

ROOT = Path(__file__).resolve().parents[2]


def files(folder: Path) -> list[Path]:
    """The files of a shipped folder, relative to it (no caches)."""
    return sorted(
        p.relative_to(folder)
        for p in folder.rglob("*")
        if p.is_file() and "__pycache__" not in p.parts
    )


def test_the_package_data_is_the_repositorys_folders() -> None:
    assert SCENARIOS == (ROOT / "scenarios").resolve()
    assert AIRCRAFT == (ROOT / "aircraft").resolve()
    assert EXAMPLES == (ROOT / "examples").resolve()


def test_examples_lists_every_scenario_and_example(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["examples"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert str(SCENARIOS) in lines[0] and str(EXAMPLES) in lines[0]
    scenarios = [
        f"scenarios/{p.relative_to(SCENARIOS).as_posix()}"
        for p in sorted(SCENARIOS.rglob("*.toml"))
    ]
    examples = [f"examples/{p.as_posix()}" for p in files(EXAMPLES)]
    assert lines[1:] == scenarios + examples
    for shipped in (
        "scenarios/fig4/a_deadband.toml",
        "examples/live/scenario.toml",
        "examples/foreign-log/map.toml",
        "examples/your-data/probe_response.csv",
    ):
        assert shipped in lines


def test_examples_copy(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "new" / "copied"
    assert cli_main(["examples", "--copy", str(target)]) == 0
    assert capsys.readouterr().out.splitlines()[-1].endswith(f"copied to {target}")
    assert sorted(p.name for p in target.iterdir()) == ["examples", "scenarios"]
    for folder, name in ((SCENARIOS, "scenarios"), (EXAMPLES, "examples")):
        assert files(target / name) == files(folder)
        for path in files(folder):
            assert (target / name / path).read_bytes() == (folder / path).read_bytes()
    assert [p.name for p in target.parent.iterdir()] == ["copied"]  # no temporary left
    assert cli_main(["examples", "--copy", str(target)]) == 2  # not empty: refused
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is not empty" in err
    file = tmp_path / "file"
    file.write_text("x")
    assert cli_main(["examples", "--copy", str(file)]) == 2
    assert file.read_text() == "x"
    empty = tmp_path / "empty"
    empty.mkdir()
    assert cli_main(["examples", "--copy", str(empty)]) == 0  # an empty folder is filled
    assert sorted(p.name for p in empty.iterdir()) == ["examples", "scenarios"]
