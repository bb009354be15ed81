"""What several sections of ``make bench`` share: a fresh twin cache, bare stepping time, the
default flight lengthened, peak RSS."""

from __future__ import annotations

import os
import resource
import shutil
import statistics
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from probing.experiment.flight.run import run_scenario
from probing.experiment.scenario import Scenario, load_scenario
from probing.sim.plant import make_plant

__all__ = [
    "BEFORE_GROUPING",
    "DEFAULT_SCENARIO",
    "ROOT",
    "bare_loop",
    "bare_seconds_per_step",
    "child_json",
    "flight",
    "median_time",
    "peak_rss_kib",
    "project_at",
    "same_data",
    "twin_cache_dir",
    "warm_up",
]

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_SCENARIO = ROOT / "scenarios" / "baseline-737.toml"
#: The main branch before issue [3/6] (every run loaded and trimmed its own aircraft): the
#: baseline of that issue's targets, run from its own source tree in the same venv.
BEFORE_GROUPING = "e9ba1c5"


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


def child_json(flag: str, value: float) -> dict:
    """``python -m bench FLAG VALUE`` in a fresh process: its last line of stdout, as JSON
    (a measurement that must not see this process's memory)."""
    import json
    import sys

    done = subprocess.run(
        [sys.executable, "-m", "bench", flag, str(value)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


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


@contextmanager
def project_at(revision: str) -> Iterator[Path | None]:
    """The project's code at ``revision`` in a temporary folder (``git archive``), flying this
    checkout's aircraft files, or None where the revision is not in this clone's history.

    Run ``python -m probing`` with that folder as working directory to run that version's
    code (the venv's editable install is shadowed by the working directory); nothing of
    this checkout changes.  The aircraft folder is this checkout's, so both versions fly the
    same model and their results can be compared number for number: what is measured is
    the code (a model that changed since, larger or slower, would otherwise be counted as
    the code's)."""
    with tempfile.TemporaryDirectory(prefix=f"bench-{revision}-") as tmp:
        archive = subprocess.run(
            ["git", "-C", str(ROOT), "archive", "--format=tar", revision],
            capture_output=True,
        )
        if archive.returncode != 0:
            yield None
            return
        subprocess.run(["tar", "-x", "-C", tmp], input=archive.stdout, check=True)
        shutil.rmtree(Path(tmp) / "aircraft", ignore_errors=True)
        shutil.copytree(ROOT / "aircraft", Path(tmp) / "aircraft")
        yield Path(tmp)


def same_data(a: Path, b: Path, pattern: str = "*/points/*/*.parquet") -> bool:
    """Whether two result folders hold the same files (``pattern``: by default a sweep's
    point files) with the same column data in every file (NaN equal to NaN; the metadata,
    which names the code's revision, aside)."""
    import numpy as np
    import pyarrow.parquet as pq

    files = sorted(p.relative_to(a) for p in a.glob(pattern))
    if not files or files != sorted(p.relative_to(b) for p in b.glob(pattern)):
        return False
    for name in files:
        ta, tb = pq.read_table(a / name), pq.read_table(b / name)
        if ta.schema.remove_metadata() != tb.schema.remove_metadata():
            return False
        for col in ta.column_names:
            x, y = ta.column(col).to_numpy(), tb.column(col).to_numpy()
            nan_ok = x.dtype.kind == "f"
            if x.shape != y.shape or not np.array_equal(x, y, equal_nan=nan_ok):
                return False
    return True


def median_time(fn: Callable[[], object], repeats: int) -> float:
    """Median wall time of ``fn()`` over ``repeats`` calls (s)."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def flight(minutes: float, name: str = "bench-flight", **changes: object) -> Scenario:
    """The default 737 scenario lengthened to about ``minutes`` of simulated flight."""
    scn = load_scenario(DEFAULT_SCENARIO)
    periods = max(3, round(minutes * 60.0 / (scn.bits_per_period * scn.bit_duration_s)))
    return scn.replace({"probe.periods": periods, "name": name, **changes})


def bare_loop(scn: Scenario) -> float:
    """Wall time of ``scn.total_steps`` bare ``fdm.run()`` calls on a freshly trimmed plant."""
    run = make_plant(scn.flight).fdm.run
    t0 = time.perf_counter()
    for _ in range(scn.total_steps):
        run()
    return time.perf_counter() - t0


def warm_up() -> None:
    """One short run, so that first-call costs (imports, caches) stay out of the figures."""
    with twin_cache_dir(), tempfile.TemporaryDirectory() as out:
        run_scenario(flight(0.2, "bench-warm-up"), out, progress=False)


def peak_rss_kib() -> int:
    """Peak resident set size of this process (KiB).

    ``VmHWM`` of ``/proc/self/status`` on Linux: Linux carries ``getrusage``'s
    ``ru_maxrss`` over ``fork`` and ``exec``, so a child started by a large parent would
    report the parent's size.  Elsewhere ``ru_maxrss`` (KiB on Linux, bytes on macOS).
    """
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    except OSError:
        pass
    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
