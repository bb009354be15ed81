"""Pulse-compression probing of aircraft dynamics through hard input nonlinearities.

The numerical core (:mod:`probing.prbs`, :mod:`probing.nonlinearities`,
:mod:`probing.correlator`) knows nothing of JSBSim; :mod:`probing.plant` is the
only module that imports it.
"""

__version__ = "0.1.0"
