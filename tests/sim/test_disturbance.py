"""Turbulence and seed as property writes: :func:`probing.sim.flight.disturbance_properties`
is the one list of what :meth:`probing.sim.plant.Plant.disturb` writes (a separate JSBSim
process is given the same writes through its socket)."""

from __future__ import annotations

import pytest

from probing.core.sensors import FPS_PER_KT
from probing.sim.flight import (
    TURBULENCE_SEVERITY,
    TURBULENCE_WIND_20FT_KT,
    Flight,
    disturbance_properties,
)

SEEDS = ("simulation/randomseed", "atmosphere/randomseed")
TURBULENCE = (
    "atmosphere/turb-type",
    "atmosphere/turbulence/milspec/severity",
    "atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps",
)


@pytest.mark.parametrize("level", ["light", "moderate", "severe"])
def test_a_level_is_the_seeds_then_the_milspec_model_at_its_severity_and_wind(level):
    writes = disturbance_properties(level, 11)
    assert list(writes) == [*SEEDS, *TURBULENCE]
    assert writes == {
        "simulation/randomseed": 11.0,
        "atmosphere/randomseed": 11.0,
        "atmosphere/turb-type": 3.0,  # ttMilspec
        "atmosphere/turbulence/milspec/severity": float(TURBULENCE_SEVERITY[level]),
        "atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps": TURBULENCE_WIND_20FT_KT[level]
        * FPS_PER_KT,
    }
    assert all(type(v) is float for v in writes.values())


def test_calm_air_writes_the_seeds_only():
    assert disturbance_properties("none", 4) == {SEEDS[0]: 4.0, SEEDS[1]: 4.0}


def test_an_unknown_level_is_refused():
    with pytest.raises(ValueError, match="turbulence must be one of"):
        disturbance_properties("gale", 0)


class _Recorder:
    """An FGFDMExec stand-in that records the writes made to it, in order."""

    def __init__(self, fdm) -> None:
        self.fdm, self.writes = fdm, []

    def __getitem__(self, name):
        return self.fdm[name]

    def __setitem__(self, name, value) -> None:
        self.writes.append((name, value))
        self.fdm[name] = value


@pytest.mark.jsbsim
@pytest.mark.parametrize(("level", "seed"), [("moderate", 7), ("none", 5)])
def test_disturb_writes_exactly_the_properties_and_jsbsim_holds_them(level, seed):
    from probing.sim.plant import make_plant

    plant = make_plant(Flight("737", 15000.0, "speed_kcas", 280.0, 0.01))  # calm, seed 0
    wanted = disturbance_properties(level, seed)
    assert any(plant.fdm[name] != value for name, value in wanted.items())  # not there yet
    fdm, plant.fdm = plant.fdm, _Recorder(plant.fdm)
    plant.disturb(level, seed)
    written, plant.fdm = plant.fdm.writes, fdm
    assert [(name, float(value)) for name, value in written] == list(wanted.items())
    assert {name: fdm[name] for name in wanted} == wanted  # read back from JSBSim
    assert (plant.turbulence, plant.seed) == (level, seed)
