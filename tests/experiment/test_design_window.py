"""``probing design --window-periods`` without flying: the amplitude chosen among the flights
(:func:`smallest_amplitude`, with made-up per-period scatters) and the per-period gain
scatter of realisations (:func:`period_gain_std`, with made-up residuals)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from probing.core.monitor import window_matrix
from probing.experiment.design.design_window import (
    period_covariance,
    period_gain_std,
    smallest_amplitude,
    window_stderr,
)
from probing.experiment.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[2]
W, B = 4, 8


@pytest.fixture(scope="module")
def scn() -> Scenario:
    """A short probe (order 5, M = 31) on the Fig. 4 baseline: 8 periods, 2 settling."""
    base = load_scenario(ROOT / "scenarios" / "fig4-737" / "baseline.toml")
    return base.replace({"probe.order": 5, "probe.amplitude_deg": 1.0})


def _design(scn: Scenario, ratios: dict[float, float]) -> tuple[float, list[float]]:
    """Run the search where a flight at amplitude a has a window gain se of
    ``ratios[a]`` times the goal; the amplitude found and those flown, deg."""
    goal = window_stderr(1.0, W, B)

    def build(amplitude_deg: float) -> Scenario:
        return scn.replace({"probe.amplitude_deg": amplitude_deg})

    def sigma_of(design: Scenario) -> float:
        return ratios[round(design.amplitude_deg, 9)]  # se / goal, as goal = se(sigma 1)

    found = smallest_amplitude(scn, build, sigma_of, goal, (W, B), (10.0, "travel"))
    return found.amplitude_deg, [a for a, _ in found.flights]


def test_when_the_last_flight_misses_the_smallest_amplitude_that_met_the_goal_is_taken(
    scn: Scenario,
) -> None:
    """1 deg gives half the goal's se (met, but far under it: scaled to 0.5 deg), 0.5 deg
    0.8 of it (met, still 20 % under: scaled to 0.4 deg), 0.4 deg 1.3 of it (missed, the
    last flight): of the two that met, the smaller amplitude, 0.5 deg, not 1 deg."""
    found, flown = _design(scn, {1.0: 0.5, 0.5: 0.8, 0.4: 1.3})
    assert flown == [1.0, 0.5, 0.4]
    assert found == 0.5


def test_a_last_flight_that_met_the_goal_is_taken(scn: Scenario) -> None:
    """The check at the amplitude found meets the goal within the tolerance: that one."""
    found, flown = _design(scn, {1.0: 0.5, 0.5: 1.05})
    assert (found, flown) == (0.5, [1.0, 0.5])


@pytest.mark.parametrize(("estimator", "unsettled"), [("cyclic", 2), ("streaming", 1)])
def test_the_per_period_gain_scatter_is_that_of_the_settled_periods_alone(
    scn: Scenario, estimator: str, unsettled: int
) -> None:
    """Realisations 1000 times larger in the periods no settled estimate reads (the two
    settling periods; with the streaming estimator, which reads the period before, the
    first) leave the per-period gain scatter as it was; doubling the settled periods' does not."""
    design = scn.replace({"output.estimator": estimator})
    m = design.bits_per_period
    x = 1e-4 * np.random.default_rng(1).standard_normal((20, design.periods * m))
    h_ref = 1e-3 * np.sin(np.arange(m) / 3.0)
    loud_start, loud_settled = x.copy(), x.copy()
    loud_start[:, : unsettled * m] *= 1e3
    loud_settled[:, design.settle_periods * m :] *= 2.0
    base = period_gain_std(design, {"theta_rad": x}, h_ref, "theta_rad")
    assert base > 0
    assert period_gain_std(design, {"theta_rad": loud_start}, h_ref, "theta_rad") == (
        pytest.approx(base, rel=1e-12)
    )
    assert period_gain_std(design, {"theta_rad": loud_settled}, h_ref, "theta_rad") > 1.5 * base


def test_a_detection_target_scales_by_its_own_factor(scn: Scenario) -> None:
    """With ``factor_of`` the search scales by the detection's factor, not the gain se's:
    1 deg needs 0.8 of itself (0.8 deg), where the factor is 1.05 (met within 10 %)."""
    factors = {1.0: 0.8, 0.8: 1.05}

    def build(amplitude_deg: float) -> Scenario:
        return scn.replace({"probe.amplitude_deg": amplitude_deg})

    found = smallest_amplitude(
        scn,
        build,
        lambda design: 1.0,  # se / goal 1 throughout: only the factor moves the amplitude
        window_stderr(1.0, W, B),
        (W, B),
        (10.0, "travel"),
        lambda design, sigma: factors[round(design.amplitude_deg, 9)],
    )
    assert [a for a, _ in found.flights] == [1.0, 0.8]
    assert found.amplitude_deg == 0.8 and found.factor == 1.05


def test_the_periods_covariance_is_each_projections_variance(scn: Scenario) -> None:
    """Any combination a of the reduced estimate's windows scatters by a' C a: the
    covariance built from pairs is the one the realisations give every direction."""
    m = scn.bits_per_period
    x = 1e-4 * np.random.default_rng(2).standard_normal((20, scn.periods * m))
    x[:, 1:] += 0.7 * x[:, :-1]  # correlated samples: off-diagonal terms
    reduce = window_matrix(m, 4)
    cov = period_covariance(scn, {"theta_rad": x}, "theta_rad", reduce)
    assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > 0)
    assert np.abs(cov - np.diag(np.diag(cov))).max() > 0.01 * np.diag(cov).max()
    a = np.array([1.0, -2.0, 0.5, 3.0])
    h_ref = a @ reduce  # the gain along a @ reduce: its variance a' C a / |a @ reduce|^4
    std = period_gain_std(scn, {"theta_rad": x}, h_ref, "theta_rad")
    assert std**2 == pytest.approx(a @ cov @ a / float(h_ref @ h_ref) ** 2, rel=1e-9)
