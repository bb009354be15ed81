"""What can go wrong in a simulation, as typed errors the command line turns into one line."""

from __future__ import annotations

from probing.core.errors import ProbingError

__all__ = [
    "AircraftNotFoundError",
    "CacheFolderError",
    "DivergenceError",
    "SimulatorLostError",
    "TrimError",
]


class AircraftNotFoundError(ProbingError, ValueError):
    """The aircraft is neither in the project's ``aircraft/`` nor among JSBSim's."""


class CacheFolderError(ProbingError, ValueError):
    """A cache folder that is not a folder, or cannot be read or removed (bad input)."""


class TrimError(ProbingError, RuntimeError):
    """JSBSim could not trim the aircraft at the requested condition."""


class DivergenceError(ProbingError, RuntimeError):
    """The simulation left the region where its results mean anything."""


class SimulatorLostError(ProbingError, RuntimeError):
    """The simulator process of a live flight ended mid-flight (killed, crashed): a run that
    failed; the message says when."""
