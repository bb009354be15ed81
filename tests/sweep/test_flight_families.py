"""A study's references of one flight fly the aircraft once (issue [5/5]).

The monitored points of a sweep that differ only in ``output.drift`` are one flight: the first
flies, the others read its log with flight computers of their own
(:class:`probing.experiment.flight.run.Companion`).  Every file of every point must be the file
that point writes when flown alone by ``probing monitor`` (:func:`monitor_scenario`), its
footer included: here with a stuck pitch sensor, whose ``gust`` twin diverges while the flight
and the other references go on (the study's seed 9; chunks of four periods, so the flight
goes on for chunks after it).
"""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from probing.experiment.flight.batch import chunked_groups, flight_families
from probing.sweep import load_sweep, run_sweep

ROOT = Path(__file__).resolve().parents[2]
STUDY_BASE = ROOT / "scenarios" / "references" / "base.toml"
PERIODS = 100
PERIOD_STEPS = 255
#: The study's stuck pitch sensor, seed 9 (``scenarios/monitor-realisable/sensor-stuck.toml``):
#: the gust twin, fed the stuck attitude, diverges in period 95; the aircraft flies on.
SWEEP = (
    f'name = "family"\nbase = "{STUDY_BASE}"\nkind = "monitor"\n[fixed]\n'
    f'"probe.periods" = {PERIODS}\n"fault.type" = "sensor_stuck"\n'
    '"fault.channel" = "theta_rad"\n"disturbance.seed" = 9\n"fault.onset_s" = 174.584\n'
    '[grid]\n"output.drift" = ["gust", "detrend", "oracle"]\n'
)


def _sweep(tmp_path: Path, text: str = SWEEP):
    path = tmp_path / "family.toml"
    path.write_text(text)
    return load_sweep(path)


def _content(path: Path) -> tuple:
    """A Parquet file's columns, their types and values bit for bit (a NaN equals a NaN),
    and its footer (its metadata, every key)."""
    table = pq.read_table(path)
    columns = [
        (name, str(c.type), c.to_pylist() if c.type == "string" else c.to_numpy().tobytes())
        for name, c in zip(table.column_names, table.columns, strict=True)
    ]
    return columns, dict(table.schema.metadata)


@pytest.mark.jsbsim
@pytest.mark.slow
def test_references_of_one_flight_write_what_they_write_alone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import probing.experiment.flight.run as run
    from probing.experiment.flight.monitor import monitor_scenario

    monkeypatch.setattr(run, "CHUNK_STEPS", 4 * PERIOD_STEPS)
    sweep = _sweep(tmp_path)
    result = run_sweep(sweep, tmp_path / "shared", jobs=1, progress=False)
    assert result.errors == 0 and result.done == 3, result.messages
    for point in sweep.points:
        shared = tmp_path / "shared" / "family" / "points" / f"point_id={point.point_id}"
        alone = tmp_path / "alone" / point.point_id
        monitored = monitor_scenario(point.scenario, tmp_path / "alone", folder=alone)
        files = sorted(p.name for p in shared.glob("*.parquet"))
        assert files == sorted(p.name for p in alone.glob("*.parquet"))
        assert files == [
            "bounds.parquet",
            "monitor.parquet",
            "probing.parquet",
            "sensors.parquet",
        ]
        for name in files:
            assert _content(shared / name) == _content(alone / name), (point.values, name)
        record = json.loads((shared / "point.json").read_text())
        assert record["monitor"] == monitored.facts()
    records = {p.values["output.drift"]: _record(tmp_path, p.point_id) for p in sweep.points}
    ended = {drift: r["monitor"]["ended"] for drift, r in records.items()}
    assert ended["gust"] is not None and ended["gust"].startswith("the reference")
    assert ended["detrend"] is None and ended["oracle"] is None
    for point in sweep.points:  # every file says why the reading ended, as a flight's do
        folder = tmp_path / "shared" / "family" / "points" / f"point_id={point.point_id}"
        for file in folder.glob("*.parquet"):
            said = pq.read_schema(file).metadata.get(b"probing.ended")
            expected = ended[point.values["output.drift"]]
            assert (said and said.decode()) == expected, (point.values, file.name)
    # The flown point (the first, gust) counts the aircraft's steps, all of them though its
    # own reading ended early, and its twin's until then; detrend, which flies nothing, none.
    steps = {drift: r["steps_simulated"] for drift, r in records.items()}
    assert steps["detrend"] == 0, steps
    aircraft = PERIODS * PERIOD_STEPS
    assert aircraft < steps["gust"] < 2 * aircraft


def _record(tmp_path: Path, point_id: str) -> dict:
    path = tmp_path / "shared" / "family" / "points" / f"point_id={point_id}" / "point.json"
    return json.loads(path.read_text())


def test_a_flight_s_references_stay_together_in_one_chunk(tmp_path: Path) -> None:
    """Two seeds x three references on two workers: two flights of three, one per chunk, in
    the sweep's order; without sharing, six runs dealt out one by one."""
    text = SWEEP.replace('"disturbance.seed" = 9\n', "") + '"disturbance.seed" = [1, 2]\n'
    sweep = _sweep(tmp_path, text)
    scenarios = [p.scenario for p in sweep.points]
    seeds = [s.seed for s in scenarios]
    families = flight_families(scenarios, [True] * 6)
    assert [sorted({seeds[i] for i in f}) for f in families] == [[1], [2]]
    assert all(len(f) == 3 for f in families)
    assert [5] in flight_families(scenarios, [True] * 5 + [False])  # a run that flies alone
    chunks = chunked_groups(scenarios, 2, shares=[True] * 6)
    assert chunks == families
    assert chunked_groups(scenarios, 2) == [[0, 2, 4], [1, 3, 5]]


@pytest.mark.jsbsim
def test_a_companion_of_another_flight_is_refused_before_anything_runs(tmp_path: Path) -> None:
    from probing.experiment.flight.run import Companion, run_scenario

    text = SWEEP.replace('"disturbance.seed" = 9\n', "") + '"disturbance.seed" = [1, 2]\n'
    first, *others = [p.scenario for p in _sweep(tmp_path, text).points]
    other_seed = next(s for s in others if s.seed != first.seed)
    with pytest.raises(ValueError, match="same flight with another reference"):
        run_scenario(
            first,
            tmp_path / "out",
            stop_on_divergence=True,
            companions=[Companion(other_seed, tmp_path / "other")],
        )
    assert not (tmp_path / "out").exists() and not (tmp_path / "other").exists()


@pytest.mark.jsbsim
def test_a_reference_s_settings_alone_make_companions_too(tmp_path: Path) -> None:
    """Two detrend orders of one flight (Fig. 4's GTM, open loop) are one flight: the
    companion with the same drift is accepted, and each writes what it writes alone."""
    from probing.experiment.flight.run import Companion, run_scenario
    from probing.experiment.scenario import load_scenario

    base = load_scenario(ROOT / "scenarios" / "fig4" / "baseline.toml")
    first = base.replace({"output.drift": "detrend", "output.detrend_order": 1})
    second = base.replace({"output.drift": "detrend", "output.detrend_order": 2})
    options = {"progress": False, "timeseries": False, "stop_on_divergence": True}
    shared = run_scenario(
        first,
        tmp_path,
        folder=tmp_path / "one",
        companions=[Companion(second, tmp_path / "two")],
        **options,
    )
    assert [r.out_dir.name for r in (shared, *shared.companions)] == ["one", "two"]
    for scn, name in ((first, "one"), (second, "two")):
        run_scenario(scn, tmp_path, folder=tmp_path / f"alone-{name}", **options)
        for file in ("probing.parquet", "bounds.parquet"):
            alone = _content(tmp_path / f"alone-{name}" / file)
            assert _content(tmp_path / name / file) == alone, (name, file)
    assert _content(tmp_path / "one" / "bounds.parquet") != _content(
        tmp_path / "two" / "bounds.parquet"
    )
