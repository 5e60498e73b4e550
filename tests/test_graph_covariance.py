"""The graph's marginal covariances: GTSAM's Pose3 tangent to NED position and body-axes attitude (against
sampled retractions), the marginal levels (estimates unchanged, cost only), and the consistency of the position
and heading covariances with simulated truth (NEES over seeded Monte-Carlo runs inside the chi-square band)."""
from __future__ import annotations

import gtsam
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from graphnav.core.errors import ConfigError
from graphnav.core.rotations import (
    C_b_n_to_euler,
    attitude_error,
    euler_covariance,
    euler_jacobian,
    heading_variance,
    yaw_jacobian,
)
from graphnav.estimators.graph import GraphOptions, InitialState
from graphnav.estimators.graph.marginals import keyframe_marginals, pose_covariances
from graphnav.estimators.replay import first_ping_time
from graphnav.estimators.options import PriorOptions
from graphnav.estimators.runs import run_graph
from graphnav.sim.simulate import default_config, simulate_mission


def _random_covariance(rng, n, scale):
    A = rng.normal(size=(n, n))
    return A @ A.T * scale


def test_pose_marginal_to_ned_against_sampled_retractions():
    rng = np.random.default_rng(0)
    pose = gtsam.Pose3(gtsam.Rot3(Rotation.random(random_state=1).as_matrix()), np.array([120.0, -45.0, 18.0]))
    S = _random_covariance(rng, 6, 1e-4)
    xi = rng.multivariate_normal(np.zeros(6), S, 40000)
    moved = [pose.retract(x) for x in xi]
    dp_n = np.array([m.translation() for m in moved]) - pose.translation()
    dtheta = np.array([gtsam.Rot3.Logmap(pose.rotation().between(m.rotation())) for m in moved])
    cov_rot_b, cov_p_n = pose_covariances(pose, S)
    # 40000 samples: the sample covariance is within ~1.5 % (+ the second-order terms, far smaller here)
    np.testing.assert_allclose(np.cov(dp_n.T), cov_p_n, atol=0.03 * np.abs(cov_p_n).max())
    np.testing.assert_allclose(np.cov(dtheta.T), cov_rot_b, atol=0.03 * np.abs(cov_rot_b).max())
    # the rotation block is the attitude error graphnav scores: attitude_error(C_est, C_true) = Log(C_true^T C_est)
    errors = attitude_error(np.array([m.rotation().matrix() for m in moved[:2000]]), pose.rotation().matrix())
    np.testing.assert_allclose(errors, dtheta[:2000], atol=1e-12)


def test_keyframe_marginals_levels():
    rng = np.random.default_rng(1)
    pose = gtsam.Pose3(gtsam.Rot3.Ypr(0.3, 0.1, -0.2), np.array([1.0, 2.0, 3.0]))
    blocks = {gtsam.symbol("x", 4): _random_covariance(rng, 6, 1.0), gtsam.symbol("v", 4): _random_covariance(rng, 3, 1.0),
              gtsam.symbol("b", 4): _random_covariance(rng, 6, 1.0)}
    assert keyframe_marginals("none", 4, pose, blocks.__getitem__) == {}
    assert set(keyframe_marginals("velocity", 4, pose, blocks.__getitem__)) == {"cov_v_n"}
    full = keyframe_marginals("full", 4, pose, blocks.__getitem__)
    R = pose.rotation().matrix()
    np.testing.assert_allclose(full["cov_p_n"], R @ blocks[gtsam.symbol("x", 4)][3:, 3:] @ R.T, atol=1e-12)
    np.testing.assert_allclose(full["cov_rot_b"], blocks[gtsam.symbol("x", 4)][:3, :3], atol=1e-12)
    np.testing.assert_allclose(full["cov_bias"], blocks[gtsam.symbol("b", 4)], atol=1e-12)


def test_euler_jacobian_against_numerical_differences():
    rng = np.random.default_rng(2)
    C = Rotation.from_euler("ZYX", rng.uniform([-3, -1.2, -3], [3, 1.2, 3], (20, 3))).as_matrix()
    J = euler_jacobian(C)
    eps = 1e-6
    for i in range(3):
        d = np.zeros(3)
        d[i] = eps
        step = Rotation.from_rotvec(d).as_matrix()
        diff = C_b_n_to_euler(C @ step) - C_b_n_to_euler(C @ step.T)
        diff = (diff + np.pi) % (2 * np.pi) - np.pi
        np.testing.assert_allclose(diff / (2 * eps), J[:, :, i], atol=1e-6)
    np.testing.assert_allclose(J[:, 2], yaw_jacobian(C), atol=1e-12)
    P = np.array([_random_covariance(rng, 3, 1e-5) for _ in C])
    np.testing.assert_allclose(euler_covariance(C, P)[:, 2, 2], heading_variance(C, P), rtol=1e-10)


def test_marginals_option_values():
    assert GraphOptions(marginals=True).marginals == "velocity"
    assert GraphOptions(marginals=False).marginals == "none"
    assert GraphOptions().marginals == "full"
    with pytest.raises(ConfigError, match="marginals"):
        GraphOptions(marginals="pose")


@pytest.fixture(scope="module")
def short_mission():
    return simulate_mission(40, imu_grade="tactical", seed=4)


@pytest.mark.parametrize("backend", ["fixed-lag", "isam2"])
def test_marginal_levels_leave_the_estimates_bit_equal(short_mission, backend):
    sols = {level: run_graph(short_mission, backend=backend, options=GraphOptions(marginals=level))
            for level in ("none", "velocity", "full")}
    for level, sol in sols.items():
        assert np.array_equal(sol.p_n, sols["none"].p_n) and np.array_equal(sol.v_n, sols["none"].v_n)
        assert np.array_equal(sol.C_b_n, sols["none"].C_b_n)
    assert sols["none"].cov_v_n is None and sols["velocity"].cov_p_n is None
    full = sols["full"]
    np.testing.assert_array_equal(full.cov_v_n, sols["velocity"].cov_v_n)
    K = len(full.t)
    assert full.cov_p_n.shape == (K, 3, 3) and full.cov_rot_b.shape == (K, 3, 3) and full.cov_bias.shape == (K, 6, 6)
    for cov in (full.cov_p_n, full.cov_rot_b, full.cov_bias):
        np.testing.assert_array_equal(cov, np.swapaxes(cov, 1, 2))
        assert np.all(np.linalg.eigvalsh(cov) > 0)
    # the first keyframe carries its prior: position sigma priors.position_sigma, attitude priors.attitude_sigma
    o = GraphOptions()
    np.testing.assert_allclose(np.sqrt(np.diagonal(full.cov_p_n[0])[:2]), o.priors.position_sigma, rtol=0.02)
    np.testing.assert_allclose(np.sqrt(full.cov_rot_b[0, 2, 2]), o.priors.attitude_sigma_for("graph"), rtol=0.05)
    # horizontal position is not observed: its sigma grows over the run
    assert np.all(np.diff(full.cov_p_n[:, 0, 0] + full.cov_p_n[:, 1, 1]) > -1e-9)


def test_position_covariance_continues_across_a_reanchor(short_mission):
    """The fixed-lag smoother's restarts (reanchor_interval_s) carry the joint marginal of the last state as a
    prior: the position and attitude covariances go on as without a restart."""
    a = run_graph(short_mission, backend="fixed-lag", options=GraphOptions(reanchor_interval_s=None))
    b = run_graph(short_mission, backend="fixed-lag", options=GraphOptions(reanchor_interval_s=10.0))
    assert b.info["reanchored"] >= 3
    for name in ("cov_p_n", "cov_rot_b"):
        restarted, reference = getattr(b, name), getattr(a, name)
        sigma = np.sqrt(np.diagonal(reference, axis1=1, axis2=2))
        np.testing.assert_allclose(np.sqrt(np.diagonal(restarted, axis1=1, axis2=2)), sigma, rtol=0.02)
        # correlations (what a restart from block priors would lose) within 0.01
        np.testing.assert_allclose(restarted / np.einsum("ki,kj->kij", sigma, sigma),
                                   reference / np.einsum("ki,kj->kij", sigma, sigma), atol=0.01)


def test_batch_marginal_levels(short_mission):
    full = run_graph(short_mission, backend="fixed-lag", batch=True, options=GraphOptions(marginals="full"))
    velocity = run_graph(short_mission, backend="fixed-lag", batch=True, options=GraphOptions(marginals="velocity"))
    assert np.array_equal(full.p_n, velocity.p_n) and np.array_equal(full.v_n, velocity.v_n)
    np.testing.assert_allclose(full.cov_v_n, velocity.cov_v_n, rtol=1e-9, atol=1e-15)
    assert velocity.cov_p_n is None and full.cov_p_n.shape == (len(full.t), 3, 3)
    # smoothed: the middle of the run knows the future, so its velocity is no less certain than the filter's
    filtered = run_graph(short_mission, backend="fixed-lag", options=GraphOptions(marginals="full"))
    k = len(full.t) // 2
    assert np.trace(full.cov_v_n[k]) <= np.trace(filtered.cov_v_n[k]) * (1 + 1e-6)
    assert full.info["batch_marginals_s"] > 0
    # QR elimination's marginals (taken from R) are Cholesky's
    qr = run_graph(short_mission, backend="fixed-lag", batch=True, options=GraphOptions(batch_factorization="QR"))
    for name in ("cov_v_n", "cov_p_n", "cov_rot_b", "cov_bias"):
        np.testing.assert_allclose(getattr(qr, name), getattr(full, name), rtol=1e-5,
                                   atol=1e-9 * np.abs(getattr(full, name)).max())


# --- consistency against simulated truth -------------------------------------------------------------------
#: The DVL error states' prior sigmas (scale, beam bias m/s): the Monte-Carlo draws the simulated DVL's errors
#: from them, as it draws the initial state from the graph's prior (GraphOptions.prior_*), so that every error
#: the graph is told about is random with the spread it is told.
DVL_SCALE_SIGMA, DVL_BIAS_SIGMA = 0.007, 0.01


def monte_carlo_nees(seeds, duration_s: float):
    """End-of-run horizontal position NEES (2 dof) and heading NEES (1 dof) per seed, for the fixed-lag
    filter's last estimate and the batch smoother's (one run each: the batch runs after a fixed-lag pass
    whose filtered estimates the callback keeps). Each seed draws the initial pose and velocity error from the
    graph's prior and the DVL scale and beam biases from :data:`DVL_SCALE_SIGMA`, :data:`DVL_BIAS_SIGMA`; the IMU
    biases come from the IMU grade's spec as the graph's bias prior."""
    options = GraphOptions(priors=PriorOptions(dvl_scale_sigma=DVL_SCALE_SIGMA, dvl_bias_sigma=DVL_BIAS_SIGMA))
    out = {"fixed-lag": [], "batch": []}
    for seed in seeds:
        rng = np.random.default_rng(1000 + seed)
        config = default_config()
        config.dvl.scale_factor = rng.normal(0.0, DVL_SCALE_SIGMA, 3)
        config.dvl.beam_bias = rng.normal(0.0, DVL_BIAS_SIGMA, 4)
        mission = simulate_mission(duration_s, imu_grade="tactical", seed=seed, config=config)
        initial = InitialState.from_ground_truth(mission, first_ping_time(mission))
        initial.pose = initial.pose.retract(np.r_[rng.normal(0.0, options.priors.attitude_sigma_for("graph"), 3),
                                                  rng.normal(0.0, options.priors.position_sigma, 3)])
        initial.v_n = initial.v_n + rng.normal(0.0, options.priors.velocity_sigma, 3)
        filtered = []
        sol = run_graph(mission, backend="fixed-lag", batch=True, options=options, initial=initial,
                        callback=filtered.append)
        last = filtered[-1]
        for name, (t, p_n, C, cov_p, cov_rot) in {
                "fixed-lag": (last.t, last.p_n, last.C_b_n, last.cov_p_n, last.cov_rot_b),
                "batch": (sol.t[-1], sol.p_n[-1], sol.C_b_n[-1], sol.cov_p_n[-1], sol.cov_rot_b[-1])}.items():
            p_true, _, C_true = mission.gt.at(np.array([t]), mission.imu)
            e = (p_n - p_true[0])[:2]
            d_yaw = yaw_jacobian(C) @ attitude_error(C, C_true[0])
            out[name].append((e @ np.linalg.solve(cov_p[:2, :2], e), d_yaw ** 2 / heading_variance(C, cov_rot)))
    return {name: np.array(v) for name, v in out.items()}


def assert_inside_chi2_band(nees: dict, n: int, p: float = 0.99):
    """Mean NEES over n runs inside the two-sided band of probability p: n * mean ~ chi2(n * dof)."""
    for name, values in nees.items():
        for column, dof, what in ((0, 2, "horizontal position"), (1, 1, "heading")):
            lo, hi = chi2.ppf([(1 - p) / 2, (1 + p) / 2], n * dof) / n
            mean = values[:, column].mean()
            assert lo <= mean <= hi, f"{name} {what} NEES {mean:.2f} outside [{lo:.2f}, {hi:.2f}]"


@pytest.mark.slow
def test_position_and_heading_covariance_consistent_over_seeds():
    seeds = range(24)
    assert_inside_chi2_band(monte_carlo_nees(seeds, 90.0), len(seeds))


def test_position_and_heading_covariance_consistent_fast():
    seeds = range(100, 106)
    assert_inside_chi2_band(monte_carlo_nees(seeds, 50.0), len(seeds))
