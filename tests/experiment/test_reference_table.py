"""The references' table (probing.experiment.scenario.references): the scenario's, the live flight's
and the replay's rules follow from it."""

from __future__ import annotations

import pytest

from probing.experiment.flight import onboard
from probing.experiment.scenario.references import (
    DRIFT_MODES,
    REFERENCES,
    Reference,
    realisable_drifts,
)


def test_the_table_gives_every_rule():
    assert DRIFT_MODES == ("reference", "follow", "detrend", "none", "oracle", "nominal", "gust")
    assert [n for n, r in REFERENCES.items() if r.knows_gusts] == ["reference", "oracle"]
    assert [n for n, r in REFERENCES.items() if r.kind == "twin"] == [
        "reference",
        "oracle",
        "nominal",
    ]
    assert realisable_drifts() == ("follow", "detrend", "none", "nominal", "gust")
    assert set(onboard.SOURCES) == {n for n, r in REFERENCES.items() if r.kind == "log"}


def test_a_reference_of_an_unknown_kind_is_refused():
    with pytest.raises(ValueError, match="kind"):
        Reference("mine", "model")
