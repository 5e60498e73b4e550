"""Noise identification from recorded data: IMU white-noise densities, beam noise, the GT's velocity error.

- **IMU white noise** (accelerometer m/s^2/sqrt(Hz), gyro rad/s/sqrt(Hz)): overlapping Allan deviation of the
  raw streams at short averaging times (``tau`` = 1..10 samples, 0.01..0.1 s at 100 Hz). For white noise
  ``sigma_A(tau) = N / sqrt(tau)``, so ``N = sigma_A(tau) sqrt(tau)``; the vehicle's motion adds a part that
  grows with tau, hence the minimum over these short taus (per axis), then the median over the axes. This is
  what the estimators' IMU model means by a white density: sample-to-sample scatter, vibration included.
- **Beam noise** (m/s): residuals ``r = y - h(x_hat)`` of every measured beam at the all-beam batch smoother
  (Graph-HN-batch with DVL error states, no outage). For a least-squares estimate ``E[r^2] = sigma^2 -
  var(h(x_hat))``, so ``sigma^2 = mean(r^2) + mean(M P_v M^T)`` with ``P_v`` the smoother's velocity marginal
  (the attitude's share of ``var(h)`` is below 1e-6 (m/s)^2 here and left out). Residuals beyond 5 sigma of
  the assumed noise (surface pings) are left out.
- **GT velocity error** (m/s per NED axis): the batch smoother's error against the GT has covariance
  ``P + Sigma_gt`` (the GT does not see the beams' synthetic noise), so ``Sigma_gt = mean(e e^T) - mean(P)``
  per axis over the mission after 60 s (clipped at 0). This attributes *all* unexplained error to the GT: it
  is an upper bound of the GT's error (and a lower bound of what the smoother's covariance misses).

``scripts/identify_noise.py`` runs this over the shared trajectories and prints the values the A-KIT loader
uses (:data:`graphnav.loaders.PHINS_RECORDED`, :data:`graphnav.loaders.AKIT_BEAM_NOISE_STD`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .dvl import DvlGeometry
from .mission import Mission
from .timeseries import interp_rows

#: Averaging times of the white-noise fit, in samples.
SHORT_TAUS = (1, 2, 3, 5, 10)
SETTLE_S = 60.0


def allan_deviation(x: np.ndarray, rate_hz: float, m_samples) -> np.ndarray:
    """Overlapping Allan deviation of the rate samples ``x`` (N,) or (N,k) at ``tau = m / rate`` (len(m),...)."""
    x = np.asarray(x, dtype=float)
    theta = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x, axis=0)]) / rate_hz
    out = []
    for m in m_samples:
        tau = m / rate_hz
        d = theta[2 * m:] - 2 * theta[m:-m] + theta[:-2 * m]
        out.append(np.sqrt(np.mean(d ** 2, axis=0) / (2 * tau ** 2)))
    return np.array(out)


def white_density(x: np.ndarray, rate_hz: float, m_samples=SHORT_TAUS) -> float:
    """White-noise density ``min_tau sigma_A(tau) sqrt(tau)`` per axis, median over axes."""
    adev = allan_deviation(x, rate_hz, m_samples)
    taus = np.asarray(m_samples, dtype=float)[:, None] / rate_hz
    return float(np.median(np.min(adev * np.sqrt(taus), axis=0)))


@dataclass
class NoiseEstimate:
    """Identified noise of one mission (units above); ``n_beams`` residuals used."""

    accel_noise_density: float
    gyro_noise_density: float
    beam_noise_std: float | None = None
    gt_velocity_sigma_n: tuple[float, float, float] | None = None
    n_beams: int = 0

    def to_dict(self) -> dict:
        return asdict(self)


def identify_imu(mission: Mission) -> NoiseEstimate:
    """IMU white-noise densities of the mission's recorded IMU (Allan deviation at short tau)."""
    rate = 1.0 / float(np.median(np.diff(mission.imu.t)))
    return NoiseEstimate(white_density(mission.imu.f_b, rate), white_density(mission.imu.omega_b, rate))


def beam_residuals(mission: Mission, sol) -> tuple[np.ndarray, np.ndarray]:
    """(r (n,), var_h (n,)): residual and predicted-beam variance of every valid beam at a keyframe of
    ``sol`` (a graph solution with ``info["batch_dvl_errors"]``, or none = no DVL error states)."""
    geo = DvlGeometry.from_spec(mission.config.dvl)
    d = sol.info.get("batch_dvl_errors")
    imu, dvl = mission.imu, mission.dvl
    k = np.searchsorted(sol.t, dvl.t)
    k = np.clip(k, 0, len(sol.t) - 1)
    at_keyframe = np.abs(sol.t[k] - dvl.t) < 1e-6
    res, var = [], []
    for j in np.flatnonzero(at_keyframe):
        i = k[j]
        valid = dvl.valid[j] & np.isfinite(dvl.beams[j])
        if not valid.any():
            continue
        omega = imu.omega_b[min(np.searchsorted(imu.t, dvl.t[j]), len(imu.t) - 1)] - sol.bias_gyro[i]
        R = sol.C_b_n[i]
        v_head = R.T @ sol.v_n[i] + np.cross(omega, geo.lever_arm_b)
        s, b = (np.zeros(3), np.zeros(4)) if d is None else (d[i, :3], d[i, 3:])
        M = (geo.T_d * (1.0 + s)) @ geo.C_d_b.T
        h = M @ v_head + b
        res.append((dvl.beams[j] - h)[valid])
        MR = M @ R.T
        var.append(np.einsum("ij,jk,ik->i", MR, sol.cov_v_n[i], MR)[valid])
    return np.concatenate(res), np.concatenate(var)


def identify(mission: Mission, sol=None) -> NoiseEstimate:
    """IMU densities, beam noise and GT velocity error of one mission with GT.

    ``sol``: an all-beam Graph-HN-batch solution with DVL error states (run here when None).
    """
    est = identify_imu(mission)
    if sol is None:
        from .graph import GraphOptions
        from .methods import run_method
        sol = run_method(mission, "Graph-HN-batch", "none", options=GraphOptions(dvl_error_states=True))
    r, var_h = beam_residuals(mission, sol)
    sigma0 = mission.config.dvl.beam_noise_std
    keep = np.abs(r) < 5 * sigma0
    est.beam_noise_std = float(np.sqrt(np.mean(r[keep] ** 2) + np.mean(var_h[keep])))
    est.n_beams = int(keep.sum())
    if mission.gt is not None and sol.cov_v_n is not None:
        sel = sol.t >= sol.t[0] + SETTLE_S
        sel &= (sol.t >= mission.gt.t[0]) & (sol.t <= mission.gt.t[-1])
        e = sol.v_n[sel] - interp_rows(sol.t[sel], mission.gt.t, mission.gt.v_n)
        p = np.diagonal(sol.cov_v_n[sel], axis1=1, axis2=2)
        est.gt_velocity_sigma_n = tuple(float(x) for x in np.sqrt(np.maximum(np.mean(e ** 2 - p, axis=0), 0)))
    return est
