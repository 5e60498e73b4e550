"""Units from the data: stamps in s/ms/us/ns, gyro in deg/s, accelerometer in g, swapped IMU blocks, DVL in mm/s,
a reference's angles in degrees and its depth with the sign flipped.

Every loader calls :func:`check_units` on its streams before anything integrates them (the axis detection,
the time-offset estimates, gap bridging). Each check looks at the whole stream, decides from physics, and
then either converts (a ``RuntimeWarning`` and a note in ``meta["streams"][stream]["notes"]``) or refuses
with a :class:`~graphnav.core.errors.DataError` naming the source and field. A unit a user *declared* (the
generic CSV loader's ``*_unit`` keys) is converted by the loader; the check then only confirms it and
refuses when the data contradict it.

The thresholds and why (measured on the ten shared A-KIT trajectories: median |f| 9.796-9.799 m/s^2, 1st
percentile 8.84, 99th 10.75; median |omega| 0.0073-0.045 rad/s, maximum 0.62 rad/s; median DVL speed
1.6-2.1 m/s, maximum 2.8 m/s; none of them is converted by any check, ``tests/test_units.py``):

* **Stamps.** The median sample step (an IMU's period from
  :func:`~graphnav.core.imu_timing.imu_step_stats`: samples over time for stamps in packets) must be a plausible
  period for the stream
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
  window; :data:`GYRO_TILT_SCALE_DEG` = 3/57.3 = 0.052 lies between, a factor 3.5 and 3.2 from either side; judged
  only when the tilt rate correlates with the gyro's, :data:`GYRO_TILT_MIN_CORRELATION`: a hovering AUV's
  thrusters turn its accelerometer, not its rotation; a declared rad/s is then kept with a warning). The same
  scale refuses rates 57.3x too small (rad/s data declared deg/s, or converted to rad/s twice: 9.6-48 on the
  ten's 60 s windows, against at most 0.84 in rad/s; :data:`GYRO_TILT_SCALE_SMALL` = 3), declared or not: no
  gyro unit is 57.3x larger than rad/s, so there is no conversion to make.
* **DVL.** A DVL measures at most +-10 m/s (:data:`~graphnav.core.mission.MAX_DVL_SPEED_MPS`); a median
  speed of 500-10000 is mm/s (RDI's raw unit: an AUV at 0.5-10 m/s). 10-500 is cm/s of a vehicle at
  0.1-5 m/s as much as mm/s of one at 0.01-0.5 m/s: refused, declare ``velocity_unit`` (a wrong guess would
  scale every velocity by 10).
* **Reference (ground truth).** The A-KIT GT file and a column map's ``gt`` entry (:func:`reference_attitude_units`,
  :func:`reference_latlon_units`, :func:`reference_depth`, :func:`check_reference_displacement`). Angles in degrees
  are certain beyond the radian range (a roll beyond pi, a pitch beyond pi/2, a latitude beyond pi/2, a longitude
  beyond 2 pi; a yaw beyond 2 pi alone is an unwrapped one unless, read as degrees, it turns with the gyro) and,
  inside it, told by rates:
  the attitude's turn rate over the gyro's (:func:`attitude_rate_ratio`) and the positions' displacement over the
  reference's own velocity's (:func:`displacement_ratio`) are 0.95-1.03 and 0.975-1.007 on the ten, 23-56 and
  28-57 with the same files in degrees; :data:`DEG_RATE_RATIO` (7.6, the geometric middle of 1 and 57.3) splits
  them (an attitude only when, converted, it turns with the gyro: a noisy one in radians also turns fast; a declared
  unit is refused when the other one fits, else kept with a warning). Converted like the gyro's deg/s (a warning
  naming the file and columns, a note); positions that follow the velocity in neither unit (outside
  :data:`SAME_UNITS_RATIO` over 10, 40 and 160 s windows: a noisy fix shrinks against the longer ones' distance) are
  refused. An A-KIT depth (-altitude) mostly outside ``depth_range_m`` is flipped back when it changes against the
  GT's down velocity (:func:`vertical_sign`, the depth sensor's fit :func:`depth_rate_fit`: correlation 0.95-1.00
  on the ten), else refused
  naming the first line and the column (a level vehicle's flipped sign cannot be told from a height above the
  ellipsoid); a depth that changes against its down velocity inside the range is refused naming both columns (which
  is wrong cannot be told, unless the attitude's pitch tells: :func:`_pitch_says`). North/east velocity or positions
  exchanged or negated keep the displacement's norm: :func:`check_reference_axes` refuses them, naming the pair its
  heading says is wrong. :func:`reference_inconsistencies` says what in a reference disagrees with itself or the
  gyro (the prepare step's DVL-against-GT refusal then names the GT file instead of the DVL's).
"""
from __future__ import annotations

import dataclasses
import warnings
from typing import Mapping

import numpy as np

from graphnav.core.errors import ConfigError, DataError
from graphnav.core.mission import MAX_DVL_SPEED_MPS, DvlData, Mission, rdi_flagged
from graphnav.core.streams import add_note, count_doubted
from graphnav.core.timeseries import interp_rows

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
                  "gyro": {"rad/s": 1.0, "deg/s": np.pi / 180}, "velocity": {"m/s": 1.0, "cm/s": 1e-2, "mm/s": 1e-3,
                                                                        "kn": 1852.0 / 3600.0}}
#: The two declared velocity units a DVL velocity is mixed up between, 1.94x apart: each is tried for the other
#: (:func:`other_unit_factors`).
KNOTS_MIX_UP = {"m/s", "kn"}


def other_unit_factors(unit: str) -> dict[str, float]:
    """The velocity units a DVL velocity declared ``unit`` may be in instead -> the factor that multiplies the velocity
    as read (unitless): a metric unit at least 10x larger or smaller, knots for m/s and m/s for knots
    (:data:`KNOTS_MIX_UP`)."""
    units = DECLARED_UNITS["velocity"]
    factors = {u: units[u] / units[unit] for u in units}
    return {u: k for u, k in factors.items() if k >= 10 or k <= 0.1 or {u, unit} == KNOTS_MIX_UP}


#: Units of a column map's attitude columns (a reference's, an earth-frame DVL's ``angle_unit``), to rad.
ANGLE_UNITS = {"rad": 1.0, "deg": np.pi / 180}


def declared_scale(spec: dict, key: str, table: dict, default: str, section: str) -> float:
    """The factor to SI of the unit ``spec[key]`` names in ``table`` (``default`` when not given); a ConfigError
    naming the configuration key ``section.key`` (``csv_columns.imu``, ``bag_topics.dvl``) for a unit not there."""
    name = spec.get(key, default)
    if name not in table:
        raise ConfigError(f"{section}.{key} = {name!r}: choose one of {sorted(table)}")
    return table[name]
#: Median |f| below this, with median |omega| inside ACCEL_GRAVITY_RANGE: the two blocks are swapped.
SWAP_ACCEL_MAX = 2.0
GYRO_MEDIAN_MAX_RADPS = 0.3
GYRO_MAX_RADPS = 3.0
#: Tilt-kinematics gyro scale above this is rates too small for rad/s, refused: rad/s data declared deg/s (or
#: converted from deg/s twice) give 57.3x the rad/s scale (the ten trajectories: 0.17-0.84 in rad/s on 60 s windows,
#: 9.6-48 with the rates 57.3x too small; simulated missions 0.91-0.98 and 52-56). No gyro unit is 57.3x larger
#: than rad/s, so there is nothing to convert to: the declaration or the logger's conversion is wrong.
GYRO_TILT_SCALE_SMALL = 3.0
#: Tilt-kinematics gyro scale below this is deg/s: the rates converted from deg/s must pass the too-small check
#: (the ten: at most 0.015 in deg/s on 60 s windows, at least 0.17 in rad/s; a surface vehicle whose hull follows
#: 90 % of the wave slope, its accelerometer the water surface's normal: 0.068 in rad/s).
GYRO_TILT_SCALE_DEG = GYRO_TILT_SCALE_SMALL * np.pi / 180
#: Median tilt rate (rad/s, :func:`gyro_tilt_scale`) below which the tilt kinematics tell nothing (the ten: >= 0.002
#: on 60 s windows).
GYRO_TILT_MIN_RADPS = 1e-3
#: Correlation of the gravity direction's turn rate with the gyro's prediction (:func:`gyro_tilt_fit`) below which
#: the scale says nothing: the accelerometer's direction then follows the vehicle's accelerations, not its rotation
#: (a hovering AUV's thrusters: 0.22 at most, scales 1.2-50; the ten 0.70-0.88, 0.11-0.98 on 60 s windows;
#: simulated missions >= 0.97).
GYRO_TILT_MIN_CORRELATION = 0.4
#: ``meta`` key of the fact the tilt kinematics could not judge the gyro's scale (``declared``: the gyro unit declared,
#: None when detected; ``field``: the gyro columns; ``correlation``): the prepare step judges it against the DVL
#: (:func:`graphnav.calibration.dvl_scale.check_gyro_against_dvl`).
GYRO_UNJUDGED = "gyro_scale_unjudged"
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
               field: str = "t", declared: str | None = None, lines: np.ndarray | None = None,
               key: str | None = None, meta: dict | None = None, stream_key: str | None = None) -> tuple[float, str]:
    """The factor that puts stamps ``t`` (as read) in seconds, and its unit name. A unit a user ``declared`` (under
    the configuration ``key``) is checked with the same evidence as a detected one: a unit that makes the median
    step no plausible sample period is a DataError naming ``key`` when another unit makes it plausible, else kept
    with a warning and a note (an instrument that samples unusually slowly or fast); ``stream_key``: the key that
    declares this stream's unit alone, advised instead of a ``key`` shared with streams whose stamps it fits.

    Raises:
        DataError: no unit makes the sample step plausible, or the stream spans more than
            :data:`MAX_SPAN_S` (naming the file line of the largest jump's later stamp, ``lines`` (N,) the line of
            each stamp; without them its index).
    """
    t = np.asarray(t, float)
    if t.size < 2:
        return 1.0, "s"
    step = np.diff(t)
    med, (lo, hi), fits = _plausible_units(t, stream)
    if declared is not None:
        if declared not in TIME_SCALES:
            raise ConfigError(f"{source}: time unit {declared!r}: choose one of {sorted(TIME_SCALES)}")
        unit = declared
        if key is not None and med > 0 and declared not in fits:
            said = (f"the declared time unit {declared!r} ({key}) makes the median stamp step "
                    f"{med * TIME_SCALES[declared]:.3g} s, no plausible {stream} sample period ({lo:g}-{hi:g} s)")
            if fits:
                raise DataError(f"{said}: the stamps look like {fits[0]}; {_set_unit(key, fits[0], stream_key)}",
                                source, field=field)
            _note(meta, stream, f"field '{field}': stamps kept in the declared unit: {said}, nor in any other unit",
                  source)
    elif lo <= med <= hi or med <= 0:
        unit = "s"       # a non-positive median step is an ordering problem, reported by the stamp checks
    else:
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
        at = "" if lines is not None else f" at index {i}"
        raise DataError(f"stamps span {span:.3g} s (more than a year: a corrupt stamp?); largest jump "
                        f"{t[i - 1]:.6g} -> {t[i]:.6g} ({unit}){at}", source,
                        None if lines is None else int(lines[i]), field)
    return scale, unit


def _set_unit(key: str, unit: str, stream_key: str | None) -> str:
    """The advice to set the time unit under ``key``, or under ``stream_key`` (the stream's own) when the shared
    ``key`` fits the other streams."""
    return (f"set {key} to {unit!r}" if stream_key is None else
            f"set {stream_key} to {unit!r} (this stream's own unit: {key} fits the others)")


def _plausible_units(t: np.ndarray, stream: str) -> tuple[float, tuple[float, float], list[str]]:
    """``(median step as read, the stream's plausible period (s), the units that make the step one)`` of stamps ``t``
    (at least two, as read)."""
    step = np.diff(t)
    med = float(np.median(step))
    if stream == "imu":     # packets stamped on receipt: 0.01 ms steps or one stamp each, yet a 10 ms period
        from graphnav.core.imu_timing import imu_step_stats, shared_stamp_packets
        packets = shared_stamp_packets(t)
        med = packets[2] if packets else imu_step_stats(step)[0] if med > 0 else med
    lo, hi = PLAUSIBLE_PERIOD_S.get(stream, (1e-4, 60.0))
    return med, (lo, hi), [u for u, k in TIME_SCALES.items() if lo <= med * k <= hi]


def _other_units(t: np.ndarray, declared: str, stream: str, fits) -> tuple[np.ndarray, list[str]]:
    """Stamps ``t`` (s, the ``declared`` unit applied) as read, and the units other than ``declared`` that make their
    step a plausible ``stream`` sample period and for which ``fits`` (of the stamps in s) holds."""
    raw = t / TIME_SCALES[declared]
    return raw, [u for u in _plausible_units(raw, stream)[2] if u != declared and fits(raw * TIME_SCALES[u])]


#: How many times shorter than the IMU's a stream's span may be, or (for a unit the data did not declare) longer,
#: and still be read as on the IMU's span: the geometric middle of 1 (the right unit) and 1000 (a unit one step off),
#: so a reference logged over a tenth of the mission is on it and stamps 1000x too short or long are not.
SPAN_RATIO_MAX = 1000.0 ** 0.5


def _on_span(t: np.ndarray, t_imu: np.ndarray, longest: float = np.inf) -> bool:
    """Stamps ``t`` (s) on the IMU span ``t_imu`` (s, the same clock): sharing at least
    :data:`~graphnav.core.timeseries.MIN_CLOCK_OVERLAP` of the shorter span
    (:func:`~graphnav.core.timeseries.on_the_imu_clock`), and no more than :data:`SPAN_RATIO_MAX` times shorter
    than the IMU's span nor ``longest`` times longer (a log may run all week around a dive)."""
    from graphnav.core.timeseries import on_the_imu_clock
    t = np.sort(np.asarray(t, float))
    ratio = (t[-1] - t[0]) / max(float(t_imu[-1] - t_imu[0]), 1e-9)
    return on_the_imu_clock(t, t_imu) and 1.0 / SPAN_RATIO_MAX <= ratio <= longest


def check_declared_time_span(t: np.ndarray, t_imu: np.ndarray, stream: str, source: str, declared: str, key: str,
                             field: str = "t", stream_key: str | None = None) -> None:
    """DataError naming ``key`` (the configuration key that ``declared`` the time unit) and the unit that fits when
    another unit with a plausible sample period (:func:`time_scale`) puts stamps ``t`` (s, the declared unit applied,
    the file's clock) on the IMU's span ``t_imu`` (s, the same clock) where the declared one does not
    (:func:`_on_span`, for the other unit within :data:`SPAN_RATIO_MAX` of the IMU's span either way): a depth at
    1 Hz in s declared ms passes the period check (1 ms) and sat 1.7e9 s before the IMU. A stream off the span in
    every unit (a clock of its own) is left to the clock checks; ``stream_key`` as for :func:`time_scale`."""
    from graphnav.core.timeseries import span_overlap_fraction
    t = np.asarray(t, float)
    if t.size < 2 or len(t_imu) < 2 or _on_span(t, t_imu):
        return
    raw, fits = _other_units(t, declared, stream, lambda x: _on_span(x, t_imu, SPAN_RATIO_MAX))
    if not fits:
        return
    t0, unit = float(t_imu[0]), fits[0]
    other = raw * TIME_SCALES[unit]

    def span(x):
        return f"[{np.nanmin(x) - t0:.3f}, {np.nanmax(x) - t0:.3f}] s"

    def share(x):
        return f"{100 * span_overlap_fraction(np.sort(x), t_imu):.0f} %"
    fix = _set_unit(key, unit, stream_key)
    raise DataError(f"the declared time unit {declared!r} ({key}) puts the {stream} stamps at {span(t)}, sharing "
                    f"{share(t)} of the IMU's {span(t_imu)} (s from the first IMU stamp; of the shorter span); in "
                    f"{unit!r} they lie at {span(other)}, sharing {share(other)}: {fix}", source, field=field)


def check_stamp_bound(t: np.ndarray, t0: float, stream: str, source: str, declared: str | None, key: str,
                      field: str, lines: np.ndarray, stream_key: str | None = None) -> None:
    """DataError naming the file line (``lines``: each stamp's) of the first stamp ``t`` (s, the file's clock) more
    than :data:`~graphnav.core.screening.MAX_STAMP_S` from the first IMU stamp ``t0`` and, with a ``declared`` unit,
    ``key`` and a unit with a plausible period that brings every stamp within it: the mission's own check names a
    sample, and a stream on a clock of its own in a unit 1000x off is caught by no span check."""
    from graphnav.core.screening import MAX_STAMP_S
    t = np.asarray(t, float)
    bad = np.flatnonzero(np.abs(t - t0) > MAX_STAMP_S)
    if not bad.size:
        return
    said = (f"time stamp {t[bad[0]] - t0:.6g} s from the first IMU stamp is beyond {MAX_STAMP_S:g} s ({bad.size} "
            "such stamp(s)")
    fix = "micro/nanoseconds read as seconds, or corrupted"
    if declared is not None:
        fits = _other_units(t, declared, stream, lambda x: np.all(np.abs(x - t0) <= MAX_STAMP_S))[1]
        said += f" in the declared unit {declared!r}, {key}"
        if fits:
            fix = f"the stamps look like {fits[0]}; {_set_unit(key, fits[0], stream_key)}"
    raise DataError(f"{said}): {fix}", source, int(lines[bad[0]]), field)


# ------------------------------------------------------------------------------------------------
# IMU
# ------------------------------------------------------------------------------------------------
def gyro_tilt_fit(t: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray) -> tuple[float, float, float]:
    """Scale k with which the gravity direction seen by the accelerometer turns at the gyro's rate:
    ``|du/dt| = k |u x omega|`` over 1 s means (norms: indifferent to axis signs and order). Returns
    ``(k, tilt_rate, correlation)``: k is ~1 for a gyro in rad/s and ~1/57.3 in deg/s; ``tilt_rate`` (rad/s, median
    of |du/dt| over the seconds used) says how much tilt motion there was to see; ``correlation`` (of the two
    rates over all seconds) how much of it the gyro explains; NaN when too little data."""
    t = np.asarray(t, float)
    if t.size < 3 or t[-1] - t[0] < 10.0:
        return float("nan"), 0.0, float("nan")
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
        return float("nan"), 0.0, float("nan")
    k = float(np.sum(du[use] * p[use]) / np.sum(p[use] ** 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        r = float(np.corrcoef(du, p)[0, 1]) if p.size >= 3 else float("nan")
    return k, float(np.median(du[use])), r


def gyro_tilt_scale(t: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray) -> tuple[float, float]:
    """``(k, tilt_rate)`` of :func:`gyro_tilt_fit`."""
    return gyro_tilt_fit(t, f_b, omega_b)[:2]


def imu_units(t: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray, source: str, meta: dict | None = None,
              declared: Mapping[str, str] | None = None, gravity: float = STANDARD_GRAVITY,
              fields: tuple[str, ...] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(f_b m/s^2, omega_b rad/s)`` with swapped blocks, g/milli-g and deg/s detected and converted (with
    a warning and a note), or DataError naming the field. ``t`` in seconds. ``declared``: units the caller
    already applied (``{"accel": "g", "gyro": "deg/s"}``): the data must then agree. ``fields``: the six
    accelerometer and gyro column names the errors name (default ``f_b`` and ``omega_b``). The units are judged on
    the measurements: a logger's all-zero filler rows (:func:`graphnav.core.screening.imu_filler`, zero in any unit,
    refused by the screening) stay zero."""
    from graphnav.core.screening import imu_filler
    declared = dict(declared or {})
    f_b, omega_b = np.asarray(f_b, float), np.asarray(omega_b, float)
    if f_b.size == 0:
        return f_b, omega_b
    filler = imu_filler(f_b, omega_b)
    if filler.any() and not filler.all():
        real = ~filler
        f_r, w_r = imu_units(np.asarray(t, float)[real], f_b[real], omega_b[real], source, meta, declared, gravity,
                             fields)
        if np.array_equal(f_r, f_b[real]) and np.array_equal(w_r, omega_b[real]):
            return f_b, omega_b
        f_b, omega_b = np.zeros_like(f_b), np.zeros_like(omega_b)
        f_b[real], omega_b[real] = f_r, w_r
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
    gyro_field = "/".join(fields[3:6]) if fields else "omega_b"
    omega_b, _ = _gyro_units(t, f_b, omega_b, source, meta, declared, gyro_field)
    return f_b, omega_b


def _gyro_units(t, f_b, omega_b, source, meta, declared, field="omega_b") -> tuple[np.ndarray, str]:
    norm = np.linalg.norm(omega_b, axis=1)
    med = float(np.nanmedian(norm))
    top = float(np.nanquantile(norm, 0.999))
    why = None
    if med > GYRO_MEDIAN_MAX_RADPS:
        why = f"median |omega| {med:.3g} rad/s (> {GYRO_MEDIAN_MAX_RADPS:g}: no AUV turns like that all along)"
    elif top > GYRO_MAX_RADPS:
        why = f"99.9th percentile |omega| {top:.3g} rad/s (> {GYRO_MAX_RADPS:g}: beyond what an AUV turns)"
    else:
        why = _gyro_tilt(t, f_b, omega_b, source, meta, declared.get("gyro"), field)
    if why is None:
        return omega_b, "rad/s"
    if "gyro" in declared:
        raise DataError(f"gyro after the declared unit {declared['gyro']!r}: {why}", source, field=field)
    if med * np.pi / 180 > GYRO_MEDIAN_MAX_RADPS or top * np.pi / 180 > 10 * GYRO_MAX_RADPS:
        raise DataError(f"gyro rates implausible in rad/s and in deg/s ({why}; median {med:.3g}, "
                        f"99.9th percentile {top:.3g})", source, field=field)
    _note(meta, "imu", f"gyro read as deg/s and converted to rad/s: {why} (a vehicle riding waves, its accelerometer "
          "following the water surface, can give this in rad/s: declare the gyro unit)", source)
    return omega_b * (np.pi / 180), "deg/s"


def _gyro_tilt(t, f_b, omega_b, source, meta, declared: str | None, field: str) -> str | None:
    """Why the tilt kinematics (:func:`gyro_tilt_fit`) say the rates are deg/s, None when they do not; rates too
    small for rad/s are a DataError. Judged only when the gyro explains the tilt motion
    (:data:`GYRO_TILT_MIN_CORRELATION`); a declared rad/s that they contradict is kept with a warning and a note."""
    k, tilt, r = gyro_tilt_fit(t, f_b, omega_b)
    if not (tilt > GYRO_TILT_MIN_RADPS and r >= GYRO_TILT_MIN_CORRELATION):
        if meta is not None:        # the prepare step judges the scale against the DVL instead
            meta[GYRO_UNJUDGED] = {"declared": declared, "field": field, "correlation": r,
                                   "tilt": accelerometer_tilt(f_b)}
        return None
    if GYRO_TILT_SCALE_DEG <= k <= GYRO_TILT_SCALE_SMALL:
        return None
    if declared == "rad/s":
        _note(meta, "imu", f"the gravity direction the accelerometer sees turns {k:.3g}x as fast as the gyro rates say "
              f"(about 1 in rad/s, 57.3 for rates 57.3x too small, 1/57.3 for deg/s; tilt kinematics, correlation "
              f"{r:.2f}): kept in the declared unit 'rad/s' (field {field})", source)
        return None
    if k > GYRO_TILT_SCALE_SMALL:
        _gyro_too_small(k, source, declared, field)
    return f"the gravity direction turns {1 / k:.3g}x slower than these rates say (57.3 for deg/s; tilt kinematics)"


def accelerometer_tilt(f_b: np.ndarray) -> float:
    """The vehicle's mean tilt from level (rad) the accelerometer sees: the angle of its mean specific force ``f_b``
    (N,3) from the z axis, whichever way each axis points (the vehicle's accelerations average out)."""
    f = np.abs(np.nanmean(np.asarray(f_b, float), axis=0))
    return float(np.arctan2(np.hypot(f[0], f[1]), f[2])) if f.size == 3 else float("nan")


def _gyro_too_small(k: float, source: str, declared: str | None, field: str) -> None:
    """DataError for gyro rates (after the ``declared`` unit, None when detected) that the gravity direction turns
    ``k`` times faster than (:func:`gyro_tilt_scale`; above :data:`GYRO_TILT_SCALE_SMALL`)."""
    gyro_too_small(f"the gravity direction the accelerometer sees turns {k:.3g}x faster than these rates say (about 1 "
                   "in rad/s; rates 57.3x too small give tens; tilt kinematics)", source, declared, field)


def gyro_too_small(turns: str, source: str, declared: str | None, field: str) -> None:
    """DataError for gyro rates (after the ``declared`` unit, None when detected) 57.3x too small, ``turns`` saying
    what shows it (the tilt kinematics here, the DVL velocity in the prepare step)."""
    if declared is not None:
        raise DataError(f"the declared gyro unit {declared!r} looks wrong: after it, {turns} (rad/s data declared "
                        "'deg/s'?)", source, field=field)
    raise DataError(f"gyro rates too small for rad/s: {turns}; no gyro unit is that much larger than rad/s: were the "
                    "rates converted from deg/s to rad/s twice, or rad/s data divided by 57.3?", source, field=field)


# ------------------------------------------------------------------------------------------------
# DVL
# ------------------------------------------------------------------------------------------------
#: What a DVL whose speeds are neither m/s nor mm/s is told to do (a column map or bag: declare the unit).
DECLARE_UNIT_FIX = "declare the velocity unit"
#: How the note of a DVL velocity detected as mm/s and converted begins (the unit the prepare step then judges).
MMPS_CONVERTED = "DVL velocities read as mm/s"


def unit_fix(declared: dict, unit: str) -> str:
    """The advice to put a DVL velocity in ``unit``: set the key of the ``declared`` unit (``{"unit", "key"}``) to
    it, or declare it under that key when the unit was taken with none declared (``"taken": True``)."""
    return f"declare {declared['key']} {unit!r}" if declared.get("taken") else f"set {declared['key']} to {unit!r}"


def taken_velocity_unit(meta: dict) -> dict:
    """The DVL velocity unit a column map's loader took where none was declared, as a declared unit is given
    (``{"unit", "key", "taken": True}``): mm/s when it detected them (:data:`MMPS_CONVERTED`), else m/s. A log in
    knots read as m/s is a declaration missing, named under ``csv_columns.dvl.velocity_unit``."""
    notes = meta.get("streams", {}).get("dvl", {}).get("notes", [])
    unit = "mm/s" if any(n.startswith(MMPS_CONVERTED) for n in notes) else "m/s"
    return {"unit": unit, "key": "csv_columns.dvl.velocity_unit", "taken": True}


def judged_velocity_unit(meta: dict) -> dict | None:
    """The DVL velocity unit the IMU judges (``{"unit", "key"}``): the one declared (``meta["prepare"]["dvl_unit"]``),
    else a column map's as its loader took it (:func:`taken_velocity_unit`); None for other formats, whose unit is
    fixed by the format or the message type."""
    prepare = meta.get("prepare", {})
    return prepare.get("dvl_unit") or (taken_velocity_unit(meta) if prepare.get("format") == "csv" else None)


def velocity_unit_fits(t_dvl: np.ndarray, v: np.ndarray, imu, factors) -> dict[float, float] | None:
    """Factor (1 for the velocity as read, and each of ``factors``) -> the share of the DVL velocity's changes the DVL
    clock model (:mod:`graphnav.core.dvl_kinematics`: the IMU's integrals, offset 0, no lever arm) leaves unexplained
    with the velocity multiplied by it: how well the IMU's accelerations say each unit explains the data. None when
    the pings are not on the IMU's clock or fill under two windows.

    Args:
        t_dvl: (M,) ping stamps, s. v: (M,3) body-frame velocity as read (NaN: none), m/s.
        imu: ``(t, f_b, omega_b)``: stamps, s; specific force, m/s^2; rates, rad/s (FRD).
    """
    from graphnav.core.dvl_kinematics import dvl_window_model, imu_integrals
    from graphnav.core.mission import ImuData, no_beams
    from graphnav.core.timeseries import on_the_imu_clock
    ok = np.all(np.isfinite(v), axis=1)
    if imu is None or ok.sum() < 2 or not on_the_imu_clock(t_dvl[ok], imu[0]):
        return None
    try:
        ints = imu_integrals(*imu)
        dvl = DvlData(t_dvl[ok], *no_beams(int(ok.sum())), np.asarray(v, float)[ok])
        return {k: 1.0 - dvl_window_model(ImuData(*imu), dvl, transform=k * np.eye(3), ints=ints)[0].score(0.0)[0]
                for k in (1.0, *factors)}
    except DataError:
        return None


def most_plausible_first(speed: np.ndarray, factors: dict[str, float], fits: dict[float, float] | None,
                         max_speed_mps: float) -> tuple[list[tuple[str, float]], str]:
    """``([(unit, median speed in it, m/s)], why)``: the units of ``factors`` (name -> factor to m/s from the
    ``speed`` (M,) as read) that put the median within what a DVL measures, the one that explains the data best first,
    and why that order ('' for one unit): what the IMU's accelerations leave unexplained in each (``fits``, factor ->
    share, :func:`velocity_unit_fits`) when known, else the share of pings within the vehicle's ``max_speed_mps``
    (the faster first between equals): a larger speed is no likelier, a vehicle beyond its envelope is not."""
    speed = np.asarray(speed, float)
    speed = speed[np.isfinite(speed)]
    med = float(np.median(speed))
    units = [u for u, k in factors.items() if med * k <= MAX_DVL_SPEED_MPS]
    if fits:
        units.sort(key=lambda u: fits[factors[u]])
        why = ("the IMU's accelerations leave " + ", ".join(f"{fits[factors[u]]:.3g}" for u in units) +
               " of the velocity's changes unexplained")
    else:
        within = {u: float(np.mean(speed * factors[u] <= max_speed_mps)) for u in units}
        units.sort(key=lambda u: (-within[u], -factors[u]))
        why = (", ".join(f"{within[u]:.0%}" for u in units) + f" of the pings within the vehicle's {max_speed_mps:g} "
               "m/s (dvl.max_speed_mps)")
    return [(u, med * factors[u]) for u in units], (f" (most plausible first: {why})" if len(units) > 1 else "")


def dvl_speed_scale(beams: np.ndarray | None, velocity: np.ndarray | None, source: str,
                    field: str = "beams", columns: str = "v_b/v_d", fix: str = DECLARE_UNIT_FIX,
                    declared: str | None = None, key: str | None = None, imu=None, t: np.ndarray | None = None,
                    max_speed_mps: float | None = None) -> tuple[float, float]:
    """``(scale to m/s, median speed as read)`` of DVL values (beams (M,4) and/or a velocity (M,3)), from
    the median speed; RDI's bad-velocity flags and non-finite values are left out. DataError when the
    speeds are neither m/s nor mm/s, naming the velocity's ``columns`` and advising ``fix`` (an A-KIT folder has
    no unit to declare); values already in m/s from a ``declared`` unit (under ``key``) beyond what a DVL measures
    are a DataError naming the key and the smaller units that fit (:func:`_declared_speed_error`). Candidate units
    are listed most plausible first (:func:`most_plausible_first`): by the IMU's accelerations when ``imu`` (``(t,
    f_b, omega_b)``) and the pings' stamps ``t`` (s) are given with a velocity, else by the vehicle's
    ``max_speed_mps`` (default ``DvlSpec``'s)."""
    def clean(a):
        a = np.asarray(a, float)
        return np.where(np.isfinite(a) & ~rdi_flagged(a), a, np.nan)
    if velocity is not None and np.any(np.isfinite(clean(velocity))):
        speed, field = np.linalg.norm(clean(velocity), axis=1), columns
    elif beams is not None and np.any(np.isfinite(clean(beams))):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            speed = np.nanmax(np.abs(clean(beams)), axis=1)
    else:
        return 1.0, float("nan")
    med = float(np.nanmedian(speed))
    if med <= MAX_DVL_SPEED_MPS:
        return 1.0, med
    if declared is None and DVL_MMPS_RANGE[0] <= med <= DVL_MMPS_RANGE[1]:
        return 1e-3, med
    if declared is None and med > DVL_MMPS_RANGE[1]:
        raise DataError(f"median DVL speed {med:.4g} is beyond the {MAX_DVL_SPEED_MPS:g} m/s a DVL measures and "
                        f"not mm/s of a moving vehicle ({DVL_MMPS_RANGE[0]:g}-{DVL_MMPS_RANGE[1]:g}): {fix}", source,
                        field=field)
    factors = ({u: k for u, k in other_unit_factors(declared).items() if k < 1} if declared is not None
               else {"cm/s": 1e-2, "mm/s": 1e-3})
    if max_speed_mps is None:
        from graphnav.core.config import DvlSpec
        max_speed_mps = DvlSpec().max_speed_mps
    fits = None if velocity is None or t is None else velocity_unit_fits(t, clean(velocity), imu, factors.values())
    ranked, why = most_plausible_first(speed, factors, fits, max_speed_mps)
    if declared is not None:
        raise _declared_speed_error(med, declared, key or "the declared velocity_unit", source, field, ranked, why)
    raise DataError(f"median DVL speed {med:.4g} is beyond the {MAX_DVL_SPEED_MPS:g} m/s a DVL measures: "
                    + " or ".join(f"{u} ({v:.3g} m/s)" for u, v in ranked) + f"{why}? {fix}", source, field=field)


def _declared_speed_error(med: float, declared: str, key: str, source: str, field: str,
                          ranked: list[tuple[str, float]], why: str) -> DataError:
    """A median DVL speed ``med`` (m/s in the ``declared`` unit) beyond what a DVL measures: the smaller units that
    bring it within, at the speed each gives, most plausible first (``ranked``, ``why``:
    :func:`most_plausible_first`), and the ``key`` to set."""
    fit = [f"{u!r} ({v:.3g} m/s)" for u, v in ranked]
    return DataError(f"median DVL speed {med:.4g} m/s in the declared unit {declared!r} ({key}) is beyond the "
                     f"{MAX_DVL_SPEED_MPS:g} m/s a DVL measures: " + (f"{' or '.join(fit)}{why}? set {key} to the "
                     "file's unit" if fit else f"no smaller unit brings it within; check {key} and the columns"),
                     source, field=field)


def dvl_velocity_units(values: np.ndarray, source: str, meta: dict | None = None, declared: str | None = None,
                       beams: bool = False, columns: str | None = None, fix: str = DECLARE_UNIT_FIX,
                       key: str | None = None, **rank) -> np.ndarray:
    """DVL values as read (beams (M,4) when ``beams``, else a velocity (M,3)) in m/s: mm/s detected and
    converted (warning, note), or DataError. RDI's raw flag -32768 becomes its m/s flag -32.768. ``columns``: the
    values' columns in ``source`` (a DataError names them), ``fix``: what a DataError advises
    (:func:`dvl_speed_scale`, which also takes ``rank``: ``imu``, ``t``, ``max_speed_mps``, to order the units it
    names); ``key``: the one that ``declared`` the unit."""
    values, med = dvl_values_in_mps(values, source, declared, beams, columns, fix, key, **rank)
    if med is not None:
        say_mmps(meta, source, f"median speed {med:.4g}")
    return values


def dvl_values_in_mps(values: np.ndarray, source: str, declared: str | None = None, beams: bool = False,
                      columns: str | None = None, fix: str = DECLARE_UNIT_FIX, key: str | None = None,
                      **rank) -> tuple[np.ndarray, float | None]:
    """:func:`dvl_velocity_units` without saying it: ``(values in m/s, the median speed as read when they were
    detected as mm/s and converted, else None)``, for a reader that says the unit once for several fields
    (:func:`say_mmps`)."""
    field = columns or ("beams" if beams else "v_b/v_d")
    scale, med = dvl_speed_scale(values if beams else None, None if beams else values, source, field=field,
                                 columns=field, fix=fix, declared=declared, key=key, **rank)
    return (values, None) if scale == 1.0 else (np.asarray(values, float) * scale, med)


def say_mmps(meta: dict | None, source: str, speeds: str) -> None:
    """Warn about and note a DVL's values detected as mm/s and converted (:data:`MMPS_CONVERTED`), ``speeds`` the
    median speeds as read that said so (and the fields they were read from)."""
    _note(meta, "dvl", f"{MMPS_CONVERTED} ({speeds}) and converted to m/s", source)


def dvl_units(dvl: DvlData, meta: dict | None = None, declared: str | None = None) -> DvlData:
    """The DVL with its velocities in m/s (mm/s detected and converted, with a warning and a note)."""
    velocity = dvl.v_b if dvl.v_b is not None else dvl.v_d
    scale, med = dvl_speed_scale(dvl.beams, velocity, dvl.source)
    if scale == 1.0:
        return dvl
    if declared is not None:
        raise DataError(f"median DVL speed {med:.4g} m/s after the declared unit {declared!r}: the data look "
                        "like mm/s", dvl.source, field="beams")
    _note(meta, "dvl", f"{MMPS_CONVERTED} (median speed {med:.4g}) and converted to m/s",
          dvl.source)

    def conv(a):
        # RDI's raw flag -32768 becomes -32.768, its m/s flag: still recognised as invalid
        return None if a is None else np.asarray(a, float) * scale
    return dataclasses.replace(dvl, beams=conv(dvl.beams), v_b=conv(dvl.v_b), v_d=conv(dvl.v_d),
                               v_d_sigma=conv(dvl.v_d_sigma))


# ------------------------------------------------------------------------------------------------
# ground truth (reference)
# ------------------------------------------------------------------------------------------------
#: A reference's rate as read over the rate it must have (its attitude's turn rate over the gyro's, its
#: horizontal displacement over its own velocity's): ~1 when both are SI (0.95-1.03 and 0.975-1.007 on the ten
#: shared trajectories), 57.3 for angles in degrees read as radians (23-56 and 28-57 with the ten in degrees; the
#: wrap of a turn faster than a radian per sample lowers it). Above the geometric middle of 1 and 57.3 the angles
#: are degrees.
DEG_RATE_RATIO = float(np.sqrt(180.0 / np.pi))
#: Rates that agree within this factor are the same units (positions against velocities, a declared unit).
SAME_UNITS_RATIO = 3.0


def _units_disagree(ratio: float) -> bool:
    """A rate ratio (finite) that two quantities in the same units cannot have (:data:`SAME_UNITS_RATIO`); NaN (the
    rates tell nothing) does not disagree."""
    return bool(np.isfinite(ratio) and not 1 / SAME_UNITS_RATIO < ratio < SAME_UNITS_RATIO)


#: An attitude that turns faster than DEG_RATE_RATIO is taken for degrees only when, converted, it turns with the
#: gyro within this factor (0.95-1.03 on the ten in degrees): noise of 0.01-0.02 rad on a radian attitude over a
#: gyro turning 2-4 mrad/s also gives ratios of 11-22, and converted those turn 0.19-0.38x as fast.
DEG_CONFIRM_RATIO = 2.0
#: Median gyro turn rate (rad/s) and reference speed (m/s) below which the rates tell nothing (the ten
#: trajectories: 0.006-0.046 rad/s, 1.5-2.1 m/s).
MIN_TURN_RATE_RADPS = 1e-3
MIN_SPEED_MPS = 0.1
#: Shortest reference interval (s) the attitude rates are compared over: a 100 Hz reference's sample-to-sample
#: noise and quantisation would otherwise swamp its turn rate.
ATTITUDE_STEP_MIN_S = 1.0
#: Windows (s) over which displacements are compared with the velocity's integral: long enough for a noisy fix
#: (USBL metres) to be small against the distance travelled.
POSITION_WINDOW_S = 10.0
#: The displacement ratio is also taken over windows this many times and its square as long, and the one closest
#: to 1 kept: a fix's noise shrinks against a longer window's distance, another unit does not (a vehicle at
#: 0.2 m/s with USBL fixes of 4 m sigma gives 3.3 over 10 s, the ratio of feet to metres; over 160 s, 1.0).
POSITION_WINDOW_GROWTH = 4.0
#: Vertical displacements (m, RMS over the windows) below which the down sign cannot be told (the ten: 0.03-1.1).
MIN_VERTICAL_MOTION_M = 0.01


def _reference_steps(t: np.ndarray, min_step_s: float) -> np.ndarray:
    """Indices of the samples of stamps ``t`` (s) kept so that neighbours are at least ``min_step_s`` apart
    (every k-th sample, k from the median step)."""
    t = np.asarray(t, float)
    step = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    k = max(1, int(np.ceil(min_step_s / step - 1e-9))) if step > 0 else 1
    return np.arange(0, t.size, k)


def attitude_rate_ratio(t_ref: np.ndarray, C_b_n: np.ndarray, t_imu: np.ndarray, omega_b: np.ndarray,
                        turn_imu: float | None = None) -> tuple[float, float]:
    """``(ratio, gyro turn rate rad/s)``: the median turn rate of the reference attitude ``C_b_n`` (K,3,3, built
    from the angles as read) over its intervals of at least :data:`ATTITUDE_STEP_MIN_S`, over the gyro's median
    turn rate (``omega_b`` (N,3) rad/s at ``t_imu`` s) over windows of the same length. Medians over each whole
    stream, so neither a clock offset between the two nor the IMU's axis signs matter: ~1 in radians, ~57 for
    degrees read as radians. NaN when the gyro turns too little (:data:`MIN_TURN_RATE_RADPS`) to tell.
    ``turn_imu``: the gyro turn rate an earlier call over the same stamps returned, not computed again."""
    from scipy.spatial.transform import Rotation

    from graphnav.core.timeseries import cumulative_integral, interp_rows
    t_ref, t_imu = np.asarray(t_ref, float), np.ascontiguousarray(t_imu, float)
    keep = _reference_steps(t_ref, ATTITUDE_STEP_MIN_S)
    if keep.size < 3 or t_imu.size < 3:
        return float("nan"), 0.0
    C = np.asarray(C_b_n, float)[keep]
    dt = np.diff(t_ref[keep])
    turn_ref = np.linalg.norm(Rotation.from_matrix(np.swapaxes(C[:-1], 1, 2) @ C[1:]).as_rotvec(), axis=1) / dt
    if turn_imu is None:
        step = float(np.median(dt))
        edges = np.arange(t_imu[0], t_imu[-1], step)
        if edges.size < 3:
            return float("nan"), 0.0
        S = interp_rows(edges, t_imu, np.asfortranarray(cumulative_integral(t_imu, np.asarray(omega_b, float))))
        turn_imu = float(np.median(np.linalg.norm(np.diff(S, axis=0), axis=1) / step))
    if not turn_imu >= MIN_TURN_RATE_RADPS:
        return float("nan"), turn_imu
    return float(np.median(turn_ref) / turn_imu), turn_imu


def _window_increments(t: np.ndarray, p: np.ndarray, v: np.ndarray, window_s: float
                       ) -> tuple[np.ndarray, np.ndarray]:
    """(W,k) displacements of positions ``p`` (K,k, m) and (W,k) integrals of velocities ``v`` (K,k, m/s, the
    trapezoid rule) over consecutive windows of ``window_s`` s of the stamps ``t`` (s)."""
    t = np.asarray(t, float)
    edges = np.arange(t[0], t[-1] + 1e-9, window_s)
    if edges.size < 3:
        return np.zeros((0, p.shape[1])), np.zeros((0, p.shape[1]))
    v = np.asarray(v, float)
    integral = np.concatenate([np.zeros((1, v.shape[1])),
                               np.cumsum((v[1:] + v[:-1]) / 2 * np.diff(t)[:, None], axis=0)])
    return (np.diff(interp_rows(edges, t, np.asarray(p, float)), axis=0),
            np.diff(interp_rows(edges, t, integral), axis=0))


def displacement_ratio(t: np.ndarray, p: np.ndarray, v: np.ndarray, window_s: float = POSITION_WINDOW_S,
                       longer: bool = True) -> tuple[float, float]:
    """``(ratio, speed m/s)``: the median displacement of positions ``p`` (K,k, m as read) over windows of
    ``window_s`` over the median of the velocities' ``v`` (K,k, m/s) integral over the same windows (norms:
    turns shorten both alike); ~1 when the two agree. With ``longer``, of the ratios over windows of ``window_s``
    and :data:`POSITION_WINDOW_GROWTH` and its square times as long (those the log holds two of), the one closest
    to 1: noisy fixes move less against a longer window's distance, other units do not (for a check that the
    units are the same; telling degrees from radians takes ``window_s`` alone). NaN when the median speed over
    ``window_s`` is below :data:`MIN_SPEED_MPS`."""
    ratios, speed = _displacement_ratios(t, p, v, window_s, 3 if longer else 1)
    return _closest_to_one(ratios), speed


def _displacement_ratios(t, p, v, window_s: float, windows: int) -> tuple[list[float], float]:
    """``(ratios, speed m/s)`` of :func:`displacement_ratio` over windows of ``window_s`` times
    :data:`POSITION_WINDOW_GROWTH` to the 0 .. ``windows`` - 1 (those the log holds two of), the first over
    ``window_s``; none when the median speed over ``window_s`` is below :data:`MIN_SPEED_MPS`."""
    ratios, speed = [], 0.0
    for k in range(windows):
        w = window_s * POSITION_WINDOW_GROWTH ** k
        dp, dv = _window_increments(t, p, v, w)
        if not len(dp):
            break
        moved = float(np.median(np.linalg.norm(dv, axis=1)))
        if k == 0:
            speed = moved / w
            if not moved >= MIN_SPEED_MPS * w:
                return [], speed
        if moved > 0:
            ratios.append(float(np.median(np.linalg.norm(dp, axis=1)) / moved))
    return ratios, speed


def _closest_to_one(ratios: list[float]) -> float:
    """The ratio closest to 1 (in log), NaN for none."""
    if not ratios:
        return float("nan")
    return min(ratios, key=lambda r: abs(np.log(r)) if r > 0 else np.inf)


def vertical_sign(t: np.ndarray, down: np.ndarray, v_down: np.ndarray, window_s: float = POSITION_WINDOW_S
                  ) -> tuple[int, float, float]:
    """``(sign, slope, correlation)``: whether the down positions ``down`` (K, m) change with the down velocity
    ``v_down`` (K, m/s, same stamps ``t`` s) (+1), against it (-1), or cannot be told (0: a correlation under
    :data:`DEPTH_FIT_MIN_CORRELATION`, too little vertical motion); slope and correlation of
    :func:`depth_rate_fit`, the one fit of a depth against a vertical velocity (a depth sensor's too)."""
    k, r = depth_rate_fit(t, down, t, v_down, window_s, min_windows=3)
    return (int(np.sign(r)) if abs(r) >= DEPTH_FIT_MIN_CORRELATION else 0), k, r


def _columns(fields) -> str:
    return ", ".join(f"'{f}'" for f in fields)


def reference_attitude_units(t: np.ndarray, euler: np.ndarray, t_imu: np.ndarray | None,
                             omega_b: np.ndarray | None, source: str, fields, meta: dict | None = None,
                             declared: str | None = None) -> np.ndarray:
    """Roll, pitch, yaw of a reference (``euler`` (K,3) as read, after a declared unit's factor) in rad: degrees
    detected and converted (a warning naming ``source`` and the columns ``fields``, a note), or DataError.

    Degrees are told by the range (a roll beyond pi or a pitch beyond pi/2 cannot be radians; a yaw beyond 2 pi
    alone is taken for an unwrapped one, with a warning when the gyro cannot tell) and, inside it, by the turn rate
    against the gyro's (:func:`attitude_rate_ratio`: ~1 in radians, ~57 in degrees; ``t_imu`` s and ``omega_b``
    rad/s after the gyro's own unit check, None without an IMU). ``declared``: the unit the caller applied
    (``"rad"``/``"deg"``): angles beyond its range are refused, and so are rates the other unit fits (within
    :data:`DEG_CONFIRM_RATIO`) where the declared one is off by more than :data:`DEG_RATE_RATIO`; rates off in
    both units are warned about (the declared unit wins).
    Rates above :data:`DEG_RATE_RATIO` are degrees only when the converted angles turn with the gyro within
    :data:`DEG_CONFIRM_RATIO`; else the angles are kept, with a warning.

    When the gyro's scale is itself unjudged (``meta[GYRO_UNJUDGED]``: a hovering vehicle), the rates cannot tell a
    reference in degrees from a gyro 57.3x too small; the unit is then settled by roll and pitch against the
    accelerometer's tilt where it can (:func:`reference_tilt_unit`; undeclared, that unit is taken, but radians not
    with a yaw beyond 2 pi, which degrees on a level vehicle with a tilted IMU give too), and the
    reference's turn against the gyro's is left in the fact for the prepare step to judge the gyro by
    (:func:`check_gyro_against_reference`).
    """
    fact = (meta or {}).get(GYRO_UNJUDGED)
    unit, how = reference_tilt_unit(euler, fact["tilt"]) if fact and np.size(euler) else (None, "")
    if unit == "rad" and declared is None and np.max(np.abs(euler[:, 2])) > 2 * np.pi:
        unit = None                     # degrees on a level vehicle, or an unwrapped yaw: cannot tell (TILT_RAD_DOUBT)
    half_turn = 180.0 if unit == "deg" else np.pi
    if unit is not None and declared is None and np.all(np.max(np.abs(euler[:, :2]), axis=0) <= [half_turn,
                                                                                            half_turn / 2]):
        out = euler if unit == "rad" else np.radians(euler)
        if unit == "deg":
            _note(meta, "gt", f"attitude columns {_columns(fields[:3])} read as degrees and converted to rad: {how}",
                  source)
    else:
        out = _attitude_units(t, euler, t_imu, omega_b, source, fields, meta, declared)
        # a declared unit is applied by the caller: the tilt confirms it when it finds radians
        unit = unit if unit == ("rad" if declared is not None or out is euler else "deg") else None
    if unit is not None:
        keep_reference_turn(meta, t, out, t_imu, omega_b, f"{source}, columns {'/'.join(fields[:3])}",
                            f"the unit of its angles settled by {how}",
                            TILT_RAD_DOUBT if unit == "rad" and declared is None else "")
    return out


def keep_reference_turn(meta: dict | None, t: np.ndarray, euler: np.ndarray, t_imu: np.ndarray | None,
                        omega_b: np.ndarray | None, where: str, how: str, doubt: str = "") -> None:
    """While the gyro's scale is unjudged (``meta[GYRO_UNJUDGED]``), leave a reference attitude whose unit is known
    (roll, pitch, yaw ``euler`` (K,3) rad at ``t`` s) turning against the gyro (``omega_b`` rad/s at ``t_imu`` s,
    :func:`reference_turn_fit`) in that fact, for the prepare step to judge the gyro by
    (:func:`check_gyro_against_reference`). ``where`` names the reference (a file and its columns, a bag's topic and
    field), ``how`` says how its unit is known; the messages quote both. ``doubt``: what else the evidence could
    mean, which makes a gyro that looks 57.3x too small a warning rather than a refusal."""
    fact = (meta or {}).get(GYRO_UNJUDGED)
    if fact is None or t_imu is None or omega_b is None:
        return
    fact["reference"] = dict(zip(("ratio", "turn", "correlation"), reference_turn_fit(t, euler, t_imu, omega_b)),
                             where=where, how=how, **({"doubt": doubt} if doubt else {}))


def check_gyro_against_reference(omega_b: np.ndarray, source: str, fact: dict, meta: dict) -> np.ndarray | None:
    """The gyro rates ``omega_b`` judged by the reference's turn (``fact["reference"]``, left by
    :func:`keep_reference_turn`: a file's angles whose unit was settled without the gyro, a bag's quaternion;
    ``fact`` the gyro's :data:`GYRO_UNJUDGED`): rates 57.3x too small are a DataError naming ``source`` and the
    gyro columns (a warning, read as they are, when the reference's unit rests on its tilt alone: ``doubt``,
    :data:`TILT_RAD_DOUBT`), deg/s converted (a warning, a note) or, declared, a DataError; in rad/s a note. Judged
    only when the two turn rates correlate at least :data:`GYRO_TILT_MIN_CORRELATION` and the ratio, the one scale
    taken, is within :data:`DEG_CONFIRM_RATIO` of 1; None when it cannot judge."""
    ref = fact.get("reference")
    if ref is None or not ref["correlation"] >= GYRO_TILT_MIN_CORRELATION:
        return None
    k = min((1.0, 180.0 / np.pi, np.pi / 180), key=lambda s_: abs(np.log(ref["ratio"] / s_)))
    if not 1 / DEG_CONFIRM_RATIO < ref["ratio"] / k < DEG_CONFIRM_RATIO:
        return None
    fit = (f"the reference attitude ({ref['where']}) turns {ref['ratio']:.3g}x as fast as these rates (1 in rad/s; "
           f"correlation {ref['correlation']:.2f}, {ref['how']})")
    if k == 1.0:
        add_note(meta, "imu", f"the gyro's scale judged against the reference attitude: {fit}")
        return omega_b
    if k > 1 and ref.get("doubt"):
        # refusing would refuse a clean log the same numbers describe; reading on with a note alone would be silent
        _note(meta, "imu", f"the gyro rates look 57.3x too small for rad/s: {fit}. {ref['doubt']}, so the rates are "
                           f"read as they are (field {fact['field']}). Rates converted from deg/s twice, or divided by "
                           "57.3? Declare the reference's angle_unit: 'rad' refuses such rates, 'deg' reads the log as "
                           "it is", source)
        count_doubted(meta, "imu", GYRO_SMALL_DOUBT, len(omega_b))
        return omega_b
    return gyro_scale_found(omega_b, k, fit, source, fact, meta)


def gyro_scale_found(omega_b: np.ndarray, k: float, fit: str, source: str, fact: dict, meta: dict) -> np.ndarray:
    """The gyro rates ``omega_b`` (rad/s as read) once a check (the DVL's velocity, a reference's turn: ``fit`` says
    what shows it) found them ``k`` times what they should be read as: 57.3x too small a DataError
    (:func:`gyro_too_small`), deg/s converted with a warning and a note, or a DataError when a gyro unit was declared
    (``fact`` the gyro's :data:`GYRO_UNJUDGED`)."""
    declared, field = fact["declared"], fact["field"]
    if k > 1:
        gyro_too_small(fit, source, declared, field)
    if declared is not None:
        raise DataError(f"the declared gyro unit {declared!r} looks wrong: {fit}: deg/s?", source, field=field)
    _note(meta, "imu", f"gyro read as deg/s and converted to rad/s: {fit} (field {field}; declare the gyro unit)",
          source)
    return omega_b * k


def _attitude_units(t, euler, t_imu, omega_b, source: str, fields, meta: dict | None, declared: str | None
                    ) -> np.ndarray:
    """:func:`reference_attitude_units` told by the range and the gyro."""
    euler = np.asarray(euler, float)
    if euler.size == 0:
        return euler
    ratio, turn_imu = _attitude_ratio(t, euler, t_imu, omega_b)
    peak = np.max(np.abs(euler), axis=0)
    tilt_beyond = peak[0] > np.pi or peak[1] > np.pi / 2
    field = "/".join(fields[:3])
    extent = f"|roll| up to {peak[0]:.4g}, |pitch| up to {peak[1]:.4g}, |yaw| up to {peak[2]:.4g}"
    turns = f"the attitude turns {ratio:.3g}x as fast as the gyro (1 in radians, 57.3 for degrees)"
    if declared is not None:
        if tilt_beyond:
            raise DataError(f"attitude after the declared unit {declared!r}: {extent} rad: not the declared unit",
                            source, field=field)
        # the other unit fitting the gyro where the declared one is off by more than the degrees split: the
        # declaration is wrong (a noisy attitude is off in both and keeps the declared unit, with a note)
        other = ratio * 180.0 / np.pi if declared == "deg" else ratio * np.pi / 180.0
        if (np.isfinite(ratio) and not 1 / DEG_RATE_RATIO < ratio < DEG_RATE_RATIO
                and 1 / DEG_CONFIRM_RATIO < other < DEG_CONFIRM_RATIO):
            raise DataError(f"attitude columns {_columns(fields[:3])} declared {declared!r} turn {ratio:.3g}x as fast "
                            f"as the gyro, and {other:.3g}x read in the other unit: the declared angle_unit (or the "
                            "gyro's unit) is wrong", source, field=field)
        if _units_disagree(ratio):
            _note(meta, "gt", f"attitude columns {_columns(fields[:3])} kept in the declared unit {declared!r}, but "
                  f"{turns}", source)
        return euler
    if np.isfinite(ratio) and ratio < DEG_RATE_RATIO:
        if tilt_beyond:
            raise DataError(f"{extent}: beyond radians, yet {turns}: neither radians nor degrees", source,
                            field=field)
        if _units_disagree(ratio):        # finite here
            _note(meta, "gt", f"attitude columns {_columns(fields[:3])} kept as radians, but {turns}", source)
        return euler                    # radians (a yaw beyond 2 pi is an unwrapped one)
    if not (tilt_beyond or np.isfinite(ratio)):
        if peak[2] > 2 * np.pi:
            # an unwrapped yaw in radians or a yaw in degrees: the turn, interval by interval, may still tell
            if _degrees_turn_with_gyro(t, euler, t_imu, omega_b, source, fields, meta, extent):
                return np.radians(euler)
            _note(meta, "gt", f"attitude columns {_columns(fields[:3])} kept as radians: {extent} (an unwrapped yaw "
                  "in radians, or degrees?); the gyro turns too little to tell and roll/pitch are inside the "
                  "radian range", source)
        return euler                    # nothing tells: radians, as a reference's angles are
    why = turns if np.isfinite(ratio) else f"{extent}: beyond radians"
    if peak[0] > 180.0 or peak[1] > 90.0:
        raise DataError(f"attitude neither radians nor degrees ({why}; {extent})", source, field=field)
    if not tilt_beyond:
        # a noisy attitude in radians also turns faster than the gyro: degrees only when they then turn with it
        ratio_deg, _ = _attitude_ratio(t, np.radians(euler), t_imu, omega_b, turn_imu)
        if not 1 / DEG_CONFIRM_RATIO < ratio_deg < DEG_CONFIRM_RATIO:
            _note(meta, "gt", f"attitude columns {_columns(fields[:3])} kept as radians, but {turns}; read as "
                  f"degrees it would turn {ratio_deg:.3g}x as fast: the gyro matches neither unit (a noisy "
                  "attitude?)", source)
            return euler
        if not _follows_gyro(t, euler, t_imu, omega_b):
            _note(meta, "gt", f"attitude columns {_columns(fields[:3])} kept as radians (the range allows them), but "
                  f"{turns}, and read as degrees {ratio_deg:.3g}x: {NOISY_TURN_DOUBT}. Declare the reference's "
                  "angle_unit", source)
            if meta is not None:
                count_doubted(meta, "gt", NOISY_TURN_DOUBT, len(euler))
            return euler
    _note(meta, "gt", f"attitude columns {_columns(fields[:3])} read as degrees and converted to rad: {why}", source)
    return np.radians(euler)


#: Why a reference whose median turn rate says degrees but whose turn does not follow the gyro's is kept in radians
#: and counted as doubted (:func:`_follows_gyro`).
NOISY_TURN_DOUBT = ("its turn does not follow the gyro's interval by interval, so its median rate may be noise "
                    "(radians with noise of 0.03-0.1 rad give 0.6-1.9x read as degrees)")
#: Largest :func:`reference_turn_fit` spread of a reference that follows the gyro without correlating with it (a
#: steady turn), the rates' median difference (a gyro bias) taken out: 0.043-0.044 for a clean one in degrees at
#: 0.01 deg, 0.088-0.097 with 0.01 deg of noise, 0.133-0.137 with 0.016 deg (any bias up to 103 deg/h: 0.033-0.043);
#: radian noise of 0.03-0.1 rad read as degrees 0.16-0.60 (steady 2 mrad/s turn, 600 s, three seeds). The two sides
#: are close (0.137 against 0.16): a reference on either side of the bound is warned about, not silent.
TURN_SPREAD_MAX = 0.15


def _follows_gyro(t, euler, t_imu, omega_b) -> bool:
    """Whether the attitude ``euler`` (K,3, as read), read as degrees, follows the gyro's turn interval by interval
    (:func:`reference_turn_fit`: correlated at least :data:`GYRO_TILT_MIN_CORRELATION`, or within
    :data:`TURN_SPREAD_MAX`), which noise matching the gyro's median rate by chance does not."""
    _, _, r, spread = reference_turn_fit(t, np.radians(euler), t_imu, omega_b)
    return bool(r >= GYRO_TILT_MIN_CORRELATION or spread <= TURN_SPREAD_MAX)


#: Why gyro rates that look 57.3x too small, read as they are, are counted as doubted (``meta["streams"]["imu"]``).
GYRO_SMALL_DOUBT = "gyro rates read as they are, though they look 57.3x too small for rad/s"
#: Why a reference read as degrees by its turn alone is counted as doubted (``meta["streams"]["gt"]["doubted"]``).
DEGREES_BY_TURN_DOUBT = "attitude read as degrees by its turn alone (or an unwrapped yaw in radians?)"


def _degrees_turn_with_gyro(t, euler, t_imu, omega_b, source: str, fields, meta: dict | None, extent: str) -> bool:
    """Whether a reference attitude ``euler`` (K,3, as read, at ``t`` s) whose yaw alone lies beyond radians turns,
    read as degrees, with the gyro (``omega_b`` rad/s at ``t_imu`` s; :func:`reference_turn_fit`: the ratio within
    :data:`DEG_CONFIRM_RATIO` of 1, the two rates correlated at least :data:`GYRO_TILT_MIN_CORRELATION`), when the gyro
    turns too little for the median rates to tell (a hovering vehicle). Then a warning naming the other reading the
    same numbers allow (an unwrapped yaw in radians with a gyro 57.3x too small), a note and a count
    (:data:`DEGREES_BY_TURN_DOUBT`)."""
    if t_imu is None or omega_b is None:
        return False
    ratio, _, r, _ = reference_turn_fit(t, np.radians(euler), t_imu, omega_b)
    if not (r >= GYRO_TILT_MIN_CORRELATION and 1 / DEG_CONFIRM_RATIO < ratio < DEG_CONFIRM_RATIO):
        return False
    _note(meta, "gt", f"attitude columns {_columns(fields[:3])} read as degrees and converted to rad: {extent}, and "
          f"read as degrees the attitude turns {ratio:.3g}x as fast as the gyro (1 in the right unit; correlation "
          f"{r:.2f}). The same numbers come from an unwrapped yaw in radians with a gyro 57.3x too small (rad/s "
          "divided by 57.3): declare the reference's angle_unit", source)
    if meta is not None:
        count_doubted(meta, "gt", DEGREES_BY_TURN_DOUBT, len(euler))
    return True


#: A reference's roll and pitch are compared with the accelerometer's tilt (:func:`reference_tilt_unit`) only when
#: that tilt is at least this (rad, 1.1 deg): a level vehicle's tilt is the IMU's mounting error and noise.
REFERENCE_TILT_MIN_RAD = 0.02


#: Why a reference's radians settled by its tilt (:func:`reference_tilt_unit`) judge a gyro that looks 57.3x too small
#: with a warning, not a refusal (:func:`check_gyro_against_reference`): the same tilt ratio and turn ratio come from
#: a clean log in degrees; only a yaw beyond the radian range (a heading over 6.3 deg from north, were it degrees)
#: tells them apart, and that yaw leaves the unit unsettled.
TILT_RAD_DOUBT = ("The same numbers come from a reference in degrees on a level vehicle whose IMU is mounted tilted "
                  "against it")


def reference_tilt_unit(euler: np.ndarray, tilt: float) -> tuple[str | None, str]:
    """``(unit, why)``: ``"rad"`` or ``"deg"`` when the mean roll and pitch of ``euler`` (K,3, as read) lie as far
    from level as the accelerometer's mean ``tilt`` (rad, :func:`accelerometer_tilt`) within
    :data:`SAME_UNITS_RATIO`, read in that unit; None when neither fits or the tilt is under
    :data:`REFERENCE_TILT_MIN_RAD` (a level vehicle)."""
    ratio = float(np.hypot(*np.mean(np.asarray(euler, float)[:, :2], axis=0))) / tilt if tilt > 0 else np.nan
    why = (f"its mean roll and pitch are {ratio:.3g}x as far from level as the accelerometer's tilt of {tilt:.3g} rad "
           "(1 in radians, 57.3 for degrees)")
    if not tilt >= REFERENCE_TILT_MIN_RAD:
        return None, why
    for unit, k in (("rad", 1.0), ("deg", np.pi / 180)):
        if not _units_disagree(ratio * k):
            return unit, why
    return None, why


def reference_turn_fit(t_ref: np.ndarray, euler: np.ndarray, t_imu: np.ndarray, omega_b: np.ndarray
                       ) -> tuple[float, float, float, float]:
    """``(ratio, turn rad/s, correlation, spread)``: the reference attitude's (roll, pitch, yaw ``euler`` (K,3) rad at
    ``t_ref`` s) median turn rate over its intervals of at least :data:`ATTITUDE_STEP_MIN_S` over the gyro's
    (``omega_b`` (N,3) at ``t_imu`` s, integrated over the same intervals), the reference's median turn rate, and the
    correlation of the two rates interval by interval (which needs the two on one clock; norms: indifferent to the
    IMU's axis signs): ~1 for a gyro in rad/s, 57.3 for rates 57.3x too small, 1/57.3 for deg/s. NaN when too short.
    ``spread``: the median departure of the two rates' difference, interval by interval, from its median (a gyro
    bias) over the gyro's median rate (near 0 when the reference follows the gyro, even turning steadily, where the
    correlation cannot tell; noise whose median happens to match the gyro's gives 0.16-0.60,
    :data:`TURN_SPREAD_MAX`)."""
    from scipy.spatial.transform import Rotation

    from graphnav.core.rotations import euler_to_C_b_n
    from graphnav.core.timeseries import cumulative_integral
    keep = _reference_steps(t_ref, ATTITUDE_STEP_MIN_S)
    t, t_imu = np.asarray(t_ref, float)[keep], np.ascontiguousarray(t_imu, float)
    inside = (t >= t_imu[0]) & (t <= t_imu[-1])
    if inside.sum() < 10:
        return float("nan"), float("nan"), float("nan"), float("nan")
    e = np.asarray(euler, float)[keep][inside]
    C, dt = euler_to_C_b_n(e[:, 0], e[:, 1], e[:, 2]), np.diff(t[inside])
    turn_ref = np.linalg.norm(Rotation.from_matrix(np.swapaxes(C[:-1], 1, 2) @ C[1:]).as_rotvec(), axis=1) / dt
    S = interp_rows(t[inside], t_imu, np.asfortranarray(cumulative_integral(t_imu, np.asarray(omega_b, float))))
    turn_imu = np.linalg.norm(np.diff(S, axis=0), axis=1) / dt
    with np.errstate(invalid="ignore", divide="ignore"):
        r = float(np.corrcoef(turn_ref, turn_imu)[0, 1])
        median_imu = float(np.median(turn_imu))
        # about the rates' median difference: a gyro bias offsets every interval alike and is not a misfit
        diff = turn_ref - turn_imu
        spread = float(np.median(np.abs(diff - np.median(diff))) / median_imu)
        return float(np.median(turn_ref) / median_imu), float(np.median(turn_ref)), r, spread


def _attitude_ratio(t, euler, t_imu, omega_b, turn_imu: float | None = None) -> tuple[float, float | None]:
    """:func:`attitude_rate_ratio` of roll, pitch, yaw ``euler`` (K,3, rad): (ratio, gyro turn rate); NaN (and None)
    without a gyro."""
    from graphnav.core.rotations import euler_to_C_b_n
    if t_imu is None or omega_b is None:
        return float("nan"), None
    return attitude_rate_ratio(t, euler_to_C_b_n(euler[:, 0], euler[:, 1], euler[:, 2]), t_imu, omega_b, turn_imu)


def check_reference_displacement(ratio: float, source: str, fields, what: str = "", t: np.ndarray | None = None
                                 ) -> None:
    """DataError when a reference's positions move ``ratio`` times as far as its velocity says
    (:func:`displacement_ratio`, NaN: cannot tell) and that is not the same units
    (:data:`SAME_UNITS_RATIO`); ``fields`` = (position columns..., velocity columns...) of ``source``. With its
    stamps ``t`` (s), a jump among them (a clock put to another time zone mid-log) is named first: it makes the
    ratio as much as other units do."""
    if _units_disagree(ratio):
        jump = _stamp_jump(t)
        raise DataError(f"the positions{what} move {ratio:.3g}x as far as the velocity says (1 when both are SI; "
                        f"columns {_columns(fields)}): " + (f"{jump}, or " if jump else "") + "the positions or the "
                        "velocity are in other units", source,
                        field="/".join(fields[:len(fields) // 2] if len(fields) > 1 else fields))


# ------------------------------------------------------------------------------------------------
# a reference's north/east axes: exchanged or negated columns
# ------------------------------------------------------------------------------------------------
#: The eight signed permutations (2,2) of north/east a reference's velocity is tried in, as read (the identity) first.
SIGNED_PERMUTATIONS = [np.array([[a, 0], [0, b]] if same else [[0, a], [b, 0]], float)
                       for same in (True, False) for a in (1, -1) for b in (1, -1)]


#: A signed permutation of a reference's north/east velocity (:func:`horizontal_axes_fit`) fits its positions when it
#: leaves at most this share of their displacement's energy unexplained, and every other one (the velocity as read
#: among them) at least :data:`AXES_FIT_MARGIN` times more. The ten shared trajectories as read: 2e-5..2e-4, the
#: seven others 0.40-4.0 (over 10, 40 and 160 s windows); their latitude and longitude exchanged (north and east
#: scaled by cos(latitude) as well) leave 0.02-0.04 to the exchange.
AXES_FIT_MAX = 0.1
AXES_FIT_MARGIN = 10.0


def horizontal_axes_fit(t: np.ndarray, p: np.ndarray, v: np.ndarray) -> tuple[list[np.ndarray], float, float, float]:
    """``(fits, unexplained, as_read, window_s)``: the signed permutations M (2,2) of the north/east velocity ``v``
    (K,2, m/s) whose integral explains the north/east positions' ``p`` (K,2, m) displacement over windows of
    ``window_s`` s (``M @ v``: the velocity as it fits; fewest negations first: a straight leg along an axis fits
    an exchange with and without the small axis negated), the share of the displacement's energy the best leaves
    unexplained, and the share the velocity as read leaves. ``fits`` is empty when the velocity as read fits or
    none does; the window length is the one of :func:`displacement_ratio`'s three where the best permutation leaves
    the least (a noisy fix moves less against a longer window's distance)."""
    best: tuple = ([], np.inf, np.nan, np.nan)
    for k in range(3 if len(t) >= 3 else 0):
        w = POSITION_WINDOW_S * POSITION_WINDOW_GROWTH ** k
        dp, dv = _window_increments(t, p, v, w)
        if len(dp) < 2 or not np.median(np.linalg.norm(dv, axis=1)) >= MIN_SPEED_MPS * w:
            break
        shares = np.array([np.sum((dp - dv @ M.T) ** 2) for M in SIGNED_PERMUTATIONS]) / max(np.sum(dp ** 2), 1e-300)
        low = float(np.min(shares))
        if low < best[1]:
            fit = np.flatnonzero(shares <= AXES_FIT_MARGIN * low) if low <= AXES_FIT_MAX else []
            fit = [] if 0 in fit else sorted(fit, key=lambda m: (np.sum(SIGNED_PERMUTATIONS[m] < 0), shares[m]))
            best = ([SIGNED_PERMUTATIONS[m] for m in fit], low, float(shares[0]), w)
    return best


def _axes_words(M: np.ndarray, cols) -> str:
    """``M`` (2,2) applied to the north/east columns ``cols``: "north = 've', east = 'vn'"."""
    terms = [("-" if M[i, j] < 0 else "") + f"'{cols[j]}'" for i in range(2) for j in range(2) if M[i, j]]
    return f"north = {terms[0]}, east = {terms[1]}"


def _forward_share(v: np.ndarray, yaw: np.ndarray) -> float:
    """Median share of the moving rows' north/east velocity ``v`` (K,2, m/s) along the heading ``yaw`` (K,) rad; NaN
    for fewer than 10 such rows."""
    speed = np.linalg.norm(v, axis=1)
    moving = speed > 3 * MIN_SPEED_MPS
    if moving.sum() < 10:
        return float("nan")
    along = v[moving, 0] * np.cos(yaw[moving]) + v[moving, 1] * np.sin(yaw[moving])
    return float(np.median(along / speed[moving]))


def _axes_advice(M: np.ndarray, cols, key: str | None) -> str:
    """What to do about north/east/down columns ``cols`` whose north/east fit as ``M`` (2,2) says: a column map
    (``key``, the ``csv_columns.gt`` entry) can reorder them, not negate one; a fixed layout's file must be
    corrected."""
    order = [cols[int(np.flatnonzero(M[i])[0])] for i in range(2)]
    if key is not None and np.all(M.sum(axis=1) > 0):
        return f"map csv_columns.gt.{key} as {order + [cols[2]]}"
    negate = [cols[j] for i in range(2) for j in range(2) if M[i, j] < 0]
    fixes = ([f"exchange '{cols[0]}' and '{cols[1]}'"] if M[0, 0] == 0 else []) + (
        [f"negate {_columns(negate)}"] if negate else [])
    return ("correct the file: " + " and ".join(fixes)
            + (" (a column map cannot negate a column)" if key is not None and negate else ""))


def check_reference_axes(t: np.ndarray, p: np.ndarray, v: np.ndarray, yaw: np.ndarray, source: str, fields,
                         keys: tuple[str, str] | None = None) -> None:
    """DataError when a reference's north/east velocity ``v`` (K,2, m/s) explains its north/east positions ``p`` (K,2,
    m, at ``t`` s) only with its columns exchanged or negated (:func:`horizontal_axes_fit`); ``fields`` = (north,
    east, down position columns, north, east, down velocity columns) of ``source``. The heading ``yaw`` (K,) rad
    tells which pair is wrong: an AUV moves forward, so the velocity along it (a median forward share of
    :data:`FORWARD_SHARE_MIN` or more) is the right one. ``keys``: the column map's position and velocity entries
    (``p_n``, ``v_n``), named in the advice; None for a fixed layout."""
    fits, share, as_read, w = horizontal_axes_fit(t, p, v)
    if not fits:
        return
    M, pos, vel = fits[0], list(fields[:3]), list(fields[3:6])
    s_read, s_fit = _forward_share(v, yaw), _forward_share(v @ M.T, yaw)
    fit = (f"the velocity fits the positions as {_axes_words(M, vel)} ({share:.2g} of their displacement over {w:g} s "
           f"windows unexplained, {as_read:.2g} as read" + "".join(f"; as {_axes_words(other, vel)} too"
                                                                  for other in fits[1:]) + ")")
    heading = f"(median forward share in its attitude {s_fit:.2f} so read, {s_read:.2f} as read)"
    v_advice, p_advice = _axes_advice(M, vel, keys and keys[1]), _axes_advice(M.T, pos, keys and keys[0])
    if s_fit >= FORWARD_SHARE_MIN > s_read:
        what, wrong = (f"the heading agrees with the velocity so read {heading}: the velocity columns are wrong; "
                       f"{v_advice}"), vel[:2]
    elif s_read >= FORWARD_SHARE_MIN > s_fit:
        what, wrong = (f"the heading agrees with the velocity as read {heading}: the position columns are wrong, "
                       f"{_axes_words(M.T, pos)}; {p_advice}"), pos[:2]
    else:
        what, wrong = (f"the heading cannot tell which pair is wrong {heading}: either the velocity columns "
                       f"({v_advice}) or the positions, {_axes_words(M.T, pos)} ({p_advice})"), pos[:2] + vel[:2]
    raise DataError(f"{fit}: {what}", source, field="/".join(wrong))


#: A reference stamp step this many times the median one (and over a minute) is a jump of its clock.
STAMP_JUMP_STEPS = 100.0


def _stamp_jump(t: np.ndarray | None) -> str:
    """What a reference's largest stamp step says when it is a jump of its clock (over a minute and
    :data:`STAMP_JUMP_STEPS` median steps), else ``""``."""
    from graphnav.core.screening import whole_hours
    steps = np.diff(np.asarray(t, float)) if t is not None and len(t) > 2 else np.zeros(0)
    if not steps.size:
        return ""
    i = int(np.argmax(np.abs(steps)))
    step = float(steps[i])
    if not (abs(step) > 60.0 and abs(step) > STAMP_JUMP_STEPS * float(np.median(np.abs(steps)))):
        return ""
    return (f"its stamps jump by {step:+.3f} s after t = {t[i]:.3f} s{whole_hours(step)} (correct the stamps or "
            "split the log there)")


#: Velocity units a reference's ``v_n`` columns may be in, named when they are not m/s (:func:`reference_speed_error`).
OTHER_SPEED_UNITS = {"mm/s": 1e-3, "cm/s": 1e-2, "ft/s": 0.3048, "kn": 1852 / 3600}


def reference_speed_error(v_n: np.ndarray, source: str, fields, max_speed_mps: float) -> DataError:
    """The DataError for a reference velocity ``v_n`` (K,3, as read) mostly beyond the vehicle's ``max_speed_mps``
    while its positions move as far as it says (:func:`check_reference_displacement` passed): neither is in metres
    and m/s. Names ``source``, the velocity columns ``fields`` and the units (:data:`OTHER_SPEED_UNITS`) that put
    the median speed between :data:`MIN_SPEED_MPS` and ``max_speed_mps``."""
    speed = float(np.median(np.linalg.norm(np.asarray(v_n, float), axis=1)))
    fits = [f"{unit} ({speed * k:.3g} m/s)" for unit, k in OTHER_SPEED_UNITS.items()
            if MIN_SPEED_MPS <= speed * k <= max_speed_mps]
    return DataError(f"velocity columns {_columns(fields)}: median speed {speed:.4g} m/s, beyond the vehicle's "
                     f"{max_speed_mps:g} m/s (dvl.max_speed_mps), and the positions move as far: both in other units"
                     + (f"; the speed fits {' or '.join(fits)}" if fits else "") + " (a reference is read in m and "
                     "m/s: convert the file), or the vehicle is faster than dvl.max_speed_mps (raise it in the "
                     "configuration)", source, field="/".join(fields))


def reference_latlon_units(t: np.ndarray, lat: np.ndarray, lon: np.ndarray, v_n: np.ndarray, source: str,
                           fields, meta: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Latitude and longitude of a reference (K,) in rad: degrees detected and converted (a warning naming
    ``source`` and the columns, a note), or DataError. ``fields`` = (latitude, longitude, velocity north,
    velocity east) columns; ``v_n`` (K,3) the reference's NED velocity, m/s.

    Degrees are told by the range (a latitude beyond pi/2 or a longitude beyond 2 pi cannot be radians) and,
    inside it, by the displacement against the reference's own velocity (:func:`displacement_ratio`: ~1 in
    radians, ~57 in degrees). Positions that move with the velocity in neither unit are refused
    (:func:`check_reference_displacement`).
    """
    lat, lon = np.asarray(lat, float), np.asarray(lon, float)
    if lat.size == 0:
        return lat, lon
    # over 10 s alone for degrees (the longer windows are for noisy fixes), the closest to 1 for the same units
    ratios = _latlon_ratios(t, lat, lon, v_n)
    ratio = ratios[0] if ratios else float("nan")
    extent = f"|latitude| up to {np.max(np.abs(lat)):.6g}, |longitude| up to {np.max(np.abs(lon)):.6g}"
    beyond = np.max(np.abs(lat)) > np.pi / 2 or np.max(np.abs(lon)) > 2 * np.pi
    if not beyond and not ratio > DEG_RATE_RATIO:         # radians, or nothing tells (NaN)
        check_reference_displacement(_closest_to_one(ratios), source, fields, t=t)
        return lat, lon
    why = (f"the positions move {ratio:.3g}x as far as the velocity says (1 in radians, 57.3 for degrees)"
           if np.isfinite(ratio) else f"{extent}: beyond radians")
    if np.max(np.abs(lat)) > 90.0 or np.max(np.abs(lon)) > 360.0:
        raise DataError(f"latitude/longitude neither radians nor degrees ({why}; {extent})", source,
                        field="/".join(fields[:2]))
    lat_r, lon_r = np.radians(lat), np.radians(lon)
    check_reference_displacement(_closest_to_one(_latlon_ratios(t, lat_r, lon_r, v_n)), source, fields,
                                 " (read as degrees)", t)
    _note(meta, "gt", f"{_columns(fields[:2])} read as degrees and converted to rad: {why}", source)
    return lat_r, lon_r


def _latlon_ratios(t, lat, lon, v_n) -> list[float]:
    """The displacement ratios (:func:`_displacement_ratios`, 10 s first) of latitude/longitude read as radians
    (local north/east, m) against the horizontal part of ``v_n``."""
    from graphnav.core.earth import WGS84_A
    dlon = np.angle(np.exp(1j * (lon - lon[0])))           # across the antimeridian too
    p = np.column_stack([WGS84_A * (lat - lat[0]), WGS84_A * np.cos(lat[0]) * dlon])
    return _displacement_ratios(t, p, np.asarray(v_n, float)[:, :2], POSITION_WINDOW_S, 3)[0]


def reference_depth(t: np.ndarray, depth: np.ndarray, v_down: np.ndarray, source: str, fields,
                    meta: dict | None = None, depth_range_m: tuple[float, float] | None = None,
                    line_offset: int = 2, lines: np.ndarray | None = None, v_pitch: np.ndarray | None = None
                    ) -> np.ndarray:
    """The reference's down positions ``depth`` (K, m, positive down, as derived from the file) checked against
    its down velocity ``v_down`` (K, m/s) and, for an absolute depth, ``depth_range_m``; ``fields`` = (position
    column, velocity column) of ``source``.

    More than half the samples outside ``depth_range_m`` (the vehicle above the sea or beyond any depth) is a
    DataError naming the file, the first such line and the column, unless the positions change against the
    velocity (:func:`vertical_sign`) and flipped they lie in the range: the sign is then flipped back (a warning,
    a note). Positions that change against the velocity inside the range are a DataError naming both columns and,
    when the attitude tells (``v_pitch`` (K,) m/s, the down velocity the reference's pitch gives its speed:
    :func:`_pitch_says`), which one has the wrong sign. ``lines``: the file line of each sample (else
    index + ``line_offset``).
    """
    depth = np.asarray(depth, float)
    if depth.size == 0:
        return depth
    sign, k, r = vertical_sign(t, depth, v_down)
    against = (f"changes against {_columns(fields[1:])} ({k:.3g}x its integral over {POSITION_WINDOW_S:g} s windows, "
               f"correlation {r:.2f})")
    fit = f"it {against}" if sign < 0 else ""
    if depth_range_m is not None:
        lo, hi = depth_range_m
        outside = ~((depth >= lo) & (depth <= hi))
        if outside.mean() > 0.5:
            if sign < 0 and np.mean((-depth >= lo) & (-depth <= hi)) > 0.5:
                _note(meta, "gt", f"column {_columns(fields[:1])} read with its sign flipped and turned back: "
                      f"depth {np.min(depth):.4g} to {np.max(depth):.4g} m is outside [{lo:g}, {hi:g}] m and {fit}",
                      source)
                return -depth
            i = int(np.flatnonzero(outside)[0])
            line = int(lines[i]) if lines is not None else i + line_offset
            hint = (f"; {fit}" if fit else
                    "; a sign flipped (depth positive down, altitude positive up), a height above the ellipsoid "
                    "instead of the sea surface, or other units?")
            raise DataError(f"{int(outside.sum())} of {depth.size} depths outside [{lo:g}, {hi:g}] m "
                            f"(SensorConfig.depth_range_m): depth {np.min(depth):.4g} to {np.max(depth):.4g} m"
                            + hint, source, line, fields[0])
    if sign < 0:
        says, field = _pitch_says(v_pitch, v_down, fields)
        raise DataError(f"the down position {_columns(fields[:1])} {against}: {says}", source, field=field)
    return depth


#: Correlation of a reference's down velocity with the one its pitch gives its speed (-speed sin(pitch)) from which
#: the pitch tells the velocity's sign: the ten shared trajectories 0.91-0.96 where the depth changes (1, 4, 6, 8),
#: 0.71-0.80 on 5 and 11, 0.37-0.60 on the steady ones (angle of attack and noise against a level path).
PITCH_FIT_MIN_CORRELATION = 0.8


def _pitch_says(v_pitch: np.ndarray | None, v_down: np.ndarray, fields) -> tuple[str, str]:
    """``(sentence, column)``: which of a down position and down velocity (``fields``) has its sign flipped, from the
    down velocity the attitude's pitch gives (``v_pitch`` (K,) m/s, None: not known) against ``v_down`` (K,) m/s; the
    position column when the pitch cannot tell."""
    r = float("nan")
    if v_pitch is not None and np.std(v_pitch) > 0 and np.std(v_down) > 0:
        r = float(np.corrcoef(v_pitch, v_down)[0, 1])
    if not abs(r) >= PITCH_FIT_MIN_CORRELATION:
        return "one of the two columns has its sign flipped" + (
            f" (the attitude's pitch cannot tell which: correlation {r:.2f})" if np.isfinite(r) else ""), fields[0]
    wrong = fields[0] if r > 0 else fields[1]
    return (f"{_columns([wrong])} has its sign flipped (the velocity the attitude's pitch gives the speed "
            f"correlates {r:.2f} with {_columns(fields[1:])}): negate {_columns([wrong])} in the file"), wrong


#: Median share of a moving reference's body-frame velocity along its x (forward) axis below which its attitude
#: and velocity disagree: an AUV moves forward (0.991-0.999 on the ten shared trajectories; their attitude read
#: in degrees gives -0.18..0.06, a yaw from east instead of north -0.58..0.12).
FORWARD_SHARE_MIN = 0.5


def reference_inconsistencies(t: np.ndarray, C_b_n: np.ndarray, p_n: np.ndarray, v_n: np.ndarray,
                              t_imu: np.ndarray | None = None, omega_b: np.ndarray | None = None
                              ) -> list[tuple[str, str]]:
    """What in a reference (stamps ``t`` s, attitude ``C_b_n`` (K,3,3) body-to-NED, NED ``p_n`` m and ``v_n``
    m/s) disagrees with itself, or with the gyro (``omega_b`` (N,3) rad/s at ``t_imu`` s, any clock and axis
    signs): its attitude's turn rate, its displacement against its velocity, its depth against its down
    velocity, its velocity off its body's forward axis. ``(quantity, sentence)`` per finding, the quantity one
    of ``attitude``, ``positions``, ``depth``, ``heading``; empty when nothing disagrees."""
    found = []
    if t_imu is not None and omega_b is not None:
        ratio, _ = attitude_rate_ratio(t, C_b_n, t_imu, omega_b)
        if _units_disagree(ratio):
            found.append(("attitude", f"its attitude turns {ratio:.3g}x as fast as the gyro"))
    ratio, _ = displacement_ratio(t, np.asarray(p_n)[:, :2], np.asarray(v_n)[:, :2])
    if _units_disagree(ratio):
        found.append(("positions", f"its positions move {ratio:.3g}x as far as its velocity says"))
    if vertical_sign(t, np.asarray(p_n)[:, 2], np.asarray(v_n)[:, 2])[0] < 0:
        found.append(("depth", "its depth changes against its down velocity"))
    v_b = np.einsum("kji,kj->ki", np.asarray(C_b_n, float), np.asarray(v_n, float))
    speed = np.linalg.norm(v_b, axis=1)
    moving = speed > 3 * MIN_SPEED_MPS
    if moving.sum() >= 10:
        share = float(np.median(v_b[moving, 0] / speed[moving]))
        if share < FORWARD_SHARE_MIN:
            found.append(("heading", f"its velocity is not along its body's forward axis in its own attitude "
                                     f"(median forward share {share:.2f}, 0.99 on the shared trajectories)"))
    return found

# ------------------------------------------------------------------------------------------------
# a depth sensor's sign, unit and zero, against the vehicle's vertical velocity
# ------------------------------------------------------------------------------------------------
#: The depth's changes over :data:`POSITION_WINDOW_S` windows are fitted to the vertical velocity's integral (a
#: slope with an intercept, which takes a velocity bias and a steady descent); the slope says the depth's sign and
#: unit only when the two correlate this well (the ten shared trajectories: 0.95-1.00 with the DVL's velocity turned
#: by the accelerometer's gravity direction, 0.97-1.00 with the GT's; their first 200 s with the DVL: 0.71).
DEPTH_FIT_MIN_CORRELATION = 0.8
#: A depth sensor reading above the sea surface by more than this (m) on most samples is not at sea: waves and a
#: pressure offset stay within it (the bags' depth screening drops such samples).
DEPTH_ABOVE_SURFACE_M = 1.0
#: One atmosphere in metres of sea water (101.325 kPa / (1025 kg/m^3 g)), and how far a depth's constant offset from
#: the GT's absolute down may be from it and still be an absolute pressure in dbar (sea-level weather: 95-106 kPa).
ATMOSPHERE_M = 10.08
ATMOSPHERE_SPREAD_M = 0.6


def vertical_velocity(mission: Mission) -> tuple[np.ndarray, np.ndarray, str]:
    """``(t s, v_down m/s, what)``: the vehicle's down velocity from the GT (``v_n`` down, on the IMU clock), else the
    DVL's body velocity turned by the accelerometer's gravity direction (1 s means; no heading needed). Empty without
    either."""
    from graphnav.core.dvl import beam_velocity_b
    from graphnav.core.timeseries import cumulative_integral, on_the_imu_clock
    dvl, imu = mission.dvl, mission.imu
    if mission.gt is not None and on_the_imu_clock(mission.gt.t, imu.t):
        return mission.gt.t, mission.gt.v_n[:, 2], f"the down velocity of {mission.gt.source}"
    v = beam_velocity_b(dvl, mission.config.dvl)
    t_imu = np.ascontiguousarray(imu.t, float)
    inside = (dvl.t - 0.5 >= t_imu[0]) & (dvl.t + 0.5 <= t_imu[-1]) & np.all(np.isfinite(v), axis=1)
    F = np.asfortranarray(cumulative_integral(t_imu, imu.f_b))
    f = interp_rows(dvl.t[inside] + 0.5, t_imu, F) - interp_rows(dvl.t[inside] - 0.5, t_imu, F)
    down_b = -f / np.maximum(np.linalg.norm(f, axis=1, keepdims=True), 1e-12)     # FRD: f = -g down at rest
    return dvl.t[inside], np.einsum("ki,ki->k", down_b, v[inside]), (f"the DVL velocity of {dvl.source} turned by "
                                                                     "the accelerometer's gravity direction")


def depth_rate_fit(t: np.ndarray, depth: np.ndarray, t_v: np.ndarray, v_down: np.ndarray,
                   window_s: float = POSITION_WINDOW_S, min_windows: int = 5) -> tuple[float, float]:
    """``(slope, correlation)`` of the depth's changes (``depth`` m at ``t`` s) over windows of ``window_s`` against
    the integral of the down velocity (``v_down`` m/s at ``t_v`` s) over them: 1 for a depth in metres positive
    down, -1 positive up, 0.098 for a pressure in bar. NaN when the velocity moves less than
    :data:`MIN_VERTICAL_MOTION_M` or there are fewer than ``min_windows`` windows."""
    t_v, v_down = np.asarray(t_v, float), np.asarray(v_down, float)
    inside = (t >= t_v[0]) & (t <= t_v[-1]) if t_v.size >= 2 else np.zeros(len(t), bool)
    if inside.sum() < 3:
        return float("nan"), float("nan")
    t = np.asarray(t, float)[inside]
    dp, dv = _window_increments(t, np.reshape(depth, (-1, 1))[inside], np.interp(t, t_v, v_down)[:, None], window_s)
    if len(dp) < min_windows:
        return float("nan"), float("nan")
    dp, dv = dp[:, 0] - dp[:, 0].mean(), dv[:, 0] - dv[:, 0].mean()
    if not np.sqrt(np.mean(dv ** 2)) >= MIN_VERTICAL_MOTION_M or not np.any(dp):
        return float("nan"), float("nan")
    return float(dp @ dv / (dv @ dv)), float(dp @ dv / np.sqrt((dp @ dp) * (dv @ dv)))


#: Windows (s) over which a depth's changes are matched with the vertical velocity's to place the depth in time
#: (:func:`depth_clock_offset`): the convention's 10 s leave a 40 s log too few to tell; the search steps a quarter.
DEPTH_CLOCK_WINDOW_S = 2.0
#: Farthest offset searched (s, either way, and at most half the shorter span: beyond, the depth shares less than
#: half the IMU span and is left out as off it).
DEPTH_CLOCK_SEARCH_S = 300.0
#: A depth whose changes match the vertical velocity best more than this far (s) from its stamps, with
#: :data:`DEPTH_CLOCK_MIN_CORRELATION` there and :data:`DEPTH_CLOCK_SSE_RATIO` times the unexplained variance at its
#: stamps, is on a clock of its own. Measured on simulate_mission(40 s, seed 5), its depth 16 s late: 0.98 at -16 s,
#: 0.31 as stamped (ratio 24); 5 s late: 0.98 at -5 s, 0.62 (ratio 17); as simulated 0.98 at 0 s.
DEPTH_CLOCK_MIN_S = 3.0
DEPTH_CLOCK_MIN_CORRELATION = 0.9
DEPTH_CLOCK_SSE_RATIO = 5.0


def depth_clock_offset(t: np.ndarray, depth: np.ndarray, t_v: np.ndarray, v_down: np.ndarray
                       ) -> tuple[float, float, float] | None:
    """``(offset s, |correlation| there, |correlation| at 0)``: the offset added to the depth stamps ``t`` (s) at
    which the depth's changes (m) over :data:`DEPTH_CLOCK_WINDOW_S` windows correlate best with the integral of the
    down velocity (``v_down`` m/s at ``t_v`` s, :func:`vertical_velocity`) over them, on a grid of a quarter window
    within :data:`DEPTH_CLOCK_SEARCH_S`; the sign is the convention's to judge. None when no offset holds ten windows
    with :data:`MIN_VERTICAL_MOTION_M` of vertical motion."""
    t, t_v = np.asarray(t, float), np.asarray(t_v, float)
    if t.size < 3 or t_v.size < 3:
        return None
    reach = min(DEPTH_CLOCK_SEARCH_S, np.ptp(t) / 2, np.ptp(t_v) / 2)
    step = DEPTH_CLOCK_WINDOW_S / 4
    offsets = np.arange(-np.floor(reach / step), np.floor(reach / step) + 1) * step
    edges = np.arange(t[0], t[-1] + 1e-9, DEPTH_CLOCK_WINDOW_S)
    dp = np.diff(np.interp(edges, t, np.asarray(depth, float)))
    at = edges[None, :] + offsets[:, None]
    integral = np.concatenate([[0.0], np.cumsum((v_down[1:] + v_down[:-1]) / 2 * np.diff(t_v))])
    dv = np.diff(np.interp(at, t_v, integral), axis=1)
    use = (at[:, :-1] >= t_v[0]) & (at[:, 1:] <= t_v[-1])
    n = use.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        dpc = np.where(use, dp - (use * dp).sum(axis=1, keepdims=True) / n[:, None], 0.0)
        dvc = np.where(use, dv - (use * dv).sum(axis=1, keepdims=True) / n[:, None], 0.0)
        dv_squares = (dvc ** 2).sum(axis=1)
        r = np.abs((dpc * dvc).sum(axis=1)) / np.sqrt((dpc ** 2).sum(axis=1) * dv_squares)
    r[(n < 10) | ~(np.sqrt(dv_squares / np.maximum(n, 1)) >= MIN_VERTICAL_MOTION_M)] = np.nan
    if not np.isfinite(r).any():
        return None
    best = int(np.nanargmax(r))
    return float(offsets[best]), float(r[best]), float(np.nan_to_num(r[offsets.size // 2]))


def depth_off_its_stamps(t: np.ndarray, depth: np.ndarray, t_v: np.ndarray, v_down: np.ndarray
                         ) -> tuple[float, float, float] | None:
    """:func:`depth_clock_offset`'s ``(offset, correlation there, at 0)`` when it puts the depth on a clock of its own
    (:data:`DEPTH_CLOCK_MIN_S`, :data:`DEPTH_CLOCK_MIN_CORRELATION`, :data:`DEPTH_CLOCK_SSE_RATIO`), else None."""
    found = depth_clock_offset(t, depth, t_v, v_down)
    if found is None:
        return None
    offset, r, r0 = found
    if abs(offset) <= DEPTH_CLOCK_MIN_S or r < DEPTH_CLOCK_MIN_CORRELATION or \
            (1 - r0 ** 2) < DEPTH_CLOCK_SSE_RATIO * (1 - r ** 2):
        return None
    return found


def depth_convention(mission: Mission, meta: dict | None, field: str, declared: str | None = None,
                     key: str = "csv_columns.depth.positive", turned: bool = False) -> np.ndarray:
    """The depth of ``mission`` (m, positive down) checked against the vehicle's vertical velocity
    (:func:`vertical_velocity`, :func:`depth_rate_fit`): changing against it while mostly above the sea surface it is
    positive up, and flipped (a warning, a note); changing against it below the surface, changing at another rate
    (:data:`SAME_UNITS_RATIO`: a pressure in bar or dbar read as metres), or above the surface by more than
    :data:`DEPTH_ABOVE_SURFACE_M` on most samples with nothing to tell why are a DataError naming the depth's
    ``field``. A depth a constant atmosphere deeper than an absolute GT down is warned about (an absolute pressure in
    dbar read as metres; nothing else can tell it). ``declared``: the convention the configuration declares under
    ``key`` (down or up, applied by the reader: ``csv_columns.depth.positive`` for a column map,
    ``bag_topics.depth.positive`` for a bag): a depth then changing against the velocity is a DataError, not
    turned. ``turned``: the reader turned the depth, read as positive up (a bag's depth topic mostly above the
    surface, :func:`graphnav.io.bag_convert.turned_positive_up`): a DataError unless the velocity confirms it."""
    depth = mission.depth
    t_v, v_down, what = vertical_velocity(mission)
    k, r = depth_rate_fit(depth.t, depth.depth, t_v, v_down)
    decided = abs(r) >= DEPTH_FIT_MIN_CORRELATION
    fit = f"its changes are {k:.3g}x those of {what} over {POSITION_WINDOW_S:g} s windows (correlation {r:.2f})"
    above = float(np.median(depth.depth)) < -DEPTH_ABOVE_SURFACE_M
    extent = f"depth {np.min(depth.depth):.4g} to {np.max(depth.depth):.4g} m"
    if turned and not (decided and k > 0):
        raise DataError(f"read as positive up (its samples mostly above the sea surface) and turned, but the vertical "
                        f"motion does not confirm it: {fit}; declare {key} 'up' or 'down'", depth.source, field=field)
    if decided and k < 0 and declared is not None:
        raise DataError(f"declared positive {declared!r} ({key}), but {fit}: set it to "
                        f"{'up' if declared == 'down' else 'down'!r}", depth.source, field=field)
    if decided and k < 0 and float(np.median(-depth.depth)) >= -DEPTH_ABOVE_SURFACE_M:
        _note(meta, "depth", f"column '{field}' read as depth positive up and turned positive down: {extent} and {fit}",
              depth.source)
        return -depth.depth
    if decided and (k < 0 or _units_disagree(k)):
        raise DataError(f"the depth does not follow the vehicle's vertical motion: {fit} (1 for metres positive down; "
                        "-1 positive up; 0.098 for a pressure in bar): "
                        + ("a sign flipped in the depth or in the velocity" if k < 0 else
                           "a pressure mapped as 'depth'? map it as 'pressure' with its pressure_unit"),
                        depth.source, field=field)
    if above:
        raise DataError(f"{extent}: the vehicle above the sea surface by more than {DEPTH_ABOVE_SURFACE_M:g} m on most "
                        f"samples (depth is metres positive down); a depth positive up ({key} 'up' declares it), "
                        "or a zero not at the surface? "
                        + (fit if np.isfinite(k) else "the vertical motion is too small to tell"),
                        depth.source, field=field)
    _absolute_dbar(mission, meta, field)
    return depth.depth


def _absolute_dbar(mission: Mission, meta: dict | None, field: str) -> None:
    """Warn when the depth is a constant atmosphere (:data:`ATMOSPHERE_M`) deeper than the GT's down: an absolute
    pressure in dbar read as metres (a GT down relative to another zero could also give it, hence no error)."""
    depth, gt = mission.depth, mission.gt
    if gt is None or len(gt.t) < 2:
        return
    inside = (depth.t >= gt.t[0]) & (depth.t <= gt.t[-1])
    if inside.sum() < 10:
        return
    diff = depth.depth[inside] - np.interp(depth.t[inside], gt.t, gt.p_n[:, 2])
    offset, spread = float(np.median(diff)), float(np.percentile(diff, 95) - np.percentile(diff, 5))
    if abs(offset - ATMOSPHERE_M) <= ATMOSPHERE_SPREAD_M and spread <= ATMOSPHERE_SPREAD_M:
        _note(meta, "depth", f"column '{field}' is {offset:.3g} m deeper than the GT's down ({gt.source}) all along: "
              f"one atmosphere is {ATMOSPHERE_M:g} m of sea water: an absolute pressure in dbar read as metres? (dbar "
              "is read as gauge pressure; subtract the surface pressure)", depth.source)


# ------------------------------------------------------------------------------------------------
# the entry point
# ------------------------------------------------------------------------------------------------
def stamps_in_seconds(t: np.ndarray, stream: str, source: str, meta: dict | None = None,
                      expected_rate_hz: float | None = None, declared: str | None = None,
                      field: str = "t", lines: np.ndarray | None = None, key: str | None = None,
                      stream_key: str | None = None) -> np.ndarray:
    """Stamps ``t`` in seconds: the unit detected by :func:`time_scale` applied (warning and note when not
    s), or DataError. A span of more than a year (:func:`time_scale`) and an IMU gap longer than can be bridged are
    DataErrors here, naming the line (``lines``: the file line of each stamp) and ``field``: it is the stamps that
    are wrong, and a check of the other streams against them (a reference's positions against its velocity) would
    blame another file. ``key``: the configuration key a user ``declared`` the unit with (checked against the data;
    a unit a format fixes, a bag's nanoseconds, is not); ``stream_key``: :func:`time_scale`'s."""
    scale, unit = time_scale(t, stream, source, expected_rate_hz, field=field, declared=declared, lines=lines,
                             key=key, meta=meta, stream_key=stream_key)
    if scale != 1.0:
        if declared is None:
            _note(meta, stream, f"stamps read as {unit} (median step {np.median(np.diff(t)):.4g}, implausible as "
                  "seconds for this stream) and converted to s", source)
        t = np.asarray(t, float) * scale
    if stream == "imu":
        _imu_gaps(np.asarray(t, float), source, field, lines)
    return t


def _imu_gaps(t: np.ndarray, source: str, field: str, lines: np.ndarray | None) -> None:
    """:func:`graphnav.core.screening.check_imu_gap` on the longest step of stamps ``t`` (s, as read)."""
    from graphnav.core.screening import check_imu_gap
    step = np.diff(t)
    if not np.any(np.isfinite(step)):
        return
    i = int(np.nanargmax(step))
    check_imu_gap(float(t[i]), float(t[i + 1]), source, None if lines is None else int(lines[i + 1]), field)


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


#: What to do about a DVL velocity in other units (``"unit"``, after the likely unit), turned about z (``"yaw"``) or in
#: FLU axes (``"flu"``): a column map or bag declares its unit and frame (``"declare"``).
DECLARE_DVL_FIXES = {"declare": True, "unit": "",
                     "yaw": "declare csv_columns.dvl.frame 'instrument' with dvl.C_d_b (graphnav calibrate estimates "
                            "it and writes both)",
                     "flu": "declare csv_columns.dvl.frame 'flu'",
                     "y": "negate the y velocity column in the file (no configuration key mirrors a DVL frame: "
                          "dvl.C_d_b must be a rotation)"}
#: The same for a bag, whose message fixes its unit and axes: a mounting turn is given as ``dvl.C_d_b``.
BAG_DVL_FIXES = {**DECLARE_DVL_FIXES,
                 "yaw": "give the DVL's mounting as dvl.C_d_b in the configuration (graphnav calibrate estimates it)",
                 "y": "negate the velocity's y where the message is written (the driver): no configuration key "
                      "mirrors a DVL frame (dvl.C_d_b must be a rotation)"}
#: The same for an A-KIT folder, whose format is fixed (m/s; DVL columns in the DVL's frame, turned to body by
#: ``dvl.C_d_b``, identity unless a configuration gives it; the loader converts mm/s itself): a unit or FLU axes are
#: converted in the file, a mounting turn given as ``dvl.C_d_b``. ``"declare"`` False: a turn found is refused
#: (:func:`graphnav.calibration.dvl_scale.check_velocity_against_imu`), as the folder's GT check refuses it.
AKIT_DVL_FIXES = {"declare": False,
                  "unit": "convert the DVL velocity columns of the file to m/s (an A-KIT folder has no unit to "
                          "declare)",
                  "yaw": "give the DVL's mounting as dvl.C_d_b in a --config file (the turn about z above, undone; "
                         "graphnav calibrate estimates it against a GT), or turn the DVL velocity columns of the file "
                         "into the body frame",
                  "flu": "negate the y and z DVL velocity columns of the file (an A-KIT folder's are body FRD)",
                  "y": "negate the DVL Y column of the file (an A-KIT folder's are body FRD; no configuration key "
                       "mirrors a DVL frame: dvl.C_d_b must be a rotation)"}


__all__ = ["check_units", "DECLARE_DVL_FIXES", "BAG_DVL_FIXES", "AKIT_DVL_FIXES", "stamps_in_seconds", "imu_units",
           "dvl_units", "dvl_velocity_units", "dvl_values_in_mps", "say_mmps", "time_scale", "check_declared_time_span",
           "check_stamp_bound", "declared_scale", "gyro_tilt_scale", "gyro_tilt_fit", "dvl_speed_scale",
           "attitude_rate_ratio", "displacement_ratio", "vertical_sign", "reference_attitude_units",
           "reference_tilt_unit", "reference_turn_fit", "keep_reference_turn", "check_gyro_against_reference",
           "gyro_scale_found",
           "accelerometer_tilt", "reference_latlon_units", "reference_depth", "check_reference_displacement",
           "check_reference_axes", "horizontal_axes_fit", "reference_speed_error", "reference_inconsistencies"]
