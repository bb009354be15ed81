"""The small-signal pulse response of a trimmed aircraft, computed two independent ways.

(a) Single pulse: a trimmed twin receives one bit of the probe amplitude on the probed
    surface (``flight.surface``, the elevator by default); its output minus an unprobed
    twin's, divided by the amplitude, sampled at the end of every bit, is the pulse response
    ``h_pulse`` (output units per deg of surface, or per unit of a normalised throttle).
(b) Linearisation: JSBSim's FGLinearization at the trim gives (A, B, C, D); discretised
    with zero-order hold at the bit duration, ``h_lin(0) = C B_d + D`` and
    ``h_lin(k) = C A_d^k B_d``: the response read at the end of each bit to a one-bit
    pulse, matching (a).

Writing them beside a run, with the probing output they predict, is
:func:`probing.experiment.truth.compute_truth`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from probing.sim.channels import CHANNELS
from probing.sim.control import ClosedLoop, control_power
from probing.sim.flight import Flight
from probing.sim.linear import zoh
from probing.sim.plant import make_plant
from probing.sim.surfaces import SURFACES

__all__ = ["linear_pulse_response", "single_pulse_response"]


def single_pulse_response(
    flight: Flight,
    channels: Sequence[str],
    amplitude_deg: float,
    steps_per_bit: int,
    n_bits: int,
) -> dict[str, np.ndarray]:
    """Response to one bit of ``amplitude_deg`` at t = 0 on ``flight.surface``, per unit of
    the surface's position (deg, or normalised throttle), sampled at each bit's end.

    In a closed-loop flight (``flight.control``) both twins fly with the autopilot and the
    pulse enters between it and the surface, as the probe does: the closed-loop response.

    Parameters
    ----------
    flight : Flight
        Aircraft, condition, step, turbulence, seed (both twins fly the same gusts) and
        autopilot.
    channels : sequence of str
        Output channels.
    amplitude_deg : float
        Height of the pulse, in the surface's unit.
    steps_per_bit : int
        Simulation steps per bit (t0 / dt).
    n_bits : int
        Length of the response, in bits.

    Returns
    -------
    dict
        Channel -> h, shape (n_bits,), in the channel's unit per deg.
    """
    n_steps = n_bits * steps_per_bit
    power = control_power(flight) if flight.closed_loop else None
    pulsed, reference = make_plant(flight), make_plant(flight)
    out_p = np.empty((n_steps, len(channels)))
    out_r = np.empty((n_steps, len(channels)))
    surface = flight.surface
    if power is not None:  # both fly the autopilot; the pulse enters between it and the surface
        pulse = np.zeros(n_steps)
        pulse[:steps_per_bit] = amplitude_deg
        ClosedLoop(pulsed, flight.control, power, surface=surface).step(
            pulse, pulsed.channel_nodes(list(channels)), out_p
        )
        pulsed.check_state()
        ClosedLoop(reference, flight.control, power, surface=surface).step(
            None, reference.channel_nodes(list(channels)), out_r
        )
    else:
        drive = pulsed.drive(surface)
        position = np.full(n_steps, drive.trim_position)
        position[:steps_per_bit] += amplitude_deg
        nodes = pulsed.channel_nodes(list(channels))
        pulsed.step(drive.command(position), nodes, out_p, drive=drive)
        pulsed.check_state()
        held = reference.drive(surface)
        cmd_trim = np.full(n_steps, held.trim_command)
        reference.step(cmd_trim, reference.channel_nodes(list(channels)), out_r, drive=held)
    h = (out_p - out_r)[steps_per_bit - 1 :: steps_per_bit] / amplitude_deg
    return {c: h[:, j] for j, c in enumerate(channels)}


def linear_pulse_response(
    flight: Flight, channels: Sequence[str], bit_duration_s: float, n_bits: int
) -> dict[str, np.ndarray]:
    """Pulse response of JSBSim's linearisation, ZOH at the bit duration, per unit of the
    probed surface's position (``flight.surface``: its input converted from normalised
    command with the model's own command-to-position slope at the trim).

    Parameters
    ----------
    flight : Flight
        Aircraft and trim condition.
    channels : sequence of str
        Output channels; those without a linearised output (:data:`CHANNELS`) are left out.
    bit_duration_s : float
        Bit duration t0, s.
    n_bits : int
        Length of the response, in bits.

    Returns
    -------
    dict
        Channel -> h, shape (n_bits,), in the channel's unit per deg; empty for a
        closed-loop flight (the linearisation is the open-loop aircraft's).
    """
    if flight.closed_loop:
        return {}
    plant = make_plant(flight)
    lin = plant.linearise()
    gain = plant.drive(flight.surface).gain_per_norm()
    iu = lin["u_names"].index(SURFACES[flight.surface].linear_input)
    a_mat, b_mat = lin["A"], lin["B"][:, [iu]] / gain  # per deg of surface
    out: dict[str, np.ndarray] = {}
    ad, bd = zoh(np.asarray(a_mat), np.asarray(b_mat), bit_duration_s)
    x = np.empty((n_bits, a_mat.shape[0]))
    x[0] = bd[:, 0]
    for k in range(1, n_bits):
        x[k] = ad @ x[k - 1]
    for channel in channels:
        name = CHANNELS[channel].linear_output
        if name is None:
            continue
        iy = lin["y_names"].index(name)
        h = x @ lin["C"][iy]
        h[0] += lin["D"][iy, iu] / gain
        out[channel] = h
    return out
