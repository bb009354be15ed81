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

import time
from contextlib import nullcontext
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
from probing.plant import TrimResult, make_plant
from probing.prbs import Probe
from probing.progress import ProgressBar
from probing.scenario import Scenario
from probing.storage import output_folder, provenance
from probing.twins import open_twin

__all__ = [
    "PROBING_SCHEMA",
    "RunResult",
    "build_nonlinearity",
    "make_plant",
    "probing_block",
    "probing_rows",
    "run_scenario",
]

#: Steps post-processed together (noise, correlation, Parquet rows): whole periods, at
#: least one; the plant is still stepped and checked period by period.
CHUNK_STEPS = 8192

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
        "channel": pa.repeat(pa.scalar(channel, pa.string()), m),  # ~5x faster than a list
        "period": np.full(m, period, dtype=np.int32),
        "tap": np.arange(m, dtype=np.int32),
        "lag_s": lag_s,
        "z": z,
        "zeta": zeta,
        "h_est": h,
    }


def probing_block(
    channels: list[str],
    periods: np.ndarray,
    lag_s: np.ndarray,
    z: np.ndarray,
    zeta: np.ndarray,
    h: np.ndarray,
) -> dict[str, object]:
    """Several periods of several channels in the layout of :data:`PROBING_SCHEMA`.

    Parameters
    ----------
    channels : list of str
        Channel names, C of them.
    periods : numpy.ndarray
        Period indices, shape (P,).
    lag_s : numpy.ndarray
        Lag of each tap (s), shape (M,).
    z, zeta, h : numpy.ndarray
        Shape (P, C, M), in the units of :data:`PROBING_SCHEMA`'s columns.

    Returns
    -------
    dict
        Columns with the rows ordered by period, then channel, then tap: the same rows as
        :func:`probing_rows` called for each period and channel in that order.
    """
    n_p, n_c, m = z.shape
    names = pa.array(channels, pa.string())
    return {
        "channel": names.take(pa.array(np.tile(np.repeat(np.arange(n_c), m), n_p))),
        "period": np.repeat(np.asarray(periods, dtype=np.int32), n_c * m),
        "tap": np.tile(np.arange(m, dtype=np.int32), n_p * n_c),
        "lag_s": np.tile(lag_s, n_p * n_c),
        "z": z.reshape(-1),
        "zeta": zeta.reshape(-1),
        "h_est": h.reshape(-1),
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


@dataclass
class RunResult:
    """What a run produced.

    Attributes
    ----------
    out_dir : pathlib.Path
        The folder holding the Parquet files.
    trim : TrimResult
        The trimmed state of the probed aircraft.
    h_est : dict
        Channel -> mean of ``h_est`` over the settled periods (output units per deg).
    steps_simulated : int
        JSBSim steps actually simulated: the probed aircraft's, plus the reference twin's
        unless it was read from the cache (trim and calibration not counted).
    wall_s : float
        Wall time of the whole call (s).
    twin_cached : bool
        True if the reference twin was read from the cache instead of simulated.
    twin_key : str or None
        The twin's cache key (:func:`probing.twins.twin_key`); None without a twin.
    """

    out_dir: Path
    trim: TrimResult
    h_est: dict[str, np.ndarray]
    steps_simulated: int
    wall_s: float
    twin_cached: bool = False
    twin_key: str | None = None


def _correlator(probe: Probe, push_size: int) -> StreamingCorrelator:
    """A correlator whose FFT block takes one push of ``push_size`` samples in one piece.

    The default block (16 M) suits long pushes; a run pushes one period (or two, when
    detrending) at a time, and a block just large enough is ~3x faster per push.
    """
    m = probe.length
    need = max(push_size + m - 1, 2 * m)  # one block per push; the correlator needs >= 2 M
    nfft = 1 << (need - 1).bit_length()  # the smallest power of two >= need
    return StreamingCorrelator(probe.reference(), probe.amplitude_deg, block=nfft)


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
    twin_cache: bool = True,
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
    twin_cache : bool
        With ``drift = "reference"``: read the unprobed twin from the cache
        (:mod:`probing.twins`) when it is stored, and store it when simulated.  The results
        are bit-identical either way; False simulates the twin and stores nothing.

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
    nodes = plant.channel_nodes(channels)
    y_trim = np.array([n.get_double_value() for n in nodes])
    reference = scn.drift == "reference"

    x_period = probe.samples(dt, 1)
    nl_state = nl.initial_state() if nl else None
    sigma = np.array([scn.sensor_noise.get(c, 0.0) for c in channels])
    rng = np.random.default_rng(scn.seed)
    # Periods are simulated one by one (state checked after each) but post-processed
    # (noise, correlation, Parquet) a chunk of periods at a time: fewer, larger calls.
    chunk = max(1, CHUNK_STEPS // n_steps)
    correlators = [_correlator(probe, chunk * m) for _ in channels]
    lag_s = np.arange(m) * probe.bit_duration_s
    h_sum = np.zeros((n_ch, m))
    h_count = 0

    folder = Path(folder) if folder is not None else Path(out) / scn.name
    meta: dict[str, object] = {
        "scenario_toml": scn.text,
        "scenario": scn.to_dict(),
        "scenario_digest": scn.digest(),
        "trim": trim.to_dict(),
        "drift": scn.drift,
        "sampling": "one correlator sample per bit: the output read after the last step of the bit",
    }
    ts_fields = [
        ("time_s", pa.float64()),
        ("probe_deg", pa.float64()),
        ("nl_out_deg", pa.float64()),
        ("elevator_deg", pa.float64()),
    ] + [(c, pa.float64()) for c in channels]
    if reference:
        ts_fields += [(f"{c}_reference", pa.float64()) for c in channels]
    # The twin: read from the cache, or simulated alongside (and stored when complete).
    twin = open_twin(scn, use_cache=twin_cache) if reference else None
    if twin:
        meta["twin"] = {"key": twin.key, "cached": twin.cached}
    with twin or nullcontext(), output_folder(folder, provenance(**meta)) as outputs:
        w_probe = outputs.writer("probing.parquet", PROBING_SCHEMA)
        w_ts = outputs.writer("timeseries.parquet", pa.schema(ts_fields))

        bar = ProgressBar(scn.periods, scn.name, "periods", stream, progress)
        out_probed = np.empty((chunk * n_steps, n_ch))
        out_ref = np.empty((chunk * n_steps, n_ch))
        elevator = np.empty(chunk * n_steps)
        nl_out = np.empty(chunk * n_steps)
        prev_bits: np.ndarray | None = None
        for first in range(0, scn.periods, chunk):
            k = min(chunk, scn.periods - first)
            rows = k * n_steps
            for i in range(k):
                span = slice(i * n_steps, (i + 1) * n_steps)
                q, nl_state = nl.process(x_period, dt, nl_state) if nl else (x_period, None)
                nl_out[span] = q
                cmd = plant.elevator_command(trim.elevator_deg + q)
                plant.step(cmd, nodes, out_probed[span], elevator[span])
                plant.check_state()
                if twin:
                    out_ref[span] = twin.next(n_steps)
            measured = out_probed[:rows] + rng.standard_normal((rows, n_ch)) * sigma
            y = measured - (out_ref[:rows] if twin else y_trim)
            y_bits = y[spb - 1 :: spb]
            if scn.drift == "detrend":
                # Each period's z windows reach back one period: detrend both together.
                done, ests = [], []
                for i in range(k):
                    bits = y_bits[i * m : (i + 1) * m]
                    if prev_bits is not None:
                        window = _detrend(np.vstack((prev_bits, bits)), scn.detrend_order)
                        per_channel = []
                        for j in range(n_ch):
                            fresh = _correlator(probe, 2 * m)
                            fresh.push(window[:, j])
                            est = fresh.pop_periods()
                            per_channel.append((est.z[1], est.zeta[1], est.h[1]))
                        done.append(first + i)
                        ests.append(per_channel)
                    prev_bits = bits.copy()
                periods = np.array(done, dtype=np.int64)
                z, zeta, h = (
                    np.array([[e[x] for e in pc] for pc in ests]).reshape(-1, n_ch, m)
                    for x in range(3)
                )
            else:
                pops = []
                for j, corr in enumerate(correlators):
                    corr.push(y_bits[:, j])
                    pops.append(corr.pop_periods())
                periods = pops[0].period
                z, zeta, h = (
                    np.stack([getattr(e, x) for e in pops], axis=1) for x in ("z", "zeta", "h")
                )
            if periods.size:
                w_probe.write(probing_block(channels, periods, lag_s, z, zeta, h))
            for p, period in enumerate(periods.tolist()):
                if period < scn.settle_periods:
                    continue
                for j in range(n_ch):
                    if np.all(np.isfinite(h[p, j])):
                        h_sum[j] += h[p, j]
                        if j == 0:
                            h_count += 1
            cols = {
                "time_s": (first * n_steps + np.arange(1, rows + 1)) * dt,
                "probe_deg": np.tile(x_period, k),
                "nl_out_deg": nl_out[:rows],
                "elevator_deg": elevator[:rows],
            }
            for j, c in enumerate(channels):
                cols[c] = measured[:, j]
                if twin:
                    cols[f"{c}_reference"] = out_ref[:rows, j]
            w_ts.write(cols)
            bar.update(first + k)
    h_mean = {
        c: h_sum[j] / h_count if h_count else np.full(m, np.nan) for j, c in enumerate(channels)
    }
    return RunResult(
        out_dir=folder,
        trim=trim,
        h_est=h_mean,
        steps_simulated=scn.total_steps + (twin.steps_simulated if twin else 0),
        wall_s=time.perf_counter() - t_start,
        twin_cached=bool(twin and twin.cached),
        twin_key=twin.key if twin else None,
    )
