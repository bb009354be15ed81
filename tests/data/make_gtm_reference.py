#!/usr/bin/env python3
"""Generate ``tests/data/gtm_reference.npz``: GTM T2 coefficients evaluated from NASA's tables.

Usage::

    python tests/data/make_gtm_reference.py PATH/TO/T2_polynomial_aerodatabase.mat

This is an independent evaluation of NASA's aero database, written without the converter
(``aircraft/convert_gtm.py``): each table is interpolated directly with
``scipy.interpolate.RegularGridInterpolator`` (multilinear; query points clamped to the grid,
as JSBSim clamps its tables). The fixture holds a few hundred random flight states and the six
total body-axis coefficients, so ``tests/test_gtm.py`` can check the JSBSim model against it
without the .mat file.

Build-up (same conventions as documented in docs/gtm.md), every surface panel at its own
deflection, as NASA's block diagram (``Aero/Control Surfaces``) sums them:

* C = C6_bas(a, b) + elevator (below) + dC6_ail(a, b, dR) + M dC6_ail(a, -b, dL)
  + sum over the upper and lower rudder of g_rud * [dC6_rud(a, b, min(dr, 0))
  + M dC6_rud(a, -b, min(-dr, 0))] + sum over the inboard and outboard spoilers of
  g_spo * [dC6_spo(a, b, sR) + M dC6_spo(a, -b, sL)] + dC3_q/p/r(a, hat) + dC6_w(a, omegahat,
  b) + dC3_lgr(a, gear) + sum over the four flap panels of flap_i * df_i
  + dC6_damage.bas(a, b, case), with M = diag(1, -1, 1, -1, 1, -1) (mirror image: CY, Cl, Cn
  change sign) and g the panels' shares per coefficient (NASA's Gains blocks); the damage
  term is 0 for case 0 (undamaged).
* The elevator is NASA's Stab1 sum: T(0) + sum over four panels of 0.25 (T(de_i) - T(0))
  with Cl = arm CZ, Cn = -arm CX of each panel (arms -0.07, -0.03, 0.03, 0.07).
* Half of the states have every surface's panels at one deflection (as the symmetric
  commands drive them), half have each panel at a deflection of its own.
* Omega = p cos a cos b + q sin b + r sin a cos b; omegahat = Omega b / 2V;
  phat = (p - Omega cos a cos b) b / 2V, qhat = (q - Omega sin b) cbar / 2V,
  rhat = (r - Omega sin a cos b) b / 2V.
* Damage case k (1..6), as NASA's block diagram combines it: + dC6_damage.bas(a, b, k); the
  rate terms replaced by dC3_p/q/r of the raw body rates (p b/2V, q cbar/2V, r b/2V), each
  scaled by dC6_damage.ddscale(a, k, rate, coefficient), no dC6_w, and CY +=
  sum ddinc(a, k, rate, CY) * rate-hat; the rudder (k = 1, 2), the left outboard flap panel
  (k = 3), the left aileron (k = 4), the left elevator panels (k = 5, 6) and the stabilizer
  (k = 6) removed.
"""

from __future__ import annotations

import argparse
import hashlib
from pathlib import Path

import numpy as np
import scipy.io
from scipy.interpolate import RegularGridInterpolator

SPAN_FT = 6.8488
CBAR_FT = 0.9153
N_STATES = 300
SEED = 20091209
MIRROR = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0])
#: Panels, their model names and NASA's position limits (deg; Actuators/Acutator Dynamics).
PANELS = {
    "left-outboard-elevator": (-30.0, 20.0),
    "left-inboard-elevator": (-30.0, 20.0),
    "right-inboard-elevator": (-30.0, 20.0),
    "right-outboard-elevator": (-30.0, 20.0),
    "right-aileron": (-20.0, 20.0),
    "left-aileron": (-20.0, 20.0),
    "upper-rudder": (-30.0, 30.0),
    "lower-rudder": (-30.0, 30.0),
    "right-inboard-spoiler": (0.0, 15.0),
    "right-outboard-spoiler": (0.0, 45.0),
    "left-inboard-spoiler": (0.0, 15.0),
    "left-outboard-spoiler": (0.0, 45.0),
    "left-outboard-flap": (0.0, 30.0),
    "left-inboard-flap": (0.0, 30.0),
    "right-inboard-flap": (0.0, 30.0),
    "right-outboard-flap": (0.0, 30.0),
}
#: The panels of one surface, which the symmetric commands drive together.
PANELS_ELEVATOR = tuple(p for p in PANELS if p.endswith("elevator"))
SURFACES = {
    "elevator": PANELS_ELEVATOR,
    "rudder": ("upper-rudder", "lower-rudder"),
    "right spoiler": ("right-inboard-spoiler", "right-outboard-spoiler"),
    "left spoiler": ("left-inboard-spoiler", "left-outboard-spoiler"),
    "flap": tuple(p for p in PANELS if p.endswith("flap")),
}
STATE_NAMES = (
    "alpha_deg",
    "beta_deg",
    "vt_fps",
    "p_rad_sec",
    "q_rad_sec",
    "r_rad_sec",
    "stabilizer_deg",
    *PANELS,
    "gear_pos",
    "damage_case",
)
#: Each rudder's and spoiler's share of its table, [CX CY CZ Cl Cm Cn] (NASA's
#: Aero/Control Surfaces/Rudder/Gains, Gains1 and Spoilers/Gains1..4 blocks).
RUDDER_GAINS = {
    "upper-rudder": np.array([0.5, 0.5, 0.5, 0.67, 0.67, 0.5]),
    "lower-rudder": np.array([0.5, 0.5, 0.5, 0.33, 0.33, 0.5]),
}
SPOILER_GAINS = {
    "inboard": np.array([0.45, 0.45, 0.45, 0.26, 0.45, 0.26]),
    "outboard": np.array([0.55, 0.55, 0.55, 0.74, 0.55, 0.74]),
}
COEFF_NAMES = ("CX", "CY", "CZ", "Cl", "Cm", "Cn")
#: The surfaces NASA's damage cases remove (DamageModels_T2.m: gain 0), by case.
LOST = {
    "rudder": (1, 2),
    "left outboard flap": (3,),
    "left aileron": (4,),
    "left-outboard-elevator": (5, 6),
    "left-inboard-elevator": (5, 6),
    "right-inboard-elevator": (),
    "right-outboard-elevator": (),
    "stabilizer": (6,),
}
#: Elevator panels and their moment arms (fraction of the span, right positive; NASA's Stab1).
ELEVATOR_ARMS = dict(zip(PANELS_ELEVATOR, (-0.07, -0.03, 0.03, 0.07), strict=True))


class Table:
    """A gridded table with clamped multilinear interpolation over its leading axes."""

    def __init__(self, axes: list[np.ndarray], values: np.ndarray) -> None:
        self.axes = [np.asarray(a, dtype=float) for a in axes]
        self.interp = RegularGridInterpolator(self.axes, np.asarray(values, dtype=float))

    def __call__(self, *coords: np.ndarray) -> np.ndarray:
        """Evaluate at points (one array per axis); returns (n, outputs)."""
        pts = np.stack(
            [
                np.clip(np.asarray(c, dtype=float), a[0], a[-1])
                for c, a in zip(coords, self.axes, strict=True)
            ],
            axis=-1,
        )
        return self.interp(pts)


def evaluate(mat: dict, s: dict[str, np.ndarray]) -> np.ndarray:
    """Total coefficients (n, 6) [CX CY CZ Cl Cm Cn] for the states ``s``."""
    n = len(s["alpha_deg"])
    a, b = s["alpha_deg"], s["beta_deg"]
    case = s["damage_case"]
    out = np.zeros((n, 6))

    bas = mat["C6_bas"]
    out += Table([bas.alpha, bas.beta], bas.data)(a, b)

    ele = mat["dC3_ele"]
    t_ele = Table([ele.alpha, ele.beta, ele.stab, ele.elev], ele.data)
    # NASA's Stab1: the stabilizer T(0) plus four panels, each 0.25 (T(de_i) - T(0)) with
    # Cl = arm CZ and Cn = -arm CX; lost panels (gain 0) removed
    t0 = t_ele(a, b, s["stabilizer_deg"], np.zeros(n))
    gains = {p: ~np.isin(case, LOST[p]) for p in ("stabilizer", *ELEVATOR_ARMS)}
    out[:, [0, 2, 4]] += t0 * gains["stabilizer"][:, None]
    for panel, arm in ELEVATOR_ARMS.items():
        step = t_ele(a, b, s["stabilizer_deg"], s[panel]) - t0
        v = 0.25 * step * gains[panel][:, None]
        out[:, [0, 2, 4]] += v
        out[:, 3] += arm * v[:, 1]  # Cl from the panel's CZ
        out[:, 5] -= arm * v[:, 0]  # Cn from its CX

    ail = mat["dC6_ail"]
    t_ail = Table([ail.alpha, ail.beta, ail.ail], ail.data)
    out += t_ail(a, b, s["right-aileron"])
    left = MIRROR * t_ail(a, -b, s["left-aileron"])
    out += left * ~np.isin(case, LOST["left aileron"])[:, None]

    rud = mat["dC6_rud"]
    t_rud = Table([rud.alpha, rud.beta, rud.rud], rud.data)
    rudder = np.zeros((n, 6))
    for panel, gain in RUDDER_GAINS.items():
        dr = s[panel]
        one = t_rud(a, b, np.minimum(dr, 0.0)) + MIRROR * t_rud(a, -b, np.minimum(-dr, 0.0))
        rudder += gain * one
    out += rudder * ~np.isin(case, LOST["rudder"])[:, None]

    spo = mat["dC6_spo"]
    t_spo = Table([spo.alpha, spo.beta, spo.spo], spo.data)
    for where, gain in SPOILER_GAINS.items():
        out += gain * t_spo(a, b, s[f"right-{where}-spoiler"])
        out += gain * MIRROR * t_spo(a, -b, s[f"left-{where}-spoiler"])

    ar, br = np.radians(a), np.radians(b)
    p, q, r, v = s["p_rad_sec"], s["q_rad_sec"], s["r_rad_sec"], s["vt_fps"]
    e_x, e_y, e_z = np.cos(ar) * np.cos(br), np.sin(br), np.sin(ar) * np.cos(br)
    omega = p * e_x + q * e_y + r * e_z
    omega_hat = omega * SPAN_FT / (2 * v)
    p_hat = (p - omega * e_x) * SPAN_FT / (2 * v)
    q_hat = (q - omega * e_y) * CBAR_FT / (2 * v)
    r_hat = (r - omega * e_z) * SPAN_FT / (2 * v)

    tq, tp, tr = mat["dC3_q"], mat["dC3_p"], mat["dC3_r"]
    t_q = Table([tq.alpha, tq.qhat], tq.data)
    t_p = Table([tp.alpha, tp.phat], tp.data)
    t_r = Table([tr.alpha, tr.rhat], tr.data)
    w = mat["dC6_w"]
    ok = case == 0  # undamaged: oscillatory rates and the rotary-balance term
    rates = np.zeros((n, 6))
    rates[:, [0, 2, 4]] += t_q(a, q_hat)
    rates[:, [1, 3, 5]] += t_p(a, p_hat)
    rates[:, [1, 3, 5]] += t_r(a, r_hat)
    rates += Table([w.alpha, w.what, w.beta], w.data)(a, omega_hat, b)
    out[ok] += rates[ok]
    # damaged (NASA's "Forced Oscillation with Damage Increments"): the raw body rates, each
    # table value scaled by ddscale(alpha, case, rate, coefficient), no rotary term, and a side
    # force ddinc(alpha, case, rate, CY) times each normalised rate
    dam = mat["dC6_damage"]
    raw = {"p": p * SPAN_FT / (2 * v), "q": q * CBAR_FT / (2 * v), "r": r * SPAN_FT / (2 * v)}
    for k in range(1, 7):
        rows = case == k
        if not rows.any():
            continue
        ak = a[rows]
        scale = Table([dam.ddscale.alpha], np.asarray(dam.ddscale.data)[:, k - 1, :, :])(ak)
        inc = Table([dam.ddinc.alpha], np.asarray(dam.ddinc.data)[:, k - 1, :, 1])(ak)
        part = np.zeros((rows.sum(), 6))
        part[:, [0, 2, 4]] += t_q(ak, raw["q"][rows]) * scale[:, 1, [0, 2, 4]]
        part[:, [1, 3, 5]] += t_p(ak, raw["p"][rows]) * scale[:, 0, [1, 3, 5]]
        part[:, [1, 3, 5]] += t_r(ak, raw["r"][rows]) * scale[:, 2, [1, 3, 5]]
        part[:, 1] += sum(inc[:, j] * raw[x][rows] for j, x in enumerate("pqr"))
        out[rows] += part

    lgr = mat["dC3_lgr"]
    out[:, [0, 2, 4]] += Table([lgr.alpha, np.array([0.0, 1.0])], lgr.data)(a, s["gear_pos"])

    fl = mat["flaps"]
    lob = s["left-outboard-flap"]
    out += np.outer(lob, fl.flaplob) + np.outer(s["left-inboard-flap"], fl.flaplib)
    out += np.outer(s["right-inboard-flap"], fl.flaprib)
    out += np.outer(s["right-outboard-flap"], fl.flaprob)
    out -= np.outer(lob * np.isin(case, LOST["left outboard flap"]), fl.flaplob)
    out += damage_increments(mat, s)
    return out


def damage_increments(mat: dict, s: dict[str, np.ndarray]) -> np.ndarray:
    """dC6_damage.bas(alpha, beta, case) (n, 6), clamped at the table ends as NASA clips it;
    zero where ``damage_case`` is 0 (undamaged)."""
    bas = mat["dC6_damage"].bas
    data = np.asarray(bas.data, dtype=float)  # alpha x beta x case x coefficient
    out = np.zeros((len(s["alpha_deg"]), 6))
    for k in range(1, data.shape[2] + 1):
        rows = s["damage_case"] == k
        if rows.any():
            table = Table([bas.alpha, bas.beta], data[:, :, k - 1, :])
            out[rows] = table(s["alpha_deg"][rows], s["beta_deg"][rows])
    return out


def random_states(rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
    """Random states inside (mostly) the tables' ranges, with some clamped corners, the
    panels inside NASA's servo limits: in half of the states each surface's panels share one
    deflection, in the other half each has its own."""
    u = rng.uniform
    stab = np.where(u(size=n) < 0.5, 0.0, u(-12.0, 4.0, n))
    gear = rng.choice([0.0, 1.0, 0.5], size=n, p=[0.6, 0.2, 0.2]) * np.where(
        u(size=n) < 0.8, 1.0, u(size=n)
    )
    states = {
        "alpha_deg": u(-5.0, 40.0, n),
        "beta_deg": u(-20.0, 20.0, n),
        "vt_fps": u(90.0, 220.0, n),
        "p_rad_sec": u(-1.5, 1.5, n),
        "q_rad_sec": u(-1.0, 1.0, n),
        "r_rad_sec": u(-1.0, 1.0, n),
        "stabilizer_deg": stab,
        "gear_pos": gear,
        "damage_case": rng.choice(7, size=n, p=[0.28] + [0.12] * 6).astype(float),
    }
    together = u(size=n) < 0.5
    for panel, (lo, hi) in PANELS.items():
        used = u(size=n) < (0.5 if "spoiler" in panel or "flap" in panel else 1.0)
        states[panel] = np.where(used, u(lo, hi, n), 0.0)
    for panels in SURFACES.values():
        lo = max(PANELS[p][0] for p in panels)
        hi = min(PANELS[p][1] for p in panels)
        common = np.clip(states[panels[0]], lo, hi)
        for p in panels:
            states[p] = np.where(together, common, states[p])
    return states


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mat", type=Path, help="T2_polynomial_aerodatabase.mat")
    parser.add_argument("--out", type=Path, default=Path(__file__).with_name("gtm_reference.npz"))
    args = parser.parse_args(argv)
    mat = scipy.io.loadmat(str(args.mat), squeeze_me=True, struct_as_record=False)
    states = random_states(np.random.default_rng(SEED), N_STATES)
    coeffs = evaluate(mat, states)
    np.savez(
        args.out,
        states=np.stack([states[k] for k in STATE_NAMES], axis=1),
        state_names=np.array(STATE_NAMES),
        coefficients=coeffs,
        damage_increments=damage_increments(mat, states),
        coefficient_names=np.array(COEFF_NAMES),
        mat_sha256=np.array(hashlib.sha256(args.mat.read_bytes()).hexdigest()),
        database_version=np.array(str(mat["ver"])),
    )
    print(f"wrote {args.out}: {N_STATES} states")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
