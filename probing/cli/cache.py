"""``probing cache info|clear``: where the cache is, what it holds, and emptying it."""

from __future__ import annotations

import argparse

from probing.cli.common import Subcommands, UsageError, command


def _kinds(clear: bool) -> list:
    from probing.sim.cache import CacheFolderError, cache_kinds, clear_cache

    try:
        return clear_cache() if clear else cache_kinds()
    except CacheFolderError as exc:
        raise UsageError(str(exc)) from None


def _cmd_cache(args: argparse.Namespace) -> int:
    from probing.sim.aircraft import cache_dir  # a cache variable naming a file: exit 2 (main)

    if args.action == "clear" and not args.yes:
        raise UsageError("cache clear removes every cached entry: confirm with --yes")
    root = cache_dir()
    kinds = _kinds(args.action == "clear")
    verb = "removed" if args.action == "clear" else "holds"
    print(f"cache root {root} ($PROBING_CACHE)")
    for kind in kinds:
        print(
            f"{kind.name:<9} {verb} {kind.entries} entries, {kind.size_bytes} bytes: {kind.folder}"
        )
    return 0


def register(sub: Subcommands) -> None:
    """Add ``cache`` to ``sub``."""
    cache = command(
        sub,
        "cache",
        "the cache (sanitised aircraft, reference twins): where it is, what it holds, clear it",
        ["probing cache info", "probing cache clear --yes"],
    )
    cache.add_argument("action", choices=("info", "clear"), help="show or remove the entries")
    cache.add_argument("--yes", action="store_true", help="confirm clear")
    cache.set_defaults(func=_cmd_cache)
