"""The frame of a DVL velocity read from columns (``csv_columns.dvl.frame``), and a check that velocity said to be
in the vehicle's frame is not in the earth's.

Frames (:data:`DVL_FRAMES`): ``body`` (forward-right-down, the default; ``frd`` is the same), ``flu`` (ROS
``base_link``: y and z negated), ``instrument`` (the DVL frame ``d``: turned to body by the configured
``dvl.C_d_b``), ``ned`` / ``enu`` (earth-fixed: turned back to ``d`` with the head's own roll, pitch and heading,
as :mod:`graphnav.io.pd0` does with an earth-coordinate ensemble's attitude, then to body by ``C_d_b``). An earth
frame needs those attitude columns (``euler`` of the DVL entry, ``angle_unit`` rad or deg); without them it is
refused: nothing on board turns an earth velocity back without a heading. A ping with a cell holding RDI's
bad-velocity flag (-32.768 m/s) is not turned (:func:`flagged_not_turned`): turned, the flag would spread over the
three axes as a plausible-looking or a "beyond max speed" velocity; kept, ``DvlData.sanitized`` refuses the ping
naming its line and the flag, as in a body-frame column.

Undeclared earth-frame velocity (:func:`course_turn_ratio`): an AUV moves mostly along its own x whatever its
heading, so the direction of a body-frame horizontal velocity turns little (a current or a sideslip turns it
somewhat); an earth-frame velocity's direction turns with the vehicle. Over 10 s windows, the RMS of the
direction's turn minus the gyro's z turn, over the RMS of the direction's turn, is 2.1-6.2 on the ten A-KIT
trajectories and 2.7-3.9 on simulated missions that turn, and 0.16-0.43 for the same logs in NED
(``docs/decisions/dvl-frame.md``): :data:`EARTH_FRAME_RATIO` 1 lies 2.1x and 2.3x from either side. The gyro's z
axis keeps its magnitude in any level mounting (FRD, FLU, a yawed IMU) and ENU negates the turn, so both signs are
tried. The check needs the DVL on the IMU clock: a DVL on a clock of its own is checked once the prepare step has
put it there (:func:`graphnav.calibration.dvl_scale.check_velocity_against_imu`). Before that, a clock-free check
(:func:`course_spread_ratio`) refuses it: the spread of a vehicle-fixed velocity's direction is a few percent of the
gyro heading's whatever the clock, an earth-fixed one's is about the same; the clock search, fitting an earth-fixed
velocity as a body one, lands tens of seconds off, where the turn check above hardly tells.

A vehicle slower than the current it moves in (an ROV, an AUV in a tidal stream) goes over the ground much as the water
does whatever its heading: its body-frame velocity turns and spreads as an earth-fixed one does. The body kinematics
tell them apart (:func:`kinematics_ratio`): on the IMU clock, a velocity the turn check would refuse is kept as body,
with a note, when they explain it better than they explain it taken as earth-fixed; within what the earth reading's
free heading per window gains from the velocity's noise alone (:func:`_kinematics`) it is kept with a counted warning,
as a slow vehicle's earth-fixed velocity pinging every few seconds fits so too. A DVL on a clock of its own that the
spread check would refuse is judged so before the clock search, each reading at its own best DVL clock offset
(:func:`_own_offsets`): the search alone picks the offset where the velocity read as body fits best, where an
earth-fixed velocity fits the body kinematics better than at its own clock; the same goes for a DVL the search has
put on the IMU clock that the turn check would refuse.
A vehicle so slow that its velocity's noise turns the direction as much as the vehicle turns
(:func:`course_turn_signal` under :data:`MIN_TURN_SIGNAL`) is not judged by either: kept as body, with a counted
warning.

These judge a frame taken with none declared. A vehicle frame the user declared (``csv_columns.dvl.frame``, a bag's
``bag_topics.dvl.frame``) is taken: where the checks find the velocity earth-fixed, it is kept in that frame with a
counted warning saying what they found (:func:`refuse_unless_declared`, :data:`DECLARED_FRAME_DOUBT`); their refusals
of an undeclared frame say so. A declared earth frame is judged as a vehicle frame is, turned to body by its attitude
columns: vehicle-fixed columns declared earth-fixed, turned by the heading, turn with the vehicle as an earth-fixed
velocity read as body does. Where the body kinematics say so clearly (:data:`DECLARED_EARTH_REFUSED`) it is refused
naming ``csv_columns.dvl.frame`` and ``body``; else kept with a counted warning (:data:`DECLARED_EARTH_DOUBT`).
Where its columns as read are earth-fixed too (read as body they turn with the vehicle), the attitude columns are
named instead: their unit or heading convention does not turn the velocity to body. On a vehicle that barely turns,
body columns declared earth-fixed point off the nose by about minus the heading once turned to body
(:func:`check_declared_earth_course`), as a true earth-frame velocity of a vehicle crabbing or moving sideways does;
where the speed changes the IMU tells them apart (the velocity's changes turned from its accelerations by about the
heading, :func:`turn_against_imu`) and body columns are refused; where it holds, they are warned about and counted.
"""
from __future__ import annotations

import functools

import numpy as np

from graphnav.core.errors import ConfigError, DataError
from graphnav.core.mission import rdi_flagged
from graphnav.core.rotations import C_NED_ENU, euler_to_C_b_n
from graphnav.io.units import ANGLE_UNITS

#: Frames a column map's DVL velocity may be declared in (``frd`` is ``body``).
DVL_FRAMES = ("body", "frd", "flu", "instrument", "ned", "enu")
EARTH_FRAMES = ("ned", "enu")
#: Windows over which the velocity's direction and the gyro turn are compared, s.
COURSE_WINDOW_S = 10.0
#: Horizontal speed under which a velocity's direction is not used, m/s (noise turns it at hover).
COURSE_MIN_SPEED_MPS = 0.3
#: The pings point one way when the mean of their horizontal unit directions is at least this long: 0.948-0.993 on
#: the ten A-KIT trajectories, 0.998-0.999 simulated (400 s, lawnmower and transit); a hovering AUV 0.02-0.09 (the
#: tests' ``_hovering_with_dvl``, seeds 1-10), whose mean direction is noise.
MIN_COURSE_RESULTANT = 0.5
#: ... and only when at least this share of the pings with a velocity is over :data:`COURSE_MIN_SPEED_MPS`: a vehicle
#: holding station crosses it on a ping or an excursion of a few seconds, whose pings point one way (resultant up to
#: 1.0) though the log does not. Over it: 0.0-0.01 of the pings of simulated vehicles holding station (400 s), 0.03-0.10
#: of hovering ones (0.15 m/s on thrusters, 3 mm/s and 3 cm/s of DVL noise); a vehicle at 0.25 +- 0.1 m/s 0.34-0.39,
#: at 0.45 m/s and the ten A-KIT trajectories 0.98-1.0.
MIN_MOVING_SHARE = 0.2
#: RMS gyro turn rate over the windows under which the check tells nothing, rad/s.
COURSE_MIN_TURN_RADPS = 2e-3
#: :func:`course_turn_ratio` under which the velocity turns with the vehicle: earth-fixed (module docstring).
EARTH_FRAME_RATIO = 1.0
#: Circular variance (1 - mean resultant length) of the gyro-integrated heading under which :func:`course_spread_ratio`
#: tells nothing: the vehicle turned too little (about a 90 deg arc).
COURSE_MIN_HEADING_SPREAD = 0.1
#: :func:`course_spread_ratio` above which the velocity turns with the vehicle: earth-fixed. Measured on the ten A-KIT
#: trajectories (whole, 60 s and 120 s crops turning enough): as recorded 0.01-0.24, in NED 0.69-1.95
#: (docs/decisions/dvl-frame.md); the geometric middle.
EARTH_FRAME_SPREAD_RATIO = 0.4
#: :func:`kinematics_ratio` under which a velocity that turns with the vehicle is kept as body: the body kinematics
#: leave less unexplained than the earth ones. Measured (docs/decisions/dvl-frame.md): slow vehicles in currents
#: (0.2-0.4 m/s in 0.5-1.0 m/s, 0.01-0.03 m/s noise) 0.28-0.98; the NED copies the turn check refuses, of the ten
#: A-KIT trajectories (whole, 60 s and 120 s crops) 1.60 and above, of simulated missions 3.5 and above. The noise
#: adds its margin (:func:`_kinematics`): 1.037 over 400 s, 1.065 over 60 s at 1 Hz, 1.36 over 60 s at 1/5 Hz; slow
#: vehicles in currents with 0.05 m/s of noise 0.99-1.023, the NED copies judged 1.08 and above at 1 Hz, but NED copies
#: pinging every 2-5 s from 1.07: kept within the margin, they are warned about and counted (:data:`FRAME_DOUBT`).
BODY_KINEMATICS_RATIO = 1.0
#: :func:`course_turn_ratio` under which the body kinematics judge a velocity (between :data:`EARTH_FRAME_RATIO` and
#: it they only refuse it, on a clock known or found: a vehicle about as fast as the current it moves in turns its
#: earth-fixed velocity's direction about as the gyro turns, ratio near 1). Measured (docs/decisions/dvl-frame.md): as
#: recorded, the ten A-KIT trajectories 2.14 and above whole, their crops in [1, 2) (60-200 s) at kinematics 0.45 at
#: most; slow vehicles' NED copies 0.8-4.2.
KINEMATICS_JUDGE_RATIO = 2.0
#: :func:`course_turn_signal` under which a velocity the turn check and the kinematics would refuse is kept as body: its
#: direction's noise turns it as much as the vehicle turns, and neither tells. Measured (docs/decisions/dvl-frame.md): a
#: simulated 0.28 m/s mission with 0.04 m/s beam noise 0.97; the NED copies refused, of simulated missions 2.4 and
#: above, of the ten A-KIT trajectories (whole, 60 s and 120 s crops) 3.6 and above; the geometric middle.
MIN_TURN_SIGNAL = 1.5
#: The ``meta`` key set when a velocity that turns with the vehicle is kept as body by its kinematics: it
#: points where the current carries the vehicle, not forward, and the prepare step judges it by no mean direction.
CARRIED = "dvl_carried_by_current"
#: The ``meta`` key set when the loader kept a velocity as body at each reading's own best DVL clock offset, its stamps
#: overlapping the IMU span but not known to be on its clock: the prepare step judges it as one off the IMU clock.
OFF_ITS_STAMPS = "dvl_carried_off_its_stamps"
#: Why DVL pings kept in the vehicle's frame are counted as doubted (``meta["streams"]["dvl"]["doubted"]``): the
#: body kinematics leave over :data:`BODY_KINEMATICS_RATIO` of them but within their noise, or the vehicle turns
#: under :data:`MIN_TURN_SIGNAL` times that noise; an earth-fixed velocity of a slow vehicle gives the same.
FRAME_DOUBT = "DVL velocity kept in the vehicle's frame, which its turns and kinematics cannot tell from an earth frame"
#: Why DVL pings kept in a vehicle frame the user declared are counted as doubted where the frame checks say the
#: velocity is earth-fixed: a declared frame is taken (the user knows the mounting), the data's contrary word said.
DECLARED_FRAME_DOUBT = "DVL velocity kept in its declared vehicle frame, though its turns say it is earth-fixed"
#: Why DVL pings declared in an earth frame are counted as doubted where, turned to body by their attitude columns,
#: the frame checks say they turn with the vehicle, but the body kinematics do not say so clearly
#: (:data:`DECLARED_EARTH_REFUSED`), or where turned to body it points off forward while its columns as read point
#: forward and the IMU does not tell (:func:`check_declared_earth_course`): the columns may be in the vehicle's frame.
DECLARED_EARTH_DOUBT = ("DVL velocity kept in its declared earth frame, though turned to body by its attitude it "
                        "turns with the vehicle or points off forward")
#: :func:`kinematics_ratio` of a velocity declared in an earth frame, turned to body by its attitude columns and found
#: turning with the vehicle, at or over which (and twice the margin its noise allows, :func:`_kinematics`) it is
#: refused: the columns read as body (its earth reading, turned back by the gyro's heading) are what the body
#: kinematics explain. Measured on the IMU clock where the turn check finds the turned velocity turning with the
#: vehicle (docs/decisions/dvl-frame.md): body-frame columns declared ned, A-KIT whole and 60-200 s crops 1.11-246
#: (Trajectory13's crops from 200 s 1.11 and 1.39, the rest 1.7 and above but one whose noise hides its turns),
#: simulated missions 1.50-1.76, slow vehicles in currents 1.07-2.37; true NED copies there, A-KIT crops 0.045 and 0.99,
#: slow vehicles 0.59-1.04 (their noise limits 1.04). Loaded, of 115 body copies declared ned 102 are refused so and 3
#: warned about; of their 115 true NED copies none is refused or warned about by this (2 slow, noisy vehicles carry
#: the "cannot tell" FRAME_DOUBT warning their body copies carry).
DECLARED_EARTH_REFUSED = 1.3
#: A velocity declared in an earth frame whose columns as read point within this of body +x (rad, their mean horizontal
#: direction) while, turned to body by its attitude columns, it points off forward (:data:`DECLARED_EARTH_OFF_WARNED`)
#: is body columns turned by the heading (:func:`check_declared_earth_course`): on a straight leg they point off the
#: vehicle's nose by minus the heading. Body-frame columns as read: -5.0..+1.9 deg on the ten A-KIT trajectories; a
#: true NED copy's columns point along its course over ground, within this of north only on such a heading.
DECLARED_EARTH_FORWARD_RAD = np.deg2rad(10.0)
#: ... warned about and counted (:data:`DECLARED_EARTH_DOUBT`) when it points further off forward than this once
#: turned to body (an AUV moves mostly forward, :data:`~graphnav.calibration.dvl_scale.FORWARD_COURSE_RAD`; a true
#: NED copy crabs this far only slower than the current it moves in, in a strong one, or moving sideways or backward
#: under its own thrust, which where it points cannot tell from body columns: only the IMU then refuses it,
#: :data:`DECLARED_EARTH_TURN_RAD`).
DECLARED_EARTH_OFF_WARNED = np.deg2rad(30.0)
#: A velocity declared in an earth frame that points off forward on a straight leg (:func:`check_declared_earth_course`)
#: is refused where its changes, turned to body, are turned about z from what the IMU's accelerations say by more than
#: this (rad) and :data:`DECLARED_EARTH_TURN_SIGMAS` sigmas beyond it, while its columns as read meet the IMU's within
#: as much (:func:`turn_against_imu`): body columns turned by the heading are turned by about minus the heading, a true
#: earth-frame velocity turned to body meets the IMU whichever way the vehicle moves over the ground (crabbing in a
#: current, sideways). The allowance covers a DVL mounted and a heading column a few degrees off (a true NED copy of
#: A-KIT, its heading column biased 5 deg: 5 deg). Measured (docs/decisions/dvl-frame.md), (|turn| - 10 deg) / sigma:
#: true NED copies at most 1.04 (A-KIT pieces that barely turn 0.54, 1152 slow vehicles in currents 0.37, straight legs
#: crabbing in cross currents or moving sideways 1.04); body copies declared ned up to 28 (A-KIT) and 59 (simulated),
#: under 3 where the speed is held (sigma 100 deg and more) and on a 0.05 m/s swing of speed (sigma about 25 deg).
#: One reading must be nearer the IMU's than the other by this too: a true NED copy heading 10 deg whose heading column
#: reads 13 deg more, in waves (sigma 0.7 deg), meets the IMU -13.1 deg turned to body and +9.9 deg as read.
DECLARED_EARTH_TURN_RAD = np.deg2rad(10.0)
#: ... and the sigmas (:data:`DECLARED_EARTH_TURN_RAD`).
DECLARED_EARTH_TURN_SIGMAS = 3.0
#: The ``meta`` key set when a declared frame was kept against the frame checks (the frame's name): said once, not
#: again by the prepare step's check.
KEPT_AS_DECLARED = "dvl_frame_kept_as_declared"
#: The ``meta`` key set (True) when an earth frame was kept though, turned to body, it points off forward while its
#: columns as read point forward (:func:`check_declared_earth_course`), not because it turns with the vehicle.
KEPT_POINTING_OFF = "dvl_frame_kept_pointing_off_forward"
#: Windows :func:`_own_offsets`' coarse scan scores at each offset (the clock search's 60 cost 1.6x as much on long
#: logs). Measured (docs/decisions/dvl-frame.md): logs up to 600 s have fewer; 5400 s slow vehicles a day off and their
#: NED copies get the same decisions, the body logs' offsets and the copies' earth offsets within 0.5 s of those at 60
#: windows (at 20 windows a body log's earth offset moved 2600 s).
OWN_OFFSETS_WINDOWS = 30
#: Headings a window's velocity taken as earth-fixed is tried at (:func:`kinematics_ratio`), rad.
_HEADINGS = np.deg2rad(np.arange(0.0, 360.0, 5.0))


def declared_frame(spec: dict, default: str = "body", key: str = "csv_columns.dvl") -> str:
    """``spec["frame"]`` of the configuration's ``key`` (a column map's DVL, or a bag's ``bag_topics.dvl``),
    ``default`` when not given, checked; ``frd`` is returned as ``body``."""
    frame = spec.get("frame", default)
    if frame not in DVL_FRAMES:
        raise ConfigError(f"{key}.frame = {frame!r}: choose one of {list(DVL_FRAMES)}")
    return "body" if frame == "frd" else frame


def velocity_to_body(v: np.ndarray, frame: str, C_d_b: np.ndarray, euler_d: np.ndarray | None = None
                     ) -> np.ndarray:
    """The DVL velocity (M,3), m/s, in ``frame`` turned to the body frame (FRD).

    Args:
        v: velocity as read, m/s, in ``frame``.
        frame: one of :data:`DVL_FRAMES` (``frd`` taken as ``body``).
        C_d_b: (3,3) DVL frame to body (``dvl.C_d_b``).
        euler_d: (M,3) roll, pitch, heading of the DVL frame in NED, rad (earth frames only).
    """
    v = np.asarray(v, float)
    if frame == "flu":
        return v * [1.0, -1.0, -1.0]
    if frame in EARTH_FRAMES:
        v_n = v @ C_NED_ENU.T if frame == "enu" else v
        C_d_n = euler_to_C_b_n(euler_d[:, 0], euler_d[:, 1], euler_d[:, 2])
        v = np.einsum("kji,kj->ki", C_d_n, v_n)                # v_d = C_d_n^T v_n
    if frame in ("instrument", *EARTH_FRAMES):
        return v @ np.asarray(C_d_b, float).T
    return v


def _unflagged(v: np.ndarray) -> np.ndarray:
    """The velocity ``v`` (M,3, m/s) with the pings where a cell is RDI's bad-velocity flag NaN."""
    return np.where(rdi_flagged(v).any(axis=1, keepdims=True), np.nan, v)


def flagged_not_turned(v: np.ndarray, turned: np.ndarray) -> np.ndarray:
    """``turned`` (M,3), the velocity ``v`` (M,3, m/s as read) in the body frame, except the pings where a cell of
    ``v`` is RDI's bad-velocity flag: those stay as read, for ``DvlData.sanitized`` to refuse by their flag."""
    return np.where(rdi_flagged(v).any(axis=1, keepdims=True), v, turned)


def _course_turns(t_dvl: np.ndarray, v: np.ndarray, t_imu: np.ndarray, omega_b: np.ndarray,
                  window_s: float = COURSE_WINDOW_S) -> tuple[np.ndarray, np.ndarray, float] | None:
    """The turn of the velocity's horizontal direction and the gyro z turn over each window of ``window_s`` moving
    pings cover (rad, both (W,)), and the noise of a window's direction turn (rad: sqrt 2 times the ping's direction
    noise, from the second differences of the direction over consecutive moving pings, a robust sigma); None when the
    gyro turns too little (:data:`COURSE_MIN_TURN_RADPS`) or fewer than 3 windows are covered. Arguments as
    :func:`course_turn_ratio`."""
    t_dvl, v = np.asarray(t_dvl, float), np.asarray(v, float)
    if len(t_dvl) < 3:
        return None
    moving = np.all(np.isfinite(v), axis=1) & (np.hypot(v[:, 0], v[:, 1]) >= COURSE_MIN_SPEED_MPS)
    course = np.arctan2(v[:, 1], v[:, 0])
    period = float(np.median(np.diff(t_dvl)))
    # turns between consecutive moving pings only (over a gap or a hover the direction between is unknown)
    pair = moving[1:] & moving[:-1] & (np.diff(t_dvl) <= 1.5 * period)
    turn = np.where(pair, np.angle(np.exp(1j * np.diff(np.where(moving, course, 0.0)))), 0.0)
    edges = np.arange(max(t_dvl[0], t_imu[0]), min(t_dvl[-1], t_imu[-1]), window_s)
    if len(edges) < 4:
        return None
    k = np.digitize(t_dvl[1:], edges) - 1
    inside = (k >= 0) & (k < len(edges) - 1)
    n = len(edges) - 1
    dvl_turn = np.bincount(k[inside], weights=turn[inside], minlength=n)[:n]
    covered = np.bincount(k[inside], weights=pair[inside], minlength=n)[:n] >= 0.8 * window_s / period
    w = np.asarray(omega_b, float)[:, 2]
    yaw = np.concatenate([[0.0], np.cumsum(np.diff(t_imu) * 0.5 * (w[1:] + w[:-1]))])
    gyro_turn = np.diff(np.interp(edges, t_imu, yaw))
    dvl_turn, gyro_turn = dvl_turn[covered], gyro_turn[covered]
    if len(dvl_turn) < 3 or np.sqrt(np.mean(gyro_turn ** 2)) / window_s < COURSE_MIN_TURN_RADPS:
        return None
    # a white noise of sigma on the direction gives its second differences a sigma of sqrt(6) sigma
    second = np.diff(turn)[pair[1:] & pair[:-1]]
    noise = np.sqrt(2.0 / 6.0) * 1.4826 * float(np.median(np.abs(second))) if len(second) else 0.0
    return dvl_turn, gyro_turn, noise


def course_turn_ratio(t_dvl: np.ndarray, v: np.ndarray, t_imu: np.ndarray, omega_b: np.ndarray,
                      window_s: float = COURSE_WINDOW_S) -> float:
    """How far the turn of the DVL velocity's horizontal direction is from the vehicle's: RMS over windows of
    ``window_s`` (both logs on one clock) of the direction's turn minus the gyro z turn (either sign: FLU and ENU
    negate it), over the RMS of the direction's turn. A vehicle-fixed velocity barely turns (ratio >> 1); an
    earth-fixed one turns with the gyro (<< 1). NaN when the gyro turns too little
    (:data:`COURSE_MIN_TURN_RADPS`) or fewer than 3 windows have moving pings throughout.

    Args:
        t_dvl: (M,) ping stamps, s. v: (M,3) velocity as read (its first two axes horizontal when level), m/s.
        t_imu: (K,) IMU stamps, s, on the DVL's clock. omega_b: (K,3) gyro rates, rad/s.
    """
    return _turn_ratio(_course_turns(t_dvl, v, t_imu, omega_b, window_s))


def _turn_ratio(turns: tuple | None) -> float:
    """:func:`course_turn_ratio` of :func:`_course_turns`' answer."""
    if turns is None:
        return float("nan")
    dvl_turn, gyro_turn, _ = turns
    apart = min(np.sqrt(np.mean((dvl_turn - s * gyro_turn) ** 2)) for s in (1.0, -1.0))
    return float(apart / max(np.sqrt(np.mean(dvl_turn ** 2)), 1e-12))


def course_turn_signal(t_dvl: np.ndarray, v: np.ndarray, t_imu: np.ndarray, omega_b: np.ndarray) -> float:
    """The RMS gyro turn over :func:`course_turn_ratio`'s windows over the noise of a window's direction turn (the
    velocity's own, ping to ping): under :data:`MIN_TURN_SIGNAL` the noise turns the direction as much as the vehicle
    does, and the turn ratio is near 1 whatever the frame. NaN where the ratio is. Arguments as
    :func:`course_turn_ratio`."""
    return _turn_signal(_course_turns(t_dvl, v, t_imu, omega_b))


def _turn_signal(turns: tuple | None) -> float:
    """:func:`course_turn_signal` of :func:`_course_turns`' answer."""
    if turns is None:
        return float("nan")
    return float(np.sqrt(np.mean(turns[1] ** 2)) / max(turns[2], 1e-12))


def course_spread_ratio(v: np.ndarray, t_imu: np.ndarray, omega_b: np.ndarray) -> float:
    """The circular variance of the DVL velocity's horizontal direction over that of the gyro-integrated heading, each
    over its own log (no common clock needed): a vehicle-fixed velocity's direction barely spreads (<< 1), an
    earth-fixed one spreads as the heading does (~1). NaN when the heading spreads under
    :data:`COURSE_MIN_HEADING_SPREAD` or fewer than 3 pings move.

    Args:
        v: (M,3) velocity as read, m/s. t_imu: (K,) IMU stamps, s. omega_b: (K,3) gyro rates, rad/s.
    """
    v = np.asarray(v, float)
    moving = np.all(np.isfinite(v), axis=1) & (np.hypot(v[:, 0], v[:, 1]) >= COURSE_MIN_SPEED_MPS)
    w = np.asarray(omega_b, float)[:, 2]
    if moving.sum() < 3 or len(w) < 2:
        return float("nan")
    yaw = np.concatenate([[0.0], np.cumsum(np.diff(t_imu) * 0.5 * (w[1:] + w[:-1]))])
    heading = 1.0 - abs(np.mean(np.exp(1j * yaw)))
    if not heading >= COURSE_MIN_HEADING_SPREAD:
        return float("nan")
    return float((1.0 - abs(np.mean(np.exp(1j * np.arctan2(v[moving, 1], v[moving, 0]))))) / heading)


def _finite_pings_and_imu(t_dvl, v, t_imu, f_b, omega_b):
    """``(t, v, imu)``: the stamps (s) and velocity (m/s) of the pings whose velocity ``v`` (M,3) is finite, and the
    IMU (``t_imu`` s, ``f_b`` m/s^2, ``omega_b`` rad/s) as :class:`~graphnav.core.mission.ImuData`: what the
    kinematics checks judge (arguments as :func:`kinematics_ratio`)."""
    from graphnav.core.mission import ImuData
    ok = np.all(np.isfinite(v), axis=1)
    return (np.asarray(t_dvl, float)[ok], np.asarray(v, float)[ok],
            ImuData(np.asarray(t_imu, float), np.asarray(f_b, float), np.asarray(omega_b, float)))


def _kinematic_residuals(imu, ints, t: np.ndarray, v: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(L, K, fitted)`` of the clock model's windows at offset 0 for the body-frame velocity ``v`` (M,3), m/s: the
    part of its residual that the velocity makes (``v + int omega x v``, less its fit per window) and the part the IMU
    makes (``int f_b``, less its fit), (win, window*3), zero at a window's padding; the residual is ``L - K``, linear
    in ``v``; and the pings fitted (win, window). None under two windows."""
    from graphnav.core.dvl_kinematics import dvl_window_model, without_window_fit
    from graphnav.core.mission import DvlData, no_beams
    model, _ = dvl_window_model(imu, DvlData(t, *no_beams(len(t)), v), ints=ints)
    inside, terms = model.terms(0.0)
    if terms is None or inside.sum() < 2:
        return None
    u, C, F, lever, A, fitted = terms             # every window whole but its padding: on one clock, offset 0
    return without_window_fit(u + C, A, fitted), without_window_fit(F + lever, A, fitted), fitted


def kinematics_ratio(t_dvl: np.ndarray, v: np.ndarray, t_imu: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray
                     ) -> float:
    """What the body kinematics ``dv_b/dt = f_b + C_n_b^T g - omega_b x v_b`` leave unexplained of the velocity's
    changes (the DVL clock model's windows, :mod:`graphnav.core.dvl_kinematics`, both logs on one clock), over what
    they leave of the same velocity taken as earth-fixed: turned into the body by the gyro's heading, at the heading
    that fits each window best (either sign of the gyro's z). A body-frame velocity obeys the body kinematics whatever
    the current (a steady current adds nothing to ``f_b``): under 1; an earth-fixed one read as body breaks the
    ``omega x v`` term in turns: over 1. NaN under two windows of pings.

    Args:
        t_dvl: (M,) ping stamps, s. v: (M,3) velocity as read, m/s. t_imu: (K,) IMU stamps, s, on the DVL's clock.
        f_b: (K,3) specific force, m/s^2. omega_b: (K,3) gyro rates, rad/s.
    """
    return _kinematics(t_dvl, v, t_imu, f_b, omega_b)[0]


def _kinematics(t_dvl: np.ndarray, v: np.ndarray, t_imu: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray
                ) -> tuple[float, float]:
    """(:func:`kinematics_ratio`, the ratio under which it keeps the velocity as body): the earth reading's free
    heading per window fits the velocity's noise, so a body-frame velocity whose noise hides its turns gives over 1.
    Per window of n pings the body reading leaves 3n - 6 numbers free (its v0 and g0 fitted), the earth reading one
    fewer; under noise alone their ratio over W windows is 1 + chi2(W) / chi2(W (3n - 7)): the ratio keeps within
    :data:`BODY_KINEMATICS_RATIO` plus 3 sigmas of that. Arguments as :func:`kinematics_ratio`; (NaN, NaN) where it
    is NaN."""
    from graphnav.core.dvl_kinematics import imu_integrals
    t, v, imu = _finite_pings_and_imu(t_dvl, v, t_imu, f_b, omega_b)
    try:
        ints = imu_integrals(imu.t, imu.f_b, imu.omega_b)
        body = _kinematic_residuals(imu, ints, t, v)
    except DataError:
        return float("nan"), float("nan")
    if body is None:
        return float("nan"), float("nan")
    L, K, fitted = body
    yaw = np.interp(t, ints.t, ints.W[:, 2])
    earth = np.inf
    for sign in (1.0, -1.0):
        c, s = np.cos(-sign * yaw), np.sin(-sign * yaw)
        u = np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=1)
        # Rz(psi) [u; uz] = cos psi [u; 0] + sin psi [J u; 0] + [0; uz]: the residual is linear in cos and sin
        parts = [_kinematic_residuals(imu, ints, t, np.column_stack([w, z]))[0]
                 for w, z in ((u, 0 * v[:, 2]), (u[:, ::-1] * [-1.0, 1.0], 0 * v[:, 2]), (0 * u, v[:, 2]))]
        P = np.stack([parts[0], parts[1], parts[2] - K], axis=-1)              # (win, window*3, 3)
        G = np.einsum("wki,wkj->wij", P, P)
        c3 = np.stack([np.cos(_HEADINGS), np.sin(_HEADINGS), np.ones_like(_HEADINGS)], axis=1)
        earth = min(earth, float(np.einsum("pi,wij,pj->wp", c3, G, c3).min(axis=1).sum()))
    return float(np.sum((L - K) ** 2) / max(earth, 1e-300)), _body_ratio_limit(fitted)


def _body_ratio_limit(fitted: np.ndarray) -> float:
    """The body-to-earth residual ratio under which a velocity is kept as body (:func:`_kinematics`' docstring), for
    the windows (rows) of ``fitted`` (win, window; True at the pings fitted, not a window's padding): each leaves 3n - 7
    numbers free over its n pings fitted."""
    windows = len(fitted)
    free = 3 * np.count_nonzero(fitted) - 7 * windows
    return float(BODY_KINEMATICS_RATIO + (windows + 3.0 * np.sqrt(2.0 * windows)) / max(free, 1))


def _readings(model, offset: float, use: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """What the body kinematics leave per window (win,) of the clock model ``model``'s velocity (whole windows) at
    ``offset`` s over the pings ``use`` (default those inside the IMU span): read as body, and read as earth-fixed
    (turned into the body by the gyro's heading at the heading that fits the window best, :func:`kinematics_ratio`'s
    earth reading); NaN at the windows not fitted."""
    from graphnav.core.dvl_kinematics import without_window_fit
    at = model.imu_at(offset, use)
    windows, terms = model.terms(offset, at=at)
    body, earth = np.full(len(model.t), np.nan), np.full(len(model.t), np.nan)
    if terms is None:
        return body, earth
    v, _, F, lever, A, fitted = terms
    W, n = at[2][1], len(v)
    zero, yaw = 0 * v[..., 0], W[..., 2]
    readings = [v, np.stack([zero, zero, v[..., 2]], axis=-1)]
    for sign in (1.0, -1.0):
        c, s = np.cos(-sign * yaw), np.sin(-sign * yaw)
        u = np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1], zero], axis=-1)
        readings += [u, np.stack([-u[..., 1], u[..., 0], zero], axis=-1)]     # Rz(psi) u = cos psi u + sin psi J u
    # the velocity's share of the residual (v + int omega x v, less its fit per window) is linear in it: the six
    # readings in one fit, and the IMU's share (int f_b) subtracted
    x = np.concatenate(readings)
    rot = np.cross(np.tile(np.diff(W, axis=1), (6, 1, 1)), 0.5 * (x[:, 1:] + x[:, :-1]))
    x = x + np.concatenate([0 * x[:, :1], np.cumsum(rot, axis=1)], axis=1)
    r = without_window_fit(x, np.tile(A, (6, 1, 1)), np.tile(fitted, (6, 1))).reshape(6, n, -1)
    r[:2] -= without_window_fit(F + lever, A, fitted)
    body[windows] = np.sum(r[0] ** 2, axis=1)
    # |cos psi r_u + sin psi r_Ju + r_z|^2 per window at each heading psi, either sign of the gyro's z
    c, s, z = np.cos(_HEADINGS), np.sin(_HEADINGS), r[1]
    trig = np.stack([c * c, s * s, 2 * c * s, 2 * c, 2 * s], axis=1)
    earth[windows] = np.sum(z ** 2, axis=1) + np.min(
        [(trig @ np.stack([np.sum(a * a, 1), np.sum(b * b, 1), np.sum(a * b, 1), np.sum(a * z, 1),
                           np.sum(b * z, 1)])).min(axis=0) for a, b in (r[2:4], r[4:6])], axis=0)
    return body, earth


def _own_offsets(t_dvl: np.ndarray, v: np.ndarray, t_imu: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray
                 ) -> tuple[float, float, float, float]:
    """(:func:`kinematics_ratio`, the ratio its noise allows, the velocity's best DVL clock offset read as body, and
    read as earth-fixed, s) of a DVL on a clock of its own, each reading judged at its own best offset: every offset of
    the DVL clock search (:func:`graphnav.core.dvl_kinematics.offset_grid`) is scored for both readings (what the
    body kinematics leave over the straight line's), each best refined, and the two compared over the windows both
    offsets fit. The search alone would pick the offset where the velocity read as body fits best, and an earth-fixed
    one read there fits the body kinematics better than at its own clock. NaN where fewer than two windows are fitted
    at both. Arguments as :func:`kinematics_ratio`, the DVL stamps on their own clock."""
    from graphnav.core.dvl_kinematics import (dvl_window_model, imu_integrals, offset_grid, refined_offset,
                                              search_overlap)
    from graphnav.core.mission import DvlData, no_beams
    nan = (float("nan"),) * 4
    t, v, imu = _finite_pings_and_imu(t_dvl, v, t_imu, f_b, omega_b)
    try:
        ints = imu_integrals(imu.t, imu.f_b, imu.omega_b)
        model, t = dvl_window_model(imu, DvlData(t, *no_beams(len(t)), v), ints=ints)
        period = float(np.median(np.diff(t)))
        overlap = search_overlap(ints.t[-1] - ints.t[0], t[-1] - t[0], model.window * period)
        h, grid = offset_grid(ints.t, t, overlap, period, "DVL", "dvl")
    except DataError:
        return nan

    def score(m, o, use=None, k=slice(None)):        # what each reading leaves over the straight line's
        out = np.array(_readings(m, o, use))[k]
        fitted = np.isfinite(out if out.ndim == 1 else out[0])
        if fitted.sum() < 2:                        # worse than any fit (the straight line's is 1)
            return np.full(out.shape[:-1], 1e12)
        return np.sum(out[..., fitted], axis=-1) / max(float(np.sum(m.sse_null_w[fitted])), 1e-12)
    # the coarse scan is most of the cost (a 5400 s log a day off: 2000 offsets), in proportion to its windows
    coarse = model.thinned(OWN_OFFSETS_WINDOWS)
    grid = grid[::2]                                # a ping period: the refinement reaches one each way
    scores = np.array([score(coarse, o) for o in grid])
    offsets = []
    for k in (0, 1):
        best = float(grid[int(np.argmin(scores[:, k]))])
        # the same pings, in the same parts between the IMU's gaps, at every offset tried, as the clock search's
        offsets.append(refined_offset(model, best, h, lambda o, use: score(model, o, use, k), xatol=1e-3)[0])
    common = model.pings(offsets[0]) & model.pings(offsets[1])
    body, earth = _readings(model, offsets[0], common)[0], _readings(model, offsets[1], common)[1]
    fitted = np.isfinite(body) & np.isfinite(earth)
    if fitted.sum() < 2:
        return nan
    ratio = float(np.sum(body[fitted]) / max(np.sum(earth[fitted]), 1e-300))
    return ratio, _body_ratio_limit(common[fitted]), *offsets


# a slow vehicle in a strong current (0.3 m/s in 0.5 m/s) moves over the ground much as the water does, whatever its
# heading: its direction turns and spreads as an earth-fixed velocity's does, and only the body kinematics tell them
# apart (kinematics_ratio), on the IMU clock or at each reading's own best clock offset (_own_offsets)
_DECLARE = ("declare csv_columns.dvl.frame 'ned' or 'enu' with the DVL's roll, pitch and heading columns ('euler', "
            "'angle_unit')")


#: What to do with a velocity the frame checks refuse that is in the vehicle's frame (``key``: the DVL entry).
_KEEP = "declare {key}.frame ('body', or the vehicle frame it is in): a declared frame is taken, with a warning"


#: What to do with an earth-fixed velocity in a bag, whose DVL entry takes no earth frame.
_BAG_DECLARE = ("republish it in the DVL's or the vehicle's frame (bag_topics.dvl.frame takes instrument, body or "
                "flu: an earth frame needs the head's attitude at each ping)")


#: What to do with a velocity declared in an earth frame that, turned to body by its attitude columns, turns with the
#: vehicle: its columns are in the vehicle's frame (or the attitude columns are not the DVL's).
_DECLARE_VEHICLE = ("declare csv_columns.dvl.frame 'body' (or the vehicle frame the columns are in: 'flu', "
                    "'instrument'), or check the attitude columns ('euler', 'angle_unit') are the DVL's roll, pitch "
                    "and heading")


#: What to do with a velocity declared in an earth frame that, turned to body by its attitude columns, turns with the
#: vehicle though its columns as read are earth-fixed (read as body they turn with the vehicle and the body kinematics
#: do not keep them): the attitude columns do not turn them to body (their unit, their heading's convention or zero),
#: and declaring 'body' would read an earth-fixed velocity as body.
_CHECK_ATTITUDE = ("the columns as read are earth-fixed as declared (read as body they turn with the vehicle too), so "
                   "the attitude columns do not turn them to body: check 'euler' are the DVL's roll, pitch and heading "
                   "(NED: heading clockwise from north) and 'angle_unit' is their unit; declaring 'body' would read an "
                   "earth-fixed velocity as body")


def _attitude_at_fault(said: dict) -> bool:
    """Whether a velocity declared in an earth frame (``said``, :func:`velocity_frame`) that turned to body turns with
    the vehicle has earth-fixed columns as read (``said["columns_as_read"]``, judged once, on the IMU clock only): its
    attitude columns, not its frame, are then what to check (:data:`_CHECK_ATTITUDE`)."""
    if "attitude_at_fault" not in said:
        vehicle_fixed = said.get("columns_as_read")
        said["attitude_at_fault"] = vehicle_fixed is not None and not vehicle_fixed()
    return said["attitude_at_fault"]


def _said(spec: dict) -> str:
    """How a column map's DVL velocity (``csv_columns.dvl`` ``spec``) got its frame, as the frame messages say it."""
    frame = declared_frame(spec)
    if "v_b" not in spec:
        return f"solved from the beam columns (on the configured geometry) in the {frame} frame"
    if frame in EARTH_FRAMES:
        return f"declared in the {frame} frame, turned to body with the attitude columns {list(spec.get('euler', []))},"
    how = "declared" if "frame" in spec else "taken (no 'frame' in csv_columns.dvl)"
    return f"{how} in the {frame} frame"


def _column_frame(spec: dict) -> dict:
    frame = declared_frame(spec)
    if frame in EARTH_FRAMES:
        return {"frame": frame, "said": _said(spec), "declare": _DECLARE_VEHICLE, "declared": True,
                "otherwise": f"if the columns are in the vehicle's frame, {_DECLARE_VEHICLE}"}
    return {"frame": frame, "said": _said(spec), "declare": _DECLARE, "declared": "frame" in spec,
            "keep": _KEEP.format(key="csv_columns.dvl")}


def _otherwise(said: dict) -> str:
    """What to do if the frame kept (``said``, :func:`velocity_frame`) is wrong, as the frame warnings end."""
    if said["frame"] in EARTH_FRAMES and _attitude_at_fault(said):
        return _CHECK_ATTITUDE
    return said.get("otherwise") or f"if it is earth-fixed, {said['declare']}"


def velocity_frame(config, meta: dict) -> dict:
    """How a log's or bag's DVL velocity got its frame, for the frame check the prepare step runs once it has put the
    DVL on the IMU clock: ``{"frame", "said", "declare"}``, the frame's name, the words saying what declared or
    assumed it (a column map's ``csv_columns.dvl.frame`` or its absence, its beams; a bag's DVL message or
    ``bag_topics.dvl.frame``) and what to do if the velocity is earth-fixed; ``"declared"``: the user declared the
    frame (``csv_columns.dvl.frame``, ``bag_topics.dvl.frame``), which the frame checks then warn against but take."""
    if meta.get("prepare", {}).get("format") != "bag":
        spec = (config.csv_columns or {}).get("dvl") or {}
        return _column_frame(spec)
    message = (meta.get("topics") or {}).get("dvl", "DVL topic")
    if "dvl_fields" in meta:                # a vendor's message read through bag_topics.dvl
        frame = meta["dvl_fields"]["frame"]
        declared = "frame" in (config.bag_topics.get("dvl") or {})
        how = "declared" if declared else "taken (no 'frame' in bag_topics.dvl)"
        return {"frame": frame, "said": f"of the bag's {message} {how} in the {frame} frame",
                "declare": _BAG_DECLARE, "declared": declared, "keep": _KEEP.format(key="bag_topics.dvl")}
    elif "dvl_twist_frame" in meta:
        frame = "instrument" if meta["dvl_twist_frame"].endswith("DVL frame") else "body"
        said = f"of the bag's {message} (frame_id {meta['dvl_twist_frame']})"
    else:
        frame, said = "instrument", f"of the bag's {message} in the DVL frame of its message"
    return {"frame": frame, "said": said, "declare": _BAG_DECLARE, "declared": False}


def _evidence(t_dvl, v, t_imu, omega_b, f_b=None, v_b=None) -> tuple:
    """(:func:`_course_turns`, :func:`course_turn_ratio`, :func:`_kinematics`) of a velocity ``v`` (M,3, m/s as read;
    ``v_b`` turned to body, default ``v``): the kinematics judged where ``f_b`` is given and the turn ratio is under
    :data:`KINEMATICS_JUDGE_RATIO`, else (NaN, NaN)."""
    turns = _course_turns(t_dvl, v, t_imu, omega_b)
    ratio = _turn_ratio(turns)
    kin = (float("nan"), float("nan")) if f_b is None or not ratio < KINEMATICS_JUDGE_RATIO else \
        _kinematics(t_dvl, v if v_b is None else v_b, t_imu, f_b, omega_b)
    return turns, ratio, kin


def _turns_with(ratio: float) -> bool:
    return bool(np.isfinite(ratio) and ratio < EARTH_FRAME_RATIO)


def _vehicle_fixed(t_dvl, v, t_imu, f_b, omega_b) -> bool:
    """A body-frame velocity ``v`` (M,3, m/s) :func:`check_not_earth_frame` keeps: it does not turn with the vehicle,
    or the body kinematics explain it better than taken as earth-fixed."""
    _, ratio, (kin, limit) = _evidence(t_dvl, v, t_imu, omega_b, f_b)
    return not _turns_with(ratio) or kin < limit


def smaller_unit_advice(t_dvl: np.ndarray, v: np.ndarray, declared: dict, t_imu: np.ndarray, f_b: np.ndarray,
                        omega_b: np.ndarray, spec, clearly: float = 1.0, speed_alone: bool = True) -> str | None:
    """Why a body-frame DVL velocity ``v`` (M,3, m/s in the ``declared`` unit: ``{"unit", "key"}``, with ``"taken":
    True`` the unit a loader took where none was declared, the fix then to declare one) that the vehicle's
    envelope or the frame check refuses is likely in a unit at least 10x smaller (or, for m/s, in knots), or None when
    none explains it: in that unit at most :data:`~graphnav.core.screening.MAX_REFUSED_FRACTION` of the pings are
    outside the envelope ``spec`` (``DvlSpec``) and, with the pings on the IMU's clock, the velocity is vehicle-fixed
    (:func:`check_not_earth_frame`'s test) and the IMU's accelerations leave less of its changes unexplained than in
    the declared unit, and under 1 (:func:`graphnav.io.units.velocity_unit_fits`). The best explained unit is named.
    ``t_imu`` (s), ``f_b`` (m/s^2), ``omega_b`` (rad/s): the IMU, FRD. ``clearly`` < 1 (beside pings refused
    whatever the unit, spikes among them): judged on the pings the declared unit keeps (inside the envelope), where
    spikes do not spoil the fits, the unit must leave under that share of what the declared one leaves unexplained.
    ``speed_alone`` False: without the IMU's fit (the pings not on its clock) no unit is advised."""
    from graphnav.core.screening import MAX_REFUSED_FRACTION, implausible_pings
    from graphnav.io.units import other_unit_factors, unit_fix, velocity_unit_fits
    unit = declared["unit"]
    factors = {u: k for u, k in other_unit_factors(unit).items() if k < 1}
    fits, cap, kept = velocity_unit_fits(t_dvl, v, (t_imu, f_b, omega_b), factors.values()), 1.0, ""
    if clearly < 1.0 and fits is not None:
        # speed spikes spoil every unit's fit alike (m/s with 30 % of its pings at 3x: 1.00 unexplained in knots, 1.02
        # in m/s; knots with 1 in 50 at 3x the same): judged on the pings the declared unit keeps, the right unit leaves
        # less (knots read as m/s, 0.005-0.045 m/s beams: 0.07-0.83 of what m/s leaves; m/s with spikes: 1.45-38x)
        refused = np.any(list(implausible_pings(t_dvl, v, spec).values()), axis=0)
        on_kept = velocity_unit_fits(t_dvl, np.where(refused[:, None], np.nan, v), (t_imu, f_b, omega_b),
                                     factors.values())
        if on_kept is not None:
            fits, cap, kept = on_kept, np.inf, f" on the {int((~refused).sum())} pings it keeps"
    n = int(np.all(np.isfinite(v), axis=1).sum())
    for u in sorted(factors, key=lambda u: fits[factors[u]] if fits else -factors[u]):
        k, w = factors[u], v * factors[u]
        outside = int(np.any(list(implausible_pings(t_dvl, w, spec).values()), axis=0).sum())
        if outside > MAX_REFUSED_FRACTION * n or (fits is None and not speed_alone) or (fits is not None and not (
                fits[k] < clearly * min(fits[1.0], cap) and _vehicle_fixed(t_dvl, w, t_imu, f_b, omega_b))):
            continue
        imu = "" if fits is None else (f", the velocity vehicle-fixed, the IMU's accelerations leaving {fits[k]:.3g} "
                                       f"of its changes unexplained against {fits[1.0]:.3g} in {unit!r}{kept}")
        said = f"the unit taken with none declared ({unit!r})" if declared.get("taken") else "the declared unit"
        return (f"{said} is the likely cause: in {u!r} (x{k:.4g}) the median speed is "
                f"{float(np.nanmedian(np.linalg.norm(w, axis=1))):.3g} m/s, {n - outside} of {n} pings within the "
                f"vehicle's envelope{imu}: {unit_fix(declared, u)}")
    return None


def check_not_earth_frame(t_dvl: np.ndarray, v: np.ndarray, t_imu: np.ndarray, omega_b: np.ndarray,
                          source: str, fields: list[str], said: dict, f_b: np.ndarray | None = None,
                          v_b: np.ndarray | None = None, meta: dict | None = None, declared: dict | None = None,
                          spec=None, own_offsets: bool = False, at_stamps: bool | None = None) -> float:
    """The :func:`course_turn_ratio` of a velocity declared (or taken) in a vehicle frame. When it turns with the
    vehicle (:data:`EARTH_FRAME_RATIO`) and the specific force ``f_b`` (K,3, m/s^2, at ``t_imu``) is given, the body
    kinematics judge it (:func:`kinematics_ratio` of ``v_b``, the velocity turned to body, default ``v``): under
    the ratio its noise allows (:func:`_kinematics`) it is kept as body (a vehicle slower than the current it moves
    in), noted in ``meta`` under :data:`BODY_KINEMATICS_RATIO`, over it warned about and counted (:data:`FRAME_DOUBT`),
    and ``meta[CARRIED]`` set; otherwise a DataError naming the file and columns: logged in
    the earth frame, or, with a ``declared`` unit (``{"unit", "key"}``) and the vehicle's envelope ``spec``, in a
    smaller unit that explains it (:func:`smaller_unit_advice`: a hovering vehicle's velocity 10x too large turns as
    an earth-fixed one does). A velocity whose turn ratio lies near 1 (under :data:`KINEMATICS_JUDGE_RATIO`: an
    earth-fixed velocity of a vehicle about as fast as the current turns so) is refused, once a clock search or a given
    offset has put the DVL on the IMU clock, where the kinematics say it is earth-fixed there and at each reading's
    own offset, and otherwise kept as before, without a word. ``own_offsets``: the DVL's clock is not known to be the
    IMU's (put there by a clock search or a given offset, or ``clock: auto``), so the kinematics at its stamps may
    favour either reading: they judge it, with each reading at its own best DVL clock offset (:func:`_own_offsets`),
    only where it would otherwise be refused; a velocity whose noise hides its turns (:data:`MIN_TURN_SIGNAL`) is
    kept there with a counted warning, as on the IMU clock. ``at_stamps`` (default: not ``own_offsets``): the
    kinematics at the stamps judge first (a clock search has not moved them to where the body reading fits best).
    ``said``: the frame, how it was declared or assumed and what to do if the velocity is earth-fixed
    (:func:`velocity_frame`)."""
    at_stamps = not own_offsets if at_stamps is None else at_stamps
    if meta is not None and meta.get(KEPT_AS_DECLARED):
        return float("nan")             # the loader kept it in its declared frame against the checks: said once
    turns, ratio, (kin, limit) = _evidence(t_dvl, v, t_imu, omega_b, f_b if at_stamps else None, v_b)
    if not ratio < KINEMATICS_JUDGE_RATIO:
        return ratio
    near = not _turns_with(ratio)       # kept by the turn check: only the kinematics refuse it
    if near and at_stamps:
        # only once the DVL is on a clock known or found: at the stamps as read, clean A-KIT body crops 1-2 s late
        # (Trajectory11 0-120 s, Trajectory1 180-240 s) fail at the stamps and at each reading's own offset alike
        return ratio
    if near and f_b is not None:
        # at stamps a clock search moved too: a body log's own clock (A-KIT Trajectory11's crops 1.06x at each
        # reading's own offset, 0.33x there), and such a velocity was never refused before
        kin, limit = _kinematics(t_dvl, v if v_b is None else v_b, t_imu, f_b, omega_b)
    if near and (f_b is None or not kin >= limit):
        return ratio
    turn = (f"over {COURSE_WINDOW_S:g} s windows its direction's turn minus the gyro's is {ratio:.2f} of its turn (a "
            f"vehicle-fixed velocity's: above {EARTH_FRAME_RATIO:g}, 2.1-6.2 on the A-KIT trajectories"
            f"{'; under ' + format(KINEMATICS_JUDGE_RATIO, 'g') + ' the body kinematics judge it' if near else ''})")
    if not near and _kept_carried(meta, source, fields, t_dvl, said, turn, kin, limit):
        return ratio
    judged = _judged(kin, limit) if np.isfinite(kin) else ""
    advice = None if not declared or spec is None or f_b is None else smaller_unit_advice(
        t_dvl, v if v_b is None else v_b, declared, t_imu, f_b, omega_b, spec)
    if advice:
        raise DataError(f"DVL velocity in the declared unit {declared['unit']!r} turns with the vehicle: {turn}; "
                        f"{judged}; {advice}", source, field=", ".join(fields))
    signal = _turn_signal(turns)
    if not near and signal < MIN_TURN_SIGNAL:
        if meta is not None:
            _keep_doubted(meta, source, fields, t_dvl, f"DVL velocity {said['said']} not judged for "
                          f"an earth frame: the vehicle turns only {signal:.2f}x the noise of its direction over "
                          f"{COURSE_WINDOW_S:g} s windows (the turn ratio {ratio:.2f}"
                          f"{', the kinematics ' + format(kin, '.2f') if np.isfinite(kin) else ''} say nothing "
                          f"under {MIN_TURN_SIGNAL:g}x): kept in the {said['frame']} frame; {_otherwise(said)}")
        return ratio
    if own_offsets and f_b is not None:
        kin, limit, *offsets = _own_offsets(t_dvl, v if v_b is None else v_b, t_imu, f_b, omega_b)
        where = _at_own_offsets(*offsets, not at_stamps)
        if (not kin >= limit) if near else _kept_carried(meta, source, fields, t_dvl, said, turn, kin, limit, where):
            if at_stamps and meta is not None and not near:
                meta[OFF_ITS_STAMPS] = True
            return ratio
        judged = _judged(kin, limit, where)
    judged = (f"{judged}: {_verdict(said)}" if np.isfinite(kin) else
              "it looks earth-fixed (NED/ENU), or a vehicle slower than the current it moves in whose velocity the "
              "body kinematics could not judge (under two windows of pings)")
    refuse_unless_declared(meta, source, fields, t_dvl, said, f"{turn}; {judged}", kin, limit)
    return ratio


def _kept_carried(meta: dict | None, source: str, fields: list[str], t_dvl: np.ndarray, said: dict, turn: str,
                  kin: float, limit: float, where: str = "") -> bool:
    """Whether a velocity that turns with the vehicle (``turn`` says how) is kept as body by the body kinematics
    (:func:`kinematics_ratio` ``kin`` under the ``limit`` its noise allows; ``where``: the offsets they were judged at,
    when not the stamps'): noted in ``meta`` under :data:`BODY_KINEMATICS_RATIO`, over it warned about and counted
    (:data:`FRAME_DOUBT`), and ``meta[CARRIED]`` set."""
    from graphnav.core.streams import add_note, stream_entry
    if not kin < limit:
        return False
    if meta is None:
        return True
    if kin < BODY_KINEMATICS_RATIO:
        # judged again once a clock search has moved the stamps: the later judgement replaces the earlier one's note
        said_before = f"velocity columns {fields} turn with the vehicle ("
        notes = stream_entry(meta, "dvl")["notes"]
        notes[:] = [n for n in notes if not n.startswith(said_before)]
        add_note(meta, "dvl", f"{said_before}{turn}), but the body kinematics leave {kin:.3f}x what they leave of it "
                 f"taken as earth-fixed{where} (under {limit:.3f}, what its noise allows): kept in the "
                 f"{said['frame']} frame, a vehicle slower than the current it moves in")
    else:
        _keep_doubted(meta, source, fields, t_dvl, f"DVL velocity {said['said']} turns with the vehicle "
                      f"({turn}), and the body kinematics leave {kin:.3f}x what they leave of it taken as earth-fixed"
                      f"{where}: over {BODY_KINEMATICS_RATIO:g}, but under {limit:.3f}, what its noise allows over "
                      f"{len(t_dvl)} pings, so a vehicle slower than the current it moves in and an earth-fixed "
                      f"velocity fit alike: kept in the {said['frame']} frame; {_otherwise(said)}",
                      stacklevel=5)
    meta[CARRIED] = True
    return True


def refuse_unless_declared(meta: dict | None, source: str, fields: list[str], t_dvl: np.ndarray, said: dict,
                           why: str, kin: float = float("nan"), limit: float = float("nan")) -> None:
    """A velocity the frame checks find earth-fixed (``why`` says how; ``kin``: the :func:`kinematics_ratio` they
    judged it by and ``limit`` the ratio its noise allows, NaN where none): a DataError naming the file and columns,
    or, its vehicle frame declared (``said["declared"]``, :func:`velocity_frame`), kept in that frame with a counted
    warning (:data:`DECLARED_FRAME_DOUBT`) saying what the data suggest: the user knows how the DVL is mounted. A
    velocity declared in an earth frame is judged turned to body by its attitude columns: one that still turns with the
    vehicle is in the vehicle's frame as read, refused where the body kinematics say so clearly (from
    :data:`DECLARED_EARTH_REFUSED`, and twice the margin its noise allows: naming ``csv_columns.dvl.frame`` and what to
    declare), else kept as declared with a counted warning (:data:`DECLARED_EARTH_DOUBT`)."""
    earth = said["frame"] in EARTH_FRAMES
    if earth and kin >= DECLARED_EARTH_REFUSED and kin - 1.0 >= 2.0 * (limit - 1.0):
        fix = _CHECK_ATTITUDE if _attitude_at_fault(said) else \
            f"they are in the vehicle's frame, not the {said['frame']} frame: {said['declare']}"
        raise DataError(f"DVL velocity {said['said']} turns with the vehicle: {why}: {fix}", source,
                        field=", ".join(fields))
    if not (said.get("declared") and meta is not None):
        keep = f"; if it is in the vehicle's frame, {said['keep']}" if said.get("keep") else ""
        raise DataError(f"DVL velocity {said['said']} turns with the vehicle: {why}: {said['declare']}{keep}",
                        source, field=", ".join(fields))
    _keep_as_declared(meta, source, fields, len(t_dvl), said, f"turns with the vehicle: {why}")


def _keep_as_declared(meta: dict, source: str, fields: list[str], n: int, said: dict, found: str) -> None:
    """Warn about and count the ``n`` pings of a velocity kept in its declared frame (``said``) against a check that
    ``found`` something else (:data:`DECLARED_EARTH_DOUBT` or :data:`DECLARED_FRAME_DOUBT`), and mark it kept
    (:data:`KEPT_AS_DECLARED`): said once."""
    from graphnav.core.streams import say_doubted
    say_doubted(meta, "dvl", source, f"field '{', '.join(fields)}': DVL velocity {said['said']} {found}: kept in the "
                f"{said['frame']} frame as declared; {_otherwise(said)}",
                DECLARED_EARTH_DOUBT if said["frame"] in EARTH_FRAMES else DECLARED_FRAME_DOUBT, n, stacklevel=4)
    meta[KEPT_AS_DECLARED] = said["frame"]


def _verdict(said: dict) -> str:
    """What the body kinematics found of a velocity they refuse, in the frame ``said`` (:func:`velocity_frame`): read
    in a vehicle frame, earth-fixed; declared in an earth frame and turned to body, vehicle-fixed as read."""
    if said["frame"] in EARTH_FRAMES and _attitude_at_fault(said):
        return "its earth reading (turned back by the gyro's heading) fits, not the body the attitude columns give"
    if said["frame"] in EARTH_FRAMES:
        return "the columns as read (its earth reading, turned back by the vehicle's heading) are vehicle-fixed"
    return "it is earth-fixed (NED/ENU)"


def _judged(kin: float, limit: float, where: str = "") -> str:
    """What the body kinematics say of a velocity they refuse as earth-fixed (:func:`_kept_carried`'s arguments)."""
    return (f"the body kinematics (dv_b/dt = f_b + g_b - omega_b x v_b) leave {kin:.2f}x what they leave of it "
            f"taken as earth-fixed{where} (a body-frame velocity's, a slow vehicle's in a current too: under "
            f"{limit:.3f}, what its noise allows)")


def _at_own_offsets(body_s: float, earth_s: float, moved: bool = False) -> str:
    """Where :func:`_own_offsets` judged the two readings (s, added to the DVL stamps as read, or with ``moved`` as
    the clock search or a given offset set them), for a message."""
    return (f", each reading at its own best DVL clock offset (as body {body_s:+.3f} s, as earth-fixed {earth_s:+.3f} s"
            f"{', added to the stamps the clock search or a given offset set' if moved else ''})")


def _keep_doubted(meta: dict, source: str, fields: list[str], t_dvl: np.ndarray, text: str, stacklevel: int = 4
                  ) -> None:
    """A velocity kept in the vehicle's frame though the data cannot tell it from an earth-fixed one: ``text`` warned
    about, noted and its pings counted (:data:`FRAME_DOUBT`)."""
    from graphnav.core.streams import say_doubted
    say_doubted(meta, "dvl", source, f"field '{', '.join(fields)}': {text}", FRAME_DOUBT, len(t_dvl),
                stacklevel=stacklevel)


def _check_spread(t_dvl: np.ndarray, v: np.ndarray, v_b: np.ndarray, t_imu: np.ndarray, omega_b: np.ndarray,
                  source: str, fields: list[str], said: dict, f_b: np.ndarray | None = None, meta: dict | None = None
                  ) -> None:
    """A velocity ``v`` (M,3, m/s as read; ``v_b`` turned to body) on a clock of its own that spreads with the heading
    (:func:`course_spread_ratio`) judged by the body kinematics with the specific force ``f_b``, each reading at its
    own best DVL clock offset (:func:`_own_offsets`): kept as body as :func:`check_not_earth_frame` keeps one on the
    IMU clock (a vehicle slower than the current it moves in), else a DataError naming the file and columns: logged
    in the earth frame."""
    ratio = course_spread_ratio(v, t_imu, omega_b)
    if not (np.isfinite(ratio) and ratio > EARTH_FRAME_SPREAD_RATIO):
        return
    spread = (f"its direction spreads {ratio:.2f}x as much as the gyro's heading (a vehicle-fixed velocity's: under "
              f"{EARTH_FRAME_SPREAD_RATIO:g}, 0.01-0.24 on the A-KIT trajectories; compared without a common clock, "
              f"the DVL's being its own)")
    kin, limit, *offsets = (float("nan"),) * 4 if f_b is None else _own_offsets(t_dvl, v_b, t_imu, f_b, omega_b)
    where = _at_own_offsets(*offsets)
    if _kept_carried(meta, source, fields, t_dvl, said, spread, kin, limit, where):
        return
    judged = (f"{_judged(kin, limit, where)}: {_verdict(said)}" if np.isfinite(kin) else
              "it looks earth-fixed (NED/ENU), or a vehicle slower than the current it moves in, which spreads so "
              "too and only the body kinematics tell apart: they could not judge it (under two windows of pings at "
              "both readings' best DVL clock offsets)")
    if not np.isfinite(kin) and not said.get("declared"):
        # two pieces of advice, each with its condition: the clock lets the kinematics judge, the frame is the fix
        said = {**said, "declare": "if the DVL clock's offset from the IMU's is known, give it (dvl_time_offset_s; "
                                   "csv_columns.dvl.clock 'imu' where the stamps are on the IMU clock) and the body "
                                   f"kinematics judge it; if it is earth-fixed, {said['declare']}"}
    refuse_unless_declared(meta, source, fields, t_dvl, said, f"{spread}; {judged}", kin, limit)


def mean_course(v: np.ndarray) -> float:
    """The mean of the horizontal unit directions of ``v`` (N,3) m/s over :data:`COURSE_MIN_SPEED_MPS`, rad about z
    from the frame's x (where the frame checks and the IMU-turn checks take a velocity to point), NaN when shorter
    than :data:`MIN_COURSE_RESULTANT` or when those pings are under :data:`MIN_MOVING_SHARE` of the pings with a
    velocity."""
    h = v[:, 0] + 1j * v[:, 1]
    known = int(np.isfinite(h).sum())
    h = h[np.abs(h) >= COURSE_MIN_SPEED_MPS]
    if not h.size or h.size < MIN_MOVING_SHARE * known:
        return float("nan")
    mean = np.mean(h / np.abs(h))
    return float(np.angle(mean)) if abs(mean) >= MIN_COURSE_RESULTANT else float("nan")


def turn_against_imu(t_dvl: np.ndarray, v: np.ndarray, t_imu: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray,
                     offsets=(0.0,)) -> tuple[float, float, float, float, bool]:
    """``(yaw, sigma, offset, r2, sign_free)``: the turn about z (rad) of the body-frame velocity ``v`` (M,3, m/s, at
    ``t_dvl`` s) against what the IMU (``t_imu`` s, ``f_b`` m/s^2, ``omega_b`` rad/s) says of its changes, and its
    standard error (rad, :func:`graphnav.core.dvl_kinematics.yaw_sigma`: the clock model's windows, no lever arm), at
    the DVL offset among ``offsets`` (s, added to ``t_dvl``) where the fit explains most of the velocity's changes
    (``r2``, :func:`~graphnav.core.dvl_kinematics.speed_scale`'s, which a turn of the velocity leaves as it is: both
    readings of one velocity are judged at one offset); ``sign_free``: another of ``offsets`` fits as well with the
    velocity turned over 90 deg from there (:func:`~graphnav.core.dvl_kinematics.fits_turned_elsewhere`: a speed
    swinging with a period, half a period off), so the turn is known only up to 180 deg. NaN under two windows of
    pings."""
    from graphnav.core.dvl_kinematics import best_speed_fit, dvl_window_model, fits_turned_elsewhere, yaw_sigma
    from graphnav.core.mission import DvlData, no_beams
    t, v, imu = _finite_pings_and_imu(t_dvl, v, t_imu, f_b, omega_b)
    try:
        model, _ = dvl_window_model(imu, DvlData(t, *no_beams(len(t)), v))
    except DataError:
        return (float("nan"),) * 4 + (False,)
    offsets = np.atleast_1d(np.asarray(offsets, float))
    best, fits = best_speed_fit(model, offsets, gapless=True)
    return (*yaw_sigma(model, float(offsets[best])), float(offsets[best]), float(fits[best][1]),
            fits_turned_elsewhere(fits, best))


#: How far off the nose body-frame columns declared in an earth frame point once turned to body by the heading: forward
#: columns read as NED point north, read as ENU east (90 deg clockwise of north).
_COLUMNS_OFF_NOSE = {"ned": "minus the heading", "enu": "90 deg minus the heading"}


def check_declared_earth_course(v: np.ndarray, v_b: np.ndarray, heading: np.ndarray, source: str, fields: list[str],
                                said: dict, meta: dict, imu: tuple | None = None) -> None:
    """A velocity declared in an earth frame (``v``, M,3, m/s as read) whose columns as read point forward
    (:data:`DECLARED_EARTH_FORWARD_RAD`) while turned to body (``v_b``, M,3, m/s) it points off forward
    (:data:`DECLARED_EARTH_OFF_WARNED`): body columns turned by the ``heading`` column (M, rad), which a vehicle that
    barely turns gives the turn checks nothing to judge by. Where the vehicle changes speed the IMU judges it
    (``imu``: the pings' stamps on the IMU clock, s, and the IMU's stamps, s, specific force, m/s^2, and rates,
    rad/s): turned to body, its changes are turned from the IMU's by more than :data:`DECLARED_EARTH_TURN_RAD` and
    :data:`DECLARED_EARTH_TURN_SIGMAS` sigmas, while the columns as read meet the IMU's within as much
    (:func:`turn_against_imu`): refused naming ``csv_columns.dvl.frame`` and 'body'; the other way round (a true
    earth-frame velocity of a vehicle in a strong cross-current, or of an ROV moving sideways or backward, which points
    so on a straight leg too) kept with a note. A speed swinging with a period leaves the turns' sign to the DVL clock
    (:func:`_changes_against_imu`): with ``clock: auto``, the stamps as they stand fix it where the turns up to a half
    turn do not. Where the IMU does not tell (a vehicle holding its speed, DVL stamps
    off the IMU span) warned about and counted (:data:`DECLARED_EARTH_DOUBT`), naming the key and 'body'
    and the current a true earth frame would need. A log already kept as declared against the frame checks is not
    warned about again."""
    as_read, turned = mean_course(v), mean_course(v_b)
    if not (abs(as_read) <= DECLARED_EARTH_FORWARD_RAD and abs(turned) > DECLARED_EARTH_OFF_WARNED):
        return                              # NaN (pointing no one way): nothing to say
    if meta.get(KEPT_AS_DECLARED):
        return
    mean_heading = float(np.angle(np.nanmean(np.exp(1j * heading))))
    speed = float(np.nanmedian(np.hypot(v_b[:, 0], v_b[:, 1])))
    current = speed * (np.sin(abs(turned)) if abs(turned) < np.pi / 2 else 1.0)
    why = (f"turned to body it points {np.degrees(turned):+.0f} deg about z from body x on average, while its columns "
           f"as read point {np.degrees(as_read):+.0f} deg (an AUV moves mostly forward): body-frame columns turned by "
           f"the heading column (mean {np.degrees(mean_heading):+.0f} deg) point off the nose by about "
           f"{_COLUMNS_OFF_NOSE[said['frame']]}")
    verdict, changes = _changes_against_imu(v, v_b, imu)
    if verdict == "body":
        raise DataError(f"DVL velocity {said['said']} points off forward: {why}; {changes}: they are in the vehicle's "
                        f"frame, not the {said['frame']} frame: {said['declare']}", source, field=", ".join(fields))
    if verdict == "earth":
        from graphnav.core.streams import add_note
        add_note(meta, "dvl", f"velocity columns {fields} point off forward turned to body ({why}), but {changes}: "
                              f"kept in the {said['frame']} frame, a vehicle crabbing or moving sideways")
        return
    why += (f"; a true {said['frame'].upper()} velocity points so only for a vehicle crabbing "
            f"{abs(np.degrees(turned)):.0f} deg on a course within {np.degrees(DECLARED_EARTH_FORWARD_RAD):g} deg of "
            f"its columns' x, in a current of at least {current:.2f} m/s (at {speed:.2f} m/s over the ground), or "
            f"moving sideways or backward under its own thrust; {changes}")
    _keep_as_declared(meta, source, fields, len(v), said, f"points off forward: {why}")
    meta[KEPT_POINTING_OFF] = True


def _changes_against_imu(v: np.ndarray, v_b: np.ndarray, imu: tuple | None) -> tuple[str | None, str]:
    """``(verdict, text)``: what the IMU says of a declared earth-frame velocity that points off forward (arguments as
    :func:`check_declared_earth_course`'s), each reading's changes turned about z from the IMU's
    (:func:`turn_against_imu`) within :data:`DECLARED_EARTH_TURN_RAD` and :data:`DECLARED_EARTH_TURN_SIGMAS` sigmas
    or beyond: ``"body"`` where the columns as read meet the IMU's and, turned to body, do not; ``"earth"`` the
    other way round; each only where that reading is nearer the IMU's than the other by :data:`DECLARED_EARTH_TURN_RAD`
    too (the readings are turned from each other by about the mean heading column: a heading column or mounting
    further off than the allowance, on a heading within it, turns them as a frame would); None where the IMU does not
    tell (a vehicle holding its speed, DVL stamps off the IMU span, readings that close). Where the turns, known only
    up to a half turn, tell nothing (body columns declared NED on a vehicle heading within about 20 deg of south, ENU
    of west), the stamps as they stand tell, where they fit as well as the best offset (:func:`_changes_at_stamps`)."""
    from graphnav.core.dvl_kinematics import MIN_SCALE_R2, SCALE_OFFSETS_S, within_half_turn
    if imu is None:
        return None, "the IMU did not judge it (the DVL stamps, with dvl_time_offset_s, off the IMU span)"
    t_dvl, t_imu, f_b, omega_b, known = imu
    # stamps not known to be on the IMU clock are judged where the changes fit best within 20 s, and only where that
    # fit explains most of them: 8 s off, the turns at the stamps are noise with a small sigma (true NED straight legs
    # refused), and a weak fit's best offset is noise too (body legs swinging 0.05 m/s kept as earth-fixed)
    yaw_b, sigma_b, offset, r2, sign_free = turn_against_imu(t_dvl, v_b, t_imu, f_b, omega_b,
                                                             0.0 if known else SCALE_OFFSETS_S)
    yaw_r, sigma_r, *_ = turn_against_imu(t_dvl, v, t_imu, f_b, omega_b, offset)
    if not (np.isfinite(yaw_b) and np.isfinite(yaw_r)):
        return None, "the IMU did not judge it (under two windows of pings)"
    if not (known or r2 >= MIN_SCALE_R2):
        return None, (f"the IMU did not judge it (the DVL clock not declared 'imu', and at its best offset "
                      f"{offset:+.1f} s the IMU's accelerations explain {r2:.2f} of the velocity's changes, "
                      f"{MIN_SCALE_R2:g} needed)")
    floor, k = DECLARED_EARTH_TURN_RAD, DECLARED_EARTH_TURN_SIGMAS
    if sign_free:
        # half a period off, a speed swinging with a period fits turned 180 deg as well as on time: only the turn
        # within a half turn says which reading meets the IMU (both readings move by the same half turn)
        yaw_b, yaw_r = within_half_turn(yaw_b), within_half_turn(yaw_r)
    found = (f"its changes, turned to body, are turned {np.degrees(yaw_b):+.1f} +- {np.degrees(sigma_b):.1f} deg "
             f"about z from what the IMU's accelerations say, its columns as read {np.degrees(yaw_r):+.1f} +- "
             f"{np.degrees(sigma_r):.1f} deg (a velocity in its right frame: within {np.degrees(floor):g} deg and "
             f"{k:g} sigmas){'' if known else f'; at the DVL offset {offset:+.1f} s, where they fit best'}"
             f"{_SIGN_FREE if sign_free else ''}")
    verdict = _frame_by_turns(yaw_b, sigma_b, yaw_r, sigma_r)
    if verdict is None and sign_free:
        verdict, at_stamps = _changes_at_stamps(v, v_b, imu, r2)
        found += at_stamps
    return verdict, (found if verdict else f"the IMU does not tell them apart: {found}")


def _frame_by_turns(yaw_b: float, sigma_b: float, yaw_r: float, sigma_r: float) -> str | None:
    """The verdict of :func:`_changes_against_imu` from the turns about z (rad) of the changes of the two readings,
    turned to body (``yaw_b``) and as read (``yaw_r``), and their sigmas (rad)."""
    floor, k = DECLARED_EARTH_TURN_RAD, DECLARED_EARTH_TURN_SIGMAS
    body_off, read_off = abs(yaw_b) - floor > k * sigma_b, abs(yaw_r) - floor > k * sigma_r
    # the two readings are turned from each other by about the mean heading column; where one is not nearer the IMU's
    # by the allowance too, a heading column or mounting that far off (a true NED copy heading 10 deg, its heading
    # column 13 deg off: -13.1 and +9.9 deg) reads as a frame's turn
    apart = abs(abs(yaw_b) - abs(yaw_r)) > floor
    return ("body" if body_off else "earth") if body_off != read_off and apart else None


def _changes_at_stamps(v: np.ndarray, v_b: np.ndarray, imu: tuple, best_r2: float) -> tuple[str | None, str]:
    """``(verdict, text)`` of :func:`_frame_by_turns` at the DVL stamps as they stand (arguments as
    :func:`check_declared_earth_course`'s), where the fit there explains the velocity's changes as well as at the best
    offset, of r^2 ``best_r2`` (:func:`~graphnav.core.dvl_kinematics.fits_as_well`), the turns taken whole; else
    ``(None, "")``. Half a period off, a speed swinging with a period fits turned 180 deg as well as on time, and taken
    up to a half turn, two readings turned about 180 deg from each other (body columns declared NED on a vehicle
    heading within about 20 deg of south) both meet the IMU's: such columns heading 175 deg were kept so, their
    velocity negated. Which of the two, on time or half a period off, is the DVL's clock only the stamps say (the
    clock search judges them later): a DVL on time, as a log gives it unless told otherwise."""
    from graphnav.core.dvl_kinematics import fits_as_well
    t_dvl, t_imu, f_b, omega_b, _ = imu
    yaw_b, sigma_b, _, r2, _ = turn_against_imu(t_dvl, v_b, t_imu, f_b, omega_b, 0.0)
    if not (np.isfinite(yaw_b) and fits_as_well(r2, best_r2)):
        return None, ""
    yaw_r, sigma_r, *_ = turn_against_imu(t_dvl, v, t_imu, f_b, omega_b, 0.0)
    verdict = _frame_by_turns(yaw_b, sigma_b, yaw_r, sigma_r)
    if verdict is None:
        return None, ""
    return verdict, (f"; at the DVL stamps as they stand, which fit as well (r^2 {r2:.3f}, the best {best_r2:.3f}), "
                     f"turned to body {np.degrees(yaw_b):+.1f} +- {np.degrees(sigma_b):.1f} deg, as read "
                     f"{np.degrees(yaw_r):+.1f} +- {np.degrees(sigma_r):.1f} deg: the stamps fix the half turn (a true "
                     "earth-frame velocity of a vehicle moving the other way, its DVL stamps half a swing of its speed "
                     "off, reads so too: declare its DVL clock 'imu' then, with dvl_time_offset_s)")


#: What the turns of :func:`_changes_against_imu` say where the fits cannot fix their sign.
_SIGN_FREE = (", up to 180 deg: another offset fits as well with the changes turned 180 deg (a speed swinging with a "
              "period, half a period off), and the DVL clock is not known")


def columns_to_body(t_dvl: np.ndarray, v: np.ndarray, euler: np.ndarray | None, spec: dict, C_d_b: np.ndarray,
                    t_imu: np.ndarray, omega_b: np.ndarray, source: str, meta: dict, f_b: np.ndarray | None = None,
                    envelope=None, given_offset_s: float = 0.0) -> np.ndarray:
    """A column map's DVL velocity (M,3), m/s, in its declared ``frame`` turned to the body frame; a velocity in a
    vehicle frame checked not to be earth-fixed (:func:`check_not_earth_frame`), one in an earth frame checked so once
    turned to body by its attitude columns (vehicle-fixed columns turned by the heading turn with the vehicle); the
    frame noted in ``meta["streams"]["dvl"]``.

    Args:
        t_dvl: (M,) stamps, s. v: (M,3) the ``v_b`` columns in m/s. euler: (M,3) the entry's ``euler`` columns
            (roll, pitch, heading of the DVL frame; ``angle_unit``) or None. spec: ``csv_columns.dvl``.
        C_d_b: (3,3) ``dvl.C_d_b``. t_imu, omega_b: the IMU's stamps, s, and rates, rad/s (FRD or FLU).
        f_b: the IMU's specific force, m/s^2, for the body kinematics that keep a slow vehicle in a current.
        envelope: the vehicle's ``DvlSpec``, with which a velocity in a declared unit (``velocity_unit``) that turns
            with the vehicle is judged in smaller units (:func:`smaller_unit_advice`).
        given_offset_s: the configuration's ``dvl_time_offset_s`` (s), which prepare adds to the DVL stamps: a
            velocity overlapping the IMU span is judged there, and with ``clock`` ``auto`` (or an offset that leaves the
            IMU span), at each reading's own best offset too where it would be refused (:func:`check_not_earth_frame`'s
            ``own_offsets``).

    Raises:
        ConfigError: an earth frame without attitude columns or their unit.
        DataError: a vehicle-frame velocity that turns with the vehicle; an earth-frame one that, turned to body,
            clearly does (:func:`refuse_unless_declared`); one that points off forward while its columns as read point
            forward, where the IMU tells its changes are the columns' as read (:func:`check_declared_earth_course`;
            warned about and counted where it does not tell).
    """
    from graphnav.core.streams import add_note
    from graphnav.core.timeseries import on_the_imu_clock
    said = _column_frame(spec)
    frame = said["frame"]
    fields = list(spec["v_b"])
    meta.setdefault("stream_fields", {})["dvl"] = ", ".join(fields)     # named by a later check of the velocity
    if frame in EARTH_FRAMES:
        unit = spec.get("angle_unit")
        if euler is None or unit not in ANGLE_UNITS:
            raise ConfigError(f"csv_columns.dvl.frame = {frame!r}: an earth-frame velocity is turned back to the DVL "
                              "frame with the DVL's own attitude at each ping: give 'euler' (3 columns of the DVL "
                              f"file: roll, pitch, heading) and 'angle_unit' ({' or '.join(ANGLE_UNITS)})")
        euler = euler * ANGLE_UNITS[unit]
    v_b = _unflagged(velocity_to_body(v, frame, C_d_b, euler))
    # an earth frame is judged turned to body: a vehicle-fixed velocity declared earth-fixed, turned by the heading,
    # turns with the vehicle as an earth-fixed one declared body does
    v_judged = v_b if frame in EARTH_FRAMES else v
    imu = None                  # (DVL stamps, IMU stamps, f_b, omega_b, on a known clock): the straight-leg check
    if on_the_imu_clock(t_dvl, t_imu):
        declared = {"unit": spec["velocity_unit"], "key": "csv_columns.dvl.velocity_unit"} \
            if spec.get("velocity_unit") else None
        # judged at the given offset, which prepare adds; at the stamps as read only when they are known to be on
        # the IMU clock, else each reading also at its own best offset where the stamps would refuse it
        given = on_the_imu_clock(t_dvl + given_offset_s, t_imu)
        t_at = t_dvl + given_offset_s if given else t_dvl
        known = spec.get("clock", "auto") == "imu" and given
        imu = (t_at, t_imu, f_b, omega_b, known) if given and f_b is not None else None
        if frame in EARTH_FRAMES:
            said["columns_as_read"] = functools.partial(_vehicle_fixed, t_at, _unflagged(v), t_imu, f_b,
                                                        omega_b)
        check_not_earth_frame(t_at, v_judged, t_imu, omega_b, source, fields, said, f_b, v_b, meta, declared,
                              envelope, own_offsets=not known, at_stamps=True)
    else:
        _check_spread(t_dvl, v_judged, v_b, t_imu, omega_b, source, fields, said, f_b, meta)
        if not meta.get(CARRIED):
            add_note(meta, "dvl", "checked for an earth-frame velocity once on the IMU clock (a clock of its own)")
    if frame == "body":
        return v
    if frame in EARTH_FRAMES:
        check_declared_earth_course(_unflagged(v), v_b, euler[:, 2], source, fields, said, meta, imu)
        add_note(meta, "dvl", f"velocity columns {fields} in the {frame} frame turned to the DVL frame with the "
                              f"attitude columns {list(spec['euler'])}, then to body by dvl.C_d_b")
    else:
        add_note(meta, "dvl", f"velocity columns {fields} in the {frame} frame turned to body (FRD)")
    return flagged_not_turned(v, velocity_to_body(v, frame, C_d_b, euler))
