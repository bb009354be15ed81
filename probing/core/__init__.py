"""The numerical core: probe, nonlinearities with their apparent-input theory, correlator,
figures of merit.  numpy and scipy only; nothing of the project outside this package."""

from probing.core.correlator import PeriodEstimates, StreamingCorrelator
from probing.core.nonlinearities import (
    NONLINEARITIES,
    Backlash,
    Deadband,
    HysteresisRelay,
    NoApparentFormError,
    Nonlinearity,
    ParameterError,
    RateLimit,
    Relay,
    Saturation,
    build_nonlinearity,
    compensate,
)
from probing.core.prbs import Probe, mls

__all__ = [
    "NONLINEARITIES",
    "Backlash",
    "Deadband",
    "HysteresisRelay",
    "NoApparentFormError",
    "Nonlinearity",
    "ParameterError",
    "PeriodEstimates",
    "Probe",
    "RateLimit",
    "Relay",
    "Saturation",
    "StreamingCorrelator",
    "build_nonlinearity",
    "compensate",
    "mls",
]
