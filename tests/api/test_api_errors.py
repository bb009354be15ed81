"""What a researcher meets calling the Python API with a wrong argument: the project's typed
error (a :class:`probing.ProbingError`) with one line naming the keyword, never a raw
TypeError, AttributeError or a library's exception, and never a command-line flag; or it
works.  None of these flies: each is refused before anything is simulated or written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import probing

ROOT = Path(__file__).resolve().parents[2]
CSV = ROOT / "examples" / "your-data" / "probe_response.csv"
SWEEP = ROOT / "tests" / "data" / "sweeps" / "backlash-small.toml"
ANALYZE = dict(input="elevator_deg", outputs=["q_rad_s", "theta_rad"], time="time_s", order=7)
ANALYZE = {**ANALYZE, "bit_duration_s": 0.04}
CONDITION = dict(aircraft="gtm_t2", altitude_ft=800, speed_kcas=75)


def _one_line(exc: BaseException) -> str:
    line = str(exc)
    assert "\n" not in line and "--" not in line, line  # a keyword, not a flag
    return line


# ------------------------------------------------------------------ Scenario.replace
def test_replace_takes_numpy_integers_and_refuses_a_key_that_is_no_name() -> None:
    scn = probing.example("fig4/a_deadband")
    changed = scn.replace({"probe.order": np.int64(7), "probe.amplitude_deg": np.int64(1)})
    assert changed.to_dict()["probe"]["order"] == 7
    assert type(changed.to_dict()["probe"]["order"]) is int
    assert (
        changed.amplitude_deg == 1.0
        and changed.digest() == scn.replace({"probe.order": 7, "probe.amplitude_deg": 1.0}).digest()
    )
    for key in (3, None, "", "probe..order"):
        with pytest.raises(probing.ScenarioError, match="must be a field's dotted name"):
            scn.replace({key: 7})
    with pytest.raises(probing.ScenarioError, match=r"got 7\.0"):
        scn.replace({"probe.order": 7.0})


def test_a_section_given_as_a_dict_replaces_the_whole_section() -> None:
    scn = probing.example("fig4/a_deadband")
    probe = scn.to_dict()["probe"]
    assert scn.replace({"probe": {**probe, "order": 7}}).to_dict()["probe"]["order"] == 7
    with pytest.raises(probing.ScenarioError, match=r"probe\.bit_duration_s: missing"):
        scn.replace({"probe": {"order": 7}})  # not merged into the section
    assert "replaces the section as a whole" in " ".join(scn.replace.__doc__.split())
