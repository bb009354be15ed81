"""The sweep figures of gain and shape error against what varies: a nonlinearity's
parameters over the apparent-input theory (:func:`theory_curve`, :func:`plot_nonlinearity`),
a rate limit's rate against the bound (21) (:func:`plot_rate_limit`), and anything else
against the point index (:func:`plot_other`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib.transforms as mtransforms
import numpy as np
import pandas as pd

from probing.analysis.sweep_axes import (
    C_MEAS,
    C_THEORY,
    fmt_value,
    gain_and_shape_axes,
    gain_limits,
    gain_range,
    mark_failed,
    shape_panel,
    short_key,
    status_masks,
    sweep_context,
    sweep_title,
)
from probing.analysis.sweep_data import SweepData, is_number
from probing.core.metrics import predicted_apparent
from probing.core.nonlinearities import NONLINEARITIES
from probing.experiment.scenario import Scenario

__all__ = ["N_DENSE", "plot_nonlinearity", "plot_other", "plot_rate_limit", "theory_curve"]

N_DENSE = 200


# ------------------------------------------------------------------ theory
def theory_curve(
    scenario: Scenario, path: Mapping[str, Sequence[float]], n: int = N_DENSE
) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Predicted apparent gain a~/a and offset b~ on a dense path through parameter space.

    The nonlinearity parameters in ``path`` are interpolated linearly along the order of
    their values (the sweep's points, sorted as they are to be drawn), at ``n`` evenly spaced
    positions plus the points themselves; each set of parameters is built into a
    nonlinearity with :func:`probing.run.build_nonlinearity` and evaluated with
    :func:`probing.metrics.predicted_apparent`.

    Parameters
    ----------
    scenario : Scenario
        A point of the sweep: its nonlinearity type, the parameters not in ``path``, the
        probe amplitude a and the bit duration t0 are used.
    path : mapping
        Dotted ``nonlinearity.*`` keys -> their values at the points along the path (deg or
        deg/s; equal lengths >= 1).
    n : int
        Number of evenly spaced positions along the path.

    Returns
    -------
    params : dict
        The keys of ``path`` -> the dense parameter values, shape (K,).
    gain : numpy.ndarray
        a~/a at each, shape (K,) (dimensionless; NaN where a rate limit admits no apparent
        form).
    offset_deg : numpy.ndarray
        b~ (deg), shape (K,).

    Raises
    ------
    ValueError
        For a key that is not a parameter of the scenario's nonlinearity, or unequal lengths.
    """
    kind = NONLINEARITIES[scenario.nonlinearity]
    names = {}
    for key in path:
        section, _, name = key.partition(".")
        if section != "nonlinearity" or name not in kind.names:
            raise ValueError(f"{key}: not a parameter of {scenario.nonlinearity}")
        names[key] = name
    columns = {k: np.asarray(v, dtype=float) for k, v in path.items()}
    lengths = {c.size for c in columns.values()}
    if len(lengths) != 1 or 0 in lengths:
        raise ValueError("path: the value lists must be non-empty and of equal length")
    m = lengths.pop()
    knots = np.arange(m, dtype=float)
    t = np.union1d(np.linspace(0.0, m - 1.0, max(int(n), 2)), knots) if m > 1 else knots
    params = {k: np.interp(t, knots, c) for k, c in columns.items()}
    gain = np.empty(t.size)
    offset = np.empty(t.size)
    for i in range(t.size):
        nl_params = {**scenario.nl_params, **{names[k]: float(params[k][i]) for k in params}}
        nl = kind.build(nl_params)
        gain[i], offset[i] = predicted_apparent(nl, scenario.amplitude_deg, scenario.bit_duration_s)
    return params, gain, offset


# ------------------------------------------------------------------ 1. nonlinearity parameter
def _x_field(data: SweepData, candidates: list[str]) -> tuple[str, bool]:
    """The x-axis field: the first with non-negative values (some positive), else the first
    (drawn as absolute value).  Returns (field, use_abs)."""
    for f in candidates:
        vals = np.array([v[f] for v in data.values.values()], dtype=float)
        if (vals >= 0).all() and (vals > 0).any():
            return f, False
    return candidates[0], True


def _axis_groups(data: SweepData) -> list[list[str]]:
    """Independent axes of the sweep: each varied [grid] key alone, the varied [zip] keys
    together."""
    zipped = [f for f in data.varying if f in data.zipped]
    groups = [[f] for f in data.varying if f not in data.zipped]
    return groups + ([zipped] if zipped else [])


def _theory_line(
    ax: Any,
    data: SweepData,
    rows: pd.DataFrame,
    xs: np.ndarray,
    x_axis: tuple[str, list[str], bool, float],
    color: str,
    series: bool,
) -> np.ndarray:
    """Draw one series' predicted gain, the dense theory curve (or, when its scenario cannot
    be rebuilt, the summary's predictions at the points); return the values drawn.

    ``x_axis`` is (x field, the keys varied with it, whether drawn as absolute value, the
    probe amplitude a); ``series`` whether there is more than one series."""
    x_field, x_group, use_abs, a = x_axis
    scn = data.scenario(int(rows["index"].iloc[0]))
    path = {f: [data.values[int(i)][f] for i in rows["index"]] for f in x_group}
    if scn is not None:
        try:
            params, gain, _ = theory_curve(scn, path)
        except ValueError:
            pass
        else:
            xd = (np.abs(params[x_field]) if use_abs else params[x_field]) / a
            ax.plot(
                xd,
                gain,
                "-",
                color=C_THEORY if not series else color,
                lw=1.0,
                label=None if series else "predicted a~/a, eq. (10)",
            )
            return gain
    # scenario not rebuildable: the summary's predictions at the points
    pg = rows["predicted_gain"].to_numpy(dtype=float)
    ax.plot(
        xs[rows.index],
        pg,
        "--",
        color=C_THEORY,
        lw=0.8,
        label=None if series else "predicted a~/a at the points",
    )
    return pg


def _measured_points(
    ax: Any,
    drawn_series: list[tuple[pd.DataFrame, str, str]],
    xs: np.ndarray,
    measured: np.ndarray,
    off: np.ndarray,
    stuck: np.ndarray,
    series: bool,
) -> None:
    """The measured gains of each series on scale: filled, or open where b~ ≠ 0 is
    predicted (one legend entry for those)."""
    open_label = "measured where b~ ≠ 0 is predicted (the offset step leaks into h)"
    if series:
        open_label = "open: " + open_label
    open_label_done = False
    for rows, color, tag in drawn_series:
        sel = rows.index.to_numpy()
        xr, meas = xs[sel], measured[sel]
        shown = ~off[sel] & np.isfinite(meas)
        plain, open_ = shown & ~stuck[sel], shown & stuck[sel]
        lab = "measured gain g" + (f" ({tag})" if tag else "")
        if plain.any() or (series and open_.any()):
            ax.plot(xr[plain], meas[plain], "o", color=color, ms=4, label=lab)
        if open_.any():
            ax.plot(
                xr[open_],
                meas[open_],
                "o",
                mfc="none",
                color=color,
                ms=5,
                label=None if open_label_done else open_label,
            )
            open_label_done = True


def plot_nonlinearity(data: SweepData) -> Any:
    """Gain over the apparent-input theory curve and shape error against a nonlinearity's
    parameter over a (one series per value of the other varied keys)."""
    df = data.summary
    nl_fields = [f for f in data.varying if f != "nonlinearity.type"]
    x_field, use_abs = _x_field(data, nl_fields)
    groups = _axis_groups(data)
    x_group = next((g for g in groups if x_field in g), [x_field])
    series_keys = [f for g in groups if g is not x_group for f in g]
    tag_fields = [_x_field(data, g)[0] for g in groups if g is not x_group]
    scn0 = data.scenario(int(df["index"].iloc[0]))
    a = scn0.amplitude_deg if scn0 is not None else data.manifest["base"]["probe"]["amplitude_deg"]
    xs = np.array([data.values[int(i)][x_field] for i in df["index"]], dtype=float)
    xs = (np.abs(xs) if use_abs else xs) / a
    label = f"|{short_key(x_field)}| / a" if use_abs else f"{short_key(x_field)} / a"
    label += f"   (a = {a:g} deg probe amplitude)"

    fig, (ax1, ax2) = gain_and_shape_axes()
    theory_values: list[np.ndarray] = []
    drawn_series: list[tuple[pd.DataFrame, str, str]] = []
    x_axis = (x_field, x_group, use_abs, a)
    series = df.groupby(
        [df["index"].map(lambda i, k=k: fmt_value(data.values[int(i)][k])) for k in series_keys]
        if series_keys
        else np.zeros(len(df), dtype=int),
        sort=False,
    )
    for s, (_key, grp) in enumerate(series):
        color = f"C{s}" if series_keys else C_MEAS
        tag = ""
        if series_keys:
            first = data.values[int(grp["index"].iloc[0])]
            tag = ", ".join(
                f"{short_key(f)}/a = {first[f] / a:.3g}" for f in tag_fields if is_number(first[f])
            )
        order = np.argsort(xs[grp.index], kind="stable")
        rows = grp.iloc[order]
        theory_values.append(_theory_line(ax1, data, rows, xs, x_axis, color, bool(series_keys)))
        drawn_series.append((rows, color, tag))
    if series_keys:  # one legend entry for the theory lines, one per series for the markers
        ax1.plot([], [], "-", color=C_THEORY, lw=1.0, label="predicted a~/a, eq. (10): lines")
    measured = df["measured_gain"].to_numpy(dtype=float)
    stuck = np.abs(df["predicted_offset_deg"].to_numpy(dtype=float)) > 0
    off = gain_range(theory_values, measured)[2]
    off_label = "measured, off scale (value written)"
    if off.any() and stuck[off].all():
        off_label = "measured, off scale, b~ ≠ 0 predicted (the offset step leaks into h)"
    off = gain_limits(ax1, theory_values, measured, xs, off_label)
    _measured_points(ax1, drawn_series, xs, measured, off, stuck, bool(series_keys))
    failed, missing = status_masks(df)
    mark_failed(ax1, xs, failed, missing)
    ax1.set_ylabel("gain a~/a (dimensionless)")
    ax1.legend(frameon=False, loc="best")
    ax1.set_title(sweep_title(data, sweep_context(data)), loc="left")
    shape_panel(ax2, xs, df, label, stuck)
    return fig


# ------------------------------------------------------------------ 2. rate limit
def plot_rate_limit(data: SweepData) -> Any:
    """Gain and shape error against a rate limit's r / (2a/t0), with the bound (21)."""
    df = data.summary
    x = df["rate_ratio"].to_numpy(dtype=float)
    fig, (ax1, ax2) = gain_and_shape_axes()
    ok = np.isfinite(x) & (x > 0)
    lo, hi = (x[ok].min(), x[ok].max()) if ok.any() else (0.25, 4.0)
    lo, hi = min(lo, 0.9) / 1.3, max(hi, 1.1) * 1.3
    for ax in (ax1, ax2):
        ax.set_xscale("log")
        ax.set_xlim(lo, hi)
        ax.axvspan(lo, 1.0, color="0.92", lw=0)
        ax.axvline(1.0, color="k", ls=":", lw=0.9)
    ax1.plot([1.0, hi], [1.0, 1.0], "-", color=C_THEORY, lw=1.0, label="predicted a~/a = 1")
    ax1.axvline(1.0, color="k", ls=":", lw=0.9, label="eq. (21): r = 2a/t0")
    ax1.text(
        math.sqrt(lo * 1.0),
        0.5,
        "no apparent form below\nthe bound (eq. 21)",
        transform=mtransforms.blended_transform_factory(ax1.transData, ax1.transAxes),
        ha="center",
        va="center",
        fontsize=7,
        color="0.3",
    )
    scn = data.scenario(int(df["index"].iloc[0]))
    steps = set()
    for i in df["index"]:
        s = data.scenario(int(i))
        if s is not None:
            steps.add(s.steps_per_bit)
    if len(steps) == 1 and scn is not None and (n := steps.pop()) > 1 and n * 1.001 < hi:
        for ax in (ax1, ax2):
            ax.axvline(n, color="0.5", ls="--", lw=0.7)
        ax1.plot(
            [],
            [],
            "--",
            color="0.5",
            lw=0.7,
            label=f"r = 2a/dt: transitions within one step (t0/dt = {n})",
        )
    meas = df["measured_gain"].to_numpy(dtype=float)
    if np.isfinite(meas).any():
        ax1.plot(x, meas, "o", color=C_MEAS, ms=4, label="measured gain g")
    gain_limits(ax1, [np.array([1.0])], meas, x)
    failed, missing = status_masks(df)
    mark_failed(ax1, x, failed, missing)
    ax1.set_ylabel("gain (dimensionless)")
    ax1.legend(frameon=False, loc="lower right")
    ax1.set_title(sweep_title(data, sweep_context(data)), loc="left")
    ticks = [t for t in (0.125, 0.25, 0.5, 1, 2, 4, 8, 16) if lo <= t <= hi]
    shape_panel(ax2, x, df, "rate limit r / (2a/t0)")
    ax2.set_xticks(ticks, [f"{t:g}" for t in ticks])
    ax2.set_xticks([], minor=True)
    return fig


# ------------------------------------------------------------------ 5. other
def plot_other(data: SweepData) -> Any:
    """Measured and predicted gain and the shape error against the point index."""
    df = data.summary
    x = df["index"].to_numpy(dtype=float)
    fig, (ax1, ax2) = gain_and_shape_axes()
    pred = df["predicted_gain"].to_numpy(dtype=float)
    meas = df["measured_gain"].to_numpy(dtype=float)
    fin = np.isfinite(pred)
    if fin.any():
        ax1.plot(x[fin], pred[fin], "_", color=C_THEORY, ms=12, mew=1.5, label="predicted a~/a")
    if np.isfinite(meas).any():
        ax1.plot(x, meas, "o", color=C_MEAS, ms=4, label="measured gain g")
    gain_limits(ax1, [pred], meas, x)
    failed, missing = status_masks(df)
    mark_failed(ax1, x, failed, missing)
    ax1.set_ylabel("gain (dimensionless)")
    ax1.legend(frameon=False, loc="best")
    varied = ", ".join(data.varying) or "nothing"
    ax1.set_title(sweep_title(data, f"{sweep_context(data)}\nvaried: {varied}"), loc="left")
    shape_panel(ax2, x, df, "point index")
    if len(df) <= 24 and data.varying:
        labels = [
            "\n".join(fmt_value(data.values.get(int(i), {}).get(f)) for f in data.varying)
            for i in df["index"]
        ]
        ax2.set_xticks(x, [f"{int(i)}\n{lab}" for i, lab in zip(x, labels, strict=True)])
        ax2.tick_params(axis="x", labelsize=6)
        ax2.set_xlabel("point index and its values of: " + ", ".join(map(short_key, data.varying)))
    return fig
