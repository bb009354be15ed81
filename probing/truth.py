"""Ground truth for a scenario: the small-signal pulse response, computed two independent ways.

(a) Single pulse: a trimmed twin receives one bit of the probe amplitude on the
    elevator; its output minus an unprobed twin's, divided by the amplitude,
    sampled at the end of every bit, is the pulse response ``h_pulse`` (output
    units per deg of elevator), as long as the whole run.
(b) Linearisation: JSBSim's FGLinearization at the trim gives (A, B, C, D);
    discretised with zero-order hold at the bit duration,
    ``h_lin(0) = C B_d + D`` and ``h_lin(k) = C A_d^k B_d`` -- the response read
    at the end of each bit to a one-bit pulse, matching (a).

A probing run folds the tail of h that lies beyond one period into its M taps
and has not reached a periodic steady state while the phugoid still rings, so
the like-for-like comparison is a *prediction*: the superposition of the
single-pulse response over the actual probe history, pushed through the same
correlator (``prediction.parquet``, same layout as ``probing.parquet``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
from scipy.signal import cont2discrete, fftconvolve

from probing.correlator import StreamingCorrelator
from probing.prbs import Probe
from probing.run import PROBING_SCHEMA, make_plant, probing_rows
from probing.scenario import Scenario
from probing.storage import output_folder, provenance

__all__ = ["LINEAR_OUTPUTS", "compute_truth", "linear_pulse_response", "single_pulse_response"]

#: Project channel -> FGLinearization output name.
LINEAR_OUTPUTS = {"theta_rad": "Theta", "q_rad_s": "Q", "alpha_rad": "Alpha"}


def single_pulse_response(scn: Scenario, n_bits: int) -> dict[str, np.ndarray]:
    """Response to one bit of amplitude a at t = 0, per deg, sampled at the end of each bit."""
    probe = Probe(scn.order, scn.bit_duration_s, scn.amplitude_deg)
    spb = probe.steps_per_bit(scn.dt_s)
    n_steps = n_bits * spb
    channels = list(scn.channels)
    pulsed, reference = make_plant(scn), make_plant(scn)
    trim = pulsed.trim_result
    surface = np.full(n_steps, trim.elevator_deg)
    surface[:spb] += scn.amplitude_deg
    out_p = np.empty((n_steps, len(channels)))
    out_r = np.empty((n_steps, len(channels)))
    pulsed.step(pulsed.elevator_command(surface), pulsed.channel_nodes(channels), out_p, None)
    pulsed.check_state()
    cmd_trim = np.full(n_steps, trim.elevator_cmd_norm)
    reference.step(cmd_trim, reference.channel_nodes(channels), out_r, None)
    h = (out_p - out_r)[spb - 1 :: spb] / scn.amplitude_deg
    return {c: h[:, j] for j, c in enumerate(channels)}


def linear_pulse_response(scn: Scenario, n_bits: int) -> dict[str, np.ndarray]:
    """Pulse response from JSBSim's linearisation, ZOH at the bit duration, per deg of elevator."""
    plant = make_plant(scn)
    lin = plant.linearise()
    gain = plant.elevator_gain_deg_per_norm()
    iu = lin["u_names"].index("DeCmd")
    a_mat, b_mat = lin["A"], lin["B"][:, [iu]] / gain  # per deg of surface
    out: dict[str, np.ndarray] = {}
    ad, bd, *_ = cont2discrete((a_mat, b_mat, lin["C"], lin["D"]), scn.bit_duration_s, "zoh")
    x = np.empty((n_bits, a_mat.shape[0]))
    x[0] = bd[:, 0]
    for k in range(1, n_bits):
        x[k] = ad @ x[k - 1]
    for channel, name in LINEAR_OUTPUTS.items():
        if channel not in scn.channels:
            continue
        iy = lin["y_names"].index(name)
        h = x @ lin["C"][iy]
        h[0] += lin["D"][iy, iu] / gain
        out[channel] = h
    return out


def predicted_probing(scn: Scenario, h_pulse: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Probing output predicted by superposing the single-pulse response over the probe history.

    Returns, per channel, an array (periods, 3, M): z, zeta, h_est per period.
    """
    probe = Probe(scn.order, scn.bit_duration_s, scn.amplitude_deg)
    bits = probe.bits(scn.periods)
    out = {}
    for channel, h in h_pulse.items():
        y = fftconvolve(bits, h)[: bits.size]
        corr = StreamingCorrelator(probe.reference(), probe.amplitude_deg)
        corr.push(y)
        est = corr.pop_periods()
        out[channel] = np.stack((est.z, est.zeta, est.h), axis=1)
    return out


def compute_truth(scn: Scenario, out: str | Path) -> Path:
    """Write ``truth.parquet`` and ``prediction.parquet`` beside the run's output.

    ``truth.parquet``: channel, tap, lag_s, h_pulse, h_lin (NaN where the
    linear model has no such output), over the whole run length.
    """
    probe = Probe(scn.order, scn.bit_duration_s, scn.amplitude_deg)
    m = probe.length
    n_bits = scn.periods * m
    h_pulse = single_pulse_response(scn, n_bits)
    h_lin = linear_pulse_response(scn, n_bits)
    pred = predicted_probing(scn, h_pulse)
    folder = Path(out) / scn.name
    meta = provenance(
        scenario_toml=scn.text,
        scenario=scn.to_dict(),
        scenario_digest=scn.digest(),
        truth="h_pulse: single one-bit pulse on a trimmed twin; h_lin: FGLinearization, ZOH at t0",
    )
    schema = pa.schema(
        [
            ("channel", pa.string()),
            ("tap", pa.int32()),
            ("lag_s", pa.float64()),
            ("h_pulse", pa.float64()),
            ("h_lin", pa.float64()),
        ]
    )
    with output_folder(folder, meta) as outputs:
        w_truth = outputs.writer("truth.parquet", schema)
        w_pred = outputs.writer("prediction.parquet", PROBING_SCHEMA)
        taps = np.arange(n_bits, dtype=np.int32)
        lag_s = np.arange(m) * probe.bit_duration_s
        for channel in scn.channels:
            w_truth.write(
                {
                    "channel": [channel] * n_bits,
                    "tap": taps,
                    "lag_s": taps * probe.bit_duration_s,
                    "h_pulse": h_pulse[channel],
                    "h_lin": h_lin.get(channel, np.full(n_bits, np.nan)),
                }
            )
            for period, (z, zeta, h) in enumerate(pred[channel]):
                w_pred.write(probing_rows(channel, period, lag_s, z, zeta, h))
    return folder / "truth.parquet"
