"""A DVL velocity's scale and axis signs against the IMU: a speed unit read wrong (knots as m/s, 1.94x) or a DVL
in FLU axes read as FRD, which no speed range catches.

The DVL clock model (:mod:`graphnav.core.dvl_kinematics`) fits each 20 s window of DVL velocities with the IMU's
integrals: ``v + int omega x v = v0 + int f_b + (int R^T) g0 + omega x l``. With the velocity ``k`` times the
true one, the DVL side is ``k`` times what the IMU side says: after the per-window ``v0`` and ``g0`` are taken out
of both sides, the IMU side regressed on the DVL side gives ``k`` (:func:`speed_scale`; regressing this way keeps
the DVL's noise from shrinking it). A velocity in FLU read as FRD explains the IMU's accelerations far worse than
the same velocity with y and z negated (:func:`flu_fit_ratio`), and an IMU mounted turned about z, which gravity
cannot see, explains them far worse than the same IMU turned back (:func:`imu_yaw_fit`, :func:`check_imu_yaw`). A
velocity whose y alone is negated (or, the same against the DVL, an IMU mirrored) explains them worse than negated
back wherever the vehicle's sideways velocity changes (:func:`dvl_y_negated_fit`, :func:`check_dvl_y`).
The same model judges the gyro's scale where the tilt kinematics cannot (:func:`check_gyro_against_dvl`: rates
57.3x too small, or deg/s, fit the DVL far worse).
Measured in ``docs/decisions/units-clocks-axes.md``.
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from graphnav.calibration.axes import TURN_ADVICE, mounting_text
from graphnav.calibration.clock import COARSE_MAX_WINDOWS
from graphnav.core.dvl_kinematics import (MIN_SCALE_R2, SCALE_OFFSETS_S, SCALE_SEARCH_S, WINDOW_S, best_speed_fit,
                                          centred, dvl_velocity_b, dvl_window_model, fits_turned_elsewhere,
                                          imu_gaps_said, imu_integrals, outage_cut_model, speed_scale, turn_at,
                                          turn_fit, within_half_turn)
from graphnav.core.errors import DataError
from graphnav.core.streams import add_note, count_doubted, say_doubted
from graphnav.io.dvl_frame import (CARRIED, EARTH_FRAMES, KEPT_AS_DECLARED, KEPT_POINTING_OFF, check_not_earth_frame,
                                  mean_course, velocity_frame)
from graphnav.io.units import (AKIT_DVL_FIXES, DECLARE_DVL_FIXES, GYRO_UNJUDGED, check_gyro_against_reference,
                               gyro_scale_found, other_unit_factors, unit_fix)

#: Scales outside (1 / this, this) are refused: a unit read wrong, not a calibration (the geometric middle of 1
#: and knots' 1.944; the nine: 0.996-1.016 in m/s, 1.937-1.976 in knots).
MAX_SCALE_ERROR = 1.4
#: What a scale (velocity as read over the IMU's) likely is: said to a column map or bag (with the key that declares
#: it), and to an A-KIT folder (what its numbers look like: it has no unit to declare).
LIKELY_UNITS = {1.943844: ("knots read as m/s (declare velocity_unit 'kn')", "in knots"),
                1 / 1.943844: ("m/s declared as knots", "m/s converted as if knots"),
                3.280840: ("ft/s read as m/s", "in ft/s"), 1 / 3.280840: ("m/s declared as ft/s",
                                                                        "m/s converted as if ft/s")}
#: The clock model's SSE as read over its SSE with y and z negated above which the velocity is FLU, when the negated
#: fit explains at least :data:`MIN_FLU_EXPLAINED` (the ten A-KIT: 0.001-0.076 as recorded, 13-1050 negated).
FLU_SSE_RATIO = 3.0
MIN_FLU_EXPLAINED = 0.5
#: A horizontal turn between the DVL's velocity and the IMU's axes beyond this (rad; the fit at the best scale's
#: offset, its r^2 at least :data:`MIN_SCALE_R2`, no sigma) is warned about (an A-KIT folder: refused):
#: instrument-frame columns of a yawed DVL read as body. The nine A-KIT trajectories judged: -0.4..0.4 deg; a DVL
#: mounted 45 deg read as body: -44.6 deg. Read at the DVL's stamps with 3 sigmas instead, 60 s A-KIT pieces turned
#: 12/20/45 deg went silent (30/27/14 of 60 against 23/22/12). Smaller turns: :data:`MIN_YAW_RAD`.
MAX_YAW_RAD = np.deg2rad(10.0)
#: A turn under :data:`MAX_YAW_RAD` is warned about (for any reader; counted as doubted) beyond this (rad) and beyond
#: :data:`YAW_SIGMAS` times its sigma (:func:`yaw_sigma`), with r^2 at least :data:`MIN_SCALE_R2`: 5 deg puts the
#: track 8.7 % of the distance sideways. Judged as read (``experiments/dvl_yaw_floor.py``), |yaw| / sigma reaches
#: 1.2 on the nine A-KIT trajectories (|yaw| <= 0.4 deg), 1.5 on their 120 s pieces, 2.8 on simulated 120 s pieces
#: (0.01 m/s beams; MEMS 18 deg at sigma 6.5); beyond 3 only where the turn is beyond 10 deg anyway (60 s pieces):
#: no small-turn warning. Turned 3/5/8 deg: warned on 8/9/9 of the nine, 16/18/18 of 22 judged 120 s pieces. The
#: floor keeps a residual the sigma does not see (a hull's sideslip, a lever arm) from being warned about.
MIN_YAW_RAD = np.deg2rad(2.0)
YAW_SIGMAS = 3.0
#: Why DVL pings read despite a velocity turned a few degrees from the IMU's axes are counted.
YAW_DOUBT = "DVL velocity turned a few degrees about z from the IMU's axes"
#: Why DVL pings read despite a velocity turned about z beyond :data:`MAX_YAW_RAD` (its own fit) or by a quarter turn
#: (the IMU-turn fit, :func:`warn_dvl_turned`) from the vehicle's axes are counted: a log or bag keeps them, warned.
TURNED_DOUBT = "DVL velocity turned about z from the vehicle's axes, its columns likely in a mounted DVL's frame"
#: A DVL velocity turned about z from a GT's body velocity (:func:`warn_turn_against_reference`, the turn fitted with a
#: lever-arm correction, :func:`turn_and_lever_against_reference`) is warned about beyond this (rad) and
#: :data:`YAW_SIGMAS` sigmas. The Snapir's DVL is calibrated: the ten A-KIT trajectories as recorded fit -0.00..+0.50
#: deg (sigma 0.04-0.19 deg, up to 5.1 of them: the residual of a calibration, which the sigma of the noise does not
#: see), their 120 s pieces -0.19..+0.83 deg, 60 s pieces -0.40..+0.68 deg (``experiments/dvl_gt_yaw.py``: none
#: warned; turned 1 deg 9/26/35 of 10/30/60 warned, 2 deg 10/30/55).
GT_MIN_YAW_RAD = np.deg2rad(1.0)
#: Why DVL pings read despite a velocity turned from the GT's body velocity are counted.
GT_YAW_DOUBT = "DVL velocity turned about z from the ground truth's body velocity"
#: A DVL lever arm the fit against a GT's body velocity moves by more than this (m, any component) and
#: :data:`YAW_SIGMAS` sigmas is warned about (:func:`warn_lever_against_reference`). The ten A-KIT trajectories as
#: recorded move it up to 0.10 m whole (the steady Trajectory13 0.60 +- 0.6 m), at most 2.9 sigmas; with their lever
#: arm 0.5 m off along x 9 of 10 are warned, 1.86 m off 10 (``experiments/dvl_gt_yaw.py --lever-errors``).
GT_MIN_LEVER_M = 0.3
#: ... and only over a log of at least this many seconds of pings (s): on shorter crops the windows' sigma is too small
#: for the lever arm (clean Trajectory11 from 270 s, 60 s: +1.37 +- 0.33 m; from 280 s, 120 s: +1.22 +- 0.33 m; 30 s of
#: Trajectory1: -0.34 +- 0.11 m, each with its own clock offset), where whole logs move it by 0.10 m at most.
GT_LEVER_MIN_SPAN_S = 300.0
#: Why DVL pings read despite a lever arm the GT's body velocity disagrees with are counted.
GT_LEVER_DOUBT = "DVL lever arm off from where the ground truth's body velocity puts the DVL"
#: Where a long log's IMU-turn fits search the DVL offset, each model's best is found on
#: :data:`~graphnav.core.dvl_kinematics.COARSE_MAX_WINDOWS` windows spread over it and all its windows are scored within
#: this of there, s (:func:`imu_yaw_fit`).
OFFSET_REFINE_S = 1.0
#: The DVL velocity must change by at least this within the clock model's windows (RMS about each window's mean,
#: m/s), or by :data:`MIN_CHANGE_OVER_NOISE` times its noise (:func:`velocity_change_rms`), for its fits to judge the
#: gyro's scale, its own unit, turn or axes, or an IMU turned: a velocity held to within its noise (a steady turn, a
#: coarse resolution) leaves the fits comparing residuals of nothing. Measured (``experiments/dvl_change_floor.py``):
#: the ten A-KIT trajectories change by 0.019-0.22 m/s whole, at least 0.011 in any 60 s piece; simulated missions
#: 0.079-0.084 (default beam noise; 0.065 in 60 s pieces), noiseless 0.041 (0.024); a speed and turn held at a
#: 1 mm/s resolution about 0.001.
MIN_VELOCITY_CHANGE_MPS = 0.005
#: ... or this many times its noise: a velocity in a smaller unit (x0.01) changes by less than the floor but as
#: many times its own noise (the ten A-KIT: 1.2-7.9 whole, Trajectory1's 4.2-6.6 in 60 s pieces); one held at a
#: resolution changes by about its noise (1), a noiseless one by nothing.
MIN_CHANGE_OVER_NOISE = 3.0


def velocity_change_rms(model) -> tuple[float, float]:
    """``(change, noise)``: how much the DVL velocity of the clock model ``model`` changes within its windows (the
    RMS of the body-frame velocity about each window's mean, m/s) and its noise as the pings show it (the RMS of
    their second differences over sqrt(6), white noise's; m/s), at least 1e-9 m/s (float rounding). The second
    differences are taken over consecutive pings at the nominal period only (:func:`consecutive_triples`): across a
    gap the velocity has changed too, and half the pings dropped doubled the noise on Trajectory1."""
    v, real = model.v, model.real
    change = float(np.sqrt(np.sum(centred(v, real) ** 2) / (3 * np.count_nonzero(real))))
    d2 = np.diff(v, 2, axis=1)
    ok = consecutive_triples(model.t, real)
    noise = float(np.sqrt(np.mean((d2[ok] if ok.any() else d2) ** 2) / 6.0))
    return change, max(noise, 1e-9)


#: Pings whose step is within this factor of the nominal period are consecutive (stamp jitter, not a dropped ping).
CONSECUTIVE_STEP_FACTOR = 1.5


def consecutive_triples(t: np.ndarray, real: np.ndarray) -> np.ndarray:
    """(W, n-2) bool: which second differences of pings stamped ``t`` (W, n) s (windows of n; ``real`` (W, n) False
    at a window's padding) join three consecutive pings, both steps within :data:`CONSECUTIVE_STEP_FACTOR` of the
    nominal period (the 10th percentile of the steps: the median of a log with most pings dropped is a multiple of
    it)."""
    dt = np.diff(np.asarray(t, float), axis=1)
    steps = real[:, 1:]
    if not steps.any():
        return np.zeros((len(t), max(t.shape[1] - 2, 0)), bool)
    short = steps & (dt <= CONSECUTIVE_STEP_FACTOR * np.percentile(dt[steps], 10))
    return short[:, :-1] & short[:, 1:]


def judging_model(imu, dvl, config, **kwargs):
    """The clock model (:func:`~graphnav.core.dvl_kinematics.dvl_window_model`, its keyword arguments) when the DVL
    velocity changes enough to judge anything by (:data:`MIN_VELOCITY_CHANGE_MPS`, :data:`MIN_CHANGE_OVER_NOISE`).

    Raises:
        DataError: under two windows of pings, or a velocity that changes by less, naming the DVL file.
    """
    model, _ = dvl_window_model(imu, dvl, config, **kwargs)
    change, noise = velocity_change_rms(model)
    if not (change >= MIN_VELOCITY_CHANGE_MPS or change >= MIN_CHANGE_OVER_NOISE * noise):
        raise DataError(f"the DVL velocity changes by {change:.2g} m/s RMS within its {WINDOW_S:g} s windows, within "
                        f"its noise ({noise:.2g} m/s; {MIN_VELOCITY_CHANGE_MPS:g} m/s or {MIN_CHANGE_OVER_NOISE:g}x "
                        "its noise needed: a vehicle holding its speed and turn)", dvl.source, field="velocity")
    return model


def flu_fit_ratio(read, imu, dvl, config, offsets=(0.0,)) -> tuple[float, float]:
    """``(SSE as read / SSE with y, z negated, explained fraction negated)`` of the clock model ``read`` (the DVL
    as read, :func:`~graphnav.core.dvl_kinematics.dvl_window_model`) at the DVL offset ``offsets`` (s), or, given
    several, each reading at its own best of them over the same windows (:func:`_best_fits`)."""
    flipped, _ = dvl_window_model(imu, dvl, config, transform=DVL_FLU, ints=read.imu)
    offsets = np.atleast_1d(np.asarray(offsets, float))
    if len(offsets) > 1:
        fits = _best_fits({0: read, "flu": flipped}, offsets)
        return fits[0][0] / max(fits["flu"][0], 1e-300), 1.0 - fits["flu"][0]
    explained, sse, _ = flipped.score(float(offsets[0]))
    return read.score(float(offsets[0]))[1] / max(sse, 1e-300), explained


def y_negated_over_flu(read, imu, dvl, config) -> float:
    """The share of the DVL velocity's changes the IMU leaves unexplained at its stamps with the velocity's y alone
    negated (:data:`DVL_Y_NEGATED`) over with its y and z negated (:data:`DVL_FLU`), on the windows of the clock model
    ``read`` (the DVL as read): about 1 where the vertical velocity barely changes (a level vehicle), which cannot tell
    FLU axes from a y negated."""
    models = {k: dvl_window_model(imu, dvl, config, transform=m, ints=read.imu)[0]
              for k, m in (("y", DVL_Y_NEGATED), ("flu", DVL_FLU))}
    return models["y"].score(0.0)[1] / max(models["flu"].score(0.0)[1], 1e-300)


#: The index of the DVL stamps as they stand (offset 0) in :data:`SCALE_OFFSETS_S`.
AT_STAMPS = int(np.argmin(np.abs(SCALE_OFFSETS_S)))
#: The IMU turns :func:`imu_yaw_fit` tries about z, deg (the IMU's axes are ``Rz(yaw)^T`` body's: 90 puts its x to
#: starboard and its y aft).
IMU_YAWS_DEG = (90, 180, 270)
#: A turn of the IMU is refused when it fits better than the axes as read by this many noise variances
#: (:func:`imu_yaw_fit`); the turn named is told apart from the next by as many, or both are named; under it either
#: way the check cannot judge (a note). Measured (``experiments/imu_yaw_rates.py``; q as read at most / turned at
#: least): the ten A-KIT trajectories whole -4.1e3 / +4.1e3, in 45 s windows -94 / +94, 120 s -769 / +769;
#: simulated 400 s missions (navigation, tactical, MEMS, lawnmower and transit, 0.042 m/s beam noise) whole -1.0e3 /
#: +1.0e3, 120 s windows -42 / +42; 60 s windows leave 7-9 of 48 not judged, one of them (MEMS) at the wrong sign,
#: |q| 3.4. No window as read refused, no wrong turn named alone.
IMU_YAW_MIN_Q = 30.0
#: A turn whose fit explains none of the velocity's changes (a straight line per window leaves less) is judged only
#: where it leaves this many times less of them unexplained than the axes as read (as :data:`DVL_Y_MIN_RATIO`): the
#: noise variances count the model's own misfit. A-KIT Trajectory13 (a vehicle holding its speed) with 0.4 s of IMU
#: missing every 7 s and its DVL 30 s late, beyond the search: 1.42 as read, 1.34 turned 90 deg (1.06x, 40.8 noise
#: variances); a simulated 400 s vehicle holding its speed in 0.042 m/s beam noise, its DVL turned 90 deg: 2.01, 1.03
#: (1.96x, 1030 noise variances: the DVL's turn).
IMU_YAW_BLIND_RATIO = 1.25
#: The DVL's mean horizontal direction within this of body +x says its velocity is in the body frame (an AUV moves
#: forward: -5.0..+1.9 deg on the ten A-KIT trajectories, -0.4..-0.2 simulated); then a turn that fits better is the
#: IMU's. A velocity pointing forward once turned back is a DVL turned, which the yaw warning of
#: :func:`check_velocity_against_imu` is about; pointing forward neither way (hovering, reversing, moving sideways),
#: the data cannot say which instrument is turned.
FORWARD_COURSE_RAD = np.deg2rad(30.0)
#: A DVL velocity whose mean horizontal direction (:func:`_course`) lies further than this from body +x over the
#: whole log is warned about when no fit judged its turn (:func:`warn_dvl_sideways`): an AUV moves mostly forward
#: (the ten A-KIT trajectories -5.0..+1.9 deg; simulated 400 s missions -0.4, -0.2, with a hull pivot 2 or 5 m
#: ahead of the IMU -0.7, -1.0), so sideways or backward over a whole log is a DVL turned 90 or 180 deg read as
#: body, or a crabbing vehicle: a warning, not a refusal.
SIDEWAYS_COURSE_RAD = np.deg2rad(60.0)
#: Why DVL pings read despite pointing sideways or backward are counted (``meta["streams"]["dvl"]["doubted"]``).
SIDEWAYS_DOUBT = "DVL velocity pointing sideways or backward over the log, its turn not judged against the IMU"


def turn_about_z(yaw_deg: float) -> np.ndarray:
    """Rz(yaw) (3,3), exact for quarter turns: the body frame's axes of an IMU mounted turned ``yaw_deg`` about z
    (body = Rz @ imu)."""
    a = np.deg2rad(yaw_deg)
    return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]]).round(12)


def imu_turned_models(read, imu, dvl, config) -> dict:
    """The clock model ``read`` (the DVL as read on the IMU, :func:`~graphnav.core.dvl_kinematics.dvl_window_model`)
    keyed 0, and keyed by each turn of :data:`IMU_YAWS_DEG` (deg) the same DVL against the IMU turned that much about
    z, on ``read``'s IMU integrals: the DVL velocity and lever arm are turned into the turned IMU's axes (the
    accelerometer's horizontal axes and the gyro's roll and pitch rates then meet the velocity as mounted).
    :func:`imu_yaw_fit` scores them all, and :func:`y_negated_fit` the one as read and the best turn again: each is
    built once."""
    models = {0: read}
    for yaw in IMU_YAWS_DEG:
        T = turn_about_z(yaw).T
        models[yaw], _ = dvl_window_model(imu, dvl, config, lever_arm_b=T @ config.dvl.lever_arm_b, transform=T,
                                          ints=read.imu)
    return models


def imu_yaw_fit(models: dict, offsets=(0.0,)) -> tuple[float, int, float]:
    """``(q, yaw, q_next)``: how much better the clock model as read (``models``: :func:`imu_turned_models`'s) fits
    with the IMU turned ``yaw`` deg about z (the best of :data:`IMU_YAWS_DEG`): the squared residual as read minus
    turned, over the noise variance (the smaller squared residual per residual); > 0 the turn fits better. Each is
    read at the DVL offset among ``offsets`` (s) where it fits best, every offset over the same windows
    (:func:`_searchable`): where the clock is known no closer than they span, the offset is no evidence for a turn (a
    turn of 180 deg half a sway period late fits a steady vehicle's velocity changes as well as the axes as read on
    time).
    ``q_next``: the same of the next best turn against the best."""
    return _yaw_evidence(_best_fits(models, offsets))


def _yaw_evidence(fits: dict) -> tuple[float, int, float]:
    """:func:`imu_yaw_fit`'s ``(q, yaw, q_next)`` from the fits (:func:`_best_fits`) of its models."""
    yaw, nxt = sorted(IMU_YAWS_DEG, key=lambda y: fits[y][0])[:2]
    return _evidence(fits[0], fits[yaw]), yaw, _evidence(fits[nxt], fits[yaw])


#: The IMU axis signs of a y axis negated on both sensors (a left-handed axis set: x forward, y port, z down).
Y_NEGATED = np.array([1.0, -1.0, 1.0])


def applied_axis_signs(config) -> np.ndarray:
    """The IMU axis signs (x, y, z) the configuration already applies to the accelerometer and gyro, ones where it
    gives none."""
    return np.ones(3) if config.imu_axis_signs is None else np.asarray(config.imu_axis_signs, float)


def y_negated_fit(models: dict, imu, dvl, config, yaw: int, offsets=(0.0,)) -> tuple[float, float]:
    """``(q_read, q_turn)``: how much better (noise variances, as :func:`imu_yaw_fit`'s) the clock model as read
    (``models``: :func:`imu_turned_models`'s) fits with the IMU's y negated on the accelerometer and gyro
    (:data:`Y_NEGATED`) than as read, and than with the IMU turned ``yaw`` deg about z (its model there). A y negated
    on both sensors is no turn (it makes the axes left-handed) and no motion explains it: the centripetal acceleration
    in turns reads on the wrong side, which a turn of 180 deg puts right (and the acceleration along x wrong), so a
    vehicle that turns more than it speeds up fits it turned."""
    fits = _best_fits({0: models[0], yaw: models[yaw], "y": imu_y_negated_model(imu, dvl, config)}, offsets)
    return _evidence(fits[0], fits["y"]), _evidence(fits[yaw], fits["y"])


def imu_y_negated_model(imu, dvl, config):
    """The clock model (:func:`~graphnav.core.dvl_kinematics.dvl_window_model`) of the DVL against the IMU with its y
    negated on the accelerometer and the gyro (:data:`Y_NEGATED`)."""
    negated = dataclasses.replace(imu, f_b=imu.f_b * Y_NEGATED, omega_b=imu.omega_b * Y_NEGATED)
    return dvl_window_model(negated, dvl, config)[0]


#: The DVL velocity's y negated (v_b = this @ v as read): a DVL frame taken left-handed (a driver's sign, an RDI
#: instrument frame taken for its ship frame). Against the IMU it is the same as an IMU mirrored (accelerometer y,
#: gyro x and z negated, the readings of the mirrored motion), which the IMU's own tilt kinematics cannot see.
DVL_Y_NEGATED = np.diag([1.0, -1.0, 1.0])
#: The DVL velocity's y and z negated (FLU axes read as FRD, :func:`flu_fit_ratio`).
DVL_FLU = np.diag([1.0, -1.0, -1.0])
#: A DVL y negated (:func:`dvl_y_negated_fit`) fitting better than as read and than every other axis error by this
#: many noise variances (:func:`imu_yaw_fit`'s), and leaving :data:`DVL_Y_MIN_RATIO` times less of the velocity's
#: changes unexplained than as read, is refused; by :data:`DVL_Y_DOUBT_Q` and :data:`DVL_Y_DOUBT_RATIO` it is warned
#: about and counted. The ratio is needed as well: on a vehicle whose sideways velocity never changes the y negated
#: fits up to 5 % better by the model's own misfit, which a long or quiet log counts as up to 95 noise variances.
#: Measured at the stamps as loaded (docs/decisions/units-clocks-axes.md).
DVL_Y_MIN_Q = IMU_YAW_MIN_Q
DVL_Y_MIN_RATIO = 1.25
DVL_Y_DOUBT_Q = 20.0
DVL_Y_DOUBT_RATIO = 1.1
#: A DVL y negated that explains less than this share of the velocity's changes is warned about, not refused, however
#: much better than as read it fits: where the IMU explains nothing either way round their ratio is noise. A clean
#: simulated MEMS mission (seed 1, 300 s, its DVL 2 m forward and turned 5 deg, the lever arm not configured) fitted
#: 1.28x better with its y negated, explaining -0.00 (as read -0.17); DVLs truly y negated on vehicles turning in a
#: current explain 0.20-0.39, crabbing 0.09-0.17 (judged by the IMU-turn check, which names the y), A-KIT pieces
#: 0.68-1.00; slow noisy ones 0.02-0.04, only warned (ratio 1.07-1.17).
DVL_Y_MIN_EXPLAINED = 0.1
#: Why DVL pings read though their velocity's y fits the IMU better negated (:data:`DVL_Y_DOUBT_Q`) are counted.
DVL_Y_DOUBT = "DVL velocity y fitting the IMU better negated (or the IMU mirrored)"


@dataclasses.dataclass(frozen=True)
class DvlYFit:
    """What the DVL velocity's changes say of its y negated against the IMU (:func:`dvl_y_negated_fit`).

    Attributes:
        q_read: how much better the DVL y negated fits the IMU than as read (noise variances, :func:`imu_yaw_fit`'s).
        ratio: the share of the velocity's changes left unexplained as read over y negated.
        q_other: how much better than the best other axis error but FLU, named by ``other`` (nan when ``q_read`` is
            under :data:`DVL_Y_DOUBT_Q`: not fitted).
        q_flu: how much better than the DVL's y and z negated (FLU axes read as FRD), nan when not fitted.
        other: the other axis error ``q_other`` is of.
        flu_ratio: the share of the velocity's changes left unexplained with its y negated over with its y and z
            negated (nan when not fitted).
        explained: the share of the velocity's changes the IMU explains with its y negated.
    """

    q_read: float
    ratio: float = float("nan")
    q_other: float = float("nan")
    q_flu: float = float("nan")
    other: str = ""
    flu_ratio: float = float("nan")
    explained: float = float("nan")

    def flu_better(self, q: float = DVL_Y_MIN_Q, ratio: float = DVL_Y_MIN_RATIO) -> bool:
        """FLU fits better than the y alone negated by ``q`` noise variances and ``ratio``: by noise variances alone
        a level vehicle's, whose z barely changes, piles up over a long log (34 over 1 h, 1.00x)."""
        return self.q_flu <= -q and self.flu_ratio >= ratio

    @property
    def clear(self) -> bool:
        """The y negated fits clearly better than as read, and FLU not clearly better than it."""
        return self.q_read >= DVL_Y_MIN_Q and self.ratio >= DVL_Y_MIN_RATIO and not self.flu_better()

    @property
    def refused(self) -> bool:
        """:attr:`clear`, and better than every other axis error but FLU as clearly."""
        return self.clear and self.q_other >= DVL_Y_MIN_Q

    def said(self, fixes: dict, kept: bool = False) -> str:
        """What the fit says of the DVL's y, with ``fixes["y"]`` (and ``fixes["flu"]`` where FLU fits about as well)
        and the mirrored IMU it cannot be told from; ``kept``: said of a velocity kept as read (a warning)."""
        flu = ("" if self.q_flu >= DVL_Y_MIN_Q else
               f" (or its y and z negated, FLU axes read as FRD, which fit {abs(self.q_flu):.3g} noise variances "
               f"{'worse' if self.q_flu > 0 else 'better'}: {fixes['flu']})")
        to_refuse = " to refuse it" if kept else ""
        return (("the DVL velocity's y may be negated against the IMU (kept as read)" if kept else
                 "the DVL velocity's y is negated against the IMU")
                + f": the accelerometer and gyro leave {self.ratio:.3g}x as much of the velocity's changes "
                f"unexplained as read as with its y negated ({DVL_Y_MIN_RATIO:g}x needed{to_refuse}"
                + (f"; explaining {self.explained:.2f} of them, {DVL_Y_MIN_EXPLAINED:g} needed{to_refuse}, so the "
                   "ratio may be noise" if kept and not self.explained >= DVL_Y_MIN_EXPLAINED else "")
                + "), which fits "
                f"better by {self.q_read:.3g} noise variances than as read, and by {self.q_other:.3g} than with "
                f"{self.other} ({DVL_Y_MIN_Q:g} needed): a DVL frame taken left-handed (a sign in the driver, an "
                f"instrument frame read as the ship's)? {fixes['y']}{flu}. Or the IMU is mirrored (its "
                "accelerometer y and gyro x and z negated, which its own tilt kinematics cannot tell; imu_axis_signs "
                "negates both sensors alike and cannot undo it): then negate those IMU columns of the file instead")


def dvl_y_negated_fit(read, imu, dvl, config) -> DvlYFit:
    """How much better the clock model ``read`` (the DVL as read on the IMU, at its stamps as they stand) fits with
    the DVL velocity's y negated (:data:`DVL_Y_NEGATED`), and, where it fits better by :data:`DVL_Y_DOUBT_Q`, than
    with the other axis errors that fit a y negated partly: the DVL's y and z negated (FLU), the IMU turned 90, 180 or
    270 deg about z (:func:`imu_turned_models`) and its y negated on both sensors (:func:`imu_y_negated_model`). A
    vehicle whose sideways velocity never changes (no current, no lever arm, no sideslip in turns) shows none of it."""
    negated = dvl_window_model(imu, dvl, config, transform=DVL_Y_NEGATED, ints=read.imu)[0]
    fits = _best_fits({0: read, "y": negated}, (0.0,))
    q_read = _evidence(fits[0], fits["y"])
    ratio = fits[0][0] / max(fits["y"][0], 1e-300)
    if not (q_read >= DVL_Y_DOUBT_Q and ratio >= DVL_Y_DOUBT_RATIO):
        return DvlYFit(q_read, ratio, explained=1.0 - fits["y"][0])
    others = {f"the IMU turned {yaw} deg about z": m for yaw, m in imu_turned_models(read, imu, dvl, config).items()
              if yaw}
    others["the IMU's y negated on both sensors"] = imu_y_negated_model(imu, dvl, config)
    others["FLU"] = dvl_window_model(imu, dvl, config, transform=DVL_FLU, ints=read.imu)[0]
    fits.update(_best_fits({0: read, **others}, (0.0,)))
    q = {k: _evidence(fits[k], fits["y"]) for k in others}
    other = min((k for k in q if k != "FLU"), key=q.get)
    return DvlYFit(q_read, ratio, q[other], q["FLU"], other, fits["y"][0] / max(fits["FLU"][0], 1e-300),
                   1.0 - fits["y"][0])


def check_dvl_y(imu, dvl, config, meta: dict, read, field: str, fixes: dict) -> str:
    """DataError naming the DVL file and its columns ``field`` when the DVL velocity fits the IMU better with its y
    negated than as read and than every other axis error (:func:`dvl_y_negated_fit`) by :data:`DVL_Y_MIN_Q` noise
    variances and :data:`DVL_Y_MIN_RATIO`, explaining at least :data:`DVL_Y_MIN_EXPLAINED` of its changes so, with
    ``fixes["y"]``; by :data:`DVL_Y_DOUBT_Q` and :data:`DVL_Y_DOUBT_RATIO` (or explaining less) a warning, noted and
    counted (:data:`DVL_Y_DOUBT`). The velocity's changes cannot tell a DVL y negated from an IMU
    mirrored: both are named. Where the DVL's y and z negated (FLU) fits clearly better, the FLU check is left to say
    it; where about as well, it is named too. Where the y negated fits clearly better than as read but a turn of the
    IMU about as well (a vehicle moving sideways, whose x changes little), the sentence :func:`check_imu_yaw`'s refusal
    of the turn adds is returned; else ""."""
    fit = dvl_y_negated_fit(read, imu, dvl, config)
    if fit.clear and abs(fit.q_other) < DVL_Y_MIN_Q:
        return (f". Or the DVL velocity's y is negated (or the IMU mirrored: its accelerometer y and gyro x and z "
                f"negated): that fits {fit.q_read:.3g} noise variances better than as read and within "
                f"{abs(fit.q_other):.0f} of {fit.other}; if so, {fixes['y']}")
    if not (min(fit.q_read, fit.q_other) >= DVL_Y_DOUBT_Q and fit.ratio >= DVL_Y_DOUBT_RATIO
            and not fit.flu_better(DVL_Y_DOUBT_Q, DVL_Y_DOUBT_RATIO)):
        return ""
    if fit.refused and fit.explained >= DVL_Y_MIN_EXPLAINED:
        raise DataError(fit.said(fixes), dvl.source, field=field)
    say_doubted(meta, "dvl", dvl.source, f"field '{field}': {fit.said(fixes, kept=True)}", DVL_Y_DOUBT, len(dvl.t),
                stacklevel=3)
    return ""


def _best_fits(models: dict, offsets) -> dict:
    """Each clock model's ``(unexplained, residuals)`` (``models``: of the same DVL stamps and IMU integrals, keyed):
    the share of the DVL velocity's changes it leaves unexplained at the offset among ``offsets`` (s) where it fits
    best, and how many residuals it has there. A log of more than :data:`COARSE_MAX_WINDOWS` windows finds each
    model's best on that many windows spread over it and scores all its windows only within
    :data:`OFFSET_REFINE_S` of there, so the search costs little more than one offset on a long log."""
    offsets, reach = np.atleast_1d(np.asarray(offsets, float)), None
    if len(offsets) > 1:
        offsets, reach = _searchable(models[0], offsets)
    near = {k: offsets for k in models}
    if len(offsets) > 1 and len(models[0].t) > COARSE_MAX_WINDOWS:
        thin = _best_offsets({k: m.thinned(COARSE_MAX_WINDOWS) for k, m in models.items()}, near, reach)
        near = {k: offsets[np.abs(offsets - thin[k][0]) <= OFFSET_REFINE_S] for k in models}
    best = _best_offsets(models, near, reach)
    return {k: (1.0 - explained, 3 * pings) for k, (_, (explained, _, _), pings) in best.items()}


def _window_reach(model) -> np.ndarray:
    """How far (s) each window of the clock model ``model`` can move either way and stay inside the IMU span."""
    return np.minimum(model.t[:, 0] - model.imu.t[0], model.imu.t[-1] - model.t[:, -1])


def _searchable(model, offsets: np.ndarray) -> tuple[np.ndarray, float]:
    """``(offsets, reach)``: the offsets of a search the IMU-turn fits are read at, and how far (s) a window must
    reach (:func:`_window_reach`) to be scored at all of them. Every offset is scored over the same windows: a fit
    whose best offset leaves out the window it explains worst is favoured by the search, not by the data (on a 60 s
    log, three windows, every wrong turn's best left one out). A log too short to keep two windows inside over all
    of ``offsets`` is searched only as far as two stay inside (a 60 s log whose stamps span the IMU's: +-1 s over its
    last two windows; none: at the stamps, where the fits then have no two windows to judge by)."""
    reaches = np.sort(_window_reach(model))
    # under two windows (pings broken up by outages, an offset given by hand) nothing reaches: at the stamps only
    second = float(reaches[-2]) if len(reaches) > 1 else 0.0
    reach = max(0.0, min(float(np.max(np.abs(offsets))), second))
    return offsets[np.abs(offsets) <= reach], reach


def _best_offsets(models: dict, near: dict, reach: float | None = None) -> dict:
    """Each model's ``(offset, score, pings)`` at its best offset among ``near[key]`` (the first of equals), with the
    pings fitted there, the IMU's integrals interpolated once per offset for the models scored there; over the
    windows reaching ``reach`` s (:func:`_searchable`; default each offset's own), less their padding (the rest of
    the pings between two outages, :func:`~graphnav.core.dvl_kinematics.window_rows`)."""
    best = {}
    first = next(iter(models.values()))
    use = None if reach is None else (_window_reach(first) >= reach)[:, None] & first.real
    for o in np.unique(np.concatenate(list(near.values()))):
        at = {}                         # per IMU integrals: models of one IMU share them
        for k in (k for k in models if np.isin(o, near[k])):
            ints = id(models[k].imu)
            if ints not in at:
                at[ints] = models[k].imu_at(o, use)
            score = models[k].score(o, at=at[ints])
            if k not in best or score[0] > best[k][1][0]:
                best[k] = (o, score, int(np.count_nonzero(at[ints][0])) if score[2] else 0)
    return best


def _evidence(a: tuple[float, int], b: tuple[float, int]) -> float:
    """How much better fit ``b`` is than ``a`` (each a value of :func:`_best_fits`), in noise variances: the difference
    of their squared residuals over the smaller's per residual (0 when either has no windows to fit)."""
    (ua, na), (ub, nb) = a, b
    if not (np.isfinite(ua) and np.isfinite(ub)):
        return 0.0
    return (ua - ub) * min(na, nb) / max(min(ua, ub), 1e-300)


def _course(dvl, config) -> float:
    """The DVL's mean horizontal direction from body +x (rad, about z; the pings over the course speed), NaN when
    they point no one way (:data:`~graphnav.io.dvl_frame.MIN_COURSE_RESULTANT`)."""
    return mean_course(dvl_velocity_b(dvl, config)[1])


def _reference_course(reference) -> float:
    """The reference's mean horizontal direction of motion in its own body frame (rad from body +x, about z: its
    NED velocity turned by its attitude), as :func:`_course`; NaN without a reference or rows with both."""
    if reference is None:
        return float("nan")
    v_b = np.einsum("kji,kj->ki", reference.C_b_n, reference.v_n)
    return mean_course(v_b[np.isfinite(v_b).all(axis=1)])


def _forward(course: float) -> bool:
    return bool(abs(course) <= FORWARD_COURSE_RAD)          # NaN: False


def _forward_turned_back(course: float, turn: float) -> bool:
    """Whether a velocity whose mean direction is ``course`` (rad from body +x, about z; NaN for none) points forward
    (:data:`FORWARD_COURSE_RAD`) once turned back by ``turn`` (rad about z): a DVL mounted turned by ``turn``."""
    return _forward(np.angle(np.exp(1j * (course - turn))))


def check_imu_yaw(imu, dvl, config, meta: dict, frame: dict, model=None, offsets=(0.0,),
                  carried: bool = False, or_dvl_y: str = "", fixes: dict | None = None) -> int | None:
    """DataError naming the IMU file, its six columns (``frame["fields"]``), the declared frame (``frame["what"]``)
    and the turn that fits, when a DVL velocity pointing forward (in the body frame) fits the IMU's accelerations
    better with the IMU turned 90, 180 or 270 deg about z (:func:`imu_yaw_fit`, :data:`IMU_YAW_MIN_Q`): an IMU
    mounted yawed, which gravity cannot see. A velocity that points forward only turned back is a DVL turned: its
    turn (deg) is returned for :func:`warn_dvl_turned`; one that points forward neither way is a DataError naming
    both instruments. 0 when the velocity fits the IMU as read; None otherwise. A note in ``meta["streams"]["imu"]``
    when the data cannot judge (under two 20 s windows of pings, too little change of velocity, or a turn that fits
    better but explains none of the changes and leaves under :data:`IMU_YAW_BLIND_RATIO` times less than as read).
    ``frame["signs"]``: the ``imu_axis_signs`` applied (an A-KIT folder), whose negated x and y fix a 180 deg turn.
    ``model``: the clock model when built already; ``offsets``: s added to its DVL stamps, each fit read at its best
    of them (:func:`imu_yaw_fit`; several where the DVL's clock is not known closer). ``carried``: a velocity
    kept as body in a current (:data:`~graphnav.io.dvl_frame.CARRIED`), whose direction says nothing of the vehicle's
    forward: a turn that fits better is refused naming both instruments. ``or_dvl_y``: the sentence naming the DVL's
    y negated, which fits about as well as the turn (:func:`check_dvl_y`), added to a refusal of the turn.
    ``fixes``: what the DVL messages advise; given, a half turn refused naming both instruments also names FLU axes
    read as FRD where they fit about as well (:func:`_or_flu_axes`).
    """
    try:
        model = model or judging_model(imu, dvl, config)
    except DataError as exc:
        add_note(meta, "imu", f"its mounting about z not checked against the DVL ({exc.message}): a turned IMU is "
                              "seen then only against a reference attitude")
        return
    models = imu_turned_models(model, imu, dvl, config)
    fits = _best_fits(models, offsets)
    q, yaw, q_next = _yaw_evidence(fits)
    blind = q >= IMU_YAW_MIN_Q and not (fits[yaw][0] < 1.0 or fits[0][0] >= IMU_YAW_BLIND_RATIO * fits[yaw][0])
    undecided = meta.get("imu_axis_signs", {}).get("decided") is False
    or_y = or_dvl_y
    if (q >= IMU_YAW_MIN_Q and not blind) or undecided:
        # a y negated on both sensors fits a vehicle that turns more than it speeds up turned 180 deg
        # each fit at its own best offset over the whole search: the one offset the velocity's scale fit chose for
        # the IMU as read is where its wrong y fits best (20 s off on a level vehicle at 1.5 m/s), favouring the turn
        wide = offsets if carried else np.union1d(offsets, SCALE_OFFSETS_S)
        or_y = check_imu_y(imu, config, meta, frame, judge_imu_y(models, imu, dvl, config, yaw, wide),
                           undecided) + or_dvl_y
    if blind:
        add_note(meta, "imu", f"its mounting about z not judged against the DVL: the IMU turned {yaw} deg fits the "
                              f"velocity changes {q:.3g} noise variances better than as read, but explains none of "
                              f"them ({fits[yaw][0]:.2f} left unexplained, {fits[0][0]:.2f} as read, "
                              f"{IMU_YAW_BLIND_RATIO:g}x needed: a straight line per window leaves less; the DVL's "
                              "clock further off than the offsets searched?)")
        return
    if carried and q >= IMU_YAW_MIN_Q:
        raise _unless_declared_earth(meta, _either_turned(imu, dvl, frame, q, yaw, float("nan"), carried), or_y)
    course = _course(dvl, config) if q >= IMU_YAW_MIN_Q else 0.0
    if not _forward(course):
        if _forward_turned_back(course, np.deg2rad(yaw)):
            return yaw      # the DVL is the one turned (turned back, its velocity points forward)
        or_y += _or_flu_axes(models, imu, dvl, config, yaw, offsets, fixes)
        raise _unless_declared_earth(meta, _either_turned(imu, dvl, frame, q, yaw, course), or_y)
    if abs(q) < IMU_YAW_MIN_Q:
        add_note(meta, "imu", f"its mounting about z not judged against the DVL: the velocity changes tell the axes "
                              f"as read from the IMU turned {yaw} deg by {q:+.0f} noise variances ({IMU_YAW_MIN_Q:g} "
                              "needed: a longer log, or one with more changes of speed and course)")
        return
    if q < 0:
        return 0            # judged: the velocity fits the IMU as read
    other = "" if q_next >= IMU_YAW_MIN_Q else f" (or another quarter turn: the next fits {q_next:.0f} worse)"
    raise _unless_declared_earth(meta, DataError(
        f"the IMU's axes are turned {yaw} deg about z{other} against {frame['what']}: the DVL velocity (pointing "
        f"forward, in the body frame) fits the accelerometer and gyro better by {q:.3g} noise variances with them "
        f"turned ({IMU_YAW_MIN_Q:g} needed). The IMU is mounted turned against the body frame "
        f"({mounting_text(turn_about_z(yaw))}): {_imu_turn_fix(yaw, frame)}", imu.source, field=frame["fields"]), or_y)


#: Why the DVL leaves the IMU's y undecided (:attr:`ImuYJudgement.why`): y negated fits better than as read, but the
#: IMU turned fits about as well (within :data:`IMU_YAW_MIN_Q`; the DVL off its clock, each fit at its own best
#: offset) ...
Y_BESIDE_TURN = "beside the turn"
#: ... or clearly better (the turn is then named alone) ...
Y_TURN_BETTER = "the turn fits better"
#: ... as read fits better than y negated, but the velocity points off forward, where a DVL turned 180 deg fits a y
#: negated IMU as read (the pair differs by x negated, which a level vehicle's turns do not show) ...
Y_DVL_OFF_FORWARD = "the DVL points off forward"
#: ... as read and y negated fit within :data:`IMU_YAW_MIN_Q` of each other.
Y_TOO_CLOSE = "within the noise"


@dataclasses.dataclass(frozen=True)
class ImuYJudgement:
    """What the DVL velocity says of the sign of the IMU's y axis on the accelerometer and gyro (:func:`judge_imu_y`).

    Attributes:
        negated: True when y negated fits better than as read and than the IMU turned ``yaw`` deg about z, each by
            :data:`IMU_YAW_MIN_Q` noise variances; False when as read fits better than y negated by as much and the
            velocity points forward; None undecided.
        why: why undecided (:data:`Y_BESIDE_TURN`, :data:`Y_TURN_BETTER`, :data:`Y_DVL_OFF_FORWARD`,
            :data:`Y_TOO_CLOSE`); "" when decided.
        q_read, q_turn: how much better y negated fits than as read and than turned (noise variances,
            :func:`y_negated_fit`).
        yaw: the turn of the IMU about z compared with (deg, the best of :func:`imu_yaw_fit`).
        course: the velocity's mean direction (rad from body +x, about z; NaN pointing no one way, or not needed).
    """

    negated: bool | None
    why: str
    q_read: float
    q_turn: float
    yaw: int
    course: float = float("nan")


def judge_imu_y(models: dict, imu, dvl, config, yaw: int, offsets=(0.0,)) -> ImuYJudgement:
    """Whether the DVL velocity fits the IMU better with its y negated on the accelerometer and gyro than as read
    and than turned ``yaw`` deg about z (the best turn; :func:`y_negated_fit`, each fit at its best of ``offsets``,
    s, on the clock models ``models``, :func:`imu_turned_models`'s), better as read, or neither by
    :data:`IMU_YAW_MIN_Q` noise variances: a y axis with its sign flipped, which the tilt kinematics of a level vehicle
    cannot see and a turn of 180 deg mimics.
    Measured (docs/decisions/units-clocks-axes.md): y negated fits level vehicles 1.8e3-3.0e3 better than as read and
    5.3e2-4.5e3 than the best turn, simulated missions and the ten A-KIT trajectories 1.5e5 and more; as read it fits
    1.8e3 worse or more; with the IMU or the DVL turned 180 deg, 5.3e2 worse than the turn or more."""
    q_read, q_turn = y_negated_fit(models, imu, dvl, config, yaw, offsets)
    if q_read >= IMU_YAW_MIN_Q:
        if q_turn >= IMU_YAW_MIN_Q:
            return ImuYJudgement(True, "", q_read, q_turn, yaw)
        return ImuYJudgement(None, Y_TURN_BETTER if q_turn <= -IMU_YAW_MIN_Q else Y_BESIDE_TURN, q_read, q_turn, yaw)
    if not q_read <= -IMU_YAW_MIN_Q:
        return ImuYJudgement(None, Y_TOO_CLOSE, q_read, q_turn, yaw)
    course = _course(dvl, config)
    if not _forward(course):
        return ImuYJudgement(None, Y_DVL_OFF_FORWARD, q_read, q_turn, yaw, course)
    return ImuYJudgement(False, "", q_read, q_turn, yaw, course)


def check_imu_y(imu, config, meta: dict, frame: dict, judged: ImuYJudgement, undecided: bool = False) -> str:
    """What :func:`judge_imu_y` ``judged`` of the IMU's y, said: a DataError naming the IMU file and its columns
    (``frame`` as :func:`check_imu_yaw`'s) and the ``imu_axis_signs`` that fix it when y is negated. ``undecided``:
    the IMU alone could not tell the y (``meta["imu_axis_signs"]["decided"]`` False): what the DVL says of it is
    noted (``meta["imu_axis_signs"]`` then decided by the DVL, when y is as read), and where y negated fits about as
    well as the turn (:data:`Y_BESIDE_TURN`) the sentence a refusal of the turn adds is returned; else ""."""
    q_read, q_turn, yaw, course = judged.q_read, judged.q_turn, judged.yaw, judged.course
    signs = tuple(int(x) for x in applied_axis_signs(config) * Y_NEGATED)
    if judged.negated:
        raise _unless_declared_earth(meta, DataError(
            f"the IMU's y axis is negated against {frame['what']}, on the accelerometer and the gyro: the DVL velocity "
            f"fits them better by {q_read:.3g} noise variances with y negated than as read, and by {q_turn:.3g} than "
            f"with the IMU turned {yaw} deg about z ({IMU_YAW_MIN_Q:g} needed). Their y negated together makes the "
            "axes left-handed (x forward, y port, z down), which no mounting gives: a sign in the driver or the "
            "logger's axis convention"
            + (" (the IMU alone cannot see it here: its tilt kinematics fit either y)" if undecided else "")
            + f". Set imu_axis_signs {signs} in the configuration (it multiplies the accelerometer and gyro x, y, z as "
            "read)", imu.source, field=frame["fields"]))
    if not undecided:
        return ""
    if judged.negated is False:
        add_note(meta, "imu", f"its y axis sign judged against the DVL instead: the velocity fits the IMU as read "
                              f"better than with y negated by {-q_read:.3g} noise variances")
        meta["imu_axis_signs"].update(decided=True, by="the DVL")
    elif judged.why == Y_BESIDE_TURN:
        return (f". Or the IMU's y is negated on the accelerometer and the gyro (a left-handed axis set, which its "
                f"tilt kinematics cannot tell here): that fits {q_read:.3g} noise variances better than as read and "
                f"within {abs(q_turn):.0f} of the turn; if so, set imu_axis_signs {signs} in the configuration")
    elif judged.why == Y_DVL_OFF_FORWARD:
        add_note(meta, "imu", f"its y axis sign not judged against the DVL either: the velocity fits the IMU as read "
                              f"better than with y negated by {-q_read:.3g} noise variances, but "
                              + (f"it points {np.degrees(course):+.0f} deg from body x" if np.isfinite(course) else
                                 "its pings point no one way (reversing, hovering or moving sideways)")
                              + ", and a DVL turned 180 deg fits a y negated as read")
    elif judged.why == Y_TOO_CLOSE:
        add_note(meta, "imu", f"its y axis sign not judged against the DVL either: the velocity changes tell y as read "
                              f"from y negated by {-q_read:+.0f} noise variances ({IMU_YAW_MIN_Q:g} needed)")
    return ""


def _unless_declared_earth(meta: dict, exc: DataError, or_y: str = "") -> DataError:
    """``exc``, a turn between the IMU and the DVL (or the DVL's y and z negated), saying first that the DVL velocity
    was kept in its declared frame against the frame checks (:data:`~graphnav.io.dvl_frame.KEPT_AS_DECLARED`): an
    earth-fixed velocity declared body fits the IMU turned by the vehicle's heading, and its frame, not the IMU, is then
    what to fix; so does a vehicle-fixed velocity declared in an earth frame, which its attitude columns turn by the
    heading. ``or_y``: the sentence naming the IMU's y negated, which fits about as well (:func:`check_imu_y`),
    added."""
    if or_y:
        exc = DataError(exc.message + or_y, exc.source, field=exc.field)
    kept = meta.get(KEPT_AS_DECLARED)
    if not kept:
        return exc
    if kept in EARTH_FRAMES:
        found = ("points off forward while its columns as read point forward" if meta.get(KEPT_POINTING_OFF) else
                 "turns with the vehicle")
        return DataError(f"{exc.message}. But the DVL velocity was kept in its declared {kept} frame though, turned "
                         f"to body by its attitude columns, it {found} (the warning on the DVL stream): "
                         f"a vehicle-fixed velocity declared earth-fixed, turned by the vehicle's heading, fits the "
                         f"IMU only with axes turned or negated; if the columns are in the vehicle's frame, declare "
                         f"csv_columns.dvl.frame 'body' as that warning says, and no axes need changing", exc.source,
                         field=exc.field)
    return DataError(f"{exc.message}. But the DVL velocity was kept in its declared vehicle frame though the frame "
                     f"checks found it earth-fixed (the warning on the DVL stream): an earth-fixed velocity declared "
                     f"in the vehicle's frame fits the IMU turned by the vehicle's heading; if it is earth-fixed, "
                     f"declare its earth frame as that warning says, and the IMU needs no turn", exc.source,
                     field=exc.field)


def warn_dvl_turned(dvl, meta: dict, field: str, yaw: int | None, fixes: dict | None = None) -> None:
    """Warn about, note and count a DVL whose velocity fits the IMU turned ``yaw`` deg about z and points forward only
    turned back (:func:`check_imu_yaw`): velocity columns in the frame of a DVL mounted turned, read as body. Said
    here when the DVL's own yaw fit explains too little to say it (a vehicle holding its speed). ``fixes``: the
    advice (:data:`DECLARE_DVL_FIXES`, the default, or :data:`AKIT_DVL_FIXES`: then a DataError)."""
    if not yaw:
        return
    fixes = fixes or DECLARE_DVL_FIXES
    _say_dvl_turned(dvl, meta, field, fixes, f"the DVL velocity points {yaw} deg about z from the vehicle's forward "
                    "and fits the IMU only turned back: columns in the instrument frame of a DVL mounted turned, read "
                    f"as body? {fixes['yaw']}")


def _say_dvl_turned(dvl, meta: dict, field: str, fixes: dict, finding: str) -> None:
    """A DVL turn ``finding`` (with its fix): warned about, noted and its pings counted (:data:`TURNED_DOUBT`) for a
    log or bag, which can declare its DVL frame; a DataError for an A-KIT folder (``fixes["declare"]`` False), as its
    GT check refuses the same turn."""
    if not fixes["declare"]:
        raise DataError(finding, dvl.source, field=field)
    text = f"field '{field}': {finding}"
    say_doubted(meta, "dvl", dvl.source, text, TURNED_DOUBT, len(dvl.t), stacklevel=4)


def warn_small_turn(dvl, meta: dict, field: str, fixes: dict, yaw: float, sigma: float, r2: float,
                    against: str = "the IMU's axes", floor: float = MIN_YAW_RAD, doubt: str = YAW_DOUBT,
                    explained: str = "of its changes") -> None:
    """Warn about, note and count (``doubt``) a DVL velocity turned ``yaw`` rad about z from ``against`` (its fit's
    ``sigma``, rad, and ``r2``, the share it explains ``explained``) when beyond ``floor`` (rad, default
    :data:`MIN_YAW_RAD`) and :data:`YAW_SIGMAS` sigmas: a head mounted off, its instrument-frame columns read as body,
    or a ``dvl.C_d_b`` that is not the head's."""
    if not (abs(yaw) > floor and abs(yaw) > YAW_SIGMAS * sigma):
        return
    places = 1 if np.degrees(sigma) >= 0.05 else 2          # a sigma from a GT is hundredths of a degree
    text = (f"field '{field}': the DVL velocity is turned {np.degrees(yaw):+.{places}f} +- "
            f"{np.degrees(sigma):.{places}f} deg about z from {against} (the fit explains {r2:.2f} {explained}; "
            f"under {np.degrees(floor):g} deg or {YAW_SIGMAS:g} sigmas nothing is said), which puts the track "
            f"{100 * abs(np.sin(yaw)):.1f} % of the distance travelled sideways: a DVL head mounted turned, its "
            f"columns in the instrument frame read as body, or a dvl.C_d_b that is not the head's? {fixes['yaw']}")
    say_doubted(meta, "dvl", dvl.source, text, doubt, len(dvl.t), stacklevel=3)


def turn_against_reference(reference, t_dvl: np.ndarray, v_b: np.ndarray,
                           lever_arm_b: np.ndarray) -> tuple[float, float, float]:
    """``turn_fit``'s ``(yaw, sigma, r2)`` (rad) of the DVL velocity ``v_b`` (N,3) m/s, body frame as read, against
    the body velocity of ``reference`` (a :class:`~graphnav.calibration.reference.Reference`) at its stamps ``t_dvl``
    (s, on the IMU clock) plus ``omega x lever_arm_b`` (m, the DVL from the reference's point), horizontally as
    ``x + iy``, the pings in :data:`~graphnav.core.dvl_kinematics.WINDOW_S` windows as its samples. The turn alone:
    a lever arm's error reads as a turn here (:func:`turn_and_lever_against_reference` fits both)."""
    sides = _reference_sides(reference, t_dvl, v_b, lever_arm_b)
    if sides is None:
        return float("nan"), float("nan"), float("nan")
    a, b, _, window = sides
    a, b = a[:, 0] + 1j * a[:, 1], b[:, 0] + 1j * b[:, 1]
    z = np.conj(b) * a
    z = np.bincount(window, z.real) + 1j * np.bincount(window, z.imag)
    return turn_fit(z, float(np.vdot(a, a).real), float(np.vdot(b, b).real))


def _reference_sides(reference, t_dvl: np.ndarray, v_b: np.ndarray, lever_arm_b: np.ndarray):
    """``(a, b, omega, window)``: the DVL's horizontal velocity (M,2) m/s and the reference's body velocity plus
    ``omega x lever_arm_b`` (M,2) at the pings the reference covers, its body rate (M,3) rad/s and each ping's
    :data:`~graphnav.core.dvl_kinematics.WINDOW_S` window (M,) numbered 0.. without gaps; None under two windows."""
    from graphnav.calibration.reference import dvl_design
    _, omega, v_ref, keep = dvl_design(reference, t_dvl, v_b)
    t = np.asarray(t_dvl, float)[keep]
    if not t.size:
        return None
    window = np.unique((t - t[0]) // WINDOW_S, return_inverse=True)[1].reshape(-1)
    if window.max() < 1:
        return None
    return np.asarray(v_b, float)[keep][:, :2], (v_ref + np.cross(omega, lever_arm_b))[:, :2], omega, window


def turn_and_lever_against_reference(reference, t_dvl: np.ndarray, v_b: np.ndarray, lever_arm_b: np.ndarray):
    """``((yaw, sigma, r2), dl, dl_sigma)``: the DVL velocity ``v_b`` (N,3) m/s, body frame as read, fitted
    horizontally as ``c (v_ref + omega x lever_arm_b) + (omega x dl)`` against the body velocity ``v_ref`` and rate
    ``omega`` of ``reference`` (a :class:`~graphnav.calibration.reference.Reference`) at its stamps ``t_dvl`` (s,
    on the IMU clock): ``c = scale exp(i yaw)`` the turn about z (rad), ``dl`` (3,) m, body frame, what the lever
    arm ``lever_arm_b`` (m, the DVL from the reference's point) lacks. A lever arm off by ``dl`` adds ``omega x dl``
    only while the vehicle turns, a turn rotates the whole velocity: fitted alone (:func:`turn_against_reference`)
    the turn takes up the lever arm's error (Trajectory5 with its lever arm 1.86 m off: -1.6 deg). Sigmas (rad, m)
    with the pings in :data:`~graphnav.core.dvl_kinematics.WINDOW_S` windows as the samples (as ``turn_fit``'s:
    the larger of the windows' spread and the least-squares error with one sample per window); ``r2`` the share of
    the horizontal velocity explained. NaN under two windows."""
    sides = _reference_sides(reference, t_dvl, v_b, lever_arm_b)
    if sides is None:
        return (float("nan"),) * 3, np.full(3, np.nan), np.full(3, np.nan)
    a, b, omega, window = sides
    wx, wy, wz, zero = omega[:, 0], omega[:, 1], omega[:, 2], np.zeros(len(a))
    # rows x, y of c b (c = p + iq) and omega x dl: x = p bx - q by + wy dlz - wz dly, y = p by + q bx + wz dlx - wx dlz
    X = np.stack([np.stack([b[:, 0], -b[:, 1], zero, -wz, wy], 1), np.stack([b[:, 1], b[:, 0], wz, zero, -wx], 1)], 1)
    theta, cov, sse = _window_lstsq(X, a, window)
    grad = np.array([-theta[1], theta[0], 0, 0, 0]) / max(theta[0] ** 2 + theta[1] ** 2, 1e-300)
    sigma = np.sqrt(max(grad @ c @ grad for c in cov))
    dl_sigma = np.sqrt(np.maximum(*(np.diag(c)[2:] for c in cov)))
    r2 = 1.0 - sse / max(float(np.sum(a ** 2)), 1e-300)
    return (float(np.arctan2(theta[1], theta[0])), float(sigma), float(r2)), theta[2:], dl_sigma


def _window_lstsq(X: np.ndarray, y: np.ndarray, window: np.ndarray):
    """``(theta, (cov_spread, cov_fit), sse)``: least squares ``y = X theta`` over rows ``X`` (N, k, p), ``y`` (N, k)
    in windows numbered ``window`` (N,) 0..n-1: its covariance from the windows' spread (the clustered sandwich) and
    from the fit's residual with one sample per window."""
    Xf, yf = X.reshape(-1, X.shape[-1]), y.reshape(-1)
    B_inv = np.linalg.pinv(Xf.T @ Xf)
    theta = B_inv @ Xf.T @ yf
    e = y - X @ theta
    n = int(window.max()) + 1
    scores = np.zeros((n, X.shape[-1]))
    np.add.at(scores, window, np.einsum("nkp,nk->np", X, e))
    sse = float(np.sum(e ** 2))
    spread = n / (n - 1) * B_inv @ scores.T @ scores @ B_inv
    return theta, (spread, sse / (X.shape[1] * n) * B_inv), sse


def warn_turn_against_reference(turn: tuple[float, float, float], dvl, meta: dict, field: str, fixes: dict,
                                source) -> None:
    """Warn about, note and count (:func:`warn_small_turn`, ``fixes``: the advice) a DVL ``dvl`` whose velocity is
    turned about z from the body velocity of a GT (file ``source``) by ``turn`` (:func:`turn_against_reference`'s
    ``(yaw, sigma, r2)``) beyond :data:`GT_MIN_YAW_RAD` and :data:`YAW_SIGMAS` sigmas."""
    warn_small_turn(dvl, meta, field, fixes, *turn, f"the ground truth's body velocity ({source})",
                    GT_MIN_YAW_RAD, GT_YAW_DOUBT, "of its horizontal velocity")


def warn_lever_against_reference(dl: np.ndarray, dl_sigma: np.ndarray, dvl, meta: dict, field: str,
                                 lever_arm_b: np.ndarray, source, span_s: float = np.inf) -> None:
    """Warn about, note and count (:data:`GT_LEVER_DOUBT`) a DVL ``dvl`` whose velocity fits the body velocity of a
    GT (file ``source``) best with its lever arm ``lever_arm_b`` (m, body frame, the configuration's
    ``dvl.lever_arm_b``) moved by ``dl`` (m; sigmas ``dl_sigma``, :func:`turn_and_lever_against_reference`): when a
    component is beyond :data:`GT_MIN_LEVER_M` and :data:`YAW_SIGMAS` sigmas, over pings spanning ``span_s`` (s) of at
    least :data:`GT_LEVER_MIN_SPAN_S` (shorter: noted as not judged)."""
    if not span_s >= GT_LEVER_MIN_SPAN_S:
        add_note(meta, "dvl", f"its lever arm is not judged against the ground truth: {span_s:.0f} s of pings, "
                 f"{GT_LEVER_MIN_SPAN_S:g} s needed")
        return
    if not np.any((np.abs(dl) > GT_MIN_LEVER_M) & (np.abs(dl) > YAW_SIGMAS * dl_sigma)):
        return
    text = (f"field '{field}': the DVL velocity fits the ground truth's body velocity ({source}) best with the DVL "
            f"{_vector_text(dl)} +- {_vector_text(dl_sigma, '')} m from where dvl.lever_arm_b "
            f"{_vector_text(lever_arm_b)} m puts it (under {GT_MIN_LEVER_M:g} m or {YAW_SIGMAS:g} sigmas nothing is "
            "said): a wrong lever arm adds omega x its error to the velocity the DVL is taken to measure while the "
            f"vehicle turns. Set dvl.lever_arm_b about {_vector_text(np.asarray(lever_arm_b) + dl)} m in a --config "
            "file (graphnav calibrate estimates it against a GT)")
    say_doubted(meta, "dvl", dvl.source, text, GT_LEVER_DOUBT, len(dvl.t))


def _vector_text(x, sign: str = "+") -> str:
    """``x`` (m) as ``(+1.00, -0.04, +0.20)``; ``sign`` '' leaves out the plus."""
    return "(" + ", ".join(f"{v:{sign}.2f}" for v in x) + ")"


def warn_dvl_sideways(dvl, config, meta: dict, field: str, why: str, fixes: dict | None = None,
                      reference=None) -> None:
    """Warn about, note and count a DVL velocity pointing sideways or backward over the whole log, for a log whose
    fits could not judge the DVL's turn (``why``: the reason, said in the warning): a DVL turned 90 or 180 deg read
    as body, which nothing else catches there, or a crabbing vehicle. With a ``reference`` (a
    :class:`~graphnav.core.mission.GroundTruth` with velocity and attitude), which says where the vehicle moves, its
    mean direction in its body frame is the one the DVL's (:func:`_course`) is compared with, and a crabbing vehicle
    passes; without, body +x is (:data:`SIDEWAYS_COURSE_RAD`)."""
    course, moving = _course(dvl, config), _reference_course(reference)
    fix = (fixes or DECLARE_DVL_FIXES)["yaw"]
    if np.isfinite(moving):
        off = float(np.angle(np.exp(1j * (course - moving))))
        if not abs(off) > SIDEWAYS_COURSE_RAD:      # NaN (pointing no one way): nothing to say
            return
        text = (f"field '{field}': the DVL velocity points {np.degrees(course):+.0f} deg about z from body x on "
                f"average over the log, the reference's ({reference.source}, its velocity turned into its body "
                f"frame) {np.degrees(moving):+.0f} deg: columns in the instrument frame of a DVL mounted turned "
                f"{np.degrees(off):+.0f} deg, read as body (or a reference attitude in another frame)? {fix}")
    elif abs(course) > SIDEWAYS_COURSE_RAD:
        text = (f"field '{field}': the DVL velocity points {np.degrees(course):+.0f} deg about z from body x on "
                f"average over the log (an AUV moves mostly forward; its turn could not be judged against the IMU: "
                f"{why}): columns in the instrument frame of a DVL mounted turned, read as body? If the vehicle does "
                f"move sideways (a crabbing ROV) ignore this; else {fix}")
    else:
        return
    say_doubted(meta, "dvl", dvl.source, text, SIDEWAYS_DOUBT, len(dvl.t), stacklevel=3)


def _imu_turn_fix(yaw: int, frame: dict) -> str:
    """What to do about an IMU turned ``yaw`` deg about z: an A-KIT folder's ``imu_axis_signs`` (``frame["signs"]``)
    undo 180 deg; otherwise the file is turned before it is read."""
    signs = frame.get("signs")
    if signs is None:
        return TURN_ADVICE[0].lower() + TURN_ADVICE[1:]
    return (f"set imu_axis_signs {tuple(int(s) for s in np.asarray(signs) * [-1, -1, 1])} in a --config file (x and "
            "y negated)" if yaw == 180 else "turn the accelerometer and gyro columns of the file into the body frame "
            "(imu_axis_signs only negates axes)")


def _or_flu_axes(models: dict, imu, dvl, config, yaw: int, offsets, fixes: dict | None) -> str:
    """The sentence a refusal of a half turn between the IMU and a DVL pointing forward neither way adds where the
    DVL velocity with its y and z negated (FLU axes read as FRD, :data:`DVL_FLU`) fits the IMU less than
    :data:`IMU_YAW_MIN_Q` noise variances worse than the turn, or better (``models``: :func:`imu_turned_models`, each
    fit at its best of ``offsets``): on a vehicle moving sideways, whose x and z velocity barely change, both negate
    what changes. FLU columns of an ROV moving sideways were refused as an IMU or DVL turned 180 deg, FLU unnamed.
    '' for other turns, without ``fixes``, or where the turn fits clearly better."""
    if yaw != 180 or fixes is None:
        return ""
    flu, _ = dvl_window_model(imu, dvl, config, transform=DVL_FLU, ints=models[0].imu)
    fits = _best_fits({0: models[0], 180: models[180], "flu": flu}, offsets)
    q = _evidence(fits[180], fits["flu"])
    if q <= -IMU_YAW_MIN_Q:
        return ""
    return (f". Or the DVL velocity is in FLU axes (ROS base_link) read as FRD, its y and z negated, which fits "
            f"{abs(q):.3g} noise variances {'better' if q > 0 else 'worse'} than the half turn (a vehicle moving "
            f"sideways barely tells them apart): if so, {fixes['flu']}")


def _either_turned(imu, dvl, frame: dict, q: float, yaw: int, course: float, carried: bool = False) -> DataError:
    """The DataError for a turn about z between the IMU and the DVL when the DVL velocity points forward neither as
    read nor turned back (``course``: its mean direction, rad, NaN for none) or is ``carried`` by a current: either
    instrument may be the one turned, each with its fix. The DVL's would be read in a frame ``d`` with ``C_d_b`` =
    Rz(-yaw) (v_b = C_d_b v_d)."""
    where = (f"its mean direction {np.degrees(course):+.0f} deg from body x" if np.isfinite(course)
             else "its pings point no one way")
    why = ("its direction says nothing of the vehicle's forward (kept as body in a current, it points where the "
           "current carries the vehicle)" if carried else "it points forward neither as read nor turned back "
           f"({where}: a vehicle hovering, reversing or moving sideways)")
    dvl_fix = (AKIT_DVL_FIXES["yaw"] if frame.get("signs") is not None else
               f"declare its frame, dvl.C_d_b {_mounting_matrix(yaw)} in the configuration (with csv_columns.dvl.frame "
               "'instrument' for velocity columns; graphnav calibrate estimates it and writes both)")
    return DataError(f"the IMU's axes and the DVL velocity ({dvl.source}) are turned {yaw} deg about z against each "
                     f"other: the velocity fits the accelerometer and gyro better by {q:.3g} noise variances with the "
                     f"IMU turned ({IMU_YAW_MIN_Q:g} needed), but {why}, so the data cannot say which "
                     f"instrument is turned. IMU turned against {frame['what']} ({mounting_text(turn_about_z(yaw))}): "
                     f"{_imu_turn_fix(yaw, frame)}; DVL turned (its velocity "
                     f"{signed_turn(yaw):+d} deg about z from the IMU's axes): {dvl_fix}", imu.source,
                     field=frame["fields"])


def _mounting_matrix(yaw: int) -> str:
    """The ``dvl.C_d_b`` (as configured: 3 lists of 3) of a DVL whose velocity fits the IMU turned ``yaw`` deg about z
    into the IMU's axes (:func:`imu_yaw_fit`): Rz(-yaw), v_b = C_d_b v_d."""
    return "[" + ", ".join("[" + ", ".join(f"{x:g}" for x in row) + "]" for row in turn_about_z(yaw).T + 0.0) + "]"


def turn_found(dvl, config, yaw: int, frame: dict, fixes: dict) -> str:
    """Which instrument a DVL clock found only with the DVL velocity turned ``yaw`` deg about z into the IMU's axes
    (as :func:`imu_yaw_fit` turns it) says is mounted turned, and what to configure: the DVL when its velocity points
    forward only turned (its ``dvl.C_d_b``, with ``fixes["yaw"]``), the IMU when it points forward as read (``frame``
    as :func:`check_imu_yaw`'s), both when neither (:data:`FORWARD_COURSE_RAD`)."""
    course = _course(dvl, config)
    dvl_turned = (f"a DVL mounted turned, its velocity {signed_turn(yaw):+d} deg about z from the IMU's axes: "
                  f"dvl.C_d_b {_mounting_matrix(yaw)}; {fixes['yaw']}")
    imu_turned = (f"an IMU mounted turned against {frame['what']} ({mounting_text(turn_about_z(yaw))}): "
                  f"{_imu_turn_fix(yaw, frame)}")
    if _forward(course):
        return f"The DVL velocity points forward as read: {imu_turned}"
    if _forward_turned_back(course, np.deg2rad(yaw)):
        return f"The DVL velocity points forward only turned: {dvl_turned}"
    where = f"{np.degrees(course):+.0f} deg from body x" if np.isfinite(course) else "no one way"
    return f"The DVL velocity points {where}, forward neither as read nor turned: either {dvl_turned}; or {imu_turned}"


def yaws_to_try(dvl, config) -> list[int]:
    """:data:`IMU_YAWS_DEG` in the order a search with the DVL velocity turned back about z tries them: the turn
    that brings its mean direction (:func:`_course`) nearest body +x first (a DVL turned 270 deg is found on the first
    search, not the third), as listed where it points no one way (an IMU turned, the velocity forward as read)."""
    course = _course(dvl, config)
    if not np.isfinite(course):
        return list(IMU_YAWS_DEG)
    return sorted(IMU_YAWS_DEG, key=lambda yaw: abs(np.angle(np.exp(1j * (course - np.deg2rad(yaw))))))


def signed_turn(yaw: int) -> int:
    """A quarter turn ``yaw`` (deg, 0-360) as -90, 90 or 180."""
    return yaw - 360 if yaw > 180 else yaw


def _likely_unit(scale: float, declare: bool) -> str:
    """The unit a velocity ``scale`` times the IMU's likely is; ``declare``: said with the column map's key to declare,
    else what the numbers look like (an A-KIT folder's columns, which have no unit to declare)."""
    factor = min(LIKELY_UNITS, key=lambda f: abs(np.log(scale / f)))
    if abs(np.log(scale / factor)) >= np.log(MAX_SCALE_ERROR) / 2:
        return "a wrong velocity_unit" if declare else f"in a unit {scale:.3g}x m/s"
    return LIKELY_UNITS[factor][0 if declare else 1]


def check_velocity_against_imu(imu, dvl, config, meta: dict, moved: bool = False, imu_frame: dict | None = None,
                               field: str | None = None, fixes: dict = DECLARE_DVL_FIXES, reference=None,
                               clock_known: bool = True) -> None:
    """DataError when the DVL velocity (on the IMU clock) is far from the IMU's in scale (:func:`speed_scale`, a
    speed unit read wrong) or in FLU axes read as FRD (:func:`flu_fit_ratio`), naming the DVL file and its columns
    (``meta["stream_fields"]["dvl"]``); nothing when the fit tells too little (module docstring). The scale is
    taken where its fit is best within +- :data:`SCALE_SEARCH_S` (a wrong scale misleads the clock search by
    seconds). ``moved``: the clock search or a given time offset has just put the DVL on the IMU clock, so the loader
    could not check it for an earth frame (:func:`graphnav.io.dvl_frame.check_not_earth_frame`): checked here, the body
    kinematics judging a velocity that turns with the vehicle at each reading's own best DVL clock offset.
    ``imu_frame``: the IMU's declared frame (the loader's ``meta["prepare"]["imu_frame"]``) when no reference attitude
    checked its axes: its turn about z is checked too (:func:`check_imu_yaw`, at the offset of the best scale fit, which
    a turn leaves, where that fit explains at least :data:`MIN_SCALE_R2` and fits no offset as well turned back
    (:func:`fits_turned_elsewhere`); else each fit at its own best offset).
    ``field``: the DVL columns named (default the loader's ``meta["stream_fields"]["dvl"]``); ``fixes``: what the
    messages advise (:data:`DECLARE_DVL_FIXES`, :data:`AKIT_DVL_FIXES`); ``reference``: the mission's reference,
    which says where the vehicle moves when the fits cannot judge the DVL's turn (:func:`warn_dvl_sideways`). A turn
    beyond 10 deg is read at the best scale's offset (:data:`MAX_YAW_RAD`), up to a half turn where another offset
    fits as well turned back (:func:`~graphnav.core.dvl_kinematics.fits_turned_elsewhere`: a speed swinging with a
    period), each turn over the windows no DVL outage crosses (:data:`~graphnav.core.dvl_kinematics.MAX_TURN_GAP_S`);
    a few degrees beyond its sigma at the DVL's stamps as they stand (a clock found, given or the vehicle's) is warned
    about and counted (:data:`MIN_YAW_RAD`, :func:`warn_small_turn`). A velocity the body kinematics kept as body in a
    current (``meta[CARRIED]``, :func:`graphnav.io.dvl_frame.check_not_earth_frame`) is judged by no mean direction.
    ``clock_known`` False: the DVL stamps have still to be judged by a clock search (``clock: auto``), so the turn at
    them is taken up to a half turn where another offset fits as well turned back, and FLU axes are judged at each
    reading's own best offset too (:func:`check_flu_axes`), and the velocity's y is not judged: a velocity that fits
    clearly better with its y negated at them is judged only after the search (its y negated misleads the scale, turn
    and FLU fits: A-KIT pieces were refused as FLU, an IMU turned or a wrong unit). Otherwise (the stamps on the IMU
    clock as declared, given or found) the y is judged at them first (:func:`check_dvl_y`; 30 s off its clock a clean
    velocity fitted the IMU 1.28x better with its y negated)."""
    field = field or meta.get("stream_fields", {}).get("dvl", "velocity")
    try:
        model = judging_model(imu, dvl, config)
    except DataError as exc:
        add_note(meta, "dvl", f"its unit, turn and axes not judged against the IMU ({exc.message})")
        if imu_frame is not None:
            check_imu_yaw(imu, dvl, config, meta, imu_frame)        # says it could not be checked
        warn_dvl_sideways(dvl, config, meta, field, exc.message, fixes, reference)
        return
    if moved:
        # with ``meta``: a velocity kept unjudged is warned about and counted as on the IMU clock; the specific force
        # judges each reading at its own best offset (docs/decisions/dvl-frame.md)
        # the columns listed as the loader's own check lists them
        check_not_earth_frame(*dvl_velocity_b(dvl, config), imu.t, imu.omega_b, dvl.source, field.split(", "),
                              velocity_frame(config, meta), imu.f_b, meta=meta, own_offsets=True)
    # before the scale and turn fits, which a mirrored velocity misleads (a 1.57x scale; an IMU turned 90 deg); not
    # where the frame checks found the velocity in another frame than declared: an earth-fixed one fits no body axes
    if meta.get(KEPT_AS_DECLARED):
        or_dvl_y = ""
    elif not clock_known:
        if dvl_y_negated_fit(model, imu, dvl, config).refused:
            # judged once the clock search has put it on the IMU clock, with its y negated where only that finds it
            add_note(meta, "dvl", "its unit, turn and axes judged against the IMU once the clock search has put it on "
                                  "the IMU clock, not at its stamps as read, where its velocity fits the IMU better "
                                  "with its y negated (as a velocity seconds off its clock can)")
            return
        or_dvl_y = ""
    else:
        or_dvl_y = check_dvl_y(imu, dvl, config, meta, model, field, fixes)
    # the scale over windows cut where the clock search's are (MAX_CLOCK_GAP_S): a window across a 7 s outage holds
    # the velocity through it, and a 60 s A-KIT piece a day off fitted 1.48x 9.5 s off the clock found there
    best, fits = best_speed_fit(outage_cut_model(imu, dvl, config, ints=model.imu), SCALE_OFFSETS_S)
    scale, r2, _ = fits[best]
    # the turn over the windows no outage crosses (MAX_TURN_GAP_S), whose 20 s length its MAX_YAW_RAD was measured on
    _, turn_r2, yaw = speed_scale(model, SCALE_OFFSETS_S[best], gapless=True)
    if r2 >= MIN_SCALE_R2 and not 1 / MAX_SCALE_ERROR < scale < MAX_SCALE_ERROR:
        declared = meta.get("prepare", {}).get("dvl_unit")      # the key a declared unit is set under, to name
        fix = f"check {declared['key']} (declared {declared['unit']!r})" if declared else fixes["unit"]
        raise DataError(f"the DVL velocity is {scale:.2f}x what the IMU's accelerations say (the fit explains "
                        f"{r2:.2f} of its changes; a right unit gives 1, within {MAX_SCALE_ERROR:g}x): "
                        f"{_likely_unit(scale, fixes['declare'])}? {fix}".rstrip(), dvl.source, field=field)
    dvl_turn = None
    # a velocity the body kinematics kept as body in a current points where the current carries the vehicle: its mean
    # direction says nothing of the vehicle's forward, and it was judged on the IMU clock as it stands (offset 0)
    carried = bool(meta.get(CARRIED))
    # a speed swinging with a period fits half a period off turned 180 deg as well as on time: where another offset
    # fits so, the best offset's turn is known only up to a half turn, and a half turn there is no DVL's
    sign_free = fits_turned_elsewhere(fits, best)
    # a velocity its own fit finds turned, pointing forward turned back, is the DVL's (45 deg is no IMU quarter turn)
    turned = turn_r2 >= MIN_SCALE_R2 and abs(yaw if not sign_free else within_half_turn(yaw)) > MAX_YAW_RAD
    dvl_yawed = turned and not carried and _forward_turned_back(_course(dvl, config), yaw)
    if imu_frame is not None and not dvl_yawed:     # before the DVL's yaw: a turned IMU turns the velocity too
        # the best scale's offset where its fit explains enough to fix the DVL's clock; where not (a vehicle holding
        # its speed: r^2 0.02-0.4) its best is noise, up to 20 s off, and every fit is read at its own best offset
        # and where another offset fits as well turned back (a speed swinging with a period) its best is noise too
        fixed = r2 >= MIN_SCALE_R2 and not sign_free
        offsets = ((0.0,) if carried else (SCALE_OFFSETS_S[best],) if fixed else SCALE_OFFSETS_S)
        dvl_turn = check_imu_yaw(imu, dvl, config, meta, imu_frame, model, offsets, carried, or_dvl_y, fixes)
    if turned:
        _say_dvl_turned(dvl, meta, field, fixes, f"the DVL velocity is turned {np.degrees(yaw):+.1f} deg about z from "
                        f"the IMU's axes (the fit explains {turn_r2:.2f} of its changes): columns in the instrument "
                        f"frame of a yawed DVL read as body? {fixes['yaw']}")
    elif dvl_turn:                      # the DVL's own fit explains too little: the IMU-turn fit may still see it
        warn_dvl_turned(dvl, meta, field, dvl_turn, fixes)
    elif carried:
        add_note(meta, "dvl", "its mean direction not compared with the vehicle's forward: a velocity carried by the "
                              "current points where the current carries the vehicle")
    elif dvl_turn is None or not r2 >= MIN_SCALE_R2:     # only the mean direction is left to judge the turn by
        why = (_too_little_said(model, r2) if not r2 >= MIN_SCALE_R2 else
               "it fits the IMU's axes as read, whose turn about z was not judged") + (
               "; it fits the IMU as read better than turned by a quarter turn" if dvl_turn == 0 else "")
        warn_dvl_sideways(dvl, config, meta, field, why, fixes, reference)
    # a few degrees are read at the DVL's stamps with their sigma: the best scale's offset, up to 20 s off, is noise
    # for them; and a turn beyond 10 deg there that the best offset missed is said too
    if not turned and not dvl_turn:                 # not a quarter turn
        yaw, sigma, r2 = turn_at(model)
        if not clock_known and fits_turned_elsewhere(fits, AT_STAMPS):
            yaw = within_half_turn(yaw)     # stamps half a swing off turn a speed swinging with a period by 180 deg
        if r2 >= MIN_SCALE_R2:
            warn_small_turn(dvl, meta, field, fixes, yaw, sigma, r2)
    check_flu_axes(model, imu, dvl, config, meta, field, fixes, clock_known)


def _too_little_said(model, r2: float) -> str:
    """Why the speed scale's fit of r^2 ``r2`` (NaN: under two windows to fit) cannot judge the DVL's turn, for the
    clock model ``model``: where the IMU's gaps left it no windows, those gaps (``nan`` of the changes said nothing)."""
    if np.isnan(r2) and len(model.imu.gaps):
        return f"no two windows to fit it on: {imu_gaps_said(model.imu.gaps, model.window)}"
    return f"its fit explains {r2:.2f} of the velocity's changes, {MIN_SCALE_R2:g} needed"


def check_flu_axes(model, imu, dvl, config, meta: dict, field: str, fixes: dict, clock_known: bool = True) -> None:
    """DataError naming the DVL file and its columns ``field`` when the DVL velocity (the clock model ``model``) fits
    the IMU :data:`FLU_SSE_RATIO` times better with its y and z negated at its stamps (:func:`flu_fit_ratio`): FLU axes
    read as FRD. ``clock_known`` False (stamps a clock search has still to judge): a velocity that fits so at its
    stamps is judged again with each reading at its own best offset within +- :data:`SCALE_SEARCH_S`, and refused
    only where y and z negated still fit so: half a period off, a speed swinging with a period fits negated (along y
    on a vehicle moving sideways, as FLU axes do), while FLU axes negate neither x nor the clock (a note then; the
    clock search of a log then tries the velocity with y and z negated where it finds no clear clock, or one that
    explains little: :func:`graphnav.calibration.preparation._flu_finds_the_clock`)."""
    ratio, explained = flu_fit_ratio(model, imu, dvl, config)
    if not (explained >= MIN_FLU_EXPLAINED and ratio >= FLU_SSE_RATIO):
        return
    where = ""
    if not clock_known:
        at_stamps = ratio
        ratio, explained = flu_fit_ratio(model, imu, dvl, config, SCALE_OFFSETS_S)
        if not (explained >= MIN_FLU_EXPLAINED and ratio >= FLU_SSE_RATIO):
            add_note(meta, "dvl", f"its axes not taken for FLU: at its stamps it fits the IMU's accelerations "
                                  f"{at_stamps:.3g}x better with y and z negated, but each reading at its own best DVL "
                                  f"offset within +-{SCALE_SEARCH_S:g} s only {ratio:.3g}x (a speed swinging with a "
                                  "period fits negated half a period off; the DVL clock is not known)")
            return
        where = f", each reading at its own best DVL offset within +-{SCALE_SEARCH_S:g} s (the clock not known)"
    raise _unless_declared_earth(meta, DataError(
        f"the DVL velocity fits the IMU's accelerations {ratio:.3g}x better with its y and z negated{where} (then "
        f"explaining {explained:.2f} of its changes): FLU axes (ROS base_link) read as FRD? {fixes['flu']}",
        dvl.source, field=field))


#: A declared DVL velocity unit whose clock model leaves this many times as much of the velocity's changes unexplained
#: as another unit at least 10x larger or smaller, or knots for m/s (:func:`check_declared_velocity_unit`) is
#: contradicted by the data. Clean, as read over the best of x10, x100 and x1000: at most 1.03
#: (``experiments/dvl_unit_fits.py``: the ten A-KIT trajectories whole and in 60 s pieces, simulated missions of every
#: grade, hovering vehicles); over x0.514 or x1.944 at most 1.55 (a 60 s piece of Trajectory1); the velocity 10x too
#: small (mm/s declared on cm/s data) over the right unit at least 18.8, 100x too small (cm/s on m/s) 1897; m/s data
#: declared kn (x0.514) at least 6.57 on the ten whole (Trajectory13), knots declared m/s 14 on nine (Trajectory13:
#: 1.53, which the data do not show clearly).
VELOCITY_UNIT_RATIO = 4.0
#: Why DVL pings read in a declared unit the IMU contradicts, where no other unit explains them either, are counted.
VELOCITY_UNIT_DOUBT = "DVL velocity read in a declared unit the IMU's accelerations contradict"
#: A unit whose clock model leaves between this and :data:`VELOCITY_UNIT_RATIO` times less unexplained than the one
#: the velocity is read in (and explains some of it) makes that unit suspect: a warning, not a refusal. Clean logs
#: read in their right unit give at most 1.55 (a 60 s piece of A-KIT Trajectory1, knots over m/s; m/s, cm/s, mm/s
#: read right at most 0.84; the ten whole 0.65, simulated 1.11); mm/s data declared cm/s on a vehicle at 0.15-0.25
#: m/s, which stays inside the envelope, 2.35-2.98 with 3 mm/s of DVL noise (1.19-1.28 with 1 cm/s: not seen)
#: (``experiments/dvl_unit_fits.py --declared --pieces 60 120 --slow``).
VELOCITY_UNIT_SUSPECT_RATIO = 2.0
#: Why DVL pings read in a unit another fits better, though not by :data:`VELOCITY_UNIT_RATIO`, are counted.
VELOCITY_UNIT_SUSPECT = "DVL velocity unit suspect: another unit fits the IMU's accelerations better"


def check_declared_velocity_unit(imu, dvl, config, meta: dict, declared: dict | None) -> None:
    """A declared DVL velocity unit (``declared``: ``{"unit": ..., "key": ...}``, the loader's
    ``meta["prepare"]["dvl_unit"]``) checked against the IMU: another unit (:func:`other_velocity_units`: cm/s or m/s
    for mm/s, m/s or mm/s for cm/s, knots for m/s, m/s for knots) whose clock model leaves
    :data:`VELOCITY_UNIT_RATIO` times less of the velocity's changes unexplained is a DataError naming the DVL source,
    its columns and the key, when it explains some of them (leaves under 1, what a straight line per window leaves);
    when it does not, the velocity is kept in the declared unit with a warning, a note and its pings counted as
    doubted (:data:`VELOCITY_UNIT_DOUBT`). A unit taken too small makes every speed 100-1000x too small, which no
    speed range tells from a hovering vehicle's, while the IMU says the vehicle moves. Only units that keep the median
    speed within what a DVL measures are tried. Knots and m/s, 1.94x apart, are judged by the same fits where the
    speed scale's regression explains too little to judge (a vehicle holding its speed: A-KIT Trajectory13 in m/s
    declared kn loaded at 0.51x). A unit that fits between :data:`VELOCITY_UNIT_SUSPECT_RATIO` and
    :data:`VELOCITY_UNIT_RATIO` times better, explaining some of the changes, leaves the velocity as read with a
    warning naming it and the key, a note and its pings counted (:data:`VELOCITY_UNIT_SUSPECT`). ``declared`` with
    ``"taken": True`` is the unit a loader took where none was declared: judged the same, the fix is to declare one.
    Nothing when no unit is given, none other is plausible, or the DVL has under two windows of pings (the DVL is on
    the IMU clock)."""
    if not declared:
        return
    unit, key = declared["unit"], declared["key"]
    speed = float(np.nanmedian(np.linalg.norm(dvl_velocity_b(dvl, config)[1], axis=1)))
    others = other_velocity_units(unit, speed, config)
    if not others:
        return
    try:
        fits = velocity_scale_fits(imu, dvl, config, others.values())
    except DataError:
        return
    best = min(others, key=lambda u: fits[others[u]])
    k = others[best]
    ratio = fits[1.0] / max(fits[k], 1e-12)
    if not ratio >= VELOCITY_UNIT_SUSPECT_RATIO or (ratio < VELOCITY_UNIT_RATIO and not fits[k] < 1.0):
        return
    taken = declared.get("taken")
    said = (f"{f'no unit declared ({key}): read in' if taken else 'declared'} {unit!r}{'' if taken else f' ({key})'}, "
            f"but the IMU's accelerations fit the velocity's changes {ratio:.3g}x better in {best!r} (x{k:g}; left "
            f"unexplained {fits[k]:.3g} against {fits[1.0]:.3g} in {unit!r}); median speed {speed:.3g} m/s in "
            f"{unit!r}, {speed * k:.3g} m/s in {best!r}")
    field = meta.get("stream_fields", {}).get("dvl", "velocity")
    fix, suspect = unit_fix(declared, best), ratio < VELOCITY_UNIT_RATIO
    if not suspect and fits[k] < 1.0:
        raise DataError(f"{said}: {fix}", dvl.source, field=field)
    reason, note, tail = ((VELOCITY_UNIT_SUSPECT, "suspect", f"under the {VELOCITY_UNIT_RATIO:g}x that refuses it: "
                           f"kept in {unit!r}, suspect; {fix} if the file is in it") if suspect else
                          (VELOCITY_UNIT_DOUBT, "which the IMU contradicts", "though neither explains them (a straight "
                           f"line per window leaves less); kept in {unit!r}: check {key}"))
    count_doubted(meta, "dvl", reason, len(dvl.t))
    add_note(meta, "dvl", f"kept in {unit!r}, {note}: {said}")
    warnings.warn(f"{dvl.source}: field '{field}': {said}, {tail}", RuntimeWarning, stacklevel=3)


def other_velocity_units(unit: str, speed: float, config) -> dict[str, float]:
    """The velocity units a DVL velocity declared ``unit`` may be in instead (name -> factor to multiply the
    velocity as read by): a metric unit at least 10x larger or smaller, knots for m/s and m/s for knots
    (:data:`KNOTS_MIX_UP`), each putting the median ``speed`` (m/s in ``unit``) within
    what a DVL measures (the larger of :data:`~graphnav.core.mission.MAX_DVL_SPEED_MPS` and ``dvl.max_speed_mps``): a
    larger unit that makes a steady 1.5 m/s vehicle 1500 m/s fits a MEMS IMU's noise better, not the vehicle."""
    from graphnav.core.mission import MAX_DVL_SPEED_MPS
    bound = max(MAX_DVL_SPEED_MPS, float(config.dvl.max_speed_mps))
    return {u: k for u, k in other_unit_factors(unit).items() if not speed * k > bound}


#: The gyro scales the DVL check compares with the rates as read: what each would mean (module docstring).
GYRO_SCALES = {"rad/s data 57.3x too small": 180.0 / np.pi, "deg/s": np.pi / 180.0}
#: A gyro scale whose clock model leaves this many times less of the DVL's velocity changes unexplained than the rates
#: as read is taken (:func:`gyro_scale_fits`). As read over the scale that is wrong: at most 0.93 (hovering, where the
#: gyro hardly matters), 0.17 on simulated 60 s windows, 0.096 on the ten A-KIT's; the rates damaged, as read over
#: the right scale: at least 5.7 for rates 57.3x too small (simulated 60 s windows; the ten's 60 s windows 10.5, the
#: 120 s of Trajectory6 from 120 s 49.5), 1800 for deg/s (docs/decisions/units-clocks-axes.md).
GYRO_DVL_RATIO = 2.5


def _unexplained(model) -> float:
    """The share of the DVL's velocity changes the clock model ``model`` leaves unexplained (``1 - explained``) at
    the best DVL offset within +- :data:`SCALE_SEARCH_S`."""
    return 1.0 - max(model.score(o)[0] for o in SCALE_OFFSETS_S)


def gyro_scale_fits(imu, dvl, config) -> dict[float, float]:
    """Gyro scale (1 for the rates as read, and each of :data:`GYRO_SCALES`) -> the share of the DVL's velocity changes
    the clock model leaves unexplained with the gyro multiplied by it (:func:`_unexplained`). The model's
    ``int omega x v`` and its gravity turned by the gyro scale with it."""
    return {k: _unexplained(judging_model(dataclasses.replace(imu, omega_b=imu.omega_b * k), dvl, config))
            for k in (1.0, *GYRO_SCALES.values())}


def velocity_scale_fits(imu, dvl, config, scales) -> dict[float, float]:
    """DVL velocity scale (1 for the velocity as read, and each of ``scales``) -> the share of the velocity's changes
    the clock model leaves unexplained with the velocity multiplied by it (:func:`_unexplained`; the straight line it
    is measured against scales with it). No floor on the velocity's change (:func:`judging_model`): a velocity in a
    unit 100x too small changes by less than its noise, while the IMU says it changes by metres per second.

    Raises:
        DataError: under two windows of pings with a velocity.
    """
    ints = imu_integrals(imu.t, imu.f_b, imu.omega_b)
    return {k: _unexplained(dvl_window_model(imu, dvl, config, transform=k * np.eye(3), ints=ints)[0])
            for k in (1.0, *scales)}


def _gyro_against_reference(imu, fact: dict, meta: dict, unjudged: str):
    """The IMU with its gyro judged by a reference attitude whose unit is settled
    (:func:`graphnav.io.units.check_gyro_against_reference`), where the DVL could not; else as read, with the note
    ``unjudged`` saying what could not judge it."""
    omega_b = check_gyro_against_reference(imu.omega_b, imu.source, fact, meta)
    if omega_b is None:
        add_note(meta, "imu", unjudged + ("" if "reference" not in fact else "; nor can the reference attitude"))
        return imu
    return imu if omega_b is imu.omega_b else dataclasses.replace(imu, omega_b=omega_b)


def check_gyro_against_dvl(imu, dvl, config, meta: dict, found: str = ""):
    """The IMU with its gyro checked against the DVL velocity where the tilt kinematics could not judge its scale
    (``meta[GYRO_UNJUDGED]``, set by :func:`graphnav.io.units.imu_units`; the fact is then removed): rates the DVL's
    velocity changes fit :data:`GYRO_DVL_RATIO` times better 57.3x larger are a DataError, deg/s (57.3x smaller) are
    converted to rad/s with a warning and a note, or a DataError when a unit was declared. Unchanged when the fact
    is absent; with a note when the DVL cannot judge either (too few pings, no scale that explains any of its
    changes, or none that fits them :data:`GYRO_DVL_RATIO` times better than the others). ``found``: how the DVL came
    onto the IMU clock, for the messages."""
    fact = meta.pop(GYRO_UNJUDGED, None)
    if fact is None:
        return imu
    unjudged = (f"the gyro's scale is not judged (field {fact['field']}): the tilt kinematics could not (correlation "
                f"{fact['correlation']:.2f})")
    try:
        fits = gyro_scale_fits(imu, dvl, config)
    except DataError as exc:
        return _gyro_against_reference(imu, fact, meta, f"{unjudged}, nor can the DVL ({exc.message})")
    k = min(GYRO_SCALES.values(), key=fits.get)
    ratio = fits[1.0] / max(fits[k], 1e-12)
    if not min(fits.values()) < 1.0:
        # every scale leaves more than a straight line per window would: their ratio is noise against noise
        return _gyro_against_reference(
            imu, fact, meta, f"{unjudged}, nor can the DVL: no scale explains its velocity's changes (left unexplained "
            f"{min(fits.values()):.3g} at best, more than a straight line per window)")
    if not ratio >= GYRO_DVL_RATIO:
        if not 1 / ratio >= GYRO_DVL_RATIO:
            return _gyro_against_reference(
                imu, fact, meta, f"{unjudged}, nor can the DVL: the rates x{k:.4g} leave {1 / ratio:.3g}x as much of "
                f"its velocity's changes unexplained as the rates as read ({GYRO_DVL_RATIO:g} needed either way; a "
                "vehicle that barely turns or accelerates)")
        return imu
    fit = (f"the DVL velocity's changes ({dvl.source}{found}) fit these rates x{k:.4g} {ratio:.3g}x better than as "
           f"read (left unexplained {fits[k]:.3f} against {fits[1.0]:.3f}; the tilt kinematics could not judge them, "
           f"correlation {fact['correlation']:.2f})")
    return dataclasses.replace(imu, omega_b=gyro_scale_found(imu.omega_b, k, fit, imu.source, fact, meta))
