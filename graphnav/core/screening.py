"""One screening mechanism for every sample: what a sensor cannot have measured never becomes a number.

The same rules serve the loaders (vectorised over a whole file) and the Navigator's stream (sample by
sample), so a recorded log and a live vehicle refuse the same samples for the same reasons:

* **Range** (the instrument's full scale, :class:`~graphnav.core.config.SensorConfig`): IMU specific force
  beyond ``imu.accel_range_mps2`` and rate beyond ``imu.gyro_range_rads`` per axis; a DVL beam beyond
  ``dvl.max_speed_mps`` (a beam is a projection of the velocity, so it cannot exceed the speed); a DVL
  velocity outside the vehicle's envelope (speed, ``|v_z|``); a depth outside ``depth_range_m``; a
  ground-truth velocity beyond the vehicle's speed.
* **Spikes** against recent samples: a value departing from the median of its neighbours by more than
  ``1.5 * max_rate * dt + tolerance`` (the vehicle cannot make and undo that change in dt; 1.5 dt bounds a
  reversal of the rate at the sample). Loaders use the neighbours on both sides (:func:`spike_mask`);
  the stream only has the past (:class:`SpikeTest`), and accepts a lasting change once ``reset_after``
  samples in a row agree with each other.
* **Stamps**: not finite, beyond :data:`MAX_STAMP_S` (1e300, or nanoseconds read as seconds), or a jump of
  more than :data:`MAX_STAMP_GAP_S` inside one stream (years): a DataError for a file, a refusal on a stream
  (:func:`stamp_problem`), checked before any loop runs over the stamps.

A refused sample is never used: loaders drop it (IMU, depth, GT rows) or mark it invalid (DVL beams) and
count it with its reason in ``Mission.meta["streams"]`` (:func:`refuse`); the Navigator counts it in its
``info``. When more than :data:`MAX_REFUSED_FRACTION` of a stream is refused the data are not what the
configuration describes, and the run ends with a :class:`~graphnav.core.errors.DataError` naming the stream
and the reasons (:func:`check_refused_fraction`) instead of a trajectory.

IMU rows get the range test and their own spike test (:func:`imu_spikes`, :class:`ImuSpikeTest`), which the rate
rule above cannot serve: vibration and shocks are real specific force and rate, with no rate of change to bound.
A row (or a run of up to :data:`IMU_SPIKE_HALF_WINDOW_S` of rows) is a spike when a value departs from the
running median of the rows within :data:`IMU_SPIKE_HALF_WINDOW_S` on each side by more than the larger of a physical
floor per sensor (``ImuSpec.accel_spike_floor_mps2``, ``gyro_spike_floor_rads``) and :data:`IMU_SPIKE_NOISE_FACTOR`
times the signal's local noise (the MAD of its first differences over blocks of :data:`IMU_SPIKE_SCALE_S`): a
vibrating IMU raises its own threshold, a quiet one keeps the floor. A departing value that got there over rows
(within that limit of the row before, which was kept and had begun to depart the same way: :func:`jumped`) is a shock
(a bump against the bottom or a dock) and kept: a spike jumps from the signal in one row, and the rest of its run
goes with it. The spans are in seconds and become rows at the
IMU's own rate (:func:`imu_spike_rows`); under :data:`IMU_SPIKE_MIN_RATE_HZ` the test is off, with a note. A row
with a NaN or infinite value (an empty cell, ``inf``) is refused too (:func:`not_finite`), before any other
rule looks at it, and so is a logger's all-zero filler (:func:`imu_filler`: no measurement, the gap it leaves
bridged as any IMU gap), before the unit, axis and clock checks judge the IMU by its rows (:func:`imu_unmeasured`);
filler whose stamp is zeroed too before the stamps are judged (:func:`zeroed_filler`). A run of rows without a
measurement, of whatever kind, leaving a gap too long to bridge is the IMU stopping (:func:`check_filler_gaps`), and
an IMU of more than :data:`MAX_FILLER_SHARE` filler delivered almost nothing (:func:`check_filler_share`).

When each IMU sample was taken (the IMU's rate from its stamps, samples a driver stamped together, a logger's clock
as coarse as the IMU's period, and restamping them) is decided in :mod:`graphnav.core.imu_timing`: the spike tests
take the rate from it, and :func:`stamp_order` has it restamp an IMU's stamps before they must increase.
"""
from __future__ import annotations

import bisect
import math
import re
import statistics
import warnings
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from graphnav.core.config import DvlSpec, SensorConfig
from graphnav.core.earth import gravity_magnitude
from graphnav.core.errors import DataError
from graphnav.core.imu_timing import (DIFF_MAD_TO_SIGMA, GAP_WARN_SAMPLES, awaits_packet_cycles, imu_rate_hz,
                                      imu_stamp_quantum, imu_step_stats, restamp_shared_stamps,
                                      samples_sharing_a_stamp, stamp_steps, stamped_in_packets, start_burst)
from graphnav.core.streams import add_note, count_doubted, count_refused, say_doubted, stream_entry

#: Largest stamp accepted, s (any clock: seconds since boot or the Unix epoch, 1e10 s being the year 2286).
#: A larger stamp is a unit error (micro/nanoseconds read as seconds) or a decoding error, never a time.
MAX_STAMP_S = 1e10
#: Largest step between consecutive stamps of one stream, s (one day). An AUV log never pauses a stream
#: for a day and resumes; a larger jump is a clock reset or a corrupted stamp, and looping over the time in
#: between (keyframes every second through a gap) would never end.
MAX_STAMP_GAP_S = 86400.0
#: A live stream whose IMU samples jumped that far ahead for this long, s of IMU samples at the configured rate,
#: had its clock stepped (one corrupted stamp is one sample): every sample after it would be refused, and the stream
#: stops there naming the jump.
CLOCK_JUMP_CONFIRM_S = 1.0
#: A sample of another stream stamped on the old clock within this of the last stamp before a clock jump, s, may have
#: been measured before the step and arrived late (a DVL ping behind the IMU); only one beyond it shows that stream
#: going on on the old clock (:attr:`StreamScreen.imu_alone`).
CLOCK_JUMP_LATE_S = 0.25
#: A stream with more than this fraction of its samples refused ends the run with a DataError.
MAX_REFUSED_FRACTION = 0.5
#: An IMU file with more than this share of its rows a logger's all-zero filler (:data:`IMU_FILLER`) ends the run with a
#: DataError: the IMU delivered almost nothing, and the DVL and reference lie mostly outside what it measured. Filler
#: is no share of bad data (:func:`measurements`): 60 % of a file at its start is an IMU that started late, and read.
MAX_FILLER_SHARE = 0.9
#: Neighbours on each side (loaders) or in the past (stream) whose median a sample is compared with.
SPIKE_NEIGHBOURS = 3
#: IMU spike test, in seconds (rows: these spans times the IMU's own rate, from its stamps). Half the window whose
#: median a row is compared with (on each side for the loaders; the accepted rows before it for the stream), and the
#: longest run of departing rows refused as a spike: a longer one is a lasting change and kept (the stream accepts it
#: from its next row on). 10 rows at 100 Hz, where the test was validated.
IMU_SPIKE_HALF_WINDOW_S = 0.1
#: Span of a block of the IMU's local noise scale (the MAD of the first differences of each block), s.
IMU_SPIKE_SCALE_S = 1.0
#: Below this IMU rate the spike test is off (a note says so): its half window holds under 5 rows, and a row is
#: as long as the runs it refuses, so a turn's onset or wave roll departs from a median of a few rows as a spike
#: does (docs/decisions/screening.md).
IMU_SPIKE_MIN_RATE_HZ = 50.0
#: A rate measured this close under :data:`IMU_SPIKE_MIN_RATE_HZ` (relative) is at it: stamps on a clock's grid leave
#: a 50 Hz IMU's rate up to a grid step over their span off (49.98 Hz over 30 s in whole 10 ms), which switched its
#: test off.
IMU_SPIKE_RATE_TOLERANCE = 0.01
#: Stamps the stream measures the IMU's rate from before its spike test starts; stamps on a grid
#: (:func:`imu_stamp_quantum`) as many more as bring a grid step under half :data:`IMU_SPIKE_RATE_TOLERANCE` of their
#: span (a 50 Hz IMU in whole 10 ms read 47.62 Hz over eleven, 2 s over 101).
IMU_SPIKE_RATE_ROWS = 11
#: A spike departs from the running median by more than this many local noise scales (and the floor). The ten
#: A-KIT trajectories depart by at most 14.3 (simulated IMUs: 7.1); docs/decisions/screening.md.
IMU_SPIKE_NOISE_FACTOR = 30.0
#: A departing IMU value is a shock's, and kept, when the row before it departed the same way by at least this fraction
#: of the limit (3 noise scales, 0.5 m/s^2 at the accelerometers' floor: the shock had begun) and is within the limit
#: of it (the value rose there over rows); with it, single-row spikes of exactly the floors are refused as often as
#: when no shock was kept (docs/decisions/screening.md, "Shocks are not spikes").
IMU_SHOCK_ONSET = 0.1
#: A run of rows with a departing specific force (a knock, or a burst of bad samples) is judged by the DVL when it is
#: there: a knock changes the velocity by the run's integral (its departure from the median times dt, with the rows
#: either side leaning its way: a knock's onset and tail), a burst does not. The DVL's change between the nearest
#: valid pings before and after the run, each within :data:`IMU_SHOCK_DVL_GAP_S` of it, less what the signal without
#: the run says the vehicle did, is compared with the integral; the verdict needs them this many times the scatter of
#: that on the ping intervals within :data:`IMU_SHOCK_DVL_SPAN_S` (1.4826 MAD), else the shape rule (:func:`jumped`)
#: decides (docs/decisions/screening.md, "A knock the DVL saw").
IMU_SHOCK_DVL_SIGMAS = 3.0
IMU_SHOCK_DVL_GAP_S = 2.0
IMU_SHOCK_DVL_SPAN_S = 30.0
#: Half the window of the longer median a burst of bad samples departs from when it outlasts the spike test's half
#: window (which then follows it), s: bursts of up to this are judged by the DVL (only refused when it denies them).
IMU_SHOCK_LONG_HALF_WINDOW_S = 2.0
#: Count key of the IMU rows of a knock the DVL saw (kept, doubted: ``meta["streams"]["imu"]["doubted"]``).
IMU_SHOCK_KEPT = "shock kept (the DVL saw its velocity change)"
#: A run of IMU rows each repeating the row before it in all six values over at least this long, s, is a stalled
#: sensor (a driver re-sending its last reading): a real IMU's noise changes some value every row (the ten A-KIT
#: trajectories: no row repeats the one before it), and 0.5 s of one reading integrates a 1 m/s^2 error into 0.5 m/s.
IMU_STALL_MIN_S = 0.5
#: ... when, within this long either side of the run, s, under this share of the rows repeat the row before them: an
#: IMU whose counts are coarser than its noise (at rest, 1e-3 rad/s counts) repeats rows everywhere, and is kept.
IMU_STALL_CONTEXT_S = 1.0
IMU_STALL_CONTEXT_REPEAT_SHARE = 0.1
#: ... and when the reading repeated is not one of a vehicle at rest: a specific force within this of gravity's size,
#: m/s^2 (gravity's spread over latitudes, 0.05, and 5 mg counts), turning no faster than this, rad/s. A quiet IMU at
#: rest on counts coarser than its noise repeats one reading for as long as it rests while the vibration around it
#: changes every row; a stall on such a reading integrates as the rest it reads.
IMU_REST_FORCE_TOL = 0.1
IMU_REST_RATE_TOL = 2e-3
#: The size of gravity a reading at rest is held against, m/s^2: midway between the equator's and the poles' (9.806,
#: each 0.026 off).
_GRAVITY_MID = (gravity_magnitude(0.0) + gravity_magnitude(math.pi / 2)) / 2
IMU_STALLED = f"stalled (repeats the row before it in every value for {IMU_STALL_MIN_S:g} s or more)"
#: The count key of a live IMU's samples repeating one reading as long as a stall does with under a second of
#: samples before it (the stream's first second, or just after an IMU gap), used though doubted
#: (:meth:`ImuStallTest.untold`).
IMU_STALL_UNTOLD = (f"repeats the row before it in every value for {IMU_STALL_MIN_S:g} s or more with under "
                    f"{IMU_STALL_CONTEXT_S:g} s of samples before it (the stream's first second or an IMU gap: a "
                    "stall not told from an IMU repeating from its start)")
#: Reason of an IMU row with all six values exactly 0 (:func:`imu_filler`): a logger's filler while the IMU delivered
#: nothing (a real accelerometer reads gravity's specific force), dropped as no measurement, the gap it leaves
#: bridged as any IMU gap. It is silence, not a bad sample: no share of it makes a stream's data wrong
#: (:func:`over_refused_limit`), but an IMU almost all silent delivered almost nothing (:func:`check_filler_share`).
IMU_FILLER = "all-zero IMU row (a logger's filler: zero specific force is impossible under gravity)"
#: Reason of an IMU row whose three accelerometer values are exactly 0 and the gyro's not all (:func:`imu_unmeasured`):
#: a dead accelerometer beside a live gyro, no measurement of the specific force (gravity's is never 0). Counted as
#: bad data: 5 s of them beside a live gyro were kept without a word, as 5 s of free fall (400 s simulated).
ACCEL_ZERO = ("accelerometer all zero beside a live gyro (a dead accelerometer: zero specific force is impossible "
              "under gravity)")
#: Names of the IMU's six values, in the order of ``f_b`` then ``omega_b`` (reasons and warnings of loaders whose
#: files have no column names of their own).
IMU_FIELDS = ("f_b x", "f_b y", "f_b z", "omega_b x", "omega_b y", "omega_b z")
#: A DVL stream silent for longer than this many nominal ping periods (and at least this many seconds) is an
#: outage worth a warning.
OUTAGE_PERIODS = 5.0
OUTAGE_MIN_S = 10.0


# ------------------------------------------------------------------------------------------------
# stamps
# ------------------------------------------------------------------------------------------------
def stamp_problem(t, previous: float | None = None) -> str | None:
    """Why the stamp t (s) cannot be used after ``previous`` (the newest stamp of its stream), or None."""
    try:
        t = float(t)
    except (TypeError, ValueError):
        return "stamp is not a number"
    if not math.isfinite(t):
        return "stamp is not a finite number"
    if abs(t) > MAX_STAMP_S:
        return (f"stamp {t:.6g} s is beyond {MAX_STAMP_S:g} s (micro/nanoseconds read as seconds, or a "
                "corrupted stamp)")
    return None if previous is None else stamp_jumps(t, previous)


def stamp_jumps(t: float, previous: float) -> str | None:
    """Why the stamp t (s, a number within :data:`MAX_STAMP_S`) is too far from ``previous`` (the newest stamp of its
    stream, s), ahead of it or behind it: more than :data:`MAX_STAMP_GAP_S` (days to years: a clock reset or a
    corrupted stamp; a stamp days in the past is as far off its stream's clock as one days ahead), or None."""
    if math.isfinite(previous) and abs(t - previous) > MAX_STAMP_GAP_S:
        return (f"stamp jumps {abs(t - previous):.6g} s {jump_direction(previous, t, 'the stream')} (more "
                f"than {MAX_STAMP_GAP_S:g} s)")
    return None


def jump_direction(before: float, after: float, of: str | None = None) -> str:
    """Which way the stamp ``after`` (s) is off ``before`` (s), in the words every message about a stamp off its clock
    uses: "ahead" or "back", or off ``of`` (what it is off: "the stream"): "ahead of ..." or "behind ..."."""
    if of is None:
        return "ahead" if after > before else "back"
    return f"{'ahead of' if after > before else 'behind'} {of}"


def clock_jump_words(before: float, after: float) -> str:
    """How far and which way a clock jumped from the stamp ``before`` to ``after`` (s): e.g. "172800 s ahead",
    "1.7e+09 s back"."""
    return f"{abs(after - before):.6g} s {jump_direction(before, after)}"


def check_stamps(t: np.ndarray, source: str, field: str = "t") -> None:
    """Raise :class:`DataError` when the stamps (s, sorted) are not finite, beyond :data:`MAX_STAMP_S` or jump
    by more than :data:`MAX_STAMP_GAP_S`, naming the sample (:meth:`DataError.at_sample`)."""
    t = np.asarray(t, float)
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise DataError.at_sample("time stamp is not finite", source, int(bad[0]), field)
    bad = np.flatnonzero(np.abs(t) > MAX_STAMP_S)
    if bad.size:
        raise DataError.at_sample(f"time stamp {t[bad[0]]:.6g} s is beyond {MAX_STAMP_S:g} s ({bad.size} such "
                                  "stamp(s); micro/nanoseconds read as seconds, or corrupted)", source, int(bad[0]),
                                  field)
    jump = stamp_jump(t)
    if jump is not None:
        raise DataError.at_sample(jump[1], source, jump[0], field)


def stamp_jump(t: np.ndarray) -> tuple[int, str] | None:
    """``(index, why)`` of the first stamp (s, sorted) more than :data:`MAX_STAMP_GAP_S` from the one before it (a
    clock reset or a corrupted stamp), or None."""
    t = np.asarray(t, float)
    jump = np.flatnonzero(np.abs(np.diff(t)) > MAX_STAMP_GAP_S) if t.size > 1 else []
    if not len(jump):
        return None
    i = int(jump[0]) + 1
    return i, (f"time stamp jumps by {t[i] - t[i - 1]:.6g} s ({t[i - 1]:.6g} s then {t[i]:.6g} s), more than "
               f"{MAX_STAMP_GAP_S:g} s inside one stream (a clock reset or corrupted stamp)")


def stamp_outliers(t: np.ndarray) -> np.ndarray:
    """Mask of stamps (s, file order) that are not times: not finite, beyond :data:`MAX_STAMP_S`, or an isolated
    stamp more than :data:`MAX_STAMP_GAP_S` from both neighbours (one corrupted row in an otherwise regular
    file). What remains may still jump (a real clock reset): :func:`check_stamps` reports that."""
    t = np.asarray(t, float)
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(t) | (np.abs(t) > MAX_STAMP_S)
    idx = np.flatnonzero(~bad)
    if idx.size > 2:
        ti = t[idx]
        far_prev = np.r_[False, np.abs(np.diff(ti)) > MAX_STAMP_GAP_S]
        far_next = np.r_[np.abs(np.diff(ti)) > MAX_STAMP_GAP_S, False]
        lone = far_prev & far_next
        lone[-1] = far_prev[-1]          # a corrupted last row has one neighbour only
        lone[0] = far_next[0] and not far_next[1]
        bad[idx[lone]] = True
    return bad


# ------------------------------------------------------------------------------------------------
# vectorised rules (loaders)
# ------------------------------------------------------------------------------------------------
def spike_mask(t: np.ndarray, x: np.ndarray, max_rate: float, tolerance: float,
               neighbours: int = SPIKE_NEIGHBOURS, usable: np.ndarray | None = None) -> np.ndarray:
    """Samples departing from the component-wise median of the ``neighbours`` usable samples on each side by
    more than ``1.5 * max_rate * dt + tolerance`` (dt: spacing to the nearest usable sample, s): a spike the
    signal makes and undoes, while a lasting change is kept.

    Args:
        t: (N,) s. x: (N,) or (N,k) values (NaN rows are never flagged nor used as neighbours).
        max_rate: largest rate of change of x (units of x per s). tolerance: the sensor's noise (units of x).
        usable: (N,) bool, samples that may serve as neighbours and be tested (default: the finite ones).
    """
    t = np.asarray(t, float)
    v = np.asarray(x, float)
    v = v[:, None] if v.ndim == 1 else v
    ok = np.all(np.isfinite(v), axis=1) if usable is None else np.asarray(usable, bool) & np.all(np.isfinite(v), axis=1)
    out = np.zeros(len(v), dtype=bool)
    idx = np.flatnonzero(ok)
    n = neighbours
    if idx.size > 2:
        vi, ti = v[idx], t[idx]
        pad = np.full((n, v.shape[1]), np.nan)
        win = np.lib.stride_tricks.sliding_window_view(np.concatenate([pad, vi, pad]), 2 * n + 1, axis=0)
        ref = np.nanmedian(np.delete(win, n, axis=2), axis=2)
        gaps = np.diff(ti)
        dt = np.minimum(np.concatenate([[np.inf], gaps]), np.concatenate([gaps, [np.inf]]))
        out[idx] = np.linalg.norm(vi - ref, axis=1) > 1.5 * max_rate * dt + tolerance
    return out


def implausible_pings(t: np.ndarray, v_b: np.ndarray, spec: DvlSpec) -> dict[str, np.ndarray]:
    """Pings whose reported velocity this vehicle cannot have (envelope of :class:`DvlSpec`).

    Args:
        t: (M,) ping stamps, s. v_b: (M,3) reported DVL velocity, body frame, m/s (NaN rows = invalid pings,
            never flagged). spec: ``max_speed_mps``, ``max_vertical_mps``, ``max_accel_mps2``,
            ``jump_tolerance_mps``.

    Returns:
        ``{"speed": mask, "vertical": mask, "jump": mask}`` (M,) bool, disjoint (a ping is counted under the
        first reason it fails); a jump is a :func:`spike_mask` with ``max_accel_mps2`` and
        ``jump_tolerance_mps`` among the pings that pass speed and vertical.
    """
    v = np.asarray(v_b, float)
    ok = np.all(np.isfinite(v), axis=1)
    speed = ok & (np.linalg.norm(np.where(ok[:, None], v, 0.0), axis=1) > spec.max_speed_mps)
    vertical = ok & ~speed & (np.abs(np.where(ok, v[:, 2], 0.0)) > spec.max_vertical_mps)
    jump = spike_mask(t, v, spec.max_accel_mps2, spec.jump_tolerance_mps, usable=ok & ~speed & ~vertical)
    return {"speed": speed, "vertical": vertical, "jump": jump}


def describe_implausible(masks: dict[str, np.ndarray], spec: DvlSpec) -> str:
    """'N speed, N vertical, N jump' with the limits, for warnings."""
    limits = {"speed": f"speed > {spec.max_speed_mps:g} m/s", "vertical": f"|v_z| > {spec.max_vertical_mps:g} m/s",
              "jump": f"jump > 1.5*{spec.max_accel_mps2:g} m/s^2*dt + {spec.jump_tolerance_mps:g} m/s"}
    return ", ".join(f"{int(m.sum())} {limits[k]}" for k, m in masks.items() if m.any())


def imu_out_of_range(f_b: np.ndarray, omega_b: np.ndarray, config: SensorConfig) -> dict[str, np.ndarray]:
    """IMU rows beyond the instrument's full scale: ``{"f_b beyond accel_range_mps2": mask, "omega_b beyond
    gyro_range_rads": mask}`` (N,) bool, disjoint (NaN counts as beyond)."""
    with np.errstate(invalid="ignore"):
        acc = ~np.all(np.abs(np.asarray(f_b, float)) <= config.imu.accel_range_mps2, axis=1)
        gyro = ~acc & ~np.all(np.abs(np.asarray(omega_b, float)) <= config.imu.gyro_range_rads, axis=1)
    return {f"f_b beyond {config.imu.accel_range_mps2:g} m/s^2": acc,
            f"omega_b beyond {config.imu.gyro_range_rads:g} rad/s": gyro}


def _by_first_field(hit: np.ndarray, fields, reason: str) -> dict[str, np.ndarray]:
    """``{reason.format(name): mask}`` (N,) bool per field of the (N,k) ``hit``, disjoint: a row goes under the
    first of the ``fields`` it is hit in."""
    first = np.where(hit.any(axis=1), np.argmax(hit, axis=1), -1)
    return {reason.format(name): first == j for j, name in enumerate(fields)}


def not_finite(values: np.ndarray, fields) -> dict[str, np.ndarray]:
    """Rows with a NaN value (what an empty cell reads as) or an infinite one (``inf``, ``Infinity``, ``1e999``):
    ``{"empty or NaN in '<field>'": mask, ..., "infinite in '<field>'": mask, ...}`` (N,) bool for each of the
    ``fields`` (the k columns of ``values`` (N,k)), disjoint (a row under its first NaN field, else its first
    infinite one)."""
    values = np.asarray(values, float)
    nan = np.isnan(values)
    infinite = np.isinf(values) & ~nan.any(axis=1, keepdims=True)
    return {**_by_first_field(nan, fields, "empty or NaN in '{}'"),
            **_by_first_field(infinite, fields, "infinite in '{}'")}


def imu_noise_scale(x: np.ndarray, block: int) -> np.ndarray:
    """(N,k) local noise scale of the signals ``x`` (N,k) (finite, file order), per row and column, units of x:
    ``1.4826 / sqrt(2)`` times the median absolute first difference of each block of ``block`` rows (a white
    noise's sigma; a shorter last block joins the one before), the larger of the row's block and its two
    neighbours (vibration that starts inside a block)."""
    x = np.asarray(x, float)
    d = np.abs(np.diff(x, axis=0))
    n_blocks = max(1, len(d) // block)
    full = (n_blocks - 1) * block
    s = np.empty((n_blocks, x.shape[1]))
    if n_blocks > 1:
        s[:-1] = np.median(d[:full].reshape(n_blocks - 1, block, -1), axis=1)
    s[-1] = np.median(d[full:], axis=0) if len(d) else 0.0
    s *= DIFF_MAD_TO_SIGMA
    s = np.max([s, np.r_[s[:1], s[:-1]], np.r_[s[1:], s[-1:]]], axis=0)
    return s[np.minimum(np.arange(len(x)) // block, n_blocks - 1)]


def imu_spike_floors(config: SensorConfig) -> np.ndarray:
    """(6,) the spike test's floor per IMU value (f_b m/s^2, omega_b rad/s), from ``config.imu``."""
    imu = config.imu
    return np.repeat([float(imu.accel_spike_floor_mps2), float(imu.gyro_spike_floor_rads)], 3)


def imu_spike_rows(rate_hz: float) -> tuple[int, int] | None:
    """(half window, noise block) of the IMU spike test in rows at ``rate_hz`` (:data:`IMU_SPIKE_HALF_WINDOW_S`,
    :data:`IMU_SPIKE_SCALE_S`); None when the test is off: the rate is under :data:`IMU_SPIKE_MIN_RATE_HZ` or
    unknown (NaN); a rate within :data:`IMU_SPIKE_RATE_TOLERANCE` under it is at it."""
    if not rate_hz >= IMU_SPIKE_MIN_RATE_HZ * (1.0 - IMU_SPIKE_RATE_TOLERANCE):
        return None
    return max(1, round(IMU_SPIKE_HALF_WINDOW_S * rate_hz)), max(2, round(IMU_SPIKE_SCALE_S * rate_hz))


def imu_spike_off_note(rate_hz: float) -> str:
    """Why the IMU spike test is off at ``rate_hz`` (a stream note and a warning)."""
    rate = "of unknown rate (fewer than two distinct stamps)" if math.isnan(rate_hz) else f"at {rate_hz:.4g} Hz"
    return (f"IMU spike test off: the IMU runs {rate}, under {IMU_SPIKE_MIN_RATE_HZ:g} Hz, where its "
            f"{2 * IMU_SPIKE_HALF_WINDOW_S:g} s window holds too few rows to tell a spike from the vehicle's own "
            "motion (a turn, wave roll); the full-scale test still applies")


def imu_spikes(t: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray, config: SensorConfig, fields=IMU_FIELDS,
               usable: np.ndarray | None = None, rate_hz: float | None = None, dvl: tuple | None = None,
               kept: list | None = None) -> dict[str, np.ndarray]:
    """IMU rows with a value departing from the median of the usable rows within ``IMU_SPIKE_HALF_WINDOW_S`` on each
    side of it by more than ``max(floor, IMU_SPIKE_NOISE_FACTOR * local noise)`` (:func:`imu_spike_floors`,
    :func:`imu_noise_scale` over blocks of ``IMU_SPIKE_SCALE_S``): ``{"spike in '<field>'": mask}`` (N,) bool per value,
    disjoint (a row under its first spiking value), but for a shock's (:func:`_not_shocks`: a departing value that did
    not :func:`jump <jumped>` there from the value before, itself kept, rose there over rows). The spans become rows at
    the rate of the usable rows' stamps (:func:`imu_spike_rows`); under ``IMU_SPIKE_MIN_RATE_HZ`` nothing is refused
    (:func:`imu_implausible` notes it).


    A run of up to the half window is a minority of every window it is in, so the median stays on the signal; a
    lasting change (a step, a turn) moves the median with it and is kept. The windows reflect at the ends of the
    stream (the first and last rows are tested too); fewer than a window of usable rows is not tested.

    Args:
        t: (N,) stamps, s (file order). f_b: (N,3) specific force, m/s^2. omega_b: (N,3) angular rate, rad/s (body
            axes, any sign convention).
        config: ``config.imu`` holds the floors. fields: names of the six values (reasons and warnings).
        usable: (N,) bool rows that may be tested and serve as neighbours (default: the finite ones; all-zero rows
            never are: they are a logger's filler, which :func:`imu_implausible` refuses).
        rate_hz: the IMU's rate, Hz, when the caller has it (default: :func:`imu_rate_hz` of the usable rows'
            stamps).
        dvl: ``(t (M,) s on the IMU's clock, v (M,3) m/s)``, the DVL's velocity in the IMU's axes (any sign per axis;
            NaN: no measurement): a run of departing specific force it judges is kept or refused as it says
            (:func:`_dvl_verdicts`). kept: a list that gets ``(first stamp s, last stamp s, rows, integral m/s, what
            the DVL saw m/s, field)`` of each run kept on the DVL's word.
    """
    x = np.hstack([np.asarray(f_b, float), np.asarray(omega_b, float)])
    # an all-zero row is a logger's filler with a rule of its own (imu_filler)
    ok = np.all(np.isfinite(x), axis=1) & np.any(x != 0.0, axis=1)
    if usable is not None:
        ok &= np.asarray(usable, bool)
    idx = np.flatnonzero(ok)
    out = np.zeros(x.shape, dtype=bool)
    # the rate from every row that may be tested (a filler row keeps its stamp), as imu_implausible's note
    if rate_hz is None:
        rate_hz = imu_rate_hz(np.asarray(t, float)[slice(None) if usable is None else usable])
    rows = imu_spike_rows(rate_hz)
    if rows is not None and idx.size >= 2 * rows[0] + 1:
        half, block = rows
        v = x[idx]
        median = _column_medians(v, 2 * half + 1)
        limit = np.maximum(imu_spike_floors(config), IMU_SPIKE_NOISE_FACTOR * imu_noise_scale(v, block))
        out[idx] = _not_shocks(v, median, limit)
        if dvl is not None:
            ts = np.asarray(t, float)[idx]
            measured = _dvl_measured(dvl, config.dvl)
            out[idx] = _dvl_verdicts(ts, v, median, limit, out[idx], measured, 1.0 / rate_hz, fields, kept)
            # a burst longer than the half window moves the median with it: a longer one sees it depart
            longer = _column_medians(v, 2 * round(IMU_SHOCK_LONG_HALF_WINDOW_S * rate_hz) + 1)
            out[idx] = _dvl_verdicts(ts, v, longer, limit, out[idx], measured, 1.0 / rate_hz, fields, longer_than=half)
    return _by_first_field(out, fields, "spike in '{}'")



def _column_medians(v: np.ndarray, size: int) -> np.ndarray:
    """The running median of each column of ``v`` (N, K) over ``size`` rows (mirrored at the ends). Column by column:
    scipy's 2-D filter with a (size, 1) footprint gives the same values but ranks through a generic footprint, 45x
    slower for the 4 s median on a 1.5 h log."""
    from scipy.ndimage import median_filter
    return np.column_stack([median_filter(v[:, k], size=size, mode="mirror") for k in range(v.shape[1])])


def _dvl_measured(dvl: tuple, spec: DvlSpec) -> tuple[np.ndarray, np.ndarray]:
    """``(t (K,), v (K,3))`` of ``dvl`` (:func:`imu_spikes`) the pings that can be measurements: finite, not all 0 (no
    bottom lock) and within ``spec.max_speed_mps`` (not an RDI flag); a loader judges them further afterwards."""
    t, v = (np.asarray(a, float) for a in dvl)
    with np.errstate(invalid="ignore"):
        ok = (np.linalg.norm(v, axis=1) <= spec.max_speed_mps) & np.any(v != 0.0, axis=1)
    return t[ok], v[ok]


def _dvl_verdicts(t: np.ndarray, v: np.ndarray, median: np.ndarray, limit: np.ndarray, refused: np.ndarray,
                  dvl: tuple, dt: float, fields, kept: list | None = None, longer_than: int = 0) -> np.ndarray:
    """``refused`` (N,6) with the DVL's verdict (:func:`_dvl_says`) on each run of rows whose specific force departs
    from ``median`` (N,6) by more than ``limit`` (6,) (rows ``v`` (N,6) at ``t`` (N,) s, ``dt`` s apart; ``dvl`` from
    :func:`_dvl_measured`), integrated with the rows either side leaning its way on the axis its departure sums
    largest on (:func:`_leaning`: a knock's onset and tail under the limit). A burst: refused with those rows, on that
    axis. A knock: its accelerometer values kept (the gyro keeps its own verdict), and each run kept that was refused
    appended to ``kept`` when given (:func:`imu_spikes`). With ``longer_than`` rows (runs of a longer median: shorter
    ones are the spike test's), only runs longer than that, from the value that jumped there on (:func:`_not_shocks`),
    and only bursts are refused."""
    if len(dvl[0]) < 2 * SPIKE_NEIGHBOURS + 2:
        return refused
    out = refused.copy()
    departure = v - median
    ratio = np.abs(departure) / limit
    departing = _not_shocks(v, median, limit) if longer_than else ratio > 1.0
    edges = np.flatnonzero(np.diff(np.r_[0, departing[:, :3].any(axis=1), 0]))
    pings = _DvlPings.of(dvl, t, median, dt) if edges.size else None
    for a, b in zip(edges[::2], edges[1::2]):
        j = int(np.argmax(np.abs(departure[a:b, :3].sum(axis=0))))
        # a knock's onset and tail under the limit change the velocity too: the run is integrated with them
        run = _leaning(departure[:, j], ratio[:, j] > IMU_SHOCK_ONSET, a, b)
        integral = departure[run, :3].sum(axis=0) * dt
        verdict, seen = _dvl_says(t[a], t[b - 1], integral, j, pings) if b - a > longer_than else (None, 0.0)
        if verdict == "burst":
            out[run, j] = True
        elif verdict == "knock" and not longer_than:
            out[a:b, :3] = False
            if kept is not None and refused[a:b].any():     # the DVL's word kept it (the shape rule keeps a rise)
                rows = int((~out[a:b].any(axis=1)).sum())
                kept.append((float(t[a]), float(t[b - 1]), rows, float(integral[j]), seen, fields[j]))
    return out


@dataclass
class _DvlPings:
    """The DVL's pings against the IMU's signal without its departing runs (:func:`_dvl_says`): stamps ``t`` (K,) s,
    velocity ``v`` (K,3) m/s, the signal integrated to each ping ``own`` (K,3) m/s; per ping interval and axis sign
    (+1, -1), the ``rate`` (2,K-1,3) m/s^2 at which that integral and the DVL's change (times the sign) part, and the
    ``residual`` (2,K-1,3) m/s of each interval from its neighbours' rate (:func:`_neighbours_rate`); ``signs`` (2,3)
    bool: the signs tried, those whose residuals scatter by at most twice the other's over the record (a vehicle that
    moved along an axis tells its sign, a still one does not)."""
    t: np.ndarray
    v: np.ndarray
    own: np.ndarray
    rate: np.ndarray
    residual: np.ndarray
    signs: np.ndarray

    @classmethod
    def of(cls, dvl: tuple, t: np.ndarray, median: np.ndarray, dt: float) -> _DvlPings:
        tp, vp = dvl
        integral = np.vstack([np.zeros(3), np.cumsum(median[:, :3], axis=0) * dt])
        own = np.column_stack([np.interp(tp, np.r_[t, t[-1] + dt], integral[:, k]) for k in range(3)])
        h = np.diff(tp)[:, None]
        rate = (np.diff(own, axis=0) - _SIGNS[:, None] * np.diff(vp, axis=0)) / h
        residual = np.stack([rate[:, k] - _neighbours_rate(rate, k, k + 1) for k in range(len(h))], axis=1) * h
        scatter = np.median(np.abs(residual), axis=1)
        return cls(tp, vp, own, rate, residual, scatter <= 2.0 * scatter.min(axis=0))


#: The two signs an IMU axis may have against the DVL's before ``prepare`` knows them.
_SIGNS = np.array([[1.0], [-1.0]])


def _neighbours_rate(rate: np.ndarray, k0: int, k1: int) -> np.ndarray:
    """(2,3) median of ``rate`` (2,K,3) over the :data:`SPIKE_NEIGHBOURS` intervals before ``k0`` and from ``k1`` on:
    gravity, turns and biases, which change no velocity, and the slow part of the vehicle's own acceleration."""
    n = SPIKE_NEIGHBOURS
    return np.median(np.concatenate([rate[:, max(0, k0 - n):k0], rate[:, k1:k1 + n]], axis=1), axis=1)


def _dvl_says(t0: float, t1: float, integral: np.ndarray, j: int, pings: _DvlPings) -> tuple[str | None, float]:
    """Whether the DVL saw a run of departing specific force from ``t0`` to ``t1`` s integrating to ``integral``
    (3,) m/s (largest on axis ``j``): ("knock", what it saw on ``j`` m/s), ("burst", 0) or (None, 0): it cannot tell.

    What the DVL saw of the run is its velocity change between the pings either side (within
    :data:`IMU_SHOCK_DVL_GAP_S`) less what the signal without the run says the vehicle did there, once the rate at
    which the two part on the :data:`SPIKE_NEIGHBOURS` intervals either side (gravity, turns, biases) is taken off.
    The noise is the scatter of that on the intervals within :data:`IMU_SHOCK_DVL_SPAN_S` (1.4826 MAD, times
    :data:`IMU_SHOCK_DVL_SIGMAS` and the square root of the intervals spanned). The IMU's axis signs are not known
    before ``prepare``: either sign of each axis the record does not decide (``pings.signs``) is tried. A knock: on
    every axis what the DVL saw matches the integral within the noise under a sign tried, and on ``j`` it stands out
    of the noise and the integral out of twice it (a burst's zero cannot match it by chance). A burst: on ``j`` the
    integral stands out of the noise and what the DVL saw misses it under every sign tried and is within the noise of
    nothing under one (a DVL that saw something else cannot call it a burst), or the DVL's whole change falls short of
    the integral by the noise of its own changes (where turns and waves swamp the signal's noise)."""
    tp, vp, own = pings.t, pings.v, pings.own
    i0, i1 = np.searchsorted(tp, t0) - 1, np.searchsorted(tp, t1, side="right")
    if i0 < 0 or i1 >= len(tp) or max(t0 - tp[i0], tp[i1] - t1) > IMU_SHOCK_DVL_GAP_S:
        return None, 0.0
    near = np.abs(0.5 * (tp[1:] + tp[:-1]) - t0) <= IMU_SHOCK_DVL_SPAN_S
    near[max(0, i0 - SPIKE_NEIGHBOURS):i1 + SPIKE_NEIGHBOURS] = False     # intervals whose baseline holds the run
    if not near.any():
        return None, 0.0
    sigmas = IMU_SHOCK_DVL_SIGMAS * 1.4826      # of a median absolute deviation
    noise = sigmas * np.median(np.abs(pings.residual[:, near]), axis=1) * math.sqrt(i1 - i0)
    baseline = _neighbours_rate(pings.rate, i0, i1) * (tp[i1] - tp[i0])
    seen = _SIGNS * (vp[i1] - vp[i0]) - (own[i1] - own[i0] - baseline)                                 # (2,3)
    match = (np.abs(seen - integral) <= noise) & pings.signs
    nothing = (np.abs(seen[:, j]) < noise[:, j]) & pings.signs[:, j]     # what a burst leaves, under each sign
    stands = match[:, j] & ~nothing & (abs(integral[j]) >= 2.0 * noise[:, j])
    if match.any(axis=0).all() and stands.any():
        return "knock", float(seen[int(np.argmax(stands)), j])
    denied = not match[:, j].any() and nothing.any() and abs(integral[j]) >= noise[pings.signs[:, j], j].max()
    steps = np.abs(np.diff(vp[:, j]))[near]
    denied |= abs(integral[j]) - abs(vp[i1, j] - vp[i0, j]) >= sigmas * np.median(steps)
    return ("burst" if denied else None), 0.0


def _leaning(departure: np.ndarray, onset: np.ndarray, a: int, b: int) -> slice:
    """Rows ``a:b`` of a run of bad samples and the rows either side of it whose ``departure`` (N,) leans its way
    (``onset`` (N,): by more than :data:`IMU_SHOCK_ONSET` of the limit): the shoulders of a burst that ramps."""
    sign = np.sign(departure[a:b].sum())
    while a > 0 and onset[a - 1] and np.sign(departure[a - 1]) == sign:
        a -= 1
    while b < len(departure) and onset[b] and np.sign(departure[b]) == sign:
        b += 1
    return slice(a, b)


def imu_stalled(t: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray) -> np.ndarray:
    """(N,) bool IMU rows of a stalled sensor: in each run of rows repeating the row before them in all six values
    (``f_b`` m/s^2, ``omega_b`` rad/s, (N,3) each) that lasts :data:`IMU_STALL_MIN_S` or longer by the stamps ``t``
    (N,) s, the repeats (the first row of the run was read), unless the IMU repeats rows around the run as well
    (:data:`IMU_STALL_CONTEXT_S`, :data:`IMU_STALL_CONTEXT_REPEAT_SHARE`: counts coarser than its noise), has no
    finite row there to tell (a noise-free IMU repeating one reading throughout), or the reading is one of a vehicle
    at rest (:data:`IMU_REST_FORCE_TOL`, :data:`IMU_REST_RATE_TOL`)."""
    t = np.asarray(t, float)
    x = np.hstack([np.asarray(f_b, float), np.asarray(omega_b, float)])
    out = np.zeros(len(t), dtype=bool)
    if len(t) < 3:
        return out
    repeats = np.r_[False, np.all(x[1:] == x[:-1], axis=1)]
    # the rows a NaN or an infinite value refuses tell nothing of how the IMU's readings change
    finite = np.all(np.isfinite(x), axis=1)
    edges = np.flatnonzero(np.diff(np.r_[0, repeats.astype(np.int8), 0]))
    for a, b in zip(edges[::2], edges[1::2]):           # rows a..b-1 repeat row a-1
        if t[b - 1] - t[a - 1] < IMU_STALL_MIN_S or _reads_rest(x[a - 1]):
            continue
        around = finite & (((t >= t[a - 1] - IMU_STALL_CONTEXT_S) & (t < t[a - 1]))
                           | ((t > t[b - 1]) & (t <= t[b - 1] + IMU_STALL_CONTEXT_S)))
        out[a:b] = stalled_run(t[b - 1] - t[a - 1], x[a - 1], repeats[around].mean() if around.any() else None)
    return out


def stalled_run(duration_s: float, reading: np.ndarray, repeat_share_around: float | None) -> bool:
    """Whether a run of IMU rows repeating one ``reading`` (f_b m/s^2 then omega_b rad/s, (6,)) for ``duration_s``
    (s, from the row read to its last repeat) is a stalled sensor (:func:`imu_stalled`): long enough
    (:data:`IMU_STALL_MIN_S`), not a reading of a vehicle at rest, and the finite rows around it repeat under
    :data:`IMU_STALL_CONTEXT_REPEAT_SHARE` of the time (``repeat_share_around``; None: no such row to tell)."""
    return bool(duration_s >= IMU_STALL_MIN_S and not _reads_rest(np.asarray(reading, float))
                and repeat_share_around is not None and repeat_share_around < IMU_STALL_CONTEXT_REPEAT_SHARE)


class ImuStallTest:
    """The stalled-sensor rule of :func:`imu_stalled` on a live IMU, in stamp order: :meth:`repeats` says whether a
    sample repeats the one before it in every value (the caller holds such samples), :meth:`stalled` whether the run
    it holds is a stall, judged by the rows of the :data:`IMU_STALL_CONTEXT_S` before the reading it repeats (a live
    stream does not wait for the second after it), and :meth:`passed` takes each sample that went on. A run with
    under that second of samples before its reading (the stream's first second, or just after an IMU gap) is judged
    by the second of samples after it instead (:meth:`untold_may_stall`, :meth:`stalled_after`): the caller holds
    the run and that second."""

    def __init__(self):
        self._recent: deque[tuple[float, bool]] = deque()     # (stamp s, repeated the one before) of those passed
        self._last: tuple[float, tuple] | None = None          # the last sample passed: (stamp s, its six values)
        #: (stamp s of the reading the samples passed since repeat (or of the last one), how many repeat it)
        self.run: tuple[float, int] = (-math.inf, 0)

    def repeats(self, values: tuple) -> bool:
        """Whether the six values (f_b then omega_b) repeat the last sample passed."""
        return self._last is not None and values == self._last[1]

    def may_stall(self) -> bool:
        """Whether a run repeating the last sample passed would be a stall if long enough: not when it reads a
        vehicle at rest or the rows before it repeat often (then no length makes it one, and nothing is held)."""
        return self.stalled(self._last[0] + IMU_STALL_MIN_S)

    def stalled(self, t_last: float) -> bool:
        """Whether the held run, repeating the last sample passed up to the stamp ``t_last`` (s), is a stall."""
        t_read, reading = self._last
        return stalled_run(t_last - t_read, np.asarray(reading, float), self._share_before())

    def _share_before(self) -> float | None:
        """The share of the samples passed within :data:`IMU_STALL_CONTEXT_S` before the last one that repeat the
        one before them; None with under that second of samples before it."""
        t_read = self._last[0]
        around = [r for t, r in self._recent if t >= t_read - IMU_STALL_CONTEXT_S and t < t_read]
        # under a second of samples before it, nothing before tells a stall from an IMU whose rows repeat everywhere
        # (a noiseless or coarse one from its start): the samples after it tell (:meth:`stalled_after`)
        told = around and self._recent[0][0] <= t_read - IMU_STALL_CONTEXT_S
        return sum(around) / len(around) if told else None

    def untold_may_stall(self) -> bool:
        """Whether a run repeating the last sample passed, which the samples before it cannot judge (under
        :data:`IMU_STALL_CONTEXT_S` of them), would be a stall if long enough and the samples after it repeat
        seldom (not on a reading of a vehicle at rest): such a run is judged by the samples after it
        (:meth:`stalled_after`)."""
        return self._share_before() is None and stalled_run(IMU_STALL_MIN_S, np.asarray(self._last[1], float), 0.0)

    def untold_long(self, t_last: float) -> bool:
        """Whether the held run, repeating the last sample passed up to the stamp ``t_last`` (s), is long enough to be
        a stall yet not told by the samples before it (:meth:`untold_may_stall`): the samples after it judge."""
        return self._share_before() is None and stalled_run(t_last - self._last[0], np.asarray(self._last[1], float),
                                                            0.0)

    @property
    def reading_stamp(self) -> float:
        """The stamp (s) of the last sample passed: the reading a held run repeats."""
        return self._last[0]

    def stalled_after(self, t_last: float, after: list[tuple]) -> bool:
        """Whether the held run, repeating the last sample passed up to the stamp ``t_last`` (s), is a stall judged
        by ``after``, the six values of each sample within :data:`IMU_STALL_CONTEXT_S` after it (the first ends the
        run): the loaders' share of them repeating the one before (:func:`imu_stalled`); none: nothing to tell."""
        t_read, reading = self._last
        share = None
        if after:
            before = [reading] + list(after[:-1])
            share = sum(a == b for a, b in zip(after, before)) / len(after)
        return stalled_run(t_last - t_read, np.asarray(reading, float), share)

    def untold(self, t_last: float) -> bool:
        """Whether the samples passed on since the stamp of the reading they repeat, up to ``t_last`` (s), would be a
        stall by their length and reading, yet under :data:`IMU_STALL_CONTEXT_S` of samples before that reading
        cannot tell it from an IMU whose readings repeat from its start (the stream's first second, or just after an
        IMU gap): they went on, to be doubted."""
        t_read = self.run[0]
        return (math.isfinite(t_read) and self._recent[0][0] > t_read - IMU_STALL_CONTEXT_S
                and stalled_run(t_last - t_read, np.asarray(self._last[1], float), 0.0))

    def passed(self, t: float, values: tuple) -> None:
        """A sample (stamp ``t`` s, six values) went on to the estimator."""
        recent = self._recent
        repeats = self.repeats(values)
        self.run = (self.run[0], self.run[1] + 1) if repeats else (t, 0)
        recent.append((t, repeats))
        while recent[0][0] < t - IMU_STALL_CONTEXT_S - 1.0:
            recent.popleft()
        self._last = (t, values)


def _reads_rest(row: np.ndarray) -> bool:
    """Whether one IMU reading (f_b m/s^2 then omega_b rad/s, (6,)) is one of a vehicle at rest: a specific force of
    gravity's size, no turn (:data:`IMU_REST_FORCE_TOL`, :data:`IMU_REST_RATE_TOL`)."""
    return bool(abs(np.linalg.norm(row[:3]) - _GRAVITY_MID) <= IMU_REST_FORCE_TOL
                and np.linalg.norm(row[3:]) <= IMU_REST_RATE_TOL)


def _not_shocks(v: np.ndarray, median: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """(N,k) values of ``v`` (N,k) departing from ``median`` by more than ``limit`` (N,k) that are no shock's: in
    each run of departing rows of a column, from the first value that jumped there on (:func:`jumped`). A shock (a
    bump against the bottom or a dock) gets there over rows; a spike in one, and the rest of its run goes with it."""
    departing = np.abs(v - median) > limit
    jumped_to = np.ones_like(departing)
    jumped_to[1:] = jumped(v[1:] - median[1:], v[:-1] - median[1:], limit[1:])
    rows = np.arange(len(v))[:, None]
    run_start = np.maximum.accumulate(np.where(departing, -1, rows), axis=0)
    last_jump = np.maximum.accumulate(np.where(departing & jumped_to, rows, -1), axis=0)
    return departing & (last_jump > run_start)


def jumped(departure, before, limit):
    """Whether a value departing from its median by ``departure`` got there in one row from the row before, which
    departed by ``before`` (both from this row's median): more than ``limit`` from it, or from a row that had not
    departed the same way by :data:`IMU_SHOCK_ONSET` of the limit. Floats or arrays, units of the value."""
    return (abs(departure - before) > limit) | (before * np.sign(departure) < IMU_SHOCK_ONSET * limit)


def imu_implausible(t: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray, config: SensorConfig, fields=IMU_FIELDS,
                    meta: dict | None = None, source: str = "", dvl: tuple | None = None,
                    lines: np.ndarray | None = None, unmeasured: bool = True) -> dict[str, np.ndarray]:
    """The IMU rows a loader refuses, by reason, disjoint and in the order tested: a logger's all-zero filler
    (:func:`imu_filler`, before anything judges the IMU by its rows: the run and the DVL clock search then see the gap
    it leaves, as any IMU gap), a NaN or infinite value (:func:`not_finite`; both :func:`imu_unmeasured`), beyond full
    scale (:func:`imu_out_of_range`), a spike among the rest (:func:`imu_spikes`, with the ``dvl``'s velocity when
    given), the repeats of a stalled sensor (:func:`imu_stalled`: the run then bridges them as a gap). ``t``: (N,)
    stamps, s; ``fields``: names of the six values, f_b then omega_b; ``lines``: the file line of each row, when
    known. Filler leaving a gap longer than can be bridged is a :class:`DataError` naming ``source``
    (:func:`check_filler_gaps`). When the IMU is too slow for the spike test, a note in ``meta``'s IMU stream (when
    given) and a warning naming ``source``; a knock kept on the DVL's word: a warning, counted as doubted, and its span
    in ``meta["imu_shocks"]`` (the stream does not test those rows again: ``NavigatorOptions.imu_shocks``).
    ``unmeasured=False``: the reader refused the rows holding no measurement already (:func:`imu_unmeasured` at read,
    before its unit and axis checks), and they are not looked for again."""
    unmeasured = imu_unmeasured(t, f_b, omega_b, fields, source, lines) if unmeasured else {}
    out_of_range = imu_out_of_range(f_b, omega_b, config)
    # the filler's stamps are the IMU's clock still ticking: its rate counts them
    bad = np.any([m for k, m in unmeasured.items() if k not in (IMU_FILLER, ACCEL_ZERO)] + list(out_of_range.values()),
                 axis=0)
    rate = imu_rate_hz(np.asarray(t, float)[~bad])
    if imu_spike_rows(rate) is None:
        note = imu_spike_off_note(rate)
        if meta is not None:
            add_note(meta, "imu", note)
        warnings.warn(f"{source}: {note}" if source else note, RuntimeWarning, stacklevel=2)
    kept: list = []
    spikes = imu_spikes(t, f_b, omega_b, config, fields, usable=~bad, rate_hz=rate, dvl=dvl, kept=kept)
    if kept:
        _note_shocks(kept, meta, source)
    return {**unmeasured, **out_of_range, **spikes, IMU_STALLED: imu_stalled(t, f_b, omega_b)}


def imu_unmeasured(t: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray, fields=IMU_FIELDS, source: str = "",
                   lines: np.ndarray | None = None, where: list[str] | None = None,
                   row: str = "IMU row(s)") -> dict[str, np.ndarray]:
    """The IMU rows that hold no measurement, by reason, disjoint: a logger's all-zero filler (:func:`imu_filler`;
    :func:`check_filler_gaps` with ``source`` and the file ``lines`` or ``where`` the file holds each row), three
    accelerometer values of exactly 0 beside a gyro's (:data:`ACCEL_ZERO`), a NaN or infinite value
    (:func:`not_finite`, named by the first of ``fields``). Zero and NaN are so in any unit: a reader refuses them
    before it judges the IMU's units or axes by its rows. ``t`` (N,) s, ``f_b`` (N,3) m/s^2, ``omega_b`` (N,3) rad/s
    (any units); ``row``: what the file calls a row, for the gap's message (a bag's: a message of its topic)."""
    filler = imu_filler(f_b, omega_b)
    dead = ~np.any(np.asarray(f_b, float) != 0.0, axis=1) & ~filler
    nan = not_finite(np.hstack([f_b, omega_b]), fields)
    check_filler_gaps(t, filler, source, lines, unmeasured=np.any([filler, dead, *nan.values()], axis=0), where=where,
                      dead=dead, row=row)
    return {IMU_FILLER: filler, ACCEL_ZERO: dead, **nan}


def imu_filler(f_b: np.ndarray, omega_b: np.ndarray) -> np.ndarray:
    """(N,) bool IMU rows whose specific force ``f_b`` (N,3) m/s^2 and rate ``omega_b`` (N,3) rad/s are all exactly 0:
    a logger's filler (:data:`IMU_FILLER`), one row among good ones as well as a run."""
    return ~np.any(np.asarray(f_b, float) != 0.0, axis=1) & ~np.any(np.asarray(omega_b, float) != 0.0, axis=1)


#: Longest IMU gap bridged by interpolation, s. Beyond it the IMU stopped rather than dropped samples:
#: interpolating would invent minutes of motion (and, for a stamp years off, never end); a DataError says so.
MAX_IMU_BRIDGE_S = 600.0


def check_imu_gap(t0: float, t1: float, source: str, index: int | None = None, field: str = "t",
                  what: str = "IMU gap") -> None:
    """DataError when an IMU gap from t0 to t1 (s) is longer than :data:`MAX_IMU_BRIDGE_S` (``index``: the line or
    index of the sample after it, ``field``: the stamp's column, ``what``: the gap, as the message names it)."""
    if t1 - t0 > MAX_IMU_BRIDGE_S:
        raise DataError(f"{what} of {t1 - t0:.6g} s after t = {t0:.3f} s is longer than the {MAX_IMU_BRIDGE_S:g} s "
                        f"that can be bridged: the IMU stopped (or a stamp is wrong{whole_hours(t1 - t0)}); split "
                        "the mission there", source, index, field)


def whole_hours(step_s: float) -> str:
    """``": N h to within a minute: a time zone or clock change applied mid-log?"`` for a stamp step (s) that
    close to a whole number of hours, else ``""``: a logger's clock put to another time zone jumps by hours."""
    hours = round(step_s / 3600.0)
    if hours == 0 or abs(step_s - 3600.0 * hours) > 60.0:
        return ""
    return f": {hours:+d} h to within a minute, a time zone or clock change applied mid-log?"


def check_filler_gaps(t: np.ndarray, filler: np.ndarray, source: str, lines: np.ndarray | None = None,
                      unmeasured: np.ndarray | None = None, where: list[str] | None = None,
                      dead: np.ndarray | None = None, row: str = "IMU row(s)") -> None:
    """DataError (:func:`check_imu_gap`, naming ``source``, the stamps around the gap and, when ``lines`` gives it,
    the file line of the row after it, or ``where`` the file holds it: a bag's message) when a run of rows without a
    measurement between two other rows at stamps ``t`` (N,) s leaves an IMU gap longer than can be bridged: the IMU
    stopped there as it does in a true gap of that length, whatever the rows hold. ``filler`` (N,) bool: the
    all-zero rows; ``unmeasured`` (N,) bool: those and any other row refused for holding no measurement (a NaN, a dead
    accelerometer, :func:`imu_unmeasured`; default ``filler``): filler next to NaN rows leaves one gap, and so do NaN
    rows alone. A lone row between two such runs does not end a gap it alone keeps from being too long
    (:func:`_lone_rows`). A run at either end of the file only starts the IMU later or ends it earlier; a file of
    filler only is a DataError too (the IMU delivered nothing). ``dead`` (N,) bool: the rows of a dead accelerometer
    among ``unmeasured`` (:data:`ACCEL_ZERO`; default none), which the message names as such (:func:`_left_by`);
    ``row``: what the file calls a row (a bag's: a message of its topic)."""
    t, filler = np.asarray(t, float), np.asarray(filler, bool)
    dead = np.zeros(len(t), bool) if dead is None else np.asarray(dead, bool)
    _check_not_all_filler(filler, source, lines)
    gone = filler if unmeasured is None else np.asarray(unmeasured, bool)
    lone = _lone_rows(gone, t)
    for a, last in _runs(gone | lone):
        b = last + 1
        if a > 0 and b < len(t):
            at = "" if where is None else f"{where[b]}: "
            left = _left_by(b - a, int(filler[a:b].sum()), int(dead[a:b].sum()), int(lone[a:b].sum()), row)
            check_imu_gap(float(t[a - 1]), float(t[b]), source, None if lines is None else int(lines[b]), None,
                          what=f"{at}IMU gap left by {left}")


def _lone_rows(gone: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(N,) bool: the rows not in ``gone`` (N,) bool alone between two runs of them that leave, with it, more than
    :data:`MAX_IMU_BRIDGE_S` between the rows around them (stamps ``t`` (N,) s): one row bridges nothing (a 700 s run
    of NaN split by one row later refused as beyond full scale was read as two runs of 350 s, each bridged, and the
    700 s were refused by the run naming no line). A row alone in a gap that can be bridged without it, or beside a
    run at the file's start or end (the IMU starting later or ending earlier), ends the runs as any row: every other
    row without a measurement for 800 s (a merged log's other sensor's rows between the IMU's, 0.1 s apart) was
    refused as one 800 s gap, and a NaN first row before a good one hid a 700 s gap after it."""
    lone = np.zeros(len(gone), bool)
    runs = np.array(_runs(gone), int).reshape(-1, 2)
    left, right = runs[:-1], runs[1:]
    inside = (left[:, 0] > 0) & (right[:, 1] + 1 < len(gone))
    before, after = np.maximum(left[:, 0] - 1, 0), np.minimum(right[:, 1] + 1, len(gone) - 1)
    alone = (right[:, 0] == left[:, 1] + 2) & inside & (t[after] - t[before] > MAX_IMU_BRIDGE_S)
    lone[left[alone, 1] + 1] = True
    return lone


def _left_by(rows: int, zeros: int, dead: int, lone: int = 0, row: str = "IMU row(s)") -> str:
    """What a run of ``rows`` IMU rows without a measurement held, ``zeros`` of them a logger's filler and ``dead``
    a dead accelerometer's, ``lone`` of them a row alone between two such runs (:func:`_lone_rows`), the others NaN or
    infinite: each kind named, so the user looks for what the file holds (a run of filler and dead-accelerometer rows
    was said to hold NaN); the rows alone hold a measurement, and are named beside them, not counted among them.
    ``row``: what the file calls a row (a bag's: a message of its topic)."""
    rows -= lone
    alone = f" and {lone} alone between them (which bridge{'s' * (lone == 1)} nothing)" if lone else ""
    if zeros == rows:
        return f"{rows} all-zero {row} (a logger's filler){alone}"
    kinds = [f"{zeros} all-zero: a logger's filler"] * bool(zeros) + [
        f"{dead} of a dead accelerometer: its three values 0 beside a live gyro"] * bool(dead)
    if rows > zeros + dead:
        kinds.append("the others NaN or infinite" if kinds else "NaN or infinite values")
    return f"{rows} {row} without a measurement ({'; '.join(kinds)}){alone}"


def _check_not_all_filler(filler: np.ndarray, source: str, lines: np.ndarray | None) -> None:
    """DataError naming ``source`` and the first of the file ``lines`` when every row of ``filler`` (N,) bool is."""
    if len(filler) and filler.all():
        raise DataError(f"all {len(filler)} IMU rows are all-zero (a logger's filler: zero specific force is "
                        "impossible under gravity): the IMU delivered no measurement", source,
                        None if lines is None else int(lines[0]), None)


def zeroed_filler(t: np.ndarray, values: np.ndarray, source: str = "", lines: np.ndarray | None = None
                  ) -> np.ndarray:
    """(N,) bool: the IMU rows written whole as zeros, their stamp ``t`` (N,) (as read, any unit) and their six
    ``values`` (N,6) (f_b then omega_b, any units): a logger's filler (:data:`IMU_FILLER`) that zeroed the stamp too.
    Such a stamp is no time: a reader takes these rows out before it checks the stamps' unit and order (they were
    refused as stamps out of order, with the advice to repair them), and counts them as filler
    (:func:`refuse_zeroed_filler`); the gap they leave is the stamps' step around them, bridged as any IMU gap. A file
    of them only is a DataError naming ``source`` and its first line (``lines``)."""
    values = np.asarray(values, float)
    zeroed = (np.asarray(t, float) == 0.0) & imu_filler(values[:, :3], values[:, 3:6])
    _check_not_all_filler(zeroed, source, lines)
    return zeroed


def refuse_zeroed_filler(meta: dict, source: str, lines: np.ndarray) -> None:
    """Count the IMU rows :func:`zeroed_filler` took out (``lines``: their file lines) as read and refused as a
    logger's filler (:data:`IMU_FILLER`), with a warning naming ``source`` and the lines; after the reader counted
    the rest as read (their stamps give the stream's span and rate)."""
    if not len(lines):
        return
    entry = stream_entry(meta, "imu")
    entry["read"] += len(lines)
    entry["used"] += len(lines)
    refuse(meta, "imu", {IMU_FILLER: np.ones(len(lines), bool)}, source, lines=np.asarray(lines))


def _note_shocks(kept: list, meta: dict | None, source: str) -> None:
    """Warn about the knocks :func:`imu_spikes` kept (``kept``), count their rows as doubted in ``meta`` and keep
    their spans (s) in ``meta["imu_shocks"]``."""
    where = "; ".join(f"t = {t0:.3f}-{t1:.3f} s, {rows} row{'s' * (rows != 1)}, '{field}' integrates to "
                      f"{integral:+.3g} m/s, the DVL saw {seen:+.3g} m/s beyond the vehicle's own motion"
                      for t0, t1, rows, integral, seen, field in kept[:5])
    shocks = "1 shock" if len(kept) == 1 else f"{len(kept)} shocks"
    warnings.warn(f"{source + ': ' if source else ''}{shocks} of the IMU kept, though departing from the signal as a "
                  f"spike does: the DVL saw the velocity change it integrates to ({where}"
                  f"{' ...' if len(kept) > 5 else ''}; a knock against the bottom or a dock?)", RuntimeWarning,
                  stacklevel=3)
    if meta is not None:
        count_doubted(meta, "imu", IMU_SHOCK_KEPT, sum(k[2] for k in kept))
        meta.setdefault("imu_shocks", []).extend([k[0], k[1]] for k in kept)


def depth_implausible(t: np.ndarray, depth_m: np.ndarray, config: SensorConfig) -> dict[str, np.ndarray]:
    """Depth samples outside ``depth_range_m`` or spiking (vertical speed ``dvl.max_vertical_mps``,
    tolerance ``depth_jump_tolerance_m``), disjoint masks."""
    d = np.asarray(depth_m, float)
    lo, hi = config.depth_range_m
    with np.errstate(invalid="ignore"):
        outside = ~((d >= lo) & (d <= hi))
    jump = spike_mask(t, d, config.dvl.max_vertical_mps, config.depth_jump_tolerance_m, usable=~outside)
    return {f"depth outside [{lo:g}, {hi:g}] m": outside, "depth spike": jump}


def gt_implausible(t: np.ndarray, v_n: np.ndarray, spec: DvlSpec) -> dict[str, np.ndarray]:
    """Ground-truth velocities (N,3, m/s) beyond the vehicle's speed or spiking (the DVL envelope: the GT
    describes the same vehicle), disjoint masks."""
    v = np.asarray(v_n, float)
    with np.errstate(invalid="ignore"):
        speed = ~(np.linalg.norm(v, axis=1) <= spec.max_speed_mps)
    jump = spike_mask(t, v, spec.max_accel_mps2, spec.jump_tolerance_mps, usable=~speed)
    return {GT_SPEED.format(spec.max_speed_mps): speed, GT_VELOCITY_SPIKE: jump}


#: Reasons of :func:`gt_implausible` (the speed with ``DvlSpec.max_speed_mps``).
GT_SPEED, GT_VELOCITY_SPIKE = "GT speed > {:g} m/s", "GT velocity spike"


def unit_check_rows(masks: dict[str, np.ndarray], spec: DvlSpec) -> tuple[np.ndarray, bool]:
    """``((K,) rows a reader decides the reference's units on, whether its velocity is mostly beyond the vehicle's
    speed)``: the rows none of ``masks`` (:func:`gt_refusals`) refuses; when the speed rule refuses more than
    :data:`MAX_REFUSED_FRACTION` of them, the rows the other rules keep: a velocity mostly too fast is in other
    units, which the unit checks (positions against velocity) name better than a count of refused rows."""
    speed = GT_SPEED.format(spec.max_speed_mps)
    too_fast = bool(np.mean(masks[speed]) > MAX_REFUSED_FRACTION) if len(masks.get(speed, ())) else False
    rest = [m for k, m in masks.items() if not (too_fast and k in (speed, GT_VELOCITY_SPIKE))]
    return ~np.any(rest, axis=0), too_fast


#: A reference position may depart from what its own velocity explains (the position less the velocity's
#: integral, against its neighbours: :func:`_position_jumps`) by ``1.5 * DvlSpec.jump_tolerance_mps * dt`` plus
#: this, m. The ten A-KIT trajectories (1 Hz) depart by at most 0.64 m (Trajectory11; the others 0.03-0.31 m).
GT_POSITION_TOLERANCE_M = 2.0
#: Reason of a reference row :func:`with_position_spikes` refuses, with the position column it jumps most in.
GT_POSITION_SPIKE = "GT position spike in '{}' (its velocity does not explain it)"
#: A reference gap longer than this many of its median steps is not integrated across (:func:`_position_jumps`).
GT_POSITION_GAP_STEPS = 5.0
#: Up to this many steps of a reference position (:func:`with_position_spikes`) are called resets of its fix; more
#: are a velocity that does not explain the positions.
GT_POSITION_RESETS = 3


def _position_residual(t: np.ndarray, p: np.ndarray, v: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """(n,3) position less the trapezoid integral of the velocity, m, at the ``ok`` rows (across a gap of more than
    :data:`GT_POSITION_GAP_STEPS` steps the position's own change is taken, so that a reference dropout is no step)."""
    dt = np.diff(t[ok])
    with np.errstate(over="ignore", invalid="ignore"):
        step = 0.5 * (v[ok][1:] + v[ok][:-1]) * dt[:, None]
        gap = dt > GT_POSITION_GAP_STEPS * np.median(dt)
        step[gap] = np.diff(p[ok], axis=0)[gap]
        return p[ok] - np.cumsum(np.vstack([np.zeros((1, 3)), step]), axis=0)


def _side_medians(r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """((n,3) component-wise median of the :data:`SPIKE_NEIGHBOURS` rows before each row of ``r``, and of those after
    it); NaN where a side is empty (the first row's before, the last row's after)."""
    n, k = SPIKE_NEIGHBOURS, r.shape[1]
    pad = np.full((n, k), np.nan)
    win = np.lib.stride_tricks.sliding_window_view(np.concatenate([pad, r, pad]), 2 * n + 1, axis=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)        # an empty side is NaN
        return np.nanmedian(win[:, :, :n], axis=2), np.nanmedian(win[:, :, n + 1:], axis=2)


def _far(a: np.ndarray, b: np.ndarray, limit) -> np.ndarray:
    """Rows of ``a`` further than ``limit`` from those of ``b`` (a NaN row is far)."""
    return ~(np.linalg.norm(a - b, axis=-1) <= limit)


def _position_jumps(t: np.ndarray, p_n: np.ndarray, v_n: np.ndarray, spec: DvlSpec, usable: np.ndarray | None
                    ) -> tuple[np.ndarray, list[tuple[int, int, np.ndarray]]]:
    """((N,3) reference rows whose position (N,3) m NED jumps where their velocity (N,3) m/s NED, at ``t`` (N,) s,
    does not and jumps back, under the axis they depart most in; the steps ``(row before, row after, (3,) step m)``)
    for :func:`with_position_spikes`.

    A spike (a corrupted cell, 1e308): the position less the trapezoid integral of the velocity departs from the
    median of its :data:`SPIKE_NEIGHBOURS` neighbours on each side while the two sides agree (the file's first and
    last rows: from their one side, whose rows agree with each other); two steps that undo each other are an
    excursion (a run of a few rows, or a longer offset burst), refused too (:func:`_excursions`). A lasting step (a
    reset of the reference fix) is no spike. Only ``usable`` rows (default: the finite ones; leave out the velocity
    spikes, whose integral steps) are tested and integrated; across a gap of more than
    :data:`GT_POSITION_GAP_STEPS` steps the position's own change is taken, so that a reference dropout is no step."""
    t, p, v = (np.asarray(a, float) for a in (t, p_n, v_n))
    ok = np.all(np.isfinite(p), axis=1) & np.all(np.isfinite(v), axis=1)
    ok &= True if usable is None else np.asarray(usable, bool)
    hit, steps = np.zeros(p.shape, dtype=bool), []
    idx = np.flatnonzero(ok)
    if idx.size < 3:
        return hit, steps
    r = _position_residual(t, p, v, ok)
    gaps = np.diff(t[idx])
    near = np.minimum(np.r_[np.inf, gaps], np.r_[gaps, np.inf])
    limit = 1.5 * spec.jump_tolerance_mps * near + GT_POSITION_TOLERANCE_M
    before, after = _side_medians(r)
    # a spike departs from both sides, which agree with each other (else it is a step); the first and last rows
    # have one side, and depart from each of its rows, which agree with each other (else it is a ramp)
    spike = _far(r, before, limit) & _far(r, after, limit) & ~_far(before, after, limit)
    for end, side, rows in ((0, after, r[1:SPIKE_NEIGHBOURS + 1]), (-1, before, r[-SPIKE_NEIGHBOURS - 1:-1])):
        spike[end] = _far(rows, r[end], limit[end]).all() and not _far(rows, side[end], limit[end]).any()
    rows = np.flatnonzero(spike)
    side = np.where(np.isnan(before[rows]), after[rows], before[rows])     # the first row has no before
    hit[idx[rows], np.argmax(np.abs(r[rows] - side), axis=1)] = True
    # a step: the rows on either side of it agree among themselves but not with each other (spikes left out)
    keep = np.flatnonzero(~spike)
    rk, before, after = r[keep], *_side_medians(r[keep])
    gap_limit = 1.5 * spec.jump_tolerance_mps * np.diff(t[idx[keep]]) + GT_POSITION_TOLERANCE_M
    jump = _far(rk[1:], rk[:-1], gap_limit) & _far(after[:-1], before[1:], gap_limit)
    steps = [(int(idx[keep[j]]), int(idx[keep[j + 1]]), rk[j + 1] - rk[j]) for j in np.flatnonzero(jump)]
    return hit, _excursions(hit, steps, t, spec, idx)


def _excursions(hit: np.ndarray, steps: list, t: np.ndarray, spec: DvlSpec, idx: np.ndarray) -> list:
    """``steps`` less the pairs that undo each other: the rows between such a pair are an excursion (a corrupted run
    too long for the spike test, a burst of outlying fixes), marked in ``hit`` (N,3) under the axis the first step is
    largest in; a lasting step stays a step. Within 2 x :data:`SPIKE_NEIGHBOURS` rows the pair must cancel within
    what the velocity can move over the run; a longer run (fewer rows than the rest of the log: else which part is
    off cannot be told) within what one row step may (an offset burst's two steps differ by two clean row steps,
    however long it lasts; two resets of the fix that stay almost never cancel that closely)."""
    out, i = [], 0
    while i < len(steps):
        (b1, a1, s1), nxt = steps[i], steps[i + 1] if i + 1 < len(steps) else None
        if nxt is not None:
            b2, a2, s2 = nxt
            rows = idx[(idx >= a1) & (idx <= b2)]
            back = 1.5 * spec.jump_tolerance_mps * (t[a2] - t[b1]) + GT_POSITION_TOLERANCE_M
            step = 1.5 * spec.jump_tolerance_mps * max(t[a1] - t[b1], t[a2] - t[b2]) + GT_POSITION_TOLERANCE_M
            if (np.all(np.abs(s1 + s2) <= back) if rows.size <= 2 * SPIKE_NEIGHBOURS else
                    2 * rows.size < idx.size and np.linalg.norm(s1 + s2) <= step):
                hit[rows, int(np.argmax(np.abs(s1)))] = True
                i += 2
                continue
        out.append(steps[i])
        i += 1
    return out


def gt_refusals(t: np.ndarray, cells: np.ndarray, fields, v_n: np.ndarray, spec: DvlSpec,
                impossible: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """Reason -> (K,) reference rows a reader refuses before deciding the reference's units (one V Down spike
    would swamp the down position's fit to it): an empty, NaN or infinite cell of ``cells`` (K,k) in its column of
    ``fields`` (:func:`not_finite`), the reader's own ``impossible`` rows, a velocity ``v_n`` (K,3) m/s the vehicle
    cannot have (:func:`gt_implausible`). The position spikes need positions in metres:
    :func:`with_position_spikes` adds them."""
    return {**not_finite(cells, fields), **(impossible or {}), **gt_implausible(t, v_n, spec)}


def with_position_spikes(masks: dict[str, np.ndarray], t: np.ndarray, p_n: np.ndarray, v_n: np.ndarray,
                         spec: DvlSpec, fields, source: str = "", lines: np.ndarray | None = None,
                         meta: dict | None = None) -> dict[str, np.ndarray]:
    """``masks`` (:func:`gt_refusals`) and the position spikes among the rows none of them refuses
    (:func:`_position_jumps`: ``p_n`` (K,3) m NED, ``v_n`` (K,3) m/s, ``fields`` the position columns). A step of
    the position its velocity does not make (a reset of the reference fix) is kept, warned about naming ``source``,
    the file ``lines`` (K,) on either side of it and the column, and noted in ``meta``."""
    refused = np.any(list(masks.values()), axis=0) if masks else None
    hit, steps = _position_jumps(t, p_n, v_n, spec, None if refused is None else ~refused)
    if steps:
        lines = np.arange(len(t)) + 2 if lines is None else np.asarray(lines)
        where = "; ".join(f"{np.linalg.norm(d):.3g} m in '{fields[int(np.argmax(np.abs(d)))]}' between lines "
                          f"{lines[i]} and {lines[j]}" for i, j, d in steps[:5]) + (" ..." if len(steps) > 5 else "")
        why = ("a reset of the reference fix (USBL, GNSS)?" if len(steps) <= GT_POSITION_RESETS else
               "the velocity does not explain the positions (columns swapped, another frame?) or the fix resets often?")
        text = (f"{len(steps)} step(s) of the reference position its velocity does not make ({where}): {why} the rows "
                "are kept, and a score against the reference across a step includes it")
        warnings.warn(f"{source}: {text}", RuntimeWarning, stacklevel=2)
        if meta is not None:
            add_note(meta, "gt", text)
    return {**masks, **_by_first_field(hit, fields, GT_POSITION_SPIKE)}


def latlon_impossible(lat: np.ndarray, lon: np.ndarray, fields=("latitude", "longitude")) -> dict[str, np.ndarray]:
    """Rows whose latitude or longitude (N,), in degrees or radians, is no angle of either kind (a latitude beyond
    90 in magnitude, a longitude outside -180..360: east of Greenwich written 0..360 as NetCDF and oceanographic tools
    do is one), refused before the unit is decided from the others; a reason per column of ``fields`` (latitude,
    longitude)."""
    with np.errstate(invalid="ignore"):
        return {f"latitude beyond 90 deg in '{fields[0]}'": np.abs(lat) > 90.0,
                f"longitude outside -180..360 deg in '{fields[1]}'": (lon < -180.0) | (lon > 360.0)}


def beams_out_of_range(beams: np.ndarray, valid: np.ndarray, spec: DvlSpec) -> np.ndarray:
    """(M,4) valid beams whose magnitude exceeds the vehicle's speed (a beam is a projection of it)."""
    with np.errstate(invalid="ignore"):
        return np.asarray(valid, bool) & ~(np.abs(np.asarray(beams, float)) <= spec.max_speed_mps)


#: Reason of a DVL ping logged as exactly 0 on every axis that no vehicle at rest explains (:func:`no_bottom_lock`).
NO_BOTTOM_LOCK = "velocity exactly 0 on every axis (no bottom lock)"
#: The coarsest DVL resolution a log is told apart by, in the unit its values are written in: 0.001 (1 mm/s in m/s,
#: PD0's native unit; 3 decimals). At that resolution a hovering DVL's noise rounds to 0, 0, 0 on some pings (6 % of
#: them for 1 mm/s of noise); finer, a ping of exactly 0 on every axis is a driver's no-lock filler.
ZERO_RESOLUTION = 1e-3
#: Speed, m/s, beyond what the vehicle can lose in the interval (``DvlSpec.max_accel_mps2`` x dt) at which a ping
#: next to zeros says the vehicle was under way: a hovering DVL's noise is 1-10 mm/s, so 0.1 m/s is no noise.
ZERO_SPEED_MARGIN_MPS = 0.1
#: A run of this many pings of exactly 0 on every axis is no bottom lock whatever the log's resolution and the pings
#: around it: a hovering DVL at 1 mm/s rounds about 6 % of its pings to 0, 0, 0, isolated (three in a row about once
#: in 5000 pings), while a driver's no-lock filler comes in blocks (a vehicle under way at 0.5 Hz, or a glider at
#: 0.25 m/s, is slower than what the speed rule can tell from one ping interval).
ZERO_RUN_PINGS = 3
#: A stream holds a zero ping for the ping after it (which tells a run, or the speed after it) at most this many of
#: its ping periods (:data:`PING_PERIOD_STEPS`): a DVL silent for longer leaves it as the past judged it (kept).
ZERO_HOLD_INTERVALS = 2.0
#: The newest step between pings sets the hold when longer than the median period and at most this many of it (a
#: DVL slowing from 5 Hz to 1 Hz: 5x); a longer one is a silence, which would hold the stream back for its length.
ZERO_HOLD_SLOWDOWN = 6.0
#: A stream's ping period is the median of its last this many steps between pings (``DvlSpec.rate_hz``'s period
#: until it has three): an outage is one long step among them, so a zero ping right after one is held two periods,
#: not two outages (the step before it, outage included, held it 30 s after a 15 s outage).
PING_PERIOD_STEPS = 15


def on_resolution_grid(values) -> tuple[int, int]:
    """(on, off): how many of the finite non-zero ``values`` are, and are not, multiples of :data:`ZERO_RESOLUTION`
    (to 0.1 % of it: float32 logs and unit conversions keep a written value on its grid)."""
    x = np.asarray(values, float).ravel()
    x = x[np.isfinite(x) & (x != 0.0)] / ZERO_RESOLUTION
    on = int(np.count_nonzero(np.abs(x - np.round(x)) <= 1e-3))
    return on, x.size - on


def zeros_without_lock(fine: bool, before: tuple[float, float] | None, after: tuple[float, float] | None,
                       spec: DvlSpec, run: int = 1) -> bool:
    """Whether a run of DVL pings logged as exactly 0 on every axis is no bottom lock rather than a vehicle at rest.

    ``fine``: the log's other values are mostly off the :data:`ZERO_RESOLUTION` grid, so its noise never rounds to
    0, 0, 0. ``before`` / ``after``: (speed m/s, s between it and the run) of the nearest ping that is not all zeros
    on each side (None: none; the Navigator's stream has the past only): a vehicle faster than
    ``max_accel_mps2 * dt`` + :data:`ZERO_SPEED_MARGIN_MPS` cannot have stopped (or started) within dt (1.1 m/s at
    1 Hz, 0.3 m/s at 5 Hz with the defaults). ``run``: pings in the run (:data:`ZERO_RUN_PINGS` or more: no lock).
    A hovering vehicle's isolated zeros in a coarse log are kept."""
    if fine or run >= ZERO_RUN_PINGS:
        return True
    return any(s is not None and s[0] > spec.max_accel_mps2 * s[1] + ZERO_SPEED_MARGIN_MPS for s in (before, after))


def zero_pings(values) -> np.ndarray:
    """(M,) pings whose values (M,k) (beams or velocity components as logged, NaN where not a measurement) are all
    exactly 0 on at least three of them."""
    x = np.asarray(values, float)
    finite = np.isfinite(x)
    return (finite.sum(axis=1) >= 3) & np.all(~finite | (x == 0.0), axis=1)


def no_bottom_lock(t: np.ndarray, values: np.ndarray, speed: np.ndarray, spec: DvlSpec,
                   fine: bool | None = None) -> np.ndarray:
    """(M,) DVL pings at ``t`` (M,) s logged as exactly 0 on every value (:func:`zero_pings`) that are no bottom
    lock (:func:`zeros_without_lock`, each run of them judged by the pings around it): ``speed`` (M,) m/s the speed
    of each ping (NaN: unknown), ``fine`` the log's resolution (default: from ``values``, :func:`on_resolution_grid`;
    a reader that converted the units passes the file's own). Water Linked DVLs and several drivers log a ping
    without bottom lock so; none of the ten A-KIT trajectories' 4000 pings nor of the real PD0 files' has it."""
    t, speed = np.asarray(t, float), np.asarray(speed, float)
    zero = zero_pings(values)
    if fine is None:
        on, off = on_resolution_grid(values)
        fine = off > on
    known = np.flatnonzero(~zero & np.isfinite(speed))
    out = np.zeros(len(t), bool)
    for first, last in _runs(zero):
        i = np.searchsorted(known, first)
        before = (speed[known[i - 1]], t[first] - t[known[i - 1]]) if i > 0 else None
        after = (speed[known[i]], t[known[i]] - t[last]) if i < known.size else None
        out[first:last + 1] = zeros_without_lock(fine, before, after, spec, last - first + 1)
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of each run of True in ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1))


def warn_no_bottom_lock(no_lock: np.ndarray, lines: np.ndarray, source: str) -> None:
    """Warn about the pings :func:`no_bottom_lock` refused, naming ``source`` and their file ``lines``."""
    if no_lock.any():
        warnings.warn(f"{source}: {int(no_lock.sum())} DVL ping(s) with a velocity of exactly 0 on every axis (a ping "
                      "without bottom lock: the log's resolution is finer than 1 mm/s or the vehicle is under way) "
                      f"refused at line(s) {first_lines(np.asarray(lines)[no_lock])}; they are not used",
                      RuntimeWarning, stacklevel=3)


# ------------------------------------------------------------------------------------------------
# counting (loaders)
# ------------------------------------------------------------------------------------------------
def refuse(meta: dict, stream: str, masks: dict[str, np.ndarray], source: str, line_offset: int = 0,
           unit: str = "sample", lines: np.ndarray | None = None, where: list[str] | None = None,
           t: np.ndarray | None = None) -> np.ndarray:
    """Count the samples of ``masks`` (reason -> (N,) bool; a sample under its first reason) as refused in
    ``meta["streams"][stream]`` and warn once naming the source, the reasons and the first lines (``lines``,
    the file line of each sample, when given; ``where``, where the file holds each sample, e.g. a PD0 ensemble or
    a bag message, when given; else, with the stamps ``t`` (s), the sample and its stamp; else index +
    ``line_offset``). Returns the union mask."""
    total = np.zeros(len(next(iter(masks.values()))) if masks else 0, dtype=bool)
    parts = []
    for reason, m in masks.items():
        m = np.asarray(m, bool) & ~total
        if m.any():
            count_refused(meta, stream, reason, int(m.sum()))
            parts.append(f"{int(m.sum())} {reason}")
        total |= m
    if total.any():
        at = located(np.flatnonzero(total), lines, where, line_offset, t=t)
        warnings.warn(f"{source}: {int(total.sum())} {stream} {unit}(s) refused ({'; '.join(parts)}) at {at}; "
                      "they are not used", RuntimeWarning, stacklevel=3)
    return total


def over_refused_limit(meta: dict, stream: str, limit: float = MAX_REFUSED_FRACTION) -> bool:
    """More than ``limit`` of the measurements of ``stream`` in ``meta["streams"]`` refused (:func:`measurements`)."""
    read, refused = measurements(meta.get("streams", {}).get(stream, {}))
    return bool(read) and sum(refused.values()) > limit * read


def measurements(entry: dict) -> tuple[int, dict[str, int]]:
    """``(samples read, {reason: samples refused})`` of a stream's record ``entry`` without a logger's filler
    (:data:`IMU_FILLER`): rows written while the sensor delivered nothing are a gap in its data, which bridging or a
    later start bounds, not a share of its measurements gone wrong."""
    refused = dict(entry.get("refused", {}))
    filler = refused.pop(IMU_FILLER, 0)
    return entry.get("read", 0) - filler, refused


def check_refused_fraction(meta: dict, limit: float = MAX_REFUSED_FRACTION, advice: dict | None = None,
                           fields: dict | None = None) -> None:
    """Raise :class:`DataError` naming the stream and its reasons when more than ``limit`` of a stream in
    ``meta["streams"]`` was refused; ``advice`` (stream -> text): what to check for that stream, when known better
    than the units and sensor ranges. The field named is the column the main reason names, the accelerometer's
    (``fields``: stream -> its six value columns, f_b first; default :data:`IMU_FIELDS`) for a dead one's rows, else
    the stream's. An IMU of more than :data:`MAX_FILLER_SHARE` filler is one too (:func:`check_filler_share`)."""
    for stream, entry in meta.get("streams", {}).items():
        check_filler_share(entry, stream)
        if over_refused_limit(meta, stream, limit):
            read, by_reason = measurements(entry)
            refused = sum(by_reason.values())
            ranked = sorted(by_reason.items(), key=lambda kv: -kv[1])
            reasons = ", ".join(f"{n} {r}" for r, n in ranked)
            column = re.search(r"in '([^']+)'", ranked[0][0])      # the column the main reason names
            named = column[1] if column else None
            if ranked[0][0] == ACCEL_ZERO:      # its rows name no column: the accelerometer's three are the ones
                named = ", ".join((fields or {}).get(stream, IMU_FIELDS)[:3])
            where = "the units, the column map" if meta.get("format") == "csv" else "the units"
            check = f"{where} and the configuration's sensor ranges"
            if ranked[0][0] in (REPAIRED_STAMP, EXACT_COPY):     # the values were never judged: the stamps are wrong
                check = ("the file's stamps: many rows share each one (two streams written into one file, or a "
                         "driver stamping packets of samples together on irregular receipts)")
            elif _holds_no_measurement(ranked[0][0]):           # so in any unit and within any range
                check = _no_measurement_advice(ranked[0][0], meta.get("format") == "csv")
            check = (advice or {}).get(stream) or f"check {check}"
            raise DataError(f"{refused} of {read} {stream} samples refused ({reasons}): more than "
                            f"{limit:.0%} of the stream; {check}",
                            entry.get("source") or stream,
                            field=named or meta.get("stream_fields", {}).get(stream, stream))


def _holds_no_measurement(reason: str) -> bool:
    """Whether rows refused for ``reason`` hold a value that no unit and no sensor range makes a measurement: empty,
    NaN or infinite (:func:`not_finite`), an accelerometer's three zeros beside a gyro's (:data:`ACCEL_ZERO`)."""
    return reason == ACCEL_ZERO or reason.startswith(("empty or NaN in '", "infinite in '"))


def _no_measurement_advice(reason: str, column_map: bool) -> str:
    """What to check when most of a stream was refused for ``reason`` (:func:`_holds_no_measurement`): the sensor
    and its logger, not the units or ranges (a dead accelerometer's 3500 of 6001 bag rows were told to check those);
    with a ``column_map``, also the columns it names."""
    if reason == ACCEL_ZERO:
        return ("the accelerometer: three values of exactly 0 beside the gyro's are no measurement in any unit (a dead "
                "accelerometer, or an IMU without one publishing zeros; the estimators need the specific force)")
    return ("the sensor and its logger or driver: an empty, NaN or infinite value is no measurement in any unit"
            + (", or the column map (a column named that holds no numbers)" if column_map else ""))


def check_filler_share(entry: dict, stream: str = "imu") -> None:
    """DataError naming the file of a stream's record ``entry`` and the share when more than :data:`MAX_FILLER_SHARE`
    of the rows it read are a logger's all-zero filler (:data:`IMU_FILLER`): 10 measured IMU rows among 40000 of filler
    loaded, and only the DVL outside their 0.1 s was warned about."""
    read, filler = entry.get("read", 0), entry.get("refused", {}).get(IMU_FILLER, 0)
    if read and filler > MAX_FILLER_SHARE * read:
        raise DataError(f"{filler} of {read} IMU rows ({filler / read:.2%}) are all-zero (a logger's filler: zero "
                        f"specific force is impossible under gravity), more than {MAX_FILLER_SHARE:.0%}: the IMU "
                        f"delivered almost no measurement ({read - filler} row(s)); check the IMU and its logger",
                        entry.get("source") or stream)


def refuse_rows(meta: dict, stream: str, masks: dict[str, np.ndarray], source: str, lines: np.ndarray | None, *arrays,
                where: list[str] | None = None, fields=None) -> tuple[np.ndarray, ...]:
    """``arrays`` (each (N, ...), rows in file order) without the rows of ``masks`` (reason -> (N,) bool), which
    are counted and warned about with their file ``lines`` (or ``where`` the file holds each row, e.g. a bag
    message: :func:`refuse`); DataError when more than half of a stream is refused now
    (:func:`check_refused_fraction`, naming the stream's value columns ``fields`` when a reason names none)."""
    bad = refuse(meta, stream, masks, source, lines=lines, where=where)
    check_refused_fraction(meta, fields=None if fields is None else {stream: tuple(fields)})
    return tuple(a[~bad] for a in arrays)


#: Reason under which a file's rows dropped for their stamps are counted (:func:`stamp_order`).
EXACT_COPY = "repeats an earlier row exactly"
#: Reason under which rows kept though they may be written twice are counted as doubted (:func:`stamp_order`).
STUCK_REPEATS = "repeats the row before it at its stamp, as every such row does (kept; maybe written twice)"
#: Share of an IMU's rows sharing a stamp that may differ from the row before them, the others repeating it, for
#: those kept as samples to be doubted (:data:`STUCK_REPEATS`): a stuck sensor's, or one whose counts barely change
#: (0.05 m/s^2, 1e-3 rad/s at rest, 200-400 Hz in whole 10 ms: 0-2 of 6000-9000 differ); an IMU at rest in 0.02 m/s^2
#: counts has 52 % differ, and its samples' stamps show it faster than its clock.
STUCK_DIFFER_SHARE = 0.01
REPAIRED_STAMP = "duplicated stamp (repair)"
#: Reason under which a row repeating the row before it in every value a moment later is dropped (:func:`stamp_order`).
NUDGED_COPY = "repeats the row before it in every value under half a step later (written twice)"
#: A row repeating the row before it in every value less than this share of the stream's median step later is the
#: same sample written twice with its stamp nudged (a logger writing a row again 1 ms later): no sample of the stream
#: comes that early, and a stamp grid's step rounds to none at it (:func:`graphnav.io.loaders.grid_step`). A DVL
#: repeating its last velocity, or an IMU at rest, repeats rows a whole step later.
NUDGED_COPY_STEP_SHARE = 0.5


def stamp_order(t: np.ndarray, rows: np.ndarray, lines: np.ndarray, source: str, field: str, repair: bool,
                meta: dict | None = None, stream: str = "", imu_rate_hz: float | None = None,
                filler_lines: np.ndarray | None = None) -> tuple[np.ndarray, dict[str, int], np.ndarray]:
    """``(indices of the rows kept, in time order; {reason: rows dropped}; their stamps, s)`` of a file's stamps
    ``t`` (N,) s and its rows as read ``rows`` (N,k), ``lines`` their file lines.

    A row equal to an earlier one in its stamp and every value (NaN equal to NaN) is the same sample written
    twice (a logger flushing its buffer again): dropped with a warning; so is a row repeating the row before it in
    every value under half a step later, its stamp nudged (:func:`nudged_copies`: a stamp grid read without it); a
    row of a stream other than an IMU stamped under a fifth of a step after the one before it (other values, or
    equal ones kept as samples) is kept, warned about and doubted (:func:`say_close_samples`). An IMU's (``stream``
    "imu") packets sharing one stamp (:func:`~graphnav.core.imu_timing.shared_stamp_packets`) or from a clock coarser
    than its period or about as coarse (:func:`~graphnav.core.imu_timing.quantised_clock`) are restamped at the period
    (:func:`~graphnav.core.imu_timing.restamp_shared_stamps`, noted in ``meta``); an IMU's row equal to the one
    before it at a stamp holding no more samples than such a stamp does is a sample (an IMU at rest with coarse
    counts, :func:`~graphnav.core.imu_timing.samples_sharing_a_stamp`), not a copy; where every row sharing a stamp
    is such a row but :data:`STUCK_DIFFER_SHARE` (a stuck sensor, or each row written twice: nothing tells) those
    kept are warned about and counted as doubted (:data:`STUCK_REPEATS`); a step of its clock or a gap is
    warned about and counted (:func:`say_imu_stamp_steps`; not the gap left by the filler taken out before at the file
    ``filler_lines``, :func:`zeroed_filler`, refused as filler); ``imu_rate_hz``, the configured rate (Hz), tells an IMU
    slower than its logger's clock from one losing samples where the stamps cannot. The rest must increase strictly;
    else, with ``repair``, the rows are sorted and those whose stamp repeats an earlier one dropped (the first kept),
    with a warning; without it a DataError naming ``source``, the line, ``field`` and the way out (``--repair-stamps``):
    one stamp on two different rows can be two streams written into one file."""
    read, rows = np.asarray(t, float), np.asarray(rows, float)
    t = read.copy()
    copies, repeat = exact_copies(t, rows)
    if copies.size and stream == "imu" and repeat:
        step = np.diff(np.sort(t))
        samples = samples_sharing_a_stamp(t, copies)
        differ = int(np.sum(step == 0)) - copies.size
        if meta is not None and np.any(samples) and differ <= STUCK_DIFFER_SHARE * np.sum(step == 0):
            every = f"all but {differ} of the rows" if differ else "every row"
            say_doubted(meta, "imu", source, f"{int(np.sum(samples))} row(s) repeating the row before them in stamp "
                        f"and every value, {every} sharing a stamp among them, with readings repeating across "
                        "stamps as often (a sensor stuck or at rest with coarse counts), kept as samples sharing "
                        f"their stamp, at line(s) {first_lines(lines[copies[samples]])}: the data cannot tell them "
                        "from rows written twice (the IMU then samples at the rate of its distinct stamps)",
                        STUCK_REPEATS, int(np.sum(samples)), stacklevel=3)
        copies = copies[~samples]
    dropped = {EXACT_COPY: int(copies.size)} if copies.size else {}
    if copies.size:
        say_exact_copies(copies, source, lines=lines, stacklevel=3)
    nudged, moved = nudged_copies(t, rows)
    if nudged.size:
        dropped[NUDGED_COPY] = int(nudged.size)
        say_nudged_copies(nudged, moved, source, lines=lines, stacklevel=3)
        copies = np.union1d(copies, nudged)
    kept = np.delete(np.arange(len(t)), copies)
    if stream == "imu":
        t[kept] = restamp_shared_stamps(read[kept], source, meta, imu_rate_hz)
    step = np.diff(t[kept])
    bad = np.flatnonzero(step <= 0)
    if not bad.size:
        _say_steps(read, t, kept, lines, source, field, meta, stream, filler_lines)
        return kept, dropped, t[kept]
    packets = stamped_in_packets(t[kept])
    if not repair:
        i = kept[bad[0] + 1]
        kind = "duplicated" if step[bad[0]] == 0 else "out of order"
        raise DataError(f"time stamp {kind} ({float(t[kept[bad[0]]])!r} s then {float(t[i])!r} s); "
                        f"{_zeroed_stamps(t, lines, filler_lines) or _repair_advice(bad.size, packets)}",
                        source, int(lines[i]), field)
    kept = kept[np.argsort(t[kept], kind="stable")]
    first = np.concatenate([[True], np.diff(t[kept]) > 0])
    warnings.warn(f"{source}: {int((~first).sum())} duplicated and {int((step < 0).sum())} out-of-order "
                  f"stamp(s) repaired (duplicates dropped, first kept; rows sorted){packets}", stacklevel=3)
    _say_steps(read, t, kept[first], lines, source, field, meta, stream, filler_lines)
    return kept[first], {**dropped, REPAIRED_STAMP: int((~first).sum())}, t[kept[first]]


def _repair_advice(rows: int, packets: str) -> str:
    """The way out of stamps out of order that sorting them is: ``rows`` such lines, ``packets`` a note of their
    being stamped in packets."""
    return (f"{rows} such line(s){packets}; pass repair=True (command line: --repair-stamps) to drop duplicates and "
            "sort")


def _zeroed_stamps(t: np.ndarray, lines: np.ndarray, filler_lines: np.ndarray | None) -> str:
    """What to do with the rows stamped exactly 0 after later stamps ``t`` (s, in file order, ``lines`` their file
    lines) or ``""`` when none: a stamp zeroed as a logger's filler's is (``filler_lines``: the lines of the filler
    taken out, :func:`zeroed_filler`) on rows holding values (a stalled sensor's repeats) is no time. Sorting them
    (``repair``) would put them at the file's start, so the advice is to delete or stamp them. Only where every row
    behind a later stamp is stamped 0: a recording whose clock restarts at 0 goes on from there (0.01 s, ...)."""
    behind = np.flatnonzero(t[1:] < np.maximum.accumulate(t)[:-1]) + 1
    zero = behind[t[behind] == 0.0]
    if not zero.size or zero.size < behind.size:
        return ""
    beside = (f", as the {len(filler_lines)} all-zero rows of a logger's filler taken out at line(s) "
              f"{first_lines(np.asarray(filler_lines))} are" if filler_lines is not None and len(filler_lines) else "")
    return (f"{zero.size} row(s) holding values stamped 0 s after later stamps, at line(s) {first_lines(lines[zero])}: "
            f"their stamps were zeroed{beside}, and a zeroed stamp is no time (repair=True would sort them to the "
            "file's start); delete those rows or write their stamps")


def zeroed_stamps_error(t: np.ndarray, lines: np.ndarray, filler_lines: np.ndarray | None, source: str,
                        field: str) -> DataError | None:
    """The DataError naming the rows stamped exactly 0 after later stamps ``t`` (as written, in the file's unit;
    ``lines`` their file lines, ``filler_lines`` the filler taken out, :func:`_zeroed_stamps`), or None. For a reader
    whose unit and gap checks come before :func:`stamp_order`: on a clock far from 0 (Unix time, an offset), the step
    from such rows back to it was refused as a span over a year or as an IMU gap to split the mission at, naming the
    line after them."""
    told = _zeroed_stamps(t, lines, filler_lines)
    if not told:
        return None
    i = int(np.flatnonzero(t[1:] < np.maximum.accumulate(t)[:-1])[0]) + 1
    return DataError(f"time stamp out of order ({float(np.max(t[:i]))!r} then 0.0, as written); {told}", source,
                     int(lines[i]), field)


def exact_copies(t: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, bool]:
    """``(indexes, repeat)``: the indexes (file order, sorted) of the rows (``rows`` (N,k) as read, with their stamps'
    column; ``t`` (N,) s) equal to the row before them in time in stamp and every value (NaN equal to NaN), and
    whether the readings repeat from one stamp to the next as often as within a stamp (:func:`readings_repeat`: an
    IMU's such rows may then be samples sharing a stamp, not copies)."""
    t, rows = np.asarray(t, float), np.asarray(rows, float)
    order = np.argsort(t, kind="stable")
    a, b = rows[order][:-1], rows[order][1:]
    equal = (a == b) | (np.isnan(a) & np.isnan(b))
    step = np.diff(t[order])
    copies = np.sort(order[1:][(step == 0) & np.all(equal, axis=1)])
    if not copies.size:
        return copies, False
    stamp = np.all(rows == t[:, None], axis=0)          # the stamp's own column: it differs from stamp to stamp
    return copies, readings_repeat(np.all(equal[:, ~stamp], axis=1), step)


def say_exact_copies(copies: np.ndarray, source: str, lines: np.ndarray | None = None,
                     where: list[str] | None = None, stacklevel: int = 2) -> None:
    """Warn about the rows :func:`exact_copies` found and are dropped (``copies``: their indexes), named by their file
    ``lines`` or, for a bag's messages, ``where`` (as :func:`located` names them)."""
    warnings.warn(f"{source}: {copies.size} row(s) repeating an earlier row exactly (same stamp and values) "
                  f"dropped, at {located(copies, lines, where)}", RuntimeWarning, stacklevel=stacklevel + 1)


#: Reason under which rows of a stream other than an IMU stamped close after the row before them are doubted
#: (:func:`say_close_samples`).
CLOSE_SAMPLES = "stamped under a fifth of a step after the row before it (kept)"
#: A row stamped less than this share of its stream's median step after the one before it is written for the same
#: sample time (a DVL ping 1 ms after another: 0.001 of its step; two stamped together). A stamp grid allows it on
#: the grid point of the row before (:func:`graphnav.io.loaders.grid_step`); a logger's burst (0.3 of a step) is no
#: grid.
SAME_POINT_SHARE = 0.2


def say_close_samples(t: np.ndarray, lines: np.ndarray | None, source: str, stream: str, meta: dict | None,
                      where: list[str] | None = None, stacklevel: int = 5) -> None:
    """Warn about and count as doubted (with ``meta``) the rows of a stream's increasing stamps ``t`` (s; ``lines``
    their file lines, or ``where`` a bag's messages named as :func:`located` names them) stamped under
    :data:`SAME_POINT_SHARE` of the median step near them (:func:`usual_steps`) after the row before them: two
    samples where the stream makes one (a row written twice with another reading, or two stamped together on
    receipt), both kept, since nothing tells the right one. An IMU's steps are :func:`say_imu_stamp_steps`'."""
    step = np.diff(t)
    if meta is None or step.size < 2:
        return
    usual = usual_steps(step)
    close = np.flatnonzero(step < SAME_POINT_SHARE * usual) + 1
    if close.size:
        later_ms = float(np.max(t[close] - t[close - 1])) * 1e3
        say_doubted(meta, stream, source, f"{close.size} {stream} row(s) stamped under a fifth of the median step "
                    f"({float(np.median(usual[close - 1])):.3g} s) after the row before them (up to {later_ms:.3g} ms "
                    f"later): two samples where the stream makes one (a row written twice with another "
                    f"reading, equal readings where the stream's repeat, or two stamped together), both kept, at "
                    f"{located(close, lines, where)}", CLOSE_SAMPLES, int(close.size), stacklevel=stacklevel)


def usual_steps(step: np.ndarray) -> np.ndarray:
    """(len(step),) s: the median of a stream's positive stamp steps ``step`` (s, in time order) near each, the
    smallest over its block of :data:`REPEAT_WINDOW_STEPS` positive steps and the blocks on either side (the whole
    file's when it holds fewer); inf at a step not positive. A DVL changing its ping rate with altitude (2 Hz, then
    20 Hz near the bottom) makes its fast pings no shorter than its steps there: over the file, every one was under a
    fifth of the median step (5999 of 12000 pings doubted), and at rest on 1 mm/s counts 3358 dropped as copies."""
    usual = np.full(len(step), np.inf)
    moving = np.flatnonzero(step > 0)
    if not moving.size:
        return usual
    blocks = np.array_split(step[moving], max(1, moving.size // REPEAT_WINDOW_STEPS))
    median = np.array([np.median(b) for b in blocks])
    padded = np.concatenate([[np.inf], median, [np.inf]])
    smallest = np.minimum(np.minimum(padded[:-2], padded[1:-1]), padded[2:])
    usual[moving] = np.repeat(smallest, [len(b) for b in blocks])
    return usual


def nudged_copies(t: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, float]:
    """``(indexes, s)``: the indexes (file order, sorted) of the rows (``rows`` (N,k) as read, their stamps ``t``
    (N,) s) that repeat the row before them in time in every value but the stamp, with a stamp later by less than
    :data:`NUDGED_COPY_STEP_SHARE` of the median step between rows that differ near it
    (:func:`steps_between_readings`): the same sample written twice, its stamp nudged, however many rows are. Rows
    of a stream whose readings repeat across whole steps near them as often (:func:`readings_repeat_near`: an IMU at
    rest with coarse counts, a depth held on coarse counts) may be samples jitter or a burst moved close: not those.
    ``s``: the largest such nudge, s."""
    t, rows = np.asarray(t, float), np.asarray(rows, float)
    order = np.argsort(t, kind="stable")
    step = np.diff(t[order])
    positive = step[step > 0]
    if positive.size < 2:
        return np.zeros(0, int), 0.0
    values = ~_stamp_columns(rows, t)
    a, b = rows[order][:-1][:, values], rows[order][1:][:, values]
    equal = np.all((a == b) | (np.isnan(a) & np.isnan(b)), axis=1)
    short = (step > 0) & (step < NUDGED_COPY_STEP_SHARE * steps_between_readings(step, equal))
    copy = short & equal
    if copy.any():
        moving = np.flatnonzero(step > 0)
        at = np.flatnonzero(copy[moving])             # the candidates among the positive steps
        copy[moving[at[readings_repeat_near(equal[moving], short[moving], at)]]] = False
    if not copy.any():
        return np.zeros(0, int), 0.0
    return np.sort(order[1:][copy]), float(np.max(step[copy]))


def steps_between_readings(step: np.ndarray, equal: np.ndarray) -> np.ndarray:
    """(len(step),) s: :func:`usual_steps` of a stream's steps ``step`` (s, in time order) from a row to one with
    other values (``equal``: each row equal in every value to the one before it), each step given that of the
    nearest such step from it on (else before it); inf at a step not positive. Copies do not set the stream's step:
    with every DVL ping written again 1 ms later, half the steps are 1 ms, their median too, and none was a copy
    (every ping weighed twice, with no word). :func:`usual_steps` of all the steps when fewer than two differ."""
    differ = np.flatnonzero((step > 0) & ~equal)
    if differ.size < 2:
        return usual_steps(step)
    nearest = np.minimum(np.searchsorted(differ, np.arange(len(step))), differ.size - 1)
    return np.where(step > 0, usual_steps(step[differ])[nearest], np.inf)


def say_nudged_copies(nudged: np.ndarray, moved: float, source: str, lines: np.ndarray | None = None,
                      where: list[str] | None = None, stacklevel: int = 2) -> None:
    """Warn about the rows :func:`nudged_copies` found (``nudged``: their indexes, ``moved``: the largest nudge, s),
    named by their file ``lines`` or, for a bag's messages, ``where`` (as :func:`located` names them)."""
    warnings.warn(f"{source}: {nudged.size} row(s) repeating the row before them in every value up to "
                  f"{moved * 1e3:.3g} ms later (the same sample written twice, its stamp nudged) dropped, at "
                  f"{located(nudged, lines, where)}", RuntimeWarning, stacklevel=stacklevel + 1)


def readings_repeat_near(equal: np.ndarray, within: np.ndarray, at: np.ndarray) -> np.ndarray:
    """(len(at),) bool: whether :func:`readings_repeat` over the :data:`REPEAT_WINDOW_STEPS` steps up to or from each
    step ``at`` (indexes; windows moved inside a shorter file) of a stream's rows in time order (``equal``: each equal
    in every value to the one before it; ``within``: its step one at which the stream makes no new sample). Judged
    near the step, not over the file: an IMU at rest with coarse counts on a clock jittering while it waits (60 s
    before a dive), or a depth held on 1 cm counts read in bursts, repeats there as often at whole steps, and a file
    moving elsewhere does not tell; a window on either side, as a stop or a start may be just after or before it.
    Readings never repeating at a whole step there do not (a short file's one row written twice, which the counts
    of 40 rows cannot tell from chance)."""
    counts = np.zeros((4, len(equal) + 1), int)
    for i, kind in enumerate((within & equal, within, ~within & equal, ~within)):
        counts[i, 1:] = np.cumsum(kind)
    last_start = max(0, len(equal) - REPEAT_WINDOW_STEPS)
    repeat = np.zeros(len(at), bool)
    for start in (np.clip(at + 1 - REPEAT_WINDOW_STEPS, 0, last_start), np.clip(at, 0, last_start)):
        n = counts[:, np.minimum(start + REPEAT_WINDOW_STEPS, len(equal))] - counts[:, start]
        repeat |= (n[2] > 0) & np.array([repeat_counts_agree(*map(int, c)) for c in n.T], bool)
    return repeat


def _stamp_columns(rows: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(k,) bool: the columns of ``rows`` (N,k) holding the stamps ``t`` (N,) s: those equal to them, else the first,
    where the readers put the stamp as read (in a time unit other than s)."""
    stamp = np.all(rows == t[:, None], axis=0)
    if not stamp.any():
        stamp[0] = True
    return stamp


def readings_repeat(equal: np.ndarray, step: np.ndarray) -> bool:
    """Whether an IMU's rows (``equal``: each, in time order, equal in every value to the one before it; ``step``:
    the stamps' steps between them, s) repeat from one stamp to the next as often as within a stamp, as far as their
    counts tell (:func:`repeat_counts_agree`): an IMU at rest with coarse counts, whose rows equal to the one before
    at a shared stamp may be samples. Readings with noise differ from sample to sample: a row repeating the one
    before in every value is written again (an even 100 Hz log with every row written twice read as packets of 2 at
    200 Hz, each sample integrated twice)."""
    within = step == 0
    return repeat_counts_agree(int(np.sum(equal[within])), int(np.sum(within)), int(np.sum(equal[~within])),
                               int(np.sum(~within)))


#: How much better (in the Bayesian information criterion) two shares of rows repeating the one before, within a
#: stamp and across stamps, must explain an IMU's counts than one share for the rows to be copies
#: (:func:`repeat_counts_agree`): over 6 is strong evidence. Live, a window's counts are judged at every sample: at 0
#: (the criterion's penalty alone) up to 35 of 6000 samples of an IMU at rest in packets of 2-10 were refused, at 6 one
#: in 240 such streams.
COPY_EVIDENCE_BIC = 6.0


def repeat_counts_agree(same_within: int, n_within: int, same_across: int, n_across: int) -> bool:
    """Whether an IMU's readings repeat from one stamp to the next as they do within a stamp: of its ``n_within``
    steps within a stamp ``same_within`` repeat the sample before in every value, of its ``n_across`` steps to a new
    stamp ``same_across`` do. They do unless the share across is under half the share within and two shares explain
    the counts better than one by :data:`COPY_EVIDENCE_BIC` (a likelihood-ratio G less its cost, the log of the
    steps): 1-3 equal rows among 45000 in packets of 4 and none among the 15000 steps between packets are chance,
    not rows written twice. With no step to a new stamp nothing tells: they may."""
    if not n_across or not n_within or same_across / n_across >= 0.5 * same_within / n_within:
        return True
    g = 2.0 * (_log_likelihood(same_within, n_within) + _log_likelihood(same_across, n_across)
               - _log_likelihood(same_within + same_across, n_within + n_across))
    return g - math.log(n_within + n_across) <= COPY_EVIDENCE_BIC


def _log_likelihood(k: int, n: int) -> float:
    """The log-likelihood of ``k`` of ``n`` trials at their own share."""
    return sum(x * math.log(x / n) for x in (k, n - k) if x)


#: Steps between a live IMU's latest samples over which :class:`RecentRepeats` counts (about 2-4 s at 100-200 Hz).
REPEAT_WINDOW_STEPS = 400


class RecentRepeats:
    """:func:`readings_repeat` of a live IMU over its latest :data:`REPEAT_WINDOW_STEPS` steps: whether a sample
    repeating the one before at its stamp may be a sample (an IMU at rest with coarse counts) or is written again."""

    def __init__(self):
        self._steps: deque[int] = deque(maxlen=REPEAT_WINDOW_STEPS)     # 2 * within a stamp + equal
        self._counts = [0, 0, 0, 0]         # by that index: plain ints, as a 100 Hz stream adds one at every sample

    def add(self, within: bool, equal: bool) -> None:
        """Count a step to the newest sample: at the stamp before it (``within``), repeating it (``equal``)."""
        steps, counts = self._steps, self._counts
        if len(steps) == REPEAT_WINDOW_STEPS:
            counts[steps[0]] -= 1
        step = 2 * bool(within) + bool(equal)
        steps.append(step)
        counts[step] += 1

    def repeat(self) -> bool:
        """Whether the readings repeat across stamps as within them over the window (:func:`repeat_counts_agree`)."""
        c = self._counts
        return repeat_counts_agree(c[3], c[2] + c[3], c[1], c[0] + c[1])

    def repeat_across(self) -> bool:
        """:meth:`repeat`, and the readings repeated across stamps at least once in the window: readings never
        repeating at a whole step do not (:func:`readings_repeat_near`)."""
        return bool(self._counts[1]) and self.repeat()


#: Positive steps of a live stream whose median is its usual step (:class:`NudgedCopies`), and how many it needs first.
NUDGED_STEP_WINDOW = 101
NUDGED_MIN_STEPS = 10
#: The latest positive steps (the newest included) whose median stands for the usual step when smaller
#: (:class:`NudgedCopies`): a stream changing its rate (a DVL from 2 Hz to 20 Hz near the bottom) has its new step
#: there within three samples, where the median of :data:`NUDGED_STEP_WINDOW` steps lags 50; one or two copies
#: among them leave it the stream's step.
NUDGED_RECENT_STEPS = 5


class NudgedCopies:
    """:func:`nudged_copies` on a live stream, sample by sample: a sample repeating the one received before it in every
    value, stamped later by under :data:`NUDGED_COPY_STEP_SHARE` of the median of the latest
    :data:`NUDGED_STEP_WINDOW` positive steps to a sample with other values (or of the latest
    :data:`NUDGED_RECENT_STEPS` such steps, when smaller: a stream changing its rate, as :func:`usual_steps` takes the
    smaller of the blocks near a step; copies do not set the step, as in :func:`steps_between_readings`), is the same
    sample sent twice, its stamp nudged; unless the stream's readings repeat across whole steps as often as across
    such short ones over the latest :data:`REPEAT_WINDOW_STEPS` steps (:meth:`RecentRepeats.repeat_across`: an IMU at
    rest with coarse counts, a depth held on coarse counts, whose samples jitter may move close). Judged once
    :data:`NUDGED_MIN_STEPS` such steps are known; a sample at or before the one before it is left to the stamp
    checks."""

    def __init__(self):
        self._last: tuple[float, tuple] | None = None
        self._steps: deque[float] = deque(maxlen=NUDGED_STEP_WINDOW)
        self._n = 0                         # positive steps seen to a sample with other values
        self._usual = math.inf              # their median, refreshed every tenth step, s
        self._repeats = RecentRepeats()     # "within a stamp" here: a step under the share of the usual one

    def is_copy(self, t: float, values: tuple) -> bool:
        """Whether the sample stamped ``t`` (s) with ``values`` (a tuple of floats, None where there is no value: NaN
        is never equal) is a copy."""
        last, self._last = self._last, (t, values)
        if last is None or not t > last[0]:
            return False
        step = t - last[0]
        equal = values == last[1]
        if not equal:
            self._steps.append(step)
            self._n += 1
            if self._n % 10 == 0:
                self._usual = statistics.median(self._steps)     # of 101 floats: a sort, faster than numpy's
        if self._n < NUDGED_MIN_STEPS:
            return False
        short = step < NUDGED_COPY_STEP_SHARE * self._usual
        if short:           # rare on a steady stream: only then the latest steps' median
            recent = statistics.median(list(self._steps)[-NUDGED_RECENT_STEPS:])
            short = step < NUDGED_COPY_STEP_SHARE * recent
        self._repeats.add(short, equal)
        return short and equal and not self._repeats.repeat_across()


def _say_steps(read: np.ndarray, t: np.ndarray, kept_rows: np.ndarray, lines: np.ndarray, source: str, field: str,
               meta: dict | None, stream: str, filler_lines: np.ndarray | None = None) -> None:
    """:func:`say_imu_stamp_steps` of a file's ``kept_rows`` (indices, in time order) of its IMU stamps ``read``
    (s, as read) and ``t`` (s, as kept, restamped or not), for :func:`stamp_order`'s caller: on the stamps as read
    where they never decrease, else (a repair sorted restamped rows) as kept; ``filler_lines``: the file lines of the
    filler taken out before (:func:`zeroed_filler`). Another ``stream``'s: :func:`say_close_samples`."""
    if stream != "imu":
        say_close_samples(t[kept_rows], lines[kept_rows], source, stream, meta)
        return
    as_read = read[kept_rows] if np.all(np.diff(read[kept_rows]) >= 0) else t[kept_rows]
    say_imu_stamp_steps(as_read, t[kept_rows], source, field, meta, lines=lines[kept_rows], stacklevel=4,
                        filler=filler_between(lines[kept_rows], filler_lines))


#: Reasons under which an IMU's samples read after a step of its stamps are counted as doubted (:func:`stamp_order`).
CLOCK_STEP = "stamped after a step of the IMU clock (no whole number of periods)"
IMU_GAP = "stamped after a gap in the IMU data (whole periods: samples lost, bridged)"


def say_imu_stamp_steps(read: np.ndarray, kept: np.ndarray, source: str, field: str, meta: dict | None,
                        lines: np.ndarray | None = None, where: list[str] | None = None, stacklevel: int = 2,
                        filler: np.ndarray | None = None) -> None:
    """Warn about the steps of an IMU's stamps ``read`` (s, as read, never decreasing; ``kept``: as the reader keeps
    them, restamped or not, s) off a line at its period (:func:`~graphnav.core.imu_timing.stamp_steps`), each kind
    once, and count the sample after each as doubted in ``meta``: a step no whole number of periods long is the IMU
    clock stepping, one of :data:`~graphnav.core.imu_timing.GAP_WARN_SAMPLES` periods or more a gap the run bridges
    (or the clock stepping whole periods: the stamps cannot tell); one sample lost is neither. The samples keep their
    stamps. Every reader's IMU stamps go through it: ``source`` and ``field`` name the file (a bag's topic) and the
    stamp field, each sample is named as :func:`located` names it (``lines``: a file's lines; ``where``: a bag's
    messages with their time); ``stacklevel``: the caller's own. ``filler`` (N-1,) int: the rows of a logger's filler
    with their stamps zeroed taken out between each sample and the next (:func:`filler_between`): a gap they leave
    alone is no samples lost (its rows were refused as filler, and said so), only what they leave beyond it."""
    period = imu_step_stats(np.diff(kept))[0]
    at, jump, lost = stamp_steps(read, period)
    taken = np.zeros(at.size, int) if filler is None else np.asarray(filler, int)[at]
    lost = np.where((taken > 0) & (lost > 0), np.maximum(lost - taken, 1), lost)
    for hit, reason in ((lost == 0, CLOCK_STEP), (lost >= GAP_WARN_SAMPLES, IMU_GAP)):
        if not np.any(hit):
            continue
        i, size, m, k = at[hit][0], jump[hit][0], lost[hit][0], taken[hit][0]
        filler_rows = f" beyond the {k} row(s) of filler taken out there" if k else ""
        what = (f"the IMU clock steps {1e3 * size:+.4g} ms off its period ({size / period:+.3g} periods: no whole "
                "number of them, so no samples lost explain it)" if reason == CLOCK_STEP else
                f"a gap of {size:.4g} s in the stamps ({m + k} periods, a whole number: {m} samples lost{filler_rows}, "
                "or the clock stepped as many periods; the stamps cannot tell), which the run bridges")
        warnings.warn(f"imu: {source}, {located(at[hit] + 1, lines, where, first=True)}, field '{field}': {what}, "
                      f"from t = {float(read[i])!r} to {float(read[i + 1])!r} s ({int(hit.sum())} such, at "
                      f"{located(at[hit] + 1, lines, where)}); the samples keep their stamps", RuntimeWarning,
                      stacklevel=stacklevel + 1)
        if meta is not None:
            count_doubted(meta, "imu", reason, int(hit.sum()))


def filler_between(order: np.ndarray, taken: np.ndarray | None) -> np.ndarray | None:
    """(N-1,) int: how many of the rows ``taken`` out (positions in the file: lines, a topic's message indexes; a
    logger's filler with its stamps zeroed, :func:`zeroed_filler`) lie between each row at ``order`` (N,) and the next
    (file positions, in time order; none where they go back); None without any taken."""
    if taken is None or not len(taken):
        return None
    taken, order = np.sort(np.asarray(taken, int)), np.asarray(order, int)
    return np.maximum(np.searchsorted(taken, order[1:]) - np.searchsorted(taken, order[:-1]), 0)


def first_lines(lines: np.ndarray) -> str:
    """The first ten of ``lines`` (file lines) for a warning."""
    return ", ".join(str(int(i)) for i in lines[:10]) + (" ..." if len(lines) > 10 else "")


def located(rows: np.ndarray, lines: np.ndarray | None = None, where: list[str] | None = None, line_offset: int = 0,
            first: bool = False, t: np.ndarray | None = None) -> str:
    """Where the file holds the samples ``rows`` (indexes into the stream), for a warning: ``where[i]`` when given
    (a PD0 ensemble, a bag message with its time), else the file line ``lines[i]``, else the index plus
    ``line_offset`` (a line when an offset is given); a stream with no file (``t``: its stamps, s, and no offset)
    says "sample i at t = ... s". The first ten, or with ``first`` the first one alone."""
    rows = np.asarray(rows, int)[:1] if first else np.asarray(rows, int)
    if where is None and lines is None and not line_offset and t is not None:
        where = [f"sample {i} at t = {float(t_i):.3f} s" for i, t_i in enumerate(t)]
    if where is not None:
        return ", ".join(str(where[i]) for i in rows[:10]) + (" ..." if len(rows) > 10 else "")
    named = np.asarray(lines)[rows] if lines is not None else rows + line_offset
    kind = "line" if lines is not None or line_offset else "index"
    if first:
        return f"{kind} {int(named[0])}"
    return ("line(s) " if kind == "line" else "index(es) ") + first_lines(named)


def dvl_outages(t: np.ndarray, usable: np.ndarray, rate_hz: float) -> list[tuple[float, float]]:
    """Stretches (t_start, t_end) s, where the DVL gave no usable ping for longer than :data:`OUTAGE_PERIODS`
    nominal periods (and :data:`OUTAGE_MIN_S`): from the last usable ping before to the first after (the
    stream's ends included when the pings stop or start late)."""
    t = np.asarray(t, float)
    good = t[np.asarray(usable, bool)]
    limit = max(OUTAGE_PERIODS / rate_hz if rate_hz > 0 else 0.0, OUTAGE_MIN_S)
    if t.size == 0:
        return []
    edges = np.concatenate([[t[0]], good, [t[-1]]])
    gaps = np.diff(edges)
    return [(float(edges[i]), float(edges[i + 1])) for i in np.flatnonzero(gaps > limit)]


def note_outages(meta: dict, t: np.ndarray, usable: np.ndarray, rate_hz: float, source: str) -> list:
    """Warn about and count (``meta["streams"]["dvl"]["outages"]``, a note) the DVL outages of
    :func:`dvl_outages`."""
    outages = dvl_outages(t, usable, rate_hz)
    if outages:
        entry = stream_entry(meta, "dvl")
        entry["outages"] = [[a, b] for a, b in outages]
        total = sum(b - a for a, b in outages)
        first = outages[0]
        text = (f"{len(outages)} DVL outage(s), {total:.0f} s in all without a usable ping (first "
                f"{first[0]:.1f}-{first[1]:.1f} s); the estimators coast on the IMU there")
        add_note(meta, "dvl", text)
        warnings.warn(f"{source}: {text}", RuntimeWarning, stacklevel=3)
    return outages


# ------------------------------------------------------------------------------------------------
# sample by sample (the stream)
# ------------------------------------------------------------------------------------------------
class SpikeTest:
    """Causal spike test for one signal of a stream: a sample departing from the component-wise median of the
    last ``neighbours`` accepted samples by more than ``1.5 * max_rate * dt + tolerance`` (dt: s since the
    newest accepted sample) is a spike. ``reset_after`` spikes in a row that agree with each other within
    the tolerance are a lasting change (a real manoeuvre the history missed): the history restarts from them
    and the sample is accepted.
    """

    def __init__(self, max_rate: float, tolerance: float, neighbours: int = SPIKE_NEIGHBOURS,
                 reset_after: int = 3):
        self.max_rate, self.tolerance = float(max_rate), float(tolerance)
        self.reset_after = int(reset_after)
        self._hist: deque = deque(maxlen=int(neighbours))      # (t, x)
        self._run: list = []                                   # consecutive spikes (t, x)

    def is_spike(self, t: float, x) -> bool:
        """Test the sample (t s, x array-like) and, when accepted, add it to the history."""
        if isinstance(x, float) and not self._run:
            # a scalar stream (depth, one beam) in its usual state, at every sample: the same test without numpy
            hist = self._hist
            if len(hist) == hist.maxlen:
                past = sorted(h[1][0] for h in hist)
                n = len(past)
                ref = past[n // 2] if n % 2 else (past[n // 2 - 1] + past[n // 2]) / 2
                dt = max(t - hist[-1][0], 0.0)
                if not abs(x - ref) <= 1.5 * self.max_rate * dt + self.tolerance:
                    return self.is_spike(t, np.array([x]))
            self._accept(t, np.array([x]))
            return False
        x = np.atleast_1d(np.asarray(x, float))
        if len(self._hist) < self._hist.maxlen:
            self._accept(t, x)
            return False
        ref = np.median(np.array([h[1] for h in self._hist]), axis=0)
        dt = max(t - self._hist[-1][0], 0.0)
        if np.linalg.norm(x - ref) <= 1.5 * self.max_rate * dt + self.tolerance:
            self._accept(t, x)
            return False
        self._run.append((t, x))
        if len(self._run) >= self.reset_after:
            xs = np.array([r[1] for r in self._run])
            if np.all(np.linalg.norm(xs - np.median(xs, axis=0), axis=1) <= self.tolerance):
                run, self._run = self._run, []
                self._hist.clear()
                for t_r, x_r in run:
                    self._hist.append((t_r, x_r))
                return False
            self._run = self._run[1:]
        return True

    def _accept(self, t: float, x: np.ndarray) -> None:
        self._hist.append((t, x))
        self._run = []


class ImuSpikeTest:
    """The IMU spike test of :func:`imu_spikes` on a stream, which has the past only: a row is a spike when a value
    departs from the median of the last ``n`` accepted rows (:data:`IMU_SPIKE_HALF_WINDOW_S`) by more than ``max(floor,
    factor * noise)``, the noise :func:`imu_noise_scale`'s over the accepted rows in blocks of ``block`` rows
    (:data:`IMU_SPIKE_SCALE_S`; the larger of the last two complete blocks; before the first block completes, the rows
    so far; and, for a departing value, of the block under way: vibration that just started). A departing value that did
    not :func:`jump <jumped>` there from the row tested before, whose value was not refused, is a shock's and accepted,
    as in :func:`imu_spikes`. Nothing is tested until the history is full. More than ``n`` spikes in a row are a lasting
    change: the history restarts from the next departing row, which is accepted.

    The rows per span come from the stream's own first :data:`IMU_SPIKE_RATE_ROWS` stamps (:func:`imu_rate_hz`;
    those rows are accepted; stamps on a clock's grid: as many as :meth:`_spans_the_grid` needs), after the burst
    it starts with, if any (:func:`start_burst` against the configured ``period_s``, s, when given: 50 samples 0.1
    ms apart read 10 kHz, a 10 s window); under
    :data:`IMU_SPIKE_MIN_RATE_HZ` the test is off
    (:attr:`note` says why) and accepts every row. Plain Python on six floats per row: the Navigator calls it at the
    IMU's rate (about 6 us a row).
    """

    def __init__(self, floors, period_s: float | None = None):
        self.floors = np.asarray(floors, float)
        self.period_s = period_s
        self._lead = period_s is not None                   # the first stamps may be a burst the stream starts with
        self.rate_hz: float | None = None
        self.active: bool | None = None                     # None until the rate is known
        self.note: str | None = None                        # why the test is off, once it is
        self.n = self.block = 0                             # half window and noise block, rows
        self._stamps: list[float] = []                      # stamps seen while the rate is measured
        self._needed = IMU_SPIKE_RATE_ROWS                  # stamps to measure it over
        self._grid_checked = False
        self._hist: deque = deque()                         # accepted rows, oldest first
        self._sorted: list[list[float]] = [[] for _ in self.floors]   # the same values, sorted per column
        self._rows: list = []                               # accepted rows of the current noise block
        self._block_scale: np.ndarray | None = None         # the last complete block's noise scale
        self._limit: list[float] | None = None              # per column, m/s^2 or rad/s
        self._run = 0
        self._before = None                                 # the row tested before, as given
        self._refused = [False] * len(self.floors)          # whether each of its values was refused

    def check(self, t: float, x) -> tuple[int, float, float] | None:
        """Test the row ``x`` (six floats: f_b m/s^2, omega_b rad/s) stamped ``t`` (s) and accept it when it is not
        a spike. Returns None, or (index of the first departing value, the median it departs from, the limit)."""
        if self.active is None:
            stamps = self._stamps
            stamps.append(float(t))
            self._hist.append(x)
            if self._lead and len(stamps) > 1:
                n = start_burst(np.diff(stamps), self.period_s)
                if n is None:
                    return None
                del stamps[:n]          # the burst's stamps but its last: the rate is from the steps after it
                self._lead = False
            if (not self._lead and len(stamps) >= self._needed and self._spans_the_grid()
                    and not (self.period_s and awaits_packet_cycles(np.diff(stamps), self.period_s))):
                self._set_rate(imu_rate_hz(self._stamps, None if self.period_s is None else 1.0 / self.period_s))
            return None
        if not self.active:
            return None
        hit = None
        if self._limit is not None and len(self._hist) == self.n:
            hit = self._spike(x)
        self._before = x
        if hit is not None:
            self._run += 1
            if self._run <= self.n:
                return hit
            self._restart()
        self._accept(x)
        return None

    def _spike(self, x) -> tuple[int, float, float] | None:
        """(index, median, limit) of the first value of ``x`` departing from the median of the history that is no
        shock's (it :func:`jumped` there from the row tested before, or that row's value was refused: as
        :func:`imu_spikes`), or None; marks each value refused or not."""
        lo, hi = (self.n - 1) // 2, self.n // 2
        hit = None
        for j, (v, col, lim) in enumerate(zip(x, self._sorted, self._limit)):
            ref = 0.5 * (col[lo] + col[hi])
            refused = False
            if abs(v - ref) > lim:
                lim = max(lim, self._recent_limit(j))
                refused = abs(v - ref) > lim and (self._refused[j] or self._before is None
                                                  or bool(jumped(v - ref, self._before[j] - ref, lim)))
                if refused and hit is None:
                    hit = j, ref, lim
            self._refused[j] = refused
        return hit

    def _spans_the_grid(self) -> bool:
        """Whether the stamps so far measure the rate to :data:`IMU_SPIKE_RATE_TOLERANCE`: on a grid found in the
        first :data:`IMU_SPIKE_RATE_ROWS`, the stamps needed to span 2 / tolerance grid steps are awaited."""
        stamps = self._stamps
        if not self._grid_checked:
            self._grid_checked = True
            quantum = imu_stamp_quantum(np.diff(stamps))
            step = (stamps[-1] - stamps[0]) / (len(stamps) - 1)
            if quantum and step > 0:
                self._needed = max(self._needed, 1 + math.ceil(2.0 * quantum / (IMU_SPIKE_RATE_TOLERANCE * step)))
        return len(stamps) >= self._needed

    def _set_rate(self, rate_hz: float) -> None:
        """Fix the rows per span at ``rate_hz`` (or switch the test off); the rows seen so far become the history."""
        self.rate_hz = rate_hz
        rows = imu_spike_rows(rate_hz)
        self.active = rows is not None
        seen, self._stamps = list(self._hist), []
        self._hist.clear()
        self._rows = []
        if rows is None:
            self.note = imu_spike_off_note(rate_hz)
            return
        self.n, self.block = rows
        for x in seen:
            self._accept(x)

    def _recent_limit(self, j: int) -> float:
        """The limit of value ``j`` from the rows of the block under way, once it has ``n`` differences
        (vibration that started after the last complete block); 0 before. Only asked for a departing value."""
        if len(self._rows) <= self.n:
            return 0.0
        v = np.asarray(self._rows, float)[:, j]
        return IMU_SPIKE_NOISE_FACTOR * DIFF_MAD_TO_SIGMA * float(np.median(np.abs(np.diff(v))))

    def _restart(self) -> None:
        self._refused = [False] * len(self.floors)
        self._hist.clear()
        for col in self._sorted:
            col.clear()
        self._rows.clear()

    def _accept(self, x) -> None:
        self._run = 0
        hist = self._hist
        if len(hist) == self.n:
            for col, old, new in zip(self._sorted, hist.popleft(), x):
                del col[bisect.bisect_left(col, old)]
                bisect.insort(col, new)
        else:
            for col, new in zip(self._sorted, x):
                bisect.insort(col, new)
        hist.append(x)
        rows = self._rows
        rows.append(x)
        if len(rows) > self.block or (self._limit is None and len(hist) == self.n):
            self._update_limit(len(rows) > self.block)

    def _update_limit(self, complete: bool) -> None:
        diffs = np.abs(np.diff(np.asarray(self._rows, float), axis=0))
        scale = DIFF_MAD_TO_SIGMA * np.median(diffs, axis=0)
        if complete:
            previous = scale if self._block_scale is None else self._block_scale
            self._block_scale = scale
            scale = np.maximum(scale, previous)
            self._rows = self._rows[-1:]          # the next block's differences start from this row
        self._limit = np.maximum(self.floors, IMU_SPIKE_NOISE_FACTOR * scale).tolist()


class ZeroPingTest:
    """:func:`zeros_without_lock` on a stream: the resolution from the values seen so far, the speed (``speed_of``
    its values, m/s) of the newest ping that was not all zeros and had one, each run of zero pings judged as
    :func:`no_bottom_lock` judges a file's: at each ping of the run (its length can decide: a third refuses the run's
    first two too), and, when the run is still kept, by the next ping that is not all zeros (the speed after the
    run). :meth:`judge` holds a zero ping until that ping comes; :meth:`is_no_lock` tells the past alone."""

    def __init__(self, spec: DvlSpec, speed_of):
        self.spec, self.speed_of = spec, speed_of
        self.on = self.off = 0                   # non-zero values on / off the resolution grid so far
        self._last: tuple[float, float] | None = None       # (speed m/s, stamp s)
        self._verdict: bool | None = None        # the current run's
        self._run = 0                            # zero pings in the current run
        self._t_run = math.nan                   # stamp of the run's newest ping, s
        self._t_ping = math.nan                  # stamp of the newest ping, s
        self._steps: deque[float] = deque(maxlen=PING_PERIOD_STEPS)     # between the newest pings, s

    def is_no_lock(self, t: float, values) -> bool:
        """Whether the ping at ``t`` s (``values`` as logged, NaN where not a measurement) is a zero ping without
        bottom lock from the pings up to it; any other ping joins the history."""
        return bool(self.judge(t, values)[0])

    def judge(self, t: float, values) -> tuple[bool | None, bool | None]:
        """(this ping, the run before it) for the ping at ``t`` s (``values`` as logged, NaN where not a
        measurement): this ping is a zero ping without bottom lock (True), a ping to use (False), or a zero ping the
        next ping decides (None: hold it); the zero pings held before it are no lock (True), to use (False), or still
        held (None: none, or this ping is one more zero). Any ping that is not all zeros joins the history."""
        values = np.asarray(values, float)
        if t > self._t_ping:
            self._steps.append(t - self._t_ping)
        self._t_ping = t
        if not zero_pings(values[None])[0]:
            held = None
            if self._run and not self._verdict:         # the run's pings were held: the speed after it decides
                speed = float(self.speed_of(values))
                after = (speed, t - self._t_run) if math.isfinite(speed) else None
                held = zeros_without_lock(self.off > self.on, self._before(self._t_run), after, self.spec, self._run)
            on, off = on_resolution_grid(values)
            self.on, self.off, self._verdict, self._run = self.on + on, self.off + off, None, 0
            speed = float(self.speed_of(values))
            self._last = (speed, t) if math.isfinite(speed) else self._last
            return False, held
        self._run += 1
        self._t_run = t
        if self._verdict:
            return True, None
        self._verdict = zeros_without_lock(self.off > self.on, self._before(t), None, self.spec, self._run)
        return (True, True if self._run > 1 else None) if self._verdict else (None, None)

    def _before(self, t: float) -> tuple[float, float] | None:
        return None if self._last is None else (self._last[0], t - self._last[1])

    @property
    def hold_s(self) -> float:
        """How long (s) a zero ping is held for the next ping: :data:`ZERO_HOLD_INTERVALS` of the stream's ping
        period (the median of the last :data:`PING_PERIOD_STEPS` steps, or the newest step when longer, up to
        :data:`ZERO_HOLD_SLOWDOWN` times the median: a DVL that slows its pings as it climbs is waited for, a silence
        is not); a stream silent for longer (an outage) leaves the run kept, as the past says."""
        period = float(np.median(self._steps)) if len(self._steps) >= 3 else 1.0 / self.spec.rate_hz
        if self._steps and self._steps[-1] <= ZERO_HOLD_SLOWDOWN * period:
            period = max(period, self._steps[-1])
        return ZERO_HOLD_INTERVALS * period


@dataclass
class StreamScreen:
    """The per-sample rules of a :class:`~graphnav.estimators.navigator.Navigator`'s stream, from one
    configuration. Each ``*_problem`` returns why a sample is refused (a short reason that is also its count
    key) or None; the DVL one returns the failing beams with their reasons."""

    config: SensorConfig
    #: (M,4) beams, (M,4) valid -> (M,) speed, m/s (:func:`graphnav.core.dvl.ping_speed` with the configuration's
    #: DVL: given by the caller, since the DVL geometry's module reads this one)
    beams_speed: Callable[[np.ndarray, np.ndarray], np.ndarray]
    #: whether the stream judges DVL pings of exactly 0 (False: a replayed mission's loader judged them, with the
    #: file's resolution and the pings after each run)
    judge_zeros: bool = True

    def __post_init__(self):
        dvl = self.config.dvl
        self._beam_spikes = [SpikeTest(dvl.max_accel_mps2, dvl.jump_tolerance_mps) for _ in range(4)]
        self._depth_spike = SpikeTest(dvl.max_vertical_mps, self.config.depth_jump_tolerance_m)
        self._imu_spike = ImuSpikeTest(imu_spike_floors(self.config), 1.0 / self.config.imu_rate_hz)
        beam_speed = lambda b: self.beams_speed(b[None], np.isfinite(b)[None])[0]  # noqa: E731
        self.zero_ping = ({"dvl": ZeroPingTest(dvl, beam_speed), "dvl_velocity": ZeroPingTest(dvl, np.linalg.norm)}
                          if self.judge_zeros else {})
        self._newest = -math.inf      # newest stamp accepted on any stream (one clock)
        self.oldest = math.inf        #: oldest stamp accepted on any stream, s
        #: the first stamp more than MAX_STAMP_GAP_S ahead of the newest or behind it: (stream, newest stamp before it,
        #: its stamp), s
        self.clock_jump: tuple[str, float, float] | None = None
        #: samples per stream refused for such a jump
        self.jumped: dict[str, int] = {}
        #: IMU samples refused for the jump of :attr:`clock_jump` since no IMU sample went on past it (0 when one
        #: did: that jump was a corrupted stamp, and the next starts a new one)
        self._imu_jump_run = 0
        self._jump_open = False
        #: since the jump of :attr:`clock_jump` opened: whether a stream other than the IMU went on past it on the old
        #: clock, and whether one had a sample refused for it (:attr:`imu_alone`)
        self._others_on = self._others_off = False

    def stamp_problem(self, stream: str, t: float) -> str | None:
        """Why a stamp of ``stream`` is refused: beyond the bounds, or a jump of more than
        :data:`MAX_STAMP_GAP_S` ahead of the newest stamp of the streams or behind it (:func:`stamp_jumps`; they share
        one clock: the first such jump is kept in :attr:`clock_jump`, the samples refused for one counted in
        :attr:`jumped`; a first record days ahead of the stream after it shows as the stream jumping back)."""
        why = stamp_problem(t)
        if why is not None:
            return why
        t = float(t)
        why = stamp_jumps(t, self._newest)
        if why is not None:
            if not self._jump_open:
                self.clock_jump, self._jump_open, self._imu_jump_run = (stream, self._newest, t), True, 0
                self._others_on = self._others_off = False
            self.jumped[stream] = self.jumped.get(stream, 0) + 1
            self._imu_jump_run += stream == "imu"
            self._others_off |= stream != "imu"
            return why
        if self._jump_open and t > self.clock_jump[1]:
            if stream == "imu":
                self._jump_open = False     # the IMU went on past the jump on the old clock: no step
            elif t > self.clock_jump[1] + CLOCK_JUMP_LATE_S:
                self._others_on = True
        self._newest = max(self._newest, t)
        self.oldest = min(self.oldest, t)
        return None

    def clock_stepped(self) -> bool:
        """Whether the IMU samples refused for the jump of :attr:`clock_jump`, with no IMU sample going on past it
        meanwhile, cover :data:`CLOCK_JUMP_CONFIRM_S` at the configured rate (isolated corrupted stamps do not add
        up to a step)."""
        return self._jump_open and self._imu_jump_run >= CLOCK_JUMP_CONFIRM_S * self.config.imu_rate_hz

    @property
    def imu_alone(self) -> bool:
        """Whether only the IMU's samples were refused for the jump of :attr:`clock_jump` while another stream went
        on past it on the old clock: the IMU's stamps are off the clock the others share (an IMU stamped from its
        boot among streams on Unix time), no step of the shared clock; the stream neither starts over on the IMU's
        clock nor is split there."""
        return self._jump_open and self._others_on and not self._others_off

    def clock_jump_text(self, received: dict[str, int], refused_stream: str = "imu") -> str:
        """The clock jump of :attr:`clock_jump` in words, with the samples of each stream (``received``: counts
        per stream) it refused; when ``refused_stream``, mostly refused for jumps, is not the IMU and no IMU sample
        jumped, or is the IMU and jumped alone (:attr:`imu_alone`), its own clock is days off the others' (splitting
        the stream would not help)."""
        stream, before, after = self.clock_jump
        own_clock = self.imu_alone if refused_stream == "imu" else not self.jumped.get("imu")
        if own_clock:
            n = self.jumped.get(refused_stream, 0)
            others = ("the IMU's", "the IMU went on") if refused_stream != "imu" else ("the other streams'",
                                                                                       "they went on")
            return (f"{n} of {received.get(refused_stream, n)} {refused_stream} samples are stamped more than "
                    f"{MAX_STAMP_GAP_S:g} s {jump_direction(before, after, others[0])} (by "
                    f"{abs(after - before):.6g} s at t = {before:.3f} s) "
                    f"while {others[1]}: the {refused_stream} stamps are not on the clock the other streams "
                    "share; correct its stamps (their offset) or its clock")
        refused = ", ".join(f"{n} of {received.get(s, n)} {s}" for s, n in self.jumped.items())
        return (f"the clock jumped {clock_jump_words(before, after)} at t = {before:.3f} s, "
                f"first on the {stream} stream (its sample stamped {after:.6g} s): more than {MAX_STAMP_GAP_S:g} s, "
                f"no stream pauses so long; {refused} samples refused after it (every stream shares the clock); "
                "split the stream there or correct its stamps")

    def imu_problem(self, f_b, omega_b) -> str | None:
        imu = self.config.imu
        if max(abs(a) for a in f_b) > imu.accel_range_mps2:
            return f"f_b beyond {imu.accel_range_mps2:g} m/s^2"
        if max(abs(a) for a in omega_b) > imu.gyro_range_rads:
            return f"omega_b beyond {imu.gyro_range_rads:g} rad/s"
        return None

    def imu_spike(self, t: float, f_b, omega_b) -> tuple[str, str] | None:
        """(reason, detail) when the sample stamped ``t`` (s; f_b m/s^2, omega_b rad/s: three floats each, within
        full scale, in stamp order) is a spike (:class:`ImuSpikeTest`), else None; an accepted sample joins the
        history. :attr:`imu_spike_note` says when the test is off."""
        x = tuple(f_b) + tuple(omega_b)
        if not any(x):          # a logger's filler: the keyframer drops and counts it (and it is no history)
            return None
        hit = self._imu_spike.check(t, x)
        if hit is None:
            return None
        j, ref, limit = hit
        value = x[j]
        return (f"spike in '{IMU_FIELDS[j]}'",
                f"{IMU_FIELDS[j]} = {value:.6g} departs from the median {ref:.6g} of the last {self._imu_spike.n} "
                f"samples ({IMU_SPIKE_HALF_WINDOW_S:g} s at {self._imu_spike.rate_hz:.4g} Hz) by more than "
                f"{limit:.3g} (the larger of ImuSpec.{'accel' if j < 3 else 'gyro'}_spike_floor_"
                f"{'mps2' if j < 3 else 'rads'} and {IMU_SPIKE_NOISE_FACTOR:g} x the signal's noise)")

    @property
    def imu_spike_note(self) -> str | None:
        """Why the IMU spike test is off (the stream's rate is too low), once its rate is known; else None."""
        return self._imu_spike.note

    def dvl_problems(self, t: float, beams: np.ndarray, valid: np.ndarray) -> dict[int, str]:
        """{beam index: reason} for the valid beams that are refused (range, then spike per beam)."""
        spec = self.config.dvl
        out = {}
        for i in np.flatnonzero(valid):
            b = float(beams[i])
            if abs(b) > spec.max_speed_mps:
                out[int(i)] = f"beam beyond {spec.max_speed_mps:g} m/s"
            elif self._beam_spikes[i].is_spike(t, b):
                out[int(i)] = "beam spike"
        return out

    def depth_problem(self, t: float, depth_m: float) -> str | None:
        lo, hi = self.config.depth_range_m
        if not lo <= depth_m <= hi:
            return f"depth outside [{lo:g}, {hi:g}] m"
        if self._depth_spike.is_spike(t, depth_m):
            return "depth spike"
        return None
