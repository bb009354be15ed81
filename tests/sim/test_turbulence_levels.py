"""The turbulence levels at low altitude against MIL-F-8785C: below 1000 ft JSBSim's
MIL-spec model takes its intensity from the wind 20 ft above ground (sigma_w = 0.1 W20),
not from the severity, so each level sets W20 (15, 30, 45 kt)."""

from __future__ import annotations

import numpy as np
import pytest

from probing.core.sensors import FPS_PER_KT
from probing.sim.flight import TURBULENCE_WIND_20FT_KT, Flight
from probing.sim.plant import make_plant

pytestmark = pytest.mark.jsbsim

STEPS = 60000  # 600 s: about 100 of the vertical gust's correlation times (L_w / V = 6 s)


def _vertical_gust_sd(level: str) -> float:
    plant = make_plant(Flight("gtm_t2", 800.0, "speed_kcas", 75.0, 0.01, turbulence=level))
    node = plant.fdm.get_property_manager().get_node("atmosphere/turb-down-fps")
    fdm = plant.fdm
    w = np.empty(STEPS)
    for k in range(STEPS):
        fdm["fcs/elevator-cmd-norm"] = fdm["fcs/elevator-cmd-norm"]
        fdm.run()
        w[k] = node.get_double_value()
    return float(w.std())


@pytest.mark.parametrize("level", ["light", "moderate"])
def test_the_vertical_gust_has_the_milspec_intensity_of_its_level(level):
    """sigma_w = 0.1 W20 within the sampling error of 600 s (about 10 %)."""
    expected = 0.1 * TURBULENCE_WIND_20FT_KT[level] * FPS_PER_KT
    assert _vertical_gust_sd(level) == pytest.approx(expected, rel=0.2)


def test_the_levels_differ_at_low_altitude():
    assert TURBULENCE_WIND_20FT_KT["moderate"] == 2 * TURBULENCE_WIND_20FT_KT["light"]
    light, moderate = _vertical_gust_sd("light"), _vertical_gust_sd("moderate")
    # the same draws, scaled (to within how the doubled gusts move the aircraft, L and V)
    assert moderate / light == pytest.approx(2.0, rel=0.01)
