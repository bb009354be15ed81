"""The small-signal pulse response of a trimmed aircraft, computed two independent ways.

(a) Single pulse: a trimmed twin receives one bit of the probe amplitude on the probed
    surface (``flight.surface``, the elevator by default); its output minus an unprobed
    twin's, divided by the amplitude, sampled at the end of every bit, is the pulse response
    ``h_pulse`` (output units per deg of surface, or per unit of a normalised throttle).
(b) Linearisation: JSBSim's FGLinearization at the trim gives (A, B, C, D), stepped as JSBSim
    steps the aircraft (:func:`probing.sim.linear.linear_response`): zero-order hold at the
    simulation step, the airframe answering one step after the surface moves (JSBSim
    integrates before its flight-control system runs in a frame), and the surface moved by
    the model's own actuator (the GTM's 5 Hz servos, which the linearisation holds at their
    command).  A one-bit pulse of the asked surface, read at the end of each bit, matches (a).
    What is left between the two is the simulator's own integration at its step (JSBSim
    integrates the body rates and attitude with forward Euler): first order in dt, a few
    per cent on the GTM's 6.7 rad/s short period at 100 Hz (docs/truth.md).

Writing them beside a run, with the probing output they predict, is
:func:`probing.experiment.studies.truth.compute_truth`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from probing.core.prbs import steps_per_bit
from probing.sim.control import autopilot_for, control_power
from probing.sim.flight import Flight
from probing.sim.linear import linear_response
from probing.sim.plant import make_plant
from probing.sim.world import JSBSimWorld

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
    pulse = np.zeros(n_steps)
    pulse[:steps_per_bit] = amplitude_deg
    # with an autopilot both fly it; the pulse enters between it and the surface
    for plant, probe, out in ((pulsed, pulse, out_p), (reference, None, out_r)):
        world = JSBSimWorld(plant, flight.surface)
        autopilot = autopilot_for(world, flight.control, power) if power is not None else None
        world.fly_probe(autopilot, probe, plant.channel_nodes(list(channels)), out)
        plant.check_state()
    h = (out_p - out_r)[steps_per_bit - 1 :: steps_per_bit] / amplitude_deg
    return {c: h[:, j] for j, c in enumerate(channels)}


def linear_pulse_response(
    flight: Flight, channels: Sequence[str], bit_duration_s: float, n_bits: int
) -> dict[str, np.ndarray]:
    """Pulse response of JSBSim's linearisation stepped as JSBSim steps the aircraft (module
    docstring, (b)), per unit of the probed surface's asked position (``flight.surface``).

    Parameters
    ----------
    flight : Flight
        Aircraft and trim condition.
    channels : sequence of str
        Output channels; those without a linearised output
        (:data:`probing.sim.channels.CHANNELS`) are left out.
    bit_duration_s : float
        Bit duration t0, s (a whole number of simulation steps).
    n_bits : int
        Length of the response, in bits.

    Returns
    -------
    dict
        Channel -> h, shape (n_bits,), in the channel's unit per deg, read at the end of each
        bit as (a) is; empty for a closed-loop flight (the linearisation is the open-loop
        aircraft's).
    """
    if flight.closed_loop:
        return {}
    spb = steps_per_bit(bit_duration_s, flight.dt_s)
    lin = linear_response(make_plant(flight), channels, flight.surface, full=True)
    asked = np.zeros(n_bits * spb)
    asked[:spb] = 1.0
    h = lin.respond(asked)[spb - 1 :: spb]
    return {c: h[:, j] for j, c in enumerate(lin.channels)}
