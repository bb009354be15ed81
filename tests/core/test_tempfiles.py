"""Temporaries of a dead writer are removed; a live process's, this process's and another
host's are never touched."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from probing.core.tempfiles import (
    nearest_existing,
    pid_alive,
    remove_dead_writers_files,
    write_refusal,
    writer_tag,
)


def dead_pid() -> int:
    """The id of a process that has ended and been reaped."""
    proc = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        check=True,
        capture_output=True,
        text=True,
    )
    pid = int(proc.stdout)
    assert not pid_alive(pid)
    return pid


def test_only_a_dead_writers_temporaries_go(tmp_path: Path) -> None:
    host = writer_tag().split("@")[1]
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        dead = dead_pid()
        names = {
            "dead": f".probing.parquet.{dead}@{host}.tmp",
            "dead_json": f".point.json.{dead}@{host}.0123abcd.tmp",
            "dead_old_style": f".probing.parquet.{dead}.tmp",
            "live": f".probing.parquet.{live.pid}@{host}.tmp",
            "mine": f".timeseries.parquet.{writer_tag()}.tmp",
            "other_host": f".probing.parquet.{dead}@elsewhere.tmp",
            "not_hidden": f"probing.parquet.{dead}@{host}.tmp",
            "no_writer": ".probing.parquet.tmp",
            "finished": "probing.parquet",
        }
        for name in names.values():
            (tmp_path / name).write_bytes(b"x")
        removed = remove_dead_writers_files(tmp_path, ".tmp")
        gone = {"dead", "dead_json", "dead_old_style"}
        assert sorted(p.name for p in removed) == sorted(names[k] for k in gone)
        assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
            v for k, v in names.items() if k not in gone
        )
    finally:
        live.kill()
        live.wait()


def test_twin_temporaries_by_their_suffix(tmp_path: Path) -> None:
    host = writer_tag().split("@")[1]
    dead = dead_pid()
    key = "ab" * 32
    twin = tmp_path / f".{key}.{dead}@{host}.140234.0123abcd.tmp.npy"
    twin.write_bytes(b"x")
    assert remove_dead_writers_files(tmp_path, ".tmp") == []  # another suffix
    assert remove_dead_writers_files(tmp_path, ".tmp.npy") == [twin]
    assert remove_dead_writers_files(tmp_path / "missing", ".tmp") == []


def test_a_live_pid_is_alive() -> None:
    assert pid_alive(os.getpid()) and not pid_alive(0)


def test_a_dead_writers_staging_folder_goes_with_folders(tmp_path: Path) -> None:
    """A command killed outright (kill -9) leaves its staging folder: removed with
    ``folders=True`` when its writer is dead, never a live writer's; files as before."""
    host = writer_tag().split("@")[1]
    dead = dead_pid()
    stale = tmp_path / f".staged.{dead}@{host}.tmp"
    (stale / "inner").mkdir(parents=True)
    (stale / "inner" / "probing.parquet").write_bytes(b"x")
    mine = tmp_path / f".staged.{writer_tag()}.tmp"
    mine.mkdir()
    assert remove_dead_writers_files(tmp_path, ".tmp") == []  # folders only when asked
    assert remove_dead_writers_files(tmp_path, ".tmp", folders=True) == [stale]
    assert sorted(p.name for p in tmp_path.iterdir()) == [mine.name]


def test_write_refusal_tries_the_folder(tmp_path: Path) -> None:
    """A folder that takes a new entry has no refusal and keeps nothing of the try; ``/proc``
    exists and still says "no such file" to any new entry (to root too): its reason says
    the file system takes nothing new there, not that something is missing."""
    assert write_refusal(tmp_path) is None
    assert list(tmp_path.iterdir()) == []
    if Path("/proc/self").is_dir():
        assert write_refusal(Path("/proc")) == (
            "its file system takes no new files or folders there"
        )


def test_nearest_existing_is_the_path_or_a_parent(tmp_path: Path) -> None:
    assert nearest_existing(tmp_path) == tmp_path
    assert nearest_existing(tmp_path / "a" / "b") == tmp_path
    (tmp_path / "link").symlink_to(tmp_path / "nowhere")
    assert nearest_existing(tmp_path / "link" / "c") == tmp_path / "link"
