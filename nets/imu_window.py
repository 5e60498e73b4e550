"""The IMU window an IMU-aware beam completer sees, and its preintegration into velocity increments.

The window is the last ``n_samples`` IMU samples up to the ping (the last sample at or before the ping time,
oldest first, at ``rate_hz``): specific force ``f_b`` (n, 3) m/s^2 and angular rate ``omega_b`` (n, 3) rad/s
in the body frame (FRD, as :func:`graphnav.missions.load_akit` gives them).

:func:`preintegrate` turns it into what the network needs, in the body frame *of the ping* (``now``), for
each of the N past pings j (``tau_j`` seconds before the ping):

- ``rot`` (N, 3, 3): ``C_j_now``, the rotation from the body frame at ping j to the body frame now (gyro
  integrated backwards from the ping: ``P_i = Exp(omega_i dt) P_{i+1}``, ``C_i_now = P_i^T``);
- ``tail`` (N, 3) m/s: ``int_{t_j}^{now} C_t_now f_b dt``, the velocity change without gravity, so that
  ``v_now = C_j_now v_j + tail_j + g_now tau_j`` (``dv_n/dt = C_b_n f_b + g_n`` seen from the body now);
- ``f_mean`` (3,) and ``M`` (3, 3): window means of ``C_t_now f_b`` and ``C_t_now [omega_t x]``; gravity in
  the body frame now is ``g_now = M v - f_mean`` for a vehicle that holds its body velocity ``v`` through the
  window (a steady turn accelerates inertially, ``omega x v``, but not in the body frame);
- ``summary`` (6,): mean ``omega_b`` over the last ping period and over the last N ping periods, rad/s.

Why: without attitude, gravity in the body frame must come from the window itself. Taking the mean inertial
acceleration as zero (``g_now = -f_mean``) fails in turns (1.8 m/s at 4 deg/s is 0.13 m/s^2 centripetal):
propagating the recorded DVL velocity of the ten A-KIT trajectories 1 s ahead was then off by 0.062 / 0.053
m/s RMS (x / y, 20 s windows), 5 s ahead by 0.31 / 0.25, no better than holding it (0.18 / 0.24). With the
centripetal term, 1 s ahead is off by 0.022 / 0.024 / 0.006 m/s (x / y / z); 10 s windows give 0.034 / 0.033,
40 s 0.015 / 0.021, 60 s 0.017 / 0.022 (the body velocity is not held that long). 20 s is the shipped window.
The earth rate (7e-5 rad/s) and Coriolis terms are neglected; the DVL is taken at the IMU (no lever-arm
term; on the Snapir AUV the DVL is within ~0.2 m of the IMU's measurement point,
``graphnav.io.loaders.AKIT_IMU_POSITION_B``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from graphnav.core.errors import DataError

#: IMU rate the shipped IMU-aware networks were trained at (A-KIT Phins), Hz.
IMU_RATE_HZ = 100.0
#: Length of the IMU window the shipped IMU-aware networks see, s.
IMU_WINDOW_S = 20.0
#: Number of summary features of :func:`preintegrate`.
N_SUMMARY = 6


@dataclass
class ImuFeatures:
    """Preintegrated IMU windows (leading batch axis B; index j = 0 of N is the oldest past ping).

    Attributes:
        rot: (B, N, 3, 3) ``C_j_now``, body frame j pings ago -> body frame now.
        tail: (B, N, 3) m/s, ``int_{t_j}^{now} C_t_now f_b dt`` (velocity change without gravity).
        f_mean: (B, 3) m/s^2, window mean of ``C_t_now f_b`` (``-g_now`` plus the mean inertial acceleration).
        M: (B, 3, 3) 1/s, window mean of ``C_t_now [omega_t x]``: ``M v_b`` is the mean centripetal term of a
            vehicle holding the body velocity ``v_b`` through the window.
        summary: (B, 6) rad/s, mean ``omega_b`` over the last ping period and over the last N periods.
    """

    rot: np.ndarray
    tail: np.ndarray
    f_mean: np.ndarray
    M: np.ndarray
    summary: np.ndarray

    FIELDS = ("rot", "tail", "f_mean", "M", "summary")

    def __len__(self) -> int:
        return len(self.tail)

    def take(self, idx) -> "ImuFeatures":
        return ImuFeatures(*(getattr(self, k)[idx] for k in self.FIELDS))

    @staticmethod
    def concatenate(parts: list["ImuFeatures"]) -> "ImuFeatures":
        return ImuFeatures(*(np.concatenate([getattr(p, k) for p in parts]) for k in ImuFeatures.FIELDS))


def check_imu(imu, n_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Validate one IMU window ``(f_b, omega_b)``; raise :class:`DataError` naming the bad field."""
    if imu is None:
        raise DataError(f"this completer needs the IMU window: imu=(f_b, omega_b), each ({n_samples}, 3)",
                        "completer", field="imu")
    try:
        f_b, omega_b = imu
    except (TypeError, ValueError):
        raise DataError("imu must be a pair (f_b, omega_b)", "completer", field="imu") from None
    out = []
    for name, a in (("f_b", f_b), ("omega_b", omega_b)):
        a = np.asarray(a, dtype=float)
        if a.shape != (n_samples, 3):
            raise DataError(f"shape {a.shape}, expected ({n_samples}, 3): the last {n_samples} IMU samples up "
                            "to the ping, oldest first", "completer", field=f"imu.{name}")
        bad = np.argwhere(~np.isfinite(a))
        if bad.size:
            raise DataError("IMU sample is not finite", "completer", int(bad[0][0]), f"imu.{name}")
        out.append(a)
    return out[0], out[1]


def _skew(w: np.ndarray) -> np.ndarray:
    """``[w x]`` (..., 3, 3) of vectors (..., 3)."""
    K = np.zeros(w.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    return K


def _exp_so3(phi: np.ndarray) -> np.ndarray:
    """Rodrigues' formula for rotation vectors (..., 3) -> (..., 3, 3)."""
    theta = np.linalg.norm(phi, axis=-1)[..., None, None]
    K = _skew(phi)
    small = theta < 1e-8
    safe = np.where(small, 1.0, theta)
    a = np.where(small, 1.0, np.sin(safe) / safe)
    b = np.where(small, 0.5, (1.0 - np.cos(safe)) / safe ** 2)
    return np.eye(3) + a * K + b * (K @ K)


def _suffix_products(E: np.ndarray) -> np.ndarray:
    """``P_i = E_i E_{i+1} ... E_{n-1}`` along axis 1 of (B, n, 3, 3), by a log-depth scan."""
    P = E.copy()
    n, step = P.shape[1], 1
    while step < n:
        P[:, :n - step] = P[:, :n - step] @ P[:, step:]
        step *= 2
    return P


def preintegrate(f_b: np.ndarray, omega_b: np.ndarray, n_past: int, rate_hz: float = IMU_RATE_HZ,
                 ping_dt: float = 1.0, chunk: int = 64) -> ImuFeatures:
    """Preintegrate IMU windows (B, n, 3) (or one window (n, 3)) for the ``n_past`` pings before the ping.

    Args:
        f_b: specific force, m/s^2, body frame; the last sample is the one at the ping.
        omega_b: angular rate, rad/s, body frame.
        n_past: number of past pings N (``ping_dt`` apart) to propagate to the ping.
        rate_hz: IMU rate, Hz.
        ping_dt: DVL ping period, s.

    Returns:
        :class:`ImuFeatures` with a batch axis (B = 1 for a single window).
    """
    f_b, omega_b = np.asarray(f_b, float), np.asarray(omega_b, float)
    if f_b.ndim == 2:
        f_b, omega_b = f_b[None], omega_b[None]
    n = f_b.shape[1]
    dt = 1.0 / rate_hz
    lags = np.rint(np.arange(n_past, 0, -1) * ping_dt * rate_hz).astype(int)     # oldest first
    if lags[0] > n:
        raise DataError(f"IMU window of {n} samples is shorter than the {n_past} past pings "
                        f"({lags[0]} samples at {rate_hz:g} Hz)", "completer", field="imu")
    last = max(1, int(round(ping_dt * rate_hz)))
    idx = n - lags
    parts = []
    for c in range(0, len(f_b), chunk):
        f, w = f_b[c:c + chunk], omega_b[c:c + chunk]
        P = _suffix_products(_exp_so3(w * dt))                  # P_i = C_now_i: C_i_now = P_i^T
        a = np.einsum("bnji,bnj->bni", P, f)                    # C_i_now f_i
        tail = np.cumsum(a[:, ::-1], axis=1)[:, ::-1] * dt      # int_{t_i}^{now} C_t_now f dt
        M = np.einsum("bnji,bnjk->bik", P, _skew(w)) / n
        summary = np.concatenate([w[:, -last:].mean(1), w[:, idx[0]:].mean(1)], axis=1)
        parts.append(ImuFeatures(np.swapaxes(P[:, idx], -1, -2), tail[:, idx], a.mean(1), M, summary))
    return ImuFeatures.concatenate(parts)


def imu_window_at(imu, t: float, n_samples: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The IMU window an estimator passes for a ping at time ``t`` (s, the IMU's clock).

    Args:
        imu: an IMU stream with ``t`` (M,) s, ``f_b`` and ``omega_b`` (M, 3) (:class:`graphnav.core.mission.ImuData`).
        n_samples: window length (the completer's ``imu_samples``).

    Returns:
        ``(f_b, omega_b)`` of the last ``n_samples`` samples at or before ``t``, or None while fewer exist
        (the first ``n_samples / rate`` seconds of a mission: use a beam-only completer then).
    """
    end = int(np.searchsorted(imu.t, t, side="right"))
    if end < n_samples:
        return None
    return imu.f_b[end - n_samples:end], imu.omega_b[end - n_samples:end]
