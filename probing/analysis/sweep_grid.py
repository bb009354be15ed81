"""The sweep figure of a flight grid: heat maps of measured over predicted gain and of the
shape error over altitude and speed (:func:`plot_flight_grid`)."""

from __future__ import annotations

import math
from typing import Any

import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np
from matplotlib.colors import LogNorm, TwoSlopeNorm

from probing.analysis.figures import text_colour_on
from probing.analysis.sweep_axes import (
    C_FAIL,
    SHAPE_FLOOR,
    short_key,
    sweep_context,
    sweep_title,
)
from probing.analysis.sweep_data import FAILED_STATUSES, SPEED_FIELDS, SweepData
from probing.sim.flight import SPEED_KINDS

__all__ = ["plot_flight_grid"]


# ------------------------------------------------------------------ 4. flight grid
def _heat_text(value: float, decimals: int, log: bool) -> str:
    if log:
        return "0" if value == 0 else f"{value:.1e}"
    return f"{value:.{decimals}f}"


def _grid(
    data: SweepData,
) -> tuple[str, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The speed field, the altitudes (rows) and speeds (columns) of a flight grid, and per
    cell measured / predicted gain, shape error and status (``absent``: no point)."""
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
    return speed_field, alts, spds, ratio, err, status


def _norms(ratio: np.ndarray, err: np.ndarray) -> tuple[int, Any, Any, np.ndarray]:
    """The decimals of the gain ratio, the colour norms of the two maps (centred on 1, and
    logarithmic), and the shape errors as drawn (0 at the bottom of the scale)."""
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
    return decimals, norm1, norm2, err_drawn


def _write_cells(
    ax: Any,
    mesh: Any,
    values: np.ndarray,
    colours: np.ndarray,
    status: np.ndarray,
    decimals: int,
    log: bool,
) -> None:
    """Write each cell's value (``colours``: what its colour shows), or hatch it as failed,
    not run or absent."""
    for i in range(values.shape[0]):
        for j in range(values.shape[1]):
            st = status[i, j]
            value = values[i, j]
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
                ax.text(
                    j,
                    i,
                    _heat_text(value, decimals, log),
                    ha="center",
                    va="center",
                    fontsize=6,
                    color=text_colour_on(mesh.cmap(mesh.norm(colours[i, j]))),
                )
            else:
                text = "undefined\n(gain 0)" if log and np.isposinf(value) else "n/a"
                ax.text(j, i, text, ha="center", va="center", fontsize=6)


def plot_flight_grid(data: SweepData) -> Any:
    """Heat maps over altitude x speed: measured / predicted gain, and the shape error."""
    speed_field, alts, spds, ratio, err, status = _grid(data)
    pred = data.summary["predicted_gain"].to_numpy(dtype=float)

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(7.6, 3.8), constrained_layout=True)
    decimals, norm1, norm2, err_drawn = _norms(ratio, err)
    unit = SPEED_KINDS[short_key(speed_field)].unit
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
        values, colours = (err, err_drawn) if log else (ratio, ratio)
        _write_cells(ax, mesh, values, colours, status, decimals, log)
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
        sweep_title(
            data, sweep_context(data) + (f"; {n_fail} failed (trim/divergence)" if n_fail else "")
        ),
        fontsize=8,
        x=0.01,
        ha="left",
    )
    return fig
