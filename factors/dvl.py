"""DVL factors for GTSAM: tightly coupled beam factors and a loosely coupled body-velocity factor.

Measurement model (``../shared/docs/method.md`` plus the lever arm): a beam i measures the velocity of the
DVL head along its unit vector,

    y_i = b_i^T C_d_b^T (R^T v_n + (omega_b - b_g) x l_b) + noise,

with ``R`` = ``C_b_n`` the attitude of Pose3 ``x_k``, ``v_n`` the NED velocity ``v_k`` (Vector3), ``b_g`` the
gyro part of the IMU bias ``b_k`` (imuBias.ConstantBias, tangent ``[acc, gyro]``), ``omega_b`` the raw body
rate at the DVL stamp (rad/s, :func:`graphnav.estimators.keyframes.gyro_at`; the Earth rate already removed
by the caller if wanted),
``l_b`` the lever arm (m, body frame) and ``b_i^T C_d_b^T`` = row i of :attr:`graphnav.core.dvl.DvlGeometry.T_b`.

One factor may hold any number m of beams (rows); per-beam sigmas go in a diagonal noise model, so the
same code serves "one factor per beam" (m = 1) and "one factor per epoch" (m = number of valid beams).
The loosely coupled factor is the same model with the identity as its rows (3 rows, the DVL-head body
velocity). A DVL-frame velocity the instrument measured itself (:func:`dvl_velocity_factor`: a velocity-only
DVL, a 3-beam solution, an earth/ship-frame log) is the model with ``T_d`` = identity (body rows ``C_d_b^T``):
``y = (1 + s) * C_d_b^T (R^T v_n + (omega_b - b_g) x l_b)``, the scale per DVL axis with the DVL error states,
no beam bias.

The model and its Jacobians are :mod:`graphnav.core.beam_model` (written once, also used by the vectorised
batch and the EKF); here they are placed in GTSAM's tangent layouts: right perturbation ``R Exp(dtheta)``,
Pose3 tangent ``[rot, trans]``, bias tangent ``[acc, gyro]``, Point3 lever arm, Vector7 DVL error states
``d = [s (3), b (4)]`` (scale factor per DVL axis, bias per beam; beam model ``y_i = T_d[i] ((1 + s) * v_d) +
b_i``, as the EKF's ``dvl_error_states``). One builder, :func:`dvl_factor`, makes every variant (fixed or
variable lever arm, with or without the DVL error states); the other builders name its common uses.

``gtsam.CustomFactor`` calls back into Python; inside the C++ optimisers each call also copies the whole
``Values`` (pybind11 casts the ``const Values&`` argument by copy), so the cost of one call grows with the
number of variables. Fewer, larger factors (one per ping, a per-row Huber kernel: :func:`beam_noise`) are
therefore preferred, and a call reads each variable once and takes the prediction and every Jacobian from one
pass of the beam model.
"""
from __future__ import annotations

import gtsam
import numpy as np

from graphnav.core.beam_model import N_DVL_ERRORS, BeamModel

__all__ = ["N_DVL_ERRORS", "beam_difference_factor", "beam_factor", "beam_factor_dvl_errors", "beam_factor_lever_arm",
           "beam_noise", "body_velocity_factor", "dvl_factor", "dvl_velocity_factor", "predict_beams"]


def beam_noise(sigmas: np.ndarray, huber_k: float | None = None, per_row: bool = False) -> gtsam.noiseModel.Base:
    """Diagonal noise model with per-row sigmas (m/s), optionally wrapped in a Huber kernel (threshold k, in
    sigmas).

    The kernel weighs the whole whitened residual by its norm (GTSAM's ``Block`` reweighting: one measurement
    of several rows, e.g. a DVL-frame velocity), or with ``per_row`` each row by its own whitened error
    (``Scalar`` reweighting): one factor over the m beams of a ping then linearises to exactly the rows of m
    one-beam Huber factors, so a bad beam does not down-weight the good ones of its ping. What differs is the
    factor's nonlinear error (GTSAM's robust loss of the residual's norm), which the incremental solvers do not
    use; an optimiser that accepts steps by that error (Levenberg-Marquardt) needs one factor per beam.
    """
    base = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(sigmas, dtype=float))
    if huber_k is None:
        return base
    scheme = gtsam.noiseModel.mEstimator.Base.ReweightScheme
    return gtsam.noiseModel.Robust.Create(
        gtsam.noiseModel.mEstimator.Huber.Create(float(huber_k), scheme.Scalar if per_row else scheme.Block), base)


def predict_beams(rows_b: np.ndarray, C_b_n: np.ndarray, v_n: np.ndarray, omega_b: np.ndarray,
                  gyro_bias: np.ndarray, lever_arm_b: np.ndarray) -> np.ndarray:
    """Predicted measurements ``B (R^T v_n + (omega_b - b_g) x l_b)`` (m,), m/s (no DVL error states)."""
    return BeamModel(rows_b).predict(np.asarray(C_b_n, float), np.asarray(v_n, float), np.asarray(omega_b, float),
                                     np.asarray(gyro_bias, float), np.asarray(lever_arm_b, float)).h


def dvl_factor(x_key: int, v_key: int, b_key: int, rows_b: np.ndarray, y: np.ndarray,
               noise: gtsam.noiseModel.Base | np.ndarray, omega_b: np.ndarray,
               lever_arm_b: np.ndarray | None = None, *, l_key: int | None = None, d_key: int | None = None,
               beam_index: np.ndarray | None = None, C_d_b: np.ndarray | None = None) -> gtsam.CustomFactor:
    """DVL factor on (Pose3 x, Vector3 v_n, ConstantBias b [, Vector7 d] [, Point3 l]) for m rows.

    Args:
        x_key, v_key, b_key: keys of the pose, NED velocity and IMU bias.
        rows_b: (m,3) beam unit vectors in the body frame (rows of ``DvlGeometry.T_b``), or I3 for LC.
        y: (m,) measured beam velocities of the DVL head, m/s (or the 3 body-velocity components).
        noise: a gtsam noise model of dimension m, or (m,) sigmas in m/s.
        omega_b: (3,) raw body rate at the ping, rad/s.
        lever_arm_b: (3,) DVL position relative to the IMU, body frame, m (fixed); or
        l_key: key of a Point3 lever-arm variable (body frame, m), for lever-arm calibration.
        d_key: key of the Vector7 DVL error states [scale (3), beam bias (4) m/s]; needs
        beam_index: (m,) 0-based beam number of each row (which bias applies; -1: a DVL-axis row, no bias) and
        C_d_b: (3,3) DVL-to-body rotation (the scale factor acts on the DVL-frame axes).

    Keys (and Jacobians) in the order x, v, b, d, l.
    """
    B = np.array(rows_b, dtype=float).reshape(-1, 3)
    y = np.array(y, dtype=float).reshape(-1)
    if B.shape[0] != y.shape[0]:
        raise ValueError(f"{B.shape[0]} beam rows but {y.shape[0]} measurements")
    if (lever_arm_b is None) == (l_key is None):
        raise ValueError("give either a fixed lever_arm_b or a lever-arm variable l_key")
    if (d_key is None) != (beam_index is None):
        raise ValueError("the DVL error states need both d_key and beam_index")
    if not isinstance(noise, gtsam.noiseModel.Base):
        noise = beam_noise(noise)
    model = BeamModel(B, beam_index, C_d_b) if d_key is not None else BeamModel(B)
    omega = np.array(omega_b, dtype=float).reshape(3)
    lever = None if lever_arm_b is None else np.array(lever_arm_b, dtype=float).reshape(3)
    zeros = np.zeros((B.shape[0], 3))
    keys = [x_key, v_key, b_key] + ([d_key] if d_key is not None else []) + ([l_key] if l_key is not None else [])
    if l_key is None:
        return gtsam.CustomFactor(noise, keys, _fixed_lever_arm_error(model, x_key, v_key, b_key, d_key, y, omega,
                                                                      lever))

    def error(_factor, values, H):
        p = model.predict(values.atPose3(x_key).rotation().matrix(), values.atVector(v_key), omega,
                          values.atConstantBias(b_key).gyroscope(),
                          lever if l_key is None else values.atPoint3(l_key),
                          None if d_key is None else values.atVector(d_key))
        if H is not None:
            H[0] = np.hstack([p.d_rot(), zeros])
            H[1] = p.d_v()
            H[2] = np.hstack([zeros, p.d_gyro_bias()])
            if d_key is not None:
                H[3] = p.d_dvl_errors()
            H[len(keys) - 1] = p.d_lever_arm()
        return p.h - y

    return gtsam.CustomFactor(noise, keys, error)


def _fixed_lever_arm_error(model: BeamModel, x_key: int, v_key: int, b_key: int, d_key: int | None, y: np.ndarray,
                           omega: np.ndarray, lever: np.ndarray):
    """The error callback of a DVL factor with a fixed lever arm (keys x, v, b [, d]): the GTSAM optimisers call
    it at every linearisation, so it reads each variable once and takes the prediction and all Jacobian blocks
    from one pass of :meth:`graphnav.core.beam_model.BeamModel.linearize_one`, written into GTSAM's tangent
    layouts (Pose3 ``[rot, trans]``, bias ``[acc, gyro]``)."""
    m = len(y)

    def error(_factor, values, H):
        R = values.atPose3(x_key).rotation().matrix()
        d = None if d_key is None else values.atVector(d_key)
        h, J, J_d = model.linearize_one(R, values.atVector(v_key), omega, values.atConstantBias(b_key).gyroscope(),
                                        lever, d)
        if H is not None:
            H_x = np.zeros((m, 6))
            H_x[:, :3] = J[:, :3]
            H_b = np.zeros((m, 6))
            H_b[:, 3:] = J[:, 6:]
            H[0] = H_x
            H[1] = J[:, 3:6]
            H[2] = H_b
            if d_key is not None:
                H[3] = J_d
        return h - y

    return error


def beam_factor(x_key: int, v_key: int, b_key: int, rows_b: np.ndarray, y: np.ndarray,
                noise: gtsam.noiseModel.Base | np.ndarray, omega_b: np.ndarray,
                lever_arm_b: np.ndarray) -> gtsam.CustomFactor:
    """DVL factor on (Pose3 x, Vector3 v_n, ConstantBias b) for m beams (:func:`dvl_factor`, fixed lever arm)."""
    return dvl_factor(x_key, v_key, b_key, rows_b, y, noise, omega_b, lever_arm_b)


def beam_factor_dvl_errors(x_key: int, v_key: int, b_key: int, d_key: int, rows_b: np.ndarray,
                           beam_index: np.ndarray, C_d_b: np.ndarray, y: np.ndarray,
                           noise: gtsam.noiseModel.Base | np.ndarray, omega_b: np.ndarray,
                           lever_arm_b: np.ndarray) -> gtsam.CustomFactor:
    """As :func:`beam_factor`, plus the DVL error states: Vector7 ``d_key`` = [scale (3), beam bias (4) m/s]
    (:func:`dvl_factor` with ``d_key``, ``beam_index``, ``C_d_b``)."""
    return dvl_factor(x_key, v_key, b_key, rows_b, y, noise, omega_b, lever_arm_b, d_key=d_key,
                      beam_index=beam_index, C_d_b=C_d_b)


def body_velocity_factor(x_key: int, v_key: int, b_key: int, v_dvl_b: np.ndarray,
                         noise: gtsam.noiseModel.Base | np.ndarray, omega_b: np.ndarray,
                         lever_arm_b: np.ndarray) -> gtsam.CustomFactor:
    """Loosely coupled factor: the DVL-head body velocity ``v_dvl_b`` (3,) m/s, residual 3 rows (the beam
    model with the identity as rows).

    ``noise`` is a 3-dimensional noise model (e.g. ``Gaussian.Covariance`` of the least-squares velocity)
    or (3,) sigmas in m/s.
    """
    return dvl_factor(x_key, v_key, b_key, np.eye(3), v_dvl_b, noise, omega_b, lever_arm_b)


def beam_factor_lever_arm(x_key: int, v_key: int, b_key: int, l_key: int, rows_b: np.ndarray,
                          y: np.ndarray, noise: gtsam.noiseModel.Base | np.ndarray,
                          omega_b: np.ndarray) -> gtsam.CustomFactor:
    """As :func:`beam_factor`, with the lever arm as a fourth variable (Point3 ``l_key``, body frame, m).

    For lever-arm calibration: put a (weak) prior on ``l_key`` and let the graph estimate it, or hold it
    constant (:func:`dvl_factor` with ``l_key``).
    """
    return dvl_factor(x_key, v_key, b_key, rows_b, y, noise, omega_b, l_key=l_key)


def dvl_velocity_factor(x_key: int, v_key: int, b_key: int, C_d_b: np.ndarray, v_d: np.ndarray,
                        noise: gtsam.noiseModel.Base | np.ndarray, omega_b: np.ndarray,
                        lever_arm_b: np.ndarray | None = None, *, l_key: int | None = None,
                        d_key: int | None = None) -> gtsam.CustomFactor:
    """A DVL-frame velocity measured by the instrument: residual (3,) ``(1 + s) * C_d_b^T (R^T v_n + (omega_b
    - b_g) x l_b) - v_d``, m/s (the beam model with ``T_d`` = identity, :meth:`graphnav.core.beam_model.BeamModel.
    dvl_velocity`).

    Args:
        x_key, v_key, b_key: keys of the pose, NED velocity and IMU bias.
        C_d_b: (3,3) DVL-to-body rotation.
        v_d: (3,) velocity of the DVL head in the DVL frame, m/s.
        noise: a 3-dimensional noise model, or (3,) sigmas per DVL axis, m/s.
        omega_b: (3,) raw body rate at the ping, rad/s.
        lever_arm_b: (3,) DVL position relative to the IMU, body frame, m (fixed); or ``l_key`` (Point3).
        d_key: key of the Vector7 DVL error states: the scale per DVL axis acts on the three rows, the beam
            biases do not (their Jacobian columns are zero).

    Keys (and Jacobians) in the order x, v, b, d, l.
    """
    C_d_b = np.asarray(C_d_b, dtype=float).reshape(3, 3)
    return dvl_factor(x_key, v_key, b_key, C_d_b.T, v_d, noise, omega_b, lever_arm_b, l_key=l_key, d_key=d_key,
                      beam_index=None if d_key is None else np.full(3, -1), C_d_b=None if d_key is None else C_d_b)


def beam_difference_factor(keys_prev: tuple, keys: tuple, rows_b: np.ndarray, y_prev: np.ndarray, y: np.ndarray,
                           phi: float, noise: gtsam.noiseModel.Base | np.ndarray, omega_prev_b: np.ndarray,
                           omega_b: np.ndarray, lever_arm_b: np.ndarray, *, beam_index: np.ndarray | None = None,
                           C_d_b: np.ndarray | None = None) -> gtsam.CustomFactor:
    """Beams whose errors are serially correlated, as a first-order Gauss-Markov process ``e_k = phi e_(k-1) + w_k``,
    seen at two consecutive keyframes: the whitened difference (Bryson and Henrikson's measurement differencing)

        r = (h_k - phi h_(k-1)) - (y_k - phi y_(k-1)),   r ~ N(0, var(w_k)),

    with ``h`` the beam model of :func:`dvl_factor` at each keyframe's state. In a smoother that holds both states
    this is exact: the errors ``e`` need no variables of their own. Used for regressed beams (a completer's
    errors stay off for many pings together), after one plain factor for the first ping of the run.

    Args:
        keys_prev, keys: (x, v, b) or, with the DVL error states, (x, v, b, d) keys of keyframes k-1 and k.
        rows_b: (m,3) body-frame unit vectors of the m beams (the same beams at both keyframes).
        y_prev, y: (m,) the beams at k-1 and k, m/s.
        phi: the Gauss-Markov coefficient ``exp(-dt / tau)`` (0 = independent errors: the plain factor at k).
        noise: an m-dimensional noise model, or (m,) sigmas of ``w_k`` (m/s).
        omega_prev_b, omega_b: (3,) body rates at the two pings (rad/s, as :func:`dvl_factor`).
        lever_arm_b: (3,) m.
        beam_index, C_d_b: with the DVL error states (a fourth key in each tuple), as :func:`dvl_factor`.

    Keys (and Jacobians) in the order keys_prev then keys.
    """
    B = np.array(rows_b, dtype=float).reshape(-1, 3)
    y_prev, y = (np.array(v, dtype=float).reshape(-1) for v in (y_prev, y))
    if not B.shape[0] == len(y_prev) == len(y):
        raise ValueError(f"{B.shape[0]} beam rows but {len(y_prev)} and {len(y)} measurements")
    with_d = len(keys) == 4
    if len(keys) != len(keys_prev) or len(keys) not in (3, 4) or with_d != (beam_index is not None):
        raise ValueError("give (x, v, b) keys at both keyframes, or (x, v, b, d) keys with beam_index")
    if not isinstance(noise, gtsam.noiseModel.Base):
        noise = beam_noise(noise)
    model = BeamModel(B, beam_index, C_d_b) if with_d else BeamModel(B)
    lever = np.array(lever_arm_b, dtype=float).reshape(3)
    states = [(tuple(int(k) for k in keys_prev), np.array(omega_prev_b, dtype=float).reshape(3), -float(phi)),
              (tuple(int(k) for k in keys), np.array(omega_b, dtype=float).reshape(3), 1.0)]
    z = y - phi * y_prev
    m = B.shape[0]

    def error(_factor, values, H):
        r = -z
        for i, (ks, omega, w) in enumerate(states):
            R = values.atPose3(ks[0]).rotation().matrix()
            d = values.atVector(ks[3]) if with_d else None
            h, J, J_d = model.linearize_one(R, values.atVector(ks[1]), omega,
                                            values.atConstantBias(ks[2]).gyroscope(), lever, d)
            r = r + w * h
            if H is not None:
                n = len(ks)
                H_x = np.zeros((m, 6))
                H_x[:, :3] = w * J[:, :3]
                H_b = np.zeros((m, 6))
                H_b[:, 3:] = w * J[:, 6:]
                H[i * n], H[i * n + 1], H[i * n + 2] = H_x, w * J[:, 3:6], H_b
                if with_d:
                    H[i * n + 3] = w * J_d
        return r

    return gtsam.CustomFactor(noise, [*states[0][0], *states[1][0]], error)
