"""The compensation of the probing output, eq. (11), and the registry of nonlinearity
types (:data:`NONLINEARITIES`): parameters with units, label, description, builder.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from probing.core.nonlinearities.base import (
    Nonlinearity,
    check_amplitude,
)
from probing.core.nonlinearities.hysteretic import Backlash, HysteresisRelay
from probing.core.nonlinearities.memoryless import Deadband, Relay, Saturation
from probing.core.nonlinearities.rate_limit import RateLimit


# --------------------------------------------------------------------- compensation
def compensate(z: ArrayLike, nonlinearity: Nonlinearity, amplitude: float) -> np.ndarray:
    """Undo a known input nonlinearity on the probing output, eq. (11).

    Through a nonlinearity with apparent probe (a~, b~), one period of the probing
    output is z_bar(k) = a~[(M+1)h(k) - S] + b~ S with S = sum_j h(j), instead of
    z(k) = a[(M+1)h(k) - S].  Summing z_bar over the period gives S (a~ + M b~), so
    S comes from the measurement itself, and z = (a/a~)(z_bar - b~ S).

    Parameters
    ----------
    z : array_like
        One period of the probing output (length M, last axis), or several periods
        stacked (periods x M); output units times probe units.  The operation is
        elementwise apart from the sum over the period, so any cyclic alignment
        of the period (time order or tap order) is fine.
    nonlinearity : Nonlinearity
        The known input nonlinearity (one with an apparent form).
    amplitude : float
        Probe amplitude a > 0, signal units.

    Returns
    -------
    numpy.ndarray
        The probing output without the nonlinearity, same shape as z.

    Raises
    ------
    ValueError
        If a~ == 0 (the probe does not get through: nothing to recover) or
        a~ + M b~ == 0 (the period sum carries no information on S).
    NoApparentFormError
        For a :class:`RateLimit` (a ``TypeError``).
    """
    a = check_amplitude(amplitude)
    zb = np.asarray(z, dtype=np.float64)
    if zb.ndim < 1 or zb.shape[-1] < 1:
        raise ValueError("z must have at least one sample along its last axis")
    a_t, b_t = nonlinearity.apparent(a)
    if a_t == 0.0:
        raise ValueError(
            f"{nonlinearity!r} gives apparent amplitude a~ = 0 for amplitude {a!r}: "
            "the probe does not get through, nothing to recover"
        )
    m = zb.shape[-1]
    denom = a_t + m * b_t
    if abs(denom) <= 1e-12 * (abs(a_t) + m * abs(b_t)):
        raise ValueError(
            f"a~ + M b~ = 0 for {nonlinearity!r} (a~ = {a_t!r}, b~ = {b_t!r}, M = {m}): "
            "the DC sum of the pulse response cannot be recovered"
        )
    s = np.sum(zb, axis=-1, keepdims=True) / denom  # sum_j h(j)
    return (a / a_t) * (zb - b_t * s)


# ------------------------------------------------------------------------ registry
@dataclass(frozen=True)
class Parameter:
    """One parameter of a nonlinearity type as the project names it.

    Attributes
    ----------
    name : str
        The name with its unit, as in scenario files (``"lower_deg"``).
    argument : str
        The class's argument (``"lower"``).
    unit : str
        ``"deg"`` (surface deflection) or ``"deg/s"``.
    description : str
        What it is, in a few words.
    """

    name: str
    argument: str
    unit: str
    description: str


@dataclass(frozen=True)
class NonlinearityType:
    """A nonlinearity type: its class, parameters (with units) and how to label it.

    Attributes
    ----------
    name : str
        The type as written in scenario files (``"deadband"``).
    label : str
        Human-readable name for titles and tables (``"hysteresis relay"``).
    cls : type or None
        The :class:`Nonlinearity` subclass; None for ``"none"`` (a straight wire).
    parameters : tuple of Parameter
        In the order of the class's arguments.
    describe : callable
        ``describe(values)`` -> the parameters as one short line (values by
        :attr:`Parameter.name`, in their units).
    """

    name: str
    label: str
    cls: type[Nonlinearity] | None
    parameters: tuple[Parameter, ...]
    describe: Callable[[Mapping[str, float]], str]

    @property
    def names(self) -> tuple[str, ...]:
        """The parameter names with units, in order."""
        return tuple(p.name for p in self.parameters)

    def build(self, values: Mapping[str, float]) -> Nonlinearity | None:
        """The nonlinearity with these parameter values (by name with units); None for none.

        Raises
        ------
        KeyError
            For a missing parameter.
        ParameterError
            For an invalid value (a ``ValueError`` naming the class's argument: map it back
            with :meth:`parameter`).
        """
        if self.cls is None:
            return None
        return self.cls(*(values[p.name] for p in self.parameters))

    def parameter(self, argument: str) -> Parameter:
        """The parameter of the class argument ``argument``."""
        return next(p for p in self.parameters if p.argument == argument)


def _deg(name: str, description: str) -> Parameter:
    return Parameter(f"{name}_deg", name, "deg", description)


def _describe_hysteresis(v: Mapping[str, float]) -> str:
    lo_s, up_s = v["lower_threshold_deg"], v["upper_threshold_deg"]
    lo, hi = v["low_deg"], v["high_deg"]
    if lo_s == -up_s and lo == -hi:
        return f"S± = ±{up_s:.4g}, l± = ±{hi:.4g} deg"
    return f"S-, S+ = {lo_s:.4g}, {up_s:.4g}; l-, l+ = {lo:.4g}, {hi:.4g} deg"


#: Every nonlinearity type of the project by its scenario name, ``"none"`` included: the one
#: table that scenario validation, sweeps, figures and summaries read.
NONLINEARITIES: dict[str, NonlinearityType] = {
    t.name: t
    for t in (
        NonlinearityType("none", "none", None, (), lambda v: ""),
        NonlinearityType(
            "deadband",
            "deadband",
            Deadband,
            (_deg("lower", "lower edge d- (<= 0)"), _deg("upper", "upper edge d+ (>= 0)")),
            lambda v: f"d-, d+ = {v['lower_deg']:.4g}, {v['upper_deg']:.4g} deg",
        ),
        NonlinearityType(
            "saturation",
            "saturation",
            Saturation,
            (_deg("lower", "lower limit U-"), _deg("upper", "upper limit U+")),
            lambda v: f"U-, U+ = {v['lower_deg']:.4g}, {v['upper_deg']:.4g} deg",
        ),
        NonlinearityType(
            "relay",
            "relay",
            Relay,
            (
                _deg("threshold", "switching point S"),
                _deg("low", "output l- below S"),
                _deg("high", "output l+ above S"),
            ),
            lambda v: (
                f"S = {v['threshold_deg']:.4g}, l-, l+ = {v['low_deg']:.4g}, "
                f"{v['high_deg']:.4g} deg"
            ),
        ),
        NonlinearityType(
            "hysteresis_relay",
            "hysteresis relay",
            HysteresisRelay,
            (
                _deg("lower_threshold", "S-: switches low below it"),
                _deg("upper_threshold", "S+: switches high above it"),
                _deg("low", "output l- (also at rest)"),
                _deg("high", "output l+"),
            ),
            _describe_hysteresis,
        ),
        NonlinearityType(
            "backlash",
            "backlash",
            Backlash,
            (_deg("width", "full gap width b_l (>= 0)"),),
            lambda v: f"width b_l = {v['width_deg']:.4g} deg",
        ),
        NonlinearityType(
            "rate_limit",
            "rate limit",
            RateLimit,
            (Parameter("rate_deg_s", "rate", "deg/s", "rate limit r_l (> 0)"),),
            lambda v: f"r_l = {v['rate_deg_s']:.4g} deg/s",
        ),
    )
}


def build_nonlinearity(kind: str, values: Mapping[str, float]) -> Nonlinearity | None:
    """The nonlinearity of registered type ``kind`` with these parameter values.

    Parameters
    ----------
    kind : str
        A key of :data:`NONLINEARITIES` (``"none"`` gives None).
    values : mapping
        Parameter name with unit -> value (deg, or deg/s for the rate).

    Returns
    -------
    Nonlinearity or None

    Examples
    --------
    >>> build_nonlinearity("backlash", {"width_deg": 0.0025}).apparent(0.005)
    (0.00375, 0.0)
    """
    return NONLINEARITIES[kind].build(values)
