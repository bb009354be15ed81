"""Longitudinal modes of the JSBSim GTM T2 model across airspeed.

Usage::

    python -m analysis.gtm_modes [--docs docs/gtm.md] [--figure figures/gtm_modes.png]

For each equivalent airspeed 60, 70, ..., 130 kt at 800 ft (gear up, stabilizer 0) the model
is trimmed straight and level with JSBSim's full trim (throttle and elevator via
``fcs/pitch-trim-cmd-norm``), then linearised with ``jsbsim.FGLinearization``. The
longitudinal block of the state matrix (states Vt, alpha, theta, q) gives the short-period and
phugoid eigenvalue pairs; their natural frequency (rad/s) and damping ratio are tabulated in
``docs/gtm.md`` (written whole by this script) and plotted in ``figures/gtm_modes.png``.

FGLinearization suspends JSBSim's time step and leaves ``simulation/dt`` at 0: the script
restores it with ``fdm.set_dt`` after each linearisation. While dt = 0 the model's servos sit
at their command, so the linear model is the bare airframe (servo dynamics excluded).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from probing.design import LONG_STATES, longitudinal_modes

ROOT = Path(__file__).resolve().parents[1]
AIRCRAFT = ROOT / "aircraft"
DT = 1.0 / 200.0
ALTITUDE_FT = 800.0
SPEEDS_KEAS = tuple(range(60, 131, 10))


@dataclass
class ModePoint:
    """Trim and longitudinal modes at one airspeed."""

    ve_kts: float
    trimmed: bool
    alpha_deg: float = math.nan
    elevator_deg: float = math.nan
    throttle: float = math.nan
    sp_wn: float = math.nan
    sp_zeta: float = math.nan
    ph_wn: float = math.nan
    ph_zeta: float = math.nan
    eigenvalues: tuple[complex, ...] = ()


def make_fdm():
    """Load gtm_t2 (gear up, dt = 1/200 s, quiet)."""
    import jsbsim

    fdm = jsbsim.FGFDMExec(None)
    fdm.set_debug_level(0)
    fdm.set_aircraft_path(str(AIRCRAFT))
    if not fdm.load_model("gtm_t2"):
        raise RuntimeError("could not load gtm_t2")
    fdm.set_dt(DT)
    fdm["gear/gear-cmd-norm"] = 0.0
    fdm["fcs/stabilizer-pos-deg"] = 0.0
    return fdm


def trim_level(fdm, ve_kts: float, h_ft: float = ALTITUDE_FT) -> bool:
    """Trim straight and level at ``ve_kts`` (KEAS); True on success."""
    fdm["ic/h-sl-ft"] = h_ft
    fdm["ic/ve-kts"] = ve_kts
    fdm["ic/alpha-deg"] = 4.0
    fdm["ic/beta-deg"] = 0.0
    fdm["ic/gamma-deg"] = 0.0
    fdm["ic/phi-deg"] = 0.0
    fdm["fcs/elevator-cmd-deg"] = 0.0
    fdm["fcs/elevator-cmd-norm"] = 0.0
    fdm.run_ic()
    try:
        fdm["simulation/do_simple_trim"] = 1
    except RuntimeError:  # jsbsim.TrimFailureError derives from RuntimeError
        return False
    return True


def longitudinal_matrix(fdm) -> np.ndarray:
    """The (Vt, alpha, theta, q) block of JSBSim's linearised state matrix."""
    import jsbsim

    lin = jsbsim.FGLinearization(fdm)
    fdm.set_dt(DT)  # FGLinearization leaves dt at 0
    names = list(lin.x_names)
    idx = [names.index(n) for n in LONG_STATES]
    return np.asarray(lin.system_matrix)[np.ix_(idx, idx)]


def sweep(speeds: tuple[int, ...] = SPEEDS_KEAS) -> list[ModePoint]:
    """Trim and linearise at each speed."""
    fdm = make_fdm()
    points: list[ModePoint] = []
    for v in speeds:
        if not trim_level(fdm, v):
            points.append(ModePoint(v, False))
            continue
        point = ModePoint(
            v,
            True,
            alpha_deg=fdm["aero/alpha-deg"],
            elevator_deg=fdm["fcs/elevator-pos-deg"],
            throttle=fdm["fcs/throttle-cmd-norm"],
        )
        eigs = np.linalg.eigvals(longitudinal_matrix(fdm))
        point.sp_wn, point.sp_zeta, point.ph_wn, point.ph_zeta = longitudinal_modes(eigs)
        point.eigenvalues = tuple(complex(e) for e in sorted(eigs, key=abs, reverse=True))
        points.append(point)
    return points


def mode_table(points: list[ModePoint]) -> str:
    """Markdown table of trim and modes."""
    lines = [
        "| KEAS | alpha (deg) | elevator (deg) | throttle | SP wn (rad/s) | SP zeta "
        "| phugoid wn (rad/s) | phugoid zeta | phugoid period (s) |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for p in points:
        if not p.trimmed:
            lines.append(f"| {p.ve_kts:.0f} | trim failed | | | | | | | |")
            continue
        period = 2 * math.pi / (p.ph_wn * math.sqrt(max(1 - p.ph_zeta**2, 0.0)))
        lines.append(
            f"| {p.ve_kts:.0f} | {p.alpha_deg:.2f} | {p.elevator_deg:.2f} | {p.throttle:.3f} "
            f"| {p.sp_wn:.2f} | {p.sp_zeta:.3f} | {p.ph_wn:.3f} | {p.ph_zeta:.3f} "
            f"| {period:.1f} |"
        )
    return "\n".join(lines)


def plot(points: list[ModePoint], path: Path) -> None:
    """Frequency and damping of both modes against airspeed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [p for p in points if p.trimmed]
    v = [p.ve_kts for p in ok]
    fig, axes = plt.subplots(2, 2, figsize=(9, 6), sharex=True)
    series = (
        (axes[0, 0], [p.sp_wn for p in ok], "short period $\\omega_n$ (rad/s)"),
        (axes[1, 0], [p.sp_zeta for p in ok], "short period $\\zeta$"),
        (axes[0, 1], [p.ph_wn for p in ok], "phugoid $\\omega_n$ (rad/s)"),
        (axes[1, 1], [p.ph_zeta for p in ok], "phugoid $\\zeta$"),
    )
    for ax, y, label in series:
        ax.plot(v, y, "o-")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    ph_ref = [math.sqrt(2) * 32.174 / (p.ve_kts * 1.68781) for p in ok]
    axes[0, 1].plot(v, ph_ref, "--", color="gray", label="$\\sqrt{2}\\,g/V$ (EAS, approx.)")
    axes[0, 1].legend(fontsize=8)
    for ax in axes[1]:
        ax.set_xlabel("equivalent airspeed (kt)")
    fig.suptitle("GTM T2 (JSBSim), 800 ft, gear up, stabilizer 0: longitudinal modes")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


DOC_HEAD = """# GTM T2 on JSBSim

`aircraft/gtm_t2` is a JSBSim 1.3 model of NASA's Generic Transport Model (tail T2, a 5.5 %
dynamically scaled twin-jet transport), generated by `aircraft/convert_gtm.py` from the public
aero database of NASA's GTM_DesignSim (LAR-17625-1). The model folder is distributed under the
NASA Open Source Agreement 1.3 (its own `NOSA-1.3.txt`, `NOTICE`, `CHANGELOG.md`); the
converter and the rest of the project are MIT. Model notes in detail:
`aircraft/gtm_t2/README.md`.

## Model in brief

* **Aerodynamics**: every table of the release except damage cases and the all-zero dC3_sym:
  C6_bas(alpha, beta); dC3_ele(alpha, beta, stab, elev) with the four panels deflected together;
  dC6_ail (right, plus the mirrored left); dC6_rud (negative tabulated, positive mirrored);
  dC6_spo (right, plus mirrored left); dC3_q/p/r forced-oscillation rate terms; dC6_w
  rotary-balance terms; dC3_lgr gear increment; flap derivatives. Multilinear interpolation,
  clamped at table ends. Totals: `aero/coefficient/{CX,CY,CZ,Cl,Cm,Cn}`.
* **Transcription check** (`tests/test_gtm.py`): at 300 random states (alpha -5..40 deg, beta
  +-20 deg, rates up to 1.5 rad/s, all surfaces) JSBSim's six totals agree with an independent
  SciPy `RegularGridInterpolator` evaluation of the .mat tables to better than 1e-9 (test
  tolerance 1e-6). States are set with `ic/*` properties and `run_ic()`; during `run_ic` the
  time step is 0 and the servos sit exactly at their commands.
* **Mass**: 57.75 lb, Ixx 1.221, Iyy 4.655, Izz 5.587, Ixz 0.274, Ixy 0.006 slug ft^2; CG at
  21.99 % MAC, aero reference point at 25 % MAC (both on the fuselage datum line).
* **Thrust** (not from NASA): two engines, thrust = throttle x 17 lbf each, instant, through
  the CG height. **Servos**: NASA's first-order 5 Hz loop with the 300 deg/s rate limit inside
  the loop; elevator -30..+20 deg; `fcs/elevator-servo-bypass` for a pure surface.
* **Gear**: JSBSim starts every model with `gear/gear-cmd-norm = 1` (down) and the model's
  `<property>` defaults cannot override that built-in property: set it to 0 before `run_ic`
  and trim (the gear servo then sits up at once while dt = 0).

## Sign conventions

* CX, CY, CZ: body axes, forward, right, **down** (lift gives CZ < 0). Cl, Cm, Cn:
  right-handed about 25 % MAC (roll right, nose up, nose right).
* JSBSim axes `X`, `Y`, `Z`, `ROLL`, `PITCH`, `YAW`: force = +qbar S C, moment =
  +qbar S {b, cbar} C about AERORP (no sign flip; JSBSim transfers to the CG).
* Elevator: positive trailing edge down, nose down (dCm/d(de) < 0, and more tail lift).
* Aileron: positive = right TED / left TEU, so positive aileron **rolls left** (NASA sign,
  kept for `fcs/aileron-cmd-norm`). Rudder: positive trailing edge left, nose left (Cn < 0),
  side force right. Spoilers: positive trailing edge up.
* Commands: `<surface>-cmd-deg + 30 deg x <surface>-cmd-norm`; the elevator also adds
  `30 deg x fcs/pitch-trim-cmd-norm`, the control JSBSim's trim sets.
* Rates: phat = p_osc b/2V, qhat = q_osc cbar/2V, rhat = r_osc b/2V; omega-hat = Omega b/2V,
  Omega the body rate along the velocity vector (zero in symmetric flight, where qhat is
  simply q cbar / 2V).

## Trim and longitudinal modes (800 ft, gear up, stabilizer 0)

Generated by `python -m analysis.gtm_modes`: JSBSim full trim, then `FGLinearization`; modes
from the (Vt, alpha, theta, q) block of the state matrix (bare airframe: the servos are at
their command while JSBSim linearises). Figure: `figures/gtm_modes.png`.

"""

DOC_TAIL = """

## What is plausible and what is not

* **Trim alpha at 75 kt is about 5.6 deg, not the ~3 deg of NASA's nominal initial condition.**
  The database gives CL = -CZ of about 0.29 at alpha = 3 deg and 0.51 at 5.6 deg; with 57.75 lb
  and S = 5.9018 ft^2 at 75 KEAS (qbar 19.0 psf) level flight needs CL = 0.51. Alpha = 3 deg
  would need about 100 KEAS. The 3 deg of the nominal condition is presumably a starting
  guess (or a different weight/flap setting); nothing in the transcription is off (see the
  1e-9 agreement above).
* Short period: 4.3 rad/s at 60 kt to 11.5 rad/s at 130 kt, damping 0.42-0.46. Froude scaling
  of a transport's 1-2.5 rad/s by 1/sqrt(0.055) = 4.3 gives 4-11 rad/s: plausible. The step
  between 70 and 80 kt is larger than its neighbours: the tables are linear between alpha
  breakpoints (4, 6, 8 deg ...), so the derivatives are piecewise constant in alpha and the
  trim alpha crosses a breakpoint there.
* Phugoid: 0.41 rad/s at 60 kt to 0.19 rad/s at 130 kt, close to sqrt(2) g/V (gray line in
  the figure), damping 0.06-0.18, in line with 1/(sqrt(2) L/D) for the trim L/D = W/T of
  10 down to 6: plausible. Its period (15-34 s) is
  far longer than the probe's 5.11 s memory, as the paper notes.
* Throttle at trim is 0.17-0.30 of the assumed 2 x 17 lbf, i.e. 5.6-10 lbf of drag. The drag
  is NASA's; the throttle values only reflect the stand-in thrust model.
* Trim elevator moves trailing edge down as speed grows (stable speed gradient).
* The trim also settles a tiny bank (about 0.05 deg) because the database is not exactly
  mirror-symmetric at beta = 0 (and Ixy is nonzero); harmless.
* Not modelled: damage cases, asymmetric elevator panels, dead zones, engine dynamics, thrust
  moments, ground effect, sensors; the landing-gear contact points are approximate.
"""


def write_doc(points: list[ModePoint], path: Path) -> None:
    """Write docs/gtm.md whole."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(DOC_HEAD + mode_table(points) + "\n" + DOC_TAIL, encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--docs", type=Path, default=ROOT / "docs" / "gtm.md")
    parser.add_argument("--figure", type=Path, default=ROOT / "figures" / "gtm_modes.png")
    args = parser.parse_args(argv)
    points = sweep()
    print(mode_table(points))
    for p in points:
        if p.trimmed:
            print(f"{p.ve_kts:.0f} kt eigenvalues: " + ", ".join(f"{e:.4f}" for e in p.eigenvalues))
    write_doc(points, args.docs)
    plot(points, args.figure)
    print(f"wrote {args.docs} and {args.figure}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
