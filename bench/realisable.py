"""The monitor study's cost for ``make bench``: a flight against the stepping of its aircraft,
and a slice of the study against the code before issue [5/5].

* A flight: the study's flight (``scenarios/references/base.toml``: the GTM at 800 ft in light
  turbulence, closed loop, NASA's T2 sensors, monitored), 100 periods, with each reference
  (``gust``: the aircraft and its gust twin; ``oracle``: the aircraft and the nominal twin
  through the same turbulence; ``detrend``: the aircraft alone), flown as a study flies it
  (a child forked from the group's trimmed aircraft, :func:`run_grouped`); its wall inside
  the child against the bare ``fdm.run()`` stepping of its aircraft (freshly trimmed, the
  same steps), measured in the same process right after.  The same code runs from this
  tree and from the tree before [5/5] (:data:`BEFORE_SPEED`), in fresh processes,
  interleaved.  This code also flies the three references as the study does, as one flight
  (:func:`probing.experiment.flight.monitor.monitor_flight`), against the stepping of the
  aircraft and both twins and against the three flights alone.
* The study: ``probing sweep`` of a slice of ``make monitor`` (case 5, two seeds, the three
  references; two workers, as ``make monitor`` runs) by this code and by the code before,
  in pairs, and their point files compared column by column.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench.common import ROOT, project_at, same_data
from bench.report import Rendered, Row

#: The main before issue [5/5] (Monte Carlo speed): its code is the "before" here.
BEFORE_SPEED = "e96f832"
#: The figures issue [5/5] started from (its own measurements and docs/benchmarks.md at
#: BEFORE_SPEED), quoted beside this run's.
PREVIOUS = (
    "a GTM sweep point's marginal wall 1.99x the bare stepping of its steps (the issue's: a "
    "48-point sweep less a 1-point one, per point), the 64-point group 1.52x; a `gust` flight "
    "of 100 periods 2.5 s against 1.39 s with the `oracle` (1.8x); `make monitor` about 45 "
    "min on two cores"
)
DRIFTS = ("gust", "oracle", "detrend")

#: One repeat of the flights, run by ``python -c`` in either tree (only what both have):
#: prints {drift: [flight wall s, bare stepping s, steps]} as JSON.
FLIGHT_CODE = """
import dataclasses, json, sys, tempfile, time
from pathlib import Path
from probing.experiment.flight.batch import run_grouped
from probing.experiment.flight.monitor import monitor_scenario
from probing.experiment.scenario import load_scenario
from probing.sim.plant import make_plant

periods = int(sys.argv[1])
base = load_scenario(Path(sys.argv[2]) / "scenarios" / "references" / "base.toml")

def bare(flight, steps, **kw):
    run = make_plant(flight, **kw).fdm.run
    t0 = time.perf_counter()
    for _ in range(steps):
        run()
    return time.perf_counter() - t0

def work(scn, aircraft):
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        monitor_scenario(scn, out, progress=False, twin_cache=False, aircraft=aircraft)
        return time.perf_counter() - t0

found = {}
for drift in sys.argv[3].split(","):
    scn = base.replace({"output.drift": drift, "probe.periods": periods, "name": "b-" + drift})
    ((_, outcome),) = list(run_grouped([scn], lambda s: s, work))
    wall, steps = outcome.get(), scn.total_steps
    floor = bare(scn.flight, steps)
    if drift == "gust":  # the gust twin: the nominal aircraft, gust-ready, in calm air
        calm = dataclasses.replace(scn.flight.nominal, turbulence="none", seed=0)
        floor += bare(calm, steps, gust_inputs=True)
    elif drift == "oracle":  # the nominal aircraft through the same turbulence
        floor += bare(scn.flight.nominal, steps)
    found[drift] = [wall, floor, steps]
if "split" in sys.argv[4:]:  # the gust flight again, its time inside JSBSim's run() summed
    import probing.sim.world as world
    inside = [0.0]
    class Timed:  # the plant's FGFDMExec, its run() timed
        def __init__(self, fdm):
            object.__setattr__(self, "fdm", fdm)
        def __getattr__(self, name):
            return getattr(self.fdm, name)
        def __getitem__(self, key):
            return self.fdm[key]
        def __setitem__(self, key, value):
            self.fdm[key] = value
        def run(self):
            t0 = time.perf_counter()
            out = self.fdm.run()
            inside[0] += time.perf_counter() - t0
            return out
    fly = world.JSBSimWorld.fly
    def timed_fly(self, *args, **kwargs):
        fdm, self.plant.fdm = self.plant.fdm, Timed(self.plant.fdm)
        try:
            return fly(self, *args, **kwargs)
        finally:
            self.plant.fdm = fdm
    world.JSBSimWorld.fly = timed_fly
    scn = base.replace({"output.drift": "gust", "probe.periods": periods, "name": "b-split"})
    def split(s, aircraft):
        wall = work(s, aircraft)
        return wall, inside[0]
    ((_, outcome),) = list(run_grouped([scn], lambda s: s, split))
    found["split"] = list(outcome.get())
if "family" in sys.argv[4:]:  # the three references as the study flies them: one flight
    from probing.experiment.flight.monitor import monitor_flight
    scns = [
        base.replace({"output.drift": d, "probe.periods": periods, "name": "b-family"})
        for d in sys.argv[3].split(",")
    ]
    def family(f, aircraft):
        with tempfile.TemporaryDirectory() as out:
            t0 = time.perf_counter()
            folders = [Path(out) / s.drift for s in f]
            monitor_flight(f, folders, progress=False, twin_cache=False, aircraft=aircraft)
            return time.perf_counter() - t0
    ((_, outcome),) = list(run_grouped([scns], lambda f: f[0], family, others=lambda f: f[1:]))
    flight, steps = scns[0].flight, scns[0].total_steps
    calm = dataclasses.replace(flight.nominal, turbulence="none", seed=0)
    floor = bare(flight, steps) + bare(calm, steps, gust_inputs=True) + bare(flight.nominal, steps)
    found["family"] = [outcome.get(), floor, steps]
print(json.dumps(found))
"""

SLICE = """name = "bench-slice"
base = "{base}"
kind = "monitor"
[fixed]
"probe.periods" = 100
"monitor.false_alarms_per_hour" = 0.025
"monitor.trajectory_false_alarms_per_hour" = 0.025
"fault.type" = "gtm_damage"
"fault.case" = 5
[grid]
"output.drift" = ["gust", "detrend", "oracle"]
[zip]
"disturbance.seed" = [1, 2]
"fault.onset_s" = [169.582, 173.728]
"""


def _flights(tree: Path, periods: int, after: bool = False) -> dict:
    """One repeat of :data:`FLIGHT_CODE` in ``tree`` (``after``: this code, which also flies
    the gust flight with ``run()`` timed and the three references as one flight)."""
    args = [str(periods), str(tree), ",".join(DRIFTS), *(["split", "family"] if after else [])]
    done = subprocess.run(
        [sys.executable, "-c", FLIGHT_CODE, *args],
        cwd=tree,
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        raise RuntimeError(f"bench flight failed in {tree}: {done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def bench_flights(periods: int, repeats: int) -> dict:
    """Each reference's flight over its stepping, this code and the code before, interleaved."""
    runs: dict[str, list[dict]] = {"after": [], "before": []}
    with project_at(BEFORE_SPEED) as old_tree:
        for _ in range(repeats):
            runs["after"].append(_flights(ROOT, periods, after=True))
            if old_tree is not None:
                runs["before"].append(_flights(old_tree, periods))
    splits = [f.pop("split") for f in runs["after"]]
    families = [(f.pop("family"), sum(f[d][0] for d in DRIFTS)) for f in runs["after"]]
    out: dict = {
        "periods": periods,
        "revision": BEFORE_SPEED,
        "drifts": {},
        # the gust flight again with JSBSim's run() timed inside it: (wall s, in run() s)
        "split": sorted(splits, key=lambda s: s[1] / s[0])[len(splits) // 2],
        # the three references as one flight: ([wall s, stepping s, steps], the three flown
        # alone in the same repeat, s), the repeat with the median ratio to its stepping
        "family": sorted(families, key=lambda f: f[0][0] / f[0][1])[len(families) // 2],
    }
    for drift in DRIFTS:
        row = {}
        for code, found in runs.items():
            if not found:
                continue
            ratios = [f[drift][0] / f[drift][1] for f in found]
            k = sorted(range(len(found)), key=lambda i: ratios[i])[len(found) // 2]
            wall, floor, steps = found[k][drift]
            row[code] = {"wall_s": wall, "bare_s": floor, "steps": steps, "ratios": ratios}
        out["drifts"][drift] = row
    return out


def _slice(tree: Path, path: Path, out: Path) -> float:
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "probing", "sweep", str(path), "--out", str(out), "-j", "2"],
        cwd=tree,
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - t0
    if done.returncode != 0 or "6 done" not in done.stdout:
        raise RuntimeError(f"bench slice failed in {tree}: {done.stdout}{done.stderr}")
    return wall


def bench_slice(repeats: int) -> dict:
    """The study's slice by this code and by the code before, in pairs (fresh processes and
    folders); the point files of the first pair compared."""
    walls: dict[str, list[float]] = {"after": [], "before": []}
    with (
        tempfile.TemporaryDirectory(prefix="bench-slice-") as tmp,
        project_at(BEFORE_SPEED) as old_tree,
    ):
        if old_tree is None:
            return {"revision": BEFORE_SPEED, "skipped": True}
        path = Path(tmp) / "slice.toml"
        path.write_text(SLICE.format(base=ROOT / "scenarios" / "references" / "base.toml"))
        for r in range(repeats):
            walls["after"].append(_slice(ROOT, path, Path(tmp) / f"after-{r}"))
            walls["before"].append(_slice(old_tree, path, Path(tmp) / f"before-{r}"))
        same = same_data(Path(tmp) / "before-0", Path(tmp) / "after-0")
    pairs = [a / b for a, b in zip(walls["after"], walls["before"], strict=True)]
    return {
        "revision": BEFORE_SPEED,
        "walls": walls,
        "pair_ratios": pairs,
        "ratio": statistics.median(pairs),
        "same_data": same,
    }


def run(args: argparse.Namespace) -> dict:
    """Measure (quick: 30 periods, one repeat, the slice once)."""
    repeats = 1 if args.quick else args.repeats
    return {
        "flights": bench_flights(64 if args.quick else 100, repeats),
        "slice": bench_slice(1 if args.quick else max(args.repeats, 3)),
    }


def _flight_rows(f: dict) -> list[Row]:
    rows = []
    names = {"gust": "its two aircraft", "oracle": "its two aircraft", "detrend": "the aircraft"}
    for drift, row in f["drifts"].items():
        after = row["after"]
        ratio = after["wall_s"] / after["bare_s"]
        before = row.get("before")
        was = f"; before [5/5] {before['wall_s'] / before['bare_s']:.2f}" if before else ""
        goal = drift == "gust"
        rows.append(
            Row(
                f"`{drift}`-reference flight, {f['periods']} periods: wall over stepping",
                f"{after['wall_s']:.2f} s",
                f"{after['bare_s']:.2f} s (bare `run()` of {names[drift]})",
                f"{ratio:.2f}{was}",
                "<= 1.15" if goal else "",
                ratio <= 1.15 if goal else None,
            )
        )
    return rows


def _family_row(f: dict) -> Row:
    """The three references of one flight, flown once, against their stepping."""
    (wall, floor, _), alone = f["family"]
    return Row(
        f"the three references of one flight ({f['periods']} periods) flown once: wall over "
        "stepping",
        f"{wall:.2f} s",
        f"{floor:.2f} s (bare `run()` of its three aircraft)",
        f"{wall / floor:.2f}; flown alone {alone:.2f} s ({wall / alone:.2f} of it)",
        "",
        None,
    )


def render(r: dict) -> Rendered:
    """Summary rows and details."""
    f, s = r["flights"], r["slice"]
    rows = [*_flight_rows(f), _family_row(f)]
    if not s.get("skipped"):
        rows.append(
            Row(
                "monitor study slice (6 points: 2 flights of 3 references, 2 workers)",
                f"{statistics.median(s['walls']['after']):.1f} s",
                f"{statistics.median(s['walls']['before']):.1f} s (main before [5/5], "
                f"{s['revision']}; same data: {'yes' if s['same_data'] else '**no**'})",
                f"{s['ratio']:.2f} (median of {len(s['pair_ratios'])} pairs)",
                "<= 0.5",
                s["ratio"] <= 0.5 and s["same_data"],
            )
        )
    lines = [
        "## The monitor study's flights",
        "",
        "The study's flight (`scenarios/references/base.toml`: GTM, 800 ft, 75 KCAS, light "
        "turbulence, pitch, bank and speed held, NASA's T2 sensors, monitored), "
        f"{f['periods']} periods, flown as a study flies it: a child forked from the group's "
        "trimmed aircraft, its wall measured inside the child. Stepping: bare `fdm.run()` of "
        "freshly trimmed copies of the aircraft it steps (the `gust` twin: the gust-ready "
        "nominal aircraft in calm air; the `oracle` twin: the nominal aircraft in the same "
        "turbulence), the same steps, in the same process right after. This code and the "
        f"code before [5/5] ({f['revision']}, its own tree, this checkout's aircraft files) "
        "in fresh processes, interleaved; the repeat with the median ratio is shown.",
        "",
        "| reference | code | flight s | stepping s | ratio | ratios of the repeats |",
        "|---|---|---|---|---|---|",
    ]
    for drift, row in f["drifts"].items():
        for code, v in row.items():
            ratios = ", ".join(f"{x:.2f}" for x in v["ratios"])
            lines.append(
                f"| `{drift}` | {code} | {v['wall_s']:.2f} | {v['bare_s']:.2f} | "
                f"{v['wall_s'] / v['bare_s']:.2f} | {ratios} |"
            )
    lines.append("")
    wall, inside = f["split"]
    lines += [
        f"Where a `gust` flight's time goes (this code, the flight again with JSBSim's `run()` "
        f"timed inside it, each call through a thin timer): {wall:.2f} s, of which "
        f"{inside:.2f} s ({100 * inside / wall:.0f} %) inside `run()` of its two aircraft and "
        f"{wall - inside:.2f} s in this project's code (the flight computer's law, the "
        "sensors, the property writes and reads of each step, the gust estimator, the "
        "estimates, the monitor and the files).",
        "",
        "The study's three references of one seed, fault and amplitude fly the aircraft "
        'once (docs/sweeps.md, "One flight, several references"): the first flies, the '
        "others read its log with flight computers of their own. Their flight (this code, "
        f"the repeat with the median ratio): {f['family'][0][0]:.2f} s against "
        f"{f['family'][0][1]:.2f} s of bare stepping of the aircraft and both twins, and "
        f"{f['family'][1]:.2f} s for the three flights above flown alone in the same repeat.",
        "",
        f"The previous figures, for comparison: {PREVIOUS}.",
        "",
    ]
    if not s.get("skipped"):
        after = ", ".join(f"{x:.1f}" for x in s["walls"]["after"])
        before = ", ".join(f"{x:.1f}" for x in s["walls"]["before"])
        lines += [
            "A slice of `make monitor` (NASA's case 5, seeds 1 and 2, the three references: "
            "6 points of 100 periods, which this code flies as 2 flights and the code before "
            "as 6), `probing sweep -j 2` in fresh processes and folders, "
            f"this code ({after} s) and the code before [5/5] ({before} s) in pairs. "
            f"The point files hold the same column data: {'yes' if s['same_data'] else 'NO'}.",
            "",
        ]
    return Rendered(rows, lines)
