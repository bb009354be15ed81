"""Trim and longitudinal modes of an aircraft across airspeed (the table of ``docs/gtm.md``).

For each equivalent airspeed the aircraft is trimmed straight and level with the project's
one trim path (:meth:`probing.sim.plant.Plant.trim`, JSBSim's full trim, gear up), then
linearised with ``FGLinearization``; the longitudinal block (Vt, alpha, theta, q) gives the
short period and the phugoid.  ``probing modes`` writes the table and figure
(:mod:`analysis.gtm_modes`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from probing.sim.errors import TrimError
from probing.sim.linear import LongitudinalModes, longitudinal_modes
from probing.sim.plant import Plant

__all__ = ["GTM_ALTITUDE_FT", "GTM_DT_S", "GTM_SPEEDS_KEAS", "ModePoint", "mode_table"]

GTM_DT_S = 1.0 / 200.0
GTM_ALTITUDE_FT = 800.0
GTM_SPEEDS_KEAS = tuple(float(v) for v in range(60, 131, 10))


@dataclass(frozen=True)
class ModePoint:
    """Trim and longitudinal modes at one airspeed.

    Attributes
    ----------
    ve_kts : float
        Equivalent airspeed, kt.
    alpha_deg, elevator_deg, throttle_norm : float
        Trimmed angle of attack (deg), elevator (deg) and throttle (0..1).
    modes : LongitudinalModes or None
        None when the trim failed (``message`` says why).
    message : str
        The trim error, if any.
    """

    ve_kts: float
    alpha_deg: float = float("nan")
    elevator_deg: float = float("nan")
    throttle_norm: float = float("nan")
    modes: LongitudinalModes | None = None
    message: str = ""

    @property
    def trimmed(self) -> bool:
        """True when the trim succeeded."""
        return self.modes is not None


def mode_table(
    model: str = "gtm_t2",
    altitude_ft: float = GTM_ALTITUDE_FT,
    speeds_keas: Sequence[float] = GTM_SPEEDS_KEAS,
    dt_s: float = GTM_DT_S,
) -> list[ModePoint]:
    """Trim a fresh plant at each speed (KEAS) and linearise it.

    Returns
    -------
    list of ModePoint
        One per speed, in order; a failed trim gives a point without modes.
    """
    points = []
    for v in speeds_keas:
        plant = Plant(model, dt_s)
        try:
            trim = plant.trim(altitude_ft, speed_keas=v)
        except TrimError as exc:
            points.append(ModePoint(float(v), message=str(exc)))
            continue
        modes = longitudinal_modes(plant)
        points.append(
            ModePoint(
                float(v),
                alpha_deg=trim.alpha_deg,
                elevator_deg=trim.elevator_deg,
                throttle_norm=trim.throttle_norm,
                modes=modes,
            )
        )
    return points
