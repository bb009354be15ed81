"""Benchmarks of the testbed (``make bench``); writes docs/benchmarks.md.

Every figure is a median of several repeats and is compared with a baseline measured in
the same run: the machines are shared and noisy, so ratios are what to read.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy import signal

from probing.correlator import StreamingCorrelator
from probing.plant import Plant
from probing.prbs import mls
from probing.run import run_scenario
from probing.scenario import load_scenario

ROOT = Path(__file__).resolve().parent.parent


def median_time(fn: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def bench_correlator(n_samples: int, repeats: int) -> list[dict]:
    rows = []
    rng = np.random.default_rng(0)
    y = rng.standard_normal(n_samples)
    for order in (9, 12):
        sigma = mls(order)

        def ours(sigma=sigma):
            corr = StreamingCorrelator(sigma, 1.0, record=False)
            for chunk in np.array_split(y, 20):  # streamed in 20 chunks
                corr.push(chunk)

        candidates = {
            "StreamingCorrelator (20 chunks)": ours,
            "scipy.signal.correlate fft": lambda s=sigma: signal.correlate(
                y, s, mode="valid", method="fft"
            ),
            "scipy.signal.oaconvolve": lambda s=sigma: signal.oaconvolve(y, s[::-1], mode="valid"),
        }
        times = {name: median_time(fn, repeats) for name, fn in candidates.items()}
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
    return rows


def bench_step_loop(seconds: float, repeats: int) -> dict:
    """Bare fdm.run() loop vs `probing run` steps/s (twin included) on the default transport."""
    scn = load_scenario(ROOT / "scenarios" / "baseline-737.toml")
    m = scn.bits_per_period
    periods = max(2, round(seconds / (m * scn.bit_duration_s)))
    scn = scn.replace(**{"probe.periods": periods, "name": "bench-steploop"})
    plant = Plant(scn.model, scn.dt_s)
    plant.trim(scn.altitude_ft, **{scn.speed_kind: scn.speed})
    run = plant.fdm.run
    n = scn.total_steps

    def bare() -> None:
        for _ in range(n):
            run()

    t_bare = median_time(bare, repeats)
    out = ROOT / "results" / "bench"
    walls = []
    steps = 0
    for _ in range(repeats):
        res = run_scenario(scn, out, progress=False)
        walls.append(res.wall_s)
        steps = res.steps_simulated
    t_run = statistics.median(walls)
    return {
        "steps_per_run": steps,
        "bare_steps_per_s": n / t_bare,
        "probing_steps_per_s": steps / t_run,
        "efficiency": (steps / t_run) / (n / t_bare),
        "real_time_factor": scn.total_steps * scn.dt_s / t_run,
        "simulated_s": scn.total_steps * scn.dt_s,
    }


def render(corr_rows: list[dict], loop: dict, command: str) -> str:
    lines = [
        "# Benchmarks",
        "",
        f"Produced by `{command}` on {platform.node() or 'this machine'} "
        f"({platform.processor() or platform.machine()}, Python {platform.python_version()}).",
        "Medians of repeats; ratios are measured within the same run.",
        "",
        "## Correlator throughput (samples/s, one stream pushed in 20 chunks)",
        "",
        "| M | method | M samples/s | speed vs scipy fft |",
        "|---|---|---|---|",
    ]
    for r in corr_rows:
        lines.append(
            f"| {r['M']} | {r['method']} | {r['Msamples_per_s']:.1f} | "
            f"{r['speed_vs_scipy_fft']:.2f} |"
        )
    lines += [
        "",
        "Targets: >= 10 M samples/s at M = 511 and at least scipy's fft correlate.",
        "",
        "## Step loop (default 737 scenario, reference twin included)",
        "",
        "| quantity | value |",
        "|---|---|",
        f"| bare `fdm.run()` steps/s | {loop['bare_steps_per_s']:.0f} |",
        f"| `probing run` steps/s (both aircraft) | {loop['probing_steps_per_s']:.0f} |",
        f"| efficiency (probing / bare) | {loop['efficiency']:.2f} |",
        f"| real-time factor (simulated s per wall s) | {loop['real_time_factor']:.0f} |",
        f"| simulated seconds per run | {loop['simulated_s']:.0f} |",
        "",
        "Target: efficiency >= 0.7.",
        "",
    ]
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(prog="python -m bench", description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=10_000_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=60.0, help="simulated s, step loop")
    parser.add_argument("--write", type=Path, default=ROOT / "docs" / "benchmarks.md")
    args = parser.parse_args()
    corr_rows = bench_correlator(args.samples, args.repeats)
    loop = bench_step_loop(args.seconds, args.repeats)
    text = render(corr_rows, loop, "make bench")
    print(text)
    raw = ROOT / "results" / "bench" / "bench.json"
    raw.parent.mkdir(parents=True, exist_ok=True)
    raw.write_text(json.dumps({"correlator": corr_rows, "step_loop": loop}, indent=1))
    args.write.write_text(text + f"\nRaw numbers: `{raw.relative_to(ROOT)}`.\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
