"""Online change detection and isolation on the per-period pulse-response estimate.

The paper's purpose is to detect, period by period, that the small-signal dynamics changed.
Its theory gives isolation too: an input nonlinearity only scales and offsets the probe
(eqs. 10-12), so a change of the estimate that keeps its *shape* (a gain and an offset on the
baseline) points at the actuator side; a change of shape points at the airframe.

:class:`ChangeDetector` works on one channel's per-period estimate h_p (M taps):

1. **Reduction.**  The taps are summed in ``windows`` windows of geometrically growing length
   (early taps, where the fast dynamics live, finely; the tail coarsely), scaled by
   1/sqrt(length): v_p = W h_p, K numbers per period.  Tap noise that is white stays white
   and of equal variance in v.
2. **Baseline.**  The first ``baseline_periods`` periods B give the mean v0 and the sample
   covariance S (B - 1 degrees of freedom): learned from the flight itself, with nothing
   assumed about the noise but that periods are independent and Gaussian.  With
   ``baseline_gap_periods`` G the baseline slides: the B periods that end G periods before
   the tested window, frozen at the first alarm (:mod:`probing.core.baseline`).
3. **Detection.**  After every later period, the mean of the last n <= W periods
   (``window_periods`` W; n grows to W after the baseline) is tested two ways:

   * Hotelling's T^2 of d = mean(v) - v0, T^2 = d' S^-1 d / (1/n + 1/B), which under no
     change is exactly (B - 1) K / (B - K) F(K, B - K): any change;
   * the gain g = v0' mean(v) / v0' v0 against 1, whose baseline scatter is v0' S v0 /
     |v0|^4 (S is independent of v0 for Gaussian periods), so (g - 1) / (its scale) is
     exactly Student's t with B - 1 degrees of freedom: the one direction a probe designed
     for a gain change (``probing design --detect-gain-change``) is sized for.

   The period's p-value is twice the smaller of the two (Bonferroni), and its
   ``statistic`` is -log10 of it; the ``threshold`` is -log10(alpha), alpha the false-alarm
   probability per period (a rate per hour times the period length).  The expected number of
   alarmed periods per hour is then at most the rate; alarms of overlapping windows come in
   runs, so alarm *events* are fewer.
4. **Isolation**, on an alarm.

   * From the channel alone: d is fitted as (g - 1) v0 + c u (a gain on the baseline and an
     offset, u = W 1), generalised least squares with S.  The residual's T^2 is the
     Hotelling statistic of a (K - 2)-dimensional part of d, (B - 1)(K - 2) / (B - K + 2)
     F(K - 2, B - K + 2) under an unchanged shape.  Exact in open loop, where the
     nonlinearity is all that stands between probe and airframe.
   * With the surface's measured deflection (``update(h, surface)``): in the periodic steady
     state the output and the surface answer the same probe, so at every frequency
     H_y(k) = P(k) H_s(k), P the airframe alone, whatever the autopilot and the actuator do.
     The baseline gives P0(k) = mean H_y / mean H_s (Wiener-damped where H_s is noise);
     each period's residual
     r = h_y - IDFT(P0 H_s) changes only if the airframe did.  Its reduced form is tested
     against the baseline's residuals with the same T^2 (K dimensions), which isolates in
     closed loop and for a rate limit too, where the probe's shape itself changes.  A
     surface whose response is indistinguishable from none (its gain against the baseline
     inside the t interval of 0) has failed: nothing reaches the airframe, and the verdict is
     the actuator's.

   ``shape_change`` is that statistic over its ``shape_false_alarm`` threshold: above 1 the
   airframe changed beyond the noise.  An alarmed period is ``"airframe"`` if it did,
   ``"actuator"`` otherwise.

**Estimates without an offset.**  ``detrend`` removes each period's mean: the taps sum to
zero and, the windows partitioning the taps (W'W 1 = 1), each reduced period is orthogonal
to the offset's u = W 1.  S is singular along u, and its floored inverse multiplied rounding
by 1e12 (a gain change moved by 0.2 between BLAS kernels).  A baseline whose periods all
sum to zero (:data:`_ZERO_SUM`) is learned and tested in the K - 1 directions orthogonal to
u, and isolation fits a gain alone (K - 2 residual dimensions, as before).  Every sum is
taken in a fixed order (:mod:`probing.core.fixedorder`): the same bytes on any processor.

All of it is exact for independent Gaussian periods (the ``cyclic`` and ``ac`` estimators
with white sensor noise); the streaming estimator's periods overlap and are correlated, so
the false-alarm rate holds only approximately there, and P0 fitted from the baseline itself
makes the surface residual's test slightly liberal (about 1/B) (``docs/monitoring.md``).
"""

from __future__ import annotations

import collections
import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.special import fdtrc, fdtri, stdtr, stdtrit

from probing.core.baseline import BaselineWindow
from probing.core.errors import ProbingError, integer, number
from probing.core.fixedorder import cov, dot, inv, orthonormal_complement, solve, vdot

__all__ = [
    "ChangeDetector",
    "Decision",
    "MonitorSettings",
    "SettingError",
    "flight_verdict",
    "window_matrix",
    "window_variance_factor",
]

#: Smallest p-value reported (its -log10, 300, caps the statistic).
_P_FLOOR = 1e-300

#: A baseline whose periods' taps all sum to zero within this fraction of sum |h| has no
#: offset (module docstring): ``detrend`` leaves sum(h) at rounding, 1e-16 to 1e-13 of
#: sum |h|; an estimate with an offset is at 1e-3 and more.
_ZERO_SUM = 1e-9


def window_variance_factor(window_periods: int, baseline_periods: int) -> float:
    """1/n + 1/B: the variance of the mean of n new periods less the mean of B baseline
    periods, in units of one period's variance (periods independent).  The detector's gain
    test and ``probing design --window-periods`` both size the window by it.

    Examples
    --------
    >>> window_variance_factor(4, 50)
    0.27
    """
    return 1.0 / window_periods + 1.0 / baseline_periods


def window_matrix(m: int, windows: int) -> np.ndarray:
    """The reduction W (windows x m): tap sums over geometrically growing windows, each
    scaled by 1/sqrt(its length), so white tap noise stays white.

    Examples
    --------
    >>> w = window_matrix(7, 3)
    >>> (w > 0).sum(axis=1)  # taps per window: 1, 2, 4
    array([1, 2, 4])
    >>> np.allclose(w @ w.T, np.eye(3))
    True
    """
    if not 1 <= windows <= m:
        raise ValueError(f"windows must be 1..{m}, got {windows}")
    edges = np.unique(np.round(np.geomspace(1, m + 1, windows + 1)).astype(int) - 1)
    while edges.size < windows + 1:  # short responses: fill with single taps from the start
        gaps = np.setdiff1d(np.arange(m + 1), edges)
        edges = np.sort(np.append(edges, gaps[0]))
    edges[-1] = m
    w = np.zeros((windows, m))
    for k in range(windows):
        lo, hi = edges[k], edges[k + 1]
        w[k, lo:hi] = 1.0 / math.sqrt(hi - lo)
    return w


@dataclass(frozen=True)
class Decision:
    """One period's test.

    Attributes
    ----------
    statistic : float
        -log10 of the period's p-value of no change (NaN while the baseline is learned).
    threshold : float
        -log10 of the false-alarm probability per period.
    alarm : bool
        ``statistic > threshold``.
    gain_change : float
        The estimated scale g of the period against the baseline (1: unchanged; GLS with an
        offset).
    shape_change : float
        The airframe test's statistic over its threshold (> 1: the airframe changed).
    verdict : str
        ``"none"`` (no alarm), ``"actuator"`` or ``"airframe"``.
    """

    statistic: float
    threshold: float
    alarm: bool
    gain_change: float
    shape_change: float
    verdict: str


class _Hotelling:
    """Mean and covariance of B reduced periods, and T^2 of a new mean of n of them."""

    def __init__(self, v: np.ndarray) -> None:
        self.b, self.k = v.shape
        self.mean = v.mean(axis=0)
        s = cov(v)
        # a floor far below any noise (1e-12 of the estimate) keeps S invertible when the
        # baseline repeats exactly
        floor = 1e-12 * np.trace(s) / self.k + 1e-24 * vdot(self.mean, self.mean) / self.k
        s += (floor + 1e-300) * np.eye(self.k)
        self.s = s
        self.s_inv = inv(s)

    def t2(self, d: np.ndarray, n: int) -> float:
        """T^2 of a deviation ``d`` of a mean of ``n`` new periods from the baseline mean."""
        return vdot(d, dot(self.s_inv, d)) / (1.0 / n + 1.0 / self.b)

    def p_value(self, t2: float, k: int | None = None) -> float:
        """P(T^2 > t2) under no change, for a ``k``-dimensional statistic (default K)."""
        k = self.k if k is None else k
        n = self.b - 1
        return float(fdtrc(k, n - k + 1, t2 * (n - k + 1) / (n * k)))

    def threshold(self, alpha: float, k: int | None = None) -> float:
        """The T^2 exceeded with probability ``alpha`` under no change."""
        k = self.k if k is None else k
        n = self.b - 1
        return n * k / (n - k + 1) * float(fdtri(k, n - k + 1, 1.0 - alpha))


class SettingError(ProbingError, ValueError):
    """A ``[monitor]`` setting out of its bounds, in one line.

    Parameters
    ----------
    field : str
        The setting's name (a field of :class:`MonitorSettings`).
    message : str
        What is allowed and what was given (``must be an integer from 3 to 64, got 2``).
    """

    def __init__(self, field: str, message: str) -> None:
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message}")


class _Bound(NamedTuple):
    """A setting's kind (``"integer"``, ``"number"`` or ``"bool"``) and range: from ``lo``
    (excluded if ``lo_open``) to ``hi``, each None for no bound."""

    kind: str
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False


#: Every setting's bounds, checked by :class:`MonitorSettings` itself and nowhere else.
#: ``baseline_periods`` is bounded by ``windows`` (more than ``windows + 1``, checked after
#: the fields) and by the run's settled periods (checked where the run is known).
_BOUNDS: dict[str, _Bound] = {
    "baseline_periods": _Bound("integer"),
    "false_alarms_per_hour": _Bound("number", 0.0, 1e6, lo_open=True),
    "windows": _Bound("integer", 3, 64),  # gain, offset and at least one shape direction
    "shape_false_alarm": _Bound("number", 0.0, 0.5, lo_open=True),
    "verdict_periods": _Bound("integer", 1, 1000),
    "window_periods": _Bound("integer", 1, 1000),
    "surface": _Bound("bool"),
    "trajectory_false_alarms_per_hour": _Bound("number", 0.0, 1e6, lo_open=True),
    "baseline_gap_periods": _Bound("integer", 0, 100000),
}


#: The settings that may be left out (None: as documented on the field).
_OPTIONAL = ("trajectory_false_alarms_per_hour", "baseline_gap_periods")


def _checked(name: str, value: object) -> object:
    """``value`` if it is within setting ``name``'s bounds (a number as a float).

    Raises
    ------
    SettingError
        If it is not, or is not of the setting's kind (:func:`probing.core.errors.integer`
        and :func:`~probing.core.errors.number`: numpy's integers and floats are, a bool is
        no integer or number).
    """
    bound = _BOUNDS[name]
    if value is None and name in _OPTIONAL:
        return None
    if bound.kind == "bool":
        if not isinstance(value, bool):
            raise SettingError(name, f"must be true or false, got {value!r}")
        return value
    if bound.kind == "integer":
        return integer(value, name, lo=bound.lo, hi=bound.hi, error=SettingError)
    return number(value, name, lo=bound.lo, hi=bound.hi, lo_open=bound.lo_open, error=SettingError)


@dataclass(frozen=True)
class MonitorSettings:
    """The ``[monitor]`` section: how the detector learns and decides.

    Attributes
    ----------
    baseline_periods : int
        Settled periods learned as the baseline before testing.
    false_alarms_per_hour : float
        The false-alarm rate the thresholds are set for, alarms per flight hour (all
        channels together: each gets an equal share).
    windows : int
        Tap windows K of the reduction.
    shape_false_alarm : float
        Probability that an unchanged shape is called changed (the isolation test's level).
    verdict_periods : int
        Periods, from a channel's first alarm on, that its isolation test rests on (the
        channel's verdict once they are in).
    window_periods : int
        Periods averaged into each test (``probing design``'s settled periods for its
        target).
    surface : bool
        Isolate with the measured elevator deflection (channel ``elevator_deg``, an
        instrument, not monitored itself) instead of the gain-and-offset rule.
    trajectory_false_alarms_per_hour : float or None
        The trajectory detector's own false-alarm budget (:mod:`probing.core.trajectory`),
        alarms per flight hour over all channels; None: ``false_alarms_per_hour``.
    baseline_gap_periods : int or None
        None: each detector's baseline is the first ``baseline_periods`` settled periods.
        G: the baseline slides, the ``baseline_periods`` periods that end G periods before
        the tested window, frozen at the detector's first alarm
        (:class:`probing.core.baseline.BaselineWindow`): it follows a slow drift of what
        the reference leaves, and an abrupt change has ``window_periods`` + G periods to
        be detected before it starts entering the baseline.

    Raises
    ------
    SettingError
        If a field is out of its bounds (:data:`_BOUNDS`: windows 3 to 64, probabilities and
        rates above 0, shape_false_alarm up to 0.5, period counts from 1 to 1000, integers
        that are ints and not bools, surface a bool), or the baseline is not more than
        ``windows + 1`` periods (a covariance of the K windows with a degree of freedom to
        spare).  Numbers are kept as floats.
    """

    baseline_periods: int = 50
    false_alarms_per_hour: float = 0.1
    windows: int = 6
    shape_false_alarm: float = 0.01
    verdict_periods: int = 3
    window_periods: int = 1
    surface: bool = False
    trajectory_false_alarms_per_hour: float | None = None
    baseline_gap_periods: int | None = None

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            object.__setattr__(self, f.name, _checked(f.name, getattr(self, f.name)))
        if self.baseline_periods <= self.windows + 1:
            raise SettingError(
                "baseline_periods",
                f"must be more than windows + 1 ({self.windows + 1}), got {self.baseline_periods}",
            )

    def alpha(self, period_s: float, channels: int) -> float:
        """False-alarm probability per period and channel (the rate shared out equally)."""
        return min(0.5, self.false_alarms_per_hour * period_s / 3600.0 / channels)

    def trajectory_alpha(self, period_s: float, channels: int) -> float:
        """The trajectory detector's false-alarm probability per period and channel."""
        rate = self.trajectory_false_alarms_per_hour
        rate = self.false_alarms_per_hour if rate is None else rate
        return min(0.5, rate * period_s / 3600.0 / channels)

    def to_dict(self) -> dict[str, float]:
        """Plain values, for metadata (a setting left out is left out here too)."""
        values = dataclasses.asdict(self)
        return {k: v for k, v in values.items() if not (v is None and k in _OPTIONAL)}


class ChangeDetector:
    """The detector of one channel (see the module docstring).

    Parameters
    ----------
    m : int
        Taps per period.
    settings : MonitorSettings
        The ``[monitor]`` settings, valid by construction: ``baseline_periods`` B learned
        before testing, ``windows`` K, ``window_periods`` W averaged into each test,
        ``shape_false_alarm`` (the isolation test's level, kept as ``shape_alpha``),
        ``verdict_periods`` (the periods after the first alarm that isolate, kept as
        ``isolation_periods``) and ``surface`` (isolate with the surface's measured deflection,
        ``update(h, surface)``, instead of the gain-and-offset rule).
    alpha : float
        False-alarm probability per period (0 < alpha < 1; :meth:`MonitorSettings.alpha`).

    Raises
    ------
    ValueError
        If ``alpha`` is not in (0, 1), or there are more windows than taps.
    """

    def __init__(self, m: int, settings: MonitorSettings, alpha: float) -> None:
        if not 0.0 < alpha < 1.0:
            raise ValueError(f"alpha must be in (0, 1), got {alpha}")
        self.settings = settings
        self.w = window_matrix(m, settings.windows)
        #: the reduction of estimates without an offset (:data:`_ZERO_SUM`): W's rows
        #: turned into K - 1 orthonormal ones orthogonal to the offset's W 1
        self._offset_free_w = dot(orthonormal_complement(dot(self.w, np.ones(m))).T, self.w)
        self._reduce = self.w  # the reduction the baseline was learned with
        self._shape_dims = settings.windows - 2  # the airframe test's dimensions
        self.m, self.k, self.b = m, settings.windows, settings.baseline_periods
        self.alpha, self.shape_alpha = alpha, settings.shape_false_alarm
        self.surface = settings.surface
        self.threshold = -math.log10(alpha)
        self._baseline: BaselineWindow[tuple[np.ndarray, np.ndarray | None]] = BaselineWindow(
            self.b, settings.window_periods, settings.baseline_gap_periods
        )
        self._recent: collections.deque[tuple[np.ndarray, np.ndarray | None]] = collections.deque(
            maxlen=settings.window_periods
        )
        self._v: _Hotelling | None = None  # the channel's reduced estimates
        self._r: _Hotelling | None = None  # the airframe residuals (with the surface)
        self._p0: np.ndarray | None = None  # the baseline's airframe P0(k)
        self._s: _Hotelling | None = None  # the surface's reduced estimates
        #: the periods from the first alarm on, up to ``isolation_periods``: what isolates
        self._since_alarm: list[tuple[np.ndarray, np.ndarray | None]] = []
        self._alarmed = False
        self.isolation_periods = settings.verdict_periods

    @classmethod
    def from_settings(cls, m: int, settings: MonitorSettings, alpha: float) -> ChangeDetector:
        """The detector a ``[monitor]`` section describes.

        Parameters
        ----------
        m : int
            Taps per period.
        settings : MonitorSettings
            The section's settings (checked when they were made).
        alpha : float
            The channel's false-alarm probability per period (:meth:`MonitorSettings.alpha`).

        Returns
        -------
        ChangeDetector
            The channel's detector, learning its baseline.
        """
        return cls(m, settings, alpha)

    @property
    def learning(self) -> bool:
        """True while the baseline is being learned."""
        return self._v is None

    @property
    def shape_threshold(self) -> float:
        """The airframe test's T^2 threshold (NaN while learning)."""
        if self._v is None:
            return math.nan
        if self.surface:
            return self._r.threshold(self.shape_alpha)
        return self._v.threshold(self.shape_alpha, self._shape_dims)

    def update(self, h: np.ndarray, surface: np.ndarray | None = None) -> Decision:
        """Add one period's estimate ``h`` (M taps), and with ``surface`` the surface's own
        (M taps, per deg of probe), and test it.

        Periods whose estimates are not finite (no estimate) are neither learned nor tested.
        """
        h = np.asarray(h, dtype=float)
        if self.surface:
            if surface is None:
                raise ValueError("this detector isolates with the surface: give its estimate")
            surface = np.asarray(surface, dtype=float)
        none = Decision(math.nan, self.threshold, False, math.nan, math.nan, "none")
        if not np.all(np.isfinite(h)) or (surface is not None and not np.all(np.isfinite(surface))):
            return none
        item = (h, surface if self.surface else None)
        learning = self._v is None
        if self._baseline.add(item):
            self._learn()
        if learning:
            return none
        self._recent.append(item)
        return self._test()

    def _test(self) -> Decision:
        n = len(self._recent)
        h = np.mean([x[0] for x in self._recent], axis=0)
        v = dot(self._reduce, h)
        d = v - self._v.mean
        p_t2, p_gain = self._p_values(v, n)
        p = min(1.0, 2.0 * min(p_t2, p_gain))
        statistic = -math.log10(max(p, _P_FLOOR))
        gain = 1.0 + float(dot(self._fit, d)[0])
        alarm = statistic > self.threshold
        if self._alarmed and len(self._since_alarm) < self.isolation_periods:
            self._since_alarm.append(self._recent[-1])
        self._alarmed = self._alarmed or alarm
        if alarm:
            self._baseline.freeze()
        shape = self._airframe_change(self._since_alarm or [self._recent[-1]])
        verdict = ("airframe" if shape > 1.0 else "actuator") if alarm else "none"
        return Decision(statistic, self.threshold, alarm, gain, shape, verdict)

    def _p_values(self, v: np.ndarray, n: int) -> tuple[float, float]:
        """The two tests' p-values of no change for a mean ``v`` (reduced) of ``n`` periods:
        Hotelling's T^2 and the two-sided gain test."""
        base = self._v
        v0 = base.mean
        p_t2 = base.p_value(base.t2(v - v0, n))
        g = vdot(v0, v) / vdot(v0, v0)
        var = vdot(v0, dot(base.s, v0)) / vdot(v0, v0) ** 2  # one period's gain
        scale = math.sqrt(var * window_variance_factor(n, self.b))
        p_gain = 2.0 * float(stdtr(self.b - 1, -abs(g - 1.0) / scale)) if scale > 0 else 1.0
        return p_t2, p_gain

    @property
    def isolated(self) -> bool:
        """True once ``isolation_periods`` periods after the first alarmed one are in: the
        verdict from then on rests on all of them."""
        return len(self._since_alarm) >= self.isolation_periods

    def _airframe_change(self, periods: list[tuple[np.ndarray, np.ndarray | None]]) -> float:
        """The airframe test over its threshold, on the mean of ``periods``: the n periods
        after the first alarmed one (up to ``isolation_periods``; the alarmed period itself
        may hold the onset, or the response's transient to it, and is left out), or, until
        there are any, the period just tested.

        With the surface, the residual is W (h - P0 * s) less the baseline's mean, tested with
        the baseline's residual covariance (K dimensions); without it, the deviation from the
        baseline less its GLS fit of a gain and an offset (K - 2).  Both are Hotelling's T^2
        of a new mean of n periods, as the detection's.  A surface that no longer answers the
        probe means a failed actuator (0).
        """
        n = len(periods)
        h = np.mean([x[0] for x in periods], axis=0)
        if self.surface:
            s = np.mean([x[1] for x in periods], axis=0)
            if self._surface_lost(s, n):
                return 0.0  # the probe no longer reaches the airframe
            r = dot(self._reduce, self._residual_of(h, s)) - self._r.mean
            return self._r.t2(r, n) / self._r.threshold(self.shape_alpha)
        base = self._v
        d = dot(self._reduce, h) - base.mean
        e = d - dot(self._xfit, d)  # less the GLS fit of gain (and offset)
        return base.t2(e, n) / base.threshold(self.shape_alpha, self._shape_dims)

    def _surface_lost(self, s: np.ndarray, n: int) -> bool:
        """True if the surface's response to the probe is indistinguishable from none (its
        gain against the baseline's within the shape test's two-sided t interval of 0): a
        stuck surface, through which nothing can be learned about the airframe."""
        s0, spread = self._s.mean, self._s.s
        gain = vdot(s0, dot(self._reduce, s)) / vdot(s0, s0)
        se = math.sqrt(vdot(s0, dot(spread, s0)) / vdot(s0, s0) ** 2 / n)
        return abs(gain) < float(stdtrit(self.b - 1, 1.0 - self.shape_alpha / 2)) * se

    def _residual_of(self, h: np.ndarray, s: np.ndarray) -> np.ndarray:
        """h minus what the baseline's airframe makes of the surface's motion s."""
        return h - np.fft.irfft(self._p0 * np.fft.rfft(s), n=self.m)

    def _learn(self) -> None:
        baseline = self._baseline.items
        hs = np.array([x[0] for x in baseline])
        offset_free = bool(np.all(np.abs(hs.sum(axis=1)) <= _ZERO_SUM * np.abs(hs).sum(axis=1)))
        self._reduce = self._offset_free_w if offset_free else self.w
        self._v = base = _Hotelling(dot(hs, self._reduce.T))
        if offset_free:  # no offset to fit: the estimates have none
            x = base.mean[:, None]
        else:
            x = np.column_stack((base.mean, dot(self.w, np.ones(self.m))))
        self._shape_dims = base.k - x.shape[1]
        xs = dot(x.T, base.s_inv)
        self._fit = solve(dot(xs, x), xs)  # GLS: beta = fit d
        self._xfit = dot(x, self._fit)  # the S^-1-orthogonal projector on (v0[, u])
        if self.surface:
            ss = np.array([x[1] for x in baseline])
            hy, hs_ = np.fft.rfft(hs, axis=1), np.fft.rfft(ss, axis=1)
            # The ratio of the baseline's means: each period's estimate is already the
            # output's correlation with the probe, the instrument, so the surface's noise
            # enters the mean H_s only (no errors-in-variables bias, as a mean of
            # H_y conj(H_s) / |H_s|^2 would have); a Wiener term, the noise of that mean,
            # keeps the frequencies where the surface hardly moves from blowing up.
            my, ms = hy.mean(axis=0), hs_.mean(axis=0)
            noise = np.var(hs_, axis=0, ddof=1) / self.b
            power = np.abs(ms) ** 2 + noise
            p0 = my * np.conj(ms) / np.where(power > 0, power, 1.0)
            self._p0 = p0
            residuals = np.array([self._residual_of(h, s) for h, s in baseline])
            self._r = _Hotelling(dot(residuals, self._reduce.T))
            self._s = _Hotelling(dot(ss, self._reduce.T))


def flight_verdict(verdicts: Sequence[str]) -> str:
    """The flight's verdict from its channels' (each decided on the ``isolation_periods``
    from its first alarm on): the majority of those that alarmed, ``"airframe"`` on a tie
    (a changed airframe was seen), ``"none"`` if none alarmed.

    Examples
    --------
    >>> flight_verdict(["actuator", "none", "actuator", "airframe"])
    'actuator'
    >>> flight_verdict(["actuator", "airframe"])
    'airframe'
    >>> flight_verdict(["none"])
    'none'
    """
    votes = [v for v in verdicts if v != "none"]
    if not votes:
        return "none"
    return "actuator" if votes.count("actuator") > votes.count("airframe") else "airframe"
