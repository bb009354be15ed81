"""What the sweep figures share: titles and the context line, the failed and not-run
markers, the gain and shape-error panels and their limits."""

from __future__ import annotations

import textwrap
from typing import Any

import matplotlib.pyplot as plt
import matplotlib.transforms as mtransforms
import numpy as np
import pandas as pd

from probing.analysis.sweep_data import FAILED_STATUSES, SPEED_FIELDS, SweepData, is_number
from probing.sim.flight import SPEED_KINDS

__all__ = [
    "C_FAIL",
    "C_MEAS",
    "C_MISSING",
    "C_THEORY",
    "SHAPE_FLOOR",
    "SIGMA",
    "fmt_value",
    "gain_and_shape_axes",
    "gain_limits",
    "gain_range",
    "mark_failed",
    "shape_panel",
    "short_key",
    "status_masks",
    "sweep_context",
    "sweep_title",
]

SHAPE_FLOOR = 1e-9  # shape errors of exactly 0 are drawn here on log axes
C_MEAS, C_THEORY, C_FAIL, C_MISSING = "tab:blue", "k", "tab:red", "0.6"
SIGMA = "\N{GREEK SMALL LETTER SIGMA}"


def short_key(key: str) -> str:
    """The last part of a dotted key (``nonlinearity.width_deg`` -> ``width_deg``)."""
    return key.rsplit(".", 1)[-1]


def fmt_value(v: Any) -> str:
    """A value for a label: a number in ``%g``, anything else as text."""
    return f"{v:g}" if is_number(v) else str(v)


def sweep_title(data: SweepData, kind_line: str) -> str:
    """The figure title: the sweep's name and description, then ``kind_line``, wrapped."""
    head = f"Sweep '{data.name}'"
    if data.description:
        head += ": " + data.description
    lines = textwrap.wrap(head, 110)
    for part in kind_line.split("\n"):
        lines += textwrap.wrap(part, 110)
    return "\n".join(lines)


def sweep_context(data: SweepData) -> str:
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


def status_masks(df: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Masks of the failed points and of the points not run yet."""
    status = df.get("status", pd.Series(["done"] * len(df))).astype(str).to_numpy()
    return np.isin(status, FAILED_STATUSES), status == "missing"


def mark_failed(ax: Any, x: np.ndarray, failed: np.ndarray, missing: np.ndarray) -> None:
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


def gain_and_shape_axes() -> tuple[Any, tuple[Any, Any]]:
    """The two-panel layout of the gain figures: gain on top, shape error below, shared x."""
    return plt.subplots(
        2, 1, figsize=(7.0, 6.2), sharex=True, constrained_layout=True, height_ratios=[3, 2]
    )


def shape_panel(
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
    failed, missing = status_masks(df)
    mark_failed(ax, x, failed, missing)
    ax.set_ylabel("shape error ||h - g h0|| / ||g h0||")
    ax.set_xlabel(xlabel)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(frameon=False, loc="best")


def gain_range(values: list[np.ndarray], measured: np.ndarray) -> tuple[float, float, np.ndarray]:
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


def gain_limits(
    ax: Any,
    values: list[np.ndarray],
    measured: np.ndarray,
    x: np.ndarray,
    off_label: str = "measured, off scale (value written)",
) -> np.ndarray:
    """Y limits from the theory and the sensible measurements; far outliers drawn at the top
    (or bottom) edge with their value.  Returns the mask of those outliers."""
    lo, hi, off = gain_range(values, measured)
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
