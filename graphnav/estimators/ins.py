"""Strapdown inertial navigation in the fixed NED tangent frame of the Earth model, vectorised over IMU samples.

Mechanisation (exact in an Earth-fixed tangent frame, see :mod:`graphnav.core.earth`; the same model as GTSAM's
preintegration with ``omegaCoriolis = earth_rate_n``, ``use2ndOrderCoriolis=False`` and the gravity of the
keyframe's position):

- attitude  ``dC_b_n/dt = C_b_n [omega_ib_b - b_g]x - [omega_ie_n]x C_b_n``
- velocity  ``dv_n/dt = C_b_n (f_b - b_a) + g_n(p_n) - 2 omega_ie_n x v_n``
- position  ``dp_n/dt = v_n``

No transport rate: the axes do not turn with the vehicle. ``g_n(p_n)`` is the plumb-bob gravity at the
position (it tilts by ``|p_h|/R`` and grows with depth); a constant ``[0, 0, g]`` costs ~17 m in 400 s at 2 m/s.

IMU samples are held constant over the segment that starts at their stamp (zero-order hold, GTSAM's
convention, :class:`graphnav.core.mission.ImuData`): sample k drives ``[t_k, t_{k+1})``. A segment may be split
where an aiding measurement falls between two IMU stamps (:func:`segment_timeline`), so estimators can stop at
arbitrary DVL stamps.

Speed: within one propagation call the biases are constant, so the body rotation increments do not depend
on the state. They are computed for all segments at once and chained by a parallel prefix product; the
Earth-rate rotation, constant in n, factors out exactly on the left:
``C_j = Exp(-omega_ie_n tau_j) C_0 D_0 ... D_{j-1}`` with ``D_i = Exp((omega_i - b_g) dt_i)``.
Velocity and position are cumulative sums over stretches of at most ``Strapdown.CHUNK_S``; gravity and the
Coriolis term, which depend on the path, are evaluated on the previous pass's path until it stops moving
(a fixed point that converges in 2-3 passes per stretch; one pass over a whole 400 s record would leave
errors of ``(2 |omega_ie| T)`` ~ 6 % of the Coriolis term).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.earth import EarthModel
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
    """Strapdown propagation in the fixed tangent frame of an :class:`~graphnav.core.earth.EarthModel`.

    Args:
        earth: the Earth model (position-dependent gravity, Earth rate).
    """

    #: longest stretch integrated in one pass of the velocity/position fixed point, s: keeps the gravity and
    #: Coriolis terms, evaluated on the previous pass's path, converged in 2-3 passes whatever the call length
    CHUNK_S = 10.0
    #: position change between two passes below which a chunk has converged, m
    CONVERGED_M = 1e-7
    #: the gravity gradient is re-evaluated when a stretch starts this far from where it was last, m: it changes
    #: by ~1e-9 s^-2 per km (g / R^2), so reusing it moves the gravity of a stretch by < 1e-10 m/s^2, while an
    #: evaluation is six Earth-model round trips (a third of the strapdown's time at one keyframe per second)
    GRADIENT_REUSE_M = 100.0

    def __init__(self, earth: EarthModel):
        self.earth = earth
        self.omega_ie_n = earth.omega_ie_n
        self._gradient: tuple[np.ndarray, np.ndarray] | None = None    # (where, d g_n / d p_n)

    @classmethod
    def from_config(cls, config: SensorConfig) -> "Strapdown":
        return cls(EarthModel.from_config(config))

    @property
    def gravity_n(self) -> np.ndarray:
        """Gravity at the origin of the navigation frame, (3,) m/s^2 (use :meth:`gravity_at` elsewhere)."""
        return self.earth.gravity_n(np.zeros(3))

    def gravity_at(self, p_n: np.ndarray) -> np.ndarray:
        """Gravity (...,3), m/s^2, at navigation-frame positions ``p_n`` (...,3), m."""
        return self.earth.gravity_n(p_n)

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
        # a sample's velocity increment is in the body axes of t_k frozen in inertial space (what an IMU
        # integrates); the n axes turn by omega_ie dt meanwhile: half of that turn, on average
        f_n = f_n - 0.5 * dt[:, None] * _cross_rows(self.omega_ie_n, f_n)
        v_all = np.empty((n + 1, 3))
        p_all = np.empty((n + 1, 3))
        v_all[0], p_all[0] = state.v_n, state.p_n
        chunk_id = np.floor(tau[:n] / self.CHUNK_S).astype(int)
        bounds = np.flatnonzero(np.diff(chunk_id)) + 1
        for i0, i1 in zip(np.concatenate([[0], bounds]), np.concatenate([bounds, [n]])):
            v_all[i0 + 1:i1 + 1], p_all[i0 + 1:i1 + 1] = self._translate(
                f_n[i0:i1], dt[i0:i1], v_all[i0], p_all[i0])
        end = StrapdownState(state.t + tau[-1], _orthonormalise(C_all[-1]), v_all[-1], p_all[-1])
        return end, PropagationPath(C, f_n, v_all[:n], p_all[:n], dt)

    def gravity_gradient(self, p_n: np.ndarray) -> np.ndarray:
        """``d g_n / d p_n`` (3,3), s^-2, at ``p_n`` (m), re-evaluated only beyond :attr:`GRADIENT_REUSE_M`."""
        cached = self._gradient
        if cached is None or np.max(np.abs(p_n - cached[0])) > self.GRADIENT_REUSE_M:
            cached = self._gradient = (np.array(p_n, dtype=float), self.earth.gravity_gradient_n(p_n))
        return cached[1]

    def _translate(self, f_n: np.ndarray, dt: np.ndarray, v0: np.ndarray, p0: np.ndarray,
                   ) -> tuple[np.ndarray, np.ndarray]:
        """Velocity and position (m,3) at the ends of m segments of a short stretch.

        Gravity and Coriolis depend on the path being computed, so they are evaluated on the previous pass's
        path (a fixed point: first pass with the start position and velocity); over ``CHUNK_S`` each pass
        shrinks their error by ~``2 |omega_ie| T`` (1.5e-3), so 2-3 passes reach rounding. Gravity is the model's
        value and gradient at the stretch's start, linear in the position over it.
        """
        v = np.broadcast_to(v0, f_n.shape)
        p = np.broadcast_to(p0, f_n.shape)
        # over a stretch (tens of metres) gravity is linear in the position to 1e-10 m/s^2: its value and
        # gradient at the start, instead of the exact model at every segment (3x faster EKF)
        g0 = self.earth.gravity_n(p0)
        G = self.gravity_gradient(p0)
        p_prev = None
        for _ in range(6):
            g = g0 + (p - p0) @ G.T
            a = f_n + g - 2.0 * _cross_rows(self.omega_ie_n, v)
            dv = a * dt[:, None]
            v_end = v0 + np.cumsum(dv, axis=0)
            v_start = np.concatenate([v0[None], v_end[:-1]])
            p_end = p0 + np.cumsum(v_start * dt[:, None] + 0.5 * dv * dt[:, None], axis=0)
            if p_prev is not None and np.max(np.abs(p_end - p_prev)) < self.CONVERGED_M:
                break
            p_prev = p_end
            v, p = v_start, np.concatenate([p0[None], p_end[:-1]])
        return v_end, p_end


def _cross_rows(w: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``w x x_i`` for one 3-vector w and rows x (n,3): the products and differences of ``np.cross`` (the same
    numbers), without its ~10 us of axis handling per call."""
    w0, w1, w2 = w.tolist()
    x0, x1, x2 = x[:, 0], x[:, 1], x[:, 2]
    return np.stack([w1 * x2 - w2 * x1, w2 * x0 - w0 * x2, w0 * x1 - w1 * x0], axis=-1)


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
