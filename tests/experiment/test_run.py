"""A probing run end to end: Parquet output, ground truth, drift modes, failures."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import base_scenario

from probing.experiment.flight.run import CHUNK_STEPS, chunk_periods, run_scenario
from probing.experiment.output.storage import AtomicParquetWriter
from probing.experiment.scenario import parse_scenario
from probing.experiment.studies.truth import compute_truth, predicted_probing
from probing.sim.errors import DivergenceError

pytestmark = pytest.mark.jsbsim

BASE = base_scenario()


def scenario(**changes):
    scn = parse_scenario(json.loads(json.dumps(BASE)))
    return scn.replace(**changes) if changes else scn


def rel_l2(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


@pytest.fixture(scope="module", autouse=True)
def private_twin_cache(tmp_path_factory):
    """Reference twins go to a fresh cache: every run here simulates its twin once."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PROBING_TWIN_CACHE", str(tmp_path_factory.mktemp("twins")))
        yield


@pytest.fixture(scope="module")
def baseline(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("baseline")
    scn = scenario()
    run_scenario(scn, out, progress=False)
    compute_truth(scn, out)
    return out / scn.name


# --------------------------------------------------------------- the plant
def test_outputs_layout_and_metadata(baseline: Path) -> None:
    probing = pq.read_table(baseline / "probing.parquet")
    df = probing.to_pandas()
    assert list(df.columns) == ["channel", "period", "tap", "lag_s", "z", "zeta", "h_est"]
    assert set(df.channel) == {"theta_rad", "q_rad_s", "alpha_rad"}
    assert sorted(df.period.unique()) == list(range(8))
    assert len(df) == 3 * 8 * 511
    one = df[(df.channel == "theta_rad") & (df.period == 3)]
    np.testing.assert_array_equal(one.tap, np.arange(511))
    np.testing.assert_allclose(one.lag_s, np.arange(511) * 0.01)
    # eq. (9): zeta = z + sum over the period of z; h = zeta / (a (M+1))
    np.testing.assert_allclose(one.zeta, one.z + one.z.sum(), rtol=1e-12)
    np.testing.assert_allclose(one.h_est, one.zeta / (0.005 * 512), rtol=1e-12)
    meta = probing.schema.metadata
    for key in (b"scenario", b"scenario_toml", b"trim", b"versions", b"git_revision", b"drift"):
        assert b"probing." + key in meta
    versions = json.loads(meta[b"probing.versions"])
    assert versions["jsbsim"] == "1.3.3"
    trim = json.loads(meta[b"probing.trim"])
    assert 0 < trim["alpha_deg"] < 10
    ts = pd.read_parquet(baseline / "timeseries.parquet")
    for col in ("time_s", "probe_deg", "nl_out_deg", "elevator_pos_deg", "theta_rad"):
        assert col in ts
    assert len(ts) == 8 * 511
    np.testing.assert_allclose(ts.elevator_pos_deg - trim["elevator_deg"], ts.probe_deg, atol=1e-12)
    assert not any(p.name.startswith(".") for p in baseline.iterdir())


def test_same_scenario_same_numbers(tmp_path: Path, baseline: Path) -> None:
    scn = scenario()
    run_scenario(scn, tmp_path, progress=False)
    a = pd.read_parquet(baseline / "probing.parquet")
    b = pd.read_parquet(tmp_path / scn.name / "probing.parquet")
    pd.testing.assert_frame_equal(a, b, check_exact=True)


def test_ground_truth_agreement(baseline: Path) -> None:
    """The acceptance target of issue [2/6].

    A settled period's z agrees with the superposition of the single-pulse response over
    the actual probe history to 1 % relative L2; the DC-corrected estimate agrees with
    JSBSim's linearised model (folded the same way, one-step delay) over the short-period
    part (first 2 s).  ``h_lin`` is stepped as JSBSim steps the aircraft, its one-step delay
    included.
    """
    pr = pd.read_parquet(baseline / "probing.parquet")
    pred = pd.read_parquet(baseline / "prediction.parquet")
    truth = pd.read_parquet(baseline / "truth.parquet")
    for channel in ("theta_rad", "q_rad_s", "alpha_rad"):
        for period in range(2, 8):
            z = pr[(pr.channel == channel) & (pr.period == period)].z.to_numpy()
            zp = pred[(pred.channel == channel) & (pred.period == period)].z.to_numpy()
            assert rel_l2(z, zp) < 0.01, (channel, period, rel_l2(z, zp))
    scn = scenario()
    h_est = pr[pr.period >= 2].groupby(["channel", "tap"]).h_est.mean()
    limits = {"theta_rad": 0.005, "q_rad_s": 0.02, "alpha_rad": 0.02}
    for channel, limit in limits.items():
        h_lin = truth[truth.channel == channel].h_lin.to_numpy()  # one-step delay included
        expected = predicted_probing(scn, {channel: h_lin})[channel][2:, 2].mean(axis=0)
        est = h_est[channel].to_numpy()
        error = rel_l2(est[:200], expected[:200])
        assert error < limit, (channel, error)
        if channel != "theta_rad":  # theta's folded estimate is dominated by the phugoid tail
            # A step early the agreement is clearly worse: the alignment matters.
            early = np.concatenate((h_lin[1:], [h_lin[-1]]))
            undelayed = predicted_probing(scn, {channel: early})[channel][2:, 2].mean(axis=0)
            assert rel_l2(est[:200], undelayed[:200]) > 1.5 * error


def test_drift_reference_vs_none(tmp_path: Path, baseline: Path) -> None:
    """Without the reference twin the trimmed 737's drift swamps the probing output."""
    scn = scenario(**{"output.drift": "none", "name": "nodrift"})
    run_scenario(scn, tmp_path, progress=False)
    ts = pd.read_parquet(tmp_path / "nodrift" / "timeseries.parquet")
    ref = pd.read_parquet(baseline / "timeseries.parquet")
    drift = ref.theta_rad_reference.to_numpy()
    period = slice(2 * 511, 3 * 511)
    assert abs(drift[period].max() - drift[period].min()) > 1e-4  # the unprobed pitch moves
    np.testing.assert_allclose(ts.theta_rad, ref.theta_rad, rtol=0, atol=1e-15)
    a = pd.read_parquet(tmp_path / "nodrift" / "probing.parquet")
    b = pd.read_parquet(baseline / "probing.parquet")
    za = a[(a.channel == "theta_rad") & (a.period == 4)].z.to_numpy()
    zb = b[(b.channel == "theta_rad") & (b.period == 4)].z.to_numpy()
    assert np.linalg.norm(za) / np.linalg.norm(zb) > 3


def test_detrend_mode_beats_no_correction(tmp_path: Path, baseline: Path) -> None:
    """Detrending (the flight-data option: a periodic part and a trend fitted together per
    window) brings z closer to the twin-corrected z.

    It cannot tell the slow part of the response from drift: theta keeps a large error
    (measured 1.38 relative L2 against 5.8 without correction), while the short-period
    channels keep their shape (4.7 % for q, 3.3 % for alpha; docs/method.md, "Drift").
    """
    for drift in ("detrend", "none"):
        run_scenario(scenario(**{"output.drift": drift, "name": drift}), tmp_path, progress=False)
    table = pq.read_table(tmp_path / "detrend" / "probing.parquet")
    assert table.schema.metadata[b"probing.drift"] == b"detrend"
    det, raw = table.to_pandas(), pd.read_parquet(tmp_path / "none" / "probing.parquet")
    assert det.period.min() == 1  # period 0 has no previous period to detrend with
    ref = pd.read_parquet(baseline / "probing.parquet")

    def z_of(df, channel):
        return df[(df.channel == channel) & (df.period == 5)].z.to_numpy()

    for channel in ("theta_rad", "q_rad_s", "alpha_rad"):
        zr = z_of(ref, channel)
        assert rel_l2(z_of(det, channel), zr) < 0.5 * rel_l2(z_of(raw, channel), zr)
    for channel in ("q_rad_s", "alpha_rad"):
        zd, zr = z_of(det, channel), z_of(ref, channel)
        assert rel_l2(zd - zd.mean(), zr - zr.mean()) < 0.1


def test_divergence_stops_cleanly(tmp_path: Path) -> None:
    """A relay stuck far nose-down dives the aircraft: clear error, nothing left behind."""
    scn = scenario(
        **{
            "name": "dive",
            "probe.order": 6,
            "probe.periods": 400,
            "nonlinearity.type": "relay",
            "nonlinearity.threshold_deg": 1.0,
            "nonlinearity.low_deg": 15.0,
            "nonlinearity.high_deg": 15.0,
        }
    )
    out = tmp_path / "out"
    with pytest.raises(DivergenceError):
        run_scenario(scn, out, progress=False)
    assert not out.exists()


def test_cli_run_and_exit_codes(tmp_path: Path) -> None:
    path = tmp_path / "s.toml"
    path.write_text(
        'name = "cli"\n[aircraft]\nmodel = "737"\n[condition]\naltitude_ft = 15000\n'
        "speed_kcas = 280\n[simulation]\ndt_s = 0.01\n[probe]\norder = 5\n"
        "bit_duration_s = 0.02\namplitude_deg = 0.01\nperiods = 3\nsettle_periods = 1\n"
        '[nonlinearity]\ntype = "backlash"\nwidth_deg = 0.005\n[output]\n'
        'channels = ["theta_rad"]\n'
    )
    res = subprocess.run(
        [sys.executable, "-m", "probing", "run", str(path), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert res.returncode == 0, res.stderr
    assert res.stderr == ""  # not a TTY: no progress bar, and no JSBSim banner
    df = pd.read_parquet(tmp_path / "o" / "cli" / "probing.parquet")
    assert len(df) == 3 * 31
    bad = path.with_name("bad.toml")
    bad.write_text(path.read_text().replace("speed_kcas = 280", "speed_kcas = 30"))
    res = subprocess.run(
        [sys.executable, "-m", "probing", "run", str(bad), "--out", str(tmp_path / "o2")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert res.returncode == 1
    assert len(res.stderr.strip().splitlines()) == 1
    assert "trim failed" in res.stderr and "speed_kcas = 30" in res.stderr
    assert not (tmp_path / "o2").exists()


def test_turbulence_is_seeded_and_shared_with_the_twin(tmp_path: Path) -> None:
    """Same seed, same gusts (run to run and probed vs twin); another seed, other gusts."""

    def theta(seed: int, name: str) -> pd.DataFrame:
        scn = scenario(
            **{
                "name": name,
                "probe.order": 6,
                "probe.periods": 3,
                "probe.settle_periods": 1,
                "disturbance.turbulence": "moderate",
                "output.drift": "oracle",
                "disturbance.seed": seed,
            }
        )
        run_scenario(scn, tmp_path, progress=False)
        return pd.read_parquet(tmp_path / name / "timeseries.parquet")

    a, b, c = theta(1, "a"), theta(1, "b"), theta(2, "c")
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    assert np.abs(a.theta_rad - c.theta_rad).max() > 1e-4
    # The twin flies through the same gusts: the probed-minus-twin difference is small
    # against the gust response itself (probe response ~1e-5 rad, gusts ~1e-3 rad).
    gust = np.abs(a.theta_rad_reference - a.theta_rad_reference.iloc[0]).max()
    diff = np.abs(a.theta_rad - a.theta_rad_reference).max()
    assert gust > 1e-3 and diff < 0.05 * gust


def test_progress_bar_only_when_asked_or_on_a_tty(tmp_path: Path) -> None:
    import io

    scn = scenario(**{"name": "bar", "probe.order": 5, "probe.periods": 3})
    shown, hidden = io.StringIO(), io.StringIO()  # StringIO is not a TTY
    run_scenario(scn, tmp_path, progress=True, stream=shown)
    run_scenario(scn, tmp_path, stream=hidden)
    assert "3/3 periods" in shown.getvalue() and "ETA" in shown.getvalue()
    assert hidden.getvalue() == ""


def test_parquet_rows_are_buffered_into_large_row_groups(tmp_path: Path) -> None:
    """Row groups of >= row_group_rows rows; a caller may reuse its arrays after write()."""
    schema = pa.schema([("s", pa.string()), ("k", pa.int64()), ("x", pa.float64())])
    writer = AtomicParquetWriter(tmp_path / "f.parquet", schema, {b"probing.t": b"1"}, 100)
    buf = np.empty(30)  # reused for every chunk, like the run's elevator buffer
    for i in range(7):
        buf[:] = np.arange(30) + 30 * i
        writer.write({"s": ["a"] * 30, "k": np.arange(30) + 30 * i, "x": buf})
    assert not (tmp_path / "f.parquet").exists()
    writer.close()
    f = pq.ParquetFile(tmp_path / "f.parquet")
    assert [f.metadata.row_group(i).num_rows for i in range(f.num_row_groups)] == [120, 90]
    table = f.read()
    np.testing.assert_array_equal(table["x"].to_numpy(), np.arange(210.0))
    np.testing.assert_array_equal(table["k"].to_numpy(), np.arange(210))
    assert table.schema.metadata[b"probing.t"] == b"1"
    assert [p.name for p in tmp_path.iterdir()] == ["f.parquet"]


@pytest.mark.parametrize("drift", ["oracle", "detrend"])
def test_chunked_post_processing_matches_period_by_period(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, drift: str
) -> None:
    """Periods post-processed in chunks of 1, 2 (+ a partial one) or all: the same results.

    The time series are bit-identical; the probing outputs agree to rounding (the FFT
    block of the correlator follows the chunk size).
    """
    import probing.experiment.flight.run as run_module

    scn = scenario(
        **{
            "probe.order": 6,
            "probe.periods": 5,
            "probe.settle_periods": 1,
            "output.drift": drift,
            "disturbance.sensor_noise": {"q_rad_s": 1e-5},
            "disturbance.turbulence": "light",
        }
    )
    results = []
    for periods_per_chunk in (1, 2, 5):
        monkeypatch.setattr(run_module, "CHUNK_STEPS", periods_per_chunk * 63)
        res = run_scenario(scn, tmp_path / str(periods_per_chunk), progress=False)
        results.append((res, frames_of(res.out_dir)))
    (ref, (pr0, ts0)), *others = results
    for res, (pr, ts) in others:
        pd.testing.assert_frame_equal(ts, ts0, check_exact=True)
        pd.testing.assert_frame_equal(
            pr[["channel", "period", "tap"]], pr0[["channel", "period", "tap"]]
        )
        for col in ("z", "zeta", "h_est"):
            np.testing.assert_allclose(pr[col], pr0[col], rtol=1e-9, atol=1e-15)
        for c in scn.channels:
            np.testing.assert_allclose(res.h_est[c], ref.h_est[c], rtol=1e-9, atol=1e-15)


def frames_of(folder: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    return pd.read_parquet(folder / "probing.parquet"), pd.read_parquet(
        folder / "timeseries.parquet"
    )


# ------------------------------------------------------------------ the run against its files
def _settled_means(folder: Path, scn) -> dict[str, np.ndarray]:
    """Mean settled h_est per channel, read independently of the run: pandas on the file;
    NaN for a channel without a settled period whose h is finite at every tap."""
    df = pd.read_parquet(folder / "probing.parquet")
    df = df[df.period >= scn.settle_periods]
    out = {}
    for channel, rows in df.groupby("channel"):
        h = rows.pivot(index="period", columns="tap", values="h_est").to_numpy()
        h = h[np.all(np.isfinite(h), axis=1)]
        out[channel] = h.mean(axis=0) if len(h) else np.full(h.shape[1], np.nan)
    return out


def _dead_sensor(monkeypatch: pytest.MonkeyPatch, period: int | None, channel: int) -> None:
    """The probed aircraft's ``channel`` reads NaN once, in ``period`` (None: never)."""
    import probing.sim.world as world_module

    fly = world_module.JSBSimWorld.fly_commands
    calls = {"probed": 0}

    def fly_with_a_dead_sensor(self, commands, nodes, out, position=None):
        fly(self, commands, nodes, out, position)
        if commands is not None:  # the probed aircraft, one period per call
            if calls["probed"] == period:
                out[5, channel] = np.nan
            calls["probed"] += 1

    monkeypatch.setattr(world_module.JSBSimWorld, "fly_commands", fly_with_a_dead_sensor)


def test_run_result_is_the_mean_of_the_settled_periods_in_the_file_channel_by_channel(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A sensor that reads NaN once leaves its channel without a finite settled period
    (the FFT correlator carries the NaN on); the other channel is untouched.  Each channel
    averages over its own settled periods: the count used to follow channel 0 only, which
    turned the dead channel's empty sum into a mean of exactly zero."""
    _dead_sensor(monkeypatch, period=3, channel=1)  # q_rad_s
    scn = scenario(
        **{
            "probe.order": 6,
            "probe.periods": 7,
            "probe.settle_periods": 1,
            "output.channels": ["theta_rad", "q_rad_s"],
        }
    )
    result = run_scenario(scn, tmp_path, progress=False, twin_cache=False)
    means = _settled_means(result.out_dir, scn)
    assert np.all(np.isfinite(means["theta_rad"])) and np.all(np.isnan(means["q_rad_s"]))
    for channel in scn.channels:
        np.testing.assert_allclose(result.h_est[channel], means[channel], rtol=1e-12)


@pytest.mark.parametrize(
    ("estimator", "drift", "dead_period"),
    [("streaming", "reference", None), ("streaming", "detrend", 3), ("cyclic", "none", 4)],
)
def test_kept_settled_periods_are_what_read_settled_reads_back(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, estimator: str, drift: str, dead_period
) -> None:
    """A sweep takes the first channel's settled periods from the run instead of reading
    its file again: they must be the file's, bit for bit, with the same periods left out
    (before settling, or not finite at every tap: a NaN sample in ``dead_period``)."""
    from probing.experiment.output.storage import read_settled

    _dead_sensor(monkeypatch, period=dead_period, channel=0)
    scn = scenario(
        **{
            "probe.order": 6,
            "probe.periods": 7,
            "probe.settle_periods": 2,
            "output.channels": ["q_rad_s", "theta_rad"],
            "output.drift": drift,
            "output.estimator": estimator,
        }
    )
    result = run_scenario(scn, tmp_path, progress=False, twin_cache=False, keep_settled=True)
    kept = result.settled
    back = read_settled(result.out_dir / "probing.parquet", "q_rad_s", 2, scn.bits_per_period)
    assert kept is not None and 0 < len(back.periods) < scn.periods - 2 + (dead_period is None)
    for name in ("periods", "lag_s", "z", "h"):
        np.testing.assert_array_equal(getattr(kept, name), getattr(back, name), err_msg=name)
    assert run_scenario(scn, tmp_path / "again", progress=False, twin_cache=False).settled is None


def test_z_is_eq5_on_measured_minus_reference_sampled_at_the_end_of_each_bit(
    tmp_path: Path,
) -> None:
    """With 3 steps per bit, z of every complete period is the sliding correlation (eq. 5)
    of the end-of-bit samples of measured - reference from timeseries.parquet."""
    from probing.core.prbs import mls

    scn = scenario(
        **{
            "probe.order": 5,
            "probe.bit_duration_s": 0.03,
            "probe.periods": 4,
            "probe.settle_periods": 1,
            "output.channels": ["theta_rad", "q_rad_s"],
            "output.drift": "oracle",
            "disturbance.sensor_noise": {"q_rad_s": 1e-5},
            "disturbance.turbulence": "light",
        }
    )
    result = run_scenario(scn, tmp_path, progress=False)
    ts = pd.read_parquet(result.out_dir / "timeseries.parquet")
    pr = pd.read_parquet(result.out_dir / "probing.parquet")
    sigma, m, spb = mls(5), 31, 3
    for channel in scn.channels:
        y = (ts[channel] - ts[f"{channel}_reference"]).to_numpy()[spb - 1 :: spb]
        z = np.correlate(y, sigma, mode="valid")  # z[k] for sample k = M-1 .. end
        for period in range(1, scn.periods):
            # sample j of period p carries tap j+1; its last sample carries tap 0
            samples = period * m + (np.arange(m) - 1) % m
            expected = z[samples - (m - 1)]
            got = pr[(pr.channel == channel) & (pr.period == period)].z.to_numpy()
            np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-15)


def test_sensor_noise_on_one_channel_changes_only_that_channel(tmp_path: Path) -> None:
    common = {
        "probe.order": 5,
        "probe.periods": 3,
        "probe.settle_periods": 1,
        "output.channels": ["theta_rad", "q_rad_s"],
    }
    quiet = run_scenario(scenario(**common, name="quiet"), tmp_path, progress=False)
    noisy_scn = scenario(**common, name="noisy", **{"disturbance.sensor_noise": {"q_rad_s": 1e-4}})
    noisy = run_scenario(noisy_scn, tmp_path, progress=False)
    a, b = (pd.read_parquet(r.out_dir / "timeseries.parquet") for r in (quiet, noisy))
    pd.testing.assert_series_equal(a.theta_rad, b.theta_rad, check_exact=True)
    assert 0.5e-4 < float((b.q_rad_s - a.q_rad_s).std()) < 2e-4
    pa_, pb_ = (pd.read_parquet(r.out_dir / "probing.parquet") for r in (quiet, noisy))
    theta = pa_.channel == "theta_rad"
    pd.testing.assert_frame_equal(pa_[theta], pb_[theta], check_exact=True)
    assert not np.allclose(pa_[~theta].z, pb_[~theta].z)


@pytest.mark.parametrize(("estimator", "drift"), [("cyclic", "reference"), ("ac", "detrend")])
def test_cyclic_estimators_read_each_period_from_the_files_samples(
    tmp_path: Path, estimator: str, drift: str
) -> None:
    """The run's cyclic and ac estimates are the estimators applied to each period's own end-of-
    bit samples of timeseries.parquet, from period 0; with drift mode detrend each period's
    from the window of itself and the period before, detrended by the joint fit, from period 1."""
    from probing.core.noise import cyclic_estimates
    from probing.core.prbs import mls
    from probing.core.trend import detrend_periodic

    scn = scenario(
        **{
            "probe.order": 5,
            "probe.bit_duration_s": 0.02,
            "probe.periods": 4,
            "probe.settle_periods": 1,
            "output.channels": ["theta_rad", "q_rad_s"],
            "output.estimator": estimator,
            "output.drift": drift,
            "disturbance.sensor_noise": {"q_rad_s": 1e-5},
        }
    )
    result = run_scenario(scn, tmp_path, progress=False)
    ts = pd.read_parquet(result.out_dir / "timeseries.parquet")
    pr = pd.read_parquet(result.out_dir / "probing.parquet")
    first = 1 if drift == "detrend" else 0
    assert sorted(pr.period.unique()) == list(range(first, 4))
    for channel in scn.channels:
        base = ts[f"{channel}_reference"] if drift == "reference" else ts[channel].iloc[0] * 0
        y = (ts[channel] - base).to_numpy()[1::2].reshape(4, 31)
        if drift == "detrend":
            y = np.stack(
                [detrend_periodic(y[p - 1 : p + 1].reshape(-1), 31)[31:] for p in (1, 2, 3)]
            )
        z, zeta, h = cyclic_estimates(y, mls(5), 0.005, dc=estimator == "cyclic")
        rows = pr[pr.channel == channel].sort_values(["period", "tap"])
        for column, expected in (("z", z), ("zeta", zeta), ("h_est", h)):
            got = rows[column].to_numpy()
            np.testing.assert_allclose(got, expected.reshape(-1), rtol=1e-9, atol=1e-15)
        settled = h[1 - first :].mean(axis=0)
        np.testing.assert_allclose(result.h_est[channel], settled, rtol=1e-9, atol=1e-15)


# ------------------------------------------------------------------ bounds.parquet
@pytest.mark.parametrize("dead_period", [None, 3])
def test_bounds_file_is_tap_bounds_of_the_settled_periods_of_probing_parquet(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, dead_period: int | None
) -> None:
    """``bounds.parquet`` beside ``probing.parquet``: per channel and tap, exactly
    :func:`tap_bounds` at 0.95 of the settled h read back from ``probing.parquet`` (a channel
    whose settled periods are not finite: NaN, its dof -1), with the level and the degrees
    of freedom in its metadata, in ``probing analyze``'s layout."""
    from probing.core.recorded import tap_bounds
    from probing.experiment.output.layouts import BOUNDS_SCHEMA
    from probing.experiment.output.storage import read_settled

    _dead_sensor(monkeypatch, period=dead_period, channel=1)  # q_rad_s
    scn = scenario(
        **{
            "probe.order": 6,
            "probe.periods": 5,
            "probe.settle_periods": 1,
            "output.channels": ["theta_rad", "q_rad_s"],
        }
    )
    result = run_scenario(scn, tmp_path, progress=False, twin_cache=False)
    table = pq.read_table(result.out_dir / "bounds.parquet")
    assert table.schema.names == BOUNDS_SCHEMA.names
    conf = json.loads(table.schema.metadata[b"probing.confidence"])
    dof = {"theta_rad": 3, "q_rad_s": 3 if dead_period is None else -1}
    assert conf == {
        "level": 0.95,
        "interval": "Student-t",
        "dof": 3 if dead_period is None else dof,
    }
    df = table.to_pandas()
    assert list(df.channel.unique()) == ["theta_rad", "q_rad_s"]
    for channel in scn.channels:
        rows = df[df.channel == channel]
        np.testing.assert_array_equal(rows.tap, np.arange(63))
        settled = read_settled(result.out_dir / "probing.parquet", channel, 1, 63)
        np.testing.assert_array_equal(rows.lag_s, settled.lag_s)
        assert len(settled.h) == dof[channel] + 1
        if len(settled.h) < 2:
            assert rows[["h_est", "h_low", "h_high", "h_std"]].isna().all().all()
            continue
        for column, want in zip(
            ("h_est", "h_low", "h_high", "h_std"), tap_bounds(settled.h, 0.95), strict=True
        ):
            np.testing.assert_array_equal(rows[column].to_numpy(), want)
    units = json.loads(table.schema.metadata[b"probing.units"])
    assert units["h_low"] == {"theta_rad": "rad/deg", "q_rad_s": "rad/s/deg"}


def test_bounds_file_leaves_probing_parquet_as_it_was(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Writing ``bounds.parquet`` changes no byte of ``probing.parquet``."""
    import probing.experiment.output.bounds as bounds_module

    scn = scenario(**{"probe.order": 5, "probe.periods": 3, "probe.settle_periods": 1})
    with_bounds = run_scenario(scn, tmp_path / "with", progress=False)
    monkeypatch.setattr(bounds_module, "write_settled_bounds", lambda *args: None)
    without = run_scenario(scn, tmp_path / "without", progress=False)
    assert (with_bounds.out_dir / "bounds.parquet").is_file()
    assert not (without.out_dir / "bounds.parquet").exists()
    for name in ("probing.parquet", "timeseries.parquet"):
        assert (with_bounds.out_dir / name).read_bytes() == (without.out_dir / name).read_bytes()


def test_a_run_with_one_settled_period_writes_no_bounds(tmp_path: Path) -> None:
    """One settled period has no scatter: the run succeeds without ``bounds.parquet``."""
    scn = scenario(**{"probe.order": 5, "probe.periods": 3, "probe.settle_periods": 2})
    result = run_scenario(scn, tmp_path, progress=False)
    assert sorted(p.name for p in result.out_dir.iterdir()) == [
        "probing.parquet",
        "timeseries.parquet",
    ]


def test_bounds_carry_the_noise_models_prediction_where_it_covers_the_run(tmp_path: Path) -> None:
    """Open loop in calm air with white sensor noise: ``h_model_sd`` is the noise model's
    standard deviation of the settled mean (scatter_models), for the scenario's own
    estimator; in turbulence the model does not cover the run and the column is NaN."""
    from probing.experiment.output.scatter import model_covers, scatter_models

    noisy = scenario(
        **{
            "probe.order": 6,
            "probe.periods": 5,
            "probe.settle_periods": 1,
            "output.channels": ["theta_rad", "q_rad_s"],
            "output.estimator": "cyclic",
            "disturbance.sensor_noise": {"theta_rad": 1e-5, "q_rad_s": 1e-4},
        }
    )
    assert model_covers(noisy)
    out = run_scenario(noisy, tmp_path / "calm", progress=False).out_dir
    bounds = pd.read_parquet(out / "bounds.parquet")
    models = scatter_models(noisy)
    for channel in noisy.channels:
        got = bounds[bounds.channel == channel].sort_values("tap").h_model_sd.to_numpy()
        np.testing.assert_allclose(got, models[channel].h_std(), rtol=1e-12)
        assert got.min() > 0
    gusty = noisy.replace({"disturbance.turbulence": "light", "output.drift": "oracle"})
    assert not model_covers(gusty)
    out = run_scenario(gusty, tmp_path / "gusty", progress=False).out_dir
    assert pd.read_parquet(out / "bounds.parquet").h_model_sd.isna().all()


def test_a_detrended_runs_bounds_are_its_settled_periods_pinned_by_their_tail(
    tmp_path: Path,
) -> None:
    """``drift = "detrend"``: no model carries the baseline, so the bounds are those of each
    channel's settled periods (read back from ``probing.parquet``) pinned by their tail,
    as ``probing analyze`` pins a record's; ``probing.convention`` says which convention
    each channel got, and a reference run says ``reference``."""
    from probing.core.pinning import pin_settled_tail, tail_taps
    from probing.core.recorded import tap_bounds
    from probing.experiment.output.storage import read_settled

    base = {"probe.order": 6, "probe.periods": 6, "probe.settle_periods": 2}
    scn = scenario(**base, **{"output.drift": "detrend", "output.estimator": "cyclic"})
    # noise on q that hides its tail, none on theta whose tail has not settled: one of each
    scn = scn.replace(**{"disturbance.sensor_noise": {"q_rad_s": 1e-3}})
    result = run_scenario(scn, tmp_path / "detrend", progress=False, twin_cache=False)
    table = pq.read_table(result.out_dir / "bounds.parquet")
    conv = json.loads(table.schema.metadata[b"probing.convention"])
    df = table.to_pandas()
    assert conv["tail"]["taps"] == tail_taps(63) == 16
    assert conv["h_est"]["q_rad_s"] == "settled tail" and conv["h_est"]["theta_rad"] == "zero mean"
    for channel in scn.channels:
        settled = read_settled(result.out_dir / "probing.parquet", channel, 2, 63)
        pin = pin_settled_tail(np.array(settled.h)[:, None, :], 16)
        want = tap_bounds(pin.h[:, 0])
        assert conv["h_est"][channel] == pin.conventions([channel])[channel]
        np.testing.assert_allclose(df[df.channel == channel].h_est, want[0], rtol=0, atol=1e-15)
    reference = run_scenario(scenario(**base), tmp_path / "ref", progress=False)
    meta = pq.read_metadata(reference.out_dir / "bounds.parquet").metadata
    assert json.loads(meta[b"probing.convention"])["h_est"] == dict.fromkeys(
        scn.channels, "reference"
    )


@pytest.mark.parametrize(
    ("period_steps", "periods"),
    [(CHUNK_STEPS // 2, 2), (CHUNK_STEPS // 2 + 1, 1), (CHUNK_STEPS, 1), (CHUNK_STEPS + 1, 1)],
)
def test_a_chunk_is_the_whole_periods_in_chunk_steps_at_least_one(period_steps, periods):
    """Two periods of half a chunk fill it, a step more and one fits; a period of a chunk or
    longer is a chunk alone (never none)."""
    assert chunk_periods(period_steps) == periods
