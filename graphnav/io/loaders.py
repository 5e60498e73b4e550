"""Readers for the published real data sets, and the one reading entry point the CLI commands share.

A-KIT (``ansfl/A-KIT``, Snapir AUV, June 2022): one folder ``TrajectoryN/`` with
``IMU_trajectoryN.csv`` (100 Hz), ``DVL_trajectoryN.csv`` and ``GT_trajectoryN.csv`` (1 Hz).
BeamsNet (``ansfl/BeamsNet``, May 2021): ``V.npy`` (3,N) and ``V_test.npy`` DVL body velocities at 1 Hz.
Please cite the data authors (A-KIT: Cohen & Klein; BeamsNet: Cohen & Klein) when using them.

What reading an A-KIT folder (:func:`read_akit_mission`) and preparing it
(:func:`graphnav.calibration.preparation.prepare`) do to the recorded files, and why (each step is a parameter).
The reader only reads: steps 1, 4 (NED, attitude, depth) and 5; what needs estimating from the data, steps 2
and 3 and the move of the GT to the IMU point, is the prepare step's (the read mission has
``meta["prepared"] = False``):

1. **Stamps.** The published stamps are ``linspace(0, 400, N)``: period 400/(N-1), i.e. 1.0025 s for the
   1 Hz files and 0.01000025 s for the IMU. The sensors ran at 1 Hz and 100 Hz: with the published stamps,
   the IMU-to-GT attitude alignment drifts by -2.5 ms per second over a file (from -0.45 s to -1.35 s on
   trajectory 1, measured in 50 s windows), and it is constant after rescaling. ``rescale_stamps=True``
   (default) therefore puts each file's stamps back on the sensor's period (:data:`AKIT_NOMINAL_RATE_HZ`),
   ``(N-1)/N`` for a file of N rows (:func:`published_period_factor`). The factor comes from the stamp step,
   not from the rows present or the last stamp: a file with rows deleted (an outage cut out of the log, most of its
   rows) or cut short keeps the stamps it had in the whole file. Rows missing from the stamp grid are warned about and
   noted; a row written twice 1 ms later (the same values: dropped by :func:`read_csv`; other values: kept, warned
   about and doubted there, and on the grid point of the row before it) leaves the grid read. The stamps are scaled
   about the folder's clock origin (:func:`akit_stamp_origins`): 0 for the published files, cut or trimmed at the
   start or not (their stamps stay on the grid that starts at 0), the first stamp of a folder on a clock more than a
   day from zero (a Unix clock: scaled about zero, 1.7e9 s moved by 4e6 s), a file's own first stamp when it starts
   on a clock days away. Stamps that are not such a grid (a logger's own, jittered stamps; stamps already on the
   period; a grid at another rate) are kept as read, with a note, and a folder with files of both kinds is warned
   about.
   Stamps that are not times (beyond :data:`graphnav.core.screening.MAX_STAMP_S`, or a lone stamp a day away
   from its neighbours) are refused with their rows and counted, before the order check.
2. **IMU axes.** ``imu_axis_signs`` multiplies the raw x/y/z of both accelerometer and gyro. The
   published IMU files predate the authors' "corrected the transformation" commit: their y axis is
   flipped (``(1, -1, 1)``); the corrected files have y in the body frame (``(1, 1, 1)``). The default
   ``"auto"`` detects the convention when the mission is prepared, with the IMU axis check
   (:func:`graphnav.calibration.axes.detect_imu_axis_signs`: gyro against the GT attitude, or gravity/gyro
   consistency without GT) and warns what it chose; an explicit tuple (or a ``--config`` that sets
   ``imu_axis_signs``) is used as given. No fitting sign convention (swapped axes, gyro and accelerometer
   flipped differently) is a DataError naming the axis.
3. **Time offsets.** Every stream ends on the IMU clock: ``t = t_file (rescaled) + offset``.
   ``config.gt_time_offset_s`` and ``config.dvl_time_offset_s`` record the offsets added (0 until prepared).
   ``"auto"`` estimates them in the prepare step (about 0.2 s per trajectory, see
   :mod:`graphnav.calibration.reference`): the GT offset by matching gyro-integrated attitude increments
   with the GT's, then the DVL offset by regressing the DVL velocity on the GT body velocity plus
   ``omega x l`` (lever arm held at ``lever_arm_b``). Estimating from the data rather than shipping a
   table works for any A-KIT folder, including the three not in ``../shared/data``. A GT or DVL file on a clock
   of its own (seconds or days away) is first put on the IMU clock from the data
   (:mod:`graphnav.calibration.clock`). A file sharing the folder's clock has its offsets, found or given, added to
   its stamps as rescaled about the folder's origin (step 1): one a few seconds late, rescaled about 0 with its
   shift, records 0.0025 of the shift more than the published file's offset less the shift. A file starting further
   from the IMU's first stamp than the longest file lasts (a day away, late or early) is rescaled about its own first
   stamp, and its offset, found, given or quoted by a message, is for its stamps as written
   (:func:`graphnav.core.streams.offset_on_rescaled_stamps`): the published file's offset less the clock's shift,
   given, lands where the published file's samples do (to 0.0025 of the offset: 2.5 ms), and is what the clock search
   records. (Added after its own rescale, a given offset landed 0.0025 ``t0`` s late for a piece cut ``t0`` s into a
   published grid: 0.83 s from 330 s.) Either way the searched samples land where the published file's do.
4. **GT.** lat/lon/alt -> NED with the project's one position convention
   (:data:`graphnav.core.mission.NED_ORIGIN_CONVENTION`): the origin is the sea surface above the first GT
   sample, ``origin_lla = (lat0, lon0, 0)``, so north/east start at 0 and ``p_n[:, 2]`` is the absolute depth
   (as the estimators' depth factors and the aligner put it); ``C_b_n`` from roll/pitch/yaw; the depth
   stream is that depth (``-altitude`` of the GT; ``meta["depth_source"] = "gt"``: the files carry no depth
   sensor). Before that the GT's units are checked (:mod:`graphnav.io.units`, as the IMU's and DVL's are):
   latitude/longitude and roll/pitch/yaw in degrees (out of the radian range, or moving 57x faster than the GT's
   velocity and the gyro say) are converted with a warning naming the file and columns; an altitude whose depth
   is mostly outside ``depth_range_m`` is flipped back when it changes against ``V Down``, else refused naming
   the line and ``Altitude [m]`` (also named, through ``meta["stream_fields"]``, by a later error about the depth
   stream).
5. **DVL.** Pings outside the vehicle's envelope (:class:`~graphnav.core.config.DvlSpec` ``max_*``: speed,
   ``|v_z|`` as without bottom lock, spikes no vehicle can make; :func:`graphnav.core.dvl.implausible_pings`)
   are marked invalid with a warning naming their lines (counts in ``meta["dvl_implausible"]`` and, with every
   other refusal, in ``meta["streams"]``; none on the ten shared trajectories). A stretch without a usable
   ping (NaN rows, deleted rows) longer than ``OUTAGE_MIN_S`` is warned about as a DVL outage.
   IMU rows with an empty, NaN or infinite cell, beyond the instrument's full scale (``ImuSpec.accel_range_mps2`` /
   ``gyro_range_rads``) or spiking (a run of up to ten rows departing from the running median past
   ``ImuSpec.*_spike_floor_*`` and the signal's own noise, :func:`graphnav.core.screening.imu_spikes`), and GT
   rows with an empty, NaN or infinite cell, whose velocity is beyond the vehicle's speed or spikes, or whose
   position jumps where the velocity does not (the column-map reader's rule, :func:`graphnav.core.screening.gt_refusals`
   and :func:`~graphnav.core.screening.with_position_spikes`) are refused (dropped, counted, warned about with their
   lines and column) before the axis detection and the time-offset estimates see them; an empty DVL cell is NaN, an
   invalid ping, and an infinite one makes the ping invalid (as an RDI flag does). More than half of a stream refused
   is a DataError.
   The file velocities are the DVL-head velocity in the body frame: they become ``dvl.v_b``
   (after ``C_d_b`` and ``1 / (1 + velocity_scale_correction)`` of a calibrated config, identity and 1 by
   default), and beams are made from them with :func:`graphnav.core.dvl.make_beams` (the paper's error model, seeded
   by ``beam_seed``). NaN rows are invalid pings.
6. **IMU error model** (:data:`PHINS_RECORDED`): see its docstring.

A folder graphnav wrote (:func:`graphnav.io.export.write_akit`, ``graphnav simulate --out``) holds its
configuration (``config_trajectoryN.json``, :func:`written_config`) and its beams (``beams_trajectoryN.csv``).
It reads as it was written: with that configuration (the axis signs and time offsets it sets are used as
given, so nothing is detected or estimated), its GT kept at the IMU point, its stamps as written (step 1) and
the written beams on the pings whose DVL velocity is their least squares (a ping edited in the DVL file gets
beams made from the edited velocity, as in step 5). A ``--config`` file's keys go over the written ones.

``read_mission`` is what every ``graphnav`` subcommand reads with (then ``prepare``; the simulated default and
the one-call ``load_mission`` are :mod:`graphnav.missions`').
"""
from __future__ import annotations

import dataclasses
import io
import re
import warnings
from pathlib import Path

import numpy as np

from graphnav.core.config import FOUND_WHEN_PREPARED, ConfigOverrides, ImuSpec, SensorConfig, read_config
from graphnav.core.dvl import describe_implausible, implausible_pings, make_beams
from graphnav.core.earth import gravity_magnitude, lla_to_ned
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.imu_timing import shown_rate_hz
from graphnav.core.mission import (
    MAX_DVL_SPEED_MPS,
    DepthData,
    DvlData,
    GroundTruth,
    ImuData,
    Mission,
    invalid_dvl_values,
)
from graphnav.core.rotations import euler_to_C_b_n
from graphnav.core.screening import (
    NO_BOTTOM_LOCK,
    SAME_POINT_SHARE,
    check_refused_fraction,
    first_lines,
    gt_refusals,
    imu_implausible,
    latlon_impossible,
    no_bottom_lock,
    note_outages,
    refuse,
    refuse_rows,
    refuse_zeroed_filler,
    stamp_order,
    stamp_jump,
    stamp_outliers,
    unit_check_rows,
    warn_no_bottom_lock,
    with_position_spikes,
    zeroed_filler,
)
from graphnav.core.streams import OWN_CLOCK_RESCALE, add_note, count_read, count_refused
from graphnav.io.screened import record_kept, screen_mission

#: Column names of the published A-KIT files, in order.
AKIT_COLUMNS: dict[str, tuple[str, ...]] = {
    "IMU": ("Time [s]", "ACC X [m/s^2]", "ACC Y [m/s^2]", "ACC Z [m/s^2]",
            "GYRO X [rad/s]", "GYRO Y [rad/s]", "GYRO Z [rad/s]"),
    "DVL": ("Time [s]", "DVL X [m/s]", "DVL Y [m/s]", "DVL Z [m/s]"),
    "GT": ("Time [s]", "Longitude [rad]", "Latitude [rad]", "Altitude [m]", "V North [m/s]",
           "V East [m/s]", "V Down [m/s]", "Roll [rad]", "Pitch [rad]", "Yaw [rad]"),
}

#: Default lever arm of the Snapir DVL relative to the INS (the GT reference point), body frame, m (data
#: README). The DVL regression against the GT kept at that point (``imu_position_b=(0, 0, 0)``) finds
#: [-1.84..-1.72, -0.10..+0.04, +0.03..+0.15] over the ten shared trajectories. ``graphnav calibrate`` reads the
#: prepared mission, whose GT is at the IMU point (:data:`AKIT_IMU_POSITION_B`, this same point), so it prints the
#: lever arm from the IMU point: [-0.20..+0.07, -0.02..+0.07, -0.07..+0.12] (docs/decisions/akit-loader.md, "What
#: `graphnav calibrate`'s positions are measured from"). Note: the recorded specific force behaves as if measured
#: ~1.8 m aft of the GT point (:func:`graphnav.calibration.dvl_fit.estimate_imu_position`), so relative to the IMU
#: the DVL is close to zero in x/y (calibrate's graph mode: [-0.2..+0.04, -0.07..+0.04, ...]).
AKIT_LEVER_ARM_B = (-1.86, -0.04, 0.2)

#: Position of the IMU's measurement point relative to the published GT reference point, body frame, m.
#: The estimators navigate the IMU point, so the prepare step moves the GT there (``imu_position_b``).
#: The DVL time offset of the published A-KIT files (s added to the rescaled DVL stamps), for folders without a GT
#: file: the mean of the prepare step's estimates against the GT on the ten shared trajectories (0.976-1.061 s, spread
#: 0.025 s; ``experiments/no_gt_runs.py`` prints them).
AKIT_DVL_TIME_OFFSET_S = 1.02

#: DVL lever arm relative to the IMU (``AKIT_LEVER_ARM_B - imu_position_b``). The accelerometer regression
#: (:func:`graphnav.calibration.dvl_fit.estimate_imu_position`, against the published GT point) puts the IMU at
#: [-1.74..-1.79, -0.03..0.00, -0.13..-0.11] m on the ten shared trajectories (sigmas <= 0.01 m, spread 0.05 m),
#: and the DVL regression puts the DVL at the lever arm above, so the DVL is within ~0.3 m of the IMU (0.3 m below
#: it with the lever arm above, 0.1-0.3 m with calibrate's per trajectory), and the default takes them as
#: co-located: the IMU point is the DVL point measured against the GT, and the DVL lever arm relative to the IMU is
#: zero. (Before the regression averaged the gravity term over each 1 s GT interval it put the IMU 1.3-2.3 m above
#: the GT point.) Navigating the accelerometer's point instead, with the DVL's lever arm from it (both chosen out of
#: fold), gave 1.1-2.6 % more mission VRMSE for Graph-TC, its batch and TC (``experiments/imu_point_folds.py``,
#: docs/decisions/akit-loader.md), so the default stays co-located.
AKIT_IMU_POSITION_B = AKIT_LEVER_ARM_B

#: IMU error model for the recorded Phins data, per-sqrt(Hz) densities (``experiments/identify_noise.py``,
#: :mod:`graphnav.calibration.noise`; docs/decisions/consistency.md). Identified at the scale the estimators
#: integrate over, the GT's 1-s sample interval and the DVL's 1-s ping interval: the mismatch of the IMU's 1-s
#: velocity and attitude increments with the GT's (:func:`graphnav.calibration.noise.identify_imu_with_gt`:
#: interval means, the accelerometer's position fitted out), median over the ten shared trajectories:
#: accelerometer 8.2e-4 m/s^2/sqrt(Hz) (5.8e-4..1.1e-3 per trajectory), gyro 1.1e-5 rad/s/sqrt(Hz)
#: (8.2e-6..1.9e-5; upper bounds: they hold the GT's own noise too). (The identification took the attitude at
#: each interval's middle until it gave 2.5e-3 for the accelerometer: a rolling vehicle's gravity seen at the
#: wrong attitude.) The sample-to-sample scatter is larger (Allan deviation at 0.01-0.1 s: gyro 6.4e-5,
#: accelerometer 1.7e-3; ``experiments/check_realdata.py``
#: 1.9e-5..1.0e-4 and 1.0e-3..4.8e-3): vehicle vibration, which averages out within a keyframe interval and
#: is therefore not white noise at the estimators' scale. The estimators use more than the 1-s
#: identification (below). Biases: the Phins datasheet (gyro 0.01 deg/h, accelerometer 50
#: micro-g); random walks from the navigation grade (a larger accelerometer walk, 3e-5, was studied out of fold and
#: not adopted: docs/decisions/fitted-defaults.md). The beam noise identified from the all-beam batch
#: residuals is 0.0411-0.0423 m/s (median 0.0414), the synthetic 0.042 of the beam model, so the DVL spec
#: keeps 0.042.
#: The GT's own velocity error, 1-sigma per NED axis (m/s), identified by ``experiments/identify_noise.py`` over
#: the ten shared trajectories (:func:`graphnav.calibration.noise.gt_white_velocity_error`): the GT's white
#: velocity error per body axis, from its 1-s velocity increments against the IMU's with the identified
#: accelerometer density removed (independent of every estimator here), median x 0, y 0, z 0.0008 m/s (0.0006 to
#: 0.0011 per trajectory; an upper bound, the excess of the accelerometer's noisiest axis over its median one,
#: which may be the accelerometer's own). No white horizontal error shows. (With the attitude at each interval's
#: middle the increments gave y 0.0081 m/s, 0.0058 per horizontal axis: the roll seen at the wrong attitude.)
#: The all-beam batch smoother's error against the IMU-carried GT beyond its own covariance
#: (:func:`graphnav.calibration.noise.identify`) bounds the GT's whole error from above and is larger (0.0136 m/s
#: east on Trajectory1); the GT's slow error is not separable from the estimators' here. The loader puts this
#: in ``mission.meta["gt_velocity_sigma_n"]``; the benchmark's consistency section adds it to the estimators'
#: covariance to show how much of their NEES the reference explains.
AKIT_GT_VELOCITY_SIGMA_N = (0.0, 0.0, 0.0008)

#: The densities the estimators use (accelerometer 3.5e-3, gyro 1.7e-5) are 4.25x and 1.5x the 1-s identification's
#: median. They were chosen by leave-trajectories-out (``experiments/leave_trajectories_out.py``,
#: docs/decisions/fitted-defaults.md) as 1.4x what the identification gave with the attitude at each interval's
#: middle (2.5e-3, 1.2e-5): at 1x that left the batch smoother over-confident on trajectories with many turns
#: (mission NEES up to 5.2); with each trajectory's own 1-s identification its NEES is 4.88 (3.06-6.71;
#: ``experiments/calibrated_density_folds.py``). What the estimators need beyond the 1-s increments (slower
#: sensor errors, the GT's, their own model's) is what ``graphnav calibrate`` multiplies its identified densities
#: by (:data:`graphnav.calibration.noise.ESTIMATOR_DENSITY_FACTOR`). One value serves
#: every estimator (the largest of their out-of-fold choices); with the 15-state EKF and its DVL error states as
#: the TC baseline three of the five folds chose 1.4x (two 1x); out of fold the all-beam velocity NEES is
#: Graph-TC 2.16, batch 3.07, TC 2.22 (at 1x on all ten: 2.27, 3.39, 2.33) for 0.3-1 % more mission VRMSE.
PHINS_RECORDED = ImuSpec(name="phins-recorded", accel_noise_density=3.5e-3, gyro_noise_density=1.7e-5,
                         accel_bias_rw=1e-6, gyro_bias_rw=1e-9, accel_bias_sigma=50 * 9.80665e-6,
                         gyro_bias_sigma=0.01 * np.pi / 180 / 3600)


# ------------------------------------------------------------------------------------------------
# CSV reading
# ------------------------------------------------------------------------------------------------
def read_csv(path: str | Path, columns: tuple[str, ...], *, nan_ok: tuple[str, ...] = (),
             repair: bool = False, meta: dict | None = None, stream: str = "",
             empty_is_nan: bool = False, inf_ok: bool = False, with_lines: bool = False,
             imu_rate_hz: float | None = None):
    """Read a numeric CSV with a known header into an (N, len(columns)) float array.

    The first line must hold ``columns`` (exact names, any order is not accepted: the published order).
    Every bad data line is found and reported (1-based line number and column): wrong number of fields
    (e.g. a truncated line), a non-numeric or empty field, NaN/inf outside the columns in ``nan_ok`` (inf in
    them too, unless ``inf_ok``).
    ``empty_is_nan``: an empty field of a ``nan_ok`` column is NaN, as pandas' ``to_csv`` writes NaN (the
    beams file :func:`graphnav.io.export.write_akit` writes leaves an invalid beam empty; the A-KIT reader
    refuses an IMU or GT row with one or with an infinite value, :func:`graphnav.core.screening.not_finite`).
    The first column is the time stamp and must increase strictly (:func:`graphnav.core.screening.stamp_order`):
    a row repeating an earlier one exactly, or the row before it in every value under half a step later, is dropped
    with a warning; with ``repair=True`` duplicated
    stamps are dropped (first kept) and the rows sorted, with a warning. With ``meta`` (a mission's meta),
    the rows are counted as read for ``stream`` and rows whose stamp is not a time
    (:func:`graphnav.core.screening.stamp_outliers`: NaN or empty (with ``empty_is_nan``), inf, 1e300, a lone
    stamp a day off) are refused and counted there, before the order check, and so are an IMU's (``stream`` "imu")
    filler rows whose stamp is zeroed too (:func:`graphnav.core.screening.zeroed_filler`), as filler.
    ``with_lines``: return ``(data, lines)``, ``lines`` (N,) the 1-based file line of each row returned.
    ``imu_rate_hz``: an IMU's configured rate (Hz), which tells an IMU slower than its logger's clock from one
    losing samples where the stamps cannot (:func:`graphnav.core.screening.stamp_order`).

    Raises:
        DataError: with ``source`` = the file, ``line`` = the first bad line, ``field`` = its column; the
            message lists up to 10 bad lines.
    """
    path = Path(path)
    source = str(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise DataError(f"cannot read file: {exc}", source) from None
    try:
        text = raw.decode("utf-8-sig")     # a byte-order mark is not part of the header
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        raise DataError(f"not UTF-8 text: byte {raw[exc.start:exc.start + 1]!r} at offset {exc.start}", source,
                        line) from None
    lines = text.splitlines()
    if not lines:
        raise DataError("empty file, expected a header line", source, 1)
    header = [h.strip() for h in lines[0].split(",")]
    missing = [c for c in columns if c not in header]
    if missing:
        # a spreadsheet set to a decimal comma separates the cells by ';' (the columns are all there)
        other = next((d for d in (";", "\t") if [h.strip() for h in lines[0].split(d)] == list(columns)), None)
        told = (f"; the header's cells are separated by {other!r}, an A-KIT file's by ',' (write ',' between cells and "
                "decimal points)") if other else ""
        raise DataError(f"missing column(s) {missing}; header is {header}, expected {list(columns)}{told}",
                        source, 1, missing[0])
    if header != list(columns):
        raise DataError(f"unexpected header {header}, expected {list(columns)}", source, 1,
                        next((h for h, c in zip(header, columns) if h != c), header[-1]))
    line_no = np.array([i + 1 for i, s in enumerate(lines) if i > 0 and s.strip()], dtype=int)
    body = [lines[i - 1] for i in line_no]
    stamps_screened = meta is not None       # a stamp that is not a time is refused below, not an error
    if empty_is_nan:
        may_be_empty = [j for j, name in enumerate(columns) if name in nan_ok or (j == 0 and stamps_screened)]
        body = [_empty_as_nan(line, may_be_empty) for line in body]
    if not body:
        raise DataError("no data lines", source, 2)
    try:
        data = np.loadtxt(io.StringIO("\n".join(body)), delimiter=",", ndmin=2, dtype=float)
        if data.shape[1] != len(columns):
            raise ValueError("column count")
    except ValueError:
        _raise_bad_lines(source, body, line_no, columns)
        raise  # pragma: no cover - _raise_bad_lines always raises
    problems = []
    for j, name in enumerate(columns):
        if j == 0 and stamps_screened:
            continue
        if name in nan_ok:
            bad = np.flatnonzero(np.isinf(data[:, j]) & (not inf_ok))
        else:
            bad = np.flatnonzero(~np.isfinite(data[:, j]))
        problems += [(int(line_no[i]), name, f"value {data[i, j]} is not finite") for i in bad]
    if problems:
        _raise_problems(source, sorted(problems))
    filler_lines = None
    if meta is not None:
        # an IMU's filler rows whose stamp is zeroed too hold no time: out before the stamps are judged
        zeroed = (zeroed_filler(data[:, 0], data[:, 1:7], source, line_no) if stream == "imu" and len(columns) == 7
                  else np.zeros(len(data), bool))
        count_read(meta, stream, data[~zeroed, 0], source, shown_rate_hz(stream, data[~zeroed, 0]))
        refuse_zeroed_filler(meta, source, line_no[zeroed])
        filler_lines = line_no[zeroed]
        data, line_no = data[~zeroed], line_no[~zeroed]
        bad = stamp_outliers(data[:, 0])
        if bad.any():
            refuse(meta, stream, {"stamp not a time": bad}, source, lines=line_no)
            data, line_no = data[~bad], line_no[~bad]
            record_kept(meta, stream, data[:, 0])
    kept, dropped, t = stamp_order(data[:, 0], data, line_no, source, columns[0], repair, meta, stream,
                                   imu_rate_hz, filler_lines=filler_lines)
    for reason, n in dropped.items() if meta is not None else ():
        count_refused(meta, stream, reason, n)
    data = data[kept]
    data[:, 0] = t
    return (data, line_no[kept]) if with_lines else data


def _empty_as_nan(line: str, columns: list[int]) -> str:
    """``line`` with the empty fields of ``columns`` (indices) written ``nan``."""
    fields = line.split(",")
    for j in columns:
        if j < len(fields) and not fields[j].strip():
            fields[j] = "nan"
    return ",".join(fields)


def _raise_bad_lines(source: str, body: list[str], line_no: np.ndarray, columns) -> None:
    """DataError naming each of the ``body`` lines (file lines ``line_no``) that does not hold one number per column
    of ``columns``: a line of too few or too many fields, or a field that is no number. A quoted field holding a
    separator is one field (``"0,5"``, a decimal comma: told so, with what to write, as a column map's)."""
    from graphnav.io.generic_csv import QUOTED_DECIMAL_COMMA, decimal_comma_number, split_numbers
    problems = []
    for n, s in zip(line_no, body):
        fields = s.split(",")
        quoted = _quoted_cells(s) if '"' in s and len(fields) != len(columns) else fields
        fields = quoted if len(quoted) == len(columns) else fields
        if len(fields) != len(columns):
            what = "truncated line" if len(fields) < len(columns) else "too many fields"
            split = len(fields) > len(columns) and split_numbers(fields, [True] * len(columns))
            problems.append((int(n), columns[min(len(fields), len(columns)) - 1] if len(fields) < len(columns)
                             else columns[-1], f"{what}: {len(fields)} fields, expected {len(columns)}"
                             + ("; likely a decimal comma (write decimal points: an A-KIT file's separator is ',')"
                                if split else "")))
            continue
        for name, f in zip(columns, fields):
            try:
                float(f)
            except ValueError:
                inner = f.strip()[1:-1] if len(f.strip()) > 1 and f.strip()[0] == f.strip()[-1] == '"' else None
                comma = inner is not None and decimal_comma_number(inner.strip()) is not None
                told = f", {QUOTED_DECIMAL_COMMA} (write decimal points: an A-KIT file's separator is ',')" * comma
                problems.append((int(n), name, f"not a number: {(inner.strip() if comma else f.strip())!r}{told}"))
    if not problems:  # loadtxt failed on something the checks above did not catch
        raise DataError("cannot parse the file as numbers", source)
    _raise_problems(source, problems)


def _quoted_cells(line: str) -> list[str]:
    """The cells of a ','-separated ``line``, a separator inside double quotes part of its cell and the quotes kept:
    a quoted cell is no number an A-KIT file holds (``"0.1"`` beside ``"0,2"`` on one line was read as 0.1, and
    refused alone)."""
    cells, cell, inside = [], [], False
    for ch in line:
        if ch == '"':
            inside = not inside
        if ch == "," and not inside:
            cells.append("".join(cell))
            cell = []
        else:
            cell.append(ch)
    return cells + ["".join(cell)]


def _raise_problems(source: str, problems: list[tuple[int, str, str]]) -> None:
    shown = "; ".join(f"line {n}, column '{c}': {m}" for n, c, m in problems[:10])
    more = f" (and {len(problems) - 10} more)" if len(problems) > 10 else ""
    line, col, msg = problems[0]
    err = DataError(f"{msg}; {len(problems)} bad line(s): {shown}{more}", source, line, col)
    err.problems = problems
    raise err


# ------------------------------------------------------------------------------------------------
# A-KIT
# ------------------------------------------------------------------------------------------------
def list_akit(root: str | Path) -> list[Path]:
    """The ``TrajectoryN`` folders under ``root`` (sorted by N) that hold all three CSV files."""
    root = Path(root)
    found = []
    for d in root.iterdir() if root.is_dir() else []:
        m = re.fullmatch(r"Trajectory(\d+)", d.name)
        if m and all((d / f"{k}_trajectory{m.group(1)}.csv").is_file() for k in AKIT_COLUMNS):
            found.append((int(m.group(1)), d))
    return [d for _, d in sorted(found)]


def akit_files(folder: str | Path, require_gt: bool = True) -> dict[str, Path]:
    """{"IMU": path, "DVL": path, "GT": path} of one A-KIT trajectory folder (no "GT" key when the GT file
    is missing and ``require_gt`` is False)."""
    folder = Path(folder)
    m = re.fullmatch(r"Trajectory(\d+)", folder.name)
    if m:
        files = {k: folder / f"{k}_trajectory{m.group(1)}.csv" for k in AKIT_COLUMNS}
    else:  # a renamed folder: accept one file per kind
        files = {}
        for k in AKIT_COLUMNS:
            hits = sorted(folder.glob(f"{k}_*.csv"))
            files[k] = hits[0] if len(hits) == 1 else folder / f"{k}_trajectoryN.csv"
    if not require_gt and not files["GT"].is_file():
        del files["GT"]
    for k, p in files.items():
        if not p.is_file():
            raise DataError(f"{k} file not found (expected A-KIT layout TrajectoryN/{{IMU,DVL,GT}}_"
                            f"trajectoryN.csv)", str(p))
    return files


@dataclasses.dataclass
class AkitRaw:
    """The three A-KIT files as read (after stamp rescaling, unit checks and screening; IMU axes as in the file,
    no time offsets)."""

    imu: np.ndarray      # (N,7) t, f_b(3), omega_b(3)
    dvl: np.ndarray      # (M,4) t, v(3)
    gt: np.ndarray | None  # (K,10) t, lon, lat, alt, v_n(3), roll, pitch, yaw; None without a GT file
    files: dict
    meta: dict = dataclasses.field(default_factory=dict)   # "streams": read / refused per file, unit conversions
    dvl_lines: np.ndarray | None = None   # (M,) the DVL file line of each row of ``dvl``


def read_akit(folder: str | Path, *, rescale_stamps: bool = True, repair: bool = False,
              config: SensorConfig | None = None) -> AkitRaw:
    """Read and check the CSVs of one trajectory folder (see the module docstring, steps 1 and 5; the IMU axes
    stay as in the file: :func:`graphnav.calibration.preparation.prepare` applies the signs).

    A folder without a GT file reads with ``gt=None``.
    ``config``: the sensor ranges and envelope the rows are screened with (default ``SensorConfig()``).
    """
    files = akit_files(folder, require_gt=False)
    cfg = config or SensorConfig()
    meta: dict = {}
    # an empty cell is NaN (what pandas' to_csv writes for it): an invalid ping in the DVL file, a refused row in
    # the IMU and GT files (below); text that is not a number stays a DataError naming the line and column
    read = {k: read_csv(files[k], AKIT_COLUMNS[k], nan_ok=AKIT_COLUMNS[k][1:], empty_is_nan=True, inf_ok=True,
                        repair=repair, meta=meta, stream=k.lower(), with_lines=True,
                        imu_rate_hz=cfg.imu_rate_hz if k == "IMU" else None) for k in files}
    lines = {k.lower(): rows for k, (_, rows) in read.items()}
    imu, dvl, gt = (read[k][0] if k in read else None for k in ("IMU", "DVL", "GT"))
    # before the screening: deg/s is not out of range; the GT rows to refuse are found with its units
    gt_refused = _akit_units(imu, dvl, gt, lines, files, meta, cfg)
    for k, (a, rows) in read.items():
        jump = stamp_jump(a[:, 0])
        if jump is not None:
            # named by its line before a stamp grid warns of the rows it seems to miss (the stream's own check, after
            # that warning, named a sample)
            raise DataError(jump[1], str(files[k]), int(rows[jump[0]]), AKIT_COLUMNS[k][0])
    if rescale_stamps:
        _rescale_akit_stamps({"imu": imu, "dvl": dvl, "gt": gt}, files, meta)
    # the DVL in the IMU's axes tells a knock from a burst of bad samples
    with np.errstate(invalid="ignore"):
        on_imu_axes = (dvl[:, 0], dvl[:, 1:4] @ cfg.dvl.C_d_b.T)
    imu, = refuse_rows(meta, "imu", imu_implausible(imu[:, 0], imu[:, 1:4], imu[:, 4:7], cfg, AKIT_COLUMNS["IMU"][1:],
                                                    meta, str(files["IMU"]), on_imu_axes, lines["imu"]),
                       str(files["IMU"]), lines["imu"], imu, fields=AKIT_COLUMNS["IMU"][1:])
    if gt is not None:
        gt, = refuse_rows(meta, "gt", gt_refused, str(files["GT"]), lines["gt"], gt)
    return AkitRaw(imu, dvl, gt, files, meta, lines["dvl"])


def _akit_units(imu: np.ndarray, dvl: np.ndarray, gt: np.ndarray | None, lines: dict, files: dict,
                meta: dict, cfg: SensorConfig) -> dict[str, np.ndarray] | None:
    """Stamps, IMU, DVL and GT units of the A-KIT arrays checked and converted in place (:mod:`graphnav.io.units`;
    the header names units, but a file written by other tools in this layout may not hold them). ``lines``: stream
    -> the file line of each row. Returns the GT rows to refuse (:func:`_akit_gt_units`), None without a GT."""
    from graphnav.io.units import AKIT_DVL_FIXES, dvl_velocity_units, imu_units, stamps_in_seconds
    for a, kind, stream, rate in ((imu, "IMU", "imu", 100.0), (dvl, "DVL", "dvl", 1.0), (gt, "GT", "gt", 1.0)):
        if a is not None:
            a[:, 0] = stamps_in_seconds(a[:, 0], stream, str(files[kind]), meta, rate, field=AKIT_COLUMNS[kind][0],
                                        lines=lines[stream])
    # a row with a NaN, a logger's filler or a dead accelerometer's zeros is refused afterwards (imu_unmeasured): no
    # measurement in any unit, the units are judged without them (a dead accelerometer was 'not gravity in m/s^2',
    # and so was a file of them or of filler only, which the refusal names)
    measured = np.all(np.isfinite(imu[:, 1:7]), axis=1) & np.any(imu[:, 1:4] != 0.0, axis=1)
    rows = np.flatnonzero(measured)
    f_b, omega_b = imu_units(imu[rows, 0], imu[rows, 1:4], imu[rows, 4:7], str(files["IMU"]), meta,
                             fields=AKIT_COLUMNS["IMU"][1:7])
    imu[rows, 1:7] = np.hstack([f_b, omega_b])
    dvl[:, 1:4] = dvl_velocity_units(dvl[:, 1:4], str(files["DVL"]), meta, columns="/".join(AKIT_COLUMNS["DVL"][1:4]),
                                     fix=AKIT_DVL_FIXES["unit"])
    if gt is None:
        return None
    return _akit_gt_units(gt, lines["gt"], imu, str(files["GT"]), meta, cfg)


def _akit_gt_units(gt: np.ndarray, gt_lines: np.ndarray, imu: np.ndarray, source: str, meta: dict,
                   cfg: SensorConfig) -> dict[str, np.ndarray]:
    """The GT array (K,10) in place: attitude and latitude/longitude in degrees converted to rad, an altitude
    with its sign flipped turned back, or DataError naming the file, line (``gt_lines``) and column
    (:mod:`graphnav.io.units`; the gyro of ``imu`` (N,7) in rad/s tells the attitude's unit, the GT's own velocity
    its positions'). Returns reason -> (K,) rows to refuse (:func:`graphnav.core.screening.gt_refusals`: a NaN or
    infinite cell, an impossible latitude, a velocity spike; and, once the latitude/longitude unit is known, a
    position spike), which are left out of the decisions and converted with the rest."""
    from graphnav.io.units import (
        check_reference_axes,
        reference_attitude_units,
        reference_depth,
        reference_latlon_units,
        reference_speed_error,
    )
    cols = AKIT_COLUMNS["GT"]
    refused = gt_refusals(gt[:, 0], gt[:, 1:], cols[1:], gt[:, 4:7], cfg.dvl,
                          latlon_impossible(gt[:, 2], gt[:, 1], (cols[2], cols[1])))
    ok, too_fast = unit_check_rows(refused, cfg.dvl)
    g, imu = gt[ok], imu[np.all(np.isfinite(imu[:, :7]), axis=1)]
    euler = g[:, 7:10]
    if reference_attitude_units(g[:, 0], euler, imu[:, 0], imu[:, 4:7], source, cols[7:10], meta) is not euler:
        gt[:, 7:10] = np.radians(gt[:, 7:10])
    lat = g[:, 2]
    if reference_latlon_units(g[:, 0], lat, g[:, 1], g[:, 4:7], source, (cols[2], cols[1], cols[4], cols[5]),
                              meta)[0] is not lat:
        gt[:, 1:3] = np.radians(gt[:, 1:3])
    if too_fast:            # the positions move as far as the velocity says: both in other units
        raise reference_speed_error(g[:, 4:7], source, cols[4:7], cfg.dvl.max_speed_mps)
    # exchanged or negated axes and position spikes are told in metres, so once the unit is known; the spikes are
    # left out of the altitude's fit too
    p_n = _local_ned(gt, ok)
    check_reference_axes(gt[ok, 0], p_n[ok, :2], gt[ok, 4:6], gt[ok, 9], source, (cols[2], cols[1], *cols[3:7]))
    refused = with_position_spikes(refused, gt[:, 0], p_n, gt[:, 4:7], cfg.dvl, (cols[2], cols[1], cols[3]), source,
                                   gt_lines, meta)
    ok = ~np.any(list(refused.values()), axis=0)
    g = gt[ok]
    # the depth is the altitude's opposite (positive up, metres above the sea surface)
    depth = -g[:, 3]
    v_pitch = -np.linalg.norm(g[:, 4:7], axis=1) * np.sin(g[:, 8])
    if reference_depth(g[:, 0], depth, g[:, 6], source, (cols[3], cols[6]), meta, cfg.depth_range_m,
                       lines=gt_lines[ok], v_pitch=v_pitch) is not depth:
        gt[:, 3] = -gt[:, 3]
    return refused


def _local_ned(gt: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """(K,3) NED positions, m, of the A-KIT GT array ``gt`` (K,10, latitude/longitude in rad) about the first of
    ``rows`` (K,) bool at the sea surface; NaN outside ``rows`` (NaN or infinite cells)."""
    p = np.full((len(gt), 3), np.nan)
    if rows.any():
        first = gt[np.argmax(rows)]
        p[rows] = lla_to_ned(gt[rows, 2], gt[rows, 1], gt[rows, 3], (first[2], first[1], 0.0))
    return p


#: Nominal rates of the A-KIT streams, Hz: the sensors' rates, which the published stamps' period misses.
AKIT_NOMINAL_RATE_HZ = {"imu": 100.0, "dvl": 1.0, "gt": 1.0}


#: The published grid's step exceeds the sensor's period by ``1/(N-1)``: 0.25 % for 400 pings. A grid slower
#: than the nominal rate by up to this much (a file of 101 rows or more) is taken for it; a slower one is a
#: stream at another rate.
PUBLISHED_STEP_EXCESS_MAX = 0.01

#: Stamps within this fraction of a step of an evenly spaced grid are on it: stamps rounded to the millisecond
#: at 1 Hz or stored as float32 at 100 Hz stay on their grid; a logger's own stamps jitter off it.
GRID_TOLERANCE = 0.01


def grid_step(t: np.ndarray) -> float | None:
    """The step (s) of the evenly spaced grid the stamps ``t`` (s) lie on, holes allowed, fitted through them
    (rounded stamps give the grid's step), or None when they do not lie on one (:data:`GRID_TOLERANCE`). A stamp
    under :data:`SAME_POINT_SHARE` of a step after the one before it is written for that grid point (a row written
    twice 1 ms later with other values, :func:`grid_points` tells them) and left out of the fit; one further off but
    under a step (a logger's burst) leaves the stamps no grid."""
    t = np.asarray(t, dtype=float)
    if len(t) < 3:
        return None
    dt = np.diff(t)
    guess = _step_guess(dt)
    if not guess > 0:
        return None
    dk = np.round(dt / guess)       # grid steps between neighbours: rounding errors do not add up
    again = dk < 1
    if np.any(again & (dt >= SAME_POINT_SHARE * guess)):
        return None
    k = np.concatenate([[0.0], np.cumsum(dk)])
    first = np.concatenate([[True], ~again])          # the first row on each grid point
    # fitted on the time since the first stamp: on Unix stamps (1.7e9 s) the fit through the absolute stamps is
    # off by 1e-9 of the step, as large as the smallest excess a published grid may have
    since = t[first] - t[0]
    step, t0 = np.polyfit(k[first], since, 1)
    if not step > 0 or np.max(np.abs(since - (t0 + k[first] * step))) > GRID_TOLERANCE * step:
        return None
    return float(step)


def grid_points(t: np.ndarray, step: float) -> np.ndarray:
    """(N,) int: the point of a grid of step ``step`` (s) each stamp ``t`` (N,) s lies on, in steps since the first
    stamp (:func:`grid_step`; two stamps on one point: a row written twice)."""
    t = np.asarray(t, dtype=float)
    return np.round((t - t[0]) / step).astype(int)


#: The median stamp difference spans a hole where the shortest difference is under this fraction of it (a step of
#: a grid the median fits rounds to one step at 0.75 of it or more; the median of differences of one and two steps
#: is 1.5 steps).
STEP_GUESS_HOLE_RATIO = 0.75


def _step_guess(dt: np.ndarray) -> float:
    """A first guess (s) of the grid step of stamps whose differences are ``dt`` (s): their median, or, where half the
    rows or more are missing (the median then spans a hole: the shortest difference is under
    :data:`STEP_GUESS_HOLE_RATIO` of it), the median of the differences within 1.5x the shortest. A DVL file with
    50-70 % of its rows removed was read as not the published grid and kept as read, 0.25 % slow against the rescaled
    IMU (1 s over 400 s). Not half the median: on a Unix clock (stamps 2.4e-7 s apart) the shortest difference, one
    step, is often exactly half the median, two steps. Differences under :data:`SAME_POINT_SHARE` of the median (two
    stamps for one grid point) are left out of the shortest."""
    guess = float(np.median(dt))
    apart = dt[dt >= SAME_POINT_SHARE * guess]
    shortest = float(np.min(apart)) if apart.size else guess
    if 0.0 < shortest < STEP_GUESS_HOLE_RATIO * guess:
        return float(np.median(dt[dt < 1.5 * shortest]))
    return guess


def published_period_factor(t: np.ndarray, rate_hz: float) -> float | None:
    """The factor that puts stamps written as ``linspace(0, T, N)`` back on the sensor's period ``1 / rate_hz``
    (``(N-1)/N`` when the sensor made N samples in T), or None when ``t`` (s) is not such a grid.

    From the grid's step alone (:func:`grid_step`), so a file cut short, or with rows deleted, gets the factor
    of the file it was cut from. Not such a grid, and left as read: stamps not evenly spaced (a logger's own
    stamps jitter), already on the nominal period, or at another rate (a step not within
    :data:`PUBLISHED_STEP_EXCESS_MAX` above the period, or not more above it than the stamps' float64 resolution
    can tell: :func:`_excess_floor`).
    """
    t = np.asarray(t, dtype=float)
    return _period_factor(grid_step(t), rate_hz, _excess_floor(t))


def _excess_floor(t: np.ndarray) -> float:
    """The smallest step excess (fraction of the period) stamps ``t`` (s) resolve: 1e-9, or four float64 spacings
    at the stamps' magnitude over their span (a period on Unix stamps, 2.4e-7 s apart, fitted over 2 s is known to
    5e-7 only: such a grid, on the period, measured 7e-9 above it)."""
    if len(t) < 2 or not t[-1] > t[0]:
        return 1e-9
    return max(1e-9, 4.0 * float(np.spacing(max(abs(t[0]), abs(t[-1])))) / float(t[-1] - t[0]))


def _period_factor(step: float | None, rate_hz: float, excess_floor: float = 1e-9) -> float | None:
    """:func:`published_period_factor` of a grid of step ``step`` s (None: not a grid; ``excess_floor``: the
    smallest step excess taken for a published grid, :func:`_excess_floor`)."""
    if step is None:
        return None
    excess = step * rate_hz - 1.0
    if not excess_floor < excess <= PUBLISHED_STEP_EXCESS_MAX:
        return None
    return 1.0 / (step * rate_hz)


def rescale_published_stamps(t: np.ndarray, rate_hz: float, origin: float | None = None
                             ) -> tuple[np.ndarray, float | None]:
    """``(stamps, factor)``: stamps ``t`` (s) written as a ``linspace`` grid put back on the sensor's period
    ``1 / rate_hz`` (:func:`published_period_factor`) about ``origin`` (s; default the first stamp), or ``t`` itself
    and None when they are not such a grid.

    About the clock's origin, not about zero: ``origin + (t - origin) * factor``. Scaled about zero, Unix stamps
    (1.7e9 s) would move by 4e6 s at the published factor; with ``origin`` 0 the result is ``t * factor`` to the
    bit."""
    t = np.asarray(t, dtype=float)
    factor = published_period_factor(t, rate_hz)
    if factor is None:
        return t, None
    return _scaled_about(t, float(t[0]) if origin is None else float(origin), factor), factor


def _scaled_about(t: np.ndarray, origin: float, factor: float) -> np.ndarray:
    """``origin + (t - origin) * factor`` (s): the rescale of :func:`rescale_published_stamps`."""
    return origin + (t - origin) * factor


#: A folder whose earliest stamp lies further than this from zero (s; one day) is on a clock far from zero (Unix
#: seconds, a logger's running clock): its grid is taken to start at that stamp (:func:`akit_stamp_origins`).
AKIT_FAR_CLOCK_S = 86400.0


def akit_stamp_origins(first: dict[str, float], last: dict[str, float]) -> dict[str, float]:
    """The stamp (s) each A-KIT file's stamps are rescaled about, by stream, from each file's first and last stamp
    (s). The files on the folder's clock (:func:`_on_the_folder_clock`: the IMU's, unless a file shares zero's) are
    rescaled about :func:`akit_folder_origin`'s stamp (0, where the published ``linspace(0, T, N)`` grids start: a file
    cut short, or trimmed at the start, keeps its stamps on that grid, so the rescale is about 0 for it too; the
    earliest of these files' first stamps when that lies more than :data:`AKIT_FAR_CLOCK_S` from zero: the folder
    moved to a Unix clock, its grids start there). A file on another clock (days away, before or after) is rescaled
    about its own first stamp, and its offsets are converted for its stamps as written
    (:func:`graphnav.core.streams.offset_on_written_stamps`)."""
    if not first:
        return {}
    common = akit_folder_origin(first, last)
    shared = _on_the_folder_clock(first, last)
    return {k: common if k in shared else t0 for k, t0 in first.items()}


def _on_the_folder_clock(first: dict[str, float], last: dict[str, float]) -> set[str]:
    """The streams whose files share the folder's clock, from each file's first and last stamp (s): those starting
    within the longest file's duration of the IMU file's first stamp (the earliest, without an IMU), unless the file
    starting nearest zero is not among them and starts within :data:`AKIT_FAR_CLOCK_S` of it: then those starting
    near that one (an IMU moved hours or a day, before or after: the others' grids start at 0, their offsets are the
    published ones plus the move). Anchored on the earliest file, a DVL a day early was taken for the folder's clock
    and the IMU and GT for clocks of their own: rescaled about 0 a day away, the DVL moved 216 s, and its correct
    offset was refused (a piece 330 s into the published grid). Anchored on the IMU alone, an IMU 86 100 s late was
    rescaled about 0 (2.15 s moved) and the others' offsets recorded 2.15 s off."""
    longest = max(last[k] - first[k] for k in first)

    def starting_near(anchor: float) -> set[str]:
        return {k for k, t0 in first.items() if abs(t0 - anchor) <= longest}
    shared = starting_near(first.get("imu", min(first.values())))
    nearest_zero = min(first, key=lambda k: abs(first[k]))
    if nearest_zero not in shared and abs(first[nearest_zero]) <= AKIT_FAR_CLOCK_S:
        shared = starting_near(first[nearest_zero])
    return shared


def akit_folder_origin(first: dict[str, float], last: dict[str, float]) -> float:
    """The stamp (s) the files sharing an A-KIT folder's clock are rescaled about (:func:`akit_stamp_origins`), from
    each file's first and last stamp (s): 0, or the earliest first stamp of the files on the folder's clock when it
    lies more than :data:`AKIT_FAR_CLOCK_S` from zero."""
    folder = min(first[k] for k in _on_the_folder_clock(first, last))
    return folder if abs(folder) > AKIT_FAR_CLOCK_S else 0.0


def _rescale_akit_stamps(arrays: dict, files: dict, meta: dict) -> None:
    """Put each published file's stamps (in place) back on the sensor's period: ``(N-1)/N`` of its published
    row count N (:func:`published_period_factor`, from the stamp step: rows deleted or a file cut short shift
    nothing), about the folder's clock origin (:func:`akit_stamp_origins`: 0 for the published files, trimmed or
    not; the first stamp of a folder on a Unix clock). Rows missing from a file's stamp grid are warned about and
    noted in ``meta["streams"]``; rows on the grid point of the row before them (written twice 1 ms later with other
    values, which :func:`read_csv` warned about) are kept and rescaled with the grid; a file whose stamps are not the
    published grid is left as read, and noted; a folder with files of both kinds is warned about (their clocks may
    now disagree)."""
    present = {k: a for k, a in arrays.items() if a is not None and len(a) >= 2}
    first = {k: float(a[0, 0]) for k, a in present.items()}
    last = {k: float(a[-1, 0]) for k, a in present.items()}
    origins, folder_origin = akit_stamp_origins(first, last), akit_folder_origin(first, last)
    # a file off the folder's clock is put on the IMU's, whose origin is not the folder's where the IMU is on a clock of
    # its own too (a GT moved a day with it: converted about the folder's, its offset was recorded 216 s off)
    imu_origin = origins.get("imu", folder_origin)
    kept, rescaled = [], []
    for k, a in present.items():
        step = grid_step(a[:, 0])
        factor = _period_factor(step, AKIT_NOMINAL_RATE_HZ[k], _excess_floor(a[:, 0]))
        if factor is None:
            add_note(meta, k, "stamps kept as read (not the published linspace(0, T, N) grid)")
            kept.append(k)
            continue
        rescaled.append(k)
        points = grid_points(a[:, 0], step)
        # rows on the point of the row before them (read_csv warned: say_close_samples) fill no hole
        missing = int(points[-1]) + 1 - np.unique(points).size
        if missing > 0:
            gap = int(np.argmax(np.diff(a[:, 0])))
            text = (f"{missing} row(s) missing from the {step:.6g} s stamp grid (largest hole after "
                    f"t = {a[gap, 0]:.3f} s); stamps rescaled from the grid, not the row count")
            add_note(meta, k, text)
            warnings.warn(f"{files[k.upper()]}: {text}", RuntimeWarning, stacklevel=4)
        a[:, 0] = _scaled_about(a[:, 0], origins[k], factor)
        if origins[k] != folder_origin:
            meta.setdefault(OWN_CLOCK_RESCALE, {})[k] = {"origin": origins[k], "factor": factor,
                                                         "folder_origin": imu_origin}
        about = f" about t = {origins[k]:.3f} s" if origins[k] else ""
        add_note(meta, k, f"stamps rescaled by {factor:.8g}{about}: the published linspace(0, T, N) step "
                          f"{step:.8g} s back on the sensor's {1.0 / AKIT_NOMINAL_RATE_HZ[k]:g} s period")
    if kept and rescaled:
        text = (f"stamps of {', '.join(rescaled)} rescaled from the published linspace(0, T, N) grid, those of "
                f"{', '.join(kept)} kept as read (not on such a grid); if these files come from one published "
                "folder, their clocks now disagree by up to 0.25 %: restore the published stamps, or read with "
                "rescale_stamps=False")
        add_note(meta, kept[0], text)
        warnings.warn(f"{files[kept[0].upper()]}: {text}", RuntimeWarning, stacklevel=4)


#: Keys of a configuration file that :func:`graphnav.calibration.preparation.prepare` applies (a mission read from an
#: A-KIT folder keeps them in ``meta["prepare"]["given"]`` until then).
PREPARE_KEYS = FOUND_WHEN_PREPARED


def read_akit_mission(folder: str | Path, *, lever_arm_b=None, beam_seed: int = 0,
                      config: SensorConfig | None = None, name: str | None = None, rescale_stamps: bool = True,
                      repair: bool = False, imu_position_b=None, given: dict | None = None) -> Mission:
    """Read one A-KIT trajectory folder as a :class:`Mission` that is not yet prepared.

    The streams are as the files hold them after the reading steps of the module docstring (stamps rescaled,
    units checked, rows screened, GT in NED, beams made from the DVL velocity): IMU axes as in the file, no
    time offsets added (``config.imu_axis_signs`` = (1, 1, 1), ``config.*_time_offset_s`` = 0), the GT and its
    depth at the published GT point. ``meta["prepared"]`` is False and ``meta["prepare"]`` holds what
    :func:`graphnav.calibration.preparation.prepare` needs: the IMU point ``imu_position_b`` (m, body frame) the GT
    is moved to, the GT's mean depth (m, for the gravity of the axis check) and ``given`` (the axis signs and
    time offsets a configuration file set; it uses them as given).

    Args:
        folder: ``.../TrajectoryN``.
        lever_arm_b: DVL position relative to the IMU, body frame, m (the beams' geometry, the config and the DVL
            offset estimate); None = the config's if one is given, else ``AKIT_LEVER_ARM_B - imu_position_b``
            (zero with the defaults).
        beam_seed: seed of the beam error model.
        config: a configuration to start from (e.g. from ``graphnav calibrate``); its DVL geometry, error model
            and IMU spec are kept, while lat and gravity are set from the GT. None: the one a folder graphnav
            wrote holds (:func:`written_config`, its :data:`PREPARE_KEYS` given), else the defaults.
        name: mission name (default: the folder name).
        rescale_stamps: fix the published stamps' period (module docstring, step 1).
        repair: drop duplicated stamps and sort (with a warning) instead of raising.
        imu_position_b: IMU point relative to the published GT point, body frame, m (``prepare`` moves the GT
            there). None = :data:`AKIT_IMU_POSITION_B` (``(0, 0, 0)`` in a folder graphnav wrote); ``(0, 0, 0)``
            keeps the GT at its published point.
        given: ``{key: value}`` of :data:`PREPARE_KEYS` a configuration file set (:func:`read_mission` passes them).
    """
    folder = Path(folder)
    written = written_config(folder)
    given_by = {}
    if written is not None:
        # graphnav wrote this folder (graphnav simulate --out): it reads with the configuration it was written
        # with and its GT is already at the IMU point
        if config is None:
            config, folder_keys = akit_base_config(folder)
            folder_given = _given_keys(config, folder_keys.sets)
            given_by = {key: str(written) for key in folder_given if key not in (given or {})}  # named when doubted
            given = {**folder_given, **(given or {})}
        imu_position_b = (0.0, 0.0, 0.0) if imu_position_b is None else imu_position_b
    raw = read_akit(folder, rescale_stamps=rescale_stamps and written is None, repair=repair, config=config)
    cfg = dataclasses.replace(config) if config is not None else SensorConfig(imu=dataclasses.replace(
        PHINS_RECORDED))     # akit_default_config(), whose lever arm the rule below gives
    cfg.dvl = dataclasses.replace(cfg.dvl)
    imu_position_b = np.asarray(AKIT_IMU_POSITION_B if imu_position_b is None else imu_position_b,
                                float).reshape(3)
    if lever_arm_b is None:
        lever_arm_b = (config.dvl.lever_arm_b if config is not None
                       else np.asarray(AKIT_LEVER_ARM_B) - imu_position_b)
    cfg.dvl.lever_arm_b = np.asarray(lever_arm_b, float).reshape(3)
    cfg.imu_axis_signs = np.ones(3)          # the file's axes: prepare applies the signs
    cfg.gt_time_offset_s = cfg.dvl_time_offset_s = 0.0

    # contiguous copies: np.interp on a strided 40k-sample column copies it at every call
    t_imu, f_b, omega_b = (np.ascontiguousarray(raw.imu[:, sl]) for sl in (0, slice(1, 4), slice(4, 7)))
    g = raw.gt
    if g is not None:
        lat0, lon0 = g[0, 2], g[0, 1]
        cfg.lat_rad = float(lat0)
        # origin at the sea surface above the first fix (p_n[:, 2] is the absolute depth the estimate carries);
        # gravity at that origin: the Earth model adds its change with position and depth
        cfg.gravity_mps2 = gravity_magnitude(lat0, 0.0)
        p_n = lla_to_ned(g[:, 2], g[:, 1], g[:, 3], (lat0, lon0, 0.0))
        C_b_n = euler_to_C_b_n(g[:, 7], g[:, 8], g[:, 9])

    # The file velocity is the DVL's own (DVL-frame) velocity: rotate by C_d_b (identity unless
    # calibrated) and remove a calibrated scale error.
    with np.errstate(invalid="ignore"):         # an infinite cell: its ping is flagged invalid below
        v_dvl = raw.dvl[:, 1:4] @ cfg.dvl.C_d_b.T / (1.0 + cfg.dvl.velocity_scale_correction)
    # RDI bad-velocity flags (-32.768 m/s, -32768) and impossible speeds are not measurements: the ping
    # becomes invalid (NaN), as a NaN row is, before anything (time-offset estimate, beams) uses it
    flagged = np.flatnonzero(np.any(invalid_dvl_values(raw.dvl[:, 1:4]), axis=1)
                             & ~np.any(np.isnan(raw.dvl[:, 1:4]), axis=1))
    if flagged.size:
        warnings.warn(f"{raw.files['DVL']}: {flagged.size} ping(s) with an invalid velocity (RDI bad-velocity "
                      f"flag -32.768/-32768 or beyond {MAX_DVL_SPEED_MPS:g} m/s) marked invalid, first at line "
                      f"{int(raw.dvl_lines[flagged[0]])}", RuntimeWarning, stacklevel=2)
        v_dvl[flagged] = np.nan          # counted with their reason by _record_akit_streams (_akit_refused)
    no_lock = no_bottom_lock(raw.dvl[:, 0], raw.dvl[:, 1:4], np.linalg.norm(v_dvl, axis=1), cfg.dvl)
    warn_no_bottom_lock(no_lock, raw.dvl_lines, str(raw.files["DVL"]))
    v_dvl[no_lock] = np.nan
    # pings this vehicle cannot have made (no bottom lock: |v_z| up to 2 m/s on real logs; speeds outside
    # the envelope; spikes): invalid too, before the offset estimate and the completers see them
    envelope = implausible_pings(raw.dvl[:, 0], v_dvl, cfg.dvl)
    outside = np.flatnonzero(np.any(list(envelope.values()), axis=0))
    if outside.size:
        warnings.warn(f"{raw.files['DVL']}: {outside.size} ping(s) outside the vehicle's envelope marked invalid "
                      f"({describe_implausible(envelope, cfg.dvl)}; DvlSpec.max_*), at line(s) "
                      f"{first_lines(raw.dvl_lines[outside])}",
                      RuntimeWarning, stacklevel=2)
        v_dvl[outside] = np.nan          # counted with their reason by _record_akit_streams (_akit_refused)
    _note_dvl_outages(raw, v_dvl)
    refused = _akit_refused(len(v_dvl), flagged, envelope, cfg.dvl, no_lock)

    src = {k: str(p) for k, p in raw.files.items()}
    valid_ping = np.all(np.isfinite(v_dvl), axis=1)
    # noise drawn for every row, so that a ping's beam noise does not depend on which other pings are valid
    beams = np.where(valid_ping[:, None], make_beams(np.where(valid_ping[:, None], v_dvl, 0.0), cfg.dvl,
                                                     beam_seed), np.nan)
    valid = np.repeat(valid_ping[:, None], 4, axis=1)
    from_file = None if written is None else _written_beams(raw, v_dvl, valid_ping, cfg, beams, valid)
    dvl = DvlData(raw.dvl[:, 0].copy(), beams, valid, v_dvl, source=src["DVL"])
    imu = ImuData(t_imu, f_b, omega_b, source=src["IMU"])
    gt = depth = None
    if g is not None:
        gt = GroundTruth(g[:, 0].copy(), p_n, g[:, 4:7], C_b_n, (float(lat0), float(lon0), 0.0), source=src["GT"])
        depth = DepthData(gt.t, gt.p_n[:, 2].copy(), source=src["GT"])
    given = {k: v for k, v in (given or {}).items() if k in PREPARE_KEYS}
    meta = {"streams": raw.meta.get("streams", {}),
            "source": str(folder), "files": src, "depth_source": "gt" if g is not None else None,
            # the column the depth comes from, for a message about the depth stream (depth = -altitude)
            **({"stream_fields": {"depth": AKIT_COLUMNS["GT"][3]}} if g is not None else {}),
            **({} if g is not None else {"ground_truth": False}),
            "rescale_stamps": rescale_stamps, "beam_seed": beam_seed,
            **({} if from_file is None else {"written_beams": dict(zip(("file", "pings", "made", "few_beams"),
                                                                       from_file))}),
            "dvl_implausible": {k: int(m.sum()) for k, m in envelope.items()},
            "prepared": False,
            "prepare": {"format": "akit", "imu_position_b": imu_position_b.tolist(),
                        "gt_mean_depth_m": None if g is None else float(np.mean(-g[:, 3])), "given": given,
                        **({"given_by": given_by} if given_by else {})},
            **raw.meta}
    if g is not None:
        meta["gt_point_b"] = [0.0, 0.0, 0.0]          # the published point until prepared
        if written is None:                           # a written folder's GT is the simulation's truth
            meta["gt_velocity_sigma_n"] = list(AKIT_GT_VELOCITY_SIGMA_N)
    _record_akit_streams(meta, imu, dvl, depth, gt, refused, raw.dvl_lines, from_file)
    _check_a_dvl_ping_is_usable(meta, src["DVL"])
    if written is not None:
        add_note(meta, "config", f"{written}: the configuration the folder was written with (graphnav simulate or "
                                 "write_akit); ground truth at the IMU point, stamps as written")
    return Mission(name or folder.name, imu, dvl, cfg, gt, depth, meta)


#: Header of the beams file :func:`graphnav.io.export.write_akit` writes beside the DVL file (empty = invalid).
WRITTEN_BEAM_COLUMNS = ("Time [s]", "Beam 1 [m/s]", "Beam 2 [m/s]", "Beam 3 [m/s]", "Beam 4 [m/s]")


#: A written ping's DVL velocity and the least squares of its written beams agree to this, m/s (the files
#: round trip to ~1e-15); a ping that differs more was edited in the DVL file, which is then the one believed.
WRITTEN_BEAMS_AGREE_MPS = 1e-9


def _written_beams(raw: AkitRaw, v_dvl: np.ndarray, valid_ping: np.ndarray, cfg: SensorConfig,
                   beams: np.ndarray, valid: np.ndarray) -> tuple[str, int, int, int] | None:
    """Put the beams of a folder graphnav wrote (``beams_trajectoryN.csv``) in place of the beams made from the
    DVL velocity (in place, ``beams`` and ``valid`` (M,4)): on the usable pings whose body-frame velocity
    ``v_dvl`` (M,3) m/s, as read from the DVL file, is the least squares of their written beams (the file's own
    beams, not a second draw of noise on their velocity), and on the pings the DVL file leaves without a velocity
    (a NaN row) whose written beams are fewer than three (no velocity could be solved from them). Returns (file,
    pings taken from it, usable pings left as made, pings with fewer than three beams taken), or None without a
    usable beams file (a damaged one is warned about: the DVL file is enough)."""
    dvl_file = Path(raw.files["DVL"])
    path = dvl_file.with_name(dvl_file.name.replace("DVL_", "beams_", 1))
    if path == dvl_file or not path.is_file():
        return None
    from graphnav.core.dvl import DvlGeometry
    try:
        written = read_csv(path, WRITTEN_BEAM_COLUMNS, nan_ok=WRITTEN_BEAM_COLUMNS[1:], empty_is_nan=True)
    except DataError as err:
        warnings.warn(f"{err}; the beams are made from the DVL file's velocity instead", RuntimeWarning,
                      stacklevel=3)
        return None
    t = raw.dvl[:, 0]
    at = np.clip(np.searchsorted(written[:, 0], t), 0, len(written) - 1)
    in_file = written[at, 0] == t
    rows = np.flatnonzero(valid_ping & in_file)
    file_beams = written[at[rows], 1:5]
    lsq = DvlGeometry.from_spec(cfg.dvl).velocity_from_beams(file_beams, np.isfinite(file_beams),
                                                             allow_missing=True)
    agree = np.all(np.abs(lsq - v_dvl[rows]) <= WRITTEN_BEAMS_AGREE_MPS, axis=1)
    rows = rows[agree]
    # a ping with too few beams for a velocity: its row in the DVL file is empty (NaN), not refused
    empty = np.all(np.isnan(raw.dvl[:, 1:4]), axis=1)
    few = np.flatnonzero(empty & in_file & (np.isfinite(written[at, 1:5]).sum(axis=1) < 3))
    for r in (rows, few):
        beams[r] = written[at[r], 1:5]
        valid[r] = np.isfinite(beams[r])
    return str(path), int(rows.size), int(valid_ping.sum() - rows.size), int(few.size)


def _akit_refused(n: int, flagged: np.ndarray, envelope: dict, spec, no_lock: np.ndarray
                  ) -> dict[str, np.ndarray]:
    """Reason -> (n,) mask of the DVL rows the A-KIT loader made invalid (NaN rows are left to the generic
    count of :func:`graphnav.io.stream_counts.record_streams`)."""
    flag = np.zeros(n, dtype=bool)
    flag[flagged] = True
    out = {f"invalid velocity (RDI flag -32.768/-32768 or beyond {MAX_DVL_SPEED_MPS:g} m/s)": flag,
           NO_BOTTOM_LOCK: no_lock}
    for key, mask in envelope.items():
        limit = describe_implausible({key: np.ones(1, bool)}, spec).split(" ", 1)[1]   # "1 speed > 3 m/s" -> limit
        out[f"outside the vehicle's envelope ({limit})"] = mask
    return out


def _check_a_dvl_ping_is_usable(meta: dict, source: str) -> None:
    """A DVL file none of whose pings is usable (every row NaN, empty, flagged or refused) leaves the estimators
    nothing to fuse and the DVL time-offset fit nothing to fit: refused naming the file and the reasons, as a
    column-map log's is (:func:`graphnav.core.screening.check_refused_fraction`)."""
    entry = meta.get("streams", {}).get("dvl", {})
    if entry.get("read") and not entry.get("used"):
        reasons = ", ".join(f"{n} {r}" for r, n in sorted(entry.get("refused", {}).items(), key=lambda kv: -kv[1]))
        raise DataError(f"no usable DVL ping: all {entry['read']} refused ({reasons}); check that the DVL kept bottom "
                        "lock and that the file holds its velocity", source, field=AKIT_COLUMNS["DVL"][1])


def _record_akit_streams(meta: dict, imu, dvl, depth, gt, refused: dict, dvl_lines: np.ndarray,
                         from_file: tuple[str, int, int, int] | None = None) -> None:
    """``meta["streams"]`` of an A-KIT mission as read: counts, refusals and what the reader did to each stream
    (``prepare`` adds the axis signs and time offsets); ``dvl_lines``: the file line of each ping; ``from_file``:
    what :func:`_written_beams` took."""
    from graphnav.io.stream_counts import record_streams
    record_streams(meta, imu=imu, dvl=dvl, depth=depth, gt=gt, dvl_refused=refused, dvl_lines=dvl_lines)
    if from_file is None:
        add_note(meta, "dvl", "beams made from the file's DVL velocity with the DVL error model (the file has no "
                              "beams)")
    else:
        path, taken, made, few = from_file
        add_note(meta, "dvl", f"beams of {taken} ping(s) read from {path}" + (
            f", and of {few} ping(s) with fewer than three beams, which the DVL file leaves without a velocity"
            if few else "") + (
            f"; {made} ping(s) whose DVL velocity is not the least squares of their written beams (edited, or "
            "not written) have beams made from it with the DVL error model" if made else ""))
    if depth is not None:
        add_note(meta, "depth", "depth is the GT's altitude (the files carry no depth sensor)")


def _note_dvl_outages(raw: AkitRaw, v_dvl: np.ndarray) -> None:
    """Warn about and note the stretches without a usable ping (NaN rows, deleted rows, refused pings), and
    end the load when most of a stream was refused."""
    t = raw.dvl[:, 0]
    usable = np.all(np.isfinite(v_dvl), axis=1)
    rate = 1.0 / float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    note_outages(raw.meta, t, usable, rate, str(raw.files["DVL"]))
    check_refused_fraction(raw.meta)


# ------------------------------------------------------------------------------------------------
# BeamsNet
# ------------------------------------------------------------------------------------------------
#: Fraction of ``V.npy`` the published split uses for training (the rest is validation).
BEAMSNET_TRAIN_FRACTION = 0.75


def load_beamsnet(folder: str | Path) -> dict:
    """The BeamsNet velocities: ``{"V": (3,N), "V_test": (3,M)}`` DVL body velocities at 1 Hz, m/s.

    Raises:
        DataError: missing file, wrong shape (must be (3, N)) or non-finite values (naming the sample).
    """
    folder = Path(folder)
    out = {}
    for key in ("V", "V_test"):
        path = folder / f"{key}.npy"
        try:
            arr = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise DataError(f"cannot read: {exc}", str(path)) from None
        if arr.ndim != 2 or arr.shape[0] != 3:
            raise DataError(f"shape {arr.shape}, expected (3, N) velocity x/y/z rows", str(path))
        bad = np.argwhere(~np.isfinite(arr))
        if bad.size:
            raise DataError("value is not finite", str(path), int(bad[0][1]), "xyz"[bad[0][0]])
        out[key] = arr.astype(float)
    return out


def beamsnet_split(V: np.ndarray, train_fraction: float = BEAMSNET_TRAIN_FRACTION
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The published split of ``V`` (3,N): (first 75 % for training, last 25 % for validation)."""
    n_train = int(V.shape[1] * train_fraction)
    return V[:, :n_train], V[:, n_train:]


# ------------------------------------------------------------------------------------------------
# The reading entry point of the CLI commands
# ------------------------------------------------------------------------------------------------
def read_mission(data: str | Path, config_path: str | Path | None = None,
                 topics: dict[str, str] | None = None, **akit_kwargs) -> Mission:
    """Read the recorded mission a ``graphnav`` command works on; nothing is estimated.

    Args:
        data: what to read, by its form:

            * a ROS bag, recognised by its content: ROS 1, MCAP, sqlite3 or a rosbag2 folder
              (:func:`graphnav.io.bags.load_bag`);
            * a Teledyne RDI PD0 file, recognised by content (``.pd0``, ``.000``, VmDAS ``.ENR/.ENS/.ENX``, any
              name), in any RDI frame (:func:`graphnav.io.generic_csv.load_pd0`);
            * a ``.csv`` file or a folder, read through the ``csv_columns`` map of the configuration
              (:func:`graphnav.io.generic_csv.load_csv_mission`);
            * an A-KIT ``TrajectoryN`` folder (:func:`read_akit_mission`).
        config_path: a SensorConfig JSON (e.g. written by ``graphnav calibrate``) or None.
        topics: bag stream -> topic overrides (``{"imu": "/imu/data"}``); bags only.
        **akit_kwargs: passed to :func:`read_akit_mission` (e.g. ``beam_seed``); A-KIT folders only, but for
            ``repair`` (drop rows whose stamp repeats an earlier one and sort), which column-map CSV logs take too.

    A configuration file may be partial: the keys it sets replace the loader's defaults one by one and the
    others stay the loader's (``{}`` is no configuration). On A-KIT folders the defaults are
    :func:`akit_default_config`; the ``imu_axis_signs``, ``gt_time_offset_s`` or ``dvl_time_offset_s`` a config
    sets are kept in ``meta["prepare"]["given"]`` for :func:`graphnav.calibration.preparation.prepare`, which applies
    them instead of estimating them (the config is the calibration). A key the data itself replaces (e.g. the
    latitude from the ground truth) is warned about.

    Returns:
        A mission with ``meta["prepared"]`` False: :func:`graphnav.calibration.preparation.prepare` puts its
        streams on the IMU clock and axes (what it estimates is listed in its docstring).
    """
    if data is None:
        raise ConfigError("read_mission reads recorded data; the simulated default mission is "
                          "graphnav.load_mission(None) (graphnav.sim.simulate.simulate_mission)")
    overrides = read_config(config_path) if config_path else None
    mission = _read(data, overrides, topics, akit_kwargs)
    if overrides:
        warn_replaced(overrides, mission)
    return mission


def akit_default_config() -> SensorConfig:
    """The configuration an A-KIT folder is loaded with when no configuration file sets a key: the recorded
    Phins' noise model (:data:`PHINS_RECORDED`) and the DVL lever arm relative to the IMU point."""
    cfg = SensorConfig(imu=dataclasses.replace(PHINS_RECORDED))
    cfg.dvl.lever_arm_b = np.asarray(AKIT_LEVER_ARM_B, float) - np.asarray(AKIT_IMU_POSITION_B, float)
    return cfg


def _read(data, overrides: ConfigOverrides | None, topics, akit_kwargs) -> Mission:
    """The mission of :func:`read_mission`, each loader's defaults overridden by the keys a config sets."""
    def over(base: SensorConfig) -> SensorConfig | None:
        return overrides.over(base) if overrides else None

    path = Path(data)
    from graphnav.io import bags, generic_csv, pd0
    if topics and not bags.is_bag(path):
        raise ConfigError(f"--topic applies to ROS bags only; {path} is not one")
    config = over(SensorConfig())
    reader = None
    if bags.is_bag(path):
        # a configured surface pressure is used as given; otherwise the bag's own start at the surface sets it
        atm = bool(overrides) and overrides.sets("atmospheric_pressure_pa")
        reader = lambda: bags.load_bag(path, config, topics, atmospheric_pressure_configured=atm,  # noqa: E731
                                       screen=False)      # screened below, as the other readers
    elif pd0.is_pd0(path) or (path.is_file() and pd0.has_pd0_suffix(path)):   # a misnamed file gets PD0's error
        repair = akit_kwargs.pop("repair", False)
        reader = lambda: generic_csv.load_pd0(path, config, repair=repair)  # noqa: E731
    elif generic_csv.uses_column_map(path, config):
        repair = akit_kwargs.pop("repair", False)
        reader = lambda: generic_csv.load_csv_mission(path, config, repair=repair)  # noqa: E731
    if reader is not None:
        if akit_kwargs:
            raise ConfigError(f"{sorted(akit_kwargs)} apply to A-KIT folders only (repair: and column-map CSV logs); "
                              f"{path} is not one")
        mission = screen_mission(reader())
        # the configuration is the calibration: prepare applies its offsets instead of estimating them
        given = _given_keys(config, lambda key: bool(overrides) and overrides.sets(key)
                            and (key != "gt_time_offset_s" or mission.gt is not None))
        if given:
            # the file to name when the data disagree with a value it gives
            mission.meta.setdefault("prepare", {}).update(given=given, given_by=dict.fromkeys(given, overrides.source))
        if "imu_axis_signs" in given:
            # the file's axes until prepare applies the signs, as an A-KIT folder's: the mission records what it applied
            mission.config = dataclasses.replace(mission.config, imu_axis_signs=np.ones(3))
        return mission
    if not path.is_dir():
        raise DataError("data folder not found", str(path))
    if not overrides:
        return read_akit_mission(path, **akit_kwargs)
    base, written = akit_base_config(path)
    config = overrides.over(base)
    if config.reference_position_b is not None:
        akit_kwargs.setdefault("imu_position_b", -config.reference_position_b)
    given = _given_keys(config, lambda key: overrides.sets(key) or (written is not None and written.sets(key)))
    mission = read_akit_mission(path, config=config, given=given, **akit_kwargs)
    # the file to name when the data disagree with a value it gives
    mission.meta["prepare"]["given_by"] = {key: overrides.source if overrides.sets(key) else written.source
                                           for key in given}
    return mission


def _given_keys(config: SensorConfig, sets) -> dict:
    """``{key: value}`` of ``config`` for the :data:`PREPARE_KEYS` that ``sets(key)`` says a configuration file
    set (``prepare`` applies them as given instead of estimating them)."""
    return {key: (tuple(getattr(config, key)) if key == "imu_axis_signs" else getattr(config, key))
            for key in PREPARE_KEYS if sets(key)}


def written_config(folder: str | Path) -> Path | None:
    """The configuration file :func:`graphnav.io.export.write_akit` leaves in an A-KIT folder it writes
    (``config_trajectoryN.json`` beside ``IMU_trajectoryN.csv``), or None: the published folders have none."""
    imu = akit_files(folder, require_gt=False)["IMU"]
    candidate = imu.with_name(imu.name.replace("IMU_", "config_", 1)).with_suffix(".json")
    return candidate if candidate.is_file() else None


def akit_base_config(folder: str | Path) -> tuple[SensorConfig, ConfigOverrides | None]:
    """The configuration an A-KIT folder reads with before a configuration file's keys: the one graphnav wrote
    it with (:func:`written_config`, laid over :func:`akit_default_config`; returned too, for the keys it sets),
    else :func:`akit_default_config` (and None)."""
    path = written_config(folder)
    if path is None:
        return akit_default_config(), None
    written = read_config(path)
    return written.over(akit_default_config()), written


def warn_replaced(overrides: ConfigOverrides, mission: Mission) -> None:
    """Warn (and note in the mission's streams) every configuration key the loader replaced from the data (the
    keys ``prepare`` applies are kept for it, not replaced)."""
    pending = mission.meta.get("prepare", {}).get("given", {})
    for key, given, used in overrides.differences(mission.config):
        if key in pending:
            continue
        note = (f"{overrides.source}: key '{key}' = {np.round(given, 6).tolist() if isinstance(given, np.ndarray) else given}"
                f" replaced by {np.round(used, 6).tolist() if isinstance(used, np.ndarray) else used} from the data")
        warnings.warn(note, RuntimeWarning, stacklevel=3)
        add_note(mission.meta, "config", note)
