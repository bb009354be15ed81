"""Batch sweeps: one base scenario, a grid of changes, run in parallel and resumably.

A sweep file (``scenarios/sweeps/*.toml``, see ``docs/sweeps.md``) names a base scenario and
the fields to vary; :mod:`~probing.sweep.spec` validates it and resolves every point,
:mod:`~probing.sweep.execute` runs the missing points on a local pool or Dask, and
:mod:`~probing.sweep.summary` writes ``summary.parquet``.  Importing this package loads
neither JSBSim nor pandas.
"""

from probing.sweep.execute import (
    EXECUTORS,
    SchedulerError,
    SweepBusyError,
    SweepResult,
    open_executor,
    run_sweep,
)
from probing.sweep.spec import Sweep, SweepPoint, load_sweep, parse_sweep
from probing.sweep.summary import open_dataset, read_summary, summarise

__all__ = [
    "EXECUTORS",
    "SchedulerError",
    "Sweep",
    "SweepBusyError",
    "SweepPoint",
    "SweepResult",
    "load_sweep",
    "open_dataset",
    "open_executor",
    "parse_sweep",
    "read_summary",
    "run_sweep",
    "summarise",
]
