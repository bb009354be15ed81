"""Benchmarks of the testbed (``make bench``); writes docs/benchmarks.md and results/bench/.

Every figure is compared with a baseline measured in the same run (the machine is shared
and noisy, so ratios are what to read) and is a median of several repeats.  The report is
assembled from :data:`SECTIONS`: each section is one module of ``bench`` with ``run(args)``,
which measures (returning a JSON-able dict), and ``render(dict)``, which renders it (summary
rows for the table at the top, and markdown details; :mod:`bench.report`).  Adding a section
is one module and one :class:`~bench.report.Section` entry.

Usage::

    python -m bench                  # everything, writes docs/benchmarks.md (make bench)
    python -m bench --quick          # smaller sizes, one repeat, prints only (smoke test)
    python -m bench --only step_loop memory
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from bench.common import ROOT, warm_up
from bench.report import Section, machine, render

COMMAND = "make bench"

#: The sections, in the report's order: key (for ``--only``), title, module of ``bench``.
SECTIONS: list[Section] = [
    Section("step_loop", "Step-loop efficiency", "step_loop"),
    Section("correlator", "Correlator", "correlator"),
    Section("memory", "Memory", "memory"),
    Section("real_time", "Real-time factor", "real_time"),
    Section("twin_cache", "Reference-twin cache", "twin_cache"),
    Section("sweep_scaling", "Sweep scaling", "sweep_scaling"),
    Section("per_point", "Per-point cost", "per_point"),
    Section("fig4", "make fig4", "fig4"),
    Section("bias", "Slow-mode bias", "noise_bias"),
    Section("monitor", "The monitor", "monitor"),
    Section("realisable", "The monitor study's flights", "realisable"),
]


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
        from bench.memory import child_flight

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
    text = render(SECTIONS, results, command, time.perf_counter() - t0)
    print(text)
    raw = ROOT / "results" / "bench" / ("bench-quick.json" if args.quick else "bench.json")
    raw.parent.mkdir(parents=True, exist_ok=True)
    raw.write_text(json.dumps({"machine": machine(), **results}, indent=1, default=str))
    if args.write is not None:
        args.write.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
