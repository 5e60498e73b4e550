"""The output every estimator returns: a navigation solution at its output epochs."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: ``info["alignment"]["position_source"]`` of a solution started from the sensors without a fix or an initial
#: latitude and longitude: its position is dead-reckoned from an origin placed at the start, whose horizontal
#: covariance (``AlignOptions.local_origin_sigma_m``) is in every epoch's ``cov_p_n``.
LOCAL_ORIGIN = "local origin at start"


@dataclass
class NavSolution:
    """Estimated trajectory of the IMU.

    Attributes:
        method: method name (``LC``, ``TC``, ``Average-LC``, ``Average-TC``, ``HNLC``, ``HNTC``,
            ``Graph-TC``, ``Graph-HN``, ``Graph-HN-batch``, ...).
        t: (K,) output stamps, s (IMU clock).
        p_n: (K,3) NED position, m.
        v_n: (K,3) NED velocity, m/s.
        C_b_n: (K,3,3) body-to-NED rotation.
        cov_v_n: optional (K,3,3) velocity covariance in NED, (m/s)^2.
        cov_p_n: optional (K,3,3) position covariance in NED, m^2 (None: the estimator has no position
            uncertainty, e.g. the paper's 12-state EKF, which integrates position without an error state).
        cov_rot_b: optional (K,3,3) attitude covariance, rad^2, of the right perturbation ``C_b_n = C_hat
            Exp(theta)`` (GTSAM's Rot3 tangent, body axes); :func:`graphnav.core.rotations.heading_variance`
            turns it into a heading variance.
        cov_bias: optional (K,6,6) covariance of the IMU biases ``[acc (m/s^2), gyro (rad/s)]`` (GTSAM's
            ConstantBias order), their units squared.

    Each covariance is the estimator's own marginal of that quantity (GTSAM marginals for the graph, blocks of
    P for the EKF); the cross-covariances between position, attitude, velocity and biases are not carried.
        bias_acc: optional (K,3) accelerometer bias estimate, m/s^2.
        bias_gyro: optional (K,3) gyro bias estimate, rad/s.
        runtime_s: wall time of the whole run, s.
        info: free-form diagnostics (e.g. update timings).
    """

    method: str
    t: np.ndarray
    p_n: np.ndarray
    v_n: np.ndarray
    C_b_n: np.ndarray
    cov_v_n: np.ndarray | None = None
    bias_acc: np.ndarray | None = None
    bias_gyro: np.ndarray | None = None
    cov_p_n: np.ndarray | None = None
    cov_rot_b: np.ndarray | None = None
    cov_bias: np.ndarray | None = None
    runtime_s: float = float("nan")
    info: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.t)

    @property
    def origin_unknown(self) -> bool:
        """True when the start's horizontal position was not known (:data:`LOCAL_ORIGIN`)."""
        return (self.info.get("alignment") or {}).get("position_source") == LOCAL_ORIGIN
