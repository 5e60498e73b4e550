"""Which stamps to trust in a bag, per stream and between streams.

Per stream (:func:`choose_stamps`): the header stamps (the time of validity) when they are sane: none zero,
strictly increasing. A topic other than the IMU's whose header clock stalls for a few messages (repeats one
stamp while the receive time runs on) keeps its header stamps but for those messages, stamped from their receive
time (:func:`stall_restamped`). A topic whose header clock steps back (or resumes from the value it stalled at)
while its messages keep arriving keeps its header stamps, those after the step moved forward onto the clock before it
(:func:`steps_back_repaired`); a topic other than the IMU's whose header clock was another clock and is set right
there has those before it moved onto the clock after it instead (:func:`set_right`). Otherwise the bag's receive
time (when the recorder got the message), with a warning and a note in ``Mission.meta["streams"]`` saying which and
why: drivers that leave the stamp at zero, stamp a burst of samples with one time, or stamp from a clock that
jumps. Samples that even the receive time cannot
order (two messages received in the same nanosecond) are dropped and counted.

Between streams (:func:`compare_clocks`): each stream's header clock is compared with the receive clock
(median difference), and the DVL span with the IMU span. A DVL whose stamps lie days away from the IMU's runs
on another clock (a DVL that never synchronised its RTC): its pings are kept as they are and the offset is
recorded in ``meta["clock"]``, for :mod:`graphnav.calibration.clock` to estimate from the data.
"""
from __future__ import annotations

import warnings

import numpy as np

from graphnav.core.streams import add_note, count_refused, say_doubted

#: Offsets between a stream's header clock and the bag's receive clock below this are latency, not another
#: clock, s (a driver's latency is milliseconds to a second).
CLOCK_OFFSET_NOTE_S = 1.0


#: A stepped header clock is judged against the receive clock over this many messages either side of the step: the
#: medians of header minus receive time there (the recorder's latency, which jitters) must differ by the step.
HEADER_STEP_WINDOW = 100
#: The spread of that latency (median absolute deviation before the step) a step must exceed this many times over.
HEADER_STEP_SPREADS = 10.0
HEADER_CLOCK_STEP = "stamped after a step of the header clock the receive clock does not show (moved back)"
HEADER_CLOCK_STEP_BACK = "stamped after a step back of the header clock the receive clock does not show (moved forward)"
HEADER_CLOCK_SET_RIGHT = "stamped before the header clock was set right (moved onto the clock after)"
#: Header stamps resolve their sample grid when their jitter about it is under this share of the period; a gap of
#: them is then on the grid within the larger of 4 jitters and a hundredth of the period.
GRID_JITTER_SHARE = 0.1
#: More steps back than this in one topic are not a clock's steps (a driver's out-of-order packets): not repaired.
MAX_STEPS_BACK = 20


def latency_step(latency: np.ndarray, k: int, lo: int = 0, hi: int | None = None,
                 trend: np.ndarray | None = None) -> tuple[float, float]:
    """How far header minus receive time ``latency`` (s) steps at message ``k`` (the medians over
    :data:`HEADER_STEP_WINDOW` messages either side, within messages ``lo`` to ``hi``: the steps either side of it),
    and its spread before it (median absolute deviation), s. ``trend`` (s, :func:`latency_trend`): the latency's
    drift, taken out about message ``k`` first (a header clock 1 % slow adds a second between windows 100 s apart)."""
    lat = latency if trend is None else latency - (trend - trend[k])
    before = lat[max(lo, k - HEADER_STEP_WINDOW):k]
    after = lat[k:min(len(latency) if hi is None else hi, k + HEADER_STEP_WINDOW)]
    return (float(np.median(after) - np.median(before)),
            float(np.median(np.abs(before - np.median(before)))))


def _latency_before(latency: np.ndarray, k: int, lo: int = 0) -> float:
    return float(np.median(latency[max(lo, k - HEADER_STEP_WINDOW):k]))


def nearer_the_receive_clock(latency: np.ndarray, k: int, step: float) -> bool:
    """Whether header minus receive time ``latency`` (s) is nearer 0 after message ``k`` than before it, where it
    steps by ``step`` (s, :func:`latency_step`): the recorder's latency dropped, or a clock off the receive clock
    set right."""
    before = _latency_before(latency, k)
    return abs(before + step) < abs(before)


def set_right(latency: np.ndarray, k: int, step: float, clock_s: float = 0.0, lo: int = 0) -> bool:
    """Whether a topic's header clock was set right at message ``k``, where header minus receive time ``latency`` (s)
    steps by ``step`` (s): off both the receive clock and the IMU's (``clock_s``: the IMU's header minus receive time,
    s; a recorder whose own clock is off the vehicle's sees every topic that far off) by more than a latency
    (:data:`CLOCK_OFFSET_NOTE_S`) before it (from message ``lo`` on), within a latency of either after it. The stamps
    before it are then the wrong ones."""
    before = _latency_before(latency, k, lo)
    off = [abs(before - c) for c in (0.0, clock_s)]
    return min(off) > CLOCK_OFFSET_NOTE_S >= min(abs(before + step - c) for c in (0.0, clock_s))


#: Header minus receive time jumping on more than this share of a topic's messages is the recorder's delivery (an
#: IMU's samples received in packets: a sawtooth of a packet's length), not a header clock's steps.
LATENCY_JUMPS_MAX_SHARE = 0.25


def latency_jumps(latency: np.ndarray, period_s: float) -> np.ndarray:
    """The messages at which header minus receive time ``latency`` (s) jumps, either way, by more than a quarter of
    the period ``period_s`` (s) and :data:`HEADER_STEP_SPREADS` of its spread from one message to the next: where a
    header clock may step, and the bounds of the stretch each step is judged over (a clock off for a few messages,
    then back, is two steps close together). Jumps on more than :data:`LATENCY_JUMPS_MAX_SHARE` of the messages are
    the recorder's delivery: then only those over :data:`HEADER_STEP_SPREADS` of the latency's own spread, and none
    when they are still as many."""
    dl = np.diff(latency)
    if not dl.size:
        return np.zeros(0, int)
    for x in (dl, latency):
        # jumping on most messages: the recorder's delivery (an IMU's samples in packets: a sawtooth of header minus
        # receive time), not a clock's steps; those are the jumps beyond that latency's own spread
        spread = float(np.median(np.abs(x - np.median(x))))
        jumps = np.flatnonzero(np.abs(dl) > max(period_s / 4, HEADER_STEP_SPREADS * spread)) + 1
        if jumps.size <= LATENCY_JUMPS_MAX_SHARE * dl.size:
            return jumps
    return np.zeros(0, int)


def _returns(latency: np.ndarray, k: int, step: float, spread: float) -> bool:
    """Whether header minus receive time ``latency`` (s) jumps back by about ``step`` (s) at message ``k``: the end
    (or the start) of a stretch on the other clock."""
    return abs(latency[k] - latency[k - 1] + step) <= max(HEADER_STEP_SPREADS * spread, 0.1 * abs(step))


def latency_drop(latency: np.ndarray, k: int, step: float) -> bool:
    """Whether a step ``step`` (s) of header minus receive time ``latency`` (s) at message ``k`` may be the recorder's
    latency dropping (a backlog flushed) rather than the header clock stepping: a latency (within
    :data:`CLOCK_OFFSET_NOTE_S`) on both sides, of one sign, nearer 0 after."""
    before = _latency_before(latency, k)
    return (abs(before) <= CLOCK_OFFSET_NOTE_S and nearer_the_receive_clock(latency, k, step)
            and before * (before + step) >= 0)


def on_the_grid(t_ns: np.ndarray, k: int, period_s: float) -> bool | None:
    """Whether the header stamps ``t_ns`` (ns) from message ``k`` on stay on the sample grid of the
    :data:`HEADER_STEP_WINDOW` stamps before it (their median phase within the larger of 4 jitters and a hundredth of
    the period ``period_s``, s): a gap on the grid is whole samples lost, a clock's step rarely is. None when the
    stamps are too uneven to tell (jitter about their grid beyond :data:`GRID_JITTER_SHARE` of the period)."""
    before = np.asarray(t_ns[max(0, k - HEADER_STEP_WINDOW):k], np.int64)
    after = np.asarray(t_ns[k:k + HEADER_STEP_WINDOW], np.int64)
    if before.size < 3 or not after.size:
        return None

    def phase(x: np.ndarray) -> np.ndarray:
        r = (x - before[-1]) / 1e9 / period_s
        return (r - np.round(r)) * period_s
    ref = float(np.median(phase(before)))
    jitter = 1.4826 * float(np.median(np.abs(phase(before) - ref)))
    if jitter > GRID_JITTER_SHARE * period_s:
        return None
    # unwrapped about the first stamp after: stamps half a period off would otherwise split between +- half
    p = phase(after)
    p = p[0] + (p - p[0]) - np.round((p - p[0]) / period_s) * period_s
    off = float(np.median(p)) - ref
    off -= round(off / period_s) * period_s
    return abs(off) <= max(4.0 * jitter, 0.01 * period_s)


def clock_step_moved(t_ns: np.ndarray, latency: np.ndarray, j: int, step: float, spread: float, period_s: float,
                     stream: str, clock_s: float, lo: int, hi: int) -> dict:
    """Take out the step ``step`` (s, :func:`latency_step` over messages ``lo`` to ``hi``, its spread ``spread``) of
    a topic's header clock at message ``j``, either way, moving the header stamps ``t_ns`` (ns) and header minus
    receive time ``latency`` (s) in place, so the step lasts as many periods ``period_s`` (s) as the receive time says
    passed: for a topic other than the IMU's whose clock was set right there (:func:`set_right`, against the IMU's
    header minus receive time ``clock_s``, s) the stamps before it onto the clock after, else those from it on onto
    the clock before. Either move stops at the jump back by as much that bounds the stretch (``lo`` or ``hi``: a
    glitch of the clock, only its stamps are moved). Returns ``jump_s`` (the header step), ``periods``, ``shift_s``
    (the moved stamps' shift; ``shift_ns`` in ns), ``before`` (True: those before moved), ``first``/``end`` (the
    moved stamps), ``whole`` (up to the topic's first or last message) and ``latency_s`` (header minus receive time
    before and after)."""
    jump = (int(t_ns[j]) - int(t_ns[j - 1])) / 1e9
    periods = max(1, round((jump - step) / period_s))
    shift_ns = int(round((jump - periods * period_s) * 1e9))
    # a stretch between a jump and a jump back by as much (a glitch) goes onto the clock either side of it, any
    # topic's, the IMU's too: moving the rest onto the glitch's clock moved (and counted) all after it twice
    glitch = bool(lo) and _returns(latency, lo, step, spread)
    before = glitch or (stream != "imu" and set_right(latency, j, step, clock_s, lo))
    if before:
        moved = slice(lo if glitch else 0, j)
    else:
        shift_ns = -shift_ns
        moved = slice(j, hi if hi < len(t_ns) and _returns(latency, hi, step, spread) else len(t_ns))
    lat = _latency_before(latency, j, lo)
    t_ns[moved] += shift_ns
    latency[moved] += shift_ns / 1e9
    return {"jump_s": jump, "periods": periods, "shift_ns": shift_ns, "shift_s": shift_ns / 1e9, "before": before,
            "first": moved.start,
            "end": moved.stop, "whole": moved.start == 0 or moved.stop == len(t_ns), "latency_s": (lat, lat + step)}


def say_set_right(meta: dict, stream: str, label: str, at: str, s: dict, prev: str, first: str, seen: str = "",
                  tail: str = "", stacklevel: int = 3) -> None:
    """Warn about and count a topic's header clock set right at ``at`` (the message and field), whichever way it
    stepped (``s``: from :func:`clock_step_moved`, with ``rx_s`` the receive time's step and ``n`` the stamps moved;
    ``prev`` names the message before it, ``first`` the first moved, ``seen`` what else the step says, ``tail``
    what could not be told)."""
    which = "before it" if s["whole"] else f"from {first} (where the clock stepped off by as much) to it"
    text = (f"{at}the header clock is set right (its stamp {s['jump_s']:+.3f} s after {prev}'s, received "
            f"{s['rx_s']:+.3f} s after it{seen}; header minus receive time {s['latency_s'][0]:+.3f} s before, "
            f"{s['latency_s'][1]:+.3f} s after): another clock before this message, the recorder's latency from it "
            f"on; the {s['n']} stamp(s) {which} are moved by {s['shift_s']:+.3f} s onto the clock after{tail}")
    say_doubted(meta, stream, label, text, HEADER_CLOCK_SET_RIGHT, s["n"], stacklevel=stacklevel + 1)


def steps_back_repaired(header_ns: np.ndarray, receive_ns: np.ndarray, stream: str, stalled: np.ndarray | None,
                        clock_s: float = 0.0, forward: bool = False) -> tuple[np.ndarray, list[dict]] | None:
    """``header_ns`` (ns) with each step back of the topic's header clock the receive clock ``receive_ns`` (ns) does
    not show taken out: a stamp at or before the one before it, the first after a stall (``stalled``, from
    :func:`stall_restamped`: a clock that resumes from the value it froze at rather than jumping ahead), or a stamp
    less than a period after the one before it that leaves the sample grid (:func:`on_the_grid`), where header minus
    receive time drops by over a quarter period and :data:`HEADER_STEP_SPREADS` of its spread, judged over
    :data:`HEADER_STEP_WINDOW` messages either side within the jumps of that latency either side of it
    (:func:`latency_jumps`: a clock off for a few messages is judged over those alone). The stamps from that message
    on are moved forward so the step lasts as many periods as the receive time says passed, or, for a topic other
    than the IMU's whose clock was set right there (:func:`set_right`, judged against the IMU's header minus receive
    time ``clock_s``, s), those before it back onto the clock after. Either move stops at the jump back by as much
    that bounds the stretch (a glitch of the clock: only its stamps move). A drop the window sees that this message's
    own stamp does not make (a step elsewhere in the window) is not this message's. ``forward``: the steps forward
    under :data:`~graphnav.core.imu_timing.GAP_WARN_SAMPLES` periods too (a gap of more is judged with the messages it
    may have lost, :func:`graphnav.io.bag_convert.header_clock_steps_removed`), found alike where header minus receive
    time rises and the stamps leave their grid, their stamps moved back (one ending where the clock steps back by as
    much is left to that step, as a glitch set right). Stalled messages are left for
    :func:`_stall_stamps`. None when nothing was repaired; else (the stamps, one dict per step: ``k`` the message,
    ``prev`` the message before it judged, ``jump_s``, ``rx_s``, ``shift_s`` (the stamps' move), ``before`` True
    when the messages before it moved, ``n`` how many moved, ``first``/``last`` the first and last moved,
    ``latency_s`` header minus receive time before and after)."""
    if stream != "imu" and stalled is None and np.any(np.diff(header_ns) == 0):
        return None         # a stall :func:`stall_restamped` did not take (bursts, copies): not a clock's step
    if len(header_ns) < 3 or np.any(header_ns == 0):
        return None
    ok = np.arange(len(header_ns)) if stalled is None else np.flatnonzero(~stalled)
    t, rx = header_ns[ok].copy(), receive_ns[ok]
    d = np.diff(t)
    if not np.any(d > 0):
        return None
    period = float(np.median(d[d > 0])) / 1e9
    latency = (t - rx) / 1e9
    jumps = latency_jumps(latency, period)
    drops = jumps[(latency[jumps] < latency[jumps - 1]) & (d[jumps - 1] > 0)]
    drops = np.array([j for j in drops if on_the_grid(t, j, period) is False], int)
    cand = np.union1d(np.flatnonzero(d <= 0) + 1, drops)
    if stalled is not None:
        cand = np.union1d(cand, np.flatnonzero(np.diff(ok) > 1) + 1)
    rises = _rises(t, latency, jumps, period) if forward else np.zeros(0, int)
    if rises.size > MAX_STEPS_BACK:
        rises = rises[:0]       # so many are no clock's steps either; the steps back are judged as before
    if not (cand.size + rises.size) or cand.size > MAX_STEPS_BACK:
        return None
    bounds = np.union1d(jumps, cand)
    # the drift taken out on increasing stamps alone: on stamps not yet sane its line runs through their steps
    trend = latency_trend(t, rx) if forward else None
    done = []
    for j in np.union1d(cand, rises):
        lo = int(bounds[bounds < j].max(initial=0))
        hi = int(bounds[bounds > j].min(initial=len(t)))
        step, spread = latency_step(latency, j, lo, hi, trend)
        sign = 1.0 if j in rises else -1.0
        if (sign * step < max(period / 4, HEADER_STEP_SPREADS * spread)
                or sign * (latency[j] - latency[j - 1]) < sign * step / 2
                or sign > 0 and hi in cand and _returns(latency, hi, step, spread)):
            continue
        moved = clock_step_moved(t, latency, j, step, spread, period, stream, clock_s, lo, hi)
        first, end = int(ok[moved["first"]]), int(ok[moved["end"]]) if moved["end"] < len(t) else len(header_ns)
        done.append({**moved, "k": int(ok[j]), "prev": int(ok[j - 1]), "rx_s": (rx[j] - rx[j - 1]) / 1e9,
                     "n": end - first, "first": first, "last": end - 1})
    if not done:
        return None
    out = header_ns.copy()
    out[ok] = t
    return out, done


def _rises(t_ns: np.ndarray, latency: np.ndarray, jumps: np.ndarray, period_s: float) -> np.ndarray:
    """The messages among ``jumps`` (:func:`latency_jumps`) where header minus receive time ``latency`` (s) rises as
    the header stamps ``t_ns`` (ns) step forward off their sample grid (:func:`on_the_grid`), a period ``period_s``
    (s) and a step of under :data:`~graphnav.core.imu_timing.GAP_WARN_SAMPLES` more apart: where the header clock may
    step forward (a step of more is a gap's, judged with the messages it may have lost)."""
    from graphnav.core.imu_timing import GAP_WARN_SAMPLES
    d = np.diff(t_ns) / 1e9
    dj = d[jumps - 1]
    # a step of 1-2 periods puts 2-3 periods between the stamps: under the gap's step, so judged here too
    up = jumps[(latency[jumps] > latency[jumps - 1]) & (dj > 0) & (dj < (GAP_WARN_SAMPLES + 1) * period_s)]
    return np.array([j for j in up if on_the_grid(t_ns, j, period_s) is False], int)


def say_steps_back(steps: list[dict], meta: dict, stream: str, label: str, stacklevel: int = 3,
                    index: np.ndarray | None = None) -> None:
    """Warn about and count each step back :func:`steps_back_repaired` took out (``index``: each stamp's message in
    the topic, when the stamps are some of its messages)."""
    def name(k: int) -> str:
        return f"message {k if index is None else int(index[k])}"
    for s in steps:
        at = f"{name(s['k'])}, field 'header.stamp': "
        if s["before"]:
            say_set_right(meta, stream, label, at, s, name(s["prev"]), name(s["first"]), stacklevel=stacklevel)
            continue
        back = s["shift_s"] > 0
        which = ("from this message on" if s["whole"] else
                 f"from this message to {name(s['last'])} (after which the clock steps back by as much), {s['n']},")
        text = (f"{at}the header clock steps {'back' if back else 'forward'} (its stamp {s['jump_s']:+.3f} s after "
                f"{name(s['prev'])}'s, received {s['rx_s']:+.3f} s after it; header minus receive time "
                f"{s['latency_s'][0]:+.3f} s before, {s['latency_s'][1]:+.3f} s after) while the messages kept "
                f"arriving; the stamps {which} are moved {'forward' if back else 'back'} by {abs(s['shift_s']):.3f} s "
                "onto the clock before the step")
        say_doubted(meta, stream, label, text, HEADER_CLOCK_STEP_BACK if back else HEADER_CLOCK_STEP, s["n"],
                    stacklevel=stacklevel)


#: A topic's header clock whose header minus receive time drifts (against the IMU's) by more than this over the
#: topic is warned about and counted, s; it is taken out when the drift is also over :data:`HEADER_STEP_SPREADS` of
#: that latency's spread about the line (a clock running fast or slow, not the recorder's jitter).
CLOCK_DRIFT_NOTE_S = 0.1
#: Messages a topic needs for its clock's drift to be judged.
CLOCK_DRIFT_MIN_MESSAGES = 20
#: Header minus receive time running faster than this against the IMU's (s per s) is no clock's drift (a crystal 5 %
#: off): the receive time is not when the messages came (a topic replayed faster, or written into the bag later).
CLOCK_DRIFT_MAX_RATE = 0.05
HEADER_CLOCK_DRIFT = "stamped by a header clock drifting against the IMU's (moved onto its rate)"
HEADER_CLOCK_DRIFT_UNTOLD = "stamped by a header clock that may drift against the IMU's (kept: too spread to tell)"
HEADER_CLOCK_DRIFT_NOT_TOLD = ("stamped by a header clock that may drift against the IMU's (kept: not told "
                               "from a recorder's latency growing)")
RECEIVED_OFF_PACE = "received at a pace no clock drifts by (the header stamps kept)"


def latency_rate(t_ns: np.ndarray, receive_ns: np.ndarray) -> tuple[float, float]:
    """(how fast header minus receive time drifts, s per s of receive time (the straight line through it once its
    jumps are taken out: :func:`latency_jumps`, a step being no drift), the spread about that line, s (1.4826 median
    absolute deviation)) of a topic on header stamps ``t_ns`` received at ``receive_ns`` (ns); (0, 0) with under
    :data:`CLOCK_DRIFT_MIN_MESSAGES` messages."""
    t_ns, receive_ns = np.asarray(t_ns, np.int64), np.asarray(receive_ns, np.int64)
    d = np.diff(t_ns)
    if len(t_ns) < CLOCK_DRIFT_MIN_MESSAGES or not np.any(d > 0) or receive_ns[-1] <= receive_ns[0]:
        return 0.0, 0.0
    rx = (receive_ns - receive_ns[0]) / 1e9
    latency = (t_ns - receive_ns) / 1e9
    jumps = latency_jumps(latency, float(np.median(d[d > 0])) / 1e9)
    for k in jumps:
        latency[k:] -= latency[k] - latency[k - 1]
    rate, c = np.polyfit(rx, latency, 1)
    res = latency - (rate * rx + c)
    return float(rate), 1.4826 * float(np.median(np.abs(res - np.median(res))))


#: The rates a driver publishes at, Hz, and the periods a DVL is set to ping at, s (times the powers of ten: every
#: 0.3 s or 3 s is a round period, 3.33 Hz and 0.333 Hz no round rate): the rates of both at least 1.11 times the next
#: lower, so a rate within :data:`CLOCK_DRIFT_MAX_RATE` of one is near no other.
ROUND_RATES_HZ = (1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0)
#: A topic's messages numbered by their header stamps must come at least this many to time their schedule.
SCHEDULE_MIN_MESSAGES = 10
HEADER_LATENCY_GROWS = ("received ever later while the header stamps keep their round rate (a recorder's queue "
                        "filling: the header stamps kept)")


def off_round_rate(period_s: float) -> float:
    """How far (relative) the rate of ``period_s`` (s), or the period itself, lies from the nearest of
    :data:`ROUND_RATES_HZ` (times a power of ten: Hz, or s); inf for no positive finite period."""
    if not np.isfinite(period_s) or period_s <= 0:
        return np.inf

    def off(x: float) -> float:
        near = np.array([*ROUND_RATES_HZ, 10.0]) * 10.0 ** np.floor(np.log10(x))
        return float(np.min(np.abs(x / near - 1.0)))
    return min(off(1.0 / period_s), off(period_s))


def schedule_periods(t_ns: np.ndarray, receive_ns: np.ndarray, clock_rate: float = 0.0
                     ) -> tuple[float, float, float] | None:
    """(the period of a topic's messages on its header clock, s; on the IMU's clock as the receive time says (the
    recorder's clock moved onto the IMU's by ``clock_rate``: the IMU's header minus receive time drift, s per s), s;
    the relative standard error of the latter): straight lines through header stamps ``t_ns`` and receive stamps
    ``receive_ns`` (ns) against each message's number on the header clock (its stamp over the median step, so a
    message lost is a number skipped). None with under :data:`SCHEDULE_MIN_MESSAGES` messages or stamps too uneven
    to number (a step off whole periods by more than a quarter)."""
    t = (np.asarray(t_ns, np.int64) - int(t_ns[0])) / 1e9
    rx = (np.asarray(receive_ns, np.int64) - int(receive_ns[0])) / 1e9
    d = np.diff(t)
    if len(t) < SCHEDULE_MIN_MESSAGES or not np.any(d > 0):
        return None
    step = float(np.median(d[d > 0]))
    k = np.round(t / step)
    if np.any(np.abs(t / step - k) > 0.25) or np.any(np.diff(k) <= 0):
        return None
    header = float(np.polyfit(k, t, 1)[0])
    (received, _), cov = np.polyfit(k, rx, 1, cov="unscaled")
    res = rx - np.polyval(np.polyfit(k, rx, 1), k)
    se = float(np.sqrt(cov[0, 0] * np.sum(res ** 2) / max(1, len(k) - 2)))
    return header, float(received) * (1.0 + clock_rate), se / abs(float(received))


def latency_trend(t_ns: np.ndarray, receive_ns: np.ndarray) -> np.ndarray | None:
    """Header minus receive time's drift at each message of a topic on header stamps ``t_ns`` received at
    ``receive_ns`` (ns), s from the first (:func:`latency_rate`: its steps taken out): None unless it drifts by more
    than :data:`CLOCK_DRIFT_NOTE_S` and :data:`HEADER_STEP_SPREADS` of its spread about the line over the topic, as a
    drift is taken out (:func:`graphnav.io.bag_convert.header_clock_drift_removed`; the steps of a latency jumping
    between messages, an IMU's in packets, are taken out a packet's sawtooth off and leave a false drift under that
    spread)."""
    rate, spread = latency_rate(t_ns, receive_ns)
    rx = (np.asarray(receive_ns, np.int64) - int(receive_ns[0])) / 1e9
    if not len(rx) or abs(rate * rx[-1]) <= max(CLOCK_DRIFT_NOTE_S, HEADER_STEP_SPREADS * spread):
        return None
    return rate * rx


def why_not_header(header_ns: np.ndarray) -> str | None:
    """Why a stream's header stamps cannot be used (None when they can)."""
    if np.all(header_ns == 0):
        return "all header stamps are zero"
    zero = int(np.count_nonzero(header_ns == 0))
    if zero:
        return f"{zero} header stamp(s) are zero"
    step = np.diff(header_ns)
    dup, back = int(np.count_nonzero(step == 0)), int(np.count_nonzero(step < 0))
    if dup or back:
        first = int(np.flatnonzero(step <= 0)[0]) + 1
        parts = ([f"{dup} duplicated"] if dup else []) + ([f"{back} non-monotonic"] if back else [])
        return f"header stamps {' and '.join(parts)} (first at message {first})"
    return None


#: A topic's header clock stalls (repeats a stamp) on at most this share of its messages for only those to be
#: restamped (:func:`stall_restamped`): a driver stamping bursts of k samples with one time repeats (k - 1) / k of
#: them, half or more.
STALL_MAX_SHARE = 0.25
#: Messages either side of a stalled one whose header minus receive time (the recorder's latency) restamps it.
STALL_LATENCY_MESSAGES = 10
HEADER_CLOCK_STALL = "stamped while the header clock stalled (restamped from the receive time)"


def stall_restamped(header_ns: np.ndarray, receive_ns: np.ndarray, stream: str) -> np.ndarray | None:
    """Which messages of a topic (not the IMU's, whose samples may share a stamp in packets) repeat the header stamp
    before them while their receive time ``receive_ns`` (ns) advanced: a header clock that stalled for a few messages
    (at most :data:`STALL_MAX_SHARE` of them, none stamped zero), each one's stamp the stall's first; a step back
    elsewhere is left to :func:`steps_back_repaired`. None when it is not such a stall."""
    if stream == "imu" or len(header_ns) < 3 or np.any(header_ns == 0):
        return None
    step = np.diff(header_ns)
    stalled = np.r_[False, step == 0]
    if not stalled.any() or stalled.mean() > STALL_MAX_SHARE:
        return None
    if np.any(np.diff(receive_ns)[stalled[1:]] <= 0):        # received together: copies, not a stall
        return None
    return stalled


def _stall_stamps(header_ns: np.ndarray, receive_ns: np.ndarray, stalled: np.ndarray) -> tuple[np.ndarray, float]:
    """(the header stamps ns with the ``stalled`` messages' replaced by their receive time plus the median header minus
    receive time of the :data:`STALL_LATENCY_MESSAGES` messages not stalled either side, the first's latency s)."""
    t_ns = header_ns.copy()
    latency = header_ns - receive_ns
    ok = np.flatnonzero(~stalled)
    first = None
    for k in np.flatnonzero(stalled):
        at = int(np.searchsorted(ok, k))
        near = ok[max(0, at - STALL_LATENCY_MESSAGES):at + STALL_LATENCY_MESSAGES]
        shift = int(np.median(latency[near]))
        t_ns[k] = receive_ns[k] + shift
        first = shift if first is None else first
    return t_ns, first / 1e9


def choose_stamps(header_ns: np.ndarray | None, receive_ns: np.ndarray, meta: dict, stream: str, label: str,
                  clock_s: float = 0.0) -> tuple[np.ndarray, np.ndarray, str]:
    """(stamps ns, kept message indices, ``"header"`` or ``"receive"``) for one stream.

    ``header_ns`` None: the message type has no header (``std_msgs/Float64``): the receive time, noted.
    ``label`` names the stream in warnings (``file:topic``). Every dropped message is counted in ``meta``.
    ``clock_s``: the IMU's header minus receive time, s (:func:`steps_back_repaired`).
    """
    receive_ns = np.asarray(receive_ns, np.int64)
    if header_ns is None:
        why = "the message type has no header"
    else:
        header_ns = np.asarray(header_ns, np.int64)
        why = why_not_header(header_ns)
        if why is None:
            return header_ns, np.arange(len(header_ns)), "header"
        stalled = stall_restamped(header_ns, receive_ns, stream)
        back = steps_back_repaired(header_ns, receive_ns, stream, stalled, clock_s)
        t_ns = header_ns if back is None else back[0]
        if stalled is not None:
            t_ns, latency_s = _stall_stamps(t_ns, receive_ns, stalled)
        if (stalled is not None or back is not None) and np.all(np.diff(t_ns) > 0):
            if back is not None:
                say_steps_back(back[1], meta, stream, label)
            if stalled is not None:
                k = int(np.flatnonzero(stalled)[0])
                say_doubted(meta, stream, label, f"message {k}, field 'header.stamp': the header clock stalls: "
                            f"{int(stalled.sum())} message(s) repeat the stamp before them while the receive time "
                            f"runs on ({(receive_ns[k] - receive_ns[k - 1]) / 1e9:+.3f} s at the first); those are "
                            f"stamped from their receive time plus the topic's latency around them ({latency_s:+.3f} "
                            "s), the others keep their header stamps", HEADER_CLOCK_STALL, int(stalled.sum()),
                            stacklevel=2)
            return t_ns, np.arange(len(header_ns)), "header"
    note = f"stamps: {why}; the bag's receive time is used"
    add_note(meta, stream, note)
    if header_ns is not None:
        warnings.warn(f"{label}: {note} (latency of the recorder included)", RuntimeWarning, stacklevel=3)
    order = np.argsort(receive_ns, kind="stable")
    t = receive_ns[order]
    keep = np.concatenate([[True], np.diff(t) > 0]) if len(t) else np.zeros(0, bool)
    dropped = int(np.count_nonzero(~keep))
    if dropped:
        count_refused(meta, stream, "same receive time as the previous message", dropped)
        warnings.warn(f"{label}: {dropped} message(s) received in the same nanosecond as the previous one "
                      "dropped (no stamp orders them)", RuntimeWarning, stacklevel=3)
    return t[keep], order[keep], "receive"


def header_minus_receive_s(t_ns: np.ndarray, rx_ns: np.ndarray, kind: str) -> float:
    """Median of a topic's stamps ``t_ns`` minus its receive stamps ``rx_ns`` (ns), s; 0 on receive time (``kind``
    not "header") or without messages."""
    if kind != "header" or not len(t_ns):
        return 0.0
    return float(np.median((np.asarray(t_ns) - np.asarray(rx_ns)).astype(np.float64))) / 1e9


def compare_clocks(stamps: dict[str, tuple[np.ndarray, np.ndarray, str]], meta: dict, source: str) -> dict:
    """Record in ``meta["clock"]`` which stamps each stream uses, how its header clock relates to the receive
    clock, and whether the DVL overlaps the IMU. ``stamps``: stream -> (chosen stamps ns, receive ns of the same messages, kind)."""
    clock: dict = {"stamps": {s: kind for s, (_, _, kind) in stamps.items()}, "header_minus_receive_s": {}}
    for stream, (t_ns, rx_ns, kind) in stamps.items():
        if kind == "header" and len(t_ns):
            offset = header_minus_receive_s(t_ns, rx_ns, kind)
            clock["header_minus_receive_s"][stream] = offset
            if abs(offset) > CLOCK_OFFSET_NOTE_S:
                add_note(meta, stream, f"clock: header stamps are {_span(offset)} "
                                       f"{'ahead of' if offset > 0 else 'behind'} the bag's receive clock")
    if "imu" in stamps and "dvl" in stamps:
        imu, dvl = stamps["imu"][0], stamps["dvl"][0]
        overlap = min(imu[-1], dvl[-1]) - max(imu[0], dvl[0])
        clock["dvl_imu_overlap_s"] = float(max(0.0, overlap / 1e9))
        clock["dvl_minus_imu_start_s"] = float(dvl[0] - imu[0]) / 1e9
        if overlap <= 0:
            gap = clock["dvl_minus_imu_start_s"]
            note = (f"clock: the DVL stamps do not overlap the IMU's (DVL starts {_span(gap)} "
                    f"{'after' if gap > 0 else 'before'} the IMU): a clock offset between the two, not pings "
                    "outside the mission; the pings are kept as stamped: estimate the offset "
                    "(graphnav.calibration.clock)")
            add_note(meta, "dvl", note)
            warnings.warn(f"{source}: {note}", RuntimeWarning, stacklevel=3)
    meta["clock"] = clock
    return clock


def _span(seconds: float) -> str:
    s = abs(seconds)
    if s >= 86400:
        return f"{s / 86400:.2f} days ({s:.0f} s)"
    if s >= 3600:
        return f"{s / 3600:.2f} h ({s:.0f} s)"
    return f"{s:.3f} s"
