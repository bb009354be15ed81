"""The flight computer's model of its aircraft, flown through the gust it estimates.

A :class:`GustTwin` is the nominal aircraft in calm air, loaded gust-ready
(:func:`probing.sim.aircraft.sanitised_root`), flying its own autopilot.  Before each step
it is given the wind (north, east, down: JSBSim's ``atmosphere/wind-*-fps``) and the
rotational gusts (body p, q, r) that :class:`probing.core.gust.GustEstimator` estimated from
the aircraft's measurements, and the aircraft's measured roll rate, which its roll-gust
observer tracks.  It knows nothing of the simulated atmosphere: it is built from a flight
in calm air, and everything it is given comes from the sensors.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from probing.sim.aircraft import GUST_INPUTS
from probing.sim.control import ClosedLoop, ControlPower
from probing.sim.flight import Control, Flight
from probing.sim.plant import Plant, make_plant

__all__ = ["WIND_PROPERTIES", "GustTwin"]

#: The steady wind JSBSim adds to its turbulence, north-east-down, ft/s.
WIND_PROPERTIES = tuple(f"atmosphere/wind-{d}-fps" for d in ("north", "east", "down"))


class GustTwin:
    """The nominal aircraft in calm air, gust-ready, flown by its own autopilot.

    Parameters
    ----------
    flight : Flight
        The nominal flight in calm air (``turbulence = "none"``, no damage).
    control : Control
        The autopilot it flies (the aircraft's).
    power : ControlPower
        The aircraft's control power at the trim (:func:`probing.sim.control.control_power`).
    channels : sequence of str
        The output channels it hands back.
    plant : Plant, optional
        The gust-ready aircraft, trimmed and undisturbed at ``flight`` (a copy forked from
        one loaded once, :meth:`probing.sim.fork.TrimmedAircraft.second_for`); None loads
        and trims one.

    Raises
    ------
    ValueError
        If the flight has turbulence or damage: the twin must know neither.
    """

    def __init__(
        self,
        flight: Flight,
        control: Control,
        power: ControlPower | None,
        channels: Sequence[str],
        plant: Plant | None = None,
    ) -> None:
        if flight.turbulence != "none" or flight.damage_case:
            raise ValueError("a gust twin flies the nominal aircraft in calm air")
        if plant is not None and not plant.gust_inputs:
            raise ValueError("a gust twin flies the gust-ready copy of the aircraft")
        self.plant = plant if plant is not None else make_plant(flight, gust_inputs=True)
        fdm = self.plant.fdm
        #: The wing span, ft (the gust estimator's b).
        self.span_ft = float(fdm["metrics/bw-ft"])
        self.loop = ClosedLoop(self.plant, control, power)
        self.nodes = self.plant.channel_nodes(list(channels))
        pm = fdm.get_property_manager()
        names = [
            *WIND_PROPERTIES,
            *(GUST_INPUTS[f"{a}_gust_rad_s"] for a in "pqr"),
            GUST_INPUTS["p_measured_rad_s"],
            GUST_INPUTS["phi_measured_rad"],
        ]
        self.inputs = [pm.get_node(name) for name in names]
        fdm[GUST_INPUTS["observer_on"]] = 1.0

    def next(
        self,
        wind_fps: np.ndarray,
        rates_rad_s: np.ndarray,
        p_measured: np.ndarray,
        phi_measured: np.ndarray,
    ) -> np.ndarray:
        """Fly the next ``n`` steps; the outputs after each, ``(n, channels)``.

        Parameters
        ----------
        wind_fps : numpy.ndarray
            ``(n, 3)``: the wind during each step, north-east-down, ft/s.
        rates_rad_s : numpy.ndarray
            ``(n, 3)``: the rotational gusts during each step, body p, q, r, rad/s.
        p_measured : numpy.ndarray
            ``(n,)``: the aircraft's measured roll rate the observer compares with the
            twin's before each step (the measurement after the previous step), rad/s.
        phi_measured : numpy.ndarray
            ``(n,)``: the aircraft's measured bank angle, likewise, rad.

        Raises
        ------
        probing.sim.errors.DivergenceError
            If the twin leaves the meaningful region.
        """
        values = np.column_stack([wind_fps, rates_rad_s, p_measured, phi_measured])
        out = np.empty((values.shape[0], len(self.nodes)))
        self.loop.step(None, self.nodes, out, inputs=(self.inputs, values))
        self.plant.check_state()
        return out
