"""What NASA's Example 6 flies and stores, without the simulator: the set-up
(:class:`Example6`), the recorded signals (:data:`SIGNALS`), the Parquet layout and where
each case's file lies (:func:`case_file`).

:mod:`probing.experiment.studies.gtm_damage` flies the cases on JSBSim;
:mod:`probing.analysis.gtm_damage`
reads them back, loading no JSBSim.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa

from probing.experiment.output.storage import field

__all__ = ["EXAMPLE6", "SCHEMA", "SIGNALS", "Example6", "case_file"]

DEG = 180.0 / math.pi


@dataclass(frozen=True)
class Example6:
    """The set-up of NASA's Example 6 (``example6.m``): trim and timing.

    Attributes
    ----------
    altitude_ft, speed_keas, gamma_deg, bank_deg : float
        Trim: altitude (ft), equivalent airspeed (kt), flight-path angle and bank (deg).
    onset_s, end_s, dt_s : float
        Damage onset and end of the run after the trim, and the step (s).
    """

    altitude_ft: float = 800.0
    speed_keas: float = 95.0
    gamma_deg: float = 3.0
    bank_deg: float = 45.0
    onset_s: float = 10.0
    end_s: float = 15.0
    dt_s: float = 1.0 / 200.0


EXAMPLE6 = Example6()

#: Recorded signals: column -> (JSBSim property, factor to the column's unit, description).
SIGNALS: dict[str, tuple[str, float, str]] = {
    "alpha_deg": ("aero/alpha-deg", 1.0, "angle of attack"),
    "beta_deg": ("aero/beta-deg", 1.0, "sideslip angle"),
    "gamma_deg": ("flight-path/gamma-deg", 1.0, "flight-path angle"),
    "eas_kt": ("velocities/ve-kts", 1.0, "equivalent airspeed"),
    "p_deg_s": ("velocities/p-rad_sec", DEG, "body roll rate"),
    "q_deg_s": ("velocities/q-rad_sec", DEG, "body pitch rate"),
    "r_deg_s": ("velocities/r-rad_sec", DEG, "body yaw rate"),
    "phi_deg": ("attitude/phi-deg", 1.0, "bank angle"),
    "theta_deg": ("attitude/theta-deg", 1.0, "pitch angle"),
    "psi_deg": ("attitude/psi-deg", 1.0, "heading"),
    "altitude_ft": ("position/h-sl-ft", 1.0, "altitude above sea level"),
}


def _unit(column: str) -> str:
    return {"deg": "deg", "kt": "kt", "deg_s": "deg/s", "ft": "ft"}[column.split("_", 1)[1]]


SCHEMA = pa.schema(
    [field("time_s", pa.float64(), "s", "time after the trim")]
    + [field(c, pa.float64(), _unit(c), d) for c, (_, _, d) in SIGNALS.items()]
)


def case_file(folder: Path, case: int) -> Path:
    """The Parquet time history of ``case`` in ``folder``."""
    return Path(folder) / f"case{case}.parquet"
