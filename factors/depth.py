"""Depth factor: a pressure-depth measurement observes the down component of the pose's NED position.

Built on GTSAM's C++ ``PoseTranslationPrior3D`` (error ``t - t_meas`` in the navigation frame, Jacobian
``[0, R]``), so it costs nothing in Python at optimisation time. North and east get a sigma of 1000 km instead
of none (GTSAM's diagonal noise model needs finite sigmas; a zero precision makes its marginals fail). Every
keyframe has one, so what they add sums over the mission: 1e-12 m^-2 each, a million keyframes less than one
1 km fix. With 1 km each (1e-6 m^-2) a 200 s run started without its position (a 100 m origin) claimed 58 m
after it, and an hour's keyframes (3600) summed into a 17 m position fix that nothing had measured.
"""
from __future__ import annotations

import gtsam
import numpy as np

#: Sigma of the axes a ``PoseTranslationPrior3D`` does not measure, m (see the module's docstring).
UNMEASURED_SIGMA_M = 1e6


def depth_factor(x_key: int, depth_m: float, sigma_m: float, north_east_guess: np.ndarray | None = None,
                 horizontal_sigma_m: float = UNMEASURED_SIGMA_M) -> gtsam.NonlinearFactor:
    """Factor on Pose3 ``x_key``: NED down of the IMU = ``depth_m`` (m, positive down) with ``sigma_m`` (m).

    ``north_east_guess`` (2,) m is where the weak horizontal part is centred (use the predicted position so
    it pulls on nothing); zeros when omitted.
    """
    ne = np.zeros(2) if north_east_guess is None else np.asarray(north_east_guess, dtype=float).reshape(2)
    noise = gtsam.noiseModel.Diagonal.Sigmas(np.array([horizontal_sigma_m, horizontal_sigma_m, sigma_m]))
    return gtsam.PoseTranslationPrior3D(x_key, np.array([ne[0], ne[1], float(depth_m)]), noise)
