"""Several surfaces probed at once: the cross-talk table and the figure of the stored runs.

Reads the ``responses.parquet`` of runs of ``[simultaneous]`` scenarios flown with
``--truth`` (``make simultaneous``): each surface's response probed together (``h_est``),
alone (``h_alone``) and on the linearisation (``h_lin``); the measured and predicted
cross-talk are in the file's metadata (``probing.crosstalk``, ``probing.design``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from probing.analysis.figures import RC, save_figure
from probing.experiment.output.storage import read_schema, read_table

__all__ = ["draw", "figure", "load_runs", "summary_markdown"]


def load_runs(results: Path) -> dict[str, tuple[pd.DataFrame, dict]]:
    """Run name -> (its responses, its metadata: scenario, design, crosstalk), for every
    ``<results>/<name>/responses.parquet`` flown with ``--truth``.

    Raises
    ------
    FileNotFoundError
        If no such run is there.
    """
    runs = {}
    for path in sorted(Path(results).glob("*/responses.parquet")):
        meta = {
            k.decode().removeprefix("probing."): v.decode()
            for k, v in (read_schema(path).metadata or {}).items()
            if k.startswith(b"probing.")
        }
        info = {k: json.loads(meta[k]) for k in ("scenario", "design", "crosstalk")}
        if info["crosstalk"] is None:
            continue
        runs[path.parent.name] = (read_table(path).to_pandas(), info)
    if not runs:
        raise FileNotFoundError(f"{results}: no simultaneous run flown with --truth")
    return runs


def summary_markdown(runs: dict[str, tuple[pd.DataFrame, dict]]) -> str:
    """One table per run: measured and predicted cross-talk per surface and channel."""
    lines = [
        "<!-- written by probing plot simultaneous (make simultaneous); do not edit -->",
        "",
    ]
    for name, (_, info) in runs.items():
        scn = info["scenario"]
        probe, sim = scn["probe"], scn["simultaneous"]
        surfaces = [probe.get("surface", "elevator"), *sim["also_surfaces"]]
        m = 2 ** probe["order"] - 1
        flown = info["design"]["check"][0]
        lines += [
            f"**{name}**: {scn['aircraft']['model']}, {sim['design']} design, "
            f"{' + '.join(surfaces)}, M = {m}, t0 = {probe['bit_duration_s']:g} s, "
            f"{info['design']['window_bits']} taps per surface, separation "
            f"{flown['separation_s']:.1f} s.",
            "",
            "| surface | channel | memory (s) | cross-talk measured | predicted | "
            "of its own peak | alone vs linearisation |",
            "|---|---|---:|---:|---:|---:|---:|",
        ]
        check = {(r["surface"], r["channel"]): r for r in info["design"]["check"]}
        for r in info["crosstalk"]:
            c = check[r["surface"], r["channel"]]
            lines.append(
                f"| {r['surface']} | {r['channel']} | {c['memory_s']:.1f} | "
                f"{100 * r['crosstalk']:.2f} % | {100 * c['predicted_crosstalk']:.2f} % | "
                f"{100 * r['crosstalk_of_own']:.1f} % | {100 * r['alone_vs_linear']:.1f} % |"
            )
        lines.append("")
    return "\n".join(lines)


def figure(name: str, table: pd.DataFrame) -> Any:
    """The figure of one run: every surface (rows) and channel (columns), probed together,
    alone and on the linearisation, and the difference together - alone (x 10).

    The legend sits below the panels, where it hides no curve.  Close the figure (or let
    :func:`draw` save it).
    """
    surfaces = list(dict.fromkeys(table.surface))
    channels = list(dict.fromkeys(table.channel))
    with plt.rc_context(RC):
        fig, axes = plt.subplots(
            len(surfaces),
            len(channels),
            figsize=(2.4 * len(channels), 1.9 * len(surfaces) + 0.3),
            squeeze=False,
            constrained_layout=True,
        )
        for i, s in enumerate(surfaces):
            for j, c in enumerate(channels):
                ax = axes[i, j]
                rows = table[(table.surface == s) & (table.channel == c)]
                lag = rows.lag_s.to_numpy()
                ax.plot(lag, rows.h_lin, color="0.6", lw=2.0, label="linearisation")
                ax.plot(lag, rows.h_alone, color="C0", label="probed alone")
                ax.plot(lag, rows.h_est, "--", color="C1", label="probed together")
                diff = 10 * (rows.h_est.to_numpy() - rows.h_alone.to_numpy())
                ax.plot(lag, diff, color="C3", lw=0.8, label="(together - alone) x 10")
                ax.set_title(f"{s} -> {c}")
                if i == len(surfaces) - 1:
                    ax.set_xlabel("lag (s)")
                if j == 0:
                    ax.set_ylabel("h (channel unit / deg)")
                ax.set_xlim(0, min(lag[-1], 30.0) if np.isfinite(lag[-1]) else None)
        handles, labels = axes[0, 0].get_legend_handles_labels()
        # one row under three panels or more; two under fewer, which it would outgrow
        ncol = len(labels) if len(channels) >= 3 else 2
        fig.legend(handles, labels, loc="outside lower center", ncol=ncol)
        fig.suptitle(f"{name}: pulse responses, probed together and one at a time")
    return fig


def draw(runs: dict[str, tuple[pd.DataFrame, dict]], figures: Path) -> list[Path]:
    """Save :func:`figure` of every run as ``<figures>/simultaneous_<name>.png``."""
    paths = []
    for name, (table, _) in runs.items():
        paths += save_figure(figure(name, table), Path(figures) / f"simultaneous_{name}")
    return paths
