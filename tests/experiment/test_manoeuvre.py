"""Incremental probing through a manoeuvre on the GTM: the schedule is the ramp it claims, the
twin flies it, and period by period the probing output follows the single-pulse truth
started at mid-period: within its steady floor before and after, tracking a response that
changes by a third in between."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from probing.experiment.scenario import load_scenario
from probing.experiment.studies.manoeuvre import run_manoeuvre
from probing.sim.flight import Manoeuvre

ROOT = Path(__file__).resolve().parents[2]
SPEED = ROOT / "scenarios" / "manoeuvres" / "speed-4kt-s.toml"


def test_the_schedule_is_a_ramp() -> None:
    man = Manoeuvre("bank", -30.0, 10.0, 2.0)
    t = np.array([0.0, 2.0, 2.5, 4.0, 5.0, 6.0, 100.0])
    np.testing.assert_allclose(man.offset(t), [0, 0, -5, -20, -30, -30, -30])
    offsets = man.offsets(250, 2, 0.01)  # t = 2.5 and 2.51 s, bank in rad, the others 0
    np.testing.assert_allclose(offsets[:, 1], np.radians([-5.0, -5.1]))
    assert not offsets[:, [0, 2]].any()
    speed = Manoeuvre("speed", 10.0, 1.0, 0.0).offsets(100, 1, 0.01)  # 1 kt after 1 s
    assert speed[0, 2] == pytest.approx(1852.0 / 0.3048 / 3600.0)  # ft/s per kt
    assert man.duration_s == 3.0


@pytest.mark.jsbsim
def test_probing_output_follows_the_single_pulse_along_the_manoeuvre(tmp_path: Path) -> None:
    # 4 kt/s from 24.5 s (after the settle periods): the ramp ends at 29.5 s; the speed hold
    # overshoots and is still by 60 s
    scn = load_scenario(SPEED).replace({"probe.periods": 26, "manoeuvre.start_s": 24.5})
    result = run_manoeuvre(scn, tmp_path, progress=False)
    table = pd.read_parquet(result.out_dir / "manoeuvre.parquet")
    q = table[table.channel == "q_rad_s"]
    first = q.groupby("period").first()
    before = first[(first.index >= scn.settle_periods) & (first.time_mid_s < 24.5)].index
    after = first.index[-3:]
    err = result.errors["q_rad_s"]
    assert len(before) >= 1
    assert err[before].max() < 0.02  # the probe settled; nothing moves yet
    assert err[after].max() < 0.005  # the manoeuvre over: the steady floor (0.1 %)
    # the twin flew the manoeuvre: 20 kt faster at the end (its speed hold, within 1 kt)
    assert first.achieved.iloc[-1] == pytest.approx(20.0, abs=1.0)
    # and the response the probe reveals changed with it, as the truth did
    peak = q.groupby("period")[["h_est", "h_pulse"]].agg(lambda h: np.abs(h).max())
    grew = peak.loc[after[-1]] / peak.loc[before[-1]]
    assert grew.h_pulse > 1.3
    assert grew.h_est == pytest.approx(grew.h_pulse, rel=0.01)


def test_a_manoeuvre_must_start_before_the_run_ends() -> None:
    """start_s at the run's end is refused (the ramp would never act), as a fault's onset is;
    one step before the end is accepted."""
    from probing.experiment.scenario import ScenarioError

    scn = load_scenario(SPEED)
    end_s = scn.total_steps * scn.dt_s
    assert scn.replace({"manoeuvre.start_s": end_s - scn.dt_s}).manoeuvre is not None
    with pytest.raises(ScenarioError, match=r"manoeuvre.start_s.*before the run ends"):
        scn.replace({"manoeuvre.start_s": end_s})
