"""Validation of the JSBSim GTM T2 model (aircraft/gtm_t2) against NASA's aero database.

The JSBSim tests read the model's total body-axis coefficients from the properties
``aero/coefficient/{CX,CY,CZ,Cl,Cm,Cn}`` after setting a state through the initial conditions
and ``run_ic()``. ``run_ic`` runs every model once with the time step suspended (dt = 0); the
servos then sit exactly at their (limited) commands, so the surfaces equal the commands set.

The reference values come from ``tests/data/gtm_reference.npz``, generated from the .mat file
by ``tests/data/make_gtm_reference.py`` (an independent SciPy evaluation of the tables), so the
suite runs without the NASA files. The converter determinism test runs only where the .mat is
available.
"""

from __future__ import annotations

import importlib.util
import math
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from conftest import BLAS_KERNELS, run_with_blas_kernel

from probing.sim.linear import LongitudinalModes, longitudinal_matrix

ROOT = Path(__file__).resolve().parents[2]
AIRCRAFT = ROOT / "aircraft"
MODEL_DIR = AIRCRAFT / "gtm_t2"
MODEL_XML = MODEL_DIR / "gtm_t2.xml"
REFERENCE = ROOT / "tests" / "data" / "gtm_reference.npz"
#: NASA's database, beside the repository (../shared/gtm/) where a developer has it.
MAT = ROOT.parent / "shared" / "gtm" / "T2_polynomial_aerodatabase.mat"
COEFFS = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")
#: NASA's control-surface panels, each with its own servo and command.
PANELS = (
    "left-outboard-elevator",
    "left-inboard-elevator",
    "right-inboard-elevator",
    "right-outboard-elevator",
    "right-aileron",
    "left-aileron",
    "upper-rudder",
    "lower-rudder",
    "right-inboard-spoiler",
    "right-outboard-spoiler",
    "left-inboard-spoiler",
    "left-outboard-spoiler",
    "left-outboard-flap",
    "left-inboard-flap",
    "right-inboard-flap",
    "right-outboard-flap",
)
S_FT2, CBAR_FT, SPAN_FT = 5.9018, 0.9153, 6.8488
NOTICE = (
    "Copyright 2009 United States Government as represented by the Administrator of the "
    "National Aeronautics and Space Administration. No copyright is claimed in the United "
    "States under Title 17, U.S. Code. All Other Rights Reserved."
)

# ------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------


def set_state(fdm, **s: float) -> None:
    """Set a flight state and surface commands, then run_ic (dt = 0: servos at command)."""
    fdm["ic/h-sl-ft"] = s.get("h_ft", 800.0)
    fdm["ic/vt-fps"] = s.get("vt_fps", 128.0)
    fdm["ic/alpha-deg"] = s.get("alpha_deg", 3.0)
    fdm["ic/beta-deg"] = s.get("beta_deg", 0.0)
    fdm["ic/phi-deg"] = 0.0
    fdm["ic/theta-deg"] = s.get("alpha_deg", 3.0)
    fdm["ic/p-rad_sec"] = s.get("p_rad_sec", 0.0)
    fdm["ic/q-rad_sec"] = s.get("q_rad_sec", 0.0)
    fdm["ic/r-rad_sec"] = s.get("r_rad_sec", 0.0)
    fdm["fcs/elevator-cmd-deg"] = s.get("elevator_deg", 0.0)
    fdm["fcs/stabilizer-pos-deg"] = s.get("stabilizer_deg", 0.0)
    fdm["fcs/aileron-cmd-deg"] = s.get("aileron_deg", 0.0)
    fdm["fcs/rudder-cmd-deg"] = s.get("rudder_deg", 0.0)
    fdm["fcs/left-spoiler-cmd-deg"] = s.get("left_spoiler_deg", 0.0)
    fdm["fcs/right-spoiler-cmd-deg"] = s.get("right_spoiler_deg", 0.0)
    fdm["gear/gear-cmd-norm"] = s.get("gear_pos", 0.0)
    fdm["fcs/flap-cmd-deg"] = s.get("flap_deg", 0.0)
    for panel in PANELS:  # a panel's own command, on top of its surface's
        fdm[f"fcs/{panel}-cmd-deg"] = s.get(panel, 0.0)
    fdm["damage/case"] = s.get("damage_case", 0.0)
    fdm.run_ic()


def group(fdm, name: str) -> np.ndarray:
    """One aero group's increment [CX CY CZ Cl Cm Cn] (0 where the group has none)."""
    out = []
    for c in COEFFS:
        try:
            out.append(fdm[f"aero/gtm/{name}/{c}"])
        except KeyError:
            out.append(0.0)
    return np.array(out)


def coefficients(fdm) -> np.ndarray:
    """The model's total body-axis coefficients [CX CY CZ Cl Cm Cn]."""
    return np.array([fdm[f"aero/coefficient/{c}"] for c in COEFFS])


@pytest.fixture(scope="module")
def fdm(new_plant):
    """One model instance shared by the coefficient tests (state reset by each test)."""
    return new_plant("gtm_t2").fdm


# ------------------------------------------------------------------------------------------
# files and licence (no JSBSim needed)
# ------------------------------------------------------------------------------------------


def test_model_files_present_and_licensed() -> None:
    """The derived aircraft folder carries NOSA 1.3, the notice and a change log."""
    for name in ("gtm_t2.xml", "NOSA-1.3.txt", "NOTICE", "CHANGELOG.md", "README.md"):
        assert (MODEL_DIR / name).is_file(), name
    assert NOTICE in (MODEL_DIR / "NOTICE").read_text()
    assert NOTICE in MODEL_XML.read_text()
    assert "GTM_DesignSim" in (MODEL_DIR / "CHANGELOG.md").read_text()
    nosa = " ".join((MODEL_DIR / "NOSA-1.3.txt").read_text(encoding="utf-8").split())
    assert "NASA OPEN SOURCE AGREEMENT VERSION 1.3" in nosa


def test_model_has_no_network_io_and_uses_body_axes() -> None:
    """No <input>/<output> socket directives; aero in X/Y/Z/ROLL/PITCH/YAW body axes."""
    root = ET.parse(MODEL_XML).getroot()
    assert root.tag == "fdm_config"
    assert root.find(".//input") is None
    assert root.find("output") is None
    axes = sorted(a.get("name") for a in root.find("aerodynamics").findall("axis"))
    assert axes == sorted(["X", "Y", "Z", "ROLL", "PITCH", "YAW"])


def test_reference_fixture_is_consistent() -> None:
    """The fixture has the expected shape and finite values."""
    ref = np.load(REFERENCE)
    assert ref["states"].shape[0] >= 200
    assert ref["coefficients"].shape == (ref["states"].shape[0], 6)
    assert np.all(np.isfinite(ref["coefficients"]))


# ------------------------------------------------------------------------------------------
# transcription
# ------------------------------------------------------------------------------------------


@pytest.mark.jsbsim
def test_coefficients_match_independent_table_evaluation(fdm) -> None:
    """JSBSim's totals equal the SciPy evaluation of NASA's tables within 1e-9 at 300 states:
    most of them damaged (every case: airframe increments, the damaged rate model with
    ddscale and ddinc, the lost surfaces and the elevator panels' roll and yaw), about half
    with every panel at a deflection of its own (four elevator panels, two ailerons, upper
    and lower rudder, four spoilers, four flaps), the other half with each surface's panels
    together; the worst was 4.5e-10 when written."""
    ref = np.load(REFERENCE)
    names = [str(n) for n in ref["state_names"]]
    worst = 0.0
    for row, expected in zip(ref["states"], ref["coefficients"], strict=True):
        s = dict(zip(names, row.tolist(), strict=True))
        set_state(fdm, **s)
        # the state really is the one asked for
        assert fdm["aero/alpha-deg"] == pytest.approx(s["alpha_deg"], abs=1e-9)
        assert fdm["aero/beta-deg"] == pytest.approx(s["beta_deg"], abs=1e-9)
        assert fdm["velocities/vt-fps"] == pytest.approx(s["vt_fps"], rel=1e-12)
        assert fdm["velocities/q-aero-rad_sec"] == pytest.approx(s["q_rad_sec"], abs=1e-12)
        got = coefficients(fdm)
        worst = max(worst, float(np.max(np.abs(got - expected))))
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9, err_msg=str(s))
    assert worst < 1e-9


@pytest.mark.jsbsim
def test_damage_increments_match_independent_table_evaluation(fdm) -> None:
    """The six cases' airframe increments (dC6_damage.bas over alpha x beta, clamped) equal
    the SciPy evaluation within 1e-9, and are exactly 0 undamaged (case 0).  The rest of a
    case (rate model, lost surfaces) is checked in the totals above."""
    ref = np.load(REFERENCE)
    names = [str(n) for n in ref["state_names"]]
    cases = ref["states"][:, names.index("damage_case")]
    assert set(cases.astype(int)) == set(range(7))  # every case, and the undamaged
    for row, expected in zip(ref["states"], ref["damage_increments"], strict=True):
        s = dict(zip(names, row.tolist(), strict=True))
        set_state(fdm, **s)
        got = np.array([fdm[f"aero/gtm/dam-bas/{c}"] for c in COEFFS])
        if s["damage_case"] == 0:
            assert np.all(got == 0.0)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9, err_msg=str(s))


@pytest.mark.jsbsim
def test_a_damage_case_switches_in_flight_at_the_next_step(new_plant) -> None:
    """``damage/case`` set between two steps acts in the next step's forces, and setting it
    back to 0 restores the undamaged coefficients exactly."""
    plant = new_plant("gtm_t2")
    plant.trim(800.0, speed_keas=75.0)
    fdm = plant.fdm
    for _ in range(20):
        fdm.run()
    calm = coefficients(fdm)
    # undamaged, the damage terms add exactly nothing and the damage point masses weigh 0
    assert all(fdm[f"aero/gtm/dam/{c}"] == 0.0 for c in COEFFS)
    assert all(fdm[f"inertia/pointmass-weight-lbs[{i}]"] == 0.0 for i in range(14))
    fdm["damage/case"] = 6  # left stabilizer off
    fdm.run()
    hit = coefficients(fdm)
    inc = np.array([fdm[f"aero/gtm/dam/{c}"] for c in COEFFS])
    assert abs(inc[4]) > 0.01  # a pitching-moment increment of this case
    # one step later the state has barely moved: the change is the increment
    np.testing.assert_allclose(hit - calm, inc, rtol=0, atol=2e-4)
    fdm["damage/case"] = 0
    fdm.run_ic()  # same state, no time step
    assert np.all(np.array([fdm[f"aero/gtm/dam/{c}"] for c in COEFFS]) == 0.0)


#: NASA's numbers (GTM_DesignSim): the T2's base mass properties (AC_baseparams_T2.m; products
#: of inertia as integrals, e.g. Ixz = int xz dm in body axes) and the damage cases' deltas of
#: DamageModels_T2.m: dWeight (lb), dCG (in; x forward, y right, z down), [dIxx dIyy dIzz
#: dIxz dIyz dIxy] (slug ft^2).  Copied here as the test's independent truth.
NASA_BASE = {"weight": 57.75, "I": (1.221, 4.655, 5.587, 0.274, 0.0, 0.006)}
NASA_DAMAGE = {
    1: (-0.13, (0.126, 0.000, 0.028), (-0.00346, -0.06698, -0.06352, -0.01409, 0.00001, 0.00003)),
    2: (-1.31, (1.166, 0.000, 0.277), (-0.03507, -0.57604, -0.54102, -0.13113, 0.00006, 0.00024)),
    3: (-0.09, (0.014, 0.041, 0.001), (-0.01018, -0.00120, -0.01137, -0.00009, -0.00027, -0.00347)),
    4: (-0.81, (0.148, 0.628, 0.032), (-0.25821, -0.01727, -0.27400, -0.00295, -0.01346, -0.05998)),
    5: (-0.07, (0.065, 0.010, 0.004), (-0.00097, -0.03391, -0.03467, -0.00188, -0.00029, -0.00510)),
    6: (-0.59, (0.553, 0.088, 0.032), (-0.00918, -0.27315, -0.28049, -0.01559, -0.00265, -0.04370)),
}


#: NASA's undamaged CG (AC_baseparams_T2.m ``cg_pos0``), in NASA's aircraft reference system
#: (ARS: ft from a datum ahead of the nose, x forward, y right, z down): 21.99 % MAC with the
#: MAC's leading edge at 4.5462 ft and cbar 0.9153 ft.
NASA_CG0_ARS_FT = (-(4.5462 + 0.9153 * 0.2199), -0.1416 / 12, -0.9761)


def nasa_cg_shift_in(dw: float, dcg_in: tuple[float, float, float]) -> np.ndarray:
    """The damaged CG's shift (in, ARS axes) as NASA's block diagram computes it
    (``/GTM_T2/A/C parameters/Inertia/Mass/CG Shift``): the undamaged weight moment
    W0 cg0 divided by the *damaged* weight W0 + dW, plus dCG."""
    w0, cg0 = NASA_BASE["weight"], 12.0 * np.array(NASA_CG0_ARS_FT)
    return w0 * cg0 / (w0 + dw) + np.array(dcg_in) - cg0


def nasa_tensor(ixx, iyy, izz, ixz, iyz, ixy) -> np.ndarray:
    """NASA's inertia matrix ("Form Inertia Matrix"): products of inertia off the diagonal
    with a minus sign."""
    return np.array([[ixx, -ixy, -ixz], [-ixy, iyy, -iyz], [-ixz, -iyz, izz]])


@pytest.mark.jsbsim
@pytest.mark.parametrize("case", range(7))
def test_damage_mass_properties_are_nasas(new_plant, case: int) -> None:
    """Weight, CG and inertia tensor of each damage case: NASA's base plus NASA's deltas
    (the CG where NASA's block diagram puts it, :func:`nasa_cg_shift_in`; the inertia
    changed by the deltas with no parallel-axis term, as NASA adds them), set by
    ``damage/case`` alone."""
    fdm = new_plant("gtm_t2").fdm
    set_state(fdm)
    cg0 = np.array([fdm["inertia/cg-x-in"], fdm["inertia/cg-y-in"], fdm["inertia/cg-z-in"]])
    set_state(fdm, damage_case=case)
    dw, dcg, di = NASA_DAMAGE.get(case, (0.0, (0.0, 0.0, 0.0), (0.0,) * 6))
    assert fdm["inertia/weight-lbs"] == pytest.approx(NASA_BASE["weight"] + dw, abs=1e-9)
    cg = np.array([fdm["inertia/cg-x-in"], fdm["inertia/cg-y-in"], fdm["inertia/cg-z-in"]])
    shift = nasa_cg_shift_in(dw, dcg)
    # structural frame: x aft, z up
    np.testing.assert_allclose(cg - cg0, [-shift[0], shift[1], -shift[2]], rtol=0, atol=1e-9)
    want = nasa_tensor(*NASA_BASE["I"]) + nasa_tensor(*di)
    with warnings.catch_warnings():  # JSBSim hands back a numpy.matrix
        warnings.simplefilter("ignore", PendingDeprecationWarning)
        got = np.array(fdm.get_mass_balance().get_J())
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


# ------------------------------------------------------------------------------------------
# sign conventions
# ------------------------------------------------------------------------------------------


@pytest.mark.jsbsim
def test_force_axes_map_database_coefficients_with_plus_sign(fdm) -> None:
    """JSBSim body forces are +qbar S CX (forward) and +qbar S CZ (down); lift is up."""
    set_state(fdm, alpha_deg=5.0, beta_deg=4.0)
    qs = fdm["aero/qbar-psf"] * S_FT2
    assert fdm["aero/coefficient/CZ"] < 0.0  # positive alpha: force up, CZ < 0
    assert fdm["forces/fbx-aero-lbs"] == pytest.approx(qs * fdm["aero/coefficient/CX"])
    assert fdm["forces/fby-aero-lbs"] == pytest.approx(qs * fdm["aero/coefficient/CY"])
    assert fdm["forces/fbz-aero-lbs"] == pytest.approx(qs * fdm["aero/coefficient/CZ"])
    assert fdm["aero/coefficient/CY"] < 0.0  # wind from the right pushes left
    assert fdm["aero/coefficient/Cn"] > 0.0  # weathercock stability
    assert fdm["aero/coefficient/Cl"] < 0.0  # dihedral effect


@pytest.mark.jsbsim
def test_moments_are_about_quarter_chord_and_transferred_to_cg(fdm) -> None:
    """Pitch moment at the CG = qSc Cm (about 25 % MAC) + lever(25 % - 21.99 % MAC) x Z."""
    set_state(fdm, alpha_deg=6.0)
    qs = fdm["aero/qbar-psf"] * S_FT2
    x_ac_in, x_cg_in = fdm["metrics/aero-rp-x-in"], fdm["inertia/cg-x-in"]
    assert x_ac_in == pytest.approx((4.5462 + 0.25 * CBAR_FT) * 12, abs=1e-5)
    assert x_cg_in == pytest.approx((4.5462 + 0.2199 * CBAR_FT) * 12, abs=1e-5)
    lever_ft = (x_ac_in - x_cg_in) / 12.0  # aero ref point aft of the CG
    expected = qs * CBAR_FT * fdm["aero/coefficient/Cm"] + lever_ft * fdm["forces/fbz-aero-lbs"]
    assert fdm["moments/m-aero-lbsft"] == pytest.approx(expected, rel=1e-9)


@pytest.mark.jsbsim
def test_control_signs(fdm) -> None:
    """Elevator TED: nose down. Aileron (NASA sign): rolls left. Rudder TEL: nose left."""
    set_state(fdm, alpha_deg=4.0)
    base = coefficients(fdm)
    set_state(fdm, alpha_deg=4.0, elevator_deg=5.0)
    up = coefficients(fdm)
    assert up[4] < base[4] - 0.05  # Cm more negative
    assert up[2] < base[2]  # more tail lift (CZ more negative)
    assert fdm["accelerations/qdot-rad_sec2"] < 0.0
    set_state(fdm, alpha_deg=4.0, aileron_deg=10.0)
    assert fdm["fcs/right-aileron-pos-deg"] == pytest.approx(10.0)
    assert fdm["fcs/left-aileron-pos-deg"] == pytest.approx(-10.0)
    assert coefficients(fdm)[3] < base[3] - 0.005
    set_state(fdm, alpha_deg=4.0, rudder_deg=10.0)
    rud = coefficients(fdm)
    assert rud[5] < base[5] - 0.01 and rud[1] > base[1]
    # the mirrored positive rudder is the negative rudder's mirror image
    set_state(fdm, alpha_deg=4.0, rudder_deg=-10.0)
    neg = coefficients(fdm)
    np.testing.assert_allclose((rud - base) * [1, -1, 1, -1, 1, -1], neg - base, atol=1e-12)


@pytest.mark.jsbsim
def test_panels_share_their_surface_as_nasa_splits_it(fdm) -> None:
    """Each panel takes NASA's share of its surface (Aero/Control Surfaces gains): the upper
    rudder alone gives half the rudders' forces and yaw and 0.67 of their roll and pitch; the
    inboard spoiler 0.45 of the forces and pitch and 0.26 of roll and yaw (at a deflection
    both panels reach); each elevator panel a quarter of the pitching moment, the left
    outboard panel rolling by its arm (-0.07 of the span) times its normal force."""
    state = {"alpha_deg": 4.0, "beta_deg": 3.0}
    set_state(fdm, **state)
    base = {g: group(fdm, g) for g in ("rud", "spo-right", "ele")}
    set_state(fdm, **state, rudder_deg=-8.0)
    both = group(fdm, "rud") - base["rud"]
    set_state(fdm, **state, **{"upper-rudder": -8.0})
    upper = group(fdm, "rud") - base["rud"]
    np.testing.assert_allclose(upper, both * [0.5, 0.5, 0.5, 0.67, 0.67, 0.5], rtol=1e-12)
    set_state(fdm, **state, right_spoiler_deg=12.0)
    both = group(fdm, "spo-right") - base["spo-right"]
    set_state(fdm, **state, **{"right-inboard-spoiler": 12.0})
    inboard = group(fdm, "spo-right") - base["spo-right"]
    np.testing.assert_allclose(inboard, both * [0.45, 0.45, 0.45, 0.26, 0.45, 0.26], rtol=1e-12)
    set_state(fdm, **state, elevator_deg=6.0)
    both = group(fdm, "ele") - base["ele"]
    assert both[3] == both[5] == 0.0  # panels together: no roll, no yaw
    set_state(fdm, **state, **{"left-outboard-elevator": 6.0})
    one = group(fdm, "ele") - base["ele"]
    np.testing.assert_allclose(one[[0, 2, 4]], 0.25 * both[[0, 2, 4]], rtol=1e-12)
    assert one[3] == pytest.approx(-0.07 * one[2], rel=1e-12)  # Cl = arm CZ
    assert one[5] == pytest.approx(0.07 * one[0], rel=1e-12)  # Cn = -arm CX


@pytest.mark.jsbsim
@pytest.mark.parametrize(
    ("case", "lost", "kept"),
    [
        (5, ("left-outboard-elevator", "left-inboard-elevator"), "right-inboard-elevator"),
        (3, ("left-outboard-flap",), "left-inboard-flap"),
        (1, ("upper-rudder", "lower-rudder"), None),
        (4, ("left-aileron",), "right-aileron"),
    ],
)
def test_a_lost_panel_does_nothing_and_the_others_still_act(
    fdm, case: int, lost: tuple[str, ...], kept: str | None
) -> None:
    """With a damage case on, moving a panel it removes changes no coefficient at all, while
    a panel it keeps still acts: the loss follows each panel, not the surface's mean."""
    state = {"alpha_deg": 4.0, "beta_deg": 2.0, "damage_case": float(case)}
    set_state(fdm, **state)
    base = coefficients(fdm)
    set_state(fdm, **state, **dict.fromkeys(lost, 7.0))
    assert fdm[f"fcs/{lost[0]}-pos-deg"] == 7.0
    np.testing.assert_allclose(coefficients(fdm), base, rtol=0, atol=1e-15)
    if kept:
        set_state(fdm, **state, **{kept: 7.0})
        assert np.max(np.abs(coefficients(fdm) - base)) > 1e-3


@pytest.mark.jsbsim
def test_differential_elevator_rolls_and_each_panel_has_its_own_servo(new_plant) -> None:
    """A panel's own command moves that panel alone, through its own NASA servo (one step:
    2 pi 5 Hz dt of the command); the symmetric command moves all four together, and the
    surface's position is their mean. Left panels down, right panels up rolls the aircraft
    right (NASA's RollYaw Coupling), with no aileron and the mean elevator unchanged."""
    plant = new_plant("gtm_t2", 1.0 / 200.0)
    fdm = plant.fdm
    set_state(fdm, alpha_deg=4.0)
    dt = fdm["simulation/dt"]
    fdm["fcs/left-outboard-elevator-cmd-deg"] = 1.0
    fdm.run()
    assert fdm["fcs/left-outboard-elevator-pos-deg"] == pytest.approx(2 * math.pi * 5 * dt)
    for panel in PANELS[1:4]:
        assert fdm[f"fcs/{panel}-pos-deg"] == 0.0
    assert fdm["fcs/elevator-pos-deg"] == pytest.approx(0.25 * 2 * math.pi * 5 * dt)
    set_state(fdm, alpha_deg=4.0)
    trimmed = fdm["fcs/elevator-pos-deg"]
    for panel, sign in zip(PANELS[:4], (1, 1, -1, -1), strict=True):
        fdm[f"fcs/{panel}-cmd-deg"] = 4.0 * sign
    for _ in range(40):
        fdm.run()
    assert fdm["fcs/elevator-pos-deg"] == pytest.approx(trimmed, abs=1e-12)
    assert fdm["fcs/left-aileron-pos-deg"] == fdm["fcs/right-aileron-pos-deg"] == 0.0
    assert fdm["aero/gtm/ele/Cl"] > 1e-4 and fdm["velocities/p-rad_sec"] > 0.01


@pytest.mark.jsbsim
def test_idle_servos_are_skipped_and_wake_on_a_command(new_plant) -> None:
    """Servos sitting at their commands are not run (they would not move); a new command
    wakes them and they follow NASA's servo: one step of 2 pi 5 Hz dt, the left aileron
    mirrored, NASA's +-20 deg aileron limit."""
    fdm = new_plant("gtm_t2", 1.0 / 200.0).fdm
    set_state(fdm, alpha_deg=4.0)
    fdm.run()
    assert fdm["fcs/aileron-busy"] == fdm["fcs/rudder-busy"] == fdm["fcs/high-lift-busy"] == 0
    dt = fdm["simulation/dt"]
    fdm["fcs/aileron-cmd-deg"] = 2.0
    fdm.run()
    assert fdm["fcs/aileron-busy"] == 1
    assert fdm["fcs/right-aileron-pos-deg"] == pytest.approx(2.0 * 2 * math.pi * 5 * dt)
    assert fdm["fcs/left-aileron-pos-deg"] == -fdm["fcs/right-aileron-pos-deg"]
    fdm["fcs/aileron-cmd-deg"] = 35.0
    fdm["fcs/flap-cmd-deg"] = 10.0
    for _ in range(600):
        fdm.run()
    assert fdm["fcs/right-aileron-pos-deg"] == pytest.approx(20.0)
    assert fdm["fcs/left-aileron-pos-deg"] == pytest.approx(-20.0)
    for panel in PANELS[-4:]:
        assert fdm[f"fcs/{panel}-pos-deg"] == pytest.approx(10.0, abs=1e-9)


@pytest.mark.jsbsim
def test_rate_damping_and_gear_drag(fdm) -> None:
    """Pitch and roll rates are damped; the gear adds drag."""
    set_state(fdm, alpha_deg=4.0)
    base = coefficients(fdm)
    set_state(fdm, alpha_deg=4.0, q_rad_sec=0.3)
    assert coefficients(fdm)[4] < base[4]
    set_state(fdm, alpha_deg=4.0, p_rad_sec=0.5)
    assert coefficients(fdm)[3] < base[3]
    set_state(fdm, alpha_deg=4.0, gear_pos=1.0)
    assert coefficients(fdm)[0] < base[0] - 0.01


@pytest.mark.jsbsim
def test_rate_normalisation_is_b_and_cbar_over_2v(fdm) -> None:
    """q-hat = q cbar / 2V (beta = 0); p-hat = p b / 2V and JSBSim's bi2vel, ci2vel agree."""
    set_state(fdm, alpha_deg=0.0, vt_fps=150.0, q_rad_sec=0.2)
    assert fdm["aero/gtm/q-hat"] == pytest.approx(0.2 * CBAR_FT / 300.0, rel=1e-12)
    assert fdm["aero/ci2vel"] == pytest.approx(CBAR_FT / 300.0, rel=1e-12)
    assert fdm["aero/bi2vel"] == pytest.approx(SPAN_FT / 300.0, rel=1e-12)
    set_state(fdm, alpha_deg=0.0, vt_fps=150.0, p_rad_sec=0.4)
    # at alpha = beta = 0 a roll rate is pure rotation about the velocity vector
    assert fdm["aero/gtm/omega-hat"] == pytest.approx(0.4 * SPAN_FT / 300.0, rel=1e-12)
    assert fdm["aero/gtm/p-hat"] == pytest.approx(0.0, abs=1e-15)


# ------------------------------------------------------------------------------------------
# servo
# ------------------------------------------------------------------------------------------


@pytest.mark.jsbsim
def test_elevator_servo_first_order_rate_limited_and_bypass(new_plant) -> None:
    """5 Hz loop, 300 deg/s inside the loop, -30..+20 deg limits, exact bypass."""
    fdm = new_plant("gtm_t2", 1.0 / 200.0).fdm
    set_state(fdm, alpha_deg=3.0)
    dt = fdm["simulation/dt"]
    # small step: linear first order, y_k = (1 - w dt)^k * (y0 - u) + u
    fdm["fcs/elevator-cmd-deg"] = 1.0
    fdm.run()
    assert fdm["fcs/elevator-pos-deg"] == pytest.approx(2 * math.pi * 5 * dt * 1.0, rel=1e-9)
    # large step: rate limited at 300 deg/s
    fdm["fcs/elevator-cmd-deg"] = -25.0
    y0 = fdm["fcs/elevator-pos-deg"]
    fdm.run()
    assert y0 - fdm["fcs/elevator-pos-deg"] == pytest.approx(300.0 * dt, rel=1e-9)
    for _ in range(400):
        fdm.run()
    assert fdm["fcs/elevator-pos-deg"] == pytest.approx(-25.0, abs=1e-6)
    fdm["fcs/elevator-cmd-deg"] = 40.0
    for _ in range(400):
        fdm.run()
    assert fdm["fcs/elevator-pos-deg"] == pytest.approx(20.0)
    assert fdm["fcs/elevator-pos-rad"] == pytest.approx(math.radians(20.0))
    # normalised command: 30 deg per unit
    fdm["fcs/elevator-cmd-deg"] = 0.0
    fdm["fcs/elevator-cmd-norm"] = -0.5
    for _ in range(400):
        fdm.run()
    assert fdm["fcs/elevator-pos-deg"] == pytest.approx(-15.0, abs=1e-6)
    # bypass: surface equals the command exactly, at once
    fdm["fcs/elevator-servo-bypass"] = 1
    fdm["fcs/elevator-cmd-norm"] = 0.0
    fdm["fcs/elevator-cmd-deg"] = 0.0123
    fdm.run()
    assert fdm["fcs/elevator-pos-deg"] == 0.0123


# ------------------------------------------------------------------------------------------
# trim
# ------------------------------------------------------------------------------------------


@pytest.mark.jsbsim
def test_trim_straight_and_level_75_kt_800_ft(new_plant) -> None:
    """Trim at 800 ft, 75 KEAS, gear up succeeds and the aircraft stays there."""
    plant = new_plant("gtm_t2")
    trim = plant.trim(800.0, speed_keas=75.0)
    fdm = plant.fdm
    alpha = fdm["aero/alpha-deg"]
    elevator = fdm["fcs/elevator-pos-deg"]
    throttle = fdm["fcs/throttle-cmd-norm"]
    assert fdm["gear/gear-pos-norm"] == 0.0
    assert 2.0 < alpha < 8.0
    assert -10.0 < elevator < 10.0
    assert 0.0 < throttle < 1.0
    assert fdm["velocities/ve-kts"] == pytest.approx(75.0, abs=0.01)
    assert trim.speed_keas == pytest.approx(75.0, abs=0.01)
    h0, theta0 = fdm["position/h-sl-ft"], fdm["attitude/theta-deg"]
    for _ in range(400):  # 2 s
        fdm.run()
    assert abs(fdm["position/h-sl-ft"] - h0) < 0.5
    assert abs(fdm["attitude/theta-deg"] - theta0) < 0.05
    assert abs(fdm["velocities/q-rad_sec"]) < 1e-3


# ------------------------------------------------------------------------------------------
# converter determinism (needs the NASA .mat)
NO_MAT = f"NASA's database is not beside the repository (looked for {MAT})"
# ------------------------------------------------------------------------------------------


def _load_converter():
    spec = importlib.util.spec_from_file_location("convert_gtm", AIRCRAFT / "convert_gtm.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.skipif(not MAT.exists(), reason=NO_MAT)
def test_converter_regenerates_committed_model_byte_for_byte(tmp_path: Path) -> None:
    """Regenerating from the .mat reproduces every committed generated file exactly."""
    written = _load_converter().write_outputs(_load_converter().load_database(MAT), tmp_path)
    assert written
    for path in written:
        rel = path.relative_to(tmp_path)
        assert path.read_bytes() == (MODEL_DIR / rel).read_bytes(), rel


@pytest.mark.skipif(not MAT.exists(), reason=NO_MAT)
@pytest.mark.parametrize("kernel", sorted(BLAS_KERNELS))
def test_converter_output_does_not_depend_on_the_blas_kernel(kernel: str, tmp_path: Path) -> None:
    """The converter in a process with OpenBLAS forced to each x86-64 kernel writes the
    committed files byte for byte (its one linear solve is exact, so no kernel's rounding
    reaches the written digits; numpy's own solve differed in the last digit on SkylakeX)."""
    run_with_blas_kernel(
        kernel, [str(AIRCRAFT / "convert_gtm.py"), str(MAT), "--out", str(tmp_path)]
    )
    for rel in ("gtm_t2.xml", "Engines/gtm_jet.xml", "Engines/gtm_direct.xml"):
        assert (tmp_path / rel).read_bytes() == (MODEL_DIR / rel).read_bytes(), rel


def test_exact_solve_against_a_rational_system() -> None:
    """solve_exact returns the correctly rounded solution: a system whose exact answer is
    known (1/3 is not a float; the nearest float is what must come back)."""
    solve_exact = _load_converter().solve_exact
    a = np.array([[3.0, 0.0], [1.0, 2.0]])
    x = solve_exact(a, np.array([1.0, 1.0]))  # x0 = 1/3, x1 = (1 - 1/3)/2 = 1/3
    assert x[0] == 1.0 / 3.0 and x[1] == 1.0 / 3.0
    a = np.array([[0.0, 1.0], [1.0, 0.0]])  # a zero pivot: rows swapped
    assert solve_exact(a, np.array([2.0, 5.0])).tolist() == [5.0, 2.0]


@pytest.mark.skipif(not MAT.exists(), reason=NO_MAT)
def test_reference_fixture_was_made_from_this_database() -> None:
    """The fixture records the SHA-256 of the .mat it came from."""
    import hashlib

    ref = np.load(REFERENCE)
    assert str(ref["mat_sha256"]) == hashlib.sha256(MAT.read_bytes()).hexdigest()


@pytest.mark.jsbsim
def test_longitudinal_modes_at_75_kt_are_plausible(new_plant) -> None:
    """Short period and phugoid from FGLinearization (as probing modes computes them)."""
    plant = new_plant("gtm_t2")
    plant.trim(800.0, speed_keas=75.0)
    a = longitudinal_matrix(plant)
    assert plant.fdm["simulation/dt"] == pytest.approx(1.0 / 200.0)  # restored after linearising
    m = LongitudinalModes.from_eigenvalues(np.linalg.eigvals(a))
    assert 3.0 < m.sp_wn < 10.0 and 0.3 < m.sp_zeta < 0.7
    assert 0.25 < m.ph_wn < 0.45 and 0.0 < m.ph_zeta < 0.2


@pytest.mark.jsbsim
def test_the_flight_computers_servo_model_is_the_gtms_own_servo(new_plant) -> None:
    """The actuator check's nominal servo (probing.sim.surfaces.SERVOS, stepped by
    probing.core.isolation.Servo) puts the elevator where JSBSim's GTM servo does, step by
    step, for a command of probe-like bits and a slow ramp, to rounding; 4.9 Hz would not."""
    from probing.core.isolation import Servo
    from probing.sim.surfaces import SERVOS

    dt = 0.01
    fdm = new_plant("gtm_t2", dt).fdm
    set_state(fdm, alpha_deg=3.0)
    rng = np.random.default_rng(3)
    command = 0.2 * np.sign(rng.standard_normal(300)) + np.linspace(0.0, -3.0, 300)
    fdm["fcs/elevator-cmd-deg"] = command[0]
    for _ in range(500):  # at rest at the first command
        fdm.run()
    position = []
    for u in command[1:]:
        fdm["fcs/elevator-cmd-deg"] = u
        fdm.run()
        position.append(fdm["fcs/elevator-pos-deg"])
    model = Servo(SERVOS["gtm_t2"], dt).update(command)[1:]
    assert np.max(np.abs(model - position)) < 1e-9
    slower = Servo(2 * math.pi * 4.9, dt).update(command)[1:]
    assert np.max(np.abs(slower - position)) > 1e-3
