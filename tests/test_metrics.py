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
