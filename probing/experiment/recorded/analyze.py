"""``probing analyze``: pulse compression on recorded data, no simulation.

A record (:mod:`probing.experiment.recorded.record`) holds the injected probe and measured outputs.
The probe is checked to be the m-sequence of the order and bit duration given
(:func:`probing.core.recorded.align_probe`); whole periods from the sequence's phase 0 are
used.  Drift: ``detrend`` fits each output's periodic part and a linear trend together
(:func:`probing.core.trend.detrend_periodic`) and removes the trend and the output's
mean; ``none`` removes the mean only; a ``reference`` column is subtracted instead (it
carries the baseline, nothing else is removed).  Without a reference the record's offset
cannot be told from the response's mean: every tap of the estimate is h - sum(h) / M, and
the constant is pinned with the response's settled tail where the tail is flat within its
noise (:mod:`probing.core.pinning`), which gives the pulse response itself; where it is not,
the estimate keeps the zero-mean convention and the files say so.  Estimates per period are
those of the ``cyclic`` estimator; bounds per tap are the two-sided Student-t interval of
the mean over the P periods.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa

from probing.core.errors import ArgumentError, choice, integer, names, number
from probing.core.pinning import SETTLED_TAIL, TailPin, pin_settled_tail, tail_taps
from probing.core.prbs import MAX_ORDER, MIN_ORDER, steps_per_bit
from probing.core.recorded import NotAnMSequence, align_probe, period_estimates, tap_bounds
from probing.core.trend import detrend_periodic
from probing.experiment.output.bounds import bounds_confidence, write_bounds
from probing.experiment.output.layouts import (
    BOUNDS_LEVEL,
    BOUNDS_SCHEMA,
    CHANNEL_UNIT,
    PER_DEG,
    field,
    probing_block,
)
from probing.experiment.output.storage import output_folder, provenance
from probing.experiment.recorded.record import (
    DRIFTS,
    RecordError,
    column_unit,
    file_sha256,
    read_columns,
    sample_step_s,
)

__all__ = [
    "LEVEL",
    "REFERENCE",
    "Analysis",
    "AnalysisRequest",
    "analyze",
    "convention_lines",
    "convention_record",
    "write_analysis",
]

#: Confidence level of the per-tap bounds (that of every ``bounds.parquet``).
LEVEL = BOUNDS_LEVEL
#: The convention of an estimate whose baseline a reference column carries: the response.
REFERENCE = "reference"


@dataclass(frozen=True)
class AnalysisRequest:
    """What ``probing analyze`` is asked: the file, its columns and the probe.

    ``time`` or ``dt_s`` (s) gives the time base; ``amplitude`` (probe unit) None: read
    from the probe column; ``drift`` ``detrend`` or ``none``, unless ``reference`` names a
    column subtracted from each output.  ``settled_after_s`` (s): the lag from which the
    response is taken to have settled, whose taps pin the estimate's constant (None: the
    last quarter of the period, :func:`probing.core.pinning.tail_taps`).
    """

    path: Path
    input: str
    outputs: tuple[str, ...]
    order: int
    bit_duration_s: float
    time: str | None = None
    dt_s: float | None = None
    amplitude: float | None = None
    drift: str = "detrend"
    reference: str | None = None
    settled_after_s: float | None = None

    def __post_init__(self) -> None:
        """Each argument of the type and range it must have, kept as the Python type
        (:mod:`probing.core.errors`: an order a real integer, numpy's included, a duration a
        number > 0, one column name or several as ``outputs``); ArgumentError naming it."""
        put = functools.partial(object.__setattr__, self)
        if self.time is None and self.dt_s is None:
            raise ArgumentError("time", "give `time` (the time column) or `dt_s` (the sample step)")
        if self.time is not None and self.dt_s is not None:
            raise ArgumentError("dt_s", "give `time` or `dt_s`, not both")
        for name in ("input", "time", "reference"):
            value = getattr(self, name)
            if value is not None and not isinstance(value, str):
                raise ArgumentError(name, f"must be a column name (a string), got {value!r}")
        put("outputs", names(self.outputs, "outputs"))
        put("order", integer(self.order, "order", lo=MIN_ORDER, hi=MAX_ORDER))
        for name in ("bit_duration_s", "dt_s", "amplitude", "settled_after_s"):
            if getattr(self, name) is not None:
                put(name, number(getattr(self, name), name, lo=0, lo_open=True))
        choice(self.drift, "drift", DRIFTS)


@dataclass(frozen=True)
class Analysis:
    """The estimates of a record: z, zeta, h (P, C, M), the bounds, what was found, and each
    output's convention (:data:`REFERENCE`, or the tail's: ``pin``)."""

    request: AnalysisRequest
    dt_s: float
    amplitude: float
    found: dict[str, object]
    z: np.ndarray
    zeta: np.ndarray
    h: np.ndarray
    bounds: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    sha256: str
    pin: TailPin | None = None

    @property
    def conventions(self) -> dict[str, str]:
        """Output -> what h_est is: the response itself (``reference``, ``settled tail``)
        or the response less sum(h) / M (``zero mean``)."""
        outputs = list(self.request.outputs)
        if self.pin is None:
            return dict.fromkeys(outputs, REFERENCE)
        return self.pin.conventions(outputs)


def _tail(req: AnalysisRequest, m: int) -> int:
    """Taps of the settled tail (:func:`probing.core.pinning.tail_taps`)."""
    if req.settled_after_s is None:
        after = None
    else:
        after = int(np.ceil(req.settled_after_s / req.bit_duration_s - 1e-9))
    try:
        return tail_taps(m, after)
    except ValueError as exc:
        raise RecordError(
            f"--settled-after-s {req.settled_after_s:g} s with {m} taps of "
            f"{req.bit_duration_s:g} s: {exc}"
        ) from None


def _columns(req: AnalysisRequest) -> dict[str, np.ndarray]:
    names = [req.input, *req.outputs]
    names += [n for n in (req.time, req.reference) if n is not None]
    return read_columns(req.path, list(dict.fromkeys(names)), time=req.time)


def _deviations(req: AnalysisRequest, cols: dict[str, np.ndarray], m: int) -> np.ndarray:
    """(P M, C) end-of-bit output samples of the periods used, drift removed (see module)."""
    y = np.column_stack([cols[c] for c in req.outputs])
    if req.reference is not None:
        return y - cols[req.reference][:, None]
    if req.drift == "detrend":
        return detrend_periodic(y, m, 1)
    return y - y.mean(axis=0)


def analyze(req: AnalysisRequest) -> Analysis:
    """Read the record, check the probe, and estimate (module docstring).

    Raises
    ------
    RecordError
        Bad file, column or time base, or a probe that is not the m-sequence asked for.
    """
    cols = _columns(req)
    where = f"{req.path}"
    dt = sample_step_s(cols[req.time], f"{where}: {req.time}") if req.time else float(req.dt_s)
    try:
        spb = steps_per_bit(req.bit_duration_s, dt)
    except ValueError as exc:
        raise RecordError(f"{where}: {exc}") from None
    try:
        al = align_probe(cols[req.input], spb, req.order)
    except NotAnMSequence as exc:
        raise RecordError(
            f"{where}: column {req.input} is not an m-sequence of order {req.order} with "
            f"{req.bit_duration_s} s bits: {exc}"
        ) from None
    if al.periods < 2:
        raise RecordError(f"{where}: {al.periods} whole period from the sequence's start; need 2")
    m = 2**req.order - 1
    n_tail = _tail(req, m)
    ends = al.first_sample + spb - 1 + spb * np.arange(al.periods * m)
    used = {k: v[ends] for k, v in cols.items()}
    amplitude = al.amplitude if req.amplitude is None else float(req.amplitude)
    z, zeta, h = period_estimates(_deviations(req, used, m), req.order, al.sign, amplitude)
    pin = None if req.reference is not None else pin_settled_tail(h, n_tail)
    if pin is not None:
        h = pin.h
    found = {
        "samples": int(cols[req.input].size),
        "samples_per_bit": spb,
        "bit_offset_samples": al.offset_samples,
        "sequence_shift_bits": al.shift_bits,
        "sign": al.sign,
        "first_sample": al.first_sample,
        "periods_used": al.periods,
        "whole_bits": al.bits,
        "samples_unused": int(cols[req.input].size - al.periods * m * spb),
        "levels": [al.mid - al.amplitude, al.mid + al.amplitude],
    }
    return Analysis(
        req, dt, amplitude, found, z, zeta, h, tap_bounds(h, LEVEL), file_sha256(req.path), pin
    )


def convention_lines(result: Analysis) -> list[str]:
    """One line per output: whether h_est is the response itself, and why not."""
    lines = []
    req, m = result.request, result.h.shape[2]
    for j, (out, conv) in enumerate(result.conventions.items()):
        if conv == REFERENCE:
            lines.append(f"{out}: h_est is the response (the reference column {req.reference})")
            continue
        pin = result.pin
        assert pin is not None
        start = (m - pin.tail_taps) * req.bit_duration_s
        test = (
            f"F {pin.statistic[j]:.3g} against {pin.threshold:.3g}, slope t "
            f"{pin.slope_t[j]:.3g} against +-{pin.slope_threshold:.3g}"
        )
        if conv == SETTLED_TAIL:
            lines.append(
                f"{out}: h_est is the response: the tail from lag {start:g} s is settled "
                f"({test}); its constant {pin.constant[j]:.4g} removed"
            )
        else:
            lines.append(
                f"{out}: the tail from lag {start:g} s has not settled ({test}): h_est is the "
                f"response less sum(h)/M (a longer period, --settled-after-s or --reference "
                f"gives the response itself)"
            )
    return lines


def convention_record(result: Analysis) -> dict[str, object]:
    """The ``probing.convention`` metadata: per output what h_est is, and the tail's test."""
    out: dict[str, object] = {"h_est": result.conventions}
    if result.pin is not None:
        pin = result.pin
        start_s = (result.h.shape[2] - pin.tail_taps) * result.request.bit_duration_s
        out["tail"] = {"from_lag_s": start_s, **pin.record(list(result.request.outputs))}
    return out


def _unit(column: str) -> str:
    """A column's unit from its name (:func:`column_unit`), else ``(unit of COLUMN)``."""
    return column_unit(column) or f"(unit of {column})"


def _units(req: AnalysisRequest) -> dict[str, object]:
    out: dict[str, object] = {"lag_s": "s"}
    for f in (*BOUNDS_SCHEMA, field("z", pa.float64(), CHANNEL_UNIT, "")):
        unit = (f.metadata or {}).get(b"unit", b"").decode()
        if unit in (CHANNEL_UNIT, PER_DEG):
            per = "" if unit == CHANNEL_UNIT else f"/{_unit(req.input)}"
            out[f.name] = {c: f"{_unit(c)}{per}" for c in req.outputs}
    out["zeta"] = out["z"]
    return out


def write_analysis(result: Analysis, out: Path) -> list[Path]:
    """Write ``probing.parquet`` (per period) and ``bounds.parquet`` (per tap) into ``out``.

    Both carry the provenance: the input file's name and SHA-256, the request, what was
    found in the record (:func:`analyze`), the drift handling and the confidence level.
    """
    req = result.request
    m = 2**req.order - 1
    meta = provenance(
        input={"file": req.path.name, "sha256": result.sha256},
        analysis={
            "input_column": req.input,
            "outputs": list(req.outputs),
            "order": req.order,
            "bit_duration_s": req.bit_duration_s,
            "dt_s": result.dt_s,
            "amplitude": result.amplitude,
            "amplitude_from": "given" if req.amplitude is not None else "probe levels",
            "settled_after_s": req.settled_after_s,
            **result.found,
        },
        drift=f"reference column {req.reference}" if req.reference else req.drift,
        convention=convention_record(result),
        estimator="cyclic",
        confidence=bounds_confidence(result.h.shape[0] - 1),
    )
    units = _units(req)
    channels = list(req.outputs)
    lag_s = np.arange(m) * req.bit_duration_s
    periods = np.arange(result.h.shape[0])
    with output_folder(out, meta) as folder:
        w = folder.writer("probing.parquet", [], own_units=units)
        w.write(probing_block(channels, periods, lag_s, result.z, result.zeta, result.h))
        write_bounds(folder, channels, lag_s, result.bounds, result.h.shape[0] - 1, own_units=units)
    return [out / "probing.parquet", out / "bounds.parquet"]
