"""The one mission data model shared by the simulator, the loaders, the EKF, the graph and the benchmark.

A :class:`Mission` holds time-stamped streams on one clock (the IMU's; loaders apply time offsets and
record them in the configuration), plus the :class:`~graphnav.core.config.SensorConfig`.

Frames: ``f_b``, ``omega_b`` in the body frame (FRD); ``beams`` are along-beam velocities of the DVL head
(m/s); ground-truth ``p_n``, ``v_n`` in local NED (m, m/s) and ``C_b_n`` body-to-NED.
"""
from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.errors import DataError
from graphnav.core.screening import check_imu_gap, check_stamps, located

#: Largest along-beam (or DVL-axis) velocity magnitude a DVL can report, m/s: the velocity range of the
#: RDI Workhorse/Pathfinder class (+-10 m/s), far above any AUV speed. A larger value is an invalid flag or
#: a decoding error, never a measurement.
MAX_DVL_SPEED_MPS = 10.0
#: RDI's "bad velocity" marker: -32768 in raw counts (mm/s) and -32.768 once scaled to m/s. Both exceed
#: :data:`MAX_DVL_SPEED_MPS`; they are listed so that the warning can name them.
RDI_BAD_VELOCITY = (-32768.0, -32.768)


def rdi_flagged(values) -> np.ndarray:
    """Mask of the values (any shape, as read) that are RDI's bad-velocity marker, compared at float32 precision:
    a bag's float32 -32.768 is -32.76800155... once read as float64, and was counted as a speed beyond range."""
    with np.errstate(invalid="ignore", over="ignore"):
        return np.isin(np.asarray(values, float).astype(np.float32), np.float32(RDI_BAD_VELOCITY))

#: IMU gaps longer than this many nominal sample periods are bridged (see :meth:`ImuData.bridge_gaps`).
IMU_GAP_PERIODS = 2.5
#: An IMU rate measured further than this (relative) from the configured ``imu_rate_hz`` replaces it: a clock's
#: error is ppm, so this is another rate (50 or 200 Hz against 100), not drift.
IMU_RATE_TOLERANCE = 0.05
#: Assumed 1-sigma of the unmeasured specific force (m/s^2) and body rate (rad/s) inside a bridged IMU gap:
#: what an AUV's accelerations and turn rates may do that a linear interpolation misses. The estimators
#: add ``(sigma * gap length)^2`` to their velocity and attitude variances over a gap (a 2 s gap: 0.2 m/s,
#: 0.11 deg). Measured on 2 s gaps (simulated 200 s, seeds 1-3 navigation + seed 4 tactical, gaps at 40/80/
#: 120 s; mean mission VRMSE Graph-TC / EKF-TC / Graph-HN-batch, m/s): zero-order hold over the gap (what
#: the estimators did before) 4.3 / 7.8 / 1.9; interpolation without inflation 0.50 / 1.9 / 0.34; with
#: (0.1, 1e-3) 0.041 / 0.046 / 0.019 (no gap: 0.030 / 0.037 / 0.014). Accel 0.03-0.3 and gyro 1e-3-2e-3 do
#: about as well; gyro 3e-4 is too small (EKF 0.37). Gyro 5e-3 did worse (Graph-TC 0.046) and made the batch
#: smoother's Cholesky report an indeterminant system on 9 of 12 gaps (the CombinedImuFactor then holds the
#: gap's rotation variance next to bias random-walk variances ~1e-18; the batch now retries with QR), hence
#: 1e-3. A gap shorter than 2 s adds less (:data:`IMU_GAP_SIGMA_LENGTH_S`).
IMU_GAP_ACCEL_SIGMA = 0.1
IMU_GAP_GYRO_SIGMA = 1e-3
#: The gap length, s, the sigmas above were measured on. A shorter gap's sigmas shrink in proportion to its length
#: (its variances grow as ``(sigma * L * L / IMU_GAP_SIGMA_LENGTH_S)^2``): what linear interpolation misses grows
#: about as L^2 below it, not as L (the true samples of simulated missions, seeds 1-3 navigation + 4 tactical, gaps
#: every 1.37 s: rms velocity error per axis <= 0.7 mm/s at 0.2 s, 8.4 mm/s at 1 s, 58 mm/s at 2 s; attitude 0.02,
#: 0.56, 4.2 mrad). Held at sigma * L, a driver's lost read of 0.2 s (0.021 m/s) undid as much velocity knowledge as
#: the filter had (0.022 m/s from a 1 Hz DVL) and moved the end of a 120 s run by 0.26-0.45 m where the
#: interpolation itself costs about 1 cm (docs/decisions/loading-and-prepare.md).
IMU_GAP_SIGMA_LENGTH_S = 2.0
#: Bridging may add at most this many interpolated samples per recorded one: more means the stamps are not in
#: seconds or the rate is wrong (a real log with gaps for 90 % of its time is not navigable anyway).
MAX_BRIDGE_FACTOR = 10
def invalid_dvl_values(values: np.ndarray, max_speed: float = MAX_DVL_SPEED_MPS) -> np.ndarray:
    """Mask of DVL velocities (any shape, m/s) that are not measurements: NaN/inf, RDI's bad-velocity
    markers, or beyond ``max_speed`` in magnitude."""
    values = np.asarray(values, float)
    with np.errstate(invalid="ignore"):
        return ~np.isfinite(values) | (np.abs(values) > max_speed) | rdi_flagged(values)


@dataclass(frozen=True)
class ImuGap:
    """An IMU gap bridged by interpolation: samples ``index`` and ``index + 1`` (of the original stream)
    are ``t_end - t_start`` seconds apart."""

    index: int
    t_start: float
    t_end: float

    @property
    def length(self) -> float:
        return self.t_end - self.t_start

    def overlap(self, t0: float, t1: float) -> float:
        """Seconds of the gap inside ``[t0, t1]``."""
        return max(0.0, min(t1, self.t_end) - max(t0, self.t_start))


def gap_variances(gaps: list[ImuGap], t0: float, t1: float) -> tuple[float, float]:
    """Extra (velocity (m/s)^2, attitude rad^2) variance per axis for the bridged gaps inside [t0, t1]
    (s): each gap's seconds inside, a gap shorter than :data:`IMU_GAP_SIGMA_LENGTH_S` weighted by its share of it."""
    length = sum(g.overlap(t0, t1) * min(1.0, g.length / IMU_GAP_SIGMA_LENGTH_S) for g in gaps)
    return (IMU_GAP_ACCEL_SIGMA * length) ** 2, (IMU_GAP_GYRO_SIGMA * length) ** 2


def _check_time(t: np.ndarray, source: str) -> None:
    if t.ndim != 1:
        raise DataError(f"time stamps must be 1-D, got shape {t.shape}", source, field="t")
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise DataError.at_sample("time stamp is not finite", source, int(bad[0]), "t")
    check_stamps(t, source)        # bounds before anything loops over the time
    step = np.diff(t)
    bad = np.flatnonzero(step <= 0)
    if bad.size:
        kind = "duplicated" if step[bad[0]] == 0 else "out of order"
        raise DataError.at_sample(f"time stamp {kind} ({t[bad[0]]:.6f} s then {t[bad[0] + 1]:.6f} s)",
                                  source, int(bad[0]) + 1, "t")


def _check_array(a: np.ndarray, shape_tail: tuple, n: int, source: str, name: str,
                 finite: np.ndarray | None = None) -> None:
    if a.shape != (n,) + shape_tail:
        raise DataError(f"shape {a.shape}, expected {(n,) + shape_tail}", source, field=name)
    values_ok = np.isfinite(a)
    if finite is not None:
        values_ok |= ~finite
    bad = np.argwhere(~values_ok)
    if bad.size:
        raise DataError.at_sample("value is not finite", source, int(bad[0][0]), name)


def _check_speed(a: np.ndarray, used: np.ndarray, source: str, name: str) -> None:
    with np.errstate(invalid="ignore"):
        bad = np.argwhere(used & (np.abs(a) > MAX_DVL_SPEED_MPS))
    if bad.size:
        i, j = bad[0]
        raise DataError.at_sample(f"value {a[i, j]:g} m/s (column {j}) is beyond the {MAX_DVL_SPEED_MPS:g} m/s a DVL "
                                  f"can measure (an invalid flag such as RDI's -32.768?); {len(bad)} such value(s); "
                                  "DvlData.sanitized() marks them invalid", source, int(i), name)


@dataclass
class ImuData:
    """IMU samples. t (N,) s; f_b (N,3) specific force, m/s^2; omega_b (N,3) angular rate, rad/s.

    What a stamp means (:mod:`graphnav.core.imu_stamps`): sample k is the **increment over** ``[t_k, t_{k+1}]``
    **divided by its length**, stamped at the **start** of that interval, body axes frozen (in inertial space)
    at ``t_k``; the estimators hold it constant over ``[t_k, t_{k+1})``. Increments that end at their stamp
    (INS/IMU logs, pyins) and instant rates (ROS ``sensor_msgs/Imu``) are converted by
    :func:`~graphnav.core.imu_stamps.increments_to_samples` and :func:`~graphnav.core.imu_stamps.rates_to_samples`;
    taken as they are, the former cost 1.2 m/s and 240 m in 400 s of pure inertial navigation (the tests' pyins
    run)
    """

    t: np.ndarray
    f_b: np.ndarray
    omega_b: np.ndarray
    source: str = "imu"

    def validate(self) -> None:
        _check_time(self.t, self.source)
        _check_array(self.f_b, (3,), len(self.t), self.source, "f_b")
        _check_array(self.omega_b, (3,), len(self.t), self.source, "omega_b")

    def take(self, idx) -> "ImuData":
        return ImuData(self.t[idx], self.f_b[idx], self.omega_b[idx], self.source)

    def bridge_gaps(self, rate_hz: float, gap_periods: float = IMU_GAP_PERIODS
                    ) -> tuple["ImuData", list[ImuGap]]:
        """The stream the estimators integrate, and the gaps they must inflate their covariance over.

        1. All-zero rows (f_b = omega_b = 0: a logger's filler, physically impossible under gravity) are
           dropped, with a warning naming them.
        2. Gaps longer than ``gap_periods / rate_hz`` are filled at the nominal rate by linear interpolation
           between the samples on either side, with a warning. Integrating the sample before a gap over the
           whole gap (zero-order hold) would treat a 2 s gap as one 2 s sample; interpolation is better, but
           what the vehicle did inside the gap is unknown, so the estimators add the variances of
           :func:`gap_variances` (:data:`IMU_GAP_ACCEL_SIGMA`, :data:`IMU_GAP_GYRO_SIGMA`) over it.

        Returns ``(self, [])`` when there is nothing to do. Gap indices refer to the stream after step 1.
        """
        imu = self
        zero = np.flatnonzero(~np.any(self.f_b, axis=1) & ~np.any(self.omega_b, axis=1))
        if zero.size:
            warnings.warn(f"{self.source}: {zero.size} all-zero IMU row(s) dropped (index {zero[:5].tolist()}"
                          f"{'...' if zero.size > 5 else ''}): zero specific force is impossible under gravity",
                          RuntimeWarning, stacklevel=2)
            imu = self.take(np.setdiff1d(np.arange(len(self.t)), zero))
        if len(imu.t) < 2:
            return imu, []
        period = 1.0 / rate_hz
        step = np.diff(imu.t)
        at = np.flatnonzero(step > gap_periods * period)
        if not at.size:
            return imu, []
        gaps = [ImuGap(int(i), float(imu.t[i]), float(imu.t[i + 1])) for i in at]
        for g in gaps:
            check_imu_gap(g.t_start, g.t_end, self.source, g.index + 1)
        n_fill = int(np.sum(np.ceil(step[at] / period) - 1))
        if n_fill > MAX_BRIDGE_FACTOR * len(imu.t):
            # stamps in ms (a 10 ms step read as 10 s) or a wrong rate, not gaps: bridging would make the
            # stream hundreds of times longer (GBs of memory, minutes of CPU) before any estimate
            raise DataError(f"bridging the IMU gaps would add {n_fill} interpolated samples to {len(imu.t)} (median "
                            f"step {np.median(step):.4g} s at the configured {rate_hz:g} Hz): are the stamps in "
                            "seconds and imu_rate_hz right? (graphnav.io.units detects ms/us/ns stamps)",
                            self.source, field="t")
        longest = max(gaps, key=lambda g: g.length)
        warnings.warn(f"{self.source}: {len(gaps)} IMU gap(s) longer than {gap_periods * period:.3g} s bridged "
                      f"by linear interpolation (longest {longest.length:.3f} s after index {longest.index}, "
                      f"t = {longest.t_start:.3f} s); velocity/attitude covariance inflated over the gaps",
                      RuntimeWarning, stacklevel=2)
        pieces_t, pieces_f, pieces_w = [], [], []
        start = 0
        for g in gaps:
            i = g.index
            pieces_t.append(imu.t[start:i + 1])
            pieces_f.append(imu.f_b[start:i + 1])
            pieces_w.append(imu.omega_b[start:i + 1])
            n_fill = int(np.ceil(g.length / period)) - 1
            t_fill = g.t_start + g.length * np.arange(1, n_fill + 1) / (n_fill + 1)
            u = ((t_fill - g.t_start) / g.length)[:, None]
            pieces_t.append(t_fill)
            pieces_f.append((1 - u) * imu.f_b[i] + u * imu.f_b[i + 1])
            pieces_w.append((1 - u) * imu.omega_b[i] + u * imu.omega_b[i + 1])
            start = i + 1
        pieces_t.append(imu.t[start:])
        pieces_f.append(imu.f_b[start:])
        pieces_w.append(imu.omega_b[start:])
        bridged = ImuData(np.concatenate(pieces_t), np.concatenate(pieces_f), np.concatenate(pieces_w),
                          self.source)
        return bridged, gaps


def no_beams(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(beams, valid)`` of ``n`` pings without beams (a velocity-only DVL): (n,4) NaN m/s and (n,4) False."""
    return np.full((n, 4), np.nan), np.zeros((n, 4), bool)


@dataclass
class DvlData:
    """DVL pings.

    Attributes:
        t: (M,) s.
        beams: (M,4) along-beam velocity of the DVL head, m/s (NaN allowed where not valid).
        valid: (M,4) bool, True where the beam returned a usable measurement.
        v_b: optional (M,3) velocity of the DVL head in the body frame as the instrument reported it, m/s.
        v_d: optional (M,3) velocity of the DVL head in the DVL frame ``d`` measured by the instrument itself
            (a 3-beam solution, a velocity-only DVL, a velocity converted from an earth/ship-frame log), m/s.
            The estimators use it, through the DVL velocity model, on pings where ``v_d_valid`` is True and
            the beams cannot be used (fewer than the beams a ping needs); NaN elsewhere.
        v_d_valid: optional (M,) bool, True where ``v_d`` is a measurement.
        v_d_sigma: optional (M,3) one-sigma of ``v_d`` per DVL axis, m/s (None: the configuration's).
    """

    t: np.ndarray
    beams: np.ndarray
    valid: np.ndarray
    v_b: np.ndarray | None = None
    source: str = "dvl"
    v_d: np.ndarray | None = None
    v_d_valid: np.ndarray | None = None
    v_d_sigma: np.ndarray | None = None

    def validate(self) -> None:
        _check_time(self.t, self.source)
        if self.valid.shape != (len(self.t), 4) or self.valid.dtype != bool:
            raise DataError(f"valid mask must be bool of shape {(len(self.t), 4)}, got "
                            f"{self.valid.dtype} {self.valid.shape}", self.source, field="valid")
        _check_array(self.beams, (4,), len(self.t), self.source, "beams", finite=self.valid)
        _check_speed(self.beams, self.valid, self.source, "beams")
        if self.v_b is not None:
            used = np.repeat(self.valid.sum(axis=1, keepdims=True) >= 3, 3, axis=1)
            _check_array(self.v_b, (3,), len(self.t), self.source, "v_b", finite=used)
            _check_speed(self.v_b, used, self.source, "v_b")
        if self.v_d is not None:
            if self.v_d_valid is None or self.v_d_valid.shape != (len(self.t),) or self.v_d_valid.dtype != bool:
                raise DataError(f"v_d needs a bool v_d_valid of shape {(len(self.t),)}", self.source,
                                field="v_d_valid")
            used = np.repeat(self.v_d_valid[:, None], 3, axis=1)
            _check_array(self.v_d, (3,), len(self.t), self.source, "v_d", finite=used)
            _check_speed(self.v_d, used, self.source, "v_d")
            if self.v_d_sigma is not None:
                _check_array(self.v_d_sigma, (3,), len(self.t), self.source, "v_d_sigma", finite=used)

    def sanitized(self, max_speed: float = MAX_DVL_SPEED_MPS, lines: np.ndarray | None = None,
                  where: list[str] | None = None) -> "DvlData":
        """A copy where every beam that is not a measurement is marked invalid (and set to NaN), with a
        warning: NaN/inf, RDI's bad-velocity markers (-32768, -32.768) and |beam| > ``max_speed`` m/s.
        A ping whose reported ``v_b`` is such a value is invalid as a whole (the instrument flagged it).
        ``lines``: the file line of each ping, ``where``: where the file holds each ping (a PD0 ensemble, a bag
        message), named by the warning (neither: the ping's index).
        The loaders call this; build in-memory data with it too (``validate`` rejects such beams)."""
        bad_beam = self.valid & invalid_dvl_values(self.beams, max_speed)
        bad_ping = np.zeros(len(self.t), dtype=bool)
        v_b = self.v_b
        if v_b is not None:
            bad_ping = np.any(invalid_dvl_values(v_b, max_speed), axis=1) & self.valid.any(axis=1) \
                & ~np.all(np.isnan(v_b), axis=1)
        if not bad_beam.any() and not bad_ping.any():
            return self
        valid = self.valid & ~bad_beam & ~bad_ping[:, None]
        beams = np.where(valid, self.beams, np.nan)
        if v_b is not None:
            v_b = np.where((valid.sum(axis=1) >= 3)[:, None], v_b, np.nan)
        rows = np.flatnonzero(bad_beam.any(axis=1) | bad_ping)
        rdi = int(rdi_flagged(self.beams[bad_beam]).sum()
                  + (0 if self.v_b is None else rdi_flagged(self.v_b[bad_ping]).sum()))
        warnings.warn(f"{self.source}: {int(bad_beam.sum())} beam value(s) and {int(bad_ping.sum())} ping "
                      f"velocit(ies) are not measurements (NaN, RDI bad-velocity flag -32768/-32.768 "
                      f"[{rdi} seen], or beyond {max_speed:g} m/s) and are marked invalid; first at "
                      f"{located(rows, lines, where, first=True, t=self.t)}, {rows.size} ping(s) affected",
                      RuntimeWarning, stacklevel=2)
        return dataclasses.replace(self, beams=beams, valid=valid, v_b=v_b)

    def take(self, idx) -> "DvlData":
        def pick(a):
            return None if a is None else a[idx]
        return DvlData(self.t[idx], self.beams[idx], self.valid[idx], pick(self.v_b), self.source,
                       pick(self.v_d), pick(self.v_d_valid), pick(self.v_d_sigma))

    @property
    def n_valid(self) -> np.ndarray:
        """Number of valid beams per ping (M,)."""
        return self.valid.sum(axis=1)


@dataclass
class DepthData:
    """Depth samples: t (N,) s; depth (N,) m, positive down: the IMU's depth below the navigation origin's
    height, as a pressure sensor reads it (the tangent frame's ``down`` is larger by the curvature drop
    ``|p_h|^2 / 2R``, :meth:`graphnav.core.earth.EarthModel.depth_of`; 2 cm at 500 m)."""

    t: np.ndarray
    depth: np.ndarray
    source: str = "depth"

    def validate(self) -> None:
        _check_time(self.t, self.source)
        _check_array(self.depth, (), len(self.t), self.source, "depth")

    def take(self, idx) -> "DepthData":
        return DepthData(self.t[idx], self.depth[idx], self.source)


#: The one position convention of every position graphnav reads, estimates, writes and scores (loaders,
#: estimators, trajectory CSV/TUM, ``graphnav evaluate``): NED in metres from an origin at the sea surface
#: above the first geodetic fix, ``origin_lla = (lat0, lon0, 0.0)``, so ``p_n[:, 2]`` is the absolute depth
#: (positive down) and never a depth relative to the start. Without a geodetic fix the horizontal origin is
#: the vehicle's start (simulation, aligner without a fix); the down axis is still the depth. A reference
#: read from a bag or a generic CSV is taken in the frame its file gives.
NED_ORIGIN_CONVENTION = ("NED, m; origin at the sea surface above the first fix (lat0, lon0, alt 0); "
                         "down = absolute depth")


@dataclass
class HeadingData:
    """Heading aiding (an AHRS, a compass, a heading topic): what the replay feeds to
    :meth:`~graphnav.estimators.navigator.Navigator.add_heading` and what the aligner uses in place of
    gyrocompassing.

    Attributes:
        t: (N,) s.
        yaw: (N,) heading of ``C_b_n`` (body FRD to NED), rad, from north, clockwise seen from above.
        sigma: (N,) 1-sigma of ``yaw``, rad (> 0).
        roll: optional (N,) roll of ``C_b_n`` (ZYX Euler angles), rad, where the source gives it.
        pitch: optional (N,) pitch of ``C_b_n``, rad.
    """

    t: np.ndarray
    yaw: np.ndarray
    sigma: np.ndarray
    roll: np.ndarray | None = None
    pitch: np.ndarray | None = None
    source: str = "heading"

    def validate(self) -> None:
        _check_time(self.t, self.source)
        _check_array(self.yaw, (), len(self.t), self.source, "yaw")
        _check_array(self.sigma, (), len(self.t), self.source, "sigma")
        bad = np.flatnonzero(self.sigma <= 0)
        if bad.size:
            raise DataError.at_sample(f"heading sigma must be > 0 rad, got {self.sigma[bad[0]]:g}", self.source,
                                      int(bad[0]), "sigma")
        for name in ("roll", "pitch"):
            a = getattr(self, name)
            if a is not None:
                _check_array(a, (), len(self.t), self.source, name)

    def take(self, idx) -> "HeadingData":
        def pick(a):
            return None if a is None else a[idx]
        return HeadingData(self.t[idx], self.yaw[idx], self.sigma[idx], pick(self.roll), pick(self.pitch),
                           self.source)


#: Largest 1-sigma a horizontal position fix may claim, m: beyond it a fix carries no useful information (a
#: GNSS receiver without a solution reports sigmas of 1e3-1e7 m or its "invalid" marker); larger ones are refused.
MAX_FIX_SIGMA_M = 1e4


@dataclass
class PositionFixData:
    """Horizontal position fixes (GNSS at the surface, USBL): what the replay feeds to
    :meth:`~graphnav.estimators.navigator.Navigator.add_position_fix`.

    Attributes:
        t: (N,) s, on the IMU clock.
        lat: (N,) geodetic latitude of the IMU, rad (WGS84).
        lon: (N,) geodetic longitude of the IMU, rad (WGS84).
        sigma_m: (N,) 1-sigma of the fix per horizontal axis (north and east), m (> 0).
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    sigma_m: np.ndarray
    source: str = "fix"

    def validate(self) -> None:
        _check_time(self.t, self.source)
        for name in ("lat", "lon", "sigma_m"):
            _check_array(getattr(self, name), (), len(self.t), self.source, name)
        bad = np.flatnonzero(np.abs(self.lat) > np.pi / 2)
        if bad.size:
            raise DataError.at_sample(f"latitude {self.lat[bad[0]]:g} rad is beyond +-pi/2 (given in degrees?)",
                                      self.source, int(bad[0]), "lat")
        bad = np.flatnonzero(np.abs(self.lon) > 2 * np.pi)
        if bad.size:
            raise DataError.at_sample(f"longitude {self.lon[bad[0]]:g} rad is beyond +-2 pi (given in degrees?)",
                                      self.source, int(bad[0]), "lon")
        bad = np.flatnonzero(~((self.sigma_m > 0) & (self.sigma_m <= MAX_FIX_SIGMA_M)))
        if bad.size:
            raise DataError.at_sample(f"fix sigma must be in (0, {MAX_FIX_SIGMA_M:g}] m, got {self.sigma_m[bad[0]]:g}",
                                      self.source, int(bad[0]), "sigma_m")

    def take(self, idx) -> "PositionFixData":
        return PositionFixData(self.t[idx], self.lat[idx], self.lon[idx], self.sigma_m[idx], self.source)

    def ne_m(self, origin_lla: tuple[float, float, float]) -> np.ndarray:
        """(N,2) north and east of the fixes in the NED tangent frame at ``origin_lla`` (rad, rad, m), m."""
        from graphnav.core.earth import lla_to_ned
        return lla_to_ned(self.lat, self.lon, np.zeros(len(self.t)), origin_lla)[:, :2]


@dataclass
class GroundTruth:
    """Reference trajectory of the IMU.

    Attributes:
        t: (K,) s.
        p_n: (K,3) NED position relative to ``origin_lla``, m (:data:`NED_ORIGIN_CONVENTION`: down is the
            absolute depth).
        v_n: (K,3) NED velocity, m/s.
        C_b_n: (K,3,3) body-to-NED rotation.
        origin_lla: (lat rad, lon rad, alt m) of the NED origin, or None when unknown (simulation).
    """

    t: np.ndarray
    p_n: np.ndarray
    v_n: np.ndarray
    C_b_n: np.ndarray
    origin_lla: tuple[float, float, float] | None = None
    source: str = "gt"

    def validate(self) -> None:
        _check_time(self.t, self.source)
        n = len(self.t)
        _check_array(self.p_n, (3,), n, self.source, "p_n")
        _check_array(self.v_n, (3,), n, self.source, "v_n")
        _check_array(self.C_b_n, (3, 3), n, self.source, "C_b_n")

    def take(self, idx) -> "GroundTruth":
        return GroundTruth(self.t[idx], self.p_n[idx], self.v_n[idx], self.C_b_n[idx],
                           self.origin_lla, self.source)

    def at(self, t, imu: "ImuData | None" = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The ground truth at stamp(s) ``t`` (s) inside its span: the one interpolator every caller uses.

        Position and velocity are interpolated linearly; the attitude by spherical linear interpolation of
        the rotations (:class:`scipy.spatial.transform.Slerp`: constant body rate between two samples), so
        at a sample stamp all three are that sample exactly, and between samples the rotation lies on the
        geodesic (never a renormalised matrix blend, never the nearest sample).

        With ``imu`` (same clock) the attitude between two samples follows the gyro: each bracketing
        sample is carried to ``t`` by the integrated body rate (zero-order hold, right perturbation) and the
        two results are slerped with the same weight, so it is still exact at the samples and equals the
        plain slerp for a constant body rate. Use it for a *state* at a sub-sample time (the estimators'
        initial state): a 1 Hz ground truth in a fast manoeuvre rolls and pitches within the second, and
        the plain slerp is then 1.5-3 deg off in roll (A-KIT Trajectory5 at 150 s, 6 at 1 s, 11 at 340 s;
        measured against the gyro-carried attitude), which an initial covariance of 0.05-0.1 deg does not
        cover. It costs a loop over the IMU samples of one GT interval per stamp: meant for a few stamps.

        Returns:
            (p_n m, v_n m/s, C_b_n): (3,), (3,), (3,3) for a scalar ``t``; (K,3), (K,3), (K,3,3) for (K,).

        Raises:
            DataError: a stamp lies outside the ground-truth span (no extrapolation).
        """
        from scipy.spatial.transform import Rotation, Slerp

        from graphnav.core.timeseries import interp_rows
        scalar = np.ndim(t) == 0
        t = np.atleast_1d(np.asarray(t, dtype=float))
        outside = np.flatnonzero(~((t >= self.t[0]) & (t <= self.t[-1])))
        if outside.size:
            # about the stamp asked for, not a sample of the reference: no line of its file to name
            raise DataError(f"stamp {t[outside[0]]:.3f} s outside the ground truth span "
                            f"[{self.t[0]:.3f}, {self.t[-1]:.3f}] s", self.source)
        if len(self.t) == 1:
            p, v = np.repeat(self.p_n, len(t), axis=0), np.repeat(self.v_n, len(t), axis=0)
            C = np.repeat(self.C_b_n, len(t), axis=0)
        else:
            p, v = interp_rows(t, self.t, self.p_n), interp_rows(t, self.t, self.v_n)
            C = Slerp(self.t, Rotation.from_matrix(self.C_b_n))(t).as_matrix()
            if imu is not None:
                C = np.array([self._gyro_carried(tk, imu) for tk in t])
            # Slerp round-trips a sample through a quaternion; return the stored matrix there (exact)
            i = np.searchsorted(self.t, t)
            hit = (i < len(self.t)) & (self.t[np.minimum(i, len(self.t) - 1)] == t)
            C[hit] = self.C_b_n[i[hit]]
        return (p[0], v[0], C[0]) if scalar else (p, v, C)

    def _gyro_carried(self, t: float, imu: "ImuData") -> np.ndarray:
        """Attitude at t (inside the span) from the two bracketing samples carried by the gyro (see :meth:`at`)."""
        from scipy.spatial.transform import Rotation, Slerp
        i = int(np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.t) - 2))
        t0, t1 = self.t[i], self.t[i + 1]

        def body_rotation(a: float, b: float) -> Rotation:
            """Integrated body rotation from a to b (a <= b), zero-order hold on the IMU samples."""
            edges = np.concatenate([[a], imu.t[(imu.t > a) & (imu.t < b)], [b]])
            j = np.clip(np.searchsorted(imu.t, edges[:-1], side="right") - 1, 0, len(imu.t) - 1)
            steps = Rotation.from_rotvec(imu.omega_b[j] * np.diff(edges)[:, None])
            out = Rotation.identity()
            for step in steps:
                out = out * step
            return out
        if t <= t0:
            return self.C_b_n[i]
        if t >= t1:
            return self.C_b_n[i + 1]
        period = float(np.median(np.diff(imu.t))) if len(imu.t) > 1 else np.inf
        # a side is carried only where the IMU covers it (a sliced mission's IMU may start after t0)
        left_ok = len(imu.t) > 0 and imu.t[0] <= t0 + 1e-9 and imu.t[-1] >= t - period
        right_ok = len(imu.t) > 0 and imu.t[0] <= t + 1e-9 and imu.t[-1] >= t1 - period
        left = Rotation.from_matrix(self.C_b_n[i]) * body_rotation(t0, t) if left_ok else None
        right = Rotation.from_matrix(self.C_b_n[i + 1]) * body_rotation(t, t1).inv() if right_ok else None
        if left is None or right is None:
            only = left or right
            if only is None:          # no IMU over the interval: the plain slerp
                return Slerp([t0, t1], Rotation.from_matrix(self.C_b_n[i:i + 2]))([t])[0].as_matrix()
            return only.as_matrix()
        u = (t - t0) / (t1 - t0)
        delta = (left.inv() * right).as_rotvec()
        return (left * Rotation.from_rotvec(u * delta)).as_matrix()

    @property
    def v_b(self) -> np.ndarray:
        """Body-frame velocity (K,3), m/s."""
        return np.einsum("kji,kj->ki", self.C_b_n, self.v_n)

    @property
    def lla(self) -> np.ndarray | None:
        """(K,3) [lat rad, lon rad, alt m] when the origin is known."""
        if self.origin_lla is None:
            return None
        from graphnav.core.earth import ned_to_lla
        return ned_to_lla(self.p_n, self.origin_lla)


#: DVL pings closer than this (s) to the IMU span are dropped without a warning (see Mission.validate).
OUTSIDE_SPAN_TOLERANCE_S = 0.5


@dataclass
class Mission:
    """One mission: IMU, DVL, optional depth, heading aiding, position fixes and ground truth, and the sensor
    configuration.

    All stamps share the IMU clock. ``validate()`` is called on construction.
    """

    name: str
    imu: ImuData
    dvl: DvlData
    config: SensorConfig = field(default_factory=SensorConfig)
    gt: GroundTruth | None = None
    depth: DepthData | None = None
    meta: dict = field(default_factory=dict)
    heading: HeadingData | None = None
    fixes: PositionFixData | None = None

    def __post_init__(self):
        # what a configuration leaves to the data (None) is, in a mission, what has been applied: nothing yet
        self.config = self.config.as_applied()
        self.validate()

    def validate(self) -> None:
        """Check every stream; raise :class:`DataError` naming stream, index and field."""
        for stream in (self.imu, self.dvl, self.gt, self.depth, self.heading, self.fixes):
            if stream is not None:
                stream.validate()
        # DVL pings outside the IMU span cannot be used. A ping within OUTSIDE_SPAN_TOLERANCE_S of the span
        # is the usual effect of a time offset at the ends of a recording (A-KIT: the last ping, 0.02-0.06 s
        # after the last IMU sample) and is dropped quietly; anything further out is reported.
        imu_t, dvl_t = self.imu.t, self.dvl.t
        t0, t1 = (imu_t[0], imu_t[-1]) if len(imu_t) else (np.inf, -np.inf)   # no IMU: every ping is outside
        outside = np.flatnonzero((dvl_t < t0) | (dvl_t > t1))
        far = np.any((dvl_t < t0 - OUTSIDE_SPAN_TOLERANCE_S) | (dvl_t > t1 + OUTSIDE_SPAN_TOLERANCE_S))
        if outside.size and far and self.meta.get("prepared", True):    # prepare may move the DVL clock
            span = f"[{t0:.3f}, {t1:.3f}]" if len(imu_t) else "[nan, nan]"
            warnings.warn(f"{self.dvl.source}: {outside.size} DVL ping(s) outside the IMU span {span} s (first at "
                          f"index {int(outside[0])}, t = {dvl_t[outside[0]]:.3f} s) cannot be used and are "
                          "ignored by the estimators", RuntimeWarning, stacklevel=2)

    @property
    def t0(self) -> float:
        return float(self.imu.t[0])

    @property
    def t1(self) -> float:
        return float(self.imu.t[-1])

    @property
    def duration(self) -> float:
        return self.t1 - self.t0

    def slice(self, t_start: float, t_end: float) -> "Mission":
        """The part of the mission with ``t_start <= t <= t_end`` (s) in every stream.

        The ground truth keeps, besides its samples inside, the sample on either side of the span (when
        there is one), so that :meth:`GroundTruth.at` can interpolate it at every stamp of the slice (a
        1 Hz ground truth would otherwise start up to 1 s after the first IMU sample or DVL ping).
        """
        def sel(t):
            return (t >= t_start) & (t <= t_end)

        def bracket(t):
            i0 = max(int(np.searchsorted(t, t_start, side="right")) - 1, 0)
            i1 = min(int(np.searchsorted(t, t_end, side="left")), len(t) - 1)
            keep = np.zeros(len(t), dtype=bool)
            keep[i0:i1 + 1] = True
            return keep
        return dataclasses.replace(
            self,
            imu=self.imu.take(sel(self.imu.t)),
            dvl=self.dvl.take(sel(self.dvl.t)),
            gt=None if self.gt is None else self.gt.take(bracket(self.gt.t)),
            depth=None if self.depth is None else self.depth.take(sel(self.depth.t)),
            heading=None if self.heading is None else self.heading.take(sel(self.heading.t)),
            fixes=None if self.fixes is None else self.fixes.take(sel(self.fixes.t)),
            meta={**self.meta, "slice": (t_start, t_end)},
        )

    def with_outage(self, *outages) -> "Mission":
        """A copy with the given :class:`~graphnav.core.scenarios.Outage` windows applied to the DVL valid mask."""
        valid = self.dvl.valid.copy()
        for outage in outages:
            valid &= ~outage.mask(self.dvl.t)
        dvl = dataclasses.replace(self.dvl, valid=valid)
        return dataclasses.replace(self, dvl=dvl,
                                   meta={**self.meta, "outages": [*self.meta.get("outages", []), *outages]})

    def with_dvl_valid(self, valid: np.ndarray) -> "Mission":
        """A copy with the DVL valid mask replaced (e.g. by a random dropout pattern)."""
        return dataclasses.replace(self, dvl=dataclasses.replace(self.dvl, valid=np.asarray(valid, bool)))
