"""Where a run's positions are on Earth (``info["position_frame"]``) and how a reference scores them: a start
without its position (from the start), a start a later fix placed (through latitude and longitude), and a run
that used fixes (its drift before each stay at the surface)."""
from __future__ import annotations

import numpy as np
import pytest

from graphnav.core.mission import GroundTruth
from graphnav.core.solution import LOCAL_ORIGIN, NavSolution
from graphnav.evaluation.consistency import pose_nees
from graphnav.evaluation.metrics import mission_drift

ORIGIN = (np.radians(32.8), np.radians(34.9), 0.0)


def _truth() -> GroundTruth:
    """400 s at 2 m/s: 400 m north, then 400 m east; 10 m deep; in the NED frame at :data:`ORIGIN`."""
    t = np.arange(0.0, 400.01, 1.0)
    north = 2.0 * np.minimum(t, 200.0)
    p = np.c_[north, 2.0 * t - north, 10.0 + 0 * t]
    return GroundTruth(t, p, np.gradient(p, t, axis=0), np.tile(np.eye(3), (len(t), 1, 1)), ORIGIN)


def _estimate(gt: GroundTruth, p_n: np.ndarray, sigma_h: np.ndarray, info: dict) -> NavSolution:
    cov = np.zeros((len(gt.t), 3, 3))
    cov[:, 0, 0] = cov[:, 1, 1] = sigma_h ** 2
    cov[:, 2, 2] = 0.01
    return NavSolution("est", gt.t.copy(), p_n, gt.v_n.copy(), gt.C_b_n.copy(), cov_p_n=cov,
                       cov_rot_b=np.tile(np.eye(3) * 1e-6, (len(gt.t), 1, 1)), info=info)


def _unknown_start(gt: GroundTruth) -> NavSolution:
    """Dead-reckoned from a start 3 m north of the truth's (the unknown origin's error) with a drift growing
    east 1 cm per second; sigma the origin's 100 m and 1 cm/s since the start."""
    drift = np.c_[0 * gt.t, 0.01 * gt.t, 0 * gt.t]
    info = {"alignment": {"position_source": LOCAL_ORIGIN}}
    return _estimate(gt, gt.p_n + [3.0, 0.0, 0.0] + drift, np.sqrt(100.0 ** 2 + (0.01 * gt.t) ** 2), info)


def test_a_start_without_its_position_counts_its_error_from_the_start():
    # the end error was absolute: the start's 3 m (the origin's) counted as drift, beside a from-start sigma
    gt = _truth()
    sol = _unknown_start(gt)
    m = mission_drift(sol, gt)
    assert m["end_error_m"] == pytest.approx(4.0, abs=1e-9)            # 1 cm/s over 400 s, not |(3, 4)| = 5
    assert m["drift_pct"] == pytest.approx(0.5)
    scores = pose_nees(sol, gt, 60.0)
    assert scores["nees_pos_mission"] == pytest.approx(1.0, abs=1e-6)  # e = (0, 0.01 t), sigma 0.01 t per axis
