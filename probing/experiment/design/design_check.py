"""``probing design``'s gain standard deviation against runs of its own design.

The designed scenario (``scenario_toml`` of ``probing design --json``) is flown at seeds 0,
1, ..., K - 1 (the design calibrates on 1000, 1001, ...: independent), with its turbulence,
sensors, autopilot and reference; each settled period's gain is the least-squares gain of
its h against the design's reference (the mean settled h of the calm run without sensor
noise, its nonlinearity kept: :func:`probing.experiment.design.design_runs.noise_free_reference`).
``period_gain_std`` is the seed-to-seed variance of each period's gain, averaged over the
settled periods, its square root: what a ``--window-periods`` design predicts
(``window.period_gain_stderr``).  ``gain_std`` is the seed-to-seed standard deviation of the
gain of the mean settled h, and ``h_std`` that of the mean settled h (RMS over taps): what
every design predicts (``predicted_gain_stderr``, ``predicted_h_stderr``).

Usage::

    python -m probing.experiment.design.design_check DESIGN.json [--seeds K] [--trial]

A design with a window is checked per period, one without on its mean settled h (the
ratios are measured / predicted there, sampling error 1/sqrt(2 (K - 1))).  ``--trial``
flies a window design at the amplitude search's trial amplitude instead, against the
per-period prediction of its first calibration (``window.flights[0]``).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from probing.core.fixedorder import dot, vdot

__all__ = ["main", "measured", "period_h"]


def _period_h(scn: Any, aircraft: Any) -> np.ndarray:
    """(settled periods, M) h of the first channel of a run."""
    import pandas as pd

    from probing.experiment.flight.run import run_scenario

    with tempfile.TemporaryDirectory(prefix="probing-design-check-") as tmp:
        result = run_scenario(scn, tmp, progress=False, aircraft=aircraft, timeseries=False)
        df = pd.read_parquet(result.out_dir / "probing.parquet")
    rows = df[df.channel == scn.channels[0]]
    first = max(scn.settle_periods, scn.first_estimated_period)
    h = rows.pivot(index="period", columns="tap", values="h_est")
    return h.loc[first:].to_numpy()


def period_h(toml: str, seeds: int) -> tuple[np.ndarray, np.ndarray]:
    """Settled per-period h (seeds, periods, M) of the designed scenario, and its reference
    (M,), channel unit per deg."""
    from probing.experiment.design.design_runs import noise_free_reference
    from probing.experiment.flight.batch import run_grouped
    from probing.experiment.scenario import parse_scenario

    scn = parse_scenario(tomllib.loads(toml))
    ref = noise_free_reference(scn)[scn.channels[0]]
    runs = [scn.replace({"disturbance.seed": k, "name": f"check{k}"}) for k in range(seeds)]
    h: list[np.ndarray] = [np.empty(0)] * seeds
    for i, outcome in run_grouped(runs, lambda s: s, _period_h):
        h[i] = outcome.get()
    periods = min(len(x) for x in h)  # every one, unless a run ended early
    return np.array([x[:periods] for x in h]), ref


def measured(toml: str, seeds: int) -> dict[str, float]:
    """``period_gain_std``, ``gain_std`` (dimensionless) and ``h_std`` (channel unit per
    deg) of the module docstring, and the mean gain."""
    h, ref = period_h(toml, seeds)
    gains = dot(h, ref) / vdot(ref, ref)
    per_period = float(np.sqrt(np.mean(gains.var(axis=0, ddof=1))))
    settled = h.mean(axis=1)  # (seeds, M): each run's mean settled h
    return {
        "period_gain_std": per_period,
        "mean_gain": float(gains.mean()),
        "gain_std": float((dot(settled, ref) / vdot(ref, ref)).std(ddof=1)),
        "h_std": float(np.sqrt(np.mean(settled.var(axis=0, ddof=1)))),
    }


def main(argv: list[str] | None = None) -> int:
    """Print the design's prediction, the measures and their ratios, one JSON object."""
    parser = argparse.ArgumentParser(prog="python -m probing.experiment.design.design_check")
    parser.add_argument("design", type=Path, help="probing design ... --json output")
    parser.add_argument("--seeds", type=int, default=16, help="runs to measure on")
    parser.add_argument(
        "--trial",
        action="store_true",
        help="fly at the search's trial amplitude instead, against its first calibration",
    )
    args = parser.parse_args(argv)
    design = json.loads(args.design.read_text())
    toml = design["scenario_toml"]
    if not design.get("window"):  # no window: the mean settled h's gain and h
        if args.trial:
            parser.error("--trial needs a design with --window-periods")
        found = measured(toml, args.seeds)
        out = {
            "amplitude_deg": design["amplitude_deg"],
            "seeds": args.seeds,
            "predicted_gain_stderr": design["predicted_gain_stderr"],
            "gain_std": found["gain_std"],
            "gain_ratio": found["gain_std"] / design["predicted_gain_stderr"],
            "predicted_h_stderr": design["predicted_h_stderr"],
            "h_std": found["h_std"],
            "h_ratio": found["h_std"] / design["predicted_h_stderr"],
            "mean_gain": found["mean_gain"],
        }
        print(json.dumps(out, indent=2))
        return 0
    predicted = design["window"]["period_gain_stderr"]
    if args.trial:
        import tomli_w

        from probing.experiment.scenario import parse_scenario

        amplitude_deg, predicted = design["window"]["flights"][0]
        scn = parse_scenario(tomllib.loads(toml)).replace({"probe.amplitude_deg": amplitude_deg})
        toml = tomli_w.dumps(scn.to_dict())
    found = measured(toml, args.seeds)
    out = {
        "amplitude_deg": tomllib.loads(toml)["probe"]["amplitude_deg"],
        "predicted_period_gain_std": predicted,
        **found,
        "ratio": predicted / found["period_gain_std"],
    }
    print(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
