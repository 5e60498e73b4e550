"""Units from the data: stamps in s/ms/us/ns, gyro in deg/s, accelerometer in g, swapped IMU blocks, DVL in mm/s.

Every loader calls :func:`check_units` on its streams before anything integrates them (the axis detection,
the time-offset estimates, gap bridging). Each check looks at the whole stream, decides from physics, and
then either converts (a ``RuntimeWarning`` and a note in ``meta["streams"][stream]["notes"]``) or refuses
with a :class:`~graphnav.core.errors.DataError` naming the source and field. A unit a user *declared* (the
generic CSV loader's ``*_unit`` keys) is converted by the loader; the check then only confirms it and
refuses when the data contradict it.

The thresholds and why (measured on the ten shared A-KIT trajectories: median |f| 9.796-9.799 m/s^2, 1st
percentile 8.84, 99th 10.75; median |omega| 0.0073-0.045 rad/s, maximum 0.62 rad/s; median DVL speed
1.6-2.1 m/s, maximum 2.8 m/s; none of them is converted by any check, ``tests/test_units.py``):

* **Stamps.** The median sample step must be a plausible period for the stream
  (:data:`PLAUSIBLE_PERIOD_S`: an IMU runs at 2 Hz..5 kHz, a DVL pings at 1/60..100 Hz, a depth sensor at
  1/60 Hz..1 kHz). Seconds are kept when plausible; otherwise the one of ms/us/ns that makes the step
  plausible is taken (closest to the configured rate when two are). Then a stream spanning more than
  :data:`MAX_SPAN_S` (a year: no AUV log is that long; the usual cause is one corrupt stamp such as
  1e300) is refused, naming the largest jump, before any loop over the samples runs.
* **Accelerometer.** An IMU on a vehicle in water sees gravity: median |f| is 9.8 +- 30 % (vehicle
  accelerations are a few percent of g). 0.7-1.3 is g, 700-1300 milli-g; anything else is refused.
* **Swapped blocks.** Median |f| below 2 with median |omega| of 7-13: the gyro columns hold gravity.
* **Gyro.** In rad/s an AUV's median |omega| is hundredths (max 0.045 above) and it never turns at 3 rad/s
  (170 deg/s); in deg/s the same motion reads 57.3x larger. Refused as rad/s and taken as deg/s when the
  median exceeds :data:`GYRO_MEDIAN_MAX_RADPS` (0.3 rad/s: 7x the largest median seen, 17 deg/s of sustained
  rotation) or the 99.9th percentile exceeds :data:`GYRO_MAX_RADPS` (3 rad/s). A quiet vehicle logging
  deg/s may stay under both; the tilt kinematics then decide when there is tilt motion to see
  (:func:`gyro_tilt_scale`: the gravity direction the accelerometer sees turns at the gyro rate; the fitted
  scale is 0.36-0.64 on the ten trajectories in rad/s and 0.006-0.011 in deg/s, at most 0.015 in any 60 s
  window; :data:`GYRO_TILT_SCALE_DEG` = 0.1 lies between, a factor 3.6 and 6.7 from either side).
* **DVL.** A DVL measures at most +-10 m/s (:data:`~graphnav.core.mission.MAX_DVL_SPEED_MPS`); a median
  speed of 500-10000 is mm/s (RDI's raw unit: an AUV at 0.5-10 m/s). 10-500 is cm/s of a vehicle at
  0.1-5 m/s as much as mm/s of one at 0.01-0.5 m/s: refused, declare ``velocity_unit`` (a wrong guess would
  scale every velocity by 10).
"""
from __future__ import annotations

import dataclasses
import warnings
from typing import Mapping

import numpy as np

from graphnav.core.errors import DataError
from graphnav.core.mission import MAX_DVL_SPEED_MPS, RDI_BAD_VELOCITY, DvlData, Mission
from graphnav.core.streams import add_note

STANDARD_GRAVITY = 9.80665
TIME_SCALES = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: Plausible median sample period per stream, s (see the module docstring).
PLAUSIBLE_PERIOD_S = {"imu": (2e-4, 0.5), "dvl": (0.01, 60.0), "depth": (1e-3, 60.0), "gt": (1e-3, 60.0)}
#: Longest span one stream may have, s (a year).
MAX_SPAN_S = 366 * 86400.0
#: Median |f| windows, m/s^2 after scaling: (low, high) around gravity.
ACCEL_GRAVITY_RANGE = (7.0, 13.0)
ACCEL_SCALES = {"m/s^2": 1.0, "g": STANDARD_GRAVITY, "mg": STANDARD_GRAVITY * 1e-3}
#: Units a user may declare (a CSV column map's ``*_unit``, a stream's ``units`` record), with their factor to SI.
DECLARED_UNITS = {"time": TIME_SCALES, "accel": {"m/s^2": 1.0, "g": STANDARD_GRAVITY},
                  "gyro": {"rad/s": 1.0, "deg/s": np.pi / 180}, "velocity": {"m/s": 1.0, "cm/s": 1e-2, "mm/s": 1e-3}}
#: Median |f| below this, with median |omega| inside ACCEL_GRAVITY_RANGE: the two blocks are swapped.
SWAP_ACCEL_MAX = 2.0
GYRO_MEDIAN_MAX_RADPS = 0.3
GYRO_MAX_RADPS = 3.0
#: Tilt-kinematics gyro scale below this is deg/s (1/57.3 = 0.017 expected; 1 for rad/s).
GYRO_TILT_SCALE_DEG = 0.1
#: Median DVL speed (per-ping norm of the instrument velocity, or the largest |beam|) taken as mm/s.
DVL_MMPS_RANGE = (500.0, 10000.0)


def _note(meta: dict | None, stream: str, text: str, source: str) -> None:
    warnings.warn(f"{source}: {text}", RuntimeWarning, stacklevel=3)
    if meta is not None:
        add_note(meta, stream, text)


# ------------------------------------------------------------------------------------------------
# stamps
# ------------------------------------------------------------------------------------------------
def time_scale(t: np.ndarray, stream: str, source: str, expected_rate_hz: float | None = None,
               field: str = "t", declared: str | None = None) -> tuple[float, str]:
    """The factor that puts stamps ``t`` (as read) in seconds, and its unit name.

    Raises:
        DataError: no unit makes the sample step plausible, or the stream spans more than
            :data:`MAX_SPAN_S` (naming the index of the largest jump).
    """
    t = np.asarray(t, float)
    if t.size < 2:
        return 1.0, "s"
    step = np.diff(t)
    med = float(np.median(step))
    lo, hi = PLAUSIBLE_PERIOD_S.get(stream, (1e-4, 60.0))
    if declared is not None:
        if declared not in TIME_SCALES:
            from graphnav.core.errors import ConfigError
            raise ConfigError(f"{source}: time unit {declared!r}: choose one of {sorted(TIME_SCALES)}")
        unit = declared
    elif lo <= med <= hi or med <= 0:
        unit = "s"       # a non-positive median step is an ordering problem, reported by the stamp checks
    else:
        fits = [u for u, k in TIME_SCALES.items() if lo <= med * k <= hi]
        if not fits:
            raise DataError(f"median stamp step {med:g} is not a plausible {stream} sample period in s, ms, us "
                            f"or ns ({lo:g}-{hi:g} s); declare the time unit", source, field=field)
        if expected_rate_hz and len(fits) > 1:
            fits.sort(key=lambda u: abs(np.log10(med * TIME_SCALES[u] * expected_rate_hz)))
        unit = fits[0]
    scale = TIME_SCALES[unit]
    finite = t[np.isfinite(t)]          # non-finite stamps are the stamp checks' to report, by line
    span = float(np.ptp(finite) * scale) if finite.size else 0.0
    if not np.isfinite(span) or span > MAX_SPAN_S:
        with np.errstate(invalid="ignore"):
            i = int(np.nanargmax(np.abs(step))) + 1 if np.any(np.isfinite(step)) else 0
        raise DataError(f"stamps span {span:.3g} s (more than a year: a corrupt stamp?); largest jump "
                        f"{t[i - 1]:.6g} -> {t[i]:.6g} ({unit}) at index {i}", source, i, field)
    return scale, unit


# ------------------------------------------------------------------------------------------------
# IMU
# ------------------------------------------------------------------------------------------------
def gyro_tilt_scale(t: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray) -> tuple[float, float]:
    """Scale k with which the gravity direction seen by the accelerometer turns at the gyro's rate:
    ``|du/dt| = k |u x omega|`` over 1 s means (norms: indifferent to axis signs and order). Returns
    ``(k, tilt_rate)``: k is ~1 for a gyro in rad/s and ~1/57.3 in deg/s; ``tilt_rate`` (rad/s, median of
    |du/dt| over the seconds used) says how much tilt motion there was to see; NaN when too little data."""
    t = np.asarray(t, float)
    if t.size < 3 or t[-1] - t[0] < 10.0:
        return float("nan"), 0.0
    from graphnav.core.timeseries import cumulative_integral, interp_rows
    t = np.ascontiguousarray(t)
    edges = np.arange(t[0], t[-1], 1.0)
    f = np.diff(interp_rows(edges, t, np.asfortranarray(cumulative_integral(t, f_b))), axis=0)
    w = np.diff(interp_rows(edges, t, np.asfortranarray(cumulative_integral(t, omega_b))), axis=0)
    u = -f / np.maximum(np.linalg.norm(f, axis=1, keepdims=True), 1e-12)
    du = np.linalg.norm((u[2:] - u[:-2]) / 2.0, axis=1)
    p = np.linalg.norm(np.cross(u[1:-1], w[1:-1]), axis=1)
    # the seconds with the most gyro tilt rate carry the signal; the rest is accelerometer noise
    use = p >= np.quantile(p, 0.75) if p.size >= 8 else np.ones(p.size, bool)
    if not np.any(p[use] > 0):
        return float("nan"), 0.0
    k = float(np.sum(du[use] * p[use]) / np.sum(p[use] ** 2))
    return k, float(np.median(du[use]))


def imu_units(t: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray, source: str, meta: dict | None = None,
              declared: Mapping[str, str] | None = None, gravity: float = STANDARD_GRAVITY
              ) -> tuple[np.ndarray, np.ndarray]:
    """``(f_b m/s^2, omega_b rad/s)`` with swapped blocks, g/milli-g and deg/s detected and converted (with
    a warning and a note), or DataError naming the field. ``t`` in seconds. ``declared``: units the caller
    already applied (``{"accel": "g", "gyro": "deg/s"}``): the data must then agree."""
    declared = dict(declared or {})
    f_b, omega_b = np.asarray(f_b, float), np.asarray(omega_b, float)
    if f_b.size == 0:
        return f_b, omega_b
    f_med = float(np.nanmedian(np.linalg.norm(f_b, axis=1)))
    w_med = float(np.nanmedian(np.linalg.norm(omega_b, axis=1)))
    lo, hi = ACCEL_GRAVITY_RANGE
    if f_med < SWAP_ACCEL_MAX and lo <= w_med <= hi:
        if declared:
            raise DataError(f"median |f_b| {f_med:.3g} and median |omega_b| {w_med:.3g}: the gyro columns hold "
                            "gravity; the accelerometer and gyro columns are swapped", source, field="f_b")
        f_b, omega_b = omega_b, f_b
        _note(meta, "imu", f"accelerometer and gyro columns swapped back (median |f| {f_med:.3g} m/s^2 but "
              f"median |omega| {w_med:.3g}: gravity is in the gyro columns)", source)
        f_med, w_med = w_med, f_med
    fits = [u for u, k in ACCEL_SCALES.items() if lo <= f_med * k <= hi]
    if not fits:
        raise DataError(f"median |f_b| = {f_med:.4g}: not gravity in m/s^2 (9.8), g (1) or milli-g (1000); "
                        "an IMU in water always sees gravity", source, field="f_b")
    unit = fits[0]
    if unit != "m/s^2":
        if "accel" in declared:
            raise DataError(f"median |f_b| = {f_med:.4g} m/s^2 after the declared unit "
                            f"{declared['accel']!r}: the data look like {unit}", source, field="f_b")
        f_b = f_b * (gravity if unit == "g" else gravity * 1e-3)
        _note(meta, "imu", f"accelerometer read as {unit} (median |f| {f_med:.4g}) and converted to m/s^2", source)
    omega_b, _ = _gyro_units(t, f_b, omega_b, source, meta, declared)
    return f_b, omega_b


def _gyro_units(t, f_b, omega_b, source, meta, declared) -> tuple[np.ndarray, str]:
    norm = np.linalg.norm(omega_b, axis=1)
    med = float(np.nanmedian(norm))
    top = float(np.nanquantile(norm, 0.999))
    why = None
    if med > GYRO_MEDIAN_MAX_RADPS:
        why = f"median |omega| {med:.3g} rad/s (> {GYRO_MEDIAN_MAX_RADPS:g}: no AUV turns like that all along)"
    elif top > GYRO_MAX_RADPS:
        why = f"99.9th percentile |omega| {top:.3g} rad/s (> {GYRO_MAX_RADPS:g}: beyond what an AUV turns)"
    else:
        k, tilt = gyro_tilt_scale(t, f_b, omega_b)
        if np.isfinite(k) and k < GYRO_TILT_SCALE_DEG and tilt > 1e-3:
            why = (f"the gravity direction turns {1 / k:.3g}x slower than these rates say (57.3 for deg/s; "
                   "tilt kinematics)")
    if why is None:
        return omega_b, "rad/s"
    if "gyro" in declared:
        raise DataError(f"gyro after the declared unit {declared['gyro']!r}: {why}", source, field="omega_b")
    if med * np.pi / 180 > GYRO_MEDIAN_MAX_RADPS or top * np.pi / 180 > 10 * GYRO_MAX_RADPS:
        raise DataError(f"gyro rates implausible in rad/s and in deg/s ({why}; median {med:.3g}, "
                        f"99.9th percentile {top:.3g})", source, field="omega_b")
    _note(meta, "imu", f"gyro read as deg/s and converted to rad/s: {why}", source)
    return omega_b * (np.pi / 180), "deg/s"


# ------------------------------------------------------------------------------------------------
# DVL
# ------------------------------------------------------------------------------------------------
def dvl_speed_scale(beams: np.ndarray | None, velocity: np.ndarray | None, source: str,
                    field: str = "beams") -> tuple[float, float]:
    """``(scale to m/s, median speed as read)`` of DVL values (beams (M,4) and/or a velocity (M,3)), from
    the median speed; RDI's bad-velocity flags and non-finite values are left out. DataError when the
    speeds are neither m/s nor mm/s."""
    def clean(a):
        a = np.asarray(a, float)
        return np.where(np.isfinite(a) & ~np.isin(a, RDI_BAD_VELOCITY), a, np.nan)
    if velocity is not None and np.any(np.isfinite(clean(velocity))):
        speed, field = np.linalg.norm(clean(velocity), axis=1), "v_b/v_d"
    elif beams is not None and np.any(np.isfinite(clean(beams))):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            speed = np.nanmax(np.abs(clean(beams)), axis=1)
    else:
        return 1.0, float("nan")
    med = float(np.nanmedian(speed))
    if med <= MAX_DVL_SPEED_MPS:
        return 1.0, med
    if DVL_MMPS_RANGE[0] <= med <= DVL_MMPS_RANGE[1]:
        return 1e-3, med
    if med < DVL_MMPS_RANGE[0]:
        raise DataError(f"median DVL speed {med:.4g} is beyond the {MAX_DVL_SPEED_MPS:g} m/s a DVL measures: "
                        f"cm/s ({med / 100:.3g} m/s) or mm/s ({med / 1000:.3g} m/s)? declare the velocity unit",
                        source, field=field)
    raise DataError(f"median DVL speed {med:.4g} is beyond the {MAX_DVL_SPEED_MPS:g} m/s a DVL measures and "
                    f"not mm/s of a moving vehicle ({DVL_MMPS_RANGE[0]:g}-{DVL_MMPS_RANGE[1]:g}); declare the "
                    "velocity unit (e.g. cm/s)", source, field=field)


def dvl_velocity_units(values: np.ndarray, source: str, meta: dict | None = None, declared: str | None = None,
                       beams: bool = False) -> np.ndarray:
    """DVL values as read (beams (M,4) when ``beams``, else a velocity (M,3)) in m/s: mm/s detected and
    converted (warning, note), or DataError. RDI's raw flag -32768 becomes its m/s flag -32.768."""
    scale, med = dvl_speed_scale(values if beams else None, None if beams else values, source)
    if scale == 1.0:
        return values
    if declared is not None:
        raise DataError(f"median DVL speed {med:.4g} m/s after the declared unit {declared!r}: the data look "
                        "like mm/s", source, field="beams" if beams else "v_b")
    _note(meta, "dvl", f"DVL velocities read as mm/s (median speed {med:.4g}) and converted to m/s", source)
    return np.asarray(values, float) * scale


def dvl_units(dvl: DvlData, meta: dict | None = None, declared: str | None = None) -> DvlData:
    """The DVL with its velocities in m/s (mm/s detected and converted, with a warning and a note)."""
    velocity = dvl.v_b if dvl.v_b is not None else dvl.v_d
    scale, med = dvl_speed_scale(dvl.beams, velocity, dvl.source)
    if scale == 1.0:
        return dvl
    if declared is not None:
        raise DataError(f"median DVL speed {med:.4g} m/s after the declared unit {declared!r}: the data look "
                        "like mm/s", dvl.source, field="beams")
    _note(meta, "dvl", f"DVL velocities read as mm/s (median speed {med:.4g}) and converted to m/s",
          dvl.source)

    def conv(a):
        # RDI's raw flag -32768 becomes -32.768, its m/s flag: still recognised as invalid
        return None if a is None else np.asarray(a, float) * scale
    return dataclasses.replace(dvl, beams=conv(dvl.beams), v_b=conv(dvl.v_b), v_d=conv(dvl.v_d),
                               v_d_sigma=conv(dvl.v_d_sigma))


# ------------------------------------------------------------------------------------------------
# the entry point
# ------------------------------------------------------------------------------------------------
def stamps_in_seconds(t: np.ndarray, stream: str, source: str, meta: dict | None = None,
                      expected_rate_hz: float | None = None, declared: str | None = None,
                      field: str = "t") -> np.ndarray:
    """Stamps ``t`` in seconds: the unit detected by :func:`time_scale` applied (warning and note when not
    s), or DataError."""
    scale, unit = time_scale(t, stream, source, expected_rate_hz, field=field, declared=declared)
    if scale == 1.0:
        return t
    if declared is None:
        _note(meta, stream, f"stamps read as {unit} (median step {np.median(np.diff(t)):.4g}, implausible as "
              "seconds for this stream) and converted to s", source)
    return np.asarray(t, float) * scale


def _stamps(stream, name: str, meta, config, declared_time: str | None):
    if stream is None:
        return stream
    rate = None
    if config is not None:
        rate = config.imu_rate_hz if name == "imu" else config.dvl.rate_hz if name == "dvl" else None
    t = stamps_in_seconds(stream.t, name, stream.source, meta, rate, declared_time)
    return stream if t is stream.t else dataclasses.replace(stream, t=t)


def check_units(streams, config=None, meta: dict | None = None, declared: Mapping[str, str] | None = None):
    """Detect and convert the units of every stream; the one entry point the loaders call.

    Args:
        streams: a :class:`~graphnav.core.mission.Mission`, or a dict with any of ``imu``
            (:class:`ImuData`), ``dvl`` (:class:`DvlData`, before ``sanitized()``: mm/s values would be
            marked invalid), ``depth`` (:class:`DepthData`), ``gt``; None values are passed through.
        config: a :class:`~graphnav.core.config.SensorConfig` (rates to tell stamp units apart, gravity), or None.
        meta: where the conversions are noted (``meta["streams"]``); a Mission's own meta when None.
        declared: units the caller already applied and that must not be re-detected: ``time``
            (s/ms/us/ns), ``accel``, ``gyro``, ``velocity``.

    Returns:
        The same kind (a Mission copy, or a dict) with converted streams.

    Raises:
        DataError: a stream in no plausible unit, naming its source and field.
    """
    declared = dict(declared or {})
    is_mission = isinstance(streams, Mission)
    if is_mission:
        meta = streams.meta if meta is None else meta
        config = streams.config if config is None else config
        out = {"imu": streams.imu, "dvl": streams.dvl, "depth": streams.depth, "gt": streams.gt}
    else:
        out = dict(streams)
    for name in ("imu", "dvl", "depth", "gt"):
        if out.get(name) is not None:
            out[name] = _stamps(out[name], name, meta, config, declared.get("time"))
    imu = out.get("imu")
    if imu is not None:
        gravity = getattr(config, "gravity_mps2", STANDARD_GRAVITY) if config is not None else STANDARD_GRAVITY
        f_b, omega_b = imu_units(imu.t, imu.f_b, imu.omega_b, imu.source, meta,
                                 {k: v for k, v in declared.items() if k in ("accel", "gyro")}, gravity)
        if f_b is not imu.f_b or omega_b is not imu.omega_b:
            out["imu"] = dataclasses.replace(imu, f_b=f_b, omega_b=omega_b)
    if out.get("dvl") is not None:
        out["dvl"] = dvl_units(out["dvl"], meta, declared.get("velocity"))
    if is_mission:
        return dataclasses.replace(streams, imu=out["imu"], dvl=out["dvl"], depth=out["depth"], gt=out["gt"],
                                   meta=meta)
    return out


__all__ = ["check_units", "stamps_in_seconds", "imu_units", "dvl_units", "dvl_velocity_units", "time_scale",
           "gyro_tilt_scale", "dvl_speed_scale"]
