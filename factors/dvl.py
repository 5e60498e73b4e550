"""DVL factors for GTSAM: tightly coupled beam factors and a loosely coupled body-velocity factor.

Measurement model (``../shared/docs/method.md`` plus the lever arm): a beam i measures the velocity of the
DVL head along its unit vector,

    y_i = b_i^T C_d_b^T (R^T v_n + (omega_b - b_g) x l_b) + noise,

with ``R`` = ``C_b_n`` the attitude of Pose3 ``x_k``, ``v_n`` the NED velocity ``v_k`` (Vector3), ``b_g`` the
gyro part of the IMU bias ``b_k`` (imuBias.ConstantBias, tangent ``[acc, gyro]``), ``omega_b`` the raw body
rate of the IMU sample nearest the DVL stamp (rad/s, the Earth rate already removed by the caller if wanted),
``l_b`` the lever arm (m, body frame) and ``b_i^T C_d_b^T`` = row i of :attr:`graphnav.core.dvl.DvlGeometry.T_b`.

One factor may hold any number m of beams (rows); per-beam sigmas go in a diagonal noise model, so the
same code serves "one factor per beam" (m = 1) and "one factor per epoch" (m = number of valid beams).
The loosely coupled factor is the same model with the identity as its rows (3 rows, the DVL-head body
velocity).

Jacobians, in GTSAM's conventions (right perturbation ``R Exp(dtheta)``, Pose3 tangent ``[rot, trans]``,
bias tangent ``[acc, gyro]``), with ``B`` the (m,3) rows:

    d/dpose = [B [R^T v]x, 0]      d/dv = B R^T      d/dbias = [0, B [l]x]      d/dl = B [omega - b_g]x

DVL error states (:func:`beam_factor_dvl_errors`, as the EKF's ``dvl_error_states``): a Vector7 variable
``d = [s (3), b (4)]`` holds the scale factor per DVL axis and the bias per beam, beam model
``y_i = T_d[i] ((1 + s) * v_d) + b_i`` with ``v_d = C_d_b^T (R^T v_n + (omega_b - b_g) x l_b)``. With
``M`` = rows ``T_d[i] diag(1 + s) C_d_b^T`` in place of ``B`` above, plus

    d/ds = T_d[i] * v_d (elementwise)      d/db = e_i (the factor's beam index)

``gtsam.CustomFactor`` calls back into Python; inside the C++ optimisers each call also copies the whole
``Values`` (pybind11 casts the ``const Values&`` argument by copy), so the cost of one call grows with the
number of variables. Fewer, larger factors (one per epoch) are therefore preferred.
"""
from __future__ import annotations

import gtsam
import numpy as np

_ZERO3 = np.zeros((0, 3))


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    # np.cross costs ~0.1 ms on 3-vectors (axis handling); this runs in every factor call
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def beam_noise(sigmas: np.ndarray, huber_k: float | None = None) -> gtsam.noiseModel.Base:
    """Diagonal noise model with per-row sigmas (m/s), optionally wrapped in a Huber kernel (threshold k)."""
    base = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(sigmas, dtype=float))
    if huber_k is None:
        return base
    return gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(float(huber_k)), base)


def _rows_measurements_noise(rows_b, y, noise):
    """(B (m,3), y (m,), noise model) of a DVL factor; (m,) sigmas become :func:`beam_noise`."""
    B = np.array(rows_b, dtype=float).reshape(-1, 3)
    y = np.array(y, dtype=float).reshape(-1)
    if B.shape[0] != y.shape[0]:
        raise ValueError(f"{B.shape[0]} beam rows but {y.shape[0]} measurements")
    if not isinstance(noise, gtsam.noiseModel.Base):
        noise = beam_noise(noise)
    return B, y, noise


def predict_beams(rows_b: np.ndarray, C_b_n: np.ndarray, v_n: np.ndarray, omega_b: np.ndarray,
                  gyro_bias: np.ndarray, lever_arm_b: np.ndarray) -> np.ndarray:
    """Predicted measurements ``B (R^T v_n + (omega_b - b_g) x l_b)`` (m,), m/s."""
    return rows_b @ (C_b_n.T @ v_n + np.cross(omega_b - gyro_bias, lever_arm_b))


def beam_factor(x_key: int, v_key: int, b_key: int, rows_b: np.ndarray, y: np.ndarray,
                noise: gtsam.noiseModel.Base | np.ndarray, omega_b: np.ndarray,
                lever_arm_b: np.ndarray) -> gtsam.CustomFactor:
    """DVL factor on (Pose3 x, Vector3 v_n, ConstantBias b) for m beams (or the 3-row body velocity).

    Args:
        x_key, v_key, b_key: keys of the pose, NED velocity and IMU bias.
        rows_b: (m,3) beam unit vectors in the body frame (rows of ``DvlGeometry.T_b``), or I3 for LC.
        y: (m,) measured beam velocities of the DVL head, m/s.
        noise: a gtsam noise model of dimension m, or (m,) sigmas in m/s.
        omega_b: (3,) measured body rate near the DVL stamp, rad/s.
        lever_arm_b: (3,) DVL position relative to the IMU, body frame, m.
    """
    B, y, noise = _rows_measurements_noise(rows_b, y, noise)
    omega = np.array(omega_b, dtype=float).reshape(3)
    lever = np.array(lever_arm_b, dtype=float).reshape(3)
    # d/dbias is constant: [0, B [l]x]
    H_bias = np.hstack([np.zeros((B.shape[0], 3)), B @ _skew(lever)])

    def error(_factor, values, H):
        R = values.atPose3(x_key).rotation().matrix()
        v_n = values.atVector(v_key)
        b_g = values.atConstantBias(b_key).gyroscope()
        v_body = R.T @ v_n
        residual = B @ (v_body + _cross(omega - b_g, lever)) - y
        if H is not None:
            H[0] = np.hstack([B @ _skew(v_body), np.zeros((B.shape[0], 3))])
            H[1] = B @ R.T
            H[2] = H_bias
        return residual

    return gtsam.CustomFactor(noise, [x_key, v_key, b_key], error)


#: Dimension of the DVL error-state vector ``[scale x, y, z, bias beam 1..4]``.
N_DVL_ERRORS = 7


def beam_factor_dvl_errors(x_key: int, v_key: int, b_key: int, d_key: int, rows_b: np.ndarray,
                           beam_index: np.ndarray, C_d_b: np.ndarray, y: np.ndarray,
                           noise: gtsam.noiseModel.Base | np.ndarray, omega_b: np.ndarray,
                           lever_arm_b: np.ndarray) -> gtsam.CustomFactor:
    """As :func:`beam_factor`, plus the DVL error states: Vector7 ``d_key`` = [scale (3), beam bias (4) m/s].

    Args:
        rows_b: (m,3) beam unit vectors in the body frame (rows of ``DvlGeometry.T_b``).
        beam_index: (m,) 0-based beam number of each row (which bias applies).
        C_d_b: (3,3) DVL-to-body rotation (the scale factor acts on the DVL-frame axes).
        Others as :func:`beam_factor`.
    """
    B, y, noise = _rows_measurements_noise(rows_b, y, noise)
    C_d_b = np.asarray(C_d_b, dtype=float).reshape(3, 3)
    rows_d = B @ C_d_b                     # T_d rows: T_b = T_d C_d_b^T
    index = np.asarray(beam_index, dtype=int).reshape(-1)
    if index.shape[0] != B.shape[0] or np.any((index < 0) | (index > 3)):
        raise ValueError(f"beam_index must hold one beam number 0..3 per row, got {index.tolist()}")
    onehot = np.zeros((B.shape[0], 4))
    onehot[np.arange(B.shape[0]), index] = 1.0
    omega = np.array(omega_b, dtype=float).reshape(3)
    lever = np.array(lever_arm_b, dtype=float).reshape(3)
    zeros = np.zeros((B.shape[0], 3))

    def error(_factor, values, H):
        R = values.atPose3(x_key).rotation().matrix()
        v_n = values.atVector(v_key)
        b_g = values.atConstantBias(b_key).gyroscope()
        d = values.atVector(d_key)
        v_body = R.T @ v_n
        v_d = C_d_b.T @ (v_body + _cross(omega - b_g, lever))
        residual = rows_d @ ((1.0 + d[:3]) * v_d) + onehot @ d[3:] - y
        if H is not None:
            M = (rows_d * (1.0 + d[:3])) @ C_d_b.T
            H[0] = np.hstack([M @ _skew(v_body), zeros])
            H[1] = M @ R.T
            H[2] = np.hstack([zeros, M @ _skew(lever)])
            H[3] = np.hstack([rows_d * v_d, onehot])
        return residual

    return gtsam.CustomFactor(noise, [x_key, v_key, b_key, d_key], error)


def body_velocity_factor(x_key: int, v_key: int, b_key: int, v_dvl_b: np.ndarray,
                         noise: gtsam.noiseModel.Base | np.ndarray, omega_b: np.ndarray,
                         lever_arm_b: np.ndarray) -> gtsam.CustomFactor:
    """Loosely coupled factor: the DVL-head body velocity ``v_dvl_b`` (3,) m/s, residual 3 rows.

    ``noise`` is a 3-dimensional noise model (e.g. ``Gaussian.Covariance`` of the least-squares velocity)
    or (3,) sigmas in m/s.
    """
    return beam_factor(x_key, v_key, b_key, np.eye(3), v_dvl_b, noise, omega_b, lever_arm_b)


def beam_factor_lever_arm(x_key: int, v_key: int, b_key: int, l_key: int, rows_b: np.ndarray,
                          y: np.ndarray, noise: gtsam.noiseModel.Base | np.ndarray,
                          omega_b: np.ndarray) -> gtsam.CustomFactor:
    """As :func:`beam_factor`, with the lever arm as a fourth variable (Point3 ``l_key``, body frame, m).

    For lever-arm calibration: put a (weak) prior on ``l_key`` and let the graph estimate it, or hold it
    constant. Extra Jacobian ``d/dl = B [omega_b - b_g]x``.
    """
    B, y, noise = _rows_measurements_noise(rows_b, y, noise)
    omega = np.array(omega_b, dtype=float).reshape(3)
    zeros = np.zeros((B.shape[0], 3))

    def error(_factor, values, H):
        R = values.atPose3(x_key).rotation().matrix()
        v_n = values.atVector(v_key)
        b_g = values.atConstantBias(b_key).gyroscope()
        lever = values.atPoint3(l_key)
        v_body = R.T @ v_n
        rate = omega - b_g
        residual = B @ (v_body + _cross(rate, lever)) - y
        if H is not None:
            H[0] = np.hstack([B @ _skew(v_body), zeros])
            H[1] = B @ R.T
            H[2] = np.hstack([zeros, B @ _skew(lever)])
            H[3] = B @ _skew(rate)
        return residual

    return gtsam.CustomFactor(noise, [x_key, v_key, b_key, l_key], error)
