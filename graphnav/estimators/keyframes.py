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
  are dropped and gaps longer than :data:`graphnav.core.mission.IMU_GAP_PERIODS` periods (the period
  :class:`~graphnav.estimators.imu_stream_timing.ImuPeriod` measures) are bridged by linear interpolation
  (warning, counted); the keyframe intervals over a gap carry the extra velocity and attitude variance of
  :func:`graphnav.core.mission.gap_variances`.
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
from graphnav.core.mission import OUTSIDE_SPAN_TOLERANCE_S, ImuGap, gap_variances
from graphnav.core.screening import check_imu_gap
from graphnav.estimators.history import BeamHistory, run_sigma_of
from graphnav.estimators.imu_buffer import NO_WINDOW_REASONS, ImuWindowBuffer
from graphnav.estimators.imu_stream_timing import ImuPeriod
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
        late_pings_said: the pings after the IMU's last sample were warned about and counted when the data were
            read (a replayed mission: ``Mission.validate``), so they are dropped here without a second warning.
    """

    max_keyframe_gap_s: float = 2.0
    imu_keyframe_interval_s: float = 1.0
    aiding_max_age_s: float = 1.5
    fix_min_interval_s: float = 1.0
    late_pings_said: bool = False

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
        #: (start, end) stamps (s) of stretches no time passed in for the vehicle (a step of the clock every stream
        #: shares, :meth:`join_step`): the IMU segments over them integrate nothing
        self._dead: list[tuple[float, float]] = []
        #: (start, end) stamps (s) of the IMU gaps already warned about (a keyframer that replays a Navigator's
        #: alignment buffer is handed those of the one before it, which said them)
        self.said_gaps: set[tuple[float, float]] = set()
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
        late = [p.t for p in self._pending if p.has_ping]
        self.stats.pings_after_end += len(late)
        if late and not self.options.late_pings_said:
            self._warn_pings_after_end(late)
        self._pending.clear()
        return out

    def _warn_pings_after_end(self, late: list[float]) -> None:
        """One warning for the pings at stamps ``late`` (s, in order) that no IMU sample follows, dropped, when the
        last lies beyond :data:`~graphnav.core.mission.OUTSIDE_SPAN_TOLERANCE_S` of the last IMU sample: within it
        a recording's last ping is the usual end of a time offset (8 of the ten A-KIT trajectories, 6-75 ms), which
        a mission drops quietly too."""
        last = self._samples[-1][0] if self._samples else -math.inf
        if late[-1] - last <= OUTSIDE_SPAN_TOLERANCE_S:
            return
        after = f" at t = {last:.3f} s (the last {late[-1] - last:.3f} s after it)" if self._samples else ""
        warnings.warn(f"dvl: {len(late)} ping(s) after the IMU's last sample{after} dropped: no IMU sample covers "
                      "them (counted as pings_after_end)", RuntimeWarning, stacklevel=4)

    # --- internals ----------------------------------------------------------------------------------
    def _insert_pending(self, p: _Pending) -> None:
        keys = [q.t for q in self._pending]
        self._pending.insert(bisect.bisect_right(keys, p.t), p)

    def _bridge(self, last, new) -> list[Keyframe]:
        """Bridge the IMU gap from sample ``last`` to ``new`` ((t, f_b, omega_b) each) by interpolation, said once
        (:attr:`said_gaps`)."""
        t0, t1 = last[0], new[0]
        length = t1 - t0
        check_imu_gap(t0, t1, "imu")          # bounds the samples made below
        n_fill = int(math.ceil(length / self.imu_period.period_s)) - 1
        f0, w0, f1, w1 = np.array(last[1]), np.array(last[2]), np.array(new[1]), np.array(new[2])
        gap = ImuGap(self._n_imu - 1, t0, t1)
        self._gaps.append(gap)
        self.stats.imu_gaps.append(gap)
        if (t0, t1) not in self.said_gaps:
            self.said_gaps.add((t0, t1))
            warnings.warn(f"imu: gap of {length:.3f} s after t = {t0:.3f} s bridged by linear interpolation "
                          f"({n_fill} samples); velocity/attitude covariance inflated over it", RuntimeWarning,
                          stacklevel=4)
        out = []
        for i in range(1, n_fill + 1):
            u = i / (n_fill + 1)
            out += self._on_sample(t0 + length * u, tuple((1 - u) * f0 + u * f1), tuple((1 - u) * w0 + u * w1),
                                   bridged=True)
        out += self._on_sample(*new)
        return out

    def join_step(self, t: float, f_b, omega_b) -> list[Keyframe]:
        """The IMU sample at stamp t (s) after a forward step of the clock every stream shares (decided by the
        Navigator, :mod:`graphnav.estimators.clock_steps`): joined to the sample before it one IMU period on, no
        time passing for the vehicle over the rest of the step (nothing bridged, nothing turned); the IMU-only
        keyframes through the DVL's silence count on from the vehicle's time. An all-zero row (a logger's filler: no
        measurement) or a first sample goes in as any sample does (:meth:`add_imu`: dropped, counted; or started on)."""
        if not self._samples or (f_b[2] == 0.0 and not (any(f_b) or any(omega_b))):
            return self.add_imu(t, f_b, omega_b)
        t0 = self._samples[-1][0]
        dead = t - t0 - self.imu_period.period_s
        if dead > 0:
            self._dead.append((t - dead, t))
            if self._anchor is not None:
                self._anchor += dead
        return self._on_sample(t, f_b, omega_b)

    def live_time(self, t0: float, t1: float) -> float:
        """The time that passed for the vehicle from stamp t0 to t1 (s): ``t1 - t0`` less the clock steps inside."""
        return t1 - t0 - sum(max(0.0, min(t1, b) - max(t0, a)) for a, b in self._dead)

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
        live = [self.live_time(a, b) for a, b in zip(starts, ends)] if self._dead else \
            [ends[i] - starts[i] for i in range(j + 1)]
        keep = [i for i in range(j + 1) if live[i] > 0]
        f = [part[i][1] for i in keep]
        w = [part[i][2] for i in keep]
        dt = [live[i] for i in keep]
        lag = [starts[i] - stamps[i] for i in keep]
        del samples[:j]
        var_v, var_att = gap_variances(self._gaps, t_open, t) if self._gaps else (0.0, 0.0)
        if self._gaps:
            self._gaps = [g for g in self._gaps if g.t_end > t]
        if self._dead:
            self._dead = [d for d in self._dead if d[1] > t]
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
