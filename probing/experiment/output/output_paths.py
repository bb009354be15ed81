"""Output paths checked before any work: a folder or a file that cannot be written is
refused with an error that names the option and says why (the command line prints it as
one line, exit code 2)."""

from __future__ import annotations

import os
from pathlib import Path

from probing.core.errors import ProbingError
from probing.core.tempfiles import nearest_existing, write_refusal

__all__ = [
    "OutputFileError",
    "OutputFolderError",
    "OutputPathError",
    "check_output_file",
    "check_output_folder",
]


class OutputPathError(ProbingError, ValueError):
    """An output path that cannot be written; the message names the option and says why."""


class OutputFolderError(OutputPathError):
    """An output path that cannot be a folder we write into."""


class OutputFileError(OutputPathError):
    """An output path that cannot be a file we write."""


def _not_empty(path: str | Path, option: str, error: type[OutputPathError]) -> Path:
    """``Path(path)``; an empty string (which ``Path`` would make the current folder) is
    refused."""
    if isinstance(path, str) and not path:
        raise error(f"{option}: empty path")
    return Path(path)


def _writable_ancestor(path: Path, start: Path, option: str, error: type[OutputPathError]) -> Path:
    """The nearest existing of ``start`` and its ancestors, which must be a folder we can
    create something in (:func:`probing.core.tempfiles.write_refusal`); ``path`` is the
    output path the message names."""
    existing = nearest_existing(start)
    if not existing.is_dir():
        raise error(f"{option} {path}: is below a file ({existing})")
    reason = write_refusal(existing)
    if reason is not None:
        raise error(f"{option} {path}: cannot write in {existing} ({reason})")
    return existing


def check_output_folder(path: str | Path, option: str) -> Path:
    """Refuse, before any work, an output folder that cannot be created or written.

    Nothing is left behind: a probe folder is created in the nearest existing ancestor and
    removed at once.

    Parameters
    ----------
    path : path
        The folder (it may not exist yet).
    option : str
        The command-line option that named it, for the message (``"--out"``).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    OutputFolderError
        When ``path`` is empty, ``path`` or an ancestor is a file, or the nearest existing
        ancestor does not let us create a folder in it.
    """
    path = _not_empty(path, option, OutputFolderError)
    if path.exists() and not path.is_dir():
        raise OutputFolderError(f"{option} {path}: is a file, not a folder")
    _writable_ancestor(path, path, option, OutputFolderError)
    return path


def check_output_file(path: str | Path, option: str) -> Path:
    """Refuse, before any work, an output file that cannot be written (the folder
    :func:`check_output_folder`'s counterpart: one rule for every output file).

    Nothing is left behind: the file is not created; a probe folder is created in the
    nearest existing ancestor of its folder and removed at once.

    Parameters
    ----------
    path : path
        The file (it may not exist yet; an existing file is replaced).
    option : str
        The command-line option that named it, for the message (``"--copy-summary"``).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    OutputFileError
        When ``path`` is empty or a folder, an ancestor is a file, the nearest existing
        ancestor does not let us create anything in it, or ``path`` is a file we may not
        write.
    """
    path = _not_empty(path, option, OutputFileError)
    if path.is_dir():
        raise OutputFileError(f"{option} {path}: is a folder, not a file")
    if path.exists() and not os.access(path, os.W_OK):
        raise OutputFileError(f"{option} {path}: cannot write it (permission denied)")
    _writable_ancestor(path, path.parent, option, OutputFileError)
    return path
