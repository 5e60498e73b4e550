"""Covariances in every output a user reads: the trajectory and per-epoch CSV sigma columns, the pose covariance
file beside the TUM trajectory, the JSON-lines estimate record, the ROS Odometry covariances (ENU, fixed axes;
checked against sampled perturbations) and the summary's uncertainty. Each with covariances (numbers back)
and without (empty, null or "unknown", never a zero)."""
from __future__ import annotations

import json

import gtsam
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from graphnav.core.rotations import euler_covariance, euler_to_C_b_n, heading_variance
from graphnav.core.solution import NavSolution
from graphnav.estimators.graph import EpochEstimate
from graphnav.io.bag_convert import ENU_NED, FLU_FRD
from graphnav.io.outputs import (
    BASE_COLUMNS,
    CSV_COLUMNS,
    HEALTH_COLUMN,
    SIGMA_COLUMNS,
    EpochCsvWriter,
    read_pose_covariance_csv,
    read_trajectory_csv,
    uncertainty_summary,
    write_pose_covariance_csv,
    write_trajectory_csv,
)
from graphnav.io.streamio import estimate_record


def _spd(rng, n, scale):
    A = rng.normal(size=(n, n))
    return A @ A.T * scale + np.eye(n) * scale * 0.1


def solution_with_covariances(k: int = 30, seed: int = 0, position: bool = True) -> NavSolution:
    rng = np.random.default_rng(seed)
    rpy = rng.uniform([-0.3, -0.3, -3.0], [0.3, 0.3, 3.0], (k, 3))
    return NavSolution(
        method="fake", t=100.0 + np.arange(k), p_n=rng.normal(0, 300, (k, 3)), v_n=rng.normal(0, 2, (k, 3)),
        C_b_n=euler_to_C_b_n(rpy[:, 0], rpy[:, 1], rpy[:, 2]),
        cov_v_n=np.array([_spd(rng, 3, 1e-4) for _ in range(k)]),
        bias_acc=rng.normal(0, 1e-3, (k, 3)), bias_gyro=rng.normal(0, 1e-6, (k, 3)),
        cov_p_n=np.array([_spd(rng, 3, 1.0) for _ in range(k)]) if position else None,
        cov_rot_b=np.array([_spd(rng, 3, 1e-6) for _ in range(k)]),
        cov_bias=np.array([_spd(rng, 6, 1e-8) for _ in range(k)]))


def _sigma(cov):
    return np.sqrt(np.diagonal(cov, axis1=-2, axis2=-1))


def test_trajectory_csv_sigmas_round_trip(tmp_path):
    sol = solution_with_covariances()
    path = write_trajectory_csv(tmp_path / "traj.csv", sol)
    header = path.read_text().splitlines()[0].split(",")
    assert header == list(CSV_COLUMNS) + [HEALTH_COLUMN]
    assert {"sigma_p_north_m", "sigma_roll_rad", "sigma_yaw_rad"} <= set(header)
    back = read_trajectory_csv(path)
    np.testing.assert_allclose(_sigma(back.cov_p_n), _sigma(sol.cov_p_n), rtol=1e-8)
    np.testing.assert_allclose(_sigma(back.cov_v_n), _sigma(sol.cov_v_n), rtol=1e-8)
    # roll, pitch, yaw sigmas as the first-order Euler covariance of the body-axes attitude covariance
    np.testing.assert_allclose(_sigma(euler_covariance(back.C_b_n, back.cov_rot_b)),
                               _sigma(euler_covariance(sol.C_b_n, sol.cov_rot_b)), rtol=1e-7)
    # the heading sigma a reader computes from what it read back is the one the estimator had
    np.testing.assert_allclose(heading_variance(back.C_b_n, back.cov_rot_b), heading_variance(sol.C_b_n, sol.cov_rot_b),
                               rtol=1e-7)


def test_trajectory_csv_without_position_covariance(tmp_path):
    sol = solution_with_covariances(position=False)
    path = write_trajectory_csv(tmp_path / "traj.csv", sol)
    text = path.read_text()
    assert "nan" not in text.lower()
    header = text.splitlines()[0].split(",")
    cells = text.splitlines()[1].split(",")
    assert [cells[header.index(c)] for c in SIGMA_COLUMNS[:3]] == ["", "", ""]       # empty, not 0
    assert all(cells[header.index(c)] for c in SIGMA_COLUMNS[3:])
    back = read_trajectory_csv(path)
    assert back.cov_p_n is None and back.cov_rot_b is not None


def test_old_trajectory_csv_still_reads_and_resumes(tmp_path):
    """A file written before the sigma columns: read (no position covariance) and resumed in its own layout."""
    sol = solution_with_covariances(6)
    path = tmp_path / "online.csv"
    rows = write_trajectory_csv(tmp_path / "new.csv", sol).read_text().splitlines()
    keep = [CSV_COLUMNS.index(c) for c in BASE_COLUMNS] + [len(CSV_COLUMNS)]
    old = [",".join(np.array(r.split(","))[keep]) for r in rows[:4]]
    path.write_text("\n".join(old) + "\n")
    back = read_trajectory_csv(path)
    assert back.cov_p_n is None and back.cov_rot_b is None and back.cov_v_n is not None
    with EpochCsvWriter(path, resume=True) as w:
        assert w.n_written == 3
        w.write(sol.t[3], sol.p_n[3], sol.v_n[3], sol.C_b_n[3], sol.cov_v_n[3], sol.bias_acc[3], sol.bias_gyro[3],
                "ok", cov_p_n=sol.cov_p_n[3], cov_rot_b=sol.cov_rot_b[3])
    lines = path.read_text().splitlines()
    assert all(len(line.split(",")) == len(BASE_COLUMNS) + 1 for line in lines)
    np.testing.assert_allclose(read_trajectory_csv(path).t, sol.t[:4])


def test_epoch_writer_writes_the_sigmas(tmp_path):
    sol = solution_with_covariances(5)
    path = tmp_path / "online.csv"
    with EpochCsvWriter(path) as w:
        for k in range(5):
            w.write(sol.t[k], sol.p_n[k], sol.v_n[k], sol.C_b_n[k], sol.cov_v_n[k], sol.bias_acc[k],
                    sol.bias_gyro[k], "ok", cov_p_n=sol.cov_p_n[k], cov_rot_b=sol.cov_rot_b[k])
    assert path.read_text() == write_trajectory_csv(tmp_path / "whole.csv", sol).read_text().replace(",\n", ",ok\n")


def test_pose_covariance_file(tmp_path):
    sol = solution_with_covariances()
    path = write_pose_covariance_csv(tmp_path / "trajectory_cov.csv", sol)
    t, cov_p, cov_rot, _ = read_pose_covariance_csv(path)
    np.testing.assert_allclose(t, sol.t, atol=1e-9)
    np.testing.assert_allclose(cov_p, sol.cov_p_n, rtol=1e-9)
    np.testing.assert_allclose(cov_rot, sol.cov_rot_b, rtol=1e-9)
    no_position = solution_with_covariances(position=False)
    t, cov_p, cov_rot, _ = read_pose_covariance_csv(write_pose_covariance_csv(tmp_path / "ekf.csv", no_position))
    assert cov_p is None and cov_rot is not None
    assert ",,,,,," in (tmp_path / "ekf.csv").read_text().splitlines()[1]


def _estimate(sol, k, full=True):
    return EpochEstimate(k, float(sol.t[k]), "dvl", gtsam.Pose3(gtsam.Rot3(sol.C_b_n[k]), sol.p_n[k]), sol.v_n[k],
                         gtsam.imuBias.ConstantBias(sol.bias_acc[k], sol.bias_gyro[k]), sol.cov_v_n[k], 4, 0, 0.001,
                         cov_p_n=sol.cov_p_n[k] if full else None, cov_rot_b=sol.cov_rot_b[k] if full else None,
                         cov_bias=sol.cov_bias[k] if full else None)


def test_estimate_record_covariances():
    sol = solution_with_covariances(3)
    rec = json.loads(json.dumps(estimate_record(_estimate(sol, 2))))
    np.testing.assert_allclose(rec["cov_p_n"], sol.cov_p_n[2], rtol=1e-12)
    np.testing.assert_allclose(rec["cov_rot_b"], sol.cov_rot_b[2], rtol=1e-12)
    np.testing.assert_allclose(rec["cov_bias"], sol.cov_bias[2], rtol=1e-12)
    np.testing.assert_allclose(rec["sigma_p_n"], _sigma(sol.cov_p_n[2]), rtol=1e-12)
    np.testing.assert_allclose(rec["sigma_v_n"], _sigma(sol.cov_v_n[2]), rtol=1e-12)
    np.testing.assert_allclose(rec["sigma_rpy"], _sigma(euler_covariance(sol.C_b_n[2], sol.cov_rot_b[2])), rtol=1e-9)
    bare = json.loads(json.dumps(estimate_record(_estimate(sol, 2, full=False))))
    assert bare["cov_p_n"] is bare["sigma_p_n"] is bare["sigma_rpy"] is bare["cov_bias"] is None
    assert bare["cov_v_n"] is not None


def test_odometry_covariances_against_sampled_perturbations():
    """Perturb the NED/FRD state by draws from the solution's covariances, convert each draw to ROS' ENU/FLU
    pose and twist, and compare the spread with the Odometry covariance blocks: position in ENU, rotation about
    ENU's fixed axes (``q_draw * q_nominal^-1``), linear twist in FLU."""
    bags = pytest.importorskip("graphnav.io.bags")
    rng = np.random.default_rng(3)
    sol = solution_with_covariances(1, seed=5)
    pose_cov, twist_cov = bags.odometry_covariances(sol)
    C = sol.C_b_n[0]
    n = 40000
    theta = rng.multivariate_normal(np.zeros(3), sol.cov_rot_b[0], n)
    dp_n = rng.multivariate_normal(np.zeros(3), sol.cov_p_n[0], n)
    dv_n = rng.multivariate_normal(np.zeros(3), sol.cov_v_n[0], n)
    C_draw = C @ Rotation.from_rotvec(theta).as_matrix()
    q_nominal = Rotation.from_matrix(ENU_NED @ C @ FLU_FRD)
    rot_enu = (Rotation.from_matrix(ENU_NED @ C_draw @ FLU_FRD) * q_nominal.inv()).as_rotvec()
    p_enu = dp_n @ ENU_NED.T
    v_flu = (dv_n @ C) @ FLU_FRD            # C^T dv_n, then FRD -> FLU
    for sample, block in ((p_enu, pose_cov[0, :3, :3]), (rot_enu, pose_cov[0, 3:, 3:]),
                          (v_flu, twist_cov[0, :3, :3])):
        np.testing.assert_allclose(np.cov(sample.T), block, atol=0.03 * np.abs(block).max())
    assert np.all(pose_cov[0, :3, 3:] == 0)
    # not estimated: the angular rate, and without a position covariance the position
    np.testing.assert_array_equal(twist_cov[0, 3:, 3:], np.eye(3) * bags.UNKNOWN_VARIANCE)
    pose_cov, _ = bags.odometry_covariances(solution_with_covariances(2, position=False))
    np.testing.assert_array_equal(pose_cov[:, :3, :3], np.broadcast_to(np.eye(3) * bags.UNKNOWN_VARIANCE, (2, 3, 3)))
    # a diverged epoch says "do not use" on every block
    diverged = solution_with_covariances(2)
    diverged.info["health_state"] = ["ok", "diverged"]
    pose_cov, twist_cov = bags.odometry_covariances(diverged)
    np.testing.assert_array_equal(pose_cov[1], np.eye(6) * bags.DIVERGED_VARIANCE)
    assert pose_cov[0, 0, 0] < bags.DIVERGED_VARIANCE


def test_odometry_bag_round_trip(tmp_path):
    bags = pytest.importorskip("graphnav.io.bags")
    pytest.importorskip("rosbags")
    sol = solution_with_covariances(8)
    back = bags.load_odometry(bags.write_odometry_bag(sol, tmp_path / "odom"))
    np.testing.assert_allclose(back.p_n, sol.p_n, atol=1e-9)
    for name in ("cov_p_n", "cov_rot_b", "cov_v_n"):
        np.testing.assert_allclose(getattr(back, name), getattr(sol, name), rtol=1e-7, atol=1e-15)
    none = bags.load_odometry(bags.write_odometry_bag(solution_with_covariances(3, position=False), tmp_path / "ekf"))
    assert none.cov_p_n is None and none.cov_rot_b is not None


def test_uncertainty_summary():
    sol = solution_with_covariances()
    u = uncertainty_summary(sol)
    horizontal = np.sqrt(sol.cov_p_n[:, 0, 0] + sol.cov_p_n[:, 1, 1])
    assert u["final_horizontal_position_sigma_m"] == pytest.approx(horizontal[-1])
    assert u["max_horizontal_position_sigma_m"] == pytest.approx(horizontal.max())
    heading = np.rad2deg(np.sqrt(heading_variance(sol.C_b_n, sol.cov_rot_b)))
    assert u["final_heading_sigma_deg"] == pytest.approx(heading[-1])
    assert u["max_heading_sigma_deg"] == pytest.approx(heading.max())
    np.testing.assert_allclose(u["final_position_sigma_ned_m"], _sigma(sol.cov_p_n[-1]))
    assert u["not_estimated"] == []
    ekf = uncertainty_summary(solution_with_covariances(position=False))
    assert ekf["final_horizontal_position_sigma_m"] is None and ekf["not_estimated"] == ["position"]
    assert ekf["final_heading_sigma_deg"] is not None


def test_the_covariance_file_holds_the_velocity_block_and_reads_one_written_before_it(tmp_path):
    from graphnav.io.outputs import POSE_COV_COLUMNS_WITHOUT_VELOCITY
    sol = solution_with_covariances()
    path = write_pose_covariance_csv(tmp_path / "trajectory_cov.csv", sol)
    np.testing.assert_allclose(read_pose_covariance_csv(path)[3], sol.cov_v_n, rtol=1e-9)
    # a file written before the velocity block: the first 13 columns, no velocity covariance
    old = tmp_path / "old_cov.csv"
    old.write_text("".join(",".join(line.split(",")[:len(POSE_COV_COLUMNS_WITHOUT_VELOCITY)]).rstrip("\n") + "\n"
                           for line in path.read_text().splitlines()))
    t, cov_p, cov_rot, cov_v = read_pose_covariance_csv(old)
    np.testing.assert_allclose(cov_p, sol.cov_p_n, rtol=1e-9)
    assert cov_v is None
