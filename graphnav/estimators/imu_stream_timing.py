"""When a live IMU's samples were taken, decided as they come: its period, and its samples put back on it.

The live counterpart of :mod:`graphnav.core.imu_timing`, which decides on a whole file's stamps; live, a sample's
stamp is decided from the stamps before it and a few after it, and every rule here uses that module's tests.

- :class:`PacketStamps` (the Navigator's, before its reorder buffer) decides, in this order: its first steps tell
  an IMU whose driver stamps samples in packets or bursts (or whose packets share one stamp) from one that is no
  packets, the samples held meanwhile once a step falls within a packet; packets are then held until they end and
  leave spread back from their last stamp at the period (a late driver read held whole, samples beyond a packet
  placed after it or left to refuse, a stream that turns clean passed as received, one decided clean decided again);
  a stream that is no packets is watched for a clock as coarse as its period or coarser, and once found its repeated
  stamps are placed within the room before the next stamp and, after enough samples, every sample on a line at the
  period through its stamps' grid steps (packets sharing one stamp whose counts vary as a clock's turn out to be
  that clock).
- :class:`ImuPeriod` (the keyframer's, after the reorder buffer) measures the period gaps are judged against from
  the first steps (a burst the stream starts with left out) and says which steps are gaps to bridge.

The Navigator asks :class:`PacketStamps` three things besides each sample's :meth:`~PacketStamps.add`:
:meth:`~PacketStamps.release_limit`, the stamp its reorder buffer may release up to while samples are held (what a
held packet will be spread over must not leave before it); :meth:`~PacketStamps.overdue`, the held samples once
the newest stamp of any stream shows the IMU went silent (queued before the buffer releases past them); and
:meth:`~PacketStamps.flush` at the end of the data. When the samples come restamped, it tells the keyframer's
:class:`ImuPeriod` where (:meth:`ImuPeriod.restamped`). Why, and the numbers measured:
docs/decisions/loading-and-prepare.md ("An IMU at another rate than configured").
"""
from __future__ import annotations

import math
import warnings
from collections import deque

import numpy as np

from graphnav.core.imu_timing import (
    BURST_STEP_SHARE, CLOCK_PATTERN_STAMPS, IMU_PACKET_STEPS, PACKET_LOSS_CYCLES, awaits_packet_cycles, clock_words,
    imu_packet_limit, imu_stamp_quantum, imu_step_stats, packets_note, quantised_clock, restamp_packets,
    shared_stamp_packets, start_burst, start_burst_warning)
from graphnav.core.mission import IMU_GAP_PERIODS, IMU_RATE_TOLERANCE


#: IMU steps a keyframer measures the stream's period over (their median) before it judges gaps by it.
IMU_RATE_STEPS = 16
#: A live IMU in packets leaves each at the size two of its latest this many packets reached
#: (:meth:`PacketStamps.typical_size`).
PACKET_SIZES = 64
#: A live IMU that is no packets is watched for a clock as coarse as its period or coarser over its latest this many
#: stamps (:meth:`LiveClock.watch`; 20 s at 100 Hz).
CLOCK_WATCH_STAMPS = 2000
#: A repeated stamp on such a clock waits for the next stamp, whose room it is placed in (the next comes one grid step
#: later, two after a repeat whose own step was left empty), as long as the reorder window and this many grid steps
#: more (:meth:`LiveClock._overdue`): an IMU arriving up to the window behind the other streams is still on time;
#: later, the IMU went silent.
CLOCK_WAIT_STEPS = 3
#: Samples of a live clock's stretch a line at the period is fitted over before it places them (:meth:`LiveClock.
#: _on_line`), and fitted again every this many: its end is then within about a millisecond of the samples' times on a
#: 10 ms grid (over 50, a line running ahead of a 200 Hz IMU's stamps put a sample before the one let out before it).
CLOCK_LINE_SAMPLES = 100
#: Periods a live clock's sample may lie outside its stamp's grid step on the line before the line is given up (samples
#: lost, the rate changed) and fitted again from that sample (:meth:`LiveClock._on_line`; offline the same slack),
#: this one by a period more; the latest :data:`CLOCK_LINE_RUN` grid steps' samples by :data:`CLOCK_LINE_MEAN_PERIODS`
#: on average.
CLOCK_LINE_SLACK_PERIODS = 0.5
#: Periods a live clock's latest samples may miss their grid steps' mid-points by on average (a sample lost moves every
#: later one a period): half a period caught the lag of a line fitted over 2000 samples of a rate drifting 1 % in 120 s
#: and put samples back at their stamps out of order.
CLOCK_LINE_MEAN_PERIODS = 0.75
#: Grid steps whose samples' mean miss of their stamps' grid steps' mid-points decides whether a live clock's line is
#: given up (:meth:`LiveClock._line_broken`): a sample lost moves every later one a period, a sample pushed across a
#: grid edge by jitter one alone a grid step (as far: samples mid-step with 2 ms of jitter on a 10 ms grid gave the
#: line up once in 290 samples on that one's miss, each time 100 samples left at their stamps).
CLOCK_LINE_RUN = 16
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
#: Samples a live IMU may hold while its first steps decide (2 s at 100 Hz): past it, the packets among them that have
#: ended leave spread back at the configured period, as they would undecided (:meth:`PacketStamps._held_too_long`).
#: Packets of 20 decide within 80 held (99 sharing one stamp), losing 0.5-1.5 and 1.6-1.8 s among the first within
#: 180 (spread back undecided, a packet cut by a loss left a spurious gap); packets of 1-3 at random took 255 and
#: held the first estimate 2.57 s.
PACKET_HOLD_STEPS = 200
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
            if not cycle > measured:    # no bursts: nor is the configured period a cycle (kept, a 0.5 s loss of
                self._cycle_s = measured    # 100 Hz configured at 4 Hz stayed under 2.5 of its 0.25 s, unsaid)
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
    is watched for a clock about as coarse as its period or coarser that its stamps come from (:meth:`_watch_clock`);
    found, the :class:`LiveClock` places every sample from then on. One sample to a stamp is never packets; packets
    sharing one stamp whose counts come to vary as a clock's are that clock from then on (:meth:`_packets_were_clock`).
    """

    def __init__(self, configured_s: float, window_s: float = 0.0):
        self.configured_s = configured_s
        self.window_s = window_s        # how far (s) an IMU sample may arrive behind the newest of any stream
        #: the period packets are restamped at, s; 0 while undecided or for an IMU that is no packets
        self.period_s = 0.0
        self._restamped = 0             # samples given another stamp in packets (:attr:`restamped`)
        self.note: str | None = None    # what was found, once decided in packets
        self._steps: list[float] | None = []
        self._k = self._in_packet = self._singles = 0      # typical packet, samples of this one, one-sample packets
        self._sizes: deque[int] = deque(maxlen=PACKET_SIZES)     # the latest packets' sizes
        self._limit = math.inf          # steps over it end a packet, s
        #: the samples held while the first steps decide (each waits for the step after it: within a packet?)
        self._pending: list[tuple[float, tuple, tuple]] = []
        self._packets_seen = False      # a step within a packet among them: held until decided
        #: the stamp (s) the reorder buffer may release up to while they are held: let out before their first packet
        self._hold_floor = -math.inf
        self._spread_held = False       # some left spread back, held too long (:meth:`_held_too_long`)
        self._held: list[tuple[float, tuple, tuple]] = []
        self._last = self._out = self._out_before = -math.inf      # newest stamp received, let out, and before it
        self._ties: list[float] = []    # the stamps while undecided, once one repeats (packets sharing one stamp?)
        #: (received stamp s, why) of samples of a driver read beyond its packet that have no place: to refuse
        self.unplaced: list[tuple[float, str]] = []
        self._late = False              # the packet held came over half a cycle late: a read of two, held whole
        self.live_clock = LiveClock(window_s)   # watched for among the stamps; places every sample once found

    @property
    def clock(self) -> tuple[float, float] | None:
        """(grid s, period s) of a clock about as coarse as the period or coarser its stamps come from, or None."""
        return self.live_clock.found

    @property
    def deciding(self) -> bool:
        """Whether samples are held while the first steps decide (:meth:`_while_deciding`)."""
        return bool(self._pending)

    @property
    def restamped(self) -> int:
        """Samples given another stamp: spread back in packets, or placed on a clock."""
        return self._restamped + self.live_clock.restamped

    def add(self, t: float, f: tuple, w: tuple, after: float = -math.inf) -> list[tuple[float, tuple, tuple]]:
        """The samples (t s, f_b, omega_b) that leave with this one received, in time order, none stamped at or
        before ``after`` (s: what the caller has let go of already)."""
        last, self._last = self._last, t
        if self.clock:
            return self.live_clock.add(t, f, w, last, after)
        if self.period_s and not self._limit:   # packets sharing one stamp: perhaps a clock's grid steps
            self.live_clock.watch_stamps([t])
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
                return self.live_clock.add(t, f, w, last, after)
            self._let_out([t])
            return [(t, f, w)]
        return self._in_packets(t, f, w, last, after)

    def _while_deciding(self, t: float, f: tuple, w: tuple, last: float,
                        after: float) -> list[tuple[float, tuple, tuple]]:
        """A sample (stamped ``t`` s, after ``last`` s) while the first steps decide. Each waits for the step after
        it: one under :data:`PACKET_STEP_SHARE` of the configured period puts the samples in a packet, and from then
        on they are held until decided (passed as received, integrated at their packets' stamps they cost 0.25 m in
        the first second for packets of 20 at 100 Hz); else it passes as received, one step late (a stream with plain
        stamps waits for nothing: the reorder buffer holds it longer). Decided in packets, the held samples leave as the
        packets after them (:meth:`_in_packets`); decided no packets or a clock, as received. Held beyond
        :data:`PACKET_HOLD_STEPS`, they leave as undecided (:meth:`_held_too_long`)."""
        clock = self._watch_clock(t, last)
        if self._steps is None:                 # decided on this sample
            spread, self._spread_held = self._spread_held and not self.period_s and not clock, False
            if spread:      # no packets, after some left spread back as undecided: the rest, this one's packet too
                self._pending.append((t, f, w))
                return self._undecided_out(after)
            held = self._as_received()
            if self.period_s:
                return self._refeed(held + [(t, f, w)], after)
            if clock:
                return held + self.live_clock.add(t, f, w, last, after)
            self._let_out([t])
            return held + [(t, f, w)]
        if not self._packets_seen and self._within_packet(t - last):
            # the packet began with the sample before: held still, or let out already (a decision opened again)
            self._packets_seen, self._hold_floor = True, self._out if self._pending else self._out_before
        out = [] if self._packets_seen else self._as_received()
        self._pending.append((t, f, w))
        return out + self._held_too_long(after)

    def _held_too_long(self, after: float) -> list[tuple[float, tuple, tuple]]:
        """The packets that ended among the samples held while deciding once these are more than
        :data:`PACKET_HOLD_STEPS`, spread back from each packet's last stamp at the configured
        period as undecided (none at or before ``after``, s); the packet still arriving stays held."""
        held = self._pending
        if not self._packets_seen or len(held) <= PACKET_HOLD_STEPS:
            return []
        starts = [j for j in range(1, len(held)) if not self._within_packet(held[j][0] - held[j - 1][0])]
        if not starts:
            return []
        self._pending = held[starts[-1]:]
        out = self._spread_undecided(held[:starts[-1]], after)
        self._hold_floor, self._spread_held = self._out, True
        return out

    def _undecided_out(self, after: float) -> list[tuple[float, tuple, tuple]]:
        """The samples held while deciding when the IMU goes silent or ends before it decides: with a packet among them,
        spread back from each packet's last stamp at the configured period (none at or before ``after``, s; as received,
        a loss of 1 s among the first packets made the keyframer read the IMU at 1e+05 Hz and bridge every later
        sample as a gap); else as received."""
        if not self._packets_seen:
            return self._as_received()
        held, self._pending, self._packets_seen = self._pending, [], False
        return self._spread_undecided(held, after)

    def _within_packet(self, step: float) -> bool:
        """Whether a ``step`` (s) while the first steps decide may be within a packet (:data:`PACKET_STEP_SHARE`)."""
        return 0.0 <= step < PACKET_STEP_SHARE * self.configured_s

    def _spread_undecided(self, held: list, after: float) -> list[tuple[float, tuple, tuple]]:
        """Samples ``held`` while deciding, each packet (split at steps not :meth:`_within_packet`) spread back from
        its last stamp at the configured period, none at or before ``after`` (s)."""
        return self._spread_back(held, self.configured_s, PACKET_STEP_SHARE * self.configured_s, max(self._out, after))

    def _as_received(self) -> list[tuple[float, tuple, tuple]]:
        """The samples held while deciding, let out with their own stamps."""
        held, self._pending, self._packets_seen = self._pending, [], False
        if held:
            self._let_out([s[0] for s in held])
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
            out += (self.live_clock.add(t, f, w, last, after) if self.clock
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
            clock = self.live_clock.watched_clock()
            if clock is not None:
                return self._packets_were_clock(clock, t, f, w, last, after)
        out = self._packet_ended(after, t) if long else []
        if not self.period_s:                   # turned clean
            self._let_out([t])
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
        it follows the packet before at the period (:meth:`_lost_after`). On a clock, its repeats held placed
        (:meth:`LiveClock.flush`)."""
        if self._pending:           # undecided: nothing else is held
            return self._undecided_out(after)
        if self.clock:
            return self.live_clock.flush(after, before)
        held, self._held = self._held, []
        if not held:
            return []
        floor = max(self._out, after)
        if self._in_packet > len(held):
            return self._beyond(held, floor, before)
        received = np.array([s[0] for s in held])
        t = self._lost_after(received, floor, before, silent)
        if t is not None:
            self._let_out(t)
            self._restamped += len(held)
            return [(float(ti), s[1], s[2]) for ti, s in zip(t, held)]
        return self._spread_back(held, self.period_s, math.inf, floor)

    def _spread_back(self, held: list, period: float, limit: float, floor: float) -> list[tuple[float, tuple, tuple]]:
        """The ``held`` samples, each packet (split at steps over ``limit``, s) spread back from its last stamp at
        ``period`` (s) after ``floor`` (s: what was let out) (:func:`~graphnav.core.imu_timing.restamp_packets`)."""
        received = np.array([s[0] for s in held])
        t = restamp_packets(received, period, limit, floor if received[-1] > floor else -math.inf)
        self._restamped += int(np.sum(t != received))
        self._let_out(t)
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
        self._restamped += n
        out = [(floor + (j + 1) * p, s[1], s[2]) for j, s in enumerate(held[:n])]
        if out:
            self._let_out([s[0] for s in out])
        return out

    def _let_out(self, stamps) -> None:
        """The stamps (s) of the samples just let out, in time order: the newest is what later samples follow, the
        one before it what a decision opened again holds the reorder buffer back to (:meth:`_while_deciding`)."""
        self._out_before = float(stamps[-2]) if len(stamps) > 1 else self._out
        self._out = float(stamps[-1])

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
        keyframe cannot close without the IMU past it anyway; inf else. While the first steps decide, once a packet
        is among the samples held, up to the sample let out before its first (restamped, they go back up to a
        packet's length, not before it; at the stream's start, nothing), else up to the one held. On a clock, the
        clock's (:meth:`LiveClock.release_limit`)."""
        if self._pending:
            return self._hold_floor if self._packets_seen else self._pending[0][0]
        if self.clock:
            return self.live_clock.release_limit(newest)
        if not self._held:
            late = self.period_s and newest - self._out < 3 * self._k * self.period_s
            return self._out if late else math.inf
        if self._overdue(newest):
            return math.inf
        return self._out if self._late else self._held[0][0] - (self._k - 1) * self.period_s

    def overdue(self, newest: float, after: float = -math.inf) -> list[tuple[float, tuple, tuple]]:
        """The held packet restamped (:meth:`flush`, none at or before ``after``, s) once ``newest`` (s, the newest
        stamp received on any stream) is two cycles past its last stamp: the IMU went silent or stopped, so the
        packet has ended, and it must leave before the reorder buffer releases past it; else none. Samples held while
        the first steps decide leave (:meth:`_undecided_out`) once ``newest`` is past them by the reorder window and,
        with a packet among them, the longest the decision may take (:data:`~graphnav.core.imu_timing.
        IMU_PACKET_STEPS` configured periods: a loss among the first packets is still decided on), else two periods.
        On a clock, the clock's (:meth:`LiveClock.overdue`)."""
        if self._pending:
            wait = (IMU_PACKET_STEPS if self._packets_seen else 2) * self.configured_s
            return self._undecided_out(after) if newest - self._pending[-1][0] > self.window_s + wait else []
        if self.clock:
            return self.live_clock.overdue(newest, after)
        return self.flush(after, silent=True) if self._held and self._overdue(newest) else []

    def _overdue(self, newest: float) -> bool:
        """Whether the held packet waited long enough: ``newest`` (s, any stream's) past its last stamp by two
        packet cycles."""
        return newest - self._held[-1][0] > 2 * self._k * self.period_s

    def _watch_clock(self, t: float, last: float) -> bool:
        """Whether the stamps of an IMU that is no packets, ``t`` (s) the newest after ``last``, come from a clock
        about as coarse as its period or coarser (:meth:`LiveClock.watch`, once the first steps decided); found, it
        is said once (:attr:`note`) and :attr:`clock` set."""
        if self.clock is None and not self.period_s:
            clock = self.live_clock.watch(t, last, decided=self._steps is None)
            if clock is not None:
                self._on_clock_found(clock, t, self.live_clock.watched_s())
        return self.clock is not None

    def _on_clock_found(self, clock: tuple[float, float], t: float, span_s: float,
                        before: str = "samples repeating a stamp before were refused as duplicate stamps") -> None:
        """The clock found at ``t`` (s) on stamps spanning ``span_s`` (s) set (:meth:`LiveClock.found_at`) and said once
        (:attr:`note`, ``before``: what became of the samples before it); the first steps decide no more."""
        self._steps, self._ties = None, []
        self.note = self.live_clock.found_at(clock, t, span_s, before)

    def _packets_were_clock(self, clock: tuple[float, float], t: float, f: tuple, w: tuple, last: float,
                            after: float) -> list[tuple[float, tuple, tuple]]:
        """Packets sharing one stamp whose counts came to vary as a clock's (:func:`~graphnav.core.imu_timing.
        quantised_clock` over the stamps since they were decided): four grid steps of a 200 Hz IMU in whole 10 ms,
        or of 400 Hz, can hold a packet's count each. The held packet's first sample leaves at its stamp (unless a
        part of it left already), the rest are repeats placed before ``t`` (s), which passes (:meth:`LiveClock.add`)."""
        held, self._held = self._held, []
        first = held[:1] if self._in_packet == len(held) else []
        self.period_s, self._in_packet = 0.0, 0
        self._on_clock_found(clock, last, self.live_clock.watched_s(), "the packets said before were its grid "
                             "steps, their samples spread back from their stamp")
        self.live_clock.hold(held[len(first):])
        return first + self.live_clock.add(t, f, w, last, after)

    def _decided(self, k: int, cycle: float, how: str = "") -> None:
        """Packets of ``k`` found, ``cycle`` (s) apart at :attr:`period_s`: the typical size until two of the packets
        that follow reach another; said once (:attr:`note`, ``how``: what the packets are, said first)."""
        self._k = k
        self._sizes.extend((k, k))
        self.live_clock.unwatch()     # a stream that turns clean again is watched for a clock from then on
        self.note = packets_note(k, cycle, self.period_s, f"stamps from t = {self._held_from(self._last):.3f} s "
                                 f"({how}counted in imu_restamped)")

    def _decide_shared(self, t: float, last: float) -> None:
        """Decide on the stamps so far once one repeats: packets sharing one stamp when
        :func:`~graphnav.core.imu_timing.shared_stamp_packets` says so over the whole packets received, four stamps or
        more, as a new one begins (the samples until then, and the rest of that one, repeat stamps and are refused
        downstream), a packet ending at any step; a clock coarser than the period
        (:func:`~graphnav.core.imu_timing.quantised_clock`) is said once and passes as received, a sample repeating a
        stamp placed after it (:meth:`LiveClock.add`); else the steps decide."""
        self._ties = self._ties or [last]
        whole = self._ties[1:] if t > last else []          # the first may be the end of a packet
        self._ties.append(t)
        packets = shared_stamp_packets(np.asarray(whole)) if len(set(whole)) >= 4 else None
        clock = quantised_clock(np.asarray(whole)) if packets is not None else None
        if clock is not None:
            self._on_clock_found(clock, t, whole[-1] - whole[0])
        elif packets is not None and packets[0] > 1:     # one sample to a stamp is no packets
            k, cycle, self.period_s = packets
            self._decided(k, cycle, "packets sharing one stamp; ")
            self.live_clock.watch_stamps(whole + [t])     # watched for a clock whose grid steps held a packet's count
            self._steps, self._ties, self._limit = None, [], 0.0
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
            self._decided(round(cycle / period), cycle)
        elif abs(period - self.configured_s) > IMU_RATE_TOLERANCE * self.configured_s:
            # no packets, at another rate than configured: the steps are judged against the rate the data show, as
            # the loaders do (calibration.preparation; the keyframer's ImuPeriod warns). Against 10 Hz each 10 ms
            # step of a 100 Hz IMU was one within a packet: decided again at every step (_reopen), a 0.5 s loss made
            # packets, its samples restamped 12 ms apart and no gap said
            self.configured_s = period


class LiveClock:
    """A clock about as coarse as a live IMU's period or coarser that its stamps come from (100 Hz logged in whole 10 ms
    with jitter, a 64 Hz IMU on a 15.625 ms timer, 200 Hz in whole 10 ms: :func:`~graphnav.core.imu_timing.
    quantised_clock` over its latest stamps, :meth:`watch`), and its samples' times once it is found
    (:meth:`found_at`). A sample repeating the stamp before it is its next sample: it waits for the next distinct stamp
    and is placed after its stamp at the period within the room before that one (:meth:`flush`); once
    :data:`CLOCK_LINE_SAMPLES` samples are in, every sample goes on a line at the period through its stamps' grid steps
    (:meth:`_on_line`). :class:`PacketStamps` holds one, feeds it the stamps to watch and, once it is found, every
    sample (:meth:`add`), and asks it what its reorder buffer may release (:meth:`release_limit`, :meth:`overdue`)."""

    def __init__(self, window_s: float = 0.0):
        self.window_s = window_s        # how far (s) an IMU sample may arrive behind the newest of any stream
        #: (grid s, period s) of the clock, once found; None before
        self.found: tuple[float, float] | None = None
        self.restamped = 0              # samples placed elsewhere than their stamp
        self._watched: deque[float] = deque(maxlen=CLOCK_WATCH_STAMPS)    # the latest stamps, watched for a clock
        self._repeats = 0               # repeated stamps watched
        #: the samples repeating a stamp, waiting for the next stamp to be placed before it
        self._held: list[tuple[float, tuple, tuple]] = []
        #: (sample index in the stretch, its stamp's mid grid step s after the stretch's first stamp)
        self._line: deque[tuple[int, float]] = deque(maxlen=CLOCK_WATCH_STAMPS)
        self._line_origin, self._line_n = 0.0, 0     # the stretch's first stamp s, and samples in it
        self._fit: tuple[int, float, float] | None = None    # the line: (sample index, its time s, the period s)
        self._misses: list[float] = []  # the latest samples' stamps' grid steps' mid-points less the line, s

    def watch(self, t: float, last: float, decided: bool) -> tuple[float, float] | None:
        """The clock (grid s, period s) the stamps come from, ``t`` (s) the newest after ``last`` (s), or None: once
        :data:`~graphnav.core.imu_timing.CLOCK_PATTERN_STAMPS` stamps repeated, at each repeat after the first steps
        ``decided`` :func:`~graphnav.core.imu_timing.quantised_clock` over the latest :data:`CLOCK_WATCH_STAMPS`
        decides (a clean IMU with a row written twice now and then has no clock's pattern)."""
        self._watched.append(t)
        self._repeats += t == last
        if t == last and decided and self._repeats >= CLOCK_PATTERN_STAMPS:
            return self.watched_clock()
        return None

    def watched_clock(self) -> tuple[float, float] | None:
        """The clock (grid s, period s) the stamps watched come from
        (:func:`~graphnav.core.imu_timing.quantised_clock`), or None."""
        return quantised_clock(np.asarray(self._watched))

    def watch_stamps(self, stamps: list[float]) -> None:
        """``stamps`` (s) watched for a clock without deciding (packets sharing one stamp: perhaps a clock's)."""
        self._watched.extend(stamps)

    def unwatch(self) -> None:
        """The stamps watched so far forgotten: the stream is watched from the next on."""
        self._watched.clear()

    def watched_s(self) -> float:
        """The span (s) of the stamps watched."""
        return self._watched[-1] - self._watched[0]

    def hold(self, samples: list[tuple[float, tuple, tuple]]) -> None:
        """``samples`` repeating a stamp, held to be placed before the next stamp (:meth:`flush`)."""
        self._held = list(samples)

    def found_at(self, clock: tuple[float, float], t: float, span_s: float, before: str) -> str:
        """The clock (grid s, period s) set, found at ``t`` (s), and what to say of it once, ``before`` saying what
        became of the samples before it; its period (samples over time) named when the stamps it was found on span
        :data:`CLOCK_PERIOD_STEPS` grid steps (``span_s``, s): over four it read 6 ms for 200 Hz."""
        self.found = clock
        self._watched.clear()
        words = clock_words(*clock, said=span_s >= CLOCK_PERIOD_STEPS * clock[0])
        return (f"{words}: from t = {t:.3f} s a sample repeating the stamp before it is the next "
                "sample, placed after that stamp at the period within the room before the next stamp, and "
                f"after {CLOCK_LINE_SAMPLES} samples every sample on a line at the period through the mid-points "
                "of their stamps' grid steps, fitted again as they come (counted in imu_restamped; a clock "
                f"truncating to its grid, the usual logger: one rounding to it leaves them {500 * clock[0]:.4g} "
                f"ms late, as offline); {before}")

    def add(self, t: float, f: tuple, w: tuple, last: float, after: float) -> list[tuple[float, tuple, tuple]]:
        """A sample on a clock about as coarse as the period or coarser: one repeating the stamp ``last`` (s) waits
        for the next stamp; the next stamp lets the waiting ones out placed (:meth:`flush`, none at or before
        ``after``, s), then itself as received; once a line through the stamps is fitted (:meth:`_on_line`), every
        sample leaves on it as it arrives."""
        placed = self._on_line(t)
        if placed is not None:
            out = self.flush(after, placed)
            self.restamped += int(placed != t)
            return out + [(placed, f, w)]
        if t == last:
            self._held.append((t, f, w))
            return []
        return self.flush(after, t if t > last else math.inf) + [(t, f, w)]

    def _on_line(self, t: float) -> float | None:
        """The time (s) of a sample stamped ``t`` (s) on a clock: on the least-squares line at the period through
        the mid-points of the grid steps of the latest :data:`CLOCK_WATCH_STAMPS` samples of its stretch, as offline
        (:func:`~graphnav.core.imu_timing.restamp_quantised`), fitted again every :data:`CLOCK_LINE_SAMPLES`. Left at
        their stamps, the samples that do not repeat one are up to a grid step early at random (5.3 ms RMS for 100 Hz
        in whole 10 ms with 1 ms of jitter), which cost 0.05-0.11 m over 90 s where a constant offset of that size
        costs 0.01 m. None (the sample left to its stamp) for the first :data:`CLOCK_LINE_SAMPLES` of a stretch; the
        line misses the grid steps of samples lost or a rate changed (:meth:`_line_broken`): such a sample starts a
        stretch."""
        grid = self.found[0]
        n, placed = self._line_n, None
        if self._fit is not None:
            placed = self._fit[1] + self._fit[2] * (n - self._fit[0])
            if self._line_broken(t + 0.5 * grid - placed):
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

    def _line_broken(self, miss: float) -> bool:
        """Whether the line misses its samples' grid steps, ``miss`` (s) the newest's stamp's grid step's mid-point
        less its place: by over the half step, :data:`CLOCK_LINE_SLACK_PERIODS` and a period more (a gap, a clock
        stepping), or by over :data:`CLOCK_LINE_MEAN_PERIODS` on average over the latest :data:`CLOCK_LINE_RUN` grid
        steps' samples (a sample lost, the rate changed: every later sample misses). A sample that jitter pushed across
        a grid edge misses by a grid step alone, as far at a clock as coarse as the period as a sample lost moves the
        rest."""
        grid, period = self.found
        n = CLOCK_LINE_RUN * max(1, round(grid / period))
        self._misses = self._misses[1 - n:] + [miss]
        far = abs(miss) > 0.5 * grid + (CLOCK_LINE_SLACK_PERIODS + 1.0) * period
        if far or (len(self._misses) == n and abs(np.mean(self._misses)) > CLOCK_LINE_MEAN_PERIODS * period):
            self._misses = []
            return True
        return False

    def release_limit(self, newest: float) -> float:
        """The stamp (s) the reorder buffer may release up to: the first sample held, so that its place is not let
        out before it; inf with none held or once they waited long enough (:meth:`_overdue`, ``newest`` s the newest
        stamp received on any stream)."""
        return math.inf if not self._held or self._overdue(newest) else self._held[0][0]

    def overdue(self, newest: float, after: float = -math.inf) -> list[tuple[float, tuple, tuple]]:
        """The held samples placed (:meth:`flush`, none at or before ``after``, s) once they waited long enough
        (:meth:`_overdue`, ``newest`` s the newest stamp received on any stream); else none."""
        return self.flush(after) if self._held and self._overdue(newest) else []

    def _overdue(self, newest: float) -> bool:
        """Whether the held samples waited long enough: ``newest`` (s, any stream's) past their last stamp by the
        reorder window and :data:`CLOCK_WAIT_STEPS` grid steps (measured against any stream, three grid steps gave up
        on an IMU arriving 40 ms behind the DVL and placed its repeats on the next stamp: refused as duplicates)."""
        return newest - self._held[-1][0] > self.window_s + CLOCK_WAIT_STEPS * self.found[0]

    def flush(self, after: float = -math.inf, before: float = math.inf) -> list[tuple[float, tuple, tuple]]:
        """The held samples repeating a stamp s (after the one let out at it), placed at s + j * step, j = 1, 2 ...,
        step the clock's period or less where the next stamp (``before``, s; inf: unknown) leaves less room for them
        (n samples in one grid step: a sample pushed across the grid's edge before it), from ``after`` (s, what the
        caller let go of) when that is later than s; the restamped count updated."""
        held, self._held = self._held, []
        if not held:
            return []
        start = max(held[0][0], after)
        step = min(self.found[1], (before - start) / (len(held) + 1))
        self.restamped += len(held)
        return [(start + (j + 1) * step, s[1], s[2]) for j, s in enumerate(held)]
