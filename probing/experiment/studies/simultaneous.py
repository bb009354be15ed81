"""Several surfaces probed in one flight (``[simultaneous]``): the design's check from the
linearisation, the flight, and its validation against each surface probed alone.

The check (:func:`check_separation`) is what ``probing design --check`` prints and what every
run does first: from JSBSim's linearisation at the trim, each surface's pulse response in
each channel, at its amplitude, must have died out (below ``max_crosstalk`` of the channel's
largest response) within the bits the design separates the surfaces by
(:attr:`probing.core.multiplex.Layout.separation_bits`).  A design that fails it is refused.
The check also predicts the cross-talk: the design flown on the linearised aircraft (bit by
bit, superposing the surfaces) against each surface flown alone on it.

:func:`run_simultaneous` flies the design on JSBSim and, with ``truth``, each surface alone
through the same design (the others held at trim); the difference in each surface's window
is the cross-talk the design really leaves, nonlinear coupling included.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TextIO

import numpy as np

from probing.core.convolution import causal_convolve
from probing.core.errors import ProbingError
from probing.core.multiplex import Layout, memory_bits
from probing.core.prbs import mls
from probing.experiment.flight.run import scenario_provenance
from probing.experiment.output.progress import progress_bar
from probing.experiment.output.storage import output_folder
from probing.experiment.scenario import Scenario
from probing.sim.channels import CHANNELS, unit_of
from probing.sim.plant import TrimResult, make_plant
from probing.sim.surfaces import SURFACES
from probing.sim.truth import linear_pulse_response
from probing.sim.twins import open_twin
from probing.sim.world import JSBSimWorld

__all__ = [
    "SeparationCheck",
    "SimultaneousResult",
    "check_separation",
    "layout_of",
    "run_simultaneous",
]


class SeparationError(ProbingError, ValueError):
    """A simultaneous design that cannot keep its surfaces apart; the message says why."""


def layout_of(scn: Scenario) -> Layout:
    """The :class:`~probing.core.multiplex.Layout` of a ``[simultaneous]`` scenario."""
    assert scn.simultaneous is not None, "not a simultaneous scenario"
    sim = scn.simultaneous
    return Layout(
        sim.design,
        len(sim.surfaces),
        2**scn.order - 1,
        scn.periods - scn.settle_periods,
        scn.settle_periods,
    )


@dataclass(frozen=True)
class SeparationCheck:
    """The memory condition of a simultaneous design, from the linearisation.

    Attributes
    ----------
    layout : Layout
        Who is probed when.
    rows : list of dict
        Per surface and channel: ``memory_s`` (until its response at its amplitude stays below
        ``max_crosstalk`` of the channel's largest), ``separation_s`` (what the design allows),
        ``predicted_crosstalk`` (the linear aircraft's cross-talk in the surface's window, as
        a fraction of the channel's largest response) and ``ok``.
    h_lin : numpy.ndarray
        (k, C, window bits): each surface's estimate flown alone on the linear aircraft.
    """

    layout: Layout
    rows: list[dict]
    h_lin: np.ndarray
    max_crosstalk: float

    @property
    def ok(self) -> bool:
        """True if every response dies out within the separation."""
        return all(r["ok"] for r in self.rows)

    def table(self) -> str:
        """The rows as a Markdown table."""
        lines = [
            "| surface | channel | memory (s) | separation (s) | predicted cross-talk | ok |",
            "|---|---|---:|---:|---:|---|",
        ]
        for r in self.rows:
            lines.append(
                f"| {r['surface']} | {r['channel']} | {r['memory_s']:.1f} | "
                f"{r['separation_s']:.1f} | {100 * r['predicted_crosstalk']:.2f} % | "
                f"{'yes' if r['ok'] else 'no'} |"
            )
        return "\n".join(lines)

    def refusal(self) -> str:
        """One line: why the design is refused (empty if it is not)."""
        bad = [r for r in self.rows if not r["ok"]]
        if not bad:
            return ""
        worst = max(
            bad, key=lambda r: (r["memory_s"] / r["separation_s"], r["predicted_crosstalk"])
        )
        what = "window M/k t0" if self.layout.design == "shift" else "settle periods"
        return (
            f"simultaneous {self.layout.design} design refused: {worst['surface']} -> "
            f"{worst['channel']} lasts {worst['memory_s']:.1f} s above "
            f"{100 * self.max_crosstalk:g} % of the channel's largest response, longer than "
            f"the {worst['separation_s']:.1f} s of its {what} (predicted cross-talk "
            f"{100 * worst['predicted_crosstalk']:.1f} %); raise the order or the bit "
            f"duration, leave out the channel, or fly the other design"
        )


def check_separation(scn: Scenario) -> SeparationCheck:
    """The memory condition and predicted cross-talk of a ``[simultaneous]`` scenario, from
    JSBSim's linearisation at its trim (see the module docstring).

    A row is ok when the response dies out within the separation and the predicted
    cross-talk stays within ``max_crosstalk`` (a slow tail under the floor can still add up).

    Raises
    ------
    SeparationError
        If a channel has no linearised output to check with.
    """
    sim = scn.simultaneous
    assert sim is not None, "not a simultaneous scenario"
    layout = layout_of(scn)
    unchecked = [c for c in scn.channels if CHANNELS[c].linear_output is None]
    if unchecked:
        raise SeparationError(
            f"simultaneous: {', '.join(unchecked)} has no linearised output to check the "
            f"design's memory with; leave it out of output.channels"
        )
    m, k = layout.length, layout.surfaces
    bits = layout.total_periods * m
    amplitudes = np.array(sim.amplitudes)
    # each surface's bit-rate pulse response, long enough to cover the whole flight
    pulse = np.array(
        [
            _per_channel(
                linear_pulse_response(
                    replace(scn.flight, surface=s), scn.channels, scn.bit_duration_s, bits
                ),
                scn.channels,
            )
            for s in sim.surfaces
        ]
    )  # (k, C, bits), per unit of the surface
    scaled = pulse * amplitudes[:, None, None]  # at each surface's amplitude
    largest = np.abs(scaled).max(axis=(0, 2))  # (C,)
    reference = mls(scn.order)
    inputs = layout.inputs(reference) * amplitudes[:, None]  # (k, bits)
    outputs = np.array(
        [
            [causal_convolve(inputs[i], pulse[i, c]) for c in range(len(scn.channels))]
            for i in range(k)
        ]
    )  # (k, C, bits): each surface's own contribution
    together = layout.responses(outputs.sum(axis=0).T, reference, amplitudes)
    alone = np.array(
        [layout.responses(outputs[i].T, reference, amplitudes)[i] for i in range(k)]
    )  # (k, C, window)
    t0 = scn.bit_duration_s
    rows = []
    for i, surface in enumerate(sim.surfaces):
        for c, channel in enumerate(scn.channels):
            floor = sim.max_crosstalk * largest[c]
            mem = memory_bits(scaled[i, c], floor) if largest[c] > 0 else 0
            miss = np.abs(amplitudes[i] * (together[i, c] - alone[i, c])).max()
            rows.append(
                {
                    "surface": surface,
                    "channel": channel,
                    "memory_s": mem * t0,
                    "separation_s": layout.separation_bits * t0,
                    "predicted_crosstalk": float(miss / largest[c]) if largest[c] > 0 else 0.0,
                    "ok": bool(
                        mem <= layout.separation_bits and miss <= sim.max_crosstalk * largest[c]
                    ),
                }
            )
    return SeparationCheck(layout, rows, alone, sim.max_crosstalk)


def _per_channel(found: dict[str, np.ndarray], channels: tuple[str, ...]) -> np.ndarray:
    return np.array([found[c] for c in channels])


@dataclass(frozen=True)
class SimultaneousResult:
    """What :func:`run_simultaneous` found.

    Attributes
    ----------
    out_dir : pathlib.Path
        The run's folder (``responses.parquet``).
    check : SeparationCheck
        The design's check from the linearisation.
    crosstalk : list of dict or None
        With ``truth``: per surface and channel, the measured cross-talk (max over the
        window of |together - alone| at the surface's amplitude, as a fraction of the
        channel's largest response alone; ``crosstalk_of_own``: of the surface's own peak in
        the channel, larger where its response is a weak one) and the error of the
        flown-alone estimate against the linearisation, the same way.
    steps_simulated : int
        JSBSim steps, all flights and twins.
    wall_s : float
        Wall-clock time, s.
    """

    out_dir: Path
    check: SeparationCheck
    crosstalk: list[dict] | None
    steps_simulated: int
    wall_s: float

    def table(self) -> str:
        """The measured cross-talk as a Markdown table (empty without ``truth``)."""
        if not self.crosstalk:
            return ""
        lines = [
            "| surface | channel | cross-talk (measured) | predicted | alone vs linearisation |",
            "|---|---|---:|---:|---:|",
        ]
        predicted = {(r["surface"], r["channel"]): r for r in self.check.rows}
        for r in self.crosstalk:
            p = predicted[r["surface"], r["channel"]]["predicted_crosstalk"]
            lines.append(
                f"| {r['surface']} | {r['channel']} | {100 * r['crosstalk']:.2f} % | "
                f"{100 * p:.2f} % | {100 * r['alone_vs_linear']:.2f} % |"
            )
        return "\n".join(lines)


def run_simultaneous(
    scn: Scenario,
    out: str | Path,
    *,
    truth: bool = False,
    progress: bool | None = None,
    stream: TextIO | None = None,
    twin_cache: bool = True,
) -> SimultaneousResult:
    """Fly a ``[simultaneous]`` scenario and write ``out/<name>/responses.parquet``.

    Parameters
    ----------
    scn : Scenario
        A validated scenario with a ``[simultaneous]`` section.
    out : path
        Output folder; results go to ``out/<scn.name>/``.
    truth : bool
        Also fly each surface alone through the same design (the others held at trim), for
        the ``h_alone`` column and the measured cross-talk; without it ``h_alone`` is NaN.
    progress, stream
        The progress bar (flights), as for :func:`probing.experiment.flight.run.run_scenario`.
    twin_cache : bool
        Read the unprobed twin from the cache (``drift = "reference"``).

    Raises
    ------
    SeparationError
        If the design fails its memory condition (:func:`check_separation`); nothing is
        flown or written.
    """
    t_start = time.perf_counter()
    check = check_separation(scn)
    if not check.ok:
        raise SeparationError(check.refusal())
    sim = scn.simultaneous
    assert sim is not None
    layout = check.layout
    k = layout.surfaces
    flights = [tuple(True for _ in range(k))]
    if truth:
        flights += [tuple(i == j for j in range(k)) for i in range(k)]
    estimates, steps, trim = [], 0, None
    reference = mls(scn.order)
    amplitudes = np.array(sim.amplitudes)
    with progress_bar(len(flights), scn.name, "flights", stream, progress) as bar:
        for active in flights:
            y_bits, n_steps, trim = _fly(scn, layout, active, twin_cache)
            estimates.append(layout.responses(y_bits, reference, amplitudes))
            steps += n_steps
            bar.advance()
    together = estimates[0]
    alone = (
        np.array([estimates[1 + i][i] for i in range(k)])
        if truth
        else np.full_like(together, np.nan)
    )
    crosstalk = _crosstalk(scn, together, alone, check.h_lin) if truth else None
    folder = Path(out) / scn.name
    meta = scenario_provenance(
        scn,
        trim,
        design={"check": check.rows, "window_bits": layout.window_bits},
        crosstalk=crosstalk,
    )
    with output_folder(folder, meta) as files:
        writer = files.writer(
            "responses.parquet",
            scn.channels,
            own_units={column: _units(scn) for column in ("h_est", "h_alone", "h_lin")},
        )
        writer.write(_rows(scn, layout, together, alone, check.h_lin))
    return SimultaneousResult(folder, check, crosstalk, steps, time.perf_counter() - t_start)


def _units(scn: Scenario) -> dict[str, str]:
    sim = scn.simultaneous
    assert sim is not None
    return {
        f"{s}/{c}": f"{unit_of(c)}/{SURFACES[s].unit}" for s in sim.surfaces for c in scn.channels
    }


def _crosstalk(
    scn: Scenario, together: np.ndarray, alone: np.ndarray, h_lin: np.ndarray
) -> list[dict]:
    sim = scn.simultaneous
    assert sim is not None
    amplitudes = np.array(sim.amplitudes)[:, None, None]
    largest = np.abs(alone * amplitudes).max(axis=(0, 2))  # (C,)
    miss = np.abs((together - alone) * amplitudes).max(axis=2) / largest  # (k, C)
    own = np.abs(alone).max(axis=2)  # (k, C): each response's own peak, per unit
    lin = np.abs((alone - h_lin) * amplitudes).max(axis=2) / largest
    return [
        {
            "surface": s,
            "channel": c,
            "crosstalk": float(miss[i, j]),
            "crosstalk_of_own": float(miss[i, j] * largest[j] / (own[i, j] * amplitudes[i, 0, 0])),
            "alone_vs_linear": float(lin[i, j]),
        }
        for i, s in enumerate(sim.surfaces)
        for j, c in enumerate(scn.channels)
    ]


def _rows(
    scn: Scenario, layout: Layout, together: np.ndarray, alone: np.ndarray, h_lin: np.ndarray
) -> dict[str, np.ndarray]:
    sim = scn.simultaneous
    assert sim is not None
    k, n_ch, w = together.shape
    taps = np.arange(w, dtype=np.int32)
    return {
        "surface": np.repeat(np.array(sim.surfaces, dtype=object), n_ch * w),
        "channel": np.tile(np.repeat(np.array(scn.channels, dtype=object), w), k),
        "tap": np.tile(taps, k * n_ch),
        "lag_s": np.tile(taps * scn.bit_duration_s, k * n_ch),
        "h_est": together.reshape(-1),
        "h_alone": alone.reshape(-1),
        "h_lin": h_lin.reshape(-1),
    }


def _fly(
    scn: Scenario, layout: Layout, active: tuple[bool, ...], twin_cache: bool
) -> tuple[np.ndarray, int, TrimResult]:
    """One flight of the design with the ``active`` surfaces probed (the others at trim):
    the output's deviation from the unprobed twin (or the trimmed output) at every bit's
    end, the steps simulated and the trim."""
    sim = scn.simultaneous
    assert sim is not None
    flight = scn.flight
    plant = make_plant(flight)
    drives = [plant.drive(s) for s in sim.surfaces]
    spb = scn.steps_per_bit
    inputs = layout.inputs(mls(scn.order))
    commands = np.empty((inputs.shape[1] * spb, len(drives)))
    for i, (drive, a) in enumerate(zip(drives, sim.amplitudes, strict=True)):
        position = drive.trim_position + (a * np.repeat(inputs[i], spb) if active[i] else 0.0)
        try:
            commands[:, i] = drive.command(position)
        except ValueError as exc:
            raise SeparationError(f"simultaneous: {exc}") from None
    nodes = plant.channel_nodes(list(scn.channels))
    y_trim = np.array([n.get_double_value() for n in nodes])
    total = commands.shape[0]
    period = layout.length * spb
    y = np.empty((total, len(nodes)))
    steps = total
    twin = (
        open_twin(flight, scn.channels, total, use_cache=twin_cache)
        if scn.twin_knows_gusts
        else None
    )
    world, setters = JSBSimWorld(plant), [d.set for d in drives]
    if twin is None:
        for first in range(0, total, period):
            span = slice(first, first + period)
            world.fly(period, nodes, y[span], table=commands[span], setters=setters)
            plant.check_state()
        y -= y_trim
    else:
        with twin:
            for first in range(0, total, period):
                span = slice(first, first + period)
                world.fly(period, nodes, y[span], table=commands[span], setters=setters)
                plant.check_state()
                y[span] -= twin.next(period)
            steps += twin.steps_simulated
    assert plant.trim_result is not None
    return y[spb - 1 :: spb], steps, plant.trim_result
