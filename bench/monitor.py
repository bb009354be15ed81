"""The monitor's cost for ``make bench``: the detector against the flight it watches, and the
memory of a long monitored flight.

* Cost: the study's flight (``scenarios/monitor/base.toml``: the GTM in closed loop, light
  turbulence, the nominal twin) monitored; the time spent in the monitor's per-period update
  is summed inside the run and set against the run's wall time.  As a cross-check the same
  flight without the monitor is timed, interleaved.
* Memory: peak RSS of fresh processes flying that flight monitored for 1 and 10 hours
  (``python -m bench --child-monitor HOURS``).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from bench.common import child_json, peak_rss_kib
from bench.report import Rendered, Row
from probing.experiment.flight import monitor as monitor_module
from probing.experiment.flight.monitor import monitor_scenario
from probing.experiment.flight.run import run_scenario
from probing.experiment.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parent.parent


def flight(hours: float) -> Scenario:
    """The study's healthy flight, ``hours`` long."""
    base = load_scenario(ROOT / "scenarios" / "monitor" / "base.toml")
    period_s = base.bits_per_period * base.bit_duration_s
    return base.replace({"probe.periods": max(60, round(hours * 3600 / period_s)), "name": "m"})


def _timed_monitor(scn: Scenario) -> tuple[float, float]:
    """(wall s of the monitored run, s spent in the monitor's updates and finish)."""
    spent = [0.0]
    original = monitor_module.Monitor.update

    def update(self, *args):  # the real update, timed
        t0 = time.perf_counter()
        original(self, *args)
        spent[0] += time.perf_counter() - t0

    monitor_module.Monitor.update = update
    try:
        with tempfile.TemporaryDirectory() as out:
            t0 = time.perf_counter()
            monitor_scenario(scn, out, progress=False, twin_cache=False)
            wall = time.perf_counter() - t0
    finally:
        monitor_module.Monitor.update = original
    return wall, spent[0]


def _plain(scn: Scenario) -> float:
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        run_scenario(
            scn, out, progress=False, twin_cache=False, timeseries=False, nominal_twin=True
        )
        return time.perf_counter() - t0


def child_monitor(hours: float) -> dict:
    """A monitored flight of ``hours`` in this process; its peak RSS (``--child-monitor``)."""
    scn = flight(hours)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        result = monitor_scenario(scn, out, progress=False, twin_cache=False)
    return {
        "hours": hours,
        "periods": scn.periods,
        "steps_simulated": result.run.steps_simulated,
        "wall_s": time.perf_counter() - t0,
        "peak_rss_kib": peak_rss_kib(),
    }


def bench_monitor(quick: bool = False, repeats: int = 3) -> dict:
    """Detector cost (interleaved repeats) and the memory of short and long flights."""
    scn = flight(0.05 if quick else 0.25)
    walls, spent, plain = [], [], []
    for _ in range(repeats):
        w, s = _timed_monitor(scn)
        walls.append(w)
        spent.append(s)
        plain.append(_plain(scn))
    short, long = (0.02, 0.1) if quick else (1.0, 10.0)
    return {
        "periods": scn.periods,
        "steps": scn.total_steps,
        "monitored_wall_s": walls,
        "detector_s": spent,
        "plain_wall_s": plain,
        "memory": {
            "short": child_json("--child-monitor", short),
            "long": child_json("--child-monitor", long),
        },
    }


def render_monitor(r: dict) -> tuple[list[dict], list[str]]:
    """Rows of the summary table and the section's text."""
    wall = statistics.median(r["monitored_wall_s"])
    det = statistics.median(r["detector_s"])
    plain = statistics.median(r["plain_wall_s"])
    share = det / (wall - det)
    short, long = r["memory"]["short"], r["memory"]["long"]
    mib_s, mib_l = short["peak_rss_kib"] / 1024, long["peak_rss_kib"] / 1024
    lo, hi = min(r["plain_wall_s"]), max(r["plain_wall_s"])
    inside = lo <= wall <= hi
    spread = (
        f"the difference, {wall - plain:+.2f} s, is "
        + ("within" if inside else "outside")
        + f" the repeats' scatter without the monitor, {lo:.2f}-{hi:.2f} s"
        + ("" if inside else "; the time in the detector itself is the measure")
    )
    rows = [
        {
            "quantity": "monitor: detector time / the rest of the monitored run",
            "value": f"{1e3 * det:.0f} ms",
            "baseline": f"{wall - det:.1f} s",
            "ratio": f"{100 * share:.2f} %",
            "target": "< 5 %",
            "met": share < 0.05,
        },
        {
            "quantity": f"monitor: peak RSS, {long['hours']:g} h monitored flight",
            "value": f"{mib_l:.0f} MiB",
            "baseline": f"{mib_s:.0f} MiB ({short['hours']:g} h)",
            "ratio": f"{mib_l / mib_s:.2f}",
            "target": "flat",
            "met": mib_l / mib_s < 1.1,
        },
    ]
    lines = [
        "## The monitor",
        "",
        f"The study's flight (`scenarios/monitor/base.toml`: GTM, closed loop, light turbulence, "
        f"the nominal twin simulated), {r['periods']} periods ({r['steps']} steps), medians of "
        f"{len(r['monitored_wall_s'])} interleaved repeats: the monitored run takes "
        f"{wall:.2f} s, of which {1e3 * det:.1f} ms in the detector's per-period updates "
        f"({100 * share:.2f} % of the rest); the same run without the monitor "
        f"{plain:.2f} s ({spread}). Per period the detector reduces one estimate to its "
        "windows and solves a few small quadratic forms.",
        "",
        "| monitored flight | periods | steps simulated | wall s | peak RSS MiB |",
        "|---|---|---|---|---|",
        f"| {short['hours']:g} h | {short['periods']} | {short['steps_simulated']} | "
        f"{short['wall_s']:.1f} | {mib_s:.0f} |",
        f"| {long['hours']:g} h | {long['periods']} | {long['steps_simulated']} | "
        f"{long['wall_s']:.1f} | {mib_l:.0f} |",
        "",
        "The detector keeps its baseline's mean and covariance and the last window of "
        "periods; `monitor.parquet` and `probing.parquet` are written a row group at a time, "
        "so nothing grows with the flight.",
        "",
    ]
    return rows, lines


def run(args: argparse.Namespace) -> dict:
    """The detector's cost and a long monitored flight's memory."""
    return bench_monitor(quick=args.quick, repeats=args.repeats)


def render(r: dict) -> Rendered:
    """The summary rows and the section's text."""
    rows, lines = render_monitor(r)
    return Rendered([Row(**row) for row in rows], lines)
