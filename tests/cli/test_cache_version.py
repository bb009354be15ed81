"""``probing --version`` and ``probing cache info|clear``, in a temporary cache folder."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from probing.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[2]


def test_version_is_pyprojects(capsys: pytest.CaptureFixture[str]) -> None:
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    with pytest.raises(SystemExit) as exc:
        cli_main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"probing {version}"


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A cache root holding one sanitised aircraft (2 files) and two twins (+ a temporary)."""
    root = tmp_path / "cache"
    monkeypatch.setenv("PROBING_CACHE", str(root))
    monkeypatch.delenv("PROBING_TWIN_CACHE", raising=False)
    model = root / "jsbsim-root" / "x-0123" / "aircraft" / "x"
    model.mkdir(parents=True)
    (model / "x.xml").write_bytes(b"a" * 10)
    (model / "y.xml").write_bytes(b"b" * 5)
    twins = root / "twins"
    twins.mkdir()
    (twins / "k1.npy").write_bytes(b"c" * 100)
    (twins / "k2.npy").write_bytes(b"d" * 20)
    (root / "keep.txt").write_text("not the project's")
    return root


def test_cache_info_counts_entries_and_bytes(cache: Path, capsys) -> None:
    assert cli_main(["cache", "info"]) == 0
    out = capsys.readouterr().out
    assert f"cache root {cache}" in out
    assert "aircraft  holds 1 entries, 15 bytes" in out
    assert "twins     holds 2 entries, 120 bytes" in out


def test_cache_clear_needs_yes_and_removes_only_entries(cache: Path, capsys) -> None:
    assert cli_main(["cache", "clear"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--yes" in err
    assert (cache / "twins" / "k1.npy").exists()
    assert cli_main(["cache", "clear", "--yes"]) == 0
    assert "twins     removed 2 entries, 120 bytes" in capsys.readouterr().out
    assert not (cache / "jsbsim-root").exists()
    assert not list((cache / "twins").glob("*.npy"))
    assert (cache / "keep.txt").exists()  # only the project's entries go
    assert cli_main(["cache", "info"]) == 0
    assert "twins     holds 0 entries, 0 bytes" in capsys.readouterr().out


def test_cache_folder_that_is_a_file_is_one_line(tmp_path: Path, monkeypatch, capsys) -> None:
    root = tmp_path / "cache"
    root.mkdir()
    (root / "twins").write_text("a file")
    monkeypatch.setenv("PROBING_CACHE", str(root))
    monkeypatch.delenv("PROBING_TWIN_CACHE", raising=False)
    for action in (["info"], ["clear", "--yes"]):
        assert cli_main(["cache", *action]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "is not a folder" in err
    assert (root / "twins").read_text() == "a file"
