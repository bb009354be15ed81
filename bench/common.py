"""What several sections of ``make bench`` share: a fresh twin cache, bare stepping time."""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from probing.experiment.scenario import Scenario
from probing.sim.plant import make_plant

__all__ = ["bare_seconds_per_step", "twin_cache_dir"]


@contextmanager
def twin_cache_dir() -> Iterator[Path]:
    """A fresh, empty reference-twin cache for the duration of the block."""
    old = os.environ.get("PROBING_TWIN_CACHE")
    with tempfile.TemporaryDirectory(prefix="bench-twins-") as tmp:
        os.environ["PROBING_TWIN_CACHE"] = tmp
        try:
            yield Path(tmp)
        finally:
            if old is None:
                os.environ.pop("PROBING_TWIN_CACHE", None)
            else:
                os.environ["PROBING_TWIN_CACHE"] = old


def bare_seconds_per_step(scn: Scenario, steps: int, repeats: int) -> float:
    """Median time of one bare ``fdm.run()`` on a freshly trimmed plant of the scenario (s)."""
    times = []
    for _ in range(repeats):
        run = make_plant(scn.flight).fdm.run
        t0 = time.perf_counter()
        for _ in range(steps):
            run()
        times.append((time.perf_counter() - t0) / steps)
    return statistics.median(times)
