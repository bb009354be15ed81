"""The fault registry: every entry is complete and valid, and the scenario reads it alone."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from probing.core import faults
from probing.core.faults import (
    FAULT_CLASSES,
    FAULT_PLACES,
    FAULTS,
    FIELD_KINDS,
    FaultField,
    FaultType,
    SensorBias,
)
from probing.experiment.scenario import SECTIONS, ScenarioError, parse_scenario


@pytest.mark.parametrize("name", FAULTS)
def test_every_entry_has_a_valid_class_place_and_fields(name: str):
    entry = FAULTS[name]
    assert entry.name == name
    assert entry.fault_class in FAULT_CLASSES
    assert entry.place in FAULT_PLACES
    assert entry.description and callable(entry.builder)
    assert len(set(entry.names)) == len(entry.names)
    assert not {"type", "onset_s"} & set(entry.names)
    for f in entry.fields:
        assert f.kind in FIELD_KINDS and f.unit and f.description
        if f.kind == "number":
            assert math.isfinite(f.lo) and math.isfinite(f.hi) and f.lo < f.hi


def test_the_existing_types_keep_their_class_and_place():
    got = {name: (t.fault_class, t.place) for name, t in FAULTS.items()}
    assert got == {
        "gtm_damage": ("airframe", "plant"),
        "nonlinearity": ("actuator", "probe_path"),
        "effectiveness": ("actuator", "actuator"),
        "stuck": ("actuator", "actuator"),
        "sensor_bias": ("sensor", "sensor"),
        "sensor_scale": ("sensor", "sensor"),
        "sensor_stuck": ("sensor", "sensor"),
    }


def base(**fault) -> dict:
    """A short GTM scenario with a [fault] section."""
    return {
        "name": "f",
        "aircraft": {"model": "gtm_t2"},
        "condition": {"altitude_ft": 800, "speed_kcas": 75},
        "simulation": {"dt_s": 0.01},
        "probe": {
            "order": 6,
            "bit_duration_s": 0.01,
            "amplitude_deg": 0.2,
            "periods": 10,
            "settle_periods": 2,
        },
        "nonlinearity": {"type": "none"},
        "output": {"channels": ["theta_rad", "q_rad_s"]},
        "fault": fault,
    }


def test_a_new_entry_is_validated_from_the_registry_alone(monkeypatch: pytest.MonkeyPatch):
    """Adding an entry needs no other edit: the schema takes its fields, checks its bounds and
    writes it back, and the scenario builds it for its place."""
    entry = FaultType(
        "sensor_gain",
        "sensor",
        "sensor",
        (
            FaultField("channel", "channel", description="the channel"),
            FaultField("gain", "number", "-", 0.5, 1.5, "its gain"),
        ),
        "a sensor's gain changes",
        lambda onset_s, v: ("scaled", v["channel"], v["gain"], onset_s),
    )
    monkeypatch.setitem(FAULTS, "sensor_gain", entry)
    # the section's allowed names are gathered from the registry when the schema is imported
    monkeypatch.setitem(SECTIONS, "fault", SECTIONS["fault"] | {"gain"})
    scn = parse_scenario(base(type="sensor_gain", channel="q_rad_s", gain=1.25, onset_s=1.0))
    assert scn.to_dict()["fault"] == {
        "type": "sensor_gain",
        "onset_s": 1.0,
        "channel": "q_rad_s",
        "gain": 1.25,
    }
    assert scn.build_fault("sensor") == ("scaled", "q_rad_s", 1.25, 1.0)
    assert scn.build_fault("actuator") is None and scn.actuator_fault is None
    assert parse_scenario(scn.to_dict()).digest() == scn.digest()
    with pytest.raises(ScenarioError) as err:
        parse_scenario(base(type="sensor_gain", channel="q_rad_s", gain=2.0, onset_s=1.0))
    assert err.value.field == "fault.gain"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(base(type="sensor_gain", channel="nz_g", gain=1.0, onset_s=1.0))
    assert err.value.field == "fault.channel"


def test_the_section_allows_exactly_the_registrys_fields():
    from probing.core.nonlinearities import NONLINEARITIES

    names = {n for t in FAULTS.values() for n in t.names}
    params = {n for t in NONLINEARITIES.values() for n in t.names}
    assert SECTIONS["fault"] == {"type", "onset_s"} | names | params


def test_sensor_bias_builds_from_its_fields():
    scn = parse_scenario(base(type="sensor_bias", channel="theta_rad", bias=0.01, onset_s=2.0))
    assert scn.build_fault("sensor") == SensorBias("theta_rad", 0.01, 2.0)
    assert scn.to_dict()["fault"] == {
        "type": "sensor_bias",
        "onset_s": 2.0,
        "channel": "theta_rad",
        "bias": 0.01,
    }
    assert not scn.stepped_one_by_one and scn.flight.damage_onset_s is None


def test_a_sensor_bias_acts_from_its_onset_step_whatever_the_chunks():
    dt, onset = 0.01, 0.37  # the onset step: 37
    rng = np.random.default_rng(0)
    y = rng.standard_normal((100, 2))
    bias = SensorBias("q_rad_s", -0.25, onset)
    whole = y.copy()
    faults.apply_sensor_fault(bias, whole, ("theta_rad", "q_rad_s"), 0, dt)
    assert np.array_equal(whole[:, 0], y[:, 0])
    assert np.array_equal(whole[:37, 1], y[:37, 1])
    assert np.array_equal(whole[37:, 1], y[37:, 1] + -0.25)
    chunked = y.copy()
    for first in range(0, 100, 30):
        faults.apply_sensor_fault(
            bias, chunked[first : first + 30], ("theta_rad", "q_rad_s"), first, dt
        )
    assert np.array_equal(chunked, whole)
    assert faults.onset_step(onset, dt) == 37
    assert [bias.measure(1.0, step, 37) for step in (36, 37)] == [1.0, 0.75]


@pytest.mark.parametrize(
    ("kind", "fields", "built"),
    [
        ("sensor_scale", {"scale": 1.2}, faults.SensorScale("theta_rad", 1.2, 2.0)),
        ("sensor_stuck", {}, faults.SensorStuck("theta_rad", 2.0)),
    ],
)
def test_the_other_sensor_faults_build_from_their_fields(kind, fields, built):
    scn = parse_scenario(base(type=kind, channel="theta_rad", onset_s=2.0, **fields))
    assert scn.build_fault("sensor") == built
    assert scn.to_dict()["fault"] == {
        "type": kind,
        "onset_s": 2.0,
        "channel": "theta_rad",
        **fields,
    }


def test_a_sensor_scale_and_a_stuck_sensor_act_from_their_onset_step_whatever_the_chunks():
    """The scale multiplies from the onset step on; the stuck sensor gives, from the onset
    step on, the measurement of the step before it (its state carried across chunks)."""
    dt, onset = 0.01, 0.37  # the onset step: 37
    y = np.random.default_rng(1).standard_normal((100, 2))
    channels = ("theta_rad", "q_rad_s")
    for fault, want in (
        (faults.SensorScale("q_rad_s", 1.5, onset), np.r_[y[:37, 1], 1.5 * y[37:, 1]]),
        (faults.SensorStuck("q_rad_s", onset), np.r_[y[:37, 1], np.full(63, y[36, 1])]),
    ):
        for size in (100, 30, 1):
            got = y.copy()
            fresh = dataclasses.replace(fault)
            for first in range(0, 100, size):
                faults.apply_sensor_fault(fresh, got[first : first + size], channels, first, dt)
            assert np.array_equal(got[:, 0], y[:, 0])
            assert np.array_equal(got[:, 1], want)


def test_a_sensor_stuck_from_the_first_step_holds_the_first_measurement():
    stuck = faults.SensorStuck("q_rad_s", 0.0)
    assert [stuck.measure(v, step, 0) for step, v in enumerate((3.0, 4.0, 5.0))] == [3.0] * 3


def test_entries_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        FAULTS["stuck"].place = "sensor"  # type: ignore[misc]


def test_an_actuator_fault_positions_the_surface_from_what_is_asked():
    assert faults.ActuatorFault("effectiveness", 1.0, 0.5).position(3.0, 1.0, 7.0) == 2.0
    assert faults.ActuatorFault("stuck", 1.0).position(3.0, 1.0, 7.0) == 7.0
    with pytest.raises(ValueError):
        faults.ActuatorFault("sensor_bias", 1.0)


def test_the_study_generators_sweep_fields_are_the_registrys():
    assert faults.sweep_fields("gtm_damage", {"case": 5}) == {
        "fault.type": "gtm_damage",
        "fault.case": 5,
    }
    fields = faults.sweep_fields("nonlinearity", {"nonlinearity": "backlash", "width_deg": 0.1})
    assert list(fields) == ["fault.type", "fault.nonlinearity", "fault.width_deg"]
    with pytest.raises(ValueError, match=r"fault\.scale: not a field of a stuck fault"):
        faults.sweep_fields("stuck", {"scale": 0.5})
    with pytest.raises(KeyError):
        faults.sweep_fields("no_such_fault", {})


@pytest.mark.parametrize(
    ("onset_s", "step"),
    [
        (0.07, 7),  # 7.000000000000001 steps of 0.01 s: step 7, not 8
        (0.29, 29),  # 28.999999999999996 steps: step 29, not 28
        (0.0, 0),
        (0.3649, 36),  # within a step: the step that starts nearest, on either side of 0.365
        (0.3651, 37),
        (0.3749, 37),
        (0.3751, 38),
    ],
)
def test_a_fault_acts_from_the_step_that_starts_at_its_onset(onset_s, step):
    """The step that starts at the onset (steps of 0.01 s from 0 at the trim), whatever
    rounding the onset's division leaves; an onset inside a step starts at the nearest step
    start."""
    assert faults.onset_step(onset_s, 0.01) == step
