"""The runs of the excitation comparison (``make excitations``, ``docs/excitations.md``): the
PRBS, a multisine and a chirp on one budget, through the paper's Fig. 4 nonlinearities, on
the GTM and the 737.

Each aircraft's Fig. 4 set (``scenarios/fig4``, ``scenarios/fig4-737``: baseline and the seven
panels at the paper's settings) is flown with each signal of :data:`SIGNALS`, the same order,
bits, periods and RMS deflection (the PRBS's +-a has RMS a; the others are scaled to RMS a),
the same calm air and the same unprobed twin as the reference; each baseline gets its ground
truth (``truth.parquet``, ``prediction.parquet``).  The baselines are flown again over
:data:`NOISE_SEEDS` seeds with white sensor noise (:data:`SENSOR_NOISE`) for the gain's
scatter over seeds.  Runs already stored with the same scenario digest are skipped; the
runs and their roles go to ``manifest.json``.  :mod:`probing.analysis.excitations` reads them.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from probing.experiment.output.storage import write_json_atomic
from probing.experiment.scenario import Scenario
from probing.experiment.studies.fig4 import BASELINE, PANELS, is_stored, load_set, run_missing
from probing.experiment.studies.truth import compute_truth

__all__ = [
    "BAND_HZ",
    "NOISE_SEEDS",
    "SENSOR_NOISE",
    "SETS",
    "SIGNALS",
    "planned",
    "run_study",
]

#: The band of the multisine and the chirp, Hz: from the second harmonic of the Fig. 4
#: period (T = 5.11 s: 0.39 Hz) to 10 Hz, the GTM's and the 737's short period and its
#: actuator with room on both sides; SIDPAC's flight-test multisines cover about this.
BAND_HZ = (0.2, 10.0)
#: Signal -> the ``[probe]`` fields that make it (the PRBS: none, the scenario as written).
SIGNALS: dict[str, dict[str, Any]] = {
    "prbs": {},
    "multisine": {"probe.signal": "multisine", "probe.band_hz": list(BAND_HZ)},
    "chirp": {"probe.signal": "chirp", "probe.band_hz": list(BAND_HZ), "probe.sweep": "linear"},
}
#: Aircraft -> its Fig. 4 set (a folder under the scenarios).
SETS = {"gtm": "fig4", "737": "fig4-737"}
#: Seeds of the noisy baselines.
NOISE_SEEDS = tuple(range(1, 9))
#: White sensor noise of the noisy baselines, per channel (rad, rad/s): about NASA's T2
#: pitch-attitude and pitch-rate noise (docs/monitoring.md) divided by 10, so that the 0.005
#: deg Fig. 4 probe's gain is measured to a few per cent.
SENSOR_NOISE = {"theta_rad": 1e-5, "q_rad_s": 1e-4}


def _variant(scn: Scenario, aircraft: str, signal: str, key: str, **extra: Any) -> Scenario:
    """``scn`` with ``signal``'s probe, named ``<aircraft>-<signal>-<key>``."""
    changes = {**SIGNALS[signal], **extra, "name": f"{aircraft}-{signal}-{key}"}
    if signal != "prbs":
        changes["output.estimator"] = "spectral"
    return scn.replace(changes)


def planned(scenarios_root: Path, out: Path) -> list[dict[str, Any]]:
    """Every run of the study: ``aircraft``, ``signal``, ``role`` (``baseline``, a panel key or
    ``noise``), ``seed``, ``scenario`` and ``folder`` (the run's parent folder).

    Raises
    ------
    probing.experiment.scenario.ScenarioError
        A Fig. 4 set that is missing or invalid.
    """
    runs = []
    for aircraft, set_name in SETS.items():
        scenarios = load_set(Path(scenarios_root) / set_name)
        for signal in SIGNALS:
            folder = Path(out) / aircraft / signal
            for key in (BASELINE, *PANELS):
                scn = _variant(scenarios[key], aircraft, signal, key)
                runs.append(_entry(aircraft, signal, key, 0, scn, folder))
            for seed in NOISE_SEEDS:
                scn = _variant(
                    scenarios[BASELINE],
                    aircraft,
                    signal,
                    f"noise-s{seed}",
                    **{"disturbance.seed": seed, "disturbance.sensor_noise": SENSOR_NOISE},
                )
                runs.append(_entry(aircraft, signal, "noise", seed, scn, folder))
    return runs


def _entry(
    aircraft: str, signal: str, role: str, seed: int, scn: Scenario, folder: Path
) -> dict[str, Any]:
    return {
        "aircraft": aircraft,
        "signal": signal,
        "role": role,
        "seed": seed,
        "scenario": scn,
        "folder": folder,
    }


def run_study(
    scenarios_root: Path,
    out: Path,
    *,
    jobs: int | None = None,
    log: Callable[[str], object] = print,
) -> Path:
    """Fly the runs not stored yet, the baselines' ground truth, and write
    ``out/manifest.json``; returns its path."""
    runs = planned(scenarios_root, out)
    out.mkdir(parents=True, exist_ok=True)
    todo = [(r["aircraft"], r["scenario"], r["folder"]) for r in runs]
    log(f"excitations: {len(todo)} runs, {sum(not _stored(r) for r in runs)} to fly")
    walls = run_missing(todo, False, jobs or os.cpu_count() or 1)
    log(f"  simulation: {sum(walls.values()):.1f} s")
    for r in runs:
        scn, folder = r["scenario"], r["folder"] / r["scenario"].name
        if r["role"] == BASELINE and (scn.name in walls or not (folder / "truth.parquet").exists()):
            compute_truth(scn, r["folder"])
    manifest = {
        "band_hz": list(BAND_HZ),
        "sensor_noise": SENSOR_NOISE,
        "runs": [
            {
                "aircraft": r["aircraft"],
                "signal": r["signal"],
                "role": r["role"],
                "seed": r["seed"],
                "folder": str((r["folder"] / r["scenario"].name).relative_to(out)),
            }
            for r in runs
        ],
    }
    path = out / "manifest.json"
    write_json_atomic(path, manifest)
    return path


def _stored(run: dict[str, Any]) -> bool:
    return is_stored(run["folder"] / run["scenario"].name, run["scenario"])
