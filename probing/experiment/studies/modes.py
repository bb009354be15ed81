"""Trim and longitudinal modes of an aircraft across airspeed (the table of ``docs/gtm.md``).

For each equivalent airspeed the aircraft is trimmed straight and level with the project's
one trim path (:meth:`probing.sim.plant.Plant.trim`, JSBSim's full trim, gear up), then
linearised with ``FGLinearization``; the longitudinal block (Vt, alpha, theta, q) gives the
short period and the phugoid.  ``probing modes`` writes the table and figure
(:mod:`probing.analysis.gtm_modes`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from probing.core.metrics import gain_and_shape
from probing.experiment.studies.modes_set import (
    GTM_ALTITUDE_FT,
    GTM_DT_S,
    GTM_SPEEDS_KEAS,
    LATERAL_PULSES,
    PULSE_AMPLITUDE_DEG,
    PULSE_BIT_S,
    PULSE_BITS,
    DamagePoint,
    ModePoint,
)
from probing.sim.errors import DivergenceError, TrimError
from probing.sim.flight import DAMAGE_CASES, DAMAGE_MODEL, Flight
from probing.sim.linear import longitudinal_modes
from probing.sim.plant import Plant, make_plant
from probing.sim.truth import single_pulse_response

__all__ = [
    "GTM_ALTITUDE_FT",
    "GTM_DT_S",
    "GTM_SPEEDS_KEAS",
    "DamagePoint",
    "ModePoint",
    "damage_table",
    "mode_table",
]


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


def damage_table(
    altitude_ft: float = GTM_ALTITUDE_FT, speed_keas: float = 75.0, dt_s: float = GTM_DT_S
) -> list[DamagePoint]:
    """Trim the GTM level with each damage case (and without), linearise it, and simulate its
    elevator-to-pitch pulse response: what a monitor would have to detect (``docs/gtm.md``)."""
    points, reference = [], None
    lateral_reference: dict[str, np.ndarray] = {}
    for case in range(len(DAMAGE_CASES) + 1):
        name = "undamaged" if case == 0 else DAMAGE_CASES[case - 1]
        flight = Flight(DAMAGE_MODEL, altitude_ft, "speed_keas", speed_keas, dt_s, damage_case=case)
        try:
            plant = make_plant(flight)
        except TrimError as exc:
            points.append(DamagePoint(case, name, message=str(exc)))
            continue
        fdm = plant.fdm
        trim = plant.trim_result
        modes = longitudinal_modes(plant)
        steps_per_bit = round(PULSE_BIT_S / dt_s)
        try:
            h = single_pulse_response(
                flight, ["theta_rad"], PULSE_AMPLITUDE_DEG, steps_per_bit, PULSE_BITS
            )["theta_rad"]
        except DivergenceError:  # departs within the pulse response (vertical tail off)
            h = None
        if case == 0:
            reference = h
        gain, shape = (math.nan,) * 2
        if h is not None and reference is not None:
            gain, shape = gain_and_shape(h, reference)
        lateral = {}
        for surface, channel in LATERAL_PULSES.items():
            lateral_flight = dataclasses.replace(flight, surface=surface)
            try:
                h_lat = single_pulse_response(
                    lateral_flight, [channel], PULSE_AMPLITUDE_DEG, steps_per_bit, PULSE_BITS
                )[channel]
            except DivergenceError:
                lateral[surface] = (math.nan, math.nan)
                continue
            if case == 0:
                lateral_reference[surface] = h_lat
            lateral[surface] = gain_and_shape(h_lat, lateral_reference[surface])
        points.append(
            DamagePoint(
                case,
                name,
                trim=trim.mode,
                alpha_deg=trim.alpha_deg,
                elevator_deg=trim.elevator_deg,
                aileron_deg=float(fdm["fcs/right-aileron-pos-deg"]),
                rudder_deg=float(fdm["fcs/rudder-pos-deg"]),
                throttle_norm=trim.throttle_norm,
                modes=modes,
                gain=gain,
                shape_error=shape,
                lateral=lateral,
            )
        )
    return points
