"""Fly the realisable monitor study's fault flights live (a separate ``jsbsim`` process per
flight, on a free loopback port) and in this process, and print the first alarm and the
verdict of each (docs/live.md, "Agreement with this process").

    .venv/bin/python examples/live/compare_faults.py OUT [--seeds 1 2] [--faults stuck ...]
        [--periods 100]

OUT receives each flight's simulator files, the live and in-process folders and
``compare.json``.  About a minute per flight pair on two cores.
"""

from __future__ import annotations

import argparse
import json
import socket
import subprocess
import time
from pathlib import Path

from probing.data import SCENARIOS
from probing.experiment.flight.live import live_monitor
from probing.experiment.flight.monitor import monitor_scenario
from probing.experiment.scenario import load_scenario
from probing.sim.live_sim import write_sim

#: The faults of scenarios/monitor-realisable, as ``Scenario.replace`` changes.
FAULTS = {
    "effectiveness 0.5": {"fault.type": "effectiveness", "fault.scale": 0.5},
    "stuck": {"fault.type": "stuck"},
    "dead band 0.8": {
        "fault.type": "nonlinearity",
        "fault.nonlinearity": "deadband",
        "fault.lower_deg": -0.04,
        "fault.upper_deg": 0.04,
    },
    "damage case 5": {"fault.type": "gtm_damage", "fault.case": 5},
    "damage case 6": {"fault.type": "gtm_damage", "fault.case": 6},
    "sensor bias 0.5 deg": {
        "fault.type": "sensor_bias",
        "fault.channel": "theta_rad",
        "fault.bias": 0.00872664626,
    },
}
#: Each seed's fault onset, s (the study's first two).
ONSETS_S = {1: 155.276, 2: 185.189}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def fly_live(scn, folder: Path):
    """``scn`` on a jsbsim process started for it (ended with the flight)."""
    port = free_port()
    line = write_sim(scn.flight, folder / "sim", port, scn.total_steps * scn.dt_s + 60.0)
    log_path = folder / "jsbsim.log"
    with log_path.open("w") as log:
        proc = subprocess.Popen(line, stdout=log, stderr=subprocess.STDOUT, cwd=folder)
        try:
            while "Execution beginning" not in log_path.read_text():
                if proc.poll() is not None:
                    raise RuntimeError(f"jsbsim ended: see {log_path}")
                time.sleep(0.1)
            return live_monitor(scn, "127.0.0.1", port, folder / "live", progress=False).monitor
        finally:
            if proc.poll() is None:
                proc.terminate()
                proc.wait(timeout=10)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--seeds", type=int, nargs="+", default=sorted(ONSETS_S))
    parser.add_argument("--faults", nargs="+", default=list(FAULTS), choices=list(FAULTS))
    parser.add_argument("--periods", type=int, default=100, help="onsets scale with it")
    args = parser.parse_args()
    scale = args.periods / 100
    base = load_scenario(SCENARIOS / "references" / "base.toml")
    rows = []
    print(
        "| fault | seed | first alarm period, live | in this process | verdict, live | in this ",
        end="",
    )
    print("process |")
    print("|---|---:|---:|---:|---|---|")
    for name in args.faults:
        for seed in args.seeds:
            scn = base.replace(
                {
                    "name": f"{name.replace(' ', '-')}-{seed}",
                    "output.drift": "gust",
                    "disturbance.seed": seed,
                    "fault.onset_s": ONSETS_S.get(seed, 155.276) * scale,
                    "probe.periods": args.periods,
                    "monitor.baseline_periods": min(50, args.periods // 2),
                    **FAULTS[name],
                }
            )
            folder = args.out / scn.name
            folder.mkdir(parents=True, exist_ok=True)
            live = fly_live(scn, folder)
            here = monitor_scenario(scn, folder / "here", progress=False)
            row = [name, seed, live.first_alarm_period, here.first_alarm_period,
                   live.verdict, here.verdict]  # fmt: skip
            rows.append(row)
            shown = ["none" if v is None else v for v in row]
            print("| " + " | ".join(str(v) for v in shown) + " |", flush=True)
    (args.out / "compare.json").write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
