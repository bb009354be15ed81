"""Write the lateral health-monitoring study's sweep files (``make monitor-lateral``).

Usage (from the repository root, after ``make setup``)::

    .venv/bin/python scenarios/monitor-lateral/generate.py   # rewrites its *.toml

The files are committed; this script is how they were made, and running it again gives the
same bytes.  NASA's lateral damage cases (1 rudder off, 2 vertical tail off, 3 left outboard
flap off, 4 left wing tip off) upset the lateral-directional axes, which the elevator probe of
``make monitor`` barely sees.  Here the probe drives the aileron or the rudder instead; the
flight is otherwise the study's of ``scenarios/monitor`` (``docs/monitoring.md``): NASA's
GTM at 800 ft, 75 KCAS, pitch, bank and speed held, light turbulence, the same probe shape
(M = 255, t0 = 0.01 s, a = 0.2 deg, the ``ac`` estimator, each test on the mean of 4
periods), the monitor learning 50 periods, 0.1 false alarms per flight hour, isolation
with the probed surface's measured position, the nominal twin.  Sensors with NASA's noise
(``NoiseParams_T2.m``): bank angle 0.02 deg and roll rate 0.535 deg/s for the aileron probe,
sideslip 0.033 deg and yaw rate 0.3397 deg/s for the rudder probe, surface pots 0.01 deg.

* ``base-aileron.toml``, ``base-rudder.toml``: the two flights;
* per probe and case, ``<probe>-damage<k>.toml``: 20 seeds, each with a random onset uniform
  over periods 55 to 75; the flight ends 25 periods after the latest onset;
* per probe, ``<probe>-none.toml``: no fault, five flights of one hour.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from probing.core.faults import sweep_fields
from probing.sweep.spec import sweep_toml, toml_value

HERE = Path(__file__).resolve().parent
SEEDS = 20
BASELINE = 50
ONSET_PERIODS = (55, 75)
AFTER_PERIODS = 25
HEALTHY_FLIGHTS, HEALTHY_FLIGHT_S = 5, 3600.0
ORDER, BIT_S, AMPLITUDE_DEG, SETTLE, WINDOW = 8, 0.01, 0.2, 2, 4
FALSE_ALARMS_PER_HOUR = 0.1
SURFACE_NOISE_DEG = 0.01  # NASA's pots
#: The probed surface -> its channels with NASA's noise (rad, rad/s), and the surface's own.
PROBES: dict[str, dict[str, float]] = {
    "aileron": {"phi_rad": math.radians(0.02), "p_rad_s": math.radians(0.5350)},
    "rudder": {"beta_rad": math.radians(0.033), "r_rad_s": math.radians(0.3397)},
}
CASES = (1, 2, 3, 4)
WRITTEN_BY = "Written by scenarios/monitor-lateral/generate.py; run by make monitor-lateral."


def base_toml(surface: str, noise: dict[str, float]) -> str:
    periods = ONSET_PERIODS[1] + AFTER_PERIODS
    channels = [*noise, f"{surface}_deg"]
    noisy = {**noise, channels[-1]: SURFACE_NOISE_DEG}
    sensors = ", ".join(f"{c} = {v!r}" for c, v in noisy.items())
    return f"""# The lateral health-monitoring study's flight, {surface} probe
# (scenarios/monitor-lateral/generate.py; docs/monitoring.md, "Lateral damage").
name = "gtm-monitored-{surface}"

[aircraft]
model = "gtm_t2"

[condition]
altitude_ft = 800.0
speed_kcas = 75.0

[simulation]
dt_s = 0.01

[probe]
surface = "{surface}"
order = {ORDER}
bit_duration_s = {BIT_S!r}
amplitude_deg = {AMPLITUDE_DEG!r}
periods = {periods}
settle_periods = {SETTLE}

[nonlinearity]
type = "none"

[output]
channels = {toml_value(channels)}
drift = "oracle"
estimator = "ac"

[disturbance]
turbulence = "light"
seed = 0
sensor_noise = {{ {sensors} }}

[control]
pitch_hold = true
bank_hold = true
speed_hold = true

[monitor]
baseline_periods = {BASELINE}
false_alarms_per_hour = {FALSE_ALARMS_PER_HOUR}
window_periods = {WINDOW}
surface = true
"""


def main() -> None:
    period_s = (2**ORDER - 1) * BIT_S
    for p, (surface, noise) in enumerate(PROBES.items()):
        base = f"base-{surface}.toml"
        (HERE / base).write_text(base_toml(surface, noise))
        for case in CASES:
            rng = np.random.default_rng(2000 + 10 * p + case)
            onsets = rng.uniform(*ONSET_PERIODS, SEEDS) * period_s
            zipped = {
                "disturbance.seed": list(range(1, SEEDS + 1)),
                "fault.onset_s": [round(float(t), 3) for t in onsets],
            }
            fixed = sweep_fields("gtm_damage", {"case": case})
            name = f"{surface}-damage{case}"
            text = f"{surface} probe, damage case {case}: {SEEDS} seeds x random onsets"
            tables = {"fixed": fixed, "zip": zipped}
            (HERE / f"{name}.toml").write_text(
                sweep_toml(f"monitor-{name}", text, base, tables, WRITTEN_BY)
            )
        healthy_periods = round(HEALTHY_FLIGHT_S / period_s)
        zipped = {"disturbance.seed": list(range(101, 101 + HEALTHY_FLIGHTS))}
        fixed = {"probe.periods": healthy_periods}
        hours = HEALTHY_FLIGHT_S / 3600
        text = f"{surface} probe, no fault: {HEALTHY_FLIGHTS} flights of {hours:g} h"
        tables = {"fixed": fixed, "zip": zipped}
        (HERE / f"{surface}-none.toml").write_text(
            sweep_toml(f"monitor-{surface}-none", text, base, tables, WRITTEN_BY)
        )


if __name__ == "__main__":
    main()
