"""One probing run: scenario -> trimmed plant -> probe + nonlinearity -> correlator -> Parquet.

Timing conventions (documented in ``docs/method.md``):

* Step k applies probe sample k (the elevator command is written, then
  ``run()``); output sample k is read right after that step.
* A bit spanning several steps becomes one correlator sample: the output read
  after the *last* step of the bit (end-of-bit sampling).  This is exactly the
  zero-order-hold discretisation at the bit duration, so the taps are the
  pulse response of the plant sampled at t0.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np
import pyarrow as pa

from probing.correlator import StreamingCorrelator
from probing.nonlinearities import (
    Backlash,
    Deadband,
    HysteresisRelay,
    Nonlinearity,
    RateLimit,
    Relay,
    Saturation,
)
from probing.plant import Plant, TrimResult
from probing.prbs import Probe
from probing.scenario import Scenario
from probing.storage import output_folder, provenance

__all__ = [
    "PROBING_SCHEMA",
    "RunResult",
    "build_nonlinearity",
    "make_plant",
    "probing_rows",
    "run_scenario",
]

PROBING_SCHEMA = pa.schema(
    [
        ("channel", pa.string()),
        ("period", pa.int32()),
        ("tap", pa.int32()),
        ("lag_s", pa.float64()),
        ("z", pa.float64()),
        ("zeta", pa.float64()),
        ("h_est", pa.float64()),
    ]
)


def probing_rows(
    channel: str, period: int, lag_s: np.ndarray, z: np.ndarray, zeta: np.ndarray, h: np.ndarray
) -> dict[str, object]:
    """One period of one channel in the layout of :data:`PROBING_SCHEMA`."""
    m = z.size
    return {
        "channel": [channel] * m,
        "period": np.full(m, period, dtype=np.int32),
        "tap": np.arange(m, dtype=np.int32),
        "lag_s": lag_s,
        "z": z,
        "zeta": zeta,
        "h_est": h,
    }


def build_nonlinearity(scn: Scenario) -> Nonlinearity | None:
    """The scenario's nonlinearity (parameters in deg, deg/s), or None."""
    p = scn.nl_params
    match scn.nonlinearity:
        case "none":
            return None
        case "deadband":
            return Deadband(p["lower_deg"], p["upper_deg"])
        case "saturation":
            return Saturation(p["lower_deg"], p["upper_deg"])
        case "relay":
            return Relay(p["threshold_deg"], p["low_deg"], p["high_deg"])
        case "hysteresis_relay":
            return HysteresisRelay(
                p["lower_threshold_deg"], p["upper_threshold_deg"], p["low_deg"], p["high_deg"]
            )
        case "backlash":
            return Backlash(p["width_deg"])
        case "rate_limit":
            return RateLimit(p["rate_deg_s"])
    raise ValueError(f"unknown nonlinearity {scn.nonlinearity!r}")


def make_plant(scn: Scenario) -> Plant:
    """A plant for the scenario, trimmed at its condition."""
    plant = Plant(scn.model, scn.dt_s, turbulence=scn.turbulence, seed=scn.seed)
    plant.trim(scn.altitude_ft, **{scn.speed_kind: scn.speed})
    return plant


@dataclass
class RunResult:
    """What a run produced."""

    out_dir: Path
    trim: TrimResult
    h_est: dict[str, np.ndarray]  # per channel, mean over the settled periods
    steps_simulated: int
    wall_s: float


class _Progress:
    """A one-line progress bar with ETA on a terminal; silent otherwise."""

    def __init__(self, total: int, label: str, stream: TextIO | None, enabled: bool | None) -> None:
        self.total = total
        self.label = label
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.start = time.perf_counter()

    def update(self, done: int) -> None:
        if not self.enabled:
            return
        frac = done / self.total
        elapsed = time.perf_counter() - self.start
        eta = elapsed / frac - elapsed if frac > 0 else math.nan
        bar = "#" * int(30 * frac)
        self.stream.write(
            f"\r{self.label} [{bar:<30}] {done}/{self.total} periods, ETA {eta:5.1f} s"
        )
        if done == self.total:
            self.stream.write("\n")
        self.stream.flush()


def _detrend(y: np.ndarray, order: int) -> np.ndarray:
    """Remove a least-squares polynomial of the given order from each column."""
    t = np.linspace(-1.0, 1.0, y.shape[0])
    basis = np.vander(t, order + 1)
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    return y - basis @ coef


def run_scenario(
    scn: Scenario,
    out: str | Path,
    *,
    progress: bool | None = None,
    stream: TextIO | None = None,
    folder: str | Path | None = None,
) -> RunResult:
    """Simulate a scenario and write ``out/<name>/probing.parquet`` and ``timeseries.parquet``.

    Parameters
    ----------
    scn : Scenario
        A validated scenario.
    out : path
        Output folder; results go to ``out/<scn.name>/``.
    progress : bool, optional
        Force the progress bar on or off; default: on when ``stream`` is a TTY.
    stream : file, optional
        Where the progress bar goes (default stderr).
    folder : path, optional
        Write into exactly this folder instead of ``out/<scn.name>/`` (used by sweeps).

    Returns
    -------
    RunResult
        Trim, averaged pulse-response estimates and timing.

    Raises
    ------
    probing.plant.TrimError, probing.plant.DivergenceError
        On trim failure or divergence; no output file is left behind.
    """
    t_start = time.perf_counter()
    probe = Probe(scn.order, scn.bit_duration_s, scn.amplitude_deg)
    nl = build_nonlinearity(scn)
    m, spb, dt = probe.length, probe.steps_per_bit(scn.dt_s), scn.dt_s
    n_steps = m * spb
    channels = list(scn.channels)
    n_ch = len(channels)

    plant = make_plant(scn)
    trim = plant.trim_result
    twin = make_plant(scn) if scn.drift == "reference" else None
    nodes = plant.channel_nodes(channels)
    twin_nodes = twin.channel_nodes(channels) if twin else None
    y_trim = np.array([n.get_double_value() for n in nodes])
    cmd_trim = np.full(n_steps, trim.elevator_cmd_norm)

    x_period = probe.samples(dt, 1)
    nl_state = nl.initial_state() if nl else None
    sigma = np.array([scn.sensor_noise.get(c, 0.0) for c in channels])
    rng = np.random.default_rng(scn.seed)
    correlators = [StreamingCorrelator(probe.reference(), probe.amplitude_deg) for _ in channels]
    lag_s = np.arange(m) * probe.bit_duration_s
    h_sum = np.zeros((n_ch, m))
    h_count = 0

    folder = Path(folder) if folder is not None else Path(out) / scn.name
    meta = provenance(
        scenario_toml=scn.text,
        scenario=scn.to_dict(),
        scenario_digest=scn.digest(),
        trim=trim.to_dict(),
        drift=scn.drift,
        sampling="one correlator sample per bit: the output read after the last step of the bit",
    )
    ts_fields = [
        ("time_s", pa.float64()),
        ("probe_deg", pa.float64()),
        ("nl_out_deg", pa.float64()),
        ("elevator_deg", pa.float64()),
    ] + [(c, pa.float64()) for c in channels]
    if twin:
        ts_fields += [(f"{c}_reference", pa.float64()) for c in channels]
    with output_folder(folder, meta) as outputs:
        w_probe = outputs.writer("probing.parquet", PROBING_SCHEMA)
        w_ts = outputs.writer("timeseries.parquet", pa.schema(ts_fields))

        bar = _Progress(scn.periods, scn.name, stream, progress)
        out_probed = np.empty((n_steps, n_ch))
        out_ref = np.empty((n_steps, n_ch))
        elevator = np.empty(n_steps)
        prev_bits: np.ndarray | None = None
        for period in range(scn.periods):
            q, nl_state = nl.process(x_period, dt, nl_state) if nl else (x_period, None)
            cmd = plant.elevator_command(trim.elevator_deg + q)
            plant.step(cmd, nodes, out_probed, elevator)
            plant.check_state()
            measured = out_probed + rng.standard_normal((n_steps, n_ch)) * sigma
            if twin:
                twin.step(cmd_trim, twin_nodes, out_ref, None)
                twin.check_state()
                y = measured - out_ref
            else:
                y = measured - y_trim
            y_bits = y[spb - 1 :: spb]
            estimates = []
            if scn.drift == "detrend":
                # Each period's z windows reach back one period: detrend both together.
                if prev_bits is not None:
                    window = _detrend(np.vstack((prev_bits, y_bits)), scn.detrend_order)
                    for j in range(n_ch):
                        fresh = StreamingCorrelator(probe.reference(), probe.amplitude_deg)
                        fresh.push(window[:, j])
                        est = fresh.pop_periods()
                        estimates.append((est.z[1:], est.zeta[1:], est.h[1:]))
                prev_bits = y_bits.copy()
            else:
                for j, corr in enumerate(correlators):
                    corr.push(y_bits[:, j])
                    est = corr.pop_periods()
                    estimates.append((est.z, est.zeta, est.h))
            for j, (z, zeta, h) in enumerate(estimates):
                if len(z) == 0:
                    continue
                w_probe.write(probing_rows(channels[j], period, lag_s, z[0], zeta[0], h[0]))
                if period >= scn.settle_periods and np.all(np.isfinite(h[0])):
                    h_sum[j] += h[0]
                    if j == 0:
                        h_count += 1
            cols = {
                "time_s": (period * n_steps + np.arange(1, n_steps + 1)) * dt,
                "probe_deg": x_period,
                "nl_out_deg": q,
                "elevator_deg": elevator,
            }
            for j, c in enumerate(channels):
                cols[c] = measured[:, j]
                if twin:
                    cols[f"{c}_reference"] = out_ref[:, j]
            w_ts.write(cols)
            bar.update(period + 1)
    h_mean = {
        c: h_sum[j] / h_count if h_count else np.full(m, np.nan) for j, c in enumerate(channels)
    }
    steps = scn.total_steps * (2 if twin else 1)
    return RunResult(
        out_dir=folder,
        trim=trim,
        h_est=h_mean,
        steps_simulated=steps,
        wall_s=time.perf_counter() - t_start,
    )
