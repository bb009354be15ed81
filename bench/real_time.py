"""Real-time factor for ``make bench``: simulated seconds per wall second of the default
scenario, in this process, by the command line, and a fresh interpreter's one-off costs."""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time

from bench.common import DEFAULT_SCENARIO, ROOT, bare_loop, median_time, twin_cache_dir
from bench.report import Rendered, Row
from probing.experiment.flight.run import run_scenario
from probing.experiment.output.storage import provenance
from probing.experiment.scenario import load_scenario
from probing.sim.plant import make_plant

#: Run in a fresh interpreter: import time, then the default scenario twice (twin simulated).
FIRST_RUN_CODE = """
import json, sys, tempfile, time
t0 = time.perf_counter()
from probing.experiment.flight.run import run_scenario
from probing.experiment.scenario import load_scenario
imported = time.perf_counter() - t0
walls = []
for name in ("first", "second"):
    with tempfile.TemporaryDirectory() as out:
        scn = load_scenario(sys.argv[1]).replace(name=name)
        walls.append(run_scenario(scn, out, progress=False, twin_cache=False).wall_s)
print(json.dumps({"import_s": imported, "first_s": walls[0], "second_s": walls[1]}))
"""


def run(args: argparse.Namespace) -> dict:
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


def render(r: dict) -> Rendered:
    """The summary row and the section's text."""
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
        "fresh interpreter (`FIRST_RUN_CODE` in `bench/real_time.py`): importing the package "
        f"{r['import_s']:.2f} s; the first `run_scenario` {r['first_run_s']:.2f} s against "
        f"{r['second_run_s']:.2f} s for the same run again (profiled: mostly pandas, imported "
        "by pyarrow's pandas shim at the first conversion of numpy arrays to Arrow).",
        "",
    ]
    return Rendered(rows, lines)
