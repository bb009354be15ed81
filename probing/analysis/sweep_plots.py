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

The figures are drawn by family: :mod:`probing.analysis.sweep_gain` (nonlinearity, rate limit,
other), :mod:`probing.analysis.sweep_noise` (noise, seeds) and :mod:`probing.analysis.sweep_grid`
(flight grid), on the data of :mod:`probing.analysis.sweep_data` and the panels of
:mod:`probing.analysis.sweep_axes`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt

from probing.analysis.figures import RC, lift_legends, save_figure
from probing.analysis.sweep_data import KINDS, NotASweepError, SweepData, classify, load_sweep_data
from probing.analysis.sweep_gain import plot_nonlinearity, plot_other, plot_rate_limit, theory_curve
from probing.analysis.sweep_grid import plot_flight_grid
from probing.analysis.sweep_noise import plot_noise, plot_seeds

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

DPI = 200  # of the PNG
FORMATS = ("png", "pdf")  # files written per figure


_DRAW = {
    "seeds": plot_seeds,
    "nonlinearity": plot_nonlinearity,
    "rate_limit": plot_rate_limit,
    "noise": plot_noise,
    "flight_grid": plot_flight_grid,
    "other": plot_other,
}


# ------------------------------------------------------------------ entry points
def sweep_figure(data: SweepData) -> Any:
    """The figure of a sweep, laid out by :func:`classify` (close it, or :func:`plot_sweep`);
    a legend that would hide data is lifted above the curves."""
    with plt.rc_context(RC):
        fig = _DRAW[classify(data)](data)
        lift_legends(fig)
    return fig


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
