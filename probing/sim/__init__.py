"""Everything that touches JSBSim: aircraft lookup and sanitising, the plant, trim,
linearisation, reference twins and ground truth.

``probing.sim`` is the only package that imports jsbsim, and only in the modules that step
or trim an aircraft (:mod:`~probing.sim.plant` and those built on it).  Looking up an
aircraft (:mod:`~probing.sim.aircraft`), the output channels (:mod:`~probing.sim.channels`)
and the errors (:mod:`~probing.sim.errors`) load no JSBSim, so a scenario can be validated
without it.
"""
