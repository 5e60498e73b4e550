"""Rotation helpers in GTSAM's convention.

``C_b_n`` is the body-to-navigation rotation matrix (GTSAM's ``nRb``: ``v_n = C_b_n @ v_b``). Euler angles
are aerospace roll/pitch/yaw with ``C_b_n = Rz(yaw) @ Ry(pitch) @ Rx(roll)``, which equals
``gtsam.Rot3.Ypr(yaw, pitch, roll)``. Perturbations are on the right: ``C = C_hat @ Exp(dtheta)``.
All functions are vectorised over a leading axis.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

#: ENU to NED (swap east and north, negate up): its own inverse, so NED to ENU too.
C_NED_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrix ``[v]x`` of a (3,) or (N,3) array, so that ``skew(a) @ b == cross(a, b)``."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def euler_to_C_b_n(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Body-to-NED rotation matrices (N,3,3) from roll, pitch, yaw in rad."""
    angles = np.stack(np.broadcast_arrays(yaw, pitch, roll), axis=-1)
    return Rotation.from_euler("ZYX", angles).as_matrix()


def euler_to_C_b_n_closed_form(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """``Rz(yaw) Ry(pitch) Rx(roll)`` (N,3,3) from roll, pitch, yaw in rad, in closed form: the same matrices as
    :func:`euler_to_C_b_n` to ~1e-15 (tested), several times faster for the simulator's millions of samples.
    :func:`euler_to_C_b_n` stays the loaders' (bit-for-bit what they have always produced)."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    C = np.empty(np.shape(roll) + (3, 3))
    C[..., 0, 0], C[..., 0, 1], C[..., 0, 2] = cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr
    C[..., 1, 0], C[..., 1, 1], C[..., 1, 2] = sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr
    C[..., 2, 0], C[..., 2, 1], C[..., 2, 2] = -sp, cp * sr, cp * cr
    return C


def C_b_n_to_euler(C_b_n: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw in rad, shape (..., 3), from body-to-NED rotation matrices."""
    ypr = Rotation.from_matrix(C_b_n).as_euler("ZYX")
    return ypr[..., ::-1]


def so3_exp_batch(phi: np.ndarray) -> np.ndarray:
    """Rodrigues' formula ``Exp(phi)`` for rotation vectors (n,3), rad -> (n,3,3).

    Plain numpy (no per-call object construction) with series coefficients for small angles.
    """
    phi = np.asarray(phi, dtype=float)
    theta2 = np.einsum("ni,ni->n", phi, phi)
    small = theta2 < 1e-8
    theta = np.sqrt(np.where(small, 1.0, theta2))
    a = np.where(small, 1.0 - theta2 / 6.0, np.sin(theta) / theta)
    b = np.where(small, 0.5 - theta2 / 24.0, (1.0 - np.cos(theta)) / np.where(small, 1.0, theta2))
    K = skew(phi)
    return np.eye(3) + a[:, None, None] * K + b[:, None, None] * (K @ K)


def so3_log(C: np.ndarray) -> np.ndarray:
    """Rotation vectors ``Log(C)`` in rad, shape (…,3)."""
    return Rotation.from_matrix(C).as_rotvec()


def attitude_error(C_est_b_n: np.ndarray, C_true_b_n: np.ndarray) -> np.ndarray:
    """Right-perturbation attitude error ``Log(C_true^T C_est)`` in rad (body frame), shape (…,3)."""
    return so3_log(np.swapaxes(C_true_b_n, -1, -2) @ C_est_b_n)


def euler_jacobian(C_b_n: np.ndarray) -> np.ndarray:
    """``d (roll, pitch, yaw) / d theta`` (…,3,3) of body-to-NED rotations for a right perturbation
    ``C = C_hat Exp(theta)`` (theta in body axes, rad): the inverse of the Euler-rate matrix ``omega_b = E
    d(roll, pitch, yaw)/dt``. Its last row is :func:`yaw_jacobian`; near +-90 deg pitch it grows without bound."""
    roll, pitch, _ = np.moveaxis(C_b_n_to_euler(np.asarray(C_b_n, dtype=float)), -1, 0)
    sr, cr, tp, cp = np.sin(roll), np.cos(roll), np.tan(pitch), np.cos(pitch)
    one, zero = np.ones_like(roll), np.zeros_like(roll)
    return np.stack([np.stack([one, sr * tp, cr * tp], -1), np.stack([zero, cr, -sr], -1),
                     np.stack([zero, sr / cp, cr / cp], -1)], -2)


def euler_covariance(C_b_n: np.ndarray, cov_rot_b: np.ndarray) -> np.ndarray:
    """Covariance (…,3,3), rad^2, of roll, pitch, yaw of attitudes ``C_b_n`` whose error covariance is
    ``cov_rot_b`` (…,3,3), rad^2, in GTSAM's right perturbation (body axes); first order."""
    J = euler_jacobian(C_b_n)
    return J @ np.asarray(cov_rot_b, dtype=float) @ np.swapaxes(J, -1, -2)


def yaw_jacobian(C_b_n: np.ndarray) -> np.ndarray:
    """``d yaw / d theta`` (…,3) of body-to-NED rotations for a right perturbation ``C = C_hat Exp(theta)``
    (theta in body axes, rad): the row that turns a body-frame attitude covariance into a heading variance.
    Near +-90 deg pitch the yaw is undefined and the row grows without bound."""
    R = np.asarray(C_b_n, dtype=float)
    c = R[..., 0, 0] ** 2 + R[..., 1, 0] ** 2
    J = np.stack([np.zeros_like(c), R[..., 1, 0] * R[..., 0, 2] - R[..., 0, 0] * R[..., 1, 2],
                  R[..., 0, 0] * R[..., 1, 1] - R[..., 1, 0] * R[..., 0, 1]], axis=-1)
    return J / c[..., None]


def heading_variance(C_b_n: np.ndarray, cov_rot_b: np.ndarray) -> np.ndarray:
    """Heading (yaw) variance, rad^2, shape (…), of attitudes ``C_b_n`` (…,3,3) whose error covariance is
    ``cov_rot_b`` (…,3,3), rad^2, in GTSAM's right perturbation (body axes)."""
    J = yaw_jacobian(C_b_n)
    return np.einsum("...i,...ij,...j->...", J, np.asarray(cov_rot_b, dtype=float), J)


def _quat_mul(q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Hamilton products q * r of scalar-last quaternions (scipy's layout), vectorised over rows."""
    x1, y1, z1, w1 = np.moveaxis(q, -1, 0)
    x2, y2, z2, w2 = np.moveaxis(r, -1, 0)
    return np.stack([w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
                     w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2], axis=-1)


def cumulative_quat_product(steps: np.ndarray) -> np.ndarray:
    """(N+1,4) running products ``identity, s0, s0 s1, ...`` of (N,4) scalar-last quaternions.

    A Hillis-Steele scan: log2(N) vectorised passes instead of a Python loop over samples (the product
    is associative), so 40 000 IMU steps take milliseconds.
    """
    q = np.concatenate([[[0.0, 0.0, 0.0, 1.0]], np.asarray(steps, float)])
    d = 1
    while d < len(q):
        q = np.concatenate([q[:d], _quat_mul(q[:-d], q[d:])])
        d *= 2
    return q / np.linalg.norm(q, axis=1, keepdims=True)
