"""The GTM mode figure (``figures/gtm_modes.png``) from a made-up mode table: no simulation.

The figure is checked by what it shows: the data read back from its axes must be the
table's numbers, each in its own panel, the failed trim left out, and sqrt(2) g/V computed
here in SI units.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pytest

from probing.analysis import gtm_modes
from probing.experiment.studies.modes import ModePoint
from probing.sim.linear import LongitudinalModes

G_M_S2 = 9.80665
KT_M_S = 1852.0 / 3600.0

#: KEAS -> (sp_wn, sp_zeta, ph_wn, ph_zeta): every number different, so a panel that drew
#: another column (or another point) cannot match.
TABLE = {
    60.0: (4.31, 0.421, 0.412, 0.061),
    70.0: (5.07, 0.437, 0.353, 0.087),
    90.0: (7.93, 0.449, 0.274, 0.123),
    130.0: (11.52, 0.463, 0.191, 0.178),
}
FAILED_KEAS = 80.0


def _points() -> list[ModePoint]:
    points = [
        ModePoint(v, alpha_deg=5.0 - v / 100, modes=LongitudinalModes(*modes))
        for v, modes in TABLE.items()
    ]
    points.insert(2, ModePoint(FAILED_KEAS, message="trim failed: Trim Failed"))
    return points


def test_each_panel_plots_its_column_against_airspeed() -> None:
    fig = gtm_modes.figure(_points())
    axes = np.array(fig.axes).reshape(2, 2)
    v = np.array(list(TABLE))
    columns = np.array(list(TABLE.values()))  # sp_wn, sp_zeta, ph_wn, ph_zeta
    panels = {(0, 0): 0, (1, 0): 1, (0, 1): 2, (1, 1): 3}
    for (row, col), k in panels.items():
        lines = axes[row, col].get_lines()
        assert len(lines) == (2 if (row, col) == (0, 1) else 1)  # + sqrt(2) g/V
        assert lines[0].get_marker() == "o"
        data = np.asarray(lines[0].get_xydata(), dtype=float)
        np.testing.assert_array_equal(data[:, 0], v)  # the failed 80 kt trim is left out
        np.testing.assert_array_equal(data[:, 1], columns[:, k])
    plt.close(fig)


def test_the_phugoid_reference_is_sqrt2_g_over_v() -> None:
    fig = gtm_modes.figure(_points())
    ax = np.array(fig.axes).reshape(2, 2)[0, 1]
    (ref,) = [ln for ln in ax.get_lines() if "g/V" in ln.get_label()]
    x, y = np.asarray(ref.get_xdata(), float), np.asarray(ref.get_ydata(), float)
    np.testing.assert_array_equal(x, list(TABLE))
    np.testing.assert_allclose(y, math.sqrt(2) * G_M_S2 / (x * KT_M_S), rtol=1e-5)
    plt.close(fig)


def test_axes_labels_carry_units() -> None:
    """Every frequency in rad/s, the damping ratios dimensionless; and the figure reads (the
    phugoid panel's legend named its approximation, not the JSBSim curve)."""
    from probing.analysis.figure_checks import figure_problems

    fig = gtm_modes.figure(_points())
    assert figure_problems(fig) == []
    axes = np.array(fig.axes).reshape(2, 2)
    for ax in axes[1]:
        assert ax.get_xlabel() == "equivalent airspeed (kt)"
    for ax in axes[0]:
        assert ax.get_ylabel().endswith("$\\omega_n$ (rad/s)")
    for ax in axes[1]:  # damping ratios: dimensionless
        assert ax.get_ylabel().endswith("$\\zeta$")
    assert [ax.get_ylabel().split()[0] for ax in axes.flat] == [
        "short",
        "phugoid",
        "short",
        "phugoid",
    ]
    plt.close(fig)


def test_save_writes_the_figure(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``probing modes`` saves this figure (``save``): the one saved shows the table."""
    drawn = []
    real = gtm_modes.save_figure

    def spy(fig: Any, *args: Any, **kwargs: Any) -> list[Path]:
        drawn.append(fig)
        return real(fig, *args, **kwargs)

    monkeypatch.setattr(gtm_modes, "save_figure", spy)
    (path,) = gtm_modes.save(_points(), tmp_path / "gtm_modes")
    assert path == tmp_path / "gtm_modes.png" and path.read_bytes().startswith(b"\x89PNG")
    (fig,) = drawn
    data = np.asarray(fig.axes[0].get_lines()[0].get_xydata(), dtype=float)
    np.testing.assert_array_equal(data, [[v, m[0]] for v, m in TABLE.items()])
