"""``probing analyze``: pulse compression on a recorded file (docs/analyze.md)."""

from __future__ import annotations

import argparse

from probing.cli.common import (
    Subcommands,
    UsageError,
    argument_usage,
    command,
    files_of,
    number_arg,
    out_folder,
    path_arg,
)

#: The Python keywords of :func:`probing.api.analyze` whose option is another.
_RENAMED = {"outputs": "--output", "file": "FILE"}


def _cmd_analyze(args: argparse.Namespace) -> int:
    """``probing analyze``: ``analyze(...).save(out)`` (:func:`probing.api.analyze`)."""
    from probing.api import analyze
    from probing.api.flight import FIGURE_NAME
    from probing.core.errors import ArgumentError
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
    except ArgumentError as exc:
        raise argument_usage(exc, _RENAMED) from None
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
    from probing.experiment.recorded.record import DRIFTS

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
    base.add_argument("--dt-s", type=number_arg, help="sample step (s)")
    p.add_argument(
        "--order", type=number_arg, required=True, help="m-sequence order n (M = 2^n - 1)"
    )
    p.add_argument("--bit-duration-s", type=number_arg, required=True, help="bit duration t0 (s)")
    p.add_argument(
        "--amplitude",
        type=number_arg,
        help="probe amplitude a in the probe's unit (default: half the difference of the "
        "probe column's two levels)",
    )
    drift = p.add_mutually_exclusive_group()
    drift.add_argument(
        "--drift",
        choices=DRIFTS,
        default="detrend",
        help="detrend: a periodic part and a linear trend fitted together, the trend and the "
        "mean removed; none: the mean removed",
    )
    drift.add_argument(
        "--reference", metavar="COL", help="a reference subtracted from each output instead"
    )
    p.add_argument(
        "--settled-after-s",
        type=number_arg,
        metavar="S",
        help="without --reference: the lag (s) from which the response has settled; the taps "
        "from there pin the estimate's constant (default: the last quarter of the period)",
    )
    p.add_argument(
        "--max-lag-s",
        type=number_arg,
        metavar="S",
        help="the figure's last lag (s) (default: the whole period, or zoomed to the response "
        "when it is short against the period)",
    )
    p.add_argument("--out", type=path_arg, required=True, help="output folder")
    p.set_defaults(func=_cmd_analyze)
