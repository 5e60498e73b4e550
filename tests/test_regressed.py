"""Screening of regressed beams against the graph's prediction, and the motion prior's factors."""
from __future__ import annotations

import numpy as np
import pytest

from graphnav.core.errors import ConfigError
from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.options import RegressedScreeningOptions
from graphnav.estimators.graph.regressed import (
    VelocityPrediction,
    OutagePriorSwitch,
    body_velocity_std,
    motion_prior_factors,
    screen_regressed,
)

ROWS = np.array([[0.5, 0.5, 0.7071], [-0.5, 0.5, 0.7071]])
C = np.eye(3)
V_TRUE = np.array([1.5, 0.2, 0.05])


def screen(y, sigma, cov, **opts):
    pred = VelocityPrediction(V_TRUE, cov, np.zeros(3))
    return screen_regressed(ROWS, np.asarray(y), np.asarray(sigma), C, np.zeros(3), np.zeros(3), pred,
                            GraphOptions(screening=RegressedScreeningOptions(**opts)))


def test_plain_options_pass_beams_through():
    y = ROWS @ V_TRUE + [0.5, -0.5]
    keep, sigma, stats = screen(y, [0.05, 0.05], np.eye(3) * 1e-4)
    assert keep.all() and np.allclose(sigma, 0.05) and not any(stats.values())
    keep, sigma, _ = screen_regressed(ROWS, y, np.array([0.05, 0.05]), C, np.zeros(3), np.zeros(3), None,
                                      GraphOptions(screening=RegressedScreeningOptions(gate_k=3.0, adaptive=True)))
    assert keep.all() and np.allclose(sigma, 0.05)     # nothing to compare with on the first keyframe


def test_gate_and_adaptive_sigma_use_the_joint_covariance():
    y = ROWS @ V_TRUE + [0.02, 0.5]                    # second beam 0.5 m/s off the prediction
    cov = np.eye(3) * 0.01 ** 2
    keep, _, stats = screen(y, [0.05, 0.05], cov, gate_k=3.0)
    assert keep.tolist() == [True, False] and stats["gated"] == 1
    # a wide prediction (0.3 m/s) makes the same completion plausible
    keep, _, _ = screen(y, [0.05, 0.05], np.eye(3) * 0.3 ** 2, gate_k=3.0)
    assert keep.all()
    keep, sigma, stats = screen(y, [0.05, 0.05], cov, adaptive=True)
    a = 0.01 ** 2   # unit rows: b^T P b = 1e-4
    assert keep.all() and sigma[0] == pytest.approx(0.05)
    assert sigma[1] == pytest.approx(np.sqrt(0.5 ** 2 - a)) and stats["inflated"] == 1


def test_correlation_drops_redundant_completions_and_weakens_the_rest():
    y = ROWS @ V_TRUE
    # sharp prediction (0.01 m/s) vs a 0.05 m/s completion with rho 0.5: c = 0.5*0.01*0.05 > a -> redundant
    keep, _, stats = screen(y, [0.05, 0.05], np.eye(3) * 0.01 ** 2, correlation=0.5)
    assert not keep.any() and stats["decorrelated_out"] == 2
    # wide prediction (0.3 m/s): kept, variance a (s^2 - c) / (a - c) > s^2
    a, s2 = 0.09, 0.05 ** 2
    c = 0.5 * np.sqrt(a * s2)
    keep, sigma, _ = screen(y, [0.05, 0.05], np.eye(3) * a, correlation=0.5)
    assert c > s2    # no equivalent factor: the floor s^2 (1 - rho^2)
    assert keep.all() and sigma[0] == pytest.approx(np.sqrt(s2 * 0.75))
    a = 0.012 ** 2   # 0.012 m/s prediction vs 0.02 m/s completion: c = 0.5*0.012*0.02 < a, kept, weaker
    s2 = 0.02 ** 2
    c = 0.5 * np.sqrt(a * s2)
    keep, sigma, _ = screen(y, [0.02, 0.02], np.eye(3) * a, correlation=0.5)
    assert keep.all() and sigma[0] == pytest.approx(np.sqrt(a * (s2 - c) / (a - c)), rel=1e-3) and sigma[0] > 0.02
    with pytest.raises(ConfigError):
        GraphOptions(screening=RegressedScreeningOptions(correlation=1.0))


def test_completion_variance_scale_weakens_what_the_correlation_rule_keeps():
    """A completer whose errors stay off for many pings carries less than its per-ping sigma says: the variance the
    correlation rule leaves (rho 0.5, as the default) is scaled; which completions are kept does not change."""
    y = ROWS @ V_TRUE
    a = 0.3 ** 2
    keep, sigma, _ = screen(y, [0.05, 0.05], np.eye(3) * a, completion_var_scale=4.0)
    assert keep.all() and np.allclose(sigma, 0.1)
    assert RegressedScreeningOptions(completion_var_scale=4.0).active
    a = 0.012 ** 2
    s2 = 0.02 ** 2
    c = 0.5 * np.sqrt(a * s2)
    keep, sigma, _ = screen(y, [0.02, 0.02], np.eye(3) * a, completion_var_scale=4.0, correlation=0.5)
    assert keep.all() and sigma[0] == pytest.approx(2 * np.sqrt(a * (s2 - c) / (a - c)), rel=1e-3)
    keep, _, stats = screen(y, [0.05, 0.05], np.eye(3) * 0.01 ** 2, completion_var_scale=4.0, correlation=0.5)
    assert not keep.any() and stats["decorrelated_out"] == 2       # redundant with the prediction, as unscaled
    with pytest.raises(ConfigError, match="completion_var_scale must be > 0"):
        RegressedScreeningOptions(completion_var_scale=0.0)


def test_motion_prior_factors_and_modes():
    graph = motion_prior_factors(5, 1.0, GraphOptions())
    assert graph.size() == 2                            # body-velocity random walk + heave
    assert motion_prior_factors(5, 1.0, GraphOptions(motion_prior_heave_sigma=None)).size() == 1
    assert motion_prior_factors(0, 1.0, GraphOptions()).size() == 0
    with pytest.raises(ConfigError, match="motion_prior"):
        GraphOptions(motion_prior="always")


def _prediction(std_n):
    return VelocityPrediction(V_TRUE, np.diag(np.square(std_n)), np.zeros(3))


def test_outage_prior_switch_on_synthetic_covariances():
    switch = OutagePriorSwitch(GraphOptions(motion_prior="total-if-uncertain", motion_prior_switch_std=0.2))
    assert not switch.decide(0, None, C)                          # first keyframe: nothing to compare with
    assert not switch.decide(0, _prediction([0.05, 0.05, 0.01]), C)   # IMU still holds the velocity
    assert not switch.decide(0, _prediction([0.5, 0.05, 0.01]), C)    # surge alone does not decide
    # yawed 90 deg: the NED north uncertainty is the body's sway
    C_yaw = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    assert np.allclose(body_velocity_std(_prediction([0.5, 0.05, 0.01]), C_yaw), [0.05, 0.5, 0.01])
    assert switch.decide(0, _prediction([0.5, 0.05, 0.01]), C_yaw)
    # latched: the prior's own effect shrinks the marginal, the prior stays until a beam is measured
    assert switch.decide(0, _prediction([0.05, 0.05, 0.01]), C)
    assert not switch.decide(1, _prediction([0.5, 0.5, 0.5]), C)
    assert not switch.decide(0, _prediction([0.05, 0.05, 0.01]), C)
    assert switch.decide(0, _prediction([0.01, 0.01, 0.3]), C)       # heave decides too
    assert switch.counts == {"prior": 3, "no_prior": 3, "switched_on": 2, "max_std": pytest.approx(0.5)}
    with pytest.raises(ConfigError, match="motion_prior_switch_std"):
        GraphOptions(motion_prior_switch_std=0.0)


@pytest.mark.parametrize("grade, switched", [("navigation", False), ("mems", True)])
def test_total_if_uncertain_switches_with_the_imu_grade(grade, switched):
    """Simulated 60 s total DVL outage: with a MEMS IMU the graph's predicted velocity std passes the switch
    and the motion prior joins the (screened) completions; with a navigation-grade IMU it stays off."""
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation.methods import GRAPH_HN_OPTIONS, MOTION_PRIOR_SETTINGS, run_method
    from graphnav.sim.simulate import simulate_mission
    mission = simulate_mission(150.0, grade, seed=4)
    run = mission.with_outage(scenario_outage("0-beams", mission.t0 + 70.0, 60.0))
    options = {**GRAPH_HN_OPTIONS, **MOTION_PRIOR_SETTINGS, "motion_prior": "total-if-uncertain",
               "motion_prior_switch_std": 0.2}
    sol = run_method(run, "Graph-HN", "0-beams", options=options)
    counts = sol.info["motion_prior_switch"]
    assert counts["prior"] + counts["no_prior"] >= 55
    assert (counts["switched_on"] == 1) == switched
    assert (counts["prior"] > 0) == switched
