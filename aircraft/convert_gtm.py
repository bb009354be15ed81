#!/usr/bin/env python3
"""Convert NASA's GTM T2 aerodynamic database into a JSBSim aircraft model.

Usage::

    python aircraft/convert_gtm.py PATH/TO/T2_polynomial_aerodatabase.mat [--out aircraft/gtm_t2]

The input is the "Polynomial Fit Aero database (unlimited distribution), Version 0.2 with
damage" shipped with NASA's GTM_DesignSim (LAR-17625-1, NASA Open Source Agreement 1.3). The
output folder receives ``gtm_t2.xml`` and the engine/thruster files it includes
(``Engines/gtm_jet.xml``, ``Engines/gtm_direct.xml``). The output is a pure function of the
.mat file: numbers are written with a fixed format, nothing depends on the clock or the
platform, so regenerating gives the committed files byte for byte.

The converter itself is project code (MIT). The files it writes are derived from NASA's
release and carry NOSA 1.3 (see ``aircraft/gtm_t2/README.md``).

Modelling decisions (all documented in the generated XML and in ``docs/gtm.md``):

* Database axes are body axes, CX forward, CY right, CZ down, Cl/Cm/Cn right-handed about the
  aero reference point (25 % MAC). JSBSim's ``X``/``Y``/``Z`` axis system uses the same
  directions, so the coefficients enter with sign +1 (no AXIAL/NORMAL flip).
* Every table is linearly interpolated and clamped at its end breakpoints (JSBSim's FGTable
  behaviour).
* The 4-D elevator table (alpha, beta, stab, elev) is written as one 3-D table (alpha, beta,
  elev) per stabilizer breakpoint, blended with piecewise-linear "hat" weights in the
  stabilizer deflection: this is exactly the 4-D multilinear interpolation.
* Every panel NASA models has its own servo and its own share of its surface's table: four
  elevator panels with their roll and yaw (NASA's Stab1), upper and lower rudder, inboard and
  outboard spoilers, four flap panels; panels at one deflection are looked up once.
* Left aileron / left spoiler and positive rudder are the mirror images (y -> -y) of the
  tabulated right aileron / right spoiler / negative rudder: evaluated at -beta (and -delta
  for the rudder) with CY, Cl and Cn negated.
* Rates: the rotary table dC6_w is indexed by omega-hat = Omega b / 2V, Omega being the
  projection of the body rate on the velocity vector; the forced-oscillation tables use the
  remaining (oscillatory) rates, phat = p_osc b/2V, qhat = q_osc cbar/2V, rhat = r_osc b/2V.
"""

from __future__ import annotations

import argparse
import itertools
import math
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path

import numpy as np
import scipy.io

# --------------------------------------------------------------------------------------------
# Geometry and mass (NASA GTM T2, gear up; FACTS.md)
# --------------------------------------------------------------------------------------------
S_FT2 = 5.9018
CBAR_FT = 0.9153
SPAN_FT = 6.8488
MAC_LE_FT = 4.5462
AERO_REF_FRAC = 0.25
CG_FRAC = 0.2199
WEIGHT_LBS = 57.75
INERTIA_SLUGFT2 = {"ixx": 1.221, "iyy": 4.655, "izz": 5.587, "ixz": 0.274, "ixy": 0.006}
#: NASA's undamaged CG (``cg_pos0``) off the fuselage's centre line and its height, inches in
#: NASA's aircraft reference system (y right, z down from a datum 0.9761 ft below the CG);
#: the model puts its CG on the x axis, but NASA's damaged CG depends on them (see
#: :func:`nasa_damaged_cg_shift_in`).
NASA_CG0_Y_IN, NASA_CG0_Z_IN = -0.1416, -0.9761 * 12.0
THRUST_PER_ENGINE_LBF = 17.0

# Servo (NASA: first-order 5 Hz loop, rate limit inside the loop)
SERVO_BANDWIDTH_HZ = 5.0
SERVO_RATE_LIMIT_DPS = 300.0
ELEVATOR_LIMITS_DEG = (-30.0, 20.0)
AILERON_LIMITS_DEG = (-20.0, 20.0)
RUDDER_LIMITS_DEG = (-30.0, 30.0)
FLAP_LIMITS_DEG = (0.0, 30.0)
DEG_PER_NORM = 30.0
GEAR_RATE_PER_S = 0.2  # full extension / retraction in 5 s

# Control-surface panels, each with its own servo (NASA's Actuators/Acutator Dynamics blocks)
# and its own aerodynamic share (Aero/Control Surfaces). Keys are NASA's panel names.
ELEVATOR_PANELS = {
    "LOB": "left-outboard-elevator",
    "LIB": "left-inboard-elevator",
    "RIB": "right-inboard-elevator",
    "ROB": "right-outboard-elevator",
}
FLAP_PANELS = {
    "LOB": "left-outboard-flap",
    "LIB": "left-inboard-flap",
    "RIB": "right-inboard-flap",
    "ROB": "right-outboard-flap",
}
RUDDER_PANELS = {"U": "upper-rudder", "L": "lower-rudder"}
SPOILER_PANELS = {
    side: {"IB": f"{side}-inboard-spoiler", "OB": f"{side}-outboard-spoiler"}
    for side in ("right", "left")
}
#: NASA's servo position limits of the spoiler panels (inboard 0..15, outboard 0..45 deg).
SPOILER_LIMITS_DEG = {"IB": (0.0, 15.0), "OB": (0.0, 45.0)}
#: Each panel's share of its surface's table, per coefficient [CX CY CZ Cl Cm Cn] (NASA's
#: Rudder/Gains, Gains1 and Spoilers/Gains1..4); the shares of a surface's panels add to 1.
RUDDER_SHARE = {"U": (0.5, 0.5, 0.5, 0.67, 0.67, 0.5), "L": (0.5, 0.5, 0.5, 0.33, 0.33, 0.5)}
SPOILER_SHARE = {
    "IB": (0.45, 0.45, 0.45, 0.26, 0.45, 0.26),
    "OB": (0.55, 0.55, 0.55, 0.74, 0.55, 0.74),
}

COEFFS6 = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")
LONG3 = ("CX", "CZ", "Cm")
LAT3 = ("CY", "Cl", "Cn")
# Mirror image in the x-z plane: lateral coefficients change sign.
MIRROR_SIGN = {"CX": 1, "CY": -1, "CZ": 1, "Cl": -1, "Cm": 1, "Cn": -1}

ALPHA = "aero/alpha-deg"
BETA = "aero/beta-deg"
BETA_MIRROR = "aero/gtm/beta-mirror-deg"
IND = "  "

NOTICE = (
    "Copyright 2009 United States Government as represented by the Administrator of the "
    "National Aeronautics and Space Administration. No copyright is claimed in the United "
    "States under Title 17, U.S. Code. All Other Rights Reserved."
)


# --------------------------------------------------------------------------------------------
# Formatting helpers
# --------------------------------------------------------------------------------------------
def fmt(x: float) -> str:
    """Format a number deterministically: 10 significant digits, no negative zero."""
    x = float(x)
    if x == 0.0:
        return "0"
    s = format(x, ".10g")
    return s


def fmt_fixed(x: float, digits: int = 6) -> str:
    """Format a geometric constant with a fixed number of decimals."""
    return f"{x:.{digits}f}"


def indent(lines: Sequence[str], level: int) -> list[str]:
    """Indent every line by ``level`` steps of two spaces."""
    pad = IND * level
    return [pad + line if line else line for line in lines]


def prop(name: str) -> str:
    """A ``<property>`` element."""
    return f"<property>{name}</property>"


def value(x: float) -> str:
    """A ``<value>`` element."""
    return f"<value>{fmt(x)}</value>"


def exact_value(x: float) -> str:
    """A ``<value>`` element with every digit of the double (computed constants)."""
    x = float(x)
    return "<value>0</value>" if x == 0.0 else f"<value>{x!r}</value>"


# --------------------------------------------------------------------------------------------
# Table writers (JSBSim FGTable: row / column / table lookups, linear, clamped)
# --------------------------------------------------------------------------------------------
def _grid_2d(rows: np.ndarray, cols: np.ndarray, data: np.ndarray) -> list[str]:
    """Lines of a 2-D tableData body: first line the column keys, then key + row values."""
    lines = ["      " + " ".join(fmt(c) for c in cols)]
    for i, r in enumerate(rows):
        lines.append(fmt(r) + " " + " ".join(fmt(v) for v in data[i, :]))
    return lines


def table_1d(var: str, keys: np.ndarray, vals: np.ndarray) -> list[str]:
    """A 1-D table element."""
    lines = ["<table>", f'{IND}<independentVar lookup="row">{var}</independentVar>']
    lines.append(f"{IND}<tableData>")
    lines += indent([f"{fmt(k)} {fmt(v)}" for k, v in zip(keys, vals, strict=True)], 2)
    lines += [f"{IND}</tableData>", "</table>"]
    return lines


def table_2d(row_var: str, rows: np.ndarray, col_var: str, cols: np.ndarray, data: np.ndarray):
    """A 2-D table element; ``data`` has shape (len(rows), len(cols))."""
    assert data.shape == (len(rows), len(cols))
    lines = [
        "<table>",
        f'{IND}<independentVar lookup="row">{row_var}</independentVar>',
        f'{IND}<independentVar lookup="column">{col_var}</independentVar>',
        f"{IND}<tableData>",
    ]
    lines += indent(_grid_2d(rows, cols, data), 2)
    lines += [f"{IND}</tableData>", "</table>"]
    return lines


def table_3d(
    row_var: str,
    rows: np.ndarray,
    col_var: str,
    cols: np.ndarray,
    tab_var: str,
    tabs: np.ndarray,
    data: np.ndarray,
) -> list[str]:
    """A 3-D table element; ``data`` has shape (len(rows), len(cols), len(tabs))."""
    assert data.shape == (len(rows), len(cols), len(tabs))
    lines = [
        "<table>",
        f'{IND}<independentVar lookup="row">{row_var}</independentVar>',
        f'{IND}<independentVar lookup="column">{col_var}</independentVar>',
        f'{IND}<independentVar lookup="table">{tab_var}</independentVar>',
    ]
    for k, t in enumerate(tabs):
        lines.append(f'{IND}<tableData breakPoint="{fmt(t)}">')
        lines += indent(_grid_2d(rows, cols, data[:, :, k]), 2)
        lines.append(f"{IND}</tableData>")
    lines.append("</table>")
    return lines


def function(name: str, body: list[str], description: str | None = None) -> list[str]:
    """A named ``<function>`` wrapping ``body``."""
    lines = [f'<function name="{name}">']
    if description:
        lines.append(f"{IND}<description>{description}</description>")
    lines += indent(body, 1)
    lines.append("</function>")
    return lines


def signed(sign: int, body: list[str]) -> list[str]:
    """Multiply an expression by -1 when ``sign`` is negative."""
    if sign > 0:
        return body
    return ["<product>", f"{IND}{value(-1)}", *indent(body, 1), "</product>"]


def scaled(factor: float, body: list[str]) -> list[str]:
    """``factor`` times an expression."""
    return ["<product>", f"{IND}{value(factor)}", *indent(body, 1), "</product>"]


def summed(*bodies: list[str]) -> list[str]:
    """The sum of expressions."""
    return ["<sum>", *(line for body in bodies for line in indent(body, 1)), "</sum>"]


def if_then(condition: str, then: list[str], otherwise: list[str]) -> list[str]:
    """``then`` where the 0/1 property ``condition`` is 1, else ``otherwise`` (JSBSim evaluates
    only the branch taken)."""
    return [
        "<ifthen>",
        f"{IND}{prop(condition)}",
        *indent(then, 1),
        *indent(otherwise, 1),
        "</ifthen>",
    ]


def pos(panel: str) -> str:
    """A panel's position property."""
    return f"fcs/{panel}-pos-deg"


def mean_of(props: Sequence[str]) -> list[str]:
    """The mean of two or four properties, summed pairwise so that it is exactly their value
    when they are all equal (a + a, 2a + 2a and the power-of-two scaling are exact)."""
    if len(props) == 2:
        return scaled(0.5, summed([prop(props[0])], [prop(props[1])]))
    assert len(props) == 4
    pairs = (summed([prop(props[0])], [prop(props[1])]), summed([prop(props[2])], [prop(props[3])]))
    return scaled(0.25, summed(*pairs))


def all_equal(name: str, panels: Sequence[str]) -> list[str]:
    """A 0/1 FCS function ``name``: 1 when the ``panels`` are all at one deflection.  It sits
    in the channel of the panels' servos, after them, so it is current whenever they move
    (and keeps its value while they do not)."""
    eqs = [f"<eq>{prop(pos(a))}{prop(pos(b))}</eq>" for a, b in itertools.pairwise(panels)]
    body = eqs if len(eqs) == 1 else ["<and>", *indent(eqs, 1), "</and>"]
    return fcs_function(name.rsplit("/", 1)[-1], name, body)


# --------------------------------------------------------------------------------------------
# Database access
# --------------------------------------------------------------------------------------------
def load_database(path: Path) -> dict[str, object]:
    """Read the .mat database (MATLAB 5 structs) into a dict of scipy mat_structs."""
    return scipy.io.loadmat(str(path), squeeze_me=True, struct_as_record=False)


def arr(x: object) -> np.ndarray:
    """A float64 copy of a database array."""
    return np.asarray(x, dtype=np.float64)


# --------------------------------------------------------------------------------------------
# Aerodynamics: one function per table group
# --------------------------------------------------------------------------------------------
def aero_inputs() -> list[str]:
    """Derived inputs: mirrored sideslip, rotary / oscillatory normalised rates."""
    ca_cb = [
        "<product>",
        "  <cos><property>aero/alpha-rad</property></cos>",
        "  <cos><property>aero/beta-rad</property></cos>",
        "</product>",
    ]
    sb = ["<sin><property>aero/beta-rad</property></sin>"]
    sa_cb = [
        "<product>",
        "  <sin><property>aero/alpha-rad</property></sin>",
        "  <cos><property>aero/beta-rad</property></cos>",
        "</product>",
    ]
    half_over_v = "aero/gtm/half-over-vt-sec_ft"
    lines: list[str] = []
    lines += function(BETA_MIRROR, ["<product>", f"  {value(-1)}", f"  {prop(BETA)}", "</product>"])
    lines += function(
        half_over_v,
        [
            "<quotient>",
            f"  {value(0.5)}",
            "  <max>",
            f"    {prop('velocities/vt-fps')}",
            f"    {value(1)}",
            "  </max>",
            "</quotient>",
        ],
        "1/(2V) with V = true airspeed (floored at 1 ft/s)",
    )
    omega = "aero/gtm/omega-rad_sec"
    lines += function(
        omega,
        [
            "<sum>",
            "  <product>",
            f"    {prop('velocities/p-aero-rad_sec')}",
            *indent(ca_cb, 2),
            "  </product>",
            "  <product>",
            f"    {prop('velocities/q-aero-rad_sec')}",
            *indent(sb, 2),
            "  </product>",
            "  <product>",
            f"    {prop('velocities/r-aero-rad_sec')}",
            *indent(sa_cb, 2),
            "  </product>",
            "</sum>",
        ],
        "body rate projected on the velocity vector (rotary-balance rate Omega)",
    )
    lines += function(
        "aero/gtm/omega-hat",
        [
            "<product>",
            f"  {prop(omega)}",
            f"  {prop('metrics/bw-ft')}",
            f"  {prop(half_over_v)}",
            "</product>",
        ],
        "Omega b / 2V",
    )
    osc = (
        ("p", "aero/gtm/p-hat", "metrics/bw-ft", ca_cb),
        ("q", "aero/gtm/q-hat", "metrics/cbarw-ft", sb),
        ("r", "aero/gtm/r-hat", "metrics/bw-ft", sa_cb),
    )
    for axis, name, length, direction in osc:
        lines += function(
            name,
            [
                "<product>",
                "  <difference>",
                f"    {prop(f'velocities/{axis}-aero-rad_sec')}",
                "    <product>",
                f"      {prop(omega)}",
                *indent(direction, 3),
                "    </product>",
                "  </difference>",
                f"  {prop(length)}",
                f"  {prop(half_over_v)}",
                "</product>",
            ],
            f"oscillatory {axis} rate, normalised ({axis}-Omega component) * ref length / 2V",
        )
    return lines


def basic(db: dict) -> list[str]:
    """C6_bas(alpha, beta): the basic airframe."""
    t = db["C6_bas"]
    a, b, d = arr(t.alpha), arr(t.beta), arr(t.data)
    lines: list[str] = []
    for i, c in enumerate(COEFFS6):
        lines += function(f"aero/gtm/bas/{c}", table_2d(ALPHA, a, BETA, b, d[:, :, i]))
    return lines


def stab_weights(db: dict) -> list[str]:
    """Piecewise-linear weights of the stabilizer breakpoints (exact 1-D interpolation)."""
    stab = arr(db["dC3_ele"].stab)
    lines: list[str] = []
    for k, s in enumerate(stab):
        w = np.zeros(len(stab))
        w[k] = 1.0
        lines += function(
            f"aero/gtm/ele/w-stab{k}",
            table_1d("fcs/stabilizer-pos-deg", stab, w),
            f"interpolation weight of the stab = {fmt(s)} deg slice",
        )
    return lines


def elevator_table(db: dict, c: str, deflection: str) -> list[str]:
    """T(de) = dC3_ele(alpha, beta, stab, de) of coefficient ``c`` (CX, CZ or Cm) at the
    deflection property ``deflection``: the stabilizer slices blended by their weights."""
    t = db["dC3_ele"]
    a, b, stab, elev, d = arr(t.alpha), arr(t.beta), arr(t.stab), arr(t.elev), arr(t.data)
    terms: list[str] = ["<sum>"]
    for k in range(len(stab)):
        body = table_3d(ALPHA, a, BETA, b, deflection, elev, d[:, :, k, :, LONG3.index(c)])
        terms += indent(["<product>", f"{IND}{prop(f'aero/gtm/ele/w-stab{k}')}"], 1)
        terms += indent(body, 2)
        terms += indent(["</product>"], 1)
    terms.append("</sum>")
    return terms


ELEVATOR_TOGETHER = "fcs/elevator-panels-together"
ELEVATOR_EACH = "fcs/elevator-each-panel"


def elevator_flags() -> list[str]:
    """FCS functions: whether the elevator panels are together, and whether each panel's
    table is to be looked up (panels apart, or a damage case that loses some)."""
    lines = all_equal(ELEVATOR_TOGETHER, list(ELEVATOR_PANELS.values()))
    lost = [f"<eq>{prop(DAMAGE_CASE)}{value(k)}</eq>" for k in ELEVATOR_LOST_IN]
    each = ["<or>", f"  <not>{prop(ELEVATOR_TOGETHER)}</not>", *indent(lost, 1), "</or>"]
    return lines + fcs_function("elevator each panel", ELEVATOR_EACH, each)


def elevator_panel(key: str, c: str) -> str:
    """The property holding T(de_i) of panel ``key`` and coefficient ``c``."""
    return f"aero/gtm/ele-{key.lower()}/{c}"


def elevator(db: dict) -> list[str]:
    """NASA's ``Stab1``: the stabilizer T(0) plus four panels, each 0.25 (T(de_i) - T(0)) with
    a rolling moment arm_i x its CZ and a yawing moment -arm_i x its CX.

    Summed over the four panels the T(0) terms cancel (the shares add to 1, the arms to 0), so
    CX, CZ, Cm = 0.25 sum T(de_i) and Cl = 0.25 sum arm_i T_CZ(de_i), Cn = -0.25 sum arm_i
    T_CX(de_i).  Each panel's T(de_i) is a property; panels at one deflection (the common
    case: the symmetric elevator command drives all four) take the first panel's T(de) with
    Cl = Cn = 0, the same sums, and the other three are looked up only when they are needed
    (panels apart, or a damage case that takes some away: ``elevator_loss``), flags the FCS
    sets (``elevator_flags``).
    """
    assert sum(ELEVATOR_ARMS.values()) == 0.0
    keys = list(ELEVATOR_PANELS)
    lines: list[str] = []
    for key, panel in ELEVATOR_PANELS.items():
        for c in LONG3:
            table = elevator_table(db, c, pos(panel))
            body = table if key == keys[0] else if_then(ELEVATOR_EACH, table, [value(0)])
            lines += function(elevator_panel(key, c), body, f"T(de) of the {panel}, {c}")
    for c in LONG3:
        apart = scaled(0.25, summed(*([prop(elevator_panel(k, c))] for k in keys)))
        body = if_then(ELEVATOR_TOGETHER, [prop(elevator_panel(keys[0], c))], apart)
        lines += function(f"aero/gtm/ele/{c}", body)
    for c, source, sign in (("Cl", "CZ", 1.0), ("Cn", "CX", -1.0)):
        terms = [
            scaled(sign * 0.25 * ELEVATOR_ARMS[k], [prop(elevator_panel(k, source))]) for k in keys
        ]
        lines += function(
            f"aero/gtm/ele/{c}",
            if_then(ELEVATOR_TOGETHER, [value(0)], summed(*terms)),
            f"{c} of elevator panels deflected unequally (NASA's RollYaw Coupling)",
        )
    return lines


def right_and_mirrored_left(db: dict, table: str, axis: str, surface: str, name: str) -> list[str]:
    """A right-surface table as tabulated, and the left surface as its mirror image."""
    t = db[table]
    a, b, defl, d = arr(t.alpha), arr(t.beta), arr(getattr(t, axis)), arr(t.data)
    lines: list[str] = []
    for i, c in enumerate(COEFFS6):
        body = table_3d(ALPHA, a, BETA, b, f"fcs/right-{surface}-pos-deg", defl, d[:, :, :, i])
        lines += function(f"aero/gtm/{name}-right/{c}", body)
    for i, c in enumerate(COEFFS6):
        body = table_3d(
            ALPHA, a, BETA_MIRROR, b, f"fcs/left-{surface}-pos-deg", defl, d[:, :, :, i]
        )
        lines += function(f"aero/gtm/{name}-left/{c}", signed(MIRROR_SIGN[c], body))
    return lines


def aileron(db: dict) -> list[str]:
    """dC6_ail: right aileron as tabulated, left aileron as its mirror image."""
    return right_and_mirrored_left(db, "dC6_ail", "ail", "aileron", "ail")


RUDDER_TOGETHER = "fcs/rudder-panels-together"


def rudder_inputs() -> list[str]:
    """FCS functions (after the rudder servos): each rudder's deflection split into the
    tabulated negative side and the mirrored positive side, and whether they are together."""
    lines: list[str] = []
    for panel in RUDDER_PANELS.values():
        lines += fcs_function(
            f"{panel} negative side",
            f"aero/gtm/{panel}-neg-deg",
            ["<min>", f"  {prop(pos(panel))}", f"  {value(0)}", "</min>"],
        )
        lines += fcs_function(
            f"{panel} mirrored side",
            f"aero/gtm/{panel}-mirror-deg",
            ["<min>", *indent(scaled(-1, [prop(pos(panel))]), 1), f"  {value(0)}", "</min>"],
        )
    return lines + all_equal(RUDDER_TOGETHER, list(RUDDER_PANELS.values()))


def shares_add_to_one(share: dict[str, tuple[float, ...]]) -> bool:
    """Whether a surface's panel shares add to 1 for every coefficient, so that panels at one
    deflection may be looked up once."""
    return all(sum(s) == 1.0 for s in zip(*share.values(), strict=True))


def rudder(db: dict) -> list[str]:
    """dC6_rud: tabulated for negative deflection; positive deflection is the mirror image.

    NASA's upper and lower rudder each take their share of the table (``RUDDER_SHARE``: half
    of the forces and yaw, 0.67 / 0.33 of roll and pitch) at their own deflection; at one
    deflection (``fcs/rudder-pos-deg``) they are looked up once (the shares add to 1).
    """
    assert shares_add_to_one(RUDDER_SHARE)
    t = db["dC6_rud"]
    a, b, rud, d = arr(t.alpha), arr(t.beta), arr(t.rud), arr(t.data)
    lines: list[str] = []
    lines: list[str] = []
    for i, c in enumerate(COEFFS6):

        def lookup(name: str, i: int = i, c: str = c) -> list[str]:
            direct = table_3d(ALPHA, a, BETA, b, f"aero/gtm/{name}-neg-deg", rud, d[:, :, :, i])
            mirrored = table_3d(
                ALPHA, a, BETA_MIRROR, b, f"aero/gtm/{name}-mirror-deg", rud, d[:, :, :, i]
            )
            return summed(direct, signed(MIRROR_SIGN[c], mirrored))

        each = [scaled(RUDDER_SHARE[k][i], lookup(p)) for k, p in RUDDER_PANELS.items()]
        lines += function(
            f"aero/gtm/rud/{c}",
            if_then(RUDDER_TOGETHER, lookup(RUDDER_PANELS["U"]), summed(*each)),
        )
    return lines


def spoiler(db: dict) -> list[str]:
    """dC6_spo: on each side an inboard and an outboard panel, each taking its share of the
    table (``SPOILER_SHARE``) at its own deflection; the right side as tabulated, the left as
    its mirror image. Panels of a side at one deflection are looked up once (the shares add
    to 1)."""
    assert shares_add_to_one(SPOILER_SHARE)
    t = db["dC6_spo"]
    a, b, defl, d = arr(t.alpha), arr(t.beta), arr(t.spo), arr(t.data)
    lines: list[str] = []
    for side, beta in (("right", BETA), ("left", BETA_MIRROR)):
        panels = SPOILER_PANELS[side]
        together = f"fcs/{side}-spoiler-panels-together"
        for i, c in enumerate(COEFFS6):
            sign = 1 if side == "right" else MIRROR_SIGN[c]

            def lookup(deflection: str, i: int = i, beta: str = beta) -> list[str]:
                return table_3d(ALPHA, a, beta, b, deflection, defl, d[:, :, :, i])

            each = [scaled(SPOILER_SHARE[k][i], lookup(pos(p))) for k, p in panels.items()]
            body = if_then(together, lookup(f"fcs/{side}-spoiler-pos-deg"), summed(*each))
            lines += function(f"aero/gtm/spo-{side}/{c}", signed(sign, body))
    return lines


def rate_damping(db: dict) -> list[str]:
    """dC3_q(alpha, qhat), dC3_p(alpha, phat), dC3_r(alpha, rhat): forced-oscillation data."""
    lines: list[str] = []
    groups = (
        ("dC3_q", "qhat", "aero/gtm/q-hat", "q", LONG3),
        ("dC3_p", "phat", "aero/gtm/p-hat", "p", LAT3),
        ("dC3_r", "rhat", "aero/gtm/r-hat", "r", LAT3),
    )
    for key, field, var, short, coeffs in groups:
        t = db[key]
        a, h, d = arr(t.alpha), arr(getattr(t, field)), arr(t.data)
        for i, c in enumerate(coeffs):
            lines += function(f"aero/gtm/{short}/{c}", table_2d(ALPHA, a, var, h, d[:, :, i]))
    return lines


def rotary(db: dict) -> list[str]:
    """dC6_w(alpha, omegahat, beta): rotary-balance increments."""
    t = db["dC6_w"]
    a, w, b, d = arr(t.alpha), arr(t.what), arr(t.beta), arr(t.data)
    lines: list[str] = []
    for i, c in enumerate(COEFFS6):
        body = table_3d(ALPHA, a, "aero/gtm/omega-hat", w, BETA, b, d[:, :, :, i])
        lines += function(f"aero/gtm/w/{c}", body)
    return lines


def landing_gear(db: dict) -> list[str]:
    """dC3_lgr(alpha, gear): gear up (0) to gear down (1), linear in gear/gear-pos-norm."""
    t = db["dC3_lgr"]
    a, d = arr(t.alpha), arr(t.data)
    gear = np.array([0.0, 1.0])
    lines: list[str] = []
    for i, c in enumerate(LONG3):
        lines += function(
            f"aero/gtm/lgr/{c}", table_2d(ALPHA, a, "gear/gear-pos-norm", gear, d[:, :, i])
        )
    return lines


FLAPS_TOGETHER = "fcs/flap-panels-together"


def flaps(db: dict) -> list[str]:
    """Flap derivatives (per degree), one per panel times its deflection; panels at one
    deflection (``fcs/flap-pos-deg``) take the four derivatives' sum."""
    t = db["flaps"]
    per_panel = {k: arr(getattr(t, f"flap{k.lower()}")) for k in FLAP_PANELS}
    total = sum(per_panel.values())
    lines: list[str] = []
    for i, c in enumerate(COEFFS6):
        together = scaled(total[i], [prop("fcs/flap-pos-deg")])
        each = [scaled(per_panel[k][i], [prop(pos(p))]) for k, p in FLAP_PANELS.items()]
        lines += function(f"aero/gtm/flp/{c}", if_then(FLAPS_TOGETHER, together, summed(*each)))
    return lines


#: NASA's damage cases: dC6_damage holds six, in the order of its ``cases`` field (1..6).
N_DAMAGE_CASES = 6
DAMAGE_CASE = "damage/case"


def per_case(undamaged_body: list[str], branches: list[list[str]]) -> list[str]:
    """``undamaged_body`` for ``damage/case`` 0, else ``branches[k - 1]`` for case k (a
    ``<switch>``: only the selected branch is evaluated)."""
    assert len(branches) == N_DAMAGE_CASES
    body = ["<switch>", f"  {prop(DAMAGE_CASE)}", *indent(undamaged_body, 1)]
    for branch in branches:
        body += indent(branch, 1)
    return [*body, "</switch>"]


#: Aero groups a damage case removes (NASA's ``DamageModels_T2``: surface gain 0), by case.
#: Both rudder panels go together (cases 1 and 2), so the one rudder of the model is lost.
LOST_IN: dict[str, tuple[int, ...]] = {"rud": (1, 2), "ail-left": (4,)}
#: NASA's elevator panels (``Stab1``): moment arm (fraction of the span, right positive) of the
#: left outboard, left inboard, right inboard and right outboard panel; each adds
#: 0.25 (T(de) - T(0)) of dC3_ele with Cl = arm CZ and Cn = -arm CX.
ELEVATOR_ARMS = {"LOB": -0.07, "LIB": -0.03, "RIB": 0.03, "ROB": 0.07}
#: The elevator panels and stabilizer each damage case removes (``DamageModels_T2``).
ELEVATOR_LOST_IN = {5: ("LOB", "LIB"), 6: ("STAB", "LOB", "LIB")}
#: The undamaged rate terms NASA's damaged dynamic model replaces, by coefficient.
RATE_GROUPS = {c: ("q", "w") if c in LONG3 else ("p", "r", "w") for c in COEFFS6}


def negated(prop_name: str) -> list[str]:
    """Minus a property."""
    return ["<product>", f"  {value(-1)}", f"  {prop(prop_name)}", "</product>"]


def elevator_at_zero(db: dict, c: str) -> list[str]:
    """T(0): dC3_ele(alpha, beta, stab, 0) of coefficient ``c``, the stabilizer's own part
    (the elevator panels add 0.25 (T(de) - T(0)) each)."""
    t = db["dC3_ele"]
    a, b, stab, elev, d = arr(t.alpha), arr(t.beta), arr(t.stab), arr(t.elev), arr(t.data)
    zero = int(np.flatnonzero(elev == 0.0)[0])
    terms = ["<sum>"]
    for k in range(len(stab)):
        table = table_2d(ALPHA, a, BETA, b, d[:, :, k, zero, LONG3.index(c)])
        terms += ["  <product>", f"    {prop(f'aero/gtm/ele/w-stab{k}')}", *indent(table, 2)]
        terms.append("  </product>")
    return [*terms, "</sum>"]


def elevator_loss(db: dict, c: str, lost: tuple[str, ...]) -> list[str]:
    """Terms that take the ``lost`` elevator panels (and the stabilizer, ``"STAB"``) out of
    NASA's ``Stab1`` sum T(0) + sum over the panels of 0.25 (T(de_i) - T(0)) (``elevator``):
    per lost panel minus 0.25 (T(de_i) - T(0)), and minus its roll arm_i x that CZ and yaw
    -arm_i x that CX; minus T(0) for the stabilizer."""
    source = {"CX": "CX", "CZ": "CZ", "Cm": "Cm", "Cl": "CZ", "Cn": "CX"}.get(c)
    if source is None:
        return []
    terms: list[str] = []
    for key in (x for x in lost if x != "STAB"):
        arm = ELEVATOR_ARMS[key]
        factor = {"Cl": -arm, "Cn": arm}.get(c, -1.0) * 0.25
        delta = [  # T(de_i) - T(0) of the source coefficient
            "<difference>",
            f"  {prop(elevator_panel(key, source))}",
            *indent(elevator_at_zero(db, source), 1),
            "</difference>",
        ]
        terms += scaled(factor, delta)
    if "STAB" in lost and c in LONG3:
        terms += scaled(-1, elevator_at_zero(db, c))
    return terms


def damage(db: dict) -> list[str]:
    """The damage cases as one correction per coefficient, ``aero/gtm/dam/<C>``: exactly 0
    undamaged (the totals keep their bits, and the only cost is one ``<switch>`` each), else
    what NASA's block diagram changes in case k:

    * + ``dC6_damage.bas(alpha, beta, k)`` (``aero/gtm/dam-bas/<C>``, clamped: NASA clips it);
    * the rate terms replaced: - the undamaged dC3_p/q/r and dC6_w terms, + dC3_p/q/r of the
      raw body rates (``aero/gtm/{p,q,r}-hat-body``) times ``ddscale(alpha, k, rate, C)``,
      and for CY + sum ``ddinc(alpha, k, rate, CY)`` times the normalised rate (NASA wires
      the CY column of ddinc only);
    * the lost surfaces' increments removed: the rudder (cases 1, 2), the left aileron
      (case 4), the left outboard flap panel (case 3), the left elevator panels (cases 5, 6)
      with the roll and yaw of the right ones left (NASA's ``Stab1``), the stabilizer
      (case 6), each at its own deflection.
    """
    bas = db["dC6_damage"].bas
    b_alpha, b_beta, b_data = arr(bas.alpha), arr(bas.beta), arr(bas.data)
    assert b_data.shape == (len(b_alpha), len(b_beta), N_DAMAGE_CASES, 6), b_data.shape
    assert len(db["dC6_damage"].cases) == N_DAMAGE_CASES
    scale, inc = db["dC6_damage"].ddscale, db["dC6_damage"].ddinc
    s_alpha, s_data = arr(scale.alpha), arr(scale.data)  # alpha x case x [p q r] x coefficient
    i_alpha, i_data = arr(inc.alpha), arr(inc.data)
    rate_tables = {
        "q": ("dC3_q", "qhat", LONG3),
        "p": ("dC3_p", "phat", LAT3),
        "r": ("dC3_r", "rhat", LAT3),
    }
    flap_lob = arr(db["flaps"].flaplob)
    lines: list[str] = []
    for axis in "pqr":
        length = "metrics/cbarw-ft" if axis == "q" else "metrics/bw-ft"
        body = ["<product>", f"  {prop(f'velocities/{axis}-aero-rad_sec')}"]
        body += [f"  {prop(length)}", f"  {prop('aero/gtm/half-over-vt-sec_ft')}", "</product>"]
        lines += function(
            f"aero/gtm/{axis}-hat-body",
            body,
            f"body rate {axis} normalised (the damaged rate model's variable)",
        )
    for i, c in enumerate(COEFFS6):
        tables = [table_2d(ALPHA, b_alpha, BETA, b_beta, b_data[:, :, k, i]) for k in range(6)]
        lines += function(
            f"aero/gtm/dam-bas/{c}",
            per_case([value(0)], tables),
            f"damage case airframe increment dC6_damage.bas, {c}",
        )
    for i, c in enumerate(COEFFS6):
        branches = []
        for k in range(1, N_DAMAGE_CASES + 1):
            terms = [prop(f"aero/gtm/dam-bas/{c}")]
            for group in RATE_GROUPS[c]:
                terms += negated(f"aero/gtm/{group}/{c}")
            for axis in "pqr":
                key, field, coeffs = rate_tables[axis]
                if c not in coeffs:
                    continue
                t = db[key]
                a, h, d = arr(t.alpha), arr(getattr(t, field)), arr(t.data)
                raw = table_2d(ALPHA, a, f"aero/gtm/{axis}-hat-body", h, d[:, :, coeffs.index(c)])
                j = "pqr".index(axis)
                factor = table_1d(ALPHA, s_alpha, s_data[:, k - 1, j, i])
                terms += ["<product>", *indent(raw, 1), *indent(factor, 1), "</product>"]
            if c == "CY":
                for j, axis in enumerate("pqr"):
                    per_rate = table_1d(ALPHA, i_alpha, i_data[:, k - 1, j, i])
                    terms += ["<product>", *indent(per_rate, 1)]
                    terms += [f"  {prop(f'aero/gtm/{axis}-hat-body')}", "</product>"]
            for group, cases in LOST_IN.items():
                if k in cases:
                    terms += negated(f"aero/gtm/{group}/{c}")
            if k in ELEVATOR_LOST_IN:
                terms += elevator_loss(db, c, ELEVATOR_LOST_IN[k])
            if k == 3 and flap_lob[i] != 0.0:  # the left outboard flap panel's derivative
                terms += ["<product>", f"  {value(-flap_lob[i])}"]
                terms += [f"  {prop(pos(FLAP_PANELS['LOB']))}", "</product>"]
            branches.append(["<sum>", *indent(terms, 1), "</sum>"])
        lines += function(
            f"aero/gtm/dam/{c}",
            per_case([value(0)], branches),
            f"what the damage case changes in {c} (0 undamaged)",
        )
    return lines


#: The surface groups every coefficient sums, in the order of the sums.
SURFACE_GROUPS = ("bas", "ele", "ail-right", "ail-left", "rud", "spo-right", "spo-left")
GROUPS: dict[str, tuple[str, ...]] = {
    "CX": (*SURFACE_GROUPS, "q", "w", "lgr", "flp", "dam"),
    "CY": (*SURFACE_GROUPS, "p", "r", "w", "flp", "dam"),
}
GROUPS["CZ"] = GROUPS["CX"]
GROUPS["Cm"] = GROUPS["CX"]
GROUPS["Cl"] = GROUPS["CY"]
GROUPS["Cn"] = GROUPS["CY"]
GROUPS["CY"] = tuple(g for g in GROUPS["CY"] if g != "ele")  # the elevator has no side force


def totals() -> list[str]:
    """Total body-axis coefficients aero/coefficient/<C> (sum of all increments)."""
    lines: list[str] = []
    for c in COEFFS6:
        body = ["<sum>"] + [f"  {prop(f'aero/gtm/{g}/{c}')}" for g in GROUPS[c]] + ["</sum>"]
        lines += function(f"aero/coefficient/{c}", body, f"total {c} (database axes)")
    return lines


def axes() -> list[str]:
    """JSBSim axis functions: forces qbar S C, moments qbar S {b, cbar} C, about AERORP."""
    spec = (
        ("X", "CX", None),
        ("Y", "CY", None),
        ("Z", "CZ", None),
        ("ROLL", "Cl", "metrics/bw-ft"),
        ("PITCH", "Cm", "metrics/cbarw-ft"),
        ("YAW", "Cn", "metrics/bw-ft"),
    )
    lines: list[str] = []
    for axis, c, length in spec:
        factors = [prop("aero/qbar-psf"), prop("metrics/Sw-sqft")]
        if length:
            factors.append(prop(length))
        factors.append(prop(f"aero/coefficient/{c}"))
        body = ["<product>", *indent(factors, 1), "</product>"]
        kind = "moment" if length else "force"
        lines.append(f'<axis name="{axis}">')
        lines += indent(function(f"aero/{kind}/gtm-{axis}", body, f"+1 * {c}"), 1)
        lines.append("</axis>")
    return lines


def aerodynamics(db: dict) -> list[str]:
    """The whole <aerodynamics> element."""
    comment = [
        "<!-- Axis mapping: the database gives body-axis coefficients with CX positive FORWARD,",
        "     CY positive RIGHT, CZ positive DOWN and Cl, Cm, Cn right-handed about the aero",
        "     reference point (25 % MAC). JSBSim's X/Y/Z axis system is the same body frame",
        "     (X forward, Y right, Z down), so each force is +qbar*S*C (no sign flip; an",
        "     AXIAL/NORMAL model would have needed -CX and -CZ). Moments are +qbar*S*{b,cbar}*C",
        "     about AERORP; JSBSim transfers them to the CG. -->",
    ]
    body: list[str] = list(comment)
    sections = (
        ("derived inputs (mirrored sideslip, normalised rates)", aero_inputs()),
        ("C6_bas: basic airframe", basic(db)),
        ("dC3_ele: stabilizer interpolation weights", stab_weights(db)),
        ("dC3_ele: stabilizer and four elevator panels (NASA's Stab1)", elevator(db)),
        ("dC6_ail: ailerons (right tabulated, left mirrored)", aileron(db)),
        ("dC6_rud: upper and lower rudder (negative tabulated, positive mirrored)", rudder(db)),
        ("dC6_spo: inboard and outboard spoilers (right tabulated, left mirrored)", spoiler(db)),
        ("dC3_q, dC3_p, dC3_r: forced-oscillation rate terms", rate_damping(db)),
        ("dC6_w: rotary-balance terms", rotary(db)),
        ("dC3_lgr: landing gear", landing_gear(db)),
        ("flaps: per-degree derivatives of four panels", flaps(db)),
        ("dC6_damage: what the damage case changes", damage(db)),
        ("totals", totals()),
    )
    for title, lines in sections:
        body.append(f"<!-- {title} -->")
        body += lines
    body += axes()
    return ["<aerodynamics>", *indent(body, 1), "</aerodynamics>"]


# --------------------------------------------------------------------------------------------
# Flight control system
# --------------------------------------------------------------------------------------------
def fcs_function(name: str, output: str | None, body: list[str]) -> list[str]:
    """An <fcs_function> component."""
    lines = [f'<fcs_function name="{name}">', f"{IND}<function>"]
    lines += indent(body, 2)
    lines.append(f"{IND}</function>")
    if output:
        lines.append(f"{IND}<output>{output}</output>")
    lines.append("</fcs_function>")
    return lines


def clip(body: list[str], lo: float, hi: float) -> list[str]:
    """max(lo, min(hi, body))."""
    return [
        "<max>",
        f"  {value(lo)}",
        "  <min>",
        f"    {value(hi)}",
        *indent(body, 2),
        "  </min>",
        "</max>",
    ]


def servo(
    surface: str,
    command: list[str],
    pos: str,
    limits: tuple[float, float],
    rate_limit: float,
    bandwidth_hz: float,
    bypass: str | None,
) -> list[str]:
    """NASA surface servo: y' = sat(2 pi f (u - y), +-rate), y limited, Euler at the frame rate.

    With simulation/dt = 0 (trim, run_ic, linearisation) the servo sits at its steady state,
    the position-limited command. ``bypass`` (if given) names a 0/1 property: when 1 the
    surface equals the unlimited command exactly.  One ``<fcs_function>``: the command, its
    limit and the rate are computed inline (JSBSim evaluates only the branch taken), which
    costs a third of four chained components and gives the same numbers.
    """
    lo, hi = limits
    limited = clip(command, lo, hi)
    err = [
        "<product>",
        f"  {value(2.0 * math.pi * bandwidth_hz)}",
        "  <difference>",
        *indent(limited, 2),
        f"    {prop(pos)}",
        "  </difference>",
        "</product>",
    ]
    step = [
        "<sum>",
        f"  {prop(pos)}",
        "  <product>",
        f"    {prop('simulation/dt')}",
        *indent(clip(err, -rate_limit, rate_limit), 2),
        "  </product>",
        "</sum>",
    ]
    integ = [
        "<ifthen>",
        f"  <gt>{prop('simulation/dt')}{value(0)}</gt>",
        *indent(clip(step, lo, hi), 1),
        *indent(limited, 1),
        "</ifthen>",
    ]
    if bypass:
        integ = [
            "<ifthen>",
            f"  <gt>{prop(bypass)}{value(0.5)}</gt>",
            *indent(command, 1),
            *indent(integ, 1),
            "</ifthen>",
        ]
    return fcs_function(f"{surface} servo", pos, integ)


def command_sum(deg_prop: str, *norm_props: str) -> list[str]:
    """deg command + 30 deg * (sum of the normalised commands)."""
    norms = [f"    {prop(p)}" for p in norm_props]
    if len(norms) > 1:
        norms = ["    <sum>", *indent(norms, 1), "    </sum>"]
    return [
        "<sum>",
        f"  {prop(deg_prop)}",
        "  <product>",
        f"    {value(DEG_PER_NORM)}",
        *norms,
        "  </product>",
        "</sum>",
    ]


def panel_servos(
    panels: Sequence[str], command: str, limits: Sequence[tuple[float, float]], bypass: str = ""
) -> list[str]:
    """One NASA servo per panel (position limits ``limits``, one pair per panel), each
    commanded by the surface's ``command`` (a property) plus its own ``fcs/<panel>-cmd-deg``
    (0 unless a panel is driven on its own)."""
    rate, bw = SERVO_RATE_LIMIT_DPS, SERVO_BANDWIDTH_HZ
    lines: list[str] = []
    commands = panel_commands(command, panels)
    for panel, (body, where), own in zip(panels, commands, limits, strict=True):
        lines += servo(panel, body, where, own, rate, bw, bypass or None)
    return lines


def servos_busy(name: str, servos: Sequence[tuple[list[str], str]]) -> list[str]:
    """A 0/1 FCS function, 1 when any of ``servos`` (command expression, position property)
    has its command away from its position.  A servo whose command equals its position (so
    the command is inside the limits) keeps its position exactly, in flight and in trim, so
    a channel of servos may skip every frame in which this is 0 and give the same numbers."""
    away = [["<nq>", *indent(cmd, 1), f"  {prop(where)}", "</nq>"] for cmd, where in servos]
    body = (
        away[0] if len(away) == 1 else ["<or>", *(x for a in away for x in indent(a, 1)), "</or>"]
    )
    return fcs_function(f"{name} busy", f"fcs/{name}-busy", body)


def panel_commands(command: str, panels: Sequence[str]) -> list[tuple[list[str], str]]:
    """(command, position) of each panel servo ``panel_servos`` makes."""
    return [(summed([prop(command)], [prop(f"fcs/{p}-cmd-deg")]), pos(p)) for p in panels]


def flight_control() -> list[str]:
    """The <flight_control> element: servos for every surface panel and the gear."""
    spoilers = [p for side in SPOILER_PANELS.values() for p in side.values()]
    all_panels = [
        *ELEVATOR_PANELS.values(),
        "right-aileron",
        "left-aileron",
        *RUDDER_PANELS.values(),
        *spoilers,
        *FLAP_PANELS.values(),
    ]
    interface = [
        '<property value="0">fcs/elevator-cmd-deg</property>',
        '<property value="0">fcs/elevator-servo-bypass</property>',
        '<property value="0">fcs/aileron-cmd-deg</property>',
        '<property value="0">fcs/rudder-cmd-deg</property>',
        '<property value="0">fcs/left-spoiler-cmd-deg</property>',
        '<property value="0">fcs/right-spoiler-cmd-deg</property>',
        '<property value="0">fcs/stabilizer-pos-deg</property>',
        '<property value="0">fcs/flap-cmd-deg</property>',
        *(f'<property value="0">fcs/{p}-cmd-deg</property>' for p in all_panels),
        *(
            f'<property value="1">{flag}</property>'  # all panels start at 0 deg
            for flag in (
                ELEVATOR_TOGETHER,
                RUDDER_TOGETHER,
                "fcs/right-spoiler-panels-together",
                "fcs/left-spoiler-panels-together",
                FLAPS_TOGETHER,
            )
        ),
        f'<property value="0">{DAMAGE_CASE}</property>',
        f'<property value="0">{MASS_CASE}</property>',
        f'<property value="0">{MASS_STALE}</property>',
    ]
    elevator_total = fcs_function(
        "elevator cmd total",
        "fcs/elevator-cmd-total",
        command_sum("fcs/elevator-cmd-deg", "fcs/elevator-cmd-norm", "fcs/pitch-trim-cmd-norm"),
    )
    panels = list(ELEVATOR_PANELS.values())
    pitch = elevator_total + panel_servos(
        panels, "fcs/elevator-cmd-total", [ELEVATOR_LIMITS_DEG] * 4, "fcs/elevator-servo-bypass"
    )
    pitch += fcs_function(
        "elevator position", "fcs/elevator-pos-deg", mean_of([pos(p) for p in panels])
    )
    pitch += elevator_flags()
    watch = fcs_function(
        "aileron cmd total",
        "fcs/aileron-cmd-total",
        command_sum("fcs/aileron-cmd-deg", "fcs/aileron-cmd-norm"),
    )
    watch += fcs_function(
        "left aileron cmd", "fcs/aileron-cmd-mirrored", scaled(-1, [prop("fcs/aileron-cmd-total")])
    )
    right = panel_servos(["right-aileron"], "fcs/aileron-cmd-total", [AILERON_LIMITS_DEG])
    left = panel_servos(["left-aileron"], "fcs/aileron-cmd-mirrored", [AILERON_LIMITS_DEG])
    rudders = list(RUDDER_PANELS.values())
    watch += fcs_function(
        "rudder cmd total",
        "fcs/rudder-cmd-total",
        command_sum("fcs/rudder-cmd-deg", "fcs/rudder-cmd-norm"),
    )
    yaw = panel_servos(rudders, "fcs/rudder-cmd-total", [RUDDER_LIMITS_DEG] * 2)
    yaw += fcs_function("rudder position", "fcs/rudder-pos-deg", mean_of([pos(p) for p in rudders]))
    yaw += rudder_inputs()
    spo: list[str] = []
    for side, side_panels in SPOILER_PANELS.items():
        names = list(side_panels.values())
        limits = [SPOILER_LIMITS_DEG[k] for k in side_panels]
        spo += panel_servos(names, f"fcs/{side}-spoiler-cmd-deg", limits)
        spo += fcs_function(
            f"{side} spoiler position",
            f"fcs/{side}-spoiler-pos-deg",
            mean_of([pos(p) for p in names]),
        )
        spo += all_equal(f"fcs/{side}-spoiler-panels-together", names)
    flaps = list(FLAP_PANELS.values())
    flap = panel_servos(flaps, "fcs/flap-cmd-deg", [FLAP_LIMITS_DEG] * 4)
    flap += fcs_function("flap position", "fcs/flap-pos-deg", mean_of([pos(p) for p in flaps]))
    flap += all_equal(FLAPS_TOGETHER, flaps)
    gear = servo(
        "gear",
        [prop("gear/gear-cmd-norm")],
        "gear/gear-pos-norm",
        (0.0, 1.0),
        GEAR_RATE_PER_S,
        10.0,
        None,
    )
    high_lift = [
        *panel_commands("fcs/right-spoiler-cmd-deg", SPOILER_PANELS["right"].values()),
        *panel_commands("fcs/left-spoiler-cmd-deg", SPOILER_PANELS["left"].values()),
        *panel_commands("fcs/flap-cmd-deg", flaps),
    ]
    watch += servos_busy(
        "aileron",
        [
            *panel_commands("fcs/aileron-cmd-total", ["right-aileron"]),
            *panel_commands("fcs/aileron-cmd-mirrored", ["left-aileron"]),
        ],
    )
    watch += servos_busy("rudder", panel_commands("fcs/rudder-cmd-total", rudders))
    watch += servos_busy("high-lift", high_lift)
    watch += servos_busy("gear", [([prop("gear/gear-cmd-norm")], "gear/gear-pos-norm")])
    # (name, components, the property that must be 1 for the channel to run, if any)
    channels = (
        ("pitch", pitch, None),
        ("servo watch", watch, None),
        ("roll", right + left, "fcs/aileron-busy"),
        ("yaw", yaw, "fcs/rudder-busy"),
        ("spoilers and flaps", spo + flap, "fcs/high-lift-busy"),
        ("landing gear", gear, "fcs/gear-busy"),
        ("damage watch", damage_mass_watch(), None),
    )
    body: list[str] = [
        "<!-- Servo, as in NASA's GTM_DesignSim: y' = sat(2 pi 5 Hz (u - y), +-300 deg/s),",
        "     position limited; forward Euler at the frame rate. With simulation/dt = 0 (trim,",
        "     run_ic, linearisation) every servo sits at its limited command (its steady",
        "     state). Commands: <surface>-cmd-deg + 30 deg * <surface>-cmd-norm; the elevator",
        "     also adds 30 deg * fcs/pitch-trim-cmd-norm, which JSBSim's trim sets.",
        "     Elevator: positive trailing edge down (nose down); fcs/elevator-servo-bypass = 1",
        "     makes the surface equal the (unlimited) command exactly.",
        "     Aileron (NASA sign): positive = right trailing edge down, left trailing edge up",
        "     (rolls LEFT). Rudder (NASA sign): positive = trailing edge left (nose left).",
        "     Every panel has its own servo, commanded by its surface's command plus its own",
        "     fcs/<panel>-cmd-deg; the surface's position (fcs/elevator-pos-deg, ...) is the",
        "     mean of its panels, exactly their deflection when they move together.",
        "     Servos that all sit at their commands are not run (fcs/<surface>-busy = 0):",
        "     they would keep their positions exactly. -->",
        *interface,
    ]
    for name, comps, execute in channels:
        body.append(
            f'<channel name="{name}" execute="{execute}">'
            if execute
            else f'<channel name="{name}">'
        )
        body += indent(comps, 1)
        body.append("</channel>")
    body.append(f'<channel name="damage mass" execute="{MASS_STALE}">')
    body += indent(damage_masses_fcs(), 1)
    body.append("</channel>")
    return ['<flight_control name="GTM T2 servos">', *indent(body, 1), "</flight_control>"]


# --------------------------------------------------------------------------------------------
# Header, metrics, mass, gear, propulsion
# --------------------------------------------------------------------------------------------
def x_station_in(frac: float) -> float:
    """Structural x (inches, aft positive, from the fuselage datum) of a fraction of the MAC."""
    return (MAC_LE_FT + frac * CBAR_FT) * 12.0


def location(name: str | None, x: float, y: float, z: float) -> list[str]:
    """A <location> element in inches."""
    attr = f' name="{name}"' if name else ""
    return [
        f'<location{attr} unit="IN">',
        f"{IND}<x> {fmt_fixed(x, 6)} </x>",
        f"{IND}<y> {fmt_fixed(y, 6)} </y>",
        f"{IND}<z> {fmt_fixed(z, 6)} </z>",
        "</location>",
    ]


def header(version: str) -> list[str]:
    """<fileheader> with licence and provenance."""
    return [
        "<fileheader>",
        f"{IND}<author>probing project (converter aircraft/convert_gtm.py)</author>",
        f"{IND}<description>NASA Generic Transport Model, tail T2 (5.5 % twin-jet transport)"
        "</description>",
        f'{IND}<reference refID="LAR-17625-1" author="NASA Langley Research Center"'
        f' title="GTM_DesignSim: Flight Dynamics Simulation of a Generic Transport Model"'
        f' date="2009"/>',
        f"{IND}<license>",
        f"{IND}{IND}<licenseName>NASA Open Source Agreement 1.3</licenseName>",
        f"{IND}{IND}<licenseURL>NOSA-1.3.txt</licenseURL>",
        f"{IND}</license>",
        f"{IND}<note>{NOTICE}</note>",
        f"{IND}<note>Derived from NASA's GTM_DesignSim aero database ({version}). Modification"
        " by the probing project; see CHANGELOG.md and README.md in this folder.</note>",
        f"{IND}<note>Generated file: do not edit, run aircraft/convert_gtm.py.</note>",
        "</fileheader>",
    ]


def metrics() -> list[str]:
    """<metrics>: reference geometry, AERORP at 25 % MAC."""
    x_ac = x_station_in(AERO_REF_FRAC)
    return [
        "<metrics>",
        f'{IND}<wingarea unit="FT2"> {fmt_fixed(S_FT2, 4)} </wingarea>',
        f'{IND}<wingspan unit="FT"> {fmt_fixed(SPAN_FT, 4)} </wingspan>',
        f'{IND}<chord unit="FT"> {fmt_fixed(CBAR_FT, 4)} </chord>',
        f"{IND}<!-- structural frame: x aft from the fuselage datum, inches; MAC leading edge"
        f" at {fmt_fixed(MAC_LE_FT, 4)} ft; AERORP at 25 % MAC -->",
        *indent(location("AERORP", x_ac, 0.0, 0.0), 1),
        *indent(location("EYEPOINT", 12.0, 0.0, 2.0), 1),
        *indent(location("VRP", x_station_in(CG_FRAC), 0.0, 0.0), 1),
        "</metrics>",
    ]


def mass_balance() -> list[str]:
    """<mass_balance>: 57.75 lb (fuel lumped), CG at 21.99 % MAC."""
    i = INERTIA_SLUGFT2
    return [
        "<mass_balance>",
        f"{IND}<!-- NASA T2, gear up, 2 x 5.74 lb fuel included in the empty weight. NASA's",
        f"{IND}     products of inertia are the integrals (Ixz = +int xz dm in body axes) and its",
        f"{IND}     tensor has -Ixy, -Ixz, -Iyz off the diagonal. JSBSim's tensor has -ixy,",
        f"{IND}     -iyz but +ixz there (FGMassBalance::Load), so ixz = -Ixz. CG at 21.99 % MAC.",
        f"{IND}-->",
        f'{IND}<ixx unit="SLUG*FT2"> {fmt_fixed(i["ixx"], 4)} </ixx>',
        f'{IND}<iyy unit="SLUG*FT2"> {fmt_fixed(i["iyy"], 4)} </iyy>',
        f'{IND}<izz unit="SLUG*FT2"> {fmt_fixed(i["izz"], 4)} </izz>',
        f'{IND}<ixy unit="SLUG*FT2"> {fmt_fixed(i["ixy"], 4)} </ixy>',
        f'{IND}<ixz unit="SLUG*FT2"> {fmt_fixed(-i["ixz"], 4)} </ixz>',
        f'{IND}<iyz unit="SLUG*FT2"> {fmt_fixed(0.0, 4)} </iyz>',
        f'{IND}<emptywt unit="LBS"> {fmt_fixed(WEIGHT_LBS, 4)} </emptywt>',
        *indent(location("CG", x_station_in(CG_FRAC), 0.0, 0.0), 1),
        f"{IND}<!-- damage cases (NASA's DamageModels_T2 deltas), weights set by the FCS -->",
        *indent(damage_point_mass_elements(), 1),
        "</mass_balance>",
    ]


#: NASA's ``DamageModels_T2`` mass deltas, case -> (dWeight lb, dCG in inches with x forward,
#: y right, z down, [dIxx dIyy dIzz dIxz dIyz dIxy] slug ft^2 with the products of inertia as
#: integrals, e.g. dIxz = d(int xz dm)).
DAMAGE_MASS: dict[int, tuple[float, tuple[float, float, float], tuple[float, ...]]] = {
    1: (-0.13, (0.126, 0.000, 0.028), (-0.00346, -0.06698, -0.06352, -0.01409, 0.00001, 0.00003)),
    2: (-1.31, (1.166, 0.000, 0.277), (-0.03507, -0.57604, -0.54102, -0.13113, 0.00006, 0.00024)),
    3: (-0.09, (0.014, 0.041, 0.001), (-0.01018, -0.00120, -0.01137, -0.00009, -0.00027, -0.00347)),
    4: (-0.81, (0.148, 0.628, 0.032), (-0.25821, -0.01727, -0.27400, -0.00295, -0.01346, -0.05998)),
    5: (-0.07, (0.065, 0.010, 0.004), (-0.00097, -0.03391, -0.03467, -0.00188, -0.00029, -0.00510)),
    6: (-0.59, (0.553, 0.088, 0.032), (-0.00918, -0.27315, -0.28049, -0.01559, -0.00265, -0.04370)),
}
SLUG_LB = 32.174049  # JSBSim's slugtolb
#: Fixed directions of the inertia "dipoles" (body axes): their six outer products span the
#: symmetric 3 x 3 matrices, so any inertia change can be made of them.
DIPOLE_DIRECTIONS = (
    np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, 0, 1], [0, 1, 1]], dtype=float)
    / np.sqrt([1, 1, 1, 2, 2, 2])[:, None]
)
DIPOLE_ARM_FT = 1.0


def nasa_damaged_cg_shift_in(dw: float, dcg: tuple[float, float, float]) -> np.ndarray:
    """The CG's shift (inches, NASA's axes: x forward, y right, z down) by a damage case, as
    NASA's simulation computes it: its block diagram (``A/C parameters/Inertia/Mass/CG
    Shift``) divides the *undamaged* weight moment W0 cg0 by the damaged weight W0 + dW and
    adds dCG, so the CG moves by dCG plus cg0 (W0 / (W0 + dW) - 1), cg0 measured from NASA's
    reference datum (ahead of the nose, above the CG).  For case 4 that is 0.66 in aft where
    dCG alone says 0.15 in forward; NASA's Example 6 plots come from it."""
    cg0 = np.array([-x_station_in(CG_FRAC), NASA_CG0_Y_IN, NASA_CG0_Z_IN])
    return np.array(dcg) + cg0 * (WEIGHT_LBS / (WEIGHT_LBS + dw) - 1.0)


def inertia_tensor(ixx: float, iyy: float, izz: float, ixz: float, iyz: float, ixy: float):
    """The inertia tensor (body axes, slug ft^2) of moments and product integrals."""
    return np.array([[ixx, -ixy, -ixz], [-ixy, iyy, -iyz], [-ixz, -iyz, izz]])


def _parallel(mass_slug: float, r_ft: np.ndarray) -> np.ndarray:
    """m (|r|^2 I - r r^T): a point mass's inertia about a point at -r from it (JSBSim's)."""
    r2 = float(r_ft[0] * r_ft[0] + r_ft[1] * r_ft[1] + r_ft[2] * r_ft[2])  # no BLAS: see below
    return mass_slug * (r2 * np.eye(3) - np.outer(r_ft, r_ft))


def solve_exact(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with a x = b, solved in exact rational arithmetic and rounded once to float64.

    The written model must be a pure function of the .mat file on every machine.  A LAPACK
    solve (and a BLAS dot product) picks its kernel by the processor (OpenBLAS's
    ``OPENBLAS_CORETYPE``), and the kernels round differently in the last digit, which
    ``exact_value`` writes; the floats in ``a`` and ``b`` are exact rationals, so Gauss-Jordan
    elimination over ``Fraction`` gives the one correctly rounded answer.  (Hand-written:
    numpy and scipy have no exact solver, and six unknowns do not justify a CAS.)
    """
    n = len(b)
    rows = [[Fraction(float(v)) for v in a[i]] + [Fraction(float(b[i]))] for i in range(n)]
    for col in range(n):
        pivot = next(r for r in range(col, n) if rows[r][col] != 0)  # exact: any nonzero
        rows[col], rows[pivot] = rows[pivot], rows[col]
        head = rows[col]
        for r in range(n):
            if r != col and rows[r][col] != 0:
                f = rows[r][col] / head[col]
                rows[r] = [x - f * y for x, y in zip(rows[r], head, strict=True)]
    return np.array([float(rows[i][n] / rows[i][i]) for i in range(n)])


def _to_body_ft(struct_in: np.ndarray, cg_in: np.ndarray) -> np.ndarray:
    """JSBSim's StructuralToBody: a structural location (in) relative to the CG, body ft."""
    d = struct_in - cg_in
    return np.array([-d[0], d[1], -d[2]]) / 12.0


def damage_point_masses() -> tuple[np.ndarray, np.ndarray]:
    """Point masses that give each damage case NASA's weight, CG and inertia.

    Returns ``weights`` (case 0..6, mass) lb and ``locations`` (case 0..6, mass, xyz) inches
    in the structural frame.  Mass 0 is the lost part: weight dW at the location that moves
    the CG where NASA's simulation moves it (:func:`nasa_damaged_cg_shift_in`).
    JSBSim adds each mass's parallel-axis inertia about the new CG (and the
    base's, about it too); NASA adds only its inertia deltas.  Masses 1-12 are six pairs at
    +-1 ft along fixed directions around the base CG and mass 13 sits at the base CG with
    minus their weight: together they weigh nothing and move no CG, and their weights are
    solved so that the total inertia is exactly the base inertia plus NASA's deltas.  Case 0:
    every weight 0, which adds nothing (to the bit).
    """
    cg0 = np.array([float(fmt_fixed(x_station_in(CG_FRAC), 6)), 0.0, 0.0])  # as JSBSim reads it
    n_dip = len(DIPOLE_DIRECTIONS)
    weights = np.zeros((7, 2 + 2 * n_dip))
    locations = np.tile(cg0, (7, 2 + 2 * n_dip, 1))
    # the dipoles' structural locations: cg0 -+ the body direction (x, z flipped)
    arm_in = 12.0 * DIPOLE_ARM_FT * DIPOLE_DIRECTIONS * np.array([-1.0, 1.0, -1.0])
    basis = [2.0 * DIPOLE_ARM_FT**2 * np.outer(e, e) for e in DIPOLE_DIRECTIONS]
    sym = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]
    a = np.array([[b[i, j] for b in basis] for i, j in sym])  # second moment per unit mass
    for case, (dw, dcg, di) in DAMAGE_MASS.items():
        w = WEIGHT_LBS + dw
        nasa = nasa_damaged_cg_shift_in(dw, dcg)
        shift = np.array([-nasa[0], nasa[1], -nasa[2]])  # structural: x aft, z up
        cg = cg0 + shift
        lost = cg0 + shift * w / dw  # W cg = W0 cg0 + dW lost
        target = inertia_tensor(*di)  # NASA: base + deltas, no parallel-axis terms
        extra = _parallel(WEIGHT_LBS / SLUG_LB, _to_body_ft(cg0, cg))
        extra += _parallel(dw / SLUG_LB, _to_body_ft(lost, cg))
        need = target - extra  # what the dipoles must add: X = tr(S) I - S
        second = 0.5 * np.trace(need) * np.eye(3) - need
        m = solve_exact(a, np.array([second[i, j] for i, j in sym]))  # slug per pair mass
        weights[case, 0] = dw
        locations[case, 0] = lost
        for k in range(n_dip):
            weights[case, 1 + 2 * k : 3 + 2 * k] = m[k] * SLUG_LB
            locations[case, 1 + 2 * k] = cg0 + arm_in[k]
            locations[case, 2 + 2 * k] = cg0 - arm_in[k]
        weights[case, -1] = -2.0 * m.sum() * SLUG_LB
        locations[case, :, :] = np.where(weights[case, :, None] == 0.0, cg0, locations[case])
    return weights, locations


MASS_CASE = "damage/mass-case"  # the case whose point masses are set
MASS_STALE = "damage/mass-stale"  # 1 while damage/case differs from it


def damage_mass_watch() -> list[str]:
    """The FCS function that flags a change of ``damage/case`` (run every frame)."""
    body = ["<nq>", f"  {prop(DAMAGE_CASE)}", f"  {prop(MASS_CASE)}", "</nq>"]
    return fcs_function("damage mass stale", MASS_STALE, body)


def damage_masses_fcs() -> list[str]:
    """FCS functions that set the damage point masses from ``damage/case``: in a channel that
    runs only in the frame after the case changed (``damage/mass-stale``), so the undamaged
    aircraft pays one comparison per frame.  The mass model runs after the FCS: a case set
    between two steps acts in the next one."""
    weights, locations = damage_point_masses()
    lines: list[str] = []
    for i in range(weights.shape[1]):
        outs = [("weight", f"inertia/pointmass-weight-lbs[{i}]", weights[:, i])]
        for j, axis in enumerate("XYZ"):
            out = f"inertia/pointmass-location-{axis}-inches[{i}]"
            outs.append((f"{axis.lower()}", out, locations[:, i, j]))
        for what, out, per in outs:
            body = ["<switch>", f"  {prop(DAMAGE_CASE)}", *[f"  {exact_value(v)}" for v in per]]
            lines += fcs_function(f"damage mass {i} {what}", out, [*body, "</switch>"])
    return lines + fcs_function("damage mass case", MASS_CASE, [prop(DAMAGE_CASE)])


def damage_point_mass_elements() -> list[str]:
    """The damage point masses in <mass_balance>, all of weight 0 (undamaged)."""
    weights, _ = damage_point_masses()
    cg0 = x_station_in(CG_FRAC)
    lines: list[str] = []
    for i in range(weights.shape[1]):
        name = "damage lost part" if i == 0 else f"damage inertia {i}"
        lines += [
            f'<pointmass name="{name}">',
            f'{IND}<weight unit="LBS"> 0 </weight>',
            *indent(location(None, cg0, 0.0, 0.0), 1),
            "</pointmass>",
        ]
    return lines


def ground_reactions() -> list[str]:
    """Retractable tricycle gear (approximate geometry, for ground handling only)."""
    gears = (
        ("NOSE", 20.0, 0.0, 300.0),
        ("LEFT_MAIN", 60.0, -9.0, 600.0),
        ("RIGHT_MAIN", 60.0, 9.0, 600.0),
    )
    lines = [
        "<ground_reactions>",
        f"{IND}<!-- approximate positions (not from NASA); retracted when"
        " gear/gear-pos-norm = 0 -->",
    ]
    for name, x, y, k in gears:
        brake = "NONE" if name == "NOSE" else name.split("_")[0]
        lines += indent(
            [
                f'<contact type="BOGEY" name="{name}">',
                *indent(location(None, x, y, -8.0), 1),
                f"{IND}<static_friction> 0.8 </static_friction>",
                f"{IND}<dynamic_friction> 0.5 </dynamic_friction>",
                f"{IND}<rolling_friction> 0.02 </rolling_friction>",
                f'{IND}<spring_coeff unit="LBS/FT"> {fmt_fixed(k, 1)} </spring_coeff>',
                f'{IND}<damping_coeff unit="LBS/FT/SEC"> {fmt_fixed(k / 20.0, 1)} </damping_coeff>',
                f'{IND}<max_steer unit="DEG"> {"10" if name == "NOSE" else "0"} </max_steer>',
                f"{IND}<brake_group> {brake} </brake_group>",
                f"{IND}<retractable>1</retractable>",
                "</contact>",
            ],
            1,
        )
    lines.append("</ground_reactions>")
    return lines


def propulsion() -> list[str]:
    """Two 'electric' engines with direct thrusters: thrust = throttle x 17 lbf each."""
    lines = [
        "<propulsion>",
        f"{IND}<!-- Thrust model (not from NASA: the design sim carries no engine model it",
        f"{IND}     uses): each engine gives thrust = fcs/throttle-cmd-norm x"
        f" {fmt(THRUST_PER_ENGINE_LBF)} lbf",
        f"{IND}     instantly, along body x through the CG height (no thrust pitching moment).",
        f"{IND}     Implemented as a JSBSim electric engine driving a direct thruster (thrust in",
        f"{IND}     lbf = power in ft*lbf/s); trim sets fcs/throttle-cmd-norm. -->",
    ]
    for side, y in (("left", -15.0), ("right", 15.0)):
        lines += indent(
            [
                f'<engine file="gtm_jet"> <!-- {side} -->',
                f'{IND}<thruster file="gtm_direct">',
                *indent(location(None, x_station_in(CG_FRAC), y, 0.0), 2),
                f'{IND}{IND}<orient unit="DEG"> <roll> 0 </roll> <pitch> 0 </pitch> <yaw> 0 </yaw>'
                " </orient>",
                f"{IND}</thruster>",
                "</engine>",
            ],
            1,
        )
    lines.append("</propulsion>")
    return lines


def engine_file() -> str:
    """Engines/gtm_jet.xml: power chosen so that direct thrust (lbf) = throttle x 17."""
    watts = THRUST_PER_ENGINE_LBF * 745.7 / 550.0
    return "\n".join(
        [
            '<?xml version="1.0"?>',
            "<!-- GTM T2 jet stand-in: JSBSim electric engine whose 'power' in ft*lbf/s becomes",
            f"     the thrust in lbf of a direct thruster: {fmt(THRUST_PER_ENGINE_LBF)} lbf at full"
            " throttle.",
            f"     {NOTICE}",
            "     Derived from NASA's GTM_DesignSim by the probing project (see CHANGELOG.md). -->",
            '<electric_engine name="gtm_jet">',
            f'{IND}<power unit="WATTS"> {fmt(watts)} </power>',
            "</electric_engine>",
            "",
        ]
    )


def thruster_file() -> str:
    """Engines/gtm_direct.xml: a direct thruster."""
    return "\n".join(
        [
            '<?xml version="1.0"?>',
            "<!-- Thrust is computed directly by the engine (lbf). -->",
            '<direct name="gtm_direct">',
            "</direct>",
            "",
        ]
    )


# --------------------------------------------------------------------------------------------
# Assembly
# --------------------------------------------------------------------------------------------
def build_model(db: dict) -> str:
    """The complete gtm_t2.xml text."""
    version = str(db.get("ver", "unknown version")).strip()
    parts = [
        header(version),
        metrics(),
        mass_balance(),
        ground_reactions(),
        propulsion(),
        flight_control(),
        aerodynamics(db),
    ]
    lines = [
        '<?xml version="1.0"?>',
        "<!-- GTM T2 for JSBSim, generated by aircraft/convert_gtm.py from NASA's",
        "     T2_polynomial_aerodatabase.mat. Do not edit by hand.",
        f"     {NOTICE}",
        "     Distributed under the NASA Open Source Agreement 1.3 (NOSA-1.3.txt). -->",
        '<fdm_config name="gtm_t2" version="2.0" release="ALPHA">',
    ]
    for part in parts:
        lines += indent(part, 1)
    lines.append("</fdm_config>")
    return "\n".join(lines) + "\n"


def write_outputs(db: dict, out: Path) -> list[Path]:
    """Write the model and its engine files into ``out``; return the paths written."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "Engines").mkdir(exist_ok=True)
    files = {
        out / "gtm_t2.xml": build_model(db),
        out / "Engines" / "gtm_jet.xml": engine_file(),
        out / "Engines" / "gtm_direct.xml": thruster_file(),
    }
    for path, text in files.items():
        path.write_bytes(text.encode("utf-8"))
    return list(files)


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mat", type=Path, help="T2_polynomial_aerodatabase.mat")
    parser.add_argument(
        "--out",
        type=Path,
        default=Path(__file__).parent / "gtm_t2",
        help="output folder (default: aircraft/gtm_t2)",
    )
    args = parser.parse_args(argv)
    for path in write_outputs(load_database(args.mat), args.out):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
