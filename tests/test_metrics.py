"""Metrics: explicit time alignment, VRMSE/VRTE, horizontal position error, velocity NEES."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from graphnav.core.errors import DataError
from graphnav.core.mission import GroundTruth
from graphnav.core.rotations import euler_to_C_b_n
from graphnav.core.solution import NavSolution
from graphnav.evaluation import metrics


def _gt():
    t = np.arange(0.0, 10.01, 1.0)
    p = np.c_[2.0 * t, -t, 0.1 * t ** 2]
    v = np.c_[np.full_like(t, 2.0), np.full_like(t, -1.0), 0.2 * t]
    C = euler_to_C_b_n(np.zeros_like(t), np.zeros_like(t), 0.1 * t)
    return GroundTruth(t, p, v, C)


def _solution(t, gt, dv=np.zeros(3), dp=np.zeros(3), cov=None):
    p, v, C = gt.at(np.clip(t, gt.t[0], gt.t[-1]))
    return NavSolution("test", np.asarray(t, float), p + dp, v + dv, C,
                       None if cov is None else np.tile(cov, (len(t), 1, 1)))


def test_align_interpolates_linearly_and_slerps_and_drops_epochs_outside():
    gt = _gt()
    sol = _solution(np.array([-1.0, 0.5, 2.25, 9.75, 11.0]), gt)
    al = metrics.align(sol, gt)
    assert al.mask.tolist() == [False, True, True, True, False]
    assert np.allclose(al.t, [0.5, 2.25, 9.75])
    assert np.allclose(al.v_true_n[:, 2], 0.2 * al.t)               # linear in velocity is exact here
    assert np.allclose(al.p_true_n[0], [1.0, -0.5, 0.05])           # linear between p(0) and p(1)
    yaw = Rotation.from_matrix(al.C_true_b_n).as_euler("ZYX")[:, 0]
    assert np.allclose(yaw, 0.1 * al.t)                               # slerp of a constant-rate yaw


def test_vrmse_window_and_vrte():
    gt = _gt()
    t = np.arange(0.0, 10.01, 0.5)
    sol = _solution(t, gt, dv=np.array([0.3, 0.4, 0.0]))
    sol.v_n[t > 5.0] += np.array([0.0, 0.0, 1.2])
    assert np.isclose(metrics.vrmse(sol, gt, 0.0, 5.0), 0.5)
    assert np.isclose(metrics.vrmse(sol, gt, 6.0, None), 1.3)
    k_late = np.count_nonzero(t > 5.0)
    assert np.isclose(metrics.vrmse(sol, gt) ** 2, (0.25 * (len(t) - k_late) + 1.69 * k_late) / len(t))
    assert np.isclose(metrics.vrte(0.35, 0.5), 30.0)
    assert np.isclose(metrics.vrte(0.6, 0.5), 20.0)
    with pytest.raises(ValueError):
        metrics.vrte(0.1, 0.0)
    with pytest.raises(DataError):
        metrics.vrmse(sol, gt, 20.0, 30.0)


def test_horizontal_position_error_at_end_and_rmse():
    gt = _gt()
    t = np.arange(0.0, 10.01, 1.0)
    sol = _solution(t, gt)
    sol.p_n[:, :2] += np.c_[0.3 * t, 0.4 * t]          # grows 0.5 m per s, down error ignored
    sol.p_n[:, 2] += 100.0
    assert np.isclose(metrics.horizontal_position_error(sol, gt), 5.0)
    assert np.isclose(metrics.horizontal_position_error(sol, gt, t=4.5), 2.0)   # last epoch <= 4.5 s
    assert np.isclose(metrics.horizontal_position_rmse(sol, gt, 2.0, 2.0), 1.0)
    assert np.isclose(metrics.horizontal_position_rmse(sol, gt), np.sqrt(np.mean((0.5 * t) ** 2)))


def test_nees_velocity_matches_chi_square_statistics():
    gt = _gt()
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 10.0, 20001)
    cov = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.0], [0.0, 0.0, 0.01]])
    sol = _solution(t, gt, cov=cov)
    sol.v_n += rng.multivariate_normal(np.zeros(3), cov, len(t))
    nees = metrics.nees_velocity(sol, gt)
    assert nees.shape == (len(t),)
    assert abs(nees.mean() - 3.0) < 0.1
    assert len(metrics.nees_velocity(sol, gt, 0.0, 1.0)) == np.count_nonzero(t <= 1.0)
    sol.cov_v_n = None
    with pytest.raises(DataError):
        metrics.nees_velocity(sol, gt)


# --- position and heading NEES, drift in % of distance travelled ------------------------------------------
def _line(duration=100.0, dt=1.0, speed=1.5):
    """Straight line north at ``speed`` m/s, level, heading north; GT at 1/dt Hz."""
    t = np.arange(0.0, duration + 1e-9, dt)
    p = np.c_[speed * t, 0 * t, 10.0 + 0 * t]
    v = np.tile([speed, 0.0, 0.0], (len(t), 1))
    return GroundTruth(t, p, v, np.tile(np.eye(3), (len(t), 1, 1)))


def test_position_nees_of_a_known_error_and_covariance():
    gt = _line(10.0)
    t = gt.t.copy()
    sol = _solution(t, gt, dp=np.array([1.0, 2.0, 50.0]))          # the depth error is not scored
    P = np.array([[1.0, 0.0, 0.0], [0.0, 4.0, 0.0], [0.0, 0.0, 1e-6]])
    sol.cov_p_n = np.tile(P, (len(t), 1, 1))
    np.testing.assert_allclose(metrics.nees_position(sol, gt), 1.0 + 1.0)
    # correlated north-east: e = (1, 2), P = [[2, 1], [1, 2]] -> e^T P^-1 e = (2 - 4 + 8) / 3 = 2
    sol.cov_p_n[:, :2, :2] = [[2.0, 1.0], [1.0, 2.0]]
    np.testing.assert_allclose(metrics.nees_position(sol, gt, 2.0, 4.0), [2.0] * 3)
    sol.cov_p_n[3] = np.nan                                            # an empty sigma row of a file
    nees = metrics.nees_position(sol, gt)
    assert np.isnan(nees[3]) and np.isfinite(np.delete(nees, 3)).all()
    sol.cov_p_n[5] = 0.0                                               # certainty the estimator cannot have
    with pytest.raises(DataError, match="singular covariance at epoch 5"):
        metrics.nees_position(sol, gt)
    sol.cov_p_n = None
    with pytest.raises(DataError, match="no position covariance"):
        metrics.nees_position(sol, gt)


def test_heading_nees_wraps_across_pi():
    t = np.arange(0.0, 5.01, 1.0)
    yaw_true = np.deg2rad(np.array([-179.0, 179.0, -179.0, 179.0, 90.0, -90.0]))
    yaw_est = np.deg2rad(np.array([179.0, -179.0, 178.0, -178.0, 92.0, -91.0]))
    zero = np.zeros_like(t)
    gt = GroundTruth(t, np.zeros((6, 3)), np.zeros((6, 3)), euler_to_C_b_n(zero, zero, yaw_true))
    sol = NavSolution("h", t, np.zeros((6, 3)), np.zeros((6, 3)), euler_to_C_b_n(zero, zero, yaw_est))
    _, d = metrics.heading_errors(sol, gt)
    np.testing.assert_allclose(np.rad2deg(d), [-2.0, 2.0, -3.0, 3.0, 2.0, -1.0], atol=1e-9)
    sigma = np.deg2rad(1.0)
    sol.cov_rot_b = np.tile(np.diag([1e-4, 1e-4, sigma ** 2]), (6, 1, 1))   # level: heading = body z
    np.testing.assert_allclose(metrics.nees_heading(sol, gt), [4.0, 4.0, 9.0, 9.0, 4.0, 1.0], rtol=1e-9)
    sol.cov_rot_b = None
    with pytest.raises(DataError, match="no attitude covariance"):
        metrics.nees_heading(sol, gt)


def test_heading_nees_of_a_tilted_vehicle_uses_the_heading_variance():
    """Rolled 57 deg and pitched 30 deg: a body-z attitude sigma is not the heading sigma; the NEES of errors
    drawn from the covariance (right perturbation) has mean 1."""
    rng = np.random.default_rng(3)
    n = 20000
    t = np.arange(n, dtype=float)
    C_true = euler_to_C_b_n(np.full(n, 1.0), np.full(n, np.deg2rad(30.0)), np.linspace(-3, 3, n))
    P = np.array([[4e-4, 1e-4, 0.0], [1e-4, 2e-4, 5e-5], [0.0, 5e-5, 3e-4]])
    from graphnav.core.rotations import so3_exp_batch
    C_est = C_true @ so3_exp_batch(rng.multivariate_normal(np.zeros(3), P, n))
    gt = GroundTruth(t, np.zeros((n, 3)), np.zeros((n, 3)), C_true)
    sol = NavSolution("h", t, np.zeros((n, 3)), np.zeros((n, 3)), C_est, cov_rot_b=np.tile(P, (n, 1, 1)))
    assert abs(np.mean(metrics.nees_heading(sol, gt)) - 1.0) < 0.04
    wrong = NavSolution("h", t, sol.p_n, sol.v_n, C_est, cov_rot_b=np.tile(np.diag([0, 0, P[2, 2]]), (n, 1, 1)))
    assert np.mean(metrics.nees_heading(wrong, gt)) > 2.5             # body z alone is not the heading


def test_horizontal_distance_interpolates_the_window_ends():
    t = np.arange(0.0, 4.01, 1.0)
    p = np.array([[0, 0, 0], [3, 4, 9], [3, 4, 0], [3, 10, 0], [6, 10, 0]], float)  # 5 + 0 + 6 + 3 m
    assert metrics.horizontal_distance(t, p) == pytest.approx(14.0)   # the depth change is not travel
    assert metrics.horizontal_distance(t, p, 0.5, 3.5) == pytest.approx(2.5 + 6.0 + 1.5)
    assert metrics.horizontal_distance(t, p, -5.0, 1.0) == pytest.approx(5.0)
    assert metrics.horizontal_distance(t, p, 3.0, 2.0) == 0.0


def test_drift_percent_of_a_straight_line_with_a_known_offset():
    gt = _line(100.0)                                                  # 150 m north
    t = np.arange(0.0, 100.01, 0.5)
    sol = _solution(t, gt)
    sol.p_n[:, 1] += 0.4 + 0.01 * t                                    # 0.4 m at the start, 1 cm/s east
    win = metrics.window_drift(sol, gt, 20.0, 50.0)
    assert win["drift_m"] == pytest.approx(0.3) and win["distance_m"] == pytest.approx(45.0)
    assert win["drift_pct"] == pytest.approx(0.3 / 45.0 * 100)       # the 0.4 m at the start is not the window's
    whole = metrics.mission_drift(sol, gt)
    assert whole["end_error_m"] == pytest.approx(1.4) and whole["distance_m"] == pytest.approx(150.0)
    assert whole["drift_pct"] == pytest.approx(1.4 / 150.0 * 100)
    # a vehicle that barely moves has no % DT
    assert metrics.window_drift(sol, gt, 20.0, 22.0)["drift_pct"] is None
    assert metrics.drift_pct(1.0, float("nan")) is None


def test_drift_summary_with_and_without_reference_and_covariance():
    gt = _line(100.0)
    t = np.arange(0.0, 100.01, 1.0)
    sol = _solution(t, gt)
    sol.p_n[:, 0] += 0.02 * t                                           # 2 m along track at the end
    s = metrics.drift_summary(sol)
    assert s["distance_m"] == pytest.approx(152.0) and s["drift_pct"] is None and s["sigma_h_end_m"] is None
    assert "- (the estimate carries no position covariance)" in metrics.drift_line(s)
    sol.cov_p_n = np.tile(np.diag([9.0, 16.0, 0.01]), (len(t), 1, 1))
    s = metrics.drift_summary(sol, gt)
    assert s["sigma_h_end_m"] == pytest.approx(5.0) and s["sigma_h_end_pct"] == pytest.approx(500 / 152.0)
    assert s["end_error_m"] == pytest.approx(2.0) and s["drift_pct"] == pytest.approx(200 / 150.0)
    line = metrics.drift_line(s)
    assert "1.33 % DT against the reference" in line and "5.00 m = 3.29 % DT" in line
