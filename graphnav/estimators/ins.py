"""Strapdown inertial navigation in a local NED frame, vectorised over IMU samples.

Mechanisation (the shared IMU model, consistent with GTSAM's preintegration with
``omegaCoriolis = earth_rate_n`` and ``use2ndOrderCoriolis=False``; transport rate neglected):

- attitude  ``dC_b_n/dt = C_b_n [omega_ib_b - b_g]x - [omega_ie_n]x C_b_n``
- velocity  ``dv_n/dt = C_b_n (f_b - b_a) + g_n - 2 omega_ie_n x v_n``
- position  ``dp_n/dt = v_n``

IMU samples are held constant over the segment that starts at their stamp (zero-order hold, GTSAM's
convention): sample k drives ``[t_k, t_{k+1})``. A segment may be split where an aiding measurement falls
between two IMU stamps (:func:`segment_timeline`), so estimators can stop at arbitrary DVL stamps.

Speed: within one propagation call the biases are constant, so the body rotation increments do not depend
on the state. They are computed for all segments at once and chained by a parallel prefix product; the
Earth-rate rotation, constant in n, factors out exactly on the left:
``C_j = Exp(-omega_ie_n tau_j) C_0 D_0 ... D_{j-1}`` with ``D_i = Exp((omega_i - b_g) dt_i)``.
Velocity is a cumulative sum; the Coriolis term (``2 |omega_ie| |v|`` ~ 3e-4 m/s^2) is evaluated on the
velocity integrated without it, an error of order ``(2 |omega_ie| T)^2`` (< 1e-7 relative over 1000 s).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.earth import earth_rate_n
from graphnav.core.mission import ImuData
from graphnav.core.rotations import so3_exp_batch


@dataclass
class StrapdownState:
    """Nominal navigation state of the IMU.

    Attributes:
        t: time, s (IMU clock).
        C_b_n: (3,3) body-to-NED rotation.
        v_n: (3,) NED velocity, m/s.
        p_n: (3,) NED position, m.
    """

    t: float
    C_b_n: np.ndarray
    v_n: np.ndarray
    p_n: np.ndarray

    def copy(self) -> "StrapdownState":
        return StrapdownState(self.t, self.C_b_n.copy(), self.v_n.copy(), self.p_n.copy())


@dataclass
class PropagationPath:
    """Nominal quantities at the start of every propagated segment (for the error-state propagation).

    Attributes:
        C_b_n: (n,3,3) attitude at each segment start.
        f_n: (n,3) bias-corrected specific force rotated to NED, m/s^2.
        v_n: (n,3) velocity at each segment start, m/s.
        p_n: (n,3) position at each segment start, m.
        dt: (n,) segment lengths, s.
    """

    C_b_n: np.ndarray
    f_n: np.ndarray
    v_n: np.ndarray
    p_n: np.ndarray
    dt: np.ndarray


def prefix_products(D: np.ndarray) -> np.ndarray:
    """Inclusive ordered products ``P_j = D_0 D_1 ... D_j`` of (n,k,k) matrices (Hillis-Steele scan)."""
    P = np.array(D, dtype=float, copy=True)
    shift = 1
    while shift < len(P):
        P[shift:] = P[:-shift] @ P[shift:]
        shift *= 2
    return P


def segment_timeline(imu_t: np.ndarray, event_t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split the IMU timeline at event stamps (e.g. DVL pings) that fall between IMU samples.

    Args:
        imu_t: (N,) increasing IMU stamps, s.
        event_t: (M,) increasing event stamps inside ``[imu_t[0], imu_t[-1]]``, s; the first event is where
            the timeline starts (e.g. the filter's initial epoch).

    Returns:
        (seg_t (S,) segment start stamps, seg_imu (S,) index of the IMU sample that drives each segment
        (zero-order hold: the last sample at or before the segment start), event_seg (M,) index of the
        segment that starts at each event, so that segments ``event_seg[m-1]:event_seg[m]`` lead from event
        m-1 to event m). The timeline ends at the last IMU stamp; ``seg_dt = diff(append(seg_t, imu_t[-1]))``.
    """
    imu_t = np.asarray(imu_t, dtype=float)
    event_t = np.asarray(event_t, dtype=float)
    if event_t[0] < imu_t[0] or event_t[-1] > imu_t[-1]:
        raise ValueError("events must lie inside the IMU time span")
    nodes = np.union1d(imu_t[imu_t >= event_t[0]], event_t)
    seg_t = nodes[:-1]
    seg_imu = np.searchsorted(imu_t, seg_t, side="right") - 1
    event_seg = np.searchsorted(nodes, event_t)
    return seg_t, seg_imu, event_seg


def segment_specific_force(imu_t: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray, seg_t: np.ndarray,
                           seg_imu: np.ndarray) -> np.ndarray:
    """Specific force (S,3) of each segment, in the body axes at the segment start, m/s^2.

    An IMU sample is an increment with the body axes frozen at its own stamp t_k. A segment that starts at a
    split point ``t_k + a`` (an event between two IMU stamps) sees the body already rotated by
    ``D_a = Exp(omega_k a)``; expressing the sample in the rotated axes, ``D_a^T f_k``, makes the split
    propagation equal the unsplit one (to the gyro-bias and Earth-rate cross terms, ~1e-9).
    """
    seg_imu = np.asarray(seg_imu)
    f = np.asarray(f_b, dtype=float)[seg_imu].copy()
    lag = np.asarray(seg_t, dtype=float) - np.asarray(imu_t, dtype=float)[seg_imu]
    split = np.flatnonzero(lag > 0)
    if split.size:
        D = so3_exp_batch(np.asarray(omega_b, dtype=float)[seg_imu[split]] * lag[split, None])
        f[split] = np.einsum("nji,nj->ni", D, f[split])
    return f


class Strapdown:
    """Strapdown propagation with a given gravity and Earth rate (NED).

    Args:
        gravity_n: (3,) gravity in NED, m/s^2.
        omega_ie_n: (3,) Earth rate in NED, rad/s (zeros to ignore Earth rotation).
    """

    def __init__(self, gravity_n: np.ndarray, omega_ie_n: np.ndarray):
        self.gravity_n = np.asarray(gravity_n, dtype=float).reshape(3)
        self.omega_ie_n = np.asarray(omega_ie_n, dtype=float).reshape(3)

    @classmethod
    def from_config(cls, config: SensorConfig) -> "Strapdown":
        rate = earth_rate_n(config.lat_rad) if config.earth_rotation else np.zeros(3)
        return cls(np.array([0.0, 0.0, config.gravity_mps2]), rate)

    def propagate(self, state: StrapdownState, f_b: np.ndarray, omega_b: np.ndarray, dt: np.ndarray,
                  bias_acc: np.ndarray | None = None, bias_gyro: np.ndarray | None = None,
                  ) -> tuple[StrapdownState, PropagationPath]:
        """Propagate over n zero-order-hold segments.

        Args:
            state: state at the start of the first segment.
            f_b: (n,3) specific force, m/s^2, body; omega_b: (n,3) angular rate, rad/s, body.
            dt: (n,) segment lengths, s.
            bias_acc, bias_gyro: (3,) bias estimates subtracted from the samples (m/s^2, rad/s).

        Returns:
            (state at the end, :class:`PropagationPath` at the segment starts).
        """
        dt = np.asarray(dt, dtype=float)
        n = len(dt)
        if n == 0:
            empty = np.zeros((0, 3))
            return state.copy(), PropagationPath(np.zeros((0, 3, 3)), empty, empty, empty, dt)
        ba = np.zeros(3) if bias_acc is None else bias_acc
        bg = np.zeros(3) if bias_gyro is None else bias_gyro
        # attitude at every segment boundary (n+1)
        D = so3_exp_batch((omega_b - bg) * dt[:, None])
        P = prefix_products(D)
        body = np.concatenate([np.eye(3)[None], P], axis=0)
        tau = np.concatenate([[0.0], np.cumsum(dt)])
        earth = so3_exp_batch(-tau[:, None] * self.omega_ie_n)
        C_all = earth @ (state.C_b_n @ body)
        C = C_all[:n]
        f_n = np.einsum("nij,nj->ni", C, f_b - ba)
        a0 = f_n + self.gravity_n
        v0 = state.v_n + np.concatenate([np.zeros((1, 3)), np.cumsum(a0 * dt[:, None], axis=0)])
        a = a0 - 2.0 * np.cross(self.omega_ie_n, v0[:n])
        dv = a * dt[:, None]
        v_all = state.v_n + np.concatenate([np.zeros((1, 3)), np.cumsum(dv, axis=0)])
        dp = v_all[:n] * dt[:, None] + 0.5 * dv * dt[:, None]
        p_all = state.p_n + np.concatenate([np.zeros((1, 3)), np.cumsum(dp, axis=0)])
        end = StrapdownState(state.t + tau[-1], _orthonormalise(C_all[-1]), v_all[-1], p_all[-1])
        return end, PropagationPath(C, f_n, v_all[:n], p_all[:n], dt)


def _orthonormalise(C: np.ndarray) -> np.ndarray:
    """Nearest rotation matrix (removes rounding drift accumulated by long products)."""
    u, _, vt = np.linalg.svd(C)
    return u @ vt


def integrate(imu: ImuData, config: SensorConfig, initial: StrapdownState,
              bias_acc: np.ndarray | None = None, bias_gyro: np.ndarray | None = None,
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Free-inertial integration of a whole IMU record from ``initial`` (at ``imu.t[0]``).

    Returns:
        (t (N,) s, C_b_n (N,3,3), v_n (N,3) m/s, p_n (N,3) m) at the IMU stamps.
    """
    strapdown = Strapdown.from_config(config)
    dt = np.diff(imu.t)
    end, path = strapdown.propagate(initial, imu.f_b[:-1], imu.omega_b[:-1], dt, bias_acc, bias_gyro)
    C = np.concatenate([path.C_b_n, end.C_b_n[None]])
    v = np.concatenate([path.v_n, end.v_n[None]])
    p = np.concatenate([path.p_n, end.p_n[None]])
    return imu.t.copy(), C, v, p
