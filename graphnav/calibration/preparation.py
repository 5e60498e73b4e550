"""The prepare step: what a recorded mission needs estimated from its own data before an estimator runs.

The loaders (:mod:`graphnav.io`) only read: they parse, check, screen and convert, and leave a mission with
``meta["prepared"] = False`` and, in ``meta["prepare"]``, the facts this step needs. :func:`prepare` then does
what the loaders used to do at load time, in the same order and with the same defaults, so that
``prepare(read_mission(path))`` is the mission ``load_mission(path)`` always gave:

A-KIT folders (:func:`graphnav.io.loaders.read_akit_mission`; the module docstring of
:mod:`graphnav.io.loaders` gives the reasons):

1. **IMU axes.** ``imu_axis_signs="auto"`` detects the file's convention
   (:func:`graphnav.calibration.axes.detect_imu_axis_signs`: gyro against the GT attitude, or gravity/gyro
   consistency without GT) and warns what it chose; the signs multiply the accelerometer and gyro x/y/z.
2. **Time offsets.** A GT on a clock of its own is first put on the IMU clock, before the axis check, which needs it
   there: off the IMU span by :func:`graphnav.calibration.clock.align_gt_clock`, on it by the clock search a log's
   reference gets (:func:`_searched_reference_clock`: a GT 16 s off shares 96 % of the span).
   ``gt_time_offset_s="auto"`` matches gyro-integrated attitude increments with the GT's
   (reusing the axis check's estimate), then ``dvl_time_offset_s="auto"`` regresses the DVL velocity on the GT
   body velocity plus ``omega x l`` (:mod:`graphnav.calibration.reference`), after a coarse clock offset when the
   DVL stamps lie off the IMU span, or on it further off than that search reaches
   (:func:`graphnav.calibration.clock.align_stream_clocks`). Without a GT file the
   DVL offset is that coarse offset or the vehicle's :data:`~graphnav.io.loaders.AKIT_DVL_TIME_OFFSET_S`, unless the
   DVL clock fit puts the DVL clearly off it (:func:`_akit_dvl_offset_without_gt`: beyond 0.2 s, its offset then,
   warned and counted).
   A DVL that follows the GT at no offset (another frame, other units) is a DataError. A GT offset a configuration
   (or a written folder's) gives gets the GT clock search on the stamps it gives, as a log's does
   (:func:`_given_reference_clock`), then the fine search's judge: one the data contradict (either search) is used
   as given and doubted (the axis check, the DVL's offset and the depth, the GT's altitude, take the GT where the
   data put it), one that leaves the GT off the IMU span is replaced by theirs. A
   given DVL offset that leaves most of its file's stamps off the IMU span is warned about and estimated as
   ``"auto"`` is.
3. **GT point.** The GT is moved from the published INS point to the IMU point
   (:func:`graphnav.calibration.reference.move_ground_truth`), and the depth stream with it.

Bags, CSV logs and PD0 files: the IMU frame the column map or the bag's frame_id declares is checked by the same
detection (:func:`graphnav.calibration.axes.declared_frame_signs`): data that contradict a frame a user declared are a
DataError, an implied frame is corrected with a warning; where the data cannot tell the y (a level vehicle's tilt
kinematics) the declared y is taken and noted, naming ``imu_axis_signs``; without a reference attitude on the IMU
clock, an IMU turned about z, or with its y negated, is found against the DVL
(:func:`graphnav.calibration.dvl_scale.check_imu_yaw`, :func:`~graphnav.calibration.dvl_scale.judge_imu_y`; an A-KIT
folder without GT gets it with the DVL's unit, yaw and FLU checks as logs and bags do,
:func:`~graphnav.calibration.dvl_scale.check_velocity_against_imu`); a depth is checked against the vehicle's
vertical velocity
(:func:`graphnav.io.units.depth_convention`: positive up turned down, other units refused); a DVL on a clock of its
own is put on the IMU's
(:func:`graphnav.calibration.clock.align_stream_clocks`, when the column map says ``"clock": "auto"``; where no
clock is found, a DVL or IMU mounted turned about z that hides it is named, :func:`_turn_finds_the_clock`, and so
are FLU DVL axes read as FRD, :func:`_flu_finds_the_clock`; where the DVL's y negated explains its velocity's changes
better than the clock found, the y is named, :func:`_y_finds_the_clock`); a bag
without a heading source is told whether the configured gyro can gyrocompass. Their reference is put on the IMU clock
(the configuration's ``gt_time_offset_s``, judged by the same clock search, else estimated as for A-KIT and added when
it is more than noise) and
moved to the IMU point from the configuration's ``reference_position_b`` (:func:`_reference_on_the_imu`). A DVL or
reference time offset a configuration gives is judged as an A-KIT folder's is (:func:`_judge_given_dvl_clock`,
:func:`_judge_given_gt_offset`): a disagreement is warned about naming the file, and counted.

Every mission: an IMU whose stamps come in packets or bursts (a driver stamping samples on receipt) has them put
back on its period, with a warning and a note; an IMU whose stamps run at another rate than the configured
``imu_rate_hz`` (50 or 200 Hz against 100) has the measured rate put in its configuration, with a note. DVL pings
outside the IMU span are counted (:func:`graphnav.io.stream_counts.record_outside_span`), and a DVL span off the
IMU's is a DataError (:func:`graphnav.io.stream_counts.check_dvl_on_imu_clock`); a log's or bag's depth or reference
span off the IMU's (the DVL's clock search done) is warned about, counted, marked not usable and left out of the mission
(:func:`graphnav.io.stream_counts.warn_off_the_imu_clock`).
What was chosen is warned about and kept in ``meta`` (``imu_axis_signs``, ``time_offsets``, ``clock_offsets``,
``meta["streams"]`` notes); ``meta["prepared"]`` becomes True. A simulated or hand-built mission (no
``meta["prepared"]``) is prepared already and comes back unchanged.
"""
from __future__ import annotations

import copy
import dataclasses
import sys
import warnings
from pathlib import Path

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.dvl_kinematics import dvl_velocity_b, still_velocity_said
from graphnav.core.earth import gravity_magnitude
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.mission import IMU_RATE_TOLERANCE, DepthData, DvlData, GroundTruth, ImuData, Mission, no_beams
from graphnav.core.streams import (add_note, clock_offsets_on_written_stamps, count_doubted,
                                   offset_on_rescaled_stamps, offset_on_written_stamps, say_doubted, set_span,
                                   stream_entry)
from graphnav.core.timeseries import on_the_imu_clock, overlap_text
from graphnav.io.dvl_frame import CARRIED, OFF_ITS_STAMPS
from graphnav.io.units import judged_velocity_unit, unit_fix

#: Largest RMS residual (m/s per axis) of the DVL velocity against the GT body velocity at the best time offset
#: that is still the same vehicle in the same frame: 0.007-0.044 m/s on the ten shared trajectories (0.044 on
#: the one that starts at the surface); a DVL in another frame (axes swapped, a wrong C_d_b) or other units
#: leaves residuals of the vehicle's speed, ~1 m/s. A bound, not a fit: 4.5x the worst clean trajectory.
DVL_GT_RMS_MAX_MPS = 0.2

AUTO = "auto"

#: What to do about an A-KIT file on a clock the data cannot align, for the error.
_GIVE_OFFSET = ("put the {kind} file's stamps on the IMU clock, or give {stream}_time_offset_s (s added to them) "
                "in a --config file")


def prepare(mission: Mission, *, imu_axis_signs=AUTO, gt_time_offset_s: float | str = AUTO,
            dvl_time_offset_s: float | str = AUTO) -> Mission:
    """The mission on the IMU clock and axes, its GT at the IMU point (module docstring).

    Args:
        mission: a mission from a loader (``meta["prepared"]`` False); a prepared one comes back unchanged.
        imu_axis_signs: signs applied to the file's IMU x, y, z (accelerometer and gyro), or ``"auto"``: the
            ones a configuration file set (``meta["prepare"]["given"]``), else detected with a warning.
        gt_time_offset_s: seconds added to the GT stamps, or ``"auto"``: the configured one, else estimated.
        dvl_time_offset_s: seconds added to the DVL stamps, or ``"auto"``: the configured one, else estimated
            (without GT: the DVL's coarse clock offset, else the vehicle's default with a warning, or the DVL clock
            fit's offset where it puts the DVL clearly off the default, warned about and counted).
        The three apply to A-KIT folders; other formats take ``"auto"`` only.

    Returns:
        A new mission (the given one is not changed) with ``meta["prepared"]`` True.

    Raises:
        ConfigError: an explicit value for a mission it does not apply to, or signs that are not +-1.
        DataError: no IMU axis convention fits, the DVL does not follow the GT, a DVL or GT clock cannot be found,
            or the DVL span is off the IMU's (:func:`graphnav.io.stream_counts.check_dvl_on_imu_clock`).
    """
    explicit = {k: v for k, v in (("imu_axis_signs", imu_axis_signs), ("gt_time_offset_s", gt_time_offset_s),
                                  ("dvl_time_offset_s", dvl_time_offset_s)) if not _is_auto(v)}
    if mission.meta.get("prepared", True):
        if explicit:
            raise ConfigError(f"{sorted(explicit)} given for mission {mission.name!r}, which is prepared already "
                              "(simulated, or prepared before): read it again to apply them")
        return mission
    meta = copy.deepcopy(mission.meta)
    facts = meta.get("prepare", {})
    mission = _measured_imu_rate(_restamped_packets(mission, meta), meta)
    if facts.get("format") == "akit":
        mission = _prepare_akit(mission, meta, facts, imu_axis_signs, gt_time_offset_s, dvl_time_offset_s)
    else:
        if explicit:
            raise ConfigError(f"{sorted(explicit)} apply to A-KIT folders; {meta.get('source', mission.name)} is "
                              f"{facts.get('format', 'another format')}: set them in its configuration instead")
        mission = _prepare_streams(mission, meta, facts)
    from graphnav.io.stream_counts import check_dvl_on_imu_clock, record_outside_span
    record_outside_span(mission)
    if facts.get("format") == "akit":
        check_dvl_on_imu_clock(mission, _GIVE_OFFSET.format(kind="DVL", stream="dvl"), field="Time [s]")
    else:
        check_dvl_on_imu_clock(mission, "put the DVL stamps on the IMU clock (a CSV column map's \"clock\": "
                                        "\"auto\" finds its offset)")
        mission = _left_out_off_the_imu_clock(mission, facts)
    return mission


def _left_out_off_the_imu_clock(mission: Mission, facts: dict) -> Mission:
    """The mission without a depth, reference or heading off the IMU span
    (:func:`graphnav.io.stream_counts.warn_off_the_imu_clock`), each named by its stamp field: a column map's key,
    a bag message's header stamp or its receive time. A bag whose heading is left out is told, as one without a
    heading source, whether the configured gyro can gyrocompass."""
    from graphnav.io.stream_counts import warn_off_the_imu_clock
    left = warn_off_the_imu_clock(mission, _stamp_fields(mission, facts))
    if mission.heading is not None and left.heading is None:
        _warn_no_heading(left.config, left.meta.get("source", "bag"), left.meta,
                         "its heading topic, off the IMU span, is left out")
    return left


def _stamp_fields(mission: Mission, facts: dict) -> dict[str, str]:
    """The stamp field of a log's or bag's depth, reference and heading: a column map's key, a bag message's header
    stamp or its receive time."""
    if facts.get("format") == "bag":
        from graphnav.io.bag_convert import STAMP_FIELDS
        kinds = mission.meta.get("clock", {}).get("stamps", {})
        return {k: STAMP_FIELDS[kinds.get(k, "header")] for k in ("depth", "gt", "heading")}
    cmap = mission.config.csv_columns or {}
    return {k: (cmap.get(k) or {}).get("t", "t") for k in ("depth", "gt", "heading")}


def _restamped_packets(mission: Mission, meta: dict) -> Mission:
    """The mission with the stamps of an IMU in packets or bursts (:func:`~graphnav.core.imu_timing.imu_step_stats`:
    a cycle longer than its period) put back on its period (:func:`~graphnav.core.imu_timing.restamp_packets`),
    warned about and noted once, with their count in ``meta["streams"]["imu"]["restamped"]``. Integrated at their
    packet's stamp, k samples made zero-length steps then one k periods long (a column-map log in packets of 20:
    VRMSE 0.098 m/s against 0.0026 from even stamps). Even stamps, gaps and stutters are no packets and keep their
    stamps; so do stamps the reader restamped already (packets sharing one stamp: one finding, one count)."""
    from graphnav.core.imu_timing import imu_packet_limit, imu_step_stats, packets_note, restamp_packets, say_restamp
    if meta.get("streams", {}).get("imu", {}).get("restamped"):
        return mission
    t = mission.imu.t
    configured_s = 1.0 / float(mission.config.imu_rate_hz)
    period, cycle = imu_step_stats(np.diff(t), configured_s, IMU_RATE_TOLERANCE)
    if not cycle > period:
        return mission
    restamped = restamp_packets(t, period, imu_packet_limit(np.diff(t), configured_s, IMU_RATE_TOLERANCE))
    moved = int(np.sum(restamped != t))
    if not moved:
        return mission
    on_period, still = imu_step_stats(np.diff(restamped), configured_s, IMU_RATE_TOLERANCE)
    # a rule that split packets wrongly leaves them mixed, whose rate contradicts the period just measured
    ok = not still > on_period and abs(on_period - period) <= IMU_RATE_TOLERANCE * period
    note = packets_note(round(cycle / period), cycle, period, f"{moved} of {t.size} stamps" if ok else None)
    if not ok:
        say_restamp(meta, mission.imu.source, note, 3)
        return mission
    say_restamp(meta, mission.imu.source, note, 3, restamped, moved, period)
    return dataclasses.replace(mission, imu=dataclasses.replace(mission.imu, t=restamped))


#: Share by which an IMU's measured rate may differ from the configured one, kept within
#: :data:`~graphnav.core.mission.IMU_RATE_TOLERANCE`, before a note says so (a 97 Hz IMU configured at 100 Hz).
IMU_RATE_NOTE_SHARE = 0.01


def _measured_imu_rate(mission: Mission, meta: dict) -> Mission:
    """The mission with ``config.imu_rate_hz`` the IMU's measured rate (:func:`~graphnav.core.imu_timing.imu_rate_hz`)
    when the configured one is off by more than :data:`~graphnav.core.mission.IMU_RATE_TOLERANCE`, noted once in
    ``meta``; ``meta["streams"]["imu"]["rate_hz"]`` (what ``graphnav info`` shows) is the measured rate, also where
    the configured one is kept (a 97 Hz IMU configured at 100 Hz shows 97 Hz, and a note says the configured rate is
    kept where they differ by more than :data:`IMU_RATE_NOTE_SHARE`). The
    keyframer's gap limit and bridging and the gravity levelling without GT read the configured rate; the screening
    and the preintegration use the stamps themselves."""
    from graphnav.core.imu_timing import imu_rate_hz, imu_stamp_quantum
    configured = float(mission.config.imu_rate_hz)
    measured = imu_rate_hz(mission.imu.t, configured, IMU_RATE_TOLERANCE)
    _check_restamped_rate(meta, measured, mission.imu.source)
    steps = np.diff(mission.imu.t)
    quantum = imu_stamp_quantum(steps)
    if quantum:
        add_note(meta, "imu", f"stamps on a {1e3 * quantum:.4g} ms grid, {quantum * measured:.0%} of a step (steps of "
                 f"{', '.join(f'{1e3 * d:.4g}' for d in np.unique(np.round(steps[steps < 1.5 / measured], 6)))} ms): "
                 f"the rate is their mean step, {measured:.4g} Hz, not the median's "
                 f"{1 / np.median(steps):.4g} Hz")
    off = abs(measured - configured) > IMU_RATE_TOLERANCE * configured      # NaN (one stamp): nothing to say
    if np.isfinite(measured) and "imu" in meta.get("streams", {}):
        # the readers' rate (imu_timing.shown_rate_hz) confirmed against the configured one: a median step near it is
        # the period whatever a few long steps say
        meta["streams"]["imu"]["rate_hz"] = float(measured)
    if not off:
        if abs(measured - configured) > IMU_RATE_NOTE_SHARE * configured:
            add_note(meta, "imu", f"stamps say {measured:.4g} Hz; the configured {configured:g} Hz is kept (within "
                     f"{IMU_RATE_TOLERANCE:.0%}) for the IMU gap limits and bridging: set imu_rate_hz if "
                     f"{measured:.4g} Hz is right")
        return mission
    add_note(meta, "imu", f"runs at {measured:.4g} Hz (stamp period {1e3 / measured:.4g} ms), not the configured "
             f"imu_rate_hz {configured:g} Hz: {measured:.4g} Hz is used")
    return dataclasses.replace(mission, config=dataclasses.replace(mission.config, imu_rate_hz=measured))


#: How far (relative) the period of an IMU's restamped stamps may be from the one they were restamped at.
RESTAMPED_PERIOD_TOLERANCE = 0.01


def _check_restamped_rate(meta: dict, measured_hz: float, source: str) -> None:
    """Warn (and count in ``meta``) when the rate ``measured_hz`` (Hz) of an IMU's restamped stamps contradicts the
    period they were restamped at (``meta["streams"]["imu"]["restamp_period_s"]``, s): the restamping misread the
    stamps (packets squeezed into the room before them read 233.7 Hz at 200 Hz). The measured rate is kept: it is
    the one the stamps as restamped give, and refusing would lose a log whose samples are all there."""
    period = meta.get("streams", {}).get("imu", {}).get("restamp_period_s")
    if period and not abs(1.0 / measured_hz - period) <= RESTAMPED_PERIOD_TOLERANCE * period:
        note = (f"field '{meta.get('stream_fields', {}).get('imu', 't')}': IMU stamps restamped at the period "
                f"{1e3 * period:.4g} ms read {measured_hz:.4g} Hz ({1e3 / measured_hz:.4g} ms) after: the restamping "
                f"misread the stamps; {measured_hz:.4g} Hz is used, the samples may sit up to a period off")
        say_doubted(meta, "imu", source, note, "restamped off the period",
                    int(meta["streams"]["imu"].get("restamped", 0)), stacklevel=4)


def _is_auto(value) -> bool:
    return isinstance(value, str) and value == AUTO


def _pick(value, facts: dict, key: str):
    """The explicit value, else the one a configuration file set, else ``"auto"``."""
    return facts.get("given", {}).get(key, AUTO) if _is_auto(value) else value


def _given_time_offset(value, facts: dict, meta: dict, stream: str):
    """The time offset of ``stream`` (``"gt"`` or ``"dvl"``) given (:func:`_pick`: the argument ``value``, else the
    configuration file's ``{stream}_time_offset_s``; else ``"auto"``) on the stamps the prepare step moves, s. It is
    given for the stamps as written: where a file is rescaled about its own first stamp, that is another offset
    (:func:`graphnav.core.streams.offset_on_rescaled_stamps`; judged on the IMU span before, a DVL's stamps were said
    1.58 s late for a piece 630 s into the published grid)."""
    value = _pick(value, facts, f"{stream}_time_offset_s")
    return value if _is_auto(value) else offset_on_rescaled_stamps(meta, stream, float(value))


# ------------------------------------------------------------------------------------------------
# A-KIT
# ------------------------------------------------------------------------------------------------
def _prepare_akit(mission: Mission, meta: dict, facts: dict, imu_axis_signs, gt_time_offset_s,
                  dvl_time_offset_s) -> Mission:
    from graphnav.calibration.reference import Reference, estimate_dvl_time_offset, estimate_gt_time_offset
    from_file = {key for key, value in (("imu_axis_signs", imu_axis_signs), ("gt_time_offset_s", gt_time_offset_s),
                                        ("dvl_time_offset_s", dvl_time_offset_s))
                 if _is_auto(value) and key in facts.get("given", {})}
    imu_axis_signs = _pick(imu_axis_signs, facts, "imu_axis_signs")
    gt_time_offset_s = _given_time_offset(gt_time_offset_s, facts, meta, "gt")
    gt_clock, used_as_given = 0.0, None
    if mission.gt is not None and not _is_auto(gt_time_offset_s):
        # a configuration file's offset is checked by the clock search, an argument is the caller's; either is placed
        # before the axis check when beyond its reach (an argument a day off had the axis check refuse the GT)
        data_s = _given_reference_clock(mission.imu, mission.gt, float(gt_time_offset_s), meta,
                                        facts)[1] if "gt_time_offset_s" in from_file else None
        if data_s is not None:
            # the axis check, the DVL's offset and the depth take the GT where the data put it; the GT handed on is
            # stamped with a given offset used as given
            used_as_given = float(gt_time_offset_s) if "gt_clock_doubted" in meta else None
            gt_time_offset_s, gt_clock = AUTO, data_s
        elif _beyond_the_fine_search(mission.gt, float(gt_time_offset_s), mission.imu):
            # a given offset (the data confirm one from a file) further than the axis check's +-2 s search finds the
            # GT: it is placed first (16 s off, it turned Trajectory10's x axis and moved its DVL 0.35 s)
            gt_time_offset_s, gt_clock = 0.0, float(gt_time_offset_s)
        if gt_clock:
            mission = dataclasses.replace(mission, gt=dataclasses.replace(mission.gt, t=mission.gt.t + gt_clock))
    dvl_time_offset_s = _given_time_offset(dvl_time_offset_s, facts, meta, "dvl")
    gt_time_offset_s = _off_the_imu_clock(mission.gt, gt_time_offset_s, mission.imu, "gt", meta)
    dvl_time_offset_s = _off_the_imu_clock(mission.dvl, dvl_time_offset_s, mission.imu, "dvl", meta)
    if mission.gt is not None and _is_auto(gt_time_offset_s) and not gt_clock:
        # a GT on a clock of its own first gets its clock offset: the axis check and the fine estimate need it
        # on the IMU's (they search +-2 s)
        gt, gt_clock = _gt_clock(mission, meta)
        mission = dataclasses.replace(mission, gt=gt)
    signs, detected = _axis_signs(mission, meta, facts, imu_axis_signs)
    judged = detected if detected is not None or "imu_axis_signs" not in from_file else \
        _judge_given_signs(mission, meta, facts, signs)
    if "gt_time_offset_s" in from_file and not _is_auto(gt_time_offset_s) and judged is not None \
            and judged.gt_offset is not None and on_the_imu_clock(mission.gt.t, mission.imu.t) \
            and _judge_given_offset(meta, facts, "gt", _gt_said(meta, gt_clock + float(gt_time_offset_s)),
                                    _gt_said(meta, gt_clock + judged.gt_offset.offset_s), judged.gt_offset.sigma_s,
                                    mission):
        # doubted by the fine search as by the clock search: the DVL's offset and the depth take the GT where the data
        # put it (0 given on Trajectory13 moved the DVL 0.6 s), the GT handed on keeps the given offset
        used_as_given, gt_time_offset_s = gt_clock + float(gt_time_offset_s), AUTO
    cfg = dataclasses.replace(mission.config)
    cfg.imu_axis_signs = signs
    t_imu = mission.imu.t
    f_b, omega_b = mission.imu.f_b * signs, mission.imu.omega_b * signs
    auto = _is_auto(dvl_time_offset_s)
    # a DVL on a clock of its own first gets its coarse clock offset (the fine search below is +-3 s); on the IMU
    # clock it judges a gyro the tilt kinematics could not, before the GT offsets integrate the gyro
    imu = ImuData(t_imu, f_b, omega_b, source=mission.imu.source)
    coarse, imu = _coarse_dvl_clock(imu, mission.dvl, meta, cfg) if auto else (0.0, imu)
    dvl = mission.dvl
    if coarse or not on_the_imu_clock(dvl.t, t_imu):
        dvl = dataclasses.replace(dvl, t=dvl.t + (coarse if auto else float(dvl_time_offset_s)))
    imu = _gyro_against_dvl(imu, dvl, cfg, meta)
    omega_b = imu.omega_b
    t_dvl, v_dvl = mission.dvl.t, mission.dvl.v_b
    meta["imu_axis_signs"] = {"signs": signs.tolist(), "detected": detected is not None,
                              "decided": None if detected is None else detected.decided}
    g = mission.gt
    if g is None:
        return _prepare_akit_without_gt(mission, meta, facts, cfg, imu, dvl_time_offset_s, coarse,
                                        judge="dvl_time_offset_s" in from_file)
    imu_position_b = np.asarray(facts["imu_position_b"], float)
    lat_for_rate = cfg.lat_rad if cfg.earth_rotation else None
    estimates = {}
    if _is_auto(gt_time_offset_s) and detected is not None and detected.gt_offset is not None \
            and cfg.earth_rotation:       # the axis check already estimated it (same function, same inputs)
        gt_time_offset_s = detected.gt_offset.offset_s
        estimates["gt"] = detected.gt_offset
    if _is_auto(gt_time_offset_s):
        est = estimate_gt_time_offset(t_imu, omega_b, g.t, g.C_b_n, lat_for_rate, source=g.source)
        gt_time_offset_s = est.offset_s
        estimates["gt"] = est
    ref = Reference(t_imu, f_b, omega_b, g.t + float(gt_time_offset_s), g.v_n, g.C_b_n, cfg.gravity_mps2,
                    lat_for_rate, cfg.dvl)
    coarse = coarse if auto else float(dvl_time_offset_s)
    try:
        # against the published GT point the DVL sits at lever arm + IMU position
        est = estimate_dvl_time_offset(ref, t_dvl + coarse, v_dvl, cfg.dvl.lever_arm_b + imu_position_b,
                                       source=mission.dvl.source or "dvl")
    except DataError:
        if auto:
            raise
        est = None          # a given offset the GT cannot check (too little overlap): the user's call
    if est is not None:
        from graphnav.calibration import dvl_scale
        from graphnav.io.loaders import AKIT_COLUMNS
        # under the RMS bound a DVL turned 5 deg passes: its turn against the GT is measured to a tenth of a degree;
        # over it (12 deg and more) the turn is what the refusal says. Fitted with the lever arm's error, which
        # would otherwise read as a turn
        pings = (ref, t_dvl + coarse + est.offset_s, mission.dvl.v_b, cfg.dvl.lever_arm_b + imu_position_b)
        turn, dl, dl_sigma = dvl_scale.turn_and_lever_against_reference(*pings)
        # with a given offset too: a DVL in another frame follows the GT at no offset near it. Said by the turn
        # alone: a lever-arm correction lets x and y swapped fit a turn of 77 deg
        _check_dvl_follows_gt(est.rms, mission.dvl.source, g, imu, pings)
        field = "/".join(AKIT_COLUMNS["DVL"][1:4])
        dvl_scale.warn_turn_against_reference(turn, mission.dvl, meta, field, dvl_scale.AKIT_DVL_FIXES, g.source)
        span = float(np.ptp(t_dvl)) if len(t_dvl) else 0.0
        dvl_scale.warn_lever_against_reference(dl, dl_sigma, mission.dvl, meta, field, cfg.dvl.lever_arm_b, g.source,
                                               span)
        if not auto and "dvl_time_offset_s" in from_file:      # est: what the data add to the given offset
            against = "as given" if used_as_given is None else "where the data put it"
            _judge_given_offset(meta, facts, "dvl", _dvl_said(meta, coarse), _dvl_said(meta, coarse + est.offset_s),
                                est.sigma_s, mission, f", against the GT {against}")
    if auto:
        est = dataclasses.replace(est, offset_s=est.offset_s + coarse)
        dvl_time_offset_s = est.offset_s
        estimates["dvl"] = est
    if gt_clock and "gt" in estimates:
        estimates["gt"] = dataclasses.replace(estimates["gt"], offset_s=estimates["gt"].offset_s + gt_clock)
    cfg.gt_time_offset_s = _gt_said(meta, gt_clock + float(gt_time_offset_s))
    cfg.dvl_time_offset_s = _dvl_said(meta, dvl_time_offset_s)

    t_gt = t_depth = g.t + float(gt_time_offset_s)          # g is on the IMU clock already (gt_clock added)
    if used_as_given is not None:
        estimates.pop("gt", None)
        _depth_where_the_data_put_it(meta, mission.depth, _gt_said(meta, used_as_given), cfg.gt_time_offset_s)
        cfg.gt_time_offset_s = _gt_said(meta, used_as_given)
        t_gt = g.t - gt_clock + used_as_given
    gt = GroundTruth(t_gt, g.p_n, g.v_n, g.C_b_n, g.origin_lla, source=g.source)
    if np.any(imu_position_b):
        from graphnav.calibration.reference import move_ground_truth
        gt = move_ground_truth(gt, t_imu, omega_b, imu_position_b, lat_for_rate)
    # the point's move changes no stamp and its position term none either: the depth is the moved GT's down
    depth = DepthData(t_depth, gt.p_n[:, 2].copy(), source=mission.depth.source)
    dvl = dataclasses.replace(mission.dvl, t=t_dvl + float(dvl_time_offset_s))
    meta["gt_point_b"] = imu_position_b.tolist()
    meta["time_offsets"] = {k: {"offset_s": e.offset_s, "sigma_s": e.sigma_s, "rms": e.rms}
                            for k, e in estimates.items()}
    _offsets_on_written_stamps(meta)
    _note_akit(meta, cfg, dvl, gt, estimates, depth)
    meta["prepared"] = True
    return dataclasses.replace(mission, imu=imu, dvl=dvl, config=cfg, gt=gt, depth=depth, meta=meta)


def _offsets_on_written_stamps(meta: dict) -> None:
    """The DVL's and GT's ``meta["clock_offsets"]`` and ``meta["time_offsets"]`` (in place), kept on their stamps as
    rescaled while the prepare step moves them, put on their stamps as written, as the configuration records the
    offsets (:func:`graphnav.core.streams.offset_on_written_stamps`; the same for a file on the folder's clock): given
    back, an offset meta keeps lands where the search put the samples (a file a day off, 0.0025 of the time its piece
    starts into the published grid: 0.84 s for one from 330 s)."""
    for stream in ("dvl", "gt"):
        for kept in (meta.get("clock_offsets", {}).get(stream), meta.get("time_offsets", {}).get(stream)):
            if kept is not None:
                kept.update(clock_offsets_on_written_stamps(meta, stream, kept))


def _depth_where_the_data_put_it(meta: dict, depth: DepthData, given: float, data_s: float) -> None:
    """Said of an A-KIT folder whose given GT offset (``given``, s) the clock or fine search contradicts: the depth,
    the GT file's altitude on the GT file's clock, is placed at the offset the data give (``data_s``, s), warned
    about naming the file and column, noted and counted as doubted. The GT, a reference to score against, is used as
    given; the depth aids the estimator, which at the given stamps would be fed a depth 16 s off the vehicle's motion
    (its depth gate refusing it in every dive). Placed rather than left out, as a log's depth on a clock of its own is:
    the GT's turns fix this clock to a millisecond, where a depth's own changes fix it to seconds."""
    from graphnav.io.loaders import AKIT_COLUMNS
    text = (f"field '{AKIT_COLUMNS['GT'][3]}': the depth (the GT's altitude, on the GT file's clock) is placed at the "
            f"offset the data give the GT, {data_s:+.3f} s, not at the given gt_time_offset_s {given:+.3f} s, which "
            f"would feed the estimator a depth {abs(data_s - given):.3f} s off the vehicle's motion")
    say_doubted(meta, "depth", depth.source, text, "placed at the GT offset the data give, not the given "
                "gt_time_offset_s", len(depth.t), stacklevel=4)


def _beyond_the_fine_search(data, offset_s: float, imu: ImuData) -> bool:
    """A given time offset (s) further than the fine search reaches (:data:`GT_OFFSET_SEARCH_S`) that puts ``data``'s
    stamps on the IMU span: what must be added before a check that searches +-2 s compares them with the IMU."""
    return abs(offset_s) > GT_OFFSET_SEARCH_S and on_the_imu_clock(np.asarray(data.t, float) + offset_s, imu.t)


def _judge_given_signs(mission: Mission, meta: dict, facts: dict, signs: np.ndarray):
    """The axis detection (:func:`detect_akit_axis_signs`, its own warning left out) run to judge the
    ``imu_axis_signs`` a configuration file gave: a warning (:func:`_doubt_given`) when it decides on others. Without
    a GT it takes x forward, blind to a turn about z: signs that differ from its only by x and y both negated (a turn
    of 180 deg about z) are the DVL's to judge (:func:`_prepare_akit_without_gt`), as the clock search's refusal that
    advised them did."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        detection = detect_akit_axis_signs(mission, facts.get("gt_mean_depth_m"))
    turned = mission.gt is None and np.array_equal(np.asarray(detection.signs, float) * signs, [-1.0, -1.0, 1.0])
    if detection.decided and not turned and not np.array_equal(np.asarray(detection.signs, float), signs):
        _doubt_given(meta, facts, "imu_axis_signs", "imu", len(mission.imu.t), tuple(int(x) for x in signs),
                     f"the data say {tuple(int(x) for x in detection.signs)}"
                     + (f" ({'; '.join(detection.notes)})" if detection.notes else ""))
    return detection


def _judge_given_offset(meta: dict, facts: dict, stream: str, given: float, data_say: float, sigma_s: float,
                        mission: Mission, against: str = "", floor_s: float | None = None) -> bool:
    """A warning (:func:`_doubt_given`) when the time offset (s) a configuration file gave for ``stream`` lies off
    the one the data say (``data_say``, s, with 1-sigma ``sigma_s``) by more than 3 sigmas and ``floor_s`` (default
    one IMU period: a rounded offset is not worth a word). ``against`` names what the estimate fits. True when
    doubted."""
    floor_s = 1.0 / float(mission.config.imu_rate_hz) if floor_s is None else floor_s
    doubted = abs(given - data_say) > max(3.0 * sigma_s, floor_s)
    if doubted:
        _doubt_given(meta, facts, f"{stream}_time_offset_s", stream, len(getattr(mission, stream).t), f"{given:+.3f} s",
                     f"the data say {data_say:+.3f} s (sigma {sigma_s:.4f} s{against})")
    return doubted


def _doubt_given(meta: dict, facts: dict, key: str, stream: str, n: int, given, data_say: str) -> None:
    """A configuration file's value of ``key`` used as given though the data disagree: warned (naming the file,
    the key, both values and how to let the data decide), noted and counted as doubted on ``stream``."""
    from graphnav.core.streams import count_doubted
    source = facts.get("given_by", {}).get(key, "the configuration")
    text = (f"{key} = {given} is given, but {data_say}: it is used as given; set {key} to null (or remove the "
            "key) to let the data decide (a configuration written before null meant 'not given' holds 0 s and "
            "(1, 1, 1) as numbers)")
    add_note(meta, stream, f"{source}: {text}")
    count_doubted(meta, stream, f"{key} used as given though the data disagree", n)
    if stream == "gt":              # what a score against it says beside the score (:func:`reference_notes`)
        meta["gt_time_doubted"] = f"{source}: {key} = {given} is given, but {data_say}"
    warnings.warn(f"{source}: {text}", RuntimeWarning, stacklevel=5)


def _off_the_imu_clock(data, offset, imu: ImuData, stream: str, meta: dict):
    """``offset`` (s added to the stamps of ``data``, a stream of the mission), or ``"auto"`` with a warning and a
    note in ``meta`` when a given offset leaves its stamps off the IMU clock
    (:func:`graphnav.core.timeseries.on_the_imu_clock`): the file is on a clock of its own (a folder whose stamps were
    moved after graphnav wrote it with its configuration), and the clock check finds it instead of every sample being
    refused. A file that only outlasts the IMU keeps the offset. None ``data``: ``offset``. The warning quotes the
    offset on the file's stamps as written, as it was given (:func:`graphnav.core.streams.offset_on_written_stamps`)."""
    if data is None or _is_auto(offset) or not len(data.t):
        return offset
    t = np.asarray(data.t, float) + float(offset)
    if on_the_imu_clock(t, imu.t):
        return offset
    given = offset_on_written_stamps(meta, stream, float(offset))
    text = (f"the configured {stream}_time_offset_s {given:+.3f} s puts the stamps at [{t[0]:.3f}, "
            f"{t[-1]:.3f}] s, sharing {overlap_text(t, imu.t)} with the IMU "
            f"span [{imu.t[0]:.3f}, {imu.t[-1]:.3f}] s: the file is on a clock of its own, whose offset is estimated "
            "from the data instead")
    add_note(meta, stream, text)
    warnings.warn(f"{data.source}: {text}", RuntimeWarning, stacklevel=4)
    return AUTO


def _gt_clock(mission: Mission, meta: dict) -> tuple[GroundTruth, float]:
    """(GT on the IMU clock, the clock offset added, s) of an A-KIT mission as read without a given GT offset. On the
    IMU span: the clock search a log's reference gets (:func:`_searched_reference_clock`; the published files: 0);
    a GT 16 s off shares 96 % of the span, and the fine search's +-2 s scored it 16 s off. Off it:
    :func:`graphnav.calibration.clock.align_gt_clock`'s, or DataError naming the GT file."""
    if on_the_imu_clock(mission.gt.t, mission.imu.t):
        return _searched_reference_clock(mission.imu, mission.gt, meta, "GT")
    from graphnav.calibration.clock import align_gt_clock
    return align_gt_clock(mission.imu, mission.gt, meta, field="Time [s]",
                          what_to_do=_GIVE_OFFSET.format(kind="GT", stream="gt"))


def _prepare_akit_without_gt(mission: Mission, meta: dict, facts: dict, cfg: SensorConfig, imu: ImuData,
                             dvl_time_offset_s, coarse: float, judge: bool) -> Mission:
    """An A-KIT folder with IMU and DVL files only, as a vehicle has them: the DVL time offset given, its coarse
    clock offset (``coarse``, s, 0 on the IMU span), or for ``"auto"`` the vehicle's
    :data:`~graphnav.io.loaders.AKIT_DVL_TIME_OFFSET_S` unless the DVL clock fit puts the DVL clearly off it
    (:func:`_akit_dvl_offset_without_gt`; the fine estimate needs the missing GT). A given offset a configuration file
    set (``judge``) is judged against the DVL clock fit, as a log's is (:func:`_judge_given_dvl_clock`)."""
    from graphnav.io.loaders import AKIT_DVL_TIME_OFFSET_S
    auto, added_by = _is_auto(dvl_time_offset_s), "given"
    if auto and coarse:
        # the clock estimate is all there is without GT (no fine reference)
        dvl_time_offset_s, added_by = coarse, "found by the DVL clock search; no GT file to refine it"
    if _is_auto(dvl_time_offset_s):
        dvl_time_offset_s = _akit_dvl_offset_without_gt(mission.dvl, imu, cfg, meta)
        added_by = ("the vehicle's default" if dvl_time_offset_s == AKIT_DVL_TIME_OFFSET_S else
                    "the DVL clock fit; no GT file")
    # recorded for the stamps as written, as a given one is meant (the stamps are moved by it as rescaled)
    cfg.dvl_time_offset_s = _dvl_said(meta, dvl_time_offset_s)
    cfg.gt_time_offset_s = 0.0
    dvl = dataclasses.replace(mission.dvl, t=mission.dvl.t + float(dvl_time_offset_s))
    if judge and not auto:
        # a given offset left for the clock search (off the IMU span: warned about) is not the one used: not judged
        _judge_given_dvl_clock(dataclasses.replace(mission, imu=imu, config=cfg), dvl, dvl, meta, facts,
                               cfg.dvl_time_offset_s)
    # the checks a log or bag without reference gets: the velocity's unit, its turn and FLU axes, the IMU's turn
    from graphnav.calibration.dvl_scale import AKIT_DVL_FIXES, check_velocity_against_imu
    from graphnav.io.loaders import AKIT_COLUMNS
    check_velocity_against_imu(imu, dvl, cfg, meta, imu_frame=_akit_imu_frame(cfg),
                               field="/".join(AKIT_COLUMNS["DVL"][1:4]), fixes=AKIT_DVL_FIXES)
    meta["time_offsets"] = {}
    _offsets_on_written_stamps(meta)
    _note_akit(meta, cfg, dvl, None, {}, added_by={"dvl": added_by})
    meta["prepared"] = True
    return dataclasses.replace(mission, imu=imu, dvl=dvl, config=cfg, meta=meta)


#: Without a GT file, the DVL clock fit replaces the vehicle's DVL time offset
#: (:data:`~graphnav.io.loaders.AKIT_DVL_TIME_OFFSET_S`) where it is confident and puts the DVL further than this (s)
#: and 3 of its sigmas from it (:func:`_akit_dvl_offset_without_gt`). Measured on the ten shared trajectories without
#: GT (the fit within +-:data:`GIVEN_DVL_CLOCK_SEARCH_S` of +1.02 s), what it adds: -0.001..+0.033 s whole, within
#: 0.054 s on 120-200 s pieces, -0.096..+0.130 s on 60 s pieces (150 copies; sigmas up to 0.073 s), within 0.087 s with
#: 1-5 % of the DVL rows removed (240 copies), all confident. With the stamps moved 0.1-0.5 s either way (700 copies)
#: the fit stays within -0.08..+0.14 s of the offset estimated against the GT. 1.5x the largest clean departure (0.195
#: s), rounded; chosen so leaving two trajectories out at a time (0.144-0.195 s), it moved none of the held-out clean or
#: rows-removed copies and placed every shift of 0.3 s or more, 89 of 140 of 0.2 s, 4 of 140 of 0.1 s. At 0.2 s on all
#: ten: 139 of 140 shifts of 0.3 s (not the 60 s piece that departs most clean), 71 of 140 of 0.2 s, each within 0.135 s
#: of the GT's offset. It was 0.5 s (half the ping period), and a DVL file 0.3-0.45 s off loaded that far off.
AKIT_DVL_CLOCK_MARGIN_S = 0.2
#: Why the pings of an A-KIT DVL placed by the clock fit, not at the vehicle's offset, are counted as doubted.
AKIT_DVL_CLOCK_DOUBT = "DVL time offset from the DVL clock fit, off the vehicle's (no GT file to check it against)"


def _akit_dvl_offset_without_gt(dvl: DvlData, imu: ImuData, cfg: SensorConfig, meta: dict) -> float:
    """The DVL time offset (s, added to the stamps of ``dvl``) of an A-KIT folder without GT whose DVL is on the IMU
    span within the fine search's reach: the vehicle's :data:`~graphnav.io.loaders.AKIT_DVL_TIME_OFFSET_S`, warned
    about, unless the DVL clock fit (:func:`_dvl_clock_fit_near` at it: the DVL's velocity changes against the IMU's
    accelerations) is confident and puts the DVL further than :data:`AKIT_DVL_CLOCK_MARGIN_S` and 3 sigmas from it.
    Its offset is then used, warned about naming it and ``dvl_time_offset_s``, and the pings are counted as doubted
    (:data:`AKIT_DVL_CLOCK_DOUBT`): a DVL file 2.5-3.5 s late was loaded that far off the IMU clock with only the
    default's warning, and one 0.3-0.45 s off (under the 0.5 s margin of then) as well. A fit that cannot judge leaves
    the default, noted; one without a clear offset that points further than the margin from it is said in the
    default's warning."""
    from graphnav.io.loaders import AKIT_COLUMNS, AKIT_DVL_TIME_OFFSET_S
    default = AKIT_DVL_TIME_OFFSET_S
    try:
        est = _dvl_clock_fit_near(imu, dataclasses.replace(dvl, t=dvl.t + default), cfg)
    except DataError as err:
        est, not_judged = None, str(err)
    else:
        not_judged = None if est.confident else (still_velocity_said(est.peak, est.rms) or (
            f"the IMU explains {est.peak:.2f} of the DVL's velocity changes at best, {est.offset_s:+.2f} s from it: "
            "no clear offset"))
    # both comparisons: a fit whose sigma is NaN (max() then keeps the margin) moved a noisy 60 s piece 0.23 s
    if not_judged is None and abs(est.offset_s) > AKIT_DVL_CLOCK_MARGIN_S and abs(est.offset_s) > 3.0 * est.sigma_s:
        offset = default + est.offset_s
        # on the stamps as read, as a clock search's estimate is (its coarse offset too)
        found = dataclasses.replace(est, offset_s=offset, coarse_offset_s=default + est.coarse_offset_s)
        text = (f"field '{AKIT_COLUMNS['DVL'][0]}': no GT file, and the DVL clock fit (its velocity changes against "
                f"the IMU's accelerations) puts the DVL at {found.describe()}, {est.offset_s:+.2f} s from this "
                f"vehicle's usual {default:+.2f} s: {offset:+.3f} s is used. Give dvl_time_offset_s (s added to the "
                "DVL stamps) in a --config file if it is known")
        say_doubted(meta, "dvl", str(dvl.source), text, AKIT_DVL_CLOCK_DOUBT, len(dvl.t), stacklevel=5)
        meta.setdefault("clock_offsets", {})["dvl"] = found.to_dict()
        return offset
    unclear = ""
    if not_judged is not None:
        add_note(meta, "dvl", f"the vehicle's DVL time offset {default:+.2f} s is not checked against the DVL clock "
                 f"fit ({not_judged})")
        # a fit without a clear offset may still point seconds away (0.04 m/s of DVL noise, 3 s late: -2.7..-3.3 s)
        if est is not None and abs(est.offset_s) > AKIT_DVL_CLOCK_MARGIN_S:
            unclear = (f"; the DVL clock fit, not clear ({not_judged}), does not confirm it: give dvl_time_offset_s if "
                       "it is known")
    warnings.warn(f"{meta.get('source')}: no GT file, so the DVL time offset cannot be estimated; using this "
                  f"vehicle's {default:+.2f} s (the mean of the estimates on the shared "
                  f"trajectories, spread 0.025 s){unclear}; `graphnav calibrate --mode graph` estimates it without GT",
                  RuntimeWarning, stacklevel=5)
    return default


def _axis_signs(mission: Mission, meta: dict, facts: dict, imu_axis_signs) -> tuple[np.ndarray, object]:
    """(signs (3,), the detection or None): the given +-1 triple, or the detected convention for ``"auto"``."""
    if isinstance(imu_axis_signs, str):
        if not _is_auto(imu_axis_signs):
            raise ConfigError(f"imu_axis_signs must be 'auto' or three +-1 values, got {imu_axis_signs!r}")
        detection = detect_akit_axis_signs(mission, facts.get("gt_mean_depth_m"))
        if not detection.decided:
            add_note(meta, "imu", f"IMU axis convention undecided from the data; the configured "
                     f"{tuple(int(x) for x in detection.signs)} is used ({'; '.join(detection.notes)})")
            notes = meta["streams"]["imu"]["notes"]
            notes.insert(0, notes.pop())    # the first thing to know about the IMU stream, as the loader put it
        return np.asarray(detection.signs, float), detection
    signs = np.asarray(imu_axis_signs, float).reshape(3)
    if not np.all(np.abs(signs) == 1):
        raise ConfigError(f"imu_axis_signs must be +-1, got {signs.tolist()}")
    return signs, None


def detect_akit_axis_signs(mission: Mission, gt_mean_depth_m: float | None):
    """:func:`graphnav.calibration.axes.detect_imu_axis_signs` on an A-KIT mission as read (IMU axes of the file,
    GT at its published point and stamps), with its warning. ``gt_mean_depth_m``: the GT's mean depth, m (the
    gravity of the check). Adds ~0.1-0.3 s (the GT offset it finds is reused)."""
    from graphnav.calibration.axes import detect_imu_axis_signs
    imu = mission.imu
    # the (N,7) rows the loader always handed the check: the same arrays, the same arithmetic
    rows = np.column_stack([imu.t, imu.f_b, imu.omega_b])
    imu_data = ImuData(np.ascontiguousarray(rows[:, 0]), rows[:, 1:4], rows[:, 4:7], source=imu.source)
    gt_data, config = None, SensorConfig()
    g = mission.gt
    if g is not None:
        lat0 = g.origin_lla[0]
        config.lat_rad = float(lat0)
        config.gravity_mps2 = gravity_magnitude(lat0, gt_mean_depth_m)
        gt_data = GroundTruth(g.t, np.zeros((len(g.t), 3)), g.v_n, g.C_b_n, source=g.source)
    detection = detect_imu_axis_signs(imu_data, config, gt_data, imu.source)
    warnings.warn(detection.message(imu.source), UserWarning, stacklevel=4)
    return detection


def _check_dvl_follows_gt(rms: float, source, gt: GroundTruth | None = None, imu: ImuData | None = None,
                          pings: tuple | None = None) -> None:
    """DataError when the DVL velocity cannot be the GT's at any offset (see :data:`DVL_GT_RMS_MAX_MPS`). It
    names the DVL file and its velocity columns, unless the GT ``gt`` disagrees with itself or with the gyro of
    ``imu`` (:func:`graphnav.io.units.reference_inconsistencies`): the GT file is then named as the likelier fault.
    ``pings``: the arguments of :func:`graphnav.calibration.dvl_scale.turn_against_reference`; the DVL's turn about z
    against the GT's body velocity, fitted only for the refusal, is said when it explains the misfit."""
    if not rms > DVL_GT_RMS_MAX_MPS:
        return
    text = (f"the DVL velocity does not follow the ground truth's body velocity at any time offset (RMS residual "
            f"{rms:.3g} m/s per axis at the best one; 0.007-0.044 m/s on the shared trajectories)")
    found = []
    if gt is not None:
        from graphnav.io.units import reference_inconsistencies
        found = reference_inconsistencies(gt.t, gt.C_b_n, gt.p_n, gt.v_n, None if imu is None else imu.t,
                                          None if imu is None else imu.omega_b)
    if found:
        from graphnav.io.loaders import AKIT_COLUMNS
        c = AKIT_COLUMNS["GT"]
        columns = {"attitude": "/".join(c[7:10]), "positions": f"{c[2]}/{c[1]}", "depth": c[3],
                   "heading": f"{c[9]}/{c[4]}/{c[5]}"}
        raise DataError(f"{text}, and the ground truth disagrees with itself: {'; '.join(s for _, s in found)}. "
                        f"The ground truth is the likelier fault (its units or angle conventions), not the DVL "
                        f"({source})", str(gt.source), field=columns[found[0][0]])
    from graphnav.calibration.dvl_scale import (AKIT_DVL_FIXES, GT_MIN_YAW_RAD, MIN_SCALE_R2, YAW_SIGMAS,
                                                turn_against_reference)
    from graphnav.io.loaders import AKIT_COLUMNS
    yaw, sigma, r2 = turn_against_reference(*pings) if pings is not None else (np.nan, np.nan, np.nan)
    # x and y swapped on a vehicle moving forward fit a quarter turn as well: the turn is said beside the frame
    said = (f"; the turn fit finds its velocity turned {np.degrees(yaw):+.1f} +- {np.degrees(sigma):.1f} deg about z "
            f"from the ground truth's (explaining {r2:.2f} of its horizontal velocity): a DVL mounted turned, its "
            f"columns in the instrument frame read as body? {AKIT_DVL_FIXES['yaw']}" if r2 >= MIN_SCALE_R2 and
            abs(yaw) > GT_MIN_YAW_RAD and abs(yaw) > YAW_SIGMAS * sigma else "")
    raise DataError(f"{text}: the DVL is in another frame (axes swapped, dvl.C_d_b) or other units{said}", str(source),
                    field="/".join(AKIT_COLUMNS["DVL"][1:4]))


def _coarse_dvl_clock(imu: ImuData, dvl: DvlData, meta: dict, cfg: SensorConfig) -> tuple[float, ImuData]:
    """``(offset, imu)``: 0 when the DVL stamps lie on the IMU's span (the published files), unless the clock search
    finds them further off than the fine search reaches (:func:`_clock_beyond_the_fine_search`); otherwise the DVL's
    clock offset from the data (:func:`graphnav.calibration.clock.align_stream_clocks`, noted in ``meta``), or
    DataError when it cannot be found, after the gyro's other scales (:func:`_gyro_finds_the_clock`, which may
    convert the ``imu`` returned) and the DVL's velocity turned about z (:func:`_turn_finds_the_clock`, which names
    a turn that finds it)."""
    t_dvl, t_imu = dvl.t, imu.t
    from graphnav.calibration.clock import ImuSide, align_stream_clocks
    imu_side = ImuSide()
    velocity_only = DvlData(t_dvl, *no_beams(len(t_dvl)), dvl.v_b, source=dvl.source)

    def search(imu_: ImuData, meta_: dict, dvl_: DvlData = velocity_only, model=None) -> float:
        aligned, _ = align_stream_clocks(imu_, dvl_, None, meta_, cfg, field="Time [s]",
                                         what_to_do=_GIVE_OFFSET.format(kind="DVL", stream="dvl"), model=model,
                                         ints=imu_side(imu_))
        return float(aligned.t[0] - dvl_.t[0])
    if np.mean((t_dvl >= t_imu[0]) & (t_dvl <= t_imu[-1])) >= 0.5:
        return _clock_beyond_the_fine_search(imu, velocity_only, cfg, meta, search, imu_side(imu)), imu
    from graphnav.calibration.dvl_scale import AKIT_DVL_FIXES
    return _clock_searched(lambda imu_: search(imu_, meta), search, imu, velocity_only, cfg, meta, None,
                           AKIT_DVL_FIXES, _akit_imu_frame(cfg))


def _clock_beyond_the_fine_search(imu: ImuData, dvl: DvlData, cfg: SensorConfig, meta: dict, search,
                                  ints=None) -> float:
    """0, or the clock offset (s) of an A-KIT DVL whose pings lie on the IMU span but further off than the fine search
    reaches (:data:`~graphnav.calibration.reference.DVL_OFFSET_SEARCH_S`): found by ``search(imu, meta, dvl, model)``
    where the IMU explains its velocity changes poorly as stamped (under the clock search's ``MIN_PEAK``:
    :func:`_stamps_explained_poorly`, whose window model the search scores). 60 s late on a 400 s trajectory, it was
    refused as a DVL in another frame (with GT) or loaded 60 s off (without). The published files' DVL, about 1 s
    early, explains -1.3 (Trajectory11) to 0.79 as stamped: the search finds it within the fine search's reach, which
    is left to take it, so they load as before. The search runs once, as a trial (:func:`_tried`), whose notes and
    warnings are the mission's only where its offset is taken, or where the IMU's gaps left it no window to score
    (:data:`~graphnav.calibration.clock.CLOCK_UNCHECKED_IMU_GAPS`). Where it finds no clear offset (a DVL too noisy for
    its clock: Trajectory13 60 s late with 0.25 m/s of noise loaded 60 s off without a word), the stamps kept are
    warned about and their pings counted (:data:`CLOCK_NOT_FOUND`), unless the DVL velocity barely changes (a straight
    steady leg: a note says its clock was not checked). ``ints``: the IMU's integrals the search's model is built on
    (:class:`graphnav.calibration.clock.ImuSide`)."""
    from graphnav.calibration.clock import CLOCK_UNCHECKED_IMU_GAPS, MIN_PEAK
    from graphnav.calibration.reference import DVL_OFFSET_SEARCH_S
    poorly = _stamps_explained_poorly(imu, dvl, cfg, ints)
    if poorly is None:
        return 0.0
    model, here = poorly
    noted = len(meta.get("streams", {}).get("dvl", {}).get("notes", []))
    trial = _tried(lambda meta_: search(imu, meta_, dvl, model), meta)
    est = _estimate_tried(trial)
    if est is not None:
        # the search wanders where the y negated leaves the velocity's changes unexplained at the right offset
        from graphnav.calibration.dvl_scale import AKIT_DVL_FIXES
        _y_finds_the_clock(None, search, imu, dvl, cfg, trial.meta, AKIT_DVL_FIXES, keeps_s=DVL_OFFSET_SEARCH_S)
    taken = est is not None and est["confident"] and abs(est["offset_s"]) > DVL_OFFSET_SEARCH_S
    # a search the IMU's gaps left without windows: its warning and count kept, as a column map's (the stamps,
    # maybe a minute off, were dropped unsaid)
    unchecked = CLOCK_UNCHECKED_IMU_GAPS in trial.meta.get("streams", {}).get("dvl", {}).get("doubted", {})
    if taken or unchecked:
        trial.keep(meta)
    still = est is not None and still_velocity_said(est["peak"], est["rms"])
    if still:
        # a DVL holding its velocity is not hurt by a clock the IMU cannot check: noted, not counted as doubted; before
        # the notes of a search kept above, which say where it then moved the stamps this note is about
        stream_entry(meta, "dvl")["notes"].insert(noted, f"clock not checked against the IMU: {still}")
    elif est is not None and not est["confident"]:
        say_doubted(meta, "dvl", dvl.source, f"{_clock_not_found_said(est)}, and the IMU explains {here:.2f} of them "
                    f"at its stamps as read (under {MIN_PEAK:g}): its stamps are kept as read, and a DVL off its clock "
                    "is judged and fused there: give dvl_time_offset_s if it is known", CLOCK_NOT_FOUND, len(dvl.t),
                    stacklevel=4)
    return trial.value if taken else 0.0


def _stamps_explained_poorly(imu: ImuData, dvl: DvlData, config: SensorConfig,
                             ints=None) -> tuple[object, float] | None:
    """``(model, here)`` where the IMU explains the DVL's velocity changes poorly at its stamps as read (``here``, under
    the clock search's ``MIN_PEAK``: a DVL that may be off its clock), ``model`` the clock search's window model
    (:func:`graphnav.calibration.clock.clock_model`) it was scored on, for the search to score as well; None where
    the stamps explain more, or the pings are too few to tell (unless the IMU's gaps left them too few: ``here`` NaN
    then). ``ints``: the IMU's integrals, when built already."""
    from graphnav.calibration.clock import MIN_PEAK, clock_model, explained_as_stamped
    try:
        model = clock_model(imu, dvl, config, ints=ints)
    except DataError:
        return None
    here = explained_as_stamped(imu, dvl, config, model=model)
    # the IMU's gaps leaving no two windows at the stamps is no sign they are right: the search says what they leave
    return (model, here) if here < MIN_PEAK or (np.isnan(here) and len(model.imu.gaps)) else None


def _akit_imu_frame(cfg: SensorConfig) -> dict:
    """What an A-KIT folder's IMU axes are judged against (``frame`` of
    :func:`graphnav.calibration.dvl_scale.check_imu_yaw`): the file's axes with ``cfg.imu_axis_signs`` applied."""
    from graphnav.io.loaders import AKIT_COLUMNS
    signs = tuple(int(s) for s in cfg.imu_axis_signs)
    return {"what": f"the file's axes with imu_axis_signs {signs}", "signs": signs,
            "fields": "/".join(AKIT_COLUMNS["IMU"][1:])}


#: An A-KIT time offset estimated with a larger sigma (s) is warned about: a twentieth of the 1 s DVL and GT period.
#: On the ten shared trajectories the sigmas are 0.0001-0.0005 s (GT) and 0.004-0.017 s (DVL).
OFFSET_SIGMA_WARN_S = 0.05


def _note_akit(meta: dict, cfg: SensorConfig, dvl: DvlData, gt: GroundTruth | None, estimates: dict,
               depth: DepthData | None = None, added_by: dict | None = None) -> None:
    """``meta["streams"]``: the prepared stamps' spans, the axis signs and the time offsets added: estimated against
    the GT (``estimates``), else as ``added_by`` says by stream (default: given)."""
    for stream, data in (("dvl", dvl), ("gt", gt), ("depth", depth)):
        if data is not None and stream in meta["streams"]:
            set_span(meta, stream, data.t)
    signs = meta["imu_axis_signs"]
    add_note(meta, "imu", f"axis signs {signs['signs']} applied to accelerometer and gyro"
                          + (" (detected at load time)" if signs["detected"] else " (given)"))
    for stream, offset in (("dvl", cfg.dvl_time_offset_s), ("gt", cfg.gt_time_offset_s)):
        if stream in meta["streams"]:
            est = estimates.get(stream)
            how = (f"estimated against the GT, sigma {est.sigma_s:.3f} s" if est is not None
                   else (added_by or {}).get(stream, "given"))
            if est is not None and not est.sigma_s <= OFFSET_SIGMA_WARN_S:
                text = (f"{stream} time offset {offset:+.3f} s estimated with sigma {est.sigma_s:.3f} s: the data "
                        "barely fix it (too little motion, or noisy); set the "
                        f"{stream}_time_offset_s of the configuration if it is known")
                add_note(meta, stream, f"time offset {offset:+.3f} s added ({how}): the data barely fix it")
                warnings.warn(f"{meta.get('files', {}).get(stream.upper(), meta.get('source', stream))}: {text}",
                              RuntimeWarning, stacklevel=4)
            else:
                add_note(meta, stream, f"time offset {offset:+.3f} s added ({how})")


# ------------------------------------------------------------------------------------------------
# Bags, CSV logs, PD0
# ------------------------------------------------------------------------------------------------
def _prepare_streams(mission: Mission, meta: dict, facts: dict) -> Mission:
    """The IMU frame checked, a DVL on its own clock put on the IMU's, the depth's sign and unit checked; a bag
    without heading told whether it can gyrocompass."""
    mission = _reference_clock(mission, meta, facts)
    # without a reference attitude on the IMU clock, the DVL is what can see an IMU turned about z
    judge = _reference_checks_axes(mission, meta, facts)
    unchecked = None if judge is not None else facts.get("imu_frame")
    mission = _imu_frame(_given_axis_signs(mission, meta, facts), meta, facts.get("imu_frame"), judge)
    # before the clock search and the reference's time offset, which integrate the gyro (a DVL on a clock of its own
    # judges it once the search has put it on the IMU's)
    mission = dataclasses.replace(mission, imu=_gyro_against_dvl(mission.imu, mission.dvl, mission.config, meta))
    dvl, depth = mission.dvl, mission.depth
    given = facts.get("given", {}).get("dvl_time_offset_s")
    # stamps a given offset moves, or that the loader kept at the velocity's own best clock offsets, are not known to
    # be on the IMU clock: judged as a DVL off it, once the offset or the clock search has moved them
    judged = on_the_imu_clock(dvl.t, mission.imu.t) and not given and not meta.get(OFF_ITS_STAMPS)
    if judged:
        # before the clock search: a velocity in other units or axes can fit the IMU best at a wrong offset
        _judge_dvl_against_imu(mission, dvl, meta, facts, unchecked, clock_known=facts.get("dvl_clock") != AUTO)
    if given is not None:
        dvl, depth = _given_dvl_offset(dvl, depth, float(given), meta)
    searched = dvl
    if facts.get("dvl_clock") == AUTO:
        # after a given offset too: a configuration copied from another mission, or a full dump's 0, may leave the
        # DVL seconds or days off; what the search finds under half a ping period is left as given
        from graphnav.calibration.clock import ImuSide, align_stream_clocks
        imu_side = ImuSide()

        def search(imu: ImuData, meta_: dict, dvl_: DvlData = searched) -> float:
            return float(align_stream_clocks(imu, dvl_, None, meta_, mission.config, ints=imu_side(imu))[0].t[0]
                         - dvl_.t[0])
        (dvl, depth), imu = _clock_searched(
            lambda imu_: align_stream_clocks(imu_, dvl, depth, meta, mission.config, ints=imu_side(imu_)), search,
            mission.imu, searched, mission.config, meta, judged_velocity_unit(meta), _dvl_fixes(facts),
            facts.get("imu_frame") or {"what": "the body frame"})
        mission = dataclasses.replace(mission, imu=imu)
        if not given and dvl is searched:
            _say_clock_not_found(dvl, meta, facts.get("format"))
    elif on_the_imu_clock(dvl.t, mission.imu.t):
        _check_declared_clock(mission, dvl, given)
    mission = dataclasses.replace(mission, imu=_gyro_against_dvl(mission.imu, dvl, mission.config, meta))
    moved = facts.get("dvl_clock") == AUTO and dvl is not searched
    if (moved or not judged) and on_the_imu_clock(dvl.t, mission.imu.t):
        # however the DVL got onto the IMU clock: searched, or by a given offset the search left as it is (or
        # ``clock: imu``); before the given offset is judged, which a velocity in other units or axes misleads. One
        # the loader kept as carried by a current off the IMU clock was judged for an earth frame at its own offsets
        _judge_dvl_against_imu(mission, dvl, meta, facts, unchecked, moved=judged or not meta.get(CARRIED),
                               clock_known=not (facts.get("dvl_clock") == AUTO and dvl is searched and not given))
    if given is not None:
        _judge_given_dvl_clock(mission, searched, dvl, meta, facts, float(given))
    # after the DVL has judged the gyro (on its clock too): the reference's offset integrates the gyro as converted
    mission = _reference_on_the_imu(mission, meta, facts)
    for stream, new, old in (("dvl", dvl, mission.dvl), ("depth", depth, mission.depth)):
        if new is not old and stream in meta.get("streams", {}):
            set_span(meta, stream, new.t)           # the stamps as the mission holds them
    if dvl is not mission.dvl:
        # the configuration records the offset added to the DVL stamps, as an A-KIT folder's does: what calibrate
        # adds its fine offset to, and what the next run is given
        offset = float(dvl.t[0] - mission.dvl.t[0]) if len(dvl.t) else 0.0
        mission = dataclasses.replace(mission, config=dataclasses.replace(mission.config, dvl_time_offset_s=offset))
    # a reference whose given offset the clock search contradicts cannot judge the depth's time or sign: the DVL can
    judged = dataclasses.replace(mission, dvl=dvl, depth=depth,
                                 gt=None if "gt_clock_doubted" in meta else mission.gt)
    if depth is not None and len(depth.t) and facts.get("imu_frame") is not None:
        depth = _depth_in_time(judged, meta, facts)
        if depth is not None:
            from graphnav.io.units import depth_convention
            key = "bag_topics.depth.positive" if facts.get("format") == "bag" else "csv_columns.depth.positive"
            checked = depth_convention(dataclasses.replace(judged, depth=depth), meta,
                                       meta.get("stream_fields", {}).get("depth", "depth"),
                                       facts.get("depth_positive"), key, turned=facts.get("depth_turned_up", False))
            depth = depth if checked is depth.depth else dataclasses.replace(depth, depth=checked)
    if facts.get("format") == "bag" and meta.get("heading_source") == "none":
        _warn_no_heading(mission.config, meta.get("source", "bag"), meta)
    meta["prepared"] = True
    return dataclasses.replace(mission, dvl=dvl, depth=depth, meta=meta)


def _check_declared_clock(mission: Mission, dvl: DvlData, given: float | None) -> None:
    """DataError when a DVL declared on the IMU clock (``clock: imu``; ``dvl``: its stamps with the ``given``
    ``dvl_time_offset_s`` added, s) is not on it: the IMU explains its velocity changes poorly at its stamps (under the
    clock search's ``MIN_PEAK``) and clearly (``confident``) at an offset further than ``PEAK_EXCLUSION_S``, searched
    over every offset keeping the overlap. A DVL 60 s late on a 600 s log was loaded 60 s off, its pings outside the
    IMU span only counted. A log whose velocity changes hide in the DVL noise (-0.07..0.13 explained on simulated
    600 s ones with the default beams) pays the search and is left as declared: no offset is clear."""
    from graphnav.calibration.clock import PEAK_EXCLUSION_S, estimate_dvl_clock_offset
    poorly = _stamps_explained_poorly(mission.imu, dvl, mission.config)
    if poorly is None:
        return
    model, here = poorly
    try:
        est = estimate_dvl_clock_offset(mission.imu, dvl, mission.config, model=model)
    except DataError:
        return
    if not (est.confident and abs(est.offset_s) > PEAK_EXCLUSION_S):
        return
    stamps = ((mission.config.csv_columns or {}).get("dvl") or {}).get("t", "t")
    plus = f" plus the given dvl_time_offset_s {given:+.3f} s" if given else ""
    raise DataError(f"the DVL stamps{plus}, declared on the IMU clock (csv_columns.dvl.clock 'imu'), are not on it: "
                    f"the IMU's accelerations explain {max(here, 0.0):.2f} of the DVL's velocity changes at them, and "
                    f"at {est.describe()}: give dvl_time_offset_s {(given or 0.0) + est.offset_s:+.3f} (s added to the "
                    "DVL stamps) in the configuration, or set csv_columns.dvl.clock to 'auto' to have it found",
                    dvl.source, field=stamps)


def _judge_dvl_against_imu(mission: Mission, dvl: DvlData, meta: dict, facts: dict, imu_frame: dict | None,
                           moved: bool = False, clock_known: bool = True) -> None:
    """A log's or bag's DVL ``dvl``, on the IMU clock, judged against the IMU: its declared velocity unit
    (:func:`graphnav.calibration.dvl_scale.check_declared_velocity_unit`; first: a velocity 100x too small fits the
    IMU as badly turned as not), then its scale, turn and FLU axes and, with ``imu_frame`` (the IMU's declared frame no
    reference checked), the IMU's turn about z (:func:`graphnav.calibration.dvl_scale.check_velocity_against_imu`).
    ``moved``: the DVL was put on the IMU clock here (by the clock search or a given ``dvl_time_offset_s``), where the
    loader could not check it for an earth frame by the body kinematics: checked too. ``clock_known`` False: stamps a
    clock search has still to judge (``clock: auto``), or that it found no clock for, at which FLU axes are not judged
    alone and the DVL's y is not judged (only on stamps on the IMU clock as declared, given or found). DataError or
    warnings as those say."""
    from graphnav.calibration.dvl_scale import check_declared_velocity_unit, check_velocity_against_imu
    check_declared_velocity_unit(mission.imu, dvl, mission.config, meta, judged_velocity_unit(meta))
    check_velocity_against_imu(mission.imu, dvl, mission.config, meta, moved=moved, imu_frame=imu_frame,
                               fixes=_dvl_fixes(facts), reference=mission.gt, clock_known=clock_known)


def _dvl_fixes(facts: dict) -> dict:
    """What the DVL checks' messages advise for a log or bag (:data:`graphnav.io.units.DECLARE_DVL_FIXES`,
    :data:`~graphnav.io.units.BAG_DVL_FIXES`)."""
    from graphnav.io.units import BAG_DVL_FIXES, DECLARE_DVL_FIXES
    return BAG_DVL_FIXES if facts.get("format") == "bag" else DECLARE_DVL_FIXES


def _depth_in_time(mission: Mission, meta: dict, facts: dict) -> DepthData | None:
    """The depth of a log or bag on the IMU span, or None when its changes match the vehicle's vertical velocity
    more than a few seconds from its stamps (:func:`graphnav.io.units.depth_off_its_stamps`): on a clock of its own
    it would be used at the wrong time (16 s late on a 40 s log it shares 60 % of the span, and no check saw it), so
    it is left out, warned about, counted and marked not usable, as a depth off the span
    (:func:`graphnav.io.stream_counts.warn_off_the_imu_clock`). One off the span is left to that rule."""
    from graphnav.io.stream_counts import DEPTH_OFF_ITS_STAMPS, OFF_THE_IMU_CLOCK_FIX, leave_out
    from graphnav.io.units import DEPTH_CLOCK_WINDOW_S, depth_off_its_stamps, vertical_velocity
    depth = mission.depth
    if not on_the_imu_clock(depth.t, mission.imu.t):
        return depth
    t_v, v_down, what = vertical_velocity(mission)
    found = depth_off_its_stamps(depth.t, depth.depth, t_v, v_down)
    if found is None:
        return depth
    offset, r, r0 = found
    fit = (f"changes match {what} best at its stamps {offset:+.1f} s (correlation {r:.2f} there, {r0:.2f} as "
           f"stamped, over {DEPTH_CLOCK_WINDOW_S:g} s windows): a clock of its own")
    text = (f"field '{_stamp_fields(mission, facts)['depth']}': the depth's {fit}; its {len(depth.t)} sample(s) "
            f"would be used at the wrong time: the depth is left out; {OFF_THE_IMU_CLOCK_FIX['depth']}")
    leave_out(meta, "depth", depth.source, f"its {fit}", text, {DEPTH_OFF_ITS_STAMPS: len(depth.t)})
    return None


def _reference_clock(mission: Mission, meta: dict, facts: dict) -> Mission:
    """A log's or bag's reference put on the IMU clock when the data find it on a clock of its own further than the
    fine time-offset search reaches (:data:`GT_OFFSET_SEARCH_S`), as an A-KIT folder's GT is: the angles it turns
    through against the gyro's (:func:`graphnav.calibration.clock.estimate_gt_clock_offset`, confident), before the
    checks that compare it with the IMU. Off the IMU span (28 s late on a 40 s log) it was left out; on it (16 s late,
    sharing 60 %) it was scored 16 s off. A given ``gt_time_offset_s`` gets the same search on the stamps it gives
    (:func:`_given_reference_clock`). One no offset explains is left as it is
    (:func:`graphnav.io.stream_counts.warn_off_the_imu_clock` leaves out one off the span)."""
    g = mission.gt
    if g is None:
        return mission
    given = facts.get("given", {}).get("gt_time_offset_s")
    moved = (_searched_reference_clock(mission.imu, g, meta, "reference") if given is None
             else _given_reference_clock(mission.imu, g, float(given), meta, facts))[0]
    return mission if moved is g else dataclasses.replace(mission, gt=moved)


def _searched_reference_clock(imu: ImuData, gt: GroundTruth, meta: dict, name: str) -> tuple[GroundTruth, float]:
    """``(gt, offset added, s)``: a reference without a given time offset (an A-KIT GT, a log's or bag's reference,
    called ``name``) put on the IMU clock when the clock search finds it further off than the fine search reaches
    (:func:`_far_reference_clock`), warned about naming its file
    (:func:`graphnav.calibration.clock.add_gt_clock_offset`); as it is, with 0, otherwise."""
    est = _far_reference_clock(imu, gt)
    if est is None:
        return gt, 0.0
    from graphnav.calibration.clock import add_gt_clock_offset
    text = (f"{name} clock offset {est.describe()} estimated from the data and added to the {name} stamps "
            f"[{gt.t[0]:.3f}, {gt.t[-1]:.3f}] s (sharing {overlap_text(gt.t, imu.t)} with the IMU span): a clock "
            "of its own; set gt_time_offset_s in the configuration if it is known")
    return add_gt_clock_offset(gt, est, meta, text), est.offset_s


def _given_reference_clock(imu: ImuData, gt: GroundTruth, given: float, meta: dict, facts: dict):
    """The clock search a reference without a given offset gets (:func:`_far_reference_clock`), run on its stamps with
    the configuration's ``gt_time_offset_s`` ``given`` (s) added, for an A-KIT folder's GT and a log's or bag's
    reference alike: ``(gt, None)`` when it finds no confident offset beyond the fine search's reach (the given offset
    stands, judged by the fine search), else ``(gt, the offset the data give in all, s)``, said as a given value the
    data contradict. With the given offset the reference on the IMU span is used as given (:func:`_doubt_given`: its
    score doubted, and ``meta["gt_clock_doubted"]``: no alignment starts from it) and ``gt`` comes back as it is; off
    the span, where as given it would be lost, what the data give is added to ``gt``'s stamps instead (besides the
    given offset), warned about naming the configuration, noted and its samples counted as doubted. The messages quote
    offsets on the reference's stamps as written (an A-KIT GT rescaled about its own first stamp:
    :func:`graphnav.core.streams.offset_on_written_stamps`), as ``gt_time_offset_s`` is given."""
    key = "gt_time_offset_s"
    shifted = dataclasses.replace(gt, t=np.asarray(gt.t, float) + given)
    est = _far_reference_clock(imu, shifted)
    if est is None:
        return gt, None
    data_s = given + est.offset_s
    says = (f"the angles the reference turns through match the gyro's at {_gt_said(meta, data_s):+.3f} s (sigma "
            f"{est.sigma_s:.3f} s; the clock search: the gyro explains {est.peak:.2f} of them there, "
            f"{est.second_peak:.2f} at the next best offset)")
    if on_the_imu_clock(shifted.t, imu.t):
        _doubt_given(meta, facts, key, "gt", len(gt.t), f"{_gt_said(meta, given):+.3f} s", says)
        meta["gt_clock_doubted"] = data_s
        return gt, data_s
    from graphnav.calibration.clock import add_gt_clock_offset
    text = (f"{key} = {_gt_said(meta, given):+.3f} s is given, but {says}; with it the reference stamps lie at "
            f"[{shifted.t[0]:.3f}, {shifted.t[-1]:.3f}] s, sharing {overlap_text(shifted.t, imu.t)} with the IMU span "
            f"[{imu.t[0]:.3f}, {imu.t[-1]:.3f}] s, and the reference would be left out: "
            f"{_gt_said(meta, data_s):+.3f} s is used instead; set {key} to it if it is known, or to null (or remove "
            "the key) to let the data decide")
    count_doubted(meta, "gt", f"{key} off the IMU span: the offset the data give used instead", len(gt.t))
    return add_gt_clock_offset(gt, est, meta, text, facts.get("given_by", {}).get(key, "the configuration")), data_s


def _reference_checks_axes(mission: Mission, meta: dict, facts: dict) -> GroundTruth | None:
    """The log's or bag's reference that checks the IMU axes, or None: on the IMU clock, and long enough
    (:func:`graphnav.calibration.axes.gt_checks_axes`). One too short (1 Hz over 30 % of a 40 s log: 9 intervals)
    refused the whole log; the reference is optional, so the IMU alone checks the axes (and the DVL a turn about z),
    and the reference is kept for the scores, warned about and counted as doubted: it judged nothing. One whose given
    offset the clock search contradicts (``meta["gt_clock_doubted"]``, used as given) checks them where the data put
    it, as an A-KIT GT does: 16 s off, the gyro against its attitude misses an IMU y axis the wrong way. One given an
    offset beyond the fine search's reach (:func:`_beyond_the_fine_search`) checks them at it: the reference as read
    is offset by it until :func:`_reference_on_the_imu` adds it."""
    from graphnav.calibration.axes import MIN_AXIS_GT_INTERVALS, gt_checks_axes
    g, t_imu = mission.gt, mission.imu.t
    given = facts.get("given", {}).get("gt_time_offset_s")
    if g is not None and "gt_clock_doubted" in meta:
        g = dataclasses.replace(g, t=g.t + meta["gt_clock_doubted"])
    elif g is not None and given is not None and _beyond_the_fine_search(g, float(given), mission.imu):
        g = dataclasses.replace(g, t=g.t + float(given))
    if g is None or facts.get("imu_frame") is None or not on_the_imu_clock(g.t, t_imu):
        return None
    enough, n = gt_checks_axes(g.t, t_imu)
    if not enough:
        text = (f"the reference [{g.t[0]:.3f}, {g.t[-1]:.3f}] s shares {n} interval(s) of about 1 s with the IMU span "
                f"[{t_imu[0]:.3f}, {t_imu[-1]:.3f}] s: too few to check the IMU axes against it "
                f"({MIN_AXIS_GT_INTERVALS} needed); the IMU alone checks them, and the reference, judged against "
                "nothing, is kept for the scores")
        say_doubted(meta, "gt", g.source, text, "too short to check the IMU axes against", len(g.t), stacklevel=4)
    return g if enough else None


#: The most of the reference's turns the next best clock offset may explain for the search to move a reference: on a
#: motion that repeats (a synthetic turn of 10 s period, both offsets explaining 1.000) the sharpness, a ratio of
#: residuals, is large by rounding alone. The ten A-KIT GTs, moved 0-16 s: next best 0.04-0.89 (Trajectory5).
REFERENCE_CLOCK_SECOND_PEAK_MAX = 0.98


def _far_reference_clock(imu: ImuData, gt: GroundTruth):
    """The reference's clock offset (:func:`graphnav.calibration.clock.estimate_gt_clock_offset`, s to add to
    ``gt``'s stamps) when it is confident and beyond the fine search's reach (:data:`GT_OFFSET_SEARCH_S`), else None
    (too short or too little overlap to tell, no offset explains it, one the fine search finds, or a motion that
    repeats: another offset explains as much, :data:`REFERENCE_CLOCK_SECOND_PEAK_MAX`)."""
    from graphnav.calibration.clock import estimate_gt_clock_offset, gt_clock_confident
    try:
        est = estimate_gt_clock_offset(imu, gt)
    except DataError:
        return None
    clear = gt_clock_confident(est) and est.second_peak <= REFERENCE_CLOCK_SECOND_PEAK_MAX
    return est if clear and abs(est.offset_s) > GT_OFFSET_SEARCH_S else None


def _gyro_against_dvl(imu: ImuData, dvl: DvlData, config: SensorConfig, meta: dict) -> ImuData:
    """The IMU with its gyro's scale checked against the DVL when the loader's tilt kinematics could not judge it
    (:func:`graphnav.calibration.dvl_scale.check_gyro_against_dvl`); a DVL not on the IMU clock yet cannot tell: the
    IMU as read, the fact kept for when the DVL is there."""
    from graphnav.io.units import GYRO_UNJUDGED
    if GYRO_UNJUDGED not in meta or not on_the_imu_clock(dvl.t, imu.t):
        return imu
    from graphnav.calibration.dvl_scale import check_gyro_against_dvl
    return check_gyro_against_dvl(imu, dvl, config, meta)


#: Why the pings of a column map's DVL overlapping the IMU span are counted when the clock search (``clock: auto``, no
#: offset given) finds no clear offset: kept on their stamps as read, which may lie seconds off the IMU clock (a bag's
#: header stamps, which no key declares on the IMU clock, keep the note only, unless the best offset lies off them:
#: :attr:`graphnav.calibration.clock.ClockOffset.off_its_stamps`).
CLOCK_NOT_FOUND = "DVL stamps kept as read: the clock search found no clear offset"


def _say_clock_not_found(dvl: DvlData, meta: dict, form: str | None) -> None:
    """A DVL the clock search left on its stamps as read for want of a clear offset (``meta["clock_offsets"]["dvl"]``
    not confident): a column map's (``form`` 'csv'), or any whose best offset lies off its stamps, warned about naming
    that offset (:func:`graphnav.calibration.clock.best_off_its_stamps`) and its pings counted
    (:data:`CLOCK_NOT_FOUND`); its note says why."""
    est = meta.get("clock_offsets", {}).get("dvl")
    if est is None or est["confident"] or not (form == "csv" or est.get("off_its_stamps")):
        return
    found = _clock_not_found_said(est)
    if meta.get(OFF_ITS_STAMPS):
        # judged at the stamps as read, its units and turn would blame the instruments for the clock
        raise DataError(f"{found}, and its velocity, which turns with the vehicle, is body-fixed only at its own best "
                        "clock offset, not at its stamps as read: give dvl_time_offset_s (s added to the DVL stamps)",
                        dvl.source, field=meta.get("stream_fields", {}).get("dvl"))
    declare = ("declare csv_columns.dvl.clock 'imu' if it is on the IMU clock, else give dvl_time_offset_s"
               if form == "csv" else "give dvl_time_offset_s if it is known")
    warnings.warn(f"{dvl.source}: {found}: its stamps are kept as read, on the IMU clock, and a DVL seconds off it is "
                  f"judged and fused there: {declare}", RuntimeWarning, stacklevel=4)
    count_doubted(meta, "dvl", CLOCK_NOT_FOUND, len(dvl.t))


def _clock_not_found_said(est: dict) -> str:
    """A DVL clock search's estimate ``est`` (``meta["clock_offsets"]["dvl"]``) that found no clear offset, said (with
    its best offset where that lies off the stamps: :func:`graphnav.calibration.clock.best_off_its_stamps`)."""
    from graphnav.calibration.clock import best_off_its_stamps
    still = still_velocity_said(est["peak"], est["rms"])
    if still:
        return f"DVL clock offset not found ({still})"
    return (f"DVL clock offset not found (the IMU's accelerations explain the DVL's velocity changes at no clear "
            f"offset: best {est['peak']:.2f}, next {est['second_peak']:.2f}{best_off_its_stamps(est)})")


def _clock_searched(run, search, imu: ImuData, dvl: DvlData, config: SensorConfig, meta: dict,
                    declared: dict | None, fixes: dict, frame: dict):
    """``(run(imu), imu)``: the DVL clock search ``run`` with the gyro's scales tried (:func:`_with_the_gyro_tried`);
    a failure tried again in other units (:func:`_unit_finds_the_clock`), in FLU axes (:func:`_flu_finds_the_clock`)
    and with the velocity turned about z (:func:`_turn_finds_the_clock`, ``frame`` the IMU's axes judged), each a
    DataError where it finds the clock, else the failure raised; a clock found is tried in other units where pings
    were refused for their speed, in FLU axes where it is not clear or explains little, and a DVL on the IMU span the
    search found no clear offset for is tried turned where its turn check saw a turn
    (:func:`_turn_finds_the_clock_on_the_span`). ``declared``: the DVL velocity unit the IMU judges, ``fixes`` what
    the messages advise."""
    try:
        found = _with_the_gyro_tried(run, search, imu, dvl, config, meta)
    except DataError as err:
        _unit_finds_the_clock(err, search, imu, dvl, config, meta, declared, fixes)
        _flu_finds_the_clock(err, search, imu, dvl, config, meta, fixes)
        _turn_finds_the_clock(err, search, imu, dvl, config, meta, fixes, frame, declared)
        _y_finds_the_clock(err, search, imu, dvl, config, meta, fixes)
        raise
    _unit_finds_the_clock(None, search, found[1], dvl, config, meta, declared, fixes)
    _flu_finds_the_clock(None, search, found[1], dvl, config, meta, fixes)
    _turn_finds_the_clock_on_the_span(search, found[1], dvl, config, meta, fixes, frame, declared)
    _y_finds_the_clock(None, search, found[1], dvl, config, meta, fixes)
    return found


def _with_the_gyro_tried(run, search, imu: ImuData, dvl: DvlData, config: SensorConfig, meta: dict):
    """``(run(imu), imu)``: a DVL clock search ``run``; when it fails, run again with the IMU
    :func:`_gyro_finds_the_clock` returns (or its DataError). ``search(imu, meta) -> offset`` is the search's trial
    form, ``dvl`` the stream it moves."""
    try:
        return run(imu), imu
    except DataError as err:
        imu = _gyro_finds_the_clock(err, search, imu, dvl, config, meta)
    return run(imu), imu


def _gyro_finds_the_clock(err: DataError, search, imu: ImuData, dvl: DvlData, config: SensorConfig,
                          meta: dict) -> ImuData:
    """After the DVL clock search failed with ``err``: with the gyro's scale unjudged (``meta[GYRO_UNJUDGED]``), the
    search ``search(imu, meta) -> offset`` (s added to the ``dvl`` stamps) is tried with the rates x57.3 and /57.3,
    since a gyro at the wrong scale can hide the clock; where one finds it, the gyro is judged against the DVL put
    there (:func:`graphnav.calibration.dvl_scale.check_gyro_against_dvl`: rates 57.3x too small are a DataError naming
    the gyro). Returns the IMU converted from deg/s, whose clock the caller searches again; otherwise ``err``,
    saying the gyro's scales were tried."""
    from graphnav.calibration.dvl_scale import GYRO_SCALES, check_gyro_against_dvl
    from graphnav.io.units import GYRO_UNJUDGED
    if GYRO_UNJUDGED not in meta:
        raise err
    for k in GYRO_SCALES.values():
        offset = _trial(lambda meta_: search(dataclasses.replace(imu, omega_b=imu.omega_b * k), meta_), meta)
        if offset is None:
            continue
        found = (f", on the IMU clock at the offset {_dvl_said(meta, offset):+.3f} s the DVL clock search finds "
                 "with the rates "
                 f"x{k:.4g}, none with them as read")
        judged = check_gyro_against_dvl(imu, dataclasses.replace(dvl, t=dvl.t + offset), config, meta, found)
        if judged is not imu:
            return judged
        break
    raise DataError(f"{err.message} (nor with the gyro rates x57.3 or /57.3, whose scale the tilt kinematics could "
                    "not judge, at an offset where the DVL judges them)", err.source, err.line, err.field) from err


def _trial(run, meta: dict) -> float | None:
    """``run(meta)`` as a trial (:func:`_tried`): its value, None where it fails with a DataError; its notes and
    warnings are not the mission's."""
    return _tried(run, meta).value


@dataclasses.dataclass
class _Trial:
    """What ``run(meta)`` gave as a trial (:func:`_tried`): its ``value`` (None where it failed with a DataError), the
    copy of ``meta`` it wrote its notes and counts to, and the warnings it gave (caught)."""
    value: object
    meta: dict
    said: list

    def keep(self, meta: dict) -> None:
        """The trial's notes and counts made ``meta``'s and its warnings given, as if it had run on ``meta``: what a
        search taken after its trial gives, without searching again."""
        _made_alike(meta, self.meta)
        for caught in self.said:
            _warn_again(caught)


def _tried(run, meta: dict) -> _Trial:
    """``run(meta)`` as a trial: on a copy of ``meta``, its warnings caught, a DataError its value None."""
    tried = copy.deepcopy(meta)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        try:
            value = run(tried)
        except DataError:
            value = None
    return _Trial(value, tried, said)


def _made_alike(meta: dict, tried: dict) -> None:
    """``meta`` changed in place into ``tried`` (a copy of it a trial wrote to): its dicts and lists are kept, since
    others hold them (the prepare step's ``facts`` is ``meta["prepare"]``)."""
    for key in [key for key in meta if key not in tried]:
        del meta[key]
    for key, value in tried.items():
        here = meta.get(key)
        if isinstance(here, dict) and isinstance(value, dict):
            _made_alike(here, value)
        elif isinstance(here, list) and isinstance(value, list):
            here[:] = value
        else:
            meta[key] = value


def _warn_again(caught: warnings.WarningMessage) -> None:
    """A warning a trial caught, given again as from where it was first given: the file and line it names, and its
    module's name and registry, which the warnings filters and their once-per-place rule see."""
    module = next((m for m in list(sys.modules.values()) if getattr(m, "__file__", None) == caught.filename), None)
    scope = vars(module) if module is not None else None
    warnings.warn_explicit(caught.message, caught.category, caught.filename, caught.lineno,
                           module=None if scope is None else scope["__name__"],
                           registry=None if scope is None else scope.setdefault("__warningregistry__", {}))


def _unit_finds_the_clock(err: DataError | None, search, imu: ImuData, dvl: DvlData, config: SensorConfig,
                          meta: dict, declared: dict | None, fixes: dict) -> None:
    """After the DVL clock search ``search(imu, meta, dvl) -> offset`` (s added to the ``dvl`` stamps) failed with
    ``err``, or found a clock (``err`` None: ``meta["clock_offsets"]["dvl"]``), it is tried with the velocity in each
    other plausible unit (:func:`~graphnav.calibration.dvl_scale.other_velocity_units`) than the one ``declared``
    (a loader's taken unit has ``"taken": True``; None: m/s, fixed by the format, ``fixes["unit"]`` says what to do):
    a declared unit 100x too small leaves the velocity's changes within its noise, which hides the clock; knots read as
    m/s put the vehicle beyond its envelope, and the hole its refused pings leave let the search settle on a weak peak
    252 s off. Tried where the search failed on a declared unit, or where pings were refused for their speed
    (:func:`_speed_refused`; after a clock was found, only where they are :data:`HOLE_MIN_REFUSED_SHARE` of the
    pings or more). Where another unit finds the clock (more clearly than the one found), the unit is
    judged there (:func:`~graphnav.calibration.dvl_scale.check_declared_velocity_unit`, a DataError naming the key),
    else a DataError adds that unit's clock to ``err`` (or the clock found). A clock found that no unit beats is then
    judged for the hole (:func:`_refuse_a_clock_by_a_hole`). Returns when nothing is wrong (``err`` stands)."""
    from graphnav.calibration.dvl_scale import check_declared_velocity_unit, other_velocity_units
    refused = _speed_refused(meta)
    found = meta.get("clock_offsets", {}).get("dvl")
    if err is None:
        # scattered spikes leave no hole a clock could settle on (three searches for nothing); a DVL too short for
        # the clock model was kept on its stamps with a note, no clock found to doubt
        if refused < HOLE_MIN_REFUSED_SHARE * len(dvl.t) or found is None:
            return
    elif not refused and (not declared or declared.get("taken")):
        return
    else:
        found = None
    unit = declared["unit"] if declared else "m/s"
    v = dvl_velocity_b(dvl, config)[1]
    for other, k in other_velocity_units(unit, float(np.median(np.linalg.norm(v, axis=1))), config).items():
        est = _velocity_trial(search, imu, dvl, config, meta, k * np.eye(3))[0]
        if est is None or found is not None and not est["peak"] > found["peak"]:
            continue
        if declared:
            shifted = dataclasses.replace(dvl, t=dvl.t + est["offset_s"])
            check_declared_velocity_unit(imu, shifted, config, meta, declared)
        said = "the declared " if declared and not declared.get("taken") else ""
        raise DataError(f"{_clock_said(err, found, meta)}; with the velocity in {other!r} instead of {said}{unit!r} "
                        f"the search finds the DVL clock at {_dvl_said(meta, est['offset_s']):+.3f} s (the IMU "
                        f"explains {est['peak']:.2f} of its velocity changes there){_speed_said(meta, refused)}: "
                        f"{_unit_advice(declared, fixes, other)}", *_where(err, dvl, meta, fixes)) from err
    if found is not None:
        _refuse_a_clock_by_a_hole(None, found["offset_s"], imu, dvl, meta, declared, fixes)


def _velocity_trial(search, imu: ImuData, dvl: DvlData, config: SensorConfig, meta: dict,
                    transform: np.ndarray) -> tuple[dict | None, DvlData]:
    """The DVL clock ``search(imu, meta, dvl)`` as a trial of the body-frame velocity of ``dvl`` multiplied by the (3,3)
    ``transform`` (in another unit, its y negated, in FLU axes, turned about z): ``(estimate, the velocity searched)``,
    the estimate :func:`_estimate_tried`'s. Every trial is this one path, and its search builds its clock model on the
    IMU's side the prepare step built once (:class:`graphnav.calibration.clock.ImuSide`): only the DVL's side
    differs between the trials."""
    t, v = dvl_velocity_b(dvl, config)
    tried = DvlData(t, *no_beams(len(t)), v @ np.asarray(transform, float).T, source=dvl.source)
    return _estimate_tried(_tried(lambda meta_: search(imu, meta_, tried), meta)), tried


def _estimate_tried(trial: _Trial) -> dict | None:
    """The estimate of a DVL clock search run as a ``trial`` (its ``clock_offsets["dvl"]``), None where it found none
    (a DataError, or too few pings to estimate it)."""
    return None if trial.value is None else trial.meta.get("clock_offsets", {}).get("dvl")


def _speed_refused(meta: dict) -> int:
    """DVL pings the loader refused for their speed (beyond the vehicle's envelope or a beam beyond its speed)."""
    refused = meta.get("streams", {}).get("dvl", {}).get("refused", {})
    return sum(n for reason, n in refused.items() if "speed" in reason or "beam beyond" in reason)


def _speed_said(meta: dict, refused: int) -> str:
    """How many pings were refused for their speed, for a message; '' for none."""
    read = meta.get("streams", {}).get("dvl", {}).get("read")
    return f"; as read, {refused}{f' of {read}' if read else ''} pings were refused for their speed" if refused else ""


def _unit_advice(declared: dict | None, fixes: dict, unit: str | None = None) -> str:
    """What to do about a DVL velocity unit the data contradict (``unit``: the one that fits, when known)."""
    if not declared:
        return fixes["unit"] or "check the DVL velocity's unit"
    if declared.get("taken"):
        return unit_fix(declared, unit) if unit else f"declare {declared['key']}"
    return f"check {declared['key']} (declared {declared['unit']!r})"


def _clock_said(err: DataError | None, found: dict | None, meta: dict) -> str:
    """The failed search's message, or the clock it found (its offset on the DVL stamps as written:
    :func:`_dvl_said`)."""
    return err.message if err is not None else (f"the DVL clock search finds the offset "
                                                f"{_dvl_said(meta, found['offset_s']):+.3f} s (the IMU explains "
                                                f"{found['peak']:.2f} of its velocity changes there)")


def _gt_said(meta: dict, offset_s: float) -> float:
    """A GT clock or time offset (s) on the GT stamps the prepare step moves, as a message or the configuration gives
    it: on the stamps as written, which ``gt_time_offset_s`` is given for (an A-KIT GT rescaled about its own first
    stamp, :func:`graphnav.core.streams.offset_on_written_stamps`); the same offset for any other."""
    return offset_on_written_stamps(meta, "gt", offset_s)


def _dvl_said(meta: dict, offset_s: float) -> float:
    """A DVL clock or time offset (s) on the DVL stamps the prepare step moves, as a message or the configuration
    gives it: on the stamps as written, which ``dvl_time_offset_s`` is given for (an A-KIT file on a clock of its own
    is rescaled about its own first stamp: 0.0025 of its distance from the folder's origin apart,
    :func:`graphnav.core.streams.offset_on_written_stamps`); the same offset for any other."""
    return offset_on_written_stamps(meta, "dvl", float(offset_s))


def _where(err: DataError | None, dvl: DvlData, meta: dict, fixes: dict) -> tuple:
    """``(source, line, field)`` of a DataError about the DVL clock: ``err``'s, else the DVL's velocity fields (an
    A-KIT file's columns: ``fixes`` that cannot declare)."""
    from graphnav.io.loaders import AKIT_COLUMNS
    field = meta.get("stream_fields", {}).get("dvl") or (
        "velocity" if fixes["declare"] else "/".join(AKIT_COLUMNS["DVL"][1:4]))
    return (err.source, err.line, err.field) if err is not None else (dvl.source, None, field)


#: A clock found with this share or more of the pings it puts on the IMU span left without a velocity (refused for
#: their speed) rests on a hole, not on the vehicle's motion: knots read as m/s, 229 of 600 pings refused, put 228 of
#: the 348 pings on the IMU span at 252 s off into the hole (0.66). A clean clock leaves none there.
HOLE_SHARE = 0.5
#: Share of the pings refused for their speed under which a clock found is not searched again in other units: a few
#: spikes (1 % of a 5400 s log's pings) cannot leave a hole, and the three searches tripled the load (9.5 -> 27.7 s);
#: knots read as m/s refuse 38 % of a 600 s log's.
HOLE_MIN_REFUSED_SHARE = 0.1


def _refuse_a_clock_by_a_hole(err: DataError | None, offset: float, imu: ImuData, dvl: DvlData, meta: dict,
                              declared: dict | None, fixes: dict, what: str = "") -> None:
    """A DataError when pings were refused for their speed and the DVL clock ``offset`` (s; found as read, or by a
    turn, ``what``) puts :data:`HOLE_SHARE` or more of the pings on the IMU span among those without a velocity: the
    unit is the likelier fault, which no turn or clock fixes. ``err``: the failed search's, added to."""
    refused = _speed_refused(meta)
    t, t_with = dvl.t + offset, dvl_velocity_b(dvl, None)[0] + offset
    on = (t >= imu.t[0]) & (t <= imu.t[-1])
    hole = int(on.sum()) - int(((t_with >= imu.t[0]) & (t_with <= imu.t[-1])).sum())
    if not refused or not hole >= HOLE_SHARE * max(int(on.sum()), 1):
        return
    raise DataError(f"{_clock_said(err, None if err is not None else meta['clock_offsets']['dvl'], meta)}"
                    f"{_speed_said(meta, refused)}, and {what or 'the search settles on'} "
                    f"{_dvl_said(meta, offset):+.3f} s, where "
                    f"{hole} of the {int(on.sum())} pings on the IMU span are among those without a velocity: a clock "
                    "beside the hole they leave, not the vehicle's motion; the velocity's unit is the likelier fault: "
                    f"{_unit_advice(declared, fixes)}", *_where(err, dvl, meta, fixes)) from err


def _turn_finds_the_clock(err: DataError, search, imu: ImuData, dvl: DvlData, config: SensorConfig, meta: dict,
                          fixes: dict, frame: dict, declared: dict | None = None, tries: int = 3) -> None:
    """After the DVL clock search ``search(imu, meta, dvl) -> offset`` (s added to the ``dvl`` stamps) failed with
    ``err``: a DVL or an IMU mounted turned about z, in a frame the configuration does not say, leaves the DVL's
    velocity changes unexplained at every offset, and the search blamed the clock. It is tried with the DVL velocity
    turned 90, 180 and 270 deg about z into the IMU's axes (the turn its mean direction suggests first,
    :func:`~graphnav.calibration.dvl_scale.yaws_to_try`); the first that finds a clear clock is a DataError adding
    to ``err`` the turn, the offset it gives and what to configure
    (:func:`~graphnav.calibration.dvl_scale.turn_found`: ``fixes`` for the DVL, ``frame`` for the IMU). The data are
    never read turned. A turn whose clock rests on the hole pings refused for their speed leave is not announced: the
    unit (``declared``, as :func:`_unit_finds_the_clock` takes it) is named instead (:func:`_refuse_a_clock_by_a_hole`).
    Returns when no turn finds the clock (``err`` stands), or (a DVL on the IMU span) when a turn finds it within half
    a ping period of the stamps: they are on the IMU clock, and the DVL's turn check has judged the turn there.
    ``tries``: how many of the turns, in that order, are searched."""
    from graphnav.calibration.dvl_scale import signed_turn, turn_about_z, turn_found, yaws_to_try
    t = dvl_velocity_b(dvl, config)[0]
    for yaw in yaws_to_try(dvl, config)[:tries]:
        est, turned = _velocity_trial(search, imu, dvl, config, meta, turn_about_z(yaw).T)
        # on the IMU span the search keeps the stamps, with its estimate, where it finds no clear offset
        if est is None or not est["confident"]:
            continue
        offset = est["offset_s"]
        if abs(offset) < 0.5 * float(np.median(np.diff(t))):
            return
        _refuse_a_clock_by_a_hole(err, offset, imu, dvl, meta, declared, fixes,
                                  f"a turn of {signed_turn(yaw):+d} deg about z finds the clock only at")
        raise DataError(f"{err.message}; but read as turned {_quarter_turn_said(imu, turned, offset, config, yaw)} "
                        f"from the IMU's axes (the velocity turned back into them), the DVL finds its clock at "
                        f"{_dvl_said(meta, offset):+.3f} s (the IMU explains {est['peak']:.2f} of its velocity "
                        "changes there, "
                        f"{est['second_peak']:.2f} at the next best offset): not the clock but a mounting turned about "
                        f"z. {turn_found(dvl, config, yaw, frame, fixes)}. The data are not read turned: with the "
                        "mounting fixed, the clock search finds the offset itself", err.source, err.line,
                        err.field) from err


def _turn_finds_the_clock_on_the_span(search, imu: ImuData, dvl: DvlData, config: SensorConfig, meta: dict,
                                      fixes: dict, frame: dict, declared: dict | None) -> None:
    """A DVL on the IMU span for which the clock search ``search(imu, meta, dvl) -> offset`` found no clear offset
    (``meta["clock_offsets"]["dvl"]`` not confident) and whose turn check, at the stamps as read before the search
    (:func:`_judge_dvl_against_imu`), saw its velocity turned about z or pointing sideways or backward
    (:data:`~graphnav.calibration.dvl_scale.TURNED_DOUBT`, :data:`~graphnav.calibration.dvl_scale.SIDEWAYS_DOUBT`
    counted): searched again with the velocity turned about z (:func:`_turn_finds_the_clock`), a DataError where a
    turn finds the clock off the stamps, as off the span. A DVL turned 90, 180 or 270 deg and 400-1800 s late on a
    5400 s simulated log (30-250 s on a 600 s one) was loaded that far off, its turn warned about at the wrong clock.
    A clean log with the default beam noise finds no clear offset either, but its velocity points forward and fits
    the IMU's axes: it is not searched turned. Only the turn the DVL's mean direction suggests is searched: with the
    default beam noise no turn finds a clear clock, and the three searches made a turned, crabbing or reversing
    600 s log load in 7-9 s of CPU instead of 2.7 (5400 s: 42 s instead of 17)."""
    from graphnav.calibration.dvl_scale import SIDEWAYS_DOUBT, TURNED_DOUBT
    est = meta.get("clock_offsets", {}).get("dvl")
    doubted = meta.get("streams", {}).get("dvl", {}).get("doubted", {})
    if est is None or est["confident"] or not (TURNED_DOUBT in doubted or SIDEWAYS_DOUBT in doubted):
        return
    err = DataError(f"{_clock_not_found_said(est)} with the stamps on the IMU span", *_where(None, dvl, meta, fixes))
    _turn_finds_the_clock(err, search, imu, dvl, config, meta, fixes, frame, declared, tries=1)


def _y_finds_the_clock(err: DataError | None, search, imu: ImuData, dvl: DvlData, config: SensorConfig, meta: dict,
                       fixes: dict, keeps_s: float | None = None) -> None:
    """After the DVL clock search ``search(imu, meta, dvl) -> offset`` (s added to the ``dvl`` stamps) failed with
    ``err``, or found a clock or none clear (``err`` None: ``meta["clock_offsets"]["dvl"]``), it is tried with the DVL
    velocity's y negated (:data:`~graphnav.calibration.dvl_scale.DVL_Y_NEGATED`); a DataError naming the y (and the
    mirrored IMU) where the y negated explains the velocity's changes better than as read
    (:func:`_y_explains_better`: nearer the stamps, or clearly) and, at the offset it fits best, fits the IMU better
    than as read by the y fit's own bars (:attr:`~graphnav.calibration.dvl_scale.DvlYFit.refused`, explaining
    :data:`~graphnav.calibration.dvl_scale.DVL_Y_MIN_EXPLAINED` of the changes, unless only the y negated finds a
    clock, at the stamps). A y negated, or an IMU mirrored,
    leaves the velocity's changes unexplained at the right offset, and the search wanders: a level vehicle turning in a
    current, its DVL y negated on the IMU clock, was placed +102 s off, refused as a DVL on a clock of its own, or
    loaded with the clock not found (``clock: auto``); A-KIT pieces were loaded 6-92 s off. Not searched again where
    the clock found keeps the stamps (under ``keeps_s``, default half a ping period) and the y fits at them as the y
    check wants it (judged there), nor for a velocity kept in the frame declared for want of a body frame."""
    from graphnav.calibration.clock import PEAK_EXCLUSION_S
    from graphnav.calibration.dvl_scale import DVL_Y_MIN_EXPLAINED, DVL_Y_NEGATED
    from graphnav.io.dvl_frame import KEPT_AS_DECLARED
    found = None if err is not None else meta.get("clock_offsets", {}).get("dvl")
    if meta.get(KEPT_AS_DECLARED) or (err is None and found is None):  # too few pings: no clock searched
        return
    t = dvl_velocity_b(dvl, config)[0]
    keeps_s = 0.5 * float(np.median(np.diff(t))) if keeps_s is None else keeps_s
    if found is not None and found["confident"] and abs(found["offset_s"]) <= keeps_s:
        at_stamps = _y_fit_at(imu, dvl, config, 0.0)
        if at_stamps is None or not at_stamps.refused:
            return
    negated = _velocity_trial(search, imu, dvl, config, meta, DVL_Y_NEGATED)[0]
    if negated is None or not _y_explains_better(negated, found, on_the_imu_clock(dvl.t, imu.t)):
        return
    fit = _y_fit_at(imu, dvl, config, negated["offset_s"])
    # where only the y negated finds a clock, at the stamps, the search's own bar of explaining stands for the fit's
    # share explained: on 60 s A-KIT pieces its few windows explain 0.02-0.10 where the search explains 0.20-0.49 within
    # 1.1 s of them. Not far off them: an A-KIT folder's velocity in knots read as m/s "found" +87 s at 0.08 explained
    only_negated = (negated["confident"] and abs(negated["offset_s"]) <= PEAK_EXCLUSION_S
                    and not (found is not None and found["confident"]))
    if fit is None or not (fit.refused and (fit.explained >= DVL_Y_MIN_EXPLAINED or only_negated)):
        return
    read = (_clock_said(err, found, meta) if err is not None or found["confident"] else
            _clock_not_found_said(found) + (" with the stamps on the IMU span" if on_the_imu_clock(dvl.t, imu.t)
                                            else ""))
    finds = "finds its clock" if negated["confident"] else "fits the IMU best"
    raise DataError(f"{read}; but with its y negated the DVL {finds} at {_dvl_said(meta, negated['offset_s']):+.3f} s "
                    f"(the IMU explains "
                    f"{negated['peak']:.2f} of its velocity changes there, {negated['second_peak']:.2f} at the next "
                    f"best offset): not the clock but {fit.said(fixes)}", *_where(err, dvl, meta, fixes)) from err


def _y_fit_at(imu: ImuData, dvl: DvlData, config: SensorConfig, offset_s: float):
    """The DVL y fit (:func:`~graphnav.calibration.dvl_scale.dvl_y_negated_fit`) with ``offset_s`` added to the DVL
    stamps; None where the clock model cannot be built there."""
    from graphnav.calibration.dvl_scale import dvl_y_negated_fit, judging_model
    shifted = dataclasses.replace(dvl, t=dvl.t + offset_s)
    try:
        return dvl_y_negated_fit(judging_model(imu, shifted, config), imu, shifted, config)
    except DataError:
        return None


def _y_explains_better(negated: dict, found: dict | None, inside: bool) -> bool:
    """Whether the clock search's estimate with the DVL's y negated (``negated``) explains its velocity's changes better
    than as read (``found``; None: the search found no offset at all): more, and at an offset nearer the stamps of a
    DVL on the IMU span (``inside``) by :data:`~graphnav.calibration.clock.PEAK_EXCLUSION_S` and by half (a DVL on the
    IMU span seconds off its clock is likelier than minutes), or else by
    :data:`~graphnav.calibration.clock.OFF_STAMPS_MIN_GAP` more at a clear peak. A noisy clean DVL 10 s late, found
    there as read explaining 0.10, fitted best with its y negated 84.9 s off explaining 0.15 (a manoeuvre repeated):
    under the clear peak, and further from the stamps."""
    from graphnav.calibration.clock import OFF_STAMPS_MIN_GAP
    if found is None:
        return True
    if not negated["peak"] > found["peak"]:
        return False
    nearer = _trial_nearer_the_stamps(negated, found, inside)
    return nearer or (_clock_clear(negated) and negated["peak"] - found["peak"] >= OFF_STAMPS_MIN_GAP)


#: A DVL clock found explaining under this share of the velocity's changes is searched again with the velocity's y and
#: z negated (:func:`_flu_finds_the_clock`): FLU copies of A-KIT pieces 5-60 s late had clear clocks found 3-92 s off
#: the right one, explaining 0.20-0.56 there (0.77-0.99 negated, at the right one). Clean clocks explain 0.49-1.00 on
#: the ten A-KIT trajectories' 60 and 200 s pieces, 0.44-0.88 on simulated missions with 5-10 mm/s beams: a search
#: more where under, and no finding (as read they fit best).
FLU_TRIAL_MAX_PEAK = 0.6
#: Where the velocity with its y and z negated finds a clear clock explaining at least
#: :data:`~graphnav.calibration.dvl_scale.MIN_FLU_EXPLAINED`, it is refused as FLU when the search's best as read leaves
#: this many times as much of the velocity's changes unexplained as that clock, each at its own best offset (the two
#: searches). Measured with the trial run on every log: FLU copies of the ten A-KIT trajectories' 60 and 200 s pieces
#: (on time and 5-60 s late) 2.9-272, of simulated 200 s missions (5 and 10 mm/s beams) 1.76-4.9; their clean copies,
#: the same searches the other way round, at most 0.35 (A-KIT) and 0.83 (simulated; 1.02 with the default 42 mm/s
#: beams, whose trials find no clear clock). A clean log's trial may find a clear clock explaining 0.5 (a 60 s piece of
#: Trajectory11: 0.56), never one explaining more than as read (0.91 there). Read near the trial's clock only (each
#: reading at its best within +-20 s) the ratio does not separate them: a clean 60 s piece of Trajectory1 scored 3.3.
FLU_TRIAL_RATIO = 1.5

def _flu_finds_the_clock(err: DataError | None, search, imu: ImuData, dvl: DvlData, config: SensorConfig, meta: dict,
                         fixes: dict) -> None:
    """After the DVL clock search ``search(imu, meta, dvl) -> offset`` (s added to the ``dvl`` stamps) failed with
    ``err``, or (``err`` None) left ``meta["clock_offsets"]["dvl"]`` without a clear offset (not confident, or taken
    under the clear peak) or with one explaining under :data:`FLU_TRIAL_MAX_PEAK` of the velocity's changes: FLU axes
    (ROS base_link) read as FRD leave the velocity's changes unexplained at the right offset, and the search gives up
    or settles elsewhere.
    It is tried with the velocity's y and z negated (:data:`~graphnav.calibration.dvl_scale.DVL_FLU`); where that finds
    a clear clock explaining at least ``MIN_FLU_EXPLAINED`` and leaving :data:`FLU_TRIAL_RATIO` times less of the
    velocity's changes unexplained than the search's best as read (each reading at its own best offset), or
    explaining more than that best at an offset nearer the stamps (:func:`_trial_nearer_the_stamps`), a DataError
    names the FLU axes, the offset and ``fixes["flu"]`` (and the y alone negated, ``fixes["y"]``, where that fits
    about as well there: a level vehicle's vertical velocity barely changes; where it fits clearly better, the y's own
    checks are left to say it). True FLU copies of A-KIT pieces 5-60 s late were
    loaded at their stamps with the clock not found, or at a clock 3-92 s off (their y and z negated, unjudged); a
    simulated FLU mission 5-60 s late was put +217..+272 s off. The data are never read negated."""
    from graphnav.calibration.dvl_scale import (DVL_FLU, DVL_Y_MIN_RATIO, MIN_FLU_EXPLAINED, judging_model,
                                                y_negated_over_flu)
    read = meta.get("clock_offsets", {}).get("dvl")
    if read is None or err is None and _clock_clear(read) and read["peak"] >= FLU_TRIAL_MAX_PEAK:
        return
    flu = _velocity_trial(search, imu, dvl, config, meta, DVL_FLU)[0]
    if flu is None or not _clock_clear(flu):
        return
    ratio = (1.0 - read["peak"]) / max(1.0 - flu["peak"], 1e-9)
    nearer = _trial_nearer_the_stamps(flu, read, on_the_imu_clock(dvl.t, imu.t))
    if not (flu["peak"] >= MIN_FLU_EXPLAINED and ratio >= FLU_TRIAL_RATIO or nearer):
        return
    try:
        there = dataclasses.replace(dvl, t=dvl.t + flu["offset_s"])
        y_ratio = y_negated_over_flu(judging_model(imu, there, config), imu, there, config)
    except DataError:
        return
    if y_ratio < 1.0 / DVL_Y_MIN_RATIO:
        return
    said = (err.message if err is not None else _clock_said(None, read, meta) if read["confident"]
            else f"{_clock_not_found_said(read)} with the stamps on the IMU span")
    as_read = (f"explains {read['peak']:.2f}, further from the stamps" if nearer and ratio < FLU_TRIAL_RATIO else
               f"leaves {ratio:.3g}x as much of them unexplained, {FLU_TRIAL_RATIO:g}x needed")
    or_y = ("" if y_ratio >= DVL_Y_MIN_RATIO else f" (or its y alone negated, which fits about as well there, "
            f"{y_ratio:.2f}x as much left unexplained: if so, {fixes['y']})")
    raise DataError(f"{said}; but with its y and z negated the DVL finds its clock at "
                    f"{_dvl_said(meta, flu['offset_s']):+.3f} s (the IMU explains {flu['peak']:.2f} of its velocity "
                    f"changes there, {flu['second_peak']:.2f} at the next best offset; as read its best, "
                    f"{_dvl_said(meta, read['offset_s']):+.3f} s, {as_read}): not the clock but FLU "
                    f"axes (ROS base_link) read as FRD? {fixes['flu']}{or_y}. The data are not read negated: with the "
                    "axes declared, the clock search finds the offset itself", *_where(err, dvl, meta, fixes)) from err


def _trial_nearer_the_stamps(trial: dict, read: dict, inside: bool) -> bool:
    """Whether a clock search's clear estimate with the DVL velocity's axes negated as a trial (``trial``) explains more
    of its changes than the search's best as read (``read``) at an offset nearer the stamps of a DVL on the IMU span
    (``inside``), by :data:`~graphnav.calibration.clock.PEAK_EXCLUSION_S` and by half at least (seconds off are
    likelier than minutes). By half: a swing repeated every few seconds fits minutes off either way (a clean DVL 8 s
    early on a leg surging every 8 s: 0.975 as read +144 s off, 0.978 with its y negated +136 s off). Asked of the y
    negated (:func:`_y_explains_better`) and of FLU axes (:func:`_flu_finds_the_clock`): a vehicle whose clean clock
    explains little (slow, in a current: 0.35-0.39) explains as little in FLU axes declared, under
    :data:`~graphnav.calibration.dvl_scale.MIN_FLU_EXPLAINED`: its FLU columns 0-8 s late were put +94..+144 s off
    (loaded, or refused as on a clock of its own)."""
    from graphnav.calibration.clock import PEAK_EXCLUSION_S
    off_trial, off_read = abs(trial["offset_s"]), abs(read["offset_s"])
    return (inside and trial["peak"] > read["peak"] and off_trial + PEAK_EXCLUSION_S < off_read
            and off_trial <= 0.5 * off_read)


def _clock_clear(est: dict) -> bool:
    """A DVL clock search's estimate ``est`` (``meta["clock_offsets"]["dvl"]``) has a clear peak
    (:attr:`graphnav.calibration.clock.ClockOffset.clear`)."""
    from graphnav.calibration.clock import clear_peak
    return clear_peak(est["peak"], est["sharpness"], "repeated_at_s" in est, est.get("lead_sigmas", float("nan")),
                      est["second_peak"])


#: A turn left over after the quarter turn a clock was found with, deg, from which the turn is said to be "about" it.
TURN_REMAINDER_SAID_DEG = 1.0


def _quarter_turn_said(imu: ImuData, turned: DvlData, offset: float, config: SensorConfig, yaw: int) -> str:
    """The quarter turn ``yaw`` (deg) a DVL clock was found with (at ``offset`` s, ``turned`` the velocity turned back
    by it), as a message says it: "+90 deg", or "about +90 deg (... and X deg more ...)" where the DVL's own fit
    there finds a remainder (a DVL mounted 100 deg off), which the DVL's turn check warns about once the quarter turn
    is configured."""
    from graphnav.calibration.dvl_scale import signed_turn, speed_scale
    from graphnav.core.dvl_kinematics import dvl_window_model
    said = f"{signed_turn(yaw):+d} deg about z"
    try:
        rest = float(np.degrees(speed_scale(dvl_window_model(imu, dataclasses.replace(turned, t=turned.t + offset),
                                                             config)[0])[2]))
    except DataError:
        return said
    if not abs(rest) >= TURN_REMAINDER_SAID_DEG:
        return said
    return (f"about {said} (the quarter turn and {rest:+.1f} deg more, which the DVL's turn check warns about once the "
            "quarter turn is configured)")


#: A DVL time offset given for a log or bag is doubted when the DVL clock fit (the DVL's velocity changes against the
#: IMU's accelerations) puts it further off than this (s) and 3 of the fit's sigmas. The fit is not the fine offset
#: against a reference: on the ten A-KIT trajectories, their DVL on the IMU clock at the offset prepare found against
#: the GT, it adds -0.024..+0.076 s (200 s) and -0.016..+0.067 s (400 s) with sigmas of 0.004-0.019 s, up to 12 of
#: them; 2.6x the largest, and under half the 1 s ping period the clock search moves a DVL by.
GIVEN_DVL_CLOCK_FLOOR_S = 0.2
#: Where a DVL declared on the IMU clock (``clock: imu``) has its given offset judged, or an A-KIT DVL without GT its
#: vehicle's offset, the DVL clock fit searches this far either side of it, s: a configuration from another vehicle is a
#: second or two off, and the clock search's +-300 s would cost ~10 s of CPU on an hour's log.
GIVEN_DVL_CLOCK_SEARCH_S = 20.0


def _judge_given_dvl_clock(mission: Mission, shifted: DvlData, dvl: DvlData, meta: dict, facts: dict,
                           given: float) -> None:
    """The configuration's ``dvl_time_offset_s`` of a log or bag (s, added to the DVL stamps: ``shifted``) judged
    against the DVL clock fit (:func:`graphnav.calibration.clock.estimate_dvl_clock_offset`, the clock search's when
    it ran, else the same search within +-:data:`GIVEN_DVL_CLOCK_SEARCH_S`): a warning
    (:func:`_judge_given_offset`, :data:`GIVEN_DVL_CLOCK_FLOOR_S`) when they disagree. A DVL the clock search moved
    on (``dvl``'s stamps not ``shifted``'s) is not: the data decided, and a note names the file and key (the search's
    warning does not). A fit without a confident offset cannot judge it: noted."""
    if dvl is not shifted and len(dvl.t) and dvl.t[0] != shifted.t[0]:
        moved = float(dvl.t[0] - shifted.t[0])
        add_note(meta, "dvl", f"{facts.get('given_by', {}).get('dvl_time_offset_s', 'the configuration')}: "
                 f"dvl_time_offset_s = {given:+.3f} s is given; the clock search added {moved:+.3f} s to it "
                 f"({given + moved:+.3f} s used)")
        return
    est = meta.get("clock_offsets", {}).get("dvl")
    if est is None:
        try:
            est = _dvl_clock_fit_near(mission.imu, shifted, mission.config).to_dict()
        except DataError as err:
            add_note(meta, "dvl", f"the configuration's dvl_time_offset_s is not judged ({err})")
            return
    if not est["confident"]:
        why = still_velocity_said(est["peak"], est["rms"]) or (f"the DVL clock fit finds no clear offset (the IMU "
                                                               f"explains {est['peak']:.2f} of the DVL's velocity "
                                                               "changes at best)")
        add_note(meta, "dvl", f"the configuration's dvl_time_offset_s is not judged: {why}")
        return
    _judge_given_offset(meta, facts, "dvl", given, given + est["offset_s"], est["sigma_s"], mission,
                        ", the DVL's velocity changes against the IMU's accelerations", GIVEN_DVL_CLOCK_FLOOR_S)


def _dvl_clock_fit_near(imu: ImuData, dvl: DvlData, config: SensorConfig):
    """The DVL clock fit (:func:`graphnav.calibration.clock.estimate_dvl_clock_offset`: the DVL's velocity changes
    against the IMU's accelerations) within +-:data:`GIVEN_DVL_CLOCK_SEARCH_S` of the stamps of ``dvl``: its
    ``offset_s`` is what the data add to them, s. DataError where the pings are too few."""
    from graphnav.calibration.clock import estimate_dvl_clock_offset
    return estimate_dvl_clock_offset(imu, dvl, config, search_s=(-GIVEN_DVL_CLOCK_SEARCH_S, GIVEN_DVL_CLOCK_SEARCH_S))


def _given_dvl_offset(dvl: DvlData, depth: DepthData | None, offset_s: float, meta: dict):
    """``(dvl, depth)`` with the configuration's ``dvl_time_offset_s`` (s) added to the DVL stamps, and to a depth
    stream of the same instrument (a DVL's pressure sensor), instead of the clock search; noted."""
    from graphnav.calibration.clock import shift_dvl
    add_note(meta, "dvl", f"time offset {offset_s:+.3f} s added (given by the configuration's dvl_time_offset_s)")
    return shift_dvl(dvl, depth, offset_s, meta)


#: A log's or bag's reference is put later or earlier by its estimated time offset only when the offset exceeds
#: this many of its sigmas and :data:`GT_OFFSET_MIN_S`: an exact reference (simulated) estimates 1e-6..1e-5 s with
#: sigmas of the same size and stays as read; the 200 s of A-KIT Trajectory1 as a column-map log: -0.410 s, sigma
#: 0.0008 s.
GT_OFFSET_SIGMAS = 3.0
#: Smallest reference time offset applied, s: a tenth of the 100 Hz IMU period, far below what a turn's heading error
#: shows (0.1 rad/s x 1 ms = 0.1 mrad).
GT_OFFSET_MIN_S = 1e-3
#: How far (s, either way) the fine reference time-offset search reaches
#: (:func:`graphnav.calibration.reference.estimate_gt_time_offset`); a clock offset beyond it is found first
#: (:func:`_reference_clock`).
GT_OFFSET_SEARCH_S = 2.0


def _reference_on_the_imu(mission: Mission, meta: dict, facts: dict) -> Mission:
    """A log's or bag's reference on the IMU clock and at the IMU point, as the A-KIT path puts its GT.

    Time: the configuration's ``gt_time_offset_s`` when it sets one (``facts["given"]``), else the offset matching the
    reference's attitude increments with the gyro's (:func:`graphnav.calibration.reference.estimate_gt_time_offset`),
    added only when it exceeds :data:`GT_OFFSET_SIGMAS` sigmas and :data:`GT_OFFSET_MIN_S`, with a warning and a note.
    Point: moved by ``-config.reference_position_b`` (m, body frame) to the IMU point
    (:func:`graphnav.calibration.reference.move_ground_truth`), with a note; ``meta["gt_point_b"]`` records the IMU
    point relative to the reference as recorded. A reference off the IMU clock is left to the clock checks."""
    g, cfg = mission.gt, mission.config
    offset = facts.get("given", {}).get("gt_time_offset_s")
    # a given offset first: it may be what puts a reference logged on another clock onto the IMU's
    if g is None or not len(g.t) or (offset is None and not on_the_imu_clock(g.t, mission.imu.t)):
        return mission
    from graphnav.calibration.reference import estimate_gt_time_offset, move_ground_truth
    lat = cfg.lat_rad if cfg.earth_rotation else None
    how = "given by the configuration's gt_time_offset_s"
    if offset is None:
        try:
            est = estimate_gt_time_offset(mission.imu.t, mission.imu.omega_b, g.t, g.C_b_n, lat, source=g.source,
                                          search_s=(-GT_OFFSET_SEARCH_S, GT_OFFSET_SEARCH_S))
        except DataError as err:         # too short a reference: it stays as read, and says so
            add_note(meta, "gt", f"time offset not estimated ({err}); the stamps are used as read")
            est = None
        if est is not None:
            meta["time_offsets"] = {"gt": {"offset_s": est.offset_s, "sigma_s": est.sigma_s, "rms": est.rms}}
        applied = est is not None and abs(est.offset_s) > max(GT_OFFSET_SIGMAS * est.sigma_s, GT_OFFSET_MIN_S)
        offset = est.offset_s if applied else 0.0
        how = f"estimated from its attitude against the gyro, sigma {est.sigma_s:.4f} s" if applied else how
    elif on_the_imu_clock(g.t + offset, mission.imu.t) and "gt_clock_doubted" not in meta \
            and "gt" not in meta.get("clock_offsets", {}):       # the clock search has said what the data give
        _judge_given_gt_offset(mission, meta, facts, float(offset), lat)
    if offset:
        text = f"time offset {offset:+.3f} s added to the reference stamps ({how})"
        add_note(meta, "gt", text)
        if "given" not in how:
            point = ("" if cfg.reference_position_b is not None else "; the reference is scored at the IMU point "
                     "(reference_position_b unset): a reference measured elsewhere differs by omega x r in turns, and "
                     "graphnav calibrate finds its point")
            warnings.warn(f"{g.source}: {text}; set gt_time_offset_s in the configuration if it is known{point}",
                          RuntimeWarning, stacklevel=5)
        g = dataclasses.replace(g, t=g.t + offset)
        set_span(meta, "gt", g.t)
    r_b = cfg.reference_position_b
    if r_b is not None and np.any(r_b):
        g = move_ground_truth(g, mission.imu.t, mission.imu.omega_b, -r_b, lat)
        meta["gt_point_b"] = (-r_b).tolist()
        add_note(meta, "gt", "moved to the IMU point from its reference_position_b "
                 f"[{', '.join(f'{x:+.3f}' for x in r_b)}] m (body frame)")
    # the configuration records all that was added to the stamps as read (a clock offset too): what the next run is
    # given
    clock = meta.get("clock_offsets", {}).get("gt", {}).get("offset_s", 0.0)
    if g is mission.gt and not clock:
        return mission
    offset += clock
    return dataclasses.replace(mission, gt=g, config=dataclasses.replace(cfg, gt_time_offset_s=float(offset)))


def _judge_given_gt_offset(mission: Mission, meta: dict, facts: dict, given: float, lat: float | None) -> None:
    """The configuration's ``gt_time_offset_s`` of a log or bag (s), which the clock search left standing
    (:func:`_given_reference_clock`), judged as an A-KIT folder's is (:func:`_judge_given_offset`): against the offset
    the reference's attitude increments, stamped with it, still need to match the gyro's
    (:func:`graphnav.calibration.reference.estimate_gt_time_offset`, +-2 s). A reference too short to estimate cannot
    judge it: noted."""
    from graphnav.calibration.reference import estimate_gt_time_offset
    g = mission.gt
    try:
        est = estimate_gt_time_offset(mission.imu.t, mission.imu.omega_b, g.t + given, g.C_b_n, lat, source=g.source)
    except DataError as err:
        add_note(meta, "gt", f"the configuration's gt_time_offset_s is not judged ({err})")
        return
    _judge_given_offset(meta, facts, "gt", given, given + est.offset_s, est.sigma_s, mission)


def _given_axis_signs(mission: Mission, meta: dict, facts: dict) -> Mission:
    """The mission with the configuration's ``imu_axis_signs`` (``facts["given"]``) multiplying the IMU x, y, z
    (accelerometer and gyro) as read, on top of the frame the column map or the bag declares, and recorded as
    applied; the declared frame is then checked on the signed axes (:func:`_imu_frame`)."""
    given = facts.get("given", {}).get("imu_axis_signs")
    if given is None:
        return mission
    signs = np.asarray(given, float).reshape(3)
    add_note(meta, "imu", f"axis signs {tuple(int(x) for x in signs)} applied to accelerometer and gyro (given by "
                          "the configuration's imu_axis_signs)")
    meta["imu_axis_signs"] = {"signs": signs.tolist(), "detected": False, "decided": None}
    imu = dataclasses.replace(mission.imu, f_b=mission.imu.f_b * signs, omega_b=mission.imu.omega_b * signs)
    return dataclasses.replace(mission, imu=imu, config=dataclasses.replace(mission.config, imu_axis_signs=signs))


#: What a score against a log's or bag's reference whose point on the vehicle is not given costs, and the fix.
REFERENCE_POINT_UNKNOWN = (
    "the reference is scored at the IMU point (reference_position_b unset): a reference measured elsewhere on the "
    "vehicle (an INS, a USBL transponder) moves by omega x r more in turns, counted as the estimate's error (VRMSE "
    "0.142 against 0.022 m/s on 200 s of Trajectory1 read as a column-map log, its reference 1.86 m ahead of the "
    "IMU); graphnav calibrate estimates the point and writes reference_position_b; set reference_position_b "
    "[0, 0, 0] if the reference is at the IMU point")


def reference_point_unknown(mission: Mission) -> str | None:
    """:data:`REFERENCE_POINT_UNKNOWN` for a prepared log's or bag's reference (ground truth) whose point on the
    vehicle the configuration does not give (``reference_position_b`` None), which the scores are then taken at the
    IMU point against; None when there is no reference, it is given, or the format fixes it (an A-KIT folder)."""
    if mission.gt is None or mission.config.reference_position_b is not None:
        return None
    return REFERENCE_POINT_UNKNOWN if mission.meta.get("prepare", {}).get("format") in ("csv", "bag") else None


#: The keys of :func:`reference_notes`, in the order a score's report prints them.
REFERENCE_NOTE_KEYS = ("reference_time", "reference_point")


def reference_notes(mission: Mission) -> dict:
    """What a score against a prepared mission's reference says beside it: ``reference_point``
    (:func:`reference_point_unknown`) and ``reference_time``, when the data contradict the reference's time offset a
    configuration gave (used as given, :func:`_doubt_given`): a score against a reference 16 s off is the vehicle's
    motion over 16 s, not the estimate's error. Empty without either."""
    point, doubted = reference_point_unknown(mission), mission.meta.get("gt_time_doubted")
    time = doubted and (f"the score is doubted: it is taken against the reference at the time offset given "
                        f"({doubted}); set gt_time_offset_s to null to let the data decide")
    return {k: v for k, v in (("reference_point", point), ("reference_time", time)) if v}


def _imu_frame(mission: Mission, meta: dict, frame: dict | None, judge: GroundTruth | None) -> Mission:
    """The mission with its IMU axes as the data say (:func:`graphnav.calibration.axes.declared_frame_signs`).

    ``frame`` (the loader's ``meta["prepare"]["imu_frame"]``): ``declared`` (the frame a user named, or None when
    implied: a column map without ``frame`` or with ``"auto"``, a bag's frame_id), ``what`` (the declaration, for
    the messages), ``fields`` (the columns or topic). Data that contradict a declared frame are a DataError; an
    implied one is corrected, warned about and noted. None (other formats): the mission unchanged. ``judge``: the
    reference that checks the axes (:func:`_reference_checks_axes`), else None: the IMU alone does."""
    if frame is None:
        return mission
    from graphnav.calibration.axes import FRAME_FAULTS, declared_frame_signs
    imu, gt = mission.imu, judge
    signs, how, undecided = declared_frame_signs(imu, mission.config, gt, imu.source, frame["fields"])
    if undecided:
        _note_y_undecided(meta, mission.config, frame, signs, undecided)
    if np.all(signs == 1):
        return mission
    applied = mission.config.imu_axis_signs
    what = frame["what"] + ("" if np.all(applied == 1) else
                            f" with the configuration's imu_axis_signs {tuple(int(x) for x in applied)}")
    # named against the data as read: the signs asked for are then the ones to give (or none, if they undo the given)
    net = tuple(int(x) for x in np.asarray(applied) * signs)
    if net == (1, 1, 1) and not np.all(applied == 1):
        need = ("as read they need no axis signs (the data already hold the frame, as a bag or log graphnav wrote "
                "from a mission does)")
    else:
        need = (f"{'' if np.all(applied == 1) else 'as read '}they need axis signs {net} on x, y, z "
                f"({FRAME_FAULTS.get(net, 'a left-handed frame: one axis negated')})")
    text = f"the IMU data contradict {what}: {need}, by {how}"
    if frame["declared"]:
        other = {"frd": "flu", "flu": "frd"}.get(frame["declared"]) if net == (1, -1, -1) else None
        fix = f"to {other!r} if the file holds that frame, or " if other else ""
        unsign = "" if np.all(applied == 1) else " (and imu_axis_signs to null, or remove it)"
        if net == (1, 1, 1) and not np.all(applied == 1):
            raise DataError(f"{text}; remove imu_axis_signs from the configuration (or set it to null)", imu.source,
                            field=frame["fields"])
        raise DataError(f"{text}; set csv_columns.imu.frame {fix}to 'auto'{unsign} to correct the axes from the data",
                        imu.source, field=frame["fields"])
    text += (": the configuration's imu_axis_signs undone (remove them from it)" if net == (1, 1, 1) else
             ": accelerometer and gyro multiplied by them")
    add_note(meta, "imu", text)
    warnings.warn(f"{imu.source}: {text}", RuntimeWarning, stacklevel=4)
    meta["imu_axis_signs"] = {"signs": (applied * signs).tolist(), "detected": True, "decided": not undecided}
    config = dataclasses.replace(mission.config, imu_axis_signs=applied * signs)
    imu = dataclasses.replace(imu, f_b=imu.f_b * signs, omega_b=imu.omega_b * signs)
    return dataclasses.replace(mission, imu=imu, config=config)


def _note_y_undecided(meta: dict, config: SensorConfig, frame: dict, signs: np.ndarray, why: str) -> None:
    """Noted on the IMU stream, and ``meta["imu_axis_signs"]["decided"]`` False (the DVL check then judges the y,
    :func:`graphnav.calibration.dvl_scale.check_imu_yaw`): the data could not tell the IMU's y as read from the y
    negated on both sensors (``why``: a level vehicle's tilt kinematics, too little rotation against a reference), so
    the y is taken as ``frame["what"]`` declares it. A note, not a warning: every level vehicle's clean log has it."""
    from graphnav.calibration.dvl_scale import Y_NEGATED, applied_axis_signs
    applied = applied_axis_signs(config)
    net = applied * signs
    given = "" if np.all(applied == 1) else f" with imu_axis_signs {tuple(int(x) for x in applied)}"
    add_note(meta, "imu", f"its y axis sign is not told by the IMU data ({why}): taken as {frame['what']}{given}, "
                          f"applying {tuple(int(x) for x in net)}; if the file's y points the other way on the "
                          f"accelerometer and gyro, set imu_axis_signs {tuple(int(x) for x in net * Y_NEGATED)} in "
                          "the configuration")
    meta.setdefault("imu_axis_signs", {"signs": net.tolist(), "detected": True})["decided"] = False


def _warn_no_heading(config: SensorConfig, source: str, meta: dict, why: str | None = None) -> None:
    """Said when the bag is prepared, not after an alignment fails: what to add for a heading. ``why``: why the bag
    has none, when it had a heading topic."""
    from graphnav.estimators.align import AlignOptions, gyrocompass_heading_terms
    limit = gyrocompass_heading_terms(config, 1.0, 1, 0.0, config.lat_rad)["gyro_bias"]
    can = limit <= AlignOptions().max_heading_sigma_rad
    why = why or ("no sensor_msgs/Imu with its orientation filled, no Float64 topic named heading, no "
                  "PoseWithCovarianceStamped")
    msg = (f"no heading source in the bag ({why}): the heading must come from gyrocompassing, which "
           + (f"the configured gyro allows (bias limit {np.degrees(limit):.2f} deg)" if can else
              f"the configured gyro cannot do (its bias alone gives {np.degrees(limit):.1f} deg; a MEMS or 10 Hz "
              "IMU never can)")
           + "; add an AHRS/compass topic (--topic heading=TOPIC) or give the initial heading")
    add_note(meta, "heading", msg)
    meta["heading_source"] = "none"
    warnings.warn(f"{source}: {msg}", RuntimeWarning, stacklevel=4)


# ------------------------------------------------------------------------------------------------
# The check behind rescale_stamps
# ------------------------------------------------------------------------------------------------
def gt_offset_drift(folder: str | Path, rescale_stamps: bool, window: int = 100) -> float:
    """Drift of the IMU-to-GT time offset over an A-KIT trajectory, s per s (the check behind
    ``rescale_stamps`` of :func:`graphnav.io.loaders.read_akit`).

    The offset is estimated in consecutive ``window``-sample GT windows and a line is fitted through them:
    with the published ``linspace`` stamps it drifts by about -2.5 ms/s, with rescaled stamps by ~0.
    """
    from graphnav.calibration.reference import estimate_gt_time_offset
    from graphnav.io.loaders import read_akit_mission
    m = read_akit_mission(folder, rescale_stamps=rescale_stamps)
    signs = np.asarray(detect_akit_axis_signs(m, m.meta["prepare"]["gt_mean_depth_m"]).signs, float)
    t_imu, omega_b, t_gt, C_b_n = m.imu.t, m.imu.omega_b * signs, m.gt.t, m.gt.C_b_n
    starts = range(0, len(t_gt) - window + 1, window)
    mid = [t_gt[s + window // 2] for s in starts]
    offsets = [estimate_gt_time_offset(t_imu, omega_b, t_gt[s:s + window], C_b_n[s:s + window]).offset_s
               for s in starts]
    return float(np.polyfit(mid, offsets, 1)[0])
