"""docs/architecture.md's "How to add" sections, done in a test: a fault type, a sensor channel
and a runner are each added here (the registry monkeypatched, never edited), and the fault
type and the channel are flown live (against a ``jsbsim`` process the test starts) and in
this process, acting alike in both to the socket's 6 digits."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.signal import lfilter
from test_live import SCENARIO, _fly_live, _table

from probing.api import calls
from probing.cli import main
from probing.cli import run as run_cli
from probing.core.faults import FAULTS, FaultField, FaultType, onset_step
from probing.core.sensors import SENSOR_SUITES, SensorSpec, SensorSuite
from probing.experiment.flight import monitor as monitor_module
from probing.experiment.flight import onboard, runners
from probing.experiment.flight.live import LiveError, check_live
from probing.experiment.flight.monitor import monitor_scenario, replay_monitor
from probing.experiment.flight.runners import Runner
from probing.experiment.scenario import load_scenario
from probing.experiment.scenario.references import REFERENCES, Reference
from probing.experiment.studies import truth
from probing.sim.channels import CHANNELS, Channel

pytestmark = pytest.mark.jsbsim

ROOT = Path(__file__).resolve().parents[2]

#: A short flight: the 737 of tests/experiment/test_live.py, 8 periods of 0.62 s, no noise.
SHORT = SCENARIO.replace("periods = 10", "periods = 8").replace(
    "sensor_noise = { theta_rad = 1e-6 }\n", ""
)


def _with(text: str, name: str, extra: str = "", channels: list[str] | None = None) -> str:
    """:data:`SHORT` renamed ``name``, its channels ``channels``, ``extra`` appended."""
    text = text.replace('name = "live-737"', f'name = "{name}"')
    if channels is not None:
        text = text.replace(
            'channels = ["theta_rad", "q_rad_s", "alpha_rad"]',
            f"channels = {json.dumps(channels)}",
        )
    return text + extra


#: With NASA's T2 sensors in place of no noise (their noise and bias; streaming estimator).
SUITE = '[sensors]\nsuite = "{suite}"\n'


def _sensed(text: str, suite: str = "nasa_t2") -> str:
    return text.replace('drift = "detrend"', 'drift = "none"') + SUITE.format(suite=suite)


def _six_digits(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Where ``a`` (a live flight's) and ``b`` (this process's) agree in 6 significant
    digits: within 1e-5 of ``b``.  A live value is read through the socket in 6 digits, and
    the separate simulator's trim is not this process's to the last bit (measured: it
    leaves theta 3.3e-7 rad above alpha, this one none), so they differ by up to 1.7 units
    of the sixth digit (the pilot's load factor, about 1 g)."""
    return np.abs(a - b) <= 1e-5 * np.abs(b)


def _fly_both(base: Path, text: str) -> tuple[object, Path, Path]:
    """``text`` flown live (a jsbsim process of its own) and in this process: (scenario,
    the live flight's folder, this process's)."""
    (base / "live").mkdir()
    scn = _fly_live(base / "live", text)
    monitor_scenario(scn, base / "here", progress=False)
    return scn, base / "live" / scn.name, base / "here" / scn.name


# ------------------------------------------------------------------ a fault type
@dataclass(frozen=True)
class SensorRamp:
    """A new kind of sensor fault: one channel's measurement drifts by ``slope`` a step from
    the onset step on (its first step already off by one ``slope``).  It implements
    :class:`probing.core.faults.SensorFault` (``channel``, ``onset_s``, ``measure``) and
    nothing else."""

    channel: str
    slope: float
    onset_s: float

    def measure(self, value: float, step: int, onset: int) -> float:
        return value + self.slope * (step - onset + 1) if step >= onset else value


SENSOR_RAMP = FaultType(
    "sensor_ramp",
    "sensor",
    "sensor",
    (
        FaultField("channel", "channel", description="the measured output channel"),
        FaultField("slope", "number", "channel", -1.0, 1.0, "the drift a step, channel unit"),
    ),
    "one measured channel drifts from the onset on (a sensor's bias growing)",
    lambda onset_s, v: SensorRamp(str(v["channel"]), float(v["slope"]), onset_s),
)

#: The fault's onset (s; step 200, inside period 3) and slope (rad a step).
ONSET_S, SLOPE = 2.0, 1e-4

FAULT = (
    f'[fault]\ntype = "sensor_ramp"\nchannel = "alpha_rad"\nslope = {SLOPE}\nonset_s = {ONSET_S}\n'
)


@pytest.fixture(scope="module", params=["noise", "suite"])
def scaled(request, tmp_path_factory):
    """The fault type added to FAULTS; the flight with it live and in this process, and
    without it in this process: without sensors (the block form of the hook,
    :class:`~probing.core.measuring.ChannelNoise`) and with NASA's T2 suite (step by step)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(FAULTS, "sensor_ramp", SENSOR_RAMP)
        base = tmp_path_factory.mktemp(f"scaled-{request.param}")
        texts = {n: _with(SHORT, f"{n}-{request.param}") for n in ("scaled", "healthy")}
        if request.param == "suite":
            texts = {n: _sensed(t) for n, t in texts.items()}
        scn, live, here = _fly_both(base, texts["scaled"] + FAULT)
        (base / "healthy.toml").write_text(texts["healthy"])
        healthy = load_scenario(base / "healthy.toml")
        monitor_scenario(healthy, base / "here", progress=False)
        replayed = replay_monitor(live / "sensors.parquet", base / "replay", progress=False)
        yield SimpleNamespace(
            scn=scn,
            live=_table(live, "sensors.parquet"),
            here=_table(here, "sensors.parquet"),
            healthy=_table(base / "here" / healthy.name, "sensors.parquet"),
            replay_probing=_table(replayed.out_dir, "probing.parquet"),
            live_probing=_table(live, "probing.parquet"),
        )


def test_a_new_fault_type_is_a_scenario_type_written_back(scaled):
    scn = scaled.scn
    assert scn.fault_type == "sensor_ramp"
    assert scn.build_fault("sensor") == SensorRamp("alpha_rad", SLOPE, ONSET_S)
    assert scn.to_dict()["fault"] == {
        "type": "sensor_ramp",
        "onset_s": ONSET_S,
        "channel": "alpha_rad",
        "slope": SLOPE,
    }


def test_a_new_fault_type_acts_from_its_onset_step_in_this_process(scaled):
    """The flight with and without it: the same up to the step before the onset step, the
    measurement off by one slope at the onset step and one more each step after (row k is
    the output after step k)."""
    k = onset_step(ONSET_S, scaled.scn.dt_s)
    alpha, alpha0 = scaled.here.alpha_rad.to_numpy(), scaled.healthy.alpha_rad.to_numpy()
    assert np.array_equal(alpha[:k], alpha0[:k])
    assert alpha[k - 1] == alpha0[k - 1] and alpha[k] == alpha0[k] + SLOPE
    assert np.array_equal(alpha[k:], alpha0[k:] + SLOPE * np.arange(1, len(alpha) - k + 1))
    assert np.array_equal(scaled.here.theta_rad, scaled.healthy.theta_rad)  # one channel only


def test_a_new_fault_type_acts_from_its_onset_step_live_as_in_this_process(scaled):
    """Live, the measurement at the step before the onset step is the healthy one and at
    the onset step the drifted one, each equal to this process's to the socket's 6 digits
    (and not to the other: the slope is far beyond them)."""
    k = onset_step(ONSET_S, scaled.scn.dt_s)
    live = scaled.live.alpha_rad.to_numpy()
    here, healthy = scaled.here.alpha_rad.to_numpy(), scaled.healthy.alpha_rad.to_numpy()
    assert len(live) == len(here) == scaled.scn.total_steps
    assert _six_digits(live[[k - 1, k]], here[[k - 1, k]]).all()
    assert _six_digits(live[k - 1], healthy[k - 1]) and _six_digits(live[k], healthy[k] + SLOPE)
    assert not _six_digits(live[k - 1], healthy[k - 1] + SLOPE)
    assert not _six_digits(live[k], healthy[k])
    assert _six_digits(live, here).all()


def test_a_live_flight_with_a_new_fault_type_replays_bit_for_bit(scaled):
    assert len(scaled.live_probing) > 0 and scaled.live_probing.equals(scaled.replay_probing)


# ------------------------------------------------------------------ a sensor channel
#: A JSBSim property not in CHANNELS: the normal load factor at the pilot's station.
PILOT = Channel(
    "nz_pilot_g", "accelerations/n-pilot-z-norm", "g", "normal load factor at the pilot's station"
)

#: NASA's T2 suite with an accelerometer at the pilot's station (numbers of the test's).
T2_PILOT = SensorSuite(
    "nasa_t2_pilot",
    {**SENSOR_SUITES["nasa_t2"].sensors, "nz_pilot_g": SensorSpec(noise_sigma=0.004, bias=0.002)},
    "nasa_t2 and the test's accelerometer at the pilot's station",
)

PILOT_CHANNELS = ["theta_rad", "q_rad_s", "nz_pilot_g"]


@pytest.fixture(scope="module", params=["noise", "suite"])
def pilot(request, tmp_path_factory):
    """The channel added to CHANNELS (and, with sensors, a suite that measures it); a flight
    estimating it live and in this process, without sensors and with the suite."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(CHANNELS, PILOT.name, PILOT)
        mp.setitem(SENSOR_SUITES, T2_PILOT.name, T2_PILOT)
        base = tmp_path_factory.mktemp(f"pilot-{request.param}")
        text = _with(SHORT, f"pilot-{request.param}", channels=PILOT_CHANNELS)
        if request.param == "suite":
            text = _sensed(text, T2_PILOT.name)
        scn, live, here = _fly_both(base, text)
        yield SimpleNamespace(
            scn=scn,
            live=_table(live, "sensors.parquet"),
            here=_table(here, "sensors.parquet"),
            live_probing=_table(live, "probing.parquet"),
            here_probing=_table(here, "probing.parquet"),
        )


def test_a_new_channel_is_logged_live_as_in_this_process(pilot):
    """The log holds the new channel, live equal to this process's to the socket's 6 digits
    at every step (it varies: a channel read a frame early or late would not be)."""
    live, here = pilot.live.nz_pilot_g.to_numpy(), pilot.here.nz_pilot_g.to_numpy()
    assert len(live) == len(here) == pilot.scn.total_steps
    assert _six_digits(live, here).all()
    assert not _six_digits(live[1:], here[:-1]).all()
    assert np.ptp(here) > 1e-3


def test_a_new_channel_is_estimated_live_as_in_this_process(pilot):
    """Its pulse response is estimated in both worlds, every period's within 5e-4 of the
    largest tap (measured: 9.9e-5 without sensors, 1.1e-4 with the suite; the estimate is
    made of differences of the logged values, so their sixth digit weighs more in it)."""
    a, b = pilot.live_probing, pilot.here_probing
    ha = a[a.channel == PILOT.name].dropna(subset=["h_est"]).h_est.to_numpy()
    hb = b[b.channel == PILOT.name].dropna(subset=["h_est"]).h_est.to_numpy()
    assert ha.size == hb.size > 0
    assert np.abs(ha - hb).max() <= 5e-4 * np.abs(hb).max()


# ------------------------------------------------------------------ a runner
#: A runner added in the test: [sensors] scenarios (standing in for a new section) are the
#: rig's, flown by probing live and probing monitor only.
RIG = Runner(
    "rig",
    "sensors",
    frozenset({"live", "monitor"}),
    "does not fly the rig's [sensors] scenarios (probing live and probing monitor do)",
)

#: The same runner flown by probing run and probing truth only.
BENCH = Runner(
    "rig",
    "sensors",
    frozenset({"run", "truth"}),
    "does not fly the rig's [sensors] scenarios (probing run and probing truth do)",
)


def _command(command: str, scenario: Path, out: Path) -> list[str]:
    if command == "live":
        return ["live", str(scenario), "--write-sim", str(out / "sim")]
    if command == "sweep":
        sweep = out.parent / "sweep.toml"
        sweep.write_text(
            f'name = "s"\nbase = "{scenario.name}"\n[grid]\n"disturbance.seed" = [1]\n'
        )
        return ["sweep", str(sweep), "--out", str(out)]
    return [command, str(scenario), "--out", str(out)]


@pytest.mark.parametrize("runner", [RIG, BENCH], ids=["rig", "bench"])
@pytest.mark.parametrize("command", ["run", "truth", "monitor", "live", "sweep"])
def test_a_new_runner_is_consulted_by_every_command(runner, command, tmp_path, capsys, monkeypatch):
    """A scenario the new runner flies is refused, with the runner's one line and exit code
    2, by the commands it does not list, and flown by those it lists (here up to the
    flight, which stands in): probing run through the runner's flier and its line."""
    monkeypatch.setattr(runners, "RUNNERS", (runner, *runners.RUNNERS))
    flown: list[str] = []
    monkeypatch.setitem(calls.FLIERS, runner.name, lambda scn, out, how: flown.append("run"))
    monkeypatch.setitem(run_cli.RUN_LINES, runner.name, lambda scn, result, folder, t: "flown")
    monkeypatch.setattr(truth, "compute_truth", lambda scn, out: flown.append("truth") or out)
    done = SimpleNamespace(line=lambda: "flown", out_dir=tmp_path)
    monkeypatch.setattr(
        monitor_module, "monitor_scenario", lambda scn, out, **kw: flown.append("monitor") or done
    )
    scenario = tmp_path / "rig.toml"
    scenario.write_text(_sensed(_with(SHORT, "rig")))
    assert runners.runner_of(load_scenario(scenario)) == runner
    code = main(_command(command, scenario, tmp_path / "out"))
    err = capsys.readouterr().err
    if command in runner.commands:
        assert code == 0, err
        assert flown == ([] if command == "live" else [command])
        if command == "live":
            check_live(load_scenario(scenario))
    else:
        assert code == 2 and err.count("\n") == 1, err
        assert f"probing {command} {runner.refusal}" in err
        assert flown == [] and not (tmp_path / "out").exists()
        if command == "live":
            with pytest.raises(LiveError, match="rig's"):
                check_live(load_scenario(scenario))


def test_design_simultaneous_checks_what_the_simultaneous_runner_flies(capsys, monkeypatch):
    """A [simultaneous] scenario that a new runner flies is not the simultaneous runner's:
    ``probing design --simultaneous`` asks ``runner_of`` and refuses it in one line, exit 2
    (the simultaneous runner's own is checked: tests/experiment/test_simultaneous.py)."""
    crosstalk = Runner("crosstalk", "simultaneous", frozenset({"run"}), "flies crosstalk")
    monkeypatch.setattr(runners, "RUNNERS", (crosstalk, *runners.RUNNERS))
    shift = ROOT / "scenarios" / "simultaneous" / "shift-737.toml"
    code = main(["design", "--simultaneous", str(shift)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "is flown by crosstalk" in err, err


# ------------------------------------------------------------------ a reference
#: The low-pass's time constant, s: far beyond the probe's period (0.62 s), so what the
#: reference leaves is the probe's response and the fast part of the drift.
LOWPASS_S = 20.0


class LowPass:
    """A new reference computed from the log: each channel's measurement through a
    first-order low-pass, started at the first row (a source of
    :data:`probing.experiment.flight.onboard.SOURCES`: ``next(log)`` -> the rows' reference)."""

    def __init__(self, scn, plant) -> None:
        self.channels = list(scn.channels)
        a = scn.dt_s / LOWPASS_S
        self.b, self.a = [a], [1.0, a - 1.0]
        self.state: np.ndarray | None = None

    def next(self, log):
        y = np.column_stack([log[c] for c in self.channels])
        if self.state is None:
            self.state = (1.0 - self.b[0]) * y[0][None, :]  # lfilter's state at rest on y[0]
        out, self.state = lfilter(self.b, self.a, y, axis=0, zi=self.state)
        return out


LOWPASS = Reference(
    "lowpass", "log", description="each channel's measurement low-passed (the test's own)"
)


@pytest.fixture(scope="module")
def lowpass(tmp_path_factory):
    """The reference added to REFERENCES and its source to SOURCES; a flight with it live and
    in this process, and the live log replayed."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(REFERENCES, "lowpass", LOWPASS)
        mp.setitem(onboard.SOURCES, "lowpass", LowPass)
        base = tmp_path_factory.mktemp("lowpass")
        text = _with(SHORT, "lowpass").replace('drift = "detrend"', 'drift = "lowpass"')
        scn, live, here = _fly_both(base, text)
        replayed = replay_monitor(live / "sensors.parquet", base / "replay", progress=False)
        yield SimpleNamespace(
            scn=scn,
            live=live,
            here=here,
            replay_probing=_table(replayed.out_dir, "probing.parquet"),
        )


def test_a_new_reference_is_a_drift_mode_offered_live(lowpass):
    assert lowpass.scn.drift == "lowpass" and lowpass.scn.to_dict()["output"]["drift"] == "lowpass"
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(REFERENCES, "lowpass", LOWPASS)
        check_live(lowpass.scn)  # realisable: offered live


def test_a_new_references_source_carries_its_state_across_chunks(lowpass):
    """The source computed chunk by chunk, as the flight computer calls it, is the low-pass
    of the whole log at once (scipy's lfilter over every row)."""
    log = _table(lowpass.here, "sensors.parquet")
    columns = {c: log[c].to_numpy() for c in lowpass.scn.channels}
    whole = LowPass(lowpass.scn, None).next(columns)
    source = LowPass(lowpass.scn, None)
    parts = [
        source.next({c: v[i : i + 100] for c, v in columns.items()})
        for i in range(0, len(log), 100)
    ]
    np.testing.assert_allclose(np.vstack(parts), whole, rtol=1e-12, atol=1e-15)
    assert np.abs(whole - np.column_stack(list(columns.values()))).max() > 0


def test_a_new_reference_flies_live_as_in_this_process(lowpass):
    """Every period's estimate within 5e-4 of the largest tap, live and in this process."""
    a = _table(lowpass.live, "probing.parquet")
    b = _table(lowpass.here, "probing.parquet")
    for channel in lowpass.scn.channels:
        ha = a[a.channel == channel].h_est.to_numpy()
        hb = b[b.channel == channel].h_est.to_numpy()
        ok = np.isfinite(ha) & np.isfinite(hb)
        assert ok.sum() > 0
        assert np.abs(ha[ok] - hb[ok]).max() <= 5e-4 * np.abs(hb[ok]).max(), channel


def test_a_live_flight_with_a_new_reference_replays_bit_for_bit(lowpass):
    live = _table(lowpass.live, "probing.parquet")
    assert len(live) > 0 and live.equals(lowpass.replay_probing)


def test_a_new_reference_is_written_beside_each_channel_by_probing_run(tmp_path, capsys):
    """``probing run`` with the new reference writes ``<channel>_reference`` in
    ``timeseries.parquet``: scipy's low-pass of the channel as measured (``run.py`` once named
    the drift modes that have one itself, and the writer dropped the columns silently)."""
    scenario = tmp_path / "lowpass.toml"
    text = _with(SHORT, "lowpass-run").replace('drift = "detrend"', 'drift = "lowpass"')
    scenario.write_text(text)
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(REFERENCES, "lowpass", LOWPASS)
        mp.setitem(onboard.SOURCES, "lowpass", LowPass)
        assert main(["run", str(scenario), "--out", str(tmp_path / "out")]) == 0
        scn = load_scenario(scenario)
    ts = _table(tmp_path / "out" / "lowpass-run", "timeseries.parquet")
    a = scn.dt_s / LOWPASS_S
    for channel in scn.channels:
        y = ts[channel].to_numpy()
        expected = lfilter([a], [1.0, a - 1.0], y, zi=[(1.0 - a) * y[0]])[0]
        np.testing.assert_allclose(ts[f"{channel}_reference"], expected, rtol=1e-12, atol=1e-15)
