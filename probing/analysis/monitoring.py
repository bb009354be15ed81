"""The health-monitoring study from stored flights (``make monitor``, ``docs/monitoring.md``).

Reads the monitor sweeps' ``summary.parquet`` and every flight's ``monitor.parquet`` (and, for
the figures of the probing output, one flight's ``probing.parquet``); runs no simulation.
The monitor was told nothing of the faults; here, knowing each fault's onset, every flight is
scored:

* a **false alarm** is an alarm *event* (an alarmed period after one without) in a period that
  ended before the onset (a flight without a fault: every tested period); the rate is events
  per monitored hour (tested periods times T), with Poisson's exact 95 % interval;
* the **detection delay** is the end of the first alarmed period after the onset, minus the
  onset, in s and in periods T;
* the **verdict** is the monitor's own (the file's ``probing.verdict``: each channel's
  isolation on the ``verdict_periods`` from its first alarm on) when that first alarm came
  after the onset; a flight whose first alarm was a false one has none for its fault.
  Right means the fault type's class in :data:`probing.core.faults.FAULTS`: ``airframe`` for
  NASA's damage cases, ``actuator`` for the actuator's;
* the **threshold law** is checked on the flights without a fault at a rate where counts
  are large (:data:`CHECK_RATE_PER_HOUR`): the tested periods whose statistic is over the
  threshold of that rate, per detector, against the periods times its false-alarm
  probability (each period's test on its own: the statistic as the flight computed it);
* the **ROC** sweeps the threshold (-log10 of the false-alarm probability per period) by a
  factor c: detection within the goal's periods against false alarms per hour of the healthy
  periods at c times the threshold (a false-alarm probability alpha^c).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from probing.core.faults import FAULTS as FAULT_TYPES
from probing.core.isolation import DETECTORS
from probing.core.monitor import MonitorSettings
from probing.experiment.output.storage import read_footer, read_table

__all__ = [
    "CHECK_RATE_PER_HOUR",
    "COST_RATE_PER_HOUR",
    "FAULTS",
    "Fault",
    "evaluate",
    "false_alarm_rate",
    "fault_table",
    "load_study",
    "roc",
    "summary_markdown",
]


@dataclass(frozen=True)
class Fault:
    """One fault of the study: its label, its ``[fault]`` type, and the goal.

    Attributes
    ----------
    label : str
        For tables and figures.
    fault_type : str
        Its ``[fault]`` type (a key of :data:`probing.core.faults.FAULTS`), or ``"none"``.
    goal_periods : int
        Detection within this many probe periods after the onset ...
    goal_probability : float
        ... with at least this probability (the issue's goals).
    """

    label: str
    fault_type: str
    goal_periods: int
    goal_probability: float

    @property
    def truth(self) -> str:
        """The verdict that is right: the fault type's class in the registry (``"airframe"``,
        ``"actuator"``, ``"sensor"``), or ``"none"`` without a fault."""
        return FAULT_TYPES[self.fault_type].fault_class if self.fault_type != "none" else "none"


#: Sweep name (without ``monitor-`` and a probed surface's prefix) -> the fault;
#: effectiveness is split by its scale.
FAULTS: dict[str, Fault] = {
    "none": Fault("no fault", "none", 0, 0.0),
    "damage1": Fault("case 1: rudder off", "gtm_damage", 3, 0.95),
    "damage2": Fault("case 2: vertical tail off", "gtm_damage", 3, 0.95),
    "damage3": Fault("case 3: left outboard flap off", "gtm_damage", 3, 0.95),
    "damage4": Fault("case 4: left wing tip off", "gtm_damage", 3, 0.95),
    "damage5": Fault("case 5: left elevator off", "gtm_damage", 3, 0.95),
    "damage6": Fault("case 6: left stabilizer off", "gtm_damage", 3, 0.95),
    "deadband": Fault("dead band, a~/a = 0.8", "nonlinearity", 5, 0.9),
    "backlash": Fault("backlash, a~/a = 0.8", "nonlinearity", 5, 0.9),
    "rate-limit": Fault("rate limit at (2a/t0) / 2", "nonlinearity", 5, 0.9),
    "effectiveness-0.8": Fault("effectiveness 0.8", "effectiveness", 5, 0.9),
    "effectiveness-0.5": Fault("effectiveness 0.5", "effectiveness", 5, 0.9),
    "stuck": Fault("elevator stuck", "stuck", 5, 0.9),
    "sensor-bias": Fault("pitch sensor bias 0.5 deg", "sensor_bias", 5, 0.9),
    "sensor-scale": Fault("pitch sensor scale 1.2", "sensor_scale", 5, 0.9),
    "sensor-stuck": Fault("pitch sensor stuck", "sensor_stuck", 5, 0.9),
}


#: The false-alarm rate (per hour) at which the flights without a fault check the threshold
#: law: at 0.1 per hour 30 hours hold about 3 events, at 5 per hour about 150 alarmed periods.
CHECK_RATE_PER_HOUR = 5.0

#: What the study's thresholds cost: each faulty flight's delay had each detector's
#: threshold been set for this rate (per hour), the previous study's (``delay_cost_s``).
COST_RATE_PER_HOUR = 0.1


#: The probed surfaces a sweep's name may start with (``monitor-aileron-damage1``); a name
#: without one is the elevator's study.
PROBES = ("elevator", "aileron", "rudder", "throttle")


def _probe_and_fault(sweep: str) -> tuple[str, str]:
    """``monitor-aileron-damage1`` -> (``aileron``, ``damage1``); ``monitor-damage5`` ->
    (``elevator``, ``damage5``)."""
    key = sweep.removeprefix("monitor-")
    probe, _, rest = key.partition("-")
    return (probe, rest) if probe in PROBES and rest else ("elevator", key)


def _fault_key(sweep: str, row: pd.Series) -> str:
    """The study fault of a sweep's flight: the sweep's name less ``monitor-`` and a probed
    surface, and less a part that only tells sweeps of one fault apart
    (``monitor-none-gust``: ``none``; ``monitor-effectiveness-chirp``: effectiveness);
    effectiveness by its scale."""
    key = _probe_and_fault(sweep)[1]
    if key not in FAULTS and key != "effectiveness":
        key = next((k for k in (*FAULTS, "effectiveness") if key.startswith(f"{k}-")), key)
    if key == "effectiveness":
        key = f"effectiveness-{row['fault.scale']:g}"
    return key


def load_study(results: str | Path) -> pd.DataFrame:
    """Every finished flight of the study's sweeps: its summary row, the fault key and the
    path of its folder.

    Raises
    ------
    FileNotFoundError
        If ``results`` holds no monitor sweep.
    ValueError
        If a flight's ``[fault]`` type (its summary's ``fault_type``) is not its study
        fault's.
    """
    results = Path(results)
    frames = []
    for summary in sorted(results.glob("monitor-*/summary.parquet")):
        df = read_table(summary).to_pandas()
        df = df[df.status == "done"].copy()
        sweep = summary.parent.name
        df["fault"] = [_fault_key(sweep, r) for _, r in df.iterrows()]
        if "fault_type" in df:  # the flights' own [fault] type must be the study fault's
            for key, kind in zip(df.fault, df.fault_type, strict=True):
                if FAULTS[key].fault_type != kind:
                    raise ValueError(
                        f"{summary}: fault_type {kind} in the sweep of {key}, "
                        f"whose faults are {FAULTS[key].fault_type}"
                    )
        # the monitor study flies turbulence, where a twin that flies the same gusts is now
        # called "oracle": results stored before the name existed say "reference"
        df["drift"] = df["drift"].replace({"reference": "oracle"})
        df["probe"] = _probe_and_fault(sweep)[0]
        df["seed"] = df.get("disturbance.seed", pd.Series(0, index=df.index))
        # the probe amplitude where the sweep varies it (NaN: the base scenario's)
        df["amplitude_deg"] = df.get("probe.amplitude_deg", pd.Series(math.nan, index=df.index))
        df["folder"] = [str(summary.parent / "points" / f"point_id={p}") for p in df.point_id]
        if "disturbance.turbulence" in df:
            df["turbulence"] = df["disturbance.turbulence"]
        else:  # a sweep that does not vary it: its scenario's
            df["turbulence"] = _base_turbulence(df.folder)
        frames.append(df)
    if not frames:
        raise FileNotFoundError(f"{results}: no monitor sweep (monitor-*/summary.parquet)")
    return pd.concat(frames, ignore_index=True)


def _base_turbulence(folders: pd.Series) -> str:
    """The turbulence level of a sweep that does not vary it: its first flight's scenario
    (``point.json``), ``""`` if there is none."""
    for folder in folders:
        point = Path(folder) / "point.json"
        if point.is_file():
            scenario = json.loads(point.read_text()).get("scenario", {})
            return str(scenario.get("disturbance", {}).get("turbulence", "none"))
    return ""


def _events(alarm: np.ndarray) -> int:
    """Alarm events: alarmed periods that follow one without."""
    a = np.asarray(alarm, dtype=bool)
    return int(np.sum(a & ~np.concatenate(([False], a[:-1]))))


def _to_first(alarm: np.ndarray) -> int:
    """Tested periods up to and including the first alarmed one (all of them without)."""
    a = np.asarray(alarm, dtype=bool)
    return int(np.argmax(a)) + 1 if a.any() else len(a)


def _per_period(rows: pd.DataFrame) -> pd.DataFrame:
    """Tested rows folded to one per period: alarmed if any channel's was, the largest
    statistic over threshold, the period's end."""
    rows = rows.assign(ratio=rows.statistic / rows.threshold)
    return rows.groupby("period", sort=True).agg(
        time_s=("time_s", "first"), alarm=("alarm", "any"), ratio=("ratio", "max")
    )


def _delay(after: pd.DataFrame, onset: float) -> float:
    """Time from the onset to the end of the first alarmed period after it (NaN: none)."""
    alarmed = after[after.alarm]
    return float(alarmed.time_s.iloc[0] - onset) if len(alarmed) else math.nan


def evaluate(study: pd.DataFrame) -> pd.DataFrame:
    """One row per flight: monitored healthy hours, false-alarm events, detection delay
    (s and periods; NaN: not detected), the verdict after the onset, and the ROC scores.

    A flight's periods are folded over its channels, and over its two detectors
    (``monitor.parquet``'s ``detector``; files without one have the probing detector's
    rows only): a period is alarmed if any of its rows is.

    Columns added to ``study``: ``healthy_h``, ``false_alarms``, ``delay_s``,
    ``delay_periods``, ``verdict_after``, ``score`` (the largest statistic over threshold in
    the goal's periods after the onset), ``healthy_ratios`` (statistic over threshold of
    every healthy tested period, in order, for the ROC), and per detector
    ``delay_probing_s``, ``delay_trajectory_s``, ``false_alarms_probing`` and
    ``false_alarms_trajectory``, and for the threshold law ``tested_<detector>`` (tested
    periods and channels before the onset, up to the detector's first alarm: a sliding
    baseline freezes there) and ``over_check_<detector>`` (those over the
    threshold of :data:`CHECK_RATE_PER_HOUR`), ``alpha_check`` (its probability per period and
    channel); ``delay_cost_s`` and per detector ``delay_cost_<detector>_s``: the delay with
    each detector's threshold at :data:`COST_RATE_PER_HOUR` (exact where the flight's own
    thresholds are stricter, as the study's are).
    """
    rows = []
    for _, f in study.iterrows():
        path = Path(f.folder) / "monitor.parquet"
        mon, meta = read_table(path).to_pandas(), read_footer(path)  # the verdict: footer
        if "detector" not in mon:
            mon["detector"] = "probing"
        mon = mon[mon.detector.isin(DETECTORS)]  # the isolation checks raise no alarm
        first_alarm = json.loads(meta[b"probing.first_alarm_s"])
        onset = f.fault_onset_s if math.isfinite(f.fault_onset_s) else math.inf
        tested = mon[mon.statistic.notna()]
        periods = _per_period(tested)
        healthy = periods[periods.time_s <= onset]
        after = periods[periods.time_s > onset]
        delay = _delay(after, onset)
        goal = FAULTS[f.fault].goal_periods
        within = after.time_s <= onset + goal * f.period_s
        row = {
            "healthy_h": len(healthy) * f.period_s / 3600.0,
            "false_alarms": _events(healthy.alarm.to_numpy()),
            # the monitor until its first false alarm (a sliding baseline freezes there)
            "first_false_alarm": bool(healthy.alarm.any()),
            "hours_to_first": _to_first(healthy.alarm.to_numpy()) * f.period_s / 3600.0,
            "delay_s": delay,
            "delay_periods": delay / f.period_s,
            "verdict_after": meta[b"probing.verdict"].decode()
            if first_alarm is not None and first_alarm > onset
            else "none",
            "score": float(after.ratio[within].max()) if within.any() else math.nan,
            "healthy_ratios": healthy.ratio.to_numpy(),
        }
        row.update(_detector_columns(tested, onset, f.period_s))
        rows.append(row)
    return pd.concat([study.reset_index(drop=True), pd.DataFrame(rows)], axis=1)


def _alpha(rate_per_hour: float, period_s: float, channels: int) -> float:
    """A detector's false-alarm probability per period and channel at ``rate_per_hour``, as
    the monitor shares it out (:meth:`probing.core.monitor.MonitorSettings.alpha`)."""
    return MonitorSettings(false_alarms_per_hour=rate_per_hour).alpha(period_s, channels)


def _detector_columns(tested: pd.DataFrame, onset: float, period_s: float) -> dict:
    """Per detector, the columns of :func:`evaluate` that read its own rows: its delay, its
    false-alarm events, the threshold law's counts, and its delay at
    :data:`COST_RATE_PER_HOUR` (the threshold -log10 of that rate's probability: exact from
    the stored statistics, since a laxer threshold is first crossed no later than the
    flight's own, before its baseline froze)."""
    channels = max(tested.channel.nunique(), 1)
    row: dict = {"alpha_check": _alpha(CHECK_RATE_PER_HOUR, period_s, channels)}
    lax = -math.log10(_alpha(COST_RATE_PER_HOUR, period_s, channels))
    for detector in ("probing", "trajectory"):
        mine = tested[tested.detector == detector]
        own = _per_period(mine)
        row[f"delay_{detector}_s"] = _delay(own[own.time_s > onset], onset)
        row[f"false_alarms_{detector}"] = _events(own[own.time_s <= onset].alarm.to_numpy())
        laxer = _per_period(mine.assign(alarm=mine.statistic > lax))
        row[f"delay_cost_{detector}_s"] = _delay(laxer[laxer.time_s > onset], onset)
        before = mine[mine.time_s <= onset]
        alarmed = before.period[before.alarm]
        if len(alarmed):  # a sliding baseline freezes at the first alarm: up to it
            before = before[before.period <= alarmed.min()]
        row[f"tested_{detector}"] = len(before)
        row[f"over_check_{detector}"] = int(
            (before.statistic > -math.log10(row["alpha_check"])).sum()
        )
    row["delay_cost_s"] = float(
        np.fmin(row["delay_cost_probing_s"], row["delay_cost_trajectory_s"])
    )
    return row


def false_alarm_rate(
    flights: pd.DataFrame, level: float = 0.95, first: bool = False
) -> tuple[int, float, float, float]:
    """False-alarm events, monitored healthy hours, and the exact Poisson interval of the
    rate per hour at ``level``: (events, hours, low, high).  With ``first``, only each
    flight's first false alarm and the hours until it (the monitor hands over at an alarm,
    and a sliding baseline freezes there: what follows in that flight is not the rate)."""
    from scipy.stats import chi2

    if first:
        events, hours = int(flights.first_false_alarm.sum()), float(flights.hours_to_first.sum())
    else:
        events, hours = int(flights.false_alarms.sum()), float(flights.healthy_h.sum())
    tail = (1 - level) / 2
    low = chi2.ppf(tail, 2 * events) / 2 / hours if events else 0.0
    high = chi2.ppf(1 - tail, 2 * events + 2) / 2 / hours
    return events, hours, low, high


def _right(verdicts: pd.Series, truth: str) -> pd.Series:
    """Whether each verdict is right for a fault of class ``truth``: the verdict is the
    class (``actuator``, ``airframe`` or ``sensor``; a flight without a sensor suite has no
    isolation checks and calls no fault a sensor's, ``probing.core.isolation``)."""
    return verdicts == truth


def fault_table(flights: pd.DataFrame) -> pd.DataFrame:
    """Per probed surface, fault and drift correction: flights, detection probability within
    the goal and at all, delay (median and 95th percentile, s and periods), verdict counts and
    how often the verdict is right."""
    out = []
    keys = ["probe", "fault", "drift", "turbulence", "amplitude_deg"]
    groups = flights.groupby(keys, sort=False, dropna=False)
    for (probe, fault, drift, turbulence, amplitude), g in groups:
        spec = FAULTS[fault]
        if spec.truth == "none":
            continue
        period_s = float(g.period_s.iloc[0])
        detected = g.delay_s.notna()
        in_goal = g.delay_s <= spec.goal_periods * period_s
        delays = g.delay_s[detected]
        cost = g.delay_cost_s.dropna()
        counts = g.verdict_after.value_counts()
        out.append(
            {
                "probe": probe,
                "fault": spec.label,
                "drift": drift,
                "turbulence": turbulence,
                "amplitude_deg": amplitude,
                "flights": len(g),
                # the detections the probing detector made first (or with the trajectory's)
                "by_probing": float(
                    (
                        g.delay_probing_s[detected]
                        <= g.delay_trajectory_s[detected].fillna(math.inf)
                    ).mean()
                )
                if detected.any()
                else math.nan,
                "goal": f"{spec.goal_probability:g} within {spec.goal_periods} T",
                "p_detect_goal": float(in_goal.mean()),
                "p_detect": float(detected.mean()),
                "delay_median_s": float(delays.median()) if len(delays) else math.nan,
                "delay_p95_s": float(delays.quantile(0.95)) if len(delays) else math.nan,
                "delay_median_T": float(delays.median() / period_s) if len(delays) else math.nan,
                "delay_p95_T": float(delays.quantile(0.95) / period_s) if len(delays) else math.nan,
                "p_detect_goal_cost": float(
                    (g.delay_cost_s <= spec.goal_periods * period_s).mean()
                ),
                "delay_median_cost_T": float(cost.median() / period_s) if len(cost) else math.nan,
                "actuator": int(counts.get("actuator", 0)),
                "airframe": int(counts.get("airframe", 0)),
                "sensor": int(counts.get("sensor", 0)),
                "none": int(counts.get("none", 0)),
                "verdict_right": float(_right(g.verdict_after, spec.truth)[detected].mean())
                if detected.any()
                else math.nan,
            }
        )
    return pd.DataFrame(out)


def roc(
    flights: pd.DataFrame, fault: str, drift: str, factors: Sequence[float]
) -> tuple[np.ndarray, np.ndarray]:
    """The ROC of a fault: for each threshold factor c, false alarms per healthy hour (every
    flight of this drift correction) and the detection probability within the goal."""
    same = flights[flights.drift == drift]
    hours = same.healthy_h.sum()
    faulty = same[same.fault == fault]
    fa, pd_ = [], []
    for c in factors:
        events = sum(_events(r > c) for r in same.healthy_ratios)
        fa.append(events / hours if hours else math.nan)
        pd_.append(float((faulty.score > c).mean()))
    return np.array(fa), np.array(pd_)


#: How the tables name each reference: the realisable ones first, the oracle as the bound.
DRIFT_LABELS = {
    "gust": "gust",
    "nominal": "nominal",
    "follow": "follow",
    "detrend": "detrend",
    "oracle": "oracle (upper bound: knows the gusts)",
}


def _drift_order(flights: pd.DataFrame) -> pd.DataFrame:
    """The flights sorted by reference in :data:`DRIFT_LABELS`' order (stable otherwise)."""
    rank = {d: i for i, d in enumerate(DRIFT_LABELS)}
    return flights.iloc[np.argsort([rank.get(d, len(rank)) for d in flights.drift], kind="stable")]


def summary_markdown(flights: pd.DataFrame) -> str:
    """The study's tables as Markdown: false alarms per hour (each detector's, and the
    threshold law at :data:`CHECK_RATE_PER_HOUR`), then detection and verdicts per fault."""
    flights = _drift_order(flights)
    several = set(flights.probe) != {"elevator"}  # a column for the probed surface
    keys = ["probe", "drift"] if several else ["drift"]
    lines = ["# Health-monitoring study: results", ""]
    lines.append(
        "Written by `probing plot monitor` (`make monitor`, `make monitor-oracle`, "
        "`make monitor-lateral`; `probing.analysis.monitoring`); the set-up and the reading are in "
        "[monitoring.md](monitoring.md)."
    )
    lines += ["", "## False alarms", ""]
    probe_head = "| probe " if several else ""
    lines.append(
        probe_head + "| drift | flights | monitored h | events | per hour | 95 % interval "
        "| probing | trajectory |"
    )
    lines.append("|---|---|---|---|---|---|---|---|" + ("---|" if several else ""))
    for key, g in flights.groupby(keys, sort=False):
        *probe, drift = key if isinstance(key, tuple) else (key,)
        events, hours, low, high = false_alarm_rate(g)
        lines.append(
            "".join(f"| {p} " for p in probe)
            + f"| {DRIFT_LABELS.get(drift, drift)} | {len(g)} | {hours:.2f} | {events} | "
            f"{events / hours:.3f} | {low:.3f} - {high:.3f} | "
            f"{int(g.false_alarms_probing.sum())} | {int(g.false_alarms_trajectory.sum())} |"
        )
    healthy = flights[flights.fault == "none"]
    for key, g in healthy.groupby(keys, sort=False):
        *probe, drift = key if isinstance(key, tuple) else (key,)
        events, hours, low, high = false_alarm_rate(g)
        what = f"{probe[0]} probe, {drift}" if probe else drift
        first, to_first, first_low, first_high = false_alarm_rate(g, first=True)
        lines.append(
            f"\nFlights without a fault alone, {what}: {events} events in {hours:.2f} h "
            f"({events / hours:.3f} per hour, 95 % interval {low:.3f} - {high:.3f}); "
            f"first false alarms: {first} of {len(g)} flights, in {to_first:.2f} h up to "
            f"them ({first / to_first:.3f} per hour, {first_low:.3f} - {first_high:.3f})."
        )
    lines += _threshold_law_lines(healthy, keys)
    table = fault_table(flights)
    lines += _detection_lines(table, several)
    lines += _cost_lines(table, several)
    return "\n".join(lines) + "\n"


def _threshold_law_lines(healthy: pd.DataFrame, keys: list[str]) -> list[str]:
    """The flights without a fault, each detector's tested periods over the threshold of
    :data:`CHECK_RATE_PER_HOUR` against what that threshold promises (at most), with the
    observed count's exact Poisson 95 % interval."""
    from scipy.stats import chi2

    if "tested_probing" not in healthy or not len(healthy):
        return []
    lines = [
        "",
        f"## The threshold law, at {CHECK_RATE_PER_HOUR:g} false alarms per hour",
        "",
        "The flights without a fault, every tested period and channel up to the detector's "
        "first alarm (where a sliding baseline freezes): the statistic over "
        f"the threshold of {CHECK_RATE_PER_HOUR:g} per hour (each period on its own) against "
        "the periods times that threshold's false-alarm probability, the most the law "
        "allows (the probing test's two p-values are combined by Bonferroni, so it is "
        "conservative).",
        "",
        "| drift | detector | tested periods | over the threshold | promised (at most) "
        "| ratio | 95 % interval of the ratio |",
        "|---|---|---|---|---|---|---|",
    ]
    for key, g in healthy.groupby(keys, sort=False):
        *probe, drift = key if isinstance(key, tuple) else (key,)
        label = DRIFT_LABELS.get(drift, drift)
        label = f"{probe[0]} probe, {label}" if probe else label  # several probed surfaces
        for detector in ("probing", "trajectory"):
            n = int(g[f"tested_{detector}"].sum())
            over = int(g[f"over_check_{detector}"].sum())
            expected = float((g[f"tested_{detector}"] * g.alpha_check).sum())
            if expected <= 0.0:  # no tested period (a detector the files do not have)
                continue
            low = chi2.ppf(0.025, 2 * over) / 2 if over else 0.0
            high = chi2.ppf(0.975, 2 * over + 2) / 2
            lines.append(
                f"| {label} | {detector} | {n} | {over} | "
                f"{expected:.1f} | {over / expected:.2f} | "
                f"{low / expected:.2f} - {high / expected:.2f} |"
            )
    return lines


#: A column of a fault table: its heading and its cell from a row of :func:`fault_table`.
Column = tuple[str, Callable[[dict], object]]


def _table_lines(table: pd.DataFrame, several: bool, columns: list[Column]) -> list[str]:
    """A fault table's Markdown heading and rows: the columns that name a row (the probe
    with ``several`` probed surfaces, the fault, the reference, and the turbulence and the
    amplitude where the study varies them), then ``columns``."""
    keys: list[Column] = [("probe", lambda r: r["probe"])] if several else []
    keys += [("fault", lambda r: r["fault"])]
    keys += [("drift", lambda r: DRIFT_LABELS.get(r["drift"], r["drift"]))]
    if table.turbulence.nunique() > 1:
        keys.append(("turbulence", lambda r: r["turbulence"]))
    if table.amplitude_deg.notna().any():
        keys.append(("a, deg", lambda r: f"{r['amplitude_deg']:g}"))
    cols = keys + columns
    lines = ["| " + " | ".join(head for head, _ in cols) + " |", "|" + "---|" * len(cols)]
    for r in table.to_dict("records"):
        lines.append("| " + " | ".join(str(cell(r)) for _, cell in cols) + " |")
    return lines


def _detection_lines(table: pd.DataFrame, several: bool) -> list[str]:
    """The detection and verdict table's Markdown lines (:func:`_table_lines`)."""
    if table.empty:  # flights without a fault only
        return []
    lines = ["", "## Detection and verdicts", ""]
    lines.append(
        "*probing first*: of the detected flights, those whose first alarm after the onset "
        "is the probing detector's (the pulse response changed), alone or with the "
        "trajectory detector's; the rest the trajectory detector saw first."
    )
    lines.append("")
    columns: list[Column] = [
        ("flights", lambda r: r["flights"]),
        ("goal", lambda r: r["goal"]),
        ("detected in goal", lambda r: f"{r['p_detect_goal']:.2f}"),
        ("detected", lambda r: f"{r['p_detect']:.2f}"),
        ("probing first", lambda r: f"{r['by_probing']:.2f}"),
        ("delay median s (T)", lambda r: f"{r['delay_median_s']:.1f} ({r['delay_median_T']:.1f})"),
        ("delay 95 % s (T)", lambda r: f"{r['delay_p95_s']:.1f} ({r['delay_p95_T']:.1f})"),
        *((v, lambda r, v=v: r[v]) for v in ("actuator", "airframe", "sensor", "none")),
        ("verdict right", lambda r: f"{r['verdict_right']:.2f}"),
    ]
    return lines + _table_lines(table, several, columns)


def _cost_lines(table: pd.DataFrame, several: bool) -> list[str]:
    """What the study's thresholds cost: per row of the detection table, detection within
    the goal and the median delay at the study's thresholds and at
    :data:`COST_RATE_PER_HOUR` per detector."""
    if table.empty:
        return []
    lax = f"{COST_RATE_PER_HOUR:g}/h"
    columns: list[Column] = [
        ("flights", lambda r: r["flights"]),
        ("in goal", lambda r: f"{r['p_detect_goal']:.2f}"),
        (f"in goal at {lax}", lambda r: f"{r['p_detect_goal_cost']:.2f}"),
        ("delay median T", lambda r: f"{r['delay_median_T']:.1f}"),
        (f"at {lax}", lambda r: f"{r['delay_median_cost_T']:.1f}"),
    ]
    return [
        "",
        f"## What the thresholds cost: the delay at {COST_RATE_PER_HOUR:g} false alarms per "
        "hour per detector",
        "",
        "Each faulty flight's stored statistics, with each detector's threshold set for "
        f"{COST_RATE_PER_HOUR:g} false alarms per hour (-log10 of its probability per period "
        "and channel): the first period over it after the onset.  Where the flight's own "
        "thresholds are stricter this is exact, as the laxer threshold is crossed first, "
        "before any baseline froze.",
        "",
        *_table_lines(table, several, columns),
    ]
