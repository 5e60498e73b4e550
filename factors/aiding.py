"""Aiding factors for heading sensors (AHRS, magnetometer) and horizontal position fixes (GNSS, USBL).

- :func:`horizontal_position_factor`: a fix observes north and east of the pose's NED position. Built, like
  the depth factor, on GTSAM's C++ ``PoseTranslationPrior3D`` with a down part of no weight to speak of
  (:data:`~graphnav.factors.depth.UNMEASURED_SIGMA_M`) centred on the predicted depth, so it costs nothing in
  Python at optimisation time.
- :func:`heading_factor`: a heading sensor observes the yaw of ``C_b_n``, ``yaw = atan2(R[1,0], R[0,0])``.
  Residual ``wrap(yaw(R) - yaw_meas)``; Jacobian for GTSAM's right perturbation ``R Exp(d)`` (Pose3 tangent
  ``[rot, trans]``): with ``c = R00^2 + R10^2``,
  ``d yaw / d d = [0, R10 R02 - R00 R12, R00 R11 - R10 R01] / c`` (from ``dR = R [d]x``).
"""
from __future__ import annotations

import math

import gtsam
import numpy as np

from graphnav.core.rotations import yaw_jacobian
from graphnav.factors.depth import UNMEASURED_SIGMA_M


def horizontal_position_factor(x_key: int, ne_m: np.ndarray, sigma_m: float, down_guess_m: float | None = None,
                               vertical_sigma_m: float = UNMEASURED_SIGMA_M) -> gtsam.NonlinearFactor:
    """Factor on Pose3 ``x_key``: NED north/east of the IMU = ``ne_m`` (m) with ``sigma_m`` (m) per axis."""
    ne = np.asarray(ne_m, dtype=float).reshape(2)
    down = 0.0 if down_guess_m is None else float(down_guess_m)
    noise = gtsam.noiseModel.Diagonal.Sigmas(np.array([sigma_m, sigma_m, vertical_sigma_m]))
    return gtsam.PoseTranslationPrior3D(x_key, np.array([ne[0], ne[1], down]), noise)


def yaw_and_jacobian(R: np.ndarray) -> tuple[float, np.ndarray]:
    """(yaw rad, d yaw / d rotation-tangent (3,)) of a body-to-NED rotation matrix (right perturbation)."""
    return math.atan2(R[1, 0], R[0, 0]), yaw_jacobian(R)


def heading_factor(x_key: int, yaw_rad: float, sigma_rad: float) -> gtsam.CustomFactor:
    """Factor on Pose3 ``x_key``: yaw of its attitude = ``yaw_rad`` with ``sigma_rad`` (near +-90 deg pitch
    the yaw is undefined; the factor then carries no information)."""
    noise = gtsam.noiseModel.Isotropic.Sigma(1, float(sigma_rad))

    def error(this: gtsam.CustomFactor, values: gtsam.Values, H):
        R = values.atPose3(this.keys()[0]).rotation().matrix()
        yaw, J = yaw_and_jacobian(R)
        if H is not None:
            H[0] = np.r_[J, np.zeros(3)].reshape(1, 6)
        return np.array([math.remainder(yaw - yaw_rad, 2 * math.pi)])

    return gtsam.CustomFactor(noise, [x_key], error)
