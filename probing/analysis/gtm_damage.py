"""NASA's Example 6 from its stored time histories: the summary table and one figure per case.

``probing gtm-damage`` flies the cases (:func:`probing.experiment.studies.gtm_damage.run_example6`);
this module reads the Parquet files back, writes ``summary.csv`` (one row per case, case 0
the undamaged flight) and ``trim.csv`` (the turn trim every case starts from: JSBSim's turn
trim, sideslip free, and the zero-sideslip one flown) and draws
``figures/gtm_damage_case<k>.png`` with the panels of NASA's Example 6: alpha and beta,
flight-path angle and EAS, body rates, Euler angles.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.lines import Line2D

from probing.analysis.figures import RC, legends_in_margins, save_figure
from probing.experiment.output.storage import read_table
from probing.experiment.studies.gtm_damage_set import case_file
from probing.sim.flight import DAMAGE_CASES

__all__ = ["SUMMARY_VARIABLES", "UNWRAPPED", "draw", "load", "summary", "trim_table"]

#: Euler angles read back unwrapped (continuous through +-180 deg), for plots and summary.
UNWRAPPED = ("phi_deg", "psi_deg")

#: The summary's variables; each gets ``_trim`` (at onset), ``_end``, ``_min``, ``_max``
#: (after onset) columns.
SUMMARY_VARIABLES = (
    "alpha_deg",
    "beta_deg",
    "gamma_deg",
    "eas_kt",
    "p_deg_s",
    "q_deg_s",
    "r_deg_s",
    "phi_deg",
    "theta_deg",
)


def load(folder: Path) -> dict[int, tuple[pd.DataFrame, dict[str, Any]]]:
    """Case -> (time history, metadata) of every case stored in ``folder``."""
    out = {}
    for case in range(len(DAMAGE_CASES) + 1):
        path = case_file(folder, case)
        if not path.exists():
            continue
        table = read_table(path)
        meta = {
            k.decode().removeprefix("probing."): v.decode()
            for k, v in (table.schema.metadata or {}).items()
            if k.startswith(b"probing.")
        }
        meta["example6"] = json.loads(meta["example6"])
        meta["turn_trim"] = json.loads(meta["turn_trim"])
        frame = table.to_pandas()
        for angle in UNWRAPPED:  # a roll or turn through +-180 deg stays continuous
            frame[angle] = np.degrees(np.unwrap(np.radians(frame[angle].to_numpy())))
        out[case] = (frame, meta)
    return out


def summary(cases: dict[int, tuple[pd.DataFrame, dict[str, Any]]]) -> pd.DataFrame:
    """One row per case: ``case``, ``name``, and per variable its value at onset
    (``_trim``: the steady turn), at the end, and its least and greatest after onset."""
    rows = []
    for case, (ts, meta) in sorted(cases.items()):
        onset = meta["example6"]["onset_s"]
        at_onset = ts.loc[(ts["time_s"] - onset).abs().idxmin()]
        after = ts[ts["time_s"] >= onset]
        row: dict[str, Any] = {"case": case, "name": meta["case_name"]}
        for var in SUMMARY_VARIABLES:
            row[f"{var}_trim"] = float(at_onset[var])
            row[f"{var}_end"] = float(ts[var].iloc[-1])
            row[f"{var}_min"] = float(after[var].min())
            row[f"{var}_max"] = float(after[var].max())
        rows.append(row)
    return pd.DataFrame(rows)


def trim_table(cases: dict[int, tuple[pd.DataFrame, dict[str, Any]]]) -> pd.DataFrame:
    """The turn trim the flights start from, one row per trim: ``jsbsim`` (JSBSim's turn
    trim, sideslip free: where the trim starts) and ``zero sideslip`` (NASA's, flown), each
    with its attitude (deg), turn rate (deg/s), controls (deg; throttle 0..1) and the six
    accelerations left (ft/s^2, rad/s^2).

    Raises
    ------
    ValueError
        If the cases were not all flown from the same trim.
    """
    trims = [meta["turn_trim"] for _, meta in cases.values()]
    if any(t != trims[0] for t in trims):
        raise ValueError("the cases were flown from different trims")
    rows = []
    for label, key in (("jsbsim", "jsbsim"), ("zero sideslip", "trimmed")):
        state = dict(trims[0][key])
        rows.append({"trim": label, **state.pop("accelerations"), **state})
    return pd.DataFrame(rows)


PANELS = (
    ("angle of attack and sideslip (deg)", (("alpha_deg", "alpha"), ("beta_deg", "beta"))),
    ("flight-path angle (deg) and EAS (kt)", (("gamma_deg", "gamma"),)),
    ("body rates (deg/s)", (("p_deg_s", "p"), ("q_deg_s", "q"), ("r_deg_s", "r"))),
    ("Euler angles (deg; bank unwrapped)", (("phi_deg", "phi"), ("theta_deg", "theta"))),
)


def figure(case: int, cases: dict[int, tuple[pd.DataFrame, dict[str, Any]]]) -> Any:
    """The four panels of NASA's Example 6 for ``case``, the undamaged flight dotted; each
    panel's legend in a band above its curves (they fill the panels: the EAS on the right
    axis ran through the left axis's legend)."""
    ts, meta = cases[case]
    nominal = cases.get(0, (None, None))[0] if case != 0 else None
    onset = meta["example6"]["onset_s"]
    with plt.rc_context(RC):
        fig, axes = plt.subplots(2, 2, figsize=(8.0, 5.6), sharex=True, layout="constrained")
        legends = []
        for ax, (title, lines) in zip(axes.flat, PANELS, strict=True):
            handles = []
            for column, label in lines:
                (line,) = ax.plot(ts["time_s"], ts[column], label=label)
                handles.append(line)
                if nominal is not None:
                    ax.plot(
                        nominal["time_s"],
                        nominal[column],
                        color=line.get_color(),
                        lw=0.6,
                        ls=":",
                        label=f"{label}, undamaged",
                    )
            twins = []
            if title.startswith("flight-path"):
                twin = ax.twinx()
                handles += twin.plot(ts["time_s"], ts["eas_kt"], color="C3", label="EAS")
                if nominal is not None:
                    twin.plot(nominal["time_s"], nominal["eas_kt"], color="C3", lw=0.6, ls=":")
                twin.set_ylabel("EAS (kt)", color="C3")
                twin.grid(False)
                twins.append(twin)
            if nominal is not None:
                handles.append(Line2D([], [], color="0.4", lw=0.6, ls=":", label="undamaged"))
            ax.axvline(onset, color="k", lw=0.6, ls="--")
            ax.set_title(title)
            owner = twins[-1] if twins else ax  # drawn last: no curve over its legend
            legend = owner.legend(
                handles=handles, loc="upper center", ncol=len(handles), fontsize=6, frameon=False
            )
            legends.append((ax, legend, twins))
        for ax in axes[1]:
            ax.set_xlabel("time (s)")
        setup = meta["example6"]
        fig.suptitle(
            f"GTM T2, damage case {case}: {meta['case_name']} at {onset:g} s (dashed)\n"
            f"open loop from a {setup['bank_deg']:g} deg bank climbing turn trimmed at zero "
            f"sideslip, {setup['speed_keas']:g} kt EAS, gamma {setup['gamma_deg']:g} deg "
            "(NASA's Example 6); dotted: undamaged",
            fontsize=8,
        )
        legends_in_margins(legends)  # once the layout is whole
    return fig


def draw(cases: dict[int, tuple[pd.DataFrame, dict[str, Any]]], folder: Path) -> list[Path]:
    """Save ``gtm_damage_case<k>.png`` for every damage case (1..6) in ``folder``."""
    paths: list[Path] = []
    for case in sorted(c for c in cases if c != 0):
        paths += save_figure(figure(case, cases), Path(folder) / f"gtm_damage_case{case}")
    return paths
