"""What a calibration found: values with their sigma, the calibrated SensorConfig and a report."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from graphnav.calibration.axes import AxisCheck
from graphnav.calibration.noise import ESTIMATOR_DENSITY_FACTOR, NoiseEstimate
from graphnav.core.config import SensorConfig


#: How each estimated quantity is printed (a single mission's report and the combination of several): field ->
#: (label, scale to the printed unit, printed unit or None for the quantity's own, digits). The two positions' labels
#: get the point they are measured from (:func:`printed_label`).
PRINTED = {"lever_arm_b": ("DVL lever arm", 1.0, None, 3), "dvl_time_offset_s": ("DVL time offset", 1.0, None, 3),
           "gt_time_offset_s": ("IMU-to-GT time offset", 1.0, None, 3),
           "dvl_yaw_rad": ("DVL mounting yaw", 180 / np.pi, "deg", 3), "dvl_scale": ("DVL scale factor", 100.0, "%", 3),
           "dvl_bias": ("DVL vertical bias", 1e3, "mm/s", 1),
           "imu_position_b": ("accelerometer", 1.0, None, 3)}

#: The point the DVL lever arm and the accelerometer's position are measured from (:attr:`CalibrationResult.
#: reference_point`): the point the estimators navigate, where the configuration's ``dvl.lever_arm_b`` starts.
IMU_POINT = "IMU point"
#: ... or the ground truth's own point, as the log holds it (a GT that ``prepare`` did not move).
GT_POINT = "GT point"


def printed_label(name: str, result: "CalibrationResult") -> str:
    """The label :data:`PRINTED` gives field ``name``; the two positions' name the point they are measured from."""
    label = PRINTED[name][0]
    return f"{label} vs {result.reference_point}" if name in ("lever_arm_b", "imu_position_b") else label


def joined(parts: list[str]) -> str:
    """One printed cell per component: a vector's as ``[a, b, c]``, a scalar's alone."""
    return "[" + ", ".join(parts) + "]" if len(parts) > 1 else parts[0]


@dataclass
class Quantity:
    """An estimate with its 1-sigma uncertainty (same shape) and unit."""

    value: float | np.ndarray
    sigma: float | np.ndarray
    unit: str

    def to_dict(self) -> dict:
        plain = (lambda x: np.asarray(x).tolist())
        return {"value": plain(self.value), "sigma": plain(self.sigma), "unit": self.unit}


@dataclass
class CalibrationResult:
    """What ``graphnav calibrate`` found. Offsets are totals relative to the raw stamps.

    Attributes:
        mode: ``"gt"`` or ``"graph"``.
        lever_arm_b: DVL lever arm, body frame, m.
        dvl_time_offset_s: value to add to raw DVL stamps, s.
        gt_time_offset_s: value to add to raw GT stamps, s (None without GT).
        dvl_yaw_rad: DVL mounting yaw misalignment psi, ``C_d_b = Rz(psi)`` (None if not estimated).
        dvl_scale: DVL velocity scale factor s, ``v_dvl = (1 + s) ...`` (None if not estimated).
        dvl_bias: constant vertical DVL velocity bias b_z, m/s (None if not estimated).
        residual_rms: RMS of the final residual (m/s per axis, or the graph's whitened RMS).
        axis_check: the IMU axis check.
        config: the calibrated configuration.
        imu_position_b: gt mode: the accelerometer's position, body frame, m, relative to the same point as the
            lever arm (:func:`estimate_imu_position`).
        gt_point_b: gt mode: where the mission's GT stood relative to the GT as the log holds it, body frame, m,
            when ``prepare`` moved it to the IMU point (``mission.meta["gt_point_b"]``: the A-KIT loader's
            ``AKIT_IMU_POSITION_B``, [-1.86, -0.04, 0.2] from the published GT point; zero in a folder graphnav
            wrote); None when the GT is as the log holds it (a bag's, a CSV log's, the simulated mission's truth).
            The lever arm and ``imu_position_b`` are measured from the point the GT stood for
            (:attr:`reference_point`); add ``gt_point_b`` for them from the GT as recorded.
        info: extra diagnostics.
        noise: identified IMU densities, beam noise and GT velocity error (:mod:`graphnav.calibration.noise`), written
            into ``config`` (``imu.*_noise_density``: the identified densities times
            :data:`graphnav.calibration.noise.ESTIMATOR_DENSITY_FACTOR`; ``dvl.beam_noise_std``); None if not
            identified.
    """

    mode: str
    lever_arm_b: Quantity
    dvl_time_offset_s: Quantity
    gt_time_offset_s: Quantity | None
    dvl_yaw_rad: Quantity | None
    dvl_scale: Quantity | None
    dvl_bias: Quantity | None
    residual_rms: float
    axis_check: AxisCheck
    config: SensorConfig
    imu_position_b: Quantity | None = None
    info: dict = field(default_factory=dict)
    noise: NoiseEstimate | None = None
    gt_point_b: np.ndarray | None = None

    @property
    def reference_point(self) -> str:
        """The point the DVL lever arm and the accelerometer's position are measured from: :data:`IMU_POINT` (graph
        mode, or the GT moved there by ``prepare``) or :data:`GT_POINT` (gt mode on a GT as the log holds it).
        The written configuration's ``dvl.lever_arm_b`` is the lever arm from it."""
        return GT_POINT if self.mode == "gt" and self.gt_point_b is None else IMU_POINT

    def point_note(self, lever_arm_b=None, imu_position_b=None) -> list[str]:
        """The report's lines on the point the positions are measured from, and in which frame; with the DVL's and the
        accelerometer's positions from the GT as recorded (``lever_arm_b``, ``imu_position_b``: m, the result's own
        by default; a combination passes its combined ones)."""
        lever_arm_b = self.lever_arm_b.value if lever_arm_b is None else lever_arm_b
        if imu_position_b is None and self.imu_position_b is not None:
            imu_position_b = self.imu_position_b.value
        if self.mode != "gt":
            return [f"  (lever arm: body frame, m, from the {IMU_POINT}, the point the estimators navigate; written as "
                    "dvl.lever_arm_b)"]
        if "reference_position_b" in self.info:
            return ["  (lever arm, accelerometer: body frame, m, from the point the GT stood for; the accelerometer's "
                    "point is written as the one the estimators navigate: the lever arm minus the accelerometer as "
                    "dvl.lever_arm_b, the reference's position from it as reference_position_b)"]
        if self.gt_point_b is None:
            return [f"  (lever arm, accelerometer: body frame, m, from the {GT_POINT} as the log holds it; the lever "
                    "arm is written as dvl.lever_arm_b, the DVL from the IMU: right when the GT stands for the IMU's "
                    "point)"]
        lines = [f"  (lever arm, accelerometer: body frame, m, from the {IMU_POINT}, where the GT was moved and the "
                 "estimators navigate; the lever arm is written as dvl.lever_arm_b)"]
        if np.any(self.gt_point_b):
            def cell(x):
                return "[" + ", ".join(f"{a:+.3f}" for a in np.asarray(x, float) + self.gt_point_b) + "]"
            lines.append(f"  (the {IMU_POINT} is {cell(np.zeros(3))} m from the GT point as recorded; from there the "
                         f"DVL is at {cell(lever_arm_b)} m"
                         + ("" if imu_position_b is None else f", the accelerometer at {cell(imu_position_b)} m") + ")")
        return lines

    def to_dict(self) -> dict:
        def q(x):
            return None if x is None else x.to_dict()
        return {"mode": self.mode, "lever_arm_b": q(self.lever_arm_b),
                "dvl_time_offset_s": q(self.dvl_time_offset_s), "gt_time_offset_s": q(self.gt_time_offset_s),
                "dvl_yaw_rad": q(self.dvl_yaw_rad), "dvl_scale": q(self.dvl_scale), "dvl_bias": q(self.dvl_bias),
                "imu_position_b": q(self.imu_position_b),
                "reference_point": {"point": self.reference_point, "frame": "body",
                                    "gt_point_b": None if self.gt_point_b is None
                                    else np.asarray(self.gt_point_b, float).tolist()},
                "residual_rms": self.residual_rms, "axis_check": self.axis_check.to_dict(),
                "noise": None if self.noise is None else self.noise.to_dict(),
                "info": {k: v for k, v in self.info.items() if isinstance(v, (int, float, str, bool))}}

    def report(self) -> str:
        def line(name):
            _, scale, unit, digits = PRINTED[name]
            label, x = printed_label(name, self), getattr(self, name)
            if x is None:
                return f"  {label:<26}: not estimated in this mode"
            v, s = np.atleast_1d(x.value) * scale, np.atleast_1d(x.sigma) * scale
            return f"  {label:<26}: " + joined([f"{a:+.{digits}f} +- {b:.{digits}f}" for a, b in zip(v, s)]) + \
                f" {unit or x.unit}"
        lines = [f"calibration mode: {self.mode}", *map(line, list(PRINTED)[:-1]),
                 f"  {'residual RMS':<26}: {self.residual_rms:.4f}", line("imu_position_b"), *self.point_note(),
                 "  (sigmas: what this mission's data fix, not how much the next mission differs; give several "
                 "missions to see that)",
                 f"  IMU axes ({self.axis_check.method}): "
                 + ("consistent" if self.axis_check.ok else "SUSPECT: " + "; ".join(self.axis_check.suspects))]
        lines += [f"    note: {n}" for n in self.axis_check.notes]
        if "reference_position_b" in self.info:
            lines.append(f"  {'reference point vs IMU':<26}: {self.info['reference_position_b']}")
        if "dvl_velocity_frame" in self.info:
            lines.append(f"  DVL velocity columns      : {self.info['dvl_velocity_frame']}")
        if self.noise is not None:
            n = self.noise
            gt = ("-" if n.gt_velocity_sigma_n is None
                  else "[" + ", ".join(f"{x:.4f}" for x in n.gt_velocity_sigma_n) + "] m/s (N, E, D; upper bound)")
            how = {"gt": "1-s increments against the GT", "allan": "Allan deviation at 0.01-0.1 s"}
            acc, gyro = n.estimator_densities()
            f_acc, f_gyro = ESTIMATOR_DENSITY_FACTOR[n.density_source]
            lines += [f"  IMU densities identified  : accel {n.accel_noise_density:.2e} m/s^2/sqrt(Hz), gyro "
                      f"{n.gyro_noise_density:.2e} rad/s/sqrt(Hz) ({how.get(n.density_source, n.density_source)})",
                      f"  IMU densities written     : accel {acc:.2e}, gyro {gyro:.2e} (x{f_acc:g}, x{f_gyro:g}: what "
                      "the estimators need; graphnav.calibration.noise.ESTIMATOR_DENSITY_FACTOR)",
                      f"  beam noise                : {n.beam_noise_std:.4f} m/s ({n.n_beams} beams)",
                      f"  GT velocity error         : {gt}"]
        return "\n".join(lines)


def _q(value, sigma, unit):
    return Quantity(value, sigma, unit)
