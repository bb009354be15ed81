"""The health monitor with each probe signal, from stored flights (``scenarios/excitations``).

Reads the sweeps that ``scenarios/excitations/generate.py`` writes, once flown
(``probing sweep scenarios/excitations/monitor-<signal>-<case>.toml --out RESULTS``): the
monitor study's flight (GTM, NASA's T2 sensors, light turbulence, the ``gust`` reference,
a sliding baseline) with its elevator probed by a PRBS, a multisine or a chirp of the same
RMS (0.2 deg), each without a fault, with the elevator's effectiveness scaled to 0.8 and with
NASA's damage case 5.  Runs no simulation: each flight's ``monitor.parquet`` and
``point.json`` (its scenario: the signal), scored by :mod:`probing.analysis.monitoring`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from probing.analysis.monitoring import FAULTS, evaluate, fault_table, load_study
from probing.experiment.output.storage import read_table

__all__ = ["CASES", "SIGNALS", "gain_changes", "monitor_table", "signal_of"]

#: The probe signals, in the table's order (``probe.signal``; a scenario without one: PRBS).
SIGNALS = ("prbs", "multisine", "chirp")
#: The cases, in the table's order: keys of :data:`probing.analysis.monitoring.FAULTS`.
CASES = ("none", "effectiveness-0.8", "damage5")
#: The channel whose gain scatter the table gives.
CHANNEL = "theta_rad"


def signal_of(folder: str | Path) -> str:
    """The probe signal a stored flight flew: its scenario's ``probe.signal`` (``point.json``),
    ``"prbs"`` where the scenario has none."""
    point = json.loads((Path(folder) / "point.json").read_text())
    return str(point["scenario"]["probe"].get("signal", "prbs"))


def gain_changes(folder: str | Path, channel: str = CHANNEL) -> np.ndarray:
    """The probing detector's ``gain_change`` (1) of every tested period of a flight's
    ``channel``, in order.

    ``gain_change`` (:class:`probing.core.monitor.Decision`) is the estimated scale g of the
    tested window against the baseline: the mean of the last ``window_periods`` periods'
    reduced pulse responses v (up to 4 in the monitor study), less the baseline's mean v0,
    fitted by generalised least squares as (g - 1) v0 plus an offset.  1 is unchanged; a
    loss of effectiveness to 0.8 is g = 0.8.  Periods still learning the baseline (NaN
    statistic) are left out.
    """
    mon = read_table(Path(folder) / "monitor.parquet").to_pandas()
    if "detector" in mon:
        mon = mon[mon.detector == "probing"]
    tested = mon[(mon.channel == channel) & mon.statistic.notna()]
    return tested.gain_change.to_numpy(dtype=float)


def monitor_table(results: Path) -> pd.DataFrame:
    """One row per probe signal and case: how the monitor detects each fault, and how much
    its gain estimate scatters without one.

    Parameters
    ----------
    results : Path
        The folder the sweeps were flown into (``<results>/monitor-<case>-<signal>/``).
        Every ``monitor-*`` sweep in it is read: flights are told apart by their scenario's
        signal and their sweep's fault (:func:`probing.analysis.monitoring.load_study`).

    Returns
    -------
    pandas.DataFrame
        Columns: ``signal``; ``case`` (the fault's label); ``flights``; ``goal`` (the monitor
        study's for the fault type, e.g. ``0.9 within 5 T``; empty without a fault);
        ``detected_goal`` and ``detected`` (flights whose first alarm after the onset came
        within the goal's periods, and at all); ``delay_median_s`` (s) and
        ``delay_median_T`` (probe periods T) of the detected; ``verdict_right`` (the share
        of the detected whose verdict is the fault's class); ``false_alarms`` (alarm events
        before the onset, every tested period without a fault) in ``healthy_h`` monitored
        hours (h); and, without a fault only (NaN otherwise), ``gain_std`` (1: the standard
        deviation, ddof 1, of :func:`gain_changes` of channel ``theta_rad`` over every
        tested period of the signal's flights pooled; a test's window holds up to 4
        overlapping periods, so one period's own scatter is larger), ``gain_mean`` (1),
        ``tested`` (periods), and the threshold law at
        :data:`probing.analysis.monitoring.CHECK_RATE_PER_HOUR`: ``check_over`` (tested periods of
        the probing detector over that rate's threshold, up to each flight's first alarm)
        against ``check_expected`` (those periods times its false-alarm probability).

    Raises
    ------
    FileNotFoundError
        If ``results`` holds no monitor sweep.
    ValueError
        If a flight flew a signal or case outside :data:`SIGNALS` and :data:`CASES`, or a
        signal flies a fault under more than one reference, turbulence or amplitude.
    """
    study = load_study(results)
    study["signal"] = [signal_of(f) for f in study.folder]
    unknown = set(study.signal) - set(SIGNALS) | set(study.fault) - set(CASES)
    if unknown:
        raise ValueError(f"{results}: signals or cases outside the study: {sorted(unknown)}")
    flights = evaluate(study)
    rows = []
    for signal in SIGNALS:
        mine = flights[flights.signal == signal]
        if mine.empty:
            continue
        faulty = mine[mine.fault != "none"]  # fault_table's rows: one per fault
        detection = fault_table(faulty).set_index("fault") if len(faulty) else None
        if detection is not None and detection.index.has_duplicates:
            raise ValueError(f"{results}: {signal} flies a fault with several set-ups")
        for case in CASES:
            g = mine[mine.fault == case]
            if g.empty:
                continue
            spec = FAULTS[case]
            row: dict[str, object] = {
                "signal": signal,
                "case": spec.label,
                "flights": len(g),
                "goal": "",
                "detected_goal": 0,
                "detected": 0,
                "delay_median_s": math.nan,
                "delay_median_T": math.nan,
                "verdict_right": math.nan,
                "false_alarms": int(g.false_alarms.sum()),
                "healthy_h": float(g.healthy_h.sum()),
            }
            if detection is not None and case != "none":
                d = detection.loc[spec.label]
                row.update(
                    goal=d.goal,
                    detected_goal=round(d.p_detect_goal * d.flights),
                    detected=round(d.p_detect * d.flights),
                    delay_median_s=d.delay_median_s,
                    delay_median_T=d.delay_median_T,
                    verdict_right=d.verdict_right,
                )
                row.update(gain_std=math.nan, gain_mean=math.nan, tested=0)
                row.update(check_over=0, check_expected=math.nan)
            else:
                gains = np.concatenate([gain_changes(f) for f in g.folder])
                row.update(
                    gain_std=float(np.std(gains, ddof=1)) if gains.size > 1 else math.nan,
                    gain_mean=float(np.mean(gains)) if gains.size else math.nan,
                    tested=int(gains.size),
                    check_over=int(g.over_check_probing.sum()),
                    check_expected=float((g.tested_probing * g.alpha_check).sum()),
                )
            rows.append(row)
    return pd.DataFrame(rows)
