"""The DVL beam measurement model and its Jacobians, written once for every estimator.

A beam measures the velocity of the DVL head along its unit vector (``../shared/docs/method.md`` plus the
lever arm and the DVL error states)::

    v_head_b = C_b_n^T v_n + (omega_b - b_g) x l_b          DVL-head velocity, body frame, m/s
    v_d      = C_d_b^T v_head_b                             the same in the DVL frame
    h_i      = T_d[i] ((1 + s) * v_d) + b_i                 beam i, m/s

with ``C_b_n`` the body-to-NED attitude, ``v_n`` the NED velocity of the IMU, ``omega_b`` the raw gyro rate at
the ping (rad/s), ``b_g`` the gyro bias (rad/s), ``l_b`` the lever arm (m, body frame), ``T_d[i]`` beam i's unit
vector in the DVL frame, and the DVL error states: ``s`` (3,) scale factor per DVL axis (unitless) and ``b``
(4,) bias per beam (m/s). Without error states (s = b = 0) a row is the body-frame unit vector
``T_b[i] = T_d[i] C_d_b^T``; a row may be any vector (the identity rows give the loosely coupled body
velocity).

A **DVL-frame velocity** measured by the instrument itself (a 3-beam solution, a velocity-only DVL) is the same
model with the identity as ``T_d`` (body rows ``C_d_b^T``, :meth:`BeamModel.dvl_velocity`): row j measures
``(1 + s_j) v_d[j]``; its rows carry beam number -1, so that no beam bias acts on them.

Jacobians (row form; ``M`` = the effective rows ``T_d[i] diag(1 + s) C_d_b^T``, or the rows themselves
without error states; ``[a]x`` the skew matrix)::

    d/dtheta = M [C^T v_n]x       attitude, right perturbation C Exp(theta) (GTSAM's Rot3 convention)
    d/dv_n   = M C^T
    d/db_g   = M [l_b]x
    d/dl_b   = M [omega_b - b_g]x
    d/ds     = T_d[i] * v_d        (elementwise)
    d/db     = e_i                 (the row's beam; zero for a DVL-axis row, beam number -1)

Shapes: ``rows`` (R,3). State arguments are one state (``C_b_n`` (3,3), vectors (3,), DVL errors (7,)), one
state per row (``C_b_n`` (R,3,3), vectors (R,3), (R,7)), or one per ping broadcast over the rows (vectors
(N,1,3) with one ``C_b_n``, outputs (N,R)). The one-state path uses plain matrix products: it runs inside
every GTSAM factor call.
"""
from __future__ import annotations

import numpy as np

#: Dimension of the DVL error-state vector ``[scale x, y, z, bias beam 1..4]``.
N_DVL_ERRORS = 7


def skew3(w: np.ndarray) -> np.ndarray:
    """``[w]x`` of one 3-vector (faster than graphnav.core.rotations.skew for a single vector)."""
    x, y, z = w.tolist()
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis, broadcasting (np.cross costs ~10 us even on 3-vectors)."""
    if a.ndim == 1 and b.ndim == 1:
        a0, a1, a2 = a.tolist()
        b0, b1, b2 = b.tolist()
        return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _rows_cross(M: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Rows ``M_r [w]x`` (= M_r x w): (R,3) with one w (3,) or one w per row."""
    return M @ skew3(w) if w.ndim == 1 else _cross(M, w)


def _rows_dot(M: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``M_r . w``: (R,) with one w, (R,) with one w per row, (N,R) with w (N,1,k)."""
    return M @ w if w.ndim == 1 else np.einsum("...i,...i->...", M, w)     # 6x faster than sum(M * w)


def _to_body(C_b_n: np.ndarray, v_n: np.ndarray) -> np.ndarray:
    """``C_b_n^T v_n`` for one or many (C, v) pairs."""
    if C_b_n.ndim == 2:
        return C_b_n.T @ v_n if v_n.ndim == 1 else v_n @ C_b_n
    return np.einsum("...ji,...j->...i", C_b_n, v_n)


class BeamPrediction:
    """Predicted beams ``h`` (m/s) at one state, and the Jacobian blocks on demand (see the module docstring).

    Attributes:
        h: (R,) predicted beams, m/s ((N,R) for per-ping states).
        v_body: C_b_n^T v_n, m/s. rate: omega_b - b_g, rad/s. v_d: DVL-head velocity in the DVL frame (with
            error states, else None). M: (R,3) effective rows.
    """

    __slots__ = ("model", "C_b_n", "v_body", "rate", "lever_arm_b", "M", "v_d", "h")

    def __init__(self, model, C_b_n, v_body, rate, lever_arm_b, M, v_d, h):
        self.model, self.C_b_n, self.v_body, self.rate, self.lever_arm_b = model, C_b_n, v_body, rate, lever_arm_b
        self.M, self.v_d, self.h = M, v_d, h

    def d_rot(self) -> np.ndarray:
        """(R,3) d h / d theta, attitude ``C_b_n Exp(theta)`` (right perturbation, body axes), m/s/rad."""
        return _rows_cross(self.M, self.v_body)

    def d_v(self) -> np.ndarray:
        """(R,3) d h / d v_n (NED velocity), unitless."""
        C = self.C_b_n
        return self.M @ C.T if C.ndim == 2 else np.einsum("...ij,...j->...i", C, self.M)

    def d_gyro_bias(self) -> np.ndarray:
        """(R,3) d h / d b_g, m/s per rad/s (= m)."""
        return _rows_cross(self.M, self.lever_arm_b)

    def d_lever_arm(self) -> np.ndarray:
        """(R,3) d h / d l_b, 1/s."""
        return _rows_cross(self.M, self.rate)

    def d_dvl_errors(self) -> np.ndarray:
        """(R,7) d h / d [s (3), b (4)]: m/s and unitless."""
        model = self.model
        if model.rows_d is None:
            raise ValueError("this beam model has no DVL error states (made without beam_index / C_d_b)")
        J_s = model.rows_d * self.v_d
        onehot = model.onehot if J_s.ndim == 2 else np.broadcast_to(model.onehot, J_s.shape[:-1] + (4,))
        return np.concatenate([J_s, onehot], axis=-1)


class BeamModel:
    """The beam model of a fixed set of rows (see the module docstring).

    Args:
        rows_b: (R,3) body-frame beam unit vectors (rows of :attr:`graphnav.core.dvl.DvlGeometry.T_b`), or the
            identity for the loosely coupled body velocity.
        beam_index: (R,) beam number 0..3 of each row: with ``C_d_b``, the DVL error states act on the rows;
            -1 marks a DVL-axis row (a measured DVL-frame velocity component): the scale acts on it, no beam
            bias does.
        C_d_b: (3,3) DVL-to-body rotation (the scale factor acts on the DVL-frame axes).
    """

    def __init__(self, rows_b: np.ndarray, beam_index: np.ndarray | None = None, C_d_b: np.ndarray | None = None):
        self.rows_b = np.array(rows_b, dtype=float).reshape(-1, 3)
        n = len(self.rows_b)
        self.rows_d = self.onehot = self.C_d_b = None
        if (beam_index is None) != (C_d_b is None):
            raise ValueError("the DVL error states need both beam_index and C_d_b")
        if beam_index is not None:
            index = np.asarray(beam_index, dtype=int).reshape(-1)
            if index.shape[0] != n or np.any((index < -1) | (index > 3)):
                raise ValueError(f"beam_index must hold one beam number 0..3 (or -1 for a DVL-axis row) per row, "
                                 f"got {index.tolist()}")
            self.C_d_b = np.asarray(C_d_b, dtype=float).reshape(3, 3)
            self.rows_d = self.rows_b @ self.C_d_b          # T_d rows: T_b = T_d C_d_b^T
            self.onehot = np.zeros((n, 4))
            beam = index >= 0
            self.onehot[np.flatnonzero(beam), index[beam]] = 1.0

    @classmethod
    def dvl_velocity(cls, C_d_b: np.ndarray, dvl_errors: bool = False) -> "BeamModel":
        """The model of a DVL-frame velocity ``v_d`` (3,) m/s measured by the instrument: the beam model with
        ``T_d`` = identity (body rows ``C_d_b^T``); with ``dvl_errors`` the scale per DVL axis acts on its rows
        and no beam bias does (beam number -1)."""
        C_d_b = np.asarray(C_d_b, dtype=float).reshape(3, 3)
        return cls(C_d_b.T, np.full(3, -1), C_d_b) if dvl_errors else cls(C_d_b.T)

    @property
    def has_dvl_errors(self) -> bool:
        return self.rows_d is not None

    def linearize_one(self, C_b_n: np.ndarray, v_n: np.ndarray, omega_b: np.ndarray, gyro_bias: np.ndarray,
                      lever_arm_b: np.ndarray, dvl_errors: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """At one state: ``(h (R,), J (R,9), J_d (R,7) or None)`` with ``J = [d_rot | d_v | d_gyro_bias]``, the
        prediction and the blocks of :class:`BeamPrediction` in one pass (what a GTSAM factor needs at each
        linearisation: the three blocks come from one product ``M [[C^T v_n]x | C^T | [l_b]x]``). Arguments as
        :meth:`predict`, one state only (``C_b_n`` (3,3), vectors (3,), ``dvl_errors`` (7,))."""
        Ct = C_b_n.T
        v_body = Ct @ v_n
        rate = omega_b - gyro_bias
        v_head = v_body + _cross(rate, lever_arm_b)
        (c00, c01, c02), (c10, c11, c12), (c20, c21, c22) = Ct.tolist()
        bx, by, bz = v_body.tolist()
        lx, ly, lz = lever_arm_b.tolist()
        K = np.array([[0.0, -bz, by, c00, c01, c02, 0.0, -lz, ly],
                      [bz, 0.0, -bx, c10, c11, c12, lz, 0.0, -lx],
                      [-by, bx, 0.0, c20, c21, c22, -ly, lx, 0.0]])
        if self.rows_d is None:
            if dvl_errors is not None:
                raise ValueError("DVL error states given to a beam model made without beam_index / C_d_b")
            M = self.rows_b
            return M @ v_head, M @ K, None
        v_d = v_head @ self.C_d_b
        J_d = np.concatenate([self.rows_d * v_d, self.onehot], axis=1)
        if dvl_errors is None:
            M = self.rows_b
            return M @ v_head, M @ K, J_d
        d = np.asarray(dvl_errors, dtype=float)
        M = (self.rows_d * (1.0 + d[:3])) @ self.C_d_b.T
        return M @ v_head + self.onehot @ d[3:], M @ K, J_d

    def predict(self, C_b_n: np.ndarray, v_n: np.ndarray, omega_b: np.ndarray, gyro_bias: np.ndarray,
                lever_arm_b: np.ndarray, dvl_errors: np.ndarray | None = None) -> BeamPrediction:
        """Predicted beams at a state (shapes in the module docstring).

        Args:
            C_b_n: body-to-NED attitude. v_n: NED velocity of the IMU, m/s. omega_b: raw gyro rate at the ping,
                rad/s. gyro_bias: rad/s. lever_arm_b: DVL position relative to the IMU, body frame, m.
            dvl_errors: [s (3), b (4)] (unitless, m/s); only with a model made with ``beam_index``/``C_d_b``
                (None there means zero).
        """
        v_body = _to_body(C_b_n, v_n)
        rate = omega_b - gyro_bias
        v_head = v_body + _cross(rate, lever_arm_b)
        if self.rows_d is None:
            if dvl_errors is not None:
                raise ValueError("DVL error states given to a beam model made without beam_index / C_d_b")
            M = self.rows_b
            return BeamPrediction(self, C_b_n, v_body, rate, lever_arm_b, M, None, _rows_dot(M, v_head))
        v_d = v_head @ self.C_d_b                           # row form of C_d_b^T v_head
        if dvl_errors is None:
            M, h = self.rows_b, _rows_dot(self.rows_b, v_head)
        else:
            d = np.asarray(dvl_errors, dtype=float)
            M = (self.rows_d * (1.0 + d[..., :3])) @ self.C_d_b.T
            h = _rows_dot(M, v_head) + _rows_dot(self.onehot, d[..., 3:])
        return BeamPrediction(self, C_b_n, v_body, rate, lever_arm_b, M, v_d, h)
