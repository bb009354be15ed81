"""Scenario files: the validator, the invalid-scenario corpus and the CLI's error contract.

Every file in ``tests/data/bad_scenarios`` is a small variation of the baseline scenario with
a first line ``# expect: <field>`` naming the field the error must name.  The library must
raise a one-line :class:`ScenarioError` naming that field and the file; the command line
(``python -m probing run FILE --out DIR``) must print exactly one line
``probing: error: <path>: <field>: <what is allowed>`` to stderr, exit with code 2, and
create nothing under DIR.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from probing.core.nonlinearities import NONLINEARITIES
from probing.experiment.scenario import (
    Scenario,
    ScenarioError,
    load_scenario,
    parse_scenario,
)

ROOT = Path(__file__).resolve().parents[2]
BASELINE = ROOT / "scenarios" / "baseline-737.toml"
BAD_DIR = ROOT / "tests" / "data" / "bad_scenarios"
BAD_FILES = sorted(BAD_DIR.glob("*.toml"))
#: The baseline's digest, pinned: a change here means every stored result's digest changes
#: too (probing fig4 would redo every run, sweeps would not find their points).
BASELINE_DIGEST = "f0830cc9f17c04c4"


def _expected_field(path: Path) -> str:
    first = path.read_bytes().split(b"\n", 1)[0].decode("utf-8")
    prefix = "# expect: "
    assert first.startswith(prefix), f"{path.name}: first line must be '{prefix}<field>'"
    return first[len(prefix) :].strip()


def _field_matches(field: str, expected: str) -> bool:
    return field == expected or field.startswith(expected + ".")


def _baseline_dict() -> dict:
    return tomllib.loads(BASELINE.read_text(encoding="utf-8"))


def _fields(s: Scenario) -> dict:
    return {f.name: getattr(s, f.name) for f in dataclasses.fields(s) if f.name != "text"}


def _run_cli(path: Path, out: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return subprocess.run(
        [sys.executable, "-m", "probing", "run", str(path), "--out", str(out)],
        capture_output=True,
        text=True,
        env=env,
        cwd=out.parent,
        timeout=120,
    )


def _assert_cli_error(result: subprocess.CompletedProcess[str], path: Path, field: str) -> None:
    assert "Traceback" not in result.stderr, result.stderr
    assert result.returncode == 2, (result.returncode, result.stderr)
    lines = result.stderr.splitlines()
    assert len(lines) == 1, f"stderr must be one line, got {result.stderr!r}"
    line = lines[0]
    assert line.strip(), "stderr line is empty"
    assert line.startswith("probing: error: "), line
    assert str(path) in line, line
    assert f": {field}" in line, line


# --------------------------------------------------------------------- the corpus
def test_corpus_is_large_enough():
    assert len(BAD_FILES) >= 30
    for path in BAD_FILES:
        _expected_field(path)


@pytest.mark.parametrize("path", BAD_FILES, ids=lambda p: p.stem)
def test_bad_scenario_is_rejected_naming_the_field(path: Path):
    expected = _expected_field(path)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    exc = info.value
    assert _field_matches(exc.field, expected), f"field {exc.field!r}, expected {expected!r}"
    message = str(exc)
    assert "\n" not in message and "\r" not in message, repr(message)
    assert str(path) in message
    assert message.startswith(f"{path}: {exc.field}: ")
    assert exc.source == str(path)


@pytest.mark.parametrize("path", BAD_FILES, ids=lambda p: p.stem)
def test_cli_rejects_bad_scenario_with_one_line_and_exit_2(path: Path, tmp_path: Path, capsys):
    """Every file through the command's entry point in this process (``probing.cli.main``,
    what ``python -m probing`` calls): its code and streams as a process gets them; a
    traceback would be an exception out of ``main`` here.  The process itself (its exit code
    and stderr from ``python -m probing``) is :func:`test_cli_missing_file`'s and
    :func:`test_cli_leaves_existing_out_dir_empty`'s, a fresh interpreter per file costing
    0.3 s each."""
    from probing.cli import main

    out = tmp_path / "out"
    code = main(["run", str(path), "--out", str(out)])
    stdout, stderr = capsys.readouterr()
    assert stdout == "", stdout
    _assert_cli_error(
        subprocess.CompletedProcess([], code, stdout, stderr), path, _expected_field(path)
    )
    assert not out.exists(), f"{out} was created for an invalid scenario"


def test_cli_missing_file(tmp_path: Path):
    missing = tmp_path / "no-such-scenario.toml"
    out = tmp_path / "out"
    result = _run_cli(missing, out)
    _assert_cli_error(result, missing, "file")
    assert not out.exists()


def test_cli_leaves_existing_out_dir_empty(tmp_path: Path):
    out = tmp_path / "out"
    out.mkdir()
    path = BAD_DIR / "order-too-small.toml"
    result = _run_cli(path, out)
    _assert_cli_error(result, path, "probe.order")
    assert list(out.iterdir()) == []


def test_missing_file_library():
    missing = BAD_DIR / "no-such-scenario.toml"
    with pytest.raises(ScenarioError) as info:
        load_scenario(missing)
    assert info.value.field == "file"
    assert str(missing) in str(info.value)


def test_error_without_source_has_no_path():
    data = _baseline_dict()
    data["probe"]["order"] = 1
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data)
    assert info.value.field == "probe.order"
    assert str(info.value).startswith("probe.order: ")
    assert info.value.source is None
    assert isinstance(info.value, ValueError)


# ----------------------------------------------------------------- valid scenarios
def test_baseline_values():
    s = load_scenario(BASELINE)
    assert s.name == "baseline-737"
    assert s.model == "737"
    assert s.altitude_ft == 15000.0
    assert (s.speed_kind, s.speed) == ("speed_kcas", 280.0)
    assert s.dt_s == 0.01
    assert s.order == 9
    assert s.bit_duration_s == 0.01
    assert s.amplitude_deg == 0.005
    assert (s.periods, s.settle_periods) == (8, 2)
    assert (s.nonlinearity, s.nl_params) == ("none", {})
    assert s.channels == ("theta_rad", "q_rad_s", "alpha_rad", "nz_g")
    assert s.drift == "reference"
    assert s.turbulence == "none"
    assert s.sensor_noise == {}
    assert s.seed == 0
    assert s.text == BASELINE.read_text(encoding="utf-8")
    assert (s.steps_per_bit, s.bits_per_period, s.total_steps) == (1, 511, 8 * 511)


VALID_NONLINEARITIES = {
    "none": {},
    "deadband": {"lower_deg": -0.002, "upper_deg": 0.001},
    "saturation": {"lower_deg": -0.003, "upper_deg": 0.004},
    "relay": {"threshold_deg": 0.0, "low_deg": -0.005, "high_deg": 0.005},
    "hysteresis_relay": {
        "lower_threshold_deg": -0.002,
        "upper_threshold_deg": 0.002,
        "low_deg": -0.005,
        "high_deg": 0.005,
    },
    "backlash": {"width_deg": 0.004},
    "rate_limit": {"rate_deg_s": 2.0},
}


def test_every_nonlinearity_type_is_covered():
    assert set(VALID_NONLINEARITIES) == set(NONLINEARITIES)


@pytest.mark.parametrize("nl_type", sorted(VALID_NONLINEARITIES))
def test_each_nonlinearity_parses(nl_type: str):
    data = _baseline_dict()
    data["nonlinearity"] = {"type": nl_type, **VALID_NONLINEARITIES[nl_type]}
    s = parse_scenario(data)
    assert s.nonlinearity == nl_type
    assert s.nl_params == VALID_NONLINEARITIES[nl_type]
    assert all(isinstance(v, float) for v in s.nl_params.values())


def _variants() -> dict[str, dict]:
    out = {"baseline": _baseline_dict()}
    for nl_type, params in VALID_NONLINEARITIES.items():
        d = _baseline_dict()
        d["nonlinearity"] = {"type": nl_type, **params}
        out[f"nl-{nl_type}"] = d
    d = _baseline_dict()
    d["condition"] = {"altitude_ft": 30000, "mach": 0.78}
    out["mach"] = d
    d = _baseline_dict()
    d["condition"] = {"altitude_ft": 5000.5, "speed_ktas": 250}
    out["ktas"] = d
    d = _baseline_dict()
    d["output"] = {"channels": ["q_rad_s"], "drift": "detrend", "detrend_order": 2}
    out["detrend"] = d
    d = _baseline_dict()
    d["output"]["detrend_order"] = 3  # given, though unused with drift = "reference"
    out["unused-detrend-order"] = d
    d = _baseline_dict()
    d["output"]["drift"] = "none"
    d["disturbance"] = {
        "turbulence": "moderate",
        "seed": 12345,
        "sensor_noise": {"theta_rad": 1e-4, "nz_g": 0.0},
    }
    out["noisy"] = d
    d = _baseline_dict()
    del d["disturbance"]
    d["simulation"]["dt_s"] = 0.005
    d["probe"].update(order=2, bit_duration_s=0.05, periods=2, settle_periods=0)
    out["minimal"] = d
    return out


VARIANTS = _variants()


@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_to_dict_round_trips(variant: str):
    s = parse_scenario(VARIANTS[variant])
    again = parse_scenario(s.to_dict())
    assert _fields(again) == _fields(s)
    assert again.digest() == s.digest()
    assert again.to_json() == s.to_json()


def test_digest_is_stable():
    a = load_scenario(BASELINE)
    b = load_scenario(BASELINE)
    assert a.digest() == b.digest() == BASELINE_DIGEST
    # Stable across processes (no dependence on hash randomisation or object identity).
    code = (
        "from probing.experiment.scenario import load_scenario; "
        f"print(load_scenario({str(BASELINE)!r}).digest())"
    )
    other = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60
    )
    assert other.stdout.strip() == a.digest()
    assert len(a.digest()) == 16
    int(a.digest(), 16)
    # Independent of comments, layout and key order: only the resolved content counts.
    reordered = {k: _baseline_dict()[k] for k in reversed(list(_baseline_dict()))}
    assert parse_scenario(reordered, text="other text").digest() == a.digest()
    # Integers and floats written either way resolve alike.
    data = _baseline_dict()
    data["condition"]["altitude_ft"] = 15000.0
    assert parse_scenario(data).digest() == a.digest()


DIGEST_CHANGES = {
    "name": "baseline-737b",
    "aircraft.model": "c172x",
    "condition.altitude_ft": 15001,
    "condition.mach": 0.6,
    "simulation.dt_s": 0.005,
    "probe.order": 10,
    "probe.bit_duration_s": 0.02,
    "probe.amplitude_deg": 0.006,
    "probe.periods": 9,
    "probe.settle_periods": 1,
    "nonlinearity.type": "rate_limit",
    "output.channels": ["theta_rad"],
    "output.drift": "none",
    "disturbance.turbulence": "light",
    "disturbance.seed": 1,
    "disturbance.sensor_noise": {"nz_g": 0.01},
}


@pytest.mark.parametrize("key", list(DIGEST_CHANGES))
def test_digest_changes_with_any_field(key: str):
    base = load_scenario(BASELINE)
    changes = {key: DIGEST_CHANGES[key]}
    if key == "nonlinearity.type":
        changes["nonlinearity.rate_deg_s"] = 5.0
    if key == "disturbance.turbulence":  # the twin that flies the gusts is the oracle
        changes["output.drift"] = "oracle"
    changed = base.replace(changes)
    assert changed.digest() != base.digest()


def test_digests_of_changes_are_distinct():
    base = load_scenario(BASELINE)
    digests = {base.digest()}
    for key, value in DIGEST_CHANGES.items():
        changes = {key: value}
        if key == "nonlinearity.type":
            changes["nonlinearity.rate_deg_s"] = 5.0
        if key == "disturbance.turbulence":
            changes["output.drift"] = "oracle"
        digests.add(base.replace(changes).digest())
    assert len(digests) == len(DIGEST_CHANGES) + 1


def test_replace_nonlinearity():
    base = load_scenario(BASELINE)
    s = base.replace({"nonlinearity.type": "backlash", "nonlinearity.width_deg": 0.01})
    assert s.nonlinearity == "backlash"
    assert s.nl_params == {"width_deg": 0.01}
    assert {k: v for k, v in _fields(s).items() if k != "nonlinearity_section"} == {
        k: v for k, v in _fields(base).items() if k != "nonlinearity_section"
    }
    assert base.nonlinearity == "none" and base.nl_params == {}  # the original is untouched
    # The parameters may come before the type, and keyword arguments work too.
    assert base.replace({"nonlinearity.width_deg": 0.01, "nonlinearity.type": "backlash"}) == s
    assert base.replace(**{"nonlinearity.type": "backlash", "nonlinearity.width_deg": 0.01}) == s
    # A new type drops the old type's parameters.
    r = s.replace({"nonlinearity.type": "rate_limit", "nonlinearity.rate_deg_s": 3.0})
    assert r.nl_params == {"rate_deg_s": 3.0}
    assert s.replace({"nonlinearity.type": "none"}).nl_params == {}


def test_replace_speed_drops_the_other_speed():
    s = load_scenario(BASELINE).replace({"condition.mach": 0.6})
    assert (s.speed_kind, s.speed) == ("mach", 0.6)


@pytest.mark.parametrize(
    ("changes", "field"),
    [
        ({"probe.order": 1}, "probe.order"),
        ({"probe.order": 9.5}, "probe.order"),
        ({"probe.amplitude_deg": float("nan")}, "probe.amplitude_deg"),
        ({"probe.settle_periods": 8}, "probe.settle_periods"),
        ({"nonlinearity.type": "backlash"}, "nonlinearity.width_deg"),
        ({"nonlinearity.type": "spring"}, "nonlinearity.type"),
        ({"nonlinearity.width_deg": 0.01}, "nonlinearity.width_deg"),
        ({"condition.mach": 9.0}, "condition.mach"),
        ({"output.channels": []}, "output.channels"),
        ({"disturbance.sensor_noise": {"h_ft": 1.0}}, "disturbance.sensor_noise.h_ft"),
        ({"name": "a/b"}, "name"),
        ({"bogus.key": 1}, "bogus"),
    ],
    ids=lambda v: str(v) if isinstance(v, str) else None,
)
def test_replace_with_invalid_value_raises(changes: dict, field: str):
    with pytest.raises(ScenarioError) as info:
        load_scenario(BASELINE).replace(changes)
    assert info.value.field == field


def test_monitor_without_its_section_says_the_section_is_missing() -> None:
    """A scenario without [monitor], too short for the detector's defaults, is told that the
    section is missing (not only that the default baseline does not fit); a section that
    leaves baseline_periods to its default is told about the default alone."""
    scn = load_scenario(BASELINE)  # 8 periods, no [monitor]
    with pytest.raises(ScenarioError, match=r"has no \[monitor\] section.*the default, 50,"):
        scn.monitor_settings()
    data = tomllib.loads(BASELINE.read_text())
    with pytest.raises(ScenarioError, match="the default, 50,") as info:
        parse_scenario({**data, "monitor": {"window_periods": 2}})
    assert "no [monitor] section" not in str(info.value)


@pytest.mark.parametrize("kind", ["stuck", "gtm_damage", "sensor_bias"])
def test_a_fault_onset_must_come_before_the_run_ends(kind: str):
    """The baseline run lasts M x periods x t0 = 511 x 8 x 0.01 s: a fault at that instant
    would act on no step and is refused naming fault.onset_s; the largest float below it,
    and a step before it, are accepted."""
    duration = 511 * 8 * 0.01
    own = {"gtm_damage": {"case": 2}, "sensor_bias": {"channel": "theta_rad", "bias": 0.01}}
    fault = {"type": kind, **own.get(kind, {})}

    def with_onset(onset: float) -> dict:
        data = _baseline_dict()
        if kind == "gtm_damage":
            data["aircraft"]["model"] = "gtm_t2"
        data["fault"] = {**fault, "onset_s": onset}
        return data

    with pytest.raises(ScenarioError, match="before the run ends") as info:
        parse_scenario(with_onset(duration))
    assert info.value.field == "fault.onset_s"
    for onset in (math.nextafter(duration, 0.0), duration - 0.01, 0.0):
        assert parse_scenario(with_onset(onset)).fault_onset_s == onset


#: A valid [fault] of each type (on the GTM), its nonlinearity a backlash.
VALID_FAULTS = {
    "nonlinearity": {"nonlinearity": "backlash", "width_deg": 0.002},
    "gtm_damage": {"case": 2},
    "effectiveness": {"scale": 0.5},
    "stuck": {},
    "sensor_bias": {"channel": "theta_rad", "bias": 0.01},
    "sensor_scale": {"channel": "theta_rad", "scale": 1.2},
    "sensor_stuck": {"channel": "theta_rad"},
}
#: The one form of the message for a field a fault type does not take.
NOT_A_FIELD = re.compile(r"not a field of a (?:(\w+) )?(\w+) fault \(takes ([a-z_, ]+)\)")


def test_every_fault_type_has_a_valid_example_here():
    from probing.core.faults import FAULTS

    assert set(VALID_FAULTS) == set(FAULTS)


@pytest.mark.parametrize("kind", sorted(VALID_FAULTS))
@pytest.mark.parametrize("extra", ["bogus_deg", "scale", "lower_deg"])
def test_a_field_a_fault_does_not_take_is_told_in_one_form(kind: str, extra: str):
    """Every fault type, a nonlinearity fault with a parameter of another nonlinearity
    (lower_deg, a deadband's) too: the same message, naming the fields it takes."""
    data = _baseline_dict()
    data["aircraft"]["model"] = "gtm_t2"
    fault = {"type": kind, "onset_s": 1.0, **VALID_FAULTS[kind]}
    parse_scenario({**data, "fault": fault})  # valid as it is
    if extra in fault:
        return  # effectiveness takes a scale
    with pytest.raises(ScenarioError) as info:
        parse_scenario({**data, "fault": {**fault, extra: 1.0}})
    assert info.value.field == f"fault.{extra}"
    found = NOT_A_FIELD.fullmatch(info.value.message)
    assert found is not None, info.value.message
    qualifier, named, takes = found.groups()
    assert named == kind and qualifier == VALID_FAULTS[kind].get("nonlinearity")
    assert takes.split(", ") == sorted({"onset_s", *VALID_FAULTS[kind]})


def test_the_bad_fault_files_and_the_sweeps_tell_an_unknown_field_the_same_way():
    from probing.core.faults import sweep_fields

    told = []
    for path in BAD_FILES:
        if path.name.startswith("fault-"):
            with pytest.raises(ScenarioError) as info:
                load_scenario(path)
            if "not a" in info.value.message:
                told.append(info.value.message)
                assert NOT_A_FIELD.fullmatch(info.value.message), (path.name, info.value.message)
    assert len(told) >= 4
    with pytest.raises(ValueError) as info:
        sweep_fields("stuck", {"scale": 0.5})
    assert str(info.value) == "fault.scale: not a field of a stuck fault (takes onset_s)"


@pytest.mark.parametrize(
    ("windows", "baseline", "accepted"),
    [(3, 4, False), (3, 5, True), (4, 5, False), (4, 6, False)],
)
def test_a_monitor_baseline_fits_between_its_windows_and_the_settled_periods(
    windows: int, baseline: int, accepted: bool
):
    """Baseline 8 periods, 2 settling: 6 settled.  A baseline needs windows + 2 periods (a
    covariance of the K windows with a degree of freedom to spare) and must leave one of the
    6 to test: with 3 windows, 5 is the only one accepted; 4 windows leave none."""
    data = _baseline_dict()
    data["monitor"] = {"windows": windows, "baseline_periods": baseline}
    if accepted:
        assert parse_scenario(data).monitor.baseline_periods == baseline
    else:
        with pytest.raises(ScenarioError) as info:
            parse_scenario(data)
        assert info.value.field == "monitor.baseline_periods"


@pytest.mark.parametrize(
    ("monitor", "field", "message"),
    [
        ({"windows": 2}, "windows", "must be an integer from 3 to 64, got 2"),
        ({"windows": 65}, "windows", "must be an integer from 3 to 64, got 65"),
        ({"windows": True}, "windows", "must be an integer from 3 to 64, got True"),
        (
            {"windows": 3, "baseline_periods": 4},
            "baseline_periods",
            "must be more than windows + 1 (4), got 4",
        ),
        (
            {"windows": 60},
            "baseline_periods",
            "must be more than windows + 1 (61), got 50 (the default)",
        ),
        ({"false_alarms_per_hour": 0}, "false_alarms_per_hour", "must be > 0 and <= 1e+06, got 0"),
        (
            {"shape_false_alarm": 0.5000001},
            "shape_false_alarm",
            "must be > 0 and <= 0.5, got 0.5",
        ),
        ({"verdict_periods": 0}, "verdict_periods", "must be an integer from 1 to 1000, got 0"),
        ({"window_periods": 1001}, "window_periods", "must be an integer from 1 to 1000, got 1001"),
        ({"surface": "yes"}, "surface", "must be true or false, got 'yes'"),
        (
            {"baseline_gap_periods": -1},
            "baseline_gap_periods",
            "must be an integer from 0 to 100000, got -1",
        ),
        (  # what needs the run: a baseline that leaves a settled period to test
            {"windows": 3, "baseline_periods": 6},
            "baseline_periods",
            "must be more than windows + 1 (4) and fewer than the run's 6 settled periods; "
            "6 is not",
        ),
    ],
)
def test_a_bad_monitor_setting_is_one_line_naming_its_field(
    monitor: dict, field: str, message: str
) -> None:
    """The bounds are MonitorSettings' own; the scenario turns its SettingError into a
    ScenarioError naming ``monitor.<field>``, in one line, and adds what needs the run."""
    from conftest import base_scenario

    with pytest.raises(ScenarioError) as info:
        parse_scenario(base_scenario(monitor=monitor))  # 8 periods, 2 settling
    assert info.value.field == f"monitor.{field}"
    assert str(info.value) == f"monitor.{field}: {message}"


def test_a_monitor_on_the_surface_needs_its_channel_in_the_outputs() -> None:
    from conftest import base_scenario

    data = base_scenario(monitor={"windows": 3, "baseline_periods": 5, "surface": True})
    with pytest.raises(ScenarioError, match="needs elevator_deg") as info:
        parse_scenario(data)
    assert info.value.field == "monitor.surface"
    data["output"]["channels"].append("elevator_deg")
    assert parse_scenario(data).monitor.surface is True


def test_the_scenarios_probe_is_built_once_and_follows_replace() -> None:
    """scn.probe is the [probe] section's Probe (built once); a replaced scenario has its
    own; steps per bit and the period come from it."""
    from probing.core.prbs import Probe

    scn = load_scenario(BASELINE)
    assert scn.probe == Probe(scn.order, scn.bit_duration_s, scn.amplitude_deg)
    assert scn.probe is scn.probe
    assert (scn.steps_per_bit, scn.bits_per_period) == (1, 511)
    assert scn.period_s == 511 * 0.01
    other = scn.replace({"probe.amplitude_deg": 0.02, "probe.bit_duration_s": 0.03})
    assert other.probe.amplitude_deg == 0.02 and other.steps_per_bit == 3
    assert scn.probe.amplitude_deg == scn.amplitude_deg  # the original's is untouched


@pytest.mark.parametrize(("bit_duration_s", "steps_per_bit"), [(0.01, 1), (0.03, 3)])
def test_a_period_is_its_bits_times_the_steps_of_a_bit(bit_duration_s, steps_per_bit):
    """The one count of a period's steps: M = 511 bits (order 9) of 1 or 3 steps of 0.01 s;
    the run is its periods of them."""
    from conftest import base_scenario

    scn = parse_scenario(base_scenario({"probe.bit_duration_s": bit_duration_s}))
    assert scn.period_steps == 511 * steps_per_bit
    assert scn.total_steps == scn.periods * scn.period_steps == 8 * 511 * steps_per_bit
