"""The slow modes' bias for ``make bench``: predicted from the linearisation against measured
on JSBSim itself, for the conditions of the noise sweeps (``scenarios/sweeps/noise-*.toml``).

Measured: a noise-free run 100 periods longer than the scenario, the mean of its settled
periods minus that of its last 10 (:func:`probing.experiment.design.noise.measured_bias`).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from bench.report import Rendered, Row
from probing.experiment.design.noise import measured_bias, predict
from probing.experiment.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parent.parent
ESTIMATORS = ("streaming", "cyclic", "ac")


def conditions() -> dict[str, Scenario]:
    """The four conditions of the noise sweeps, theta and q, no sensor noise."""
    s737 = load_scenario(ROOT / "scenarios" / "baseline-737.toml")
    gtm = load_scenario(ROOT / "scenarios" / "fig4" / "baseline.toml")
    channels = {"output.channels": ["theta_rad", "q_rad_s"]}
    return {
        "737, 15,000 ft, 280 KCAS": s737.replace(channels),
        "737, 5,000 ft, 250 KCAS": s737.replace(
            {**channels, "condition.altitude_ft": 5000, "condition.speed_kcas": 250}
        ),
        "GTM, 800 ft, 75 KCAS": gtm.replace(channels),
        "GTM, 800 ft, 100 KCAS": gtm.replace({**channels, "condition.speed_kcas": 100}),
    }


def bench_noise_bias(quick: bool = False) -> dict:
    """Predicted and measured bias of every estimator and channel at every condition."""
    rows = []
    t0 = time.perf_counter()
    chosen = list(conditions().items())[: 1 if quick else None]
    for label, base in chosen:
        for estimator in ESTIMATORS:
            scn = base.replace({"output.estimator": estimator})
            predicted = predict(scn)
            measured = measured_bias(scn, extra_periods=20 if quick else 100)
            for channel in scn.channels:
                rows.append(
                    {
                        "condition": label,
                        "estimator": estimator,
                        "channel": channel,
                        "predicted": predicted[channel].h_bias,
                        "measured": measured[channel],
                    }
                )
    return {"rows": rows, "wall_s": time.perf_counter() - t0}


def render_noise_bias(r: dict) -> tuple[list[tuple[str, str, str, str]], list[str]]:
    """Summary rows (quantity, value, baseline, ratio) and the markdown table."""
    rows = r["rows"]
    ratios = [x["measured"] / x["predicted"] for x in rows if x["predicted"] > 0]
    within = sum(0.75 <= q <= 1.25 for q in ratios)
    theta = [
        x["measured"] / x["predicted"]
        for x in rows
        if x["estimator"] == "streaming" and x["channel"] == "theta_rad"
    ]
    summary = [
        (
            "slow-mode bias, measured / predicted",
            f"{within} of {len(ratios)} cases within 25 %",
            "streaming theta (the largest bias): " + ", ".join(f"{q:.2f}" for q in theta),
            "",
        )
    ]
    lines = [
        "## Slow-mode bias: predicted against measured",
        "",
        "The bias of the mean settled h_est (RMS over taps, channel unit per deg) that the "
        "run's start from trim leaves: predicted from JSBSim's linearisation with the model's "
        "actuator (`probing.experiment.design.noise.predict`), measured on a noise-free run "
        "100 periods "
        "longer (settled mean minus the mean of the last 10 periods). "
        f"{r['wall_s']:.0f} s.",
        "",
        "| condition | estimator | channel | predicted | measured | measured / predicted |",
        "|---|---|---|---|---|---|",
    ]
    for x in rows:
        ratio = x["measured"] / x["predicted"] if x["predicted"] > 0 else float("nan")
        lines.append(
            f"| {x['condition']} | {x['estimator']} | {x['channel']} | {x['predicted']:.3g} "
            f"| {x['measured']:.3g} | {ratio:.2f} |"
        )
    lines.append("")
    return summary, lines


def run(args: argparse.Namespace) -> dict:
    """Predicted vs measured slow-mode bias."""
    return bench_noise_bias(quick=args.quick)


def render(r: dict) -> Rendered:
    """The summary rows and the section's text."""
    rows, lines = render_noise_bias(r)
    return Rendered([Row(q, v, b, ratio) for q, v, b, ratio in rows], lines)
