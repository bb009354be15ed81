"""Write the health-monitoring study's sweep files (``make monitor``, ``docs/monitoring.md``).

Usage (from the repository root, after ``make setup``)::

    .venv/bin/python scenarios/monitor/generate.py      # rewrites scenarios/monitor/*.toml

The files are committed; this script is how they were made, and running it again gives the
same bytes.  It asks ``probing design`` for the probe, then writes:

* ``base.toml``: NASA's GTM at the paper's condition (800 ft, 75 KCAS), closed loop (pitch,
  bank and speed held), light turbulence, NASA's pitch-attitude and surface-position noise
  (0.02 and 0.01 deg, ``NoiseParams_T2.m``), the design's probe and estimator, and the
  monitor: baseline 50 periods, 0.1 false alarms per flight hour, each test on the mean of
  the design's settled periods, isolation with the elevator's measured deflection;
* one sweep per fault (``kind = "monitor"``): 50 seeds, each with a random onset, uniform
  over periods 55 to 75 (after the baseline), under both drift corrections (the nominal twin,
  and detrending with no model at all); the flight ends 25 periods after the latest onset;
* ``none.toml``: no fault, ten flights of one hour per drift correction.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from probing.core.faults import sweep_fields
from probing.experiment.design.design import DesignRequest, recommend
from probing.sweep.spec import sweep_toml

HERE = Path(__file__).resolve().parent
#: NASA's pitch-attitude noise, MIDG theta (NoiseParams_T2.m): 0.02 deg.
THETA_NOISE_RAD = math.radians(0.02)
#: NASA's control-surface position noise, pots (NoiseParams_T2.m): 0.01 deg.
SURFACE_NOISE_DEG = 0.01
FALSE_ALARMS_PER_HOUR = 0.1
AMPLITUDE_DEG = 0.2  # the design's amplitude (the paper's 0.005 deg needs > 2000 periods)
SEEDS = 50
BASELINE = 50
ONSET_PERIODS = (55, 75)
AFTER_PERIODS = 25
HEALTHY_FLIGHTS, HEALTHY_FLIGHT_S = 10, 3600.0
WRITTEN_BY = "Written by scenarios/monitor/generate.py; run by make monitor (docs/monitoring.md)."

#: The faults: file name -> (its type in probing.core.faults.FAULTS, its fields without
#: onset_s); a~/a = 0.8 for the dead band (edges +-0.2 a) and the backlash (width 0.4 a);
#: the rate limit at half of 2a/t0.
FAULTS: dict[str, tuple[str, dict]] = {
    "damage5": ("gtm_damage", {"case": 5}),
    "damage6": ("gtm_damage", {"case": 6}),
    "deadband": ("nonlinearity", {"nonlinearity": "deadband"}),  # edges set below
    "backlash": ("nonlinearity", {"nonlinearity": "backlash"}),
    "rate-limit": ("nonlinearity", {"nonlinearity": "rate_limit"}),
    "effectiveness": ("effectiveness", {}),  # scale 0.8 and 0.5, a grid
    "stuck": ("stuck", {}),
}


def design() -> tuple:
    """``probing design`` for a 10 % gain change at the monitor's false-alarm probability."""
    period_guess_s = 2.55  # M t0 of the design below; the false alarm depends on it
    request = DesignRequest(
        aircraft="gtm_t2",
        altitude_ft=800.0,
        speed_kcas=75.0,
        noise_sigma=THETA_NOISE_RAD,
        turbulence="light",
        detect_gain_change=0.1,
        false_alarm=FALSE_ALARMS_PER_HOUR * period_guess_s / 3600.0,
        amplitude_deg=AMPLITUDE_DEG,
    )
    d, _, _ = recommend(request)
    assert math.isclose(d.bits_per_period * d.bit_duration_s, period_guess_s), d
    return d, request


def base_toml(d, request) -> str:
    periods = ONSET_PERIODS[1] + AFTER_PERIODS
    settled = d.periods - d.settle_periods
    header = (
        "# The health-monitoring study's flight (scenarios/monitor/generate.py; "
        "docs/monitoring.md).\n"
        f"# Probe and estimator from: probing design --aircraft gtm_t2 --altitude-ft 800 "
        f"--speed-kcas 75\n"
        f"#   --noise-sigma {THETA_NOISE_RAD:.6g} --turbulence light --detect-gain-change 0.1\n"
        f"#   --false-alarm {request.false_alarm:.3g} --amplitude-deg {AMPLITUDE_DEG}\n"
        f"# which predicts a gain se of {d.predicted_gain_stderr:.3g} over {settled} settled "
        "periods (open loop):\n"
        "# each test averages that many periods (monitor.window_periods).\n"
    )
    return (
        header
        + f"""name = "gtm-monitored"

[aircraft]
model = "gtm_t2"

[condition]
altitude_ft = 800.0
speed_kcas = 75.0

[simulation]
dt_s = 0.01

[probe]
order = {d.order}
bit_duration_s = {d.bit_duration_s!r}
amplitude_deg = {d.amplitude_deg!r}
periods = {periods}
settle_periods = {d.settle_periods}

[nonlinearity]
type = "none"

[output]
channels = ["theta_rad", "elevator_deg"]
drift = "oracle"
estimator = "{d.estimator}"

[disturbance]
turbulence = "light"
seed = 0
sensor_noise = {{ theta_rad = {THETA_NOISE_RAD!r}, elevator_deg = {SURFACE_NOISE_DEG!r} }}

[control]
pitch_hold = true
bank_hold = true
speed_hold = true

[monitor]
baseline_periods = {BASELINE}
false_alarms_per_hour = {FALSE_ALARMS_PER_HOUR}
window_periods = {d.periods - d.settle_periods}
surface = true
"""
    )


def main() -> None:
    d, request = design()
    period_s = d.bits_per_period * d.bit_duration_s
    (HERE / "base.toml").write_text(base_toml(d, request))
    drifts = {"output.drift": ["oracle", "detrend"]}
    a = d.amplitude_deg
    params = {
        "deadband": {"fault.lower_deg": -0.2 * a, "fault.upper_deg": 0.2 * a},
        "backlash": {"fault.width_deg": 0.4 * a},
        "rate-limit": {"fault.rate_deg_s": 0.5 * 2 * a / d.bit_duration_s},
        "effectiveness": {},
        "damage5": {},
        "damage6": {},
        "stuck": {},
    }
    for i, (name, (kind, fault)) in enumerate(FAULTS.items()):
        rng = np.random.default_rng(1000 + i)
        onsets = rng.uniform(*ONSET_PERIODS, SEEDS) * period_s
        fixed = sweep_fields(kind, fault)
        fixed |= {k: round(v, 12) for k, v in params[name].items()}
        grid = dict(drifts)
        if name == "effectiveness":
            grid["fault.scale"] = [0.8, 0.5]
        zipped = {
            "disturbance.seed": list(range(1, SEEDS + 1)),
            "fault.onset_s": [round(float(t), 3) for t in onsets],
        }
        text = f"{name}: {SEEDS} seeds x random onsets x 2 drift corrections"
        tables = {"fixed": fixed, "grid": grid, "zip": zipped}
        (HERE / f"{name}.toml").write_text(
            sweep_toml(f"monitor-{name}", text, "base.toml", tables, WRITTEN_BY)
        )
    healthy_periods = round(HEALTHY_FLIGHT_S / period_s)
    zipped = {"disturbance.seed": list(range(101, 101 + HEALTHY_FLIGHTS))}
    fixed = {"probe.periods": healthy_periods}
    hours = HEALTHY_FLIGHT_S / 3600
    text = f"no fault: {HEALTHY_FLIGHTS} flights of {hours:g} h x 2 drift corrections"
    tables = {"fixed": fixed, "grid": drifts, "zip": zipped}
    (HERE / "none.toml").write_text(
        sweep_toml("monitor-none", text, "base.toml", tables, WRITTEN_BY)
    )


if __name__ == "__main__":
    main()
