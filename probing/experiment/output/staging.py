"""Putting output files into place: the files of an earlier run that new ones replace
(:func:`earlier_files`, which :func:`probing.experiment.output.storage.output_folder` removes), and
a command's whole output made in a staging folder and moved into place as its last act, so
that an interrupt at any moment leaves nothing of it (:func:`staged_output`: ``probing
analyze``, ``probing monitor --replay``)."""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TextIO

import pyarrow as pa
import pyarrow.parquet as pq

from probing.core.forked import INTERRUPTS
from probing.core.tempfiles import (
    missing_folders,
    remove_created,
    remove_dead_writers_files,
    writer_tag,
)
from probing.experiment.output.layouts import RUN_FILES

__all__ = ["DIGEST_KEY", "earlier_files", "report_removed", "staged_output", "work_folder"]

#: The key of the scenario digest a run's files carry.
DIGEST_KEY = b"probing.scenario_digest"


def _scenario_digest(path: Path) -> bytes | None:
    """The scenario digest a Parquet file of the project carries (None: none, unreadable)."""
    try:
        return (pq.read_schema(path).metadata or {}).get(DIGEST_KEY)
    except (OSError, pa.ArrowException):
        return None


def earlier_files(
    folder: Path, written: set[str], digest: bytes | None = None, adds: bool = False
) -> list[Path]:
    """The files of an earlier run in ``folder`` that the files being written replace:
    those of :data:`RUN_FILES` not among ``written`` (with ``adds``, only those of another
    scenario than ``digest``)."""
    earlier = []
    for name in RUN_FILES:
        path = folder / name
        if name in written or not path.is_file():
            continue
        if adds and digest is not None and _scenario_digest(path) == digest:
            continue  # the run these files are added to
        earlier.append(path)
    return earlier


def report_removed(path: Path, earlier: list[Path], stream: TextIO | None) -> None:
    """One line on ``stream`` (default stderr) naming the ``earlier`` files removed, if any."""
    if earlier:
        names = ", ".join(p.name for p in earlier)
        print(
            f"{path}: removed the files of an earlier run: {names}",
            file=stream or sys.stderr,
            flush=True,
        )


@contextmanager
def staged_output(path: Path, *, stream: TextIO | None = None, hold: bool = True) -> Iterator[Path]:
    """A command's whole output, made in a staging folder and moved into ``path`` as the
    command's last act: an interrupt at any moment leaves nothing of it.

    The staging folder (``path/.staged.<writer>.tmp``, made with ``path`` and its missing
    parents; a dead writer's, left by a command killed outright, is removed first) is
    yielded; the command writes every file there (through
    :func:`output_folder`, a figure, ...).  On success Ctrl-C and SIGTERM are held to the
    end of the process (:meth:`probing.core.forked.Interrupts.hold_to_the_end`: one noted
    before is raised first), the files an earlier run left in ``path`` that are not written
    now are removed (as :func:`output_folder` does), and the staged files moved into place.
    ``hold`` False leaves Ctrl-C alone (a Python session's save, which goes on after it).
    On any exception the staging folder and the folders this call created are removed.
    """
    path = Path(path)
    created = missing_folders(path)
    staging = path / f".staged.{writer_tag()}.tmp"
    if not created:
        remove_dead_writers_files(path, ".tmp", folders=True)  # a killed command's staging
    try:
        path.mkdir(parents=True, exist_ok=True)
        staging.mkdir()
        yield staging
        if hold:
            INTERRUPTS.hold_to_the_end()
    except BaseException:
        remove_created(created, staging)
        raise
    with INTERRUPTS.deferred():  # moved whole, or (hold False) not at all
        staged = sorted(p for p in staging.iterdir() if not p.name.startswith("."))
        earlier = earlier_files(path, {p.name for p in staged})
        for stale in earlier:
            stale.unlink(missing_ok=True)
        for p in staged:
            os.replace(p, path / p.name)
        shutil.rmtree(staging, ignore_errors=True)
    report_removed(path, earlier, stream)


@contextmanager
def work_folder(place: Path | None = None) -> Iterator[Path]:
    """A private folder a command's files are made in before they are read into memory
    (:func:`probing.fly`), removed at the end whatever happens.

    ``place`` None: a new folder in the system's temporary folder.  Otherwise a hidden
    folder named after its writer in ``place`` (made with its missing parents; the
    command line gives the run's own folder), so that the one a command killed outright
    left is removed by the next command into ``place``
    (:func:`probing.core.tempfiles.remove_dead_writers_files`); on an exception the
    folders this call created are removed too.
    """
    if place is None:
        with tempfile.TemporaryDirectory(prefix="probing-") as tmp:
            yield Path(tmp)
        return
    place = Path(place)
    created = missing_folders(place)
    if not created:
        remove_dead_writers_files(place, ".tmp", folders=True)
    try:
        place.mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(prefix=f".work.{writer_tag()}.", suffix=".tmp", dir=place))
    except BaseException:
        remove_created(created)
        raise
    done = False
    try:
        yield work
        done = True
    finally:
        remove_created(created, work, whole=not done)
