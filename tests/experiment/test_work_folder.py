"""The private folder the Python API makes a command's files in
(:func:`probing.experiment.output.staging.work_folder`): gone at the end whatever happens,
with the folders it created, and the one a killed writer left removed by the next."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from probing.core.tempfiles import writer_tag
from probing.experiment.output.staging import work_folder


def test_without_a_place_it_is_a_temporary_folder_removed_at_the_end() -> None:
    with work_folder() as work:
        (work / "probing.parquet").write_text("x")
        assert work.is_dir()
    assert not work.exists()


def test_in_a_place_it_is_hidden_named_after_its_writer_and_gone_with_the_place(
    tmp_path: Path,
) -> None:
    place = tmp_path / "out" / "run"
    with work_folder(place) as work:
        assert work.parent == place and work.name.startswith(".work.")
        assert work.name.endswith(".tmp")
        (work / "file").write_text("x")
    assert not (tmp_path / "out").exists()  # created here, left empty: removed


def test_a_place_that_existed_stays_with_what_it_holds(tmp_path: Path) -> None:
    (tmp_path / "earlier.parquet").write_text("kept")
    with work_folder(tmp_path) as work:
        pass
    assert not work.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["earlier.parquet"]


def test_on_an_exception_everything_it_created_goes(tmp_path: Path) -> None:
    place = tmp_path / "a" / "b"
    with pytest.raises(KeyboardInterrupt), work_folder(place) as work:
        (work / "partial").write_text("x")
        raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_a_dead_writers_work_folder_is_removed_and_a_live_ones_kept(tmp_path: Path) -> None:
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], text=True,
                          capture_output=True, check=True).stdout.strip()  # fmt: skip
    host = writer_tag().split("@")[1]
    stale = tmp_path / f".work.{dead}@{host}.abc.tmp"
    stale.mkdir()
    (stale / "probing.parquet").write_text("left by a kill -9")
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        kept = tmp_path / f".work.{live.pid}@{host}.abc.tmp"
        kept.mkdir()
        with work_folder(tmp_path):
            assert not stale.exists() and kept.is_dir()
    finally:
        live.kill()
        live.wait()


@pytest.mark.parametrize("fails", [False, True])
def test_a_ctrl_c_in_its_clean_up_is_raised_after_it(tmp_path, monkeypatch, fails) -> None:
    """Ctrl-C landing while the folder is being removed (after the work, or after an error)
    is raised once it is gone, with the folders made for it: it was raised inside the
    removal and left the folder behind (``probing monitor --replay`` interrupted then)."""
    real = shutil.rmtree

    def interrupted(path, *args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)
        real(path, *args, **kwargs)

    monkeypatch.setattr(shutil, "rmtree", interrupted)
    with pytest.raises(KeyboardInterrupt), work_folder(tmp_path / "out" / "run") as work:
        (work / "probing.parquet").write_text("x")
        if fails:
            raise RuntimeError("the work failed")
    assert list(tmp_path.iterdir()) == []
