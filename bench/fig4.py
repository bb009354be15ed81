"""``make fig4`` end to end for ``make bench``: the command in a fresh process against bare
stepping of its steps and against the main before [3/6] (one load per run), with the profile
of the same runs in one process."""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from bench.common import (
    BEFORE_GROUPING,
    ROOT,
    bare_seconds_per_step,
    project_at,
    same_data,
    twin_cache_dir,
)
from bench.profiling import profile, render_profile
from bench.report import Rendered, Row
from probing.experiment.scenario import Scenario, parse_scenario


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


def run(args: argparse.Namespace) -> dict:
    """``probing fig4`` end to end in a fresh process vs bare stepping of its steps."""
    from probing.experiment.studies.fig4 import run_set

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


def render(r: dict) -> Rendered:
    """The summary row and the section's text."""
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
