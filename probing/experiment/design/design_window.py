"""``probing design --window-periods``: the smallest amplitude that keeps a monitor's promise.

The monitor (:class:`probing.core.monitor.ChangeDetector`) tests the gain of the mean h of
the last W periods against a baseline of B periods; its gain test's standard error is
``sigma_p * sqrt(1/W + 1/B)``, with ``sigma_p`` the standard deviation of one period's gain
(:func:`window_stderr`).  That assumes the periods' gains independent of one another and
the baseline's mean known to the same per-period scatter: both as the detector assumes.

``sigma_p`` is measured (:func:`period_gain_std`): the residual realisations of
:func:`probing.experiment.design.design_runs.turbulence_residual` (what the reference leaves of the
turbulence, and a sensor suite's noise as it reaches the estimate) through one period's
estimator, each settled period in turn, plus the analytic white sensor noise of
``disturbance.sensor_noise`` (none with a suite).  The residual does not depend on the
probe's amplitude to first order and the estimator's weights go as 1/a, so the gain's
standard error goes as 1/a: :func:`smallest_amplitude` measures it at a trial amplitude,
scales, flies a check at the amplitude found and scales once more if the check is off by
more than :data:`CHECK_TOLERANCE`.  If the last of the :data:`MAX_FLIGHTS` still misses,
the smallest amplitude flown that met the target is taken, else the last (warned of).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from probing.core.monitor import window_variance_factor
from probing.experiment.design.design_request import DesignError, DesignRequest
from probing.experiment.output.scatter import scatter_models
from probing.experiment.scenario import Scenario

__all__ = [
    "WindowDesign",
    "missed",
    "period_covariance",
    "period_gain_std",
    "smallest_amplitude",
    "window_dict",
    "window_reasons",
    "window_stderr",
]

#: The check's relative miss of the target beyond which the amplitude is scaled again.
CHECK_TOLERANCE = 0.1
#: Flights of the residual at most: the trial and two checks.
MAX_FLIGHTS = 3


def window_stderr(period_gain_std: float, window_periods: int, baseline_periods: int) -> float:
    """The standard error of a window's gain against the baseline's (dimensionless):
    ``sigma_p * sqrt(1/W + 1/B)``, periods independent.

    Examples
    --------
    >>> round(window_stderr(0.47, 4, 50), 4)
    0.2442
    """
    return period_gain_std * math.sqrt(window_variance_factor(window_periods, baseline_periods))


def period_gain_std(
    scn: Scenario, samples: Mapping[str, np.ndarray], h_ref: np.ndarray, channel: str
) -> float:
    """The standard deviation of one settled period's gain against ``h_ref`` (dimensionless):
    the seed-to-seed variance of each settled period's gain (``samples``: channel ->
    realisations (K, n) from the run's start, channel unit), averaged over the settled
    periods of ``scn``, plus the analytic sensor noise of ``scn``; its square root."""
    one = scatter_models(scn.replace({"probe.periods": scn.settle_periods + 1}))[channel]
    first = max(scn.settle_periods, scn.first_estimated_period)
    x = samples.get(channel)
    if x is None:  # sensor noise alone: the same for every period
        return one.gain_std(h_ref)
    variances = [
        one.with_noise(one.acov, x, p).gain_std(h_ref) ** 2 for p in range(first, scn.periods)
    ]
    return float(math.sqrt(np.mean(variances)))


@dataclass
class WindowDesign:
    """The amplitude found and what it was found on.

    Attributes
    ----------
    scenario : Scenario
        The design at the amplitude found.
    amplitude_deg : float
        The amplitude, deg.
    period_gain_std : float
        Per-period gain standard deviation flown at that amplitude (dimensionless).
    window_gain_stderr : float
        :func:`window_stderr` of it.
    flights : list of (float, float)
        (amplitude deg, per-period gain standard deviation) of each residual flown.
    factor : float
        The factor the amplitude found would still have to grow by to meet the target
        exactly (about 1; the window's gain se over the goal, or the detection's).
    """

    scenario: Scenario
    amplitude_deg: float
    period_gain_std: float
    window_gain_stderr: float
    flights: list[tuple[float, float]]
    factor: float = 1.0


def _round_up(x: float, digits: int = 3) -> float:
    """``x`` rounded up to ``digits`` significant figures."""
    scale = 10.0 ** (digits - 1 - math.floor(math.log10(x)))
    return math.ceil(x * scale - 1e-9) / scale


def smallest_amplitude(
    scn: Scenario,
    build: Callable[[float], Scenario],
    sigma_of: Callable[[Scenario], float],
    goal: float,
    windows: tuple[int, int],
    room: tuple[float, str],
    factor_of: Callable[[Scenario, float], float] | None = None,
) -> WindowDesign:
    """The smallest amplitude whose window gain standard error meets ``goal`` (or, with
    ``factor_of``, whose detection within the monitor's periods does).

    Parameters
    ----------
    scn : Scenario
        The design at the trial amplitude.
    build : callable
        Amplitude (deg) -> the design at that amplitude.
    sigma_of : callable
        Design -> its per-period gain standard deviation (flies the residual).
    goal : float
        The window's gain standard error to meet (dimensionless).
    windows : (int, int)
        W and B, periods of the window and of the baseline.
    room : (float, str)
        How far the amplitude may go (deg) and the limit's name.
    factor_of : callable, optional
        (design, its per-period gain std) -> the factor its amplitude must grow by to meet
        the target (:func:`probing.core.detection.detection_scale`); default: the window's
        gain se over ``goal``.

    Raises
    ------
    DesignError
        When the amplitude needed exceeds the room, in one line.
    """
    w, b = windows

    def factor(design: Scenario, sigma: float) -> float:
        if factor_of is not None:
            return factor_of(design, sigma)
        return window_stderr(sigma, w, b) / goal

    sigma = sigma_of(scn)
    tried = [(scn, sigma, factor(scn, sigma))]
    while abs(tried[-1][2] - 1.0) > CHECK_TOLERANCE and len(tried) < MAX_FLIGHTS:
        need = _round_up(scn.amplitude_deg * tried[-1][2])
        if need > room[0]:
            raise DesignError(
                f"no acceptable probe: a gain standard error of {goal:.3g} over {w} periods "
                f"against {b} needs {need:.3g} deg of the surface, and the {room[1]} is "
                f"{room[0]:.3g} deg"
            )
        scn = build(need)
        sigma = sigma_of(scn)
        tried.append((scn, sigma, factor(scn, sigma)))
    # the last flight, or when it misses the smallest amplitude flown that met the target
    met = [t for t in tried if t[2] <= 1.0 + CHECK_TOLERANCE]
    scn, sigma, last = tried[-1] if not met or met[-1] is tried[-1] else min(met, key=_amplitude)
    flights = [(t[0].amplitude_deg, t[1]) for t in tried]
    return WindowDesign(
        scn, scn.amplitude_deg, sigma, window_stderr(sigma, w, b), flights, factor=last
    )


def _amplitude(flight: tuple[Scenario, float, float]) -> float:
    return flight[0].amplitude_deg


def period_covariance(
    scn: Scenario,
    samples: Mapping[str, np.ndarray],
    channel: str,
    reduce: np.ndarray,
) -> np.ndarray:
    """One settled period's covariance of the monitor's reduced estimate ``reduce @ h``
    ((K, K), ``reduce`` the detector's window matrix (K, M)): each settled period's from
    the realisations ``samples`` (as :func:`period_gain_std`'s), averaged, plus the analytic
    sensor noise; an entry (i, j) from the variances of rows i, j and their sum."""
    one = scatter_models(scn.replace({"probe.periods": scn.settle_periods + 1}))[channel]
    first = max(scn.settle_periods, scn.first_estimated_period)
    x = samples.get(channel)
    settled = range(first, scn.periods)
    models = [one] if x is None else [one.with_noise(one.acov, x, k) for k in settled]
    k = reduce.shape[0]
    total = np.zeros((k, k))
    for model in models:
        var = np.array([model.projection_std(row) ** 2 for row in reduce])
        cov = np.diag(var)
        for i in range(k):
            for j in range(i + 1, k):
                both = model.projection_std(reduce[i] + reduce[j]) ** 2
                cov[i, j] = cov[j, i] = 0.5 * (both - var[i] - var[j])
        total += cov
    return total / len(models)


def window_reasons(request: DesignRequest, found: WindowDesign) -> dict[str, str]:
    """The reasons of the amplitude and the periods of a ``--window-periods`` design."""
    w, b = request.window_periods, request.baseline_periods
    flown = "; ".join(f"{a:.3g} deg: {s:.3g}" for a, s in found.flights)
    goal = request.gain_goal(found.scenario.period_s)
    met = (
        f"meets {goal:.3g} (within {CHECK_TOLERANCE:.0%})"
        if missed(request, found) is None
        else f"misses {goal:.3g} after {MAX_FLIGHTS} flights"
    )
    amplitude = (
        f"the smallest whose gain se over a mean of {w} periods against a baseline of "
        f"{b}, sigma_p sqrt(1/{w} + 1/{b}) = {found.window_gain_stderr:.3g}, {met} "
        f"(sigma_p, one period's gain std, goes as 1/a; flown at {flown})"
    )
    n = request.within_periods
    if n is not None:
        amplitude = (
            f"the smallest at which the monitor's own tests (Hotelling's T^2 and the gain's t "
            f"of a mean of {w} periods against a baseline of {b}, one after every period) "
            f"detect a gain change of {request.detect_gain_change:g} within {n} periods of "
            f"its onset with probability {request.detection_probability:g} "
            f"(probing.core.detection), the periods' covariance flown "
            f"{'' if missed(request, found) is None else 'and missed '}at {flown} "
            "(deg: sigma_p, one period's gain std, goes as 1/a)"
        )
    return {
        "amplitude_deg": amplitude,
        "periods": (
            f"a baseline of {b} and a window of {w} settled periods, plus "
            f"{found.scenario.settle_periods} settling"
        ),
    }


def missed(request: DesignRequest, found: WindowDesign) -> str | None:
    """A warning when the design misses its target (the window's gain se, or with
    ``--within-periods`` the detection) by more than the tolerance (the residual then
    depends on the amplitude more than the 1/a rule allows), else None."""
    if found.factor <= 1.0 + CHECK_TOLERANCE:
        return None
    goal = request.gain_goal(found.scenario.period_s)
    if request.within_periods is not None:
        return (
            f"the detection at {found.amplitude_deg:.3g} deg misses its target by more than "
            f"{CHECK_TOLERANCE:.0%} after {MAX_FLIGHTS} flights (the amplitude would grow by "
            f"{found.factor:.3g}): what the reference leaves depends on the amplitude more "
            "than as 1/a"
        )
    return (
        f"the window's gain se {found.window_gain_stderr:.3g} at {found.amplitude_deg:.3g} deg "
        f"misses the target {goal:.3g} by more than {CHECK_TOLERANCE:.0%} after "
        f"{MAX_FLIGHTS} flights: what the reference leaves depends on the amplitude more "
        "than as 1/a"
    )


def window_dict(request: DesignRequest, found: WindowDesign | None) -> dict[str, Any]:
    """What a ``--window-periods`` design found, for JSON (empty without one)."""
    if found is None:
        return {}
    return {
        "window_periods": request.window_periods,
        "baseline_periods": request.baseline_periods,
        "target_gain_stderr": request.gain_goal(found.scenario.period_s),
        "false_alarm": request.false_alarm_of(found.scenario.period_s),
        "period_gain_stderr": found.period_gain_std,
        "window_gain_stderr": found.window_gain_stderr,
        "flights": [list(f) for f in found.flights],
        **(
            {"within_periods": request.within_periods, "detection_factor": found.factor}
            if request.within_periods is not None
            else {}
        ),
    }
