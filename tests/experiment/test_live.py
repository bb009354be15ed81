"""``probing live``: a scenario flown on a JSBSim process started apart from the project
(the ``jsbsim`` executable, on a free loopback port), through its input socket in lock step.

The live flight's tables equal a replay of the log it recorded bit for bit, and its
estimates agree with the same scenario flown in this process (``probing monitor``)."""

from __future__ import annotations

import contextlib
import io
import json
import os
import shlex
import socket
import subprocess
import sys
import threading
import time
import types
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from probing.cli import main
from probing.experiment.flight import live as live_module
from probing.experiment.flight.flight_computer import FlightComputer
from probing.experiment.flight.live import LIVE_CHUNK_PERIODS, LiveError, check_live, live_monitor
from probing.experiment.flight.monitor import logged_chunk_periods, monitor_scenario, replay_monitor
from probing.experiment.flight.run import CHUNK_STEPS
from probing.experiment.output.storage import read_footer
from probing.experiment.scenario import load_scenario
from probing.sim.channels import CHANNELS
from probing.sim.live_sim import write_sim
from probing.sim.surfaces import SURFACES

pytestmark = pytest.mark.jsbsim

ROOT = Path(__file__).resolve().parents[2]

SCENARIO = """\
name = "live-737"
[aircraft]
model = "737"
[condition]
altitude_ft = 15000
speed_kcas = 280
[simulation]
dt_s = 0.01
[probe]
order = 5
bit_duration_s = 0.02
amplitude_deg = 0.5
periods = 10
settle_periods = 2
[nonlinearity]
type = "none"
[output]
channels = ["theta_rad", "q_rad_s", "alpha_rad"]
drift = "detrend"
[disturbance]
turbulence = "none"
sensor_noise = { theta_rad = 1e-6 }
seed = 3
[monitor]
baseline_periods = 5
windows = 3
"""

#: The longest the simulator may take to load and trim, s.
START_S = 60.0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


#: The longest the simulator may take to stop after the flight computer is done, s.
STOP_S = 5.0


#: Where Linux lists the TCP sockets.
PROC_NET_TCP = Path("/proc/net/tcp")


def _listening(port: int) -> set[str]:
    """The IPv4 addresses listening on TCP ``port`` (Linux's /proc/net/tcp)."""
    found = set()
    for row in PROC_NET_TCP.read_text().splitlines()[1:]:
        local, state = row.split()[1], row.split()[3]
        address, hex_port = local.split(":")
        if state == "0A" and int(hex_port, 16) == port:
            found.add(socket.inet_ntoa(bytes.fromhex(address)[::-1]))
    return found


@contextlib.contextmanager
def _simulator(base: Path, sim_dir: Path, extra: tuple[str, ...] = ()):
    """The command ``--write-sim`` wrote into ``sim_dir`` (plus ``extra``), run as written
    (its first word is the jsbsim executable) from ``base`` until it has trimmed; stopped
    afterwards if it is still running."""
    line = [*shlex.split((sim_dir / "command.txt").read_text()), *extra]
    log_path = base / "jsbsim.log"
    log = log_path.open("w")
    proc = subprocess.Popen(line, stdout=log, stderr=subprocess.STDOUT, cwd=base)
    try:
        deadline = time.monotonic() + START_S
        while "Execution beginning" not in log_path.read_text():
            assert proc.poll() is None and time.monotonic() < deadline, "jsbsim did not start"
            time.sleep(0.1)
        yield proc
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        log.close()


def _stopped_within(proc: subprocess.Popen, limit_s: float) -> float | None:
    """Seconds until ``proc`` exits, or None if it still runs after ``limit_s``."""
    start = time.monotonic()
    try:
        proc.wait(timeout=limit_s)
    except subprocess.TimeoutExpired:
        return None
    return time.monotonic() - start


def _write_sim(base: Path, text: str) -> tuple[Path, Path, int]:
    """``text`` as a scenario in ``base`` and its simulator's files: (scenario, root, port)."""
    scenario = base / "live.toml"
    scenario.write_text(text)
    port = _free_port()
    sim_dir = base / "sim"
    assert main(["live", str(scenario), "--write-sim", str(sim_dir), "--port", str(port)]) == 0
    return scenario, sim_dir, port


def _fly_live(base: Path, text: str, extra: tuple[str, ...] = ()):
    """``text`` flown live on a separate jsbsim process (always stopped afterwards) into
    ``base``; its scenario.  ``base/progress.txt`` gets the progress lines and
    ``base/sim-stopped.txt`` the seconds the simulator took to exit after the flight
    (``running`` if it had not after :data:`STOP_S`), ``base/listening.txt`` the addresses it
    listened at (where Linux's /proc/net/tcp tells)."""
    scenario, sim_dir, port = _write_sim(base, text)
    with _simulator(base, sim_dir, extra) as proc:
        if PROC_NET_TCP.is_file():
            (base / "listening.txt").write_text(" ".join(sorted(_listening(port))))
        with contextlib.redirect_stderr(io.StringIO()) as err:
            code = main(
                ["live", str(scenario), "--connect", f"127.0.0.1:{port}", "--out", str(base)]
            )
        (base / "progress.txt").write_text(err.getvalue())
        stopped = _stopped_within(proc, STOP_S)
        (base / "sim-stopped.txt").write_text("running" if stopped is None else f"{stopped:.3f}")
    assert code == 0
    return load_scenario(scenario)


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    """The scenario flown live."""
    base = tmp_path_factory.mktemp("live")
    return base, _fly_live(base, SCENARIO)


def _table(folder: Path, name: str):
    return pq.read_table(folder / name).to_pandas()


def test_the_live_flight_writes_the_monitors_files(live):
    """The files ``probing live`` writes are the monitor's, and its help names each of them
    (it left out bounds.parquet): :data:`~probing.experiment.output.layouts.FLIGHT_FILES`."""
    from probing.cli import build_parser
    from probing.experiment.output.layouts import FLIGHT_FILES, OUTPUT_FILES

    base, scn = live
    written = sorted(p.name for p in (base / scn.name).iterdir())
    assert written == sorted(FLIGHT_FILES["live"]) == sorted(FLIGHT_FILES["monitor"])
    text = build_parser()._subparsers._group_actions[0].choices["live"].description
    assert [n for n in OUTPUT_FILES if n in text] == list(FLIGHT_FILES["live"]), text
    log = _table(base / scn.name, "sensors.parquet")
    assert len(log) == scn.total_steps and np.isfinite(log.to_numpy(dtype=float)).all()


def test_a_replay_of_the_live_log_is_the_live_monitor_bit_for_bit(live, tmp_path):
    base, scn = live
    again = replay_monitor(base / scn.name / "sensors.parquet", tmp_path, progress=False)
    for name in ("monitor.parquet", "probing.parquet", "bounds.parquet"):
        a, b = _table(base / scn.name, name), _table(again.out_dir, name)
        assert len(a) > 0 and a.equals(b), name


def test_the_live_flight_reports_every_period_once_in_order(live):
    """One line per period as it ends: its number and end time, the latest estimate's
    largest tap of the first monitored channel (once there is one) and the first alarm."""
    base, scn = live
    lines = [x for x in (base / "progress.txt").read_text().splitlines() if ": period " in x]
    assert len(lines) == scn.periods
    for p, line in enumerate(lines):
        assert f"{p + 1}/{scn.periods} periods" in line
        assert f": period {p} at {(p + 1) * scn.period_s:.2f} s: " in line
        assert "first alarm: " in line
    assert "h peak" in lines[-1] and f"(period {scn.periods - 1})" in lines[-1]


def test_the_live_log_records_its_chunk_and_an_older_log_chunks_as_before(live):
    base, scn = live
    meta = read_footer(base / scn.name / "sensors.parquet")
    assert json.loads(meta[b"probing.chunk_periods"]) == LIVE_CHUNK_PERIODS == 1
    steps = scn.period_s / scn.dt_s
    assert logged_chunk_periods(meta, round(steps)) == 1
    del meta[b"probing.chunk_periods"]
    assert logged_chunk_periods(meta, 127) == CHUNK_STEPS // 127 == 64


def test_the_live_estimate_agrees_with_the_flight_in_this_process(live, tmp_path):
    base, scn = live
    monitor_scenario(scn, tmp_path, progress=False)
    a = _table(base / scn.name, "probing.parquet")
    b = _table(tmp_path / scn.name, "probing.parquet")
    for first, tolerance in ((scn.settle_periods, SETTLED), (LATE_PERIOD, LATE)):
        for channel in scn.channels:
            ha = a[(a.channel == channel) & (a.period >= first)].h_est.to_numpy()
            hb = b[(b.channel == channel) & (b.period >= first)].h_est.to_numpy()
            assert ha.size == hb.size > 0
            assert np.abs(ha - hb).max() <= tolerance * np.abs(hb).max(), (channel, first)


#: The live estimate's largest difference from this process's, relative to the largest tap:
#: over the settled periods (measured: 9.7e-4) and from period 6 on (measured: 1.3e-3).  The
#: flight in this process starts as its trim left it, as the separate simulator does; what
#: is left is the separate simulator's readings, 6 significant digits (docs/live.md,
#: "Agreement with this process").  Before the first step was the trim's own, a kick of
#: q = 5.6e-5 rad/s made these 3.0e-2 and 4.4e-3.
SETTLED, LATE_PERIOD, LATE = 0.005, 6, 0.005


def test_a_remote_host_is_refused_without_allow_remote(tmp_path, capsys):
    scenario = tmp_path / "live.toml"
    scenario.write_text(SCENARIO)
    code = main(["live", str(scenario), "--connect", "192.0.2.1:5139", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2 and "--allow-remote" in err and err.count("\n") == 1
    assert not (tmp_path / "live-737").exists()


def test_nothing_listening_is_one_line_and_exit_2(tmp_path, capsys):
    scenario = tmp_path / "live.toml"
    scenario.write_text(SCENARIO)
    out = tmp_path / "out"
    code = main(
        ["live", str(scenario), "--connect", f"127.0.0.1:{_free_port()}", "--out", str(out)]
    )
    err = capsys.readouterr().err
    assert code == 2 and "no simulator at" in err and err.count("\n") == 1
    assert not (out / "live-737").exists()


#: The scenario with NASA's T2 sensors instead of ``disturbance.sensor_noise``, and without
#: detrending: the streaming estimator's results depend on the chunks (to the last bits), so
#: its replay is equal only in the live flight's chunks, which the log's footer records.
SENSED = (
    SCENARIO.replace('name = "live-737"', 'name = "live-737-t2"')
    .replace("sensor_noise = { theta_rad = 1e-6 }\n", "")
    .replace('drift = "detrend"', 'drift = "none"')
    + '[sensors]\nsuite = "nasa_t2"\n'
)

#: The same scenario's sensors without noise (biases kept), for the flight in this process.
QUIET = SENSED + "".join(
    f"[sensors.{c}]\nnoise_sigma = 0.0\n" for c in ("theta_rad", "q_rad_s", "alpha_rad")
)


@pytest.fixture(scope="module")
def sensed(tmp_path_factory):
    """The scenario with the nasa_t2 suite flown live."""
    base = tmp_path_factory.mktemp("sensed")
    return base, _fly_live(base, SENSED)


def test_a_live_flight_with_sensors_replays_bit_for_bit(sensed, tmp_path):
    base, scn = sensed
    log = _table(base / scn.name, "sensors.parquet")
    assert list(scn.sensors.sensors) == [c for c in log.columns if c in scn.sensors.sensors]
    again = replay_monitor(base / scn.name / "sensors.parquet", tmp_path, progress=False)
    for name in ("monitor.parquet", "probing.parquet"):
        a, b = _table(base / scn.name, name), _table(again.out_dir, name)
        assert len(a) > 0 and a.equals(b), name


def test_the_live_sensors_measure_with_the_suites_noise_and_bias(sensed, tmp_path):
    """The live log less the same flight in this process with the sensors' noise off (their
    biases on): what is left is the live sensors' noise, whose std is the suite's sigma
    within 10 % (1270 rows: the std's own scatter is 2 %; the two flights' true values differ
    by ~1e-5 rad, 3 % of theta's sigma, the smallest), and whose mean is within 4 sigma of
    its scatter.  The trim as measured (``probing.trim_measured``) agrees to a tenth of
    sigma, so the live sensors add the bias (theta's is 4.5 sigma)."""
    base, scn = sensed
    quiet = tmp_path / "quiet.toml"
    quiet.write_text(QUIET)
    monitor_scenario(load_scenario(quiet), tmp_path, progress=False)
    live_log = _table(base / scn.name, "sensors.parquet")
    calm_log = _table(tmp_path / scn.name, "sensors.parquet")
    trims = [
        json.loads(read_footer(folder / "sensors.parquet")[b"probing.trim_measured"])
        for folder in (base / scn.name, tmp_path / scn.name)
    ]
    assert len(live_log) == len(calm_log) == scn.total_steps
    for channel in scn.channels:
        sigma = scn.sensors.sensors[channel].noise_sigma
        noise = live_log[channel].to_numpy() - calm_log[channel].to_numpy()
        assert abs(noise.std() / sigma - 1.0) < 0.1, channel
        assert abs(noise.mean()) < 4 * sigma / np.sqrt(noise.size), channel
        assert abs(trims[0][channel] - trims[1][channel]) < 0.1 * sigma, channel


def test_the_simulator_stops_when_the_flight_is_done(live):
    """The flight computer ends the simulator's run (``simulation/terminate``): it does not
    stay held, polling its socket on a core, after the flight."""
    base, _ = live
    stopped = (base / "sim-stopped.txt").read_text()
    assert stopped != "running" and float(stopped) < STOP_S


@pytest.mark.parametrize("flight", ["live", "sensed"])
def test_the_progress_says_no_estimate_yet_before_the_first_estimate(flight, request):
    """Before the first estimate the line says "no estimate yet", as docs/live.md does, and
    no line reports a NaN tap: with detrending the first period has no row, without it
    (``sensed``: the streaming estimator) its row is NaN."""
    base, scn = request.getfixturevalue(flight)
    lines = [x for x in (base / "progress.txt").read_text().splitlines() if ": period " in x]
    assert len(lines) == scn.periods
    assert not any("nan" in line.lower() for line in lines)
    estimated = _table(base / scn.name, "probing.parquet").dropna(subset=["h_est"])
    first = int(estimated.period.min())
    assert first >= 1
    for p, line in enumerate(lines):
        assert ("no estimate yet" in line) == (p < first), line
        assert ("h peak" in line) == (p >= first), line


def _scenario_file(tmp_path: Path) -> Path:
    scenario = tmp_path / "live.toml"
    scenario.write_text(SCENARIO)
    return scenario


@pytest.mark.parametrize(("port", "ok"), [(0, False), (1, True), (65535, True), (65536, False)])
def test_write_sim_takes_a_port_1_to_65535(tmp_path, capsys, port, ok):
    sim_dir = tmp_path / "sim"
    code = main(
        ["live", str(_scenario_file(tmp_path)), "--write-sim", str(sim_dir), "--port", str(port)]
    )
    err = capsys.readouterr().err
    if ok:
        assert code == 0
        assert f'port="{port}"' in (sim_dir / "aircraft" / "737" / "737.xml").read_text()
    else:
        assert code == 2 and err.count("\n") == 1 and "--port" in err and "1..65535" in err
        assert not sim_dir.exists()


@pytest.mark.parametrize(("port", "ok"), [(0, False), (1, True), (65535, True), (65536, False)])
def test_connect_takes_a_port_1_to_65535(tmp_path, capsys, port, ok):
    out = tmp_path / "out"
    scenario = str(_scenario_file(tmp_path))
    code = main(["live", scenario, "--connect", f"127.0.0.1:{port}", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert ("1..65535" in err) == (not ok) and ("no simulator at" in err) == ok
    assert not (out / "live-737").exists()


def test_port_with_connect_is_refused(tmp_path, capsys):
    out = tmp_path / "out"
    scenario = str(_scenario_file(tmp_path))
    connect = f"127.0.0.1:{_free_port()}"
    code = main(["live", scenario, "--connect", connect, "--port", "5140", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "--port" in err and "--connect" in err
    assert not out.exists()


def test_write_sim_prints_a_command_that_runs_as_printed(tmp_path, capsys):
    """The printed command's first word is the jsbsim executable (JSBSim's Python package
    installs it beside this Python, which need not be on PATH); command.txt holds it too."""
    sim_dir = tmp_path / "sim"
    assert main(["live", str(_scenario_file(tmp_path)), "--write-sim", str(sim_dir)]) == 0
    out = capsys.readouterr().out
    printed = out.splitlines()[0]
    assert (sim_dir / "command.txt").read_text() == printed + "\n"
    program = Path(shlex.split(printed)[0])
    assert program.is_absolute() and program.name == "jsbsim"
    assert program.is_file() and os.access(program, os.X_OK)
    version = subprocess.run([program, "--version"], capture_output=True, text=True, timeout=60)
    assert version.returncode == 0 and version.stdout.strip()


def test_write_sim_says_the_socket_listens_on_every_interface(tmp_path, capsys):
    """JSBSim binds its input socket to every interface and has no attribute to do
    otherwise (docs/live.md): ``--write-sim`` says so."""
    sim_dir = tmp_path / "sim"
    assert main(["live", str(_scenario_file(tmp_path)), "--write-sim", str(sim_dir)]) == 0
    captured = capsys.readouterr()
    assert "every interface" in captured.err and "5139" in captured.err
    assert captured.out.count("\n") == 1  # stdout: the command alone


def _ask(sock: socket.socket, command: str) -> str:
    """One command to a JSBSim input socket; its reply line."""
    sock.sendall(f"{command}\r\n".encode())
    data = b""
    while b"\r\n" not in data.replace(b"JSBSim> ", b"").lstrip(b"\r\n"):
        data += sock.recv(4096)
    return data.decode().replace("JSBSim> ", "").strip()


@pytest.mark.skipif(not PROC_NET_TCP.is_file(), reason="reads Linux's /proc/net/tcp")
def test_the_simulator_listens_on_every_interface(live):
    """JSBSim binds its input socket to every interface, as docs/live.md says (it has no
    address for it): a JSBSim that binds otherwise fails here, and the doc is to change."""
    base, _ = live
    assert (base / "listening.txt").read_text() == "0.0.0.0"


def test_a_simulator_that_has_flown_is_refused_at_connect(tmp_path, capsys):
    """A simulator that has flown past its trim frame (a first client flew one frame, then
    held it and left, as a live flight used to) is refused when the flight computer
    connects: one line, exit code 2, nothing written; and the simulator is stopped.  (Every
    other flight of this file connects at the trim frame, 0.01 s, and is flown.)"""
    scenario, sim_dir, port = _write_sim(tmp_path, SCENARIO)
    with _simulator(tmp_path, sim_dir) as proc:
        with socket.create_connection(("127.0.0.1", port), timeout=10) as first:
            assert "JSBSim" in first.recv(4096).decode()
            assert _ask(first, "resume") == "Resuming"
            # a frame past the trim's (0.01 s, where every flight of this file connects):
            # asked until it comes, however slowly a loaded machine schedules the simulator
            # (five asks in a row once all came back at 0.01 s, under a whole suite's load)
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline:
                time_s = float(_ask(first, "get simulation/sim-time-sec").split("=")[1])
                if time_s > 0.015:
                    break
            assert 0.015 < time_s < 0.035
            assert _ask(first, "hold") == "Holding"
            first.sendall(b"quit\r\n")
        capsys.readouterr()  # --write-sim's
        out = tmp_path / "out"
        code = main(["live", str(scenario), "--connect", f"127.0.0.1:{port}", "--out", str(out)])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and "has flown" in err, err
        assert not out.exists()
        assert _stopped_within(proc, STOP_S) is not None


def test_a_simulator_killed_mid_flight_is_a_failed_run_named_by_its_time(tmp_path, monkeypatch):
    """The jsbsim process killed (SIGKILL) after the third period (it said ``probing: error:
    ... closed the connection``, exit code 2, as if the input were bad) is a run that failed:
    one line saying the simulator closed the connection and when (the first frame of the
    fourth period, 3 x 62 steps of 0.01 s), exit code 1, nothing written."""
    scenario, sim_dir, port = _write_sim(tmp_path, SCENARIO)
    scn = load_scenario(scenario)
    fly_probe = live_module.SocketWorld.fly_probe
    with _simulator(tmp_path, sim_dir) as proc:
        flown = []

        def fly_then_kill(world, *args, **kwargs):
            if len(flown) == 3:
                proc.kill()
                proc.wait()
            flown.append(world.steps)
            return fly_probe(world, *args, **kwargs)

        monkeypatch.setattr(live_module.SocketWorld, "fly_probe", fly_then_kill)
        out = tmp_path / "out"
        with contextlib.redirect_stderr(io.StringIO()) as err:
            code = main(
                ["live", str(scenario), "--connect", f"127.0.0.1:{port}", "--out", str(out)]
            )
    lines = [x for x in err.getvalue().splitlines() if not x.startswith(f"{scn.name} live")]
    assert code == 1, lines
    assert len(lines) == 1 and lines[0].startswith(
        f"probing: error: {scenario}: the simulator at 127.0.0.1:{port} closed the connection "
        "at t = 1.86 s"
    ), lines
    assert flown[-1] == 3 * scn.bits_per_period * round(scn.probe.bit_duration_s / scn.dt_s)
    assert not (out / scn.name).exists()


#: Channels of both kinds: the integrator's state (already the frame's when the message is
#: answered) and what JSBSim computes after the command (air data, load factors, the
#: surface: the frame's only in the next frame's message).  Not ``h_ft``, ``u_fps`` or
#: ``vt_fps``: a frame changes them by less than the socket's 6 digits resolve (0.1 ft at
#: 15,000 ft, 0.01 ft/s at 586 ft/s), so a shift would not show.
FRAMED_CHANNELS = (
    "theta_rad",
    "q_rad_s",
    "w_fps",
    "alpha_rad",
    "gamma_rad",
    "nz_g",
    "elevator_deg",
)

#: The scenario with those channels and no sensor noise: the log holds the simulator's values.
FRAMED = (
    SCENARIO.replace('name = "live-737"', 'name = "live-737-framed"')
    .replace("sensor_noise = { theta_rad = 1e-6 }\n", "")
    .replace(
        'channels = ["theta_rad", "q_rad_s", "alpha_rad"]',
        f"channels = {json.dumps(list(FRAMED_CHANNELS))}",
    )
)


@pytest.fixture(scope="module")
def framed(tmp_path_factory):
    """The scenario with :data:`FRAMED_CHANNELS` flown live, the simulator writing its own
    values of them at every frame (JSBSim's CSV output: ``sim/frames.csv``, in its root, at
    the end of each frame, with its time, in full precision)."""
    base = tmp_path_factory.mktemp("framed")
    props = "".join(f"  <property>{CHANNELS[c].prop}</property>\n" for c in FRAMED_CHANNELS)
    directive = base / "frames.xml"
    directive.write_text(f'<output name="frames.csv" type="CSV" rate="100">\n{props}</output>\n')
    scn = _fly_live(base, FRAMED, extra=(f"--logdirectivefile={directive}",))
    return base, scn


def _frames(path: Path, dt_s: float) -> dict[int, np.ndarray]:
    """JSBSim's CSV output: frame number (its time over dt) -> the row's values (the last
    row of a frame written twice: the held trim frame is)."""
    rows = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {round(row[0] / dt_s): row[1:] for row in rows}


def _agree(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Where ``a`` (read through the socket: 6 significant digits) is ``b`` (full)."""
    return np.abs(a - b) <= 5e-6 * np.abs(b) + 1e-15


def test_each_logged_value_is_the_simulators_own_of_its_frame(framed):
    """Every logged value, of the integrator's state and of what JSBSim computes after the
    command (air data, load factors, the surface), is the simulator's own value (its CSV
    output) of the row's frame: the row at ``time_s`` after the trim is the frame at sim time
    trim + ``time_s`` (the trim's frame is the first, at one dt), to the socket's 6 digits.
    The frame before and the frame after differ by more, for every channel, so a channel
    logged a frame early or late fails here."""
    base, scn = framed
    frames = _frames(base / "sim" / "frames.csv", scn.dt_s)
    log = _table(base / scn.name, "sensors.parquet")
    assert len(log) == scn.total_steps
    frame = 1 + np.rint(log["time_s"].to_numpy() / scn.dt_s).astype(int)
    for j, channel in enumerate(FRAMED_CHANNELS):
        logged = log[channel].to_numpy()
        own = np.array([frames[f][j] for f in frame])
        assert _agree(logged, own).all(), channel
        for shift in (-1, 1):  # (the simulator ends held in the frame after the last)
            there = np.array([f + shift in frames for f in frame])
            other = np.array([frames[f + shift][j] for f in frame[there]])
            assert there.sum() >= len(frame) - 1
            assert not _agree(logged[there], other).all(), (channel, shift)


@contextlib.contextmanager
def _fake_simulator(dt_s: float, delay_s: float):
    """A stand-in for JSBSim's blocking input socket on a free loopback port (yielded): it
    answers like JSBSim (``set``, ``get``, ``hold``, ``resume``, ``quit``), at its trim frame
    (``simulation/sim-time-sec`` = dt), with made-up values, each message ``delay_s`` late."""
    server = socket.create_server(("127.0.0.1", 0))
    values = iter(np.random.default_rng(0).normal(0.0, 1e-3, 10**7).tolist())
    fixed = {"simulation/dt": dt_s, "simulation/sim-time-sec": dt_s}

    def reply(line: str) -> str:
        words = line.split()
        if words[0] == "set":
            return "set successful"
        if words[0] == "get":
            return f"{words[1]} = {fixed.get(words[1], next(values)):12.6g}"
        return {"hold": "Holding", "resume": "Resuming"}[words[0]]

    def serve() -> None:
        conn, _ = server.accept()
        with conn:
            conn.sendall(b"Connected to JSBSim server\r\nJSBSim> ")
            buffer = ""
            while True:
                data = conn.recv(65536)
                if not data:
                    return
                buffer += data.decode()
                *lines, buffer = buffer.split("\r\n")
                if any(line.startswith("quit") for line in lines):
                    return
                time.sleep(delay_s)
                conn.sendall("".join(f"{reply(x)}\r\nJSBSim> " for x in lines if x).encode())

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield server.getsockname()[1]
    finally:
        server.close()
        thread.join(timeout=10)


#: The fake simulator's delay per message, s.
DELAY_S = 0.002


def test_the_compute_time_leaves_out_the_waits_for_the_simulator(tmp_path):
    """Every frame waits ``DELAY_S`` for the (fake) simulator's reply: the waits count all of
    it, and the flight computer's own time per period none of it."""
    scn = load_scenario(_scenario_file(tmp_path))
    with _fake_simulator(scn.dt_s, DELAY_S) as port:
        result = live_monitor(scn, "127.0.0.1", port, tmp_path, progress=False)
    periods = result.steps / result.steps_per_period
    assert result.steps == scn.total_steps
    assert result.wait_s >= result.steps * DELAY_S
    assert result.compute_per_period_s * periods <= result.wall_s - result.steps * DELAY_S


def test_the_compute_time_leaves_out_the_waits_for_the_clock(tmp_path, monkeypatch):
    """Paced at the wall clock (``realtime``), each frame sleeps until its time: the waits
    count every sleep, and the flight computer's own time per period none of them."""
    slept = []

    def sleep(seconds: float) -> None:
        slept.append(seconds)
        time.sleep(seconds)

    clock = types.SimpleNamespace(perf_counter=time.perf_counter, sleep=sleep)
    monkeypatch.setattr(live_module, "time", clock)
    scenario = tmp_path / "live.toml"
    scenario.write_text(SCENARIO.replace("bit_duration_s = 0.02", "bit_duration_s = 0.01"))
    scn = load_scenario(scenario)
    with _fake_simulator(scn.dt_s, 0.0) as port:
        result = live_monitor(scn, "127.0.0.1", port, tmp_path, realtime=True, progress=False)
    periods = result.steps / result.steps_per_period
    assert (
        len(slept) == result.steps == scn.total_steps
        and sum(slept) > 0.25 * scn.total_steps * scn.dt_s
    )
    assert result.wait_s >= sum(slept)
    assert result.compute_per_period_s * periods <= result.wall_s - sum(slept)


# ------------------------------------------------------- the study's flight, live
#: The realisable monitor study's flight (scenarios/references/base.toml: GTM at 800 ft and
#: 75 KCAS, the autopilot's three loops, NASA's T2 sensors, light turbulence) with the ``gust``
#: reference and the elevator's effectiveness halved at 155 s: a fault inside the loop; or
#: the pitch attitude's sensor biased by 0.5 deg at the same time.
STUDY = {
    "name": "live-study",
    "output.drift": "gust",
    "disturbance.seed": 1,
    "fault.onset_s": 155.276,
}
STUDY_FAULTS = {
    "actuator": {"fault.type": "effectiveness", "fault.scale": 0.5},
    "sensor": {"fault.type": "sensor_bias", "fault.channel": "theta_rad", "fault.bias": 0.0087},
}


@pytest.fixture(scope="module", params=sorted(STUDY_FAULTS))
def study(request, tmp_path_factory):
    """The study's fault flight flown live and in this process, with the same seed."""
    base = tmp_path_factory.mktemp(f"study-{request.param}")
    scn = load_scenario(ROOT / "scenarios" / "references" / "base.toml").replace(
        {**STUDY, **STUDY_FAULTS[request.param]}
    )
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    sim_dir = base / "sim"
    write_sim(scn.flight, sim_dir, port, scn.total_steps * scn.dt_s + 60.0)
    with _simulator(base, sim_dir) as proc:
        live = live_monitor(scn, "127.0.0.1", port, base / "live", progress=False)
        stopped = _stopped_within(proc, STOP_S)
    here = monitor_scenario(scn, base / "here", progress=False)
    return scn, live, here, stopped


def test_the_study_flight_flies_live_as_in_this_process(study):
    """Closed loop on the T2 sensors, light turbulence seeded alike in both simulators (the
    turbulence written in the first frame), the gust reference and an actuator fault: the
    same first alarm within a period and the same verdict; the logs agree to the socket's
    resolution through the loop (measured: theta within 7.2e-7 rad, the elevator within
    2.5e-5 deg over 100 periods, against a theta std of 0.011 rad: the turbulence is the
    same realisation, not one alike, and the autopilot sees the whole row before, as in this
    process; with the airspeed a frame older it was 4.3e-5 rad).  The verdict is the
    isolation checks': actuator for the lost effectiveness, sensor for the biased attitude."""
    scn, live, here, stopped = study
    a, b = live.monitor, here
    assert a.first_alarm_period is not None and b.first_alarm_period is not None
    assert abs(a.first_alarm_period - b.first_alarm_period) <= 1
    fault = scn.fault_type
    assert a.verdict == b.verdict == ("sensor" if fault == "sensor_bias" else "actuator")
    log_a = _table(live.monitor.out_dir, "sensors.parquet")
    log_b = _table(here.out_dir, "sensors.parquet")
    assert list(log_a.columns) == list(log_b.columns) and len(log_a) == scn.total_steps
    theta = np.abs(log_a["theta_rad"].to_numpy() - log_b["theta_rad"].to_numpy())
    assert theta.max() < 5e-6 < 1e-3 * log_b["theta_rad"].std()
    assert stopped is not None  # the simulator ended with the flight


def test_the_study_flights_live_log_replays_bit_for_bit(study, tmp_path):
    _, live, _, _ = study
    again = replay_monitor(live.monitor.out_dir / "sensors.parquet", tmp_path, progress=False)
    for name in ("monitor.parquet", "probing.parquet", "bounds.parquet"):
        a, b = _table(live.monitor.out_dir, name), _table(again.out_dir, name)
        assert len(a) > 0 and a.equals(b), name


def test_in_process_live_and_replay_fly_one_flight_computer(live, tmp_path, monkeypatch):
    """The three worlds hand their chunks to the same class's one consumer."""
    base, scn = live
    seen: list[str] = []
    consume = FlightComputer.consume

    def counted(self, log, first):
        seen.append(type(self).__qualname__)
        return consume(self, log, first)

    monkeypatch.setattr(FlightComputer, "consume", counted)
    kinds = []
    monitor_scenario(scn, tmp_path / "here", progress=False)
    kinds.append(len(seen))
    replay_monitor(base / scn.name / "sensors.parquet", tmp_path / "again", progress=False)
    kinds.append(len(seen) - sum(kinds))
    (tmp_path / "live").mkdir()
    _fly_live(tmp_path / "live", SCENARIO)
    kinds.append(len(seen) - sum(kinds))
    assert all(k > 0 for k in kinds) and set(seen) == {"FlightComputer"}


@pytest.mark.parametrize(
    ("changes", "refused"),
    [
        ({"output.drift": "oracle"}, "output.drift is oracle"),
        (
            {"output.drift": "reference", "disturbance.turbulence": "none"},
            "output.drift is reference",
        ),
        ({"fault.type": "gtm_damage", "fault.case": 5, "fault.onset_s": 10.0}, None),
        ({"output.drift": "nominal"}, None),
    ],
)
def test_live_refuses_only_what_needs_the_simulators_own_turbulence(changes, refused):
    scn = load_scenario(ROOT / "scenarios" / "references" / "base.toml").replace(changes)
    if refused is None:
        check_live(scn)
    else:
        with pytest.raises(LiveError, match=refused):
            check_live(scn)


def test_the_fault_comparison_example_prints_its_table(tmp_path):
    """examples/live/compare_faults.py (docs/live.md's table), one short flight pair: its
    row says the same first alarm and verdict live and in this process."""
    script = ROOT / "examples" / "live" / "compare_faults.py"
    args = ["--seeds", "1", "--faults", "damage case 5", "--periods", "24"]
    done = subprocess.run(
        [sys.executable, str(script), str(tmp_path), *args], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    row = done.stdout.splitlines()[-1].strip("| ").split(" | ")
    assert row[0] == "damage case 5" and row[2] == row[3] and row[4] == row[5]
    assert (
        json.loads((tmp_path / "compare.json").read_text())[0][2:4]
        == [int(row[2]) if row[2] != "none" else None] * 2
    )


class _HeldSimulator:
    """A stand-in for :class:`SimSocket` without a socket: the probed surface's position it
    reports in frame k (the position after step k - 1: the row before's, completed) is
    1000 + k deg, at the trim 999 deg, every other value 0; it keeps what each frame writes."""

    def __init__(self, position: str) -> None:
        self.position, self.frames, self.written = position, 0, []

    def get(self, names):
        return [1000.0 - 1 if n == self.position else 0.0 for n in names]  # at the trim

    def held_get(self, names):
        values = [1000.0 + self.frames if n == self.position else 0.0 for n in names]
        self.frames += 1
        return values

    def resume_with(self, values):
        self.written.append(dict(values))


class _LinearDrive:
    """An actuator map known to the rig: command = position / 20, trimmed at 2 deg."""

    trim_position = 2.0

    @staticmethod
    def command_clipped(position: float) -> float:
        return position / 20.0


@pytest.mark.parametrize("kind", ["stuck", "effectiveness"])
@pytest.mark.parametrize(("onset_s", "onset"), [(0.05, 5), (0.07, 7)])  # 0.07 / 0.01 = 7.000...1
def test_the_live_worlds_actuator_fault_acts_from_the_exact_step_of_its_onset(kind, onset_s, onset):
    """The rig's actuator fault, frame by frame, without a simulator: up to the step before
    the onset the probed surface's command is the map's of what the law asks; from the onset
    step on a stuck one is the map's of its position after the step before the onset (the
    stand-in reports it in the onset's frame: 1000 + onset deg), one at half its
    effectiveness the map's of trim + 0.5 (asked - trim)."""
    fault = {"fault.type": kind, "fault.onset_s": onset_s}
    if kind == "effectiveness":
        fault["fault.scale"] = 0.5
    scn = load_scenario(ROOT / "tests" / "data" / "sweeps" / "base-737-small.toml").replace(fault)
    sim = _HeldSimulator(SURFACES[scn.surface].position)
    plant = types.SimpleNamespace(engine_count=lambda: 2, drive=lambda surface=None: _LinearDrive)
    world = live_module.SocketWorld(scn, sim, plant, realtime=False)
    asked = [2.0 + 0.1 * k for k in range(12)]
    world.fly(12, law=lambda k: (asked[k], None, None, None))
    command = [frame[SURFACES[scn.surface].command] for frame in sim.written]
    if kind == "stuck":
        realised = asked[:onset] + [1000.0 + onset] * (12 - onset)
    else:
        realised = asked[:onset] + [2.0 + 0.5 * (a - 2.0) for a in asked[onset:]]
    assert command == pytest.approx([p / 20.0 for p in realised], rel=1e-15)
    assert command[onset - 1] == pytest.approx(asked[onset - 1] / 20.0, rel=1e-15)
