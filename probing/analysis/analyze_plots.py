"""The pulse-response figure of a ``bounds.parquet``: each channel's estimate with its
confidence bounds, drawn from the file alone (no simulation).  ``probing analyze`` draws it
for a record; a flight's ``bounds.parquet`` (``probing run``, ``monitor --replay``, ``live``)
draws the same way."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from probing.analysis.figures import RC, detached_figure, save_figure
from probing.experiment.output.storage import read_footer, read_table

__all__ = [
    "auto_max_lag_s",
    "bounds_figure",
    "draw_bounds",
    "per_label",
    "predicted_mean",
    "wide_band_note",
]

#: What each convention of h_est means, for the panel's title.
CONVENTION_TEXT = {
    "reference": "the response (a reference carries the baseline)",
    "baseline": "the response (the trim's output is the baseline)",
    "settled tail": "the response (constant pinned by the settled tail)",
    "zero mean": "response less sum(h)/M: tail not settled",
    "ac": "response less sum(h)/(M+1) (ac estimator)",
}
#: What the prediction drawn with the estimate is (prediction.parquet).
PREDICTION_LABEL = "truth: the single pulse's probing output, linear (no nonlinearity)"
#: The automatic zoom shows the lag up to this multiple of the last tap that stands out.
ZOOM_MARGIN = 1.5
#: A tap stands out where |h| exceeds its bound's half-width and this share of the peak.
ZOOM_SHARE = 0.02
#: The automatic zoom applies when it would show at most this share of the period.
ZOOM_WHEN = 0.5
#: A band wider than its estimate is *flat* when its largest half-width over the lags drawn
#: is at most this multiple of its smallest: the periods then differ by a level.
FLAT_BAND = 1.25


def per_label(unit: str) -> str:
    """``rad/s/deg`` -> ``rad/s per deg``: the last ``/`` is "per unit of probe".

    Examples
    --------
    >>> per_label("rad/s/deg"), per_label("rad/deg"), per_label("m")
    ('rad/s per deg', 'rad per deg', 'm')
    """
    if "/" not in unit:
        return unit
    num, den = unit.rsplit("/", 1)
    return f"{num} per {den}"


def auto_max_lag_s(lag_s: np.ndarray, h: np.ndarray, half_width: np.ndarray) -> float | None:
    """The lag to zoom to when the response is short against the period, else None.

    The last tap where |h| stands out (above its bound's half-width and :data:`ZOOM_SHARE` of
    the peak), times :data:`ZOOM_MARGIN`; None when that is more than :data:`ZOOM_WHEN` of
    the period (the whole period is shown).

    Parameters
    ----------
    lag_s : numpy.ndarray
        Lag of each tap (s), shape (M,).
    h, half_width : numpy.ndarray
        Shape (C, M): the estimates and their bounds' half-widths (unit of h).
    """
    peak = np.nanmax(np.abs(h), axis=1, keepdims=True)
    out = (np.abs(h) > np.maximum(np.nan_to_num(half_width), ZOOM_SHARE * peak)).any(axis=0)
    if not out.any():
        return None
    last = lag_s[np.flatnonzero(out)[-1]]
    span = float(lag_s[-1] + (lag_s[1] - lag_s[0] if lag_s.size > 1 else 0.0))
    want = max(ZOOM_MARGIN * float(last), 10 * float(lag_s[1] - lag_s[0]))
    return want if want <= ZOOM_WHEN * span else None


def wide_band_note(h: np.ndarray, half_width: np.ndarray) -> str | None:
    """Why a channel's band is wider than its estimate, for its panel; None when it is not.

    The band is wide when its half-width, at the median over the lags drawn, is more than
    the largest |h| there: a newcomer reads it as a failed estimate.  A flat wide band
    (largest half-width at most :data:`FLAT_BAND` times the smallest) is the periods'
    estimates differing by a level, not a shape: a mode slower than the period folds its
    tail into every tap and moves from period to period (the GTM's phugoid, docs/fig4.md),
    while the shape holds.

    Parameters
    ----------
    h, half_width : numpy.ndarray
        Shape (M,), over the lags drawn: the estimate and its bound's half-width (unit of h).

    Returns
    -------
    str or None
        The note, or None.
    """
    half = np.nan_to_num(half_width)
    if h.size == 0 or not np.median(half) > np.nanmax(np.abs(h)):
        return None
    if half.max() <= FLAT_BAND * half.min():
        return (
            "band wide and flat: the periods differ by a level, not a shape\n"
            "(a mode slower than the period folds in: docs/fig4.md)"
        )
    return "band wider than the estimate: the periods disagree by more than the response"


def _meta(meta: dict[bytes, bytes], key: str) -> dict:
    raw = meta.get(f"probing.{key}".encode())
    return json.loads(raw) if raw else {}


def draw_bounds(bounds: Path, stem: Path, max_lag_s: float | None = None) -> Path:
    """Draw ``bounds.parquet``'s h_est and its interval per channel into ``<stem>.png``.

    Parameters
    ----------
    bounds : pathlib.Path
        A ``bounds.parquet`` written by ``probing analyze`` or by a flight.
    stem : pathlib.Path
        The figure's path without ``.png``.
    max_lag_s : float, optional
        The last lag shown (s); None: the whole period, or the lag the response stands out
        to (:func:`auto_max_lag_s`) when that is short against the period; the figure says
        which.

    Returns
    -------
    pathlib.Path
        The PNG written (the same bounds give the same bytes).
    """
    figure = bounds_figure(read_table(bounds).to_pandas(), read_footer(bounds), max_lag_s)
    return save_figure(figure, stem)[0]


def bounds_figure(
    table: pd.DataFrame,
    meta: dict[bytes, bytes],
    max_lag_s: float | None = None,
    prediction: pd.DataFrame | None = None,
    settle_periods: int | None = None,
) -> Figure:
    """The figure of a ``bounds.parquet``: each channel's h_est and its interval.

    Parameters
    ----------
    table : pandas.DataFrame
        The file's rows (channel, lag_s, h_est, h_low, h_high).
    meta : dict
        The file's key-value metadata (its confidence, units, conventions, source).
    max_lag_s : float, optional
        As for :func:`draw_bounds`.
    prediction : pandas.DataFrame, optional
        A ``prediction.parquet`` (the probing output the single-pulse truth predicts): its
        h_est averaged over the periods from ``settle_periods`` on is drawn too.
    settle_periods : int, optional
        The periods the prediction's average leaves out (None: none).

    Returns
    -------
    matplotlib.figure.Figure
    """
    conf = _meta(meta, "confidence")
    source = _meta(meta, "input").get("file") or _meta(meta, "scenario").get("name") or "?"
    units = _meta(meta, "units").get("h_est", {})
    conventions = _meta(meta, "convention").get("h_est", {})
    channels = list(dict.fromkeys(table["channel"]))
    rows = {c: table[table["channel"] == c] for c in channels}
    lag = rows[channels[0]]["lag_s"].to_numpy()
    h = np.array([rows[c]["h_est"].to_numpy() for c in channels])
    half = np.array([(rows[c]["h_high"] - rows[c]["h_low"]).to_numpy() / 2 for c in channels])
    period_s = float(lag[-1] + (lag[1] - lag[0]))
    zoom = auto_max_lag_s(lag, h, half) if max_lag_s is None else None
    right = max_lag_s if max_lag_s is not None else zoom if zoom is not None else period_s
    dof = conf.get("dof")
    periods = {c: (dof[c] if isinstance(dof, dict) else dof) for c in channels}
    # made before the style's context: a notebook's backend, loaded by the first figure,
    # turns interactive mode on, which the context would turn off again on its way out
    shown = lag <= right
    notes = {c: wide_band_note(h[i][shown], half[i][shown]) for i, c in enumerate(channels)}
    lines = sum(note.count("\n") + 1 for note in notes.values() if note)  # taller titles
    height = 2.3 * len(channels) + 0.5 + 0.2 * lines
    fig = detached_figure(figsize=(6.0, height), layout="constrained")
    with plt.rc_context(RC):
        axes = fig.subplots(len(channels), 1, squeeze=False)
        for ax, channel in zip(axes[:, 0], channels, strict=True):
            r = rows[channel]
            ax.fill_between(
                lag,
                r["h_low"].to_numpy(),
                r["h_high"].to_numpy(),
                color="C0",
                alpha=0.3,
                linewidth=0,
                label=f"{conf.get('level', 0.95):.0%} Student-t bounds of the mean",
            )
            ax.plot(lag, r["h_est"].to_numpy(), color="C0", label="h_est, mean over periods")
            if prediction is not None:
                truth = predicted_mean(prediction, channel, settle_periods or 0, len(lag))
                ax.plot(lag, truth, "k--", lw=1.0, label=PREDICTION_LABEL)
            ax.axhline(0.0, color="0.5", linewidth=0.5)
            unit = units.get(channel) if isinstance(units, dict) else None
            ax.set_ylabel(per_label(unit) if unit else f"{channel} per probe unit")
            ax.set_xlim(0.0, right)
            n = periods.get(channel)
            what = CONVENTION_TEXT.get(conventions.get(channel, ""), "")
            note = notes[channel]
            ax.set_title(
                f"{channel}" + (f" ({n + 1} periods)" if isinstance(n, int) else "")
                + (f": {what}" if what else "") + (f"\n{note}" if note else ""),
                loc="left",
            )  # fmt: skip
        if max_lag_s is not None:
            lag_note = f"lag (s): 0-{max_lag_s:g} s shown of the period's {period_s:g} s"
        elif zoom is not None:
            lag_note = f"lag (s): zoomed to 0-{zoom:.3g} s of the period's {period_s:g} s"
        else:
            lag_note = "lag (s)"
        axes[-1, 0].set_xlabel(lag_note)
        fig.suptitle(f"pulse response from {source}", fontsize=RC["axes.titlesize"])
        handles, labels = axes[0, 0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncols=2, frameon=False)
    return fig


def predicted_mean(
    prediction: pd.DataFrame, channel: str, settle_periods: int, m: int
) -> np.ndarray:
    """The mean h_est of a ``prediction.parquet`` over one channel's periods from
    ``settle_periods`` on, by tap, shape (m,): what the single-pulse truth predicts the
    settled estimate to be."""
    rows = prediction[(prediction["channel"] == channel) & (prediction["period"] >= settle_periods)]
    h = rows.sort_values(["period", "tap"])["h_est"].to_numpy().reshape(-1, m)
    return h.mean(axis=0)
