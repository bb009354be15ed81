"""Step-loop efficiency for ``make bench``: a bare ``fdm.run()`` loop against ``probing run`` on
a long flight, twin simulated (an empty cache), and where the time goes (cProfile)."""

from __future__ import annotations

import argparse
import statistics
import tempfile

from bench.common import bare_loop, flight, twin_cache_dir
from bench.profiling import profile, render_profile
from bench.report import Rendered, Row
from probing.experiment.flight.run import run_scenario


def run(args: argparse.Namespace) -> dict:
    """Bare ``fdm.run()`` vs ``probing run`` on a long flight, twin simulated (cold cache)."""
    scn = flight(args.minutes, "bench-steploop")
    walls, bares, steps = [], [], 0
    for _ in range(args.repeats):  # interleaved: a noisy neighbour hits both alike
        bares.append(bare_loop(scn))
        with twin_cache_dir(), tempfile.TemporaryDirectory() as out:
            res = run_scenario(scn, out, progress=False)
        assert not res.twin_cached
        walls.append(res.wall_s)
        steps = res.steps_simulated
    n = scn.total_steps
    effs = [(steps / w) / (n / b) for w, b in zip(walls, bares, strict=True)]
    with twin_cache_dir(), tempfile.TemporaryDirectory() as out:  # where the time goes
        prof = profile(lambda: run_scenario(scn, out, progress=False))
    bare_step = statistics.median(bares) / n
    return {
        "simulated_s": n * scn.dt_s,
        "periods": scn.periods,
        "channels": list(scn.channels),
        "steps_simulated": steps,
        "bare_steps_per_s": n / statistics.median(bares),
        "probing_steps_per_s": steps / statistics.median(walls),
        "efficiency": statistics.median(effs),
        "efficiencies": effs,
        "run_wall_s": statistics.median(walls),
        "bare_us_per_step": 1e6 * bare_step,
        "profile": {**prof, "jsbsim_run_s_estimate": steps * bare_step},
    }


def render(r: dict) -> Rendered:
    """The summary row and the section's text."""
    p = r["profile"]
    steps = r["steps_simulated"]
    rows = [
        Row(
            "step-loop efficiency (`probing run` steps/s over bare `fdm.run()`)",
            f"{r['probing_steps_per_s']:.0f} steps/s",
            f"{r['bare_steps_per_s']:.0f} steps/s",
            f"{r['efficiency']:.2f}",
            ">= 0.7",
            r["efficiency"] >= 0.7,
        )
    ]
    lines = [
        f"## Step-loop efficiency ({r['simulated_s'] / 60:.0f} simulated minutes, "
        f"{len(r['channels'])} channels, twin simulated)",
        "",
        f"The default 737 scenario lengthened to {r['periods']} periods; each repeat runs a bare "
        "`fdm.run()` loop over the same number of steps on a freshly trimmed 737, then "
        "`run_scenario` with an empty twin cache (so the twin is simulated, counted and "
        f"stored). {steps} steps simulated per run (both aircraft); efficiencies of the "
        f"repeats: {', '.join(f'{e:.2f}' for e in r['efficiencies'])}. A short run before "
        "all sections pays the one-off costs of a fresh process (see the real-time factor).",
        "",
        "| quantity | value |",
        "|---|---|",
        f"| bare `fdm.run()` | {r['bare_steps_per_s']:.0f} steps/s "
        f"({r['bare_us_per_step']:.2f} us/step) |",
        f"| `probing run`, both aircraft | {r['probing_steps_per_s']:.0f} steps/s "
        f"({1e6 / r['probing_steps_per_s']:.2f} us/step) |",
        f"| efficiency (median of per-repeat ratios) | **{r['efficiency']:.2f}** |",
        "",
        f"Where the time goes: one more run under cProfile ({p['wall_s']:.2f} s wall against "
        f"{r['run_wall_s']:.2f} s without the profiler, whose overhead falls mostly on the "
        "per-step loop: read its share as an upper bound). JSBSim's Cython calls are "
        "invisible to cProfile and counted in `Plant.step`, so `run()` is estimated as the "
        "steps times the bare per-step time above and the rest of `Plant.step` is the "
        "property writes and reads and the loop.",
        "",
        *render_profile(p, steps, p["jsbsim_run_s_estimate"]),
    ]
    return Rendered(rows, lines)
