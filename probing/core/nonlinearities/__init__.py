"""Hard input nonlinearities of section III-B of Ruschmann & Wu, and their compensation.

Six nonlinearities act on the probe p before it reaches the plant (Fig. 1 of the
paper).  All values (parameters, input and output) are in the units of the signal
(deg of surface deflection in this project); rates are in signal units per second
and sample intervals ``dt`` in seconds.

============================  ======================================================
class                         law (x input, y output, k sample index)
============================  ======================================================
``Deadband(lower, upper)``    y = x - upper (x > upper), 0 (lower <= x <= upper),
                              x - lower (x < lower)           eq. (13) with erratum
``Saturation(lower, upper)``  y = clip(x, lower, upper)                  eq. (16)
``Relay(threshold, lo, hi)``  y = hi (x > S), lo (x < S), (lo + hi)/2 (x == S)
                                                              eq. (17) with erratum
``HysteresisRelay(...)``      y switches to hi when x > upper_threshold, to lo
                              when x < lower_threshold, holds otherwise; starts lo
``Backlash(width)``           y[k] = clip(y[k-1], x[k] - w/2, x[k] + w/2); y = 0 at
                              rest (gear play of full width w)
``RateLimit(rate)``           y[k] = x[k] if |x[k] - y[k-1]| <= rate dt, else
                              y[k-1] +- rate dt; y = 0 at rest
============================  ======================================================

Every class processes a signal in chunks with an explicit state, scipy style
(``y, state = nl.process(x, dt, state)``): feeding a signal in chunks of any sizes
gives bitwise the same output as one call to :meth:`Nonlinearity.apply`.

The first five nonlinearities turn the two-level probe +-a into another two-level
signal, eq. (10): q = (a~/a) p + b~.  With q(+a) and q(-a) the two output levels
(for the hysteretic ones: after the first input transition of each sign),

    a~ = (q(+a) - q(-a)) / 2,        b~ = (q(+a) + q(-a)) / 2.

:meth:`Nonlinearity.apparent` gives (a~, b~) in closed form, case by case as in
the paper (with the errata of docs/method.md), and :func:`compensate` undoes the effect
on the probing output, eq. (11).  The rate limit has no such form; its admissible
rates follow eq. (21), :meth:`RateLimit.admits`.
"""

from __future__ import annotations

from probing.core.nonlinearities.base import NoApparentFormError, Nonlinearity, ParameterError
from probing.core.nonlinearities.hysteretic import Backlash, HysteresisRelay
from probing.core.nonlinearities.memoryless import Deadband, Relay, Saturation
from probing.core.nonlinearities.rate_limit import RateLimit, RateLimitState
from probing.core.nonlinearities.registry import (
    NONLINEARITIES,
    NonlinearityType,
    Parameter,
    build_nonlinearity,
    compensate,
)

__all__ = [
    "NONLINEARITIES",
    "Backlash",
    "Deadband",
    "HysteresisRelay",
    "NoApparentFormError",
    "Nonlinearity",
    "NonlinearityType",
    "Parameter",
    "ParameterError",
    "RateLimit",
    "RateLimitState",
    "Relay",
    "Saturation",
    "build_nonlinearity",
    "compensate",
]
