"""What the project keeps in its cache, and how much: sanitised aircraft and reference twins.

The cache root is :func:`probing.sim.aircraft.cache_dir` (``$PROBING_CACHE``, else
``$XDG_CACHE_HOME/probing``, by default ``~/.cache/probing``); the twins may live apart
(``$PROBING_TWIN_CACHE``, :func:`probing.sim.twins.twin_cache_dir`).  Everything in it is
made again when missing, so clearing it costs time, never results.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from probing.sim.aircraft import cache_dir
from probing.sim.errors import CacheFolderError
from probing.sim.twins import twin_cache_dir

__all__ = ["CacheFolderError", "CacheKind", "cache_kinds", "check_cache", "clear_cache"]


@dataclass(frozen=True)
class CacheKind:
    """One kind of cached entry: its name, folder, number of entries and bytes on disk."""

    name: str
    folder: Path
    entries: int
    size_bytes: int


def _folders() -> dict[str, Path]:
    """Each kind's folder: ``aircraft`` (sanitised JSBSim roots) and ``twins``."""
    return {"aircraft": cache_dir() / "jsbsim-root", "twins": twin_cache_dir()}


def check_cache() -> None:
    """Refuse, before any work, a cache that cannot be used: where it lives is resolved
    (:func:`probing.sim.aircraft.usable_folder`'s check), as every use of it does.

    A command that simulates calls it first, so that a cache it cannot use is one error
    before anything is written, not one per worker of a sweep.

    Raises
    ------
    CacheFolderError
        If the cache root or the twins' folder is not a folder, or nothing can be made in it.
    """
    _folders()


def _measure(name: str, folder: Path) -> CacheKind:
    if not folder.exists():
        return CacheKind(name, folder, 0, 0)
    if not folder.is_dir():
        raise CacheFolderError(f"cache folder {folder} is not a folder")
    try:
        if name == "twins":
            files = list(folder.glob("*.npy"))
            entries = sum(1 for p in files if not p.name.startswith("."))
        else:
            files = [p for p in folder.rglob("*") if p.is_file()]
            entries = sum(1 for p in folder.iterdir() if not p.name.startswith("."))
        size = sum(p.stat().st_size for p in files)
    except OSError as exc:
        raise CacheFolderError(f"cache folder {folder} cannot be read ({exc.strerror})") from None
    return CacheKind(name, folder, entries, size)


def cache_kinds() -> list[CacheKind]:
    """Every kind of cached entry with its folder, entries (temporaries left out) and bytes.

    Raises
    ------
    CacheFolderError
        If a folder exists but is not a folder or cannot be read.
    """
    return [_measure(name, folder) for name, folder in _folders().items()]


def clear_cache() -> list[CacheKind]:
    """Remove the cached entries: the sanitised aircraft's folder (``jsbsim-root``, a name the
    project owns) and the twins' ``.npy`` files; nothing else is touched.

    Returns
    -------
    list of CacheKind
        What was there before, as :func:`cache_kinds` measured it.

    Raises
    ------
    CacheFolderError
        If a folder is not a folder, or cannot be read or emptied (every kind is measured
        before anything is removed).
    """
    kinds = cache_kinds()
    for kind in kinds:
        if not kind.folder.exists():
            continue
        try:
            if kind.name == "twins":
                for path in kind.folder.glob("*.npy"):
                    path.unlink(missing_ok=True)
            else:
                shutil.rmtree(kind.folder)
        except OSError as exc:
            raise CacheFolderError(
                f"cache folder {kind.folder} cannot be emptied ({exc.strerror})"
            ) from None
    return kinds
