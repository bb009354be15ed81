"""Scenario files: TOML in, a validated, frozen :class:`Scenario` out (``docs/scenarios.md``).

The package's modules: the schema, :class:`ScenarioError` and the checks of one value
(:mod:`~probing.experiment.scenario.schema`), the probe's signal
(:mod:`~probing.experiment.scenario.probe_signal`), one parser per section
(:mod:`~probing.experiment.scenario.sections`, those a flight adds in
:mod:`~probing.experiment.scenario.flight_sections`), the rules between sections
(:mod:`~probing.experiment.scenario.rules`), and the scenario itself
(:mod:`~probing.experiment.scenario.scenario`).
"""

from probing.experiment.scenario.references import DRIFT_MODES
from probing.experiment.scenario.scenario import (
    Scenario,
    check_name,
    load_scenario,
    parse_scenario,
    read_toml,
)
from probing.experiment.scenario.schema import (
    DEFAULT_MAX_CROSSTALK,
    FAULT_TYPES,
    MAX_PERIODS,
    SECTIONS,
    ScenarioError,
    field_label,
)
from probing.experiment.scenario.sections import AMPLITUDE_MAX

__all__ = [
    "AMPLITUDE_MAX",
    "DEFAULT_MAX_CROSSTALK",
    "DRIFT_MODES",
    "FAULT_TYPES",
    "MAX_PERIODS",
    "SECTIONS",
    "Scenario",
    "ScenarioError",
    "check_name",
    "field_label",
    "load_scenario",
    "parse_scenario",
    "read_toml",
]
