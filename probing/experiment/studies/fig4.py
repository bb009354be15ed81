"""The runs of the paper's Fig. 4: a scenario set, a constant-offset twin and a rate-limit sweep.

A Fig. 4 set is a folder holding ``baseline.toml`` and one file per panel,
``a_deadband.toml`` .. ``g_hysteresis_relay.toml``.  :func:`run_set` runs every scenario of
the set, a constant-offset twin for the saturation panel (:func:`offset_twin`) and a
rate-limit sweep (:func:`sweep_scenarios`), skipping runs whose ``probing.parquet`` already
holds the same scenario digest (Parquet metadata key ``probing.scenario_digest``), and writes
``manifest.json`` (which run folder belongs to which panel).  The figures and the summary are
drawn from the stored Parquet by :mod:`probing.analysis.fig4`; see ``docs/fig4.md``.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from pathlib import Path

from probing.core.nonlinearities import RateLimit
from probing.experiment.flight.batch import run_grouped
from probing.experiment.flight.run import run_scenario
from probing.experiment.output.storage import read_schema, write_json_atomic
from probing.experiment.scenario import Scenario, ScenarioError, load_scenario
from probing.experiment.studies.fig4_set import (
    BASELINE,
    CHANNEL,
    OFFSET_TWIN,
    PANELS,
    SWEEP_BITS_S,
    SWEEP_PERIODS,
    SWEEP_RATIOS,
    SWEEP_SETTLE,
)
from probing.sim.fork import TrimmedAircraft, trim_spec

__all__ = [
    "BASELINE",
    "CHANNEL",
    "OFFSET_TWIN",
    "PANELS",
    "is_stored",
    "load_set",
    "offset_twin",
    "planned_runs",
    "run_missing",
    "run_set",
    "stored_digest",
    "sweep_scenarios",
]

DIGEST_KEY = b"probing.scenario_digest"
AIRCRAFT_KEY = b"probing.aircraft"


def stored_digest(folder: Path) -> str | None:
    """The scenario digest stored in ``folder/probing.parquet``, or None."""
    meta = _stored_metadata(folder)
    value = meta.get(DIGEST_KEY)
    return value.decode() if value else None


def is_stored(folder: Path, scn: Scenario) -> bool:
    """Whether ``folder`` holds this scenario's run, made with the same aircraft files,
    condition and JSBSim version (a changed model file makes a stored run stale)."""
    meta = _stored_metadata(folder)
    aircraft = meta.get(AIRCRAFT_KEY)
    return (
        stored_digest(folder) == scn.digest()
        and aircraft is not None
        and json.loads(aircraft) == trim_spec(scn.flight)
    )


def _stored_metadata(folder: Path) -> dict[bytes, bytes]:
    path = folder / "probing.parquet"
    if not path.exists() or not (folder / "timeseries.parquet").exists():
        return {}
    return read_schema(path).metadata or {}


def offset_twin(sat: Scenario) -> Scenario:
    """The saturation scenario with its probe replaced by the constant offset b~.

    A relay whose threshold lies far above the probe (90 deg) outputs its low level for every
    probe value; with low = high = b~ it is a constant b~: the same step the saturated run
    receives on average, without the probe.
    """
    _, b_t = sat.build_nonlinearity().apparent(sat.amplitude_deg)
    return sat.replace(
        {
            "name": f"{sat.name}-offset",
            "nonlinearity.type": "relay",
            "nonlinearity.threshold_deg": 90.0,
            "nonlinearity.low_deg": b_t,
            "nonlinearity.high_deg": b_t,
        }
    )


def sweep_scenarios(template: Scenario) -> list[tuple[float, float, Scenario]]:
    """(t0, ratio, scenario) of the rate-limit sweep; ratio NaN marks the baseline of a t0."""
    out = []
    a = template.amplitude_deg
    for t0 in SWEEP_BITS_S:
        common = {
            "probe.bit_duration_s": t0,
            "probe.periods": SWEEP_PERIODS,
            "probe.settle_periods": SWEEP_SETTLE,
            "output.channels": [CHANNEL],
        }
        base = template.replace(
            {**common, "name": f"{template.name}-sweep-t0-{t0:g}-none", "nonlinearity.type": "none"}
        )
        out.append((t0, math.nan, base))
        for ratio in SWEEP_RATIOS:
            rate = ratio * RateLimit.bound(a, t0)
            scn = template.replace(
                {
                    **common,
                    "name": f"{template.name}-sweep-t0-{t0:g}-r{ratio:.3f}",
                    "nonlinearity.type": "rate_limit",
                    "nonlinearity.rate_deg_s": rate,
                }
            )
            out.append((t0, ratio, scn))
    return out


def load_set(scen_dir: Path) -> dict[str, Scenario]:
    """The scenarios of a Fig. 4 set, keyed by file stem (baseline and the seven panels).

    Raises
    ------
    ScenarioError
        For a folder that is not there, a missing file or an invalid scenario.
    """
    scen_dir = Path(scen_dir)
    if not scen_dir.is_dir():
        raise ScenarioError("--scenarios", "not a folder of Fig. 4 scenarios", str(scen_dir))
    scenarios = {}
    for key in (BASELINE, *PANELS):
        path = scen_dir / f"{key}.toml"
        if not path.is_file():
            raise ScenarioError("file", f"missing (a Fig. 4 set needs {key}.toml)", str(path))
        scenarios[key] = load_scenario(path)
    return scenarios


def _plan(
    scen_dir: Path, out: Path, sweep_rate_limit: bool
) -> tuple[
    dict[str, Scenario],
    list[tuple[float, float, Scenario]],
    list[tuple[str | None, Scenario, Path]],
]:
    """The set's scenarios (with the offset twin), the rate-limit sweep's (t0, ratio,
    scenario) and every run as (panel key or None, scenario, parent folder)."""
    scenarios = load_set(scen_dir)
    scenarios[OFFSET_TWIN] = offset_twin(scenarios["b_saturation"])
    todo = sweep_scenarios(scenarios["f_rate_limit"]) if sweep_rate_limit else []
    runs: list[tuple[str | None, Scenario, Path]] = [
        (key, scn, out) for key, scn in scenarios.items()
    ]
    runs += [(None, scn, out / "rate_limit_sweep") for _, _, scn in todo]
    return scenarios, todo, runs


def planned_runs(
    scen_dir: Path, out: Path, *, sweep_rate_limit: bool = True
) -> list[tuple[Scenario, Path]]:
    """Every run :func:`run_set` makes, as (scenario, its folder), for checks before it.

    Raises
    ------
    ScenarioError
        As :func:`load_set`.
    """
    return [
        (scn, folder / scn.name) for _, scn, folder in _plan(scen_dir, out, sweep_rate_limit)[2]
    ]


def run_set(
    scen_dir: Path,
    out: Path,
    *,
    force: bool = False,
    sweep_rate_limit: bool = True,
    jobs: int | None = None,
    log: Callable[[str], object] = print,
) -> dict:
    """Run a Fig. 4 set (skipping runs already stored) and write ``out/manifest.json``.

    ``sweep_rate_limit=False`` leaves out the rate-limit sweep (and its figure).  The runs
    to do share one load and trim per flight condition and run ``jobs`` at a time (default:
    one per core) in children forked from the trimmed aircraft
    (:mod:`probing.experiment.flight.batch`); the results are the same bytes as run one by one.
    A stored ``probing.parquet`` that cannot be read raises
    :class:`probing.experiment.output.storage.StoredFileError` before anything runs (unless
    ``force``).
    """
    scenarios, todo, runs = _plan(scen_dir, out, sweep_rate_limit)
    out.mkdir(parents=True, exist_ok=True)
    walls = run_missing(runs, force, jobs or os.cpu_count() or 1)
    for key, scn, _ in runs[: len(scenarios)]:
        wall = walls.get(scn.name)
        status = f"ran in {wall:.2f} s" if wall is not None else "stored"
        log(f"  {key:<22} {scn.name:<36} {status}")
    n_ran = sum(scn.name in walls for _, _, scn in todo)
    log(f"  rate-limit sweep: {len(todo)} runs, {n_ran} simulated")
    log(f"  simulation: {sum(walls.values()):.2f} s")
    manifest = {
        "set": Path(scen_dir).resolve().name,
        "scenarios_dir": str(scen_dir),
        "panels": {k: s.name for k, s in scenarios.items()},
        "sweep": [
            {"bit_duration_s": t0, "ratio": ratio, "folder": scn.name} for t0, ratio, scn in todo
        ],
    }
    write_json_atomic(out / "manifest.json", manifest)
    return manifest


def run_missing(
    runs: list[tuple[str | None, Scenario, Path]], force: bool, jobs: int
) -> dict[str, float]:
    """Run the scenarios not stored yet (all with ``force``), grouped by trimmed state;
    scenario name -> wall time of its run (s).  The first failure is raised."""
    missing = [
        (scn, folder) for _, scn, folder in runs if force or not is_stored(folder / scn.name, scn)
    ]

    def work(item: tuple[Scenario, Path], aircraft: TrimmedAircraft | None) -> float:
        scn, folder = item
        return run_scenario(scn, folder, progress=False, aircraft=aircraft).wall_s

    walls = {}
    for i, outcome in run_grouped(missing, lambda item: item[0], work, jobs=jobs):
        walls[missing[i][0].name] = outcome.get()
    return walls
