"""Per-point cost for ``make bench``: one load and trim per group against one per point.

*Before* is the path every run took until issue [3/6]: each point loads and trims its own
aircraft (``run_scenario`` without an aircraft, or ``PROBING_FORK=0`` for the command line).
*After* is the grouped path (:mod:`probing.experiment.flight.batch`): one load and trim per group,
one forked child per point.  Both are measured in the same run, one worker, each repeat with
a fresh twin cache (the group's one twin is simulated in both).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from bench.common import (
    BEFORE_GROUPING,
    bare_seconds_per_step,
    project_at,
    same_data,
    twin_cache_dir,
)
from bench.report import Rendered, Row
from probing.experiment.flight.batch import run_grouped
from probing.experiment.flight.run import run_scenario
from probing.experiment.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parent.parent
BASES = {
    "gtm_t2": ROOT / "scenarios" / "fig4" / "baseline.toml",
    "737": ROOT / "scenarios" / "baseline-737.toml",
}


def group(model: str, n: int) -> list[Scenario]:
    """``n`` points of one flight condition: backlash widths 0 .. (n-1) x 1e-5 deg."""
    base = load_scenario(BASES[model])
    return [
        base.replace(
            {
                "name": f"pp-{model}-{i}",
                "nonlinearity.type": "backlash",
                "nonlinearity.width_deg": 1e-5 * i,
            }
        )
        for i in range(n)
    ]


def _with_fresh_twins(fn: Callable[[Path], float]) -> tuple[float, float]:
    """Wall time of ``fn(folder)`` with a fresh twin cache and a fresh output folder (s), and
    what it returned: the summed wall time of its runs (s)."""
    with twin_cache_dir(), tempfile.TemporaryDirectory(prefix="bench-pp-") as tmp:
        t0 = time.perf_counter()
        in_runs = fn(Path(tmp))
        return time.perf_counter() - t0, in_runs


def _before(points: list[Scenario], out: Path) -> float:
    return sum(run_scenario(scn, out, progress=False).wall_s for scn in points)


def _after(points: list[Scenario], out: Path) -> float:
    def work(scn: Scenario, aircraft: object) -> float:
        return run_scenario(scn, out, progress=False, aircraft=aircraft).wall_s

    return sum(outcome.get() for _, outcome in run_grouped(points, lambda s: s, work))


def bench_groups(sizes: tuple[int, ...], repeats: int) -> dict:
    """Wall time per point, before and after, for each model and group size, against the
    bare stepping of the same steps (the points' and the one twin's).  The bare step time is
    taken afresh in every repeat, just before its two runs: the machine's speed drifts by
    tens of percent over minutes, and a ratio is only worth its same-moment baseline."""
    rows = []
    for model in BASES:
        for n in sizes:
            points = group(model, n)
            steps = sum(s.total_steps for s in points) + points[0].total_steps  # + the twin
            per_step, before, after = [], [], []
            for _ in range(repeats):  # interleaved, so drifts of the machine hit all three
                per_step.append(bare_seconds_per_step(points[0], 20_000, 1))
                before.append(_with_fresh_twins(lambda out: _before(points, out)))  # noqa: B023
                after.append(_with_fresh_twins(lambda out: _after(points, out)))  # noqa: B023
            # The repeat with the median ratio of after to stepping, with its parts.
            k = sorted(range(repeats), key=lambda i: after[i][0] / per_step[i])[repeats // 2]
            rows.append(
                {
                    "model": model,
                    "points": n,
                    "steps_per_point": points[0].total_steps,
                    "stepping_s": steps * per_step[k],
                    "points_stepping_s": (steps - points[0].total_steps) * per_step[k],
                    "before_s": before[k][0],
                    "after_s": after[k][0],
                    "after_in_runs_s": after[k][1],
                    "ratios_after_stepping": [
                        a[0] / (steps * t) for a, t in zip(after, per_step, strict=True)
                    ],
                    "speedups": [b[0] / a[0] for b, a in zip(before, after, strict=True)],
                }
            )
    return {"groups": rows}


SWEEP_CODE = 'name = "bench-gtm64"\nbase = "{base}"\n[grid]\n' + (
    '"nonlinearity.type" = ["backlash"]\n"nonlinearity.width_deg" = [{widths}]\n'
)


def bench_sweep64(repeats: int, points: int = 64, extra: int = 2) -> dict:
    """``probing sweep`` of a ``points``-point GTM sweep, one worker, fresh processes and
    folders, interleaved: the main before issue [3/6] (:data:`BEFORE_GROUPING`, its code from
    its own tree flying this checkout's aircraft files; skipped outside a git clone) and this
    code grouped, ``repeats`` pairs; this code with ``PROBING_FORK=0`` (each point loads and
    trims) in the first ``extra`` repeats.  The point files' column data is compared across
    all three."""
    walls: dict[str, list[float]] = {"main": [], "before": [], "after": []}
    with (
        tempfile.TemporaryDirectory(prefix="bench-sweep64-") as tmp,
        project_at(BEFORE_GROUPING) as old_tree,
    ):
        path = Path(tmp) / "gtm64.toml"
        widths = ", ".join(f"{1e-5 * i:.5f}" for i in range(points))
        path.write_text(SWEEP_CODE.format(base=BASES["gtm_t2"], widths=widths))
        for r in range(repeats):
            for mode in ("main", "before", "after"):
                if (mode == "main" and old_tree is None) or (mode == "before" and r >= extra):
                    continue
                out = Path(tmp) / f"{mode}-{r}"
                env = {**os.environ, "PROBING_TWIN_CACHE": str(out / "twins")}
                if mode == "before":
                    env["PROBING_FORK"] = "0"
                cmd = [sys.executable, "-m", "probing", "sweep", str(path), "--out", str(out)]
                t0 = time.perf_counter()
                done = subprocess.run(
                    [*cmd, "-j", "1"],
                    cwd=old_tree if mode == "main" else ROOT,
                    env=env,
                    capture_output=True,
                    text=True,
                )
                walls[mode].append(time.perf_counter() - t0)
                if done.returncode != 0 or f"{points} done" not in done.stdout:
                    raise RuntimeError(f"bench sweep failed: {done.stdout}{done.stderr}")
        differ = [
            mode
            for mode in ("main", "before")
            if walls[mode] and not same_data(Path(tmp) / f"{mode}-0", Path(tmp) / "after-0")
        ]
    pairs = [m / a for m, a in zip(walls["main"], walls["after"], strict=False)]
    return {
        "points": points,
        "main_revision": BEFORE_GROUPING,
        "differing_data": differ,
        "walls": walls,
        "pair_speedups": pairs,
        "speedup": statistics.median(pairs) if pairs else None,
        "main_s": statistics.median(walls["main"]) if walls["main"] else None,
        "before_s": statistics.median(walls["before"]),
        "after_s": statistics.median(walls["after"]),
    }


def _rss_kib() -> int:
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:"))


def bench_memory(points: int) -> dict:
    """The parent's RSS over a ``points``-run group (737, order 5, 2 periods)."""
    base = load_scenario(BASES["737"]).replace(
        {"probe.order": 5, "probe.periods": 2, "probe.settle_periods": 1}
    )
    scns = [base.replace({"name": f"m{i}", "disturbance.seed": i}) for i in range(points)]
    marks = {}

    def work(scn: Scenario, aircraft: object) -> None:
        run_scenario(scn, out, progress=False, aircraft=aircraft)

    with twin_cache_dir(), tempfile.TemporaryDirectory(prefix="bench-rss-") as tmp:
        out = Path(tmp)
        t0 = time.perf_counter()
        for k, (_, outcome) in enumerate(run_grouped(scns, lambda s: s, work)):
            outcome.get()
            if k + 1 in (min(50, points), points):
                marks[k + 1] = _rss_kib()
        wall = time.perf_counter() - t0
    first, last = marks[min(50, points)], marks[points]
    return {"points": points, "rss_first_kib": first, "rss_last_kib": last, "wall_s": wall}


def bench_per_point(quick: bool, repeats: int) -> dict:
    """All of it; small sizes with ``quick``."""
    sizes = (1, 8) if quick else (1, 8, 64)
    return {
        **bench_groups(sizes, repeats),
        # five pairs at least: one pair's ratio moves by +-20 % with the machine's speed
        "sweep": bench_sweep64(repeats if quick else max(repeats, 5), points=8 if quick else 64),
        "memory": bench_memory(100 if quick else 1000),
    }


def render_per_point(r: dict) -> tuple[list[dict], list[str]]:
    """Summary rows and the section's lines."""
    sweep, mem = r["sweep"], r["memory"]
    gtm = [g for g in r["groups"] if g["model"] == "gtm_t2"]
    big, one = gtm[-1], gtm[0]
    ratio = big["after_s"] / big["stepping_s"]
    marginal, own = _marginal(one, big)
    growth = (mem["rss_last_kib"] - mem["rss_first_kib"]) / 1024
    rows = [
        {
            "quantity": f"a GTM sweep point's marginal wall ({big['points']}-point group minus "
            f"{one['points']}-point, per point), one worker",
            "value": f"{marginal * 1e3:.0f} ms",
            "baseline": f"{own * 1e3:.0f} ms (bare `run()` of its {big['steps_per_point']} steps)",
            "ratio": f"{marginal / own:.2f}",
            "target": "<= 1.3",
            "met": marginal / own <= 1.3,
        },
        {
            "quantity": f"{big['points']}-point GTM group, one worker: wall over stepping",
            "value": f"{big['after_s']:.2f} s",
            "baseline": f"{big['stepping_s']:.2f} s (bare `run()` of its steps)",
            "ratio": f"{ratio:.2f}",
            "target": "<= 1.3",
            "met": ratio <= 1.3,
        },
    ]
    if sweep["main_s"] is not None:
        speed = sweep["speedup"]
        rows.append(
            {
                "quantity": f"{sweep['points']}-point GTM sweep, one worker",
                "value": f"{sweep['after_s']:.1f} s",
                "baseline": f"{sweep['main_s']:.1f} s (main before [3/6], "
                f"{sweep['main_revision']}, same aircraft files, same data)",
                "ratio": f"{speed:.2f}x faster (median of {len(sweep['pair_speedups'])} pairs)",
                "target": ">= 2x",
                "met": speed >= 2,
            }
        )
    rows += [
        {
            "quantity": f"{sweep['points']}-point GTM sweep, one worker, grouped",
            "value": f"{sweep['after_s']:.1f} s",
            "baseline": f"{sweep['before_s']:.1f} s (`PROBING_FORK=0`: a load per point)",
            "ratio": f"{sweep['before_s'] / sweep['after_s']:.2f}x faster",
        },
        {
            "quantity": f"parent RSS over a {mem['points']}-run group",
            "value": f"{mem['rss_last_kib'] / 1024:.0f} MiB",
            "baseline": f"{mem['rss_first_kib'] / 1024:.0f} MiB (after 50 runs)",
            "ratio": f"{growth:+.1f} MiB",
            "target": "flat",
            "met": growth < 5,
        },
    ]
    lines = [
        "## Per-point cost: one load and trim per group",
        "",
        "Points of one flight condition (backlash widths, the Fig. 4 GTM baseline and the "
        "default 737 scenario), one worker, a fresh twin cache each repeat, medians of "
        "interleaved repeats. *Before*: every point loads and trims its aircraft (the path of "
        "every run until issue [3/6]). *After*: one load and trim per group, one forked child "
        "per point (`probing.experiment.flight.batch`). Stepping: bare `fdm.run()` of the points' "
        "steps and the group's one twin, timed in every repeat just before its runs. The "
        "seconds are those of the repeat with the median ratio of after to stepping; the "
        "speed-up is the median of the repeats' before/after.",
        "",
        "| model | points | steps per point | stepping s | before s | after s | before/point "
        "| after/point | after / stepping | speed-up |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for g in r["groups"]:
        n = g["points"]
        lines.append(
            f"| {g['model']} | {n} | {g['steps_per_point']} | {g['stepping_s']:.2f} | "
            f"{g['before_s']:.2f} | {g['after_s']:.2f} | {g['before_s'] / n:.3f} | "
            f"{g['after_s'] / n:.3f} | {g['after_s'] / g['stepping_s']:.2f} | "
            f"{statistics.median(g['speedups']):.2f}x |"
        )
    ratios = ", ".join(f"{x:.2f}" for x in big["ratios_after_stepping"])
    lines += ["", f"After over stepping in the repeats of the largest GTM group: {ratios}.", ""]
    lines += [*_remains(big), ""]
    fmt = {k: ", ".join(f"{w:.1f}" for w in v) for k, v in sweep["walls"].items()}
    main = (
        f"the main before [3/6] ({sweep['main_revision']}, its code run from its own tree, "
        f"flying this checkout's aircraft files) {fmt['main']} s, "
        if sweep["main_s"] is not None
        else "(the main before [3/6] is not in this clone's history: not measured), "
    )
    lines += [
        f"The whole command, `probing sweep` of {sweep['points']} GTM points with `-j 1` in a "
        "fresh process (start-up, reference, twin, predictions and summary included), "
        f"interleaved: {main}grouped {fmt['after']} s, and in the first pairs this code with "
        f"`PROBING_FORK=0` {fmt['before']} s. "
        + (
            "Speed-up over that main, pair by pair (each pair run back to back, the machine's "
            "speed drifting between pairs): "
            + ", ".join(f"{x:.2f}" for x in sweep["pair_speedups"])
            + "x. "
            if sweep["pair_speedups"]
            else ""
        )
        + _same_data_line(sweep["differing_data"]),
        "",
        f"Memory: the parent of a {mem['points']}-run group (737, order 5, 2 periods, each "
        f"run a forked child; {mem['wall_s']:.1f} s) holds {mem['rss_first_kib'] / 1024:.1f} "
        f"MiB after 50 runs and {mem['rss_last_kib'] / 1024:.1f} MiB after all.",
    ]
    return rows, lines


def _same_data_line(differing: list[str]) -> str:
    """What the exact comparison of the point files found."""
    if not differing:
        return (
            "The column data of every point file is the same in all of them (checked): the "
            "main before [3/6] flies the same aircraft files, so only the code differs."
        )
    return f"**The point data differs from: {', '.join(differing)}.**"


def _marginal(one: dict, big: dict) -> tuple[float, float]:
    """A point's marginal wall (the larger group's less the smaller's, per point added) and
    the bare stepping of its own steps (s)."""
    added = big["points"] - one["points"]
    per_point = big["points_stepping_s"] / big["points"]
    return (big["after_s"] - one["after_s"]) / added, per_point


def _remains(g: dict) -> list[str]:
    """Where a large group's time goes beyond stepping, per point, and what that implies."""
    n, steps = g["points"], g["steps_per_point"]
    per_step = g["points_stepping_s"] / (n * steps)
    stepping = 1e3 * per_step * steps
    in_run = 1e3 * (g["after_in_runs_s"] - g["points_stepping_s"]) / n
    outside = 1e3 * (g["after_s"] - g["after_in_runs_s"] - per_step * steps) / n
    need = (in_run + outside) / 1e3 / (0.3 * per_step)
    return [
        f"What remains, per point of the {n}-point {g['model']} group: bare stepping "
        f"{stepping:.1f} ms; inside the run, beyond stepping, {in_run:.1f} ms (the property "
        "write and reads of each step, the nonlinearity, the correlator, the two Parquet "
        "files with their folder, and the copy-on-write page faults of a forked child, "
        "~3 us per page it writes); outside the runs "
        f"{outside:.1f} ms (fork and exit of the child, and the group's load, trim and twin "
        f"shared out). Both are fixed per point, so the ratio to stepping falls with the "
        f"point's length: within 1.3x takes points of about {need:,.0f} steps or more "
        f"(these have {steps}). A run's own work beyond stepping (its output) is the "
        "larger part and stays whatever the grouping; the grouping removed the load and "
        "trim, which was the rest.",
    ]


def run(args: argparse.Namespace) -> dict:
    """Groups of 1, 8, 64 points before and after one trim per group."""
    return bench_per_point(quick=args.quick, repeats=args.repeats)


def render(r: dict) -> Rendered:
    """The summary rows and the section's text."""
    rows, lines = render_per_point(r)
    return Rendered([Row(**row) for row in rows], lines)
