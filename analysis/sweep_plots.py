"""Figures of a parameter sweep (``probing plot sweep DIR``), from stored results only.

A sweep folder written by :func:`probing.sweep.run_sweep` holds ``sweep.json`` (the sweep
file, its base scenario and every point's varied values) and ``summary.parquet`` (one row per
point).  :func:`plot_sweep` draws one figure, ``<figures>/sweep_<name>.png`` (and ``.pdf``),
whose layout follows what the sweep varies (:func:`classify`):

``nonlinearity``
    numeric ``nonlinearity.*`` parameters: measured gain over the dense apparent-input theory
    curve a~/a (:func:`theory_curve`) and the shape error, against the parameter over a.
``rate_limit``
    the rate of a rate limit: gain and shape error against r / (2a/t0), with the bound (21).
``noise``
    a ``disturbance.sensor_noise.*`` level: measured standard error of h against
    sigma / (a sqrt(M P)) and against the closed form of the estimator.
``flight_grid``
    altitude x speed: heat maps of measured / predicted gain and of the shape error.
``other``
    measured and predicted gain and the shape error against the point index.

No simulation is run; the scenarios of the points are rebuilt from ``sweep.json`` (base
scenario, the sweep file's ``[fixed]`` table, then the point's values) only to evaluate the
theory between the points.
"""

from __future__ import annotations

import json
import math
import textwrap
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import matplotlib.ticker
import matplotlib.transforms as mtransforms
import numpy as np
import pandas as pd
from matplotlib.colors import LogNorm, TwoSlopeNorm

from analysis.figures import RC, save_figure
from analysis.seeds import QUANTITIES, has_seeds, seed_statistics
from probing.core.metrics import predicted_apparent
from probing.core.nonlinearities import NONLINEARITIES
from probing.experiment.scenario import Scenario, ScenarioError, parse_scenario
from probing.sim.channels import CHANNELS
from probing.sim.flight import SPEED_KINDS

__all__ = [
    "KINDS",
    "NotASweepError",
    "SweepData",
    "classify",
    "load_sweep_data",
    "plot_sweep",
    "sweep_figure",
    "theory_curve",
]

#: Figure layouts, in the order they are tried by :func:`classify` (``other`` last).
KINDS = ("flight_grid", "noise", "seeds", "rate_limit", "nonlinearity", "other")
FAILED_STATUSES = ("failed", "error")
SHAPE_FLOOR = 1e-9  # shape errors of exactly 0 are drawn here on log axes
N_DENSE = 200
DPI = 200  # of the PNG
FORMATS = ("png", "pdf")  # files written per figure
SPEED_FIELDS = tuple(f"condition.{k}" for k in SPEED_KINDS)
C_MEAS, C_THEORY, C_FAIL, C_MISSING = "tab:blue", "k", "tab:red", "0.6"
SIGMA = "\N{GREEK SMALL LETTER SIGMA}"


class NotASweepError(FileNotFoundError):
    """The folder has no ``summary.parquet`` or ``sweep.json`` (or they cannot be read)."""


# ------------------------------------------------------------------ loading
@dataclass
class SweepData:
    """A sweep folder's summary and manifest, with the points' scenarios rebuilt on demand.

    Attributes
    ----------
    folder : Path
        The sweep folder.
    name, description : str
        From the sweep file.
    manifest : dict
        ``sweep.json``.
    summary : pandas.DataFrame
        ``summary.parquet``, sorted by ``index``.
    fields : list of str
        The sweep's ``[grid]`` and ``[zip]`` keys, in order.
    varying : list of str
        Those of ``fields`` that take more than one value.
    zipped : list of str
        The ``[zip]`` keys (varied together).
    fixed : dict
        The sweep file's ``[fixed]`` changes.
    values : dict
        Point index -> its varied values (as written in ``sweep.json``).
    """

    folder: Path
    name: str
    description: str
    manifest: dict[str, Any]
    summary: pd.DataFrame
    fields: list[str]
    varying: list[str]
    zipped: list[str]
    fixed: dict[str, Any]
    values: dict[int, dict[str, Any]]
    _cache: dict[int | None, Scenario | None] = field(default_factory=dict, repr=False)

    @property
    def base(self) -> Scenario | None:
        """The base scenario with ``[fixed]`` applied, or None if it cannot be rebuilt."""
        if None not in self._cache:
            try:
                base = parse_scenario(self.manifest["base"])
                self._cache[None] = base.replace(self.fixed) if self.fixed else base
            except (ScenarioError, KeyError, TypeError):
                self._cache[None] = None
        return self._cache[None]

    def scenario(self, index: int) -> Scenario | None:
        """The scenario of point ``index`` (base, fixed, values), or None if not rebuildable."""
        if index not in self._cache:
            base = self.base
            try:
                scn = base.replace(self.values.get(index, {})) if base is not None else None
            except (ScenarioError, TypeError):
                scn = None
            self._cache[index] = scn
        return self._cache[index]

    def nl_type(self) -> str | None:
        """The nonlinearity type if the same at every point, else None."""
        types = set()
        for index in self.values:
            vals = self.values[index]
            if "nonlinearity.type" in vals:
                types.add(vals["nonlinearity.type"])
            elif "nonlinearity.type" in self.fixed:
                types.add(self.fixed["nonlinearity.type"])
            else:
                types.add(self.manifest.get("base", {}).get("nonlinearity", {}).get("type"))
        return types.pop() if len(types) == 1 else None


def _distinct(values: Sequence[Any]) -> int:
    return len({json.dumps(v, sort_keys=True, default=str) for v in values})


def load_sweep_data(folder: str | Path) -> SweepData:
    """Read a sweep folder's ``sweep.json`` and ``summary.parquet``.

    Parameters
    ----------
    folder : path
        A folder written by ``probing sweep`` (``<out>/<name>``).

    Returns
    -------
    SweepData
        The manifest and summary.

    Raises
    ------
    NotASweepError
        When either file is missing or unreadable.
    """
    folder = Path(folder)
    for file in ("summary.parquet", "sweep.json"):
        if not (folder / file).is_file():
            raise NotASweepError(
                f"{folder}: not a sweep folder (no {file}); run probing sweep first"
            )
    try:
        manifest = json.loads((folder / "sweep.json").read_text(encoding="utf-8"))
        summary = pd.read_parquet(folder / "summary.parquet")
    except Exception as exc:  # any unreadable file: one line for the user
        raise NotASweepError(
            f"{folder}: cannot read the sweep ({exc.__class__.__name__}: {exc})"
        ) from None
    if "index" in summary:
        summary = summary.sort_values("index").reset_index(drop=True)
    else:
        summary = summary.assign(index=np.arange(len(summary)))
    toml: dict[str, Any] = {}
    try:
        toml = tomllib.loads(manifest.get("sweep_toml") or "")
    except tomllib.TOMLDecodeError:
        pass
    fields = list(manifest.get("fields") or [])
    values = {int(p["index"]): dict(p.get("values", {})) for p in manifest.get("points", [])}
    if not values:  # no point list: take the values from the summary columns
        for row in summary.to_dict("records"):
            values[int(row["index"])] = {k: row[k] for k in fields if k in row}
    varying = [f for f in fields if _distinct([v.get(f) for v in values.values()]) > 1]
    return SweepData(
        folder=folder,
        name=str(manifest.get("name") or folder.name),
        description=str(toml.get("description") or ""),
        manifest=manifest,
        summary=summary,
        fields=fields,
        varying=varying,
        zipped=[k for k in toml.get("zip", {}) if k in fields],
        fixed=dict(toml.get("fixed", {})),
        values=values,
    )


# ------------------------------------------------------------------ classification
def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def classify(data: SweepData) -> str:
    """Which figure a sweep gets: one of :data:`KINDS`.

    ``flight_grid`` when exactly the altitude and one speed vary; ``noise`` when a sensor
    noise level varies; ``seeds`` when the points repeat over 3 or more seeds
    (:mod:`analysis.seeds`); ``rate_limit`` when every point has a rate limit and its rate (or
    r / (2a/t0)) varies; ``nonlinearity`` when only numeric parameters of one nonlinearity
    type vary; ``other`` otherwise.
    """
    varying = set(data.varying)
    speeds = varying & set(SPEED_FIELDS)
    if varying == {"condition.altitude_ft", *speeds} and len(speeds) == 1:
        return "flight_grid"
    if any(f.startswith("disturbance.sensor_noise.") for f in varying):
        return "noise"
    if has_seeds(data):
        return "seeds"
    nl_type = data.nl_type()
    if nl_type == "rate_limit":
        ratios = data.summary.get("rate_ratio", pd.Series(dtype=float)).to_numpy(dtype=float)
        if (
            "nonlinearity.rate_deg_s" in varying
            or _distinct([round(r, 12) for r in ratios[np.isfinite(ratios)]]) > 1
        ):
            return "rate_limit"
    nl_fields = [f for f in varying if f.startswith("nonlinearity.") and f != "nonlinearity.type"]
    numeric = all(_is_number(v.get(f)) for v in data.values.values() for f in nl_fields)
    if (
        nl_fields
        and len(nl_fields) == len(varying)
        and numeric
        and nl_type not in (None, "none", "rate_limit")
    ):
        return "nonlinearity"
    return "other"


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


# ------------------------------------------------------------------ helpers
def _short(key: str) -> str:
    return key.rsplit(".", 1)[-1]


def _fmt(v: Any) -> str:
    return f"{v:g}" if _is_number(v) else str(v)


def _title(data: SweepData, kind_line: str) -> str:
    head = f"Sweep '{data.name}'"
    if data.description:
        head += ": " + data.description
    lines = textwrap.wrap(head, 110)
    for part in kind_line.split("\n"):
        lines += textwrap.wrap(part, 110)
    return "\n".join(lines)


def _context(data: SweepData) -> str:
    """Common conditions of the points (the varied ones left out)."""
    scn = data.base
    if scn is None:
        return f"{len(data.summary)} points"
    varied = set(data.varying)
    parts = [f"aircraft {scn.model}"]
    if "condition.altitude_ft" not in varied:
        parts.append(f"{scn.altitude_ft:g} ft")
    if not varied & set(SPEED_FIELDS):
        parts.append(f"{scn.speed:g} {SPEED_KINDS[scn.speed_kind].unit}")
    if "probe.amplitude_deg" not in varied:
        parts.append(f"a = {scn.amplitude_deg:g} deg")
    if "probe.bit_duration_s" not in varied:
        parts.append(f"t0 = {scn.bit_duration_s:g} s")
    if "probe.order" not in varied:
        parts.append(f"M = {scn.bits_per_period}")
    if not varied & {"probe.periods", "probe.settle_periods"}:
        parts.append(f"P = {scn.periods - scn.settle_periods} settled periods")
    channels = set(data.summary.get("channel", pd.Series(dtype=str)).dropna())
    if len(channels) == 1:
        parts.append(f"channel {channels.pop()}")
    return f"{len(data.summary)} points; " + ", ".join(parts)


def _status_masks(df: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    status = df.get("status", pd.Series(["done"] * len(df))).astype(str).to_numpy()
    return np.isin(status, FAILED_STATUSES), status == "missing"


def _mark_failed(ax: Any, x: np.ndarray, failed: np.ndarray, missing: np.ndarray) -> None:
    """Red x (failed) and grey o (not run) at the bottom of ``ax``, at data x."""
    trans = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
    if failed.any():
        ax.plot(
            x[failed],
            np.full(failed.sum(), 0.04),
            "x",
            color=C_FAIL,
            ms=6,
            mew=1.5,
            transform=trans,
            clip_on=False,
            label=f"failed (trim/divergence): {failed.sum()}",
        )
    if missing.any():
        ax.plot(
            x[missing],
            np.full(missing.sum(), 0.04),
            "o",
            mfc="none",
            color=C_MISSING,
            ms=5,
            transform=trans,
            clip_on=False,
            label=f"not run yet: {missing.sum()}",
        )


def _gain_and_shape_axes() -> tuple[Any, tuple[Any, Any]]:
    """The two-panel layout of the gain figures: gain on top, shape error below, shared x."""
    return plt.subplots(
        2, 1, figsize=(7.0, 6.2), sharex=True, constrained_layout=True, height_ratios=[3, 2]
    )


def _shape_panel(
    ax: Any, x: np.ndarray, df: pd.DataFrame, xlabel: str, stuck: np.ndarray | None = None
) -> None:
    """Shape error on a log axis: zeros at the floor, inf (gain 0) at the top edge; the
    points in ``stuck`` (b~ ≠ 0 predicted) as open circles."""
    shape = df["shape_error"].to_numpy(dtype=float)
    stuck = np.zeros(len(df), dtype=bool) if stuck is None else stuck
    finite = np.isfinite(shape)
    zero = finite & (shape <= 0)
    pos = finite & (shape > 0)
    hi = max(1.0, 10 * shape[pos].max()) if pos.any() else 1.0
    ax.set_yscale("log")
    ax.set_ylim(SHAPE_FLOOR / 3, hi)
    if (pos & ~stuck).any():
        ax.plot(x[pos & ~stuck], shape[pos & ~stuck], "o", color=C_MEAS, ms=4, label="measured")
    if (pos & stuck).any():
        ax.plot(
            x[pos & stuck],
            shape[pos & stuck],
            "o",
            mfc="none",
            color=C_MEAS,
            ms=5,
            label="measured, b~ ≠ 0 predicted",
        )
    if zero.any():
        ax.plot(
            x[zero],
            np.full(zero.sum(), SHAPE_FLOOR),
            "v",
            color=C_MEAS,
            mfc="none",
            ms=5,
            label=f"exactly 0 (drawn at {SHAPE_FLOOR:g})",
        )
    inf = np.isposinf(shape)
    if inf.any():
        trans = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
        ax.plot(
            x[inf],
            np.full(inf.sum(), 0.96),
            "^",
            color=C_MEAS,
            mfc="none",
            ms=5,
            transform=trans,
            clip_on=False,
            label="undefined: measured gain 0",
        )
    failed, missing = _status_masks(df)
    _mark_failed(ax, x, failed, missing)
    ax.set_ylabel("shape error ||h - g h0|| / ||g h0||")
    ax.set_xlabel(xlabel)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(frameon=False, loc="best")


def _gain_range(values: list[np.ndarray], measured: np.ndarray) -> tuple[float, float, np.ndarray]:
    """Gain axis range covering 0, 1, the theory and the measurements within two spans of
    it, and the mask of the measurements outside (drawn as off scale)."""
    ref = np.concatenate([v[np.isfinite(v)] for v in values] + [np.array([0.0, 1.0])])
    lo_ref, hi_ref = ref.min(), ref.max()
    span = max(hi_ref - lo_ref, 1.0)
    ok = np.isfinite(measured)
    off = ok & ((measured > hi_ref + 2 * span) | (measured < lo_ref - 2 * span))
    inside = measured[ok & ~off]
    lo = min(lo_ref, inside.min()) if inside.size else lo_ref
    hi = max(hi_ref, inside.max()) if inside.size else hi_ref
    return float(lo), float(hi), off


def _gain_limits(
    ax: Any,
    values: list[np.ndarray],
    measured: np.ndarray,
    x: np.ndarray,
    off_label: str = "measured, off scale (value written)",
) -> np.ndarray:
    """Y limits from the theory and the sensible measurements; far outliers drawn at the top
    (or bottom) edge with their value.  Returns the mask of those outliers."""
    lo, hi, off = _gain_range(values, measured)
    pad = 0.08 * (hi - lo)
    ax.set_ylim(lo - 1.6 * pad, hi + 1.6 * pad)
    if off.any():
        trans = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
        above = measured[off] > hi
        ax.plot(
            x[off],
            np.where(above, 0.97, 0.1),
            "^",
            color=C_FAIL,
            mfc="none",
            ms=6,
            transform=trans,
            clip_on=False,
            label=off_label,
        )
        for xi, yi, up in zip(x[off], measured[off], above, strict=True):
            ax.annotate(
                f"{yi:.3g}",
                (xi, 0.97 if up else 0.1),
                xycoords=trans,
                xytext=(0, -9 if up else 6),
                textcoords="offset points",
                ha="center",
                fontsize=6,
                color=C_FAIL,
            )
    return off


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


def _plot_nonlinearity(data: SweepData) -> Any:
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
    label = f"|{_short(x_field)}| / a" if use_abs else f"{_short(x_field)} / a"
    label += f"   (a = {a:g} deg probe amplitude)"

    fig, (ax1, ax2) = _gain_and_shape_axes()
    theory_values: list[np.ndarray] = []
    drawn_series: list[tuple[pd.DataFrame, str, str]] = []
    series = df.groupby(
        [df["index"].map(lambda i, k=k: _fmt(data.values[int(i)][k])) for k in series_keys]
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
                f"{_short(f)}/a = {first[f] / a:.3g}" for f in tag_fields if _is_number(first[f])
            )
        order = np.argsort(xs[grp.index], kind="stable")
        rows = grp.iloc[order]
        scn = data.scenario(int(rows["index"].iloc[0]))
        path = {f: [data.values[int(i)][f] for i in rows["index"]] for f in x_group}
        drawn = False
        if scn is not None:
            try:
                params, gain, _ = theory_curve(scn, path)
            except ValueError:
                pass
            else:
                xd = (np.abs(params[x_field]) if use_abs else params[x_field]) / a
                ax1.plot(
                    xd,
                    gain,
                    "-",
                    color=C_THEORY if not series_keys else color,
                    lw=1.0,
                    label=None if series_keys else "predicted a~/a, eq. (10)",
                )
                theory_values.append(gain)
                drawn = True
        if not drawn:  # scenario not rebuildable: the summary's predictions at the points
            pg = rows["predicted_gain"].to_numpy(dtype=float)
            ax1.plot(
                xs[rows.index],
                pg,
                "--",
                color=C_THEORY,
                lw=0.8,
                label=None if series_keys else "predicted a~/a at the points",
            )
            theory_values.append(pg)
        drawn_series.append((rows, color, tag))
    if series_keys:  # one legend entry for the theory lines, one per series for the markers
        ax1.plot([], [], "-", color=C_THEORY, lw=1.0, label="predicted a~/a, eq. (10): lines")
    measured = df["measured_gain"].to_numpy(dtype=float)
    stuck = np.abs(df["predicted_offset_deg"].to_numpy(dtype=float)) > 0
    off = _gain_range(theory_values, measured)[2]
    off_label = "measured, off scale (value written)"
    if off.any() and stuck[off].all():
        off_label = "measured, off scale, b~ ≠ 0 predicted (the offset step leaks into h)"
    off = _gain_limits(ax1, theory_values, measured, xs, off_label)
    open_label = "measured where b~ ≠ 0 is predicted (the offset step leaks into h)"
    if series_keys:
        open_label = "open: " + open_label
    open_label_done = False
    for rows, color, tag in drawn_series:
        sel = rows.index.to_numpy()
        xr, meas = xs[sel], measured[sel]
        shown = ~off[sel] & np.isfinite(meas)
        plain, open_ = shown & ~stuck[sel], shown & stuck[sel]
        lab = "measured gain g" + (f" ({tag})" if tag else "")
        if plain.any() or (series_keys and open_.any()):
            ax1.plot(xr[plain], meas[plain], "o", color=color, ms=4, label=lab)
        if open_.any():
            ax1.plot(
                xr[open_],
                meas[open_],
                "o",
                mfc="none",
                color=color,
                ms=5,
                label=None if open_label_done else open_label,
            )
            open_label_done = True
    failed, missing = _status_masks(df)
    _mark_failed(ax1, xs, failed, missing)
    ax1.set_ylabel("gain a~/a (dimensionless)")
    ax1.legend(frameon=False, loc="best")
    ax1.set_title(_title(data, _context(data)), loc="left")
    _shape_panel(ax2, xs, df, label, stuck)
    return fig


# ------------------------------------------------------------------ 2. rate limit
def _plot_rate_limit(data: SweepData) -> Any:
    df = data.summary
    x = df["rate_ratio"].to_numpy(dtype=float)
    fig, (ax1, ax2) = _gain_and_shape_axes()
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
    _gain_limits(ax1, [np.array([1.0])], meas, x)
    failed, missing = _status_masks(df)
    _mark_failed(ax1, x, failed, missing)
    ax1.set_ylabel("gain (dimensionless)")
    ax1.legend(frameon=False, loc="lower right")
    ax1.set_title(_title(data, _context(data)), loc="left")
    ticks = [t for t in (0.125, 0.25, 0.5, 1, 2, 4, 8, 16) if lo <= t <= hi]
    _shape_panel(ax2, x, df, "rate limit r / (2a/t0)")
    ax2.set_xticks(ticks, [f"{t:g}" for t in ticks])
    ax2.set_xticks([], minor=True)
    return fig


# ------------------------------------------------------------------ 3. noise
def _noise_frame(data: SweepData) -> tuple[pd.DataFrame, str]:
    """One row per point, or per group of seeds: the naive rule, the measured and the
    predicted standard error of h, and what "measured" means."""
    df = data.summary
    if not has_seeds(data):
        frame = df.assign(measured=df["h_stderr"], predicted=df["predicted_h_stderr"])
        return frame, "measured: period-to-period spread / √P (not the seed-to-seed error)"
    channel = str(df["channel"].iloc[0])
    by_index = df.set_index("index")
    rows = []
    for s in seed_statistics(data):
        if s.channel == channel:
            first = by_index.loc[s.indices[0]]
            rows.append({**first.to_dict(), "index": s.indices[0], "status": "done",
                         "measured": s.measured["h_stderr"],
                         "predicted": s.predicted["h_stderr"]})  # fmt: skip
    frame = pd.DataFrame(rows) if rows else df.iloc[:0].assign(measured=[], predicted=[])
    seeds = len({v.get("disturbance.seed") for v in data.values.values()})
    return frame, (
        f"measured: standard deviation over the same {seeds} seeds at every point (the "
        f"noise scales as {SIGMA}/a: one draw, sampling error "
        f"{100 / math.sqrt(2 * (seeds - 1)):.0f} %)"
    )


def _plot_noise(data: SweepData) -> Any:
    df, meaning = _noise_frame(data)
    naive = df["h_stderr_naive"].to_numpy(dtype=float)
    meas = df["measured"].to_numpy(dtype=float)
    theory = df["predicted"].to_numpy(dtype=float)
    channel = str(df["channel"].iloc[0]) if "channel" in df and len(df) else "?"
    unit = CHANNELS[channel].unit if channel in CHANNELS else "output unit"
    noise_fields = [f for f in data.varying if f.startswith("disturbance.sensor_noise.")]
    amp_varies = "probe.amplitude_deg" in data.varying
    usable = np.isfinite(naive) & (naive > 0) & np.isfinite(meas) & (meas > 0)
    failed, missing = _status_masks(df)

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(7.6, 3.9), constrained_layout=True)
    if amp_varies:
        amps = np.array([data.values[int(i)]["probe.amplitude_deg"] for i in df["index"]])
        groups = [(f"a = {v:g} deg", amps == v) for v in sorted(set(amps.tolist()))]
    else:
        groups = [("measured", np.ones(len(df), dtype=bool))]
    for k, (lab, sel) in enumerate(groups):
        color = f"C{k}" if amp_varies else C_MEAS
        m = sel & usable
        if not m.any():
            continue
        ax1.loglog(naive[m], meas[m], "o", color=color, ms=4.5, label=lab)
        ax1.loglog(naive[m], theory[m], "+", color=color, ms=7, mew=1.0)
        ax2.semilogx(naive[m], meas[m] / theory[m], "o", color=color, ms=4.5, label=lab)
    if usable.any():
        lo, hi = naive[usable].min() / 2, naive[usable].max() * 2
        line = np.array([lo, hi])
        ax1.loglog(line, line, ":", color="0.4", lw=1.0, label=f"y = x: {SIGMA}/(a √(MP))")
        th = usable & np.isfinite(theory) & (theory > 0)
        if th.any():
            order = np.argsort(naive[th])
            ax1.loglog(
                naive[th][order],
                theory[th][order],
                "--",
                color=C_THEORY,
                lw=0.8,
                label=f"noise model, {_estimators(data)} (+)",
            )
        r_naive = np.median(meas[usable] / naive[usable])
        r_theory = np.median(meas[th] / theory[th]) if th.any() else math.nan
        ax1.text(
            0.98,
            0.03,
            f"median measured / naive = {r_naive:.3g}\n"
            f"median measured / noise model = {r_theory:.3f}",
            transform=ax1.transAxes,
            ha="right",
            va="bottom",
            fontsize=7,
            bbox={"fc": "white", "ec": "0.8", "lw": 0.5},
        )
        ax2.axhline(1.0, color=C_THEORY, ls="--", lw=0.8, label="= noise model")
        ax2.axhspan(0.75, 1.25, color="0.92", lw=0, label="within 25 %")
        ratio = meas[th] / theory[th] if th.any() else np.array([1.0])
        ax2.set_ylim(
            min(0.5, 0.9 * float(np.nanmin(ratio))), max(1.5, 1.1 * float(np.nanmax(ratio)))
        )
    skipped = int(len(df) - usable.sum() - failed.sum() - missing.sum())
    notes = []
    if failed.any():
        notes.append(f"{failed.sum()} failed (trim/divergence) points not shown")
    if missing.any():
        notes.append(f"{missing.sum()} points not run yet")
    if skipped:
        where = ", ".join(_short(f) for f in noise_fields)
        elsewhere = f"; the varied noise is on {where}" if channel not in where.split(", ") else ""
        notes.append(f"{skipped} points with {SIGMA} = 0 on {channel} not shown{elsewhere}")
    if not usable.any():
        ax1.text(
            0.5,
            0.5,
            "no point with a usable standard error",
            transform=ax1.transAxes,
            ha="center",
            va="center",
            color=C_FAIL,
        )
    units = f"({unit})/deg"
    for ax in (ax1, ax2):
        ax.set_xlabel(f"{SIGMA} / (a √(M P))  [{units}]")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax1.set_ylabel(f"standard error of mean h  [{units}]")
    ax1.set_title("standard error of h (o measured, + noise model)", loc="left")
    if ax1.get_legend_handles_labels()[0]:
        ax1.legend(frameon=False, loc="upper left")
    ax2.set_ylabel("measured / predicted standard error")
    ax2.set_title("measured over predicted (> 1: spread not from noise)", loc="left")
    if ax2.get_legend_handles_labels()[0]:
        ax2.legend(frameon=False, loc="best")
    context = _context(data) + "".join(f"; {n}" for n in [meaning, *notes])
    fig.suptitle(_title(data, context), fontsize=8, x=0.01, ha="left")
    return fig


def _estimators(data: SweepData) -> str:
    """The estimator(s) of the sweep's points, for labels."""
    names = {s.estimator for i in data.values if (s := data.scenario(i)) is not None}
    return ", ".join(sorted(names)) + " estimator" + ("s" if len(names) > 1 else "")


# ------------------------------------------------------------------ seeds
SEED_TITLES = {
    "h_stderr": "scatter of mean h_est, RMS over taps",
    "z_stderr": "scatter of mean z, RMS over taps",
    "gain_stderr": "scatter of the gain",
}


def _plot_seeds(data: SweepData) -> Any:
    """Measured (dots, sampling error bars) against predicted (bars) scatter, per group of
    seeds (columns: h, z, gain; rows: the channels)."""
    stats = seed_statistics(data)
    channels = list(dict.fromkeys(s.channel for s in stats)) or ["?"]
    labels = list(dict.fromkeys(s.label for s in stats))
    fig, axes = plt.subplots(
        len(channels),
        len(QUANTITIES),
        figsize=(2.2 * len(QUANTITIES) + 0.6, 2.3 * len(channels) + 0.9),
        constrained_layout=True,
        squeeze=False,
    )
    x = np.arange(len(labels))
    for row, channel in enumerate(channels):
        unit = CHANNELS[channel].unit if channel in CHANNELS else "?"
        units = {"h_stderr": f"{unit}/deg", "z_stderr": unit, "gain_stderr": "1"}
        mine = {s.label: s for s in stats if s.channel == channel}
        for col, q in enumerate(QUANTITIES):
            ax = axes[row, col]
            meas = np.array([mine[lab].measured[q] if lab in mine else np.nan for lab in labels])
            pred = np.array([mine[lab].predicted[q] if lab in mine else np.nan for lab in labels])
            err = np.array([mine[lab].sampling_error if lab in mine else np.nan for lab in labels])
            ax.bar(x, pred, width=0.6, color="0.85", edgecolor="0.4", label="predicted")
            ax.errorbar(x, meas, yerr=meas * err, fmt="o", color=C_MEAS, ms=4, label="measured")
            for xi, m_, p_ in zip(x, meas, pred, strict=True):
                if np.isfinite(m_) and np.isfinite(p_) and p_ > 0:
                    ax.annotate(f"{m_ / p_:.2f}", (xi, m_), xytext=(0, 5),
                                textcoords="offset points", ha="center", fontsize=6)  # fmt: skip
            positive = np.concatenate([v[np.isfinite(v) & (v > 0)] for v in (meas, pred)])
            if positive.size:
                ax.set_yscale("log")
                ax.set_ylim(positive.min() / 3, positive.max() * 4)
            ax.set_xticks(x, labels, rotation=30, ha="right", fontsize=6)
            ax.set_title(f"{channel}: {SEED_TITLES[q]}", loc="left", fontsize=7)
            ax.set_ylabel(units[q])
    axes[0, 0].legend(frameon=False, loc="lower left", fontsize=6)
    seeds = stats[0].seeds if stats else 0
    line = (
        f"{_context(data)}; {seeds} seeds per group; numbers: measured / predicted; "
        "error bars: sampling error of a standard deviation over the seeds"
    )
    fig.suptitle(_title(data, line), fontsize=8, x=0.01, ha="left")
    return fig


# ------------------------------------------------------------------ 4. flight grid
def _heat_text(value: float, decimals: int, log: bool) -> str:
    if log:
        return "0" if value == 0 else f"{value:.1e}"
    return f"{value:.{decimals}f}"


def _plot_flight_grid(data: SweepData) -> Any:
    df = data.summary
    speed_field = next(f for f in data.varying if f in SPEED_FIELDS)
    alt = np.array([data.values[int(i)]["condition.altitude_ft"] for i in df["index"]], float)
    spd = np.array([data.values[int(i)][speed_field] for i in df["index"]], float)
    alts, spds = np.unique(alt), np.unique(spd)
    rows, cols = np.searchsorted(alts, alt), np.searchsorted(spds, spd)
    shape = (alts.size, spds.size)
    ratio = np.full(shape, np.nan)
    err = np.full(shape, np.nan)
    status = np.full(shape, "absent", dtype=object)
    pred = df["predicted_gain"].to_numpy(dtype=float)
    meas = df["measured_gain"].to_numpy(dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(np.isfinite(pred) & (pred != 0), meas / pred, np.nan)
    ratio[rows, cols] = r
    err[rows, cols] = df["shape_error"].to_numpy(dtype=float)
    status[rows, cols] = df["status"].astype(str).to_numpy()

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(7.6, 3.8), constrained_layout=True)
    fin = ratio[np.isfinite(ratio)]
    dev = np.abs(fin - 1).max() if fin.size else 0.0
    dev = max(dev, 1e-9)
    decimals = int(np.clip(math.ceil(-math.log10(dev)) + 1, 2, 7))
    norm1 = TwoSlopeNorm(vcenter=1.0, vmin=1 - 1.05 * dev, vmax=1 + 1.05 * dev)
    ok_err = err[np.isfinite(err) & (err > 0)]
    e_lo, e_hi = (ok_err.min(), ok_err.max()) if ok_err.size else (SHAPE_FLOOR, 1.0)
    if e_hi <= e_lo:
        e_lo, e_hi = e_lo / 10, e_hi * 10
    norm2 = LogNorm(vmin=max(e_lo, SHAPE_FLOOR), vmax=e_hi)
    err_drawn = np.where(err == 0, norm2.vmin, err)
    unit = SPEED_KINDS[_short(speed_field)].unit
    panels = (
        (ax1, ratio, norm1, "RdBu_r", "measured / predicted gain", False),
        (ax2, err_drawn, norm2, "viridis", "shape error ||h - g h0|| / ||g h0||", True),
    )
    for ax, grid, norm, cmap, label, log in panels:
        drawn = np.ma.masked_invalid(grid)
        mesh = ax.pcolormesh(
            np.arange(spds.size + 1) - 0.5,
            np.arange(alts.size + 1) - 0.5,
            drawn,
            cmap=cmap,
            norm=norm,
            shading="flat",
        )
        cbar = fig.colorbar(mesh, ax=ax, label=label, shrink=0.9)
        if not log:
            cbar.ax.yaxis.set_major_formatter(
                matplotlib.ticker.FuncFormatter(lambda v, _pos: f"{v:.{decimals}f}")
            )
        ax.set_facecolor("white")
        for i in range(alts.size):
            for j in range(spds.size):
                st = status[i, j]
                value = (ratio if not log else err)[i, j]
                if st in FAILED_STATUSES or st in ("missing", "absent"):
                    ax.add_patch(
                        plt.Rectangle(
                            (j - 0.5, i - 0.5),
                            1,
                            1,
                            fc="0.85",
                            ec="0.5",
                            hatch="///",
                            lw=0.3,
                        )
                    )
                    text = {"missing": "not run", "absent": "no point"}.get(st, "failed")
                    ax.text(
                        j,
                        i,
                        text,
                        ha="center",
                        va="center",
                        fontsize=6.5,
                        color=C_FAIL,
                        bbox={"fc": "white", "ec": "none", "alpha": 0.8, "pad": 1.0},
                    )
                elif np.isfinite(value):
                    rgba = mesh.cmap(mesh.norm(err_drawn[i, j] if log else value))
                    dark = 0.299 * rgba[0] + 0.587 * rgba[1] + 0.114 * rgba[2] < 0.5
                    ax.text(
                        j,
                        i,
                        _heat_text(value, decimals, log),
                        ha="center",
                        va="center",
                        fontsize=6,
                        color="white" if dark else "black",
                    )
                else:
                    text = "undefined\n(gain 0)" if log and np.isposinf(value) else "n/a"
                    ax.text(j, i, text, ha="center", va="center", fontsize=6)
        ax.set_xticks(range(spds.size), [f"{v:g}" for v in spds])
        ax.set_yticks(range(alts.size), [f"{v:g}" for v in alts])
        ax.set_xlabel(f"speed ({unit})")
        ax.set_ylabel("altitude (ft)")
        ax.grid(False)
    pg = pred[np.isfinite(pred)]
    pg_txt = f" (predicted a~/a = {pg[0]:.4g})" if pg.size and np.ptp(pg) == 0 else ""
    ax1.set_title(f"measured / predicted gain{pg_txt}", loc="left")
    ax2.set_title("shape error (log colour)", loc="left")
    n_fail = int(np.isin(status, FAILED_STATUSES).sum())
    fig.suptitle(
        _title(data, _context(data) + (f"; {n_fail} failed (trim/divergence)" if n_fail else "")),
        fontsize=8,
        x=0.01,
        ha="left",
    )
    return fig


# ------------------------------------------------------------------ 5. other
def _plot_other(data: SweepData) -> Any:
    df = data.summary
    x = df["index"].to_numpy(dtype=float)
    fig, (ax1, ax2) = _gain_and_shape_axes()
    pred = df["predicted_gain"].to_numpy(dtype=float)
    meas = df["measured_gain"].to_numpy(dtype=float)
    fin = np.isfinite(pred)
    if fin.any():
        ax1.plot(x[fin], pred[fin], "_", color=C_THEORY, ms=12, mew=1.5, label="predicted a~/a")
    if np.isfinite(meas).any():
        ax1.plot(x, meas, "o", color=C_MEAS, ms=4, label="measured gain g")
    _gain_limits(ax1, [pred], meas, x)
    failed, missing = _status_masks(df)
    _mark_failed(ax1, x, failed, missing)
    ax1.set_ylabel("gain (dimensionless)")
    ax1.legend(frameon=False, loc="best")
    varied = ", ".join(data.varying) or "nothing"
    ax1.set_title(_title(data, f"{_context(data)}\nvaried: {varied}"), loc="left")
    _shape_panel(ax2, x, df, "point index")
    if len(df) <= 24 and data.varying:
        labels = [
            "\n".join(_fmt(data.values.get(int(i), {}).get(f)) for f in data.varying)
            for i in df["index"]
        ]
        ax2.set_xticks(x, [f"{int(i)}\n{lab}" for i, lab in zip(x, labels, strict=True)])
        ax2.tick_params(axis="x", labelsize=6)
        ax2.set_xlabel("point index and its values of: " + ", ".join(map(_short, data.varying)))
    return fig


_DRAW = {
    "seeds": _plot_seeds,
    "nonlinearity": _plot_nonlinearity,
    "rate_limit": _plot_rate_limit,
    "noise": _plot_noise,
    "flight_grid": _plot_flight_grid,
    "other": _plot_other,
}


# ------------------------------------------------------------------ entry points
def sweep_figure(data: SweepData) -> Any:
    """The figure of a sweep, laid out by :func:`classify` (close it, or :func:`plot_sweep`)."""
    with plt.rc_context(RC):
        return _DRAW[classify(data)](data)


def plot_sweep(folder: Path, figures: Path | None = None) -> list[Path]:
    """Draw the figure of one sweep folder into ``<figures>/sweep_<name>.png`` and ``.pdf``.

    Parameters
    ----------
    folder : Path
        A sweep folder (``results/sweeps/<name>``) with ``sweep.json`` and
        ``summary.parquet``.
    figures : Path, optional
        Figure folder (created if needed); default: ``<folder>/figures``.

    Returns
    -------
    list of Path
        The files written (PNG, then PDF).

    Raises
    ------
    NotASweepError
        When the folder is not a sweep folder.
    """
    data = load_sweep_data(folder)
    target = Path(figures) if figures is not None else Path(folder) / "figures"
    return save_figure(sweep_figure(data), target / f"sweep_{data.name}", FORMATS, DPI)
