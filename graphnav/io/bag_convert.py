"""From a bag's decoded messages to the Mission's streams: IMU, DVL (beams and the instrument's own velocity),
depth chosen by plausibility, heading aiding, reference odometry.

Frames. graphnav works in FRD body / NED navigation. ROS' REP-103 uses FLU body / ENU world; a ``frame_id``
ending in ``_frd`` / ``_ned`` (the marine and PX4 convention) marks FRD / NED data. The DVL messages are in the
DVL's own frame (marine_acoustic_msgs: z along the DVL axis, x vehicle forward; Water Linked: x forward, y
right, z down; for a down-looking DVL both are graphnav's DVL frame d).
"""
from __future__ import annotations

import warnings
import dataclasses
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from graphnav.core.config import SensorConfig
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.mission import (MAX_DVL_SPEED_MPS, MAX_FIX_SIGMA_M, DepthData, DvlData, GroundTruth, HeadingData,
                                   ImuData, PositionFixData, no_beams)
from graphnav.core.rotations import C_NED_ENU
from graphnav.core.screening import (EXACT_COPY, IMU_FILLER, MAX_STAMP_GAP_S, NUDGED_COPY, exact_copies, filler_between,
                                     imu_unmeasured, located, nudged_copies, refuse_rows, say_exact_copies,
                                     say_imu_stamp_steps, say_nudged_copies, zeroed_filler)
from graphnav.core.streams import add_note, count_refused, say_doubted
from graphnav.io import bag_fields
from graphnav.io.bag_stamps import (CLOCK_DRIFT_MAX_RATE, CLOCK_DRIFT_NOTE_S, HEADER_CLOCK_DRIFT,
                                    HEADER_CLOCK_DRIFT_NOT_TOLD, HEADER_CLOCK_DRIFT_UNTOLD, HEADER_CLOCK_STEP,
                                    HEADER_LATENCY_GROWS, HEADER_STEP_SPREADS, RECEIVED_OFF_PACE, clock_step_moved,
                                    latency_drop, latency_rate, latency_step, latency_trend, nearer_the_receive_clock,
                                    off_round_rate, on_the_grid, say_set_right, say_steps_back, schedule_periods,
                                    steps_back_repaired)
from graphnav.io.bag_msgs import MARINE_DVL, WL_DVL

#: FLU <-> FRD (its own inverse) and ENU <-> NED (its own inverse).
FLU_FRD = np.diag([1.0, -1.0, -1.0])
ENU_NED = C_NED_ENU


def flu_frd(x: np.ndarray) -> np.ndarray:
    """(N,3) vectors turned between FLU and FRD (either way) value by value: a NaN or infinite value stays in its
    axis, where a product with :data:`FLU_FRD` spreads a NaN to all three (a bag written from an IMU with a NaN in
    one value would hold three)."""
    return np.asarray(x, float) * np.diag(FLU_FRD)
TWIST_DVL = "geometry_msgs/msg/TwistWithCovarianceStamped"
#: The fields of the built-in DVL messages read for the velocity and the beams (as :func:`bag_fields.named_fields`).
DVL_MESSAGE_FIELDS = {MARINE_DVL: ("velocity", "beam_velocity"), WL_DVL: ("velocity", "beams[].velocity"),
                      TWIST_DVL: ("twist.twist.linear", None)}
#: The field a stream's stamps come from, by :class:`Stream` ``stamp_kind``, for warnings.
STAMP_FIELDS = {"header": "header.stamp", "receive": "receive time"}

#: Absolute pressure a water-pressure sensor can read, Pa: from a low atmosphere (80 kPa, a storm at altitude)
#: to 11 km of sea water (~110 MPa). All zeros, or a leak detector's 0/1, are not water.
WATER_PRESSURE_RANGE_PA = (8.0e4, 1.2e8)
#: A surface pressure reading must lie in this range to be taken as the atmosphere, Pa (sea-level weather
#: 95-105 kPa; above it the vehicle is already 0.5 m or more under water).
ATMOSPHERE_RANGE_PA = (9.4e4, 1.06e5)
#: The first seconds of a pressure stream averaged for the surface pressure, s, and the largest spread
#: (Pa from the first reading; ~1.5 cm of water) they may have for the vehicle to count as still at the surface.
SURFACE_WINDOW_S = 5.0
SURFACE_MAX_DEV_PA = 150.0
#: Depth range check, m: above the surface beyond the tolerance (waves, a pressure offset) or deeper than the
#: ocean is not a depth.
DEPTH_ABOVE_SURFACE_TOL_M = 1.0
MAX_DEPTH_M = 11000.0
#: A depth stream must vary by at least this much (m, 2nd to 98th percentile) to be taken as the vehicle's:
#: a housing's internal pressure or a disconnected sensor stays flat.
MIN_DEPTH_VARIATION_M = 0.2
#: Heading 1-sigma of an AHRS / heading topic that gives no variance, rad: the 1-3 deg a MEMS AHRS with a
#: calibrated magnetometer states, at its upper end (a vehicle's own fields disturb it).
DEFAULT_HEADING_SIGMA_RAD = float(np.deg2rad(3.0))
#: 1-sigma per horizontal axis, m, of a NavSatFix without a position covariance (``position_covariance_type``
#: 0, unknown): a standalone GNSS receiver's typical horizontal accuracy.
DEFAULT_FIX_SIGMA_M = 5.0
#: ``sensor_msgs/NavSatStatus.STATUS_NO_FIX``: the receiver has no position.
NAVSAT_NO_FIX = -1


@dataclass
class Stream:
    """One topic's decoded messages: stamps (ns, as chosen by :mod:`graphnav.io.bag_stamps`: ``stamp_kind``
    ``"header"`` or ``"receive"``), the receive stamps of the same messages, how many messages the topic
    had before any was dropped, the stamp repairs (a ``meta`` of its own, see :mod:`graphnav.core.streams`) and
    each message's index in the topic (None: every message, in the bag's order)."""

    topic: str
    msgtype: str
    t_ns: np.ndarray
    rows: list
    stamp_kind: str = "header"
    receive_ns: np.ndarray | None = None
    n_read: int = 0
    log: dict = field(default_factory=dict)
    index: np.ndarray | None = None
    #: the messages dropped as published twice (:func:`decoded_stream`): reason -> (their indexes in the topic, their
    #: stamps ns, the largest nudge s), warned about when the topic is used
    twice: dict = field(default_factory=dict)


def messages(s: Stream, t0_ns: int) -> list[str]:
    """Each message of ``s`` named for a warning: its index in the topic and its time on the mission's clock."""
    index = np.arange(len(s.rows)) if s.index is None else s.index
    return _named(index, s.t_ns, t0_ns)


def _named(index: np.ndarray, t_ns: np.ndarray, t0_ns: int) -> list[str]:
    return [f"message {int(i)} (t = {t:.3f} s)" for i, t in zip(index, (np.asarray(t_ns) - t0_ns) / 1e9)]


def message_values(rows: list) -> np.ndarray:
    """(N,k) every number each decoded message holds but its header (the stamp and, in ROS 1, a sequence number that
    a message published again changes), in field order, with each array's length; rows shorter than the longest
    padded with NaN. Strings (frame ids) are left out. Read field by field over the topic (a third of the time of
    message by message, which added 30 us to the 43 us of decoding an IMU message) unless an array's length varies
    between messages."""
    columns: list = []
    if rows and _columns(rows, columns):
        return np.column_stack(columns) if columns else np.zeros((len(rows), 0))
    values = [_numbers(m, []) for m in rows]
    width = max((len(v) for v in values), default=0)
    out = np.full((len(values), width), np.nan)
    for i, v in enumerate(values):
        out[i, :len(v)] = v
    return out


def _columns(msgs: list, out: list) -> bool:
    """:func:`message_values`' columns of the messages ``msgs`` (each (N,)) added to ``out``, as :func:`_numbers`
    lays them; False (``out`` then unusable) when an array's or a list's length varies between them."""
    return all(_column([getattr(m, name) for m in msgs], out) for name in msgs[0].__dataclass_fields__
               if name != "header")


def _column(values: list, out: list) -> bool:
    v = values[0]
    if isinstance(v, (bool, int, float, np.number)):
        out.append(np.array(values, float))
    elif isinstance(v, np.ndarray):
        if any(x.shape != v.shape for x in values):
            return False
        out.append(np.full(len(values), float(v.size)))
        out.extend(np.stack(values).reshape(len(values), -1).astype(float).T)
    elif isinstance(v, (list, tuple)):
        if any(len(x) != len(v) for x in values):
            return False
        out.append(np.full(len(values), float(len(v))))
        return all(_column([x[j] for x in values], out) for j in range(len(v)))
    elif hasattr(v, "__dataclass_fields__"):
        return _columns(values, out)
    return True


def _numbers(msg, out: list) -> list:
    for name in msg.__dataclass_fields__:
        if name != "header":
            _number(getattr(msg, name), out)
    return out


def _number(v, out: list) -> None:
    if isinstance(v, (bool, int, float, np.number)):
        out.append(float(v))
    elif isinstance(v, np.ndarray):
        out.append(float(v.size))
        out.extend(v.astype(float).ravel().tolist())
    elif isinstance(v, (list, tuple)):
        out.append(float(len(v)))
        for x in v:
            _number(x, out)
    elif hasattr(v, "__dataclass_fields__"):
        _numbers(v, out)


def decoded_stream(topic: str, msgtype: str, header_ns: np.ndarray | None, receive_ns: np.ndarray, rows: list,
                   stream: str, label: str, clock_s: float = 0.0) -> Stream:
    """The :class:`Stream` of a topic's decoded messages (``rows``, their header stamps ``header_ns`` or None and
    receive stamps ``receive_ns``, ns) read for ``stream``, without the messages published twice, as a log's rows
    written twice are dropped (:func:`graphnav.core.screening.stamp_order`), every value compared
    (:func:`message_values`): one repeating an earlier message exactly at its header stamp
    (:func:`~graphnav.core.screening.exact_copies`: dropped before the stamps are chosen, so the header stamps stay
    usable; an IMU's whose readings repeat across stamps as often may be samples sharing a stamp and are left to
    :func:`~graphnav.io.bag_stamps.choose_stamps`), then, on the stamps chosen, one repeating the message before it a
    moment later (:func:`~graphnav.core.screening.nudged_copies`). Each is counted in the stream's log and kept in
    ``Stream.twice`` for the warning when the topic is used (:func:`warn_written_twice`). ``clock_s``: the IMU's
    header minus receive time, s (a header clock set right is judged against it)."""
    from graphnav.io.bag_stamps import why_not_header, choose_stamps
    sub: dict = {}
    twice: dict = {}
    values = message_values(rows)
    index = np.arange(len(rows))
    zeroed = _zeroed_filler(stream, header_ns, rows, label)
    rest = ~zeroed       # the other messages' stamps judged as below, without the messages published twice
    copies = None       # found once on the messages they are dropped from
    if zeroed.any():
        copies = _copies(stream, header_ns[rest], values[rest])
        if why_not_header(np.delete(header_ns[rest], copies)) is None:
            count_refused(sub, stream, IMU_FILLER, int(zeroed.sum()))
            twice[IMU_FILLER] = (np.flatnonzero(zeroed), receive_ns[zeroed], 0.0)
            index = np.flatnonzero(rest)
            header_ns, receive_ns, values = header_ns[index], receive_ns[index], values[index]
        else:
            copies = None
    if header_ns is not None and len(rows) > 2 and np.all(header_ns != 0):
        copies = _copies(stream, header_ns, values) if copies is None else copies
        if copies.size:
            count_refused(sub, stream, EXACT_COPY, int(copies.size))
            twice[EXACT_COPY] = (index[copies], header_ns[copies], 0.0)
            kept = np.delete(np.arange(len(index)), copies)     # positions in the messages left, not in the topic
            index, header_ns, receive_ns, values = index[kept], header_ns[kept], receive_ns[kept], values[kept]
    t_ns, keep, how = choose_stamps(header_ns, receive_ns, sub, stream, label, clock_s)
    index, values, receive_ns = index[keep], values[keep], receive_ns[keep]
    if len(t_ns) > 2:
        t = (t_ns - t_ns[0]) / 1e9
        copies, moved = nudged_copies(t, np.column_stack([t, values]))
        if copies.size:
            count_refused(sub, stream, NUDGED_COPY, int(copies.size))
            twice[NUDGED_COPY] = (index[copies], t_ns[copies], moved)
            kept = np.delete(np.arange(len(t_ns)), copies)
            t_ns, index, receive_ns = t_ns[kept], index[kept], receive_ns[kept]
    return Stream(topic, msgtype, t_ns, [rows[i] for i in index], how, receive_ns, len(rows), sub.get("streams", {}),
                  index, twice)


def _copies(stream: str, header_ns: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The indexes of the messages (header stamps ``header_ns`` (N,) ns, ``values`` (N,k) as
    :func:`message_values`) repeating an earlier one exactly (:func:`~graphnav.core.screening.exact_copies`), none for
    an IMU whose readings repeat across stamps as often (samples sharing a stamp, left to the stamps' choice)."""
    t = (header_ns - header_ns[0]) / 1e9
    copies, repeat = exact_copies(t, np.column_stack([t, values]))
    return copies[:0] if stream == "imu" and repeat else copies


def _zeroed_filler(stream: str, header_ns: np.ndarray | None, rows: list, label: str) -> np.ndarray:
    """(N,) bool: the IMU messages (``stream`` "imu") of a logger's filler whose header stamp is zeroed too
    (:func:`graphnav.core.screening.zeroed_filler`): no time, so out before the stamps are chosen, as a column map's
    rows are (21 of them put the whole topic on its receive time, 'header stamp(s) are zero'), when the other
    messages' header stamps are sane once the messages published twice are left out (:func:`_copies`; one such copy
    put the topic on its receive time). A topic whose every stamp is zero has no header clock, and one whose other
    stamps are not sane (a stall, a step back) is on its receive time anyway: there the filler's stamps are there, and
    it is refused with the other messages holding no measurement. A topic of filler only is a DataError naming
    ``label``."""
    if (stream != "imu" or header_ns is None or not np.any(header_ns != 0)
            or not hasattr(rows[0], "linear_acceleration")):
        return np.zeros(len(rows), bool)
    six = np.array([[*vec(m.linear_acceleration), *vec(m.angular_velocity)] for m in rows])
    return zeroed_filler(header_ns, six, label)


def warn_written_twice(s: Stream, t0_ns: int, source: str) -> None:
    """The warnings of the messages :func:`decoded_stream` dropped as published twice, each named by its index in
    the topic and its time on the mission's clock, and of an IMU's filler with its stamp zeroed (named by its receive
    time)."""
    for reason, (index, t_ns, moved) in s.twice.items():
        where = _named(index, t_ns, t0_ns)
        at = np.arange(index.size)
        if reason == IMU_FILLER:
            warnings.warn(f"{source}:{s.topic}: {index.size} imu sample(s) refused ({index.size} {IMU_FILLER}, its "
                          f"header stamp zeroed too, received at {located(at, where=where)}); they are not used",
                          RuntimeWarning, stacklevel=2)
        elif reason == EXACT_COPY:
            say_exact_copies(at, f"{source}:{s.topic}", where=where, stacklevel=3)
        else:
            say_nudged_copies(at, moved, f"{source}:{s.topic}", where=where, stacklevel=3)


def frame_is(frame_id: str, suffix: str) -> bool:
    return frame_id.lower().rstrip("/").endswith(suffix)


def vec(v) -> np.ndarray:
    return np.array([v.x, v.y, v.z], dtype=float)


def quat(q) -> np.ndarray:
    return np.array([q.x, q.y, q.z, q.w], dtype=float)


def _rel(s: Stream, t0_ns: int) -> np.ndarray:
    return (s.t_ns - t0_ns) / 1e9


# --- IMU ---------------------------------------------------------------------------------------------------
def header_clock_steps_removed(s: Stream, source: str, meta: dict, steps: list | None = None, kind: str = "imu",
                               clock_s: float = 0.0) -> Stream:
    """``s`` (a topic on its header stamps, read for stream ``kind``: the IMU, DVL, depth, heading or reference) with
    each forward step of its own header clock that the bag's receive clock does not share taken out: a gap of whole
    periods in the header stamps reads as samples lost (an IMU's bridged by the run, a DVL's pings missing), but when
    the messages kept arriving at the period (header minus receive time steps by the gap and stays there) no message
    was lost: the topic's clock stepped (+5 s, or days: a driver's clock reset), and the stamps from that message on
    are moved back so the step lasts as many periods as the receive time says passed (one, or two: one message
    lost). A topic other than the IMU's whose clock was another clock before the step and is set right by it
    (:func:`graphnav.io.bag_stamps.set_right`, judged against the IMU's header minus receive time ``clock_s``, s)
    has the stamps before it moved onto the clock after it instead. Each
    step is warned about naming the topic, the message, its time and the field, and its messages counted as doubted
    on ``kind`` in ``meta``; a gap the receive time shares too (messages lost, or the recorder's clock stepping with
    it), or does in part (:data:`GAP_WARN_SAMPLES` messages lost or more by the receive time) while header minus
    receive time comes nearer 0 (a latency dropping as they are lost: a driver restarted, a backlog flushed) is left
    as it is (an IMU's to :func:`graphnav.core.screening.say_imu_stamp_steps`). A step the receive time does not
    share that may as well be messages lost as the recorder's latency dropped by as much
    (:func:`graphnav.io.bag_stamps.latency_drop`) is told by the sample grid: stamps staying on it across the gap are
    messages lost (left, warned), stamps leaving it a clock step (moved); stamps too uneven to tell are moved, the
    warning saying it could not be told. Each step moved back is appended to ``steps`` (when given) as (the receive
    time of its first message, ns; the stamps' shift, ns) for :func:`shared_clock_step_removed`. Before them, any
    topic, the IMU's too, has its steps back under a period and forward under :data:`GAP_WARN_SAMPLES` (its stamps
    still increasing without a gap, so not repaired as they were chosen nor judged as a gap) taken out by
    :func:`graphnav.io.bag_stamps.steps_back_repaired` (the IMU's own: not shared); either way the stamps are moved by
    :func:`graphnav.io.bag_stamps.clock_step_moved` and a clock set right is said in one wording."""
    from graphnav.core.imu_timing import GAP_WARN_SAMPLES, imu_step_stats
    if s.stamp_kind != "header" or s.receive_ns is None or len(s.t_ns) < 3:
        return s
    t_ns = np.asarray(s.t_ns, np.int64).copy()
    rx_ns = np.asarray(s.receive_ns, np.int64)
    period = imu_step_stats(np.diff(t_ns) / 1e9)[0]
    if not np.isfinite(period) or period <= 0:
        return s
    moved = 0
    # a step back under a period (forward under two) keeps the stamps increasing (not gapping): not taken out as they
    # were chosen (nor below)
    back = steps_back_repaired(t_ns, rx_ns, kind, None, clock_s, forward=True)
    if back is not None:
        t_ns, moved = back[0], len(back[1])
        say_steps_back(back[1], meta, kind, f"{source}:{s.topic}", index=s.index)
    latency = (t_ns - rx_ns) / 1e9      # moved with the stamps: computed once (a gap per second over hours)
    gaps = np.flatnonzero(np.diff(t_ns) / 1e9 >= GAP_WARN_SAMPLES * period)
    # a header clock drifting as it steps: the step measured off the drift (1 % slow read a +5 s step as +4 s)
    trend = latency_trend(t_ns, rx_ns) if gaps.size else None
    for i in gaps:
        step, spread = latency_step(latency, i + 1, trend=trend)
        if step < max(GAP_WARN_SAMPLES * period, HEADER_STEP_SPREADS * spread):
            continue
        jump = (t_ns[i + 1] - t_ns[i]) / 1e9
        periods = max(1, round((jump - step) / period))
        if periods - 1 >= GAP_WARN_SAMPLES and nearer_the_receive_clock(latency, i + 1, step):
            # messages lost (the receive time gaps too) as header and receive time came closer: a latency dropping
            # as they were lost (a driver restarted, a backlog flushed) reads as the header clock stepping
            continue
        at_i = _named(np.array([i + 1 if s.index is None else s.index[i + 1]]), t_ns[i + 1:i + 2], t_ns[0])[0]
        rx_s = (rx_ns[i + 1] - rx_ns[i]) / 1e9
        lost_n = round(jump / period) - 1
        untold = ""
        if latency_drop(latency, i + 1, step):
            grid = on_the_grid(t_ns, i + 1, period)
            if grid:
                _say_lost_as_latency_dropped(s, at_i, jump, rx_s, step, lost_n, kind, source, meta)
                continue
            untold = ("; it cannot be told from {} message(s) lost as the recorder's latency dropped {:.3f} s: the "
                      "header stamps are too uneven to say whether they stay on their sample grid"
                      if grid is None else "; the stamps leave their sample grid, so the header clock stepped, but "
                      "whether some of the {} period(s) were messages lost as the recorder's latency dropped {:.3f} s "
                      "cannot be told").format(lost_n, step)
        lost = ("while the messages kept arriving (receive time {:+.3f} s): no messages lost" if periods == 1 else
                f"while the receive time steps {{:+.3f}} s: {periods - 1} messages lost by it, the rest the clock's "
                "step").format(rx_s)
        moved += 1
        m = clock_step_moved(t_ns, latency, i + 1, step, spread, period, kind, clock_s, 0, len(t_ns))
        at = f"{s.topic}, {at_i}, field '{STAMP_FIELDS['header']}': "
        if m["before"]:
            prev = f"message {i if s.index is None else s.index[i]}"
            seen = f", {periods - 1} messages lost by it" if periods > 1 else ""
            say_set_right(meta, kind, source, at, {**m, "rx_s": rx_s, "n": i + 1}, prev, prev, seen, untold,
                          stacklevel=2)
            continue
        if steps is not None:
            steps.append((int(rx_ns[i + 1]), -m["shift_ns"]))
        text = (f"{at}the header clock steps {jump:+.3f} s {lost}; the stamps from this message on are moved back by "
                f"{-m['shift_s']:.3f} s onto the clock before the step")
        say_doubted(meta, kind, source, text + untold, HEADER_CLOCK_STEP, len(t_ns) - i - 1, stacklevel=2)
    return dataclasses.replace(s, t_ns=t_ns) if moved else s


def header_clock_drift_removed(s: Stream, source: str, meta: dict, kind: str, clock_rate: float | None = 0.0
                               ) -> Stream:
    """``s`` (a topic other than the IMU's, on its header stamps, its steps taken out) with its header clock's drift
    against the IMU's taken out: header minus receive time running on a line
    (:func:`~graphnav.io.bag_stamps.latency_rate`) that leaves the IMU's (``clock_rate``: the IMU's, s per s; a
    recorder's clock drifting drifts every topic alike) by more than
    :data:`~graphnav.io.bag_stamps.CLOCK_DRIFT_NOTE_S` over the topic is a clock running fast or slow (a DVL's own
    oscillator 1 % slow ends 1.5 s behind after 150 s). Warned naming the topic and the field, every message
    counted as doubted on ``kind``; the stamps are moved onto the IMU's rate from the first message on when the drift
    is over :data:`HEADER_STEP_SPREADS` of the latency's spread about its line, else kept (the warning says so). A
    drift faster than :data:`~graphnav.io.bag_stamps.CLOCK_DRIFT_MAX_RATE` is no clock's: the topic received at
    another pace than stamped (replayed, written into the bag later), warned and counted, its header stamps kept. A
    clear drift is taken out only where the header clock is shown to drift rather than the recorder's latency to grow
    (:func:`_drift_kept`); ``clock_rate`` None: the IMU is on the receive time, the mission's clock the recorder's,
    and a clear drift is taken out onto it (a recorder's clock drifting would read as every topic's latency growing)."""
    if s.stamp_kind != "header" or s.receive_ns is None:
        return s
    t_ns = np.asarray(s.t_ns, np.int64)
    rate, spread = latency_rate(t_ns, s.receive_ns)
    rate -= clock_rate or 0.0
    span = (int(s.receive_ns[-1]) - int(s.receive_ns[0])) / 1e9 if len(t_ns) else 0.0
    drift = rate * span
    if abs(drift) <= CLOCK_DRIFT_NOTE_S:
        return s
    clear = abs(drift) > HEADER_STEP_SPREADS * spread
    seen = (f"header minus receive time drifts {drift:+.3f} s over the {span:.1f} s of its {len(t_ns)} messages "
            f"({spread:.3f} s spread about that line)")
    if abs(rate) > CLOCK_DRIFT_MAX_RATE:
        say_doubted(meta, kind, source, f"{s.topic}, field 'receive time': {seen}, {abs(rate) * 100:.1f} % against "
                    f"the IMU's, more than a clock drifts ({CLOCK_DRIFT_MAX_RATE:.0%}): the topic was received at "
                    "another pace than it was stamped (replayed, or written into the bag later); the header stamps "
                    "are kept", RECEIVED_OFF_PACE, len(t_ns), stacklevel=2)
        return s
    text = (f"{s.topic}, field '{STAMP_FIELDS['header']}': the header clock runs {abs(rate) * 100:.3f} % "
            f"{'fast' if rate > 0 else 'slow'} against the IMU's: {seen}; ")
    if not clear:
        say_doubted(meta, kind, source, text + "too spread to take the drift out: the header stamps are kept",
                    HEADER_CLOCK_DRIFT_UNTOLD, len(t_ns), stacklevel=2)
        return s
    why = None if clock_rate is None else _drift_kept(t_ns, s.receive_ns, rate, clock_rate)
    if why is not None:
        latency = why[1] == HEADER_LATENCY_GROWS
        text = (f"{s.topic}, field '{STAMP_FIELDS['header']}': {seen}, {abs(rate) * 100:.3f} % against the IMU's: "
                if latency else text)
        say_doubted(meta, kind, source, text + why[0], why[1], len(t_ns), stacklevel=2)
        return s
    moved = t_ns[0] + np.round((t_ns - t_ns[0]) / (1.0 + rate)).astype(np.int64)
    say_doubted(meta, kind, source, text + f"the stamps are moved onto the IMU's clock rate from the first message on "
                f"({(moved[-1] - t_ns[-1]) / 1e9:+.3f} s at the last)", HEADER_CLOCK_DRIFT, len(t_ns), stacklevel=2)
    return dataclasses.replace(s, t_ns=moved)


def _drift_kept(t_ns: np.ndarray, receive_ns: np.ndarray, rate: float, clock_rate: float) -> tuple[str, str] | None:
    """Why a topic's header minus receive time drifting by ``rate`` (s per s against the IMU's, whose own is
    ``clock_rate``) is not its header clock's drift to take out, as (the warning's end, the reason counted); None when
    the clock is shown drifting: the messages come at a round rate (or period) on the IMU's clock
    (:func:`~graphnav.io.bag_stamps.schedule_periods`, :data:`~graphnav.io.bag_stamps.ROUND_RATES_HZ`, within a
    quarter of the drift) and their header stamps leave it by the drift. A recorder's latency growing (a queue
    filling) drifts header minus receive time alike, but leaves the header stamps at their round rate and the
    receive time off it: then the header stamps are kept; neither round (a DVL pinging at its own pace), it cannot be
    told, and they are kept too, counted as such."""
    sched = schedule_periods(t_ns, receive_ns, clock_rate)
    bar = abs(rate) / 4
    if sched is not None:
        header, received, se = sched
        if off_round_rate(received) < bar and 3 * se < bar:
            return None
        periods = f"its period {header:.6f} s on the header clock, {received:.6f} s on the IMU's as received"
        if off_round_rate(header) < bar:
            return (f"{periods}: the header stamps keep a round rate (or period) and the receive time leaves it, so "
                    "the recorder's latency grows (a queue filling), not the header clock: the header stamps are kept",
                    HEADER_LATENCY_GROWS)
    else:
        periods = "its stamps too uneven to time the messages' period"
    return (f"{periods}: neither shows which clock keeps the messages' round rate (or period), so the header clock "
            "drifting cannot be told from the recorder's latency growing: the header stamps are kept",
            HEADER_CLOCK_DRIFT_NOT_TOLD)


def _say_lost_as_latency_dropped(s: Stream, at: str, jump: float, rx_s: float, step: float, lost_n: int, kind: str,
                                 source: str, meta: dict) -> None:
    """Warn about and note a gap of a topic's header stamps the receive time does not show that stays on the sample
    grid: messages lost as the recorder's latency dropped, kept as stamped (the gap left to the stream's own checks)."""
    text = (f"{s.topic}, {at}, field '{STAMP_FIELDS['header']}': the header stamps gap {jump:+.3f} s while the receive "
            f"time steps {rx_s:+.3f} s, yet stay on their sample grid: {lost_n} message(s) lost as the recorder's "
            f"latency dropped {step:.3f} s, not a step of the header clock; the header stamps are kept")
    warnings.warn(f"{source}: {text}", RuntimeWarning, stacklevel=3)
    add_note(meta, kind, text)


def check_stamp_jump(s: Stream, t0_ns: int, source: str) -> None:
    """Refuse a topic whose stamps still jump by more than :data:`~graphnav.core.screening.MAX_STAMP_GAP_S` (days)
    once its own header clock steps are taken out (:func:`header_clock_steps_removed`): a DataError naming the topic,
    the message and the stamp field, saying whether the receive time jumped with it (the recorder's clock stepped
    too, so no clock in the bag says what time passed) or not (a header clock step the receive time could not
    confirm: header minus receive time too spread around it)."""
    from graphnav.core.screening import stamp_jump
    jump = stamp_jump((np.asarray(s.t_ns, np.int64) - t0_ns) / 1e9)
    if jump is None:
        return
    i, why = jump
    at = _named(np.array([i if s.index is None else s.index[i]]), s.t_ns[i:i + 1], t0_ns)[0]
    if s.stamp_kind == "header" and s.receive_ns is not None:
        rx_s = (int(s.receive_ns[i]) - int(s.receive_ns[i - 1])) / 1e9
        shared = abs(rx_s) > MAX_STAMP_GAP_S
        why += (f"; the receive time jumps {rx_s:+.6g} s with it: the recorder's clock stepped too, so no clock in "
                "the bag says what time passed: split the bag there" if shared else
                f"; the receive time steps {rx_s:+.6g} s, but header minus receive time is too spread around it "
                "to take the step out as the header clock's own")
    raise DataError(f"{at}: {why}", f"{source}:{s.topic}", None, STAMP_FIELDS[s.stamp_kind])


def shared_clock_step_removed(s: Stream, steps: list, kind: str, source: str, meta: dict) -> Stream:
    """``s`` (a topic other than the IMU's, on its header stamps) with the IMU's header clock steps ``steps`` (from
    :func:`header_clock_steps_removed`) taken out where its own header clock stepped with the IMU's: a time-sync
    unit or a vehicle computer stamping every sensor steps them all while the recorder's receive clock runs on, and
    the IMU moved back alone left the rest of this topic that far off it. Shared: its header minus receive time
    steps by the IMU's shift, within :data:`HEADER_STEP_SPREADS` of its spread or a tenth of the shift, at the
    message received at the step or next to it. Warned naming the topic and message, counted as doubted on ``kind``;
    a topic whose clock did not step (its own) is left as it is."""
    if s.stamp_kind != "header" or s.receive_ns is None or len(s.t_ns) < 3 or not steps:
        return s
    t_ns = np.asarray(s.t_ns, np.int64).copy()
    rx_ns = np.asarray(s.receive_ns, np.int64)
    latency = (t_ns - rx_ns) / 1e9
    moved = 0
    for step_rx_ns, shift_ns in steps:
        j = int(np.searchsorted(rx_ns, step_rx_ns))
        if j <= 0 or j >= len(t_ns):
            continue
        # the first message on the new clock: a message stamped just before the step may be received just after it
        near = np.arange(max(1, j - 2), min(len(t_ns), j + 3))
        k = int(near[np.argmax(np.diff(latency)[near - 1])])
        step, spread = latency_step(latency, k)
        shift = shift_ns / 1e9
        if abs(step - shift) > max(HEADER_STEP_SPREADS * spread, 0.1 * abs(shift)):
            continue
        t_ns[k:] -= shift_ns
        latency[k:] -= shift
        moved += 1
        at = _named(np.array([k if s.index is None else s.index[k]]), t_ns[k:k + 1] + shift_ns, t_ns[0])[0]
        text = (f"{s.topic}, {at}, field '{STAMP_FIELDS['header']}': the header clock steps with the IMU's "
                f"({step:+.3f} s against the receive time): the stamps from this message on are moved back by "
                f"{shift:.3f} s, as the IMU's")
        say_doubted(meta, kind, source, text, HEADER_CLOCK_STEP, len(t_ns) - k, stacklevel=2)
    return dataclasses.replace(s, t_ns=t_ns) if moved else s


#: The IMU message's fields, in the order of ``f_b`` then ``omega_b`` (the IMU rows' names in refusal reasons).
IMU_MESSAGE_FIELDS = tuple(f"{v}.{a}" for v in ("linear_acceleration", "angular_velocity") for a in "xyz")


def imu(s: Stream, t0_ns: int, source: str, meta: dict) -> ImuData:
    """The IMU stream's samples (FRD, SI): a message holding no measurement (a NaN or infinite value, all six values
    exactly 0 as a logger's filler, a dead accelerometer beside a live gyro:
    :func:`graphnav.core.screening.imu_unmeasured`, the one rule a column map's rows get, the gap left bridged as
    any IMU gap) is refused, warned about (its index in the topic and its time) and counted in ``meta`` under the
    reasons a column map's row gets (``meta["imu_unmeasured_screened"]``: not judged again); more than half refused
    is a DataError (:func:`graphnav.core.screening.check_refused_fraction`), and so is such a run leaving a gap longer
    than can be bridged (naming the message after it, and the run as the topic's messages). A step of the IMU clock
    or a gap in every message's stamps is warned about and counted as a file's is
    (:func:`graphnav.core.screening.say_imu_stamp_steps`)."""
    f = np.array([vec(m.linear_acceleration) for m in s.rows])
    w = np.array([vec(m.angular_velocity) for m in s.rows])
    t = _rel(s, t0_ns)
    where = messages(s, t0_ns)
    topic = f"{source}:{s.topic}"
    # on every message's stamp, as a column map's rows before any is refused: the stamps of messages holding no
    # measurement are the IMU's clock still ticking, no samples lost (their gap is the run's to bridge)
    filler = s.twice.get(IMU_FILLER)       # those whose stamps were zeroed too, taken out before: no loss
    say_imu_stamp_steps(t, t, topic, STAMP_FIELDS[s.stamp_kind], meta, where=where, filler=filler_between(
        np.arange(len(s.rows)) if s.index is None else s.index, None if filler is None else filler[0]))
    unmeasured = imu_unmeasured(t, f, w, IMU_MESSAGE_FIELDS, topic, where=where, row=f"message(s) of {s.topic}")
    t, f, w = refuse_rows(meta, "imu", unmeasured, topic, None, t, f, w, where=where, fields=IMU_MESSAGE_FIELDS)
    meta["imu_unmeasured_screened"] = True
    if not frame_is(s.rows[0].header.frame_id, "_frd"):
        f, w = f @ FLU_FRD, w @ FLU_FRD
    return ImuData(t, f, w, topic)


# --- DVL ---------------------------------------------------------------------------------------------------
def _sigma_from_cov(cov: np.ndarray) -> np.ndarray:
    """Per-axis 1-sigma from a row-major 3x3 covariance; NaN when unknown (all zero or -1)."""
    cov = np.asarray(cov, float)
    if cov.size < 9:
        return np.full(3, np.nan)
    d = np.diag(cov[:9].reshape(3, 3))
    return np.where(np.isfinite(d) & (d > 0), np.sqrt(np.abs(d)), np.nan)


def _marine(s: Stream, source: str, info: dict):
    n = len(s.rows)
    beams, valid = no_beams(n)
    v_d, v_ok, sig = np.full((n, 3), np.nan), np.zeros(n, bool), np.full((n, 3), np.nan)
    mismatch, unit = 0, None
    for i, m in enumerate(s.rows):
        b = np.asarray(m.beam_velocity, float)
        ok = np.isfinite(b) & bool(m.beam_velocities_valid)
        beams[i], valid[i] = b, ok
        if m.beam_velocities_valid and int(ok.sum()) != int(m.num_good_beams):
            mismatch += 1
        v_d[i] = vec(m.velocity)
        # a velocity solution needs three beams; the message has no other validity flag for it
        v_ok[i] = int(m.num_good_beams) >= 3
        sig[i] = _sigma_from_cov(m.velocity_covar)
        vecs = np.array([vec(u) for u in m.beam_unit_vec])
        if unit is None and np.allclose(np.linalg.norm(vecs, axis=1), 1.0, atol=1e-3):
            unit = vecs
    if mismatch:
        warnings.warn(f"{source}:{s.topic}: {mismatch} ping(s) where num_good_beams differs from the finite "
                      "beam velocities; the per-beam values are used", RuntimeWarning, stacklevel=4)
    info["dvl_num_good_beams_mismatch"] = mismatch
    if unit is not None:
        info["beam_unit_vec_d"] = unit.tolist()
    return beams, valid, v_d, v_ok, sig


def _water_linked(s: Stream, source: str, info: dict):
    n = len(s.rows)
    beams, valid = no_beams(n)
    v_d, v_ok, sig = np.full((n, 3), np.nan), np.zeros(n, bool), np.full((n, 3), np.nan)
    unknown_id = 0
    for i, m in enumerate(s.rows):
        for k, beam in enumerate(m.beams):
            good_id = 0 <= int(beam.id) < 4
            unknown_id += not good_id
            j = int(beam.id) if good_id else k
            if j < 4:
                beams[i, j], valid[i, j] = float(beam.velocity), bool(beam.valid)
        v_d[i] = vec(m.velocity)
        v_ok[i] = bool(m.velocity_valid)
        if hasattr(m, "covariance"):          # the protocol v3 message only
            sig[i] = _sigma_from_cov(m.covariance)
    if unknown_id:
        warnings.warn(f"{source}:{s.topic}: {unknown_id} DVLBeam id(s) outside 0..3; list position used",
                      RuntimeWarning, stacklevel=4)
    return beams, valid, v_d, v_ok, sig


def _twist(s: Stream, config: SensorConfig, source: str, info: dict):
    """``TwistWithCovarianceStamped``: a ``frame_id`` naming the DVL holds the DVL's own velocity (frame d);
    any other frame is the body (FRD when it ends in ``_frd``, else REP-103 FLU), turned into d."""
    n = len(s.rows)
    frame_id = s.rows[0].header.frame_id
    C_d_b = config.dvl.C_d_b
    if "dvl" in frame_id.lower():
        R, how = np.eye(3), "DVL frame"
    else:
        B = np.eye(3) if frame_is(frame_id, "_frd") else FLU_FRD       # message frame -> FRD body
        R, how = C_d_b.T @ B, "body frame turned into the DVL frame with C_d_b"
    info["dvl_twist_frame"] = f"{frame_id or '(empty)'}: {how}"
    v_d, v_ok, sig = np.full((n, 3), np.nan), np.zeros(n, bool), np.full((n, 3), np.nan)
    for i, m in enumerate(s.rows):
        v_d[i] = R @ vec(m.twist.twist.linear)
        cov6 = np.asarray(m.twist.covariance, float).reshape(6, 6)
        # -1 on the diagonal is the drivers' "invalid measurement"
        v_ok[i] = bool(np.all(np.isfinite(v_d[i])) and cov6[0, 0] >= 0)
        cov = R @ cov6[:3, :3] @ R.T
        sig[i] = _sigma_from_cov(cov.reshape(9))
    return *no_beams(n), v_d, v_ok, sig


def dvl(s: Stream, t0_ns: int, config: SensorConfig, source: str, meta: dict) -> tuple[DvlData, dict]:
    """Beams (where the message has them) and the instrument's own velocity ``v_d`` with its validity and
    1-sigma, every invalid ping counted in ``meta["streams"]["dvl"]``."""
    info: dict = {"dvl_message": s.msgtype}
    fields, where = config.bag_topics.get("dvl"), messages(s, t0_ns)
    if fields:
        beams, valid, v_d, v_ok, sig = bag_fields.read(s, fields, config.dvl.C_d_b, source, meta, info, where)
    elif s.msgtype == MARINE_DVL:
        beams, valid, v_d, v_ok, sig = _marine(s, source, info)
    elif s.msgtype == WL_DVL:
        beams, valid, v_d, v_ok, sig = _water_linked(s, source, info)
    else:
        beams, valid, v_d, v_ok, sig = _twist(s, config, source, info)
    # A NaN velocity is a driver's "not computed" (the beams still count); a finite one beyond any DVL's
    # range is an invalid flag or a decoding error.
    unset = v_ok & ~np.all(np.isfinite(v_d), axis=1)
    if unset.any():
        info["dvl_v_d_not_finite"] = int(unset.sum())
    with np.errstate(invalid="ignore"):
        too_fast = v_ok & ~unset & np.any(np.abs(v_d) > MAX_DVL_SPEED_MPS, axis=1)
    if too_fast.any():
        warnings.warn(f"{source}:{s.topic}: {int(too_fast.sum())} DVL velocit(ies) beyond {MAX_DVL_SPEED_MPS:g} "
                      "m/s marked invalid", RuntimeWarning, stacklevel=3)
        add_note(meta, "dvl", f"{int(too_fast.sum())} instrument velocit(ies) beyond {MAX_DVL_SPEED_MPS:g} m/s not "
                              "used (their beams are)")
    v_ok &= ~too_fast & ~unset
    v_d = np.where(v_ok[:, None], v_d, np.nan)
    has_sigma = np.all(np.isfinite(sig[v_ok]), axis=1) if v_ok.any() else np.zeros(0, bool)
    v_d_sigma = None
    if has_sigma.size and has_sigma.all():
        v_d_sigma = np.where(v_ok[:, None], sig, np.nan)
    elif has_sigma.size and has_sigma.any():
        info["dvl_v_d_sigma"] = (f"not used: the message's covariance is missing on {int((~has_sigma).sum())} of "
                                 f"{has_sigma.size} valid pings (the configuration's noise is used)")
    beamless = ~valid.any(axis=1)
    unusable = beamless & ~v_ok
    if unusable.any():
        count_refused(meta, "dvl", "no valid beam and no valid velocity", int(unusable.sum()))
        warnings.warn(f"{source}:{s.topic}: {int(unusable.sum())} DVL ping(s) with no valid beam and no valid "
                      f"velocity (first at {located(np.flatnonzero(unusable), where=where, first=True)}) "
                      "are not used", RuntimeWarning, stacklevel=2)
    if s.msgtype == TWIST_DVL or (beamless.all() and v_ok.any()):
        add_note(meta, "dvl", f"velocity-only DVL ({s.msgtype}): the instrument's velocity v_d is used, no beams")
    # The instrument's body-frame velocity (v_b) where it has beams too; pings without >= 3 beams leave it NaN.
    v_b = np.where((valid.sum(axis=1) >= 3)[:, None], v_d @ config.dvl.C_d_b.T, np.nan)
    if np.any(~np.all(np.isfinite(v_b), axis=1) & (valid.sum(axis=1) >= 3)):
        v_b = None
        info["dvl_v_b"] = "not used: missing on pings with >= 3 valid beams"
    elif not np.isfinite(v_b).any():
        v_b = None
    out = DvlData(_rel(s, t0_ns), np.where(valid, beams, np.nan), valid, v_b, f"{source}:{s.topic}",
                  v_d=v_d, v_d_valid=v_ok, v_d_sigma=v_d_sigma)
    # the fields a later message about the stream names (the envelope's refusal, the unit checks): the velocity's,
    # which the envelope judges, else the beams' its velocity is solved from
    velocity, beam = (bag_fields.named_fields(fields) if fields
                      else DVL_MESSAGE_FIELDS.get(s.msgtype, DVL_MESSAGE_FIELDS[TWIST_DVL]))
    meta.setdefault("stream_fields", {})["dvl"] = velocity if v_b is not None or not beam else beam
    return out.sanitized(where=where), info


# --- depth -------------------------------------------------------------------------------------------------
def _surface_pressure(t_s: np.ndarray, p: np.ndarray, config: SensorConfig, configured: bool
                      ) -> tuple[float, str]:
    """The atmospheric pressure (Pa) subtracted from the readings, and why that value: the configured one, else
    the median of the leading readings (up to :data:`SURFACE_WINDOW_S`) that stay within
    :data:`SURFACE_MAX_DEV_PA` of the first, when the first lies in :data:`ATMOSPHERE_RANGE_PA` and they last
    at least a second (the vehicle floats while the recording starts)."""
    if configured:
        return config.atmospheric_pressure_pa, "SensorConfig.atmospheric_pressure_pa (configured)"
    lo, hi = ATMOSPHERE_RANGE_PA
    window = (t_s - t_s[0] <= SURFACE_WINDOW_S) & np.isfinite(p)
    still = window & (np.abs(p - p[0]) <= SURFACE_MAX_DEV_PA)
    run = int(np.argmin(still)) if not still.all() else len(p)      # length of the leading run
    if lo <= p[0] <= hi and run >= 3 and t_s[run - 1] - t_s[0] >= 1.0:
        return float(np.median(p[:run])), (f"estimated at the surface from the first {t_s[run - 1] - t_s[0]:.1f} s "
                                           f"({run} samples)")
    return config.atmospheric_pressure_pa, ("SensorConfig.atmospheric_pressure_pa (the record does not start at the "
                                            "surface)")


PRESSURE = "sensor_msgs/msg/FluidPressure"
#: The configuration key that declares a depth topic's convention (``SensorConfig.bag_topics``), as
#: ``csv_columns.depth.positive`` does a column's.
POSITIVE_KEY = "bag_topics.depth.positive"


def declared_positive(config: SensorConfig) -> str | None:
    """The depth convention the configuration declares (:data:`POSITIVE_KEY`): ``down``, ``up`` or None."""
    positive = (config.bag_topics.get("depth") or {}).get("positive")
    if positive not in (None, "down", "up"):
        raise ConfigError(f"{POSITIVE_KEY} = {positive!r}: choose down or up, for a depth topic (Float64/Float32)")
    return positive


def check_declared_positive(positive: str | None, chosen: Stream | None, source: str, meta: dict) -> None:
    """A declared convention (:data:`POSITIVE_KEY`) must fit the depth topic read: a ConfigError for a pressure
    topic (positive down by its physics), a warning when no depth topic is read (the key says nothing then)."""
    if positive is None:
        return
    if chosen is None:
        warnings.warn(f"{source}: {POSITIVE_KEY} = {positive!r} declared, but no depth topic is read: the key is "
                      "not used", RuntimeWarning, stacklevel=3)
    elif chosen.msgtype == PRESSURE:
        raise ConfigError(f"{POSITIVE_KEY} = {positive!r}: the depth is read from the pressure topic {chosen.topic} "
                          f"({chosen.msgtype}), whose depth is positive down; the key is for a depth topic "
                          "(Float64/Float32): drop it, or choose one with --topic depth=TOPIC")
    elif positive == "up":
        add_note(meta, "depth", f"{source}:{chosen.topic} declared positive up ({POSITIVE_KEY}): negated")


def depth_candidate(s: Stream, config: SensorConfig, configured_atm: bool, positive: str | None = None) -> dict:
    """A pressure/depth topic's depth (m, positive down) and its plausibility: ``ok`` and ``why``; a depth topic
    declared ``positive`` up (:data:`POSITIVE_KEY`) is negated."""
    t_s = s.t_ns / 1e9
    if s.msgtype == PRESSURE:
        p = np.array([m.fluid_pressure for m in s.rows], float)
        finite = p[np.isfinite(p)]
        lo, hi = WATER_PRESSURE_RANGE_PA
        if not finite.size or not np.any(finite):
            return {"ok": False, "why": "all zeros: not a water pressure (a leak or housing sensor?)"}
        inside = np.mean((finite >= lo) & (finite <= hi))
        if inside < 0.9:
            return {"ok": False, "why": f"only {inside:.0%} of the readings lie in the water pressure range "
                                        f"{lo / 1e3:g} kPa..{hi / 1e6:g} MPa (not Pa, or not water)"}
        p_atm, atm_why = _surface_pressure(t_s, p, config, configured_atm)
        depth = (p - p_atm) / (config.water_density_kgpm3 * config.gravity_mps2)
        extra = {"atmospheric_pressure_pa": p_atm, "atmosphere": atm_why}
    else:
        depth = np.array([m.data for m in s.rows], float) * (-1.0 if positive == "up" else 1.0)
        if not np.any(depth[np.isfinite(depth)]):
            return {"ok": False, "why": "all zeros"}
        extra = {}
    finite = depth[np.isfinite(depth)]
    spread = float(np.percentile(finite, 98) - np.percentile(finite, 2))
    if spread < MIN_DEPTH_VARIATION_M:
        return {"ok": False, "why": f"does not vary (2-98 % spread {spread:.3f} m < {MIN_DEPTH_VARIATION_M} m)",
                "spread_m": spread}
    return {"ok": True, "why": f"water pressure range, varies by {spread:.1f} m", "spread_m": spread,
            "depth": depth, **extra}


def choose_depth(candidates: dict[str, tuple[Stream, dict]], source: str, meta: dict) -> str | None:
    """The topic of the most plausible depth stream (the largest variation among the plausible ones), the
    choice and every rejection said in ``meta["depth_choice"]`` and a warning when there were several."""
    report = {topic: c["why"] for topic, (_, c) in candidates.items()}
    good = {t: c for t, (_, c) in candidates.items() if c["ok"]}
    chosen = max(good, key=lambda t: good[t]["spread_m"]) if good else None
    meta["depth_choice"] = {"chosen": chosen, "candidates": report}
    if len(candidates) > 1 or chosen is None:
        others = "; ".join(f"{t}: {w}" for t, w in report.items() if t != chosen)
        msg = (f"{source}: depth from {chosen} ({report[chosen]})" if chosen else f"{source}: no usable depth topic") \
            + (f"; not used: {others}" if others else "")
        warnings.warn(msg, RuntimeWarning, stacklevel=3)
    if chosen:
        add_note(meta, "depth", f"depth from {chosen}: {report[chosen]}"
                 + (f"; atmosphere {good[chosen]['atmospheric_pressure_pa']:.0f} Pa, {good[chosen]['atmosphere']}"
                    if "atmosphere" in good[chosen] else ""))
    return chosen


def depth(s: Stream, cand: dict, t0_ns: int, source: str, meta: dict, positive: str | None = None) -> DepthData:
    """The chosen depth stream, range-checked: depths above the surface beyond the tolerance or deeper than
    the ocean are dropped and counted. A depth topic whose convention is not declared (``positive`` None) and whose
    samples lie mostly above the surface is read as positive up (:func:`turned_positive_up`)."""
    d = cand["depth"]
    if positive is None and s.msgtype != PRESSURE:
        d = turned_positive_up(s, d, source, meta)
    checks = {f"above the surface by more than {DEPTH_ABOVE_SURFACE_TOL_M:g} m": d < -DEPTH_ABOVE_SURFACE_TOL_M,
              f"deeper than {MAX_DEPTH_M:g} m": d > MAX_DEPTH_M, "not finite": ~np.isfinite(d)}
    bad = np.zeros(len(d), bool)
    for reason, mask in checks.items():
        mask = mask & ~bad
        if mask.any():
            count_refused(meta, "depth", reason, int(mask.sum()))
            # undeclared, such a topic was turned (turned_positive_up): only a declared convention leaves it above
            up = reason.startswith("above") and s.msgtype != PRESSURE and mask.mean() > 0.5 and positive is not None
            warnings.warn(f"{source}:{s.topic}: {int(mask.sum())} depth sample(s) {reason} dropped (first at "
                          f"{located(np.flatnonzero(mask), where=messages(s, t0_ns), first=True)}, {d[mask][0]:.2f} m)"
                          + (_other_convention(positive) if up else ""), RuntimeWarning, stacklevel=3)
        bad |= mask
    meta["depth_where"] = [m for m, b in zip(messages(s, t0_ns), bad) if not b]
    return DepthData(_rel(s, t0_ns)[~bad], d[~bad], f"{source}:{s.topic}")


def _other_convention(positive: str) -> str:
    """The hint for a depth topic declared ``positive`` (down or up) whose samples lie mostly above the surface."""
    other = "up" if positive == "down" else "down"
    return f"; a depth topic positive {other}? declare {POSITIVE_KEY} '{other}' (declared {positive!r})"


def turned_positive_up(s: Stream, d: np.ndarray, source: str, meta: dict) -> np.ndarray:
    """``d`` (m) of a depth topic of undeclared convention, negated when most samples lie above the surface by more
    than :data:`DEPTH_ABOVE_SURFACE_TOL_M` (no vehicle does; a topic positive up does), as a column-map depth is:
    warned about naming the topic and its field, counted in ``meta["depth_turned_up"]``; the prepare step keeps it
    only if the vehicle's vertical velocity confirms it (:func:`graphnav.io.units.depth_convention`)."""
    with np.errstate(invalid="ignore"):
        above = d < -DEPTH_ABOVE_SURFACE_TOL_M
    if not above.mean() > 0.5:
        return d
    meta["depth_turned_up"] = int(len(d))
    said = (f"{int(above.sum())} of {len(d)} samples above the surface by more than {DEPTH_ABOVE_SURFACE_TOL_M:g} m: "
            "read as depth positive up and turned positive down (checked against the vehicle's vertical velocity "
            f"when the mission is prepared; {POSITIVE_KEY} declares it)")
    warnings.warn(f"{source}:{s.topic}, field 'data': {said}", RuntimeWarning, stacklevel=3)
    add_note(meta, "depth", f"{source}:{s.topic} field 'data': {said}")
    return -d


# --- heading -----------------------------------------------------------------------------------------------
def ahrs_check(rows) -> tuple[bool, str]:
    """Whether a ``sensor_msgs/Imu`` stream is an AHRS, and why: its orientation is filled
    (orientation_covariance[0] != -1, a non-zero quaternion) on most messages and is not one constant value
    (drivers without an orientation often publish the identity with a zero covariance)."""
    q = np.array([quat(m.orientation) for m in rows])
    filled = np.array([m.orientation_covariance[0] != -1 for m in rows]) & (np.linalg.norm(q, axis=1) > 0.5)
    if not rows or float(np.mean(filled)) <= 0.5:
        return False, "orientation not filled (orientation_covariance[0] = -1 or a zero quaternion)"
    if np.ptp(q[filled], axis=0).max() == 0.0:
        return False, f"orientation constant ({q[filled][0].round(3).tolist()}): a placeholder, not an AHRS"
    return True, "orientation filled"


def _C_b_n(q: np.ndarray, frame_id: str, world_frame_id: str = "") -> np.ndarray:
    """Body FRD -> NED from ROS orientations (child -> world): REP-103 FLU/ENU unless ``_frd``/``_ned``."""
    C = Rotation.from_quat(q).as_matrix()
    A = np.eye(3) if frame_is(frame_id, "_frd") or frame_is(world_frame_id, "_ned") else ENU_NED
    B = np.eye(3) if frame_is(frame_id, "_frd") else FLU_FRD
    return A @ C @ B


def _heading_from_C(C: np.ndarray, sigma: np.ndarray, t: np.ndarray, label: str, keep_tilt: bool) -> HeadingData:
    zyx = Rotation.from_matrix(C).as_euler("ZYX")
    return HeadingData(t, zyx[:, 0], sigma, zyx[:, 2] if keep_tilt else None, zyx[:, 1] if keep_tilt else None,
                       label)


def heading(s: Stream, t0_ns: int, source: str, meta: dict) -> HeadingData:
    """Heading aiding from an AHRS ``Imu`` orientation, a ``PoseWithCovarianceStamped``/``Odometry``
    orientation or a ``Float64``/``Float32`` heading topic (compass heading, clockwise from north, degrees
    when any value exceeds 2 pi, else radians)."""
    label = f"{source}:{s.topic}"
    t = _rel(s, t0_ns)
    if s.msgtype in ("std_msgs/msg/Float64", "std_msgs/msg/Float32"):
        yaw = np.array([m.data for m in s.rows], float)
        degrees = bool(np.nanmax(np.abs(yaw)) > 2 * np.pi + 0.1)
        add_note(meta, "heading", f"heading from {s.topic} ({s.msgtype}, compass heading in "
                                  f"{'degrees' if degrees else 'radians'}, {np.degrees(DEFAULT_HEADING_SIGMA_RAD):g} "
                                  "deg 1-sigma assumed)")
        yaw = np.radians(yaw) if degrees else yaw
        return HeadingData(t, (yaw + np.pi) % (2 * np.pi) - np.pi, np.full(len(t), DEFAULT_HEADING_SIGMA_RAD),
                           source=label)
    if s.msgtype == "sensor_msgs/msg/Imu":
        q = np.array([quat(m.orientation) for m in s.rows])
        var = np.array([m.orientation_covariance[8] for m in s.rows], float)
        frame_id, world = s.rows[0].header.frame_id, ""
        kind = "AHRS orientation (sensor_msgs/Imu)"
    else:
        pose = [m.pose.pose if hasattr(m.pose, "pose") else m.pose for m in s.rows]
        q = np.array([quat(p.orientation) for p in pose])
        var = np.array([np.asarray(m.pose.covariance, float)[35] for m in s.rows])
        world = s.rows[0].header.frame_id
        frame_id = getattr(s.rows[0], "child_frame_id", "") or "base_link"
        kind = f"orientation of {s.msgtype}"
    norm = np.linalg.norm(q, axis=1)
    bad = np.abs(norm - 1.0) > 1e-2
    if bad.any():
        count_refused(meta, "heading", "orientation quaternion not unit length", int(bad.sum()))
        warnings.warn(f"{label}: {int(bad.sum())} orientation(s) not of unit length dropped", RuntimeWarning,
                      stacklevel=3)
    sigma = np.where(np.isfinite(var) & (var > 0), np.sqrt(np.abs(var)), DEFAULT_HEADING_SIGMA_RAD)
    assumed = not np.any(np.isfinite(var) & (var > 0))
    add_note(meta, "heading", f"heading (and roll/pitch) from the {kind} on {s.topic}"
             + (f"; no variance given, {np.degrees(DEFAULT_HEADING_SIGMA_RAD):g} deg 1-sigma assumed"
                if assumed else "")
             + "; a magnetic heading needs the declination added")
    keep = ~bad
    C = _C_b_n(q[keep] / norm[keep, None], frame_id, world)
    return _heading_from_C(C, sigma[keep], t[keep], label, keep_tilt=True)


# --- reference ---------------------------------------------------------------------------------------------
def gt(s: Stream, t0_ns: int, source: str) -> GroundTruth:
    p = np.array([vec(m.pose.pose.position) for m in s.rows])
    q = np.array([quat(m.pose.pose.orientation) for m in s.rows])
    v_child = np.array([vec(m.twist.twist.linear) for m in s.rows])
    bad = np.flatnonzero(np.abs(np.linalg.norm(q, axis=1) - 1.0) > 1e-3)
    if bad.size:
        raise DataError(f"orientation quaternion not unit length (|q| = {np.linalg.norm(q[bad[0]]):.4f})",
                        f"{source}:{s.topic}", int(bad[0]), "pose.pose.orientation")
    C_child_world = Rotation.from_quat(q).as_matrix()
    world_ned = frame_is(s.rows[0].header.frame_id, "_ned")
    child_frd = frame_is(s.rows[0].child_frame_id, "_frd")
    A = np.eye(3) if world_ned else ENU_NED            # world -> NED
    B = np.eye(3) if child_frd else FLU_FRD            # FRD body -> child
    C_b_n = A @ C_child_world @ B
    p_n = p @ A.T
    v_n = np.einsum("kij,kj->ki", C_b_n, v_child @ B)  # twist is in the child frame; B is symmetric
    return GroundTruth(_rel(s, t0_ns), p_n, v_n, C_b_n, None, f"{source}:{s.topic}")


# --- position fixes ----------------------------------------------------------------------------------------
def fixes(s: Stream, t0_ns: int, source: str, meta: dict) -> PositionFixData | None:
    """GNSS fixes of a ``sensor_msgs/NavSatFix`` topic: latitude/longitude (deg -> rad) with the horizontal sigma
    ``sqrt(max(var_east, var_north))`` of ``position_covariance`` (ENU, m^2) where it is given, else
    :data:`DEFAULT_FIX_SIGMA_M`. Messages without a fix (status -1: a receiver under water), with a non-finite
    position or a sigma beyond :data:`~graphnav.core.mission.MAX_FIX_SIGMA_M`, and repeated stamps are refused
    and counted. None when nothing is left."""
    label = f"{source}:{s.topic}"
    t = _rel(s, t0_ns)
    status = np.array([m.status.status for m in s.rows], int)
    lat = np.radians(np.array([m.latitude for m in s.rows], float))
    lon = np.radians(np.array([m.longitude for m in s.rows], float))
    cov = np.array([np.asarray(m.position_covariance, float) for m in s.rows]).reshape(-1, 9)
    known = np.array([m.position_covariance_type for m in s.rows], int) > 0
    var = np.maximum(cov[:, 0], cov[:, 4])
    given = known & np.isfinite(var) & (var > 0)
    sigma = np.where(given, np.sqrt(np.where(given, var, 1.0)), DEFAULT_FIX_SIGMA_M)
    reasons = {"no fix (NavSatStatus -1)": status <= NAVSAT_NO_FIX,
               "latitude/longitude not finite or out of range": ~(np.isfinite(lat) & np.isfinite(lon)
                                                                  & (np.abs(lat) <= np.pi / 2)),
               f"sigma beyond {MAX_FIX_SIGMA_M:g} m": sigma > MAX_FIX_SIGMA_M}
    bad = np.zeros(len(t), bool)
    for reason, mask in reasons.items():
        mask = mask & ~bad
        if mask.any():
            count_refused(meta, "fix", reason, int(mask.sum()))
        bad |= mask
    order_bad = np.zeros(len(t), bool)
    last = -np.inf
    for i in np.flatnonzero(~bad):
        if t[i] <= last:
            order_bad[i] = True
        else:
            last = t[i]
    if order_bad.any():
        count_refused(meta, "fix", "stamp repeated or out of order", int(order_bad.sum()))
    keep = ~bad & ~order_bad
    if (~keep).any():
        warnings.warn(f"{label}: {int((~keep).sum())} of {len(t)} NavSatFix message(s) refused (no fix, bad position, "
                      "huge sigma or repeated stamp; counts in meta['streams'])", RuntimeWarning, stacklevel=3)
    if not keep.any():
        add_note(meta, "fix", f"no usable fix on {s.topic}")
        return None
    add_note(meta, "fix", f"GNSS fixes from {s.topic} ({int(keep.sum())} used)"
             + ("" if given[keep].all() else f"; {DEFAULT_FIX_SIGMA_M:g} m 1-sigma assumed where no covariance"
                                             " is given"))
    return PositionFixData(t[keep], lat[keep], lon[keep], sigma[keep], source=label)
