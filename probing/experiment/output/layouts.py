"""The layouts of a run folder's Parquet files, with units: every column carries field
metadata ``unit`` and ``description``; a unit written ``<channel>`` (or ``<channel>/deg``) is
the unit of the row's channel (per deg of probe), and :func:`units` resolves them per channel
for the file's ``probing.units``.  :data:`OUTPUT_FILES` is the registry of the files.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pyarrow as pa

from probing.sim.autopilot import COMMAND_COLUMNS
from probing.sim.channels import unit_of
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACES

__all__ = [
    "AUTOPILOT_COLUMNS",
    "BOUNDS_LEVEL",
    "BOUNDS_SCHEMA",
    "CHANNEL_UNIT",
    "FLIGHT_FILES",
    "MANOEUVRE_SCHEMA",
    "MONITOR_SCHEMA",
    "OUTPUT_FILES",
    "PER_DEG",
    "PROBING_SCHEMA",
    "RESPONSES_SCHEMA",
    "RUN_FILES",
    "TRUTH_SCHEMA",
    "OutputFile",
    "bounds_block",
    "field",
    "probing_block",
    "sensors_schema",
    "timeseries_schema",
    "units",
]

CHANNEL_UNIT = "<channel>"  # placeholder: the unit of the row's channel
PER_DEG = "<channel>/deg"  # ... per deg of probe


def field(name: str, dtype: pa.DataType, unit: str, description: str) -> pa.Field:
    """A Parquet column with its unit and description as field metadata."""
    return pa.field(name, dtype, metadata={"unit": unit, "description": description})


PROBING_SCHEMA = pa.schema(
    [
        field("channel", pa.string(), "", "output channel (its name carries its unit)"),
        field("period", pa.int32(), "1", "probe period p, counted from the first probe sample"),
        field("tap", pa.int32(), "1", "tap i: the response i bits after a one-bit pulse"),
        field("lag_s", pa.float64(), "s", "lag of the tap, i t0"),
        field("z", pa.float64(), CHANNEL_UNIT, "probing output, eq. (5), in tap order"),
        field("zeta", pa.float64(), CHANNEL_UNIT, "DC-corrected probing output, eq. (9)"),
        field("h_est", pa.float64(), PER_DEG, "pulse-response estimate zeta / (a (M+1))"),
    ]
)

#: Confidence level of the per-tap bounds of ``bounds.parquet`` (``probing analyze`` and
#: ``probing run``): two-sided, Student-t over the periods used.
BOUNDS_LEVEL = 0.95

#: The per-tap bounds of ``probing analyze`` (every whole period) and ``probing run`` (the
#: settled periods): the mean over the periods used and its interval.
BOUNDS_SCHEMA = pa.schema(
    [
        field("channel", pa.string(), "", "output column"),
        field("tap", pa.int32(), "1", "tap i: the response i bits after a one-bit pulse"),
        field("lag_s", pa.float64(), "s", "lag of the tap, i t0"),
        field("h_est", pa.float64(), PER_DEG, "mean over the periods used of h_est"),
        field("h_low", pa.float64(), PER_DEG, "lower bound of the mean's 95 % Student-t interval"),
        field("h_high", pa.float64(), PER_DEG, "upper bound of the mean's 95 % Student-t interval"),
        field("h_std", pa.float64(), PER_DEG, "period-to-period standard deviation (ddof 1)"),
        field(
            "h_model_sd",
            pa.float64(),
            PER_DEG,
            "standard deviation of the mean predicted by the noise model from the white sensor "
            "noise (docs/noise.md); NaN where the model does not cover the run",
        ),
    ]
)

MONITOR_SCHEMA = pa.schema(
    [
        field("period", pa.int32(), "1", "probe period p, counted from the first probe sample"),
        field("time_s", pa.float64(), "s", "time after trim at the end of the period"),
        field("channel", pa.string(), "", "output channel (its name carries its unit)"),
        field(
            "detector",
            pa.string(),
            "",
            "probing (the pulse response changed) or trajectory (the output left the reference's)",
        ),
        field("statistic", pa.float64(), "1", "-log10 p of no change (NaN: baseline)"),
        field("threshold", pa.float64(), "1", "-log10 of the false-alarm probability"),
        field("alarm", pa.bool_(), "", "statistic > threshold"),
        field(
            "gain_change", pa.float64(), "1", "estimated scale of h against the baseline (probing)"
        ),
        field("shape_change", pa.float64(), "1", "airframe test over its threshold (probing)"),
        field("verdict", pa.string(), "", "none, actuator (gain and offset) or airframe"),
    ]
)

TRUTH_SCHEMA = pa.schema(
    [
        field("channel", pa.string(), "", "output channel (its name carries its unit)"),
        field("tap", pa.int32(), "1", "bits after the pulse"),
        field("lag_s", pa.float64(), "s", "time after the pulse, tap t0"),
        field("h_pulse", pa.float64(), PER_DEG, "single one-bit pulse on a trimmed twin"),
        field("h_lin", pa.float64(), PER_DEG, "FGLinearization, ZOH at t0 (NaN: no output)"),
    ]
)


def timeseries_schema(
    channels: list[str], reference: bool, control: bool = False, surface: str = DEFAULT_SURFACE
) -> pa.Schema:
    """``timeseries.parquet``: one row per simulation step; channels in their own units; the
    probe, its nonlinearity's output and the probed surface's realised position in the
    surface's unit (``probe_deg``, ``nl_out_deg``, ``elevator_pos_deg``; ``_norm`` and
    ``throttle_pos_norm`` for the throttle; the surface's sensor channel, ``elevator_deg``,
    is a channel like any other); with ``control``, the autopilot's command of the probed
    surface too."""
    s = SURFACES[surface]
    u = s.unit
    fields = [
        field("time_s", pa.float64(), "s", "time after trim, at the end of the step"),
        field(f"probe_{u}", pa.float64(), u, "probe a sigma, relative to trim"),
        field(f"nl_out_{u}", pa.float64(), u, "probe after the nonlinearity"),
        field(s.position_column, pa.float64(), u, f"realised {s.name} position (no noise)"),
    ]
    if control:
        fields.append(
            field(f"control_{u}", pa.float64(), u, f"the autopilot's {s.name} command, from trim")
        )
    fields += [
        field(c, pa.float64(), unit_of(c), "measured (sensor noise added)") for c in channels
    ]
    if reference:
        fields += [
            field(f"{c}_reference", pa.float64(), unit_of(c), "unprobed twin") for c in channels
        ]
    return pa.schema(fields)


#: The autopilot's commands a flight records (``sensors.parquet``): the elevator's from trim
#: (before the probe), the aileron's and every engine's throttle (normalised, absolute).
AUTOPILOT_COLUMNS = COMMAND_COLUMNS


def sensors_schema(
    channels: Sequence[str], autopilot: bool, surface: str = DEFAULT_SURFACE
) -> pa.Schema:
    """``sensors.parquet``: what the flight computer recorded, one row per simulation step:
    the probe it injected (the probed surface's unit), with ``autopilot`` the autopilot's
    commands (:data:`AUTOPILOT_COLUMNS`), and every sensor's measurement under its channel
    name, in the channel's unit.  Nothing of the simulation's truth."""
    u = SURFACES[surface].unit
    fields = [
        field("time_s", pa.float64(), "s", "time after trim, at the end of the step"),
        field(f"probe_{u}", pa.float64(), u, "the probe injected, a sigma, relative to trim"),
    ]
    if autopilot:
        fields += [
            field(AUTOPILOT_COLUMNS[0], pa.float64(), "deg", "the autopilot's elevator, from trim"),
            field(AUTOPILOT_COLUMNS[1], pa.float64(), "1", "the autopilot's aileron command"),
            field(AUTOPILOT_COLUMNS[2], pa.float64(), "1", "the autopilot's throttle command"),
        ]
    fields += [field(c, pa.float64(), unit_of(c), "measured by its sensor") for c in channels]
    return pa.schema(fields)


MANOEUVRE_SCHEMA = pa.schema(
    [
        field("channel", pa.string(), "", "output channel (its name carries its unit)"),
        field("period", pa.int32(), "1", "probe period p, counted from the first probe sample"),
        field("time_mid_s", pa.float64(), "s", "time after trim at the middle of the period"),
        field("reference", pa.float64(), "<manoeuvre>", "the hold's reference change there"),
        field(
            "achieved",
            pa.float64(),
            "<manoeuvre>",
            "the twin's change there (pitch, bank: deg; speed: kt true)",
        ),
        field("tap", pa.int32(), "1", "tap i: the response i bits after a one-bit pulse"),
        field("lag_s", pa.float64(), "s", "lag of the tap, i t0"),
        field("h_est", pa.float64(), PER_DEG, "the period's own cyclic estimate"),
        field(
            "h_pulse",
            pa.float64(),
            PER_DEG,
            "single pulse on the twin at mid-period, folded onto one period",
        ),
    ]
)

RESPONSES_SCHEMA = pa.schema(
    [
        field("surface", pa.string(), "", "probed surface (its unit: deg, or norm)"),
        field("channel", pa.string(), "", "output channel (its name carries its unit)"),
        field("tap", pa.int32(), "1", "bits after the surface's pulse"),
        field("lag_s", pa.float64(), "s", "lag of the tap, tap t0"),
        field("h_est", pa.float64(), "<channel>/<surface>", "the surfaces probed together"),
        field("h_alone", pa.float64(), "<channel>/<surface>", "this surface probed alone"),
        field("h_lin", pa.float64(), "<channel>/<surface>", "the linearisation, alone"),
    ]
)


@dataclass(frozen=True)
class OutputFile:
    """A file of a run's folder: its layout and what it holds.

    Attributes
    ----------
    name : str
        The file name in the run's folder.
    description : str
        Stored as the file's ``probing.description``.
    schema : pyarrow.Schema or None
        Its columns with their units; None for a file laid out per run (its writer builds
        the schema: ``timeseries.parquet``'s columns are the run's channels).
    pandas_attrs : bool
        Its ``probing.*`` keys are also kept where pandas keeps a DataFrame's ``attrs``, so
        a file a user reads and writes again with pandas keeps them (``sensors.parquet``).
    """

    name: str
    description: str
    schema: pa.Schema | None
    pandas_attrs: bool = False


#: Every file a run writes into its folder: the one place a file's name, layout and
#: description live (:meth:`OutputFolder.writer` reads it; adding a file is one entry).
OUTPUT_FILES: dict[str, OutputFile] = {
    f.name: f
    for f in (
        OutputFile(
            "probing.parquet",
            "probing output z (eq. 5), its DC-corrected form zeta (eq. 9) and the "
            "pulse-response estimate h_est, one row per channel, period and tap",
            PROBING_SCHEMA,
        ),
        OutputFile(
            "bounds.parquet",
            "the mean over the periods used (probing analyze: every whole period; probing "
            "run: the settled periods) of h_est per channel and tap, with the 95 % Student-t "
            "confidence interval of that mean over the P periods (P - 1 degrees of freedom) "
            "and the period-to-period standard deviation",
            BOUNDS_SCHEMA,
        ),
        OutputFile(
            "timeseries.parquet",
            "the run step by step: probe, nonlinearity output, realised surface, measured "
            "outputs (sensor noise added) and the unprobed twin's outputs",
            None,
        ),
        OutputFile(
            "sensors.parquet",
            "what the flight computer recorded, step by step: the probe it injected, the "
            "autopilot's commands and every sensor's measurement; probing monitor --replay "
            "recomputes the monitor from it alone",
            None,
            pandas_attrs=True,
        ),
        OutputFile(
            "truth.parquet",
            "ground truth: h_pulse, one-bit pulse of amplitude a on a trimmed twin minus an "
            "unprobed twin, over a; h_lin, JSBSim's FGLinearization discretised with "
            "zero-order hold at t0; both sampled at the end of each bit, over the whole run",
            TRUTH_SCHEMA,
        ),
        OutputFile(
            "prediction.parquet",
            "predicted probing output: h_pulse superposed over the run's probe history and "
            "passed through the same correlator; compare row by row with probing.parquet",
            PROBING_SCHEMA,
        ),
        OutputFile(
            "monitor.parquet",
            "change detection after every probe period, one row per period and monitored "
            "channel: -log10 p of no change of the period's pulse-response estimate against "
            "the flight's own baseline (Hotelling T^2 and the gain), its threshold for the "
            "false-alarm rate, the gain against the baseline and the airframe test",
            MONITOR_SCHEMA,
        ),
        OutputFile(
            "responses.parquet",
            "each probed surface's pulse response, probed together, alone and on the "
            "linearisation, over the surface's window of taps",
            RESPONSES_SCHEMA,
        ),
        OutputFile(
            "manoeuvre.parquet",
            "the probing output's pulse response period by period along the manoeuvre, "
            "and a single pulse on the unprobed twin at each period's middle",
            MANOEUVRE_SCHEMA,
        ),
    )
}

#: What each way of flying a scenario writes into its folder, in :data:`OUTPUT_FILES`'s
#: order: ``run`` (a steady scenario), ``truth`` (added by ``probing truth`` or ``run
#: --truth``), ``monitor`` (``probing monitor`` and ``--replay``; ``--timeseries`` adds
#: ``timeseries.parquet``), ``live`` and ``analyze`` (a record, beside its figure).  The
#: command line's help names the files from here; the tests compare it with the folders.
FLIGHT_FILES: dict[str, tuple[str, ...]] = {
    "run": ("probing.parquet", "bounds.parquet", "timeseries.parquet"),
    "truth": ("truth.parquet", "prediction.parquet"),
    "monitor": ("probing.parquet", "bounds.parquet", "sensors.parquet", "monitor.parquet"),
    "live": ("probing.parquet", "bounds.parquet", "sensors.parquet", "monitor.parquet"),
    "analyze": ("probing.parquet", "bounds.parquet"),
}
assert all(n in OUTPUT_FILES for names in FLIGHT_FILES.values() for n in names)

#: The files the project writes into a run's folder (:data:`OUTPUT_FILES`).  A run that
#: completes into a folder removes those of them it did not write (an earlier run's), so the
#: folder holds the files of one run only.
RUN_FILES = tuple(OUTPUT_FILES)


def units(schema: pa.Schema, channels: Sequence[str], per: str = "deg") -> dict[str, Any]:
    """The ``probing.units`` map of a file: column -> unit, or channel -> unit for the columns
    in the unit of the row's channel; ``per``: the probed surface's unit, which a column per
    deg of probe (:data:`PER_DEG`) is per (``"norm"`` for the throttle)."""
    out: dict[str, Any] = {}
    for f in schema:
        unit = (f.metadata or {}).get(b"unit", b"").decode()
        if unit in (CHANNEL_UNIT, PER_DEG):
            suffix = unit.removeprefix(CHANNEL_UNIT).replace("deg", per)
            out[f.name] = {c: unit_of(c) + suffix for c in channels}
        elif unit:
            out[f.name] = unit
    return out


def probing_block(
    channels: list[str],
    periods: np.ndarray,
    lag_s: np.ndarray,
    z: np.ndarray,
    zeta: np.ndarray,
    h: np.ndarray,
) -> dict[str, object]:
    """Periods of several channels in the layout of :data:`PROBING_SCHEMA`.

    Parameters
    ----------
    channels : list of str
        Channel names, C of them.
    periods : numpy.ndarray
        Period indices, shape (P,).
    lag_s : numpy.ndarray
        Lag of each tap (s), shape (M,).
    z, zeta, h : numpy.ndarray
        Shape (P, C, M), in the units of :data:`PROBING_SCHEMA`'s columns.

    Returns
    -------
    dict
        Columns with the rows ordered by period, then channel, then tap.
    """
    n_p, n_c, m = z.shape
    names = pa.array(channels, pa.string())
    return {
        "channel": names.take(pa.array(np.tile(np.repeat(np.arange(n_c), m), n_p))),
        "period": np.repeat(np.asarray(periods, dtype=np.int32), n_c * m),
        "tap": np.tile(np.arange(m, dtype=np.int32), n_p * n_c),
        "lag_s": np.tile(lag_s, n_p * n_c),
        "z": z.reshape(-1),
        "zeta": zeta.reshape(-1),
        "h_est": h.reshape(-1),
    }


def bounds_block(
    channels: list[str],
    lag_s: np.ndarray,
    mean: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    std: np.ndarray,
    model_sd: np.ndarray | None = None,
) -> dict[str, object]:
    """Per-tap bounds of several channels in the layout of :data:`BOUNDS_SCHEMA`.

    Parameters
    ----------
    channels : list of str
        Channel names, C of them.
    lag_s : numpy.ndarray
        Lag of each tap (s), shape (M,).
    mean, low, high, std : numpy.ndarray
        Shape (C, M), in the unit of ``h_est`` (the channel's unit per unit of probe), as
        :func:`probing.core.recorded.tap_bounds` returns them.
    model_sd : numpy.ndarray, optional
        Shape (C, M): the noise model's standard deviation of the mean, same unit; None: NaN
        (no model covers the estimate).

    Returns
    -------
    dict
        Columns with the rows ordered by channel, then tap.
    """
    n_c, m = mean.shape
    names = pa.array(channels, pa.string())
    return {
        "channel": names.take(pa.array(np.repeat(np.arange(n_c), m))),
        "tap": np.tile(np.arange(m, dtype=np.int32), n_c),
        "lag_s": np.tile(lag_s, n_c),
        "h_est": mean.reshape(-1),
        "h_low": low.reshape(-1),
        "h_high": high.reshape(-1),
        "h_std": std.reshape(-1),
        "h_model_sd": np.full(n_c * m, np.nan) if model_sd is None else model_sd.reshape(-1),
    }
