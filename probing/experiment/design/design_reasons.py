"""What ``probing design`` says about its choices: the reason for each (estimator, drift,
periods, the window's), its warnings and notes, and why a target is out of reach.  Split from
:mod:`probing.experiment.design.design`, which computes the choices."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from probing.experiment.design.design_request import DesignError, DesignRequest
from probing.experiment.design.design_window import missed, window_reasons
from probing.experiment.design.noise import ChannelPrediction
from probing.experiment.scenario import Scenario

if TYPE_CHECKING:
    from probing.experiment.design.design_runs import Gusts
    from probing.experiment.design.design_window import WindowDesign

__all__ = [
    "CANDIDATES",
    "LARGEST_AMPLITUDE",
    "SATURATION",
    "SURFACE_RANGE",
    "estimator_reason",
    "no_amplitude",
    "notes",
    "periods_reason",
    "said",
    "too_tight",
]

#: The estimators a design chooses among, best first under sensor noise, per target kind.
CANDIDATES = {"gain": ("ac", "cyclic", "streaming"), "h": ("cyclic", "streaming")}


#: The bounds of the amplitude, as the reasons and refusals name them.
SATURATION = "saturation margin"
SURFACE_RANGE = "elevator's range about trim"
LARGEST_AMPLITUDE = "largest amplitude a scenario takes"


def no_amplitude(request: DesignRequest, half_deg: float, room_deg: float, limit: str) -> str:
    """Why no design fits a dead band of half width ``half_deg`` (deg) when the amplitude may
    go to ``room_deg`` (deg), bounded by ``limit`` (:data:`SATURATION`,
    :data:`SURFACE_RANGE` or :data:`LARGEST_AMPLITUDE`): the band is wider than the bound,
    or the amplitude that clears it by the margin is more than the bound, with what would
    fit."""
    if half_deg >= room_deg:
        return (
            f"the deadband (half width {half_deg:g} deg) is wider than the "
            f"{limit} ({room_deg:g} deg): no amplitude clears one and stays inside the other"
        )
    margin = request.deadband_margin
    remedy = f"a margin of at most {room_deg / half_deg:.3g} (`deadband_margin`)" + (
        " or a wider saturation" if limit == SATURATION else ""
    )
    return (
        f"clearing the deadband (half width {half_deg:g} deg) takes an "
        f"amplitude of {margin * half_deg:g} deg ({margin:g} x its half width), which exceeds "
        f"the {limit} ({room_deg:g} deg); {remedy} would fit"
    )


def too_tight(request: DesignRequest, shape: Any, kind: str, goal: float, exc: DesignError) -> str:
    """Why a precision target (``kind`` gain or h, ``goal`` its standard error) cannot be met
    by the design's ``shape`` (its amplitude, deg), with what would meet it."""
    what = "gain standard error" if kind == "gain" else f"standard error of h on {request.channel}"
    return (
        f"the target {what} {goal:.3g} is out of reach: {exc.message}; the scatter falls as 1/a, "
        f"so a larger amplitude than {shape.amplitude_deg:g} deg (`amplitude_deg`) or less "
        "noise would be needed"
    )


def estimator_reason(
    request: DesignRequest, estimator: str, scores: dict[str, float], target: Any
) -> str:
    """Why ``estimator``: given, the least predicted scatter of ``scores``, or no noise."""
    kind = target[0] if target else "gain"
    if request.noiseless and not request.estimator:
        return (
            "no noise to compare the estimators on (no --noise-sigma, --turbulence or "
            f"--sensors: each predicts a scatter of 0); {estimator}, the one with the least "
            f"{'gain' if kind == 'gain' else 'h'} scatter under sensor noise "
            f"({' < '.join(CANDIDATES[kind])})"
        )
    listing = ", ".join(f"{k} {v:.3g}" for k, v in scores.items())
    how = "given" if request.estimator else "smallest predicted"
    return f"{how} {'gain' if kind == 'gain' else 'h'} scatter per settled period: {listing}"


def periods_reason(
    request: DesignRequest, periods: int, pred: ChannelPrediction, target: Any, gusts: bool
) -> str:
    """Why ``periods`` settled periods: the target they meet, or none asked."""
    sources = "sensor noise" + (" + turbulence the twin leaves" if gusts else "")
    if target is None:
        settle = request.settle_periods
        return f"no precision target: {periods} settled periods, plus {settle} settling"
    kind, goal = target
    got = pred.gain_stderr if kind == "gain" else pred.h_stderr
    text = "gain" if kind == "gain" else "h"
    if request.detect_gain_change is not None:
        text += (
            f" (a change of {request.detect_gain_change:g} at false alarm "
            f"{request.false_alarm:g}, detection {request.detection_probability:g})"
        )
    return (
        f"{periods} settled periods bring the {text} scatter from {sources} to {got:.4g} "
        f"<= {goal:.4g}, plus {request.settle_periods} settling"
    )


def notes(request: DesignRequest, pred: ChannelPrediction) -> list[str]:
    """Warnings of the request (nonlinearities left out) and the prediction (a bias above the
    scatter)."""
    notes = []
    if len(request.nonlinearities()) > 1:
        notes.append(
            f"a scenario holds one nonlinearity: the scenario carries the "
            f"{request.nonlinearities()[0][1]['type']}; the bounds of all were applied"
        )
    if math.isfinite(pred.h_bias) and pred.h_bias > pred.h_stderr:
        notes.append(
            f"the slow modes' transient biases h by {pred.h_bias:.3g} (RMS), more than its "
            f"scatter {pred.h_stderr:.3g}: more settling periods (--settle-periods) reduce it"
        )
    return notes


def said(
    request: DesignRequest,
    shape: Any,
    scn: Scenario,
    window: WindowDesign | None,
    chosen: tuple[str, dict],
    pred: ChannelPrediction,
    gusts: Gusts,
) -> tuple[dict[str, str], list[str]]:
    """The design's reasons (the shape's, the estimator, the drift, the periods and the
    window's) and its warnings (the shape's, and a window that missed its goal); ``shape``:
    the design's :class:`~probing.experiment.design.design.ProbeShape` (its reasons, warnings)."""
    estimator, scores = chosen
    target = request.target
    reasons = dict(shape.reasons)
    reasons["estimator"] = estimator_reason(request, estimator, scores, target)
    reasons["drift"] = request.drift_reason()
    reasons["periods"] = periods_reason(request, scn.settled_periods, pred, target, gusts.on)
    warnings = list(shape.warnings)
    if window is not None:
        reasons.update(window_reasons(request, window))
        warnings += [w for w in [missed(request, window)] if w]
    return reasons, warnings
