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


@pytest.mark.parametrize(
    ("variable", "inside"),
    [("PROBING_CACHE", ""), ("PROBING_CACHE", "sub"), ("PROBING_TWIN_CACHE", "")],
)
def test_cache_variable_naming_a_file_is_one_line_exit_2(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys, variable: str, inside: str
) -> None:
    """A cache variable naming a regular file (or a folder inside one): every command that
    resolves the cache says so in one line naming the variable and the path, exit 2, and
    writes nothing; ``cache info`` reported 0 entries with exit 0."""
    blocker = tmp_path / "cache-file"
    blocker.write_text("not a folder")
    value = blocker / inside if inside else blocker
    monkeypatch.delenv("PROBING_CACHE", raising=False)
    monkeypatch.delenv("PROBING_TWIN_CACHE", raising=False)
    monkeypatch.setenv(variable, str(value))
    if variable == "PROBING_TWIN_CACHE":
        monkeypatch.setenv("PROBING_CACHE", str(tmp_path / "root"))
    out = tmp_path / "out"
    scenario = ROOT / "scenarios" / "fig4" / "a_deadband.toml"
    for argv in (
        ["cache", "info"],
        ["cache", "clear", "--yes"],
        *([["run", str(scenario), "--out", str(out)]] if variable == "PROBING_CACHE" else []),
    ):
        capsys.readouterr()
        assert cli_main(argv) == 2, argv
        captured = capsys.readouterr()
        err = captured.err.splitlines()
        assert len(err) == 1 and err[0].startswith("probing: error: "), (argv, err)
        assert f"${variable} {value}" in err[0] and "not a folder" in err[0], err
        assert captured.out == ""
    assert blocker.read_text() == "not a folder"
    assert not out.exists()
    assert not (tmp_path / "root").exists()


def test_cache_variable_naming_a_folder_to_be_made_is_used(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    """The other side: a cache folder that does not exist yet is fine (made when needed)."""
    monkeypatch.setenv("PROBING_CACHE", str(tmp_path / "new" / "cache"))
    monkeypatch.delenv("PROBING_TWIN_CACHE", raising=False)
    assert cli_main(["cache", "info"]) == 0
    assert "aircraft  holds 0 entries" in capsys.readouterr().out


def _unusable_caches(tmp_path: Path) -> list[Path]:
    """Cache folders in which nothing can be made: one in ``/proc`` (a folder that takes no
    new entries, whoever asks), and one below a folder without write permission (root may
    write there anyway: then it is not one)."""
    found = [Path("/proc/probing-cache")] if Path("/proc/self").is_dir() else []
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        (locked / "x").mkdir()
    except PermissionError:
        found.append(locked / "cache")
    else:
        (locked / "x").rmdir()
    return found


def test_a_cache_that_cannot_be_written_is_one_line_exit_2(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    """``$PROBING_CACHE`` in ``/proc`` (or in a folder without write permission): ``run``
    ended in three chained tracebacks, ``sweep`` recorded an error per point, and ``cache
    info`` said 0 entries, exit 0.  Every command that uses the cache says it cannot be used,
    in one line, exit 2, and writes nothing."""
    caches = _unusable_caches(tmp_path)
    if not caches:
        pytest.skip("no folder here refuses new entries")
    monkeypatch.delenv("PROBING_TWIN_CACHE", raising=False)
    out = tmp_path / "out"
    scenario = ROOT / "scenarios" / "fig4" / "a_deadband.toml"
    sweep = ROOT / "scenarios" / "sweeps" / "backlash-width.toml"
    for cache in caches:
        monkeypatch.setenv("PROBING_CACHE", str(cache))
        for argv in (
            ["cache", "info"],
            ["cache", "clear", "--yes"],
            ["run", str(scenario), "--out", str(out)],
            ["sweep", str(sweep), "--out", str(out)],
            ["fig4", "--out", str(out), "--figures", str(out)],
        ):
            capsys.readouterr()
            assert cli_main(argv) == 2, argv
            captured = capsys.readouterr()
            err = captured.err.splitlines()
            assert len(err) == 1, (argv, err)
            assert err[0].startswith(f"probing: error: $PROBING_CACHE {cache} cannot be used: "), (
                err
            )
            assert f"cannot write in {cache.parent} (" in err[0], err
            assert captured.out == ""
            assert not out.exists(), argv
    (tmp_path / "locked").chmod(0o700)
