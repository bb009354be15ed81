"""``probing analyze``: pulse compression on a recorded file (docs/analyze.md)."""

from __future__ import annotations

import argparse

from probing.cli.common import (
    Subcommands,
    UsageError,
    command,
    files_of,
    out_folder,
    path_arg,
)


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def _order(text: str) -> int:
    """An m-sequence order the project supports (:data:`probing.core.prbs.MIN_ORDER` to
    :data:`~probing.core.prbs.MAX_ORDER`)."""
    from probing.core.prbs import MAX_ORDER, MIN_ORDER

    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or not MIN_ORDER <= value <= MAX_ORDER:
        raise argparse.ArgumentTypeError(
            f"must be an integer from {MIN_ORDER} to {MAX_ORDER}, got {text}"
        )
    return value


def _cmd_analyze(args: argparse.Namespace) -> int:
    """``probing analyze``: ``analyze(...).save(out)`` (:func:`probing.api.analyze`)."""
    from probing.api import analyze
    from probing.api.flight import FIGURE_NAME
    from probing.experiment.recorded.analyze import convention_lines
    from probing.experiment.recorded.record import RecordError

    out_folder(args.out, "--out")
    try:
        record = analyze(
            args.file,
            input=args.input,
            outputs=args.output,
            order=args.order,
            bit_duration_s=args.bit_duration_s,
            time=args.time,
            dt_s=args.dt_s,
            amplitude=args.amplitude,
            drift=args.drift,
            reference=args.reference,
            settled_after_s=args.settled_after_s,
            max_lag_s=args.max_lag_s,
            scratch=args.out,
        )
    except RecordError as exc:
        raise UsageError(str(exc)) from None
    record.save(args.out, hold_interrupts=True)  # an interrupt at any moment leaves nothing
    result = record.result
    f = result.found
    print(
        f"{args.file.name}: sequence shift {f['sequence_shift_bits']} bits, bit boundary at "
        f"sample {f['bit_offset_samples']}, {f['periods_used']} whole periods used from sample "
        f"{f['first_sample']} ({f['samples_unused']} of {f['samples']} samples unused), "
        f"amplitude {result.amplitude:g}"
    )
    for line in convention_lines(result):
        print(line)
    for name in (*record.files, f"{FIGURE_NAME}.png"):
        print(f"-> {args.out / name}")
    return 0


def register(sub: Subcommands) -> None:
    """Add ``analyze`` to ``sub``."""
    p = command(
        sub,
        "analyze",
        "pulse compression on recorded data (CSV, Parquet or MATLAB .mat): "
        f"{files_of('analyze')} and pulse_response.png in --out (docs/analyze.md)",
        [
            "probing analyze examples/your-data/probe_response.csv --time time_s "
            "--input elevator_deg --output q_rad_s theta_rad --order 7 --bit-duration-s 0.04 "
            "--out results/your-data",
        ],
    )
    p.add_argument("file", type=path_arg, metavar="FILE", help="the record: .csv, .parquet or .mat")
    p.add_argument("--input", required=True, metavar="COL", help="the probe as injected")
    p.add_argument(
        "--output", required=True, nargs="+", metavar="COL", help="one or more measured outputs"
    )
    base = p.add_mutually_exclusive_group(required=True)
    base.add_argument("--time", metavar="COL", help="time column (s), uniform step")
    base.add_argument("--dt-s", type=_positive, help="sample step (s)")
    p.add_argument("--order", type=_order, required=True, help="m-sequence order n (M = 2^n - 1)")
    p.add_argument("--bit-duration-s", type=_positive, required=True, help="bit duration t0 (s)")
    p.add_argument(
        "--amplitude",
        type=_positive,
        help="probe amplitude a in the probe's unit (default: half the difference of the "
        "probe column's two levels)",
    )
    drift = p.add_mutually_exclusive_group()
    drift.add_argument(
        "--drift",
        choices=("detrend", "none"),
        default="detrend",
        help="detrend: a periodic part and a linear trend fitted together, the trend and the "
        "mean removed; none: the mean removed",
    )
    drift.add_argument(
        "--reference", metavar="COL", help="a reference subtracted from each output instead"
    )
    p.add_argument(
        "--settled-after-s",
        type=_positive,
        metavar="S",
        help="without --reference: the lag (s) from which the response has settled; the taps "
        "from there pin the estimate's constant (default: the last quarter of the period)",
    )
    p.add_argument(
        "--max-lag-s",
        type=_positive,
        metavar="S",
        help="the figure's last lag (s) (default: the whole period, or zoomed to the response "
        "when it is short against the period)",
    )
    p.add_argument("--out", type=path_arg, required=True, help="output folder")
    p.set_defaults(func=_cmd_analyze)
