"""The flight computer's consumer of a chunk (probing.experiment.flight.flight_computer)
without an aircraft: a made-up log, a reference that diverges where the test says, and a
monitor that records what it is told."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from probing.experiment.flight.flight_computer import FlightComputer, ReferenceDiverged
from probing.experiment.flight.onboard import ReferenceLost
from probing.experiment.output.storage import metadata, output_folder
from probing.experiment.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
#: Order 5 (M = 31), two steps per bit: 62 steps a period; two chunks of three periods.
SCN = load_scenario(ROOT / "tests" / "data" / "sweeps" / "base-737-small.toml").replace(
    {"probe.periods": 6, "output.estimator": "ac"}
)
CHUNK = 3
STEPS = SCN.probe.length * SCN.steps_per_bit


class _Diverging:
    """A reference flat at 0 that diverges in period ``at`` of the flight (None: never),
    found at that period's last step: it hands back the whole periods before, as the
    references do (:class:`ReferenceLost`)."""

    def __init__(self, at: int | None) -> None:
        self.at, self.first = at, 0

    def next(self, log):
        rows = len(log["time_s"])
        first, self.first = self.first, self.first + rows // STEPS
        if self.at is not None and first <= self.at < self.first:
            flown = np.zeros(((self.at - first) * STEPS, len(SCN.channels)))
            raise ReferenceLost(f"aircraft hit the ground at t = {(self.at + 1) * 1.24} s", flown)
        return np.zeros((rows, len(SCN.channels)))


class _Told:
    """A monitor that keeps the periods it is told."""

    def __init__(self) -> None:
        self.periods: list[int] = []
        self.isolation_checks: dict[str, tuple[str, ...]] = {}

    def open(self, outputs) -> None:
        pass

    def update(self, periods, h, z, trajectory=None, isolation=None) -> None:
        self.periods += periods.tolist()

    def finish(self) -> None:
        pass


@pytest.mark.parametrize("at", [None, 3, 4, 5])
def test_a_reference_diverging_in_a_chunk_ends_the_flight_at_that_chunk(at, tmp_path):
    """The second chunk (periods 3, 4, 5) with a reference that diverges in period ``at``:
    the whole periods before it are written and told to the monitor, then the flight ends
    (ReferenceDiverged, with the reference's reason); diverging in the chunk's last period
    (found at the chunk's last step) ends it as one in its middle does, and in its first
    period nothing of the chunk is told.  A reference that does not diverge goes on."""
    rng = np.random.default_rng(0)
    told = _Told()
    computer = FlightComputer(SCN, None, np.zeros(2), _Diverging(at), CHUNK, told)
    with output_folder(tmp_path / "f", metadata(test=True)) as outputs:
        computer.open(outputs, np.arange(SCN.probe.length) * SCN.probe.bit_duration_s)
        for first in (0, CHUNK):
            rows = CHUNK * STEPS
            log = {"time_s": (first * STEPS + np.arange(1, rows + 1)) * SCN.dt_s}
            log |= {c: 1e-3 * rng.standard_normal(rows) for c in SCN.channels}
            if at is None or first == 0:
                computer.consume(log, first)
                continue
            with pytest.raises(ReferenceDiverged, match=r"^the reference: aircraft hit"):
                computer.consume(log, first)
        computer.finish(outputs)
    flown = list(range(6 if at is None else at))
    assert told.periods == flown
    written = pd.read_parquet(tmp_path / "f" / "probing.parquet")
    assert sorted(set(written.period)) == flown
