"""Memory for ``make bench``: peak RSS of fresh processes flying the default scenario for two
lengths, and of one that only imports and trims (``python -m bench --child-flight MINUTES``)."""

from __future__ import annotations

import argparse
import tempfile
import time

from bench.common import child_json, flight, peak_rss_kib, twin_cache_dir
from bench.report import Rendered, Row
from probing.experiment.flight.run import run_scenario
from probing.sim.plant import make_plant


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


def _flight_in_child(minutes: float) -> dict:
    with twin_cache_dir():
        return child_json("--child-flight", minutes)


def run(args: argparse.Namespace) -> dict:
    """Peak RSS of fresh processes flying the default scenario for two lengths."""
    short, long = args.memory_minutes
    return {
        "fixed": _flight_in_child(0),
        "short": _flight_in_child(short),
        "long": _flight_in_child(long),
    }


def render(r: dict) -> Rendered:
    """The summary row and the section's text."""
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
