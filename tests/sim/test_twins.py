"""The reference-twin cache: same numbers with and without it, one entry per twin, safe writes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from conftest import base_scenario

from probing.experiment.flight.run import run_scenario
from probing.experiment.scenario import parse_scenario
from probing.sim.errors import DivergenceError
from probing.sim.plant import make_plant
from probing.sim.twins import open_twin as _open_twin
from probing.sim.twins import twin_key as _twin_key
from probing.sim.twins import twin_spec as _twin_spec
from probing.sim.world import JSBSimWorld

pytestmark = pytest.mark.jsbsim

BASE = base_scenario(
    {
        "probe.order": 6,
        "probe.periods": 3,
        "probe.settle_periods": 1,
        "output.channels": ["theta_rad", "q_rad_s"],
        "output.drift": "oracle",  # the twin flies the same gusts
    },
    name="tw",
    disturbance={"turbulence": "light", "seed": 4},
)


def twin_key(scn):
    return _twin_key(scn.flight, scn.channels, scn.total_steps)


def twin_spec(scn):
    return _twin_spec(scn.flight, scn.channels, scn.total_steps)


def open_twin(scn, **kwargs):
    return _open_twin(scn.flight, scn.channels, scn.total_steps, **kwargs)


def scenario(**changes):
    scn = parse_scenario(json.loads(json.dumps(BASE)))
    return scn.replace(**changes) if changes else scn


@pytest.fixture(autouse=True)
def twin_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A private, empty twin cache (sanitised aircraft stay in the usual cache)."""
    cache = tmp_path / "twins"
    monkeypatch.setenv("PROBING_TWIN_CACHE", str(cache))
    return cache


def entries(cache: Path) -> list[str]:
    return sorted(p.name for p in cache.iterdir()) if cache.exists() else []


def frames(folder: Path) -> dict[str, pd.DataFrame]:
    return {n: pd.read_parquet(folder / n) for n in ("probing.parquet", "timeseries.parquet")}


def test_cached_twin_gives_bit_identical_results(tmp_path: Path, twin_cache: Path) -> None:
    """Cold cache, warm cache and no cache at all: the same Parquet files, byte for byte."""
    scn = scenario(**{"nonlinearity.type": "backlash", "nonlinearity.width_deg": 0.003})
    plain = run_scenario(scn, tmp_path / "plain", progress=False, twin_cache=False)
    assert entries(twin_cache) == []  # twin_cache=False neither reads nor stores
    cold = run_scenario(scn, tmp_path / "cold", progress=False)
    warm = run_scenario(scn, tmp_path / "warm", progress=False)
    assert entries(twin_cache) == [f"{cold.twin_key}.npy"]
    assert (plain.twin_cached, cold.twin_cached, warm.twin_cached) == (False, False, True)
    assert plain.steps_simulated == cold.steps_simulated == 2 * scn.total_steps
    assert warm.steps_simulated == scn.total_steps
    reference = frames(plain.out_dir)
    for result in (cold, warm):
        for name, df in frames(result.out_dir).items():
            pd.testing.assert_frame_equal(df, reference[name], check_exact=True)
    # The stored twin is exactly the reference columns of the uncached run.
    stored = np.load(twin_cache / f"{cold.twin_key}.npy")
    ts = reference["timeseries.parquet"]
    np.testing.assert_array_equal(stored, ts[["theta_rad_reference", "q_rad_s_reference"]])
    # Provenance: the twin's key, but not whether it came from the cache, so that the
    # files themselves are byte-identical (docs/method.md promises it).
    for result in (cold, warm):
        meta = pq.read_schema(result.out_dir / "probing.parquet").metadata
        assert json.loads(meta[b"probing.twin"]) == {"key": result.twin_key}
        for name in ("probing.parquet", "timeseries.parquet"):
            assert (result.out_dir / name).read_bytes() == (plain.out_dir / name).read_bytes()


def test_nonlinearity_and_probe_variants_share_one_twin(tmp_path: Path, twin_cache: Path) -> None:
    a = scenario(
        **{
            "name": "a",
            "nonlinearity.type": "deadband",
            "nonlinearity.lower_deg": -0.001,
            "nonlinearity.upper_deg": 0.001,
        }
    )
    b = scenario(
        **{
            "name": "b",
            "probe.amplitude_deg": 0.01,
            "nonlinearity.type": "rate_limit",
            "nonlinearity.rate_deg_s": 0.5,
            "disturbance.sensor_noise": {"theta_rad": 1e-5},
            "probe.settle_periods": 2,
        }
    )
    assert twin_key(a) == twin_key(b)
    first = run_scenario(a, tmp_path, progress=False)
    second = run_scenario(b, tmp_path, progress=False)
    assert not first.twin_cached and second.twin_cached
    assert entries(twin_cache) == [f"{first.twin_key}.npy"]
    ta = pd.read_parquet(tmp_path / "a" / "timeseries.parquet")
    tb = pd.read_parquet(tmp_path / "b" / "timeseries.parquet")
    np.testing.assert_array_equal(ta.theta_rad_reference, tb.theta_rad_reference)


@pytest.mark.parametrize(
    "change",
    [
        {"disturbance.seed": 5},
        {"disturbance.turbulence": "moderate"},
        {"simulation.dt_s": 0.005},
        {"condition.altitude_ft": 16000},
        {"condition.speed_kcas": 281},
        {"probe.periods": 4},
        {"probe.order": 7},  # another run length
        {"output.channels": ["q_rad_s", "theta_rad"]},  # the column order is stored
        {"output.channels": ["theta_rad"]},
        {"aircraft.model": "A320"},
    ],
)
def test_what_the_twin_depends_on_changes_the_key(change: dict) -> None:
    assert twin_key(scenario(**change)) != twin_key(scenario())


def test_key_ignores_what_the_twin_does_not_see() -> None:
    key = twin_key(scenario())
    same = scenario(
        **{
            "name": "other",
            "probe.bit_duration_s": 0.01,
            "probe.settle_periods": 2,
            "output.drift": "detrend",
            "disturbance.sensor_noise": {"q_rad_s": 1e-4},
        }
    )
    assert twin_key(same) == key
    # A condition written as an integer or a float is the same condition.
    assert twin_spec(scenario(**{"condition.altitude_ft": 15000.0}))["altitude_ft"] == 15000.0
    assert twin_key(scenario(**{"condition.altitude_ft": 15000.0})) == key


def test_failed_or_incomplete_twin_leaves_no_entry(twin_cache: Path) -> None:
    scn = scenario()
    n = scn.bits_per_period
    with pytest.raises(DivergenceError), open_twin(scn) as twin:
        twin.next(n)
        raise DivergenceError("the probed aircraft dived")
    assert entries(twin_cache) == []
    with open_twin(scn) as twin:  # a clean exit before the last step
        twin.next(n)
    assert entries(twin_cache) == []
    with open_twin(scn) as twin, pytest.raises(ValueError, match="asked for"):
        twin.next(scn.total_steps + 1)
    assert entries(twin_cache) == []


def test_concurrent_writers_of_one_twin(twin_cache: Path) -> None:
    """Two writers that both missed the cache: each writes its own file, one entry remains."""
    scn = scenario()
    a, b = open_twin(scn), open_twin(scn)
    assert not a.cached and not b.cached
    assert len(entries(twin_cache)) == 2  # two temporary files, different names
    ya, yb = a.next(scn.total_steps), b.next(scn.total_steps)
    a.close(success=True)
    b.close(success=True)
    assert entries(twin_cache) == [f"{a.key}.npy"]
    np.testing.assert_array_equal(ya, yb)
    with open_twin(scn) as c:
        assert c.cached and c.steps_simulated == 0
        np.testing.assert_array_equal(c.next(scn.total_steps), ya)


def test_entry_of_the_wrong_shape_or_truncated_is_ignored(twin_cache: Path) -> None:
    scn = scenario()
    entry = twin_cache / f"{twin_key(scn)}.npy"
    twin_cache.mkdir(parents=True)
    np.save(entry, np.zeros((3, 2)))
    with open_twin(scn) as twin:
        assert not twin.cached
        y = twin.next(scn.total_steps)
    np.testing.assert_array_equal(np.load(entry), y)
    entry.write_bytes(entry.read_bytes()[:-8])  # the right header, one value short
    with open_twin(scn) as twin:
        assert not twin.cached
        twin.next(scn.total_steps)
    with open_twin(scn) as twin:
        assert twin.cached
        np.testing.assert_array_equal(twin.next(scn.total_steps), y)


@pytest.mark.parametrize("model", ["737", "gtm_t2"])
def test_holding_the_trim_command_equals_writing_it(model: str) -> None:
    """The twin holds the trimmed command instead of writing it each step: same numbers."""
    scn = scenario(**{"aircraft.model": model})
    if model == "gtm_t2":
        scn = scn.replace(**{"condition.altitude_ft": 800, "condition.speed_kcas": 75})
    held, written = make_plant(scn.flight), make_plant(scn.flight)
    nodes_h = held.channel_nodes(["theta_rad", "q_rad_s", "alpha_rad"])
    nodes_w = written.channel_nodes(["theta_rad", "q_rad_s", "alpha_rad"])
    out_h, out_w = np.empty((300, 3)), np.empty((300, 3))
    JSBSimWorld(held).fly_commands(None, nodes_h, out_h)
    JSBSimWorld(written).fly_commands(
        np.full(300, written.trim_result.elevator_cmd_norm), nodes_w, out_w
    )
    np.testing.assert_array_equal(out_h, out_w)
    assert np.ptp(out_h[:, 0]) > 0  # the aircraft does move (turbulence, drift)
