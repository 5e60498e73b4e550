"""The loaders' side of :mod:`graphnav.core.streams`: fill ``Mission.meta["streams"]`` from the streams a loader
built, with the DVL pings it refused and why.

A DVL ping is *used* when it has at least one valid beam or a valid instrument velocity ``v_d`` (the graph
and the tightly coupled EKF use single beams); every other ping is *refused* under the first reason that
applies: the loader's own reasons (an RDI flag, outside the vehicle's envelope, ...), then
:data:`NO_VALID_BEAM`. Pings with 1-3 valid beams are used, and ``graphnav info`` shows how many beams pings
had. A ping with no valid beam measures nothing, but the hybrid methods regress all its beams there (completed, not
measured): its warning says so.
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from graphnav.core.imu_timing import shown_rate_hz
from graphnav.core.mission import OUTSIDE_SPAN_TOLERANCE_S, Mission
from graphnav.core.screening import located
from graphnav.core.streams import add_note, count_read, count_refused, set_span, stream_entry

#: Reason of a ping with no valid beam and no valid instrument velocity that no loader reason explains.
NO_VALID_BEAM = "no valid beam (flagged invalid, NaN or RDI -32768 in the file)"
#: Reason of a ping outside the IMU's time span (the estimators cannot use it).
OUTSIDE_IMU_SPAN = "outside the IMU time span"


def dvl_used(dvl) -> np.ndarray:
    """(M,) bool: pings with a valid beam or a valid instrument velocity."""
    used = np.asarray(dvl.valid, bool).any(axis=1)
    if dvl.v_d is not None and dvl.v_d_valid is not None:
        used |= np.asarray(dvl.v_d_valid, bool)
    return used


def record_streams(meta: dict, *, imu=None, dvl=None, depth=None, gt=None,
                   dvl_refused: dict[str, np.ndarray] | None = None, dvl_lines: np.ndarray | None = None) -> dict:
    """Count every given stream as read (``count_read``) and refuse the DVL pings that are not used, by reason.

    Args:
        meta: the mission's ``meta`` (its ``"streams"`` entry is created or added to).
        imu, dvl, depth, gt: the streams the loader built (``ImuData``, ``DvlData``, ``DepthData``,
            ``GroundTruth``), each with ``t`` and ``source``; None for a stream the input does not have.
        dvl_refused: reason -> (M,) bool mask of pings the loader refused for that reason (first reason in
            the dict wins); the loader has warned about them.
        dvl_lines: (M,) the file line of each DVL ping, for the warning (without them it names the ping's index).

    The pings not used and not under a loader reason are counted under :data:`NO_VALID_BEAM`, with a warning.
    Returns ``meta["streams"]``.
    """
    for name, stream in (("imu", imu), ("dvl", dvl), ("depth", depth), ("gt", gt)):
        if stream is None:
            continue
        rate = shown_rate_hz(name, stream.t)
        if meta.get("streams", {}).get(name, {}).get("read"):      # a reader counted it; the stamps may have moved
            set_span(meta, name, stream.t, rate)
        else:
            count_read(meta, name, stream.t, stream.source, rate)
    if dvl is not None:
        left = ~dvl_used(dvl)
        for reason, mask in (dvl_refused or {}).items():
            hit = left & np.asarray(mask, bool)
            count_refused(meta, "dvl", reason, int(hit.sum()))
            left &= ~hit
        if left.any():
            first = int(np.flatnonzero(left)[0])
            where = (f"line {int(dvl_lines[first])}, t = {dvl.t[first]:.3f} s" if dvl_lines is not None
                     else located([first], t=dvl.t, first=True))
            warnings.warn(f"{dvl.source}: {int(left.sum())} of {len(left)} DVL ping(s) have no valid beam (first at "
                          f"{where}): nothing is measured there; only the hybrid methods use them, with the beams "
                          "their completer regresses", RuntimeWarning, stacklevel=3)
            count_refused(meta, "dvl", NO_VALID_BEAM, int(left.sum()))
    return meta.get("streams", {})


def record_outside_span(mission: Mission) -> None:
    """Count the used DVL pings outside the IMU span (``Mission.validate`` warns about them when they are
    further than ``OUTSIDE_SPAN_TOLERANCE_S`` out; the estimators skip them all)."""
    if "dvl" not in mission.meta.get("streams", {}) or not len(mission.imu.t):
        return
    t = mission.dvl.t
    outside = dvl_used(mission.dvl) & ((t < mission.imu.t[0]) | (t > mission.imu.t[-1]))
    if outside.any():
        count_refused(mission.meta, "dvl", OUTSIDE_IMU_SPAN, int(outside.sum()))
        _name_stamp_jump(mission, outside)
        near = np.all((t[outside] >= mission.imu.t[0] - OUTSIDE_SPAN_TOLERANCE_S)
                      & (t[outside] <= mission.imu.t[-1] + OUTSIDE_SPAN_TOLERANCE_S))
        if near:
            add_note(mission.meta, "dvl", f"{int(outside.sum())} ping(s) within {OUTSIDE_SPAN_TOLERANCE_S:g} s "
                                          "outside the IMU span (the end of a recording) not used")


def _name_stamp_jump(mission: Mission, outside: np.ndarray) -> None:
    """Warn about and note a step of the DVL stamps longer than an IMU gap can be (:data:`MAX_IMU_BRIDGE_S`) that
    takes pings (``outside``: the used ones outside the IMU span) out of the IMU span: a clock that jumped (a time
    zone set mid-log) loses them as surely as an outage, and the outage and outside-span warnings did not say why."""
    from graphnav.core.screening import MAX_IMU_BRIDGE_S, whole_hours
    t = mission.dvl.t
    steps = np.flatnonzero(np.diff(t) > MAX_IMU_BRIDGE_S)
    jumps = [i for i in steps if outside[i + 1:].all() or outside[:i + 1].all()]
    if not jumps:
        return
    i = int(jumps[0])
    text = (f"the DVL stamps jump by {t[i + 1] - t[i]:+.3f} s between ping indexes {i} and {i + 1} ({t[i]:.3f} -> "
            f"{t[i + 1]:.3f} s{whole_hours(t[i + 1] - t[i])}): a clock step rather than an outage; the "
            f"{int(outside.sum())} ping(s) it puts outside the IMU span are not used; correct the stamps")
    add_note(mission.meta, "dvl", text)
    warnings.warn(f"{mission.dvl.source}: {text}", RuntimeWarning, stacklevel=4)


#: What to do about a depth or reference whose span is off the IMU's (:func:`warn_off_the_imu_clock`).
OFF_THE_IMU_CLOCK_FIX = {"depth": "put the depth stamps on the IMU clock",
                         "gt": "give gt_time_offset_s (s added to the reference stamps) in the configuration",
                         "heading": "choose another heading topic (--topic heading=TOPIC) or put its stamps on the "
                                    "IMU clock"}
#: Reason of the samples inside the IMU span of a depth or reference stream on a clock of its own: on another
#: clock they would be used at the wrong time.
OFF_THE_IMU_CLOCK = "inside the IMU span, but on a clock of its own (the stream is off the IMU span)"


def warn_off_the_imu_clock(mission: Mission, fields: dict[str, str]) -> Mission:
    """The mission without a depth, reference or heading stream whose span is off the IMU's once it is prepared
    (:func:`graphnav.core.timeseries.on_the_imu_clock`), each warned about, noted, marked not usable in
    ``meta["streams"]`` (``usable`` False, ``reason``) and every sample counted as refused (:data:`OUTSIDE_IMU_SPAN`,
    :data:`OFF_THE_IMU_CLOCK` for the few inside the span): all are optional, so the estimators run without the
    depth or heading (the aligner gyrocompasses, or takes the initial heading) and the commands score nothing, as
    without them. Kept, the estimators would take the samples inside the span at the wrong time, and scoring failed
    on the reference. ``fields``: each stream's stamp field."""
    from graphnav.core.timeseries import on_the_imu_clock, overlap_text
    t_imu, left_out = mission.imu.t, {}
    for stream, data in (("depth", mission.depth), ("gt", mission.gt), ("heading", mission.heading)):
        if data is None or not len(data.t) or not len(t_imu) or on_the_imu_clock(data.t, t_imu):
            continue
        outside = int(np.sum((data.t < t_imu[0]) | (data.t > t_imu[-1])))
        what = "reference" if stream == "gt" else stream
        off = (f"[{data.t[0]:.3f}, {data.t[-1]:.3f}] s lie off the IMU span [{t_imu[0]:.3f}, {t_imu[-1]:.3f}] s "
               f"(sharing {overlap_text(data.t, t_imu)}): a clock of its own")
        reason = f"its stamps {off}"
        inside = f" and the {len(data.t) - outside} inside it" if outside < len(data.t) else ""
        text = (f"field '{fields.get(stream, 't')}': the {what} stamps {off}; the "
                f"{outside} of {len(data.t)} sample(s) outside the IMU span{inside} are not used: the {what} is "
                f"left out; {OFF_THE_IMU_CLOCK_FIX[stream]}")
        leave_out(mission.meta, stream, data.source, reason, text,
                  {OUTSIDE_IMU_SPAN: outside, OFF_THE_IMU_CLOCK: len(data.t) - outside})
        left_out[stream] = None
    return dataclasses.replace(mission, **left_out) if left_out else mission


#: Reason of the samples of a depth the vertical motion places seconds from its stamps
#: (:func:`graphnav.io.units.depth_off_its_stamps`): inside the IMU span, they would be used at the wrong time.
DEPTH_OFF_ITS_STAMPS = "on a clock of its own: its changes match the vertical velocity seconds from its stamps"


def leave_out(meta: dict, stream: str, source: str, reason: str, text: str, refused: dict[str, int]) -> None:
    """An optional stream left out of the mission: warned about (naming ``source``), noted (``text``), marked not
    usable in ``meta["streams"]`` (``reason``) and its samples counted as refused (``refused``: reason -> count)."""
    for why, n in refused.items():
        count_refused(meta, stream, why, n)
    add_note(meta, stream, text)
    stream_entry(meta, stream).update(usable=False, reason=reason)
    warnings.warn(f"{source}: {text}", RuntimeWarning, stacklevel=4)


def check_dvl_on_imu_clock(mission: Mission, what_to_do: str = "put the DVL stamps on the IMU clock",
                           field: str = "t") -> None:
    """DataError naming the DVL source, both time spans and ``what_to_do`` when the span of the usable DVL pings is
    off the IMU's (:func:`graphnav.core.timeseries.on_the_imu_clock`: they share less than half of the shorter span):
    the DVL is on another clock, and the estimators would refuse the stream (``graphnav info`` called such a mission
    usable, ``graphnav smooth`` then failed on it). A DVL that only logged longer than the IMU passes: its pings
    outside the IMU span are counted (:func:`record_outside_span`) and skipped."""
    from graphnav.core.errors import DataError
    from graphnav.core.timeseries import on_the_imu_clock, overlap_text
    used = dvl_used(mission.dvl)
    t, t_imu = mission.dvl.t[used], mission.imu.t
    if not used.any() or on_the_imu_clock(t, t_imu):
        return
    outside = int(np.sum((t < t_imu[0]) | (t > t_imu[-1])))
    raise DataError(f"{outside} of {int(used.sum())} usable DVL pings lie outside the IMU span [{t_imu[0]:.3f}, "
                    f"{t_imu[-1]:.3f}] s (DVL stamps [{t[0]:.3f}, {t[-1]:.3f}] s, sharing {overlap_text(t, t_imu)}): "
                    f"the DVL is on a clock of its own, and the estimators cannot use it; {what_to_do}",
                    mission.dvl.source, field=field)


def ensure_streams(mission: Mission) -> dict:
    """``mission.meta["streams"]``, recorded from the mission's streams when no loader did (a simulated or
    hand-built mission)."""
    if not mission.meta.get("streams"):
        record_streams(mission.meta, imu=mission.imu, dvl=mission.dvl, depth=mission.depth, gt=mission.gt)
    return mission.meta["streams"]
