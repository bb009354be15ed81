"""Make flight.csv: a project flight's log written as a log recorded elsewhere, in the layout
map.toml reads (docs/formats.md, "A log recorded elsewhere").

    probing monitor examples/foreign-log/scenario.toml --out results/own
    python examples/foreign-log/make_flight.py results/own/gtm-flight-test/sensors.parquet \
        results/flight.csv

Each column the map names is renamed to the file's column and divided by the map's scale
(value_file = value_project / scale: rad -> deg, ft/s -> kt, ft -> m); floats are written
with repr, so they read back exactly.  Before the probe the log gets 2 s of rows
(-2 s < time <= 0) at the sensors' reading of the trim (the flight's own, from its footer),
the probe at 0, from which the map's ``mean_before_s = 2.0`` takes the trim reading; the
other columns hold their first logged value there.  Deterministic: the same flight gives the
same file.
"""

from __future__ import annotations

import json
import sys
import tomllib
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

BEFORE_S = 2.0  # the map's trim.mean_before_s


def main(log: Path, out: Path) -> Path:
    columns = tomllib.loads(Path(__file__).with_name("map.toml").read_text())["columns"]
    table = pq.read_table(log)
    trim = json.loads(pq.read_metadata(log).metadata[b"probing.trim_measured"])
    data = {name: table.column(name).to_numpy().astype(float) for name in table.column_names}
    t = data["time_s"]
    dt_s = float(t[1] - t[0])
    steps = round(BEFORE_S / dt_s)
    before = {"time_s": (np.arange(steps) - (steps - 1)) * dt_s}  # ... -dt, 0
    for name, values in data.items():
        if name == "time_s":
            continue
        level = 0.0 if name.startswith("probe_") else trim.get(name, values[0])
        before[name] = np.full(steps, level)
    header, rows = [], []
    for name, values in data.items():
        spec = columns.get(name, name)
        column, scale = (
            (spec, 1.0) if isinstance(spec, str) else (spec["column"], spec.get("scale", 1.0))
        )
        header.append(column)
        rows.append(np.concatenate([before[name], values]) / scale)
    with open(out, "w") as f:
        f.write(",".join(header) + "\n")
        for row in zip(*(r.tolist() for r in rows), strict=True):
            f.write(",".join(repr(v) for v in row) + "\n")
    return out


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: make_flight.py SENSORS.parquet FLIGHT.csv")
    print(main(Path(sys.argv[1]), Path(sys.argv[2])))
