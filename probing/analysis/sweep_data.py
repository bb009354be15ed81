"""A sweep folder read back for its figure: the summary and manifest (:class:`SweepData`,
:func:`load_sweep_data`) and which figure it gets (:func:`classify`).

No simulation is run; the points' scenarios are rebuilt from ``sweep.json`` on demand.
"""

from __future__ import annotations

import json
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from probing.analysis.seeds import has_seeds
from probing.core.errors import ProbingError
from probing.experiment.scenario import Scenario, ScenarioError, parse_scenario
from probing.sim.flight import SPEED_KINDS

__all__ = [
    "FAILED_STATUSES",
    "KINDS",
    "SPEED_FIELDS",
    "NotASweepError",
    "SweepData",
    "classify",
    "is_number",
    "load_sweep_data",
]

#: Figure layouts, in the order they are tried by :func:`classify` (``other`` last).
KINDS = ("flight_grid", "noise", "seeds", "rate_limit", "nonlinearity", "other")
FAILED_STATUSES = ("failed", "error")
SPEED_FIELDS = tuple(f"condition.{k}" for k in SPEED_KINDS)


class NotASweepError(ProbingError, FileNotFoundError):
    """The folder has no ``summary.parquet`` or ``sweep.json`` (or they cannot be read)."""


@dataclass
class SweepData:
    """A sweep folder's summary and manifest, with the points' scenarios rebuilt on demand.

    Attributes
    ----------
    folder : Path
        The sweep folder.
    name, description : str
        From the sweep file.
    manifest : dict
        ``sweep.json``.
    summary : pandas.DataFrame
        ``summary.parquet``, sorted by ``index``.
    fields : list of str
        The sweep's ``[grid]`` and ``[zip]`` keys, in order.
    varying : list of str
        Those of ``fields`` that take more than one value.
    zipped : list of str
        The ``[zip]`` keys (varied together).
    fixed : dict
        The sweep file's ``[fixed]`` changes.
    values : dict
        Point index -> its varied values (as written in ``sweep.json``).
    """

    folder: Path
    name: str
    description: str
    manifest: dict[str, Any]
    summary: pd.DataFrame
    fields: list[str]
    varying: list[str]
    zipped: list[str]
    fixed: dict[str, Any]
    values: dict[int, dict[str, Any]]
    _cache: dict[int | None, Scenario | None] = field(default_factory=dict, repr=False)

    @property
    def base(self) -> Scenario | None:
        """The base scenario with ``[fixed]`` applied, or None if it cannot be rebuilt."""
        if None not in self._cache:
            try:
                base = parse_scenario(self.manifest["base"])
                self._cache[None] = base.replace(self.fixed) if self.fixed else base
            except (ScenarioError, KeyError, TypeError):
                self._cache[None] = None
        return self._cache[None]

    def scenario(self, index: int) -> Scenario | None:
        """The scenario of point ``index`` (base, fixed, values), or None if not rebuildable."""
        if index not in self._cache:
            base = self.base
            try:
                scn = base.replace(self.values.get(index, {})) if base is not None else None
            except (ScenarioError, TypeError):
                scn = None
            self._cache[index] = scn
        return self._cache[index]

    def nl_type(self) -> str | None:
        """The nonlinearity type if the same at every point, else None."""
        types = set()
        for index in self.values:
            vals = self.values[index]
            if "nonlinearity.type" in vals:
                types.add(vals["nonlinearity.type"])
            elif "nonlinearity.type" in self.fixed:
                types.add(self.fixed["nonlinearity.type"])
            else:
                types.add(self.manifest.get("base", {}).get("nonlinearity", {}).get("type"))
        return types.pop() if len(types) == 1 else None


def _distinct(values: Sequence[Any]) -> int:
    return len({json.dumps(v, sort_keys=True, default=str) for v in values})


def load_sweep_data(folder: str | Path) -> SweepData:
    """Read a sweep folder's ``sweep.json`` and ``summary.parquet``.

    Parameters
    ----------
    folder : path
        A folder written by ``probing sweep`` (``<out>/<name>``).

    Returns
    -------
    SweepData
        The manifest and summary.

    Raises
    ------
    NotASweepError
        When either file is missing or unreadable.
    """
    folder = Path(folder)
    for file in ("summary.parquet", "sweep.json"):
        if not (folder / file).is_file():
            raise NotASweepError(
                f"{folder}: not a sweep folder (no {file}); run probing sweep first"
            )
    try:
        manifest = json.loads((folder / "sweep.json").read_text(encoding="utf-8"))
        summary = pd.read_parquet(folder / "summary.parquet")
    except Exception as exc:  # any unreadable file: one line for the user
        raise NotASweepError(
            f"{folder}: cannot read the sweep ({exc.__class__.__name__}: {exc})"
        ) from None
    if "index" in summary:
        summary = summary.sort_values("index").reset_index(drop=True)
    else:
        summary = summary.assign(index=np.arange(len(summary)))
    toml: dict[str, Any] = {}
    try:
        toml = tomllib.loads(manifest.get("sweep_toml") or "")
    except tomllib.TOMLDecodeError:
        pass
    fields = list(manifest.get("fields") or [])
    values = {int(p["index"]): dict(p.get("values", {})) for p in manifest.get("points", [])}
    if not values:  # no point list: take the values from the summary columns
        for row in summary.to_dict("records"):
            values[int(row["index"])] = {k: row[k] for k in fields if k in row}
    varying = [f for f in fields if _distinct([v.get(f) for v in values.values()]) > 1]
    return SweepData(
        folder=folder,
        name=str(manifest.get("name") or folder.name),
        description=str(toml.get("description") or ""),
        manifest=manifest,
        summary=summary,
        fields=fields,
        varying=varying,
        zipped=[k for k in toml.get("zip", {}) if k in fields],
        fixed=dict(toml.get("fixed", {})),
        values=values,
    )


# ------------------------------------------------------------------ classification
def is_number(v: Any) -> bool:
    """Whether ``v`` is an int or a float (not a bool)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def classify(data: SweepData) -> str:
    """Which figure a sweep gets: one of :data:`KINDS`.

    ``flight_grid`` when exactly the altitude and one speed vary; ``noise`` when a sensor
    noise level varies; ``seeds`` when the points repeat over 3 or more seeds
    (:mod:`probing.analysis.seeds`); ``rate_limit`` when every point has a rate limit and its
    rate (or r / (2a/t0)) varies; ``nonlinearity`` when only numeric parameters of one
    nonlinearity type vary; ``other`` otherwise.
    """
    varying = set(data.varying)
    speeds = varying & set(SPEED_FIELDS)
    if varying == {"condition.altitude_ft", *speeds} and len(speeds) == 1:
        return "flight_grid"
    if any(f.startswith("disturbance.sensor_noise.") for f in varying):
        return "noise"
    if has_seeds(data):
        return "seeds"
    nl_type = data.nl_type()
    if nl_type == "rate_limit":
        ratios = data.summary.get("rate_ratio", pd.Series(dtype=float)).to_numpy(dtype=float)
        if (
            "nonlinearity.rate_deg_s" in varying
            or _distinct([round(r, 12) for r in ratios[np.isfinite(ratios)]]) > 1
        ):
            return "rate_limit"
    nl_fields = [f for f in varying if f.startswith("nonlinearity.") and f != "nonlinearity.type"]
    numeric = all(is_number(v.get(f)) for v in data.values.values() for f in nl_fields)
    if (
        nl_fields
        and len(nl_fields) == len(varying)
        and numeric
        and nl_type not in (None, "none", "rate_limit")
    ):
        return "nonlinearity"
    return "other"
