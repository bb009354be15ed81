"""Temporary files named after their writer, and the removal of those a dead writer left.

A file written under a temporary name and renamed into place once complete stays behind
when its writer is killed (``kill -9``, the machine stops): nothing else knows it is
garbage.  Its name therefore carries :func:`writer_tag`, the writer's process id and host
(``.probing.parquet.4242@node1.tmp``), and :func:`remove_dead_writers_files` removes the
temporaries of a folder whose writer is a process of this host that no longer exists.  A
live process's temporaries, this process's and another host's (a folder on a shared file
system) are never touched, so two runs at once cannot delete each other's files.

A writer that makes its folder removes what it made when it fails
(:func:`missing_folders`, :func:`remove_created`).  Whether a folder takes anything new is
tried, not guessed from its permissions (:func:`write_refusal`): root passes every
permission check, and a file system such as ``/proc`` refuses whatever they say.

Standard library, and :mod:`probing.core.forked`'s deferral of Ctrl-C.
"""

from __future__ import annotations

import errno
import os
import re
import shutil
import socket
import tempfile
from collections.abc import Sequence
from pathlib import Path

from probing.core.forked import INTERRUPTS

__all__ = [
    "missing_folders",
    "nearest_existing",
    "pid_alive",
    "remove_created",
    "remove_dead_writers_files",
    "write_refusal",
    "writer_tag",
]

_TAG = re.compile(r"^(\d+)(?:@([A-Za-z0-9-]+))?$")


def _host() -> str:
    """This host's name as it goes into a file name: letters, digits and ``-`` only."""
    return re.sub(r"[^A-Za-z0-9-]", "-", socket.gethostname()) or "host"


def writer_tag() -> str:
    """``<pid>@<host>``: this process's mark in the name of a temporary file it writes."""
    return f"{os.getpid()}@{_host()}"


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists on this host (one of another user counts)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _writer(name: str) -> tuple[int, str | None] | None:
    """(pid, host) of a temporary file's name: the first dot-separated part after the
    file's own first part that reads ``<pid>@<host>`` (or a bare ``<pid>``, as written
    before the host was part of the name); None when there is none."""
    for part in name.split(".")[2:]:
        found = _TAG.match(part)
        if found:
            return int(found.group(1)), found.group(2)
    return None


def remove_dead_writers_files(folder: Path, suffix: str, folders: bool = False) -> list[Path]:
    """Remove the temporaries in ``folder`` whose writer is dead.

    Parameters
    ----------
    folder : pathlib.Path
        The folder (a missing one holds nothing).
    suffix : str
        How the temporaries' names end (``".tmp"``, ``".tmp.npy"``); only hidden files
        (a leading dot) with a writer's tag are considered.
    folders : bool
        Also remove such folders, with what they hold (a command's staging folder,
        :func:`probing.experiment.output.staging.staged_output`).

    Returns
    -------
    list of pathlib.Path
        The files removed: those written on this host by a process other than this one
        that no longer exists.
    """
    host, me = _host(), os.getpid()
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        if not (entry.name.startswith(".") and entry.name.endswith(suffix)):
            continue
        writer = _writer(entry.name)
        if writer is None:
            continue
        pid, where = writer
        if (where is not None and where != host) or pid == me or pid_alive(pid):
            continue
        try:
            if entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
            elif folders and entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path)
                removed.append(Path(entry.path))
        except OSError:
            pass  # gone already (another process cleaned up), or not ours to remove
    return removed


def missing_folders(path: Path) -> list[Path]:
    """The folders of ``path`` (its parents and itself) that do not exist yet, outermost
    first: those a writer into ``path`` makes, to remove again (:func:`remove_created`)."""
    return [p for p in (*reversed(path.parents), path) if not p.exists()]


def remove_created(
    created: Sequence[Path], folder: Path | None = None, *, whole: bool = True
) -> None:
    """Remove ``folder`` (a command's staging or work folder, if any) and then the folders
    ``created`` for it (:func:`missing_folders`), innermost first (``whole`` False: only
    those left empty; another writer's files may be in them), with Ctrl-C deferred to the
    end (:meth:`probing.core.forked.Interrupts.deferred`): one that lands in the middle of
    it (after the work, or a second one after an error) must not leave half of it."""
    with INTERRUPTS.deferred():
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)
        for p in reversed(created):
            if whole:
                shutil.rmtree(p, ignore_errors=True)
                continue
            try:
                p.rmdir()
            except OSError:  # not empty: another writer's
                break


def nearest_existing(path: Path) -> Path:
    """``path`` or the nearest of its parents that exists (a dangling link counts: it is
    there, and nothing can be made through it)."""
    for there in (path, *path.parents):
        if there.exists() or there.is_symlink():
            return there
    return Path(path.anchor or ".")


def write_refusal(folder: Path) -> str | None:
    """Why nothing can be made in the existing folder ``folder``, or None when something can:
    a probe folder is made there and removed at once.

    Returns
    -------
    str or None
        The system's reason (``"Permission denied"``, ``"Read-only file system"``), or, for a
        folder that exists and still says "no such file" (``/proc``), that its file system
        takes nothing new there.
    """
    try:
        probe = tempfile.mkdtemp(prefix=".probing-write-test-", dir=folder)
    except OSError as exc:
        if exc.errno == errno.ENOENT and folder.is_dir():
            return "its file system takes no new files or folders there"
        return exc.strerror or exc.__class__.__name__
    os.rmdir(probe)
    return None
