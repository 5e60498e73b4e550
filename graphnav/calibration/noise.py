"""Noise identification from recorded data: IMU white-noise densities, beam noise, the GT's velocity error.

- **IMU white noise** (accelerometer m/s^2/sqrt(Hz), gyro rad/s/sqrt(Hz)) at the scale the estimators
  integrate over (keyframes 1 s apart): with GT, the mismatch of the IMU's 1-s velocity and attitude
  increments with the GT's (:func:`identify_imu_with_gt`; the accelerometer's as interval means with its position
  fitted out), ``N = std / sqrt(dt)``. Without GT: overlapping Allan deviation of the raw streams at short tau
  (1..10 samples), ``N = min_tau sigma_A(tau) sqrt(tau)``, median over axes. On the A-KIT Phins data the two
  disagree: the short-tau Allan density of the accelerometer (median 1.7e-3) is twice the 1-s one (8.2e-4) and
  its gyro density 6x (6.4e-5 against 1.1e-5) -- the recorded vibration is not white and averages out within a
  keyframe. Neither is what the estimators need: a calibrated configuration gets them times
  :data:`ESTIMATOR_DENSITY_FACTOR`.
- **Beam noise** (m/s): residuals ``r = y - h(x_hat)`` of every measured beam at the all-beam batch smoother
  (Graph-HN-batch with DVL error states, no outage). For a least-squares estimate ``E[r^2] = sigma^2 -
  var(h(x_hat))``, so ``sigma^2 = mean(r^2) + mean(M P_v M^T)`` with ``P_v`` the smoother's velocity marginal
  (the attitude's share of ``var(h)`` is below 1e-6 (m/s)^2 here and left out). Residuals beyond 5 sigma of
  the assumed noise (surface pings) are left out.
- **The recorded DVL's own errors** (:func:`dvl_error_drift`): white part and random-walk density of the
  recorded DVL velocity against the IMU-carried GT, in beam space (what the DVL error states' walk must hold).
- **GT velocity error** (m/s per NED axis): the batch smoother's error against the GT (carried to the
  smoother's epochs by the IMU, :class:`graphnav.calibration.reference.Reference`) has covariance
  ``P + Sigma_gt`` (the GT does not see the beams' synthetic noise), so ``Sigma_gt = mean(e e^T) - mean(P)``
  per axis over the mission after 60 s (clipped at 0). This attributes *all* unexplained error to the GT: it
  is an upper bound of the GT's error (and a lower bound of what the smoother's covariance misses), and it
  is *not* independent of the batch smoother (its own NEES with it is ~3 by construction).
  An independent check of the GT's fast (sample-to-sample) error: the GT's 1-s velocity increments against
  the IMU's (:func:`gt_white_velocity_error`): ``d_k = (mean f_imu - f_gt) dt``, the accelerometer's position
  and a bias fitted out, has variance ``2 sigma_white^2 + N_acc^2 dt`` and lag-1 correlation -0.5 if the GT
  error is white.

``experiments/identify_noise.py`` runs this over the shared trajectories and prints the identification behind the
A-KIT loader's values (:data:`graphnav.io.loaders.PHINS_RECORDED`,
:data:`graphnav.io.loaders.AKIT_GT_VELOCITY_SIGMA_N`, the beam noise of its DVL spec).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from graphnav.core.dvl import DvlGeometry
from graphnav.core.mission import Mission
from graphnav.estimators.keyframes import gyro_at

#: The white densities the estimators need over those identified, (accelerometer, gyro), by how they were
#: identified: ``"gt"``, the 1-s increments against a GT (:func:`identify_imu_with_gt`); ``"allan"``, the
#: Allan deviation at short tau without one (:func:`white_density`). Chosen leave-trajectories-out on the ten
#: shared trajectories (``experiments/calibrated_density_folds.py``, docs/decisions/consistency.md): the densities
#: the estimators use there (:data:`graphnav.io.loaders.PHINS_RECORDED`, chosen by their NEES) over the
#: identification's median on the other folds, 4.03-4.59 and 1.40-1.69 per fold against the GT, 1.99-2.20 and
#: 0.24-0.29 by the Allan deviation. The 1-s increments do not hold what the estimators must also cover (slower
#: sensor errors, the GT's, their own model's); the short-tau Allan deviation holds vibration that averages out
#: within a keyframe interval. One vehicle's numbers: on another the factor may differ.
ESTIMATOR_DENSITY_FACTOR = {"gt": (4.25, 1.5), "allan": (2.1, 0.27)}

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


def increment_mismatch(mission: Mission) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(d_v (K,3) m/s, d_theta (K,3) rad, dt (K,) s, keep (K,) bool) per GT interval, body frame.

    Velocity: the accelerometer's interval means against the GT's, with the accelerometer's position and a
    constant bias fitted out (:func:`graphnav.calibration.dvl_fit.accelerometer_mismatch`), times ``dt``.
    Attitude: ``integral(omega_imu) - Log(C_k^T C_k+1)`` (Earth rate included), median removed. ``keep`` leaves
    out intervals beyond 5 MAD on any axis (surface, manoeuvres)."""
    from graphnav.calibration.dvl_fit import accelerometer_mismatch
    from graphnav.calibration.reference import (
        cumulative_integral,
        reference_gyro_increments,
    )
    gt, imu, cfg = mission.gt, mission.imu, mission.config
    accel = accelerometer_mismatch(mission)
    first = int(np.searchsorted(gt.t, accel.a[0]))
    sel = slice(first, first + len(accel.a) + 1)
    t = gt.t[sel]
    dt = np.diff(t)
    d_v = accel.fit()[1] * dt[:, None]
    integral = np.stack([np.interp(t, imu.t, cumulative_integral(imu.t, imu.omega_b[:, i])) for i in range(3)], 1)
    d_th = reference_gyro_increments(t, gt.C_b_n[sel], cfg.lat_rad if cfg.earth_rotation else None) \
        - np.diff(integral, axis=0)
    d_th -= np.median(d_th, axis=0)
    keep = np.ones(len(dt), dtype=bool)
    for d in (d_v, d_th):
        keep &= np.all(np.abs(d) < 5 * 1.4826 * np.median(np.abs(d), axis=0), axis=1)
    return d_v, d_th, dt, keep


def identify_imu_with_gt(mission: Mission, mismatch=None) -> tuple[float, float]:
    """(accel m/s^2/sqrt(Hz), gyro rad/s/sqrt(Hz)) white densities at the keyframe scale (the GT interval,
    1 s): ``std(d) / sqrt(dt)`` of the increment mismatches (:func:`increment_mismatch`, or ``mismatch``, its
    result), median over the axes. Both hold the GT's own noise too (an upper bound; :func:`gt_white_velocity_error`
    for the velocity)."""
    d_v, d_th, dt, keep = increment_mismatch(mission) if mismatch is None else mismatch
    scale = np.sqrt(float(np.median(dt)))
    acc = np.std(d_v[keep], axis=0) / scale
    gyro = np.std(d_th[keep], axis=0) / scale
    return float(np.median(acc)), float(np.median(gyro))


def gt_white_velocity_error(mission: Mission, mismatch=None) -> tuple[np.ndarray, np.ndarray]:
    """(sigma (3,), lag-1 correlation (3,)) per body axis of the GT's white velocity error, m/s.

    From the velocity-increment mismatch d (:func:`increment_mismatch`, or ``mismatch``, its result): ``sigma^2 =
    (var(d) - N_acc^2 dt) / 2`` with ``N_acc`` the accelerometer density of :func:`identify_imu_with_gt` (the
    median axis). The lag-1 correlation of d is -0.5 for a white GT error (a slow error or IMU noise gives ~0).
    """
    mismatch = increment_mismatch(mission) if mismatch is None else mismatch
    d, _, dt, keep = mismatch
    n_acc, _ = identify_imu_with_gt(mission, mismatch)
    var = np.var(d[keep], axis=0) - n_acc ** 2 * float(np.median(dt))
    a, b = d[:-1], d[1:]
    both = keep[:-1] & keep[1:]
    rho = np.sum(a[both] * b[both], axis=0) / np.sqrt(np.sum(a[both] ** 2, axis=0) * np.sum(b[both] ** 2, axis=0))
    return np.sqrt(np.maximum(var, 0.0) / 2.0), rho


@dataclass
class NoiseEstimate:
    """Identified noise of one mission (units above); ``density_source``: how the IMU densities were identified
    (a key of :data:`ESTIMATOR_DENSITY_FACTOR`); ``n_beams`` residuals used; ``gt_white_*``: the GT's
    white velocity error per body axis and the lag-1 correlation of its increments
    (:func:`gt_white_velocity_error`); ``dvl_white_std`` (m/s) and ``dvl_bias_rw`` (m/s/sqrt(s)): the recorded
    DVL's own beam errors (:func:`dvl_error_drift`)."""

    accel_noise_density: float
    gyro_noise_density: float
    allan_accel_density: float | None = None
    allan_gyro_density: float | None = None
    beam_noise_std: float | None = None
    gt_velocity_sigma_n: tuple[float, float, float] | None = None
    gt_white_sigma_b: tuple[float, float, float] | None = None
    gt_white_lag1_b: tuple[float, float, float] | None = None
    dvl_white_std: float | None = None
    dvl_bias_rw: float | None = None
    n_beams: int = 0
    density_source: str = "allan"

    def estimator_densities(self) -> tuple[float, float]:
        """(accelerometer m/s^2/sqrt(Hz), gyro rad/s/sqrt(Hz)): the identified densities times
        :data:`ESTIMATOR_DENSITY_FACTOR`, what a calibrated configuration gives the estimators."""
        acc, gyro = ESTIMATOR_DENSITY_FACTOR[self.density_source]
        return self.accel_noise_density * acc, self.gyro_noise_density * gyro

    def to_dict(self) -> dict:
        return {**asdict(self), "estimator_densities": self.estimator_densities()}


def identify_imu(mission: Mission, mismatch=None) -> NoiseEstimate:
    """IMU white-noise densities: at the keyframe scale against the GT when the mission has one
    (:func:`identify_imu_with_gt`, with ``mismatch`` if given), else the Allan deviation at short tau; the Allan
    values are kept too."""
    rate = 1.0 / float(np.median(np.diff(mission.imu.t)))
    acc, gyro = white_density(mission.imu.f_b, rate), white_density(mission.imu.omega_b, rate)
    est = NoiseEstimate(acc, gyro, acc, gyro)
    if mission.gt is not None:
        est.accel_noise_density, est.gyro_noise_density = identify_imu_with_gt(mission, mismatch)
        est.density_source = "gt"
    return est


def beam_residuals(mission: Mission, sol) -> tuple[np.ndarray, np.ndarray]:
    """(r (n,), var_h (n,)): residual and predicted-beam variance of every valid beam at a keyframe of
    ``sol`` (a graph solution with ``info["batch_dvl_errors"]``, or none = no DVL error states)."""
    geo = DvlGeometry.from_spec(mission.config.dvl)
    d = sol.info.get("batch_dvl_errors")
    model = geo.beam_model(dvl_errors=d is not None)
    imu, dvl = mission.imu, mission.dvl
    samples = list(zip(imu.t, imu.f_b, imu.omega_b))
    k = np.searchsorted(sol.t, dvl.t)
    k = np.clip(k, 0, len(sol.t) - 1)
    at_keyframe = np.abs(sol.t[k] - dvl.t) < 1e-6
    res, var = [], []
    for j in np.flatnonzero(at_keyframe):
        i = k[j]
        valid = dvl.valid[j] & np.isfinite(dvl.beams[j])
        if not valid.any():
            continue
        p = model.predict(sol.C_b_n[i], sol.v_n[i], gyro_at(dvl.t[j], samples), sol.bias_gyro[i], geo.lever_arm_b,
                          None if d is None else d[i])
        res.append((dvl.beams[j] - p.h)[valid])
        H_v = p.d_v()
        var.append(np.einsum("ij,jk,ik->i", H_v, sol.cov_v_n[i], H_v)[valid])
    return np.concatenate(res), np.concatenate(var)


def identify(mission: Mission, sol=None, completer=None) -> NoiseEstimate:
    """IMU densities, beam noise and GT velocity error of one mission with GT.

    ``sol``: an all-beam batch-smoother solution with DVL error states; when None it is run here, with
    ``completer``'s regressed beams at pings with missing beams (Graph-HN-batch; the callers above this layer
    pass the registry's completer for the data as recorded,
    ``graphnav.evaluation.methods.network_completer("none")``) or on the measured beams only (None).
    """
    # the IMU's increments against the GT, once for its densities and the GT's white error
    mismatch = None if mission.gt is None else increment_mismatch(mission)
    est = identify_imu(mission, mismatch)
    if sol is None:
        from graphnav.estimators.graph import GraphOptions
        from graphnav.estimators.runs import run_graph
        sol = run_graph(mission, completer=completer, batch=True, options=GraphOptions(dvl_error_states=True))
    r, var_h = beam_residuals(mission, sol)
    sigma0 = mission.config.dvl.beam_noise_std
    keep = np.abs(r) < 5 * sigma0
    est.beam_noise_std = float(np.sqrt(np.mean(r[keep] ** 2) + np.mean(var_h[keep])))
    est.n_beams = int(keep.sum())
    if mission.gt is not None and sol.cov_v_n is not None:
        from graphnav.calibration.reference import mission_reference
        ref = mission_reference(mission)
        sel = (sol.t >= sol.t[0] + SETTLE_S) & ref.covers(sol.t)
        # the GT at the smoother's epochs carried there by the IMU: a 1 Hz GT interpolated linearly misses
        # the motion within the second (0.1 m/s in waves), which is not the GT's error at its samples
        e = sol.v_n[sel] - ref.v_n(sol.t[sel])
        p = np.diagonal(sol.cov_v_n[sel], axis1=1, axis2=2)
        est.gt_velocity_sigma_n = tuple(float(x) for x in np.sqrt(np.maximum(np.mean(e ** 2 - p, axis=0), 0)))
        white, rho = gt_white_velocity_error(mission, mismatch)
        est.gt_white_sigma_b = tuple(float(x) for x in white)
        est.gt_white_lag1_b = tuple(float(x) for x in rho)
        if mission.dvl.v_b is not None:
            est.dvl_white_std, est.dvl_bias_rw = dvl_error_drift(mission)
    return est


#: Averaging times (s) of the DVL error drift fit: long enough for the 1 Hz white part to have averaged down.
DRIFT_TAUS_S = (20.0, 50.0)


def dvl_error_drift(mission) -> tuple[float, float]:
    """(white m/s, random-walk density m/s/sqrt(s)) of the recorded DVL's own beam errors, from the
    beam-space residuals of the recorded DVL velocity against the GT carried to each ping by the IMU
    (:func:`graphnav.calibration.reference.dvl_design`, lever arm ``omega x l`` removed, submerged pings
    only, per-beam median removed): the Allan deviation at 1 ping gives the white part ``N`` (1 Hz), and a
    random walk ``K`` adds ``K^2 tau / 3`` to the Allan variance, so ``K^2 = 3 (sigma_A^2(tau) - N^2 / tau)
    / tau``, largest over :data:`DRIFT_TAUS_S`, median over beams. The GT's own slow error is in the
    residual too, so ``K`` bounds the DVL's drift from above -- the size of the walk the DVL error states
    (:class:`graphnav.estimators.graph.GraphOptions` ``dvl_bias_rw``) need."""
    from graphnav.calibration.reference import (
        dvl_design,
        mission_reference,
        submerged_pings,
    )
    dvl = mission.dvl
    ok = np.all(np.isfinite(dvl.v_b), axis=1) & submerged_pings(mission)
    ref = mission_reference(mission)
    ok &= ref.covers(dvl.t)
    r, omega, _, _ = dvl_design(ref, dvl.t[ok], dvl.v_b[ok])
    e_b = (r - np.cross(omega, mission.config.dvl.lever_arm_b)) @ DvlGeometry.from_spec(mission.config.dvl).T_b.T
    e_b -= np.median(e_b, axis=0)
    rate = 1.0 / float(np.median(np.diff(dvl.t[ok])))
    taus = [1] + [int(round(t * rate)) for t in DRIFT_TAUS_S]
    adev = allan_deviation(e_b, rate, taus)
    white = adev[0] * np.sqrt(1.0 / rate)
    k2 = [3.0 * np.maximum(adev[i] ** 2 - white ** 2 / (taus[i] / rate), 0.0) / (taus[i] / rate)
          for i in range(1, len(taus))]
    return float(np.median(white)), float(np.median(np.sqrt(np.max(k2, axis=0))))
