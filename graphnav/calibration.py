"""Sensor calibration from a recorded mission: DVL lever arm, time offsets, DVL mounting, IMU axes.

Two modes (``graphnav calibrate``):

* **with ground truth** (``mode="gt"``): the IMU axes are checked against the GT attitude (gyro) and the
  GT roll/pitch (accelerometer gravity direction), the IMU-to-GT offset is found by matching attitude
  increments, and the DVL is regressed on the GT body velocity over candidate DVL offsets:

      v_dvl = (1 + s) Rz(psi)^T (v_b + omega_b x l_b) + [0, 0, b_z]

  (``v_b`` from the IMU-aided GT interpolation of :class:`graphnav.calibration_align.Reference`); l_b
  (lever arm), s (scale factor), psi (DVL mounting yaw, so that ``C_d_b = Rz(psi)``) and b_z (a vertical
  velocity bias: equal beam biases, the paper's model, show up on z only; horizontal biases would be
  nearly collinear with the scale factor at survey speed) by least squares at each candidate offset, the offset by minimising the residual.
  Uncertainties: parameter covariance ``sigma^2 (A^T A)^-1`` of the fit and offset sigma from the
  curvature of the profiled cost, both inflated by the residuals' autocorrelation
  (:func:`correlation_inflation`; real DVL-minus-GT residuals are correlated over a few seconds). They
  are statistical only: differences between trajectories (e.g. lever arm z) are larger.
* **without ground truth** (``mode="graph"``): see :mod:`graphnav.calibration_graph` (lever arm as a
  Point3 variable in the beam factors, DVL offset by profiling the graph's negative log-likelihood).

The result converts to a :class:`~graphnav.config.SensorConfig` (``SensorConfig.save`` writes the JSON
that every command accepts as ``--config``). Offsets in it are *totals* relative to the raw stamps (the
mission's already-applied offset plus the correction found here).
"""
from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from .calibration_align import (OffsetEstimate, Reference, _search_offset, _sigma_from_curvature,
                                cumulative_integral, estimate_gt_time_offset, interp_rows,
                                reference_gyro_increments, submerged_pings)
from .config import SensorConfig
from .dvl import DvlGeometry
from .errors import DataError
from .mission import Mission
from .noise_id import NoiseEstimate
from .rotations import skew

AXES = "xyz"


@dataclass
class Quantity:
    """An estimate with its 1-sigma uncertainty (same shape) and unit."""

    value: float | np.ndarray
    sigma: float | np.ndarray
    unit: str

    def to_dict(self) -> dict:
        plain = (lambda x: np.asarray(x).tolist())
        return {"value": plain(self.value), "sigma": plain(self.sigma), "unit": self.unit}


# ------------------------------------------------------------------------------------------------
# IMU axis check
# ------------------------------------------------------------------------------------------------
def signed_permutations() -> list[np.ndarray]:
    """The 48 signed permutation matrices P (corrected = P @ raw), identity first."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            P = np.zeros((3, 3))
            P[np.arange(3), perm] = signs
            out.append(P)
    return out


def describe_axis_map(P: np.ndarray, sensor: str) -> list[str]:
    """Human-readable suspects for a correction P (corrected axis i = sign * raw axis j)."""
    notes = []
    for i in range(3):
        j = int(np.flatnonzero(P[i])[0])
        sign = P[i, j]
        if j != i:
            notes.append(f"{sensor} {AXES[i]}: reads the raw {AXES[j]} axis"
                         + (" with its sign flipped" if sign < 0 else " (swapped axes)"))
        elif sign < 0:
            notes.append(f"{sensor} {AXES[i]}: sign flipped")
    return notes


@dataclass
class AxisCheck:
    """Result of the IMU axis check.

    Attributes:
        method: what the axes were checked against.
        gyro_map, accel_map: best correction P (corrected = P @ as-loaded), identity when consistent; None
            when not checked.
        gyro_rms, accel_rms: residual of the as-loaded axes and of the best map (rad per interval;
            m/s^2), as (as_loaded, best).
        suspects: named suspect axes (empty when the axes are consistent).
        notes: limits of the check.
    """

    method: str
    gyro_map: np.ndarray | None = None
    accel_map: np.ndarray | None = None
    gyro_rms: tuple[float, float] | None = None
    accel_rms: tuple[float, float] | None = None
    suspects: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.suspects

    @property
    def sign_correction(self) -> np.ndarray:
        """Per-axis sign corrections when both maps are pure sign flips on the same axes, else ones."""
        maps = [m for m in (self.gyro_map, self.accel_map) if m is not None]
        if not maps or any(not np.allclose(np.abs(m), np.eye(3)) for m in maps):
            return np.ones(3)
        signs = [np.diag(m) for m in maps]
        return signs[0] if all(np.array_equal(signs[0], s) for s in signs) else np.ones(3)

    def to_dict(self) -> dict:
        def plain(x):
            return None if x is None else np.asarray(x).tolist()
        return {"method": self.method, "ok": self.ok, "suspects": self.suspects, "notes": self.notes,
                "gyro_map": plain(self.gyro_map), "accel_map": plain(self.accel_map),
                "gyro_rms_as_loaded_best": plain(self.gyro_rms), "accel_rms_as_loaded_best": plain(self.accel_rms)}


#: A candidate axis map must beat the as-loaded axes by this factor to be reported. Against GT the
#: flipped A-KIT y axis scores 10-100x worse than the fix; without GT (tilt kinematics) 1.9-3.6x worse
#: (correct axes: exactly 1), hence the smaller margin there.
AXIS_MARGIN = 2.0
AXIS_MARGIN_NO_GT = 1.5


def _gt_predicted_specific_force(mission: Mission, gt_t: np.ndarray):
    """Mean specific force over each GT interval predicted from GT velocity and attitude, (K-1,3)."""
    gt = mission.gt
    g_n = np.array([0.0, 0.0, mission.config.gravity_mps2])
    dt = np.diff(gt_t)
    a_n = np.diff(gt.v_n, axis=0) / dt[:, None]
    incr = Rotation.from_matrix(np.swapaxes(gt.C_b_n[:-1], 1, 2) @ gt.C_b_n[1:]).as_rotvec()
    C_mid = (Rotation.from_matrix(gt.C_b_n[:-1]) * Rotation.from_rotvec(0.5 * incr)).as_matrix()
    return np.einsum("kji,kj->ki", C_mid, a_n - g_n)


def check_imu_axes_with_gt(mission: Mission) -> tuple[AxisCheck, OffsetEstimate]:
    """Check gyro and accelerometer axes against the GT; also returns the GT offset of the best gyro map.

    Gyro: each of the 48 signed permutations is scored by the residual of the attitude increments at its
    best IMU-to-GT offset (grid of 0.05 s over +-2 s); the GT offset returned is refined for the chosen map. Accelerometer: the interval-mean specific force against the one
    predicted from the GT (``C^T (dv_n/dt - g_n)``, dominated by the gravity direction, i.e. roll/pitch).
    """
    imu, gt, cfg = mission.imu, mission.gt, mission.config
    lat = cfg.lat_rad if cfg.earth_rotation else None
    t_imu = np.ascontiguousarray(imu.t)
    # Increments of a mapped gyro are the mapped increments (the integral is linear), so all 48 maps are
    # scored on one grid of offsets; ~1 s between reference samples is plenty to tell them apart.
    stride = max(1, int(round(1.0 / np.median(np.diff(gt.t)))))
    t_ref, C_ref = gt.t[::stride], gt.C_b_n[::stride]
    incr_ref = reference_gyro_increments(t_ref, C_ref, lat)
    S = np.asfortranarray(cumulative_integral(t_imu, imu.omega_b))
    offsets = np.arange(-2.0, 2.0 + 1e-9, 0.05)
    inside = (t_ref[:-1] - 2.0 >= t_imu[0]) & (t_ref[1:] + 2.0 <= t_imu[-1])
    incr = np.stack([interp_rows(t_ref[1:][inside] + o, t_imu, S) - interp_rows(t_ref[:-1][inside] + o, t_imu, S)
                     for o in offsets])                                   # (n_offsets, K, 3)
    maps = signed_permutations()
    scores = []
    for P in maps:
        rms = np.sqrt(np.mean((incr @ P.T - incr_ref[inside]) ** 2, axis=(1, 2)))
        scores.append(float(rms.min()))
    i_best = int(np.argmin(scores))
    check = AxisCheck("GT attitude (gyro increments) and GT roll/pitch (accelerometer gravity direction)")
    gyro_map = maps[i_best] if scores[i_best] * AXIS_MARGIN < scores[0] else np.eye(3)
    check.gyro_map = gyro_map
    check.gyro_rms = (scores[0], scores[i_best])
    offset = estimate_gt_time_offset(t_imu, imu.omega_b @ gyro_map.T, gt.t, gt.C_b_n, lat)
    # accelerometer: interval means on the IMU clock with the GT shifted by the offset found
    gt_t = gt.t + offset.offset_s
    f_pred = _gt_predicted_specific_force(mission, gt_t)
    F = np.asfortranarray(cumulative_integral(t_imu, imu.f_b))
    ok = (gt_t[:-1] >= t_imu[0]) & (gt_t[1:] <= t_imu[-1])
    f_meas = (interp_rows(gt_t[1:][ok], t_imu, F) - interp_rows(gt_t[:-1][ok], t_imu, F)) \
        / np.diff(gt_t)[ok][:, None]
    acc = [(float(np.sqrt(np.mean((f_meas @ P.T - f_pred[ok]) ** 2))), P) for P in signed_permutations()]
    best_acc = min(acc, key=lambda r: r[0])
    accel_map = best_acc[1] if best_acc[0] * AXIS_MARGIN < acc[0][0] else np.eye(3)
    check.accel_map = accel_map
    check.accel_rms = (acc[0][0], best_acc[0])
    check.suspects = describe_axis_map(gyro_map, "gyro") + describe_axis_map(accel_map, "accelerometer")
    return check, offset


def check_imu_axes_without_gt(mission: Mission) -> AxisCheck:
    """Axis check from the IMU alone: gravity on the accelerometer z axis, and tilt kinematics.

    The gravity direction seen by the accelerometer, ``u = -f_b/|f_b|`` (1 s means), must turn as
    ``du/dt = u x omega_b`` with the gyro. Sign flips of the x/y axes of either sensor (including a flipped
    y on both, a left-handed frame) break that relation. Not checkable this way: the gyro z sign (rotation
    about gravity leaves u unchanged) and a 180 deg rotation about z of both sensors.
    """
    imu = mission.imu
    check = AxisCheck("IMU self-consistency: gravity on accelerometer z, tilt kinematics (gyro vs "
                      "accelerometer)")
    check.notes.append("gyro z sign and a 180 deg turn about z of both sensors need a heading reference (GT)")
    t = np.ascontiguousarray(imu.t)
    edges = np.arange(t[0], t[-1], 1.0)
    F = np.asfortranarray(cumulative_integral(t, imu.f_b))
    W = np.asfortranarray(cumulative_integral(t, imu.omega_b))
    f = np.diff(interp_rows(edges, t, F), axis=0)
    w = np.diff(interp_rows(edges, t, W), axis=0)
    accel = np.eye(3)
    if np.mean(f[:, 2]) > 0:                     # FRD at rest: f_z = -g
        accel = np.diag([1.0, 1.0, -1.0])
        check.suspects.append("accelerometer z: sign flipped (gravity reads +g on z, FRD expects -g)")
    results = []
    for sa in itertools.product((1.0, -1.0), repeat=2):
        for sg in itertools.product((1.0, -1.0), repeat=2):
            Sa = accel @ np.diag([*sa, 1.0])
            Sg = np.diag([*sg, 1.0])
            u = -(f @ Sa.T)
            u /= np.linalg.norm(u, axis=1, keepdims=True)
            du = (u[2:] - u[:-2]) / 2.0                     # central difference at 1 s spacing
            pred = np.cross(u[1:-1], w[1:-1] @ Sg.T)
            results.append((float(np.sqrt(np.mean((du - pred)[:, :2] ** 2))), Sa, Sg, len(np.flatnonzero(
                np.concatenate([np.array(sa), np.array(sg)]) < 0))))
    as_loaded = results[0]
    best = min(results, key=lambda r: (round(r[0] / max(as_loaded[0], 1e-12), 2), r[3]))
    if best[0] * AXIS_MARGIN_NO_GT < as_loaded[0]:
        check.accel_map, check.gyro_map = best[1], best[2]
        check.suspects += describe_axis_map(np.diag(np.diag(best[1]) * np.diag(accel)), "accelerometer") \
            + describe_axis_map(best[2], "gyro")
    else:
        check.accel_map, check.gyro_map = accel, np.eye(3)
    check.gyro_rms = (as_loaded[0], best[0])
    return check


def apply_axis_map(mission: Mission, gyro_map: np.ndarray, accel_map: np.ndarray) -> Mission:
    """A copy of the mission with the IMU axes corrected (corrected = map @ as-loaded)."""
    imu = dataclasses.replace(mission.imu, f_b=mission.imu.f_b @ accel_map.T,
                              omega_b=mission.imu.omega_b @ gyro_map.T)
    return dataclasses.replace(mission, imu=imu)


#: The axis convention of the published A-KIT IMU files (signs that make the raw axes FRD: y flipped); the
#: authors' corrected files have y in the body frame, (1, 1, 1).
AKIT_PUBLISHED_AXIS_SIGNS = (1.0, -1.0, 1.0)


@dataclass
class AxisDetection:
    """What :func:`detect_imu_axis_signs` chose and why.

    Attributes:
        signs: signs to apply to the raw x, y, z of both accelerometer and gyro (FRD afterwards).
        check: the axis check that decided (run on the raw axes, or on the y-flipped axes when the raw
            axes looked consistent and had to be confirmed against the other convention).
        gt_offset: the IMU-to-GT offset the GT check found for the chosen axes (None without GT).
        decided: False when the data cannot tell the conventions apart (too little rotation); ``signs``
            are then the published A-KIT convention.
        notes: what the warning says beyond the choice.
    """

    signs: np.ndarray
    check: AxisCheck
    gt_offset: OffsetEstimate | None = None
    decided: bool = True
    notes: list[str] = field(default_factory=list)

    def message(self, source: str) -> str:
        how = "against the GT attitude" if self.gt_offset is not None else "from gravity/gyro consistency (no GT)"
        what = (f"chose imu_axis_signs={tuple(int(s) for s in self.signs)}" if self.decided else
                f"could not tell the conventions apart; assumed {tuple(int(s) for s in self.signs)}")
        return (f"{source}: IMU axis convention detected {how}: {what}"
                + "".join(f"; {n}" for n in self.notes) + "; pass imu_axis_signs explicitly to override")


def _run_axis_check(imu, gt, config) -> tuple[AxisCheck, OffsetEstimate | None]:
    probe = SimpleNamespace(imu=imu, gt=gt, config=config)   # the checks read only these three
    if gt is not None:
        return check_imu_axes_with_gt(probe)
    return check_imu_axes_without_gt(probe), None


def detect_imu_axis_signs(imu, config: SensorConfig, gt=None, source: str = "IMU") -> AxisDetection:
    """The sign convention of raw IMU axes, by the IMU axis check (:func:`check_imu_axes_with_gt`, or
    :func:`check_imu_axes_without_gt` when ``gt`` is None).

    One set of signs applies to both sensors (a file convention, as :func:`graphnav.loaders.read_akit`
    applies it). The check runs on the raw axes; when it finds them consistent it runs again on the
    y-flipped axes, which must then be reported flipped, otherwise the data cannot tell the conventions
    apart (``decided=False``, the published A-KIT signs are assumed). Rules: with GT the gyro decides (its
    attitude increments separate the conventions 10-100x); the accelerometer (gravity direction, weak at
    small roll) must not contradict it. Without GT the x/y signs come from the tilt kinematics and z from
    gravity; a turn about z of both sensors is invisible to the IMU alone: of the two sign conventions
    that then fit equally (a 180 deg turn apart) the one with x = +1 (x forward, as in both A-KIT
    conventions) is taken, and swapped x/y axes are not detected without GT.

    Args:
        imu: :class:`~graphnav.mission.ImuData` with the raw axes. config: lat/gravity/earth_rotation used
        by the GT check. gt: :class:`~graphnav.mission.GroundTruth` on the file's clock, or None.

    Raises:
        DataError: no sign convention fits (swapped axes, or gyro and accelerometer flipped differently),
            naming the axis.
    """
    check, offset = _run_axis_check(imu, gt, config)
    signs = _signs_of(check, gt is not None, source)
    notes = []
    decided = True
    g, a = np.diag(check.gyro_map), np.diag(check.accel_map)
    if gt is not None and np.any(g != a):
        # one sensor decided a flip the other did not see: the flipped axes must then check consistent
        fixed = dataclasses.replace(imu, f_b=imu.f_b * signs, omega_b=imu.omega_b * signs)
        recheck, offset = _run_axis_check(fixed, gt, config)
        if not recheck.ok:
            rg, ra = np.diag(recheck.gyro_map), np.diag(recheck.accel_map)
            i = int(np.flatnonzero((rg != 1) | (ra != 1))[0]) if np.any((rg != 1) | (ra != 1)) else 0
            raise _disagree(check, g, a, i, source)
        notes.append(f"{'accelerometer' if np.all(a == 1) else 'gyro'} check undecided on "
                     f"{', '.join(AXES[i] for i in np.flatnonzero(g != a))} (too little motion), the other decided")
    if np.all(signs == 1):
        flip = np.asarray(AKIT_PUBLISHED_AXIS_SIGNS)
        flipped = dataclasses.replace(imu, f_b=imu.f_b * flip, omega_b=imu.omega_b * flip)
        check_f, offset_f = _run_axis_check(flipped, gt, config)
        if np.array_equal(_signs_of(check_f, gt is not None, source), flip):
            offset = offset_f if offset_f is not None else offset
        else:
            decided = False
            signs = flip.copy()
            notes.append("the data carry too little rotation/tilt to tell y as recorded from y flipped")
    if gt is None:
        notes.append("without GT the gyro z sign follows the accelerometer's gravity and x is taken forward "
                     "(a turn about z cannot be seen)")
    return AxisDetection(signs, check, offset, decided, notes)


def _signs_of(check: AxisCheck, with_gt: bool, source: str) -> np.ndarray:
    """The one sign vector of a check's maps, or DataError naming the axis when none fits."""
    for P, sensor in ((check.gyro_map, "gyro"), (check.accel_map, "accelerometer")):
        if not np.allclose(np.abs(P), np.eye(3)):
            swapped = [AXES[i] for i in range(3) if P[i, i] == 0]
            raise DataError(f"no IMU axis sign convention fits: {'; '.join(describe_axis_map(P, sensor))}"
                            f" (axes are swapped, not sign-flipped); fix the file or pass imu_axis_signs",
                            source, field=f"{sensor} {swapped[0]}")
    g, a = np.diag(check.gyro_map).copy(), np.diag(check.accel_map).copy()
    if not with_gt:
        g[2] = a[2]                       # gyro z is not observable from tilt: it follows gravity's axis
        if g[0] < 0 and a[0] < 0:         # 180 deg about z of both sensors: take x forward
            g[:2] *= -1
            a[:2] *= -1
    differ = np.flatnonzero(g != a)
    if differ.size and with_gt:
        # against GT a check reports a flip only when it beats the as-loaded axes by AXIS_MARGIN, while "as
        # loaded" may mean undecided (no rotation about that axis, little roll/pitch): the flip wins, and
        # detect_imu_axis_signs re-checks the result
        return np.minimum(g, a)
    if differ.size:
        raise _disagree(check, g, a, int(differ[0]), source)
    return g


def _disagree(check: AxisCheck, g: np.ndarray, a: np.ndarray, i: int, source: str) -> DataError:
    return DataError(f"no IMU axis sign convention fits: gyro {AXES[i]} sign {g[i]:+.0f} but accelerometer "
                     f"{AXES[i]} sign {a[i]:+.0f} (one convention applies to both sensors); suspects: "
                     f"{'; '.join(check.suspects) or 'none'}; pass imu_axis_signs", source, field=f"axis {AXES[i]}")


# ------------------------------------------------------------------------------------------------
# Where the accelerometer sits relative to the reference (GT) point
# ------------------------------------------------------------------------------------------------
def estimate_imu_position(mission: Mission) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Position r (body, m) of the accelerometer's measurement point relative to the GT reference point.

    A rigid body's specific force at r differs from the one at the reference point by
    ``omega_dot x r + omega x (omega x r)``. Interval means (between GT samples) of the measured specific
    force minus the one predicted from the GT (``C^T (dv_n/dt - g_n)``) are regressed on that, with a
    constant bias. Returns (r, covariance of r, residual RMS before, after), m/s^2. The GT stamps must
    already be on the IMU clock. r matters because the estimators integrate the IMU: the DVL lever arm
    they need is the DVL's position relative to the accelerometer point, ``l_dvl - r``.
    """
    imu, gt = mission.imu, mission.gt
    t = np.ascontiguousarray(imu.t)
    ok = (gt.t[:-1] >= t[0]) & (gt.t[1:] <= t[-1])
    a, b = gt.t[:-1][ok], gt.t[1:][ok]
    F = np.asfortranarray(cumulative_integral(t, imu.f_b))
    W = np.asfortranarray(cumulative_integral(t, imu.omega_b))
    dt = (b - a)[:, None]
    f_meas = (interp_rows(b, t, F) - interp_rows(a, t, F)) / dt
    w_mean = (interp_rows(b, t, W) - interp_rows(a, t, W)) / dt
    d = f_meas - _gt_predicted_specific_force(mission, gt.t)[ok]
    w_dot = np.gradient(w_mean, 0.5 * (a + b), axis=0)
    A = np.concatenate([skew(w_dot) + skew(w_mean) @ skew(w_mean), np.broadcast_to(np.eye(3), (len(a), 3, 3))],
                       axis=2).reshape(-1, 6)
    x, *_ = np.linalg.lstsq(A, d.reshape(-1), rcond=None)
    e = d.reshape(-1) - A @ x
    cov = np.linalg.pinv(A.T @ A) * float(e @ e) / max(len(e) - 6, 1) * correlation_inflation(e.reshape(-1, 3))
    return x[:3], cov[:3, :3], float(np.sqrt(np.mean(d ** 2))), float(np.sqrt(np.mean(e ** 2)))


# ------------------------------------------------------------------------------------------------
# DVL regression against the GT
# ------------------------------------------------------------------------------------------------
PARAM_NAMES = ("l_x", "l_y", "l_z", "scale", "yaw", "b_z")
N_PARAMS = len(PARAM_NAMES)


def dvl_velocity(mission: Mission) -> tuple[np.ndarray, np.ndarray]:
    """The DVL-head body velocity of each ping as the estimators see it, and the mask of usable pings.

    The instrument's own velocity (``dvl.v_b``) when present, else least squares from >= 3 valid beams
    with the configured geometry.
    """
    dvl = mission.dvl
    if dvl.v_b is not None:
        v = dvl.v_b
    else:
        v = DvlGeometry.from_spec(mission.config.dvl).velocity_from_beams(dvl.beams, dvl.valid,
                                                                          allow_missing=True)
    return v, np.all(np.isfinite(v), axis=1)


def _design(reference: Reference, t: np.ndarray):
    C = reference.C_b_n(t)
    v_ref = reference.v_b(t, C)
    omega = reference.omega_nb_b(t, C)
    # linearised about l = s = psi = b = 0 (the small terms' products, e.g. s * omega x l, are left to the
    # exact refinement)
    A = np.zeros((len(t), 3, N_PARAMS))
    A[:, :, 0:3] = skew(omega)                   # omega x l
    A[:, :, 3] = v_ref                           # s v
    A[:, :, 4] = np.stack([v_ref[:, 1], -v_ref[:, 0], np.zeros(len(t))], axis=1)  # Rz(psi)^T v ~ v + psi [v_y, -v_x, 0]
    A[:, 2, 5] = 1.0                             # vertical bias (equal beam biases show up on z only)
    return A, v_ref, omega


def _exact_residual(theta, v_dvl, v_ref, omega):
    l, s, psi, b = theta[0:3], theta[3], theta[4], np.array([0.0, 0.0, theta[5]])
    head = v_ref + np.cross(omega, l)
    Rz_T = Rotation.from_euler("z", -psi).as_matrix()
    return (v_dvl - ((1 + s) * head @ Rz_T.T + b)).reshape(-1)


@dataclass
class DvlFit:
    """DVL regression result at one offset: parameters, covariance, residual RMS, pings used."""

    offset_s: float
    theta: np.ndarray
    cov: np.ndarray
    rms: float
    n_pings: int
    sse: float


def correlation_inflation(e: np.ndarray, max_lag: int = 20) -> float:
    """Variance inflation ``1 + 2 sum_k rho_k`` of a mean over residuals correlated in time (k up to the
    first non-positive autocorrelation, at most ``max_lag``), averaged over the columns of e (N,k).

    Least-squares covariances assume white residuals; the real DVL-minus-GT residuals are correlated over
    a few pings (GT smoothing, waves), which this factor accounts for (approximately: it treats every
    regressor as slowly varying).
    """
    e = e - e.mean(axis=0)
    var = np.sum(e * e, axis=0)
    if np.any(var <= 0):
        return 1.0
    total = 1.0
    for k in range(1, min(max_lag, len(e) - 1) + 1):
        rho = float(np.mean(np.sum(e[k:] * e[:-k], axis=0) / var))
        if rho <= 0:
            break
        total += 2 * rho
    return total


def fit_dvl(reference: Reference, t_raw: np.ndarray, v_dvl: np.ndarray, offset_s: float,
            use: np.ndarray, exact: bool = False) -> DvlFit:
    """Least-squares fit of (l, s, psi, b) at one DVL offset (linearised; ``exact`` refines the
    nonlinear model with scipy's least_squares)."""
    t = t_raw[use] + offset_s
    A, v_ref, omega = _design(reference, t)
    r = (v_dvl[use] - v_ref).reshape(-1)
    A2 = A.reshape(-1, N_PARAMS)
    theta, *_ = np.linalg.lstsq(A2, r, rcond=None)
    if exact:
        sol = least_squares(_exact_residual, theta, args=(v_dvl[use], v_ref, omega), method="lm")
        theta = sol.x
        e = sol.fun
        J = sol.jac
    else:
        e = r - A2 @ theta
        J = A2
    sse = float(e @ e)
    dof = max(len(e) - N_PARAMS, 1)
    cov = np.linalg.pinv(J.T @ J) * sse / dof * correlation_inflation(e.reshape(-1, 3))
    return DvlFit(offset_s, theta, cov, float(np.sqrt(sse / len(e))), int(use.sum()), sse)


def calibrate_dvl_with_gt(reference: Reference, t_raw: np.ndarray, v_dvl: np.ndarray, use: np.ndarray,
                          search_s: tuple[float, float] = (-3.0, 3.0), step_s: float = 0.1
                          ) -> tuple[DvlFit, float]:
    """Profile the DVL fit over candidate offsets; returns (exact fit at the best offset, offset sigma)."""
    use = use & reference.covers(t_raw + search_s[0]) & reference.covers(t_raw + search_s[1])
    if use.sum() < 20:
        raise DataError("fewer than 20 DVL pings overlap the ground truth", "dvl")

    def cost(offset):
        return fit_dvl(reference, t_raw, v_dvl, offset, use).sse

    x, sse, curv = _search_offset(cost, search_s[0], search_s[1], step_s)
    fit = fit_dvl(reference, t_raw, v_dvl, x, use, exact=True)
    inflation = correlation_inflation(_exact_residual(fit.theta, v_dvl[use], *_design(reference, t_raw[use] + x)[1:]
                                                      ).reshape(-1, 3))
    sigma = _sigma_from_curvature(sse, curv, 3 * int(use.sum()), N_PARAMS + 1) * np.sqrt(inflation)
    return fit, sigma


# ------------------------------------------------------------------------------------------------
# The result and the entry points
# ------------------------------------------------------------------------------------------------
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
        imu_position_b: gt mode: the accelerometer's position relative to the GT reference point, m
            (:func:`estimate_imu_position`); the lever arm above is relative to the GT point.
        info: extra diagnostics.
        noise: identified IMU densities, beam noise and GT velocity error (:mod:`graphnav.noise_id`), written
            into ``config`` (``imu.*_noise_density``, ``dvl.beam_noise_std``); None if not identified.
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

    def to_dict(self) -> dict:
        def q(x):
            return None if x is None else x.to_dict()
        return {"mode": self.mode, "lever_arm_b": q(self.lever_arm_b),
                "dvl_time_offset_s": q(self.dvl_time_offset_s), "gt_time_offset_s": q(self.gt_time_offset_s),
                "dvl_yaw_rad": q(self.dvl_yaw_rad), "dvl_scale": q(self.dvl_scale), "dvl_bias": q(self.dvl_bias),
                "imu_position_b": q(self.imu_position_b),
                "residual_rms": self.residual_rms, "axis_check": self.axis_check.to_dict(),
                "noise": None if self.noise is None else self.noise.to_dict(),
                "info": {k: v for k, v in self.info.items() if isinstance(v, (int, float, str, bool))}}

    def report(self) -> str:
        def fmt(x: Quantity | None, scale=1.0, unit=None, digits=3):
            if x is None:
                return "not estimated in this mode"
            v, s = np.atleast_1d(x.value) * scale, np.atleast_1d(x.sigma) * scale
            parts = [f"{a:+.{digits}f} +- {b:.{digits}f}" for a, b in zip(v, s)]
            return ("[" + ", ".join(parts) + "]" if len(parts) > 1 else parts[0]) + f" {unit or x.unit}"
        ref = "GT point" if self.mode == "gt" else "IMU"
        lines = [f"calibration mode: {self.mode}",
                 f"  DVL lever arm (vs {ref:<8}): {fmt(self.lever_arm_b)}",
                 f"  DVL time offset           : {fmt(self.dvl_time_offset_s)}",
                 f"  IMU-to-GT time offset     : {fmt(self.gt_time_offset_s)}",
                 f"  DVL mounting yaw          : {fmt(self.dvl_yaw_rad, 180 / np.pi, 'deg')}",
                 f"  DVL scale factor          : {fmt(self.dvl_scale, 100, '%')}",
                 f"  DVL vertical bias         : {fmt(self.dvl_bias, 1e3, 'mm/s', 1)}",
                 f"  residual RMS              : {self.residual_rms:.4f}",
                 f"  IMU position vs GT point  : {fmt(self.imu_position_b)}",
                 f"  IMU axes ({self.axis_check.method}): "
                 + ("consistent" if self.axis_check.ok else "SUSPECT: " + "; ".join(self.axis_check.suspects))]
        lines += [f"    note: {n}" for n in self.axis_check.notes]
        if self.noise is not None:
            n = self.noise
            gt = ("-" if n.gt_velocity_sigma_n is None
                  else "[" + ", ".join(f"{x:.4f}" for x in n.gt_velocity_sigma_n) + "] m/s (N, E, D; upper bound)")
            lines += [f"  accel noise density       : {n.accel_noise_density:.2e} m/s^2/sqrt(Hz)",
                      f"  gyro noise density        : {n.gyro_noise_density:.2e} rad/s/sqrt(Hz)",
                      f"  beam noise                : {n.beam_noise_std:.4f} m/s ({n.n_beams} beams)",
                      f"  GT velocity error         : {gt}"]
        return "\n".join(lines)


def _q(value, sigma, unit):
    return Quantity(value, sigma, unit)


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
                    cfg0.gravity_mps2, cfg0.lat_rad if cfg0.earth_rotation else None)
    v_dvl, usable = dvl_velocity(work)
    usable &= submerged_pings(work, min_depth_m) if work.depth is not None else True
    fit, off_sigma = calibrate_dvl_with_gt(ref, work.dvl.t, v_dvl, usable)
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
    return CalibrationResult(
        "gt", _q(th[0:3], sig[0:3], "m"), _q(cfg.dvl_time_offset_s, off_sigma, "s"),
        _q(cfg.gt_time_offset_s, gt_est.sigma_s, "s"), _q(th[4], sig[4], "rad"), _q(th[3], sig[3], "-"),
        _q(th[5], sig[5], "m/s"), fit.rms, check, cfg, _q(r_imu, np.sqrt(np.diag(r_cov)), "m"),
        info={"accel_residual_rms_before_after": f"{r_before:.4f} -> {r_after:.4f} m/s^2","dvl_offset_correction_s": fit.offset_s, "gt_offset_correction_s": gt_est.offset_s,
              "pings_used": fit.n_pings, "gyro_increment_rms_rad": gt_est.rms})


def calibrate(mission: Mission, mode: str = "auto", identify_noise: bool = False, **kwargs) -> CalibrationResult:
    """Calibrate a mission: ``mode`` = ``"gt"``, ``"graph"`` or ``"auto"`` (gt when GT is present).

    ``identify_noise``: also identify the IMU white-noise densities and the beam noise from the data
    (:func:`graphnav.noise_id.identify`, one all-beam batch-smoother run; with GT also the GT's velocity
    error) and write them into the calibrated configuration (``graphnav calibrate`` does by default).
    """
    if mode == "auto":
        mode = "gt" if mission.gt is not None else "graph"
    if mode == "gt":
        result = calibrate_with_gt(mission, **kwargs)
    elif mode == "graph":
        from .calibration_graph import calibrate_with_graph
        result = calibrate_with_graph(mission, **kwargs)
    else:
        raise ValueError(f"unknown calibration mode '{mode}' (gt, graph, auto)")
    if identify_noise:
        from .noise_id import identify
        noise = identify(mission)
        result.noise = noise
        result.config.imu.accel_noise_density = noise.accel_noise_density
        result.config.imu.gyro_noise_density = noise.gyro_noise_density
        result.config.dvl.beam_noise_std = noise.beam_noise_std
    return result
