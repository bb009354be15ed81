"""Seed-to-seed statistics of a sweep that repeats its points over ``disturbance.seed``: the
measured scatter and bias of the estimates against the noise model's predictions.

Points that differ only in their seed form a group.  For each group and output channel:

* **h, z scatter**: the standard deviation over seeds of the mean settled h_est (z), RMS over
  taps; predicted by :mod:`probing.experiment.design.noise` (stored by each point in
  ``point.json``).
* **gain scatter**: the standard deviation over seeds of the least-squares gain of each
  seed's h against the group's seed mean; predicted by the noise model for that same
  reference (:meth:`probing.core.noise.NoiseModel.gain_std`).

The bias is not measured here: the seed mean still carries the scatter / sqrt(S), and the
steady state it would be compared with is known only as well as the linearisation.  It is
checked on long noise-free runs instead (:func:`probing.experiment.design.noise.measured_bias`).

With S seeds a measured standard deviation has a relative sampling error of about
1 / sqrt(2 (S - 1)) (10 % at S = 50), drawn as error bars.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from probing.analysis.tables import fmt
from probing.core.fixedorder import dot, vdot
from probing.core.noise import noise_model, white
from probing.experiment.output.storage import read_settled

__all__ = ["SEED", "GroupStats", "has_seeds", "seed_statistics", "seed_table"]

SEED = "disturbance.seed"
QUANTITIES = ("h_stderr", "z_stderr", "gain_stderr")


@dataclass
class GroupStats:
    """Measured and predicted statistics of one group of seeds, for one channel."""

    label: str
    channel: str
    seeds: int
    measured: dict[str, float]
    predicted: dict[str, float]
    indices: tuple[int, ...] = ()  # the group's points (the summary's ``index``)

    def ratio(self, quantity: str) -> float:
        """Measured over predicted (NaN when the prediction is 0 or missing)."""
        p = self.predicted.get(quantity, math.nan)
        return self.measured[quantity] / p if p and math.isfinite(p) else math.nan

    @property
    def sampling_error(self) -> float:
        """Relative standard error of a standard deviation measured over the seeds."""
        return 1.0 / math.sqrt(2 * (self.seeds - 1)) if self.seeds > 1 else math.nan


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def has_seeds(data: Any) -> bool:
    """True when the sweep repeats its points over at least 3 seeds."""
    seeds = {v.get(SEED) for v in data.values.values()}
    return SEED in data.varying and len(seeds) >= 3


def seed_statistics(data: Any) -> list[GroupStats]:
    """The groups of a seed sweep (:class:`probing.analysis.sweep_plots.SweepData`), every channel.

    Groups whose points are not all done, or hold fewer than 3 seeds, are left out.
    """
    df = data.summary
    others = [f for f in data.varying if f != SEED]
    groups: dict[tuple, list[int]] = {}
    for index, status in zip(df["index"], df["status"], strict=True):
        key = tuple(json.dumps(data.values[int(index)].get(f), default=str) for f in others)
        groups.setdefault(key, []).append(int(index) if status == "done" else -1)
    out: list[GroupStats] = []
    for key, indices in groups.items():
        if -1 in indices or len(indices) < 3:
            continue
        label = ", ".join(
            f"{f.rsplit('.', 1)[-1]}={json.loads(v)}" for f, v in zip(others, key, strict=True)
        )
        out += _group(data, indices, label or "all")
    return out


def _group(data: Any, indices: list[int], label: str) -> list[GroupStats]:
    scn = data.scenario(indices[0])
    ids = {
        int(i): pid for i, pid in zip(data.summary["index"], data.summary["point_id"], strict=True)
    }
    folders = [data.folder / "points" / f"point_id={ids[i]}" for i in indices]
    infos = [json.loads((f / "point.json").read_text()) for f in folders]
    m = scn.bits_per_period
    ref = scn.probe.reference()
    detrend_order = scn.detrend_order if scn.detrends else None
    out = []
    for channel in scn.channels:
        settled = [
            read_settled(f / "probing.parquet", channel, scn.settle_periods, m) for f in folders
        ]
        h = np.array([s.h.mean(axis=0) for s in settled])
        z = np.array([s.z.mean(axis=0) for s in settled])
        h_bar = h.mean(axis=0)
        gains = dot(h, h_bar) / vdot(h_bar, h_bar)
        predicted = [info.get("predicted", {}).get(channel) or {} for info in infos]
        first = predicted[0]
        periods = int(settled[0].h.shape[0])
        model = noise_model(
            ref,
            scn.amplitude_deg,
            scn.estimator,
            periods,
            white(scn.sensor_noise.get(channel, 0.0)),
            detrend_order,
            scn.probe.harmonics,
        )
        measured = {
            "h_stderr": _rms(h.std(axis=0, ddof=1)),
            "z_stderr": _rms(z.std(axis=0, ddof=1)),
            "gain_stderr": float(gains.std(ddof=1)),
        }
        out.append(
            GroupStats(
                label,
                channel,
                len(indices),
                measured,
                {
                    "h_stderr": _num(first.get("h_stderr")),
                    "z_stderr": _num(first.get("z_stderr")),
                    "gain_stderr": model.gain_std(h_bar),
                },
                tuple(indices),
            )
        )
    return out


def _num(value: Any) -> float:
    return math.nan if value is None else float(value)


def seed_table(stats: list[GroupStats]) -> str:
    """A Markdown table: per group and channel, each quantity measured / predicted (ratio);
    channels without noise (nothing predicted) are left out."""
    head = "| group | channel | seeds | " + " | ".join(QUANTITIES) + " |"
    lines = [head, "|" + "---|" * (3 + len(QUANTITIES))]
    for s in stats:
        if not any(s.predicted[q] for q in QUANTITIES):  # a channel without noise
            continue
        cells = [
            f"{fmt(s.measured[q], 3)} / {fmt(s.predicted[q], 3)} ({fmt(s.ratio(q), 3)})"
            for q in QUANTITIES
        ]
        lines.append(f"| {s.label} | {s.channel} | {s.seeds} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
