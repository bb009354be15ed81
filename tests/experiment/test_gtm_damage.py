"""NASA's Example 6: the steady climbing-turn trim, damage switched on in flight, the summary."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from conftest import BLAS_KERNELS, run_with_blas_kernel

from probing.analysis import gtm_damage
from probing.cli import main as cli_main
from probing.experiment.studies.gtm_damage import EXAMPLE6, fly, run_example6
from probing.sim.flight import Flight

pytestmark = pytest.mark.jsbsim

SHORT = dataclasses.replace(EXAMPLE6, onset_s=0.5, end_s=1.0)
G_FT_S2 = 32.174


#: JSBSim's six body-axis accelerations (ft/s^2, rad/s^2), read straight from its properties.
ACCELERATION_PROPERTIES = tuple(
    f"accelerations/{axis}dot-{unit}"
    for axis, unit in zip("uvwpqr", ["ft_sec2"] * 3 + ["rad_sec2"] * 3, strict=True)
)


def _assert_zero_sideslip_turn(fdm, bank_deg: float = 45.0, gamma_deg: float = 3.0) -> None:
    """The state is NASA's trimmed turn: beta 0, bank, climb and EAS as asked, and every one of
    JSBSim's six accelerations (read here from its properties) zero to 1e-9."""
    assert abs(fdm["aero/beta-deg"]) < 1e-9
    assert fdm["attitude/phi-deg"] == pytest.approx(bank_deg, abs=1e-9)
    assert fdm["flight-path/gamma-deg"] == pytest.approx(gamma_deg, abs=1e-9)
    assert fdm["velocities/ve-kts"] == pytest.approx(95.0, abs=1e-6)
    for prop in ACCELERATION_PROPERTIES:
        assert abs(fdm[prop]) < 1e-9, (prop, fdm[prop])


def test_turn_trim_holds_zero_sideslip_as_nasa_does(new_plant) -> None:
    """NASA's Example 6 trim (``trimgtm.m``: beta 0 by default, yaw rate free): the bank,
    climb and EAS asked for at zero sideslip with all six accelerations zero, where JSBSim's
    own turn trim (its start) leaves beta at -0.3 deg; the turn rate is the side-force
    balance's, 1.4 % below the coordinated g tan(phi) / (V cos(gamma)); and the open-loop
    aircraft holds the turn for 2 s (beta within 0.001 deg)."""
    plant = new_plant("gtm_t2", EXAMPLE6.dt_s)
    trim = plant.trim(800.0, speed_keas=95.0, gamma_deg=3.0, bank_deg=45.0)
    fdm = plant.fdm
    _assert_zero_sideslip_turn(fdm)
    assert trim.mode == "turn" and trim.alpha_deg == fdm["aero/alpha-deg"]
    start, trimmed = plant.turn_trim.jsbsim, plant.turn_trim.trimmed
    assert start.beta_deg < -0.3 and start.worst_acceleration > 1e-5  # JSBSim's, beta free
    assert trimmed.beta_deg == fdm["aero/beta-deg"]
    assert trimmed.accelerations["rdot_rad_s2"] == fdm["accelerations/rdot-rad_sec2"]
    v = fdm["velocities/vt-fps"]
    coordinated = G_FT_S2 * math.tan(math.radians(45.0)) / (v * math.cos(math.radians(3.0)))
    assert fdm["velocities/psidot-rad_sec"] == pytest.approx(0.986 * coordinated, rel=0.003)
    assert -0.6 < trimmed.rudder_deg < -0.2  # trailing edge right, nose right: into the turn
    for _ in range(400):  # 2 s
        fdm.run()
    assert abs(fdm["aero/beta-deg"]) < 1e-3
    assert fdm["attitude/phi-deg"] == pytest.approx(45.0, abs=0.01)
    assert fdm["flight-path/gamma-deg"] == pytest.approx(3.0, abs=0.01)


def test_the_rudder_holds_zero_sideslip_in_a_damaged_turn() -> None:
    """Trimmed in the turn with the left outboard flap already gone (case 3), the aircraft
    still flies it at zero sideslip with every acceleration zero: the aileron holds the roll
    bias, and the rudder, more than twice the undamaged turn's, the yaw; JSBSim's turn trim
    needed 0.6 deg of sideslip instead.  Without a rudder (case 1) there is no such trim."""
    from probing.sim.errors import TrimError
    from probing.sim.plant import make_plant

    turn = Flight("gtm_t2", 800.0, "speed_keas", 95.0, EXAMPLE6.dt_s, gamma_deg=3.0, bank_deg=45.0)
    undamaged = make_plant(turn).turn_trim.trimmed
    plant = make_plant(dataclasses.replace(turn, damage_case=3))
    _assert_zero_sideslip_turn(plant.fdm)
    trimmed = plant.turn_trim.trimmed
    assert plant.turn_trim.jsbsim.beta_deg < -0.5
    assert trimmed.rudder_deg < 2.0 * undamaged.rudder_deg < -0.5
    assert trimmed.aileron_deg < -5.0 < undamaged.aileron_deg
    nudged = plant.fdm
    nudged["fcs/rudder-cmd-norm"] += 0.5 / 30.0  # half a degree more rudder: yaw no longer
    nudged.run_ic()
    assert abs(nudged["accelerations/rdot-rad_sec2"]) > 1e-3
    with pytest.raises(TrimError, match="rdot"):
        make_plant(dataclasses.replace(turn, damage_case=1))


def test_the_damage_acts_from_the_step_after_onset() -> None:
    """Up to the onset sample the damaged flight is the undamaged one to the bit; from the
    next step on it is not (vertical tail off: the side force and yaw change at once)."""
    calm, hit = fly(0, SHORT)[0], fly(2, SHORT)[0]
    onset = round(SHORT.onset_s / SHORT.dt_s)
    assert calm["time_s"][onset] == pytest.approx(SHORT.onset_s)
    for column in ("beta_deg", "r_deg_s", "phi_deg", "alpha_deg"):
        assert np.array_equal(calm[column][: onset + 1], hit[column][: onset + 1]), column
    assert not np.array_equal(calm["r_deg_s"][onset + 1 :], hit["r_deg_s"][onset + 1 :])
    assert len(calm["time_s"]) == round(SHORT.end_s / SHORT.dt_s) + 1


#: NASA's Example 6, case 4 (left wing tip off), read off its plot ("Example-6:
#: DamageCase-04"): bank at 15 s (unwrapped), the peaks of alpha and of the roll rate after
#: onset, EAS at 15 s; and how far this model may be from each.  With the CG moved by dCG
#: alone (not as NASA's block diagram moves it) the model gave -408 deg, 5.7 deg,
#: -113 deg/s and 121 kt; with NASA's CG -498 deg, 7.3 deg, -130 deg/s, 115 kt.
NASA_CASE4 = {
    "bank_deg": (-510.0, 25.0),
    "alpha_deg": (7.2, 0.4),
    "p_deg_s": (-125.0, 8.0),
    "eas_kt": (115.0, 2.0),
}


def test_case4_rolls_as_nasas_plot() -> None:
    """The lost wing tip (case 4) with the CG where NASA's simulation puts it rolls through
    about 1.4 turns by 15 s, with NASA's alpha, roll rate and speed."""
    c = fly(4)[0]
    after = c["time_s"] >= EXAMPLE6.onset_s
    got = {
        "bank_deg": float(np.degrees(np.unwrap(np.radians(c["phi_deg"])))[-1]),
        "alpha_deg": float(c["alpha_deg"][after].max()),
        "p_deg_s": float(c["p_deg_s"][after].min()),
        "eas_kt": float(c["eas_kt"][-1]),
    }
    for name, (nasa, tolerance) in NASA_CASE4.items():
        assert abs(got[name] - nasa) <= tolerance, (name, got[name], nasa)


def test_damage_is_refused_where_it_does_not_exist(new_plant) -> None:
    with pytest.raises(ValueError, match=r"0\.\.6"):
        new_plant("gtm_t2", EXAMPLE6.dt_s).damage(7)
    with pytest.raises(ValueError, match="gtm_t2 only"):
        new_plant("737", 0.01).damage(1)


#: What each of NASA's four panels must show: legend label -> Parquet column.
PANEL_COLUMNS = (
    {"alpha": "alpha_deg", "beta": "beta_deg"},
    {"gamma": "gamma_deg"},
    {"p": "p_deg_s", "q": "q_deg_s", "r": "r_deg_s"},
    {"phi": "phi_deg", "theta": "theta_deg"},
)
PANEL_UNITS = (("(deg)",), ("(deg)", "(kt)"), ("(deg/s)",), ("(deg",))


def _assert_plotted(line, time_s, values, column: str) -> None:
    """The line's x is the time history's time, its y the column; bank (``phi_deg``) is
    drawn unwrapped: continuous, and equal to the stored angle modulo 360 deg."""
    x, y = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
    np.testing.assert_array_equal(x, time_s)
    if column != "phi_deg":
        np.testing.assert_array_equal(y, values, err_msg=column)
        return
    assert np.abs(np.diff(y)).max() < 90.0
    np.testing.assert_allclose((y - values + 180.0) % 360.0 - 180.0, 0.0, atol=1e-9)


def _assert_figure_shows(fig, case: int, damaged, undamaged) -> None:
    """A figure of ``draw`` plots the stored time histories (read from Parquet here) of the
    damaged flight and, dotted, the undamaged one, each variable in its panel."""
    assert f"damage case {case}:" in fig.get_suptitle()
    panels, twins = fig.axes[:4], fig.axes[4:]
    for ax, columns, units in zip(panels, PANEL_COLUMNS, PANEL_UNITS, strict=True):
        lines = {ln.get_label(): ln for ln in ax.get_lines() if not ln.get_label().startswith("_")}
        assert set(lines) == {*columns, *(f"{lab}, undamaged" for lab in columns)}
        for label, column in columns.items():
            _assert_plotted(lines[label], damaged["time_s"], damaged[column], column)
            dotted = lines[f"{label}, undamaged"]
            assert dotted.get_linestyle() == ":"
            _assert_plotted(dotted, undamaged["time_s"], undamaged[column], column)
        onset = [ln for ln in ax.get_lines() if ln.get_label().startswith("_")]
        assert [list(ln.get_xdata()) for ln in onset] == [[SHORT.onset_s] * 2]
        assert all(unit in ax.get_title() for unit in units), ax.get_title()
    for ax in panels[2:]:
        assert ax.get_xlabel() == "time (s)"
    (eas_axis,) = twins
    assert eas_axis.get_ylabel() == "EAS (kt)"
    eas, eas_nominal = eas_axis.get_lines()
    assert eas.get_label() == "EAS" and eas_nominal.get_linestyle() == ":"
    _assert_plotted(eas, damaged["time_s"], damaged["eas_kt"], "eas_kt")
    _assert_plotted(eas_nominal, undamaged["time_s"], undamaged["eas_kt"], "eas_kt")


def test_files_summary_and_figures(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Seven time histories with units; the summary's rows and columns as the issue asks,
    its values read from the histories; six figures showing the stored histories, the same
    bytes when drawn again."""
    paths = run_example6(tmp_path / "results", SHORT)
    assert [p.name for p in paths] == [f"case{k}.parquet" for k in range(7)]
    schema = pq.read_schema(paths[2])
    assert schema.field("r_deg_s").metadata[b"unit"] == b"deg/s"
    assert b"probing.versions" in schema.metadata
    cases = gtm_damage.load(tmp_path / "results")
    table = gtm_damage.summary(cases)
    assert table["case"].tolist() == list(range(7))
    assert table["name"][2] == "vertical tail off" and table["name"][0] == "undamaged"
    for var in gtm_damage.SUMMARY_VARIABLES:
        for suffix in ("trim", "end", "min", "max"):
            assert f"{var}_{suffix}" in table.columns
    ts = cases[2][0]
    onset = ts[ts["time_s"] >= SHORT.onset_s - 1e-12].iloc[0]
    assert table.loc[2, "r_deg_s_trim"] == onset["r_deg_s"]
    assert table.loc[2, "beta_deg_end"] == ts["beta_deg"].iloc[-1]
    after = ts[ts["time_s"] >= SHORT.onset_s - 1e-12]
    assert table.loc[2, "beta_deg_max"] == after["beta_deg"].max()
    trim = gtm_damage.trim_table(cases).set_index("trim")
    assert list(trim.index) == ["jsbsim", "zero sideslip"]
    assert abs(trim.loc["zero sideslip", "beta_deg"]) < 1e-9 < -trim.loc["jsbsim", "beta_deg"]
    assert trim.loc["zero sideslip", "rdot_rad_s2"] == pytest.approx(0.0, abs=1e-9)
    assert trim.loc["zero sideslip", "beta_deg"] == cases[0][0]["beta_deg"].iloc[0]
    drawn = []
    save_figure = gtm_damage.save_figure

    def spy(fig, *args, **kwargs):
        drawn.append(fig)
        return save_figure(fig, *args, **kwargs)

    monkeypatch.setattr(gtm_damage, "save_figure", spy)
    first = gtm_damage.draw(cases, tmp_path / "f1")
    assert [p.name for p in first] == [f"gtm_damage_case{k}.png" for k in range(1, 7)]
    stored = [pq.read_table(p).to_pandas() for p in paths]  # not through gtm_damage.load
    for case, fig in zip(range(1, 7), drawn, strict=True):
        _assert_figure_shows(fig, case, stored[case], stored[0])
    again = gtm_damage.draw(cases, tmp_path / "f2")
    assert all(a.read_bytes() == b.read_bytes() for a, b in zip(first, again, strict=True))


def test_cli_refuses_a_file_as_output_folder(tmp_path: Path, capsys) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert cli_main(["gtm-damage", "--out", str(blocker)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--out" in err[0]


def test_a_flight_carries_its_damage_into_the_trim_and_its_keys() -> None:
    """A damaged flight trims with its damage (the symmetric cases, whose lost rudder leaves
    JSBSim's full trim a control without authority, longitudinally), and keys apart from the
    undamaged one, whose key is what it was before damage existed."""
    from probing.sim.fork import trim_spec
    from probing.sim.plant import make_plant

    level = Flight("gtm_t2", 800.0, "speed_keas", 75.0, EXAMPLE6.dt_s)
    assert "damage_case" not in trim_spec(level)
    rudder_off = dataclasses.replace(level, damage_case=1)
    wing_tip = dataclasses.replace(level, damage_case=4)
    assert trim_spec(rudder_off)["damage_case"] == 1
    assert make_plant(rudder_off).trim_result.mode == "longitudinal"
    plant = make_plant(wing_tip)
    assert plant.trim_result.mode == "full"
    assert plant.fdm["damage/case"] == 4
    assert plant.fdm["fcs/right-aileron-pos-deg"] < -5.0  # holding up the lost left tip
    with pytest.raises(ValueError, match="gtm_t2 only"):
        Flight("737", 15000.0, "speed_kcas", 280.0, 0.01, damage_case=1)
    with pytest.raises(ValueError, match=r"0\.\.6"):
        dataclasses.replace(level, damage_case=7)


def test_damage_table_sees_half_the_elevator_gone() -> None:
    """Level at 800 ft / 75 KEAS every case trims; the undamaged pulse response is its own
    reference (gain 1, shape 0) and losing the two left elevator panels halves the
    elevator-to-pitch pulse response (the right panels' share, 0.5; 0.54 measured, the trim
    having moved)."""
    from probing.experiment.studies.modes import damage_table

    table = {p.case: p for p in damage_table()}
    assert all(p.modes is not None for p in table.values()), [p.message for p in table.values()]
    assert table[0].gain == 1.0 and table[0].shape_error == 0.0
    assert 0.45 < table[5].gain < 0.6
    assert table[5].elevator_deg < table[0].elevator_deg - 2.0  # more nose-up elevator
    assert table[1].trim == "longitudinal"  # no rudder: JSBSim's full trim fails
    # vertical tail off: directionally unstable, it departs within the elevator's pulse
    assert math.isnan(table[2].gain) and math.isnan(table[2].shape_error)
    # the lateral probes: no rudder, no rudder response; no left aileron, less roll
    assert table[0].lateral == {"aileron": (1.0, 0.0), "rudder": (1.0, 0.0)}
    assert abs(table[1].lateral["rudder"][0]) < 0.05
    assert 0.5 < table[4].lateral["aileron"][0] < 0.9


def test_a_scenario_can_be_flown_in_a_climbing_turn(tmp_path: Path) -> None:
    """``[condition] gamma_deg, bank_deg``: the probed run is trimmed in the steady turn (the
    trim and the aircraft metadata say so), keys apart from the level flight, and a level
    scenario keeps its digest (the zero angles are left out of its condition)."""
    import json

    from probing.experiment.flight.run import run_scenario
    from probing.experiment.scenario import load_scenario
    from probing.sim.fork import trim_key

    root = Path(__file__).resolve().parents[2]
    level = load_scenario(root / "scenarios" / "fig4" / "baseline.toml")
    assert set(level.to_dict()["condition"]) == {"altitude_ft", "speed_kcas"}
    turn = level.replace(
        {
            "name": "turn",
            "condition.bank_deg": 30.0,
            "condition.gamma_deg": 2.0,
            "probe.periods": 3,
            "probe.settle_periods": 1,
        }
    )
    assert turn.to_dict()["condition"]["bank_deg"] == 30.0
    assert trim_key(turn.flight) != trim_key(level.flight)
    out = run_scenario(turn, tmp_path, progress=False, twin_cache=False).out_dir
    meta = pq.read_schema(out / "probing.parquet").metadata
    assert json.loads(meta[b"probing.trim"])["mode"] == "turn"
    assert json.loads(meta[b"probing.aircraft"])["bank_deg"] == 30.0
    ts = pq.read_table(out / "timeseries.parquet").to_pandas()
    assert np.all(np.isfinite(ts["theta_rad"]))


def test_a_fault_appears_in_flight_for_the_probed_aircraft_and_its_twin(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``[fault] type = "gtm_damage"``: trimmed undamaged, the case switched on at onset_s.
    Up to the onset the run is the fault-free one to the bit, probed aircraft and reference
    twin alike (the twin flies the same fault, so it keeps removing what the probe did not
    cause); after it both change. Grouped runs forked from one trimmed aircraft give the
    same bytes as runs on their own (the onset is counted per run, not per process)."""
    from probing.experiment.flight.batch import run_grouped
    from probing.experiment.flight.run import run_scenario
    from probing.experiment.scenario import load_scenario

    monkeypatch.setenv("PROBING_TWIN_CACHE", str(tmp_path / "twins"))
    root = Path(__file__).resolve().parents[2]
    base = load_scenario(root / "scenarios" / "fig4" / "baseline.toml").replace(
        {"probe.periods": 3, "probe.settle_periods": 1}
    )
    fault = base.replace(
        {
            "name": "fault",
            "fault.type": "gtm_damage",
            "fault.case": "left elevator off",
            "fault.onset_s": 1.0,
        }
    )
    assert fault.flight.damage_case == 5 and fault.flight.trimmed_damage == 0
    files = {}
    for scn in (base, fault):
        out = run_scenario(scn, tmp_path / "alone", progress=False, twin_cache=False).out_dir
        files[scn.name] = pq.read_table(out / "timeseries.parquet").to_pandas()
    onset = round(1.0 / base.dt_s)
    calm, hit = files[base.name], files["fault"]
    for column in ("theta_rad", "theta_rad_reference", "q_rad_s"):
        assert np.array_equal(calm[column][:onset], hit[column][:onset]), column
        assert not np.array_equal(calm[column][onset:], hit[column][onset:]), column

    def work(scn, aircraft) -> None:
        run_scenario(scn, tmp_path / "grouped", progress=False, aircraft=aircraft)

    for _, outcome in run_grouped([base, fault], lambda s: s, work):
        outcome.get()
    for name in ("probing.parquet", "timeseries.parquet"):
        grouped = (tmp_path / "grouped" / "fault" / name).read_bytes()
        assert grouped == (tmp_path / "alone" / "fault" / name).read_bytes(), name


TURN_TRIM_SNIPPET = (
    "from probing.sim.plant import Plant\n"
    "plant = Plant('gtm_t2', 1 / 200)\n"
    "plant.trim(800.0, speed_keas=95.0, gamma_deg=3.0, bank_deg=45.0)\n"
    "print(repr(plant.turn_trim.trimmed))\n"
)


@pytest.mark.jsbsim
@pytest.mark.parametrize("kernel", sorted(BLAS_KERNELS))
def test_the_turn_trim_does_not_depend_on_the_blas_kernel(kernel: str, new_plant) -> None:
    """The zero-sideslip turn trim in a process forced to each of OpenBLAS's x86-64 kernels
    is the same to the last digit as here (every trimmed state, control and acceleration):
    Example 6's files are the same bytes on any x86-64 machine.  (The bounded trust-region
    solver, whose linear algebra is BLAS's, differed from the 14th digit on.)"""
    plant = new_plant("gtm_t2", 1 / 200)
    plant.trim(800.0, speed_keas=95.0, gamma_deg=3.0, bank_deg=45.0)
    out = run_with_blas_kernel(kernel, ["-c", TURN_TRIM_SNIPPET])
    assert out.strip() == repr(plant.turn_trim.trimmed)
