"""The gust estimate from air data and INS (probing.core.gust) against independent truth:
scipy's rotations for the wind, the MIL-spec recursions written out with scipy.signal for
the rotational gusts."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import lfilter
from scipy.spatial.transform import Rotation

from probing.core.gust import GUST_SENSORS, GustEstimator, wind_ned_fps

N = 400


def _measured(wind: np.ndarray, rng: np.random.Generator, n: int = N) -> dict[str, np.ndarray]:
    """Air data and INS of an aircraft at random attitudes and flow angles in ``wind``:
    the INS velocity is scipy's body->NED rotation of the air velocity plus the wind."""
    phi, theta, psi = rng.uniform(-0.6, 0.6, n), rng.uniform(-0.4, 0.4, n), rng.uniform(-3, 3, n)
    alpha, beta = rng.uniform(-0.2, 0.3, n), rng.uniform(-0.15, 0.15, n)
    vt = rng.uniform(80.0, 300.0, n)
    air = np.stack(
        [vt * np.cos(alpha) * np.cos(beta), vt * np.sin(beta), vt * np.sin(alpha) * np.cos(beta)],
        axis=1,
    )
    b2n = Rotation.from_euler("ZYX", np.stack([psi, theta, phi], axis=1)).as_matrix()
    ground = np.einsum("nij,nj->ni", b2n, air) + wind
    return dict(
        vt_fps=vt,
        alpha_rad=alpha,
        beta_rad=beta,
        phi_rad=phi,
        theta_rad=theta,
        psi_rad=psi,
        v_north_fps=ground[:, 0],
        v_east_fps=ground[:, 1],
        v_down_fps=ground[:, 2],
    )


def test_the_wind_is_the_ins_velocity_minus_the_air_velocity_turned_by_scipy():
    rng = np.random.default_rng(1)
    wind = rng.normal(0.0, 10.0, (N, 3))
    got = wind_ned_fps(_measured(wind, rng))
    np.testing.assert_allclose(got, wind, rtol=0, atol=1e-9)


def test_a_wrong_sign_of_one_flow_angle_is_seen():
    """The check can fail: beta read with the wrong sign gives another wind."""
    rng = np.random.default_rng(2)
    m = _measured(np.zeros((N, 3)), rng)
    m["beta_rad"] = -m["beta_rad"]
    assert np.abs(wind_ned_fps(m)).max() > 1.0


def _level_north(down: np.ndarray, across: np.ndarray, vt: float) -> dict[str, np.ndarray]:
    """Level flight heading north at ``vt`` (alpha = beta = 0) through a gust (down,
    east = across the heading)."""
    n = down.size
    z = np.zeros(n)
    return dict(
        vt_fps=np.full(n, vt),
        alpha_rad=z,
        beta_rad=z,
        phi_rad=z,
        theta_rad=z,
        psi_rad=z,
        v_north_fps=np.full(n, vt),
        v_east_fps=across,
        v_down_fps=down,
    )


def _milspec(x: np.ndarray, tau_factor: float, span_ft: float, vt: float, dt: float) -> np.ndarray:
    """Yeager's eqs. (34)/(35), y[k] = (1 - T V / tau') y[k-1] + (1 / tau')(x[k] - x[k-1]),
    tau' = tau_factor * b / pi, as a scipy filter started at rest on x[0]."""
    k = math.pi / (tau_factor * span_ft)
    a = 1.0 - dt * vt * k
    return lfilter([k, -k], [1.0, -a], x - x[0])


@pytest.mark.parametrize("dt", [0.01, 0.005])
def test_the_rotational_gusts_are_the_milspec_filters_of_the_estimated_wind(dt):
    rng = np.random.default_rng(3)
    span, vt = 6.85, 128.0
    down = np.cumsum(rng.normal(0, 0.3, N))
    across = np.cumsum(rng.normal(0, 0.3, N))
    _, rates = GustEstimator(span, dt).update(_level_north(down, across, vt))
    np.testing.assert_allclose(rates[:, 1], _milspec(down, 4.0, span, vt, dt), atol=1e-12)
    np.testing.assert_allclose(rates[:, 2], _milspec(across, 3.0, span, vt, dt), atol=1e-12)
    assert np.all(rates[:, 0] == 0.0)  # level, heading north: no roll gust is estimated
    assert np.abs(rates[:, 1]).max() > 1e-3  # the gust is not trivially small


def test_chunks_give_what_the_whole_stream_gives():
    rng = np.random.default_rng(4)
    m = _measured(rng.normal(0, 5, (N, 3)), rng)
    whole = GustEstimator(10.0, 0.01).update(m)
    est = GustEstimator(10.0, 0.01)
    parts = [est.update({c: v[s] for c, v in m.items()}) for s in (slice(0, 137), slice(137, N))]
    for j in range(2):
        np.testing.assert_array_equal(np.vstack([p[j] for p in parts]), whole[j])


def test_the_gradients_follow_the_heading():
    """Heading east, a gust from the north is across the aircraft: it rolls the yaw gust;
    a vertical gust still pitches."""
    n = 50
    rng = np.random.default_rng(5)
    gust = np.cumsum(rng.normal(0, 0.5, n))
    z = np.zeros(n)
    east = dict(
        vt_fps=np.full(n, 100.0),
        alpha_rad=z,
        beta_rad=z,
        phi_rad=z,
        theta_rad=z,
        psi_rad=np.full(n, math.pi / 2),
        v_north_fps=gust,  # the wind from north is the only northward motion
        v_east_fps=np.full(n, 100.0),
        v_down_fps=z,
    )
    _, rates = GustEstimator(8.0, 0.01).update(east)
    np.testing.assert_allclose(rates[:, 2], -_milspec(gust, 3.0, 8.0, 100.0, 0.01), atol=1e-12)
    np.testing.assert_allclose(rates[:, 1], 0.0, atol=1e-12)


@pytest.mark.parametrize(
    ("span", "dt", "ok"),
    [
        (0.0, 0.01, False),
        (1e-9, 0.01, True),
        (5.0, 0.0, False),
        (5.0, 1e-9, True),
        (math.nan, 0.01, False),
    ],
)
def test_span_and_step_must_be_positive(span, dt, ok):
    if ok:
        GustEstimator(span, dt)
    else:
        with pytest.raises(ValueError):
            GustEstimator(span, dt)


def test_the_sensor_list_is_what_the_estimate_reads():
    m = _measured(np.zeros((3, 3)), np.random.default_rng(6), n=3)
    assert set(m) == set(GUST_SENSORS)
    for c in GUST_SENSORS:
        broken = {k: v for k, v in m.items() if k != c}
        with pytest.raises(KeyError):
            GustEstimator(5.0, 0.01).update(broken)
