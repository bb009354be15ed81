"""Experiments: the scenario schema, the run that wires the simulator and the core, storage
(Parquet layouts with units, provenance, the settled-estimate reader), progress, ground truth
files, probe design, the Fig. 4 runs and the mode table.

Importing :mod:`probing.experiment.scenario` and validating a scenario loads no JSBSim;
running one does (through :mod:`probing.sim`).
"""
