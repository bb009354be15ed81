"""Build a scenario in code, fly it, and compare the measured gain with eq. (10), all through
the public Python API (docs/api.md).

Usage (from the repository root, after ``make setup``)::

    .venv/bin/python scenarios/examples/build_and_run.py [--order 9] [--out results/examples]

What it shows:

1. ``probing.load`` checks a dict laid out like a scenario file (the baseline: 737 at
   15000 ft, 280 kcas, no nonlinearity);
2. ``Scenario.replace`` derives a variant with dotted field names (a symmetric deadband of
   +-a/3, which should pass the probe with the apparent amplitude a~ = 2a/3);
3. ``probing.fly`` flies both in memory, and ``Flight.save`` writes their files into
   ``<out>/<name>/`` (what ``probing run`` writes);
4. the least-squares gain of the deadband's settled h_est (``Flight.bounds``) against the
   baseline's, g = <h, h0>/<h0, h0>, is compared with the prediction a~/a of
   ``Deadband.apparent``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import probing


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--order", type=int, default=9, help="PRBS order (M = 2**order - 1)")
    parser.add_argument("--out", type=Path, default=Path("results/examples"))
    args = parser.parse_args()

    a = 0.005  # deg, the paper's amplitude
    baseline = probing.load(
        {
            "name": f"example-baseline-n{args.order}",
            "aircraft": {"model": "737"},
            "condition": {"altitude_ft": 15000, "speed_kcas": 280},
            "simulation": {"dt_s": 0.01},
            "probe": {
                "order": args.order,
                "bit_duration_s": 0.01,
                "amplitude_deg": a,
                "periods": 4,
                "settle_periods": 2,
            },
            "nonlinearity": {"type": "none"},
            "output": {"channels": ["theta_rad"], "drift": "reference"},
        }
    )
    deadband = baseline.replace(
        {
            "name": f"example-deadband-n{args.order}",
            "nonlinearity.type": "deadband",
            "nonlinearity.lower_deg": -a / 3,
            "nonlinearity.upper_deg": a / 3,
        }
    )
    settled = {}
    for scn in (baseline, deadband):
        flight = probing.fly(scn)
        folder = flight.save(args.out)
        steps, wall_s = flight.result.steps_simulated, flight.result.wall_s
        print(f"{scn.name}: {steps} steps in {wall_s:.2f} s -> {folder}")
        settled[scn.name] = flight.bounds["h_est"].to_numpy()  # theta_rad, per tap

    h0, h = settled[baseline.name], settled[deadband.name]
    gain = float(h @ h0 / (h0 @ h0))
    a_t, b_t = deadband.build_nonlinearity().apparent(a)
    print(f"predicted gain a~/a = {a_t / a:.4f} (b~ = {b_t:g} deg)")
    print(f"measured gain       = {gain:.4f}")


if __name__ == "__main__":
    main()
