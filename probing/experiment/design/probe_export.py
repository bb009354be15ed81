"""A designed probe for a flight computer: one period of the m-sequence as a CSV table and as
a C header (``probing design ... --export-probe FILE``).

Both hold exactly the sequence the project flies, :func:`probing.core.prbs.mls` of the
scenario's order, from its first bit (the phase the probe starts with at the trim, t = 0):

* ``.csv``: one row per bit, ``time_s`` (the start of the bit, k t0) and
  ``command_<unit>`` (the surface command a sigma(k) relative to trim, in the probed
  surface's unit: ``command_deg``, or ``command_norm`` for the throttle); a flight computer
  holds each value for t0 and repeats the table cyclically.
* ``.h``: a ``static const int8_t`` array of +-1 (the unit sequence sigma), with the order,
  length, bit duration, amplitude and the generator (the feedback taps of
  :data:`probing.core.prbs.RECURRENCE`, its start state and bit mapping) in comments and
  as ``#define``s.
"""

from __future__ import annotations

from decimal import Decimal
from pathlib import Path

import numpy as np

from probing.core.prbs import RECURRENCE, mls
from probing.experiment.output.storage import write_text_atomic
from probing.experiment.scenario import Scenario

__all__ = ["EXPORT_SUFFIXES", "export_probe", "probe_csv", "probe_header", "step_decimals"]

#: The file kinds ``--export-probe`` writes, by the file's suffix.
EXPORT_SUFFIXES = (".csv", ".h")


def probe_csv(scn: Scenario) -> str:
    """One period of the scenario's probe, one row per bit, as CSV text.

    Parameters
    ----------
    scn : Scenario
        The scenario whose ``[probe]`` is exported (order n, bit duration t0 in s,
        amplitude a in the probed surface's unit).

    Returns
    -------
    str
        A header line ``time_s,command_<unit>`` and M = 2**n - 1 rows: the start of bit k,
        k t0 in s, as decimal text with the simulation step's decimals (t0 is a whole
        number of steps: ``5.10``, not the float product ``5.1000000000000005``), and the
        command a sigma(k) relative to trim, in the surface's unit, written with
        :func:`repr` so that it reads back exactly.
    """
    probe = scn.probe
    command = probe.amplitude_deg * mls(probe.order)
    decimals = step_decimals(scn.dt_s)
    lines = [f"time_s,command_{scn.surface_unit}"]
    for k, value in enumerate(command.tolist()):
        lines.append(f"{k * probe.bit_duration_s:.{decimals}f},{value!r}")
    return "\n".join(lines) + "\n"


def step_decimals(dt_s: float) -> int:
    """The decimals of a time step's shortest text (s): 2 for 0.01, 3 for 0.005, 0 for 1.

    Examples
    --------
    >>> [step_decimals(dt) for dt in (0.01, 0.005, 0.1, 1.0, 2.5, 1e-05)]
    [2, 3, 1, 0, 1, 5]
    """
    exponent = Decimal(repr(dt_s)).normalize().as_tuple().exponent
    assert isinstance(exponent, int)  # a finite step
    return max(0, -exponent)


def _taps_text(order: int) -> tuple[str, str]:
    """The generator polynomial and the recurrence of the order's m-sequence, as text."""
    lags = RECURRENCE[order]
    poly = " + ".join([f"x^{order}", *(f"x^{j}" if j else "1" for j in sorted(lags, reverse=True))])
    recurrence = " ^ ".join(f"b[k+{j}]" if j else "b[k]" for j in lags)
    return poly, f"b[k+{order}] = {recurrence}"


def probe_header(scn: Scenario) -> str:
    """One period of the scenario's unit probe sequence as a C header.

    Parameters
    ----------
    scn : Scenario
        The scenario whose ``[probe]`` is exported.

    Returns
    -------
    str
        C text: ``PROBE_ORDER``, ``PROBE_LENGTH`` (M = 2**n - 1), ``PROBE_BIT_DURATION_S``
        (t0, s) and ``PROBE_AMPLITUDE_<UNIT>`` (a, the probed surface's unit) as
        ``#define``s, and ``static const int8_t probe_sequence[PROBE_LENGTH]`` of +-1; the
        command is ``PROBE_AMPLITUDE_<UNIT> * probe_sequence[k]`` relative to trim during
        bit k.  The comments name the generator: the feedback taps, the all-ones start and
        the mapping bit 0 -> +1, bit 1 -> -1.
    """
    probe, unit = scn.probe, scn.surface_unit.upper()
    seq = mls(probe.order).astype(np.int8)
    poly, recurrence = _taps_text(probe.order)
    taps = ", ".join(str(j) for j in RECURRENCE[probe.order])
    guard = "PROBING_PROBE_H"
    rows = [", ".join(f"{v:2d}" for v in seq[i : i + 16]) for i in range(0, seq.size, 16)]
    lines = [
        f"/* Probe of scenario {scn.name!r}: one period of the m-sequence, written by",
        " * probing design --export-probe.",
        f" * surface: {scn.surface}; command = amplitude * probe_sequence[k] relative to trim,",
        " * held for one bit duration per value, repeated cyclically from k = 0 at t = 0.",
        f" * order n: {probe.order}",
        f" * bits M = 2^n - 1: {probe.length}",
        f" * bit duration t0: {probe.bit_duration_s!r} s",
        f" * amplitude a: {probe.amplitude_deg!r} {scn.surface_unit}",
        f" * feedback polynomial over GF(2): {poly}",
        f" * feedback taps: {taps}",
        f" * recurrence: {recurrence} (k >= 0)",
        f" * start state: b[0] .. b[{probe.order - 1}] = 1",
        " * mapping: bit 0 -> +1, bit 1 -> -1",
        " */",
        f"#ifndef {guard}",
        f"#define {guard}",
        "",
        "#include <stdint.h>",
        "",
        f"#define PROBE_ORDER {probe.order}",
        f"#define PROBE_LENGTH {probe.length}",
        f"#define PROBE_BIT_DURATION_S {probe.bit_duration_s!r}",
        f"#define PROBE_AMPLITUDE_{unit} {probe.amplitude_deg!r}",
        "",
        "static const int8_t probe_sequence[PROBE_LENGTH] = {",
        *(f"    {row}," for row in rows),
        "};",
        "",
        f"#endif /* {guard} */",
    ]
    return "\n".join(lines) + "\n"


def export_probe(scn: Scenario, path: str | Path) -> Path:
    """Write the scenario's probe to ``path``, its kind by the suffix (:data:`EXPORT_SUFFIXES`:
    ``.csv`` :func:`probe_csv`, ``.h`` :func:`probe_header`), atomically.

    Raises
    ------
    ValueError
        If the suffix is neither.
    """
    path = Path(path)
    writers = {".csv": probe_csv, ".h": probe_header}
    if path.suffix not in writers:
        raise ValueError(f"{path}: the file must end in .csv or .h")
    write_text_atomic(path, writers[path.suffix](scn))
    return path
