"""Benchmarks of the testbed (``make bench``); writes docs/benchmarks.md and results/bench/.

Every figure is compared with a baseline measured in the same run (the machine is shared
and noisy, so ratios are what to read) and is a median of several repeats.  The report is
assembled from :data:`SECTIONS`: each section is one function that measures (returning a
JSON-able dict) and one that renders it (summary rows for the table at the top, and
markdown details).  Adding a section is one :class:`Section` entry.

Usage::

    python -m bench                  # everything, writes docs/benchmarks.md (make bench)
    python -m bench --quick          # smaller sizes, one repeat, prints only (smoke test)
    python -m bench --only step_loop memory
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import platform
import pstats
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import signal

from bench.common import (
    BEFORE_GROUPING,
    bare_seconds_per_step,
    child_json,
    project_at,
    same_data,
    twin_cache_dir,
)
from probing.core.correlator import StreamingCorrelator
from probing.core.prbs import mls
from probing.experiment.run import run_scenario
from probing.experiment.scenario import Scenario, load_scenario, parse_scenario
from probing.experiment.storage import provenance
from probing.sim.aircraft import jsbsim_version
from probing.sim.plant import make_plant

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_SCENARIO = ROOT / "scenarios" / "baseline-737.toml"
COMMAND = "make bench"


# ------------------------------------------------------------------------ helpers
@dataclass
class Row:
    """One line of the summary table: a measured figure against its same-run baseline."""

    quantity: str
    value: str
    baseline: str = ""
    ratio: str = ""
    target: str = ""
    met: bool | None = None


@dataclass
class Rendered:
    """A section's contribution to the report."""

    rows: list[Row] = field(default_factory=list)
    details: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class Section:
    """A benchmark: ``run(args) -> dict`` (stored in bench.json), ``render(dict) -> Rendered``."""

    key: str
    title: str
    run: Callable[[argparse.Namespace], dict]
    render: Callable[[dict], Rendered]


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


def machine() -> str:
    """CPU model, cores, OS, Python and JSBSim versions (no host name, no date)."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.machine()}, "
        f"Python {platform.python_version()}, JSBSim {jsbsim_version()}"
    )


# ------------------------------------------------------------ 1. step-loop efficiency
#: Profile categories, matched in order against "file:function" of each profiled function.
PROFILE_GROUPS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("stepping loop (JSBSim run() + property set/get)", ("plant.py:step", "'append' of 'list'")),
    ("Parquet output (pyarrow, storage)", ("pyarrow", "storage.py")),
    ("correlator (FFT overlap-add)", ("correlator.py", "scipy/fft", "pocketfft")),
    ("reference-twin cache I/O", ("twins.py", "BufferedWriter", "BufferedReader")),
    ("model load, trim, calibration", ("plant.py", "aircraft.py", "xml/etree", "ElementTree")),
    ("provenance (git revision)", ("subprocess", "selectors", "'poll'", "storage.py:git")),
)


OTHER = "other (numpy glue, noise, nonlinearity, run loop)"
STEPPING = PROFILE_GROUPS[0][0]


def profile(fn: Callable[[], object]) -> dict:
    """Run ``fn`` under cProfile: wall time, own time (tottime) per category, top functions.

    cProfile does not see JSBSim's Cython calls: ``run()`` and the property calls are
    counted in the Python function calling them (``Plant.step``, ``Plant.__init__`` for
    the model load).
    """
    profiler = cProfile.Profile()
    t0 = time.perf_counter()
    profiler.enable()
    try:
        fn()
    finally:
        profiler.disable()
    wall = time.perf_counter() - t0
    groups: dict[str, float] = {name: 0.0 for name, _ in PROFILE_GROUPS}
    groups[OTHER] = 0.0
    funcs = []
    stats = pstats.Stats(profiler).stats  # type: ignore[attr-defined]
    for (file, line, func), (_, _, tt, _, _) in stats.items():
        label = f"{file}:{func}"
        funcs.append((f"{Path(file).name}:{line}({func})" if file != "~" else func, tt))
        for name, patterns in PROFILE_GROUPS:
            if any(p in label for p in patterns):
                groups[name] += tt
                break
        else:
            groups[OTHER] += tt
    funcs.sort(key=lambda x: -x[1])
    return {"wall_s": wall, "groups_s": groups, "top": funcs[:8]}


def render_profile(p: dict, steps: int, run_s: float) -> list[str]:
    """The categories of :func:`profile`, the stepping loop split into ``run()`` and the rest.

    ``run_s`` is the estimated time in JSBSim's ``run()`` (steps times the bare per-step
    time measured in the same benchmark).
    """
    loop = p["groups_s"][STEPPING]
    run_s = min(run_s, loop)
    parts = {
        "JSBSim run() (steps x bare per-step time)": run_s,
        "property writes/reads and loop (rest of Plant.step)": loop - run_s,
    }
    parts.update({k: v for k, v in p["groups_s"].items() if k != STEPPING})
    total = sum(parts.values())
    non_bare = total - run_s
    lines = [
        "| part | s | us per simulated step | share of total | share of non-bare time |",
        "|---|---|---|---|---|",
    ]
    for name, sec in parts.items():
        nb = "" if name.startswith("JSBSim run()") else f"{100 * sec / non_bare:.0f} %"
        lines.append(
            f"| {name} | {sec:.3f} | {1e6 * sec / steps:.2f} | {100 * sec / total:.0f} % | {nb} |"
        )
    largest = sorted(
        ((sec, name) for name, sec in parts.items() if not name.startswith("JSBSim run()")),
        reverse=True,
    )[:3]
    lines += [
        "",
        "Largest parts beyond the bare `run()`: "
        + "; ".join(f"{name} {100 * sec / non_bare:.0f} %" for sec, name in largest)
        + ".",
    ]
    lines += ["", "Top functions by own time (tottime):", "", "| function | s |", "|---|---|"]
    lines += [f"| `{name}` | {tt:.3f} |" for name, tt in p["top"]]
    lines.append("")
    return lines


def bench_step_loop(args: argparse.Namespace) -> dict:
    """Bare ``fdm.run()`` vs ``probing run`` on a long flight, twin simulated (cold cache)."""
    scn = flight(args.minutes, "bench-steploop")
    walls, bares, steps = [], [], 0
    for _ in range(args.repeats):  # interleaved: a noisy neighbour hits both alike
        bares.append(bare_loop(scn))
        with twin_cache_dir(), tempfile.TemporaryDirectory() as out:
            res = run_scenario(scn, out, progress=False)
        assert not res.twin_cached
        walls.append(res.wall_s)
        steps = res.steps_simulated
    n = scn.total_steps
    effs = [(steps / w) / (n / b) for w, b in zip(walls, bares, strict=True)]
    with twin_cache_dir(), tempfile.TemporaryDirectory() as out:  # where the time goes
        prof = profile(lambda: run_scenario(scn, out, progress=False))
    bare_step = statistics.median(bares) / n
    return {
        "simulated_s": n * scn.dt_s,
        "periods": scn.periods,
        "channels": list(scn.channels),
        "steps_simulated": steps,
        "bare_steps_per_s": n / statistics.median(bares),
        "probing_steps_per_s": steps / statistics.median(walls),
        "efficiency": statistics.median(effs),
        "efficiencies": effs,
        "run_wall_s": statistics.median(walls),
        "bare_us_per_step": 1e6 * bare_step,
        "profile": {**prof, "jsbsim_run_s_estimate": steps * bare_step},
    }


def render_step_loop(r: dict) -> Rendered:
    p = r["profile"]
    steps = r["steps_simulated"]
    rows = [
        Row(
            "step-loop efficiency (`probing run` steps/s over bare `fdm.run()`)",
            f"{r['probing_steps_per_s']:.0f} steps/s",
            f"{r['bare_steps_per_s']:.0f} steps/s",
            f"{r['efficiency']:.2f}",
            ">= 0.7",
            r["efficiency"] >= 0.7,
        )
    ]
    lines = [
        f"## Step-loop efficiency ({r['simulated_s'] / 60:.0f} simulated minutes, "
        f"{len(r['channels'])} channels, twin simulated)",
        "",
        f"The default 737 scenario lengthened to {r['periods']} periods; each repeat runs a bare "
        "`fdm.run()` loop over the same number of steps on a freshly trimmed 737, then "
        "`run_scenario` with an empty twin cache (so the twin is simulated, counted and "
        f"stored). {steps} steps simulated per run (both aircraft); efficiencies of the "
        f"repeats: {', '.join(f'{e:.2f}' for e in r['efficiencies'])}. A short run before "
        "all sections pays the one-off costs of a fresh process (see the real-time factor).",
        "",
        "| quantity | value |",
        "|---|---|",
        f"| bare `fdm.run()` | {r['bare_steps_per_s']:.0f} steps/s "
        f"({r['bare_us_per_step']:.2f} us/step) |",
        f"| `probing run`, both aircraft | {r['probing_steps_per_s']:.0f} steps/s "
        f"({1e6 / r['probing_steps_per_s']:.2f} us/step) |",
        f"| efficiency (median of per-repeat ratios) | **{r['efficiency']:.2f}** |",
        "",
        f"Where the time goes: one more run under cProfile ({p['wall_s']:.2f} s wall against "
        f"{r['run_wall_s']:.2f} s without the profiler, whose overhead falls mostly on the "
        "per-step loop: read its share as an upper bound). JSBSim's Cython calls are "
        "invisible to cProfile and counted in `Plant.step`, so `run()` is estimated as the "
        "steps times the bare per-step time above and the rest of `Plant.step` is the "
        "property writes and reads and the loop.",
        "",
        *render_profile(p, steps, p["jsbsim_run_s_estimate"]),
    ]
    return Rendered(rows, lines)


# ------------------------------------------------------------------- 2. correlator
def bench_correlator(args: argparse.Namespace) -> dict:
    """StreamingCorrelator against scipy on one long stream (pushed in 20 chunks)."""
    rows = []
    rng = np.random.default_rng(0)
    n_samples = args.samples
    y = rng.standard_normal(n_samples)
    for order in (9, 12):
        sigma = mls(order)

        def ours(sigma=sigma):
            corr = StreamingCorrelator(sigma, 1.0, record=False)
            for chunk in np.array_split(y, 20):
                corr.push(chunk)

        candidates = {
            "StreamingCorrelator (20 chunks)": ours,
            "scipy.signal.correlate fft": lambda s=sigma: signal.correlate(
                y, s, mode="valid", method="fft"
            ),
            "scipy.signal.oaconvolve": lambda s=sigma: signal.oaconvolve(y, s[::-1], mode="valid"),
        }
        times = {name: median_time(fn, args.repeats) for name, fn in candidates.items()}
        base = times["scipy.signal.correlate fft"]
        for name, t in times.items():
            rows.append(
                {
                    "M": sigma.size,
                    "method": name,
                    "Msamples_per_s": n_samples / t / 1e6,
                    "speed_vs_scipy_fft": base / t,
                }
            )
    return {"samples": n_samples, "rows": rows}


def render_correlator(r: dict) -> Rendered:
    ours = next(
        x for x in r["rows"] if x["M"] == 511 and x["method"].startswith("StreamingCorrelator")
    )
    fft = next(x for x in r["rows"] if x["M"] == 511 and x["method"].endswith("fft"))
    rows = [
        Row(
            "correlator throughput, M = 511",
            f"{ours['Msamples_per_s']:.1f} M samples/s",
            f"{fft['Msamples_per_s']:.1f} (scipy fft)",
            f"{ours['speed_vs_scipy_fft']:.2f}",
            ">= 10 M/s and >= scipy fft",
            ours["Msamples_per_s"] >= 10 and ours["speed_vs_scipy_fft"] >= 1,
        )
    ]
    lines = [
        f"## Correlator throughput ({r['samples'] / 1e6:.0f} M samples, one stream pushed "
        "in 20 chunks)",
        "",
        "| M | method | M samples/s | speed vs scipy fft |",
        "|---|---|---|---|",
    ]
    for x in r["rows"]:
        lines.append(
            f"| {x['M']} | {x['method']} | {x['Msamples_per_s']:.1f} | "
            f"{x['speed_vs_scipy_fft']:.2f} |"
        )
    lines += [
        "",
        "No per-sample Python work and no per-sample allocation: each push is one batched "
        "real FFT over all blocks of the chunk. `probing run` pushes a chunk of periods "
        "(>= 8192 steps) at a time, with the FFT block sized to the chunk.",
        "",
    ]
    return Rendered(rows, lines)


# ----------------------------------------------------------------------- 3. memory
def child_flight(minutes: float) -> dict:
    """Run a flight in this process and report its peak RSS (``--child-flight``).

    ``minutes = 0`` measures the fixed footprint: the imports and two trimmed aircraft.
    """
    t0 = time.perf_counter()
    idle: list = []
    steps = 0
    if minutes > 0:
        with tempfile.TemporaryDirectory() as out:
            steps = run_scenario(flight(minutes), out, progress=False).steps_simulated
    else:
        idle = [make_plant(flight(1.0).flight) for _ in range(2)]  # both alive when measured
    return {
        "minutes": minutes,
        "steps_simulated": steps,
        "idle_aircraft": len(idle),
        "wall_s": time.perf_counter() - t0,
        "peak_rss_kib": peak_rss_kib(),
    }


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


#: Run in a fresh interpreter: import time, then the default scenario twice (twin simulated).
FIRST_RUN_CODE = """
import json, sys, tempfile, time
t0 = time.perf_counter()
from probing.experiment.run import run_scenario
from probing.experiment.scenario import load_scenario
imported = time.perf_counter() - t0
walls = []
for name in ("first", "second"):
    with tempfile.TemporaryDirectory() as out:
        scn = load_scenario(sys.argv[1]).replace(name=name)
        walls.append(run_scenario(scn, out, progress=False, twin_cache=False).wall_s)
print(json.dumps({"import_s": imported, "first_s": walls[0], "second_s": walls[1]}))
"""


def _flight_in_child(minutes: float) -> dict:
    with twin_cache_dir():
        return child_json("--child-flight", minutes)


def bench_memory(args: argparse.Namespace) -> dict:
    """Peak RSS of fresh processes flying the default scenario for two lengths."""
    short, long = args.memory_minutes
    return {
        "fixed": _flight_in_child(0),
        "short": _flight_in_child(short),
        "long": _flight_in_child(long),
    }


def render_memory(r: dict) -> Rendered:
    fixed, short, long = r["fixed"], r["short"], r["long"]
    mib = {k: v["peak_rss_kib"] / 1024 for k, v in r.items()}
    ratio = mib["long"] / mib["short"]
    rows = [
        Row(
            f"peak RSS, {long['minutes']:g}-minute flight",
            f"{mib['long']:.0f} MiB",
            f"{mib['short']:.0f} MiB ({short['minutes']:g} min)",
            f"{ratio:.2f}",
            "< 300 MB, not meaningfully larger",
            mib["long"] * 1.048576 < 300 and ratio < 1.1,
        )
    ]
    lines = [
        "## Memory (peak RSS of a fresh process, 100 Hz)",
        "",
        "`python -m bench --child-flight MINUTES`: the default scenario lengthened to MINUTES, "
        "twin simulated (empty cache), peak RSS (`VmHWM` of `/proc/self/status`) at the end "
        "of the child. (`getrusage`'s `ru_maxrss` is not used: Linux carries it over fork and "
        "exec, so every child would report the bench process's own size.)",
        "",
        "| flight | steps simulated | flight wall s | peak RSS MiB |",
        "|---|---|---|---|",
        f"| none (imports + two trimmed 737s) | 0 | {fixed['wall_s']:.1f} | {mib['fixed']:.0f} |",
        f"| {short['minutes']:g} min | {short['steps_simulated']} | {short['wall_s']:.1f} | "
        f"{mib['short']:.0f} |",
        f"| {long['minutes']:g} min | {long['steps_simulated']} | {long['wall_s']:.1f} | "
        f"{mib['long']:.0f} |",
        "",
        "Nothing grows with the flight: Parquet rows are buffered up to one row group "
        "(65536 rows) and written, the twin is written to its cache file period by period, "
        "the correlators keep one period.",
        "",
    ]
    return Rendered(rows, lines)


# -------------------------------------------------------------- 4. real-time factor
def bench_real_time(args: argparse.Namespace) -> dict:
    """Simulated seconds per wall second of the default scenario, in process and by CLI."""
    scn = load_scenario(DEFAULT_SCENARIO)
    walls, bares = [], []
    for _ in range(args.repeats):
        bares.append(bare_loop(scn))
        with twin_cache_dir(), tempfile.TemporaryDirectory() as out:
            walls.append(run_scenario(scn, out, progress=False).wall_s)
    cli, first = [], []
    for _ in range(args.repeats):
        with twin_cache_dir(), tempfile.TemporaryDirectory() as out:
            cmd = [sys.executable, "-m", "probing", "run", str(DEFAULT_SCENARIO), "--out", out]
            t0 = time.perf_counter()
            subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True)
            cli.append(time.perf_counter() - t0)
        cmd = [sys.executable, "-c", FIRST_RUN_CODE, str(DEFAULT_SCENARIO)]
        done = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True)
        first.append(json.loads(done.stdout.strip().splitlines()[-1]))
    simulated = scn.total_steps * scn.dt_s
    steps = 2 * scn.total_steps  # probed aircraft and twin
    return {
        "simulated_s": simulated,
        "steps_simulated": steps,
        "make_plant_s": median_time(lambda: make_plant(scn.flight), args.repeats),
        "provenance_s": median_time(provenance, args.repeats),
        "import_s": statistics.median(f["import_s"] for f in first),
        "first_run_s": statistics.median(f["first_s"] for f in first),
        "second_run_s": statistics.median(f["second_s"] for f in first),
        "run_wall_s": statistics.median(walls),
        "bare_wall_s": statistics.median(bares),
        "cli_wall_s": statistics.median(cli),
        "rtf": simulated / statistics.median(walls),
        "rtf_bare": simulated / (2 * statistics.median(bares)),
        "rtf_cli": simulated / statistics.median(cli),
    }


def render_real_time(r: dict) -> Rendered:
    rows = [
        Row(
            "real-time factor, default scenario (`run_scenario`, twin simulated)",
            f"{r['rtf']:.0f}x",
            f"{r['rtf_bare']:.0f}x (bare `run()` of both aircraft's steps)",
            f"{r['rtf'] / r['rtf_bare']:.2f}",
        )
    ]
    lines = [
        f"## Real-time factor (`scenarios/baseline-737.toml` as is: "
        f"{r['simulated_s']:.1f} simulated s)",
        "",
        "| how | wall s | simulated s per wall s |",
        "|---|---|---|",
        f"| bare `fdm.run()` loop, one aircraft | {r['bare_wall_s']:.3f} | "
        f"{r['simulated_s'] / r['bare_wall_s']:.0f} |",
        f"| bare `fdm.run()`, the steps of both aircraft | {2 * r['bare_wall_s']:.3f} | "
        f"{r['rtf_bare']:.0f} |",
        f"| `run_scenario` (probed + twin, Parquet) | {r['run_wall_s']:.3f} | {r['rtf']:.0f} |",
        f"| `probing run` command, fresh process | {r['cli_wall_s']:.3f} | {r['rtf_cli']:.0f} |",
        "",
        f"A run this short ({r['steps_simulated']} steps) carries fixed costs: each of the "
        f"two aircraft is loaded, trimmed and calibrated in {1e3 * r['make_plant_s']:.0f} ms, "
        f"the provenance (git revision) takes {1e3 * r['provenance_s']:.0f} ms, and the "
        "Parquet files are opened and closed. On long runs they vanish (step-loop "
        "efficiency above). "
        "The command's wall time is mostly one-off costs of a fresh process, measured in a "
        "fresh interpreter (`FIRST_RUN_CODE` in `bench/__main__.py`): importing the package "
        f"{r['import_s']:.2f} s; the first `run_scenario` {r['first_run_s']:.2f} s against "
        f"{r['second_run_s']:.2f} s for the same run again (profiled: mostly pandas, imported "
        "by pyarrow's pandas shim at the first conversion of numpy arrays to Arrow).",
        "",
    ]
    return Rendered(rows, lines)


# ----------------------------------------------------------------- twin-cache saving
def bench_twin_cache(args: argparse.Namespace) -> dict:
    """Wall of a nonlinearity point with an empty twin cache vs one holding its twin."""
    cold, warm = [], []
    widths = (0.003, 0.004)  # two points of a backlash sweep: one twin
    for _ in range(args.repeats):
        with twin_cache_dir(), tempfile.TemporaryDirectory() as out:
            nl = {"nonlinearity.type": "backlash", "nonlinearity.width_deg": widths[0]}
            a = flight(args.minutes, "bench-twin-a", **nl)
            b = a.replace({"name": "bench-twin-b", "nonlinearity.width_deg": widths[1]})
            ra = run_scenario(a, out, progress=False)
            rb = run_scenario(b, out, progress=False)
        assert not ra.twin_cached and rb.twin_cached and ra.twin_key == rb.twin_key
        cold.append(ra.wall_s)
        warm.append(rb.wall_s)
    ratios = [c / w for c, w in zip(cold, warm, strict=True)]
    return {
        "simulated_s": a.total_steps * a.dt_s,
        "cold_wall_s": statistics.median(cold),
        "warm_wall_s": statistics.median(warm),
        "speedup": statistics.median(ratios),
        "speedups": ratios,
        "steps_cold": ra.steps_simulated,
        "steps_warm": rb.steps_simulated,
    }


def render_twin_cache(r: dict) -> Rendered:
    rows = [
        Row(
            "shared reference twin: a nonlinearity point, twin cached",
            f"{r['warm_wall_s']:.2f} s",
            f"{r['cold_wall_s']:.2f} s (twin simulated)",
            f"{r['speedup']:.2f}x faster",
            "~2x",
        )
    ]
    lines = [
        f"## Reference-twin cache ({r['simulated_s'] / 60:.0f} simulated minutes, backlash)",
        "",
        "Two points of a backlash sweep (widths 0.003 and 0.004 deg) share one unprobed twin "
        "(`probing.sim.twins`): the first simulates and stores it, the second reads it back. "
        f"Steps simulated: {r['steps_cold']} vs {r['steps_warm']}; per-repeat speed-ups "
        f"{', '.join(f'{s:.2f}' for s in r['speedups'])}. The saving is below 2x because "
        "the probed aircraft's per-run costs (trim, Parquet, correlator) remain.",
        "",
    ]
    return Rendered(rows, lines)


# ------------------------------------------------------------------- 6. make fig4
def _fig4_steps(results: Path) -> tuple[dict[tuple, tuple[int, Scenario]], int, int]:
    """JSBSim steps simulated by a fig4 run per (model, condition, dt), from the Parquet.

    Each group also carries one of its scenarios, to measure the bare stepping rate on.
    Also returns the number of runs and of twins simulated (not read from the cache).
    """
    import pyarrow.parquet as pq

    steps: dict[tuple, tuple[int, Scenario]] = {}
    runs = twins = 0
    seen: set[str] = set()  # from an empty twin cache, each twin is simulated once
    for path in sorted(results.rglob("probing.parquet")):
        meta = pq.read_schema(path).metadata
        scn = parse_scenario(json.loads(meta[b"probing.scenario"]))
        twin = json.loads(meta.get(b"probing.twin", b"null"))
        simulated_twin = twin is not None and twin["key"] not in seen
        if twin is not None:
            seen.add(twin["key"])
        n = scn.total_steps * (2 if simulated_twin else 1)
        group = (scn.model, scn.altitude_ft, scn.speed_kind, scn.speed, scn.dt_s)
        steps[group] = (steps.get(group, (0, scn))[0] + n, scn)
        runs += 1
        twins += simulated_twin
    return steps, runs, twins


def _fig4_once(cwd: Path, then: Callable[[Path, str], None] | None = None) -> float:
    """Wall time of ``probing fig4 --force`` run in ``cwd`` into fresh folders and a fresh twin
    cache (s); ``then(folder, stdout)`` looks at what it wrote before the folder goes."""
    with twin_cache_dir(), tempfile.TemporaryDirectory(prefix="bench-fig4-") as tmp:
        cmd = [sys.executable, "-m", "probing", "fig4", "--force", "--out", f"{tmp}/results"]
        t0 = time.perf_counter()
        done = subprocess.run(
            [*cmd, "--figures", f"{tmp}/figures"],
            cwd=cwd,
            check=True,
            capture_output=True,
            text=True,
        )
        wall = time.perf_counter() - t0
        if then is not None:
            then(Path(tmp), done.stdout)
        return wall


def bench_fig4(args: argparse.Namespace) -> dict:
    """``probing fig4`` end to end in a fresh process vs bare stepping of its steps."""
    from probing.experiment.fig4 import run_set

    walls, sim_walls, replots, main_walls = [], [], [], []
    found: dict[str, object] = {}

    def measure(tmp: Path, stdout: str) -> None:
        sim_walls.append(float(re.search(r"simulation: ([0-9.]+) s", stdout)[1]))
        found["steps"], found["runs"], found["twins"] = _fig4_steps(tmp / "results")
        cmd = [sys.executable, "-m", "probing", "plot", "fig4", f"{tmp}/results"]
        t0 = time.perf_counter()
        subprocess.run(
            [*cmd, "--figures", f"{tmp}/replot"], cwd=ROOT, check=True, capture_output=True
        )
        replots.append(time.perf_counter() - t0)

    kept: dict[str, Path] = {}

    def keep(name: str) -> Callable[[Path, str], None]:
        def then(tmp: Path, stdout: str) -> None:  # the first repeat's runs, compared below
            if name not in kept:
                kept[name] = Path(shutil.copytree(tmp / "results", cmp_dir / name))

        return then

    def ours(tmp: Path, stdout: str) -> None:
        measure(tmp, stdout)
        keep("after")(tmp, stdout)

    with project_at(BEFORE_GROUPING) as old_tree, tempfile.TemporaryDirectory() as cmp:
        cmp_dir = Path(cmp)
        for _ in range(args.fig4_repeats):  # interleaved with the main before [3/6]
            if old_tree is not None:
                main_walls.append(_fig4_once(old_tree, keep("main")))
            walls.append(_fig4_once(ROOT, ours))
        same = same_data(kept["main"], kept["after"], "**/*.parquet") if "main" in kept else None
    steps, runs, twins = found["steps"], found["runs"], found["twins"]
    bare = 0.0
    per_group = []
    for n, scn in steps.values():
        per_step = bare_seconds_per_step(scn, 20_000, args.repeats)
        bare += n * per_step
        per_group.append({"model": scn.model, "steps": n, "bare_us_per_step": 1e6 * per_step})
    with twin_cache_dir(), tempfile.TemporaryDirectory(prefix="bench-fig4-") as tmp:
        scen_dir = ROOT / "scenarios" / "fig4"
        os.environ["PROBING_FORK"] = "0"  # in this process, where cProfile sees the runs
        try:
            prof = profile(lambda: run_set(scen_dir, Path(tmp), force=True, log=lambda *_: None))
        finally:
            os.environ.pop("PROBING_FORK", None)
    wall = statistics.median(walls)
    return {
        "wall_s": wall,
        "walls": walls,
        "main_revision": BEFORE_GROUPING,
        "main_walls": main_walls,
        "same_data_as_main": same,
        "simulation_wall_s": statistics.median(sim_walls),
        "replot_wall_s": statistics.median(replots),
        "steps": sum(n for n, _ in steps.values()),
        "runs": runs,
        "twins_simulated": twins,
        "groups": per_group,
        "bare_s": bare,
        "ratio": wall / bare,
        "profile": {**prof, "jsbsim_run_s_estimate": bare},
    }


def _gtm_xml_mb() -> float:
    return (ROOT / "aircraft" / "gtm_t2" / "gtm_t2.xml").stat().st_size / 1e6


def render_fig4(r: dict) -> Rendered:
    rows = [
        Row(
            "`make fig4` end to end (fresh process, empty twin cache)",
            f"{r['wall_s']:.1f} s",
            f"{r['bare_s']:.1f} s (bare `run()` of its {r['steps']} steps)",
            f"{r['ratio']:.2f}",
        )
    ]
    if r.get("main_walls"):
        main = statistics.median(r["main_walls"])
        rows.append(
            Row(
                "`make fig4` end to end",
                f"{r['wall_s']:.1f} s",
                f"{main:.1f} s (main before [3/6], {r['main_revision']}, same aircraft files)",
                f"{r['wall_s'] / main:.2f}",
                "< 0.5",
                r["wall_s"] / main < 0.5,
            )
        )
    groups = ", ".join(
        f"{g['model']}: {g['steps']} steps at {g['bare_us_per_step']:.2f} us" for g in r["groups"]
    )
    loads = r["runs"] + r["twins_simulated"]
    lines = [
        "## `make fig4` end to end",
        "",
        "`python -m probing fig4 --out TMP --figures TMP --force` in a fresh process with an "
        f"empty twin cache: {r['runs']} runs (panels, offset twin, rate-limit sweep) that "
        f"simulate only {r['twins_simulated']} twins between them; the aircraft is loaded "
        f"and trimmed once per flight condition, where the main before [3/6] (its code, "
        f"flying the same aircraft files) loaded it {loads} times; "
        + {
            True: "the Parquet data of every run is the same in both (checked). ",
            False: "**the Parquet data of the runs differs from that main's.** ",
            None: "",
        }[r.get("same_data_as_main")]
        + "Steps counted from the Parquet metadata of every run "
        f"(twin steps only where simulated): {groups} (bare per-step time measured here).",
        "",
        "| part | s |",
        "|---|---|",
        f"| wall, whole command (median of {len(r['walls'])}) | {r['wall_s']:.1f} |",
        f"| of which in `run_scenario` (manifest `simulation_wall_s`) | "
        f"{r['simulation_wall_s']:.1f} |",
        f"| `probing plot fig4` on the results (start-up, read, figures, summary) | "
        f"{r['replot_wall_s']:.1f} |",
        f"| bare `fdm.run()` of the same steps | {r['bare_s']:.1f} |",
        "",
        "Outside `run_scenario` the command spends its time like the replot: interpreter "
        "start-up and imports, reading the Parquet back, the figures (matplotlib) and the "
        "summary. The runs themselves are forked from one trimmed aircraft per condition, "
        'two at a time (see "Per-point cost"). For comparison, the profile of the same '
        "runs in one process, each loading its aircraft as before grouping (`PROBING_FORK=0`, "
        f"{r['profile']['wall_s']:.1f} s under cProfile): there the model load dominates, "
        f"the GTM's {_gtm_xml_mb():.1f} MB XML parsed by JSBSim for every aircraft "
        "(`Plant.__init__`):",
        "",
        *render_profile(r["profile"], r["steps"], r["profile"]["jsbsim_run_s_estimate"]),
    ]
    return Rendered(rows, lines)


# ------------------------------------------------------------- 5. sweep scaling
def bench_sweeps(args: argparse.Namespace) -> dict:
    """1 vs 2 workers and Dask on a 16-point sweep (``bench.sweep_scaling``)."""
    from bench.sweep_scaling import bench_sweep_scaling

    return bench_sweep_scaling(periods=args.sweep_periods, repeats=args.repeats)


def render_sweeps(r: dict) -> Rendered:
    from bench.sweep_scaling import render_sweep_scaling

    rows, lines = render_sweep_scaling(r)
    return Rendered([Row(**row) for row in rows], lines)


# ------------------------------------------------------------- 6. per-point cost
def bench_per_point(args: argparse.Namespace) -> dict:
    """Groups of 1, 8, 64 points before and after one trim per group (``bench.per_point``)."""
    from bench.per_point import bench_per_point as run

    return run(quick=args.quick, repeats=args.repeats)


def render_per_point(r: dict) -> Rendered:
    from bench.per_point import render_per_point as render_section

    rows, lines = render_section(r)
    return Rendered([Row(**row) for row in rows], lines)


# ------------------------------------------------------------------------ report
def bench_bias(args: argparse.Namespace) -> dict:
    """Predicted vs measured slow-mode bias (``bench.noise_bias``)."""
    from bench.noise_bias import bench_noise_bias

    return bench_noise_bias(quick=args.quick)


def render_bias(r: dict) -> Rendered:
    from bench.noise_bias import render_noise_bias

    rows, lines = render_noise_bias(r)
    return Rendered([Row(q, v, b, ratio) for q, v, b, ratio in rows], lines)


def bench_monitor(args: argparse.Namespace) -> dict:
    """The detector's cost and a long monitored flight's memory (``bench.monitor``)."""
    from bench.monitor import bench_monitor as run

    return run(quick=args.quick, repeats=args.repeats)


def render_monitor(r: dict) -> Rendered:
    from bench.monitor import render_monitor as render_section

    rows, lines = render_section(r)
    return Rendered([Row(**row) for row in rows], lines)


SECTIONS: list[Section] = [
    Section("step_loop", "Step-loop efficiency", bench_step_loop, render_step_loop),
    Section("correlator", "Correlator", bench_correlator, render_correlator),
    Section("memory", "Memory", bench_memory, render_memory),
    Section("real_time", "Real-time factor", bench_real_time, render_real_time),
    Section("twin_cache", "Reference-twin cache", bench_twin_cache, render_twin_cache),
    Section("sweep_scaling", "Sweep scaling", bench_sweeps, render_sweeps),
    Section("per_point", "Per-point cost", bench_per_point, render_per_point),
    Section("fig4", "make fig4", bench_fig4, render_fig4),
    Section("bias", "Slow-mode bias", bench_bias, render_bias),
    Section("monitor", "The monitor", bench_monitor, render_monitor),
]


def render(results: dict[str, dict], command: str, wall_s: float) -> str:
    rendered = {s.key: s.render(results[s.key]) for s in SECTIONS if s.key in results}
    lines = [
        "# Benchmarks",
        "",
        "Reproduce with `make bench` (that is `.venv/bin/python -m bench`; "
        "`python -m bench --quick` is a smoke run that writes no docs).",
        f"This report: `{command}`, {wall_s:.0f} s, on {machine()}.",
        "Every figure is compared with a baseline measured in the same run; medians of "
        "repeats. Raw numbers: `results/bench/bench.json`.",
        "",
        "| quantity | measured | same-run baseline | ratio | target | met |",
        "|---|---|---|---|---|---|",
    ]
    for r in rendered.values():
        for row in r.rows:
            met = "" if row.met is None else ("yes" if row.met else "**no**")
            lines.append(
                f"| {row.quantity} | {row.value} | {row.baseline} | {row.ratio} | "
                f"{row.target} | {met} |"
            )
    lines.append("")
    for r in rendered.values():
        lines += r.details
    return "\n".join(lines)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m bench", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, one repeat, no docs")
    parser.add_argument("--only", nargs="+", choices=[s.key for s in SECTIONS], default=None)
    parser.add_argument("--repeats", type=int, default=None, help="repeats (default 3; quick 1)")
    parser.add_argument("--samples", type=int, default=None, help="correlator stream length")
    parser.add_argument("--minutes", type=float, default=None, help="simulated min, step loop")
    parser.add_argument(
        "--memory-minutes", type=float, nargs=2, default=None, help="the two flight lengths"
    )
    parser.add_argument("--fig4-repeats", type=int, default=None)
    parser.add_argument(
        "--sweep-periods", type=int, default=None, help="probe periods per sweep point"
    )
    parser.add_argument(
        "--write", type=Path, default=None, help="report file (default docs/benchmarks.md)"
    )
    parser.add_argument("--child-flight", type=float, default=None, help=argparse.SUPPRESS)
    parser.add_argument("--child-monitor", type=float, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    quick = args.quick
    defaults = {
        "repeats": 1 if quick else 3,
        "samples": 1_000_000 if quick else 10_000_000,
        "minutes": 1.0 if quick else 10.0,
        "memory_minutes": [1.0, 3.0] if quick else [10.0, 60.0],
        "fig4_repeats": 1 if quick else 3,
        "sweep_periods": 4 if quick else 200,
    }
    for k, v in defaults.items():
        if getattr(args, k) is None:
            setattr(args, k, v)
    if args.write is None and not quick:
        args.write = ROOT / "docs" / "benchmarks.md"
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.child_flight is not None:
        print(json.dumps(child_flight(args.child_flight)))
        return 0
    if args.child_monitor is not None:
        from bench.monitor import child_monitor

        print(json.dumps(child_monitor(args.child_monitor)))
        return 0
    t0 = time.perf_counter()
    warm_up()
    results: dict[str, dict] = {}
    for section in SECTIONS:
        if args.only and section.key not in args.only:
            continue
        ts = time.perf_counter()
        print(f"bench: {section.title} ...", file=sys.stderr, flush=True)
        results[section.key] = section.run(args)
        print(f"bench: {section.title}: {time.perf_counter() - ts:.1f} s", file=sys.stderr)
    command = (
        COMMAND
        if not (args.quick or args.only)
        else "python -m bench " + " ".join(sys.argv[1:] if argv is None else argv)
    )
    text = render(results, command, time.perf_counter() - t0)
    print(text)
    raw = ROOT / "results" / "bench" / ("bench-quick.json" if args.quick else "bench.json")
    raw.parent.mkdir(parents=True, exist_ok=True)
    raw.write_text(json.dumps({"machine": machine(), **results}, indent=1, default=str))
    if args.write is not None:
        args.write.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
