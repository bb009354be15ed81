"""Correlator throughput for ``make bench``: :class:`StreamingCorrelator` against scipy on one
long stream pushed in 20 chunks."""

from __future__ import annotations

import argparse

import numpy as np
from scipy import signal

from bench.common import median_time
from bench.report import Rendered, Row
from probing.core.correlator import StreamingCorrelator
from probing.core.prbs import mls


def run(args: argparse.Namespace) -> dict:
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


def render(r: dict) -> Rendered:
    """The summary row and the section's text."""
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
