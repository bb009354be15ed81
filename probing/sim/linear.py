"""JSBSim's linearisation of a trimmed aircraft: longitudinal modes, and the linear response
to a surface history (what the probing output should be without noise, and its transient).

``FGLinearization`` suspends JSBSim's time step while it linearises: the servos then sit at
their command, so the linear model is the bare airframe (servo dynamics excluded).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from probing.core.convolution import causal_convolve
from probing.core.fixedorder import dot, eigvals, expm, matrix_power, solve
from probing.sim.channels import CHANNELS
from probing.sim.modes import LongitudinalModes
from probing.sim.plant import Plant
from probing.sim.surfaces import DEFAULT_SURFACE, SURFACES
from probing.sim.world import actuator_pulse_response

__all__ = [
    "LAT_STATES",
    "LONG_STATES",
    "LinearResponse",
    "LongitudinalModes",
    "linear_response",
    "longitudinal_matrix",
    "longitudinal_modes",
    "zoh",
]

#: FGLinearization's names of the longitudinal states.
LONG_STATES = ("Vt", "Alpha", "Theta", "Q")
#: ... and of the lateral-directional ones that do not merely integrate others (heading does).
LAT_STATES = ("Beta", "Phi", "P", "R")


def longitudinal_matrix(plant: Plant) -> np.ndarray:
    """The (Vt, alpha, theta, q) block of JSBSim's linearised state matrix at the trim."""
    lin = plant.linearise()
    names = list(lin["x_names"])
    idx = [names.index(n) for n in LONG_STATES]
    return np.asarray(lin["A"])[np.ix_(idx, idx)]


def longitudinal_modes(plant: Plant) -> LongitudinalModes:
    """Short period and phugoid of a trimmed plant (eigenvalues of :func:`longitudinal_matrix`,
    by :func:`probing.core.fixedorder.eigvals`: the same bits on any processor)."""
    return LongitudinalModes.from_eigenvalues(eigvals(longitudinal_matrix(plant)))


@dataclass(frozen=True)
class LinearResponse:
    """The linearised aircraft at its trim, stepped as JSBSim steps it, per unit of the probed
    surface's position (deg, or normalised throttle).

    Discretised with zero-order hold at the step ``dt_s``.  JSBSim moves the surface in the
    step its command is written but the airframe responds one step later, so the output read
    after step k is ``C x(k) + D u(k-1)`` with ``x(k+1) = A x(k) + B u(k)`` (the one-step delay
    of ``docs/method.md``).  Only channels with a linearised output
    (:data:`probing.sim.channels.CHANNELS`) are covered.

    Attributes
    ----------
    a : numpy.ndarray
        (n, n) state transition over one step.
    b : numpy.ndarray
        (n,) input column, per unit of the surface's position.
    c, d : numpy.ndarray
        (C, n) and (C,) outputs of the channels.
    channels : tuple of str
        The channels, in the order of the rows of ``c``.
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    channels: tuple[str, ...]
    actuator: np.ndarray  # realised surface per deg asked, after each step of a one-step pulse

    def surface(self, u: np.ndarray, periodic: bool = False) -> np.ndarray:
        """The realised surface (deg) for the asked deviation ``u`` (deg), through the
        actuator: from rest, or cyclically for one period of a periodic ``u``."""
        u = np.asarray(u, dtype=float)
        if not periodic:
            return causal_convolve(u, self.actuator)
        fir = np.zeros(u.size)
        np.add.at(fir, np.arange(self.actuator.size) % u.size, self.actuator)
        return np.fft.irfft(np.fft.rfft(u) * np.fft.rfft(fir), u.size)

    def step_response(self, n: int) -> np.ndarray:
        """Output after each of ``n`` steps for a one-step unit pulse of the *realised*
        surface at step 0, (n, C): 0, then ``C B + D``, then ``C A^(k-1) B``.

        The states A^(k-1) B are made by doubling (:func:`_powers_times`), every sum in a
        fixed order: the same bits whatever BLAS kernel the processor gets.
        """
        out = np.zeros((n, len(self.channels)))
        if n < 2:
            return out
        out[1:] = dot(_powers_times(self.a, self.b, n - 1), self.c.T)
        out[1] += self.d
        return out

    def respond(self, u: np.ndarray, pulse: np.ndarray | None = None) -> np.ndarray:
        """Output after each step for the asked surface deviation ``u`` from rest, (N, C).

        ``pulse``: :meth:`step_response` of at least N steps, when the caller has it already.
        """
        u = self.surface(u)
        pulse = self.step_response(u.size) if pulse is None else pulse[: u.size]
        return causal_convolve(u, pulse)

    def periodic(self, u: np.ndarray) -> np.ndarray:
        """Periodic steady-state output for ``u`` (deg, one period of steps) repeated forever,
        over one period, (N, C).

        The cyclic convolution of the realised surface with the step response folded onto
        one period, sum over j of g[k + jN] = C A^(k-1) (I - A^N)^-1 B: the geometric series
        of A^N summed exactly, then one FFT.
        """
        u = self.surface(u, periodic=True)
        n = u.size
        eye = np.eye(self.a.shape[0])
        folded_b = solve(eye - matrix_power(self.a, n), self.b)  # the folded geometric series
        # folded[k] = sum_j g[k + jN]: C A^(k-1) B for k = 1 .. N, where k = N lands on 0
        g = dot(_powers_times(self.a, folded_b, n), self.c.T)  # (N, C): folded g[1 .. N]
        folded = np.roll(g, 1, axis=0)  # folded[0] = g[N] (+ g[2N] + ...), folded[1] = g[1] ...
        folded[1 % n] += self.d  # the feed-through acts once, one step after its input
        spectrum = np.fft.rfft(folded, axis=0) * np.fft.rfft(u)[:, None]
        return np.fft.irfft(spectrum, n, axis=0)


def _powers_times(a: np.ndarray, x: np.ndarray, n: int) -> np.ndarray:
    """Rows A^k x for k = 0 .. n - 1, shape (n, len(x)): by doubling, the block of the first
    2^j rows times (A^(2^j))' giving the next, each product in a fixed order.

    Examples
    --------
    >>> _powers_times(np.array([[2.0, 0.0], [0.0, 3.0]]), np.array([1.0, 1.0]), 3)
    array([[1., 1.],
           [2., 3.],
           [4., 9.]])
    """
    rows = np.asarray(x, dtype=float)[None, :]
    power = np.asarray(a, dtype=float)  # A^(rows so far)
    while rows.shape[0] < n:
        rows = np.concatenate((rows, dot(rows, power.T)))
        if rows.shape[0] < n:
            power = dot(power, power)
    return rows[:n]


def zoh(a: np.ndarray, b: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretisation of dx/dt = A x + B u over one step ``dt_s`` (s).

    The exponential of the block matrix [[A, B], [0, 0]] dt holds both A_d = e^(A dt) and
    B_d = int_0^dt e^(A s) ds B (what :func:`scipy.signal.cont2discrete` computes for
    ``"zoh"``), with :func:`probing.core.fixedorder.expm`: the same bits on any processor.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    n = a.shape[0]
    block = np.zeros((n + b.shape[1], n + b.shape[1]))
    block[:n, :n], block[:n, n:] = a, b
    e = expm(block * dt_s)
    return e[:n, :n], e[:n, n:]


def linear_response(
    plant: Plant,
    channels: Sequence[str],
    surface: str = DEFAULT_SURFACE,
    full: bool = False,
) -> LinearResponse:
    """:class:`LinearResponse` of a trimmed plant to ``surface``: the longitudinal states (Vt,
    alpha, theta, q) for the elevator and throttle, with the lateral-directional ones (beta,
    phi, p, r) added for the aileron and rudder, and the channels among them.

    The realised surface follows the asked one through the model's actuator, measured on the
    plant itself (:func:`~probing.sim.world.actuator_pulse_response`); the plant is
    stepped for that, so use it for nothing else afterwards.  The altitude, heading and
    position states are left out: they integrate the others (the
    full model has an eigenvalue at 1, so no periodic steady state) and feed back only
    through the density gradient.  In straight and level flight of a symmetric aircraft the
    two axes decouple, which is why a longitudinal surface keeps the longitudinal states
    alone (as it always did).  The surface's input (``DeCmd``, ...) is converted to per unit
    of position with the model's own command-to-position slope at the trim.  ``full`` keeps
    the lateral-directional states for a longitudinal surface too, and the altitude (every
    channel with a linearised output is covered, the other axis through the model's
    coupling, and the slow height mode the density gradient gives the phugoid: what a
    response from rest over many periods shows; :meth:`LinearResponse.periodic` wants the
    default).
    """
    spec = SURFACES[surface]
    states = LONG_STATES + LAT_STATES if spec.lateral or full else LONG_STATES
    if full:
        states += ("Alt",)
    lin = plant.linearise()
    gain = plant.drive(surface).gain_per_norm()
    iu = lin["u_names"].index(spec.linear_input)
    covered = tuple(c for c in channels if CHANNELS[c].linear_output in states)
    x = [list(lin["x_names"]).index(n) for n in states]
    rows = [list(lin["y_names"]).index(CHANNELS[c].linear_output) for c in covered]
    a_mat = np.asarray(lin["A"])[np.ix_(x, x)]
    b_mat = np.asarray(lin["B"])[x][:, [iu]] / gain
    c = np.asarray(lin["C"])[np.ix_(rows, x)]
    d = np.asarray(lin["D"])[rows, iu] / gain
    ad, bd = zoh(a_mat, b_mat, plant.dt_s)
    actuator = actuator_pulse_response(plant, surface=surface)  # last: it steps the plant
    return LinearResponse(ad, bd[:, 0], c, d, covered, actuator)
