"""The figure of a simultaneous run (``probing plot simultaneous``), from a small synthetic
table shaped like the 737's aileron and rudder runs: no simulation."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from probing.analysis import simultaneous
from probing.analysis.figure_checks import figure_problems


def _table() -> pd.DataFrame:
    """Two surfaces, two channels; the roll rate's response to the aileron settles at 0 after
    a sharp dip, so its curves and the (together - alone) x 10 line run along the top of the
    panel, where the legend used to sit."""
    lag = np.arange(300) * 0.1
    rows = []
    for k, surface in enumerate(("aileron", "rudder")):
        for j, channel in enumerate(("p_rad_s", "r_rad_s")):
            h = -(6 - k - 2 * j) * 1e-3 * np.exp(-lag / (0.5 + j)) + 1e-4 * np.exp(-lag / 10)
            rows.append(
                pd.DataFrame(
                    {
                        "surface": surface,
                        "channel": channel,
                        "lag_s": lag,
                        "h_lin": h,
                        "h_alone": h * 1.01,
                        "h_est": h * 1.01 + 1e-6,
                    }
                )
            )
    return pd.concat(rows, ignore_index=True)


def test_figure_plots_the_table() -> None:
    table = _table()
    fig = simultaneous.figure("shift-737", table)
    ax = fig.axes[0]
    assert ax.get_title() == "aileron -> p_rad_s"
    rows = table[(table.surface == "aileron") & (table.channel == "p_rad_s")]
    lines = {line.get_label(): line for line in ax.get_lines()}
    np.testing.assert_allclose(lines["probed together"].get_ydata(), rows.h_est)
    np.testing.assert_allclose(
        lines["(together - alone) x 10"].get_ydata(), 10 * (rows.h_est - rows.h_alone)
    )
    plt.close(fig)


def test_legend_hides_no_curve_and_no_text_is_clipped() -> None:
    """The legend used to sit in the upper right of the first panel, over its curves."""
    fig = simultaneous.figure("shift-737", _table())
    assert figure_problems(fig) == []
    plt.close(fig)
