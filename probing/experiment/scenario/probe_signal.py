"""The probe's signal in a scenario: ``probe.signal``, ``band_hz`` and ``sweep``, and the
estimator each signal is read with (:mod:`probing.core.excitation`)."""

from __future__ import annotations

from typing import Any

from probing.core.errors import is_number
from probing.core.excitation import PRBS, SIGNALS, SPECTRAL, SWEEPS, Excitation
from probing.core.prbs import Probe
from probing.experiment.scenario.schema import ScenarioError, choice


def parse_excitation(probe: dict[str, Any], order: int, bit_s: float) -> Excitation:
    """``probe.signal`` (the PRBS by default), with a multisine's or chirp's ``band_hz`` and
    a chirp's ``sweep``; the band checked against the period and the bits."""
    signal = choice(probe, "probe", "signal", tuple(SIGNALS)) if "signal" in probe else "prbs"
    if signal == "prbs":
        for key in ("band_hz", "sweep"):
            if key in probe:
                raise ScenarioError(f"probe.{key}", "is for a multisine or a chirp, not the PRBS")
        return PRBS
    if "band_hz" not in probe:
        raise ScenarioError("probe.band_hz", f"missing: a {signal} needs [low, high] in Hz")
    band = probe["band_hz"]
    if not isinstance(band, list) or len(band) != 2 or not all(is_number(f) for f in band):
        raise ScenarioError("probe.band_hz", f"must be [low, high] in Hz, got {band!r}")
    if "sweep" in probe and signal != "chirp":
        raise ScenarioError("probe.sweep", "is for a chirp")
    sweep = choice(probe, "probe", "sweep", SWEEPS) if "sweep" in probe else "linear"
    excitation = Excitation(signal, (float(band[0]), float(band[1])), sweep)
    try:
        Probe(order, bit_s, 1.0, excitation)  # builds the signal: the band's rules
    except ValueError as exc:
        raise ScenarioError("probe.band_hz", str(exc)) from None
    return excitation


def check_estimator(excitation: Excitation, estimator: str | None) -> str:
    """The estimator of the probe's signal: the PRBS's ``output.estimator`` (streaming by
    default, or cyclic, ac, spectral); a multisine's or chirp's is ``spectral`` (its spectrum
    over the input's), and another is refused."""
    if excitation.is_binary:
        return estimator or "streaming"
    if estimator not in (None, SPECTRAL):
        raise ScenarioError(
            "output.estimator",
            f"{estimator} correlates with a binary sequence; a {excitation.signal} is "
            f'estimated from its spectrum: estimator = "{SPECTRAL}" (or leave it out)',
        )
    return SPECTRAL


def signal_fields(excitation: Excitation) -> dict[str, Any]:
    """``probe.signal`` and its fields as the file writes them; nothing for the PRBS (the
    digests stay as they were before other signals existed)."""
    if excitation.is_binary:
        return {}
    assert excitation.band_hz is not None
    out: dict[str, Any] = {"signal": excitation.signal, "band_hz": list(excitation.band_hz)}
    return {**out, "sweep": excitation.sweep} if excitation.signal == "chirp" else out
