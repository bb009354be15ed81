"""The ``[sensors]`` section, its rules, and the drift modes' names (``oracle``, ``nominal``,
``gust``): each rule accepted and refused with its field, overrides applied, round trips,
and every committed scenario's digest as it was before the section existed."""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any

import pytest
from conftest import base_scenario

from probing.core.gust import GUST_SENSORS
from probing.core.sensors import SENSOR_SUITES, SensorSpec, SensorSuite
from probing.experiment.scenario import (
    DRIFT_MODES,
    ScenarioError,
    load_scenario,
    parse_scenario,
    read_toml,
)
from probing.experiment.scenario.references import REFERENCES
from probing.sim.flight import LOOP_SENSORS, Control

ROOT = Path(__file__).resolve().parents[2]
#: {file: digest, or "error: <field>"} of every scenario file under scenarios/ and
#: tests/data, recorded before [sensors] and the new drift names existed.
DIGESTS = ROOT / "tests" / "data" / "scenario_digests.json"
#: Files changed on purpose: turbulence with drift "reference", now "oracle".
TO_ORACLE = {
    "scenarios/monitor/base.toml",
    "scenarios/monitor-lateral/base-aileron.toml",
    "scenarios/monitor-lateral/base-rudder.toml",
}
SUITE = {"suite": "nasa_t2"}
REFERENCE_IN_TURBULENCE = (
    '"reference" is a twin that flies the same gusts as the aircraft, which no real aircraft '
    'knows; with turbulence say "oracle" (that upper bound) or a realisable reference: '
    '"nominal", "gust" or "detrend"'
)


def refused(data: dict[str, Any]) -> ScenarioError:
    with pytest.raises(ScenarioError) as err:
        parse_scenario(data)
    assert "\n" not in str(err.value)  # one line
    return err.value


def with_sensors(sensors: dict[str, Any] | None = None, **entries: Any) -> dict[str, Any]:
    return base_scenario(sensors=dict(SUITE if sensors is None else sensors), **entries)


def gust_ready(**changes: Any) -> dict[str, Any]:
    """A scenario that ``drift = "gust"`` accepts: the suite, a pitch hold, turbulence."""
    data = with_sensors(
        control={"pitch_hold": True},
        disturbance={"turbulence": "light"},
    )
    data["output"]["drift"] = "gust"
    data.update(changes)
    return data


@pytest.fixture
def small_suite(monkeypatch: pytest.MonkeyPatch) -> SensorSuite:
    """A suite ``small`` with theta, q and alpha only."""
    suite = SensorSuite(
        "small", {c: SensorSpec() for c in ("theta_rad", "q_rad_s", "alpha_rad")}, "test"
    )
    monkeypatch.setitem(SENSOR_SUITES, "small", suite)
    return suite


# ------------------------------------------------------------------ the section
def test_a_scenario_without_sensors_has_none_and_writes_none() -> None:
    scn = parse_scenario(base_scenario())
    assert scn.sensors is None and scn.sensors_section is None
    assert "sensors" not in scn.to_dict()


def test_the_suite_is_resolved() -> None:
    scn = parse_scenario(with_sensors())
    assert scn.sensors == SENSOR_SUITES["nasa_t2"]
    assert scn.to_dict()["sensors"] == {"suite": "nasa_t2"}


def test_overrides_change_their_sensor_only() -> None:
    scn = parse_scenario(
        with_sensors({"suite": "nasa_t2", "theta_rad": {"bias": 0.0, "rate_hz": 50}})
    )
    nasa = SENSOR_SUITES["nasa_t2"].sensors
    assert scn.sensors is not None
    theta = scn.sensors.sensors["theta_rad"]
    assert theta == nasa["theta_rad"].replace(bias=0.0, rate_hz=50.0)
    assert theta.bias == 0.0 != nasa["theta_rad"].bias
    assert theta.noise_sigma == nasa["theta_rad"].noise_sigma
    for channel, spec in nasa.items():
        if channel != "theta_rad":
            assert scn.sensors.sensors[channel] == spec
    assert SENSOR_SUITES["nasa_t2"].sensors["theta_rad"] == nasa["theta_rad"]  # untouched
    assert scn.sensors_section.overrides == {"theta_rad": {"bias": 0.0, "rate_hz": 50.0}}


@pytest.mark.parametrize(
    "sensors",
    [
        SUITE,
        {"suite": "nasa_t2", "theta_rad": {"bias": 0.001, "quantum": 1e-4}},
        {"suite": "nasa_t2", "q_rad_s": {"lag_rad_s": 30.0}, "vt_fps": {"scale": -1.0}},
        {"suite": "nasa_t2", "h_ft": {}},  # an empty table changes nothing
    ],
)
def test_round_trip(sensors: dict[str, Any]) -> None:
    scn = parse_scenario(with_sensors(sensors))
    again = parse_scenario(scn.to_dict())
    assert again == scn
    assert again.digest() == scn.digest()
    assert again.to_dict() == scn.to_dict()
    assert scn.replace({"probe.order": 8}).sensors == scn.sensors


def test_an_empty_table_is_the_suite_itself() -> None:
    plain = parse_scenario(with_sensors())
    empty = parse_scenario(with_sensors({"suite": "nasa_t2", "h_ft": {}}))
    assert empty.digest() == plain.digest()


def test_overrides_change_the_digest() -> None:
    plain = parse_scenario(with_sensors())
    changed = parse_scenario(with_sensors({"suite": "nasa_t2", "theta_rad": {"bias": 0.0}}))
    assert plain.digest() != changed.digest() != parse_scenario(base_scenario()).digest()


@pytest.mark.parametrize(
    ("sensors", "field"),
    [
        ({}, "sensors.suite"),
        ({"suite": "nasa_t3"}, "sensors.suite"),
        ({"suite": 1}, "sensors.suite"),
        ({"suite": "nasa_t2", "gamma_rad": {"bias": 0.0}}, "sensors.gamma_rad"),
        ({"suite": "nasa_t2", "thrust": {"bias": 0.0}}, "sensors.thrust"),
        ({"suite": "nasa_t2", "theta_rad": 0.1}, "sensors.theta_rad"),
        ({"suite": "nasa_t2", "theta_rad": {"offset": 0.1}}, "sensors.theta_rad.offset"),
        ({"suite": "nasa_t2", "theta_rad": {"bias": True}}, "sensors.theta_rad.bias"),
        ({"suite": "nasa_t2", "theta_rad": {"bias": "0"}}, "sensors.theta_rad.bias"),
        ({"suite": "nasa_t2", "theta_rad": {"noise_sigma": -1.0}}, "sensors.theta_rad.noise_sigma"),
        (
            {"suite": "nasa_t2", "theta_rad": {"noise_sigma": math.nan}},
            "sensors.theta_rad.noise_sigma",
        ),
        ({"suite": "nasa_t2", "theta_rad": {"bias": math.inf}}, "sensors.theta_rad.bias"),
        ({"suite": "nasa_t2", "theta_rad": {"scale": 0}}, "sensors.theta_rad.scale"),
        ({"suite": "nasa_t2", "theta_rad": {"lag_rad_s": -1}}, "sensors.theta_rad.lag_rad_s"),
        ({"suite": "nasa_t2", "theta_rad": {"quantum": -1e-3}}, "sensors.theta_rad.quantum"),
        # dt 0.01 s: 30 Hz is no whole number of steps, 200 Hz is faster than a step
        ({"suite": "nasa_t2", "theta_rad": {"rate_hz": 30.0}}, "sensors.theta_rad.rate_hz"),
        ({"suite": "nasa_t2", "theta_rad": {"rate_hz": 200.0}}, "sensors.theta_rad.rate_hz"),
    ],
)
def test_bad_sections_are_refused(sensors: dict[str, Any], field: str) -> None:
    assert refused(with_sensors(sensors)).field == field


def test_an_unknown_suite_lists_the_known_ones() -> None:
    err = refused(with_sensors({"suite": "nasa_t3"}))
    assert all(name in err.message for name in SENSOR_SUITES)


def test_sensors_must_be_a_table() -> None:
    assert refused(base_scenario(sensors="nasa_t2")).field == "sensors"


# ------------------------------------------------------------------ the rules
def test_sensor_noise_comes_from_the_sensors() -> None:
    data = with_sensors(disturbance={"sensor_noise": {"theta_rad": 1e-5}})
    err = refused(data)
    assert err.field == "disturbance.sensor_noise"
    assert "[sensors]" in err.message
    parse_scenario(with_sensors(disturbance={"sensor_noise": {}}))  # empty: nothing to drop
    parse_scenario(base_scenario(disturbance={"sensor_noise": {"theta_rad": 1e-5}}))


def test_every_output_channel_needs_a_sensor() -> None:
    data = with_sensors()
    data["output"]["channels"] = ["theta_rad", "gamma_rad"]
    err = refused(data)
    assert err.field == "output.channels" and "gamma_rad" in err.message
    data["output"]["channels"] = ["theta_rad", "nx_g", "psi_rad", "v_down_fps"]
    parse_scenario(data)
    parse_scenario(base_scenario({"output.channels": ["gamma_rad"]}))  # no [sensors]: any


def test_loop_sensors_are_what_the_autopilot_reads() -> None:
    assert set(LOOP_SENSORS) == {"pitch_hold", "bank_hold", "speed_hold"}
    assert all(hasattr(Control(), loop) for loop in LOOP_SENSORS)


@pytest.mark.parametrize("loop", sorted(LOOP_SENSORS))
def test_a_closed_loop_flies_on_sensors_of_the_suite(small_suite, loop: str) -> None:
    ok = set(LOOP_SENSORS[loop]) <= set(small_suite.sensors)
    data = with_sensors({"suite": "small"}, control={loop: True})
    if ok:
        assert parse_scenario(data).sensors == small_suite
    else:
        err = refused(data)
        assert err.field == f"control.{loop}"
        lacking = [c for c in LOOP_SENSORS[loop] if c not in small_suite.sensors]
        assert all(c in err.message for c in lacking)
    # with the nasa_t2 suite every loop is measured
    parse_scenario(with_sensors(control={loop: True}))
    # switched off, a loop reads nothing
    parse_scenario(with_sensors({"suite": "small"}, control={loop: False}))


def test_simultaneous_with_sensors_is_not_yet_supported() -> None:
    data, _ = read_toml(ROOT / "scenarios" / "simultaneous" / "shift-737.toml")
    parse_scenario(data)
    data["sensors"] = dict(SUITE)
    err = refused(data)
    assert err.field == "sensors" and "not yet supported" in err.message


def test_a_manoeuvre_with_sensors_is_not_yet_supported() -> None:
    data, _ = read_toml(ROOT / "scenarios" / "manoeuvres" / "speed-1kt-s.toml")
    parse_scenario(data)
    data["sensors"] = dict(SUITE)
    err = refused(data)
    assert err.field == "sensors" and "not yet supported" in err.message


# ------------------------------------------------------------------ drift names
def test_the_drift_names() -> None:
    assert DRIFT_MODES == ("reference", "follow", "detrend", "none", "oracle", "nominal", "gust")


@pytest.mark.parametrize(
    ("drift", "uses_twin", "knows_gusts"),
    [
        ("reference", True, True),
        ("oracle", True, True),
        ("nominal", True, False),
        ("detrend", False, False),
        ("none", False, False),
    ],
)
def test_which_references_are_twins(drift: str, uses_twin: bool, knows_gusts: bool) -> None:
    scn = parse_scenario(base_scenario({"output.drift": drift}))
    assert (REFERENCES[drift].kind == "twin", scn.twin_knows_gusts) == (uses_twin, knows_gusts)


def test_gust_is_no_precomputed_twin() -> None:
    scn = parse_scenario(gust_ready())
    twin = REFERENCES[scn.drift].kind == "twin"
    assert (twin, scn.twin_knows_gusts, scn.follows) == (False, False, False)


def test_reference_in_turbulence_is_refused() -> None:
    data = base_scenario(disturbance={"turbulence": "light"})
    err = refused(data)
    assert (err.field, err.message) == ("output.drift", REFERENCE_IN_TURBULENCE)
    del data["output"]["drift"]  # the default is "reference"
    assert refused(data).field == "output.drift"
    parse_scenario(base_scenario(disturbance={"turbulence": "none"}))  # calm: as before


@pytest.mark.parametrize("drift", ["oracle", "nominal", "detrend", "none"])
def test_other_references_fly_turbulence(drift: str) -> None:
    scn = parse_scenario(
        base_scenario({"output.drift": drift}, disturbance={"turbulence": "light"})
    )
    assert scn.drift == drift


def test_oracle_in_calm_air_is_the_reference_twin() -> None:
    ref = parse_scenario(base_scenario())
    oracle = parse_scenario(base_scenario({"output.drift": "oracle"}))
    assert oracle.flight == ref.flight and REFERENCES["oracle"].kind == "twin"
    assert oracle.twin_knows_gusts


def test_gust_is_accepted_with_its_sensors_and_a_pitch_hold() -> None:
    scn = parse_scenario(gust_ready())
    assert scn.drift == "gust" and scn.sensors is not None
    assert set(GUST_SENSORS) <= set(scn.sensors.sensors)
    assert parse_scenario(scn.to_dict()) == scn


def test_gust_needs_sensors() -> None:
    data = gust_ready()
    del data["sensors"]
    err = refused(data)
    assert err.field == "output.drift" and "[sensors]" in err.message


def test_gust_needs_every_gust_sensor(small_suite) -> None:
    data = gust_ready(sensors={"suite": "small"})
    err = refused(data)
    assert err.field == "output.drift"
    assert "psi_rad" in err.message and "theta_rad," not in err.message.split("none of")[1]


@pytest.mark.parametrize("control", [None, {"bank_hold": True}, {"pitch_hold": False}])
def test_gust_needs_a_pitch_hold(control: dict[str, Any] | None) -> None:
    data = gust_ready()
    if control is None:
        del data["control"]
    else:
        data["control"] = control
    err = refused(data)
    assert err.field == "output.drift" and "pitch_hold" in err.message


def test_follow_is_unchanged() -> None:
    err = refused(base_scenario({"output.drift": "follow"}))
    assert err.field == "output.drift"
    parse_scenario(base_scenario({"output.drift": "follow"}, control={"pitch_hold": True}))


def test_simultaneous_takes_oracle_as_reference() -> None:
    data, _ = read_toml(ROOT / "scenarios" / "simultaneous" / "shift-737.toml")
    for drift in ("reference", "oracle", "none"):
        data["output"]["drift"] = drift
        parse_scenario(data)
    for drift in ("nominal", "gust", "detrend"):
        data["output"]["drift"] = drift
        assert refused(data).field in ("simultaneous", "output.drift")


# ------------------------------------------------------------------ committed files
def _digest(data: dict[str, Any]) -> str:
    text = json.dumps(data, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _files() -> list[str]:
    return json.loads(DIGESTS.read_text())


def test_the_recorded_files_are_every_scenario_file_but_those_with_sensors() -> None:
    """Every file recorded before [sensors] is still there, and every file added since
    flies with [sensors] (a scenario) or sweeps one (a sweep file names its base)."""
    files = {
        str(p.relative_to(ROOT))
        for top in ("scenarios", "tests/data")
        for p in (ROOT / top).rglob("*.toml")
    }
    recorded = set(_files())
    assert recorded <= files
    for path in sorted(files - recorded):
        text = (ROOT / path).read_text()
        if "\nbase = " in text:
            base = (ROOT / path).parent / text.split("\nbase = ")[1].split("\n")[0].strip('"')
            assert load_scenario(base).sensors is not None, path
        else:
            assert load_scenario(ROOT / path).sensors is not None, path


@pytest.mark.parametrize("path", sorted(json.loads(DIGESTS.read_text())))
def test_committed_scenarios_keep_their_digest(path: str) -> None:
    """Every file reads as it did before [sensors] (its digest, or an error naming the same
    field), except the monitor scenarios that fly turbulence with ``drift = "reference"``:
    now ``"oracle"``, and that is all that changed in them."""
    expected = json.loads(DIGESTS.read_text())[path]
    try:
        scn = load_scenario(ROOT / path)
    except ScenarioError as err:
        assert expected == f"error: {err.field}"
        return
    if path in TO_ORACLE:
        assert scn.drift == "oracle" and scn.turbulence != "none"
        assert scn.digest() != expected
        data = scn.to_dict()
        data["output"]["drift"] = "reference"
        assert _digest(data) == expected
    else:
        assert scn.digest() == expected
        assert scn.sensors is None
