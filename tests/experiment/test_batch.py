"""Runs grouped by trimmed state: one load and trim per group, the same bytes as alone."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from conftest import base_scenario

import probing.experiment.flight.run as run_module
from probing.core.forked import forked_map
from probing.experiment.flight.batch import chunked_groups, group_indices, run_grouped
from probing.experiment.flight.run import run_scenario
from probing.experiment.scenario import Scenario, parse_scenario
from probing.sim.errors import TrimError
from probing.sim.flight import Flight
from probing.sim.fork import TrimmedAircraft, trim_key
from probing.sim.world import JSBSimWorld

pytestmark = pytest.mark.jsbsim

BASE = base_scenario(
    {
        "probe.order": 6,
        "probe.bit_duration_s": 0.02,
        "probe.amplitude_deg": 0.01,
        "probe.periods": 3,
        "probe.settle_periods": 1,
        "output.channels": ["theta_rad", "q_rad_s"],
    },
    name="b",
)


def scenario(name: str, **changes: object) -> Scenario:
    return parse_scenario(BASE).replace({"name": name, **changes})


SCENARIOS = [
    scenario("plain"),
    scenario("backlash", **{"nonlinearity.type": "backlash", "nonlinearity.width_deg": 0.004}),
    scenario(  # turbulence and seed are applied after the shared trim
        "gusty",
        **{
            "disturbance.turbulence": "moderate",
            "output.drift": "oracle",
            "disturbance.seed": 7,
            "disturbance.sensor_noise": {"theta_rad": 1e-5},
        },
    ),
    scenario("cyclic", **{"output.drift": "none", "output.estimator": "cyclic"}),
    scenario(  # a second trimmed state: another group
        "gtm",
        **{"aircraft.model": "gtm_t2", "condition.altitude_ft": 800, "condition.speed_kcas": 75},
    ),
    scenario("no-trim", **{"condition.speed_kcas": 40}),  # the 737 does not trim there
]


def test_groups_follow_what_the_trim_depends_on() -> None:
    assert group_indices(SCENARIOS) == [[0, 1, 2, 3], [4], [5]]
    assert trim_key(SCENARIOS[0].flight) == trim_key(SCENARIOS[2].flight)  # turbulence, seed
    other_dt = SCENARIOS[0].replace({"simulation.dt_s": 0.005}).flight
    assert trim_key(other_dt) != trim_key(SCENARIOS[0].flight)
    # A group of 5 on 2 workers: chunks of 3 and 2, each loading and trimming once, the runs
    # dealt out in turn (neighbours in a sweep cost alike).
    five = [SCENARIOS[0]] * 5
    assert chunked_groups(five, 2) == [[0, 2, 4], [1, 3]]
    assert chunked_groups(five, 1, largest=2) == [[0, 3], [1, 4], [2]]
    assert chunked_groups(five, 5) == [[0], [1], [2], [3], [4]]


@pytest.fixture()
def loads(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Models loaded by make_plant in a run (a forked run reports its own count)."""
    seen: list[str] = []
    real = run_module.make_plant

    def counting(flight: Flight):
        seen.append(flight.model)
        return real(flight)

    monkeypatch.setattr(run_module, "make_plant", counting)
    return seen


def test_grouped_runs_are_the_same_bytes_and_load_once(
    loads: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("PROBING_TWIN_CACHE", str(tmp_path / "twins"))  # twins stored here

    def work(scn: Scenario, aircraft: TrimmedAircraft | None) -> list[str]:
        run_scenario(scn, tmp_path / "grouped", progress=False, aircraft=aircraft)
        return list(loads)  # what this child loaded itself

    outcomes = dict(run_grouped(SCENARIOS, lambda s: s, work, jobs=2))
    assert sorted(outcomes) == list(range(len(SCENARIOS)))
    for i, scn in enumerate(SCENARIOS[:-1]):
        assert outcomes[i].get() == [], f"{scn.name} loaded its own aircraft"
    with pytest.raises(TrimError) as grouped_error:  # the failed trim, reported by the run
        outcomes[len(SCENARIOS) - 1].get()
    with pytest.raises(TrimError) as alone_error:
        run_scenario(SCENARIOS[-1], tmp_path / "alone", progress=False)
    assert str(grouped_error.value) == str(alone_error.value)

    for scn in SCENARIOS[:-1]:
        alone = run_scenario(scn, tmp_path / "alone", progress=False, twin_cache=False)
        for name in ("probing.parquet", "timeseries.parquet"):
            grouped = (tmp_path / "grouped" / scn.name / name).read_bytes()
            assert grouped == (alone.out_dir / name).read_bytes(), f"{scn.name}/{name}"


def test_the_next_chunk_of_a_group_reuses_the_trimmed_aircraft(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A sweep worker runs a large group chunk after chunk: the aircraft is loaded and
    trimmed for the first chunk only, and the later chunks' runs (forked from an aircraft
    that has served other runs) are still the bytes of runs on their own."""
    import probing.experiment.flight.batch as batch

    built: list[str] = []

    class Counting(TrimmedAircraft):
        def __init__(self, flight: Flight) -> None:
            built.append(flight.model)
            super().__init__(flight)

    monkeypatch.setattr(batch, "TrimmedAircraft", Counting)
    monkeypatch.setattr(batch, "_LAST", [])
    monkeypatch.setenv("PROBING_TWIN_CACHE", str(tmp_path / "twins"))

    def work(scn: Scenario, aircraft: TrimmedAircraft | None) -> None:
        run_scenario(scn, tmp_path / "chunks", progress=False, aircraft=aircraft)

    chunks = [
        SCENARIOS[0:2],
        SCENARIOS[2:4],
        [SCENARIOS[4]],
        [SCENARIOS[0].replace({"name": "again"})],
    ]
    for chunk in chunks:
        for _, outcome in run_grouped(chunk, lambda s: s, work):
            outcome.get()
    assert built == ["737", "gtm_t2", "737"]  # the 737 again only after the GTM's group
    for scn in SCENARIOS[2:4]:
        alone = run_scenario(scn, tmp_path / "alone", progress=False, twin_cache=False)
        for name in ("probing.parquet", "timeseries.parquet"):
            chunked = (tmp_path / "chunks" / scn.name / name).read_bytes()
            assert chunked == (alone.out_dir / name).read_bytes(), f"{scn.name}/{name}"


def test_a_trimmed_aircraft_serves_only_its_condition() -> None:
    aircraft = TrimmedAircraft(SCENARIOS[0].flight)

    def other(flight: Flight) -> None:
        aircraft.plant_for(flight)

    (outcome,) = forked_map(other, [SCENARIOS[4].flight])
    with pytest.raises(ValueError, match="not the trimmed aircraft's flight"):
        outcome.get()


def _rss_kib() -> int:
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:"))


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc")
def test_the_parent_stays_flat_over_many_children() -> None:
    import numpy as np

    aircraft = TrimmedAircraft(SCENARIOS[0].flight)

    def step(seed: int) -> float:
        plant = aircraft.plant_for(dataclasses.replace(SCENARIOS[2].flight, seed=seed))
        out = np.empty((500, 1))
        JSBSimWorld(plant).fly_commands(None, plant.channel_nodes(["theta_rad"]), out)
        return float(out[-1, 0])

    last = [o.get() for o in forked_map(step, range(40))]
    before = _rss_kib()
    last += [o.get() for o in forked_map(step, range(40, 400), 2)]
    after = _rss_kib()
    assert after - before < 2048, f"the parent grew by {after - before} KiB over 360 children"
    assert len(set(last)) > 300  # the children flew different turbulence (seeds differ)
    # and the parent itself never stepped: still at the trim
    assert aircraft.plant.fdm.get_sim_time() == pytest.approx(0.0, abs=0.05)
