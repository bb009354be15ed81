"""Load and trim once, step many times: forked copies of a trimmed aircraft.

Loading a model and trimming it cost more than stepping a short run (the GTM: 0.1-0.25 s to
load, 0.085 s for 4,600 steps).  JSBSim cannot copy or restore its whole state (integrator
histories, filter states, the random generator), but the operating system can: a process
that has loaded and trimmed an aircraft forks one child per run, and each child starts
from the identical trimmed state, byte for byte in memory.  A run in a child is therefore
bit-identical to a run that loaded and trimmed for itself, and the parent never steps, so
it stays trimmed (and its memory flat) however many children it forks.

* :func:`trim_key` says which flights share a trimmed state (model and its files,
  condition, step, JSBSim version, the plant's code); turbulence and seed do not enter, a
  child applies them (:meth:`probing.sim.plant.Plant.disturb`).
* :class:`TrimmedAircraft` is the parent's trimmed plant.
* :func:`probing.core.forked.forked_map` forks the children.
"""

from __future__ import annotations

import functools
import hashlib
import json
from pathlib import Path

from probing.sim import drive as _drive_module
from probing.sim import plant as _plant_module
from probing.sim import turn_trim as _turn_trim_module
from probing.sim.aircraft import aircraft_digest, jsbsim_version
from probing.sim.flight import Flight
from probing.sim.plant import Plant, trim_flight

__all__ = ["TrimmedAircraft", "trim_key", "trim_spec"]


@functools.cache
def _plant_source() -> str:
    """SHA-256 of the code a trim's numbers come from: the plant, its surface drive and the
    turn trim at zero sideslip."""
    digest = hashlib.sha256()
    for module in (_plant_module, _drive_module, _turn_trim_module):
        digest.update(Path(module.__file__).read_bytes())
    return digest.hexdigest()


def trim_spec(flight: Flight) -> dict:
    """The flight's trim as plain JSON-able values: model and the digest of its files,
    altitude (ft), speed kind and value (kt or Mach), dt (s), JSBSim version."""
    return {
        "model": flight.model,
        "aircraft_sha256": aircraft_digest(flight.model),
        "altitude_ft": float(flight.altitude_ft),
        "speed_kind": flight.speed_kind,
        "speed": float(flight.speed),
        "dt_s": float(flight.dt_s),
        "jsbsim": jsbsim_version(),
        # damage and a climb or turn change the trim; a straight-and-level undamaged flight
        # keeps the keys it had before they existed
        **{
            k: v
            for k, v in (
                ("damage_case", flight.trimmed_damage),
                ("gamma_deg", float(flight.gamma_deg)),
                ("bank_deg", float(flight.bank_deg)),
            )
            if v
        },
    }


def trim_key(flight: Flight) -> str:
    """SHA-256 (hex) of what the trimmed state depends on, and nothing else.

    Parameters
    ----------
    flight : Flight
        The flight; its turbulence and seed are left out (the trim does not depend on them).

    Returns
    -------
    str
        Equal for two flights exactly when one trimmed aircraft serves both: model name
        and the digest of its files, altitude (ft), speed kind and value, dt (s), the
        JSBSim version and the digest of the plant's code.
    """
    spec = {**trim_spec(flight), "plant_sha256": _plant_source()}
    text = json.dumps(spec, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


class TrimmedAircraft:
    """An aircraft loaded and trimmed once, for children to fork from.

    Parameters
    ----------
    flight : Flight
        Model, condition and step; turbulence and seed are applied in each child by
        :meth:`plant_for`.

    Raises
    ------
    probing.sim.errors.TrimError, probing.sim.errors.AircraftNotFoundError
        As :func:`probing.sim.plant.make_plant`.
    """

    def __init__(self, flight: Flight) -> None:
        self.key = trim_key(flight)
        self._condition = _condition(flight)
        self._flight = flight
        self.plant = Plant(flight.model, flight.dt_s)
        trim_flight(self.plant, flight)
        #: The second copies, by whether they take gust inputs.
        self.seconds: dict[bool, Plant] = {}

    def add_second(self, gust_inputs: bool = False) -> None:
        """Load and trim a second copy (once, in the owner, before forking), undamaged: the
        nominal twin that flies a run's own commands (``drift = "follow"``) or, with
        ``gust_inputs`` (:func:`probing.sim.aircraft.sanitised_root`), the gust it estimates
        (``drift = "gust"``) steps it in the child."""
        if gust_inputs not in self.seconds:
            second = Plant(self._flight.model, self._flight.dt_s, gust_inputs=gust_inputs)
            trim_flight(second, self._flight)
            self.seconds[gust_inputs] = second

    def second_for(self, flight: Flight, gust_inputs: bool = False) -> Plant | None:
        """The second copy, disturbed as ``flight`` asks and undamaged (None without one):
        call it in a child only."""
        second = self.seconds.get(gust_inputs)
        if second is None:
            return None
        if _condition(flight) != self._condition:
            raise ValueError(f"{flight.condition} is not the trimmed aircraft's flight")
        second.disturb(flight.turbulence, flight.seed)
        second.schedule(flight.nominal)
        return second

    def plant_for(self, flight: Flight) -> Plant:
        """The trimmed plant, disturbed as ``flight`` asks: call it in a child only.

        Raises
        ------
        ValueError
            If ``flight`` needs another trimmed state (:func:`trim_key` differs).
        """
        if _condition(flight) != self._condition:
            raise ValueError(f"{flight.condition} is not the trimmed aircraft's flight")
        self.plant.disturb(flight.turbulence, flight.seed)
        self.plant.schedule(flight)
        return self.plant


def _condition(flight: Flight) -> tuple:
    """The parts of :func:`trim_key` that a flight sets (the rest is the same in a process)."""
    return (
        flight.model,
        flight.altitude_ft,
        flight.speed_kind,
        flight.speed,
        flight.dt_s,
        flight.trimmed_damage,
        flight.gamma_deg,
        flight.bank_deg,
    )
