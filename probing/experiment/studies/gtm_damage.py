"""NASA's Example 6 on the GTM: each damage case switched on in a steady climbing turn.

NASA's ``example6.m`` trims the undamaged T2 in a 45 deg bank climbing turn at 95 kt EAS and
3 deg flight-path angle, holds every control at its trim value (open loop), switches a damage
case on at 10 s and simulates to 15 s.  :func:`fly` does the same on ``gtm_t2``
(the turn trimmed at zero sideslip as NASA's ``trimgtm.m`` trims it,
:meth:`probing.sim.plant.Plant.trim`; the damage as a fault at its onset,
:meth:`~probing.sim.plant.Plant.schedule`); :func:`run_example6` flies the undamaged aircraft
and the six cases and writes one Parquet time history per case, with the trim (JSBSim's turn
trim it started from and the zero-sideslip one) in its metadata.  ``probing gtm-damage`` draws
them and writes the summary (:mod:`probing.analysis.gtm_damage`).
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import numpy as np

from probing.experiment.output.storage import AtomicParquetWriter, provenance
from probing.experiment.studies.gtm_damage_set import EXAMPLE6, SCHEMA, SIGNALS, Example6, case_file
from probing.sim.flight import DAMAGE_CASES, DAMAGE_MODEL, Flight
from probing.sim.plant import TurnTrim, make_plant
from probing.sim.world import JSBSimWorld

__all__ = ["EXAMPLE6", "SIGNALS", "Example6", "case_file", "fly", "run_example6"]


def fly(case: int, setup: Example6 = EXAMPLE6) -> tuple[dict[str, np.ndarray], TurnTrim]:
    """Trim in the turn, fly ``setup.end_s`` open loop with damage ``case`` from onset.

    Parameters
    ----------
    case : int
        0 (undamaged) or a damage case 1..6.
    setup : Example6
        Trim and timing.

    Returns
    -------
    dict
        ``time_s`` and every column of :data:`SIGNALS`, one sample per step, the first at
        the trim (t = 0).
    TurnTrim
        How the turn was trimmed (JSBSim's turn trim, beta free, and the zero-sideslip
        trim flown: attitude, controls, the six accelerations).
    """
    flight = Flight(
        DAMAGE_MODEL,
        setup.altitude_ft,
        "speed_keas",
        setup.speed_keas,
        setup.dt_s,
        damage_case=case,
        damage_onset_s=setup.onset_s if case else None,  # trimmed undamaged, damaged in flight
        gamma_deg=setup.gamma_deg,
        bank_deg=setup.bank_deg,
    )
    plant = make_plant(flight)
    assert plant.turn_trim is not None  # a turn
    manager = plant.fdm.get_property_manager()
    nodes = [manager.get_node(prop) for prop, _, _ in SIGNALS.values()]
    out = np.empty((round(setup.end_s / setup.dt_s) + 1, len(nodes)))
    out[0] = [node.get_double_value() for node in nodes]
    JSBSimWorld(plant).fly(len(out) - 1, nodes, out[1:])  # open loop; damaged from the onset
    out *= [factor for _, factor, _ in SIGNALS.values()]
    columns = {"time_s": np.arange(out.shape[0]) * setup.dt_s}
    columns.update({c: out[:, j] for j, c in enumerate(SIGNALS)})
    return columns, plant.turn_trim


def run_example6(folder: Path, setup: Example6 = EXAMPLE6) -> list[Path]:
    """Fly the undamaged aircraft and the six damage cases; one Parquet file per case.

    Each file carries the set-up, the case and its name, the turn trim
    (:class:`~probing.sim.plant.TurnTrim`) and the versions (metadata ``probing.*``); its
    columns carry their units.
    """
    paths = []
    for case in range(len(DAMAGE_CASES) + 1):
        columns, trim = fly(case, setup)
        name = "undamaged" if case == 0 else DAMAGE_CASES[case - 1]
        meta = provenance(
            example6=asdict(setup), case=case, case_name=name, turn_trim=trim.to_dict()
        )
        path = case_file(folder, case)
        path.parent.mkdir(parents=True, exist_ok=True)
        writer = AtomicParquetWriter(path, SCHEMA, meta)
        writer.write(columns)
        writer.close()
        paths.append(path)
    return paths
