"""The public Python API (docs/api.md): scenarios in, :class:`Flight` results out, as
``import probing`` exposes them.  The command line (:mod:`probing.cli`) is a thin layer over
it: ``probing run`` is ``fly(...).save(...)``."""

from probing.api.calls import analyze, example, example_path, fly, load, read, replay
from probing.api.flight import Flight
from probing.api.studies import Recommendation, check_simultaneous, design, fly_sweep
from probing.core.errors import ArgumentError, ProbingError
from probing.experiment.design.design import DesignError, DesignInputError
from probing.experiment.flight.monitor import ReplayError
from probing.experiment.output.storage import OutputPathError, StoredFileError
from probing.experiment.recorded.record import RecordError
from probing.experiment.scenario import Scenario, ScenarioError
from probing.experiment.studies.simultaneous import SeparationError
from probing.sim.errors import AircraftNotFoundError, DivergenceError, TrimError
from probing.sweep import SchedulerError, SweepBusyError

#: Written out for type checkers, which read a literal ``__all__`` only; ``probing.API``
#: holds the same names for ``import probing``, which must not import this package
#: (tests/api/test_api.py checks that the two agree).
__all__ = [
    "AircraftNotFoundError",
    "ArgumentError",
    "DesignError",
    "DesignInputError",
    "DivergenceError",
    "Flight",
    "OutputPathError",
    "ProbingError",
    "Recommendation",
    "RecordError",
    "ReplayError",
    "Scenario",
    "ScenarioError",
    "SchedulerError",
    "SeparationError",
    "StoredFileError",
    "SweepBusyError",
    "TrimError",
    "analyze",
    "check_simultaneous",
    "design",
    "example",
    "example_path",
    "fly",
    "fly_sweep",
    "load",
    "read",
    "replay",
]
