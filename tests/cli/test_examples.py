"""``probing examples``: the shipped scenarios listed, and copied out all or nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

from probing.cli import main as cli_main
from probing.data import AIRCRAFT, SCENARIOS

ROOT = Path(__file__).resolve().parents[2]


def test_the_package_data_is_the_repositorys_folders() -> None:
    assert SCENARIOS == (ROOT / "scenarios").resolve()
    assert AIRCRAFT == (ROOT / "aircraft").resolve()


def test_examples_lists_every_scenario(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["examples"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert str(SCENARIOS) in lines[0]
    expected = [p.relative_to(SCENARIOS).as_posix() for p in sorted(SCENARIOS.rglob("*.toml"))]
    assert lines[1:] == expected and "fig4/a_deadband.toml" in expected


def test_examples_copy(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "new" / "scenarios"
    assert cli_main(["examples", "--copy", str(target)]) == 0
    for path in SCENARIOS.rglob("*.toml"):
        assert (target / path.relative_to(SCENARIOS)).read_bytes() == path.read_bytes()
    assert [p.name for p in target.parent.iterdir()] == ["scenarios"]  # no temporary left
    capsys.readouterr()
    assert cli_main(["examples", "--copy", str(target)]) == 2  # not empty: refused
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is not empty" in err
    file = tmp_path / "file"
    file.write_text("x")
    assert cli_main(["examples", "--copy", str(file)]) == 2
    assert file.read_text() == "x"
