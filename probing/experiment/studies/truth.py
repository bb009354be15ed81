"""Ground truth for a scenario, written beside its run: ``truth.parquet`` and the probing
output it predicts, ``prediction.parquet``.

The pulse responses come from :mod:`probing.sim.truth` (single pulse and linearisation).
A probing run folds the tail of h that lies beyond one period into its M taps and has not
reached a periodic steady state while the phugoid still rings, so the like-for-like
comparison is a *prediction*: the superposition of the single-pulse response over the actual
probe history, pushed through the same correlator (same layout as ``probing.parquet``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from probing.experiment.flight.drift import predicted_probing
from probing.experiment.output.storage import (
    OutputFolder,
    output_folder,
    probing_block,
    provenance,
)
from probing.experiment.scenario import Scenario
from probing.sim.truth import linear_pulse_response, single_pulse_response

__all__ = [
    "TruthFiles",
    "compute_truth",
    "predicted_probing",
    "write_truth",
]


def compute_truth(scn: Scenario, out: str | Path) -> Path:
    """Write ``truth.parquet`` and ``prediction.parquet`` into ``out/<name>/``.

    ``truth.parquet``: channel, tap, lag_s, h_pulse, h_lin (NaN where the linear model has
    no such output), over the whole run length.  They are added to the run of the same
    scenario in that folder; the files of a run of another scenario there are removed
    (:func:`probing.experiment.output.storage.output_folder`).  Returns the path of
    ``truth.parquet``.
    """
    folder = Path(out) / scn.name
    meta = provenance(scenario_toml=scn.text, scenario=scn.to_dict(), scenario_digest=scn.digest())
    with output_folder(folder, meta, adds=True) as outputs:
        write_truth(scn, outputs)
    return folder / "truth.parquet"


def write_truth(scn: Scenario, outputs: OutputFolder) -> None:
    """Compute the ground truth of ``scn`` and write its two files into an open folder."""
    probe = scn.probe
    m = probe.length
    n_bits = scn.periods * m
    spb = probe.steps_per_bit(scn.dt_s)
    h_pulse = single_pulse_response(scn.flight, scn.channels, scn.amplitude_deg, spb, n_bits)
    h_lin = linear_pulse_response(scn.flight, scn.channels, scn.bit_duration_s, n_bits)
    pred = predicted_probing(scn, h_pulse)
    channels = list(scn.channels)
    w_truth = outputs.writer("truth.parquet", channels)
    w_pred = outputs.writer("prediction.parquet", channels)
    taps = np.arange(n_bits, dtype=np.int32)
    lag_s = np.arange(m) * probe.bit_duration_s
    for channel in channels:
        w_truth.write(
            {
                "channel": [channel] * n_bits,
                "tap": taps,
                "lag_s": taps * probe.bit_duration_s,
                "h_pulse": h_pulse[channel],
                "h_lin": h_lin.get(channel, np.full(n_bits, np.nan)),
            }
        )
        z, zeta, h = (pred[channel][:, None, k] for k in range(3))
        w_pred.write(probing_block([channel], np.arange(len(z)), lag_s, z, zeta, h))


class TruthFiles:
    """A run's observer that writes the scenario's ground truth into the run's folder, so
    ``probing run --truth`` writes one run's files: they appear together, or none does.

    Parameters
    ----------
    scn : Scenario
        The scenario being run.
    """

    def __init__(self, scn: Scenario) -> None:
        self.scn = scn
        self.outputs: OutputFolder | None = None

    def open(self, outputs: OutputFolder) -> None:
        """Keep the run's folder."""
        self.outputs = outputs

    def update(
        self,
        periods: np.ndarray,
        h: np.ndarray,
        z: np.ndarray,
        trajectory: tuple[np.ndarray, np.ndarray] | None = None,
        isolation: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
    ) -> None:
        """Nothing to follow period by period."""

    @property
    def isolation_checks(self) -> dict[str, tuple[str, ...]]:
        """None: it reads no isolation check."""
        return {}

    def finish(self) -> None:
        """Write ``truth.parquet`` and ``prediction.parquet`` beside the run's files."""
        assert self.outputs is not None
        write_truth(self.scn, self.outputs)
