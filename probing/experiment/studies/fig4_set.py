"""What a Fig. 4 set is, without the simulator: its panels (file stem -> letter), the
baseline's and the offset twin's keys, the channel read, and the rate-limit sweep's ratios
and bit durations.

:mod:`probing.experiment.studies.fig4` runs a set on JSBSim; :mod:`probing.analysis.fig4` reads the
runs
back, loading no JSBSim.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "BASELINE",
    "CHANNEL",
    "OFFSET_TWIN",
    "PANELS",
    "SWEEP_BITS_S",
    "SWEEP_PERIODS",
    "SWEEP_RATIOS",
    "SWEEP_SETTLE",
]

#: Panel key (scenario file stem) -> panel letter, in figure order.
PANELS: dict[str, str] = {
    "a_deadband": "a",
    "b_saturation": "b",
    "c_relay": "c",
    "d_backlash": "d",
    "e_rate_limit": "e",
    "f_rate_limit": "f",
    "g_hysteresis_relay": "g",
}
BASELINE = "baseline"
OFFSET_TWIN = "b_saturation_offset"  # constant b~ through the same chain: the remedy run
CHANNEL = "theta_rad"
#: Rate-limit sweep: r_l / (2a/t0), log-spaced, and the bit durations (s).
SWEEP_RATIOS = tuple(float(r) for r in np.geomspace(0.25, 4.0, 9))  # 0.25 * sqrt(2)**k
SWEEP_BITS_S = (0.01, 0.04)
SWEEP_PERIODS, SWEEP_SETTLE = 4, 2
