"""IMU axis conventions: the check of the gyro and accelerometer axes against the GT attitude or against
gravity and each other, and the detection the prepare step runs on a mission as read
(:mod:`graphnav.calibration.preparation`)."""
from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np
from scipy.spatial.transform import Rotation

from graphnav.calibration.reference import (
    OffsetEstimate,
    cumulative_integral,
    estimate_gt_time_offset,
    interp_rows,
    reference_gyro_increments,
)
from graphnav.core.config import SensorConfig
from graphnav.core.errors import DataError
from graphnav.core.mission import Mission
from graphnav.io.units import GYRO_TILT_MIN_RADPS

AXES = "xyz"


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


def gt_predicted_specific_force(mission: Mission, gt_t: np.ndarray):
    """Mean specific force over each GT interval predicted from GT velocity and attitude, (K-1,3)."""
    gt = mission.gt
    g_n = np.array([0.0, 0.0, mission.config.gravity_mps2])
    dt = np.diff(gt_t)
    a_n = np.diff(gt.v_n, axis=0) / dt[:, None]
    incr = Rotation.from_matrix(np.swapaxes(gt.C_b_n[:-1], 1, 2) @ gt.C_b_n[1:]).as_rotvec()
    C_mid = (Rotation.from_matrix(gt.C_b_n[:-1]) * Rotation.from_rotvec(0.5 * incr)).as_matrix()
    return np.einsum("kji,kj->ki", C_mid, a_n - g_n)


#: Fewest reference intervals of about 1 s inside the IMU span (+-2 s of offset searched) the gyro is checked
#: against (:func:`check_imu_axes_with_gt`).
MIN_AXIS_GT_INTERVALS = 10


def _axis_intervals(t_ref: np.ndarray, t_imu: np.ndarray) -> np.ndarray:
    """(K-1,) True for the intervals of reference stamps ``t_ref`` (s) inside the IMU span at every offset searched."""
    return (t_ref[:-1] - 2.0 >= t_imu[0]) & (t_ref[1:] + 2.0 <= t_imu[-1])


def gt_checks_axes(t_gt: np.ndarray, t_imu: np.ndarray) -> tuple[bool, int]:
    """``(enough, n)``: whether a reference stamped ``t_gt`` (s, on the IMU clock ``t_imu``) shares the
    :data:`MIN_AXIS_GT_INTERVALS` intervals of about 1 s :func:`check_imu_axes_with_gt` needs, and how many."""
    t_gt = np.asarray(t_gt, float)
    if t_gt.size < 2:
        return False, 0
    stride = max(1, int(round(1.0 / np.median(np.diff(t_gt)))))
    n = int(_axis_intervals(t_gt[::stride], np.asarray(t_imu, float)).sum())
    return n >= MIN_AXIS_GT_INTERVALS, n


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
    inside = _axis_intervals(t_ref, t_imu)
    if inside.sum() < MIN_AXIS_GT_INTERVALS:       # the scores below would be means of nothing
        raise DataError(f"the GT stamps [{gt.t[0]:.3f}, {gt.t[-1]:.3f}] s share {int(inside.sum())} interval(s) with "
                        f"the IMU span [{t_imu[0]:.3f}, {t_imu[-1]:.3f}] s: too few to check the IMU axes against it "
                        f"({MIN_AXIS_GT_INTERVALS} needed): give imu_axis_signs and gt_time_offset_s in a --config "
                        "file, or leave the GT out", gt.source, field="t")
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
    offset = estimate_gt_time_offset(t_imu, imu.omega_b @ gyro_map.T, gt.t, gt.C_b_n, lat, source=gt.source)
    # accelerometer: interval means on the IMU clock with the GT shifted by the offset found
    gt_t = gt.t + offset.offset_s
    f_pred = gt_predicted_specific_force(mission, gt_t)
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
    accel = np.eye(3)
    if _gravity_on_plus_z(imu):                  # FRD at rest: f_z = -g
        accel = np.diag([1.0, 1.0, -1.0])
        check.suspects.append("accelerometer z: sign flipped (gravity reads +g on z, FRD expects -g)")
    results = []
    for (sa, sg), rms in tilt_residuals(imu, accel[2, 2]).items():
        Sa = accel @ np.diag([*sa, 1.0])
        results.append((rms, Sa, np.diag([*sg, 1.0]), int(np.sum(np.array([*sa, *sg]) < 0))))
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


def _gravity_on_plus_z(imu) -> bool:
    return bool(np.mean(imu.f_b[:, 2]) > 0)


def tilt_residuals(imu, accel_z_sign: float = 1.0) -> dict:
    """RMS mismatch (rad/s) of the tilt kinematics ``du/dt = u x omega`` (u: gravity direction from the
    accelerometer, 1 s means) for the 16 x/y sign choices of both sensors: ``{((ax, ay), (gx, gy)): rms}``
    (z of the accelerometer multiplied by ``accel_z_sign``; the gyro z does not enter the x/y rows)."""
    t = np.ascontiguousarray(imu.t)
    edges = np.arange(t[0], t[-1], 1.0)
    F = np.asfortranarray(cumulative_integral(t, imu.f_b))
    W = np.asfortranarray(cumulative_integral(t, imu.omega_b))
    f = np.diff(interp_rows(edges, t, F), axis=0)
    w = np.diff(interp_rows(edges, t, W), axis=0)
    out = {}
    for sa in itertools.product((1.0, -1.0), repeat=2):
        for sg in itertools.product((1.0, -1.0), repeat=2):
            u = -(f * [*sa, accel_z_sign])
            u /= np.linalg.norm(u, axis=1, keepdims=True)
            du = (u[2:] - u[:-2]) / 2.0                     # central difference at 1 s spacing
            pred = np.cross(u[1:-1], (w * [*sg, 1.0])[1:-1])
            out[(sa, sg)] = float(np.sqrt(np.mean((du - pred)[:, :2] ** 2)))
    return out


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
        undecided: why the data could not tell y as recorded from y flipped (one of ``notes``), None when decided.
    """

    signs: np.ndarray
    check: AxisCheck
    gt_offset: OffsetEstimate | None = None
    decided: bool = True
    notes: list[str] = field(default_factory=list)
    undecided: str | None = None

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


def detect_imu_axis_signs(imu, config: SensorConfig, gt=None, source: str = "IMU",
                          fallback_signs=AKIT_PUBLISHED_AXIS_SIGNS) -> AxisDetection:
    """The sign convention of raw IMU axes, by the IMU axis check (:func:`check_imu_axes_with_gt`, or
    :func:`check_imu_axes_without_gt` when ``gt`` is None).

    One set of signs applies to both sensors (a file convention, as :func:`graphnav.io.loaders.read_akit`
    applies it). The check runs on the raw axes; when it finds them consistent it runs again on the
    y-flipped axes, which must then be reported flipped, otherwise the data cannot tell the conventions
    apart (``decided=False``, the published A-KIT signs are assumed). Rules: with GT the gyro decides (its
    attitude increments separate the conventions 10-100x); the accelerometer (gravity direction, weak at
    small roll) must not contradict it. Without GT the x/y signs come from the tilt kinematics and z from
    gravity; a turn about z of both sensors is invisible to the IMU alone: of the two sign conventions
    that then fit equally (a 180 deg turn apart) the one with x = +1 (x forward, as in both A-KIT
    conventions) is taken, and swapped x/y axes are not detected without GT.

    Without GT the conventions are compared as wholes (:func:`_detect_without_gt`): one sign vector for both
    sensors, y as recorded against y flipped; when neither fits :data:`AXIS_MARGIN_JOINT` better, the
    detection falls back to ``fallback_signs`` (``decided=False``, the caller warns and notes it) rather than
    refusing.

    Args:
        imu: :class:`~graphnav.core.mission.ImuData` with the raw axes. config: lat/gravity/earth_rotation used
        by the GT check. gt: :class:`~graphnav.core.mission.GroundTruth` on the file's clock, or None.
        fallback_signs: the configured convention, taken when the data cannot decide.

    Raises:
        DataError: no sign convention fits (swapped axes, or gyro and accelerometer flipped differently),
            naming the axis.
    """
    if gt is None:
        return _detect_without_gt(imu, source, fallback_signs)
    check, offset = _run_axis_check(imu, gt, config)
    signs = _signs_of(check, gt is not None, source)
    notes = []
    undecided = None
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
            signs = flip.copy()
            undecided = "the data carry too little rotation/tilt to tell y as recorded from y flipped"
            notes.append(undecided)
    return AxisDetection(signs, check, offset, undecided is None, notes, undecided)


#: Without GT, the y-as-recorded and y-flipped conventions (both sensors, x forward) are told apart when the
#: worse one's tilt-kinematics residual is this many times the better one's. Measured on 60 s windows of the
#: ten shared trajectories, every 30 s (120 windows, ``experiments/axis_detection_rates.py``): the wrong convention's
#: residual is 1.06-9x the right one's (5th percentile 1.45, median 2.4), never below 1; at 1.2, 99 % of the
#: windows decide, all of them right, and whole trajectories all decide right.
AXIS_MARGIN_JOINT = 1.2
#: A mixed choice (gyro and accelerometer flipped differently) is reported as a fault when it fits this many
#: times better than the better convention. Measured (``experiments/axis_detection_rates.py --mixed``): on the
#: clean files the best mixed choice beats the better convention by at most 0.98x over whole trajectories and
#: 1.29x over 60 s windows (noise); with the gyro y flipped alone it wins by 1.17-2.02x over whole
#: trajectories and 1.02-2.89x (median 1.56) over 60 s windows. Below the margin the convention is chosen.
#: Logs of at least MIXED_LONG_S use the smaller margin, between the clean 0.98 and the faulty 1.17 above
#: (clean 250 s and 300 s windows every 50 s: 70 windows, none refused; faulty 300 s windows: 27 of 30 refused).
#: Under :data:`~graphnav.io.units.GYRO_TILT_MIN_RADPS` of tilt motion (a nearly level vehicle) the accelerometer's
#: gravity direction follows the vehicle's accelerations in turns as much as its tilt, and the conventions are told
#: apart at this larger margin. Measured (simulated 300 s vehicles at 0.4 m/s turning at up to 3 deg/s, seeds 1-3,
#: accelerometer noise 0-0.03 m/s^2): level ones (no roll or pitch) fit the wrong y 1.20-1.26x better, those rolling and
#: pitching 0.05-0.2 deg (median tilt rate 3.4e-4-8.4e-4 rad/s) the right y 1.69-10x better.
AXIS_MARGIN_LEVEL = 1.5
MIXED_MARGIN = 1.4
MIXED_MARGIN_LONG = 1.1
MIXED_LONG_S = 250.0


def _detect_without_gt(imu, source: str, fallback_signs) -> AxisDetection:
    """The sign convention from the IMU alone: z from gravity, then the two x/y conventions of both sensors
    together (a 180 deg turn about z is invisible, so x is taken forward) by their tilt-kinematics residuals."""
    z = -1.0 if _gravity_on_plus_z(imu) else 1.0
    r = tilt_residuals(imu, z)
    keep = min(r[((1.0, 1.0), (1.0, 1.0))], r[((-1.0, -1.0), (-1.0, -1.0))])
    flip = min(r[((1.0, -1.0), (1.0, -1.0))], r[((-1.0, 1.0), (-1.0, 1.0))])
    mixed_key = min((k for k in r if k[0] != k[1]), key=r.get)
    check = AxisCheck("IMU self-consistency: gravity on accelerometer z, tilt kinematics of the two x/y sign "
                      "conventions (both sensors)")
    check.notes.append("gyro z sign and a 180 deg turn about z of both sensors need a heading reference (GT)")
    check.gyro_rms = (r[((1.0, 1.0), (1.0, 1.0))], min(keep, flip))
    notes = ["without GT the gyro z sign follows the accelerometer's gravity and x is taken forward "
             "(a turn about z cannot be seen)"]
    margin = MIXED_MARGIN_LONG if imu.t[-1] - imu.t[0] >= MIXED_LONG_S else MIXED_MARGIN
    if min(keep, flip) > margin * r[mixed_key]:
        sa, sg = mixed_key
        i = int(np.flatnonzero(np.array(sa) != np.array(sg))[0])
        raise DataError(f"no IMU axis sign convention fits: gyro {AXES[i]} sign {sg[i]:+.0f} but accelerometer "
                        f"{AXES[i]} sign {sa[i]:+.0f} fits the tilt kinematics "
                        f"{min(keep, flip) / r[mixed_key]:.1f}x better than any one convention for both sensors; "
                        f"{_ONE_SENSOR}", source, field=f"axis {AXES[i]}")
    y = 1.0 if keep <= flip else -1.0
    tilt = _tilt_rate(imu)
    level = not tilt > GYRO_TILT_MIN_RADPS
    decided = max(keep, flip) >= (AXIS_MARGIN_LEVEL if level else AXIS_MARGIN_JOINT) * min(keep, flip)
    undecided = None
    if decided:
        signs = np.array([1.0, y, z])
    elif level:
        signs = np.asarray(fallback_signs, float).copy()
        undecided = (f"the tilt kinematics fit y as recorded and y flipped within {AXIS_MARGIN_LEVEL:g}x ({keep:.2e} "
                     f"vs {flip:.2e} rad/s) on a nearly level vehicle (median tilt rate {tilt:.2e} rad/s, under "
                     f"{GYRO_TILT_MIN_RADPS:g}), whose accelerations in turns its accelerometer's gravity direction "
                     f"follows as much as its tilt")
    else:
        signs = np.asarray(fallback_signs, float).copy()
        undecided = (f"the tilt kinematics fit y as recorded and y flipped within {AXIS_MARGIN_JOINT:g}x "
                     f"({keep:.2e} vs {flip:.2e} rad/s): too little tilt motion")
    if undecided:
        notes.append(undecided)
    check.gyro_map = check.accel_map = np.diag(signs)
    check.suspects = describe_axis_map(np.diag(signs), "gyro") + describe_axis_map(np.diag(signs), "accelerometer")
    return AxisDetection(signs, check, None, decided, notes, undecided)


def _tilt_rate(imu) -> float:
    """The median rate (rad/s) at which the accelerometer's gravity direction turns (:func:`graphnav.io.units.
    gyro_tilt_fit`): under :data:`~graphnav.io.units.GYRO_TILT_MIN_RADPS` the vehicle is level and the direction
    follows its horizontal accelerations (a level ROV reversing in turns: 1.0e-4-1.6e-4 rad/s, its y flipped fitting
    1.2x better), not its tilt (the ten A-KIT trajectories 0.002 and above on 60 s windows, simulated missions 0.02)."""
    from graphnav.io.units import gyro_tilt_fit
    return gyro_tilt_fit(imu.t, imu.f_b, imu.omega_b)[1]


def _signs_of(check: AxisCheck, with_gt: bool, source: str) -> np.ndarray:
    """The one sign vector of a check's maps, or DataError naming the axis when none fits."""
    for P, sensor in ((check.gyro_map, "gyro"), (check.accel_map, "accelerometer")):
        if not np.allclose(np.abs(P), np.eye(3)):
            swapped = [AXES[i] for i in range(3) if P[i, i] == 0]
            raise DataError(f"no IMU axis sign convention fits: {'; '.join(describe_axis_map(P, sensor))}"
                            f" (axes are swapped, not sign-flipped); fix the file's columns (a column map: list them "
                            "in "
                            "the body order x, y, z; a bag: the driver's axis convention, then record again): "
                            "imu_axis_signs only flips signs",
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


#: What to do when the two sensors need different signs on an axis.
_ONE_SENSOR = ("negate that axis of one sensor in the file (imu_axis_signs and a column map's frame apply to both "
               "sensors at once); a bag cannot be edited: set that sensor's axis convention in the driver that "
               "publishes it (its frame or axis parameters) and record again")


def _disagree(check: AxisCheck, g: np.ndarray, a: np.ndarray, i: int, source: str) -> DataError:
    return DataError(f"no IMU axis sign convention fits: gyro {AXES[i]} sign {g[i]:+.0f} but accelerometer "
                     f"{AXES[i]} sign {a[i]:+.0f} (one convention applies to both sensors); suspects: "
                     f"{'; '.join(check.suspects) or 'none'}; {_ONE_SENSOR}", source, field=f"axis {AXES[i]}")


# ------------------------------------------------------------------------------------------------
# An IMU in a declared frame (column-map CSV, bags): the same detection, checking the declaration
# ------------------------------------------------------------------------------------------------
#: What the sign corrections that keep a frame right-handed mean for an IMU declared FRD, for the messages.
FRAME_FAULTS = {(1, -1, -1): "FLU axes (ROS REP-103), or an IMU mounted upside down (rolled 180 deg)",
                (-1, 1, -1): "an IMU mounted pitched 180 deg (x aft, z up)",
                (-1, -1, 1): "an IMU turned 180 deg about z (x aft)"}


def declared_frame_signs(imu, config: SensorConfig, gt=None, source: str = "IMU", field: str = "omega_b"
                         ) -> tuple[np.ndarray, str, str | None]:
    """``(signs, how, undecided)``: the signs the IMU's x, y, z (accelerometer and gyro, in the FRD frame a loader
    turned them into by a declaration) need according to the data, ones when the data agree or cannot tell; ``how``
    says what saw it; ``undecided``: why the data could not tell the y as read from the y negated (a level vehicle,
    too little rotation), None when they did.

    The detection of :func:`detect_imu_axis_signs` with no convention assumed. With ``gt`` (on the IMU clock):
    the gyro against its attitude, taken when decided. Without: z from gravity (an FRD IMU reads -g on z, so
    +g is certain), y from the tilt kinematics when they decide, else y follows z (the frame stays
    right-handed); x cannot be seen without a heading reference and stays. ``field``: the columns an error names.

    Raises:
        DataError: the axes are swapped or turned about z against the GT (naming the likely mounting), or gyro
            and accelerometer flipped differently.
    """
    if gt is None:
        z = -1.0 if _gravity_on_plus_z(imu) else 1.0
        detection = _detect_without_gt(imu, source, (1.0, z, z))
        how = ("gravity reading +g on the accelerometer z axis (an FRD IMU reads -g)" if z < 0 else
               "the tilt kinematics (gyro against the accelerometer's gravity direction)")
        # a turn of 180 deg about z cannot be seen without a heading reference: (1,-1,-1) and (-1,1,-1) fit alike
        how += ("; x taken forward, an assumption: without a GT a 180 deg turn about z cannot be seen"
                + (" (an IMU pitched 180 deg, x aft and z up, needs (-1, 1, -1) and gets (1, -1, -1))" if z < 0 else "")
                + ", and its heading would then be 180 deg off")
        return np.asarray(detection.signs, float), how, detection.undecided
    try:
        detection = detect_imu_axis_signs(imu, config, gt, source, fallback_signs=(1.0, 1.0, 1.0))
    except DataError as exc:
        raise _turned(imu, config, gt, source, field) or exc from None
    signs = np.asarray(detection.signs, float) if detection.decided else np.ones(3)
    return signs, "the gyro against the GT attitude", detection.undecided


def _turned(imu, config: SensorConfig, gt, source: str, field: str) -> DataError | None:
    """DataError saying where the IMU's axes point in the body frame when the gyro fits the GT attitude only
    with its axes permuted (an IMU mounted turned 90 deg about z: its heading turns against the GT's by a
    constant 90 deg); None when the gyro map is not a permutation."""
    check, _ = _run_axis_check(imu, gt, config)
    P = check.gyro_map
    if P is None or np.allclose(np.abs(P), np.eye(3)):
        return None
    return DataError(f"the gyro fits the GT attitude only with its axes permuted ({'; '.join(check.suspects)}): "
                     f"the IMU is mounted turned against the body frame ({mounting_text(P)}). {TURN_ADVICE}", source,
                     field=field)


#: What to do about an IMU mounted turned against the body frame, for the messages.
TURN_ADVICE = ("Turn the accelerometer and gyro into the body frame before graphnav reads them (a column map can "
               "reorder columns, not turn or negate single axes)")


def mounting_text(P: np.ndarray) -> str:
    """Where the IMU's axes point in the body frame for a correction ``P`` (corrected = P @ raw, a signed
    permutation): "its x axis points starboard, its y axis points aft, its z axis points down; FRD: ..."."""
    names = {(0, 1.0): "forward", (0, -1.0): "aft", (1, 1.0): "starboard", (1, -1.0): "port",
             (2, 1.0): "down", (2, -1.0): "up"}
    # IMU axis j is the body direction P[:, j] (corrected = P @ raw, P orthogonal)
    points = [f"its {AXES[j]} axis points {names[(int(np.flatnonzero(P[:, j])[0]), float(P[:, j].sum()))]}"
              for j in range(3)]
    return f"{', '.join(points)}; FRD: x forward, y starboard, z down"
