"""Build a scenario in code, run it, read the Parquet back and print the gain.

Usage (from the repository root, after ``make setup``)::

    .venv/bin/python scenarios/examples/build_and_run.py [--order 9] [--out results/examples]

What it shows:

1. ``parse_scenario`` validates a dict laid out like a scenario file (the baseline: 737 at
   15000 ft, 280 kcas, no nonlinearity);
2. ``Scenario.replace`` derives a variant with dotted field names (a symmetric deadband of
   +-a/3, which should pass the probe with the apparent amplitude a~ = 2a/3);
3. ``run_scenario`` simulates both and writes ``<out>/<name>/probing.parquet``;
4. ``read_settled`` reads the settled pulse-response estimates back from
   ``probing.parquet``, and the least-squares gain of the deadband's h_est against the
   baseline's, g = <h, h0>/<h0, h0>, is compared with the prediction a~/a of
   ``Deadband.apparent``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from probing.experiment.flight.run import run_scenario
from probing.experiment.output.storage import read_settled
from probing.experiment.scenario import Scenario, parse_scenario


def settled_h(folder: Path, scn: Scenario, channel: str = "theta_rad") -> np.ndarray:
    """Mean h_est over the settled periods of one channel, read from probing.parquet."""
    path = folder / "probing.parquet"
    return read_settled(path, channel, scn.settle_periods, scn.bits_per_period).h.mean(axis=0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--order", type=int, default=9, help="PRBS order (M = 2**order - 1)")
    parser.add_argument("--out", type=Path, default=Path("results/examples"))
    args = parser.parse_args()

    a = 0.005  # deg, the paper's amplitude
    baseline = parse_scenario(
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
    for scn in (baseline, deadband):
        result = run_scenario(scn, args.out, progress=False)
        print(f"{scn.name}: {result.steps_simulated} steps in {result.wall_s:.2f} s")

    h0 = settled_h(args.out / baseline.name, baseline)
    h = settled_h(args.out / deadband.name, deadband)
    gain = float(h @ h0 / (h0 @ h0))
    a_t, b_t = deadband.build_nonlinearity().apparent(a)
    print(f"predicted gain a~/a = {a_t / a:.4f} (b~ = {b_t:g} deg)")
    print(f"measured gain       = {gain:.4f}")


if __name__ == "__main__":
    main()
