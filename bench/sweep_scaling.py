"""Sweep scaling for ``make bench``: 1 vs 2 workers on a 16-point sweep, and Dask's overhead.

Each measurement runs the real command line (``python -m probing sweep``) in a fresh process
with a fresh output folder and a fresh reference-twin cache, so every repeat does the same
work: one reference run (which simulates the shared twin) and 16 points.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench.report import Rendered, Row

ROOT = Path(__file__).resolve().parent.parent
POINTS = 16


def sweep_file(folder: Path, periods: int) -> Path:
    """A 16-point backlash sweep on the default 737 scenario, ``periods`` probe periods each."""
    widths = ", ".join(f"{0.0005 * i:g}" for i in range(POINTS))
    path = folder / "bench-scaling.toml"
    path.write_text(
        'name = "bench-scaling"\n'
        f'base = "{ROOT / "scenarios" / "baseline-737.toml"}"\n'
        f'[fixed]\n"probe.periods" = {periods}\n'
        f'[grid]\n"nonlinearity.type" = ["backlash"]\n"nonlinearity.width_deg" = [{widths}]\n'
    )
    return path


def _timed_sweep(path: Path, jobs: int, executor: str, twins: Path | None) -> float:
    """Wall time of one sweep in a fresh process and a fresh output folder.

    ``twins``: the twin cache to use; None for a fresh, empty one.
    """
    with tempfile.TemporaryDirectory(prefix="bench-sweep-") as tmp:
        cache = twins if twins is not None else Path(tmp) / "twins"
        env = {**os.environ, "PROBING_TWIN_CACHE": str(cache)}
        cmd = [sys.executable, "-m", "probing", "sweep", str(path), "--out", tmp, "-j", str(jobs)]
        cmd += ["--executor", executor]
        t0 = time.perf_counter()
        done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    if done.returncode != 0 or f"{POINTS} done" not in done.stdout:
        raise RuntimeError(f"bench sweep failed: {done.stdout}{done.stderr}")
    return wall


PREDICTION_CODE = """
import json, sys, time
from probing.sweep import load_sweep
from probing.sweep.summary import predictions
walls = []
for point in load_sweep(sys.argv[1]).points:
    t0 = time.perf_counter()
    predictions(point.scenario)
    walls.append(time.perf_counter() - t0)
print(json.dumps(walls))
"""


def _prediction_walls(path: Path) -> list[float]:
    """Wall time of each point's noise-model prediction, in order, in one fresh process (as
    one worker computes them: the first pays the aircraft's linearisation)."""
    cmd = [sys.executable, "-c", PREDICTION_CODE, str(path)]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=True)
    return json.loads(done.stdout.splitlines()[-1])


def bench_sweep_scaling(periods: int = 200, repeats: int = 3) -> dict:
    """Median wall time of the sweep with 1 and 2 local workers and with Dask (2 workers).

    Cold: every repeat starts from an empty twin cache, so the reference's twin is simulated
    (with two workers, the first point simulates it too, in parallel).  Warm: the twin is
    already cached (as when a sweep reuses a base another sweep has run).  The runs are
    interleaved so that a noisy neighbour affects all alike.
    """
    with tempfile.TemporaryDirectory(prefix="bench-sweep-file-") as tmp:
        path = sweep_file(Path(tmp), periods)
        warm_cache = Path(tmp) / "twins"
        _timed_sweep(path, 2, "local", warm_cache)  # fills the warm cache
        walls: dict[str, list[float]] = {
            k: [] for k in ("local-1", "local-2", "dask-2", "warm-local-1", "warm-local-2")
        }
        for _ in range(repeats):
            walls["local-1"].append(_timed_sweep(path, 1, "local", None))
            walls["local-2"].append(_timed_sweep(path, 2, "local", None))
            walls["dask-2"].append(_timed_sweep(path, 2, "dask", None))
            walls["warm-local-1"].append(_timed_sweep(path, 1, "local", warm_cache))
            walls["warm-local-2"].append(_timed_sweep(path, 2, "local", warm_cache))
        predicted = _prediction_walls(path)
    med = {k: statistics.median(v) for k, v in walls.items()}
    runs = POINTS + 1  # the points and their shared reference
    return {
        "points": POINTS,
        "runs": runs,
        "periods": periods,
        "repeats": repeats,
        "cpu_count": os.cpu_count(),
        "wall_s": med,
        "all_wall_s": walls,
        "speedup_2_over_1": med["local-1"] / med["local-2"],
        "speedup_2_over_1_warm": med["warm-local-1"] / med["warm-local-2"],
        "dask_overhead_s": med["dask-2"] - med["local-2"],
        "dask_overhead_per_run_s": (med["dask-2"] - med["local-2"]) / runs,
        "dask_ratio": med["dask-2"] / med["local-2"],
        "prediction_first_s": predicted[0],
        "prediction_rest_s": statistics.median(predicted[1:]),
        "prediction_total_s": sum(predicted),
    }


def render_sweep_scaling(r: dict) -> tuple[list[dict], list[str]]:
    """Summary rows (as dicts of the report's Row fields) and markdown lines."""
    w = r["wall_s"]
    rows = [
        {
            "quantity": f"sweep of {r['points']} points, 2 workers vs 1 (empty twin cache)",
            "value": f"{w['local-2']:.1f} s",
            "baseline": f"{w['local-1']:.1f} s (1 worker)",
            "ratio": f"{r['speedup_2_over_1']:.2f}x",
            "target": ">= 1.8x",
            "met": r["speedup_2_over_1"] >= 1.8,
        },
        {
            "quantity": "same, twin already cached",
            "value": f"{w['warm-local-2']:.1f} s",
            "baseline": f"{w['warm-local-1']:.1f} s (1 worker)",
            "ratio": f"{r['speedup_2_over_1_warm']:.2f}x",
            "target": ">= 1.8x",
            "met": r["speedup_2_over_1_warm"] >= 1.8,
        },
        {
            "quantity": "Dask LocalCluster (2 workers) overhead per run",
            "value": f"{1000 * r['dask_overhead_per_run_s']:.0f} ms",
            "baseline": f"{w['local-2']:.1f} s local pool",
            "ratio": f"{r['dask_ratio']:.2f}",
        },
    ]
    lines = [
        f"## Sweep scaling ({r['points']}-point backlash sweep + 1 shared reference, "
        f"{r['periods']} periods of M = 511 per run)",
        "",
        "Each figure is the real command (`python -m probing sweep`) in a fresh process and a "
        f"fresh output folder; medians of {r['repeats']} interleaved repeats on "
        f"{r['cpu_count']} cores.",
        "",
        "| executor | workers | twin cache | wall s |",
        "|---|---|---|---|",
        f"| local pool | 1 | empty | {w['local-1']:.2f} |",
        f"| local pool | 2 | empty | {w['local-2']:.2f} |",
        f"| Dask LocalCluster | 2 | empty | {w['dask-2']:.2f} |",
        f"| local pool | 1 | warm | {w['warm-local-1']:.2f} |",
        f"| local pool | 2 | warm | {w['warm-local-2']:.2f} |",
        "",
        f"- 2 workers over 1: **{r['speedup_2_over_1']:.2f}x** from an empty twin cache, "
        f"**{r['speedup_2_over_1_warm']:.2f}x** with the twin cached (target >= 1.8x).",
        "- The work is not 17 equal parts: from an empty cache the reference simulates the "
        "shared twin (two aircraft), and with two workers the first point simulates it "
        "too, in parallel, instead of idling. In units of one point, one worker does 18; "
        "two finish after 10 (2 for the first pair, then 15 points: 8 rounds), so 1.8x is "
        "the ceiling from an empty cache. With the twin cached, 17 equal runs take 9 rounds "
        "on two workers: ceiling 17/9 = 1.89x. Process start-up, imports (~0.3 s) and the "
        "summary (~0.2 s) are serial on top, and each worker's first run pays ~0.2 s of "
        "one-off costs (first model load).",
        "- Each point also computes the noise model's prediction in its worker "
        "(`probing.sweep.summary.predictions`), timed apart in one fresh process: the first "
        f"point {r['prediction_first_s']:.2f} s (the aircraft loaded, trimmed and "
        f"linearised, the step response), then {r['prediction_rest_s']:.3f} s per point "
        f"({r['prediction_total_s']:.1f} s for the {r['points']} points). Every worker "
        "pays the first-point cost once, so two workers pay it twice, in parallel.",
        f"- Dask overhead against the local pool: {r['dask_overhead_s']:.2f} s per sweep, "
        f"**{1000 * r['dask_overhead_per_run_s']:.0f} ms per run** over {r['runs']} runs "
        f"(ratio {r['dask_ratio']:.2f}); mostly starting the LocalCluster's scheduler and "
        "worker processes, which import the package afresh.",
        "",
    ]
    return rows, lines


if __name__ == "__main__":  # pragma: no cover - manual use
    _, text = render_sweep_scaling(bench_sweep_scaling())
    print("\n".join(text))


def run(args: argparse.Namespace) -> dict:
    """1 vs 2 workers and Dask on a 16-point sweep."""
    return bench_sweep_scaling(periods=args.sweep_periods, repeats=args.repeats)


def render(r: dict) -> Rendered:
    """The summary rows and the section's text."""
    rows, lines = render_sweep_scaling(r)
    return Rendered([Row(**row) for row in rows], lines)
