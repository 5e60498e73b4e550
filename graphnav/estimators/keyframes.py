"""Streaming keyframes: turn time-ordered sensor samples into the keyframes every estimator consumes.

No look-ahead: a keyframe is closed as soon as the IMU has passed its stamp, from the samples seen so far.

- **Keyframes** sit at the initial epoch, at every DVL ping and at every (decimated) position fix. When the
  DVL has been silent for longer than ``max_keyframe_gap_s`` since the last ping, IMU-only keyframes follow
  every ``imu_keyframe_interval_s`` from that ping, each decided half an interval after its stamp, and
  skipped when a ping arrives within that half interval (so none sits closer than half an interval before
  the next ping: the rule the whole-mission builder used with look-ahead, now without it).
- **IMU.** Sample j holds over ``[t_j, t_{j+1})`` (zero-order hold, GTSAM's convention). A keyframe between
  two IMU stamps splits that interval: each keyframe gets the zero-order-hold segments ``(f_b, omega_b, dt,
  lag)`` since the previous keyframe, ``lag`` being how far into its sample a segment starts. All-zero rows
  are dropped and gaps longer than :data:`graphnav.core.mission.IMU_GAP_PERIODS` periods are bridged by linear
  interpolation (warning, counted); the keyframe intervals over a gap carry the extra velocity and attitude
  variance of :func:`graphnav.core.mission.gap_variances`.
- **DVL.** A ping arrives as the :class:`Ping` the Navigator made (:meth:`Keyframer.add_ping`) and leaves in its
  keyframe as a copy (``dataclasses.replace``) that adds what the keyframer knows: the gyro rate at the ping
  and, when a completer is set (hybrid methods), the regressed beams and their sigmas from the shared
  :class:`~graphnav.estimators.history.BeamHistory`. The gyro rate at the ping (for the lever-arm term) is
  interpolated linearly between the centres of the IMU sample intervals around the ping (:func:`gyro_at`),
  the same for the graph and the EKF. An IMU-aware completer (``needs_imu``) also gets the last
  ``completer.imu_samples`` IMU samples up to the ping (:class:`~graphnav.estimators.imu_buffer.ImuWindowBuffer`,
  kept from the first sample on); without a usable window (not yet full, a bridged gap, another rate) it gets
  ``imu=None`` and completes the ping beam-only (``nets.ImuAutoCompleter``), counted per reason in
  :attr:`KeyframerStats.imu_window_missing`. A completer whose beam-only members need a shorter window of their
  own (``member_imu_samples``: the pivot completer fused with the networks) gets that one there instead, where it
  is clean, and its learning members see each fully measured ping with their window (``observe_imu_samples``).
  A completer with networks is bound to the mission's DVL first (``bind_dvl``, :mod:`graphnav.nets.dvl_match`): a
  network trained for a DVL whose beams point elsewhere leaves its pings to the average estimator (warning; counted
  in the completer's ``fallbacks["dvl"]``). Each ping enters the history with its stamp, so that a network also
  leaves to the average estimator a ping whose past pings are not spaced as it was trained for (a DVL pinging faster,
  a gap of several pings; ``fallbacks["period"]``, :mod:`graphnav.nets.dvl_match`), and the keyframer warns once.
- **DVL velocity.** A DVL-frame velocity the instrument measured itself (:meth:`Keyframer.add_dvl_velocity`:
  a velocity-only DVL, a 3-beam solution, an earth/ship-frame log) makes a ping too, carried in
  :attr:`Ping.v_d`. One ping is used once: when beams and a velocity arrive at the same stamp, a ping with at
  least :data:`MIN_BEAMS_OVER_VELOCITY` measured beams uses its beams (the velocity is counted in
  ``velocity_superseded``), else its velocity (its 1-2 beams are counted in ``beams_superseded``, with a
  warning). No completer runs on a velocity ping; its beams as the velocity implies them (``T_d v_d``) go into
  the completer's history as a measured ping.
- **Depth and heading** are sampled at a keyframe's stamp: interpolated between the samples around it when
  both have arrived, else extrapolated linearly from the last two samples, at most ``aiding_max_age_s`` old.
"""
from __future__ import annotations

import bisect
import dataclasses
import math
import warnings
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.dvl import DvlGeometry, off_period
from graphnav.core.errors import ConfigError
from graphnav.core.mission import IMU_GAP_PERIODS, IMU_RATE_TOLERANCE, ImuGap, check_imu_gap, gap_variances
from graphnav.core.imu_timing import (  # noqa: F401  (BURST_STEP_SHARE: read here before it moved)
    BURST_STEP_SHARE, CLOCK_PATTERN_STAMPS, IMU_PACKET_STEPS, PACKET_LOSS_CYCLES, awaits_packet_cycles, clock_words,
    imu_packet_limit, imu_stamp_quantum, imu_step_stats, packets_note, quantised_clock, restamp_packets,
    shared_stamp_packets,
    start_burst, start_burst_warning)
from graphnav.estimators.history import BeamHistory, run_sigma_of
from graphnav.estimators.imu_buffer import NO_WINDOW_REASONS, ImuWindowBuffer
from graphnav.estimators.types import ImuSegments, Keyframe, Ping, PositionFix


#: A ping with at least this many measured beams uses them rather than a DVL-frame velocity at the same stamp
#: (three beams determine the velocity the instrument would report, and the tightly coupled estimators use
#: them one by one); with fewer, the instrument's velocity measures all three axes and is used instead.
MIN_BEAMS_OVER_VELOCITY = 3


@dataclass
class KeyframeOptions:
    """Where keyframes go (s).

    Attributes:
        max_keyframe_gap_s: insert IMU-only keyframes once the DVL has been silent for longer than this.
        imu_keyframe_interval_s: spacing of IMU-only keyframes in such a gap.
        aiding_max_age_s: depth/heading older than this at a keyframe (with nothing newer) are not used.
        fix_min_interval_s: position fixes closer than this to the previous fix used are decimated.
    """

    max_keyframe_gap_s: float = 2.0
    imu_keyframe_interval_s: float = 1.0
    aiding_max_age_s: float = 1.5
    fix_min_interval_s: float = 1.0

    def __post_init__(self):
        if self.imu_keyframe_interval_s <= 0 or self.max_keyframe_gap_s < self.imu_keyframe_interval_s:
            raise ConfigError("need 0 < imu_keyframe_interval_s <= max_keyframe_gap_s")


@dataclass
class _Pending:
    t: float
    kind: str
    beams: Ping | None = None          # a beam ping at t, as it entered
    velocity: Ping | None = None       # a velocity ping at t, as it entered
    fix: PositionFix | None = None

    @property
    def has_ping(self) -> bool:
        return self.beams is not None or self.velocity is not None


@dataclass
class KeyframerStats:
    """Counters of what the keyframer dropped or repaired, and of the completions it made.

    ``regressed_pings`` / ``regressed_beams``: pings with beams regressed by the completer, and those beams.
    ``imu_window_missing``: pings an IMU-aware completer regressed without its own (``imu_samples``) IMU window
    (with none, or with its beam-only member's shorter one), per reason of
    :data:`~graphnav.estimators.imu_buffer.NO_WINDOW_REASONS` (None without an IMU-aware completer).
    ``velocity_pings``: pings that carry a DVL-frame velocity (:attr:`Ping.v_d`); ``velocity_superseded``:
    velocities not used because their ping had >= :data:`MIN_BEAMS_OVER_VELOCITY` measured beams;
    ``beams_superseded``: measured beams not used because their ping used its velocity.
    """

    zero_imu_rows: int = 0
    imu_gaps: list = field(default_factory=list)
    fixes_decimated: int = 0
    pings_before_start: int = 0
    pings_after_end: int = 0
    regressed_pings: int = 0
    regressed_beams: int = 0
    imu_window_missing: dict | None = None
    velocity_pings: int = 0
    velocity_superseded: int = 0
    beams_superseded: int = 0


#: IMU steps a keyframer measures the stream's period over (their median) before it judges gaps by it.
IMU_RATE_STEPS = 16
#: A live IMU in packets leaves each at the size two of its latest this many packets reached
#: (:meth:`PacketStamps.typical_size`).
PACKET_SIZES = 64
#: A live IMU that is no packets is watched for a clock as coarse as its period or coarser over its latest this many
#: stamps (:meth:`PacketStamps._watch_clock`; 20 s at 100 Hz).
CLOCK_WATCH_STAMPS = 2000
#: A repeated stamp on such a clock waits for the next stamp, whose room it is placed in (the next comes one grid step
#: later, two after a repeat whose own step was left empty), as long as the reorder window and this many grid steps
#: more (:meth:`PacketStamps._overdue`): an IMU arriving up to the window behind the other streams is still on time;
#: later, the IMU went silent.
CLOCK_WAIT_STEPS = 3
#: Samples of a live clock's stretch a line at the period is fitted over before it places them (:meth:`PacketStamps.
#: _on_line`), and fitted again every this many: its end is then within about a millisecond of the samples' times on a
#: 10 ms grid (over 50, a line running ahead of a 200 Hz IMU's stamps put a sample before the one let out before it).
CLOCK_LINE_SAMPLES = 100
#: Periods a live clock's sample may lie outside its stamp's grid step on the line before the line is given up (samples
#: lost, the rate changed) and fitted again from that sample (:meth:`PacketStamps._on_line`; offline the same slack).
CLOCK_LINE_SLACK_PERIODS = 0.5
#: Grid steps a live clock's stamps must span for the period measured on them (samples over time) to be said: a
#: grid step of error is then 3 % at most (a 200 Hz IMU in whole 10 ms found on its first four stamps read 6 ms).
CLOCK_PERIOD_STEPS = 30
#: Share of the period that the stamps' grid may make of a quantised stream's measured span: its period is measured
#: over as many steps as bring the grid's error under it (3334-5000 for a 400 Hz IMU in whole ms, 8-12.5 s: a grid
#: step over the median of the first steps, 2, 2.5 or 3 ms).
IMU_QUANTISED_SPAN_SHARE = 1e-4
#: A step under this share of the configured period, while a live IMU's first steps decide, may be within a packet
#: (its samples stamped on receipt 0.01-1.5 ms apart at 100 Hz): the samples are held until decided
#: (:meth:`PacketStamps._while_deciding`). Even stamps with jitter of a tenth of the period never make one.
PACKET_STEP_SHARE = 0.5
#: A live packet whose step from the packet before is over this many cycles came late (a delayed driver read, two
#: packets at once): it is held until its end and spread back whole from its last stamp, since its size is not known
#: when its first part has reached the typical size.
LATE_READ_CYCLES = 1.5


class ImuPeriod:
    """The IMU period gaps are judged against, s. A batch mission's configuration carries the measured rate
    (:func:`graphnav.calibration.preparation.prepare`); a live stream's configuration line may name another rate
    (100 Hz for an IMU at 20 Hz would make every step a gap). So the period is the median of the first
    :data:`IMU_RATE_STEPS` steps (:func:`~graphnav.core.imu_timing.imu_step_stats`: samples over time for stamps in
    bursts, the mean step for stamps quantised coarser than a tenth of it, measured then over as many steps as make
    the grid :data:`IMU_QUANTISED_SPAN_SHARE` of their span) when it is off the configured one by more than
    :data:`~graphnav.core.mission.IMU_RATE_TOLERANCE` (warned once), the configured one otherwise; before those
    steps, the longer of the configured one and the shortest step so far. Gaps are judged against the longer of
    the period and a burst's cycle. A burst the stream starts with (:func:`~graphnav.core.imu_timing.start_burst`:
    a driver's buffer emptied at once, 50 samples 0.1 ms apart read ``runs at 1e+04 Hz``) is left out of those steps,
    warned and counted (:attr:`start_burst`)."""

    def __init__(self, configured_s: float):
        self.configured_s = self.period_s = self._cycle_s = configured_s
        self._steps: list[float] = []
        self._needed = IMU_RATE_STEPS
        self._bridged: list[float] = []     # the gaps (s) bridged before the period was measured
        self._lead: list[float] | None = []     # the first steps, while they may be a burst the stream starts with
        #: (samples, first stamp s, last stamp s) of the burst the stream started with, or None
        self.start_burst: tuple[int, float, float] | None = None
        self._restamped_after = math.inf    # samples stamped after this (s) come put back on the period, not in packets

    def add_step(self, dt: float, t: float = math.nan) -> None:
        """One step between IMU stamps, s, ending at the stamp ``t`` (s) (once the period is measured, nothing
        changes). A step ending after the samples come restamped (:meth:`restamped`) measures the period from the
        steps before it, as the packets were received: the stream's samples put back on the period among them read
        313.6 Hz (packets of 10, two lost among the first five)."""
        if len(self._steps) >= self._needed or not dt > 0:
            return
        if t > self._restamped_after and self._lead is None and len(self._steps) >= IMU_RATE_STEPS:
            self._needed = len(self._steps)     # the packets as received decide, not the steps restamped after them
            self._measured()
            return
        lead = self._lead
        if lead is None:
            self._collect(dt)
            return
        lead.append(dt)
        n = start_burst(lead, self.configured_s)
        if n is None:
            return
        self._lead = None
        if n:
            span, end = sum(lead[:n]), t - sum(lead[n:])
            self.start_burst = (n + 1, end - span, end)
            warnings.warn(start_burst_warning(n, end, span), RuntimeWarning, stacklevel=4)
        rest = lead[n:]
        if any(not d < BURST_STEP_SHARE * self.configured_s for d in rest):   # packets longer than the steps taken
            self._needed = max(self._needed, len(rest))
        for d in rest:
            self._collect(d)

    def _collect(self, dt: float) -> None:
        if len(self._steps) >= self._needed:
            return
        self._steps.append(dt)
        if len(self._steps) == IMU_RATE_STEPS:
            quantum = imu_stamp_quantum(np.asarray(self._steps))
            if quantum:
                step = float(np.median(self._steps))
                self._needed = max(IMU_RATE_STEPS, math.ceil(quantum / (IMU_QUANTISED_SPAN_SHARE * step)))
                warnings.warn(f"imu: stamps on a {1e3 * quantum:.4g} ms grid, {quantum / step:.0%} "
                              "of a step: the period is their mean step, measured over the first "
                              f"{self._needed} steps", RuntimeWarning, stacklevel=5)
        if len(self._steps) == self._needed and awaits_packet_cycles(self._steps, self.configured_s):
            self._needed += IMU_RATE_STEPS
        if len(self._steps) < self._needed:
            self.period_s = max(self.configured_s, min(self._steps))
            return
        self._measured()

    def _measured(self) -> None:
        """The period and a burst's cycle from the steps collected, warned about when off the configured one."""
        measured, cycle = imu_step_stats(np.asarray(self._steps), self.configured_s, IMU_RATE_TOLERANCE)
        self.period_s = self.configured_s
        self._cycle_s = cycle if cycle > measured else self._cycle_s     # stamps in bursts
        if abs(measured - self.configured_s) > IMU_RATE_TOLERANCE * self.configured_s:
            self.period_s = measured
            warnings.warn(f"imu: runs at {1 / measured:.4g} Hz (from its first {len(self._steps)} steps, "
                          f"{1e3 * measured:.4g} ms), not the configured imu_rate_hz {1 / self.configured_s:g} Hz: "
                          f"gaps are judged against {1 / measured:.4g} Hz", RuntimeWarning, stacklevel=6)

    def is_gap(self, dt: float, t: float = -math.inf) -> bool:
        """Whether the newest step (``dt`` s, given to :meth:`add_step` first, ending at the stamp ``t`` s) is a gap
        to bridge: longer than :attr:`gap_limit_s`, or than the period's once the samples come restamped
        (:meth:`restamped`). Before the period is measured, a stream whose shortest step is under
        :data:`BURST_STEP_SHARE` of the configured period comes in bursts (a driver stamping on receipt), and its
        long step is a gap only when its samples so far fall short of the configured rate by more than a bridged
        gap adds (bursts of three every 30 ms at 100 Hz bridged their first five cycles as gaps); after a gap, only
        when longer than :data:`~graphnav.core.imu_timing.PACKET_LOSS_CYCLES` of the packets' cycles so far."""
        limit = IMU_GAP_PERIODS * self.period_s if t > self._restamped_after else self.gap_limit_s
        if not dt > limit:
            return False
        steps = self._lead or self._steps       # a start that may be a burst or a packet: its steps so far
        if len(self._steps) >= self._needed or not min(steps, default=dt) < BURST_STEP_SHARE * self.configured_s:
            return True
        if self._bridged:
            # a loss that cut the packet after it took its first samples, and a packet's step counts the next one's
            # time: counted against the rate they bridged a spurious 0.2 s gap after samples lost from 0.5 to 1.5 s
            # in packets of 20, and in packets of 8-12 a packet short of the one after the gap
            gap = dt > PACKET_LOSS_CYCLES * self._cycle_so_far(steps)
        else:
            gap = sum(steps) / self.configured_s - len(steps) > IMU_GAP_PERIODS - 1
        if gap:
            self._bridged.append(dt)
        return gap

    def _cycle_so_far(self, steps: list[float]) -> float:
        """The median packet cycle (s) among the ``steps`` before the newest (s), the gaps bridged left out; inf for
        none (the step after a gap the stream's first packet ends is a cycle)."""
        cycles = [d for d in steps[:-1] if not d < BURST_STEP_SHARE * self.configured_s and d not in self._bridged]
        return float(np.median(cycles)) if cycles else math.inf

    def restamped(self, t: float) -> None:
        """The samples stamped after ``t`` (s) come restamped at the period (:class:`PacketStamps` decided on packets
        there): a step between them is a gap against the period, not against the packets' cycle the first steps
        measured (a lost packet of 20 at 100 Hz, 0.21 s, stayed under 2.5 cycles, 0.5 s, and was held from the
        sample before it, unwarned). The packets before ``t`` (replayed after an alignment) are judged as before."""
        self._restamped_after = min(self._restamped_after, t)

    @property
    def gap_limit_s(self) -> float:
        """Steps of the samples as received longer than this are gaps, bridged
        (:data:`~graphnav.core.mission.IMU_GAP_PERIODS` periods), s."""
        return IMU_GAP_PERIODS * max(self.period_s, self._cycle_s)


class PacketStamps:
    """A live IMU's samples put back on its period when it comes in packets or bursts (k samples stamped together on
    receipt), as :func:`~graphnav.core.imu_timing.restamp_packets` does a log's: integrated at their packet's stamp they
    make zero-length steps then one k periods long. Its first :data:`IMU_RATE_STEPS` steps (or three packet cycles,
    :func:`~graphnav.core.imu_timing.awaits_packet_cycles`; a burst it starts with left out,
    :func:`~graphnav.core.imu_timing.start_burst`) decide, by :func:`~graphnav.core.imu_timing.imu_step_stats`;
    meanwhile each sample waits for the next step, and once one falls within a packet they are held until decided
    (:meth:`_while_deciding`), then leave as the packets after them; every sample of an IMU that is no packets passes
    with its own stamp. Then a packet ends at the next long step (:func:`~graphnav.core.imu_timing.imu_packet_limit`)
    or a step back, and leaves restamped, spread back from its last stamp; one of the typical size
    (:meth:`typical_size`) leaves with its last sample (no latency for packets of one size), a smaller one with the
    next packet's first sample (one cycle later: the Navigator holds its reorder buffer back meanwhile,
    :meth:`release_limit`, so that the packet is not squeezed into the time left).
    Samples of a packet beyond the typical size (a driver read of two packets at once) came after its first part left
    spread back from its stamp: their times are unknown. They wait for its end and follow that part at the period as
    far as the next packet leaves room (:meth:`_beyond`); the rest are refused by the caller (:attr:`unplaced`).
    Such a read that comes over half a cycle late (:data:`LATE_READ_CYCLES`) is held until its end instead and spread
    back whole, the reorder buffer held at the last packet's end from that end on (:meth:`release_limit`). A
    packet held when the newest stamp of any stream is two cycles past it has ended (the IMU went silent):
    :meth:`overdue` lets it out. The typical size is the largest two of the latest packets reached, so an IMU a little
    faster than its reads (100.2 Hz read every 200 ms: a packet of 21 about every 25) holds every packet of 20 a
    cycle. A packet stamped at or before the last stamp let out (a clock stepping back) is spread back at the
    period all the same and left to the reorder buffer. :data:`IMU_RATE_STEPS` packets of one sample in a row: the
    stream no longer comes in packets, and its samples pass as received again; a stream decided no packets is decided
    again from a step within a packet on (:meth:`_reopen`: a driver changing its read mode). An IMU that is no packets
    but whose stamps come from a clock about as coarse as its period or coarser (100 Hz logged in whole 10 ms with
    jitter, a 64 Hz IMU on a 15.625 ms timer, 200 Hz in whole 10 ms: :func:`~graphnav.core.imu_timing.quantised_clock`
    over its latest stamps) passes as received, but a sample repeating the stamp before it is its next sample: it waits
    for the next distinct stamp and is placed after its stamp at the period within the room before that one
    (:meth:`_place_repeats`); once :data:`CLOCK_LINE_SAMPLES` samples are in, every sample goes on a line at the period
    through its stamps' grid steps (:meth:`_on_line`). One sample to a stamp is never packets; packets sharing one
    stamp whose counts come to vary as a clock's are that clock from then on (:meth:`_packets_were_clock`)."""

    def __init__(self, configured_s: float, window_s: float = 0.0):
        self.configured_s = configured_s
        self.window_s = window_s        # how far (s) an IMU sample may arrive behind the newest of any stream
        #: the period packets are restamped at, s; 0 while undecided or for an IMU that is no packets
        self.period_s = 0.0
        self.restamped = 0              # samples given another stamp
        self.note: str | None = None    # what was found, once decided in packets
        self._steps: list[float] | None = []
        self._k = self._in_packet = self._singles = 0      # typical packet, samples of this one, one-sample packets
        self._sizes: deque[int] = deque(maxlen=PACKET_SIZES)     # the latest packets' sizes
        self._limit = math.inf          # steps over it end a packet, s
        #: the samples held while the first steps decide (each waits for the step after it: within a packet?)
        self._pending: list[tuple[float, tuple, tuple]] = []
        self._packets_seen = False      # a step within a packet among them: held until decided
        self._held: list[tuple[float, tuple, tuple]] = []
        self._last = self._out = -math.inf      # newest stamp received, and let out
        self._ties: list[float] = []    # the stamps while undecided, once one repeats (packets sharing one stamp?)
        #: (received stamp s, why) of samples of a driver read beyond its packet that have no place: to refuse
        self.unplaced: list[tuple[float, str]] = []
        #: (grid s, period s) of a clock about as coarse as the period or coarser its stamps come from, or None
        self.clock: tuple[float, float] | None = None
        self._watch: deque[float] = deque(maxlen=CLOCK_WATCH_STAMPS)    # the latest stamps, watched for a clock
        self._repeats = 0               # repeated stamps watched
        #: on a clock, (sample index in the stretch, its stamp's mid grid step s after the stretch's first stamp)
        self._line: deque[tuple[int, float]] = deque(maxlen=CLOCK_WATCH_STAMPS)
        self._line_origin, self._line_n = 0.0, 0     # the stretch's first stamp s, and samples in it
        self._fit: tuple[int, float, float] | None = None    # the line: (sample index, its time s, the period s)
        self._late = False              # the packet held came over half a cycle late: a read of two, held whole

    def add(self, t: float, f: tuple, w: tuple, after: float = -math.inf) -> list[tuple[float, tuple, tuple]]:
        """The samples (t s, f_b, omega_b) that leave with this one received, in time order, none stamped at or
        before ``after`` (s: what the caller has let go of already)."""
        last, self._last = self._last, t
        if self.clock:
            return self._on_clock(t, f, w, last, after)
        if self.period_s and not self._limit:   # packets sharing one stamp: perhaps a clock's grid steps
            self._watch.append(t)
        if not self.period_s:
            self._reopen(t - last)
            undecided = self._steps is not None
            if undecided and (t == last or self._ties):
                self._decide_shared(t, last)
            elif undecided and t > last > -math.inf:
                self._decide(t - last)
            if undecided:
                return self._while_deciding(t, f, w, last, after)
            if self._watch_clock(t, last):
                return self._on_clock(t, f, w, last, after)
            self._out = t
            return [(t, f, w)]
        return self._in_packets(t, f, w, last, after)

    def _while_deciding(self, t: float, f: tuple, w: tuple, last: float,
                        after: float) -> list[tuple[float, tuple, tuple]]:
        """A sample (stamped ``t`` s, after ``last`` s) while the first steps decide. Each waits for the step after
        it: one under :data:`PACKET_STEP_SHARE` of the configured period puts the samples in a packet, and from then
        on they are held until decided (passed as received, integrated at their packets' stamps they cost 0.25 m in
        the first second for packets of 20 at 100 Hz); else it passes as received, one step late (a stream with plain
        stamps waits for nothing: the reorder buffer holds it longer). Decided in packets, the held samples leave as the
        packets after them (:meth:`_in_packets`); decided no packets or a clock, as received."""
        clock = self._watch_clock(t, last)
        if self._steps is None:                 # decided on this sample
            held = self._as_received()
            if self.period_s:
                return self._refeed(held + [(t, f, w)], after)
            if clock:
                return held + self._on_clock(t, f, w, last, after)
            self._out = t
            return held + [(t, f, w)]
        self._packets_seen |= 0.0 <= t - last < PACKET_STEP_SHARE * self.configured_s
        out = [] if self._packets_seen else self._as_received()
        self._pending.append((t, f, w))
        return out

    def _undecided_out(self, after: float) -> list[tuple[float, tuple, tuple]]:
        """The samples held while deciding when the IMU goes silent or ends before it decides: with a packet among them,
        spread back from each packet's last stamp at the configured period (none at or before ``after``, s; as received,
        a loss of 1 s among the first packets made the keyframer read the IMU at 1e+05 Hz and bridge every later
        sample as a gap); else as received."""
        if not self._packets_seen:
            return self._as_received()
        held, self._pending, self._packets_seen = self._pending, [], False
        return self._spread_back(held, self.configured_s, PACKET_STEP_SHARE * self.configured_s, max(self._out, after))

    def _as_received(self) -> list[tuple[float, tuple, tuple]]:
        """The samples held while deciding, let out with their own stamps."""
        held, self._pending, self._packets_seen = self._pending, [], False
        if held:
            self._out = held[-1][0]
        return held

    def _held_from(self, t: float) -> float:
        """The first stamp (s) held while deciding, ``t`` (s) with none."""
        return self._pending[0][0] if self._pending else t

    def _refeed(self, held: list, after: float) -> list[tuple[float, tuple, tuple]]:
        """The samples held while deciding, decided in packets: ended and restamped as the packets after them (none
        at or before ``after``, s). The packets a long step among them ended leave whole, whatever their size (at the
        size decided, a larger one among them had samples refused beyond it)."""
        stamps = [s[0] for s in held]
        ended = max((j for j in range(1, len(held)) if not 0.0 <= stamps[j] - stamps[j - 1] <= self._limit), default=0)
        out, last = [], stamps[0]
        for j, (t, f, w) in enumerate(held):
            out += (self._on_clock(t, f, w, last, after) if self.clock
                    else self._in_packets(t, f, w, last, after, ended=j < ended))
            last = t
        return out

    def _in_packets(self, t: float, f: tuple, w: tuple, last: float, after: float,
                    ended: bool = False) -> list[tuple[float, tuple, tuple]]:
        """A sample of an IMU decided in packets, stamped ``t`` (s) after ``last`` (s): held until its packet ends,
        then restamped with it (see the class docstring); ``ended``: its packet is known to end at the next long step,
        so it does not leave at the typical size."""
        step = t - last
        long = step < 0.0 or step > self._limit
        if not self._limit and long and t > last and self._in_packet not in (0, self._k):
            clock = quantised_clock(np.asarray(self._watch))
            if clock is not None:
                return self._packets_were_clock(clock, t, f, w, last, after)
        out = self._packet_ended(after, t) if long else []
        if not self.period_s:                   # turned clean
            self._out = t
            return out + [(t, f, w)]
        if long:
            self._late = step > LATE_READ_CYCLES * self._k * self.period_s
        self._held.append((t, f, w))
        self._in_packet += 1
        whole = (len(self._held) >= self._k and self._in_packet == len(self._held)   # none of it let out yet
                 and not self._late and not ended)
        return out + self.flush(after) if whole else out

    def _reopen(self, step: float) -> None:
        """A stream decided no packets whose ``step`` (s) is under :data:`BURST_STEP_SHARE` of the period (a driver
        changing its read mode) is decided again on the steps that follow, as at its start: packets from there on
        are restamped, not bridged as a gap each (150 in 30 s of packets of 20)."""
        decided_plain = self._steps is None and not self.period_s and not self.clock
        if decided_plain and 0.0 < step < BURST_STEP_SHARE * self.configured_s:
            self._steps = []

    def _packet_ended(self, after: float, t: float) -> list[tuple[float, tuple, tuple]]:
        """The held samples of the packet a long step (to the stamp ``t``, s) ended, restamped; the typical packet and
        the one-sample packets in a row updated (:data:`IMU_RATE_STEPS` of them: no packets any more)."""
        out = self.flush(after, t)
        if self._in_packet:
            self._sizes.append(self._in_packet)
            self._k = self.typical_size()
        self._singles = self._singles + 1 if self._in_packet == 1 else 0
        self._in_packet = 0
        if self._singles >= IMU_RATE_STEPS:
            self.period_s, self._steps = 0.0, None
        return out

    def flush(self, after: float = -math.inf, before: float = math.inf,
              silent: bool = False) -> list[tuple[float, tuple, tuple]]:
        """The held samples restamped as one packet (the end of the data ends it), none at or before ``after``
        (s); those that follow a part of their packet let out already (:meth:`_beyond`; ``before``: the next
        packet's first stamp, s) at the period after it. A packet short of the typical size that the IMU went
        ``silent`` after, or that the next one follows by more than 1.5 cycles, lost its last samples, not its first:
        it follows the packet before at the period (:meth:`_lost_after`)."""
        if self._pending:           # undecided: nothing else is held
            return self._undecided_out(after)
        if self.clock:
            return self._place_repeats(after, before)
        held, self._held = self._held, []
        if not held:
            return []
        floor = max(self._out, after)
        if self._in_packet > len(held):
            return self._beyond(held, floor, before)
        received = np.array([s[0] for s in held])
        t = self._lost_after(received, floor, before, silent)
        if t is not None:
            self._out = float(t[-1])
            self.restamped += len(held)
            return [(float(ti), s[1], s[2]) for ti, s in zip(t, held)]
        return self._spread_back(held, self.period_s, math.inf, floor)

    def _spread_back(self, held: list, period: float, limit: float, floor: float) -> list[tuple[float, tuple, tuple]]:
        """The ``held`` samples, each packet (split at steps over ``limit``, s) spread back from its last stamp at
        ``period`` (s) after ``floor`` (s: what was let out) (:func:`~graphnav.core.imu_timing.restamp_packets`)."""
        received = np.array([s[0] for s in held])
        t = restamp_packets(received, period, limit, floor if received[-1] > floor else -math.inf)
        self.restamped += int(np.sum(t != received))
        self._out = float(t[-1])
        return [(float(ti), s[1], s[2]) for ti, s in zip(t, held)]

    def _lost_after(self, received: np.ndarray, floor: float, before: float, silent: bool) -> np.ndarray | None:
        """Stamps (s) at the period after ``floor`` (s, the packet before) for a short packet received at
        ``received`` (s) that a loss follows (``silent``, or the next packet at ``before``, s, more than 1.5 cycles
        later): spread back from its stamp, it left a second, spurious gap before it (0.110 s beside 1.810 s for
        samples lost from 28.5 to 30.4 s in packets of 20). None for any other packet, with no room before its
        stamp, or for one that a loss precedes too (it may have lost its first samples: the last ten of a packet
        between losses of 0.5-1.5 and 1.6-1.8 s went to 0.5 s)."""
        n, cycle = received.size, self._k * self.period_s
        loss = silent or (before < math.inf and before - received[-1] > PACKET_LOSS_CYCLES * cycle)
        if (n >= self._k or not loss or not floor > -math.inf or floor + n * self.period_s > received[-1]
                or received[-1] - floor > PACKET_LOSS_CYCLES * cycle):
            return None
        return floor + self.period_s * np.arange(1, n + 1)

    def _beyond(self, held: list, floor: float, before: float) -> list[tuple[float, tuple, tuple]]:
        """Samples of a driver read larger than the typical size (two packets read at once) that came after its
        first part left, spread back from its stamp: their times are unknown. They follow it at the period, as
        many as leave the next packet (of the typical size, received at ``before``, s) steps of at least 1 -
        :data:`~graphnav.core.mission.IMU_RATE_TOLERANCE` periods; the rest are left to refuse (:attr:`unplaced`)."""
        p = self.period_s
        room = (before - floor) / p - self._k * (1.0 - IMU_RATE_TOLERANCE)
        n = len(held) if before == math.inf else min(len(held), max(0, math.floor(room + 1e-9)))
        why = (f"a driver read of {self._in_packet} samples stamped together: {len(held)} beyond the packet size "
               f"of {self._k}, their times unknown, and no room at the period before the next packet for "
               f"{len(held) - n}")
        self.unplaced += [(s[0], why) for s in held[n:]]
        self.restamped += n
        if n:
            self._out = floor + n * p
        return [(floor + (j + 1) * p, s[1], s[2]) for j, s in enumerate(held[:n])]

    def typical_size(self) -> int:
        """The size a packet leaves at: the largest that two of the latest :data:`PACKET_SIZES` packets reached (one
        larger packet alone does not hold every later one a cycle; packets of 8-12 still leave whole). An IMU whose
        reads take one sample more now and then (100.2 Hz read every 200 ms: 21 about every 25th) keeps two such
        among the latest, and each smaller packet is held a cycle (release lag mean 0.276 s against 0.242 s for packets
        of 20 only)."""
        return sorted(self._sizes)[-2]

    def release_limit(self, newest: float) -> float:
        """The stamp (s) the reorder buffer may release up to while a packet is held: its first sample's place on
        the period when it grows to the typical size, the last packet's end for a late one (:data:`LATE_READ_CYCLES`,
        held whole); inf once ``newest`` (s, the newest stamp received) is two cycles past it (an IMU outage must not
        stall the other streams). With none held, the last packet's end while the next read is under two cycles late
        (``newest`` under three cycles past it): a driver read of two packets at once reaches back to it, and a
        keyframe cannot close without the IMU past it anyway; inf else. While the first steps decide, nothing once
        a packet is among the samples held (restamped, they go back up to a packet's length), else up to the one
        held."""
        if self._pending:
            return -math.inf if self._packets_seen else self._pending[0][0]
        if not self._held:
            late = self.period_s and not self.clock and newest - self._out < 3 * self._k * self.period_s
            return self._out if late else math.inf
        if self._overdue(newest):
            return math.inf
        if self.clock:
            return self._held[0][0]
        return self._out if self._late else self._held[0][0] - (self._k - 1) * self.period_s

    def overdue(self, newest: float, after: float = -math.inf) -> list[tuple[float, tuple, tuple]]:
        """The held packet restamped (:meth:`flush`, none at or before ``after``, s) once ``newest`` (s, the newest
        stamp received on any stream) is two cycles past its last stamp: the IMU went silent or stopped, so the
        packet has ended, and it must leave before the reorder buffer releases past it; else none. Samples held while
        the first steps decide leave (:meth:`_undecided_out`) once ``newest`` is past them by the reorder window and,
        with a packet among them, the longest the decision may take (:data:`~graphnav.core.imu_timing.
        IMU_PACKET_STEPS` configured periods: a loss among the first packets is still decided on), else two periods."""
        if self._pending:
            wait = (IMU_PACKET_STEPS if self._packets_seen else 2) * self.configured_s
            return self._undecided_out(after) if newest - self._pending[-1][0] > self.window_s + wait else []
        return self.flush(after, silent=True) if self._held and self._overdue(newest) else []

    def _overdue(self, newest: float) -> bool:
        """Whether the held samples waited long enough: ``newest`` (s, any stream's) past their last stamp by two
        packet cycles, or on a clock by the reorder window and :data:`CLOCK_WAIT_STEPS` grid steps (measured
        against any stream, three grid steps gave up on an IMU arriving 40 ms behind the DVL and placed its
        repeats on the next stamp: refused as duplicates)."""
        wait = self.window_s + CLOCK_WAIT_STEPS * self.clock[0] if self.clock else 2 * self._k * self.period_s
        return newest - self._held[-1][0] > wait

    def _watch_clock(self, t: float, last: float) -> bool:
        """Whether the stamps of an IMU that is no packets, ``t`` (s) the newest after ``last``, come from a clock
        about as coarse as its period or coarser: once :data:`~graphnav.core.imu_timing.CLOCK_PATTERN_STAMPS` stamps
        repeated, at each repeat :func:`~graphnav.core.imu_timing.quantised_clock` over the latest
        :data:`CLOCK_WATCH_STAMPS` decides (a clean IMU with a row written twice now and then has no clock's pattern);
        found, it is said once (:attr:`note`) and :attr:`clock` set."""
        if self.clock is None and not self.period_s:
            self._watch.append(t)
            self._repeats += t == last
            if t == last and self._steps is None and self._repeats >= CLOCK_PATTERN_STAMPS:
                clock = quantised_clock(np.asarray(self._watch))
                if clock is not None:
                    self._on_clock_found(clock, t, self._watch[-1] - self._watch[0])
        return self.clock is not None

    def _on_clock_found(self, clock: tuple[float, float], t: float, span_s: float,
                        before: str = "samples repeating a stamp before were refused as duplicate stamps") -> None:
        """The clock set and said once (:attr:`note`); its period (samples over time) named when the stamps it was
        found on span :data:`CLOCK_PERIOD_STEPS` grid steps (``span_s``, s): over four it read 6 ms for 200 Hz."""
        self.clock, self._steps, self._ties = clock, None, []
        self._watch.clear()
        words = clock_words(*clock, said=span_s >= CLOCK_PERIOD_STEPS * clock[0])
        self.note = (f"{words}: from t = {t:.3f} s a sample repeating the stamp before it is the next "
                     "sample, placed after that stamp at the period within the room before the next stamp, and "
                     f"after {CLOCK_LINE_SAMPLES} samples every sample on a line at the period through the mid-points "
                     "of their stamps' grid steps, fitted again as they come (counted in imu_restamped); "
                     f"{before}")

    def _packets_were_clock(self, clock: tuple[float, float], t: float, f: tuple, w: tuple, last: float,
                            after: float) -> list[tuple[float, tuple, tuple]]:
        """Packets sharing one stamp whose counts came to vary as a clock's (:func:`~graphnav.core.imu_timing.
        quantised_clock` over the stamps since they were decided): four grid steps of a 200 Hz IMU in whole 10 ms,
        or of 400 Hz, can hold a packet's count each. The held packet's first sample leaves at its stamp (unless a
        part of it left already), the rest are repeats placed before ``t`` (s), which passes (:meth:`_on_clock`)."""
        held, self._held = self._held, []
        first = held[:1] if self._in_packet == len(held) else []
        self.period_s, self._in_packet = 0.0, 0
        self._on_clock_found(clock, last, self._watch[-1] - self._watch[0], "the packets said before were its grid "
                             "steps, their samples spread back from their stamp")
        self._held = held[len(first):]
        return first + self._on_clock(t, f, w, last, after)

    def _on_clock(self, t: float, f: tuple, w: tuple, last: float, after: float) -> list[tuple[float, tuple, tuple]]:
        """A sample on a clock about as coarse as the period or coarser: one repeating the stamp ``last`` (s) waits
        for the next stamp; the next stamp lets the waiting ones out placed (:meth:`_place_repeats`, none at or before
        ``after``, s), then itself as received; once a line through the stamps is fitted (:meth:`_on_line`), every
        sample leaves on it as it arrives."""
        placed = self._on_line(t)
        if placed is not None:
            out = self._place_repeats(after, placed)
            self.restamped += int(placed != t)
            self._out = placed
            return out + [(placed, f, w)]
        if t == last:
            self._held.append((t, f, w))
            return []
        out = self._place_repeats(after, t if t > last else math.inf)
        self._out = t
        return out + [(t, f, w)]

    def _on_line(self, t: float) -> float | None:
        """The time (s) of a sample stamped ``t`` (s) on a clock: on the least-squares line at the period through
        the mid-points of the grid steps of the latest :data:`CLOCK_WATCH_STAMPS` samples of its stretch, as offline
        (:func:`~graphnav.core.imu_timing.restamp_quantised`), fitted again every :data:`CLOCK_LINE_SAMPLES`. Left at
        their stamps, the samples that do not repeat one are up to a grid step early at random (5.3 ms RMS for 100 Hz
        in whole 10 ms with 1 ms of jitter), which cost 0.05-0.11 m over 90 s where a constant offset of that size
        costs 0.01 m. None (the sample left to its stamp) for the first :data:`CLOCK_LINE_SAMPLES` of a stretch; a
        sample whose stamp's grid step the line misses by over :data:`CLOCK_LINE_SLACK_PERIODS` (samples lost, the
        rate changed) starts a stretch."""
        grid, period = self.clock
        n, placed = self._line_n, None
        if self._fit is not None:
            placed = self._fit[1] + self._fit[2] * (n - self._fit[0])
            slack = CLOCK_LINE_SLACK_PERIODS * period
            if not t - slack <= placed <= t + grid + slack:
                placed, self._fit = None, None
                self._line.clear()
        if not self._line:
            self._line_origin, n = t, 0
        self._line.append((n, t - self._line_origin + 0.5 * grid))
        self._line_n = n + 1
        if not self._line_n % CLOCK_LINE_SAMPLES:
            i, y = np.asarray(self._line).T
            slope, offset = np.polyfit(i - n, y, 1)
            self._fit = (n, self._line_origin + float(offset), float(slope))
        return placed

    def _place_repeats(self, after: float, before: float) -> list[tuple[float, tuple, tuple]]:
        """The held samples repeating a stamp s (after the one let out at it), placed at s + j * step, j = 1, 2 ...,
        step the clock's period or less where the next stamp (``before``, s; inf: unknown) leaves less room for them
        (n samples in one grid step: a sample pushed across the grid's edge before it), from ``after`` (s, what the
        caller let go of) when that is later than s; the restamped count updated."""
        held, self._held = self._held, []
        if not held:
            return []
        start = max(held[0][0], after)
        step = min(self.clock[1], (before - start) / (len(held) + 1))
        self.restamped += len(held)
        return [(start + (j + 1) * step, s[1], s[2]) for j, s in enumerate(held)]

    def _decided(self, k: int) -> None:
        """Packets of ``k`` found: the typical size until two of the packets that follow reach another."""
        self._k = k
        self._sizes.extend((k, k))
        self._watch.clear()         # a stream that turns clean again is watched for a clock from then on

    def _decide_shared(self, t: float, last: float) -> None:
        """Decide on the stamps so far once one repeats: packets sharing one stamp when
        :func:`~graphnav.core.imu_timing.shared_stamp_packets` says so over the whole packets received, four stamps or
        more, as a new one begins (the samples until then, and the rest of that one, repeat stamps and are refused
        downstream), a packet ending at any step; a clock coarser than the period
        (:func:`~graphnav.core.imu_timing.quantised_clock`) is said once and passes as received, a sample repeating a
        stamp placed after it (:meth:`_on_clock`); else the steps decide."""
        self._ties = self._ties or [last]
        whole = self._ties[1:] if t > last else []          # the first may be the end of a packet
        self._ties.append(t)
        packets = shared_stamp_packets(np.asarray(whole)) if len(set(whole)) >= 4 else None
        clock = quantised_clock(np.asarray(whole)) if packets is not None else None
        if clock is not None:
            self._on_clock_found(clock, t, whole[-1] - whole[0])
        elif packets is not None and packets[0] > 1:     # one sample to a stamp is no packets
            k, cycle, self.period_s = packets
            self._decided(k)
            self._watch.extend(whole + [t])     # watched for a clock whose grid steps held a packet's count so far
            self._steps, self._ties, self._limit = None, [], 0.0
            self.note = packets_note(self._k, cycle, self.period_s, f"stamps from t = {self._held_from(t):.3f} s "
                                     "(packets sharing "
                                     "one stamp; counted in imu_restamped)")
        elif t > last:
            self._decide(t - last)

    def _decide(self, dt: float) -> None:
        self._steps.append(dt)
        n = start_burst(self._steps, self.configured_s)        # a first packet or a buffer emptied at once
        steps = self._steps[n or 0:]
        if n is None or len(steps) < IMU_RATE_STEPS or awaits_packet_cycles(steps, self.configured_s):
            return
        self._steps = None
        period, cycle = imu_step_stats(np.asarray(steps), self.configured_s, IMU_RATE_TOLERANCE)
        limit = imu_packet_limit(np.asarray(steps), self.configured_s, IMU_RATE_TOLERANCE)
        if cycle > period and limit < period:
            self.period_s, self._limit = period, limit
            self._decided(round(cycle / period))
            self.note = packets_note(self._k, cycle, period, f"stamps from t = {self._held_from(self._last):.3f} s "
                                     "(counted in "
                                     "imu_restamped)")


class Keyframer:
    """Assemble keyframes from time-ordered samples (see the module docstring).

    Feed samples in time order with :meth:`add_imu`, :meth:`add_ping` (a replayed sample: :meth:`add_dvl`,
    :meth:`add_dvl_velocity`), :meth:`add_depth`, :meth:`add_heading`, :meth:`add_fix` (each returns the
    keyframes it closed); :meth:`start` sets the initial epoch (before it,
    only the last IMU sample is kept); :meth:`finish` closes what the end of the data allows.

    Args:
        config: sensor configuration (IMU rate).
        options: keyframe placement.
        completer: beam completer for the hybrid methods, or None. An IMU-aware one (``needs_imu``) must
            complete a ping beam-only when given ``imu=None`` (``beam_only``: ``graphnav.nets.ImuAutoCompleter``).
    """

    def __init__(self, config: SensorConfig, options: KeyframeOptions | None = None, completer=None):
        self.config = config
        self.options = options or KeyframeOptions()
        self.completer = completer
        self.history = BeamHistory(completer.n_past) if completer is not None else None
        if completer is not None:
            run_sigma_of(completer)     # refused here, not at an outage in the middle of a mission
        #: the graph's rehearsed outages (:mod:`graphnav.estimators.rehearsal`), set by the Navigator; None: none
        self.rehearsal = None
        self.stats = KeyframerStats()
        self._imu_buffer, self._member_samples, self._observe_samples = None, None, None
        if getattr(completer, "needs_imu", False):
            if getattr(completer, "beam_only", None) is None:
                raise ConfigError(f"{type(completer).__name__} needs the IMU window and has no beam-only completer for "
                                  "pings without one (the first 20 s, IMU gaps): wrap it in graphnav.nets.ImuAutoCompleter")
            self._imu_buffer = ImuWindowBuffer(completer.imu_samples, completer.imu_rate_hz)
            # the shorter window its beam-only member reads alone (None: it needs none), and the one its learning
            # members read (None: the completer's): checked here, not at a ping in the middle of a mission
            self._member_samples = getattr(completer, "member_imu_samples", None)
            self._observe_samples = getattr(completer, "observe_imu_samples", None)
            for name, n in (("member_imu_samples", self._member_samples),
                            ("observe_imu_samples", self._observe_samples)):
                self._imu_buffer.check_length(n, f"{type(completer).__name__}.{name}")
            self.stats.imu_window_missing = dict.fromkeys(NO_WINDOW_REASONS, 0)
            if abs(config.imu_rate_hz - completer.imu_rate_hz) > 0.02 * completer.imu_rate_hz:
                warnings.warn(f"the IMU runs at {config.imu_rate_hz:g} Hz and the IMU-aware completer wants "
                              f"{completer.imu_rate_hz:g} Hz: every ping's beams will be regressed beam-only "
                              "(counted in imu_window_missing['rate'])", RuntimeWarning, stacklevel=2)
        bind_dvl = getattr(completer, "bind_dvl", None)
        if bind_dvl is not None:
            unmatched = bind_dvl(DvlGeometry.from_spec(config.dvl).T_b)
            if unmatched:
                # attributed here, not to the caller, so that the Navigator's second keyframer (after aligning)
                # does not say it again under Python's default warning filter
                warnings.warn(f"dvl: the completer's networks do not serve this DVL: {'; '.join(unmatched)}. The "
                              "average estimator completes the pings they would have (counted in "
                              "completer_fallbacks['dvl']). If the DVL is the one they were trained for, check "
                              "dvl.theta_rad, dvl.psi_rad and dvl.C_d_b in the configuration; Graph-HN and Graph-HNP "
                              "complete without networks", RuntimeWarning, stacklevel=1)
        #: whether the warning on a ping whose past is not spaced as the network was trained has been given (once a
        #: run: a keyframer that takes over from another, as the Navigator's after aligning, takes this over too)
        self.warned_period = False
        self._T_d = DvlGeometry.from_spec(config.dvl).T_d
        self.imu_period = ImuPeriod(1.0 / config.imu_rate_hz)
        self._max_gap = self.options.max_keyframe_gap_s
        # IMU samples (t, f, w) from the one that covers the newest keyframe's stamp on (before the start:
        # the newest two)
        self._samples: list[tuple[float, tuple, tuple]] = []
        self._started = False
        self._index = 0
        self._t_kf: float | None = None                          # stamp of the newest keyframe
        self._anchor: float | None = None                        # newest ping (or start): fillers count from it
        self._pending: list[_Pending] = []                       # keyframes waiting for the IMU, by time
        self._depth: deque = deque(maxlen=64)
        self._heading: deque = deque(maxlen=64)
        self._last_fix_t = -math.inf
        self._gaps: list[ImuGap] = []
        self._n_imu = 0
        self._fill_i = 1                                         # next IMU-only keyframe: anchor + i * step

    # --- state -------------------------------------------------------------------------------------
    @property
    def samples(self) -> list[tuple[float, tuple, tuple]]:
        """The IMU samples (t, f_b, omega_b) from the one that covers the newest keyframe's stamp to the newest
        (read only)."""
        return self._samples

    def start(self, t0: float) -> list[Keyframe]:
        """Set the initial epoch t0 (s): keyframe 0 sits there (with a ping at exactly t0, if any)."""
        if self._started:
            raise ConfigError("Keyframer.start called twice")
        self._started = True
        self._anchor = t0
        self._pending.insert(0, _Pending(t0, "init"))
        return self._close_ready()

    # --- inputs (time order) ------------------------------------------------------------------------
    def add_imu(self, t: float, f_b, omega_b) -> list[Keyframe]:
        """An IMU sample (f_b m/s^2, omega_b rad/s: 3-tuples of floats) in time order."""
        if f_b[2] == 0.0 and not (any(f_b) or any(omega_b)):      # z first: gravity makes it non-zero
            self.stats.zero_imu_rows += 1
            if self.stats.zero_imu_rows == 1:
                warnings.warn(f"imu: all-zero IMU row at t = {t:.3f} s dropped (zero specific force is impossible "
                              "under gravity); further ones are counted", RuntimeWarning, stacklevel=3)
            return []
        samples = self._samples
        if samples:
            self.imu_period.add_step(t - samples[-1][0], t)
            if self.imu_period.is_gap(t - samples[-1][0], t):
                return self._bridge(samples[-1], (t, f_b, omega_b))
        return self._on_sample(t, f_b, omega_b)

    def add_ping(self, ping: Ping) -> list[Keyframe]:
        """A DVL ping as it entered (:meth:`Ping.from_beams` or :meth:`Ping.from_velocity`), in time order; a
        beam ping and a velocity ping at the same stamp are one ping (see the module docstring)."""
        if not self._started:
            self.stats.pings_before_start += 1
            return []
        slot = "velocity" if ping.is_velocity else "beams"
        for p in self._pending:
            if abs(p.t - ping.t) <= 1e-9:       # the initial epoch, a fix or the other half of this ping
                p.kind = "dvl"
                setattr(p, slot, ping)
                break
        else:
            if ping.t <= self._t_kf_or_start():       # at or before the newest keyframe: no place for it
                self.stats.pings_before_start += 1
                return []
            self._insert_pending(_Pending(ping.t, "dvl", **{slot: ping}))
        return self._close_ready()

    def add_dvl(self, t: float, beams, valid) -> list[Keyframe]:
        """A beam ping from a replayed sample (``beams`` (4,) m/s, ``valid`` (4,) bool): :meth:`add_ping`."""
        return self.add_ping(Ping.from_beams(t, beams, valid))

    def add_dvl_velocity(self, t: float, v_d, sigma) -> list[Keyframe]:
        """A DVL-frame velocity of the DVL head (``v_d`` (3,) m/s) measured by the instrument, with its one-sigma
        per DVL axis (``sigma`` (3,) m/s, NaN = the configured one), from a replayed sample: :meth:`add_ping`."""
        return self.add_ping(Ping.from_velocity(t, v_d, sigma))

    def add_depth(self, t: float, depth_m: float) -> list[Keyframe]:
        self._depth.append((t, depth_m))
        return []

    def add_heading(self, t: float, yaw: float, sigma: float) -> list[Keyframe]:
        if self._heading:
            # unwrap against the previous sample so that interpolation never crosses +-pi the long way
            prev = self._heading[-1][1]
            yaw = prev + (yaw - prev + math.pi) % (2 * math.pi) - math.pi
        self._heading.append((t, yaw, sigma))
        return []

    def add_fix(self, t: float, lat: float, lon: float, sigma_m: float) -> list[Keyframe]:
        """A horizontal position fix (rad, rad, m): its own keyframe unless decimated."""
        fix = PositionFix(t, lat, lon, sigma_m)
        if not self._started:
            return []
        if fix.t - self._last_fix_t < self.options.fix_min_interval_s:
            self.stats.fixes_decimated += 1
            return []
        self._last_fix_t = fix.t
        for p in self._pending:
            if abs(p.t - fix.t) <= 1e-9:
                p.fix = fix
                break
        else:
            self._insert_pending(_Pending(fix.t, "fix", fix=fix))
        return self._close_ready()

    def finish(self) -> list[Keyframe]:
        """End of data: IMU-only keyframes up to half an interval before the last IMU sample (if the DVL
        has been silent long enough) and every pending keyframe the IMU covers; later pings are dropped."""
        out = []
        if self._started and self._samples:
            out += self._close_ready()
            out += self._fill_gap(self._samples[-1][0])
        n_late = sum(1 for p in self._pending if p.has_ping)
        self.stats.pings_after_end += n_late
        self._pending.clear()
        return out

    # --- internals ----------------------------------------------------------------------------------
    def _insert_pending(self, p: _Pending) -> None:
        keys = [q.t for q in self._pending]
        self._pending.insert(bisect.bisect_right(keys, p.t), p)

    def _bridge(self, last, new) -> list[Keyframe]:
        t0, t1 = last[0], new[0]
        length = t1 - t0
        check_imu_gap(t0, t1, "imu")          # bounds the samples made below
        n_fill = int(math.ceil(length / self.imu_period.period_s)) - 1
        gap = ImuGap(self._n_imu - 1, t0, t1)
        self._gaps.append(gap)
        self.stats.imu_gaps.append(gap)
        warnings.warn(f"imu: gap of {length:.3f} s after t = {t0:.3f} s bridged by linear interpolation "
                      f"({n_fill} samples); velocity/attitude covariance inflated over it", RuntimeWarning,
                      stacklevel=4)
        f0, w0, f1, w1 = np.array(last[1]), np.array(last[2]), np.array(new[1]), np.array(new[2])
        out = []
        for i in range(1, n_fill + 1):
            u = i / (n_fill + 1)
            out += self._on_sample(t0 + length * u, tuple((1 - u) * f0 + u * f1), tuple((1 - u) * w0 + u * w1),
                                   bridged=True)
        out += self._on_sample(*new)
        return out

    def _on_sample(self, t: float, f: tuple, w: tuple, bridged: bool = False) -> list[Keyframe]:
        self._n_imu += 1
        if self._imu_buffer is not None:
            self._imu_buffer.push(t, f, w, bridged)
        samples = self._samples
        samples.append((t, f, w))
        if not self._started:
            if len(samples) > 2:
                del samples[0]
            return []
        out = self._close_ready() if self._pending and self._pending[0].t <= t else []
        if t - self._anchor > self._max_gap:
            out += self._fill_gap(t)
        return out

    def _t_kf_or_start(self) -> float:
        return self._t_kf if self._t_kf is not None else (self._pending[0].t if self._pending else math.inf)

    def _fill_gap(self, now: float) -> list[Keyframe]:
        """IMU-only keyframes in a DVL gap, decided at time ``now`` (see the module docstring)."""
        o = self.options
        step = o.imu_keyframe_interval_s
        out = []
        if self._t_kf is None:
            return out
        # a bound in keyframes, not in time: one filler per interval from the anchor to now, plus one per
        # pending ping (closing one moves the anchor back to it)
        for _ in range(int(max(now - self._anchor, 0.0) / step) + 2 + len(self._pending)):
            if not now - self._anchor > o.max_keyframe_gap_s:
                break
            t_f = self._anchor + self._fill_i * step
            if t_f + 0.5 * step > now + 1e-12:
                break
            if any(p.has_ping and t_f < p.t < t_f + 0.5 * step - 1e-12 for p in self._pending):
                break      # a ping closes within half an interval: it takes the filler's place
            self._fill_i += 1
            if t_f > self._t_kf + 1e-9 and not any(abs(p.t - t_f) <= 1e-9 for p in self._pending):
                self._insert_pending(_Pending(t_f, "imu"))
                out += self._close_ready()
        return out

    def _close_ready(self) -> list[Keyframe]:
        out = []
        pending, samples = self._pending, self._samples
        while pending and samples and pending[0].t <= samples[-1][0] + 1e-12:
            out.append(self._close(pending.pop(0)))
        return out

    def _take_segments(self, t: float) -> ImuSegments | None:
        """The zero-order-hold segments from the newest keyframe to t; the samples before the one that
        covers t are dropped."""
        t_open = self._t_kf
        samples = self._samples
        if t_open is None:       # keyframe 0: nothing to integrate; keep the sample that covers t0
            j = max(0, bisect.bisect_right(samples, t, key=stamp_of) - 1)
            del samples[:j]
            return None
        # samples[0] holds at t_open; samples[j] is the last one at or before t (it holds at t)
        j = max(0, bisect.bisect_right(samples, t, key=stamp_of) - 1)
        part = samples[:j + 2]
        stamps = [x[0] for x in part]
        starts = [max(ti, t_open) for ti in stamps[:j + 1]]
        ends = [min(te, t) for te in stamps[1:j + 1]] + [t]
        keep = [i for i in range(j + 1) if ends[i] > starts[i]]
        f = [part[i][1] for i in keep]
        w = [part[i][2] for i in keep]
        dt = [ends[i] - starts[i] for i in keep]
        lag = [starts[i] - stamps[i] for i in keep]
        del samples[:j]
        var_v, var_att = gap_variances(self._gaps, t_open, t) if self._gaps else (0.0, 0.0)
        if self._gaps:
            self._gaps = [g for g in self._gaps if g.t_end > t]
        if not dt:
            return ImuSegments(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0), var_v, var_att)
        return ImuSegments(np.array(f), np.array(w), np.array(dt), np.array(lag), var_v, var_att)

    def _close(self, p: _Pending) -> Keyframe:
        ping = self._choose_ping(p) if p.has_ping else None
        imu = self._take_segments(p.t)
        if p.has_ping or p.kind == "init":
            self._anchor, self._fill_i = p.t, 1
        kind = "dvl" if p.has_ping else p.kind
        kf = Keyframe(self._index, p.t, kind, imu, ping, self._sample(self._depth, p.t),
                      self._heading_at(p.t), p.fix)
        self._index += 1
        self._t_kf = p.t
        return kf

    def _choose_ping(self, p: _Pending) -> Ping:
        """The ping of a pending keyframe: its beams or its DVL-frame velocity, never both (module docstring)."""
        if p.velocity is None:
            return self._beam_ping(p.beams)
        n_beams = 0 if p.beams is None else p.beams.n_measured
        if n_beams >= MIN_BEAMS_OVER_VELOCITY:
            self.stats.velocity_superseded += 1
            return self._beam_ping(p.beams)
        if n_beams:
            self.stats.beams_superseded += n_beams
            if self.stats.beams_superseded == n_beams:
                warnings.warn(f"dvl: {n_beams} beam(s) of the ping at t = {p.t:.3f} s not used: the ping has fewer "
                              f"than {MIN_BEAMS_OVER_VELOCITY} and a DVL-frame velocity, which is used instead; "
                              "further ones are counted (beams_superseded)", RuntimeWarning, stacklevel=5)
        return self._velocity_ping(p.velocity)

    def _velocity_ping(self, ping: Ping) -> Ping:
        """The velocity ping with its gyro rate (no completer runs on it)."""
        self.stats.velocity_pings += 1
        if self.history is not None:
            # a measured ping for the completer's history: the beams the velocity implies
            self.history.push_measured(self._T_d @ ping.v_d, ping.t)
            if self.rehearsal is not None:
                self.rehearsal.interrupt()
            self._observe(ping.t, self._T_d @ ping.v_d)
        return dataclasses.replace(ping, omega_b=gyro_at(ping.t, self._samples))

    def _beam_ping(self, ping: Ping) -> Ping:
        """The beam ping with its gyro rate and, with a completer, its regressed beams and their sigmas."""
        t, measured = ping.t, ping.measured
        omega_b = gyro_at(t, self._samples)
        if self.history is None:
            return dataclasses.replace(ping, omega_b=omega_b)
        imu = None
        # a ping with beams to complete, and the intervals of its past pings (the newest one's to it), s
        completes = self.history.ready and not measured.all()
        past_dt = self.history.past_dt(t) if completes else None
        if self._imu_buffer is not None and completes:
            imu, reason = self._imu_buffer.window(t)
            if reason is not None and self._member_samples:
                # no window for the networks (the first 20 s, a gap): the members read their own shorter one
                imu = self._imu_buffer.window(t, self._member_samples)[0]
            if imu is not None and not self._pings_one_period_apart(past_dt):
                imu, reason = None, reason or "ping_dt"
            if reason is not None:
                self.stats.imu_window_missing[reason] += 1
        elif measured.all():
            self._observe(t, ping.beams)
        # only a ping with beams to complete can be refused for its past's spacing, and it is said once a run
        watch = not self.warned_period and completes
        off_period_before = self._period_fallbacks() if watch else 0
        result = self.history.complete(self.completer, np.where(measured, ping.beams, 0.0), measured, imu=imu, t=t)
        if watch and self._period_fallbacks() > off_period_before:
            self.warned_period = True
            warnings.warn("dvl: a ping is completed by the average estimator, not the completer's network: the "
                          "intervals of its past pings (the newest one's to the ping) are "
                          f"{', '.join(f'{x:.3g}' for x in past_dt)} s, not the spacing the network was trained "
                          "for (a DVL pinging faster than the one it was trained for, or a gap of several pings); "
                          "further ones are counted in completer_fallbacks['period']",
                          RuntimeWarning, stacklevel=1)
        if self.rehearsal is not None and (measured.all() or result is None):
            self._rehearse_measured(ping) if measured.all() else self.rehearsal.interrupt()
        if result is None:
            return dataclasses.replace(ping, omega_b=omega_b)
        beams, sigma = np.asarray(result[0], float), np.asarray(result[1], float)
        has_regressed = not measured.all()
        rehearsed = None
        if has_regressed:
            self.stats.regressed_pings += 1
            self.stats.regressed_beams += int((np.isfinite(beams) & ~measured).sum())
            if self.rehearsal is not None:
                self.rehearsal.interrupt()
                beams, sigma, rehearsed = self.rehearsal.decide(t, beams, sigma, np.isfinite(beams) & ~measured,
                                                                self.history.run_steps, measured)
        return dataclasses.replace(ping, beams=beams, sigma_regressed=sigma, has_regressed=has_regressed,
                                   omega_b=omega_b, rehearsed=rehearsed)

    def _rehearse_measured(self, ping: Ping) -> None:
        """A fully measured ping (already in the history) for the completer's side of the rehearsals, with the
        completer's IMU window (None without one)."""
        imu = self._imu_buffer.window(ping.t)[0] if self._imu_buffer is not None else None
        self.rehearsal.completer_ping(self.completer, ping.t, ping.beams, imu, self.history)

    def _period_fallbacks(self) -> int:
        """The pings the completer's networks have left to the average estimator for their past's ping period."""
        return getattr(self.completer, "fallbacks", {}).get("period", 0)

    def _observe(self, t: float, beams: np.ndarray) -> None:
        """Hand a ping whose four beams were all measured to a completer that learns from them (``observe``, e.g.
        :class:`graphnav.nets.pivot.PivotCompleter`'s online fit), with its IMU window when there is one: the
        completer's, or the shorter one its learning members read (``observe_imu_samples``), so that they learn from
        the pings they would learn from alone."""
        observe = getattr(self.completer, "observe", None)
        if observe is None:
            return
        imu = self._imu_buffer.window(t, self._observe_samples)[0] if self._imu_buffer is not None else None
        observe(t, np.asarray(beams, float), imu)

    def _pings_one_period_apart(self, past_dt: np.ndarray | None) -> bool:
        """Whether the history's pings and the ping being completed are the IMU-aware completer's ``ping_dt``
        apart (within :data:`~graphnav.core.dvl.PING_PERIOD_TOLERANCE` of it; ``past_dt``: their intervals, s,
        :meth:`BeamHistory.past_dt`): it propagates each past ping over that many seconds."""
        dt = getattr(self.completer, "ping_dt", None)
        if dt is None:
            return True
        return not off_period(past_dt, dt)

    def _sample(self, samples: deque, t: float) -> float | None:
        """Interpolate (or extrapolate from the last two) a scalar stream at t; None when too old."""
        if not samples:
            return None
        max_age = self.options.aiding_max_age_s
        after = [s for s in samples if s[0] >= t]
        before = [s for s in samples if s[0] <= t]
        if before and after:
            a, b = before[-1], after[0]
            if b[0] - a[0] <= 2 * max_age:
                return a[1] if b[0] == a[0] else a[1] + (b[1] - a[1]) * (t - a[0]) / (b[0] - a[0])
        if after and not before:
            return after[0][1] if after[0][0] - t <= 0.5 else None
        b = before[-1]
        if t - b[0] > max_age:
            return None
        if len(before) >= 2 and b[0] - before[-2][0] <= max_age:
            a = before[-2]
            return b[1] + (b[1] - a[1]) * (t - b[0]) / (b[0] - a[0])
        return b[1]

    def _heading_at(self, t: float):
        if not self._heading:
            return None
        yaw = self._sample(deque((s[0], s[1]) for s in self._heading), t)
        if yaw is None:
            return None
        sigma = min(self._heading, key=lambda s: abs(s[0] - t))[2]
        return (math.remainder(yaw, 2 * math.pi), sigma)


def gyro_at(t: float, samples: list[tuple[float, tuple, tuple]]) -> np.ndarray:
    """Raw gyro rate (3,) rad/s at a ping stamp t (s) from time-ordered IMU samples ``(t_k, f_b, omega_b)``.

    An IMU sample is the increment over ``[t_k, t_k+1]`` divided by the interval (the convention of the
    simulator and of GTSAM's zero-order-hold preintegration), i.e. the mean rate over the interval: the rate
    at the interval's centre to second order. The rate at t is interpolated linearly between the centres of
    the two intervals around t, and held beyond the first centre. Only the samples up to the first one after
    t are used (its centre is taken half the previous interval after its stamp), so the result does not
    depend on how many later samples have arrived. ``experiments/gyro_at_ping.py`` measures this rule against the
    simulator's true rate: 2e-8..1.4e-7 rad/s RMS at the pings, where the sample nearest the ping is off by
    7e-6..9.3e-5 rad/s and interpolation between the sample stamps by 4.5e-5..6.5e-5 rad/s; the lever arm
    turns a rate error into a beam error ``|l| |d omega|``.
    """
    i = bisect.bisect_right(samples, t, key=stamp_of) - 1        # the sample at or before t
    if i < 0:
        return np.array(samples[0][2], float)
    n = min(len(samples), i + 2)
    if n == 1:
        return np.array(samples[0][2], float)

    def centre(k: int) -> float:
        t_k = samples[k][0]
        return 0.5 * (t_k + samples[k + 1][0]) if k + 1 < n else t_k + 0.5 * (t_k - samples[k - 1][0])

    i = min(i, n - 1)
    c_i = centre(i)
    j = i + 1 if t >= c_i else i - 1                 # the neighbouring interval on t's side of the centre
    if j < 0 or j >= n:
        return np.array(samples[i][2], float)
    u = (t - c_i) / (centre(j) - c_i)
    return (1.0 - u) * np.asarray(samples[i][2], float) + u * np.asarray(samples[j][2], float)


def stamp_of(sample: tuple) -> float:
    """The stamp of a (t, ...) sample tuple (a sort key)."""
    return sample[0]
