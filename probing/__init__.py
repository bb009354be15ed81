"""Pulse-compression probing of aircraft dynamics through hard input nonlinearities.

The package is layered; imports run one way only (checked by import-linter, ``make lint``):

``probing.core`` (numpy/scipy) <- ``probing.sim`` (the only place that imports jsbsim) <-
``probing.experiment`` <- ``probing.sweep`` <- ``probing.analysis`` <- ``probing.cli``.

The numerical core is re-exported here; ``import probing`` loads neither JSBSim, matplotlib
nor pandas.
"""

from importlib.metadata import PackageNotFoundError, version

from probing import core
from probing.core import *  # noqa: F403 (the public API is the core's: probing.core.__all__)

try:
    __version__ = version("probing")  # the one version string: pyproject.toml's
except PackageNotFoundError:  # run from a source tree that was never installed
    __version__ = "unknown"

__all__ = [*core.__all__, "__version__"]
