"""Batch sweeps: one base scenario, a grid of changes, run in parallel and resumably.

A sweep file (``scenarios/sweeps/*.toml``, see ``docs/sweeps.md``)::

    name = "backlash-width"
    base = "../baseline-737.toml"          # relative to this file
    [fixed]                                # optional: changes applied to every point
    "probe.periods" = 6
    [grid]                                 # cartesian product of these lists
    "nonlinearity.type" = ["backlash"]
    "nonlinearity.width_deg" = [0.0, 0.0025, 0.005]
    [zip]                                  # optional: lists varied together (equal lengths)
    "probe.amplitude_deg" = [0.005, 0.01]
    "disturbance.sensor_noise.theta_rad" = [1e-5, 2e-5]

Keys are dotted scenario fields.  Every point is validated before anything runs.  A point is
identified by the digest of its fully resolved scenario (named after the sweep), and its
outputs (the files of ``probing run`` plus ``point.json``) appear atomically in
``<out>/<sweep>/points/point_id=<id>/`` (Hive-style, so the points form one dataset, see
:func:`open_dataset`).  The gain of each point is measured against the same scenario without
the nonlinearity, simulated once per distinct reference into ``references/point_id=<id>/``.
Finished runs are never redone or rewritten; a failed run (trim failure, divergence) is
recorded in ``failed/<id>.json`` and the sweep goes on.  ``summary.parquet`` has one row
per point.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from probing.experiment.flight.runners import runner_of
from probing.experiment.scenario import (
    SECTIONS,
    Scenario,
    ScenarioError,
    check_name,
    field_label,
    load_scenario,
    read_toml,
)
from probing.experiment.scenario.sections import resolve_model

__all__ = [
    "MAX_POINTS",
    "POINT_FILE",
    "SWEEP_KINDS",
    "Sweep",
    "SweepPoint",
    "load_sweep",
    "parse_sweep",
    "point_folder",
    "sweep_folders",
    "sweep_toml",
    "toml_value",
]

MAX_POINTS = 100_000
_TOP_KEYS = ("name", "base", "description", "kind", "fixed", "grid", "zip")
#: What a sweep's points run: ``probing run`` (the default) or ``probing monitor``.
SWEEP_KINDS = ("probing", "monitor")
#: The file that marks a finished run folder (written last, inside the folder).
POINT_FILE = "point.json"


def toml_value(value: Any) -> str:
    """A sweep or scenario value as TOML: a bool, a string, a list of them, or a number.

    Examples
    --------
    >>> toml_value([True, "a", 0.5])
    '[true, "a", 0.5]'
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return repr(value)


def sweep_toml(
    name: str,
    description: str,
    base: str,
    tables: dict[str, dict[str, Any]],
    written_by: str,
    kind: str = "monitor",
) -> str:
    """The text of a sweep file, as the study generators write them: a comment with the
    description and ``written_by``, the top keys, then the non-empty ``tables`` (``fixed``,
    ``grid``, ``zip``) in their order; :func:`load_sweep` reads it back."""
    lines = [
        f"# {description}",
        f"# {written_by}",
        f'name = "{name}"',
        f'description = "{description}"',
        f'base = "{base}"',
        f'kind = "{kind}"',
    ]
    for table, entries in tables.items():
        if entries:
            lines.append(f"\n[{table}]")
            lines += [f'"{k}" = {toml_value(v)}' for k, v in entries.items()]
    return "\n".join(lines) + "\n"


def sweep_folders(sweep_dir: Path) -> tuple[Path, Path, Path]:
    """``points/``, ``references/`` and ``failed/`` of a sweep folder."""
    return sweep_dir / "points", sweep_dir / "references", sweep_dir / "failed"


def point_folder(base: Path, run_id: str) -> Path:
    """The Hive-style folder of one run: ``<base>/point_id=<id>``."""
    return base / f"point_id={run_id}"


# ------------------------------------------------------------------ the sweep file
@dataclass(frozen=True)
class SweepPoint:
    """One point of a sweep.

    Attributes
    ----------
    index : int
        Position in the sweep (grid order, zip rows innermost).
    values : dict
        The varied fields (dotted keys) and their values at this point.
    scenario : Scenario
        The resolved scenario (named after the sweep).
    point_id : str
        ``scenario.digest()``: the point's identity and folder name.
    reference : Scenario
        The same scenario without the nonlinearity (the point itself when it has none).
    reference_id : str
        ``reference.digest()``.
    """

    index: int
    values: dict[str, Any]
    scenario: Scenario
    point_id: str
    reference: Scenario
    reference_id: str

    @property
    def is_own_reference(self) -> bool:
        """True when the point has no nonlinearity (its reference is itself)."""
        return self.point_id == self.reference_id


@dataclass(frozen=True)
class Sweep:
    """A validated sweep: its base scenario and every point."""

    name: str
    source: str
    text: str
    base: Scenario
    fields: tuple[str, ...]
    points: tuple[SweepPoint, ...]
    description: str = ""
    kind: str = "probing"

    def references(self) -> dict[str, Scenario]:
        """Distinct reference scenarios that are not themselves points, by id (none for a
        monitor sweep: its points measure no gain against a reference)."""
        if self.kind == "monitor":
            return {}
        ids = {p.point_id for p in self.points}
        return {p.reference_id: p.reference for p in self.points if p.reference_id not in ids}


def _checkfield_label(table: str, key: str, source: str) -> None:
    parts = key.split(".")
    label = _label(table, key)
    sections = [s for s, allowed in SECTIONS.items() if allowed is not None]
    if len(parts) < 2 or parts[0] not in sections or not all(parts):
        raise ScenarioError(
            label,
            f"not a dotted scenario field (section.field, sections: {', '.join(sections)})",
            source,
        )
    nested = len(parts) == 3 and (
        parts[:2] == ["disturbance", "sensor_noise"] or parts[0] == "sensors"
    )  # a channel's noise, or a field of a channel's sensor: sensors.theta_rad.bias
    if len(parts) > 2 and not nested:
        raise ScenarioError(label, "too many dots: a scenario field is section.field", source)


def _label(table: str, key: str) -> str:
    """``grid["probe.order"]``; keys that could break the one-line message are repr'd."""
    return f'{table}["{key}"]' if key.isprintable() else f"{table}[{key!r}]"


def _check_header(data: dict[str, Any], source: str) -> tuple[str, str, str]:
    """Check the top-level keys, ``name``, ``description`` and ``kind``; return the last three.

    A scenario file given as a sweep (no ``base``, a scenario's sections) is named as one.
    """
    sections = [k for k in data if k in SECTIONS and k not in _TOP_KEYS]
    if sections and "base" not in data:
        raise ScenarioError(
            "file",
            f"a scenario (it has [{sections[0]}]), not a sweep file: fly it with probing run, "
            "or vary it from a sweep file whose base it is (docs/sweeps.md)",
            source,
        )
    for key in data:
        if key not in _TOP_KEYS:
            raise ScenarioError(
                field_label(key), f"unknown field; allowed: {', '.join(_TOP_KEYS)}", source
            )
    name = data.get("name")
    if name is None:
        raise ScenarioError(
            "name", "missing (a plain file name, also the output folder name)", source
        )
    check_name(name, source)
    description = data.get("description", "")
    if not isinstance(description, str):
        raise ScenarioError("description", "must be a string", source)
    kind = data.get("kind", "probing")
    if kind not in SWEEP_KINDS:
        raise ScenarioError(
            "kind", f"must be one of {', '.join(SWEEP_KINDS)}; got {kind!r}", source
        )
    return name, description, kind


def _load_base(data: dict[str, Any], path: Path, source: str) -> Scenario:
    """Load the ``base`` scenario (relative to the sweep file) and check a sweep flies it."""
    base_rel = data.get("base")
    if not isinstance(base_rel, str) or not base_rel:
        raise ScenarioError("base", "missing: a scenario file, relative to the sweep file", source)
    base_path = path.parent / base_rel
    try:
        base = load_scenario(base_path)
    except ScenarioError as exc:
        raise ScenarioError("base", f"{base_rel}: {exc.field}: {exc.message}", source) from None
    refusal = runner_of(base).refuses("sweep")
    if refusal is not None:
        raise ScenarioError("base", f"{base_rel}: {refusal}", source)
    return base


def _read_tables(
    data: dict[str, Any], source: str
) -> tuple[dict[str, dict[str, Any]], dict[str, str], int]:
    """Check ``[fixed]``, ``[grid]`` and ``[zip]``; return them, the table of each key and the
    number of zip rows (1 without a zip)."""
    tables: dict[str, dict[str, Any]] = {}
    for table in ("fixed", "grid", "zip"):
        value = data.get(table, {})
        if not isinstance(value, dict):
            raise ScenarioError(table, 'must be a table of "section.field" = value(s)', source)
        for key in value:
            _checkfield_label(table, key, source)
        tables[table] = value
    seen: dict[str, str] = {}
    for table, entries in tables.items():
        for key in entries:
            if key in seen:
                raise ScenarioError(_label(table, key), f"already given in [{seen[key]}]", source)
            seen[key] = table
    for table in ("grid", "zip"):
        for key, values in tables[table].items():
            if not isinstance(values, list) or not values:
                raise ScenarioError(
                    _label(table, key), "must be a non-empty list of values", source
                )
    zip_lengths = {len(v) for v in tables["zip"].values()}
    if len(zip_lengths) > 1:
        lengths = ", ".join(f"{k}: {len(v)}" for k, v in tables["zip"].items())
        raise ScenarioError("zip", f"lists must have equal lengths, got {lengths}", source)
    if not tables["grid"] and not tables["zip"]:
        raise ScenarioError(
            "grid", "a sweep needs at least one varied field in [grid] or [zip]", source
        )
    n_zip = zip_lengths.pop() if tables["zip"] else 1
    n_points = math.prod(len(v) for v in tables["grid"].values()) * n_zip
    if n_points > MAX_POINTS:
        raise ScenarioError("grid", f"{n_points} points; at most {MAX_POINTS} allowed", source)
    return tables, seen, n_zip


def _point_scenario(
    base: Scenario,
    changes: dict[str, Any],
    values: dict[str, Any],
    index: int,
    seen: dict[str, str],
    source: str,
) -> Scenario:
    """The base scenario with one point's changes; an invalid point names its values."""
    try:
        return base.replace(changes)
    except ScenarioError as exc:
        where = ", ".join(f"{k}={v!r}" for k, v in values.items())
        table = seen.get(exc.field)
        label = _label(table, exc.field) if table else exc.field
        raise ScenarioError(label, f"{exc.message} (point {index}: {where})", source) from None


def _check_monitor_point(scn: Scenario, values: dict[str, Any], index: int, source: str) -> None:
    """Check that a point of a monitor sweep has valid monitor settings."""
    try:
        scn.monitor_settings()
    except ScenarioError as exc:
        where = ", ".join(f"{k}={v!r}" for k, v in values.items())
        raise ScenarioError(exc.field, f"{exc.message} (point {index}: {where})", source) from None


def parse_sweep(data: dict[str, Any], *, path: str | Path, text: str = "") -> Sweep:
    """Validate a parsed sweep file and resolve every point.

    Parameters
    ----------
    data : dict
        The parsed TOML.
    path : path
        The sweep file (``base`` is relative to its folder; also the error prefix).
    text : str
        The file text, kept for provenance.

    Raises
    ------
    ScenarioError
        For the first problem: an unknown key, an empty or mismatched list, a bad base, or a
        point that is not a valid scenario (the message names the point).
    """
    path = Path(path)
    source = str(path)
    name, description, kind = _check_header(data, source)
    base = _load_base(data, path, source)
    tables, seen, n_zip = _read_tables(data, source)

    grid_keys = list(tables["grid"])
    zip_keys = list(tables["zip"])
    combos = itertools.product(*(tables["grid"][k] for k in grid_keys))
    points: list[SweepPoint] = []
    by_id: dict[str, int] = {}
    for index, (combo, row) in enumerate(itertools.product(combos, range(n_zip))):
        values = dict(zip(grid_keys, combo, strict=True))
        values.update({k: tables["zip"][k][row] for k in zip_keys})
        changes = {**tables["fixed"], **values, "name": name}
        if isinstance(changes.get("aircraft.model"), str):  # a path: from the sweep file
            changes["aircraft.model"] = resolve_model(changes["aircraft.model"], path.parent)
        scn = _point_scenario(base, changes, values, index, seen, source)
        pid = scn.digest()
        if pid in by_id:
            raise ScenarioError(
                "grid",
                f"points {by_id[pid]} and {index} are the same scenario (repeated value?)",
                source,
            )
        by_id[pid] = index
        ref = scn if scn.nonlinearity == "none" else scn.replace({"nonlinearity.type": "none"})
        if kind == "monitor":
            _check_monitor_point(scn, values, index, source)
        points.append(SweepPoint(index, values, scn, pid, ref, ref.digest()))
    return Sweep(
        name=name,
        source=source,
        text=text,
        base=base,
        fields=tuple(grid_keys + zip_keys),
        points=tuple(points),
        description=description,
        kind=kind,
    )


def load_sweep(path: str | Path) -> Sweep:
    """Read and validate a sweep file (see the module docstring).

    Raises
    ------
    ScenarioError
        With the file name, the field and what is allowed.
    """
    path = Path(path)
    data, text = read_toml(path)
    return parse_sweep(data, path=path, text=text)
