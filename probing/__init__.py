"""Pulse-compression probing of aircraft dynamics through hard input nonlinearities.

The package is layered; imports run one way only (checked by import-linter, ``make lint``):

``probing.core`` (numpy/scipy) <- ``probing.sim`` (the only place that imports jsbsim) <-
``probing.experiment`` <- ``probing.sweep`` <- ``probing.analysis`` <- ``probing.api`` <-
``probing.cli``.

The public API (docs/api.md) is here: the Python API's scenarios and flights
(:mod:`probing.api`: ``load``, ``example``, ``fly``, ``read``, ``analyze``, ``replay``,
``design``, ``fly_sweep``, ``Flight``, the typed errors) and the numerical core
(:mod:`probing.core`: ``Probe``, the nonlinearities, the correlator).  ``import probing``
loads neither JSBSim, matplotlib nor pandas: the API's names are imported on first use.
"""

from importlib import import_module
from importlib.metadata import PackageNotFoundError, version
from typing import TYPE_CHECKING, Any

from probing import core
from probing.core import *  # noqa: F403 (the core's public names: probing.core.__all__)

if TYPE_CHECKING:
    from probing.api import *  # noqa: F403

try:
    __version__ = version("probing")  # the one version string: pyproject.toml's
except PackageNotFoundError:  # run from a source tree that was never installed
    __version__ = "unknown"

#: The Python API's names (:data:`probing.api.__all__`), imported on first use.
API = (
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
)

__all__ = [*API, *core.__all__, "__version__"]


def __getattr__(name: str) -> Any:
    if name in API:
        return getattr(import_module("probing.api"), name)
    raise AttributeError(f"module 'probing' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *API})
