"""Write the excitation study's monitor sweeps: the three probe signals at one RMS.

Usage (from the repository root, after ``make setup``)::

    .venv/bin/python scenarios/excitations/generate.py   # rewrites its monitor-*.toml

The flight is the monitor study's (``scenarios/references/base.toml``: the GTM with NASA's T2
sensors, light turbulence, the ``gust`` reference, a sliding baseline), its probe an RMS of
0.2 deg on the elevator (order 8, 0.01 s bits, T = 2.55 s) as one of three signals:

* ``prbs``: the base's +-0.2 deg PRBS, estimator ``ac``;
* ``multisine``: harmonics of 1/T from 0.4 to 10 Hz, estimator ``spectral``;
* ``chirp``: a linear sweep over the same band, estimator ``spectral``.

Per signal, three sweeps: ``monitor-<signal>-none.toml`` (10 seeds of 100 periods, no fault:
the per-period gain scatter and false alarms), ``monitor-<signal>-effectiveness.toml`` (the
elevator's effectiveness scaled to 0.8) and ``monitor-<signal>-damage5.toml`` (NASA's case 5,
left elevator off), each with the monitor study's seeds and random onsets
(``scenarios/monitor-realisable/generate.py``, imported: one rule).  A sweep is named
``monitor-<fault>-<signal>`` (``monitor-effectiveness-chirp``): ``probing.analysis.monitoring``
reads the fault from the part after ``monitor-`` and takes the rest as what tells sweeps of
one fault apart.  Scored by ``probing/analysis/excitation_monitor.py``.  The files are committed;
running this again gives the same bytes.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from probing.core.faults import sweep_fields
from probing.sweep.spec import sweep_toml

HERE = Path(__file__).resolve().parent
BASE = "../references/base.toml"
BY = "Written by scenarios/excitations/generate.py."
#: The band of the multisine and chirp, Hz: from about the short period's frequency down to
#: the harmonics the period resolves, up to a fifth of the bit rate.
BAND_HZ = [0.4, 10.0]
#: signal -> the ``[fixed]`` fields that make the base's probe that signal (same RMS: a
#: multisine's or chirp's ``amplitude_deg`` is its RMS, the PRBS's +-a has RMS a).
SIGNALS: dict[str, dict[str, Any]] = {
    "prbs": {"output.estimator": "ac"},
    "multisine": {
        "probe.signal": "multisine",
        "probe.band_hz": BAND_HZ,
        "output.estimator": "spectral",
    },
    "chirp": {
        "probe.signal": "chirp",
        "probe.band_hz": BAND_HZ,
        "probe.sweep": "linear",
        "output.estimator": "spectral",
    },
}
#: The faults: file part -> (its type in probing.core.faults.FAULTS, its fields without
#: onset_s, the grid's fields, the monitor study's fault whose onsets it flies).  The scale
#: is in the grid: ``probing.analysis.monitoring`` reads it from the summary.
FAULTS: dict[str, tuple[str, dict[str, Any], dict[str, list[Any]], str]] = {
    "effectiveness": ("effectiveness", {}, {"fault.scale": [0.8]}, "effectiveness"),
    "damage5": ("gtm_damage", {"case": 5}, {}, "damage5"),
}
HEALTHY_SEEDS = list(range(201, 211))  # the seeds of the monitor study's flights without a fault


def _study() -> ModuleType:
    """The monitor study's generator (``scenarios/monitor-realisable/generate.py``)."""
    path = HERE.parent / "monitor-realisable" / "generate.py"
    spec = importlib.util.spec_from_file_location("monitor_realisable_generate", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def onsets_s(study: ModuleType, fault: str) -> list[float]:
    """The onsets (s) the monitor study flies ``fault`` at, one per seed: its rule
    (uniform over its onset periods, a generator seeded by the fault's place), rounded as
    it writes them."""
    index = list(study.FAULTS).index(fault)
    rng = np.random.default_rng(2000 + index)
    onsets = rng.uniform(*study.ONSET_PERIODS, study.SEEDS) * study.PERIOD_S
    return [round(float(t), 3) for t in onsets]


def main() -> None:
    study = _study()
    periods = study.ONSET_PERIODS[1] + study.AFTER_PERIODS
    for signal, probe in SIGNALS.items():
        base = {"probe.amplitude_deg": study.AMPLITUDE_DEG, "probe.periods": periods, **probe}
        grid = {"output.drift": ["gust"]}
        zipped = {"disturbance.seed": HEALTHY_SEEDS}
        text = f"{signal}, no fault: {len(HEALTHY_SEEDS)} seeds of {periods} periods, gust"
        tables = {"fixed": base, "grid": grid, "zip": zipped}
        sweep = sweep_toml(f"monitor-none-{signal}", text, BASE, tables, BY)
        (HERE / f"monitor-{signal}-none.toml").write_text(sweep)
        for name, (kind, fields, extra, onsets_of) in FAULTS.items():
            fixed = {**base, **sweep_fields(kind, fields)}
            zipped = {
                "disturbance.seed": list(range(1, study.SEEDS + 1)),
                "fault.onset_s": onsets_s(study, onsets_of),
            }
            text = f"{signal}, {name}: {study.SEEDS} seeds x random onsets, gust"
            tables = {"fixed": fixed, "grid": {**grid, **extra}, "zip": zipped}
            sweep = sweep_toml(f"monitor-{name}-{signal}", text, BASE, tables, BY)
            (HERE / f"monitor-{signal}-{name}.toml").write_text(sweep)


if __name__ == "__main__":
    main()
