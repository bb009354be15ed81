"""Monitor sweeps (``kind = "monitor"``): every point a monitored flight, resumable, its
findings in the summary; validation before anything runs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from probing.experiment.scenario import ScenarioError
from probing.sweep import load_sweep, read_summary, run_sweep

BASE = Path(__file__).resolve().parents[1] / "data" / "sweeps" / "base-gtm-monitor.toml"


def write(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "m.toml"
    path.write_text(f'name = "mon"\nbase = "{BASE}"\n{body}')
    return path


@pytest.mark.jsbsim
def test_a_monitor_sweep_records_each_flights_findings_and_resumes(tmp_path):
    """Two flights with a dead band onset (a~/a = 0.6) at different times and seeds: both
    found within 4 periods of their onset and called actuator faults; no reference runs; a
    rerun skips."""
    path = write(
        tmp_path,
        'kind = "monitor"\n[fixed]\n"fault.type" = "nonlinearity"\n'
        '"fault.nonlinearity" = "deadband"\n"fault.lower_deg" = -0.08\n'
        '"fault.upper_deg" = 0.08\n[zip]\n"disturbance.seed" = [1, 2]\n'
        '"fault.onset_s" = [22.0, 25.5]\n',
    )
    sweep = load_sweep(path)
    result = run_sweep(sweep, tmp_path / "out", jobs=1, progress=False)
    assert (result.done, result.references) == (2, 0)
    summary = read_summary(tmp_path / "out" / "mon")
    for row in summary.itertuples():
        assert row.fault_type == "nonlinearity" and row.drift == "reference"
        assert row.fault_onset_s < row.first_alarm_s <= row.fault_onset_s + 4 * 0.63
        assert row.verdict == "actuator"
        info = json.loads(
            (
                tmp_path / "out" / "mon" / "points" / f"point_id={row.point_id}" / "point.json"
            ).read_text()
        )
        assert info["monitor"]["verdict"] == "actuator"
    assert not (tmp_path / "out" / "mon" / "references").exists() or not any(
        (tmp_path / "out" / "mon" / "references").iterdir()
    )
    again = run_sweep(sweep, tmp_path / "out", jobs=1, progress=False)
    assert (again.done, again.skipped) == (0, 2)


def test_a_bad_kind_and_a_baseline_that_does_not_fit_are_refused(tmp_path):
    with pytest.raises(ScenarioError) as exc:
        load_sweep(write(tmp_path, 'kind = "watch"\n[grid]\n"disturbance.seed" = [1]\n'))
    assert exc.value.field == "kind"
    with pytest.raises(ScenarioError) as exc:  # 20 settled periods, the baseline 30
        load_sweep(write(tmp_path, 'kind = "monitor"\n[grid]\n"probe.periods" = [22, 60]\n'))
    assert exc.value.field.endswith("monitor.baseline_periods") and "point 0" in str(exc.value)


def test_the_studies_sweeps_are_valid_and_the_lateral_ones_are_what_generates_them(tmp_path):
    """Every committed study sweep (make monitor, make monitor-lateral) is a valid monitor
    sweep; a lateral sweep's base probes the surface its name says; and the lateral files are
    the bytes their generator writes."""
    import runpy

    from probing.experiment.scenario import load_scenario

    root = Path(__file__).resolve().parents[2] / "scenarios"
    lateral = root / "monitor-lateral"
    for folder in (root / "monitor", lateral):
        for path in sorted(folder.glob("*.toml")):
            if path.name.startswith("base"):
                load_scenario(path)
                continue
            sweep = load_sweep(path)
            assert sweep.kind == "monitor" and sweep.points, path.name
            if folder == lateral:
                surface = path.stem.split("-")[0]
                assert {p.scenario.surface for p in sweep.points} == {surface}
    main = runpy.run_path(str(lateral / "generate.py"))["main"]
    main.__globals__["HERE"] = tmp_path
    main()
    written = sorted(p.name for p in tmp_path.glob("*.toml"))
    assert written == sorted(p.name for p in lateral.glob("*.toml"))
    for name in written:
        assert (tmp_path / name).read_bytes() == (lateral / name).read_bytes(), name
