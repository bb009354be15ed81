"""Reproduction of the paper's Fig. 4: probing output through seven hard input nonlinearities.

Usage::

    probing fig4 [--scenarios scenarios/fig4] [--out results/<set>] [--figures figures] [--force]
    probing plot fig4 RESULTS_DIR [--figures figures]

``probing fig4`` runs every scenario of a set (``baseline.toml`` and one file per panel,
``a_deadband.toml`` .. ``g_hysteresis_relay.toml``), a constant-offset twin for the
saturation panel, and a rate-limit sweep; then draws the figures and writes the summary.
A run is skipped when its ``probing.parquet`` already holds the same scenario digest (Parquet
metadata key ``probing.scenario_digest``), so a second call only replots.
``probing plot fig4`` replots from the Parquet files and ``manifest.json`` of a results folder
without touching the simulator.

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

import argparse
import csv
import json
import math
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq

from probing.correlator import StreamingCorrelator
from probing.metrics import gain_and_shape
from probing.nonlinearities import RateLimit, compensate
from probing.prbs import Probe
from probing.run import build_nonlinearity, run_scenario
from probing.scenario import Scenario, load_scenario, parse_scenario
from probing.storage import write_json_atomic

__all__ = [
    "PANELS",
    "PanelResult",
    "collect",
    "main",
    "plot_main",
    "run_set",
]

#: Panel key (scenario file stem) -> panel letter, in figure order.
PANELS: dict[str, str] = {
    "a_deadband": "a",
    "b_saturation": "b",
    "c_relay": "c",
    "d_backlash": "d",
    "e_rate_limit": "e",
    "f_rate_limit": "f",
    "g_hysteresis_relay": "g",
}
BASELINE = "baseline"
OFFSET_TWIN = "b_saturation_offset"  # constant b~ through the same chain: the remedy run
CHANNEL = "theta_rad"
DIGEST_KEY = b"probing.scenario_digest"
#: Rate-limit sweep: r_l / (2a/t0), log-spaced, and the bit durations (s).
SWEEP_RATIOS = tuple(float(r) for r in np.geomspace(0.25, 4.0, 9))  # 0.25 * sqrt(2)**k
SWEEP_BITS_S = (0.01, 0.04)
SWEEP_PERIODS, SWEEP_SETTLE = 4, 2


# ---------------------------------------------------------------------------- runs
def stored_digest(folder: Path) -> str | None:
    """The scenario digest stored in ``folder/probing.parquet``, or None."""
    path = folder / "probing.parquet"
    if not path.exists() or not (folder / "timeseries.parquet").exists():
        return None
    meta = pq.read_schema(path).metadata or {}
    value = meta.get(DIGEST_KEY)
    return value.decode() if value else None


def ensure_run(scn: Scenario, out: Path, force: bool = False) -> tuple[float, bool]:
    """Run ``scn`` into ``out/<name>`` unless it is already there; (wall s, simulated?)."""
    if not force and stored_digest(out / scn.name) == scn.digest():
        return 0.0, False
    result = run_scenario(scn, out, progress=None)
    return result.wall_s, True


def offset_twin(sat: Scenario) -> Scenario:
    """The saturation scenario with its probe replaced by the constant offset b~.

    A relay whose threshold lies far above the probe (90 deg) outputs its low level for every
    probe value; with low = high = b~ it is a constant b~: the same step the saturated run
    receives on average, without the probe.
    """
    _, b_t = build_nonlinearity(sat).apparent(sat.amplitude_deg)
    return sat.replace(
        {
            "name": f"{sat.name}-offset",
            "nonlinearity.type": "relay",
            "nonlinearity.threshold_deg": 90.0,
            "nonlinearity.low_deg": b_t,
            "nonlinearity.high_deg": b_t,
        }
    )


def sweep_scenarios(template: Scenario) -> list[tuple[float, float, Scenario]]:
    """(t0, ratio, scenario) of the rate-limit sweep; ratio NaN marks the baseline of a t0."""
    out = []
    a = template.amplitude_deg
    for t0 in SWEEP_BITS_S:
        common = {
            "probe.bit_duration_s": t0,
            "probe.periods": SWEEP_PERIODS,
            "probe.settle_periods": SWEEP_SETTLE,
            "output.channels": [CHANNEL],
        }
        base = template.replace(
            {**common, "name": f"{template.name}-sweep-t0-{t0:g}-none", "nonlinearity.type": "none"}
        )
        out.append((t0, math.nan, base))
        for ratio in SWEEP_RATIOS:
            rate = ratio * RateLimit.bound(a, t0)
            scn = template.replace(
                {
                    **common,
                    "name": f"{template.name}-sweep-t0-{t0:g}-r{ratio:.3f}",
                    "nonlinearity.type": "rate_limit",
                    "nonlinearity.rate_deg_s": rate,
                }
            )
            out.append((t0, ratio, scn))
    return out


def load_set(scen_dir: Path) -> dict[str, Scenario]:
    """The scenarios of a Fig. 4 set, keyed by file stem (baseline and the seven panels)."""
    scenarios = {}
    for key in (BASELINE, *PANELS):
        path = scen_dir / f"{key}.toml"
        if not path.exists():
            raise FileNotFoundError(f"{path}: missing (a Fig. 4 set needs {key}.toml)")
        scenarios[key] = load_scenario(path)
    return scenarios


def run_set(
    scen_dir: Path, out: Path, *, force: bool = False, sweep_rate_limit: bool = True, log=print
) -> dict:
    """Run a Fig. 4 set (skipping runs already stored) and write ``out/manifest.json``.

    ``sweep_rate_limit=False`` leaves out the rate-limit sweep (and its figure).
    """
    scenarios = load_set(scen_dir)
    scenarios[OFFSET_TWIN] = offset_twin(scenarios["b_saturation"])
    out.mkdir(parents=True, exist_ok=True)
    sim_wall = 0.0
    for key, scn in scenarios.items():
        wall, ran = ensure_run(scn, out, force)
        sim_wall += wall
        status = f"ran in {wall:.2f} s" if ran else "stored"
        log(f"  {key:<22} {scn.name:<36} {status}")
    sweep_dir = out / "rate_limit_sweep"
    sweep = []
    n_ran = 0
    todo = sweep_scenarios(scenarios["f_rate_limit"]) if sweep_rate_limit else []
    for t0, ratio, scn in todo:
        wall, ran = ensure_run(scn, sweep_dir, force)
        sim_wall += wall
        n_ran += ran
        sweep.append({"bit_duration_s": t0, "ratio": ratio, "folder": scn.name})
    log(f"  rate-limit sweep: {len(sweep)} runs, {n_ran} simulated")
    manifest = {
        "set": scen_dir.resolve().name,
        "scenarios_dir": str(scen_dir),
        "panels": {k: s.name for k, s in scenarios.items()},
        "sweep": sweep,
        "simulation_wall_s": sim_wall,
    }
    write_json_atomic(out / "manifest.json", manifest)
    return manifest


# ------------------------------------------------------------------------ analysis
@dataclass
class RunData:
    """What the figures need from one run folder."""

    scenario: Scenario
    lag_s: np.ndarray
    z: np.ndarray  # settled periods x M, tap order
    h: np.ndarray  # settled periods x M
    z_all: np.ndarray = field(repr=False)  # every period (for the transient)


def read_run(folder: Path, channel: str = CHANNEL) -> RunData:
    """Read ``probing.parquet`` of a run: z and h_est per period of one channel."""
    table = pq.read_table(folder / "probing.parquet")
    meta = table.schema.metadata
    scn = parse_scenario(json.loads(meta[b"probing.scenario"]))
    df = table.to_pandas()
    df = df[df["channel"] == channel].sort_values(["period", "tap"])
    m = scn.bits_per_period
    z_all = df["z"].to_numpy().reshape(-1, m)
    h_all = df["h_est"].to_numpy().reshape(-1, m)
    periods = df["period"].to_numpy().reshape(-1, m)[:, 0]
    keep = periods >= scn.settle_periods
    return RunData(scn, df["lag_s"].to_numpy()[:m], z_all[keep], h_all[keep], z_all)


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
    return RunData(scn, sat.lag_s, est.z[keep], est.h[keep], est.z)


def describe(scn: Scenario) -> tuple[str, str]:
    """(nonlinearity name, its parameters) for titles and tables."""
    p = scn.nl_params
    match scn.nonlinearity:
        case "deadband":
            return "deadband", f"d-, d+ = {p['lower_deg']:.4g}, {p['upper_deg']:.4g} deg"
        case "saturation":
            return "saturation", f"U-, U+ = {p['lower_deg']:.4g}, {p['upper_deg']:.4g} deg"
        case "relay":
            return "relay", (
                f"S = {p['threshold_deg']:.4g}, l-, l+ = {p['low_deg']:.4g}, "
                f"{p['high_deg']:.4g} deg"
            )
        case "hysteresis_relay" if (
            p["lower_threshold_deg"] == -p["upper_threshold_deg"] and p["low_deg"] == -p["high_deg"]
        ):
            return "hysteresis relay", (
                f"S± = ±{p['upper_threshold_deg']:.4g}, l± = ±{p['high_deg']:.4g} deg"
            )
        case "hysteresis_relay":
            return "hysteresis relay", (
                f"S-, S+ = {p['lower_threshold_deg']:.4g}, {p['upper_threshold_deg']:.4g}; "
                f"l-, l+ = {p['low_deg']:.4g}, {p['high_deg']:.4g} deg"
            )
        case "backlash":
            return "backlash", f"width b_l = {p['width_deg']:.4g} deg"
        case "rate_limit":
            return "rate limit", f"r_l = {p['rate_deg_s']:.4g} deg/s"
    return "none", ""


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
    simulation_wall_s: float


def collect(results: Path) -> Fig4Data:
    """Read a Fig. 4 results folder (``manifest.json`` and the runs' Parquet files)."""
    manifest = json.loads((results / "manifest.json").read_text())
    folders = manifest["panels"]
    base = read_run(results / folders[BASELINE])
    h0 = base.h.mean(axis=0)
    z0 = base.z.mean(axis=0)
    panels = []
    for key, letter in PANELS.items():
        run = read_run(results / folders[key])
        scn = run.scenario
        nl = build_nonlinearity(scn)
        a = scn.amplitude_deg
        name, params = describe(scn)
        if isinstance(nl, RateLimit):
            pg = 1.0 if nl.admits(a, scn.bit_duration_s) else math.nan
            pb = 0.0 if nl.admits(a, scn.bit_duration_s) else math.nan
        else:
            a_t, b_t = nl.apparent(a)
            pg, pb = a_t / a, b_t
        g, shape = gain_and_shape(run.h.mean(axis=0), h0)
        res = PanelResult(key, letter, name, params, pg, pb, g, shape, run)
        res.measured_gain_z, res.shape_error_z = gain_and_shape(run.z.mean(axis=0), z0)
        if not isinstance(nl, RateLimit):
            zc = compensate(run.z, nl, a).mean(axis=0)
            res.compensated_z = zc
            res.compensation_error = float(np.linalg.norm(zc - z0) / np.linalg.norm(z0))
        panels.append(res)
    remedy = remedy_row = None
    if OFFSET_TWIN in folders and (results / folders[OFFSET_TWIN]).exists():
        remedy = offset_removed(results / folders["b_saturation"], results / folders[OFFSET_TWIN])
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
        remedy_row.measured_gain_z, remedy_row.shape_error_z = gain_and_shape(
            remedy.z.mean(axis=0), z0
        )
        remedy_row.compensated_z = zr
        remedy_row.compensation_error = float(np.linalg.norm(zr - z0) / np.linalg.norm(z0))
    rows = []
    for entry in manifest.get("sweep", []):
        folder = results / "rate_limit_sweep" / entry["folder"]
        if folder.exists():
            run = read_run(folder)
            rows.append({**entry, "h": run.h.mean(axis=0), "z": run.z.mean(axis=0)})
    sweep_rows = []
    for t0 in sorted({r["bit_duration_s"] for r in rows}):
        group = [r for r in rows if r["bit_duration_s"] == t0]
        base_rows = [r for r in group if r["ratio"] is None or math.isnan(r["ratio"])]
        if not base_rows:
            continue
        hb, zb = base_rows[0]["h"], base_rows[0]["z"]
        for r in group:
            if r["ratio"] is None or math.isnan(r["ratio"]):
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
    return Fig4Data(
        manifest["set"],
        base,
        panels,
        remedy,
        remedy_row,
        pd.DataFrame(sweep_rows),
        float(manifest.get("simulation_wall_s", math.nan)),
    )


# -------------------------------------------------------------------------- output
def _fmt(x: float, spec: str = ".4f") -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def summary_rows(data: Fig4Data) -> list[dict[str, object]]:
    rows = [p.row() for p in data.panels]
    if data.remedy_row is not None:
        rows.insert(2, data.remedy_row.row())
    return rows


def write_summary(data: Fig4Data, results: Path, wall_s: float | None = None) -> str:
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
        "fit on the probing output z (the curves drawn): on the GTM h_est is dominated by "
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
    if wall_s is not None:
        lines += ["", f"Wall time of this `probing fig4` call: {wall_s:.1f} s."]
    text = "\n".join(lines) + "\n"
    (results / "summary.md").write_text(text)
    return text


def figure_stem(set_name: str) -> str:
    return set_name


def _plot_all(data: Fig4Data, figures: Path) -> list[Path]:
    from analysis import fig4_plots

    return fig4_plots.draw(data, figures, figure_stem(data.set_name))


# ------------------------------------------------------------------------- commands
def _finish(results: Path, figures: Path, copy_summary: Path | None, t_start: float) -> int:
    data = collect(results)
    paths = _plot_all(data, figures)
    wall = time.perf_counter() - t_start
    text = write_summary(data, results, wall)
    if copy_summary is not None:
        copy_summary.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(results / "summary.md", copy_summary)
    print(text)
    for p in paths:
        print(f"figure -> {p}")
    print(f"summary -> {results / 'summary.csv'}, {results / 'summary.md'}")
    print(f"wall time {wall:.1f} s")
    return 0


def main(args: argparse.Namespace) -> int:
    """``probing fig4``: run the set (skipping stored runs), draw, summarise."""
    t_start = time.perf_counter()
    scen_dir = Path(getattr(args, "scenarios", None) or "scenarios/fig4")
    out = getattr(args, "out", None)
    results = Path(out) if out else Path("results") / scen_dir.resolve().name
    figures = Path(getattr(args, "figures", None) or "figures")
    print(f"probing fig4: {scen_dir} -> {results}")
    run_set(scen_dir, results, force=bool(getattr(args, "force", False)))
    return _finish(results, figures, getattr(args, "copy_summary", None), t_start)


def plot_main(args: argparse.Namespace) -> int:
    """``probing plot fig4 RESULTS_DIR``: replot from stored Parquet, no simulation."""
    t_start = time.perf_counter()
    results = Path(args.results)
    if not (results / "manifest.json").exists():
        print(f"probing plot fig4: {results}/manifest.json missing: run `probing fig4` first")
        return 2
    figures = Path(getattr(args, "figures", None) or "figures")
    return _finish(results, figures, getattr(args, "copy_summary", None), t_start)
