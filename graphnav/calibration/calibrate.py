"""Sensor calibration from a recorded mission: DVL lever arm, time offsets, DVL mounting, IMU axes.

Two modes (``graphnav calibrate``):

* **with ground truth** (``mode="gt"``): the IMU axes are checked against the GT attitude (gyro) and the
  GT roll/pitch (accelerometer gravity direction), the IMU-to-GT offset is found by matching attitude
  increments, and the DVL is regressed on the GT body velocity over candidate DVL offsets:

      v_dvl = (1 + s) Rz(psi)^T (v_b + omega_b x l_b) + [0, 0, b_z]

  (``v_b`` from the IMU-aided GT interpolation of :class:`graphnav.calibration.reference.Reference`); l_b
  (lever arm), s (scale factor), psi (DVL mounting yaw, so that ``C_d_b = Rz(psi)``) and b_z (a vertical
  velocity bias: equal beam biases, the paper's model, show up on z only; horizontal biases would be
  nearly collinear with the scale factor at survey speed) by least squares at each candidate offset, the offset by minimising the residual.
  Uncertainties: parameter covariance ``sigma^2 (A^T A)^-1`` of the fit and offset sigma from the
  curvature of the profiled cost, both inflated by the residuals' autocorrelation
  (:func:`correlation_inflation`; real DVL-minus-GT residuals are correlated over a few seconds). They
  are statistical only: on the ten Snapir trajectories they cover the lever arm and the vertical bias, but the
  mounting yaw, the scale factor and the accelerometer's position differ between missions by 2.1-4.3 times them
  (:mod:`graphnav.calibration.combine` combines several missions with that spread).
* **without ground truth** (``mode="graph"``): see :mod:`graphnav.calibration.without_gt` (lever arm as a
  Point3 variable in the beam factors, DVL offset by profiling the graph's negative log-likelihood).

The result converts to a :class:`~graphnav.core.config.SensorConfig` (``SensorConfig.save`` writes the JSON
that every command accepts as ``--config``). Offsets in it are *totals* relative to the raw stamps (the
mission's already-applied offset plus the correction found here).
"""
from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

from graphnav.calibration.axes import apply_axis_map, check_imu_axes_with_gt
from graphnav.calibration.dvl_fit import (
    calibrate_dvl_with_gt,
    dvl_velocity,
    estimate_imu_position,
)
from graphnav.calibration.reference import Reference, submerged_pings
from graphnav.calibration.result import CalibrationResult, _q
from graphnav.core.config import SensorConfig
from graphnav.core.errors import DataError
from graphnav.core.mission import Mission


def calibrate_with_gt(mission: Mission, min_depth_m: float = 2.0) -> CalibrationResult:
    """Calibrate against the mission's ground truth (see the module docstring).

    Pings shallower than ``min_depth_m`` (surface, waves) are left out of the DVL regression.
    """
    if mission.gt is None:
        raise DataError("calibration with GT needs a mission with ground truth", mission.name, field="gt")
    cfg0 = mission.config
    check, gt_est = check_imu_axes_with_gt(mission)
    work = apply_axis_map(mission, check.gyro_map, check.accel_map) if not check.ok else mission
    gt_t = work.gt.t + gt_est.offset_s
    ref = Reference(work.imu.t, work.imu.f_b, work.imu.omega_b, gt_t, work.gt.v_n, work.gt.C_b_n,
                    cfg0.gravity_mps2, cfg0.lat_rad if cfg0.earth_rotation else None, cfg0.dvl)
    v_dvl, usable = dvl_velocity(work)
    usable &= submerged_pings(work, min_depth_m) if work.depth is not None else True
    fit, off_sigma = calibrate_dvl_with_gt(ref, work.dvl.t, v_dvl, usable, source=work.dvl.source or mission.name)
    sig = np.sqrt(np.diag(fit.cov))
    th = fit.theta
    cfg = SensorConfig.from_dict(cfg0.to_dict())
    cfg.gt_time_offset_s = cfg0.gt_time_offset_s + gt_est.offset_s
    cfg.dvl_time_offset_s = cfg0.dvl_time_offset_s + fit.offset_s
    cfg.dvl.lever_arm_b = th[0:3].copy()
    cfg.dvl.C_d_b = Rotation.from_euler("z", th[4]).as_matrix() @ cfg0.dvl.C_d_b
    cfg.dvl.velocity_scale_correction = float((1 + cfg0.dvl.velocity_scale_correction) * (1 + th[3]) - 1)
    cfg.imu_axis_signs = cfg0.imu_axis_signs * check.sign_correction
    r_imu, r_cov, r_before, r_after = estimate_imu_position(dataclasses.replace(
        work, gt=dataclasses.replace(work.gt, t=gt_t)))
    info = {}
    if mission.meta.get("prepare", {}).get("format") in LOG_FORMATS:
        info["reference_position_b"] = _navigate_the_accelerometer(cfg, cfg0, r_imu)
    return CalibrationResult(
        "gt", _q(th[0:3], sig[0:3], "m"), _q(cfg.dvl_time_offset_s, off_sigma, "s"),
        _q(cfg.gt_time_offset_s, gt_est.sigma_s, "s"), _q(th[4], sig[4], "rad"), _q(th[3], sig[3], "-"),
        _q(th[5], sig[5], "m/s"), fit.rms, check, cfg, _q(r_imu, np.sqrt(np.diag(r_cov)), "m"),
        info={"accel_residual_rms_before_after": f"{r_before:.4f} -> {r_after:.4f} m/s^2",
              "dvl_offset_correction_s": fit.offset_s, "gt_offset_correction_s": gt_est.offset_s,
              "pings_used": fit.n_pings, "gyro_increment_rms_rad": gt_est.rms, **info},
        gt_point_b=_gt_point_b(mission))


#: The formats whose reference point ``calibrate`` writes (``reference_position_b``): logs and bags, whose column map
#: or topics cannot say where the reference stands. An A-KIT folder's is the vehicle's (the loader's
#: ``AKIT_IMU_POSITION_B``, docs/decisions/akit-loader.md); a simulated reference is at the IMU point.
LOG_FORMATS = ("csv", "bag")


def _navigate_the_accelerometer(cfg: SensorConfig, cfg0: SensorConfig, r_imu: np.ndarray) -> str:
    """``cfg`` set to navigate the accelerometer's point ``r_imu`` (m, body frame, from the point the mission's GT
    stands for): the reference's position from it (``reference_position_b``, which ``prepare`` moves the reference
    by) and the DVL lever arm from it. Returns the report's line."""
    before = np.zeros(3) if cfg0.reference_position_b is None else cfg0.reference_position_b
    cfg.reference_position_b = before - r_imu
    cfg.dvl.lever_arm_b = cfg.dvl.lever_arm_b - r_imu
    cells = ", ".join(f"{x:+.3f}" for x in cfg.reference_position_b)
    return (f"[{cells}] m (the reference from the accelerometer's point, body frame; written as reference_position_b, "
            "the lever arm written from the same point)")


def _gt_point_b(mission: Mission) -> np.ndarray | None:
    """Where ``prepare`` moved the mission's GT (the IMU point), relative to the GT as recorded, body frame, m; None
    when the GT is as the log holds it. The GT-mode regressions measure from the point the GT stands for."""
    point = mission.meta.get("gt_point_b")
    return None if point is None else np.asarray(point, float).reshape(3)


def calibrate(mission: Mission, mode: str = "auto", identify_noise: bool = False, completer=None,
              **kwargs) -> CalibrationResult:
    """Calibrate a mission: ``mode`` = ``"gt"``, ``"graph"`` or ``"auto"`` (gt when GT is present).

    ``identify_noise``: also identify the IMU white-noise densities and the beam noise from the data
    (:func:`graphnav.calibration.noise.identify`, one all-beam batch-smoother run; with GT also the GT's velocity
    error) and write them into the calibrated configuration (``graphnav calibrate`` does by default; the IMU
    densities times :data:`graphnav.calibration.noise.ESTIMATOR_DENSITY_FACTOR`, what the estimators need);
    ``completer`` fills the pings with missing beams in that run (see :func:`~graphnav.calibration.noise.identify`).
    """
    if mode == "auto":
        mode = "gt" if mission.gt is not None else "graph"
    if mode == "gt":
        result = calibrate_with_gt(mission, **kwargs)
    elif mode == "graph":
        from graphnav.calibration.without_gt import calibrate_with_graph
        result = calibrate_with_graph(mission, **kwargs)
    else:
        raise ValueError(f"unknown calibration mode '{mode}' (gt, graph, auto)")
    _velocity_columns_in_the_instrument_frame(mission, result)
    if identify_noise:
        from graphnav.calibration.noise import identify
        noise = identify(mission, completer=completer)
        result.noise = noise
        result.config.imu.accel_noise_density, result.config.imu.gyro_noise_density = noise.estimator_densities()
        result.config.dvl.beam_noise_std = noise.beam_noise_std
    return result


def _velocity_columns_in_the_instrument_frame(mission: Mission, result: CalibrationResult) -> None:
    """A column map's ``v_b`` columns read as body velocity (no ``frame``) are what the mounting was fitted to: the
    body velocity is the fitted turn (the calibrated ``C_d_b`` times the configured one's transpose) times the columns.
    The written configuration says so: the columns in the ``instrument`` frame, that turn as ``C_d_b`` (the beams are
    then the columns' own projections). Written as the configured ``C_d_b`` composed with the turn, body columns were
    read unturned by the next run. A configured ``C_d_b`` other than I that the calibration left (graph mode) stays
    with the body frame."""
    cmap = result.config.csv_columns or {}
    dvl = cmap.get("dvl") or {}
    C0, C1 = mission.config.dvl.C_d_b, result.config.dvl.C_d_b
    identity = np.allclose(C0, np.eye(3))
    if (not mission.meta.get("beams_from_v_b") or dvl.get("frame", "body") not in ("body", "frd")
            or (not identity and np.allclose(C1, C0))):
        return
    result.config.dvl.C_d_b = C1 @ C0.T
    result.config.csv_columns = {**cmap, "dvl": {**dvl, "frame": "instrument"}}
    replaced = "" if identity else "; dvl.C_d_b written as that turn, not composed with the configured head's mounting"
    result.info["dvl_velocity_frame"] = ("csv_columns.dvl.frame set to 'instrument': the v_b columns are the DVL's "
                                         "velocity, turned to body by the calibrated C_d_b" + replaced)
