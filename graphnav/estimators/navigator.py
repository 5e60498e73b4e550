"""``Navigator``: the streaming navigation backend a vehicle runs, fed sample by sample by its drivers.

The loop is the one of GTSAM's ``ImuFactorISAM2Example`` and navlie's filters::

    nav = Navigator(config)                        # fixed-lag graph; aligns itself from the sensors
    for kind, t, payload in driver:                # any order within the reorder window
        for est in getattr(nav, "add_" + kind)(t, *payload):
            publish(est)                           # filtered state at each closed keyframe
        command = controller(nav.state_at(now))    # IMU-rate state for the vehicle's controller

What happens to a sample:

1. **Checks.** A non-finite stamp or value (NaN/inf; a DVL beam may be NaN only where it is not valid), a
   stamp older than the reorder window allows, or a stamp already seen on the same stream is refused with a
   warning naming the stream, stamp and field, and counted in :attr:`Navigator.info` (``refused``). Then the
   screening of :mod:`graphnav.core.screening`, the same rules the loaders apply: a stamp beyond
   ``MAX_STAMP_S`` or more than a day ahead of the stream or behind it, an IMU value beyond the instrument's full
   scale or spiking (a run of up to 0.1 s of samples departing from the median of the last 0.1 s accepted, past the
   spike test's floor and the signal's own noise, unless it rose there over samples as a shock does:
   :class:`~graphnav.core.screening.ImuSpikeTest`, run in stamp order as
   the samples leave the reorder buffer; off, with a warning and a note in :attr:`Navigator.info` (``notes``), for
   an IMU under 50 Hz), a DVL beam beyond the
   vehicle's speed or spiking (the ping is refused: one beam the instrument got wrong makes the others suspect,
   and the completers expect the missing-beam patterns of outages), a DVL ping logged as exactly 0 with no bottom
   lock (:class:`~graphnav.core.screening.ZeroPingTest`: the log's resolution, the run's length or the speed of
   the pings before it; one the past keeps is held until the next ping, whose speed or zeros can refuse its run),
   a depth outside its range or spiking, and a sample of any stream repeating the one received before it in every
   value a moment later (a sample sent twice, its stamp nudged: :class:`~graphnav.core.screening.NudgedCopies`, as
   the loaders drop such a row). Nothing estimated so far changes. When more than half of a stream
   was refused, :meth:`Navigator.finish` raises a DataError naming the stream and the reasons.
2. **Reordering.** Samples wait in a buffer until the newest stamp seen is ``reorder_window_s`` ahead of
   them, then leave in time order (at equal stamps: aiding, then DVL, then IMU). A DVL that reports late by
   its processing time is thus slotted in before the IMU samples that follow its stamp. An IMU whose driver stamps
   its samples in packets is put back on its period before it enters
   (:class:`~graphnav.estimators.imu_stream_timing.PacketStamps`, counted in ``info["imu_restamped"]``).
3. **Initialisation.** With an ``initial`` state the estimator starts at its stamp; without one an
   :class:`~graphnav.estimators.align.Aligner` levels and gyrocompasses (or uses the heading sensor) from the first
   samples, and the estimator starts where the alignment ends, with the alignment's covariance as prior; with
   ``align_catch_up`` it starts at the first buffered sample and runs through the buffer twice: once from the
   alignment's covariance for the window's estimates, then, to go on, from what was known before those samples
   (they would otherwise count twice: docs/decisions/alignment.md).
4. **Keyframes** (:mod:`graphnav.estimators.keyframes`): at every ping, every decimated position fix and, through DVL
   gaps, every ``imu_keyframe_interval_s``; each closes as soon as the IMU has passed its stamp (no look-ahead)
   and goes to the backend (:mod:`graphnav.estimators.backends`: ``"fixed-lag"``, ``"isam2"`` or ``"ekf"``).
   A gap of 1 s or more in every stream at once is held until the IMU samples after it tell a step of the clock the
   streams share (joined with no time passed) from a loss of every sensor (bridged), or say they cannot
   (:mod:`graphnav.estimators.clock_steps`); meanwhile :meth:`Navigator.state_at` has no sample after the gap.

Every ``add_*`` returns the estimates it completed (usually none; one per closed keyframe).
:meth:`Navigator.estimate` is the latest of them, :meth:`Navigator.state_at` propagates it with every IMU sample
received since (including those still in the reorder buffer) for a controller at the IMU rate, and
:meth:`Navigator.finish` drains the buffer at the end of the data.
"""
from __future__ import annotations

import bisect
import dataclasses
import heapq
import math
import warnings
from collections import deque
from dataclasses import dataclass, field
from typing import Iterator

import gtsam
import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.dvl import ping_speed
from graphnav.core.earth import EarthModel
from graphnav.core.errors import ConfigError, DataError
from graphnav.core.mission import MAX_DVL_SPEED_MPS
from graphnav.core.screening import (CLOCK_JUMP_CONFIRM_S, EXACT_COPY, IMU_STALL_CONTEXT_S, IMU_STALL_UNTOLD,
                                     IMU_STALLED, MAX_REFUSED_FRACTION, NO_BOTTOM_LOCK, NUDGED_COPY, ImuStallTest,
                                     NudgedCopies, RecentRepeats, StreamScreen, clock_jump_words)
from graphnav.estimators.align import GAP_JOINED_S, AlignOptions
from graphnav.estimators.backends import BACKENDS, make_backend
from graphnav.estimators.clock_steps import (AFTER_GAP_S, JUDGE_WINDOW_S, JUDGED_GAP_MIN_S, MIN_SAMPLES, judge_gap,
                                             side_full)
from graphnav.estimators.coasting import CoastingMonitor, SigmaMonitor
from graphnav.estimators.ekf import EkfOptions
from graphnav.estimators.graph.builder import preintegration_gravity, preintegration_params
from graphnav.estimators.graph.options import GraphOptions
from graphnav.estimators.graph.incremental import is_indeterminant
from graphnav.estimators.health import LostTrack, epoch_health
from graphnav.estimators.history import run_sigma_of
from graphnav.estimators.imu_stream_timing import PacketStamps
from graphnav.estimators.keyframes import KeyframeOptions, Keyframer, stamp_of
from graphnav.estimators.replay import STREAM_ORDER, replay
from graphnav.estimators.types import EpochEstimate, InitialState, Ping

#: the streams whose samples are a :class:`~graphnav.estimators.types.Ping` (made once, in ``add_dvl`` and
#: ``add_dvl_velocity``), handed on as it is
PING_STREAMS = ("dvl", "dvl_velocity")
#: why a zero ping of each ping stream is refused as no bottom lock
ZERO_PING_WHY = {"dvl": "every valid beam exactly 0 (the DVL's resolution is finer or the vehicle was under way)",
                 "dvl_velocity": "v_d exactly 0 on every axis (the DVL's resolution is finer or the vehicle was under "
                                 "way)"}


@dataclass
class NavigatorOptions:
    """Streaming settings of :class:`Navigator`.

    Attributes:
        reorder_window_s: how long (s of stream time) a sample waits for later-arriving samples with earlier
            stamps. A DVL reports its ping after its processing time (tenths of a second); a sample more than
            this late is refused. 0 = the input must be in time order.
        keyframes: where keyframes go (:class:`~graphnav.estimators.keyframes.KeyframeOptions`).
        max_extrapolation_s: :meth:`Navigator.state_at` extrapolates at most this far beyond the newest IMU
            sample (s).
        align_catch_up: when a sensor alignment completes, start the estimator at the first sample the aligner
            holds (the aligned attitude carried back with the gyros, :meth:`graphnav.estimators.align.Aligner.result_at`)
            and run it through the samples buffered meanwhile, so that the estimates cover the alignment time
            too (they all arrive when the alignment completes); False starts it where the alignment ends.
        align_buffer_s: the longest stretch of samples kept for the catch-up, s (the newest).
        align: settings of the :class:`~graphnav.estimators.align.Aligner` that starts the estimator when no
            initial state is given, with what is known at the start (initial heading, position)
            (:class:`~graphnav.estimators.align.AlignOptions`).
        dvl_zeros_judged: the DVL pings of exactly 0 were judged when the log was read (a replayed mission: the
            loader knows the file's resolution and the pings after each run,
            :func:`graphnav.core.screening.no_bottom_lock`);
            the stream, which knows neither, does not judge them again.
        imu_shocks: ``[first, last]`` stamps (s) of IMU shocks the loader kept on the DVL's word (a replayed
            mission's ``meta["imu_shocks"]``, :func:`graphnav.core.screening.imu_implausible`): the stream, which
            has no ping after them yet, does not test their rows again.
    """

    reorder_window_s: float = 0.2
    keyframes: KeyframeOptions = field(default_factory=KeyframeOptions)
    max_extrapolation_s: float = 0.1
    align_catch_up: bool = True
    align_buffer_s: float = 600.0
    align: AlignOptions = field(default_factory=AlignOptions)
    dvl_zeros_judged: bool = False
    imu_shocks: tuple = ()

    def __post_init__(self):
        if self.reorder_window_s < 0:
            raise ConfigError(f"reorder_window_s must be >= 0, got {self.reorder_window_s}")


@dataclass
class NavState:
    """The state a controller reads: stamp t (s), attitude ``C_b_n``, NED velocity ``v_n`` (m/s) and position
    ``p_n`` (m), and the bias-corrected body rate ``omega_b`` (rad/s) of the newest IMU sample."""

    t: float
    C_b_n: np.ndarray
    v_n: np.ndarray
    p_n: np.ndarray
    omega_b: np.ndarray


class Navigator:
    """Streaming INS/DVL navigation (see the module docstring).

    Args:
        config: sensor configuration (IMU noise, DVL geometry and lever arm, latitude, gravity).
        backend: ``"fixed-lag"`` (default: bounded time and memory for missions of any length), ``"isam2"``
            or ``"ekf"``; ``"dead-reckoning"`` builds the graph's keyframe factors without a solver (states from
            the IMU and the DVL's least-squares velocity): the batch smoother's cheap first pass, not a navigator.
        completer: a beam completer (``complete(past, measured)``, ``n_past``) for the hybrid methods: missing
            beams are regressed and enter as weaker factors (graph) or inflated updates (EKF).
        initial: the initial state and its stamp (``initial.t``); None = align from the sensors.
        graph_options, ekf_options: the backend's settings.
        tight: EKF backend only: tightly (True) or loosely coupled beam updates.
        options: streaming and alignment settings (``options.align`` when ``initial`` is None).
        keep_keyframe_graphs: graph backends keep every keyframe's factors (for a batch smoother afterwards,
            :meth:`keyframe_graphs`).
        name: the estimator's name in health warnings (e.g. the method name).
    """

    def __init__(self, config: SensorConfig, backend: str = "fixed-lag", *, completer=None,
                 initial: InitialState | None = None, graph_options: GraphOptions | None = None,
                 ekf_options: EkfOptions | None = None, tight: bool = True,
                 options: NavigatorOptions | None = None, keep_keyframe_graphs: bool = False, name: str | None = None):
        if backend not in BACKENDS:
            raise ConfigError(f"unknown backend '{backend}'; choose one of {', '.join(BACKENDS)}")
        # what a restart on a stream's new clock builds again (:meth:`_start_over_on_new_clock`)
        self._init_args = (config, backend, dict(completer=completer, initial=initial, graph_options=graph_options,
                                                 ekf_options=ekf_options, tight=tight, options=options,
                                                 keep_keyframe_graphs=keep_keyframe_graphs, name=name))
        self.config = config
        self.backend_name = backend
        self.options = options or NavigatorOptions()
        self._backend_kwargs = {"graph_options": graph_options, "ekf_options": ekf_options, "tight": tight,
                                "keep_keyframe_graphs": keep_keyframe_graphs, "label": name}
        self._completer = completer
        self._refuse_rehearsal()
        # a registry completer is shared within a process: its counters before this Navigator, for info's counts
        self._fallbacks_before = dict(getattr(completer, "fallbacks", {}))
        self.keyframer = Keyframer(config, self.options.keyframes, completer)
        # an IMU in packets put back on its period
        self._packets = PacketStamps(1.0 / config.imu_rate_hz, self.options.reorder_window_s)
        self._align_events: deque = deque()       # released samples kept during alignment (catch-up)
        self.backend = None
        self.aligner = None
        self.alignment = None
        self.alignment_ready_t: float | None = None   # stamp at which the alignment completed
        self._heap: list = []             # aiding and DVL samples waiting, by (t, stream order, arrival)
        self._imu_q: deque = deque()      # IMU samples waiting, in time order (the 100 Hz stream: no heap)
        self._seq = 0
        self._newest = -math.inf          # newest stamp received
        self._released = -math.inf        # everything up to here has left the reorder buffer
        self._stamps: dict[str, set] = {k: set() for k in STREAM_ORDER}
        self._last_released: dict[str, float] = {k: -math.inf for k in STREAM_ORDER}
        self._last_imu_released = -math.inf
        self._last_imu_in: tuple | None = None      # the latest IMU sample received (t, f, w), for a copy of it
        self._imu_repeats = RecentRepeats()         # how often its readings repeat, within and across stamps
        # a stalled IMU (the loaders' rule, screening.imu_stalled): samples repeating the one before them are held
        # (nothing later leaves meanwhile) until the run ends or is a stall, whose samples are refused
        self._stall = ImuStallTest()
        self._stall_held: list[tuple[float, tuple, tuple]] = []
        self._stall_refused: list[float] = []       # stamps of the stalled run being refused, s
        self._stall_cleared = -math.inf             # held samples let go (no stall) up to this stamp, s
        self._untold_read = -math.inf       # the reading of the last run doubted as a stall not told (s)
        #: samples after a held run the samples before it could not judge (the stream's first second, right after an
        #: IMU gap), held with it while they judge it (ImuStallTest.stalled_after); None when not judging
        self._stall_after: list[tuple[float, tuple, tuple]] | None = None
        self._stall_judged = -math.inf      # the reading of the last such run the samples after it found no stall (s)
        #: samples used despite a doubt, per stream and reason (e.g. a stall in the stream's first second)
        self.doubted: dict[str, dict[str, int]] = {}
        self._nudged = {k: NudgedCopies() for k in STREAM_ORDER}     # samples sent again a moment later
        self._latest: EpochEstimate | None = None
        #: (t s, why) where the estimator lost track on a number (:meth:`_lose_track`): no estimate after it
        self.lost_track: tuple[float, str] | None = None
        self._prop: tuple | None = None             # cached propagation for state_at
        self._pim_params = preintegration_params(config, graph_options or GraphOptions())
        self._earth = EarthModel.from_config(config)
        self.refused: dict[str, dict[str, int]] = {}
        self._screen = StreamScreen(config, lambda beams, valid: ping_speed(beams, valid, config.dvl),
                                    judge_zeros=not self.options.dvl_zeros_judged)
        self._imu_spike_noted = False         # the spike test's "off" note is told once, when the rate is known
        self._held: dict[str, list] = {k: [] for k in PING_STREAMS}    # zero pings the next ping decides: (t, sample)
        self._hold_before = math.inf          # the reorder buffer releases nothing after this while pings are held
        self.notes: dict[str, list[str]] = {}       # sentences about a stream a user must see (info)
        #: the IMU's full scale (m/s^2, rad/s): a sample within it needs no further screening call
        self._imu_full_scale = (float(config.imu.accel_range_mps2), float(config.imu.gyro_range_rads))
        self.received: dict[str, int] = {}          # samples given to add_* per stream
        self.samples_refused: dict[str, int] = {}   # samples refused per stream, whatever the reason
        self.n_estimates = 0
        # a gap in every stream at once, judged a step of their clock or a loss by the IMU samples either side
        # (:mod:`graphnav.estimators.clock_steps`): the last JUDGE_WINDOW_S of IMU samples fed, the gap being judged
        # ({"after": IMU samples after it, "events": every sample released since, held}), the oldest stamp of
        # another stream released since the last IMU sample
        self._imu_before: deque = deque()
        self._judging: dict | None = None
        self._other_since_imu = math.inf
        #: gaps in every stream judged, by verdict (step / loss / undecided)
        self.gaps_judged: dict[str, int] = {}
        self._gap_doubt: str | None = None     # an undecided gap: why the estimates after it are degraded
        #: live pure-inertial check (:mod:`graphnav.estimators.coasting`), created when the estimator starts
        self.coasting: CoastingMonitor | None = None
        #: live check of the claimed velocity sigma (:class:`~graphnav.estimators.coasting.SigmaMonitor`), likewise
        self.sigma: SigmaMonitor | None = None
        if initial is not None:
            if initial.t is None:
                raise ConfigError("initial.t (the stamp of the initial state) is required")
            self._start(initial)
        else:
            from graphnav.estimators.align import Aligner
            self.aligner = Aligner(config, self._align_options())

    # --- inputs -------------------------------------------------------------------------------------
    def add_imu(self, t: float, f_b, omega_b) -> list[EpochEstimate]:
        """An IMU sample: specific force ``f_b`` (3,) m/s^2 and angular rate ``omega_b`` (3,) rad/s, body
        frame, at stamp t (s). Held over ``[t, t_next)`` (zero-order hold)."""
        try:     # the fast path of a 100 Hz stream: three floats each, all finite (x - x == 0 fails for inf/NaN)
            fx, fy, fz = f_b
            wx, wy, wz = omega_b
            f = (float(fx), float(fy), float(fz))
            w = (float(wx), float(wy), float(wz))
            total = float(t) + f[0] + f[1] + f[2] + w[0] + w[1] + w[2]
            ok = total - total == 0.0
        except (TypeError, ValueError):
            ok = False
        self.received["imu"] = self.received.get("imu", 0) + 1
        if not ok:
            f = self._vector("imu", t, "f_b", f_b, 3)
            w = self._vector("imu", t, "omega_b", omega_b, 3)
            if f is None or w is None:
                return []
        else:       # t is a finite float here: straight to the stamp screening of _stamp_ok
            why = self._screen.stamp_problem("imu", t)
            if why is not None:
                self._stop_at_clock_step("imu")
                return self._refuse("imu", t, "t", why)
        acc, gyro = self._imu_full_scale
        if (abs(f[0]) > acc or abs(f[1]) > acc or abs(f[2]) > acc or abs(w[0]) > gyro or abs(w[1]) > gyro
                or abs(w[2]) > gyro or not ok):
            why = self._screen.imu_problem(f, w)
        else:
            why = None
        if why is not None:
            return self._refuse("imu", t, why, f"f_b {list(f)}, omega_b {list(w)}: beyond the IMU's full scale "
                                "(ImuSpec.accel_range_mps2 / gyro_range_rads)", screened=True)
        if self._imu_copy(t, f, w):
            return self._refuse("imu", t, EXACT_COPY, "the same stamp and values as the sample before it (a sample "
                                "written again; its readings differ from stamp to stamp)", screened=True)
        if self._sent_twice("imu", t, f + w):
            return []
        packets = self._packets
        samples = packets.add(t, f, w, self._released)
        if packets.deciding and t > self._newest:   # held while its first steps decide: the other streams go on
            self._newest = t
        out = self._queue_packet(samples)  # queued whole before anything leaves
        if packets.note is not None:
            self._note("imu", packets.note)
            packets.note = None
            if packets.period_s:        # the samples held while it decided come restamped too
                self.keyframer.imu_period.restamped(min(t, samples[0][0]) if samples else t)
        return out + self._release(self._newest - self.options.reorder_window_s)

    def _imu_copy(self, t: float, f, w) -> bool:
        """Whether an IMU sample (stamp ``t`` s, ``f`` m/s^2, ``w`` rad/s) repeats the one received before it in its
        stamp and every value while the readings over the latest steps differ from stamp to stamp: a sample written
        again (each of an even 100 Hz stream's samples sent twice was restamped as packets of 2 at 200 Hz, each
        integrated twice). Readings repeating from stamp to stamp as often as within one are an IMU at rest with
        coarse counts, whose packets' samples sharing a stamp may be equal: they pass (:class:`RecentRepeats`, as
        :func:`graphnav.core.screening.readings_repeat` offline)."""
        sample, last = (t, tuple(f), tuple(w)), self._last_imu_in
        self._last_imu_in = sample
        if last is None:
            return False
        within, equal = t == last[0], sample[1:] == last[1:]
        self._imu_repeats.add(within, equal)
        return within and equal and not self._imu_repeats.repeat()

    def _sent_twice(self, stream: str, t: float, values: tuple) -> bool:
        """Whether a sample of ``stream`` (stamp ``t`` s, ``values`` a tuple of floats) repeats the one received before
        it in every value a moment later (:class:`~graphnav.core.screening.NudgedCopies`, as
        :func:`~graphnav.core.screening.nudged_copies` offline): refused and counted under ``NUDGED_COPY`` when so."""
        if not self._nudged[stream].is_copy(t, values):
            return False
        self._refuse(stream, t, NUDGED_COPY, "the same values as the sample received before it under half the "
                     "stream's usual step later (a sample sent again, its stamp nudged)", screened=True)
        return True

    def _queue_packet(self, samples: list) -> list[EpochEstimate]:
        """The IMU samples :class:`PacketStamps` let out into the reorder buffer, and those of a driver read it
        found no place for refused (counted under ``beyond its packet``)."""
        out = [e for sample in samples for e in self._queue_imu(*sample)]
        for t, why in self._packets.unplaced:
            self._refuse("imu", t, "beyond its packet", why, screened=True)
        self._packets.unplaced.clear()
        return out

    def _queue_imu(self, t: float, f: tuple, w: tuple) -> list[EpochEstimate]:
        """An IMU sample into the reorder buffer (refused when it repeats a stamp or comes too late); the caller
        releases."""
        q = self._imu_q
        in_order = not q or t > q[-1][0]
        if t == self._last_imu_released or (not in_order and any(s[0] == t for s in q)):
            return self._refuse("imu", t, "t", "duplicate stamp")
        if t < self._released:
            return self._refuse("imu", t, "t", f"out of order: {self._released - t:.3f} s older than what already "
                                f"left the reorder buffer (window {self.options.reorder_window_s} s)")
        if in_order:
            q.append((t, f, w))
        else:
            q.insert(bisect.bisect(q, t, key=stamp_of), (t, f, w))
        if t > self._newest:
            self._newest = t
        return []

    def add_dvl(self, t: float, beams, valid=None) -> list[EpochEstimate]:
        """A DVL ping: along-beam velocities ``beams`` (4,) m/s of the DVL head and their validity ``valid``
        (4,) bool (None: the finite beams). Invalid beams may hold anything (NaN, RDI's -32.768)."""
        self.received["dvl"] = self.received.get("dvl", 0) + 1
        if not self._stamp_ok("dvl", t):
            return []
        try:
            b = np.asarray(beams, float).reshape(4)
            v = np.isfinite(b) if valid is None else np.asarray(valid, bool).reshape(4)
        except (ValueError, TypeError) as exc:
            return self._refuse("dvl", t, "beams", f"not four beams with validity ({exc})")
        bad = v & ~np.isfinite(b)
        if bad.any():
            return self._refuse("dvl", t, "beams", f"beam {int(np.flatnonzero(bad)[0]) + 1} is marked valid but "
                                "not finite")
        if self._sent_twice("dvl", t, tuple(float(x) if ok else None for x, ok in zip(b, v))) \
                or not self._accept("dvl", t):
            return []
        return self._zero_judged("dvl", t, np.where(v, b, np.nan), (b, v))

    def add_dvl_velocity(self, t: float, v_d, sigma=None) -> list[EpochEstimate]:
        """A velocity of the DVL head in the DVL frame measured by the instrument itself: ``v_d`` (3,) m/s (a
        velocity-only DVL, a 3-beam solution, a velocity converted to the DVL frame from an earth/ship-frame
        log), with its one-sigma per DVL axis ``sigma`` (3,) m/s (None, or NaN for an axis: the configured
        ``config.dvl.velocity_noise_std``).
        It enters through the beam model with ``T_d`` = identity; a ping that also has >= 3 valid beams at the
        same stamp uses the beams instead (:mod:`graphnav.estimators.keyframes`)."""
        self.received["dvl_velocity"] = self.received.get("dvl_velocity", 0) + 1
        v = self._vector("dvl_velocity", t, "v_d", v_d, 3)
        if v is None:
            return []
        if max(abs(a) for a in v) > MAX_DVL_SPEED_MPS:
            return self._refuse("dvl_velocity", t, "v_d", f"beyond the DVL's velocity range ({MAX_DVL_SPEED_MPS:g} "
                                f"m/s): {list(v)}")
        try:
            s = (math.nan,) * 3 if sigma is None else tuple(float(a) for a in sigma)
        except (TypeError, ValueError) as exc:
            return self._refuse("dvl_velocity", t, "sigma", f"not a vector of 3 numbers ({exc})")
        if len(s) != 3 or not all(a > 0 and math.isfinite(a) or math.isnan(a) for a in s):
            return self._refuse("dvl_velocity", t, "sigma", f"expected 3 values > 0 (m/s; NaN: the configured one), "
                                f"got {list(s)}")
        if (self._sent_twice("dvl_velocity", t, v + tuple(None if math.isnan(a) else a for a in s))
                or not self._accept("dvl_velocity", t)):
            return []
        return self._zero_judged("dvl_velocity", t, v, (v, s))

    def add_depth(self, t: float, depth_m: float) -> list[EpochEstimate]:
        """Depth of the IMU (m, positive down) from a pressure sensor."""
        self.received["depth"] = self.received.get("depth", 0) + 1
        d = self._scalar("depth", t, "depth_m", depth_m)
        if d is None or self._sent_twice("depth", t, (d,)) or not self._accept("depth", t):
            return []
        why = self._screen.depth_problem(t, d)
        if why is not None:
            return self._refuse("depth", t, why, f"depth {d:.6g} m ({why}; SensorConfig.depth_range_m, "
                                "depth_jump_tolerance_m)", screened=True)
        return self._push("depth", t, (d,))

    def add_position_fix(self, t: float, lat: float, lon: float, sigma_m: float) -> list[EpochEstimate]:
        """A horizontal position fix (GNSS at the surface, USBL): geodetic ``lat``, ``lon`` (rad) with a
        1-sigma of ``sigma_m`` (m) per horizontal axis."""
        self.received["fix"] = self.received.get("fix", 0) + 1
        vals = [self._scalar("fix", t, name, x) for name, x in (("lat", lat), ("lon", lon), ("sigma_m", sigma_m))]
        if any(v is None for v in vals) or self._sent_twice("fix", t, tuple(vals)) or not self._accept("fix", t):
            return []
        if vals[2] <= 0:
            return self._refuse("fix", t, "sigma_m", f"must be > 0, got {vals[2]}")
        return self._push("fix", t, tuple(vals))

    def add_heading(self, t: float, yaw: float, sigma: float) -> list[EpochEstimate]:
        """A heading measurement (AHRS, magnetometer): yaw of ``C_b_n`` (rad, from north, clockwise seen from
        above) with 1-sigma ``sigma`` (rad)."""
        self.received["heading"] = self.received.get("heading", 0) + 1
        vals = [self._scalar("heading", t, name, x) for name, x in (("yaw", yaw), ("sigma", sigma))]
        if (any(v is None for v in vals) or self._sent_twice("heading", t, tuple(vals))
                or not self._accept("heading", t)):
            return []
        if vals[1] <= 0:
            return self._refuse("heading", t, "sigma", f"must be > 0, got {vals[1]}")
        return self._push("heading", t, tuple(vals))

    def finish(self) -> list[EpochEstimate]:
        """End of data: release everything still buffered and close the keyframes the IMU covers."""
        self._check_refused()
        out = self._queue_packet(self._packets.flush(self._released))
        out += self._release(math.inf)
        if self._judging is not None:        # the data ended within the window that judges a gap
            out += self._judge_gap()
        self._warn_stall()
        if self.backend is None and self.aligner is not None:
            out += self._align_at_end()
        if self.backend is not None:
            out += self._process(self.keyframer.finish())
        elif self.aligner is not None:
            warnings.warn(f"navigator: the data ended before the alignment finished ({self._align_missing()}); "
                          "no estimate was made", RuntimeWarning, stacklevel=2)
        self._warn_refusals()
        return out

    # --- outputs ------------------------------------------------------------------------------------
    @property
    def completer(self):
        """The beam completer the hybrid methods regress missing beams with (None without one)."""
        return self._completer

    @property
    def initialised(self) -> bool:
        return self.backend is not None

    def estimate(self) -> EpochEstimate:
        """The latest filtered state (pose, velocity, biases) with its velocity covariance."""
        if self._latest is None:
            why = "still aligning: " + self._align_missing() if self.aligner is not None else "no keyframe closed yet"
            raise ConfigError(f"navigator: no estimate yet ({why})")
        return self._latest

    def state_at(self, t: float) -> NavState:
        """The state at t (s), propagated from the latest estimate with the IMU samples received since
        (GTSAM preintegration with the estimated biases; the part of the newest sample up to t to first
        order), for t between the latest estimate and the newest IMU sample plus ``max_extrapolation_s``.
        Repeated calls with increasing t integrate each new sample once (tens of microseconds a call). After a loss
        of track (:attr:`lost_track`) there is no state to give: a ConfigError naming it."""
        est = self.estimate()
        if self.lost_track is not None:     # propagated on from the last estimate, it drifted unsaid for as long
            raise ConfigError(f"state_at({t:.3f}): the {self.backend_name} estimator lost track at t = "
                              f"{self.lost_track[0]:.3f} s ({self.lost_track[1]}); no state after its last estimate "
                              f"(t = {est.t:.3f} s)")
        # the samples since the one covering the latest estimate: the keyframer's (released), then the ones
        # still in the reorder buffer; a sample keeps its index here until the next estimate
        recent = _Concat(self.keyframer.samples, self._imu_q)
        if t < est.t - 1e-9:
            raise ConfigError(f"state_at({t:.3f}): before the latest estimate (t = {est.t:.3f} s)")
        newest = recent[-1][0] if recent else est.t
        if t > newest + self.options.max_extrapolation_s:
            raise ConfigError(f"state_at({t:.3f}): more than {self.options.max_extrapolation_s} s after the newest "
                              f"IMU sample (t = {newest:.3f} s)")
        _, pim, upto, j = self._advance_propagation(est, recent, t)
        start = gtsam.NavState(est.pose, est.v_n)
        nav = pim.predict(start, est.bias) if upto > est.t else start
        C, v, p = nav.attitude().matrix(), nav.velocity(), nav.position()
        if not recent:
            return NavState(t, C, v, p, np.zeros(3))
        _, f, w = recent[j]
        omega = np.asarray(w) - est.bias.gyroscope()
        dt = t - upto
        if dt > 0:
            acc = C @ (np.asarray(f) - est.bias.accelerometer()) + self._earth.gravity_n(p)
            p = p + v * dt + 0.5 * acc * dt * dt
            v = v + acc * dt
            C = C @ gtsam.Rot3.Expmap(omega * dt).matrix()
        return NavState(t, C, v, p, omega)

    def _advance_propagation(self, est: EpochEstimate, recent, t: float) -> list:
        """The cached preintegration from the latest estimate, advanced over the whole IMU samples up to t:
        [estimate, pim, integrated up to (s), index of the sample that holds at that stamp]."""
        prop = self._prop
        if prop is None or prop[0] is not est or t < prop[2]:
            j = 0
            while j + 1 < len(recent) and recent[j + 1][0] <= est.t:
                j += 1
            # a fresh propagation: the gravity of the estimate's position (GTSAM takes one vector per
            # preintegration; it changes 1.5e-6 m/s^2 per metre, nothing over the seconds propagated here)
            self._pim_params.n_gravity = preintegration_gravity(self._earth, est.pose.translation(), est.v_n, 0.0)
            prop = [est, gtsam.PreintegratedImuMeasurements(self._pim_params, est.bias), est.t, j]
        _, pim, upto, j = prop
        while j + 1 < len(recent) and recent[j + 1][0] <= t:
            if recent[j + 1][0] > upto:
                pim.integrateMeasurement(recent[j][1], recent[j][2], self.keyframer.live_time(upto, recent[j + 1][0]))
                upto = recent[j + 1][0]
            j += 1
        prop[2], prop[3] = upto, j
        self._prop = prop
        return prop

    @property
    def info(self) -> dict:
        """Counters and diagnostics: refused samples per stream and reason, keyframer repairs, backend info,
        alignment summary; with a network completer, the pings it left to the average estimator since this Navigator
        was made, by reason (``completer_fallbacks``, as :func:`graphnav.evaluation.methods.run_method` counts them)."""
        stats = self.keyframer.stats
        info = {"backend": self.backend_name, "estimates": self.n_estimates,
                "refused": {k: dict(v) for k, v in self.refused.items()},
                "received": dict(self.received), "samples_refused": dict(self.samples_refused),
                "n_refused": sum(sum(v.values()) for v in self.refused.values()),
                "imu_zero_rows": stats.zero_imu_rows, "imu_gaps": len(stats.imu_gaps),
                "imu_start_burst": (self.keyframer.imu_period.start_burst or (0,))[0],
                "imu_restamped": self._packets.restamped,
                "fixes_decimated": stats.fixes_decimated, "pings_before_start": stats.pings_before_start,
                "pings_after_end": stats.pings_after_end, "regressed_pings": stats.regressed_pings,
                "regressed_beams": stats.regressed_beams, "velocity_pings": stats.velocity_pings,
                "velocity_superseded": stats.velocity_superseded, "beams_superseded": stats.beams_superseded}
        if self.notes:
            info["notes"] = {k: list(v) for k, v in self.notes.items()}
        if self.gaps_judged:
            info["gaps_in_every_stream"] = dict(self.gaps_judged)
        if self.doubted:
            info["doubted"] = {k: dict(v) for k, v in self.doubted.items()}
        if stats.imu_window_missing is not None:
            info["imu_window_missing"] = dict(stats.imu_window_missing)
        if self._fallbacks_before:
            info["completer_fallbacks"] = {k: self._completer.fallbacks[k] - n
                                           for k, n in self._fallbacks_before.items()}
        if self.backend is not None:
            info.update(self.backend.info)
            info["n_fixes"] = self.backend.n_fixes
            if self.backend.first_fix_departure is not None:
                info["first_fix_departure_m"], info["first_fix_departure_sigmas"] = self.backend.first_fix_departure
            info.update(self.coasting.summary())
            info.update(self.sigma.summary())
        if self.alignment is not None:
            a = self.alignment
            info["alignment"] = {**a.info, "t": a.t, "heading_source": a.heading_source,
                                 "completed_t": self.alignment_ready_t}
        if self.backend is not None:
            info["position_frame"] = self.backend.position_frame(info)
        return info

    def keyframe_graphs(self) -> list:
        """Every keyframe's factors so far, one (link factors, :class:`~graphnav.estimators.graph.builder.
        KeyframeFactors`) per keyframe, for :func:`graphnav.estimators.graph.batch.batch_smooth` afterwards.
        ConfigError unless the Navigator runs a graph backend made with ``keep_keyframe_graphs=True``."""
        return self._graph_backend("keyframe factors").keyframe_graphs()

    def dvl_errors(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """The DVL error states of keyframe ``index`` while it is still in the graph: estimate (7,) [scale per DVL
        axis, bias per beam m/s] and marginal covariance (7,7). ConfigError without a graph backend with
        ``GraphOptions.dvl_error_states``."""
        return self._graph_backend("DVL error states").dvl_errors(index)

    def screening_counts(self) -> dict:
        """What a graph backend did with regressed beams so far (``regressed_screening``) and the motion-prior
        switch's counters (:meth:`graphnav.estimators.backends.GraphBackend.screening_counts`, also in :attr:`info`);
        {} before the start and for the EKF, whose counts are in :attr:`info` only."""
        if self.backend is None or not hasattr(self.backend, "screening_counts"):
            return {}
        return self.backend.screening_counts()

    def _graph_backend(self, what: str):
        if self.backend is None or not hasattr(self.backend, "keyframe_graphs"):
            state = "has not started" if self.backend is None else f"runs the '{self.backend_name}' backend"
            raise ConfigError(f"navigator: no {what}: the navigator {state}, not a graph backend")
        return self.backend

    # --- internals ----------------------------------------------------------------------------------
    def _refuse(self, stream: str, t, field_name: str, why: str, screened: bool = False) -> list:
        """Count and warn (three times per stream and key). ``field_name`` is the count key: the field for
        malformed samples, the screening reason when ``screened``."""
        counts = self.refused.setdefault(stream, {})
        counts[field_name] = counts.get(field_name, 0) + 1
        self.samples_refused[stream] = self.samples_refused.get(stream, 0) + 1
        n = counts[field_name]
        if n <= 3:
            finite = isinstance(t, (int, float)) and math.isfinite(t)
            stamp = (f"{t:.6f}" if abs(t) < 1e12 else f"{t:.6g}") if finite else repr(t)
            what = f"refused ({field_name}): {why}" if screened else f"refused, field '{field_name}': {why}"
            warnings.warn(f"navigator: {stream} sample at t = {stamp} s {what}"
                          + ("; further refusals of this kind are only counted" if n == 3 else ""),
                          RuntimeWarning, stacklevel=3)
        return []

    def _note(self, stream: str, text: str) -> None:
        """A sentence about ``stream`` a user must see: warned once and kept in :attr:`info` (``notes``)."""
        self.notes.setdefault(stream, []).append(text)
        warnings.warn(f"navigator: {stream}: {text}", RuntimeWarning, stacklevel=3)

    def _stop_at_clock_step(self, stream: str) -> None:
        """DataError naming the clock jump once the IMU samples refused for it show the clock stepped
        (:meth:`~graphnav.core.screening.StreamScreen.clock_stepped`): every sample after it would be refused;
        ``stream``: that of the sample being refused. Before the estimator started, with no more of the stream on the
        old clock than the second of IMU samples on the new one that confirmed the step (or all of it still in the
        reorder buffer), the stream starts over on the new clock instead (:meth:`_start_over_on_new_clock`): a
        logger's first fraction of a second stamped before its clock was set is longer than the reorder window. The
        IMU alone off the clock the other streams go on with (:attr:`~graphnav.core.screening.StreamScreen.imu_alone`)
        is no step: refused while it is so from its start, named as on its own clock once it left the shared one."""
        if not self._screen.clock_stepped():
            return
        if self._screen.imu_alone:
            # an IMU stamped on its own clock from the start (its boot) is refused until it comes on the shared one,
            # and named at the end if it never does; one that went on the shared clock and left it alone is named now
            imu_kept = self._kept(stream).get("imu", 0)
            if self.backend is None and imu_kept <= CLOCK_JUMP_CONFIRM_S * self.config.imu_rate_hz:
                return
            raise DataError(f"navigator: {self._screen.clock_jump_text(self.received)}", "imu", field="t")
        old_clock_s = self._screen.clock_jump[1] - self._screen.oldest
        if self.backend is None and (self._released == -math.inf or old_clock_s <= CLOCK_JUMP_CONFIRM_S):
            self._start_over_on_new_clock(stream)
            return
        raise DataError(f"navigator: {self._screen.clock_jump_text(self.received)}", self._screen.clock_jump[0],
                        field="t")

    def _kept(self, refusing: str) -> dict[str, int]:
        """Samples received and not refused, per stream, the one of ``refusing`` being refused now counted out."""
        return {k: n - self.samples_refused.get(k, 0) - (k == refusing) for k, n in self.received.items()}

    def _start_over_on_new_clock(self, refusing: str) -> None:
        """The clock stepped days ahead or back before the estimator started, after at most a second of samples (a
        stream whose first stamps are bad, 0 then Unix time, or Unix time then seconds since boot;
        :meth:`_stop_at_clock_step`): those few are
        not trusted over the second of IMU samples after them that confirmed the new clock. They are refused and
        counted, and the Navigator starts over on the new clock, its counts kept (the samples that showed the step
        were refused already; ``refusing``: the stream of the one being refused)."""
        stream, before, after = self._screen.clock_jump
        kept = {k: n for k, n in self._kept(refusing).items() if n > 0}
        jumped = ", ".join(f"{n} {k}" for k, n in self._screen.jumped.items())
        counts = self.received, self.samples_refused, self.refused, self.notes, self.doubted
        config, backend, kwargs = self._init_args
        self.__init__(config, backend, **kwargs)
        self.received, self.samples_refused, self.refused, self.notes, self.doubted = counts
        for k, n in kept.items():      # counted as any refused stamp (field 't')
            self.samples_refused[k] = self.samples_refused.get(k, 0) + n
            self.refused.setdefault(k, {})["t"] = self.refused.get(k, {}).get("t", 0) + n
        warnings.warn(f"navigator: the clock jumped {clock_jump_words(before, after)} at t = {before:.3f} s, first "
                      f"on the {stream} stream (its sample stamped {after:.6g} s), after only "
                      f"{', '.join(f'{n} {k}' for k, n in kept.items())} sample(s): those are refused as stamped on "
                      f"another clock than the stream went on with, and the stream starts over on that clock "
                      f"({jumped} samples after the step were refused while it could have been corrupted stamps)",
                      RuntimeWarning, stacklevel=4)

    def _check_refused(self) -> None:
        """DataError when more than MAX_REFUSED_FRACTION of a stream was refused: the data are not what the
        configuration describes (units, column map, ranges), and a trajectory from the rest would mislead."""
        for stream, n in self.received.items():
            bad = self.samples_refused.get(stream, 0)
            if n >= 10 and bad > MAX_REFUSED_FRACTION * n and self._screen.jumped.get(stream, 0) > bad / 2:
                raise DataError(f"navigator: {self._screen.clock_jump_text(self.received, stream)}",
                                self._screen.clock_jump[0], field="t")
            if n >= 10 and bad > MAX_REFUSED_FRACTION * n:
                reasons = ", ".join(f"{k}: {c}" for k, c in sorted(self.refused.get(stream, {}).items(),
                                                                    key=lambda kv: -kv[1]))
                raise DataError(f"navigator: {bad} of {n} {stream} samples refused ({reasons}): more than "
                                f"{MAX_REFUSED_FRACTION:.0%} of the stream; check units and sensor ranges",
                                stream, field=stream)

    def _warn_refusals(self) -> None:
        for stream, counts in self.refused.items():
            many = {k: n for k, n in counts.items() if n > 3}
            if many:
                warnings.warn(f"navigator: {stream} samples refused in all: {many}", RuntimeWarning, stacklevel=3)

    def _stamp_ok(self, stream: str, t) -> bool:
        try:
            ok = math.isfinite(t)
        except TypeError:
            ok = False
        if not ok:
            self._refuse(stream, t, "t", "stamp is not a finite number")
            return False
        why = self._screen.stamp_problem(stream, t)
        if why is not None:
            self._stop_at_clock_step(stream)
            self._refuse(stream, t, "t", why)
            return False
        return True

    def _vector(self, stream: str, t, name: str, x, n: int):
        if not self._stamp_ok(stream, t):
            return None
        try:
            v = tuple(float(a) for a in x)
        except (TypeError, ValueError) as exc:
            self._refuse(stream, t, name, f"not a vector of {n} numbers ({exc})")
            return None
        if len(v) != n or not all(math.isfinite(a) for a in v):
            self._refuse(stream, t, name, f"expected {n} finite values, got {list(v)}")
            return None
        return v

    def _scalar(self, stream: str, t, name: str, x):
        if not self._stamp_ok(stream, t):
            return None
        try:
            v = float(x)
        except (TypeError, ValueError):
            v = math.nan
        if not math.isfinite(v):
            self._refuse(stream, t, name, f"not a finite number: {x!r}")
            return None
        return v

    def _accept(self, stream: str, t: float) -> bool:
        if t in self._stamps[stream] or t == self._last_released[stream]:
            self._refuse(stream, t, "t", "duplicate stamp")
            return False
        if t < self._released:
            self._refuse(stream, t, "t", f"out of order: {self._released - t:.3f} s older than what already left "
                         f"the reorder buffer (window {self.options.reorder_window_s} s)")
            return False
        return True

    def _zero_judged(self, stream: str, t: float, values, sample: tuple) -> list[EpochEstimate]:
        """A ping of ``stream`` (``values`` as logged, NaN where not a measurement; ``sample``: what
        :meth:`_take_ping` makes it from) past the zero-ping test: refused as no bottom lock, taken, or held until
        the next ping says whether its run of zeros is no lock (the loaders look at the ping after a run too);
        the reorder buffer releases nothing from a held ping's stamp on meanwhile."""
        zero = self._screen.zero_ping.get(stream)
        if zero is None:
            return self._take_ping(stream, t, sample)
        verdict, held = zero.judge(t, values)
        out = self._settle(stream, held)
        if verdict is None:
            self._held[stream].append((t, sample))
            self._stamps[stream].add(t)
            self._hold_until()
            return out + self._release(self._newest - self.options.reorder_window_s)
        if verdict:
            return out + self._refuse(stream, t, NO_BOTTOM_LOCK, ZERO_PING_WHY[stream], screened=True)
        return out + self._take_ping(stream, t, sample)

    def _settle(self, stream: str, no_lock: bool | None) -> list[EpochEstimate]:
        """Refuse (``no_lock``) or take the zero pings held on ``stream``; None: keep holding them."""
        held = self._held[stream]
        if no_lock is None or not held:
            return []
        self._held[stream] = []
        self._hold_until()
        out = []
        for t, sample in held:
            self._stamps[stream].discard(t)
            out += (self._refuse(stream, t, NO_BOTTOM_LOCK, ZERO_PING_WHY[stream], screened=True) if no_lock
                    else self._take_ping(stream, t, sample))
        return out

    def _hold_until(self) -> None:
        """The newest stamp the reorder buffer may release while zero pings are held (just before the oldest)."""
        first = [h[0][0] for h in self._held.values() if h]
        self._hold_before = math.nextafter(min(first), -math.inf) if first else math.inf

    def _take_ping(self, stream: str, t: float, sample: tuple) -> list[EpochEstimate]:
        if stream == "dvl_velocity":
            return self._push(stream, t, (Ping.from_velocity(t, *sample),))
        b, v = sample
        screened = self._screen.dvl_problems(t, b, v)
        if screened:        # a beam the instrument got wrong makes the ping suspect: refused as a whole
            i, why = next(iter(screened.items()))
            return self._refuse("dvl", t, why, f"beam {i + 1} = {b[i]:.6g} m/s ({why}; DvlSpec max_speed_mps, "
                                "max_accel_mps2, jump_tolerance_mps)", screened=True)
        return self._push("dvl", t, (Ping.from_beams(t, b, v),))

    def _push(self, stream: str, t: float, payload: tuple) -> list[EpochEstimate]:
        heapq.heappush(self._heap, (t, STREAM_ORDER[stream], self._seq, stream, payload))
        self._seq += 1
        self._stamps[stream].add(t)
        if t > self._newest:
            self._newest = t
        return self._release(self._newest - self.options.reorder_window_s)

    def _release(self, until: float) -> list[EpochEstimate]:
        out = []
        if until > self._hold_before:
            for stream, held in self._held.items():     # a DVL silent for so long: its next ping cannot tell
                if held and (until == math.inf or self._newest - held[-1][0] > self._screen.zero_ping[stream].hold_s):
                    out += self._settle(stream, False)
            until = min(until, self._hold_before)
        # an IMU packet held for its end: what it will be spread over must not leave before it; one held so long
        # that the IMU went silent has ended, and is queued before anything leaves past it
        out += self._queue_packet(self._packets.overdue(self._newest, self._released))
        if until < math.inf:        # the end of the data holds nothing back
            until = min(until, self._packets.release_limit(self._newest))
        heap, q, held = self._heap, self._imu_q, self._stall_held
        while True:
            if q and q[0][0] <= until and (held or not heap or q[0][0] < heap[0][0]):
                t, f, w = q.popleft()
                self._last_imu_released = self._released = t
                if self._stalled(t, f, w):
                    continue
                if self._imu_spike(t, f, w):
                    continue
                self._stall.passed(t, f + w)
                self._doubt_untold_stall(t)
                if self.backend is not None:
                    out += self._feed_imu(t, f, w)
                else:
                    out += self._dispatch("imu", t, (f, w))
            elif held and until == math.inf:        # the data ended in a held run, or in the second after one
                self._end_held_run()
            elif heap and heap[0][0] <= until and not held:
                t, _, _, stream, payload = heapq.heappop(heap)
                self._stamps[stream].discard(t)
                self._last_released[stream] = self._released = t
                out += self._dispatch(stream, t, payload)
            else:
                return out

    def _stalled(self, t: float, f: tuple, w: tuple) -> bool:
        """Whether the IMU sample leaving the reorder buffer (stamp ``t`` s) is held or refused as part of a run
        repeating the sample before it (:class:`~graphnav.core.screening.ImuStallTest`, the loaders' rule): held
        while the run is shorter than a stall, refused once it is one (a run no length makes one, a reading of a
        vehicle at rest, goes on at once: held, it delayed every estimate as long as the vehicle rested); a sample
        ending a held run that was no stall comes back after it, to go on in stamp order. A run as long as a stall
        with under a second of samples before its reading is held on with the second after it, which judges it
        (:meth:`_judge_by_after`)."""
        if t <= self._stall_cleared:
            return False
        held, refused, after = self._stall_held, self._stall_refused, self._stall_after
        if after is not None:
            if t - held[-1][0] <= IMU_STALL_CONTEXT_S:
                after.append((t, f, w))
            else:
                self._imu_q.appendleft((t, f, w))
                self._judge_by_after()
            return True
        if self._stall.repeats(f + w) and (held or refused or self._stall.may_stall()
                                           or self._stall.untold_may_stall()):
            self._prop = None
            if refused:
                refused.append(t)
            else:
                held.append((t, f, w))
                if self._stall.stalled(t):
                    refused += [x[0] for x in held]
                    held.clear()
            return True
        self._warn_stall()
        if not held:
            return False
        self._imu_q.appendleft((t, f, w))
        if self._stall.untold_long(held[-1][0]):
            self._stall_after = []      # this sample first, when within the second after the run
        else:
            self._let_held_go()
        return True

    def _judge_by_after(self) -> None:
        """A held run as long as a stall with under a second of samples before its reading (the stream's first
        second, right after an IMU gap) judged by the samples of the second after it, as the loaders judge
        (:meth:`ImuStallTest.stalled_after`): refused and warned as a stall, or let go; the samples after it go back
        to the front of the reorder buffer, to be judged in turn. With none after it (the data ended, an IMU gap),
        nothing tells: let go, and doubted (:meth:`_doubt_untold_stall`)."""
        held, after = self._stall_held, self._stall_after
        self._stall_after = None
        self._imu_q.extendleft(reversed(after))
        if self._stall.stalled_after(held[-1][0], [f + w for _, f, w in after]):
            self._stall_refused += [x[0] for x in held]
            held.clear()
            self._warn_stall(f"the reading at t = {self._stall.reading_stamp:.3f} s repeated "
                             f"{self._untold_where(self._stall.reading_stamp)}, judged by the {IMU_STALL_CONTEXT_S:g} "
                             "s of samples after it as the loaders do")
            return
        if after:
            self._stall_judged = self._stall.reading_stamp
        self._let_held_go()

    def _end_held_run(self) -> None:
        """The data ended in a held run that was no stall, or in the second after one the samples after it judge."""
        if self._stall_after is not None:
            self._judge_by_after()
        else:
            self._let_held_go()

    def _doubt_untold_stall(self, t: float) -> None:
        """Count as doubted (and warn once per run) the IMU samples repeating one reading as long as a stall while the
        stream has under a second of samples before that reading (:meth:`ImuStallTest.untold`: the stream's first
        second, or just after an IMU gap) and no sample within a second after the run to judge it by
        (:meth:`_judge_by_after`: the data ended, an IMU gap); used, not refused, as the loaders keep a run with
        nothing around it to tell it from an IMU whose readings repeat from its start."""
        if not self._stall.untold(t) or self._stall.run[0] == self._stall_judged:
            return
        t_read, n = self._stall.run
        counts = self.doubted.setdefault("imu", {})
        if t_read != self._untold_read:
            self._untold_read = t_read
            warnings.warn(f"navigator: imu: the reading at t = {t_read:.3f} s is repeated in every value for "
                          f"{t - t_read:.3f} s or more {self._untold_where(t_read)}: a stalled IMU cannot be told "
                          "there from one whose readings repeat from its start (no second of samples before it, "
                          "none within a second after it); used, counted as doubted (check the IMU driver if the "
                          "vehicle moved)", RuntimeWarning, stacklevel=4)
        else:
            n = 1
        counts[IMU_STALL_UNTOLD] = counts.get(IMU_STALL_UNTOLD, 0) + n

    def _untold_where(self, t_read: float) -> str:
        """Where a reading at ``t_read`` (s) has under a second of IMU samples before it."""
        # the other way to have under a second of samples before it: an IMU gap just before the reading
        return (f"in the stream's first {IMU_STALL_CONTEXT_S:g} s" if t_read - self._screen.oldest < IMU_STALL_CONTEXT_S
                else f"right after an IMU gap (under {IMU_STALL_CONTEXT_S:g} s of IMU samples before it)")

    def _let_held_go(self) -> None:
        """The held run was no stall: back to the front of the reorder buffer, to go on unjudged."""
        held = self._stall_held
        self._imu_q.extendleft(reversed(held))
        self._stall_cleared = held[-1][0]
        held.clear()

    def _warn_stall(self, how: str = "") -> None:
        """Count and warn about the stalled run refused (the estimator then bridges it as a gap, as the loaders');
        ``how``: how it was judged, when not by the second before it."""
        refused = self._stall_refused
        if not refused:
            return
        n = len(refused)
        counts = self.refused.setdefault("imu", {})
        counts[IMU_STALLED] = counts.get(IMU_STALLED, 0) + n
        self.samples_refused["imu"] = self.samples_refused.get("imu", 0) + n
        how = f" ({how})" if how else ""
        warnings.warn(f"navigator: {n} imu sample(s) refused ({n} {IMU_STALLED}) from t = {refused[0]:.3f} to "
                      f"{refused[-1]:.3f} s{how}; they are not used", RuntimeWarning, stacklevel=4)
        refused.clear()

    def _imu_spike(self, t: float, f: tuple, w: tuple) -> bool:
        """True when the spike test refuses the IMU sample leaving the reorder buffer (refused and counted). It
        runs here, in stamp order, not on arrival: its history is the past, and a sample that arrived late belongs
        before the ones that overtook it. The propagation :meth:`state_at` cached over the buffered samples, this
        one included, starts again without it."""
        if any(t0 <= t <= t1 for t0, t1 in self.options.imu_shocks):
            return False        # nor does a kept shock's row join the history its next rows are compared with
        spike = self._screen.imu_spike(t, f, w)
        if not self._imu_spike_noted and self._screen.imu_spike_note is not None:
            self._imu_spike_noted = True
            self._note("imu", self._screen.imu_spike_note)
        if spike is None:
            return False
        self._refuse("imu", t, spike[0], spike[1], screened=True)
        self._prop = None
        return True

    def _dispatch(self, stream: str, t: float, payload: tuple) -> list[EpochEstimate]:
        if self.backend is None:
            if stream == "imu":     # before the start the keyframer only keeps the sample that covers t0
                gaps = self.keyframer.stats.imu_gaps
                n_gaps = len(gaps)
                self.keyframer.add_imu(t, *payload)
                if len(gaps) > n_gaps:     # the keyframer's rule: the gap the estimator will bridge
                    self.aligner.imu_gap(gaps[-1].t_start, gaps[-1].t_end)
                if not (any(payload[0]) or any(payload[1])):
                    return []       # an all-zero row (dropped and counted by the keyframer) is no alignment data
            if self.options.align_catch_up:
                events = self._align_events
                events.append((stream, t, payload))
                while events[0][1] < t - self.options.align_buffer_s:
                    events.popleft()
            return self._align(stream, t, payload)
        if stream == "imu":
            return self._feed_imu(t, *payload)
        self._other_since_imu = min(self._other_since_imu, t)
        if self._judging is not None:
            self._judging["events"].append((stream, t, payload))
            return []
        if stream in PING_STREAMS:
            kfs = self.keyframer.add_ping(*payload)
        else:
            kfs = getattr(self.keyframer, "add_" + stream)(t, *payload)
        return self._process(kfs) if kfs else []

    def _feed_imu(self, t: float, f: tuple, w: tuple) -> list[EpochEstimate]:
        """An IMU sample released to the running estimator. After a gap of at least ``JUDGED_GAP_MIN_S`` in which no
        other stream has a sample either, it and everything released after it are held until ``JUDGE_WINDOW_S`` of
        IMU samples past the gap (and ``MIN_SAMPLES``: a slow IMU's 0.5 s are too few to fit) tell a step of the clock
        from a loss (:meth:`_judge_gap`)."""
        judging, before = self._judging, self._imu_before
        other, self._other_since_imu = self._other_since_imu, math.inf
        out = []
        if judging is not None and t - judging["after"][-1][0] >= JUDGED_GAP_MIN_S and other >= t - AFTER_GAP_S:
            # a second gap before the window after the first filled: the first is judged by the samples between
            # (held on, this one would be fitted inside that window and bridged unjudged), this one on its own
            out, judging = self._judge_gap(), None
        if judging is None and before and t - before[-1][0] >= JUDGED_GAP_MIN_S and other >= t - AFTER_GAP_S:
            judging = self._judging = {"after": [], "events": []}
        if judging is not None:
            judging["after"].append((t, f, w))
            judging["events"].append(("imu", t, (f, w)))
            return out + self._judge_gap() if side_full(judging["after"]) else out
        before.append((t, f, w))
        if len(before) > MIN_SAMPLES and before[0][0] < t - JUDGE_WINDOW_S:
            before.popleft()
        kfs = self.keyframer.add_imu(t, f, w)
        return out + self._process(kfs) if kfs else out

    def _judge_gap(self) -> list[EpochEstimate]:
        """Decide the gap held (:func:`~graphnav.estimators.clock_steps.judge_gap`), say and count the verdict, and
        feed what was held: a step joined with no time passed (:meth:`Keyframer.join_step`), a loss bridged as any
        IMU gap; undecided, bridged as a loss and every estimate after it degraded, saying why."""
        judging, self._judging = self._judging, None
        before, after = list(self._imu_before), judging["after"]
        period = self.keyframer.imu_period.period_s
        verdict = judge_gap(before, after, period)
        kind = "undecided" if verdict is None else verdict.kind
        why = verdict.why if verdict is not None else (f"under {MIN_SAMPLES} IMU samples on a side of it to judge "
                                                         "by")
        self.gaps_judged[kind] = self.gaps_judged.get(kind, 0) + 1
        (t0, _, w0), (t1, _, w1) = before[-1], after[0]
        tau = t1 - t0
        # what a loss bridges: the rates either side interpolated over the gap
        turn_deg = math.degrees(float(np.linalg.norm(0.5 * (np.asarray(w0) + np.asarray(w1)) * tau)))
        head = f"navigator: no stream has a sample for {tau:.3f} s after t = {t0:.3f} s"
        if kind == "step":
            text = (f"{head}: taken as a step of the clock they share ({why}); joined with no time passed (its "
                    f"stamps from t = {t1:.3f} s on are {tau - period:.3f} s ahead of the vehicle's time)")
        elif kind == "loss":
            text = f"{head}: taken as a loss of every sensor ({why}); bridged"
        else:
            text = (f"{head}: a step of the clock they share cannot be told from a loss of every sensor ({why}); "
                    f"bridged as a loss, a turn of {turn_deg:.1f} deg a step would not have made; the estimates "
                    "after it are degraded")
            self._gap_doubt = (f"the gap of {tau:.3f} s in every stream after t = {t0:.3f} s may be a step of their "
                               f"clock, not a loss (a turn of {turn_deg:.1f} deg bridged)")
        warnings.warn(f"{text} (counted in info['gaps_in_every_stream'])", RuntimeWarning, stacklevel=5)
        self._imu_before.clear()
        out = []
        for stream, t, payload in judging["events"]:
            if stream != "imu":
                out += self._dispatch(stream, t, payload)
                continue
            kfs = self.keyframer.join_step(t, *payload) if kind == "step" and t == t1 else \
                self.keyframer.add_imu(t, *payload)
            self._imu_before.append((t, *payload))
            out += self._process(kfs) if kfs else []
        self._other_since_imu = math.inf        # the samples replayed came before the IMU sample that ends them
        return out

    def _process(self, kfs) -> list[EpochEstimate]:
        out = []
        for kf in kfs:
            if self.lost_track is not None:
                break
            try:
                est = self.backend.process(kf)
                if not (np.all(np.isfinite(est.p_n)) and np.all(np.isfinite(est.v_n))):
                    raise LostTrack(kf.t, f"its estimate is not finite (velocity {np.linalg.norm(est.v_n):.3g} m/s)")
            except (LostTrack, np.linalg.LinAlgError, RuntimeError) as exc:
                # numpy's singular or not positive definite matrix is the numbers failing; an array of the wrong shape
                # ("Last 2 dimensions of the array must be square") is a programming error, to be seen as one
                if (isinstance(exc, RuntimeError) and not is_indeterminant(exc)
                        or isinstance(exc, np.linalg.LinAlgError) and "dimension" in str(exc)):
                    raise
                self._lose_track(kf.t, exc.why if isinstance(exc, LostTrack) else
                                 f"{type(exc).__name__}: {str(exc).strip().splitlines()[0]}")
                break
            self.coasting.update(est.t, self.backend.last_aided, est.cov_v_n, self.backend.last_completed)
            self.sigma.update(est.t, est.v_n, est.cov_v_n)
            est.health, est.health_why = epoch_health(self.backend.monitor, self.coasting, self.sigma)
            if self._gap_doubt is not None:     # an undecided gap: never "ok" after it, and said why
                est.health = "degraded" if est.health == "ok" else est.health
                est.health_why = "; ".join(w for w in (est.health_why, self._gap_doubt) if w)
            out.append(est)
        if out:
            self._latest = out[-1]
            self.n_estimates += len(out)
            if self._prop is not None:
                # a controller reads state_at: propagate the new estimate now rather than in its next call
                recent = _Concat(self.keyframer.samples, self._imu_q)
                if recent:
                    self._advance_propagation(self._latest, recent, recent[-1][0])
        return out

    def _lose_track(self, t: float, why: str) -> None:
        """The estimator's numbers failed at ``t`` (s) (:class:`~graphnav.estimators.health.LostTrack`, a singular
        matrix, a solver that failed twice): it takes nothing more; the estimates before stand, and the run ends
        diverged (said by its monitor, :meth:`~graphnav.estimators.health.NisMonitor.lost`, and here)."""
        self.lost_track = (float(t), why)
        self._say_lost_track()

    def _say_lost_track(self) -> None:
        """Flag and warn about the loss of track on the monitor that publishes the health (once per monitor)."""
        t, why = self.lost_track
        monitor = self.backend.monitor
        if monitor is None or monitor.lost_at is not None:
            return
        monitor.lost(t, why, self._latest.t if self._latest is not None else None)
        made = f" (to t = {self._latest.t:.3f} s)" if self._latest is not None else ""
        warnings.warn(f"navigator: {self.backend_name} lost track at t = {t:.3f} s ({why}); it takes no more data: "
                      f"the {self.n_estimates} estimate(s) made{made} stand, none follows", RuntimeWarning,
                      stacklevel=2)

    # --- initialisation -----------------------------------------------------------------------------
    def _refuse_rehearsal(self) -> None:
        """Refuse ``GraphOptions.rehearsed_outages`` before any data where it cannot serve: a graph without a
        completer (nothing to rehearse), a completer without ``rehearse``, a batch smoother's first pass; and
        ``GraphOptions.measured_both_margin`` without a completer whose sigma the measured beams judge."""
        options = self._backend_kwargs["graph_options"]
        if self.backend_name != "ekf" and options is not None and options.measured_both_margin is not None \
                and run_sigma_of(self._completer)[0] != "measured-change":
            raise ConfigError("measured_both_margin compares the completions' error judged by the beams still "
                              "measured with the graph's: it needs a completer whose run_sigma is "
                              "'measured-change'")
        if self.backend_name == "ekf" or options is None or options.rehearsed_outages is None:
            return
        completer = self._completer
        if completer is None:
            why = "this graph runs without a completer, so there is no completion to rehearse"
        elif not hasattr(completer, "rehearse"):
            why = f"{type(completer).__name__} cannot rehearse an outage (it has no 'rehearse')"
        elif getattr(completer, "rehearsal_measured", None) is not None and (
                options.rehearsal_graph != "imu" or options.rehearsal_fusion != "independent"):
            # the variants rehearse every pattern; a one-pattern completer completes its own only
            why = (f"{type(completer).__name__} rehearses its one pattern only, and the variants rehearsal_graph / "
                   "rehearsal_fusion every pattern")
        elif self._backend_kwargs["keep_keyframe_graphs"]:
            raise ConfigError("rehearsed_outages is for the incremental smoothers (ISAM2, fixed-lag): the batch "
                              "smoother re-solves the mission with what its first pass kept and was not studied "
                              "with the rehearsals; leave it None for a batch run")
        else:
            return
        raise ConfigError(f"rehearsed_outages: {why}: run the pivot completer or the average estimator (or, "
                          "without the variants, an IMU-aware completer of one pattern)")

    def _hand_rehearsal(self) -> None:
        """Hand a graph backend's rehearsed outages (``GraphOptions.rehearsed_outages``) to the keyframer, which
        feeds them the completer's side (what cannot serve was refused by :meth:`_refuse_rehearsal`)."""
        self.keyframer.rehearsal = getattr(getattr(self.backend, "ctx", None), "rehearsal", None)

    def _estimator_options(self):
        """The backend's options (:class:`EkfOptions` or :class:`GraphOptions`, defaults where not given)."""
        kw = self._backend_kwargs
        return (kw["ekf_options"] or EkfOptions()) if self.backend_name == "ekf" else \
            (kw["graph_options"] or GraphOptions())

    def _align_options(self) -> AlignOptions:
        """``options.align`` with the estimator's own DVL error priors where it leaves them open: the aligner fits
        the DVL's errors with the priors the estimator will carry on with."""
        o = self.options.align
        scale, bias = self._estimator_options().priors.dvl_error_sigmas(self.config.dvl)
        return dataclasses.replace(o, dvl_scale_sigma=scale if o.dvl_scale_sigma is None else o.dvl_scale_sigma,
                                   dvl_bias_sigma=bias if o.dvl_bias_sigma is None else o.dvl_bias_sigma)

    def _start(self, initial: InitialState) -> list[EpochEstimate]:
        kw = self._backend_kwargs
        self.backend = make_backend(self.backend_name, self.config, initial, **kw)
        self._hand_rehearsal()
        options = self._estimator_options()
        self.coasting = CoastingMonitor(self.backend.name, options.max_pure_inertial_s)
        self.sigma = SigmaMonitor(self.backend.name, options.health)
        self._imu_before.clear()
        self._judging, self._other_since_imu = None, math.inf
        return self._process(self.keyframer.start(float(initial.t)))

    def _align(self, stream: str, t: float, payload: tuple) -> list[EpochEstimate]:
        a = self.aligner
        if stream in PING_STREAMS:
            a.add_ping(*payload)
        else:
            getattr(a, "add_position_fix" if stream == "fix" else "add_" + stream)(t, *payload)
        # across joined IMU gaps it waits for the data after the last of them (Aligner.check_ready), when it can run
        # the estimator through the data gathered meanwhile: else a held alignment would leave them unaided
        if stream != "imu" or not a.check_ready(self.options.align_catch_up):
            return []
        return self._start_from_aligner(t)

    def _start_from_aligner(self, t: float, end_of_data: bool = False) -> list[EpochEstimate]:
        """Start the estimator from the aligner's result: carried back to the first buffered sample and run
        through the buffer (``align_catch_up``), else where the alignment ends."""
        a, events = self.aligner, self._align_events
        t_first = next((e[1] for e in events if e[0] == "imu"), None)
        if t_first is not None and end_of_data:
            a.missing(end_of_data=True)     # the longest stretch without an IMU gap
            a.settle(end_of_data=True)      # across short ones only when the heading is determined over them
        if t_first is not None and a.t_first is not None and a.t_first > t_first:
            # a joined gap the gyros could carry it over: the alignment chose the data after it, and says why
            gap = next((g for g in reversed(a.imu_gaps) if g[1] <= a.t_first), None)
            why = (": " + a._not_joined if a._not_joined and (gap is None or gap[1] - gap[0] <= GAP_JOINED_S)
                   else ", over which the gyros cannot carry its attitude back")
            warnings.warn(f"navigator: no estimates from t = {t_first:.3f} to {a.t_first:.3f} s: the alignment "
                          f"starts after the IMU gap there{why}", RuntimeWarning, stacklevel=4)
            t_first = a.t_first
        al = None
        if (self.options.align_catch_up or end_of_data) and t_first is not None:
            from graphnav.estimators.align import AlignmentError
            try:
                al = a.result_at(t_first, end_of_data=end_of_data)
            except AlignmentError as exc:
                if end_of_data:
                    raise
                warnings.warn(f"navigator: alignment not carried back to t = {t_first:.3f} s ({exc}); the "
                              "estimator starts where the alignment ends", RuntimeWarning, stacklevel=4)
        self.aligner = None
        self.alignment_ready_t = t
        if al is None:
            events.clear()
            self.alignment = al = a.result()
            return self._start(initial_from_alignment(al))
        self.alignment = al
        # a fresh keyframer from the first buffered sample on: keyframe 0 at t_first, then the buffer; what the
        # first one has said is not said again
        warned_period, imu_period = self.keyframer.warned_period, self.keyframer.imu_period
        said_gaps = self.keyframer.said_gaps
        self.keyframer = Keyframer(self.config, self.options.keyframes, self._completer)
        self.keyframer.warned_period, self.keyframer.imu_period = warned_period, imu_period
        self.keyframer.said_gaps = set(said_gaps)
        out = self._start(initial_from_alignment(al, hand_over_fit=False))
        replayed = [e for e in events if e[1] >= t_first]
        events.clear()
        for stream, t_, payload in replayed:
            out += self._dispatch(stream, t_, payload)
        if self._judging is not None:       # the buffer ended within the window that judges a gap
            out += self._judge_gap()
        self._rerun_without_alignment_prior(al, replayed, warned_period, imu_period)
        return out

    def _rerun_without_alignment_prior(self, al, replayed: list, warned_period, imu_period) -> None:
        """Run the buffered samples again through a fresh estimator whose prior holds only what was known before
        them (:func:`initial_from_alignment` with ``before_data``), and go on with that one.

        The alignment's heading, tilt and velocity come from these same samples: the estimator that returned the
        catch-up estimates counted them twice (a heading sigma about half its error). Its estimates through the
        alignment window stand (the aligned state there uses the whole window, as a smoother would); the
        estimator that goes on has counted each sample once. Its warnings about the same samples were given by
        the first run and are not repeated, and the health goes on from the first run's monitors: the estimates
        published through the window are that run's (the second starts from a wide prior, whose sigma over the
        window would have made a clean run "degraded")."""
        latest, n_estimates, judged = self._latest, self.n_estimates, dict(self.gaps_judged)
        published = (self.coasting, self.sigma, self.backend.monitor)
        fallbacks = dict(getattr(self._completer, "fallbacks", {}))
        self.keyframer = Keyframer(self.config, self.options.keyframes, self._completer)
        self.keyframer.warned_period, self.keyframer.imu_period = warned_period, imu_period
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            # the EKF's only: the graph re-linearises and comes back from a heading far off
            factor = getattr(self._estimator_options(), "catch_up_heading_sigma_factor", None)
            self._start(initial_from_alignment(al, self.options.align, heading_sigma_factor=factor))
            for stream, t_, payload in replayed:
                self._dispatch(stream, t_, payload)
            if self._judging is not None:
                self._judge_gap()
        # the gaps were judged (and counted) by the first run, on the same samples
        self._latest, self.n_estimates, self._prop, self.gaps_judged = latest, n_estimates, None, judged
        self.coasting, self.sigma, self.backend.monitor = published
        if self.lost_track is not None:     # said on the monitor that goes on, unsilenced
            self._say_lost_track()
        for k, n in fallbacks.items():      # the completer's pings of the window are counted once
            self._fallbacks_before[k] = self._fallbacks_before.get(k, 0) + self._completer.fallbacks[k] - n

    def _align_at_end(self) -> list[EpochEstimate]:
        """The data ended before ``AlignOptions.duration_s``: align over what there is when it covers
        ``min_duration_s`` (with a warning giving the expected heading accuracy), and run the buffer."""
        a = self.aligner
        if a.waiting_after_joined_gaps:     # ready across joined IMU gaps; the data after them were too short
            a.stop_waiting()
            return self._start_from_aligner(self._align_events[-1][1] if self._align_events else a.result().t)
        if a.missing(end_of_data=True) or not self._align_events:
            return []
        out = self._start_from_aligner(self._align_events[-1][1], end_of_data=True)
        al = self.alignment
        sigma = al.info.get("heading_sigma_rad")
        warnings.warn(f"navigator: the data ended before the {a.options.duration_s:g} s alignment finished; aligned "
                      f"over the {al.info.get('duration_s', float('nan')):.0f} s there are"
                      + (f" (expected heading sigma {np.degrees(sigma):.1f} deg)" if sigma is not None else ""),
                      RuntimeWarning, stacklevel=3)
        return out

    def _align_missing(self) -> str:
        """What the aligner still lacks at the end of the data (its error message)."""
        missing = self.aligner.missing(end_of_data=True)
        return "cannot align from the sensors: " + "; ".join(missing) if missing else "alignment ready"


def initial_from_alignment(al, before_data: AlignOptions | None = None, hand_over_fit: bool = True,
                           heading_sigma_factor: float | None = None) -> InitialState:
    """The estimator's initial state and prior from an :class:`~graphnav.estimators.align.Alignment` (the position
    covariance moves from NED to the body axes of GTSAM's Pose3 tangent ``[rot, trans]``).

    ``hand_over_fit``: the DVL errors the alignment fitted start the estimator's DVL error states, with the
    alignment's joint covariance of attitude, velocity, accelerometer bias and DVL errors
    (``InitialState.cov_joint``), for an estimator that starts where the alignment ends. False for one that runs
    through the alignment's own data from its prior (the catch-up's first run): the DVL errors counted twice
    there pulled its heading further from the truth than the alignment's (docs/decisions/alignment.md).

    ``before_data``: for an estimator that will see the alignment's data again, the prior holds only what was
    known before them (``AlignOptions.unaligned_*`` sigmas on tilt, velocity and, unless it was given, heading;
    the accelerometer bias at zero with the spec's sigma, the DVL errors at zero with the estimator's prior); the
    aligned state is still where it starts. ``heading_sigma_factor``: the gyrocompassed heading's sigma is the
    alignment's times this (at most the unaligned one), for an estimator that cannot come back from a heading
    far off (:attr:`graphnav.estimators.ekf.EkfOptions.catch_up_heading_sigma_factor`)."""
    C = np.asarray(al.C_b_n, float)
    cov_rot, cov_v_n, bias_acc = np.asarray(al.cov_rot, float), np.asarray(al.cov_v_n, float), al.bias_acc
    fit = hand_over_fit and before_data is None
    dvl_errors, cov_joint = (np.asarray(al.dvl_errors, float), al.cov_joint) if fit else (None, None)
    if before_data is not None:
        o = before_data
        heading_var = _rerun_heading_variance(al, (C @ cov_rot @ C.T)[2, 2], o, heading_sigma_factor)
        # NED axes: roll/pitch about north and east, heading about down
        cov_rot = C.T @ np.diag([o.unaligned_tilt_sigma_rad ** 2] * 2 + [heading_var]) @ C
        cov_v_n = np.eye(3) * o.unaligned_velocity_sigma_mps ** 2
        bias_acc = np.zeros(3)
    cov_pose = np.zeros((6, 6))
    cov_pose[:3, :3] = cov_rot
    cov_pose[3:, 3:] = C.T @ np.asarray(al.cov_p_n, float) @ C
    return InitialState(gtsam.Pose3(gtsam.Rot3(C), np.asarray(al.p_n, float)), np.asarray(al.v_n, float),
                        gtsam.imuBias.ConstantBias(np.asarray(bias_acc, float), np.asarray(al.bias_gyro, float)),
                        t=float(al.t), cov_pose=cov_pose, cov_v_n=cov_v_n, origin_lla=al.origin_lla,
                        dvl_errors=dvl_errors, cov_joint=cov_joint)


def _rerun_heading_variance(al, aligned_var: float, o: AlignOptions, factor: float | None) -> float:
    """Heading variance, rad^2, of an estimator that runs through the alignment's data again: the alignment's
    (``aligned_var``, NED down axis) when the heading was given, known before the data; else the unaligned one,
    or ``factor`` times the alignment's sigma when that is narrower (it counts the alignment's heading
    information a second time, 1 / factor^2 of it)."""
    if al.heading_source == "given":
        return aligned_var
    unaligned = o.unaligned_heading_sigma_rad ** 2
    return unaligned if factor is None else min(unaligned, factor ** 2 * aligned_var)


def stream_adders(nav: Navigator) -> dict:
    """The Navigator call for each sample kind of :func:`graphnav.estimators.replay.replay`."""
    return {"imu": nav.add_imu, "dvl": nav.add_dvl, "dvl_velocity": nav.add_dvl_velocity, "depth": nav.add_depth,
            "heading": nav.add_heading, "fix": nav.add_position_fix}


def navigate(nav: Navigator, mission, depth: bool = True, stop=None) -> Iterator[EpochEstimate]:
    """Replay a recorded mission into ``nav`` sample by sample in time order (never its ground truth) and yield
    every estimate as it is made, those of :meth:`Navigator.finish` last. ``stop()``, when given, is asked
    between samples and a True answer ends the replay with KeyboardInterrupt (a clean point to stop at: an
    interrupt delivered inside a GTSAM call can surface as another exception)."""
    adders = stream_adders(nav)
    try:
        for kind, t, payload in replay(mission, depth=depth):
            if stop is not None and stop():
                raise KeyboardInterrupt
            yield from adders[kind](t, *payload)
        yield from nav.finish()
    except DataError as err:
        named = _named_after_source(err, mission)
        if named is err:
            raise
        raise named from err


#: The mission stream each replayed sample kind comes from.
_KIND_STREAM = {"imu": "imu", "dvl": "dvl", "dvl_velocity": "dvl", "depth": "depth", "heading": "heading",
                "fix": "fixes"}


def _named_after_source(err: DataError, mission) -> DataError:
    """``err`` (the Navigator's, naming a sample kind: it sees samples, not files) naming the file the mission's
    stream was read from and its column (``meta["stream_fields"]``, e.g. the A-KIT depth's GT altitude); ``err``
    itself when it names something else or the stream has no source of its own."""
    stream = getattr(mission, _KIND_STREAM.get(err.source, ""), None) if isinstance(err.source, str) else None
    source = getattr(stream, "source", None)
    if not source or source == err.source:
        return err
    field = (getattr(mission, "meta", None) or {}).get("stream_fields", {}).get(err.source, err.field)
    return DataError(err.message, source, err.line, field)


def feed_mission(nav: Navigator, mission, callback=None, depth: bool = True, stop=None) -> list[EpochEstimate]:
    """:func:`navigate` to the end: every estimate, ``callback(estimate)`` called as each is made."""
    out = []
    for est in navigate(nav, mission, depth, stop):
        out.append(est)
        if callback is not None:
            callback(est)
    return out


class _Concat:
    """Read-only indexable view of a list followed by a deque (the IMU samples of :meth:`Navigator.state_at`)."""

    __slots__ = ("a", "b")

    def __init__(self, a: list, b: deque):
        self.a, self.b = a, b

    def __len__(self) -> int:
        return len(self.a) + len(self.b)

    def __bool__(self) -> bool:
        return bool(self.a) or bool(self.b)

    def __getitem__(self, i: int):
        n = len(self.a)
        if i < 0:
            i += n + len(self.b)
        return self.a[i] if i < n else self.b[i - n]
