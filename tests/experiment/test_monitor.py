"""Closed loop, faults in flight and the monitor, on the GTM.

Independent truths: the single-pulse twin flown with the same autopilot (superposed over the
probe history), the core nonlinearity classes applied here to the probe, the scenario with
and without its fault, and what the fault is (the monitor is told nothing of it).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from probing.core.nonlinearities import NONLINEARITIES
from probing.core.prbs import Probe
from probing.experiment.flight.monitor import monitor_scenario
from probing.experiment.flight.run import run_scenario
from probing.experiment.scenario import parse_scenario, read_toml
from probing.experiment.studies.truth import compute_truth

pytestmark = pytest.mark.jsbsim

ROOT = Path(__file__).resolve().parents[2]
#: A quarter of NASA's pitch-attitude noise (NoiseParams_T2.m: 0.02 deg): this short probe
#: (M = 63) then estimates the gain to about 4 % per period.
THETA_NOISE_RAD = np.radians(0.005)


def closed_loop(**changes) -> dict:
    """A short closed-loop GTM flight: M = 63 at t0 = 0.01 s (T = 0.63 s), a = 0.2 deg,
    pitch, bank and speed held, pitch noise, the monitor learning 30 periods."""
    data = {
        "name": "cl",
        "aircraft": {"model": "gtm_t2"},
        "condition": {"altitude_ft": 800, "speed_kcas": 75},
        "simulation": {"dt_s": 0.01},
        "probe": {
            "order": 6,
            "bit_duration_s": 0.01,
            "amplitude_deg": 0.2,
            "periods": 60,
            "settle_periods": 2,
        },
        "nonlinearity": {"type": "none"},
        "output": {"channels": ["theta_rad"], "drift": "reference", "estimator": "ac"},
        "disturbance": {"seed": 4, "sensor_noise": {"theta_rad": THETA_NOISE_RAD}},
        "control": {"pitch_hold": True, "bank_hold": True, "speed_hold": True},
        "monitor": {"baseline_periods": 30, "windows": 4},
    }
    for key, value in changes.items():
        section, _, name = key.partition(".")
        if value is None:
            data[section].pop(name) if name else data.pop(section)
        elif name:
            data.setdefault(section, {})[name] = value
        else:
            data[section] = value
    return data


def rel_l2(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


#: The paper's probe on theta and q, noise-free, no monitor: for comparing responses.
PAPER_PROBE = {
    "probe.order": 9,
    "probe.amplitude_deg": 0.005,
    "probe.periods": 5,
    "output.channels": ["theta_rad", "q_rad_s"],
    "output.estimator": None,
    "disturbance": {"seed": 0},
    "monitor": None,
}


# ------------------------------------------------------------------ closed-loop truth
def test_closed_loop_probing_matches_its_single_pulse_truth(tmp_path):
    """Closed loop, the paper's probe (M = 511, a = 0.005 deg), no noise: every settled
    period's z agrees with the single-pulse response of the twin flown with the same
    autopilot, superposed over the probe history, within the open-loop test's 1 %; and the
    closed loop's response is not the open loop's (the autopilot acts within the memory)."""
    common = PAPER_PROBE
    z = {}
    for name, control in (("closed", "keep"), ("open", None)):
        changes = {**common, "name": name}
        if control is None:
            changes["control"] = None
        scn = parse_scenario(closed_loop(**changes))
        run_scenario(scn, tmp_path, progress=False)
        pr = pd.read_parquet(tmp_path / name / "probing.parquet")
        z[name] = pr[(pr.channel == "theta_rad") & (pr.period == 4)].z.to_numpy()
        if name == "open":
            continue
        compute_truth(scn, tmp_path)
        pred = pd.read_parquet(tmp_path / name / "prediction.parquet")
        for channel in ("theta_rad", "q_rad_s"):
            for period in range(2, 5):
                sel = (pr.channel == channel) & (pr.period == period)
                got = pr[sel].z.to_numpy()
                want = pred[(pred.channel == channel) & (pred.period == period)].z.to_numpy()
                assert rel_l2(got, want) < 0.01, (channel, period, rel_l2(got, want))
        truth = pd.read_parquet(tmp_path / name / "truth.parquet")
        assert truth.h_lin.isna().all()  # the linearisation is the open-loop aircraft's
    assert rel_l2(z["closed"], z["open"]) > 0.3


def test_a_twin_flying_our_own_commands_recovers_the_open_loop_response(tmp_path):
    """drift = "follow": the nominal twin replays the probed aircraft's autopilot commands, so
    the difference is the probe's own response through the airframe, P A q: in closed loop
    the estimate is the open loop's (q within 1 %; theta within 2 %, where the slow modes'
    transients of the two flights differ), not the closed loop's (over 50 % away)."""
    common = PAPER_PROBE
    z = {}
    for name, changes in (
        ("follow", {"output.drift": "follow"}),
        ("open", {"control": None}),
        ("closed", {}),
    ):
        scn = parse_scenario(closed_loop(name=name, **common, **changes))
        run_scenario(scn, tmp_path, progress=False)
        pr = pd.read_parquet(tmp_path / name / "probing.parquet")
        z[name] = {
            c: pr[(pr.channel == c) & (pr.period == 4)].z.to_numpy()
            for c in common["output.channels"]
        }
    assert rel_l2(z["follow"]["q_rad_s"], z["open"]["q_rad_s"]) < 0.01
    assert rel_l2(z["follow"]["theta_rad"], z["open"]["theta_rad"]) < 0.02
    for channel in ("theta_rad", "q_rad_s"):
        assert rel_l2(z["closed"][channel], z["open"][channel]) > 0.5


# ------------------------------------------------------------------ faults on the probe path
def test_a_nonlinearity_fault_acts_on_the_probe_path_from_its_onset(tmp_path):
    """nl_out_deg is the probe through [nonlinearity] and, from the onset step on, through the
    fault's nonlinearity too (its state starting there), as the core classes compute it."""
    onset_s = 1.3  # inside period 2, not on a bit edge
    data = closed_loop(
        name="nlfault",
        **{
            "probe.periods": 4,
            "control": None,
            "monitor": None,
            "nonlinearity": {"type": "deadband", "lower_deg": -0.02, "upper_deg": 0.02},
            "fault": {
                "type": "nonlinearity",
                "nonlinearity": "backlash",
                "width_deg": 0.1,
                "onset_s": onset_s,
            },
        },
    )
    scn = parse_scenario(data)
    run_scenario(scn, tmp_path, progress=False)
    ts = pd.read_parquet(tmp_path / "nlfault" / "timeseries.parquet")
    probe = Probe(6, 0.01, 0.2).samples(0.01, 4)
    deadband = NONLINEARITIES["deadband"].build({"lower_deg": -0.02, "upper_deg": 0.02})
    q = deadband.apply(probe, 0.01)
    k = round(onset_s / 0.01)
    backlash = NONLINEARITIES["backlash"].build({"width_deg": 0.1})
    expected = np.concatenate((q[:k], backlash.apply(q[k:], 0.01)))
    assert np.array_equal(ts.nl_out_deg.to_numpy(), expected)
    assert not np.array_equal(expected[k:], q[k:])  # the fault changed something


# ------------------------------------------------------------------ the monitor
@pytest.fixture(scope="module")
def flights(tmp_path_factory) -> dict:
    """The same closed-loop flight with no fault, a dead band growing to a~/a = 0.6 at 25 s,
    NASA's left elevator lost at 25 s, and no noise at all."""
    out = tmp_path_factory.mktemp("monitor")
    cases = {
        "healthy": {},
        "deadband": {
            "fault": {
                "type": "nonlinearity",
                "nonlinearity": "deadband",
                "lower_deg": -0.08,
                "upper_deg": 0.08,
                "onset_s": 25.0,
            }
        },
        "elevator": {"fault": {"type": "gtm_damage", "case": 5, "onset_s": 25.0}},
        "quiet": {"disturbance": {"seed": 4}},
    }
    results = {}
    for name, changes in cases.items():
        scn = parse_scenario(closed_loop(name=name, **changes))
        results[name] = (scn, monitor_scenario(scn, out, progress=False), out / name)
    return results


def test_a_healthy_flight_raises_no_alarm_noisy_or_noise_free(flights):
    for name in ("healthy", "quiet"):
        _, result, folder = flights[name]
        assert result.first_alarm_s is None and result.verdict == "none", name
        mon = pd.read_parquet(folder / "monitor.parquet")
        assert not mon.alarm.any()


def test_a_dead_band_onset_is_found_and_called_an_actuator_fault(flights):
    """Dead band of +-0.4 a from 25 s (a~/a = 0.6, eq. 10): the first alarm comes within two
    periods of the onset, the gain against the baseline is 0.6, and the shape is unchanged."""
    _, result, folder = flights["deadband"]
    period_s = 63 * 0.01
    assert 25.0 < result.first_alarm_s <= 25.0 + 2 * period_s
    assert result.verdict == "actuator"
    mon = pd.read_parquet(folder / "monitor.parquet")
    mon = mon[mon.detector == "probing"]  # the pulse response's detector
    after = mon[mon.time_s > 25.0 + period_s]
    assert after.gain_change.median() == pytest.approx(0.6, abs=0.03)
    alarmed = after[after.alarm]
    assert len(alarmed) >= 0.8 * len(after)
    assert (alarmed.verdict == "actuator").mean() >= 0.85  # the shape test's level is 1 %


def test_a_lost_elevator_panel_is_found_and_called_an_airframe_change(flights):
    """NASA's case 5 from 25 s: found in the first period after the onset, and its shape
    changed (the monitor's twin is the nominal aircraft, as it must be)."""
    _, result, folder = flights["elevator"]
    assert 25.0 < result.first_alarm_s <= 25.0 + 2 * 63 * 0.01
    assert result.verdict == "airframe"
    meta = pq.read_schema(folder / "probing.parquet").metadata
    assert json.loads(meta[b"probing.twin"])["nominal"] is True


def with_surface(name: str, fault: dict) -> dict:
    """The flight with the elevator's position sensor (a quarter of NASA's 0.01 deg) as the
    monitor's instrument for isolation."""
    return closed_loop(
        name=name,
        **{
            "output.channels": ["theta_rad", "elevator_deg"],
            "disturbance": {
                "seed": 4,
                "sensor_noise": {"theta_rad": THETA_NOISE_RAD, "elevator_deg": 0.0025},
            },
            "monitor": {"baseline_periods": 30, "windows": 4, "surface": True},
            "fault": fault,
        },
    )


@pytest.mark.parametrize(
    ("fault", "surface", "verdict"),
    [
        ({"type": "effectiveness", "scale": 0.5, "onset_s": 25.0}, True, "actuator"),
        ({"type": "stuck", "onset_s": 25.0}, True, "actuator"),
        ({"type": "gtm_damage", "case": 5, "onset_s": 25.0}, True, "airframe"),
    ],
)
def test_in_closed_loop_the_surface_tells_the_actuator_from_the_airframe(
    tmp_path, fault, surface, verdict
):
    """A weaker or stuck elevator inside the loop changes the closed loop's shape (the
    gain-and-offset rule then calls it airframe, docs/monitoring.md); isolating with the
    surface's own response (H_y = P H_s: the airframe P unchanged; a stuck surface does not
    answer the probe at all) calls it actuator, and NASA's lost elevator panel (P changed,
    the surface still moves as asked) airframe."""
    data = with_surface("s", fault) if surface else closed_loop(name="s", fault=fault)
    result = monitor_scenario(parse_scenario(data), tmp_path, progress=False)
    assert result.first_alarm_s is not None and result.first_alarm_s > 25.0
    assert result.verdict == verdict
    mon = pd.read_parquet(tmp_path / "s" / "monitor.parquet")
    assert set(mon.channel) == {"theta_rad"}  # the surface is an instrument, not monitored


def test_a_departure_ends_the_monitored_flight_and_keeps_what_came_before(tmp_path):
    """Open loop, NASA's vertical tail lost at 22 s: the GTM departs; the monitor's record
    ends at the divergence, with the alarm before it and the reason in the files."""
    data = closed_loop(
        name="dep",
        **{"control": None, "fault": {"type": "gtm_damage", "case": 2, "onset_s": 22.0}},
    )
    result = monitor_scenario(parse_scenario(data), tmp_path, progress=False)
    assert result.ended is not None and "t = " in result.ended
    mon = pd.read_parquet(tmp_path / "dep" / "monitor.parquet")
    assert mon.period.max() < 59  # ended before the last period
    assert result.first_alarm_s is not None and 22.0 < result.first_alarm_s
    meta = pq.read_metadata(tmp_path / "dep" / "probing.parquet").metadata
    assert meta[b"probing.ended"].decode() == result.ended


def test_monitor_file_has_a_row_per_period_and_its_verdict_in_the_metadata(flights):
    scn, result, folder = flights["deadband"]
    table = pq.read_table(folder / "monitor.parquet")
    rows = table.to_pandas()
    meta = pq.read_metadata(folder / "monitor.parquet").metadata  # the file's footer
    first = max(scn.settle_periods, scn.first_estimated_period)
    assert rows.detector.tolist() == ["probing", "trajectory"] * (scn.periods - first)
    trajectory = rows[rows.detector == "trajectory"]
    assert trajectory.period.tolist() == list(range(first, scn.periods))
    mon = rows[rows.detector == "probing"]
    assert mon.period.tolist() == list(range(first, scn.periods))
    assert mon.statistic.iloc[:30].isna().all() and mon.statistic.iloc[30:].notna().all()
    assert (mon.alarm == (mon.statistic > mon.threshold)).all()
    assert json.loads(meta[b"probing.first_alarm_s"]) == pytest.approx(result.first_alarm_s)
    assert meta[b"probing.verdict"] == b"actuator"
    detector = json.loads(meta[b"probing.detector"])
    assert detector["baseline_periods"] == 30 and detector["windows"] == 4
    assert detector["alpha_per_period"] == pytest.approx(0.1 * 63 * 0.01 / 3600)
    assert table.schema.field("time_s").metadata[b"unit"] == b"s"


def _toml(data: dict) -> str:
    lines = []
    for key, value in data.items():
        if not isinstance(value, dict):
            lines.append(f"{key} = {json.dumps(value)}")
    for section, table in data.items():
        if isinstance(table, dict):
            lines.append(f"[{section}]")
            for key, value in table.items():
                if isinstance(value, dict):
                    inner = ", ".join(f"{k} = {json.dumps(v)}" for k, v in value.items())
                    lines.append(f"{key} = {{ {inner} }}")
                else:
                    lines.append(f"{key} = {json.dumps(value)}")
    return "\n".join(lines) + "\n"


def _probing(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "probing", *args], capture_output=True, text=True, cwd=ROOT
    )


def test_cli_monitor_one_line_and_short_runs_refused(tmp_path):
    good = tmp_path / "good.toml"
    good.write_text(_toml(closed_loop(name="good", **{"probe.periods": 34})))
    res = _probing("monitor", str(good), "--out", str(tmp_path / "out"))
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert len(lines) == 1 and "first alarm: none" in lines[0] and "verdict: none" in lines[0]
    assert (tmp_path / "out" / "good" / "monitor.parquet").exists()
    assert not (tmp_path / "out" / "good" / "timeseries.parquet").exists()

    short = tmp_path / "short.toml"
    short.write_text(_toml(closed_loop(name="short", **{"monitor": None, "probe.periods": 40})))
    res = _probing("monitor", str(short), "--out", str(tmp_path / "out2"))
    assert res.returncode == 2 and len(res.stderr.splitlines()) == 1, res.stderr
    assert "monitor.baseline_periods" in res.stderr and "Traceback" not in res.stderr
    assert not (tmp_path / "out2").exists()


def test_a_sensor_bias_offsets_the_measured_channel_from_its_onset_step_only(tmp_path):
    """`probing monitor` on the study's flight (scenarios/monitor/base.toml, shortened), with
    and without a bias on theta_rad: the measured theta differs by exactly the bias from the
    step that starts at the onset on (its output is the row at onset + dt), and not at all
    before; the other channel and the reference twin's theta do not see it."""
    data, _ = read_toml(ROOT / "scenarios" / "monitor" / "base.toml")
    data["probe"].update(order=6, periods=14)  # T = 0.63 s, 8.82 s in all
    data["monitor"].update(baseline_periods=8, window_periods=1)
    onset_s, bias = 5.0, 0.0123  # the onset step: 500, inside period 7
    frames = {}
    for name, fault in (
        ("healthy", None),
        ("biased", {"type": "sensor_bias", "channel": "theta_rad", "bias": bias}),
    ):
        flight = {**data, "name": name}
        if fault is not None:
            flight["fault"] = {**fault, "onset_s": onset_s}
        path = tmp_path / f"{name}.toml"
        path.write_text(_toml(flight))
        res = _probing("monitor", str(path), "--out", str(tmp_path / "out"), "--timeseries")
        assert res.returncode == 0, res.stderr
        frames[name] = pd.read_parquet(tmp_path / "out" / name / "timeseries.parquet")
    healthy, biased = frames["healthy"], frames["biased"]
    k = round(onset_s / 0.01)
    assert biased.time_s.iloc[k] == pytest.approx(onset_s + 0.01)
    theta, theta0 = biased.theta_rad.to_numpy(), healthy.theta_rad.to_numpy()
    assert np.array_equal(theta[:k], theta0[:k])  # up to the step before the onset step
    assert theta[k - 1] == theta0[k - 1] and theta[k] == theta0[k] + bias
    assert np.array_equal(theta[k:], theta0[k:] + bias)
    for column in ("elevator_deg", "theta_rad_reference", "elevator_pos_deg"):
        assert np.array_equal(biased[column].to_numpy(), healthy[column].to_numpy()), column


@pytest.mark.parametrize(
    ("surface", "monitored"),
    [(True, ["theta_rad", "q_rad_s"]), (False, ["theta_rad", "q_rad_s", "elevator_deg"])],
)
def test_the_false_alarm_rate_is_shared_by_the_monitored_channels_only(
    tmp_path, surface, monitored
):
    """theta, q and the elevator's sensor: isolating with the surface, the elevator is an
    instrument and the rate (0.1 per hour) is shared by the two monitored channels, alpha =
    0.1 T / 3600 / 2 per period (T = 63 x 0.01 s); without it, by all three.  Every row's
    threshold is -log10 of that alpha, and each row ends its period: time_s = (p + 1) T
    (the analysis scores delays from it)."""
    period_s = 63 * 0.01
    data = closed_loop(
        name="share",
        **{
            "probe.periods": 14,
            "output.channels": ["theta_rad", "q_rad_s", "elevator_deg"],
            "disturbance": {
                "seed": 4,
                "sensor_noise": {"theta_rad": THETA_NOISE_RAD, "elevator_deg": 0.0025},
            },
            "monitor": {"baseline_periods": 8, "windows": 4, "surface": surface},
        },
    )
    result = monitor_scenario(parse_scenario(data), tmp_path, progress=False)
    alpha = 0.1 * period_s / 3600 / len(monitored)
    assert result.alpha == pytest.approx(alpha, rel=1e-12)
    mon = pd.read_parquet(tmp_path / "share" / "monitor.parquet")
    assert sorted(set(mon.channel)) == sorted(monitored)
    np.testing.assert_allclose(mon.threshold, -np.log10(alpha), rtol=1e-12)
    meta = pq.read_metadata(tmp_path / "share" / "monitor.parquet").metadata
    assert json.loads(meta[b"probing.detector"])["alpha_per_period"] == pytest.approx(alpha)
    assert mon.period.min() == 2 and mon.period.max() == 13
    np.testing.assert_allclose(mon.time_s, (mon.period + 1) * period_s, rtol=1e-12)


def test_the_first_alarms_row_ends_at_the_reported_first_alarm(flights):
    """The dead band flight: the first alarmed row's time_s is the end of its period,
    (p + 1) T, which is the first alarm the metadata and the result report; no row ending
    by the onset (25 s) is alarmed."""
    _, result, folder = flights["deadband"]
    period_s = 63 * 0.01
    mon = pd.read_parquet(folder / "monitor.parquet")
    np.testing.assert_allclose(mon.time_s, (mon.period + 1) * period_s, rtol=1e-12)
    first = mon[mon.alarm].iloc[0]
    assert first.period == result.first_alarm_period
    assert first.time_s == pytest.approx(result.first_alarm_s, rel=1e-12)
    meta = pq.read_metadata(folder / "monitor.parquet").metadata
    assert json.loads(meta[b"probing.first_alarm_s"]) == pytest.approx(first.time_s, rel=1e-12)
    assert not mon[mon.time_s <= 25.0].alarm.any()


@pytest.mark.parametrize(
    ("alarm_s", "period", "detector", "ended", "expected"),
    [
        (None, None, None, None, "first alarm: none; verdict: none"),
        (None, None, None, "x", "first alarm: none; verdict: none; the flight ended: x"),
        (46.0, 22, "probing", None, "first alarm: 46.00 s (period 22, probing); verdict: none"),
    ],
)  # fmt: skip
def test_the_result_line_says_none_without_a_period(alarm_s, period, detector, ended, expected):
    """No alarm: "first alarm: none", not "(period None)"; an alarm keeps its period."""
    from probing.experiment.flight.monitor import MonitorResult

    result = MonitorResult(None, alarm_s, period, "none", 0.01, ended, alarm_detector=detector)
    assert result.line() == expected
