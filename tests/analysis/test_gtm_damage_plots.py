"""The figures of NASA's Example 6 (``probing gtm-damage``), drawn from made-up time
histories: no simulation."""

from __future__ import annotations

from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from probing.analysis import gtm_damage
from probing.analysis.figure_checks import figure_problems

ONSET_S = 10.0


def _flight(damaged: bool) -> pd.DataFrame:
    """15 s of a turn; damaged, as case 1: the flight-path angle climbs after the onset and
    the EAS, steady near the top of its axis, falls (it ran through the left axis's legend,
    which loc="best" put at the upper left, where the flight-path angle is low)."""
    t = np.linspace(0.0, 15.0, 301)
    after = np.clip(t - ONSET_S, 0.0, None) if damaged else 0.0 * t
    wobble = np.sin(6.0 * after) * np.exp(-after)
    return pd.DataFrame(
        {
            "time_s": t,
            "alpha_deg": 4.7 - 0.1 * wobble,
            "beta_deg": 0.2 * wobble,
            "gamma_deg": 3.0 - 0.01 * t + 0.13 * after**2,
            "eas_kt": 95.0 - 0.01 * t - 0.07 * after**2,
            "p_deg_s": -1.2 - 3.0 * wobble - 0.5 * after,
            "q_deg_s": 7.9 - 0.5 * after,
            "r_deg_s": 7.9 - 0.4 * after + wobble,
            "phi_deg": 45.0 - 2.6 * after,
            "theta_deg": 6.3 + 0.15 * after**2,
        }
    )


def _cases() -> dict[int, tuple[pd.DataFrame, dict[str, Any]]]:
    meta = {
        "example6": {"onset_s": ONSET_S, "bank_deg": 45.0, "speed_keas": 95.0, "gamma_deg": 3.0},
    }
    return {
        0: (_flight(False), {**meta, "case_name": "undamaged"}),
        1: (_flight(True), {**meta, "case_name": "rudder off"}),
    }


def test_no_legend_hides_a_curve_and_every_curve_is_named() -> None:
    """Each panel's legend lies above its curves, the right axis's EAS included; the dotted
    undamaged curves are named by one entry; the onset line stops under the legend."""
    fig = gtm_damage.figure(1, _cases())
    assert figure_problems(fig) == []
    eas_axis = fig.axes[4]
    assert [t.get_text() for t in eas_axis.get_legend().get_texts()] == [
        "gamma",
        "EAS",
        "undamaged",
    ]
    plt.close(fig)
