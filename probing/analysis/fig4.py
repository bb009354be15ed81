"""The numbers of the paper's Fig. 4, read from a results folder: no simulation.

``probing fig4`` runs a set (:mod:`probing.experiment.studies.fig4`), then this module reads the
runs'
Parquet files and ``manifest.json`` (:func:`collect`) and writes the summary
(:func:`write_summary`); :mod:`probing.analysis.fig4_plots` draws the figures from the same data.
``probing plot fig4 RESULTS_DIR`` does the last two alone.

Figures (``<stem>`` is ``fig4`` for the GTM set ``scenarios/fig4`` and the set folder's name
otherwise, e.g. ``fig4-737``):

* ``<stem>.png/.pdf``: one panel per nonlinearity, the probing output z of pitch (theta)
  against lag, mean over the settled periods, over the baseline.
* ``<stem>_compensated.png``: z with the known nonlinearity undone (eq. 11) over the baseline.
* ``<stem>_rate_limit.png``: shape error and gain against r_l / (2a/t0) for one and several
  simulation steps per bit.

Summary (``summary.csv``, ``summary.md`` in the results folder): one row per panel with the
predicted gain a~/a, the measured least-squares gain of h_est against the baseline's
(g = <h, h0>/<h0, h0>), the predicted offset b~ and the shape error ||h - g h0|| / ||g h0||.
See ``docs/fig4.md``.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from probing.core.correlator import StreamingCorrelator
from probing.core.errors import ProbingError
from probing.core.fixedorder import norm
from probing.core.metrics import gain_and_shape, predicted_apparent
from probing.core.nonlinearities import NoApparentFormError, RateLimit, compensate
from probing.core.prbs import Probe
from probing.experiment.output.storage import read_schema, read_settled
from probing.experiment.scenario import Scenario, parse_scenario
from probing.experiment.studies.fig4_set import BASELINE, CHANNEL, OFFSET_TWIN, PANELS

__all__ = [
    "Fig4Data",
    "NotAFig4FolderError",
    "PanelResult",
    "RunData",
    "collect",
    "read_run",
    "write_summary",
]


class NotAFig4FolderError(ProbingError, FileNotFoundError):
    """The folder holds no ``manifest.json`` of ``probing fig4`` (or it cannot be read)."""


# ------------------------------------------------------------------------ analysis
@dataclass
class RunData:
    """What the figures need from one run folder."""

    scenario: Scenario
    lag_s: np.ndarray
    z: np.ndarray  # settled periods x M, tap order
    h: np.ndarray  # settled periods x M


def read_run(folder: Path, channel: str = CHANNEL) -> RunData:
    """Read ``probing.parquet`` of a run: z and h_est of the settled periods of one channel."""
    path = folder / "probing.parquet"
    scn = parse_scenario(json.loads(read_schema(path).metadata[b"probing.scenario"]))
    settled = read_settled(path, channel, scn.settle_periods, scn.bits_per_period)
    return RunData(scn, settled.lag_s, settled.z, settled.h)


def offset_removed(sat_dir: Path, off_dir: Path, channel: str = CHANNEL) -> RunData:
    """The remedy: correlate theta_saturated - theta_offset_twin over the bit samples.

    Both runs receive the same mean offset b~ (a step) from the same trim; the offset twin
    has no probe, so the difference is the response to the probe part (a~/a) p alone and its
    probing output is free of the non-periodic transient the step starts.
    """
    sat = read_run(sat_dir, channel)
    scn = sat.scenario
    y_sat = pd.read_parquet(sat_dir / "timeseries.parquet", columns=[channel])[channel]
    y_off = pd.read_parquet(off_dir / "timeseries.parquet", columns=[channel])[channel]
    spb = scn.steps_per_bit
    y = (y_sat.to_numpy() - y_off.to_numpy())[spb - 1 :: spb]
    probe = Probe(scn.order, scn.bit_duration_s, scn.amplitude_deg)
    corr = StreamingCorrelator(probe.reference(), probe.amplitude_deg)
    corr.push(y)
    est = corr.pop_periods()
    keep = est.period >= scn.settle_periods
    return RunData(scn, sat.lag_s, est.z[keep], est.h[keep])


@dataclass
class PanelResult:
    """One panel's numbers (a row of the summary)."""

    key: str
    letter: str
    nonlinearity: str
    parameters: str
    predicted_gain: float  # a~/a; NaN without an apparent form
    predicted_offset_deg: float  # b~; NaN without an apparent form
    measured_gain: float
    shape_error: float
    run: RunData
    measured_gain_z: float = math.nan  # the same fit on the probing output z
    shape_error_z: float = math.nan
    compensated_z: np.ndarray | None = None  # mean over settled periods
    compensated_periods: np.ndarray | None = None  # per settled period (P, M), for bounds
    compensation_error: float = math.nan  # ||zc - z0|| / ||z0||

    def row(self) -> dict[str, object]:
        return {
            "panel": self.letter,
            "nonlinearity": self.nonlinearity,
            "parameters": self.parameters,
            "predicted_gain": self.predicted_gain,
            "measured_gain": self.measured_gain,
            "predicted_offset_deg": self.predicted_offset_deg,
            "shape_error": self.shape_error,
            "measured_gain_z": self.measured_gain_z,
            "shape_error_z": self.shape_error_z,
            "compensation_error": self.compensation_error,
        }


@dataclass
class Fig4Data:
    """Everything the figures and the summary need, read from a results folder."""

    set_name: str
    baseline: RunData
    panels: list[PanelResult]
    remedy: RunData | None
    remedy_row: PanelResult | None
    sweep: pd.DataFrame


def _read_manifest(results: Path) -> dict:
    """The ``manifest.json`` of a Fig. 4 results folder (it must name the panels' folders)."""
    try:
        manifest = json.loads((results / "manifest.json").read_text())
        manifest["panels"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise NotAFig4FolderError(
            f"{results}: not a results folder of probing fig4 "
            f"(manifest.json: {exc.__class__.__name__}); run probing fig4 first"
        ) from None
    return manifest


def _panel_result(
    key: str, letter: str, run: RunData, h0: np.ndarray, z0: np.ndarray
) -> PanelResult:
    """One panel's numbers: predicted and measured gain, shape error, compensated z."""
    scn = run.scenario
    nl = scn.build_nonlinearity()
    a = scn.amplitude_deg
    pg, pb = predicted_apparent(nl, a, scn.bit_duration_s)
    g, shape = gain_and_shape(run.h.mean(axis=0), h0)
    res = PanelResult(
        key, letter, scn.nonlinearity_label, scn.describe_nonlinearity(), pg, pb, g, shape, run
    )
    res.measured_gain_z, res.shape_error_z = gain_and_shape(run.z.mean(axis=0), z0)
    try:
        per_period = compensate(run.z, nl, a)
    except NoApparentFormError:  # a rate limit: nothing to undo
        pass
    else:
        zc = per_period.mean(axis=0)
        res.compensated_z = zc
        res.compensated_periods = per_period
        res.compensation_error = norm(zc - z0) / norm(z0)
    return res


def _remedy_row(
    remedy: RunData, panels: list[PanelResult], h0: np.ndarray, z0: np.ndarray
) -> PanelResult:
    """The row of the remedy (saturation with the offset twin subtracted)."""
    sat = next(p for p in panels if p.key == "b_saturation")
    g, shape = gain_and_shape(remedy.h.mean(axis=0), h0)
    remedy_row = PanelResult(
        "b_saturation_offset_removed",
        "b'",
        "saturation, offset twin subtracted",
        sat.parameters,
        sat.predicted_gain,
        0.0,
        g,
        shape,
        remedy,
    )
    # The remedy removes the offset b~ from the output: only the scale a~/a is left.
    zr = remedy.z.mean(axis=0) / sat.predicted_gain
    remedy_row.measured_gain_z, remedy_row.shape_error_z = gain_and_shape(remedy.z.mean(axis=0), z0)
    remedy_row.compensated_z = zr
    remedy_row.compensated_periods = remedy.z / sat.predicted_gain
    remedy_row.compensation_error = norm(zr - z0) / norm(z0)
    return remedy_row


def _is_sweep_baseline(r: dict) -> bool:
    """A rate-limit sweep run without a rate limit (its ratio is None or NaN)."""
    return r["ratio"] is None or math.isnan(r["ratio"])


def _read_sweep_runs(results: Path, manifest: dict) -> list[dict]:
    """The rate-limit sweep's manifest entries with the mean h and z of each run present."""
    rows = []
    for entry in manifest.get("sweep", []):
        folder = results / "rate_limit_sweep" / entry["folder"]
        if folder.exists():
            run = read_run(folder)
            rows.append({**entry, "h": run.h.mean(axis=0), "z": run.z.mean(axis=0)})
    return rows


def _sweep_rows(rows: list[dict]) -> list[dict[str, object]]:
    """Gain and shape error of each rate-limited run against its bit duration's baseline."""
    sweep_rows = []
    for t0 in sorted({r["bit_duration_s"] for r in rows}):
        group = [r for r in rows if r["bit_duration_s"] == t0]
        base_rows = [r for r in group if _is_sweep_baseline(r)]
        if not base_rows:
            continue
        hb, zb = base_rows[0]["h"], base_rows[0]["z"]
        for r in group:
            if _is_sweep_baseline(r):
                continue
            g, shape = gain_and_shape(r["h"], hb)
            gz, shape_z = gain_and_shape(r["z"], zb)
            sweep_rows.append(
                {
                    "bit_duration_s": t0,
                    "ratio": r["ratio"],
                    "gain": g,
                    "shape_error": shape,
                    "gain_z": gz,
                    "shape_error_z": shape_z,
                }
            )
    return sweep_rows


def collect(results: Path) -> Fig4Data:
    """Read a Fig. 4 results folder (``manifest.json`` and the runs' Parquet files)."""
    manifest = _read_manifest(results)
    folders = manifest["panels"]
    base = read_run(results / folders[BASELINE])
    h0 = base.h.mean(axis=0)
    z0 = base.z.mean(axis=0)
    panels = [
        _panel_result(key, letter, read_run(results / folders[key]), h0, z0)
        for key, letter in PANELS.items()
    ]
    remedy = remedy_row = None
    if OFFSET_TWIN in folders and (results / folders[OFFSET_TWIN]).exists():
        remedy = offset_removed(results / folders["b_saturation"], results / folders[OFFSET_TWIN])
        remedy_row = _remedy_row(remedy, panels, h0, z0)
    sweep_rows = _sweep_rows(_read_sweep_runs(results, manifest))
    return Fig4Data(
        manifest["set"],
        base,
        panels,
        remedy,
        remedy_row,
        pd.DataFrame(sweep_rows),
    )


# -------------------------------------------------------------------------- output
#: How the summary names an aircraft model; a model not listed goes by its own name.
_AIRCRAFT_NAMES = {"gtm_t2": "GTM"}


def _fmt(x: float, spec: str = ".4f") -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def summary_rows(data: Fig4Data) -> list[dict[str, object]]:
    rows = [p.row() for p in data.panels]
    if data.remedy_row is not None:
        rows.insert(2, data.remedy_row.row())
    return rows


def write_summary(data: Fig4Data, results: Path) -> str:
    """Write ``summary.csv`` and ``summary.md``; return the Markdown table."""
    rows = summary_rows(data)
    with (results / "summary.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    base = data.baseline.scenario
    lines = [
        f"# Fig. 4 summary: {data.set_name} ({base.model}, {base.altitude_ft:g} ft, "
        f"{base.speed:g} {base.speed_kind.removeprefix('speed_')})",
        "",
        f"Probe: order {base.order} (M = {base.bits_per_period}), t0 = {base.bit_duration_s:g} s, "
        f"dt = {base.dt_s:g} s, a = {base.amplitude_deg:g} deg, {base.periods} periods "
        f"({base.settle_periods} settling); output {CHANNEL}.",
        "Gains: a~/a predicted from the nonlinearity, measured as the least-squares gain of "
        "h_est (mean over settled periods) against the baseline's; shape error "
        "||h - g h0|| / ||g h0||; compensation error ||z_c - z0|| / ||z0|| after eq. (11) "
        "(row b': z of the offset-removed run divided by a~/a). The _z columns make the same "
        "fit on the probing output z (the curves drawn): on the "
        f"{_AIRCRAFT_NAMES.get(base.model, base.model)} h_est is dominated by "
        "the phugoid's DC term, z shows the shape.",
        "",
        "| panel | nonlinearity | parameters | predicted_gain | measured_gain "
        "| predicted_offset_deg | shape_error | measured_gain_z | shape_error_z "
        "| compensation_error |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['panel']} | {r['nonlinearity']} | {r['parameters']} "
            f"| {_fmt(r['predicted_gain'])} | {_fmt(r['measured_gain'])} "
            f"| {_fmt(r['predicted_offset_deg'], '.4g')} | {_fmt(r['shape_error'], '.2e')} "
            f"| {_fmt(r['measured_gain_z'])} | {_fmt(r['shape_error_z'], '.2e')} "
            f"| {_fmt(r['compensation_error'], '.2e')} |"
        )
    if not data.sweep.empty:
        lines += [
            "",
            "Rate-limit sweep (periods 4, settle 2): shape error and gain against r_l/(2a/t0).",
            "",
            "| t0 (s) | r_l/(2a/t0) | r_l (deg/s) | gain (h) | shape_error (h) | gain (z) "
            "| shape_error (z) |",
            "|---|---|---|---|---|---|---|",
        ]
        for r in data.sweep.itertuples():
            rate = r.ratio * RateLimit.bound(base.amplitude_deg, r.bit_duration_s)
            lines.append(
                f"| {r.bit_duration_s:g} | {r.ratio:.3f} | {rate:.3g} | {r.gain:.4f} "
                f"| {r.shape_error:.2e} | {r.gain_z:.4f} | {r.shape_error_z:.2e} |"
            )
    text = "\n".join(lines) + "\n"
    (results / "summary.md").write_text(text)
    return text
