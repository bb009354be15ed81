"""The figure of ``probing analyze``: each output's pulse-response estimate with its
confidence bounds, drawn from ``bounds.parquet`` (no simulation)."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from analysis.figures import RC, save_figure
from probing.experiment.storage import read_footer, read_table

__all__ = ["draw_bounds"]


def draw_bounds(bounds: Path, stem: Path) -> Path:
    """Draw ``bounds.parquet``'s h_est and its interval per channel into ``<stem>.png``.

    Parameters
    ----------
    bounds : pathlib.Path
        A ``bounds.parquet`` written by ``probing analyze``.
    stem : pathlib.Path
        The figure's path without ``.png``.

    Returns
    -------
    pathlib.Path
        The PNG written (the same bounds give the same bytes).
    """
    table = read_table(bounds).to_pandas()
    meta = read_footer(bounds)
    conf = json.loads(meta[b"probing.confidence"])
    source = json.loads(meta[b"probing.input"])["file"]
    channels = list(dict.fromkeys(table["channel"]))
    with plt.rc_context(RC):
        fig, axes = plt.subplots(
            len(channels),
            1,
            figsize=(6.0, 2.2 * len(channels)),
            squeeze=False,
            layout="constrained",
        )
        for ax, channel in zip(axes[:, 0], channels, strict=True):
            rows = table[table["channel"] == channel]
            lag = rows["lag_s"].to_numpy()
            ax.fill_between(
                lag,
                rows["h_low"].to_numpy(),
                rows["h_high"].to_numpy(),
                step=None,
                color="C0",
                alpha=0.3,
                linewidth=0,
                label=f"{conf['level']:.0%} Student-t bounds ({conf['dof'] + 1} periods)",
            )
            ax.plot(lag, rows["h_est"].to_numpy(), color="C0", label="h_est (mean)")
            ax.axhline(0.0, color="0.5", linewidth=0.5)
            ax.set_ylabel(f"{channel} per probe unit")
            ax.set_xlim(0.0, float(np.max(lag)))
            ax.legend(loc="upper right")
        axes[-1, 0].set_xlabel("lag (s)")
        axes[0, 0].set_title(f"pulse response from {source}")
    return save_figure(fig, stem)[0]
