"""What the mode and damage tables hold, without the simulator: their speeds, the pulse of
the damage table and the points (:class:`ModePoint`, :class:`DamagePoint`).

:mod:`probing.experiment.studies.modes` computes the points (trim, linearisation, pulses on JSBSim);
:mod:`probing.analysis.gtm_modes` writes them out, loading no JSBSim.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from probing.sim.modes import LongitudinalModes

__all__ = [
    "GTM_ALTITUDE_FT",
    "GTM_DT_S",
    "GTM_SPEEDS_KEAS",
    "LATERAL_PULSES",
    "PULSE_AMPLITUDE_DEG",
    "PULSE_BITS",
    "PULSE_BIT_S",
    "DamagePoint",
    "ModePoint",
]

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


@dataclass(frozen=True)
class DamagePoint:
    """The GTM trimmed level with a damage case, against the undamaged aircraft.

    Attributes
    ----------
    case : int
        0 (undamaged) or NASA's damage case 1..6; ``name`` says which.
    alpha_deg, elevator_deg, aileron_deg, rudder_deg, throttle_norm : float
        The level trim (deg; throttle 0..1); NaN when it failed (``message`` says why).
    modes : LongitudinalModes or None
        Short period and phugoid of the linearisation at that trim.
    gain, shape_error : float
        Elevator-to-pitch pulse response (one bit of ``PULSE_BIT_S``, simulated on the
        trimmed aircraft, :func:`probing.sim.truth.single_pulse_response`) against the
        undamaged one: least-squares gain and the shape error left.
    lateral : dict
        The same for the lateral probes, :data:`LATERAL_PULSES` (``"aileron"``:
        aileron-to-bank, ``"rudder"``: rudder-to-sideslip) -> (gain, shape error); NaN
        where the pulse made the damaged aircraft depart.
    """

    case: int
    name: str
    trim: str = "failed"  # "full", or "longitudinal" where the full trim had no authority
    alpha_deg: float = float("nan")
    elevator_deg: float = float("nan")
    aileron_deg: float = float("nan")
    rudder_deg: float = float("nan")
    throttle_norm: float = float("nan")
    modes: LongitudinalModes | None = None
    gain: float = float("nan")
    shape_error: float = float("nan")
    message: str = ""
    lateral: dict[str, tuple[float, float]] = field(default_factory=dict)


#: The pulse of the damage table: one bit of the paper's Fig. 4 probe (t0 = 0.01 s,
#: a = 0.005 deg), 511 bits long.
PULSE_BIT_S, PULSE_AMPLITUDE_DEG, PULSE_BITS = 0.01, 0.005, 511
#: The lateral probes of the damage table: surface -> the channel its pulse is read on.
LATERAL_PULSES = {"aileron": "phi_rad", "rudder": "beta_rad"}
