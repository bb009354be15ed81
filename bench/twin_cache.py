"""Reference-twin cache for ``make bench``: a nonlinearity point with an empty twin cache
against one whose twin is cached."""

from __future__ import annotations

import argparse
import statistics
import tempfile

from bench.common import flight, twin_cache_dir
from bench.report import Rendered, Row
from probing.experiment.flight.run import run_scenario


def run(args: argparse.Namespace) -> dict:
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


def render(r: dict) -> Rendered:
    """The summary row and the section's text."""
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
