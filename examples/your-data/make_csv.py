"""Make probe_response.csv: a recorded probe and two outputs of a made-up aircraft-like
system, for ``probing analyze`` (README, "Your own data").

Deterministic (seeded): the same file every time.  The probe is scipy's own m-sequence of
order 7 (M = 127 bits), 0.04 s bits, sampled at 0.02 s, +-0.5 deg about a trim of 1.2 deg; the
outputs are a damped second-order pitch-rate-like response and its integral, both with an
offset, a slow linear drift and white noise.  The recording starts mid-sequence and
mid-bit and does not end on a bit boundary.

    python examples/your-data/make_csv.py      # writes examples/your-data/probe_response.csv
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import signal

DT_S, SAMPLES_PER_BIT, ORDER, AMPLITUDE_DEG, TRIM_DEG = 0.02, 2, 7, 0.5, 1.2
NOISE, DRIFT_PER_S = 2e-3, 1e-3


def main() -> Path:
    rng = np.random.default_rng(7)
    bits = signal.max_len_seq(ORDER)[0].astype(float)
    probe = np.repeat(np.tile(AMPLITUDE_DEG * (2.0 * bits - 1.0), 8), SAMPLES_PER_BIT)
    # short-period-like mode (1.2 Hz, damping 0.4) from deg of elevator to rad/s of pitch rate
    wn, zeta = 2 * np.pi * 1.2, 0.4
    a, b, c, d = signal.tf2ss([-0.02 * wn**2], [1.0, 2 * zeta * wn, wn**2])
    ad, bd, cd, dd, _ = signal.cont2discrete((a, b, c, d), DT_S)
    pitch_rate = signal.dlsim((ad, bd, cd, dd, DT_S), probe)[1][:, 0]
    pitch = np.cumsum(pitch_rate) * DT_S
    keep = slice(81, 81 + 6 * 127 * SAMPLES_PER_BIT + 57)  # mid-sequence, mid-bit start
    t = np.arange(keep.stop - keep.start) * DT_S
    data = {
        "time_s": np.round(t, 10),
        "elevator_deg": TRIM_DEG + probe[keep],
        "q_rad_s": 0.004 + pitch_rate[keep] + DRIFT_PER_S * t + NOISE * rng.standard_normal(t.size),
        "theta_rad": 0.05 + pitch[keep] - DRIFT_PER_S * t + NOISE * rng.standard_normal(t.size),
    }
    out = Path(__file__).with_name("probe_response.csv")
    with open(out, "w") as f:
        f.write(",".join(data) + "\n")
        for row in zip(*data.values(), strict=True):
            f.write(",".join(f"{v:.9g}" for v in row) + "\n")
    return out


if __name__ == "__main__":
    print(main())
