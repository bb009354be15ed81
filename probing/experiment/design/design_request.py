"""What ``probing design`` is asked (:class:`DesignRequest`), its defaults and the help of
each of its options, and the checks of a request: light enough for the command line to
build its options from it without loading the simulator.
"""

from __future__ import annotations

import dataclasses
import functools
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import MISSING, dataclass, field
from typing import Any

from probing.core.errors import ArgumentError, ProbingError, choice, integer, number, refer
from probing.core.noise import ESTIMATORS
from probing.core.sensors import SENSOR_SUITES
from probing.experiment.scenario import Scenario, ScenarioError, parse_scenario
from probing.sim.channels import CHANNEL_NAMES
from probing.sim.flight import TURBULENCE_SEVERITY

__all__ = ["DESIGN_DRIFTS", "DesignError", "DesignInputError", "DesignRequest", "detectable_stderr"]

#: The references ``probing design --drift`` calibrates turbulence against: three a real
#: aircraft can run, and the oracle, an upper bound (docs/monitoring.md).
DESIGN_DRIFTS = ("gust", "nominal", "detrend", "oracle")


def _option(default: Any = MISSING, *, help: str, exclusive: str | None = None, **kw: Any) -> Any:
    """A :class:`DesignRequest` field that is a ``probing design`` option: ``help`` is its
    help text, ``exclusive`` names the group of options of which one at most is given, and
    ``kw`` are further keywords of :meth:`argparse.ArgumentParser.add_argument` (``metavar``,
    ``choices``).  No default: a required value, which the command checks itself."""
    return field(default=default, metadata={"option": {"help": help, "exclusive": exclusive, **kw}})


class DesignError(ProbingError, ValueError):
    """The request cannot be met; ``message`` says why, an option it names written between
    backticks: the Python keyword in ``str(error)``, the command line's option in
    :meth:`line`.

    Examples
    --------
    >>> str(DesignError("a margin of at most 2 (`deadband_margin`) would fit"))
    'a margin of at most 2 (deadband_margin) would fit'
    """

    def __init__(self, message: str) -> None:
        self.message = message
        super().__init__(refer(message, str))

    def __reduce__(self) -> tuple[Any, ...]:  # pickled as made (a forked run hands it back)
        return type(self), (self.message,)

    def line(self, name: Callable[[str], str]) -> str:
        """The one line, each option it names written ``name(option)``."""
        return refer(self.message, name)


class DesignInputError(ArgumentError):
    """An invalid request: ``option`` (``argument``) names the :class:`DesignRequest` field,
    the keyword of :func:`probing.design` (``probing design`` writes it as its option,
    ``--altitude-ft``), ``message`` the rule; another field it names is written between
    backticks (:meth:`~probing.core.errors.ArgumentError.line`)."""

    @property
    def option(self) -> str:
        """The field refused."""
        return self.argument


#: Scenario field -> the :class:`DesignRequest` field that sets it.
_OPTIONS = {
    "name": "aircraft",
    "aircraft.model": "aircraft",
    "condition.altitude_ft": "altitude_ft",
    "condition.speed_kcas": "speed_kcas",
    "simulation.dt_s": "dt_s",
    "probe.amplitude_deg": "amplitude_deg",
    "probe.settle_periods": "settle_periods",
    "output.channels": "channel",
    "output.estimator": "estimator",
    "disturbance.turbulence": "turbulence",
    "output.drift": "drift",
    "sensors.suite": "sensors",
}


@dataclass(frozen=True)
class DesignRequest:
    """What ``probing design`` is asked: aircraft, condition, nonlinearities, noise, target.

    Attributes are in the units of their names; ``noise_sigma`` is the sensor noise of
    ``channel`` (its unit, 1 sigma); ``target_h_se`` is in the channel's unit per deg.  Each
    field is the option ``--field-name`` of ``probing design``, with the default and help
    of its metadata ``"option"`` (:func:`_option`).
    """

    aircraft: str = _option(help="JSBSim model, e.g. gtm_t2 or 737 (required)")
    altitude_ft: float = _option(help="trim altitude (ft) (required)")
    speed_kcas: float = _option(help="trim speed (kt CAS) (required)")
    dt_s: float = _option(0.01, help="simulation step (s)")
    deadband_deg: tuple[float, float] | None = _option(
        None, help="deadband edges relative to trim (deg)", metavar=("LOWER", "UPPER")
    )
    saturation_deg: tuple[float, float] | None = _option(
        None, help="saturation limits relative to trim (deg)", metavar=("LOWER", "UPPER")
    )
    rate_limit_deg_s: float | None = _option(None, help="rate limit (deg/s)", metavar="R")
    channel: str = _option("theta_rad", help="the output to estimate", choices=CHANNEL_NAMES)
    noise_sigma: float = _option(0.0, help="sensor noise on the channel (1 sigma)")
    turbulence: str = _option(
        "none",
        help="turbulence level; what the reference twin does not cancel is measured",
        choices=list(TURBULENCE_SEVERITY),
    )
    drift: str = _option(
        "gust",
        help="the reference the turbulence is calibrated against: gust (a calm twin through "
        "the gust estimated from the sensors; needs `sensors` and `closed_loop`), nominal "
        "(a calm twin), detrend (no model), or oracle (a twin flying the same gusts: an "
        "upper bound that knows the gusts, simulation only); in calm air without sensors "
        "every twin is the same aircraft",
        choices=DESIGN_DRIFTS,
    )
    sensors: str | None = _option(
        None,
        help="the sensor suite the aircraft measures (and its autopilot flies) with: its "
        "noise reaches the estimate through the loop and the reference, measured by the "
        "calibration runs (default: the state itself, plus `noise_sigma`)",
        choices=list(SENSOR_SUITES),
        metavar="SUITE",
    )
    closed_loop: bool = _option(
        False, help="fly with pitch, bank and speed hold (the study's [control])"
    )
    calibration_seeds: int = _option(
        32,
        help="turbulence runs to measure it on (a std from K of them: 1/sqrt(2(K-1)))",
    )
    estimator: str | None = _option(
        None,
        help="the estimator (default: the one with the smallest predicted scatter)",
        choices=list(ESTIMATORS),
    )
    target_gain_se: float | None = _option(
        None, help="standard error of the gain", exclusive="target"
    )
    detect_gain_change: float | None = _option(
        None,
        help="a gain change to detect (with `false_alarm` and `detection_probability`)",
        metavar="CHANGE",
        exclusive="target",
    )
    target_h_se: float | None = _option(
        None, help="standard error of h, RMS over taps (channel unit per deg)", exclusive="target"
    )
    false_alarm: float = _option(0.01, help="false-alarm probability (two-sided)")
    detection_probability: float = _option(0.9, help="detection probability")
    amplitude_deg: float = _option(0.005, help="amplitude without a deadband (deg)")
    deadband_margin: float = _option(3.0, help="a >= margin x deadband half width")
    settle_periods: int = _option(2, help="periods left out before averaging")
    window_periods: int | None = _option(
        None,
        help="with a gain target: the smallest amplitude whose gain standard error over a "
        "mean of W periods, tested against a baseline of `baseline_periods`, meets it "
        "(instead of the periods at `amplitude_deg`, then the trial amplitude)",
        metavar="W",
    )
    baseline_periods: int = _option(50, help="with `window_periods`: the baseline's periods")
    within_periods: int | None = _option(
        None,
        help="with `window_periods` and `detect_gain_change`: the change detected within N "
        "periods of its onset by the monitor's own tests, one after every period "
        "(probing.core.detection), instead of by one test",
        metavar="N",
    )
    false_alarms_per_hour: float | None = _option(
        None,
        help="with `window_periods`: the false-alarm rate per flight hour, per period tested, "
        "instead of `false_alarm`",
        metavar="RATE",
    )

    def __post_init__(self) -> None:
        """Each field of the type its hint says (an int a real integer, a number an int or
        a float, numpy's included, a pair two numbers), and one of its ``choices``; kept as
        the Python type (DesignInputError naming the field)."""
        hints = _hints()
        for f in dataclasses.fields(self):
            value = _typed(getattr(self, f.name), f.name, hints[f.name], f.metadata["option"])
            object.__setattr__(self, f.name, value)

    @classmethod
    def of(cls, options: Mapping[str, Any]) -> DesignRequest:
        """The request of ``options`` (field name -> value), as :func:`probing.design`'s
        keywords give it.

        Raises
        ------
        DesignInputError
            An option that is no field, a required field missing, a value of the wrong type.
        """
        fields = [f.name for f in dataclasses.fields(cls)]
        for name in options:
            if name not in fields:
                raise DesignInputError(
                    str(name), f"no such option of design (its options: {', '.join(fields)})"
                )
        missing = [f.name for f in dataclasses.fields(cls) if f.default is MISSING]
        missing = [name for name in missing if name not in options]
        if missing:
            more = ", ".join(f"`{name}`" for name in missing[1:])
            raise DesignInputError(missing[0], "required" + (f", as is {more}" if more else ""))
        return cls(**options)

    def base(self) -> dict[str, Any]:
        """The request as a scenario (file layout): probe placeholders, no nonlinearity."""
        noise = {self.channel: self.noise_sigma} if self.noise_sigma else {}
        drift = "reference" if self.every_twin_alike else self.drift
        data: dict[str, Any] = {
            "name": "design",
            "aircraft": {"model": self.aircraft},
            "condition": {"altitude_ft": self.altitude_ft, "speed_kcas": self.speed_kcas},
            "simulation": {"dt_s": self.dt_s},
            "probe": {
                "order": 9,
                "bit_duration_s": self.dt_s,
                "amplitude_deg": self.amplitude_deg,
                "periods": max(self.settle_periods + 1, 2),
                "settle_periods": self.settle_periods,
            },
            "nonlinearity": {"type": "none"},
            "output": {
                "channels": [self.channel],
                "drift": drift,
                "estimator": self.estimator or "streaming",
            },
            "disturbance": {"turbulence": self.turbulence, "sensor_noise": noise},
        }
        if self.sensors is not None:
            data["sensors"] = {"suite": self.sensors}
        if self.closed_loop:
            data["control"] = {"pitch_hold": True, "bank_hold": True, "speed_hold": True}
        return data

    @property
    def every_twin_alike(self) -> bool:
        """True in calm air without sensors: every reference twin is the same aircraft, so
        ``drift`` changes nothing and the scenario says ``drift = "reference"``."""
        return self.turbulence == "none" and self.sensors is None

    @property
    def noiseless(self) -> bool:
        """True without sensor noise, turbulence or a sensor suite: every estimator's
        predicted scatter is 0, so there is no noise to compare them on or to meet a
        precision target against."""
        return self.noise_sigma == 0 and self.every_twin_alike

    def drift_reason(self) -> str:
        """What the design's reference is, and why (one line, for the design's table)."""
        if self.every_twin_alike:
            return (
                "calm air without sensors: every twin is the same aircraft, so the reference "
                "is a calm twin, whatever --drift"
            )
        return f"--drift {self.drift}: the reference the turbulence is calibrated against"

    def nonlinearities(self) -> list[tuple[str, dict[str, Any]]]:
        """The nonlinearities asked about, as (option, scenario changes), in order."""
        out = []
        if self.deadband_deg is not None:
            lo, up = self.deadband_deg
            change = {"type": "deadband", "lower_deg": lo, "upper_deg": up}
            out.append(("deadband_deg", change))
        if self.saturation_deg is not None:
            lo, up = self.saturation_deg
            change = {"type": "saturation", "lower_deg": lo, "upper_deg": up}
            out.append(("saturation_deg", change))
        if self.rate_limit_deg_s is not None:
            change = {"type": "rate_limit", "rate_deg_s": self.rate_limit_deg_s}
            out.append(("rate_limit_deg_s", change))
        return out

    def validate(self) -> Scenario:
        """Check every value as the scenario schema does; the base scenario.

        Raises
        ------
        DesignInputError
            Naming the option and the rule, for the first invalid value.
        """
        self._check_reference()
        data = self.base()
        try:
            scn = parse_scenario(data)
        except ScenarioError as exc:
            option = _OPTIONS.get(exc.field, exc.field)
            if exc.field.startswith("disturbance.sensor_noise"):
                option = "noise_sigma"
            raise DesignInputError(option, exc.message) from None
        for option, change in self.nonlinearities():
            try:
                scn.replace({f"nonlinearity.{k}": v for k, v in change.items()})
            except ScenarioError as exc:
                raise DesignInputError(option, f"{exc.field}: {exc.message}") from None
        positive = (
            ("target_gain_se", self.target_gain_se),
            ("detect_gain_change", self.detect_gain_change),
            ("target_h_se", self.target_h_se),
            ("deadband_margin", self.deadband_margin),
        )
        for option, value in positive:
            if value is not None:
                number(value, option, lo=0, lo_open=True, error=DesignInputError)
        for option, value in (
            ("false_alarm", self.false_alarm),
            ("detection_probability", self.detection_probability),
        ):
            if not 0 < value < 1:
                raise DesignInputError(option, f"must be a probability in (0, 1), got {value:g}")
        targets = [t for t in (self.target_gain_se, self.detect_gain_change, self.target_h_se) if t]
        if len(targets) > 1:
            raise DesignInputError(
                "target_gain_se", "give one target: a gain standard error, a gain change "
                "to detect, or a standard error of h"
            )  # fmt: skip
        if targets and self.noiseless:
            raise DesignInputError(
                "noise_sigma", "a precision target needs noise to meet it against (> 0)"
            )
        integer(self.calibration_seeds, "calibration_seeds", lo=2, hi=100, error=DesignInputError)
        self._check_window(bool(targets))
        return scn

    def _check_reference(self) -> None:
        """The reference's needs, as options: gust flies from the sensors with a pitch hold;
        a suite carries its own noise."""
        if self.sensors is not None and self.noise_sigma:
            raise DesignInputError(
                "noise_sigma", "the suite's sensors carry the noise (`sensors`): give one"
            )
        if self.drift != "gust" or self.every_twin_alike:
            return
        if self.sensors is None:
            raise DesignInputError(
                "drift",
                "gust estimates the gust from the sensors: give `sensors` SUITE and "
                "`closed_loop`, or `drift` oracle (an upper bound that knows the gusts)",
            )
        if not self.closed_loop:
            raise DesignInputError(
                "drift", "gust's twin flies its own autopilot: give `closed_loop`"
            )

    def _check_window(self, targeted: bool) -> None:
        """``window_periods`` needs a gain target; its settings are the monitor's."""
        from probing.core.monitor import MonitorSettings, SettingError

        if self.window_periods is None:
            for option, value in (
                ("false_alarms_per_hour", self.false_alarms_per_hour),
                ("within_periods", self.within_periods),
            ):
                if value is not None:
                    raise DesignInputError(option, "needs `window_periods`")
            return
        if self.within_periods is not None:
            if self.detect_gain_change is None:
                raise DesignInputError("within_periods", "needs `detect_gain_change`")
            integer(self.within_periods, "within_periods", lo=1, hi=1000, error=DesignInputError)
        if not targeted or self.target_h_se is not None:
            raise DesignInputError(
                "window_periods", "needs a gain target (`detect_gain_change` or "
                "`target_gain_se`)"
            )  # fmt: skip
        try:
            MonitorSettings(
                baseline_periods=self.baseline_periods,
                false_alarms_per_hour=self.false_alarms_per_hour or 0.1,
                window_periods=self.window_periods,
            )
        except SettingError as exc:
            raise DesignInputError(exc.field, exc.message) from None

    def false_alarm_of(self, period_s: float) -> float:
        """The two-sided false-alarm probability of one test: ``false_alarm``, or with
        ``false_alarms_per_hour`` the monitor's per period (one channel) for a period of
        ``period_s`` (s)."""
        if self.false_alarms_per_hour is None:
            return self.false_alarm
        from probing.core.monitor import MonitorSettings

        settings = MonitorSettings(
            baseline_periods=self.baseline_periods, false_alarms_per_hour=self.false_alarms_per_hour
        )
        return settings.alpha(period_s, 1)

    def gain_goal(self, period_s: float) -> float:
        """The gain's standard error to meet (dimensionless): ``target_gain_se``, or that
        at which ``detect_gain_change`` is detected, at the false alarm of one test
        (:meth:`false_alarm_of` a period of ``period_s``, s)."""
        if self.detect_gain_change is None:
            assert self.target_gain_se is not None
            return self.target_gain_se
        alpha = self.false_alarm_of(period_s)
        return detectable_stderr(self.detect_gain_change, alpha, self.detection_probability)

    @property
    def target(self) -> tuple[str, float] | None:
        """("gain", its standard error) or ("h", its standard error) or None."""
        if self.detect_gain_change is not None:
            return "gain", detectable_stderr(
                self.detect_gain_change, self.false_alarm, self.detection_probability
            )
        if self.target_gain_se is not None:
            return "gain", self.target_gain_se
        if self.target_h_se is not None:
            return "h", self.target_h_se
        return None


@functools.cache
def _hints() -> dict[str, Any]:
    """:class:`DesignRequest`'s fields' types."""
    return typing.get_type_hints(DesignRequest)


def _typed(value: Any, name: str, hint: Any, option: Mapping[str, Any]) -> Any:
    """``value`` of the field ``name`` as its type ``hint`` (``X | None``: None, or an X)
    and its ``option``'s ``choices`` say (DesignInputError naming ``name``)."""
    if isinstance(hint, types.UnionType):
        if value is None:
            return None
        (hint,) = [k for k in typing.get_args(hint) if k is not type(None)]
    if hint is bool:
        if not isinstance(value, bool):
            raise DesignInputError(name, f"must be True or False, got {value!r}")
        return value
    if hint is int:
        return integer(value, name, error=DesignInputError)
    if hint is float:
        return number(value, name, error=DesignInputError)
    if typing.get_origin(hint) is tuple:
        if not isinstance(value, list | tuple) or len(value) != len(typing.get_args(hint)):
            raise DesignInputError(name, f"must be a pair of numbers (lower, upper), got {value!r}")
        return tuple(number(v, name, error=DesignInputError) for v in value)
    if "choices" in option:
        return choice(value, name, tuple(option["choices"]), error=DesignInputError)
    if not isinstance(value, str):
        raise DesignInputError(name, f"must be a string, got {value!r}")
    return value


def detectable_stderr(change: float, false_alarm: float, detection_probability: float) -> float:
    """The gain standard error at which a gain change ``change`` is detected with
    ``detection_probability`` by a two-sided test of false-alarm probability ``false_alarm``.

    Examples
    --------
    >>> print(round(detectable_stderr(0.05, 0.01, 0.9), 5))  # 0.05 / (2.576 + 1.282)
    0.01296
    """
    from scipy.stats import norm

    return change / (norm.ppf(1 - false_alarm / 2) + norm.ppf(detection_probability))
