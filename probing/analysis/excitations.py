"""The excitation comparison's numbers, read from ``probing excitations``'s results (no
simulation): the PRBS, a multisine and a chirp on one RMS budget (``docs/excitations.md``).

For each aircraft and signal (:func:`collect`):

* **the signal**: harmonics excited, RMS, peak, crest factor and the largest step between
  two bits over the bit duration (what a rate limit must pass, eq. 21);
* **accuracy in calm air** without a nonlinearity: the settled estimate against JSBSim's
  linearisation (one step's delay), superposed over the signal's own history and estimated
  by its own estimator: the linearised truth over the signal's harmonics
  (:func:`probing.experiment.flight.drift.predicted_probing`), and against the whole linearised
  pulse response (folded over the period): what the band leaves out;
* **the gain's scatter over seeds**: the least-squares gain of each noisy baseline against
  the noise-free one (white sensor noise, same seeds for every signal);
* **each Fig. 4 nonlinearity**: the measured gain and shape error against the same signal's
  linear baseline, and the theory's: the estimate the nonlinearity leaves of that baseline,
  ``IDFT(H0_k Q_k / P_k)`` over the estimator's harmonics
  (:func:`probing.core.metrics.through_nonlinearity`), exact in the noise-free periodic
  steady state for any signal; for the PRBS it is eqs. 10-12's ``a~/a``.  The compensation of
  the known nonlinearity: eq. (11) on the PRBS's z, and for the others the same scalar rule,
  the estimate over the predicted gain.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from probing.analysis import fig4
from probing.core.errors import ProbingError
from probing.core.excitation import band_limited, crest_factor
from probing.core.fixedorder import norm
from probing.core.metrics import gain_and_shape, harmonic_ratio, through_nonlinearity
from probing.core.nonlinearities import NoApparentFormError, compensate
from probing.experiment.flight.drift import predicted_probing
from probing.experiment.output.storage import read_settled
from probing.experiment.scenario import Scenario
from probing.experiment.studies.fig4_set import PANELS

__all__ = ["CHANNELS", "Study", "collect", "summary_markdown"]

#: The channels compared: pitch attitude and pitch rate.
CHANNELS = ("theta_rad", "q_rad_s")


class NotAnExcitationsFolderError(ProbingError, FileNotFoundError):
    """The folder holds no ``manifest.json`` of ``probing excitations``."""


@dataclass
class Run:
    """One run: its scenario and each channel's settled h (P, M) and z (P, M)."""

    scenario: Scenario
    folder: Path
    h: dict[str, np.ndarray]
    z: dict[str, np.ndarray]

    def mean(self, channel: str) -> np.ndarray:
        return self.h[channel].mean(axis=0)


def read_run(folder: Path) -> Run:
    """A run folder's scenario and settled estimates of :data:`CHANNELS`
    (:func:`probing.analysis.fig4.read_run`, channel by channel)."""
    runs = {channel: fig4.read_run(folder, channel) for channel in CHANNELS}
    h = {channel: run.h for channel, run in runs.items()}
    z = {channel: run.z for channel, run in runs.items()}
    return Run(runs[CHANNELS[0]].scenario, folder, h, z)


@dataclass
class Study:
    """Everything read: ``runs[(aircraft, signal, role, seed)]``."""

    root: Path
    manifest: dict[str, Any]
    runs: dict[tuple[str, str, str, int], Run]

    @property
    def aircraft(self) -> list[str]:
        return list(dict.fromkeys(k[0] for k in self.runs))

    @property
    def signals(self) -> list[str]:
        return list(dict.fromkeys(k[1] for k in self.runs))

    def run(self, aircraft: str, signal: str, role: str, seed: int = 0) -> Run:
        return self.runs[(aircraft, signal, role, seed)]


def collect(results: Path) -> Study:
    """Read the study's runs listed in ``results/manifest.json``."""
    path = Path(results) / "manifest.json"
    if not path.is_file():
        raise NotAnExcitationsFolderError(f"{results}: no manifest.json of probing excitations")
    manifest = json.loads(path.read_text())
    runs = {
        (r["aircraft"], r["signal"], r["role"], int(r["seed"])): read_run(
            Path(results) / r["folder"]
        )
        for r in manifest["runs"]
    }
    return Study(Path(results), manifest, runs)


def rel(a: np.ndarray, b: np.ndarray) -> float:
    """||a - b|| / ||b||."""
    return norm(a - b) / norm(b)


# ----------------------------------------------------------------- the tables' rows
def signal_rows(study: Study) -> pd.DataFrame:
    """Per aircraft and signal: harmonics, RMS, peak, crest factor, largest step rate."""
    rows = []
    for aircraft in study.aircraft:
        for signal in study.signals:
            probe = study.run(aircraft, signal, "baseline").scenario.probe
            bits = probe.bits(1)
            k = probe.harmonics
            rows.append(
                {
                    "aircraft": aircraft,
                    "signal": signal,
                    "harmonics": probe.length if k is None else int(k.size),
                    "band_hz": "all (DC to Nyquist)"
                    if k is None
                    else f"{k[0] / probe.memory_s:.2f}-{k[-1] / probe.memory_s:.2f}",
                    "rms_deg": float(np.sqrt(np.mean(bits**2))),
                    "peak_deg": probe.peak_deg,
                    "crest_factor": crest_factor(bits),
                    "peak_step_rate_deg_s": probe.peak_step_rate_deg_s,
                }
            )
    return pd.DataFrame(rows)


def _truth(run: Run, channel: str) -> tuple[np.ndarray, np.ndarray]:
    """The linearised truth over the signal's harmonics (estimated as the run estimates) and
    the whole linearised pulse response folded over the period."""
    scn = run.scenario
    truth = pd.read_parquet(run.folder / "truth.parquet", filters=[("channel", "==", channel)])
    h_lin = truth.sort_values("tap").h_lin.to_numpy()
    # h_lin is stepped as JSBSim steps the aircraft: the airframe answers one step later
    pred = predicted_probing(scn, {channel: h_lin})[channel][scn.settle_periods :, 2]
    m = scn.bits_per_period
    whole = h_lin[: (h_lin.size // m) * m].reshape(-1, m).sum(axis=0)
    return pred.mean(axis=0), whole


def _views(study: Study, aircraft: str) -> list[tuple[str, str, Any]]:
    """(label, signal, view of h) for the accuracy table: each signal as estimated, and the
    PRBS's estimate projected on the band of the others (the same harmonics compared)."""
    views: list[tuple[str, str, Any]] = [(s, s, lambda h: h) for s in study.signals]
    banded = [
        s
        for s in study.signals
        if study.run(aircraft, s, "baseline").scenario.probe.harmonics is not None
    ]
    if "prbs" in study.signals and banded:
        k = study.run(aircraft, banded[0], "baseline").scenario.probe.harmonics
        views.insert(1, ("prbs, in the band", "prbs", lambda h: band_limited(h, k)))
    return views


def accuracy_rows(study: Study) -> pd.DataFrame:
    """Per aircraft, signal and channel: the calm baseline against the linearised truth in
    the signal's band, against the single-pulse truth (``prediction.parquet``) and against
    the whole linearised pulse response, and the gain's scatter over the noisy seeds."""
    rows = []
    seeds = sorted({k[3] for k in study.runs if k[2] == "noise"})
    for aircraft in study.aircraft:
        for label, signal, view in _views(study, aircraft):
            base = study.run(aircraft, signal, "baseline")
            scn = base.scenario
            for channel in CHANNELS:
                in_band, whole = _truth(base, channel)
                pulse = read_settled(
                    base.folder / "prediction.parquet",
                    channel,
                    scn.settle_periods,
                    scn.bits_per_period,
                ).h.mean(axis=0)
                h0 = view(base.mean(channel))
                noisy = [view(study.run(aircraft, signal, "noise", s).h[channel]) for s in seeds]
                gains = np.array([gain_and_shape(h.mean(axis=0), h0)[0] for h in noisy])
                taps = np.array([h.std(axis=0) for h in noisy])
                rows.append(
                    {
                        "aircraft": aircraft,
                        "signal": label,
                        "channel": channel,
                        "error_band": rel(h0, view(in_band)),
                        "error_pulse": rel(h0, view(pulse)),
                        "error_whole": rel(h0, whole),
                        "gain_sd_seeds": float(gains.std(ddof=1)) if gains.size > 1 else math.nan,
                        "seeds": int(gains.size),
                        "tap_sd_rel": float(np.sqrt(np.mean(taps**2)) / np.sqrt(np.mean(h0**2))),
                    }
                )
    return pd.DataFrame(rows)


def predicted_estimate(run: Run, base: Run, channel: str) -> np.ndarray:
    """The theory's estimate of ``run`` (a nonlinearity) from its signal's linear ``base``:
    :func:`probing.core.metrics.through_nonlinearity` of the harmonic ratio of the run's
    nonlinearity on its probe (one sample per bit: the Fig. 4 set-up)."""
    scn = run.scenario
    probe = scn.probe
    ratio = harmonic_ratio(
        scn.build_nonlinearity(), probe.bits(1), scn.dt_s, probe.steps_per_bit(scn.dt_s)
    )
    return through_nonlinearity(base.mean(channel), ratio, probe.harmonics)


def nonlinearity_rows(study: Study, channel: str = "q_rad_s") -> pd.DataFrame:
    """Per aircraft, panel and signal: measured and predicted gain and shape error against the
    signal's own linear baseline, and what compensating the known nonlinearity leaves."""
    rows = []
    for aircraft in study.aircraft:
        for key, letter in PANELS.items():
            for signal in study.signals:
                base = study.run(aircraft, signal, "baseline")
                run = study.run(aircraft, signal, key)
                h, h0 = ac(run.mean(channel)), ac(base.mean(channel))
                gain, shape = gain_and_shape(h, h0)
                predicted = ac(predicted_estimate(run, base, channel))
                p_gain, p_shape = gain_and_shape(predicted, h0)
                rows.append(
                    {
                        "aircraft": aircraft,
                        "panel": letter,
                        "nonlinearity": run.scenario.nonlinearity_label,
                        "signal": signal,
                        "gain": gain,
                        "gain_predicted": p_gain,
                        "shape_error": shape,
                        "shape_error_predicted": p_shape,
                        "theory_error": rel(h, predicted),
                        "compensated_error": _compensated(run, base, channel, p_gain),
                    }
                )
    return pd.DataFrame(rows)


def ac(h: np.ndarray) -> np.ndarray:
    """``h`` without its mean over the taps (its DC harmonic): a probe's mean offset (a
    saturation's b~, a rate limit's uneven ramps) is a step the aircraft answers with a
    transient no periodic steady state holds, and the multisine and the chirp have no DC."""
    return h - h.mean(axis=-1, keepdims=True)


def _compensated(run: Run, base: Run, channel: str, predicted_gain: float) -> float:
    """What the known nonlinearity's compensation leaves: ||x_c - x0|| / ||x0|| with eq. (11)
    on the PRBS's settled z (x = z), the estimate over the predicted gain otherwise (x = h)."""
    scn = run.scenario
    nl = scn.build_nonlinearity()
    if scn.probe.excitation.is_binary and nl is not None:
        try:
            zc = compensate(run.z[channel], nl, scn.amplitude_deg).mean(axis=0)
        except (NoApparentFormError, ValueError):
            return math.nan
        return rel(zc, base.z[channel].mean(axis=0))
    if not predicted_gain:
        return math.nan
    return rel(ac(run.mean(channel)) / predicted_gain, ac(base.mean(channel)))


# ------------------------------------------------------------------------- summary
def _table(frame: pd.DataFrame, columns: dict[str, tuple[str, str]]) -> list[str]:
    """A markdown table of ``frame``'s ``columns`` (name -> (header, format))."""
    lines = [
        "| " + " | ".join(h for h, _ in columns.values()) + " |",
        "|" + "---|" * len(columns),
    ]
    for _, r in frame.iterrows():
        cells = [
            (fmt.format(r[c]) if not (isinstance(r[c], float) and math.isnan(r[c])) else "-")
            for c, (_, fmt) in columns.items()
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def summary_markdown(study: Study, monitor: pd.DataFrame | None = None) -> str:
    """The study's tables as markdown (``docs/excitations_summary.md``)."""
    sig, acc, nl = signal_rows(study), accuracy_rows(study), nonlinearity_rows(study)
    out = [
        "# Excitations: the numbers",
        "",
        "Written by `make excitations` (`probing excitations`); read with "
        "[excitations.md](excitations.md).  Every signal: order 9 (M = 511), 0.01 s bits "
        f"(T = 5.11 s), the same RMS elevator deflection; multisine and chirp over "
        f"{study.manifest['band_hz'][0]:g}-{study.manifest['band_hz'][1]:g} Hz.  Calm air, "
        "the unprobed twin as the reference (the Fig. 4 set-up).",
        "",
        "## The signals",
        "",
    ]
    out += _table(
        sig[sig.aircraft == study.aircraft[0]],
        {
            "signal": ("signal", "{}"),
            "harmonics": ("harmonics", "{}"),
            "band_hz": ("band, Hz", "{}"),
            "rms_deg": ("RMS, deg", "{:.4f}"),
            "peak_deg": ("peak, deg", "{:.4f}"),
            "crest_factor": ("crest factor", "{:.2f}"),
            "peak_step_rate_deg_s": ("largest step / t0, deg/s", "{:.3f}"),
        },
    )
    noise = ", ".join(f"{c} {v:g}" for c, v in study.manifest["sensor_noise"].items())
    for aircraft in study.aircraft:
        out += _aircraft_sections(aircraft, acc, nl, noise)
    if monitor is not None and len(monitor):
        out += ["", "## The monitor (GTM, light turbulence, gust reference)", ""]
        out += [
            "Order 8 (T = 2.55 s), 0.2 deg RMS, the multisine and chirp over 0.4-10 Hz "
            "(harmonics 2 to 25), 10 seeds each; the PRBS with the ac estimator.  gain sd: "
            "the probing detector's gain against its baseline over the tested windows of the "
            "flights without a fault.",
            "",
        ]
        out += _table(
            monitor,
            {
                "signal": ("signal", "{}"),
                "case": ("case", "{}"),
                "flights": ("flights", "{}"),
                "goal": ("goal", "{}"),
                "detected_goal": ("in goal", "{}"),
                "detected": ("detected", "{}"),
                "delay_median_T": ("median delay, T", "{:.1f}"),
                "verdict_right": ("verdict right", "{:.2f}"),
                "false_alarms": ("false alarms", "{}"),
                "gain_std": ("gain sd", "{:.3f}"),
            },
        )
    return "\n".join(out) + "\n"


def _aircraft_sections(aircraft: str, acc: pd.DataFrame, nl: pd.DataFrame, noise: str) -> list[str]:
    """One aircraft's accuracy and nonlinearity tables."""
    out: list[str] = []
    out += [
        "",
        f"## {aircraft}: accuracy and scatter",
        "",
        "Error of the calm baseline's settled estimate against the linearised truth over "
        "the signal's band, and against the whole linearised pulse response (folded over "
        "the period); the gain's standard deviation over "
        f"{int(acc.seeds.max())} seeds of white sensor noise ({noise}), and the "
        "period-to-period scatter per tap over the estimate's RMS.",
        "",
    ]
    out += _table(
        acc[acc.aircraft == aircraft],
        {
            "signal": ("signal", "{}"),
            "channel": ("channel", "{}"),
            "error_band": ("vs linearised, in band", "{:.2%}"),
            "error_pulse": ("vs single pulse", "{:.2%}"),
            "error_whole": ("vs whole linearised", "{:.1%}"),
            "gain_sd_seeds": ("gain sd over seeds", "{:.2%}"),
            "tap_sd_rel": ("tap scatter / RMS", "{:.2f}"),
        },
    )
    out += [
        "",
        f"## {aircraft}: the Fig. 4 nonlinearities (pitch rate q)",
        "",
        "Pitch rate, each estimate without its mean over the taps (a probe's mean offset is "
        "a step whose transient no periodic steady state holds; pitch attitude integrates "
        "it).  Gain and shape error against the same signal's linear baseline, measured and "
        "predicted (the estimate the nonlinearity leaves of that baseline in the "
        "noise-free periodic steady state); the measured estimate against that "
        "prediction; and what compensating the known nonlinearity leaves (eq. 11 for the "
        "PRBS; the estimate over the predicted gain for the others).",
        "",
    ]
    out += _table(
        nl[nl.aircraft == aircraft],
        {
            "panel": ("panel", "{}"),
            "nonlinearity": ("nonlinearity", "{}"),
            "signal": ("signal", "{}"),
            "gain": ("gain", "{:.3f}"),
            "gain_predicted": ("predicted", "{:.3f}"),
            "shape_error": ("shape error", "{:.3f}"),
            "shape_error_predicted": ("predicted", "{:.3f}"),
            "theory_error": ("vs prediction", "{:.3f}"),
            "compensated_error": ("compensated", "{:.3f}"),
        },
    )
    return out
