"""GTSAM marginals in :class:`graphnav.core.solution.NavSolution`'s conventions.

A ``Pose3`` marginal is a 6x6 covariance in GTSAM's tangent ``[rot (body axes, rad), trans (body axes, m)]``.
``Pose3.retract`` moves the translation by ``R dt_b`` (to first order, for both of GTSAM's Pose3 charts:
``Expmap`` gives ``t + R J_l(w) v`` and the non-Expmap chart ``t + R v``), so the NED position error is
``dp_n = R dt_b`` and its covariance ``R S_tt R^T``; the rotation block is already the right perturbation of
``C_b_n`` in body axes (``cov_rot_b``). ``tests/test_graph_covariance.py`` checks both against sampled
retractions.
"""
from __future__ import annotations

from typing import Callable

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, V, X


def pose_covariances(pose: gtsam.Pose3, cov_pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cov_rot_b (3,3) rad^2, body-axes right perturbation; cov_p_n (3,3) m^2, NED) of a Pose3 marginal
    ``cov_pose`` (6,6) in GTSAM's tangent ``[rot, trans]``."""
    S = np.asarray(cov_pose, float)
    R = pose.rotation().matrix()
    cov_p_n = R @ S[3:, 3:] @ R.T
    return _symmetric(S[:3, :3]), _symmetric(cov_p_n)


def _symmetric(P: np.ndarray) -> np.ndarray:
    # marginals come out of back-substitution symmetric to rounding only; the writers take square roots
    return 0.5 * (P + P.T)


def keyframe_marginals(level: str, k: int, pose: gtsam.Pose3,
                       marginal: Callable[[int], np.ndarray]) -> dict:
    """The covariances of keyframe k a :class:`~graphnav.estimators.types.EpochEstimate` carries at marginal
    ``level`` (:data:`~graphnav.estimators.graph.options.MARGINAL_LEVELS`): keys ``cov_v_n`` (NED, (m/s)^2)
    and, at ``"full"``, ``cov_p_n``, ``cov_rot_b``, ``cov_bias`` ([acc, gyro]); ``marginal(key)`` is the
    solver's marginal covariance of one variable in its tangent space."""
    if level == "none":
        return {}
    out = {"cov_v_n": _symmetric(marginal(V(k)))}
    if level == "full":
        out["cov_rot_b"], out["cov_p_n"] = pose_covariances(pose, marginal(X(k)))
        out["cov_bias"] = _symmetric(marginal(B(k)))
    return out
