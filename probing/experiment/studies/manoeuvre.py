"""Incremental probing through a manoeuvre (``[manoeuvre]``): the probing output period by
period around a moving operating point, against a single-pulse truth started there.

Two aircraft fly the same autopilot and the same manoeuvre (one hold loop's reference ramps,
:class:`probing.sim.flight.Manoeuvre`): the probed one, with the probe between the autopilot
and the surface, and an unprobed twin.  Their difference holds only the probe's response
around the moving point (to first order); each period is estimated from its own samples (the
cyclic estimator with its DC correction), so period p reports the response the aircraft had
during that period.

Truth: at the middle of every period the twin is forked, and the copy gets a one-bit pulse
of the probe's amplitude while a second copy does not; both fly on for
:data:`FOLD_PERIODS` periods with the same autopilot and manoeuvre.  Their difference, folded
onto one period as the cyclic estimate folds a response longer than a period, is the
small-signal pulse response at the state the manoeuvre reached there, closed loop as
the probe sees it (JSBSim's linearisation is the open-loop aircraft's, and away from trim
the state is not an equilibrium: the single-pulse twin is the truth that holds both).
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from probing.core.fixedorder import norm
from probing.core.forked import forked_map
from probing.core.noise import cyclic_estimates
from probing.experiment.flight.run import scenario_provenance
from probing.experiment.output.progress import progress_bar
from probing.experiment.output.storage import OUTPUT_FILES, output_folder
from probing.experiment.scenario import Scenario
from probing.sim.control import ClosedLoop, control_power
from probing.sim.plant import make_plant

__all__ = ["ManoeuvreResult", "run_manoeuvre"]


@dataclass(frozen=True)
class ManoeuvreResult:
    """What :func:`run_manoeuvre` found.

    Attributes
    ----------
    out_dir : pathlib.Path
        The run's folder (``manoeuvre.parquet``).
    errors : dict
        Channel -> per period, ||h_est - h_pulse|| / ||h_pulse|| (L2 over the taps).
    steps_simulated : int
        JSBSim steps: both aircraft and the truth's copies.
    wall_s : float
        Wall-clock time, s.
    """

    out_dir: Path
    errors: dict[str, np.ndarray]
    steps_simulated: int
    wall_s: float


#: Periods the truth's copies fly on after their pulse: the response is folded onto one
#: period over them (sum of h[k + jM]), as the cyclic estimate folds it.
FOLD_PERIODS = 8


def _pulse_copy(
    pulsed: bool, loop: ClosedLoop, nodes: list, n_steps: int, spb: int, amplitude: float
) -> np.ndarray:
    """In a forked copy of the twin: fly on ``n_steps`` steps, with a one-bit pulse first if
    ``pulsed``; the outputs at every bit's end."""
    probe = None
    if pulsed:
        probe = np.zeros(n_steps)
        probe[:spb] = amplitude
    out = np.empty((n_steps, len(nodes)))
    loop.step(probe, nodes, out)
    loop.plant.check_state()
    return out[spb - 1 :: spb]


def _truth(twin: ClosedLoop, nodes: list, m: int, spb: int, amplitude: float) -> np.ndarray:
    """The single-pulse truth at the twin's present state: a pulsed and an unpulsed forked
    copy fly on :data:`FOLD_PERIODS` periods; their difference per unit amplitude, folded
    onto one period, (C, M)."""
    copy = functools.partial(
        _pulse_copy,
        loop=twin,
        nodes=nodes,
        n_steps=FOLD_PERIODS * m * spb,
        spb=spb,
        amplitude=amplitude,
    )
    found = {o.index: o.get() for o in forked_map(copy, [True, False], jobs=2)}
    pulse = (found[0] - found[1]) / amplitude  # (FOLD_PERIODS M, C)
    return pulse.reshape(FOLD_PERIODS, m, -1).sum(axis=0).T  # folded, (C, M)


def _append_period(
    rows: dict[str, list],
    errors: dict[str, list[float]],
    scn: Scenario,
    p: int,
    mid_s: float,
    achieved: float,
    h_est: np.ndarray,
    h_pulse: np.ndarray,
) -> None:
    """Append period ``p``'s rows (every channel, every tap) and its errors per channel."""
    man = scn.manoeuvre
    m = h_est.shape[1]
    taps = np.arange(m, dtype=np.int32)
    for j, c in enumerate(scn.channels):
        rows["channel"] += [c] * m
        rows["period"] += [p] * m
        rows["time_mid_s"] += [mid_s] * m
        rows["reference"] += [float(man.offset(np.array(mid_s)))] * m
        rows["achieved"] += [achieved] * m
        rows["tap"].append(taps)
        rows["lag_s"].append(taps * scn.bit_duration_s)
        rows["h_est"].append(h_est[j])
        rows["h_pulse"].append(h_pulse[j])
        errors[c].append(norm(h_est[j] - h_pulse[j]) / norm(h_pulse[j]))


def _write_rows(scn: Scenario, out: str | Path, rows: dict[str, list], trim_result) -> Path:
    """Write the rows to ``out/<name>/manoeuvre.parquet``; the run's folder."""
    man = scn.manoeuvre
    columns = {
        k: np.concatenate(v) if k in ("tap", "lag_s", "h_est", "h_pulse") else np.array(v)
        for k, v in rows.items()
    }
    columns["period"] = columns["period"].astype(np.int32)
    folder = Path(out) / scn.name
    meta = scenario_provenance(scn, trim_result)
    with output_folder(folder, meta) as files:
        writer = files.writer(
            "manoeuvre.parquet",
            list(scn.channels),
            scn.surface_unit,
            own_units={"reference": man.unit, "achieved": man.unit},
        )
        writer.write(columns)
    return folder


def run_manoeuvre(
    scn: Scenario,
    out: str | Path,
    *,
    progress: bool | None = None,
    stream: TextIO | None = None,
) -> ManoeuvreResult:
    """Fly a ``[manoeuvre]`` scenario and write ``out/<name>/manoeuvre.parquet``.

    Raises
    ------
    probing.sim.errors.TrimError, probing.sim.errors.DivergenceError
        On trim failure or divergence; nothing is written.
    """
    t_start = time.perf_counter()
    man = scn.manoeuvre
    assert man is not None and scn.control is not None, "not a manoeuvre scenario"
    flight = scn.flight
    power = control_power(flight)
    probe = scn.probe
    m, spb = probe.length, probe.steps_per_bit(scn.dt_s)
    period = m * spb
    half = (m // 2) * spb  # the pulse of the truth starts on a bit boundary near mid-period
    channels = list(scn.channels)
    loops = []
    for _ in range(2):
        plant = make_plant(flight)
        loops.append(ClosedLoop(plant, scn.control, power, surface=scn.surface, manoeuvre=man))
    probed, twin = loops
    nodes_p, nodes_t = (loop.plant.channel_nodes(channels) for loop in loops)
    (achieved_node,) = twin.plant.channel_nodes([man.channel])
    trimmed_value = achieved_node.get_double_value()
    u = probe.samples(scn.dt_s)
    reference = probe.reference()
    y_p, y_t = np.empty((period, len(channels))), np.empty((period, len(channels)))
    rows: dict[str, list] = {f.name: [] for f in OUTPUT_FILES["manoeuvre.parquet"].schema}
    errors: dict[str, list[float]] = {c: [] for c in channels}
    steps = 0
    with progress_bar(scn.periods, scn.name, "periods", stream, progress) as bar:
        for p in range(scn.periods):
            probed.step(u, nodes_p, y_p)
            probed.plant.check_state()
            twin.step(None, nodes_t, y_t[:half])
            mid_s = (p * period + half) * scn.dt_s
            achieved = man.in_unit(achieved_node.get_double_value() - trimmed_value)
            h_pulse = _truth(twin, nodes_t, m, spb, scn.amplitude_deg)
            twin.step(None, nodes_t, y_t[half:])
            twin.plant.check_state()
            steps += (2 + 2 * FOLD_PERIODS) * period
            dy = (y_p - y_t)[spb - 1 :: spb]  # (M, C)
            _, _, h_est = cyclic_estimates(dy.T, reference, scn.amplitude_deg)  # (C, M)
            _append_period(rows, errors, scn, p, mid_s, achieved, h_est, h_pulse)
            bar.advance()
    folder = _write_rows(scn, out, rows, probed.plant.trim_result)
    return ManoeuvreResult(
        folder,
        {c: np.array(e) for c, e in errors.items()},
        steps,
        time.perf_counter() - t_start,
    )
