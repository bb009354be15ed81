"""The gust an aircraft flies through, estimated from what it measures (air data and INS).

A real aircraft does not know its gusts, but it measures two velocities that differ by
them: the INS gives its velocity over the ground (north, east, down), the air data its
velocity through the air (true airspeed and the alpha and beta vanes, in body axes, turned
to north-east-down with the INS's Euler angles).  Their difference is the wind:

    w_NED = v_INS - C_bn(phi, theta, psi) * vt * (cos a cos b, sin b, sin a cos b)

One vane sees the air at one point; the air's *rotation* (the gust's gradients across the
aircraft, which the aerodynamics feel as body rates) it cannot see.  Two of them follow
from the estimated wind under Taylor's frozen-turbulence hypothesis, with the relations of
the MIL-F-8785C / MIL-HDBK-1797 Dryden model (Yeager 1998, eqs. 34 and 35, as JSBSim's
``ttMilspec`` turbulence implements them):

    q_g[k] = (1 - T V / tau_q') q_g[k-1] + pi / (4 b) (w_g[k] - w_g[k-1]),  tau_q' = 4 b / pi
    r_g[k] = (1 - T V / tau_r') r_g[k-1] + pi / (3 b) (v_g[k] - v_g[k-1]),  tau_r' = 3 b / pi

(w_g down, v_g across the aircraft's heading, b the wing span, V the true airspeed, T the
step).  The roll gust p_g is an independent process in that model (the span-wise gradient
of the vertical gust): nothing here estimates it; the gust twin infers it from the measured
roll rate instead (:data:`probing.sim.aircraft.ROLL_OBSERVER_GAIN_PER_S`), along the
turbulence's north axis as JSBSim orients it, so that a heading a few degrees off north
or the aircraft's pitch attitude turn part of it into pitch and yaw.

Assumptions, named: the vanes and the INS measure at the centre of gravity (no upwash, no
lever arm); the air data and the INS are sampled together; the gust field is frozen as the
aircraft crosses it; the pitch and yaw gusts are oriented by the aircraft's heading (JSBSim
orients its by the mean wind's azimuth, 0 in calm mean wind: the two agree for a flight
heading north, as the study's does; orienting them north instead changed the study's
per-period scatter by 0.3 %), the roll gust by north.  numpy only.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

__all__ = [
    "GUST_REFERENCE_SENSORS",
    "GUST_SENSORS",
    "GustEstimator",
    "HighPass",
    "LowPass",
    "body_to_ned",
    "ned_to_body",
    "wind_ned_fps",
]

#: The measured channels the estimate needs, in the order :func:`wind_ned_fps` takes them.
GUST_SENSORS = (
    "vt_fps",
    "alpha_rad",
    "beta_rad",
    "phi_rad",
    "theta_rad",
    "psi_rad",
    "v_north_fps",
    "v_east_fps",
    "v_down_fps",
)

#: What a gust reference reads from the recorded stream: the estimate's sensors, and the
#: roll rate and altitude its twin's observers follow (``probing.experiment.flight.onboard``).
GUST_REFERENCE_SENSORS = (*GUST_SENSORS, "p_rad_s", "h_ft")


def _direction_cosines(phi: np.ndarray, theta: np.ndarray, psi: np.ndarray) -> tuple:
    """The body-to-north-east-down matrix of the Euler angles (rad), entry by entry: rows
    north, east, down; columns body x, y, z (its transpose turns NED to body)."""
    cph, sph, cth, sth, cps, sps = (
        np.cos(phi),
        np.sin(phi),
        np.cos(theta),
        np.sin(theta),
        np.cos(psi),
        np.sin(psi),
    )
    return (
        (cth * cps, sph * sth * cps - cph * sps, cph * sth * cps + sph * sps),
        (cth * sps, sph * sth * sps + cph * cps, cph * sth * sps - sph * cps),
        (-sth, sph * cth, cph * cth),
    )


def body_to_ned(
    phi: np.ndarray, theta: np.ndarray, psi: np.ndarray, body: np.ndarray
) -> np.ndarray:
    """Body-axes vectors ``(n, 3)`` turned to north-east-down by the Euler angles (rad)."""
    c = _direction_cosines(phi, theta, psi)
    x, y, z = body[:, 0], body[:, 1], body[:, 2]
    return np.stack([row[0] * x + row[1] * y + row[2] * z for row in c], axis=1)


def ned_to_body(phi: np.ndarray, theta: np.ndarray, psi: np.ndarray, ned: np.ndarray) -> np.ndarray:
    """North-east-down vectors ``(n, 3)`` turned to body axes (the transpose of
    :func:`body_to_ned`'s matrix)."""
    c = _direction_cosines(phi, theta, psi)
    n, e, d = ned[:, 0], ned[:, 1], ned[:, 2]
    return np.stack([c[0][j] * n + c[1][j] * e + c[2][j] * d for j in range(3)], axis=1)


def wind_ned_fps(measured: Mapping[str, np.ndarray]) -> np.ndarray:
    """The wind (steady and gust) from air data and INS, north-east-down, ft/s, ``(n, 3)``.

    Parameters
    ----------
    measured : mapping
        The channels of :data:`GUST_SENSORS` (ft/s, rad), each shape ``(n,)``.

    Examples
    --------
    Flying north level at 100 ft/s over the ground through a 10 ft/s head wind, the air
    data read 110 ft/s:

    >>> z = np.zeros(1)
    >>> m = dict(vt_fps=np.array([110.0]), alpha_rad=z, beta_rad=z, phi_rad=z, theta_rad=z,
    ...          psi_rad=z, v_north_fps=np.array([100.0]), v_east_fps=z, v_down_fps=z)
    >>> wind_ned_fps(m).round(12).tolist()
    [[-10.0, 0.0, 0.0]]
    """
    vt, alpha, beta = (np.asarray(measured[c], dtype=float) for c in GUST_SENSORS[:3])
    air_body = np.stack(
        [vt * np.cos(alpha) * np.cos(beta), vt * np.sin(beta), vt * np.sin(alpha) * np.cos(beta)],
        axis=1,
    )
    phi, theta, psi = (np.asarray(measured[c], dtype=float) for c in GUST_SENSORS[3:6])
    ground = np.stack([np.asarray(measured[c], dtype=float) for c in GUST_SENSORS[6:]], axis=1)
    return ground - body_to_ned(phi, theta, psi, air_body)


class GustEstimator:
    """The wind and the rotational gusts (:mod:`probing.core.gust`) from a measured stream,
    chunk by chunk: the filters' state carries over, so chunks give what the whole does.

    Parameters
    ----------
    span_ft : float
        Wing span b, ft.
    dt_s : float
        Sample interval T, s.
    """

    def __init__(self, span_ft: float, dt_s: float, steady_time_s: float = 0.0) -> None:
        if not (math.isfinite(span_ft) and span_ft > 0):
            raise ValueError(f"the wing span must be > 0 ft, got {span_ft!r}")
        if not (math.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s must be > 0, got {dt_s!r}")
        self.span_ft, self.dt_s = float(span_ft), float(dt_s)
        self.steady_time_s = float(steady_time_s)
        self._last: tuple[float, float] | None = None  # the previous (w_g, v_g), ft/s
        self._q = self._r = 0.0  # the filters' outputs, rad/s
        #: the steady wind removed (with ``steady_time_s``), None: the whole wind is flown
        self._steady = HighPass(steady_time_s, dt_s) if steady_time_s else None

    def update(self, measured: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """The next chunk's wind ``(n, 3)`` (NED, ft/s) and rotational gust ``(n, 3)`` (body
        p, q, r, rad/s; p is 0: not estimated).  The first sample of the stream starts the
        gradient filters at rest.  With ``steady_time_s`` the wind is the gust only: the
        estimate minus its first-order low-pass of that time constant (started at the first
        sample), which holds the steady wind and the sensors' biases alike."""
        wind = wind_ned_fps(measured)
        if self._steady is not None:
            wind = self._steady.update(wind)
        psi = np.asarray(measured["psi_rad"], dtype=float)
        vt = np.asarray(measured["vt_fps"], dtype=float)
        across = -np.sin(psi) * wind[:, 0] + np.cos(psi) * wind[:, 1]  # v_g, ft/s
        down = wind[:, 2]  # w_g, ft/s
        n = down.size
        q_g, r_g = np.empty(n), np.empty(n)
        b, t = self.span_ft, self.dt_s
        kq, kr = math.pi / (4.0 * b), math.pi / (3.0 * b)
        q, r = self._q, self._r
        last = self._last
        for k, (w, v, speed) in enumerate(
            zip(down.tolist(), across.tolist(), vt.tolist(), strict=True)
        ):
            if last is None:
                last = (w, v)
            q = (1.0 - t * speed * kq) * q + kq * (w - last[0])
            r = (1.0 - t * speed * kr) * r + kr * (v - last[1])
            q_g[k], r_g[k] = q, r
            last = (w, v)
        self._q, self._r, self._last = q, r, last
        axis_q = np.stack([-np.sin(psi) * q_g, np.cos(psi) * q_g, r_g], axis=1)  # NED
        phi, theta = (np.asarray(measured[c], dtype=float) for c in ("phi_rad", "theta_rad"))
        rates = ned_to_body(phi, theta, psi, axis_q)
        return wind, rates


class LowPass:
    """A first-order low-pass of time constant ``time_s``, forward Euler at the sample
    interval (y_k = y_(k-1) + dt / time_s (x_k - y_(k-1))), started at rest at the first
    sample; chunk by chunk, its state carries over.

    Parameters
    ----------
    time_s : float
        The time constant, s (>= ``dt_s``).
    dt_s : float
        Sample interval, s.
    """

    def __init__(self, time_s: float, dt_s: float) -> None:
        if not (math.isfinite(time_s) and math.isfinite(dt_s) and 0 < dt_s <= time_s):
            raise ValueError(f"need 0 < dt_s <= time_s, got dt_s={dt_s!r}, time_s={time_s!r}")
        self.k = dt_s / time_s
        self._steady: np.ndarray | None = None

    def update(self, x: np.ndarray) -> np.ndarray:
        """The next rows ``(n, k)`` (or samples ``(n,)``), low-passed."""
        x = np.asarray(x, dtype=float)
        flat = x.reshape(x.shape[0], -1)
        if not len(flat):
            return x
        steady = flat[0].copy() if self._steady is None else self._steady
        out = np.empty_like(flat)
        k = self.k
        # Column by column on Python floats: the recursion cannot be vectorised without
        # changing its rounding (scipy's lfilter sums its terms in another order), and a
        # float loop costs a tenth of numpy's per-row operations on short rows.
        for j, (column, y) in enumerate(zip(flat.T.tolist(), steady.tolist(), strict=True)):
            ys = out[:, j]
            for i, value in enumerate(column):
                y = y + k * (value - y)
                ys[i] = y
        self._steady = out[-1].copy()
        return out.reshape(x.shape)


class HighPass:
    """A signal minus its first-order low-pass of time constant ``time_s`` (:class:`LowPass`,
    started at the first sample): what varies faster than that, with any steady offset (a
    bias) removed.

    Parameters
    ----------
    time_s : float
        The low-pass's time constant, s (>= ``dt_s``).
    dt_s : float
        Sample interval, s.
    """

    def __init__(self, time_s: float, dt_s: float) -> None:
        self.low = LowPass(time_s, dt_s)

    def update(self, x: np.ndarray) -> np.ndarray:
        """The next rows ``(n, k)`` (or samples ``(n,)``), high-passed; the state carries over."""
        x = np.asarray(x, dtype=float)
        return x - self.low.update(x)
