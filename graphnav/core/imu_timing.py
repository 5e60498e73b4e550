"""When each IMU sample was taken: the IMU's rate from its stamps, and stamps put back where the samples were measured.

A stamp is when a logger or a driver wrote a sample down, which is not always when the IMU measured it: a driver
stamps a packet of samples on receipt, a logger's clock may be as coarse as the IMU's period or coarser, a driver's
buffer may empty at once. Integrated at such stamps, samples make zero-length steps and then long ones. From the
stamps alone, in this order:

* **A file's stamps as read** (:func:`restamp_shared_stamps`, which the readers' IMU stamps go through in
  :func:`graphnav.core.screening.stamp_order` before they must increase): stamps from a clock coarser than the IMU's
  period or about as coarse (:func:`quantised_clock`) are put on one even grid, in stretches
  (:func:`restamp_quantised`); else packets sharing one stamp (:func:`shared_stamp_packets`) are spread back from
  their stamp at the period (:func:`restamp_packets`); else samples that jitter moved onto the stamp before on a grid
  finer than the period (:func:`grid_repeats`) are placed after it. A row equal to the one before it at such a stamp
  is a sample, not a copy (:func:`samples_sharing_a_stamp`); stamps repeating in runs that are none of these are a
  duplicated-stamp error, which says what they look like (:func:`stamped_in_packets`). A step of the stamps the
  samples after it keep, off a line at the period (:func:`stamp_steps`), is a clock step or a gap, said by the reader.
* **The rate** (:func:`imu_rate_hz`, :func:`imu_step_stats`): the median step of even stamps; the mean one-period
  step of stamps on a grid coarser than a tenth of it (:func:`imu_stamp_quantum`) or of an IMU slower than its
  clock's grid, or samples over time where jitter spreads such steps (a lost sample's step counted as the periods it
  spans, a row written twice as none: :func:`_odd_steps`); samples over time without the gaps for stamps in packets
  or bursts (:func:`imu_packet_limit`: the step that ends one); the readers record it as the IMU's rate of a mission
  as read (:func:`shown_rate_hz`). ``prepare`` puts distinct stamps in packets back on
  the period with the same :func:`restamp_packets` and uses the measured rate where the configured one is off; the
  IMU spike tests of :mod:`graphnav.core.screening` take their windows in rows from it.
* **A live stream** (the keyframer, the stream's spike test): a burst the stream starts with (:func:`start_burst`)
  is left out of its rate, and no rate is measured while packets have too few cycles to tell
  (:func:`awaits_packet_cycles`). A live IMU's stamps are decided as they come, with these rules, by
  :mod:`graphnav.estimators.imu_stream_timing`.

Every restamping is warned about and noted once (:func:`say_restamp`: the count in
``meta["streams"]["imu"]["restamped"]``, the period in ``"restamp_period_s"``). Why, and the numbers measured:
docs/decisions/loading-and-prepare.md ("An IMU at another rate than configured"). What a sample's stamp means once
it is right: :mod:`graphnav.core.imu_stamps`.
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from graphnav.core.streams import add_note, set_span

#: Steps an IMU arriving in packets is measured over at most, while it has not three packets' cycles
#: (:func:`awaits_packet_cycles`; the keyframer and the stream's spike test): packets of up to about 120 samples.
IMU_PACKET_STEPS = 256


#: Share of an IMU's steps off their median (under half or over twice it) above which its stamps come in bursts (a
#: driver stamping messages on receipt: three samples 0.1 ms apart every 30 ms have 1/3 of their steps off; even
#: stamps with dropped samples or gaps have a few).
IMU_BURST_SHARE = 0.2
#: A step longer than this many burst cycles (the median of the long steps) is a gap, left out of a burst stream's rate.
IMU_BURST_GAP_CYCLES = 4.0


#: A step under this share of the configured IMU period is within a burst (stamps on receipt), not one period long.
BURST_STEP_SHARE = 0.1
#: A stream whose first this many steps or more are within a burst (:data:`BURST_STEP_SHARE`) starts with one: a
#: driver's buffer emptied at once. Its steps are left out of the rate a stream measures (half of the keyframer's 16
#: steps: a median over them is the burst's). Fewer, as at the start of a stream in bursts of three, are kept.
IMU_START_BURST_STEPS = 8
#: A run of burst steps at a stream's start lasting this many configured periods is the IMU's own rate (an IMU ten
#: times faster than configured), not a burst: its steps are measured.
IMU_START_BURST_PERIODS = 16


def start_burst(steps, period_s: float) -> int | None:
    """How many of a stream's first ``steps`` between IMU stamps (s) are a burst at its start (:data:`
    IMU_START_BURST_STEPS` or more steps under :data:`BURST_STEP_SHARE` of the configured ``period_s`` before a longer
    one that a step as long follows), 0 for none; None while undecided (every step so far is that short, over less
    than :data:`IMU_START_BURST_PERIODS` periods, or the step after the first longer one is to come). A short step
    after the longer one is the next of an IMU's packets (k samples stamped together every k periods): the start was
    one too, no burst."""
    short = BURST_STEP_SHARE * period_s
    n = next((i for i, d in enumerate(steps) if not d < short), None)
    if n is None:
        return None if sum(steps) < IMU_START_BURST_PERIODS * period_s else 0
    if n < IMU_START_BURST_STEPS:
        return 0
    if len(steps) == n + 1:
        return None
    return 0 if steps[n + 1] < short else n


def start_burst_warning(n_steps: int, t_end: float, span_s: float) -> str:
    """What a stream says of the burst of ``n_steps`` steps over ``span_s`` (s) ending at ``t_end`` (s) it starts
    with (:func:`start_burst`)."""
    return (f"imu: the stream starts with a burst of {n_steps + 1} samples within {1e3 * span_s:.3g} ms (t = "
            f"{t_end - span_s:.4f} to {t_end:.4f} s; a driver's buffer emptied at once): their steps are left out of "
            "the IMU's rate")


#: Stamps on a grid coarser than this share of the IMU's step are quantised (a 400 Hz IMU logged in whole ms: steps
#: of 2 and 3 ms on a 1 ms grid, whose median reads 333 or 500 Hz): their period is the mean step, not the median.
IMU_STAMP_QUANTUM_SHARE = 0.1


def step_lengths(steps) -> np.ndarray:
    """The lengths (s) of the finite non-zero ``steps`` (s) between stamps, which an IMU's period is measured from."""
    d = np.abs(np.asarray(steps, float))
    return d[np.isfinite(d) & (d > 0.0)]


def imu_stamp_quantum(steps: np.ndarray) -> float:
    """The grid of an IMU's stamps from the steps between them (s), s, when it is coarser than
    :data:`IMU_STAMP_QUANTUM_SHARE` of the median step: the steps within half a median of it take two or more
    lengths, every one a multiple of the shortest difference between them; else 0 (even stamps, jitter finer than
    the grid, stamps in bursts)."""
    d = step_lengths(steps)
    if not d.size:
        return 0.0
    med = float(np.median(d))
    resolution = 1e-3 * med             # float stamps (Unix seconds) carry ~1e-7 s of rounding
    near = d[np.abs(d - med) <= 0.5 * med]
    lengths, which = np.unique(np.round(near / resolution), return_inverse=True)
    if lengths.size < 2:
        return 0.0
    means = np.bincount(which, near) / np.bincount(which)          # each length as logged, not its rounding
    quantum = float(np.min(np.diff(means)))
    # against the lengths as logged: rounded, 9 and 10 ms steps (110 Hz) or 5, 6 and 7 (160 Hz) fell off their grid
    if not np.all(np.abs(means / quantum - np.round(means / quantum)) * quantum <= resolution):
        return 0.0
    return quantum if quantum > IMU_STAMP_QUANTUM_SHARE * med else 0.0


def _quantised_period(d: np.ndarray, med: float, quantum: float, steps) -> float:
    """The mean of the steps ``d`` (s) of stamps on a ``quantum`` grid (s) that are one period long: those within a
    grid step (at least half a median) of the median ``med``, then within half their mean of that mean (a dropped
    sample's double step is left out, so is a gap). Over a run of steps it is the run's span over its count. A grid
    half the period or coarser (50 Hz in 10 ms with jitter: steps of 10, 20, 30 ms) puts a moved sample's steps a grid
    step either side of the period, half a mean away or more: they are kept up to one and a half grid steps away
    (below the period), where one side alone read 60 Hz, 42.7 Hz, or 42.1 Hz over 10 steps; a lost sample's double
    step, as long there (30 ms at 55 or 60 Hz), is told by the samples after it (:func:`_lost_steps` of the ``steps``
    as read) and left out (60 Hz in whole 10 ms with 1 % lost read 59.55-59.76 Hz); counted over time instead
    (:func:`_counted_period`) where no sample was lost (50 Hz in whole 10 ms with 3 ms of jitter: the mean 0.05-0.10 %
    off, counted 0.00), where stamps repeat (500 Hz in whole ms with 0.5 ms of jitter) or where the count is over
    :data:`MEAN_STEP_MISS_SHARE` off the mean (the same, its repeats placed, read 511 Hz). On a finer grid the steps
    near the median taking more than two lengths (jitter) are counted over time (:func:`_counted_period`): a mean
    over a window about the median left out more of one side (385 Hz in whole ms with 0.2 ms of jitter read 386.4 Hz,
    150 Hz with 0.5 ms 142.86 Hz); without jitter the mean is exact, and a count misses some of many lost samples."""
    near = np.abs(d - med) <= max(0.5 * med, quantum) + 1e-3 * med
    first = float(np.mean(d[near]))
    if quantum < 0.45 * first:
        one = d[near][np.abs(d[near] - first) < 0.5 * first]
        if np.unique(np.round(d[near] / quantum)).size <= 2:    # a rate on a grid, no jitter: one of two steps
            return float(np.mean(one))
        return _counted_period(_counted_steps(steps), float(np.mean(one)))
    for _ in range(2):
        one = near & (np.abs(d - first) <= min(1.5 * quantum, 0.95 * first))
        lost = _lost_steps(steps, first)
        first = float(np.mean(d[one & ~lost]))
    counted = _counted_period(_counted_steps(steps), first)
    # the count misjudges some lost samples the mean leaves out; the mean splits a repeated stamp's pair of steps
    if np.any(lost) and not np.any(_read_steps(steps) == 0.0) and abs(counted - first) <= MEAN_STEP_MISS_SHARE * first:
        return first
    return counted


#: How far (relative) the period counted over time must be from the mean one-period step of stamps on a grid half
#: the period or coarser, samples lost, to be taken for it (:func:`_quantised_period`): the count misjudges some lost
#: samples the mean leaves out (64 Hz in whole 10 ms with 0.5-2 ms of jitter, 1 % lost: counted 0.08-0.29 % off, the
#: mean 0.00-0.10 %), and repeats placed after their stamps split steps the mean leaves out (500 Hz in whole ms with
#: 0.5 ms of jitter: the mean 2.3-2.8 % off, counted 0.00-0.37 %).
MEAN_STEP_MISS_SHARE = 0.01


def _counted_period(x: np.ndarray, mean_s: float) -> float:
    """The period (s) of IMU steps ``x`` (s, in order; 0 for a repeated stamp) on a grid finer than it, counted over
    time (:func:`_periods_over_time`) from the ``mean_s`` of the steps near it (s) and from the median time of
    :data:`SPAN_STEPS` steps over their count: the count whose samples keep closer to its line, lost samples and rows
    written twice counted (:func:`_odd_steps`). Jitter of a fifth of the period or more leaves out more long steps than
    short ones from that mean, and a line at a period 5 % off parts its samples as a lost one does (counted from that
    mean alone, 250 Hz in whole ms with 1 ms of jitter read 236 Hz); a row written twice among a few stamps is in
    most spans of them."""
    spreads = [(_line_spread(x, p), p) for p in (_periods_over_time(x, s) for s in (mean_s, _span_period(x)))]
    return min([(math.inf, mean_s), *spreads], key=lambda c: c[0])[1]      # a NaN spread (no steps) is never less


def _line_spread(x: np.ndarray, period_s: float) -> float:
    """The spread (s, standard deviation) of IMU steps ``x`` (s, in order) about a line at ``period_s`` (s), lost
    samples and rows written twice counted (:func:`_odd_steps`); NaN without steps."""
    return float(np.std(_line_offsets(x, _periods_spanned(x, *_odd_steps(x, period_s), period_s), period_s)))


#: Steps whose time over their count starts :func:`_counted_period` too (:func:`_span_period`).
SPAN_STEPS = 4


def _span_period(x: np.ndarray) -> float:
    """The median time (s) of :data:`SPAN_STEPS` consecutive IMU steps ``x`` (s, in order; 0 for a repeated stamp)
    over their count: jitter moves a span's ends alone, and a lost sample or a row written twice is in few spans."""
    span = np.convolve(x, np.ones(SPAN_STEPS), "valid")
    return float(np.median(span) / SPAN_STEPS) if span.size else float(np.mean(x))


def _read_steps(steps) -> np.ndarray:
    """The finite, non-negative ``steps`` (s) between an IMU's stamps, in order (0 for a repeated stamp)."""
    x = np.asarray(steps, float)
    return x[np.isfinite(x) & (x >= 0.0)]


def _counted_steps(steps) -> np.ndarray:
    """The ``steps`` (s, as read, in order) a period is counted over (:func:`_counted_period`): as read, a repeated
    stamp a step of 0 (a row written twice, counted as no period), unless repeated stamps are more than
    :data:`IMU_BURST_SHARE` of them: packets sharing one stamp as read, whose repeats are left out as
    :func:`imu_step_stats` leaves them (counted as rows written twice, the period shrank towards 0 s: packets of 4
    at 100 Hz in whole ms with 0.5 ms of jitter read 25.7 Hz with numpy dividing by zero, for 25 Hz)."""
    x = _read_steps(steps)
    return x if np.mean(x == 0.0) <= IMU_BURST_SHARE else x[x > 0.0]


def _periods_over_time(x: np.ndarray, period_s: float) -> float:
    """The period (s) of IMU steps ``x`` (s, in order, finite, non-negative: :func:`_counted_steps`; 0 for a repeated
    stamp) near ``period_s`` (s): their time over their count, a lost sample's step counted as the periods it spans
    and a row written twice as none (:func:`_odd_steps`), steps over :data:`IMU_BURST_GAP_CYCLES` periods (gaps, clock
    steps) left out; refined twice. A sample jitter moves lengthens one step and shortens the next by as much: a mean
    of the steps near the period left out the long one of such a pair and not the short one (128 Hz in whole ms with
    2 ms of jitter read 130.5-131.4 Hz, 190 Hz with 2 ms 198.6 Hz)."""
    for _ in range(3):
        keep = x <= IMU_BURST_GAP_CYCLES * period_s
        periods = float(np.sum(_periods_spanned(x, *_odd_steps(x, period_s), period_s)[keep]))
        if not periods > 0:
            break
        period_s = float(np.sum(x[keep])) / periods
    return period_s


#: Samples on each side of a long step whose mean offsets from a line at the period tell a sample lost (they differ by
#: a period) from one moved across a grid edge (they agree) on a grid over 0.45 of the period (:func:`_lost_steps`).
LOST_STEP_SAMPLES = 10


def _lost_steps(steps, period_s: float) -> np.ndarray:
    """Which of the positive finite ``steps`` (s, as read, in order; :func:`step_lengths`) between stamps on a grid as
    coarse as half the ``period_s`` (s) or more span a lost sample (:func:`_odd_steps`)."""
    d = np.abs(np.asarray(steps, float))
    d = d[np.isfinite(d)]
    return _odd_steps(d, period_s)[0][d > 0.0]


def _odd_steps(d: np.ndarray, period_s: float) -> tuple[np.ndarray, np.ndarray]:
    """``(lost, extra)``: which of the finite non-negative steps ``d`` (s, as read, in order) between IMU stamps span a
    lost sample (over 1.45 periods ``period_s``, s) or end a row written twice (under half a period), the samples after
    them (:data:`LOST_STEP_SAMPLES`) a period or more later (or earlier) against a line at the period than those before
    (half of it decides), most so among the neighbours that may be one; in passes, each on the line that counts those
    found before (two lost samples or rows written twice within as many samples part the line at one of them by most).
    A sample moved across a grid edge lengthens one step and shortens the next, so the line holds (50 Hz in whole 10 ms:
    a 30 ms step may be either); one sharing the stamp before it is a step of 0, counted."""
    lost, extra = np.zeros(d.size, bool), np.zeros(d.size, bool)
    for _ in range(ODD_STEP_PASSES):
        jump = _line_jump(d, _periods_spanned(d, lost, extra, period_s), period_s)
        # a lost sample's jump peaks at its step and tapers over the samples either side: a moved one near it is no loss
        new_lost = _peaks(~lost & (d > 1.45 * period_s) & (jump > 0.5 * period_s), jump)
        new_extra = _peaks(~extra & (d < 0.5 * period_s) & (jump < -0.5 * period_s), -jump)
        if not (np.any(new_lost) or np.any(new_extra)):
            break
        lost, extra = lost | new_lost, extra | new_extra
    return lost, extra


#: Passes of :func:`_odd_steps`: each finds one more of lost samples or rows written twice closer together than
#: :data:`LOST_STEP_SAMPLES`.
ODD_STEP_PASSES = 4


def _periods_spanned(d: np.ndarray, lost: np.ndarray, extra: np.ndarray, period_s: float) -> np.ndarray:
    """How many periods ``period_s`` (s) each of the steps ``d`` (s) between IMU stamps spans: as many as it is long
    where a sample was ``lost``, none where it ends a row written twice (``extra``), else one (:func:`_odd_steps`)."""
    return np.where(lost, np.round(d / period_s), 1.0 - extra)


def _line_offsets(d: np.ndarray, periods: np.ndarray, period_s: float) -> np.ndarray:
    """How far (s) each IMU stamp after the steps ``d`` (s, spanning ``periods`` each) lies from a line at
    ``period_s`` (s) through the first."""
    return np.cumsum(d) - np.cumsum(periods) * period_s


def _line_jump(d: np.ndarray, periods: np.ndarray, period_s: float) -> np.ndarray:
    """At each of the steps ``d`` (s) between IMU stamps, spanning ``periods`` each, how much later (s) the
    :data:`LOST_STEP_SAMPLES` samples after it sit against a line at ``period_s`` (s) than as many before it."""
    n = LOST_STEP_SAMPLES
    off = np.r_[0.0, _line_offsets(d, periods, period_s)]
    total = np.r_[0.0, np.cumsum(off)]
    c = np.arange(d.size)
    a, b = np.maximum(c + 1 - n, 0), np.minimum(c + 1 + n, off.size)
    return (total[b] - total[c + 1]) / (b - c - 1) - (total[c + 1] - total[a]) / (c + 1 - a)


def _peaks(candidate: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Which ``candidate`` places hold the largest of ``x`` among the candidates within :data:`LOST_STEP_SAMPLES` - 1
    places of them."""
    n = LOST_STEP_SAMPLES
    padded = np.pad(np.where(candidate, x, -np.inf), n - 1, constant_values=-np.inf)
    return candidate & (x >= np.max(np.lib.stride_tricks.sliding_window_view(padded, 2 * n - 1), axis=1))


def awaits_packet_cycles(steps, period_s: float) -> bool:
    """Whether a stream's IMU ``steps`` so far (s) are an IMU's packets (steps under :data:`BURST_STEP_SHARE` of the
    configured ``period_s`` and longer ones) whose cycles do not make packets for :func:`in_packets` yet (fewer than
    three, or a lost packet's double cycle among three or four), and :data:`IMU_PACKET_STEPS` not reached: a rate
    measured now would be the packets' inner step (packets of 4 or 5 samples gave two cycles in a spike test's eleven
    stamps and read 100 kHz; packets of 20 with the second lost read 1e+05 Hz and bridged every later packet)."""
    d = np.asarray(steps, float)
    long = d > 2.0 * float(np.median(d))
    return (0 < int(np.sum(long)) and not in_packets(d, long) and float(np.median(d[~long])) < 0.5 * period_s
            and d.size < IMU_PACKET_STEPS)


def in_packets(d: np.ndarray, long: np.ndarray) -> bool:
    """Whether IMU steps ``d`` (s; ``long``: those over twice their median) are an IMU's packets, k samples stamped
    together every k periods: too few long steps for :data:`IMU_BURST_SHARE` from k = 5 on, yet two or more, most
    within half of their median (a regular cycle, where gaps have any length; three of them at least), the others under
    :data:`BURST_STEP_SHARE` of the time (a stream at its rate with gaps spends more between them)."""
    cycles = d[long]
    # three cycles at least: two gaps of a clean stream among its first stamps fit the rest as well (a stream's spike
    # test read 7.4 Hz from two 0.5 s dropouts in eleven stamps and stayed off)
    if cycles.size < 3 or np.sum(d[~long]) >= BURST_STEP_SHARE * np.sum(d):
        return False
    cycle = np.median(cycles)
    return bool(np.mean(np.abs(cycles - cycle) <= 0.5 * cycle) >= 0.8)


#: A share of an IMU's steps at least this large under :data:`BURST_STEP_SHARE` of its configured period, with
#: regular longer steps between them (:func:`in_packets`), is packets whatever the median step: packets of 2 make as
#: many short steps as long ones, and their median fell between them (read as even) or on either side as the log
#: was cut.
PACKET_SHORT_SHARE = 1.0 / 3.0


def _long_step_limit(d: np.ndarray, med: float, expected_s: float | None, tolerance: float) -> float:
    """The step (s) over which one of an IMU's positive steps ``d`` (s; ``med`` their median, or the quantised
    period) ends a packet or burst: twice the median when :func:`in_packets` or :data:`IMU_BURST_SHARE` says so, a
    tenth of the ``expected_s`` period when :data:`PACKET_SHORT_SHARE` of the steps are that short
    (:func:`in_packets` over the longer ones, whose median is over 1.5 periods: a stream half even, half in packets
    is no packets of its even steps); inf for even stamps (a median within ``tolerance`` of
    ``expected_s`` is even whatever the long steps: gaps and stutters)."""
    long = d > 2.0 * med
    packets = in_packets(d, long)
    if expected_s is not None:
        limit = BURST_STEP_SHARE * expected_s
        ends = d > limit        # a packet's long step spans all but its samples' short ones: over 1.5 periods
        if (not packets and np.mean(~ends) >= PACKET_SHORT_SHARE and in_packets(d, ends)
                and np.median(d[ends]) > 1.5 * expected_s):
            return limit
        if abs(med - expected_s) <= tolerance * expected_s:
            return math.inf
    if not packets and (np.mean(long | (d < 0.5 * med)) <= IMU_BURST_SHARE or not np.any(long)):
        return math.inf
    return 2.0 * med


def _positive_steps(steps) -> tuple[np.ndarray, float]:
    """The positive finite ``steps`` (s) and their median, or the mean one-period step of stamps quantised coarser
    than a tenth of it (:func:`imu_stamp_quantum`), or samples over time of a clock slower than its grid
    (:func:`_slower_than_grid`), s."""
    d = step_lengths(steps)
    if not d.size:
        return d, math.nan
    med = float(np.median(d))
    quantum = imu_stamp_quantum(d)
    if quantum:
        return d, _quantised_period(d, med, quantum, steps)
    return d, _slower_than_grid(steps, med) or _fine_grid_period(d, med, steps)


#: Finest grid, as a share of the median step, that :func:`_fine_grid_period` looks for (a whole-ms log of a 55 Hz
#: IMU: 5.6 %); a grid of 1 us under a 10 ms step is float rounding, not a clock.
FINE_GRID_SHARE = 0.01
#: Share of a grid step by which the mean one-period step must differ from the median for it to be the period
#: (:func:`_fine_grid_period`): up to 1 ms of jitter and 5 % lost move a 100 Hz log in whole ms by under 0.015; 99 and
#: 101 Hz (steps of 10 ms and 9 or 11) are 0.1 off it, and a tenth read 100 Hz for most of them.
FINE_GRID_OFF_SHARE = 0.05


def _fine_grid_period(d: np.ndarray, med: float, steps) -> float:
    """The period (s) of positive steps ``d`` (s; ``med`` their median; ``steps`` as read) on a grid of whole 10 ms or
    1 ms finer than :data:`IMU_STAMP_QUANTUM_SHARE` of the median and not finer than :data:`FINE_GRID_SHARE`: their mean
    one-period step (:func:`_quantised_period`) where it is off the median by :data:`FINE_GRID_OFF_SHARE` of a grid
    step or more, else the median. The median of steps on a grid is a grid multiple: 55 Hz in whole ms (steps of 18
    and 19 ms) read 55.56 Hz, 60 Hz 58.82 Hz, 64 Hz 62.5 Hz."""
    grid = _fine_grid(d, med)
    if not grid:
        return med
    period = _quantised_period(d, med, grid, steps)
    return period if abs(period - med) >= FINE_GRID_OFF_SHARE * grid else med


def _fine_grid(d: np.ndarray, med: float) -> float:
    """The grid (s) of whole 10 ms or 1 ms that positive IMU steps ``d`` (s; ``med`` their median) lie on, between
    :data:`FINE_GRID_SHARE` of the median and :data:`IMU_STAMP_QUANTUM_SHARE` of it (1 ms at 100 Hz); 0 for none."""
    for grid in (1e-2, 1e-3):      # finer ones hold restamped stamps a float's rounding off a grid multiple
        if FINE_GRID_SHARE * med <= grid <= (1.0 + 1e-3) * IMU_STAMP_QUANTUM_SHARE * med and _on_grid(d, grid):
            return grid
    return 0.0


#: Share of an IMU's steps, at least, two grid steps long for a regular pattern of them to be an IMU slower than its
#: clock's grid (:func:`_slower_than_grid`), unless spaced by two consecutive lengths, each a fifth of the spacings or
#: more (97 Hz in whole 10 ms: every 33rd or 34th step 20 ms; it read 100 Hz, the median step, with no note): the
#: IMU's rate beating against the grid. One spacing alone under this share (98 Hz in whole 10 ms: every 50th step)
#: cannot be told from an IMU at the grid's rate losing every 50th sample, and is read at the grid's rate.
SLOWER_CLOCK_SHARE = 0.05


def _slower_than_grid(steps, grid_s: float) -> float | None:
    """The period (s) of IMU ``steps`` (s, as read: 0 for a repeated stamp) on a ``grid_s`` grid (s, their median) that
    leave grid steps empty as an IMU slower than the grid does (70 Hz in whole 10 ms: steps of 10 and 20 ms, 30 % of
    them 20; 97 Hz: every 33rd or 34th): :data:`CLOCK_PATTERN_STAMPS` steps or more two grid steps long or more,
    :data:`ALTERNATING_SHARE` of them spaced by two consecutive lengths (a sample lost shifts the pattern once), both
    taken or :data:`SLOWER_CLOCK_SHARE` of the steps so long, or that share and :data:`BALANCED_SHORT_STAMPS` whose
    samples to a grid step are :func:`_balanced`; samples over time, steps of three grid steps or more left out. None
    else: samples lost at random (their spacing spreads: 10 % lost puts 19 % of it on two lengths), or too few."""
    raw = np.abs(np.asarray(steps, float))
    n = np.round(raw[np.isfinite(raw)] / grid_s)
    if not n.size or not _on_grid(raw[np.isfinite(raw)], grid_s):
        return None
    empty = np.flatnonzero(n >= 2)
    if empty.size < CLOCK_PATTERN_STAMPS:
        return None
    spacing = np.bincount(np.diff(empty))
    pair = int(np.argmax(spacing[:-1] + spacing[1:]))
    regular = spacing[pair] + spacing[pair + 1] >= ALTERNATING_SHARE * (empty.size - 1)
    # both lengths: the IMU's rate beating against the grid; one alone (every 97th) is a driver losing samples as well
    beat = min(spacing[pair], spacing[pair + 1]) >= (1.0 - ALTERNATING_SHARE) * (empty.size - 1)
    many = empty.size >= SLOWER_CLOCK_SHARE * n.size
    if not (regular and (beat or many) or (many and empty.size >= BALANCED_SHORT_STAMPS
                                           and _balanced(np.ones(n.size), n))):
        return None
    return float(grid_s * np.sum(n[n <= 2]) / np.sum(n <= 2))


def imu_packet_limit(steps: np.ndarray, expected_s: float | None = None, tolerance: float = 0.05) -> float:
    """The step (s) over which one of an IMU's ``steps`` (s) ends a packet or burst, by the rule
    :func:`imu_step_stats` measures them with (``expected_s``, ``tolerance``: the configured period and how near a
    median step confirms it); inf for even stamps or none."""
    d, med = _positive_steps(steps)
    return _long_step_limit(d, med, expected_s, tolerance) if d.size else math.inf


def imu_step_stats(steps: np.ndarray, expected_s: float | None = None, tolerance: float = 0.05
                   ) -> tuple[float, float]:
    """``(period, cycle)`` of an IMU from the steps between its stamps (s; out-of-order and repeated stamps left
    out), s: for even stamps both are the median step, for stamps quantised coarser than a tenth of it
    (:func:`imu_stamp_quantum`) the mean one-period step; for stamps in packets or bursts (the long steps of
    :func:`imu_packet_limit` end them) the period is the mean step without the gaps (so the rate is samples over
    time) and the cycle the median time from a packet's last stamp to the next's (its long step alone leaves out
    the time inside a packet: packets of 10 0.6 ms apart read 9; in regular packets the packets either side of a
    loss are left out, :func:`_whole_packet_steps`: packets of 20 with one lost among the first five read 80 Hz,
    packets of 2 with five lost 108 Hz). A median step within ``tolerance``
    (relative) of the ``expected_s`` period (the configured one) is that period whatever the long steps, unless a
    share of the steps under a tenth of it makes packets: they are gaps and stutters, not bursts (a start with four
    0.2 s hiccups in sixteen steps read 57.5 ms). NaN without a positive finite step."""
    d, med = _positive_steps(steps)
    if not d.size:
        return math.nan, math.nan
    long = d > _long_step_limit(d, med, expected_s, tolerance)
    if not np.any(long):
        return med, med
    ends = np.flatnonzero(long)
    between = np.diff(np.cumsum(d)[ends])
    cycle = float(np.median(between if between.size else d[long]))
    span = slice(ends[0] + 1, ends[-1] + 1) if ends.size >= 2 else slice(None)  # whole bursts: a cut one biases
    whole = d[span]                                                                # a short count
    keep = whole <= IMU_BURST_GAP_CYCLES * cycle
    if in_packets(d, long):
        kept = _whole_packet_steps(d, long, cycle)[span]      # a loss before the span may cut its first packet
        keep = kept if np.any(kept) else keep
    return float(np.mean(whole[keep])), cycle


#: A step from one of an IMU's packets to the next longer than this many packet cycles is a loss (samples or packets
#: lost), not a cycle of packets of varying size.
PACKET_LOSS_CYCLES = 1.5


def _whole_packet_steps(steps: np.ndarray, ends: np.ndarray, cycle_s: float) -> np.ndarray:
    """Which of an IMU's ``steps`` (s; ``ends``: those ending a packet) in packets every ``cycle_s`` (s) make its rate:
    all but those of a packet whose long step is a loss (:data:`PACKET_LOSS_CYCLES`) and of the packet after it. A
    loss's samples are not counted, so neither is its time; one that cuts packets leaves them short on either side of
    its long step, their time a whole cycle each (counting the loss as one cycle per lost packet read 98.9 Hz for
    100 Hz)."""
    packet = np.cumsum(ends) - ends         # a packet's long step ends it: it belongs to the packet before
    lost = np.unique(packet[ends & (steps > PACKET_LOSS_CYCLES * cycle_s)])
    return ~np.isin(packet, np.r_[lost, lost + 1])


def restamp_packets(t: np.ndarray, period_s: float, limit_s: float, after: float = -math.inf) -> np.ndarray:
    """IMU stamps ``t`` (s, increasing) with each packet (a run of samples whose steps are at most ``limit_s``, s,
    :func:`imu_packet_limit`: a packet or burst stamped on receipt) spread backward from its last stamp (the receipt:
    its samples were measured before it) at ``period_s`` (s), so that each sample's stamp is the start of its own
    interval again; a run with too little room after the one before it (or ``after``, s) is spread evenly over that
    room. A sample alone keeps its stamp, bit for bit (gaps stay gaps)."""
    t = np.asarray(t, float)
    if not t.size:
        return t.copy()
    ends = np.r_[np.flatnonzero(np.diff(t) > limit_s), t.size - 1]
    run = np.searchsorted(ends, np.arange(t.size))
    step = np.minimum(period_s, np.diff(np.r_[after, t[ends]]) / np.diff(np.r_[-1, ends]))
    back = ends[run] - np.arange(t.size)
    return np.where(back > 0, t[ends][run] - back * step[run], t)


def packets_note(k: int, cycle_s: float, period_s: float, which: str | None) -> str:
    """What restamping an IMU in packets of ``k`` every ``cycle_s`` (s) at ``period_s`` (s) did to ``which`` stamps
    (a stream note and a warning); ``which`` None: the stamps were left as read, since restamped they were not on
    the period."""
    found = (f"stamped in packets of {k} (every {1e3 * cycle_s:.4g} ms; a driver stamping samples on receipt): "
             f"{which or 'no stamps'} restamped at the period {1e3 * period_s:.4g} ms")
    if which is None:
        return found + (": spread back from each packet's last stamp they are not on that period, so they are "
                        "integrated as read")
    early = f"{k - 1} period{'s' * (k > 2)}, {1e3 * (k - 1) * period_s:.4g} ms"
    return found + (", each packet spread back from its last stamp, taken as its last sample's (a driver stamping "
                    f"a packet's first sample leaves them {early}, early)")


def imu_rate_hz(t: np.ndarray, expected_hz: float | None = None, tolerance: float = 0.05) -> float:
    """The IMU's rate from its stamps ``t`` (s), Hz: 1 / the period of :func:`imu_step_stats` (the median step, or
    samples over time for stamps in bursts; gaps do not lower it; ``expected_hz``, ``tolerance``: the configured rate
    that a median step near it confirms); NaN with fewer than two distinct finite stamps."""
    expected = None if expected_hz is None else 1.0 / expected_hz
    return 1.0 / imu_step_stats(np.diff(np.asarray(t, float)), expected, tolerance)[0]


def shown_rate_hz(stream: str, t: np.ndarray) -> float | None:
    """The rate (Hz) a reader records for ``stream`` (``meta["streams"][stream]["rate_hz"]``, what ``graphnav info``
    shows of a mission as read) from its stamps ``t`` (s, any order, NaN where a sample has none): the IMU's
    :func:`imu_rate_hz` of its finite stamps in order, as the readers and the screening read it (in whole ms the
    median step of a 128 Hz IMU is 8 ms, 125 Hz; NaN with fewer than two distinct stamps); None for any other stream,
    whose rate is its median step (:func:`graphnav.core.streams.set_span`). ``prepare`` confirms the IMU's against
    the configured rate."""
    if stream != "imu":
        return None
    t = np.asarray(t, float)
    return imu_rate_hz(np.sort(t[np.isfinite(t)]))


#: Share of the steps between an IMU's shared stamps within a hundredth of their median above which the packets come
#: at a steady cycle (a driver reading k samples at a time) and their period is the cycle over k: samples over time
#: read 10.48 ms for packets of 10 at 100 Hz with 5 % of the samples lost.
STEADY_CYCLE_SHARE = 0.9


def stamp_runs(t: np.ndarray) -> tuple[int, float, np.ndarray, np.ndarray] | None:
    """``(k median run, cycle s, steps s, counts)`` of stamps ``t`` (s) most of which repeat in runs (four distinct
    stamps or more, half of them repeated; the steps between them, their median the cycle), else None: packets
    sharing a stamp for :func:`shared_stamp_packets` and for a duplicated-stamp message (:func:`stamped_in_packets`)."""
    stamps, counts = np.unique(np.asarray(t, float), return_counts=True)
    if stamps.size < 4 or np.mean(counts > 1) < 0.5:
        return None
    d = np.diff(stamps)
    return int(np.median(counts)), float(np.median(d)), d, counts


def shared_stamp_packets(t: np.ndarray) -> tuple[int, float, float] | None:
    """``(k, cycle s, period s)`` of IMU stamps ``t`` (s, file order) that come in packets sharing one stamp (a driver
    stamping each read of k samples with its receipt, or a 400 Hz IMU in packets of 4 logged in whole ms): never
    decreasing, most in runs (:func:`stamp_runs`), the steps between the runs a regular cycle (most within
    half of their median: gaps have any length); the period is the cycle over the median count where the cycle is
    steady (:data:`STEADY_CYCLE_SHARE` of the steps within a hundredth of it: samples lost from such packets do not
    lengthen it) and the counts hold (:func:`counts_vary`), else samples over time, steps over
    :data:`IMU_BURST_GAP_CYCLES` cycles left out. None else: a few repeated stamps in an even file are no packets."""
    t = np.asarray(t, float)
    runs = None if t.size < 2 or np.any(np.diff(t) < 0) else stamp_runs(t)
    if runs is None:
        return None
    k, cycle, d, counts = runs
    if np.mean(np.abs(d - cycle) <= 0.5 * cycle) < 0.8:
        return None
    # counts above k (a clock coarser than a period it does not divide: 205 Hz in whole 10 ms) make cycle / k the
    # wrong period; short packets are samples lost
    if np.mean(np.abs(d - cycle) <= 0.01 * cycle) >= STEADY_CYCLE_SHARE and not counts_vary(counts):
        return k, cycle, cycle / k
    # each step holds the samples of the packet it ends: they were measured since the stamp before
    inside = d <= IMU_BURST_GAP_CYCLES * cycle
    return k, cycle, float(np.sum(d[inside]) / np.sum(counts[1:][inside]))


#: Share of a quantised clock's distinct stamps, and of the steps between them, that lie on its grid (within a
#: hundredth of a grid step) (:func:`quantised_clock`).
QUANTISED_GRID_SHARE = 0.99


def _on_grid(x: np.ndarray, grid: float, share: float | None = QUANTISED_GRID_SHARE) -> bool:
    """Whether ``share`` of ``x`` (s), or with None all of them, lie within 1 % of a step of a multiple of ``grid``
    (s)."""
    near = np.abs(x / grid - np.round(x / grid)) <= 0.01
    return bool(np.all(near)) if share is None else bool(np.mean(near) >= share)


#: Share of the stamps (first and last left out) holding one sample more than most do, above which they vary:
#: a clock coarser than an IMU's period whose ratio to it is no whole number (200 Hz in whole 10 ms with 0.5 ms
#: jitter: a quarter hold 3; 202 Hz: 2 %); a driver's regular packets hold their count, fewer where samples are lost.
VARYING_COUNT_SHARE = 1e-3


#: Stamps showing a clock's pattern needed before it is believed: stamps holding one sample fewer than most do, spaced
#: by two consecutive lengths only (:func:`counts_vary`), or repeated stamps alternating with empty grid steps
#: (:func:`_clock_at_period`); a driver's packets losing a sample, or an even log with a row written twice, make one.
CLOCK_PATTERN_STAMPS = 10
#: Stamps holding one sample fewer than most do, at least this many, whose cumulative count (less its mean) spans
#: under :data:`BALANCED_COUNT_SPAN` samples, are a clock's with jitter (100 Hz on Windows' 15.6 ms timer with 1 ms
#: of jitter: 44 % hold 1, the rest 2, spanning 2.9 at most over 40 draws of 30000 samples), where 100 samples lost
#: at random from packets span 5.7 or more (1000 draws in 1000 to 200000 stamps).
BALANCED_SHORT_STAMPS = 100
BALANCED_COUNT_SPAN = 4.0


def counts_vary(counts: np.ndarray) -> bool:
    """Whether the samples to a stamp (``counts``, in stamp order) vary as a clock's do: one more than their median
    more often than :data:`VARYING_COUNT_SHARE`, or one fewer at :data:`CLOCK_PATTERN_STAMPS` stamps or more spaced
    by two consecutive lengths only (190 Hz in whole 10 ms: every tenth stamp holds 1, the others 2), or at
    :data:`BALANCED_SHORT_STAMPS` or more not wandering off a line (such a clock with jitter). Samples lost
    from packets fall short at random (5 % lost from packets of 10 leaves 40 % short, spaced anyhow); twice as many
    is a packet written twice; the first and last stamps may hold a part of a packet or grid step."""
    inner = counts[1:-1]
    if not inner.size:
        return False
    med = np.median(counts)
    short = np.flatnonzero(inner == med - 1)
    spacing = np.diff(short)
    regular = spacing.size >= CLOCK_PATTERN_STAMPS - 1 and np.ptp(spacing) <= 1
    regular |= short.size >= BALANCED_SHORT_STAMPS and _balanced(inner)
    return bool(np.mean(inner == med + 1) > VARYING_COUNT_SHARE or regular)


def _balanced(counts: np.ndarray, steps: np.ndarray | None = None) -> bool:
    """Whether the cumulative sum of ``counts`` (samples to a stamp; ``steps``: the grid steps to each stamp from the
    one before, 1 each when None) stays within :data:`BALANCED_COUNT_SPAN` samples of the line through its ends
    against the grid steps, as a clock's does (each sample in its own grid step, give or take jitter); samples lost
    or written twice at random wander off it."""
    at = np.cumsum(np.ones(counts.size) if steps is None else steps)
    total = np.cumsum(counts)
    return bool(np.ptp(total - total[-1] / at[-1] * at) < BALANCED_COUNT_SPAN)


def _clock_events(counts: np.ndarray, steps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(kind, where)``: the repeated stamps (+1) and empty grid steps (-1) of distinct stamps holding ``counts``
    samples ``steps`` grid steps apart, in time order, and where each lies in distinct stamps (a repeated stamp at
    its index, an empty grid step half-way between its stamps)."""
    repeated = np.flatnonzero(counts > 1)
    where = np.r_[repeated, np.flatnonzero(steps > 1) + 0.5]
    order = np.argsort(where, kind="stable")
    return np.r_[np.ones(repeated.size), -np.ones(where.size - repeated.size)][order], where[order]


#: How far apart, in distinct stamps, a repeated stamp and the empty grid step jitter left with it may lie (a sample
#: pushed across a grid edge: the stamps in between hold their samples a step early or late; 100 Hz in whole 10 ms
#: with 1 ms of jitter: 83 % beside each other, 99.4 % within this, two stamps between them at most).
PAIR_STAMPS = 3


def _alternating(kind: np.ndarray) -> bool:
    """Whether a clock's events (:func:`_clock_events`) are followed by the other kind, :data:`ALTERNATING_SHARE` of
    them or more: sampling jitter across the grid's edges, few samples lost."""
    return kind.size >= 2 and bool(np.mean(kind[1:] != kind[:-1]) >= ALTERNATING_SHARE)


def _jitter_pairs(kind: np.ndarray, where: np.ndarray, n_steps: int) -> tuple[np.ndarray, int] | None:
    """``(paired, lost)``: which of a clock's events (``kind``, ``where``: :func:`_clock_events`) pair a repeated
    stamp with an empty grid step within :data:`PAIR_STAMPS` stamps, each event in one pair at most (nested as
    parentheses: two samples pushed across, then their two empty steps), and the empty steps left, samples lost, when
    :data:`ALTERNATING_SHARE` of the repeats or more are paired and those are under :data:`SLOWER_CLOCK_SHARE` of the
    ``n_steps`` between distinct stamps: jitter across the grid's edges where samples were lost, however few repeats
    (100 Hz in whole 10 ms with 1 ms of jitter, its samples mid-step: 1 to 9 repeats in 12000 stamps, among 60-240
    steps left empty by 0.5-2 % lost). None else: a row written twice in an even log repeats a stamp with no empty
    step beside it (unless a sample was lost there: the stamps cannot tell); an IMU slower than its grid (80 Hz in
    whole 10 ms: a quarter of the steps empty) pairs its repeats by chance."""
    paired = np.zeros(kind.size, bool)
    unpaired: list[int] = []
    for i in range(kind.size):
        if unpaired and kind[unpaired[-1]] != kind[i] and where[i] - where[unpaired[-1]] <= PAIR_STAMPS:
            paired[unpaired.pop()] = paired[i] = True
        else:
            unpaired.append(i)
    repeats = kind > 0
    lost = np.sum(~paired & ~repeats)
    if not np.any(repeats) or np.mean(paired[repeats]) < ALTERNATING_SHARE or lost >= SLOWER_CLOCK_SHARE * n_steps:
        return None
    return paired, lost


#: How likely at most the repeated stamps right beside an empty grid step may be by chance, from samples lost, for them
#: to be a clock's jitter (:func:`_pushed_across`): one row written twice in an even log beside one of 3 % of samples
#: lost is 6 % likely; a 100 Hz log in whole 10 ms with one sample pushed across among 2 % lost 3.7 %.
CHANCE_PAIRS_SHARE = 0.05


def _pushed_across(kind: np.ndarray, where: np.ndarray, n_steps: int) -> bool:
    """Whether a clock's events (``kind``, ``where``: :func:`_clock_events`; ``n_steps`` between distinct stamps) are
    jitter across its grid's edges where samples were lost: the repeats paired with empty grid steps
    (:func:`_jitter_pairs`), and as many right beside one (a sample pushed across empties the step next to its
    repeat) as the lost samples' empty steps, the unpaired ones, would leave there by chance with at most
    :data:`CHANCE_PAIRS_SHARE` likelihood (binomial). A row written twice beside a lost sample in an even log cannot be
    told from one sample pushed across: rare enough, it is one."""
    pairs = _jitter_pairs(kind, where, n_steps)
    if pairs is None:
        return False
    from scipy.stats import binom       # only on this path: a few repeats among many lost samples

    repeats, empty = where[kind > 0], where[kind < 0]
    beside = int(np.sum(np.isin(repeats - 0.5, empty) | np.isin(repeats + 0.5, empty)))
    chance = min(1.0, 2.0 * pairs[1] / n_steps)
    return bool(binom.sf(beside - 1, repeats.size, chance) <= CHANCE_PAIRS_SHARE)


def _repeats_unpaired(counts: np.ndarray, steps: np.ndarray) -> bool:
    """Whether fewer grid steps are empty (``steps`` grid steps between distinct stamps over 1) than half the stamps
    repeated (``counts`` over 1): a sample pushed across a grid edge repeats one stamp and empties another."""
    return bool(np.sum(steps > 1) < 0.5 * np.sum(counts > 1))


def quantised_clock(t: np.ndarray) -> tuple[float, float] | None:
    """``(grid s, period s)`` of IMU stamps ``t`` (s, file order) from a clock coarser than the IMU's period
    (:func:`_coarser_clock`: stamps :func:`shared_stamp_packets` would take for packets) or about as coarse as it
    (:func:`_clock_at_period`: stamps no packets, fewer than half of them repeated), else None."""
    return _clock_or_packets(t)[0]


def _clock_or_packets(t: np.ndarray) -> tuple[tuple[float, float] | None, tuple[int, float, float] | None]:
    """``(clock, packets)`` of IMU stamps ``t`` (s, file order): the clock's ``(grid s, period s)`` when they come
    from one about as coarse as the IMU's period or coarser (:func:`quantised_clock`), else None and the packets
    sharing one stamp (:func:`shared_stamp_packets`) or None; the packets test run once."""
    t = np.asarray(t, float)
    packets = shared_stamp_packets(t)
    clock = _clock_at_period(t) if packets is None else _coarser_clock(t)
    return clock, None if clock else packets


def _coarser_clock(t: np.ndarray) -> tuple[float, float] | None:
    """``(grid s, period s)`` of IMU stamps ``t`` (s, file order) that :func:`shared_stamp_packets` takes for packets
    when they come from a clock coarser than the IMU's period (a 200 Hz IMU logged in whole 10 ms with jitter, 205 Hz
    in whole 10 ms): their steps and offsets from the first stamp are multiples of a grid (their median step, rounded
    to the microsecond: Unix seconds carry ~1e-7 s of rounding) at least 1.5 periods long, holding varying counts
    (:func:`counts_vary`). The period is samples over time (:func:`_samples_over_time`), steps over two grid steps
    left out. None else: a driver's packets sharing a receipt stamp, whose count is constant (fewer where samples are
    lost) even where the stamps fall on multiples of the cycle; such a clock with a whole number of periods to a step
    is read so too (the stamps cannot tell)."""
    grid, d, counts, on_grid = _stamp_grid(t)
    period = _samples_over_time(d, counts, d <= 2.0 * grid)
    if not on_grid or grid < 1.5 * period or not counts_vary(counts):
        return None
    return grid, period


def _to_the_microsecond(grid_s: float) -> float:
    """A grid (s) measured from stamps rounded to the microsecond, from 0.1 ms up: Unix seconds carry ~1e-7 s of
    rounding, which over a long log would put whole stamps off the grid (a 10 ms grid read 9.99998 ms: 200 s of
    stamps 0.045 of a grid step off it)."""
    return round(grid_s, 6) if grid_s >= 1e-4 else grid_s


def _stamp_grid(t: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, bool]:
    """``(grid s, steps s, counts, on it)`` of stamps ``t`` (s, never decreasing): the median step between distinct
    stamps, rounded to the microsecond (Unix seconds carry ~1e-7 s of rounding), those steps, the samples each stamp
    holds, and whether :data:`QUANTISED_GRID_SHARE` of the steps and of the offsets from the first stamp are
    multiples of the grid."""
    stamps, counts = np.unique(t, return_counts=True)
    stamps = stamps - stamps[0]
    d = np.diff(stamps)
    grid = _to_the_microsecond(float(np.median(d)))
    return grid, d, counts, bool(_on_grid(d, grid) and _on_grid(stamps, grid))


#: Share of a clock's repeated stamps and empty grid steps, in time order, followed by the other kind above which they
#: are sampling jitter across the grid's edges on a clock as coarse as the IMU's period (:func:`_clock_at_period`).
ALTERNATING_SHARE = 0.8


def _clock_at_period(t: np.ndarray) -> tuple[float, float] | None:
    """``(grid s, period s)`` of IMU stamps ``t`` (s, file order, never decreasing) from a clock about as coarse as
    the IMU's period (100 Hz logged in whole 10 ms with jitter, a 64 Hz IMU on Windows' 15.625 ms timer, 128 Hz in
    whole 10 ms): on a grid, most steps one grid step, fewer than half the stamps repeated
    (:data:`CLOCK_PATTERN_STAMPS` or more), and the repeated stamps and empty grid steps alternating
    (:func:`_alternating`: samples pushed across a grid edge leave a step empty before or after them, samples
    in between one step late), or :data:`BALANCED_SHORT_STAMPS` repeated or more and the samples to a grid step
    :func:`_balanced`; or, however few, the repeats paired with empty grid steps beside them and few steps left
    empty, more of them right beside one than samples lost would leave by chance (:func:`_pushed_across`: samples
    lost, whose empty steps outnumber the repeats of a log whose samples lie mid-step). The period is samples over
    time, steps over two grid steps left out. None else: rows written twice
    and samples lost in an even log come in any order."""
    if t.size < 4 or np.any(np.diff(t) < 0) or np.all(np.diff(t) > 0):
        return None
    grid, d, counts, on_grid = _stamp_grid(t)
    steps = np.round(d / grid)
    if not on_grid or d.size < 3 or np.mean(steps == 1) < 0.5:
        return None
    repeated = np.flatnonzero(counts > 1)
    kind, where = _clock_events(counts, steps)
    balanced = repeated.size >= BALANCED_SHORT_STAMPS and _balanced(counts[1:-1], steps[:-1])
    pattern = repeated.size >= CLOCK_PATTERN_STAMPS and (_alternating(kind) or balanced)
    if not pattern and not _pushed_across(kind, where, steps.size) and not _slower_with_jitter(t, grid):
        return None
    return grid, _samples_over_time(d, counts, steps <= 2)


def _slower_with_jitter(t: np.ndarray, grid_s: float) -> bool:
    """Whether IMU stamps ``t`` (s, never decreasing, some repeated) on a ``grid_s`` grid (s) are an IMU slower than
    its grid (:func:`_slower_than_grid`: 70 or 80 Hz in whole 10 ms, 30 or 25 % of the steps empty) whose repeated
    stamps are sampling jitter, each keeping the samples on either side on one line at the period
    (:func:`_on_the_line`). Its repeats are too few to alternate with the IMU's own empty steps or for
    :func:`_balanced` (16-34 in 12000 samples at 80 Hz with 1 ms of jitter). A row written twice puts the samples
    after it a period behind the line: no such clock."""
    d = np.diff(t)
    period = _slower_than_grid(d, grid_s)
    return period is not None and bool(np.all(_on_the_line(t - t[0], np.flatnonzero(d == 0) + 1, period)))


def _samples_over_time(d: np.ndarray, counts: np.ndarray, inside: np.ndarray) -> float:
    """The period (s) of a clock's samples: the steps ``d`` (s) between its distinct stamps where ``inside`` over the
    samples the stamps before them hold (``counts``), each stamp holding the samples up to the next (a clock
    truncating to its grid)."""
    return float(np.sum(d[inside]) / np.sum(counts[:-1][inside]))


#: Samples on each side of a repeated stamp whose mean offset from a line at the period tells jitter that moved a
#: sample across a grid edge (the offset holds) from a row written twice or a sample lost (it moves by a period):
#: a second at 50 Hz, the offset known to 0.3 ms on a 10 ms grid (:func:`grid_repeats`).
REPEAT_CHECK_SAMPLES = 50


def grid_repeats(t: np.ndarray) -> tuple[float, float, np.ndarray, int] | None:
    """``(grid s, period s, stamps s, moved)`` of IMU stamps ``t`` (s, file order, never decreasing) on a grid finer
    than their steps (:func:`imu_stamp_quantum`: 50 Hz in whole 10 ms with jitter, steps of 10, 20, 30 ms) where jitter
    moved ``moved`` samples across a grid edge into the step of the one before: each repeat keeps the mean offset
    from a line at the period over :data:`REPEAT_CHECK_SAMPLES` samples on either side (within half a period, or later
    where a sample was lost near it: only the repeat is moved, less than a period) and is placed on the grid after its
    stamp (:func:`place_repeats`) before the next. None else: stamps without such a grid
    (an even log's), or a repeat the grid cannot explain (a row written twice shifts the samples after it by a
    period), or placed stamps that do not read the period (:func:`_reads_period`). The grid is that of
    :func:`imu_stamp_quantum`, or whole ms a tenth of the step (:func:`_tenth_grid`); a repeat of the first stamp is
    judged by the first sample alone before it."""
    t = np.asarray(t, float)
    d = np.diff(t)
    if t.size < 4 or np.any(d < 0) or np.all(d > 0):
        return None
    grid = _to_the_microsecond(imu_stamp_quantum(d) or _tenth_grid(step_lengths(d)))
    s = t - t[0]
    if not grid or np.any(np.abs(s / grid - np.round(s / grid)) > 0.01):
        return None
    period = _positive_steps(d)[1]
    repeats = np.flatnonzero(d == 0) + 1
    if not np.all(_on_the_line(s, repeats, period, later=True)):
        return None
    placed = place_repeats(t, repeats, period, grid)
    if not np.all(np.diff(placed) > 0) or not _reads_period(placed, period):
        return None
    return grid, period, placed, repeats.size


#: How far (relative) the period of restamped IMU stamps may be from the one they were placed at
#: (:func:`grid_repeats`).
RESTAMPED_PERIOD_SHARE = 0.01


def _reads_period(t: np.ndarray, period_s: float) -> bool:
    """Whether increasing IMU stamps ``t`` (s) read the ``period_s`` (s) they were placed at, within
    :data:`RESTAMPED_PERIOD_SHARE`: their rate (:func:`imu_rate_hz`), or their time over their count, a lost sample's
    step counted as the periods it spans (:func:`_periods_over_time`), with that rate no faster. Jitter of half a
    period (500 Hz in whole ms with 1 ms) leaves repeats whose placing read 585 Hz; refused, they say they were
    duplicated, not a wrong rate. Jitter of a fifth of the period or more is read as bursts, samples over time, and 1 %
    of samples lost at random read 1 % slower (400 Hz in whole ms with 1 ms of jitter placed at 400.24 Hz read
    395.99 Hz, counted 400.16 Hz): counted, such logs keep every sample."""
    period = 1.0 / imu_rate_hz(t)
    off = RESTAMPED_PERIOD_SHARE * period_s
    return abs(period - period_s) <= off or (period > period_s and abs(_periods_over_time(np.diff(t), period_s)
                                                                          - period_s) <= off)


def _tenth_grid(d: np.ndarray) -> float:
    """The grid (s) of positive IMU steps ``d`` (s) a tenth of their median or finer (:func:`_fine_grid`: 1 ms at
    100 Hz, which :func:`imu_stamp_quantum` leaves out) that no grid ten times as coarse holds (80 Hz in whole 10 ms
    is an IMU slower than its grid, :func:`_slower_with_jitter`); 0 for none."""
    grid = _fine_grid(d, float(np.median(d))) if d.size else 0.0
    return grid if grid and not _on_grid(d, 10.0 * grid) else 0.0


def _on_the_line(s: np.ndarray, repeats: np.ndarray, period_s: float, later: bool = False) -> np.ndarray:
    """Which of the ``repeats`` (indexes of samples repeating the stamp before them) of relative stamps ``s`` (s)
    keep the mean offset from a line at ``period_s`` (s) over :data:`REPEAT_CHECK_SAMPLES` samples on either side
    within half a period (jitter moved a sample across a grid edge; a row written twice or a sample lost moves it by a
    period), with samples after it (a repeat of the first stamp judged against that sample alone); with ``later``, or
    moves it later (a sample lost near the repeat: 200 Hz in whole ms with 1 ms of jitter and 1 % lost at random had
    one within 50 samples of most repeats), never half a period earlier (a row written twice puts the samples after it
    a period early)."""
    moved = _moved_along_the_line(s, np.asarray(repeats, int), period_s, np.zeros(len(repeats), bool))
    return (moved > -0.5) & (later | (moved < 0.5))


def _moved_along_the_line(s: np.ndarray, repeats: np.ndarray, period_s: float, copies: np.ndarray,
                          samples: int = REPEAT_CHECK_SAMPLES) -> np.ndarray:
    """How far (periods) the mean offset of relative stamps ``s`` (s) from a line at ``period_s`` (s) moves across
    each of the ``repeats`` (indexes of samples repeating the stamp before them), over ``samples`` samples on either
    side (fewer at the ends); NaN without samples after it. The samples after the repeats judged ``copies`` (bool,
    each) are counted one earlier, each repeat's own move left in."""
    r = repeats                     # the pair r - 1, r left out: their offsets are the jitter
    total = np.r_[0.0, np.cumsum(s - _order_without(s.size, r[copies]) * period_s)]
    a, b = np.maximum(0, r - 1 - samples), np.minimum(s.size, r + 1 + samples)
    # a repeat of the first stamp has the pair's first sample alone before it: a row written twice there still puts
    # the samples after it a period early against that sample; after the last stamp nothing tells
    end = np.maximum(r - 1, 1)
    before = (total[end] - total[a]) / (end - a)
    after = (total[b] - total[r + 1]) / np.maximum(b - r - 1, 1)
    moved = (after - before) / period_s - copies
    return np.where(b > r + 1, moved, np.nan)


def _order_without(n: int, copies: np.ndarray) -> np.ndarray:
    """The place of each of ``n`` samples in their order once the rows ``copies`` (indexes, increasing) are taken
    out."""
    return np.arange(n) - np.searchsorted(copies, np.arange(n))


def place_repeats(t: np.ndarray, repeats: np.ndarray, period_s: float, grid_s: float) -> np.ndarray:
    """IMU stamps ``t`` (s, never decreasing) with each of the ``repeats`` (indexes of samples repeating the stamp
    before them) placed after its stamp at j x step (the j-th repeat of it), the step the period ``period_s`` (s) or
    the room to the next stamp shared among the stamp's samples, whichever is less, in whole ``grid_s`` (s): a step
    off the grid would make the grid look finer than it is (a 5 ms grid read 52.5 Hz for 50 Hz in whole 10 ms). Where
    that room is under a grid step (two or three samples of a 400 Hz IMU in one whole ms, the next stamp a ms later)
    the step is the room shared, off the grid: left on its stamp the repeat refused the file."""
    t = np.asarray(t, float)
    stamps, first, counts = np.unique(t, return_index=True, return_counts=True)
    at = np.searchsorted(stamps, t[repeats])
    room = np.r_[np.diff(stamps), math.inf][at] / counts[at]
    share = np.minimum(period_s, room)
    step = np.floor(share / grid_s + 1e-6) * grid_s
    step = np.where(step > 0, step, share)      # no whole grid step free: the room shared, off the grid
    out = t.copy()
    out[repeats] = t[repeats] + (repeats - first[at]) * step
    return out


def samples_sharing_a_stamp(t: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Which of the ``rows`` (indexes into IMU stamps ``t``, s, file order) repeating the row before them exactly are
    samples: the stamps come in packets sharing one stamp and the row is among the first its stamp may hold (the
    packets' count; a logger flushing its buffer again writes more), or from a quantised clock
    (:func:`shared_stamp_packets`, :func:`quantised_clock`) and the row leaves the samples after it on the line
    through the others (:func:`_rows_on_the_line`: a row written twice puts them a period early; counts at rest repeat
    rows at random, a stamp holding one more sample than the grid's periods where jitter moves one). On a clock about
    as coarse as the period whose repeated stamps are :func:`_repeats_unpaired` no sample was pushed across a grid
    edge, and one the stamps show only with the copies (:func:`_clock_at_period` without them) is none: its copies are
    rows written twice (one repeat beside a lost sample's empty grid step shows such a clock). Packets or a clock
    coarser than the period that show a clock about as coarse as the period without the rows are that clock (each row
    of an even log on such a clock written again right after itself makes one twice as fine). Stamps that show no
    packets without the rows leave them samples: the rows asked about are an IMU's whose readings repeat from stamp
    to stamp (:func:`graphnav.core.screening.readings_repeat`), and at rest with 55-93 % of its rows repeating most
    of its packets' rows are such rows. The stamps the rows judged samples leave are those
    :func:`restamp_shared_stamps` reads: where they show no clock or packets there, no row is a sample (one place
    decides)."""
    read = _clock_or_packets(t)
    clock, packets = read
    if (clock or packets) and not _at_period(clock):
        other = _clock_or_packets(np.delete(t, rows))
        if _at_period(other[0]):
            clock, packets = other
    if _at_period(clock):
        grid, d, counts, _ = _stamp_grid(t)
        if _repeats_unpaired(counts, np.round(d / grid)) or _clock_at_period(np.delete(t, rows)) is None:
            return np.zeros(rows.size, bool)
    _, first = np.unique(t, return_index=True)
    place = rows - first[np.searchsorted(t[first], t[rows])]       # among the samples its stamp holds
    if clock:
        by_count = not _at_period(clock) and place < math.floor(clock[0] / clock[1]) + 1
        samples = _rows_on_the_line(t, rows, by_count)
    elif packets:
        samples = place < packets[0]
    else:
        return np.zeros(rows.size, bool)
    if not np.any(samples):
        return samples
    left = read if np.all(samples) else _clock_or_packets(np.delete(t, rows[~samples]))
    return samples if left != (None, None) else np.zeros(rows.size, bool)


def _rows_on_the_line(t: np.ndarray, rows: np.ndarray, untold: np.ndarray) -> np.ndarray:
    """Which of the ``rows`` (indexes into IMU stamps ``t``, s, never decreasing, each repeating the row before it)
    are samples: judged again and again, the most clearly misjudged first (:func:`_apart`), from every row a sample
    and from every row written twice, until a row written twice moves the samples after it a period early against
    the line through the others (:func:`_moved_along_the_line`) and a sample does not; of the two the judgement whose
    samples lie closer to their line (:func:`_line_through`). A row with no sample before the pair it repeats or
    none after it cannot be told: a sample where ``untold`` (bool, each) says so (among the count a clock coarser
    than the period may hold), else a row written twice, as an exact copy was before the line judged rows (on a clock
    as coarse as the period the first sample's offset is mostly its grid's: a copy as the first row was kept in 1 of
    12 logs, as the last in most). The line's period is fitted to the samples judged so: measured with rows written
    twice, or without samples repeating their row (an IMU at rest with coarse counts), it is a few per cent off, and
    over :data:`REPEAT_CHECK_SAMPLES` samples drifts about as far as a copy moves the samples. An IMU faster than its
    clock keeps a row in every step of it without the rows (:func:`_a_row_in_every_step`), samples or copies alike:
    every row a copy then leaves one stamp a step, an exact line (spread 1.6e-8 s^2 against 1.2e-5 for a stuck
    200 Hz IMU's samples in whole 10 ms), taken for any IMU whose readings barely change, which then lost half its
    rows; nothing tells, and the rows are judged from every row a sample alone (a row written twice among them still
    moves the samples after it a period early). A row judged a copy must move them so over more samples
    (:func:`_confirmed`)."""
    s = t - t[0]
    told = (rows >= 2) & (rows < t.size - 1)
    edge = ~np.asarray(untold, bool)
    judged = _judged_from(s, rows, told, np.where(told, False, edge))
    if not _a_row_in_every_step(np.delete(t, rows)):
        copies = _judged_from(s, rows, told, np.where(told, True, edge))
        judged = min(judged, copies, key=lambda copies: _line_through(s, rows[copies])[1])
    return ~_confirmed(s, rows, judged)


def _judged_from(s: np.ndarray, rows: np.ndarray, told: np.ndarray, copies: np.ndarray) -> np.ndarray:
    """Which of the ``rows`` (indexes into relative IMU stamps ``s``, s) are copies, judged again from ``copies``
    (bool, each; changed where ``told``, the rows with samples on both sides) until every row is on the side of the
    line it was judged (:func:`_rows_on_the_line`)."""
    for _ in range(2 * rows.size + 1):
        period = _line_through(s, rows[copies])[0]
        moved = _moved_along_the_line(s, rows, period, copies)
        wrong = np.where(told, np.where(copies, moved + 0.5, -0.5 - moved), -1.0)
        if not wrong.size or wrong.max() <= 0:
            break
        copies[_apart(rows, wrong)] ^= True
    return copies


#: Samples on each side over which a row judged written twice must still put the samples after it a period early
#: (:func:`_confirmed`): their mean offset known twice as well as over :data:`REPEAT_CHECK_SAMPLES`.
CONFIRM_SAMPLES = 4 * REPEAT_CHECK_SAMPLES


def _confirmed(s: np.ndarray, rows: np.ndarray, copies: np.ndarray) -> np.ndarray:
    """``copies`` (bool, each of the ``rows``, indexes into relative IMU stamps ``s``, s) less those which, counted
    as samples, do not put the samples after them half a period early over :data:`CONFIRM_SAMPLES` samples on either
    side, against the line through the samples judged so; a row without as many on both sides stays as judged. Over
    :data:`REPEAT_CHECK_SAMPLES` the mean offset moves by 0.12-0.15 periods (one sigma) where no row was written
    twice (200 Hz in whole 10 ms with jitter): beyond half a period at about one repeat in 10^4, 25 of 352429 rows
    repeating at shared stamps over 1.5 h, each dropped and the grid broken there."""
    r = rows[copies]
    whole = (r - 1 - CONFIRM_SAMPLES >= 0) & (r + 1 + CONFIRM_SAMPLES <= s.size)
    # the move with the copies counted out, each one's own period put back: as the samples they would be
    moved = _moved_along_the_line(s, r, _line_through(s, r)[0], np.ones(r.size, bool), CONFIRM_SAMPLES) + 1.0
    out = copies.copy()
    out[np.flatnonzero(copies)[whole & (moved > 0.5)]] = False
    return out


def _a_row_in_every_step(t: np.ndarray) -> bool:
    """Whether IMU stamps ``t`` (s, never decreasing, on a quantised clock) leave no single step of the clock (their
    median step) empty: a step twice as long is a sample pushed across a grid edge or lost by an IMU about as fast
    as its clock; longer ones are gaps, which a faster IMU shows as well."""
    d = np.diff(t)
    d = d[d > 0]
    return d.size > 0 and not np.any(np.abs(d / np.median(d) - 2.0) < 0.5)


def _apart(rows: np.ndarray, wrong: np.ndarray) -> np.ndarray:
    """The indexes of the ``rows`` (increasing) misjudged (``wrong`` over 0), the most clearly first, each over twice
    :data:`REPEAT_CHECK_SAMPLES` samples from those before it: judging one moves none of the others' samples. Taken
    in rounds, each the rows misjudged most clearly within that reach among those left, then those within it of them
    left out: the work grows with the rows, where comparing each with every one taken grew with their square
    (22 s for 1.08 million stamps)."""
    from scipy.ndimage import maximum_filter1d, minimum_filter1d     # only on this path
    reach = 2 * (2 * REPEAT_CHECK_SAMPLES + 2) + 1
    live = np.argsort(-wrong)[:int(np.sum(wrong > 0))]
    at = rows - (rows[0] if rows.size else 0)
    taken = []
    while live.size:
        rank = np.full(at[-1] + 1, live.size)
        rank[at[live]] = np.arange(live.size)
        first = live[(minimum_filter1d(rank, reach, mode="constant", cval=live.size) == rank)[at[live]]]
        taken.append(first)
        near = np.zeros(rank.size, bool)
        near[at[first]] = True
        live = live[~maximum_filter1d(near, reach, mode="constant")[at[live]]]
    return np.concatenate(taken) if taken else np.zeros(0, int)


def _line_through(s: np.ndarray, copies: np.ndarray) -> tuple[float, float]:
    """``(period s, spread s^2)``: the least-squares line through relative stamps ``s`` (s) without the rows
    ``copies`` (indexes, increasing) against their order, and the variance of their offsets from it about their mean
    over :data:`REPEAT_CHECK_SAMPLES` samples on either side (a row misjudged far off moves a stretch of samples,
    not its neighbours' offsets)."""
    keep = np.delete(np.arange(s.size), copies)
    order = _order_without(s.size, copies)[keep]
    slope = float(np.polyfit(order, s[keep], 1)[0])
    offset = s[keep] - slope * order
    total, n = np.r_[0.0, np.cumsum(offset)], np.arange(offset.size)
    a, b = np.maximum(0, n - REPEAT_CHECK_SAMPLES), np.minimum(offset.size, n + REPEAT_CHECK_SAMPLES + 1)
    return slope, float(np.mean((offset - (total[b] - total[a]) / (b - a)) ** 2))


def _at_period(clock: tuple[float, float] | None) -> bool:
    """Whether a quantised ``clock`` (``(grid s, period s)``, :func:`quantised_clock`) is about as coarse as the IMU's
    period (under 1.5 periods), not coarser."""
    return clock is not None and clock[0] < 1.5 * clock[1]


#: How far (in periods) a sample of a clock coarser than its period may be put outside its stamp's grid step:
#: sampling jitter moves samples across the grid's edges (0.5 ms at 200 Hz in 10 ms: a quarter of the steps hold 3).
QUANTISED_SLACK_PERIODS = 0.5


def restamp_quantised(t: np.ndarray, grid_s: float, period_s: float) -> tuple[np.ndarray | None, float, int]:
    """IMU stamps ``t`` (s, never decreasing) from a clock on a ``grid_s`` grid coarser than the IMU's period put on an
    even grid at the period (s) over each stretch, the period, and the number of stretches (``period_s``: the
    samples over time :func:`quantised_clock` measured, which the stretches refine). A stretch lasts while
    one line at the period keeps every sample within its stamp's grid step (give or take
    :data:`QUANTISED_SLACK_PERIODS`): it ends where samples are lost or the rate drifts, and starts again at a
    stamp; on a clock about as coarse as the period also where :func:`_lost_samples` says a sample was lost (the
    band spans two periods there: a line a period off fitted). Its offset is the least-squares one through the
    mid-points of the grid steps (each sample after its stamp, mid-way on average, as a clock truncating to its grid
    stamps them), held inside that band (:func:`_place_stretches`). The period is samples over time within the
    stretches, refined four times (samples lost make samples over the whole time too slow; 2 % lost at 200 Hz with
    0.5 ms jitter: 5.10 ms, 5.04 ms refined). The stamps are None where a sample would leave its band (the note's
    promise): the caller leaves them as read."""
    t = np.asarray(t, float)
    s = t - t[0]                    # Unix seconds: the offsets are exact, the grid arithmetic then holds
    period = period_s
    lost = _lost_samples(t, grid_s) if grid_s < 1.5 * period_s else np.zeros(0, int)
    for _ in range(4):
        starts = _even_stretches(s, grid_s, period, lost)
        period = _pooled_period(s + 0.5 * grid_s, starts, period)
    starts = _even_stretches(s, grid_s, period, lost)
    placed = _place_stretches(s, grid_s, period, starts)
    slack = QUANTISED_SLACK_PERIODS * period + 1e-9 * grid_s
    if np.any(placed < s - slack) or np.any(placed > s + grid_s + slack):
        return None, period, starts.size
    return t[0] + placed, period, starts.size


def _lost_samples(t: np.ndarray, grid_s: float) -> np.ndarray:
    """Where (indexes, at a stamp's first sample) stamps ``t`` (s, never decreasing) from a clock about as coarse as the
    IMU's period on a ``grid_s`` grid (s) lost samples: after an empty grid step next to another among the clock's
    repeated stamps and empty steps in time order (jitter pairs each empty step with a repeat), or a step of three
    grid steps or more; where they do not alternate (:func:`_alternating`), after the empty steps no repeat pairs
    (:func:`_jitter_pairs`: samples lost outnumbering the repeats), none where the repeats do not pair either (a
    clock slower than its grid leaves steps empty without repeats). A line at the period fits a lost sample's
    stretch a period off: the grid step and the jitter's slack span two periods."""
    stamps, first, counts = np.unique(t, return_index=True, return_counts=True)
    steps = np.round(np.diff(stamps) / grid_s)
    kind, where = _clock_events(counts, steps)
    empty = np.flatnonzero(steps > 1)                   # in time order, as their events in kind
    if _alternating(kind):
        lone = (kind[1:] == -1) & (kind[:-1] == -1)
        at = empty[(np.cumsum(kind == -1) - 1)[np.r_[lone, False] | np.r_[False, lone]]]
    else:
        pairs = _jitter_pairs(kind, where, steps.size)
        if pairs is None:
            return np.zeros(0, int)
        at = empty[~pairs[0][kind < 0]]
    return first[1:][np.union1d(at, np.flatnonzero(steps > 2))]


def _stretch_index(n: int, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(stretch, k)`` of ``n`` samples cut at ``starts``: each sample's stretch and its index within it."""
    stretch = np.cumsum(np.isin(np.arange(n), starts)) - 1
    return stretch, np.arange(n) - starts[stretch]


def _pooled_period(mid: np.ndarray, starts: np.ndarray, period_s: float) -> float:
    """The least-squares period (s) of the grid steps' mid-points ``mid`` (s), one offset a stretch (``starts``);
    ``period_s`` when no stretch spans two stamps."""
    stretch, k = _stretch_index(mid.size, starts)
    n = np.bincount(stretch)
    dk = k - (np.bincount(stretch, k) / n)[stretch]
    dm = mid - (np.bincount(stretch, mid) / n)[stretch]
    return float(np.sum(dk * dm) / np.sum(dk * dk)) if np.any(dm) else period_s


def _band(s: np.ndarray, grid_s: float, period_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Running bounds (s) on the offset of a line at ``period_s`` through relative stamps ``s`` (s) from their first
    that keeps each sample within its grid step, give or take :data:`QUANTISED_SLACK_PERIODS`."""
    slack = QUANTISED_SLACK_PERIODS * period_s
    at = s - np.arange(s.size) * period_s
    return np.maximum.accumulate(at - slack), np.minimum.accumulate(at + grid_s + slack)


def _even_stretches(s: np.ndarray, grid_s: float, period_s: float, lost=()) -> np.ndarray:
    """Where the stretches of relative stamps ``s`` (s, never decreasing) begin (indexes, at a stamp's first
    sample, or within a stamp holding more samples than its grid step fits) over which one line at ``period_s`` (s)
    fits (:func:`_band`), and at each of ``lost`` (indexes where samples were lost)."""
    first = np.searchsorted(s, s, "left")
    ends = np.r_[np.asarray(lost, int), s.size]
    starts, i = [], 0
    while i < s.size:
        starts.append(i)
        end, window = int(ends[ends > i][0]), 1024
        while True:
            lo, hi = _band(s[i:min(i + window, end)], grid_s, period_s)
            bad = np.flatnonzero(hi <= lo)
            if bad.size or i + window >= end:
                break
            window *= 4
        if not bad.size:
            i = end
            continue
        j = i + int(bad[0])
        i = first[j] if first[j] > i else j
    return np.asarray(starts)


def _place_stretches(s: np.ndarray, grid_s: float, period_s: float, starts: np.ndarray) -> np.ndarray:
    """Relative stamps ``s`` (s) on a line at ``period_s`` (s) over each stretch (``starts``): the least-squares
    offset through the grid steps' mid-points, held within :func:`_band`; where a stretch begins before the one
    before it ends, that one's last samples are moved back to a thousandth of a period before the next."""
    out, gap = np.empty_like(s), 1e-3 * period_s
    before = -math.inf
    for a, b in zip(starts, np.r_[starts[1:], s.size]):
        k = np.arange(b - a) * period_s
        lo, hi = _band(s[a:b], grid_s, period_s)
        offset = min(max(float(np.mean(s[a:b] + 0.5 * grid_s - k)), lo[-1]), hi[-1])
        out[a:b] = min(max(offset, before + gap), hi[-1]) + k
        before = out[b - 1]
    return _ordered(out, gap)


def _ordered(x: np.ndarray, gap: float) -> np.ndarray:
    """``x`` with each value held at least ``gap`` before the next, by moving it back."""
    i = np.arange(x.size) * gap
    return np.minimum.accumulate((x - i)[::-1])[::-1] + i


def clock_words(grid_s: float, period_s: float, said: bool = True) -> str:
    """``stamps on a G ms clock, coarser than / about as coarse as the IMU's P ms period`` (``grid_s``, ``period_s``
    s; without P unless ``said``: measured on too few stamps), as the notes on such a clock, offline and live,
    begin."""
    coarse = "coarser than" if grid_s >= 1.1 * period_s else "about as coarse as"
    period = f"{1e3 * period_s:.4g} ms period" if said else "period"
    return f"stamps on a {1e3 * grid_s:.4g} ms clock, {coarse} the IMU's {period}"


def quantised_note(grid_s: float, period_s: float, counts: np.ndarray, which: str, stretches: int = 1) -> str:
    """What putting the stamps of a clock on a ``grid_s`` grid coarser than the IMU's ``period_s`` (s; ``counts``
    the samples each stamp held) on an even grid in ``stretches`` did to ``which`` stamps (a note and a warning)."""
    where = ("one even grid" if stretches == 1 else f"an even grid in {stretches} stretches (a new one where samples "
             "were lost or the rate drifted off the line)")
    empty = "" if grid_s >= 1.1 * period_s else (", a stamp holding one more or one fewer where the rates differ or "
                                                 "jitter moves a sample across the grid's edges")
    return (f"{clock_words(grid_s, period_s)} ({int(counts.min())} "
            f"to {int(counts.max())} samples to a stamp{empty}): {which} put on {where} at the period (samples over "
            f"time), each sample at or after its stamp, within its grid step give or take half a period (a clock "
            f"truncating to its grid, the usual logger; one rounding to it leaves them {1e3 * grid_s / 2:.4g} ms "
            "late)")


#: How near (relative) the samples over an IMU log's span must come to its configured rate, and how much further its
#: stamps' own reading must be, for the configured rate to be the IMU's (:func:`configured_rate_clock`): a clock is off
#: by ppm; a 60 s log's span in whole 10 ms by up to 1.7e-4.
CONFIGURED_RATE_SHARE = 1e-3


def configured_rate_clock(t: np.ndarray, expected_hz: float | None) -> tuple[float, float, float] | None:
    """``(grid s, read Hz, over span Hz)`` of increasing IMU stamps ``t`` (s) on a grid (:func:`_stamp_grid`) that
    read a rate (:func:`imu_rate_hz`) off the configured ``expected_hz`` (Hz) by more than
    :data:`CONFIGURED_RATE_SHARE` where the samples over their span agree with it within that share: 98 Hz in whole
    10 ms without jitter (every 50th step 20 ms) reads 100 Hz, which the stamps alone cannot tell from 100 Hz losing
    every 50th sample; the configuration can. None else."""
    t = np.asarray(t, float)
    if expected_hz is None or t.size < 3 or not t[-1] > t[0] or np.any(np.diff(t) <= 0):
        return None
    over_span = (t.size - 1) / float(t[-1] - t[0])
    if abs(over_span / expected_hz - 1.0) > CONFIGURED_RATE_SHARE:
        return None
    read = imu_rate_hz(t)
    grid, _, _, on_grid = _stamp_grid(t)
    if not on_grid or abs(read / expected_hz - 1.0) <= 2.0 * CONFIGURED_RATE_SHARE:
        return None
    return grid, read, over_span


def _restamp_at_configured_rate(t: np.ndarray, clock: tuple[float, float, float], expected_hz: float
                                ) -> tuple[np.ndarray | None, float, int, str]:
    """``(stamps s or None, period s, moved, note)``: IMU stamps ``t`` (s) that :func:`configured_rate_clock` found
    (``clock``) put on one even grid at about the configured ``expected_hz`` (:func:`restamp_quantised`), ``moved`` of
    them, or None (left as read, 0 moved) where one line does not keep every sample within its grid step (samples
    lost, or another rate: the evidence is not clear), and what the note says."""
    grid, read, over_span = clock
    restamped, period, stretches = restamp_quantised(t, grid, 1.0 / expected_hz)
    said = (f"stamps on a {1e3 * grid:.4g} ms grid read {read:.5g} Hz, but the samples over their span "
            f"({over_span:.5g} Hz) agree with the configured imu_rate_hz {expected_hz:.5g} Hz: an IMU slower than its "
            f"logger's clock, which the stamps alone cannot tell from {read:.5g} Hz losing samples")
    if restamped is None or stretches > 1:
        return None, period, 0, said + (f"; no one even grid at {1e3 / expected_hz:.4g} ms keeps every sample within "
                                        "its grid step (samples lost?): the stamps are left as read")
    moved = int(np.sum(restamped != t))
    return restamped, period, moved, said + (f": {moved} of {t.size} stamps put on one even grid at the period "
                                             f"{1e3 * period:.5g} ms, each within its grid step give or take half a "
                                             "period")


def restamp_shared_stamps(t: np.ndarray, source: str, meta: dict | None, expected_hz: float | None = None
                          ) -> np.ndarray:
    """IMU stamps ``t`` (s, file order) whose packets share one stamp (:func:`shared_stamp_packets`) with each
    packet spread back from its stamp at the period (:func:`restamp_packets`), or from a clock coarser than the
    period (:func:`quantised_clock`) put on an even grid (:func:`restamp_quantised`), or on a grid finer than the
    period with samples moved into the step before by jitter (:func:`grid_repeats`) those placed after it, warned
    about and noted once, their count in ``meta["streams"]["imu"]["restamped"]`` and the period in
    ``"restamp_period_s"``; else, even stamps on a grid that the configured rate ``expected_hz`` (Hz, None: not
    known) and the samples over their span say are an IMU slower than its logger's clock
    (:func:`configured_rate_clock`), put on one even grid at that rate where one fits, warned about either way; else
    ``t`` as given. Left as read, every sample but one of a stamp was a duplicated stamp: the file was refused, and
    its repair dropped k - 1 in k samples."""
    clock, packets = _clock_or_packets(t)
    if clock:
        restamped, period, stretches = restamp_quantised(t, *clock)
        if restamped is None:       # as read: its repeated stamps are refused as duplicates
            warnings.warn(f"imu: {source}: {clock_words(clock[0], period)}: no even grid keeps every sample within "
                          "its grid step give or take half a period; the stamps are left as read", RuntimeWarning,
                          stacklevel=4)
            return t
        moved = int(np.sum(restamped != t))
        note = quantised_note(clock[0], period, np.unique(t, return_counts=True)[1], f"{moved} of {t.size} stamps",
                              stretches)
    elif packets:
        k, cycle, period = packets
        restamped = restamp_packets(t, period, 0.0)
        moved = int(np.sum(restamped != t))
        note = packets_note(k, cycle, period, f"{moved} of {t.size} stamps (each packet's samples shared one stamp)")
    elif jittered := grid_repeats(t):
        grid, period, restamped, moved = jittered
        note = (f"stamps on a {1e3 * grid:.4g} ms grid, finer than the IMU's {1e3 * period:.4g} ms period: {moved} "
                f"of {t.size} repeat the stamp before (jitter moved a sample across the grid's edge: the samples on "
                "either side keep one line at the period), each placed on the grid after that stamp, a period or the "
                f"room before the next stamp later{_off_the_grid(restamped - t[0], grid)}")
    elif configured := configured_rate_clock(t, expected_hz):
        restamped, period, moved, note = _restamp_at_configured_rate(t, configured, expected_hz)
        if restamped is None:
            say_restamp(meta, source, note, 4)
            return t
    else:
        return t
    say_restamp(meta, source, note, 4, restamped, moved, period)
    return restamped


def _off_the_grid(s: np.ndarray, grid_s: float) -> str:
    """What a restamping of jitter's repeats adds about the relative stamps ``s`` (s) it placed off the ``grid_s``
    grid (s): no whole grid step was free (several samples within one, as a host's jitter leaves a 400 Hz IMU in
    whole ms); "" for none."""
    off = int(np.sum(np.abs(s / grid_s - np.round(s / grid_s)) > 0.01))
    return f" ({off} off the grid, sharing the room where no whole grid step was free)" if off else ""


def say_restamp(meta: dict | None, source: str, note: str, stacklevel: int, restamped: np.ndarray | None = None,
                moved: int = 0, period_s: float = math.nan) -> None:
    """An IMU's restamping (``note``, of the file ``source``) warned about (``stacklevel`` as the caller's own) and
    noted in ``meta``; when the ``restamped`` stamps (s) are kept, ``moved`` of them and the ``period_s`` (s) in
    ``meta["streams"]["imu"]`` (``restamped``, ``restamp_period_s``) and its span theirs."""
    warnings.warn(f"imu: {source}: {note}", RuntimeWarning, stacklevel=stacklevel + 1)
    if meta is None:
        return
    entry = add_note(meta, "imu", note)
    if restamped is not None:
        entry.update(restamped=moved, restamp_period_s=period_s)
        set_span(meta, "imu", restamped, shown_rate_hz("imu", restamped))


def stamped_in_packets(t: np.ndarray) -> str:
    """What a file's stamps ``t`` (s, in file order) say when most of them repeat in runs (:func:`stamp_runs`: a
    driver stamping a packet of samples together on receipt, one stamp for 10 samples of a 100 Hz IMU, or 4 samples
    of a 400 Hz IMU logged in whole ms), for a duplicated-stamp message; "" else."""
    runs = stamp_runs(t)
    if runs is None:
        return ""
    k, cycle = runs[:2]
    return (f"; the stamps repeat in runs of {k} about every {1e3 * cycle:.4g} ms: packets of samples stamped "
            f"together on receipt, a sample every {1e3 * cycle / k:.4g} ms; dropping the repeats loses "
            f"{(k - 1) / k:.0%} of the samples: give each sample its own stamp (its packet's stamp less the periods "
            "after it)")


#: A white noise's sigma from the median absolute first difference of its samples (1.4826 MAD / sqrt(2)).
DIFF_MAD_TO_SIGMA = 1.4826 / math.sqrt(2.0)
#: Samples on each side of a step of an IMU's stamps that tell a step of its clock or a gap (every one after it later
#: against a line at the period than every one before) from jitter: 50 Gaussian draws on each side fall wholly apart by
#: chance once in 1e29.
CLOCK_STEP_SAMPLES = 50
#: Widest spread, in periods, of those samples about the line for a step to be judged: a coarse clock's grid, packets
#: or a sample lost among them spread them a period or more, and their mean jump is no longer the step's (1 % lost at
#: random read as gaps of 2 samples with a whole period allowed); 1 ms of jitter at 100 Hz spreads 50 about 5 ms.
CLOCK_STEP_SPREAD_PERIODS = 0.75
#: Share of those samples at either end of a set that jitter's spread leaves out (:func:`_spread_as_jitter`): 1 ms of
#: jitter at 200 Hz spreads 50 samples over about 0.9 of a period, their middle 80 % over about half of one; a sample
#: lost inside a set still spreads its middle a period.
CLOCK_STEP_SPREAD_TAIL = 0.1
#: Jitter sigmas (measured in the sets of samples either side of a step, :func:`_jumps_apart`) within which a set
#: that jumps apart from the other spreads about its line, and the step between them is the sets' jump: two samples
#: lost in the sets tilt their line and jump them apart with no step there.
CLOCK_STEP_CLEAN_SIGMAS = 8.0
#: Jitter sigmas within which the jump between the two samples next to a step (the last before, the first after) is
#: the sets' jump, for the step to be there and not spread over the sets (:func:`_jumps_apart`).
CLOCK_STEP_EDGE_SIGMAS = 3.5
#: Least distance, in periods, between those samples for a step: Unix seconds carry ~1e-7 s of rounding.
CLOCK_STEP_FLOOR_PERIODS = 1e-3
#: Robust spreads of a log's jumps between sets of samples (:func:`_jump_limit`: the jump between the samples before
#: and after each step) by which a jump stands out as a step where the sets are not wholly apart: jitter spreads 50
#: samples of each over 4.5 sigma, so a +5 ms step at 1 ms of jitter (about 12 spreads) was missed in 6 of 10 logs.
#: Clean logs with Gaussian jitter reach 4.4 spreads at most (300 simulated logs of 12000 stamps, 50-200 Hz, 0-2 ms of
#: jitter; in whole ms up to 8.6, under the 1.5 ms the stamps' resolution asks); 7 leaves a step of 2.8 sigma found.
CLOCK_STEP_SPREADS = 7.0
#: Samples on the short side of a gap within :data:`CLOCK_STEP_SAMPLES` of the stamps' ends, at least, for it to be
#: judged (:func:`_gaps_near_the_ends`): ten jittered samples fall three periods apart by chance far less than the
#: 50 a clock step of a fraction of a period asks.
CLOCK_STEP_END_SAMPLES = 10
#: Samples lost, at least, in a gap that is warned about: its step, three periods, is one the run bridges (over
#: ``IMU_GAP_PERIODS``, 2.5); one sample lost is integrated over, as the stamps say.
GAP_WARN_SAMPLES = 2


def stamp_steps(t: np.ndarray, period_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(i, jump s, lost)`` of the steps ``t[i] -> t[i + 1]`` of IMU stamps ``t`` (s, never decreasing) after which
    the next :data:`CLOCK_STEP_SAMPLES` sit later (or earlier) than as many before against a line at their own rate
    (:func:`_step_at`; found against one at ``period_s``, s): each of them than each, or their mean by more than
    :data:`CLOCK_STEP_SPREADS` robust spreads of the log's jumps between such sets (:func:`_jump_limit`: the jitter
    measured in the log), and by more than the stamps' resolution (:func:`_stamp_resolution`: a coarse clock's grid
    steps where its rate is off it): the jump of their mean (s) and the samples lost at the step, when that many
    periods put the two sets back among each other; 0 where they do not: a clock step, which no samples lost explain
    (half a period forward, or any step back). A gap of whole periods may be a clock step of whole periods too: the
    stamps cannot tell."""
    t = np.asarray(t, float)
    n = CLOCK_STEP_SAMPLES
    none = np.zeros(0, int), np.zeros(0), np.zeros(0, int)
    if t.size < 2 * n or not period_s > 0:
        return none
    windows = np.lib.stride_tricks.sliding_window_view(t - t[0] - np.arange(t.size) * period_s, n)
    low, high = windows.min(axis=1), windows.max(axis=1)
    floor = CLOCK_STEP_FLOOR_PERIODS * period_s
    apart = np.flatnonzero((low[n:] - high[:-n] > floor) | (low[:-n] - high[n:] > floor)) + n - 1
    jumps, limit = _jump_limit(windows)
    resolution = _stamp_resolution(t) if apart.size or np.any(np.abs(jumps) > limit) else 0.0
    limit = max(limit, 1.5 * resolution, floor)
    candidates = np.union1d(apart, np.flatnonzero(np.abs(jumps) > limit) + n - 1)
    # one step, its largest jump, within as many samples as a set: a sample's jitter may part the sets a step early
    # or late too, and sets holding a step in them jump part of it, or off it where it tilts their line
    runs = np.cumsum(np.diff(np.r_[-2 * n, candidates]) > n)
    found = [(i, *step, r) for i, r in zip(candidates, runs) if (step := _step_at(t, i, resolution, limit))]
    found += _gaps_near_the_ends(t, period_s, resolution, limit, runs[-1] + 1 if runs.size else 0)
    if not found:
        return none
    i, jump, lost, run = (np.asarray(x) for x in zip(*found))
    order = np.lexsort((-np.abs(jump), run))
    first = order[np.diff(np.r_[0, run[order]]) > 0]
    return i[first], jump[first], lost[first].astype(int)


def _jump_limit(windows: np.ndarray) -> tuple[np.ndarray, float]:
    """``(jumps s, limit s)``: the jump of the mean of each set of :data:`CLOCK_STEP_SAMPLES` offsets of IMU stamps
    from a line (``windows``, s, one set a row) from the mean of the set before it against their least-squares line,
    as :func:`_step_at` measures it, and the least jump that stands out of them as a step: :data:`CLOCK_STEP_SPREADS`
    robust spreads (1.4826 median absolute deviations: jitter, a clock's wander, samples lost; a step moves the jumps
    of 100 sets only); inf with fewer than 100 jumps."""
    n = windows.shape[1]
    k = _centred(n)
    mean, tilt = windows.mean(axis=1), windows @ k
    jumps = mean[n:] - mean[:-n] - n * (tilt[n:] + tilt[:-n]) / (2.0 * float(k @ k))
    if jumps.size < 2 * n:
        return jumps, math.inf
    return jumps, CLOCK_STEP_SPREADS * 1.4826 * float(np.median(np.abs(jumps - np.median(jumps))))


def _gaps_near_the_ends(t: np.ndarray, period_s: float, resolution_s: float, limit_s: float, run: int) -> list:
    """The gaps (:data:`GAP_WARN_SAMPLES` samples lost or more) of IMU stamps ``t`` (s) within
    :data:`CLOCK_STEP_SAMPLES` of either end, where a full set of samples on both sides of a step (:func:`_step_at`)
    is not there: judged as there on the :data:`CLOCK_STEP_END_SAMPLES` or more on the short side (a loss at a bag's
    20th message went unsaid). Only the steps of :data:`GAP_WARN_SAMPLES` and a half periods or more are judged; each
    as ``(i, jump s, lost, run)``, numbered from ``run``."""
    n = CLOCK_STEP_SAMPLES
    ends = np.r_[np.arange(0, min(n - 1, t.size - 1)), np.arange(max(t.size - n, n - 1), t.size - 1)]
    long = ends[np.diff(t)[ends] >= (GAP_WARN_SAMPLES + 1.5) * period_s]
    found = []
    for i in long:
        step = _step_at(t, int(i), resolution_s, limit_s, least=CLOCK_STEP_END_SAMPLES)
        if step and step[1] >= GAP_WARN_SAMPLES:
            found.append((int(i), *step, run + len(found)))
    return found


def _centred(n: int) -> np.ndarray:
    """The indexes of ``n`` samples less their mean: the weights of a least-squares line's slope through them."""
    return np.arange(n) - 0.5 * (n - 1)


def _step_at(t: np.ndarray, i: int, resolution_s: float, limit_s: float, least: int = CLOCK_STEP_SAMPLES
             ) -> tuple[float, int] | None:
    """``(jump s, lost)`` of the step ``t[i] -> t[i + 1]`` of IMU stamps ``t`` (s) when the :data:`CLOCK_STEP_SAMPLES`
    after it and as many before, each set within :data:`CLOCK_STEP_SPREAD_PERIODS` of a line at their rate (or spread
    as jitter, :func:`_spread_as_jitter`), lie wholly apart on it by :data:`CLOCK_STEP_FLOOR_PERIODS` or jump apart
    (:func:`_jumps_apart`), and their means by more than 1.5 ``resolution_s`` (s); ``lost``: the samples lost at the
    step, 0 where that many periods do not put the sets back among each other (sets spread as their jitter: within
    ``limit_s`` too, s, at least 1.5 ``resolution_s``), give or take 1.5 ``resolution_s`` (a grid step where the rate
    is off the grid). None else; ``least``: the samples a set may be cut to near the stamps' ends."""
    n = CLOCK_STEP_SAMPLES
    before, after = t[max(i - n + 1, 0):i + 1], t[i + 1:i + n + 1]
    if min(before.size, after.size) < least:
        return None
    # least squares: the ends alone tilted 1 ms of jitter's sets by a period
    kb, ka = _centred(before.size), _centred(after.size)
    period = float(kb @ (before - np.mean(before)) + ka @ (after - np.mean(after))) / float(kb @ kb + ka @ ka)
    ob = before - t[i] + np.arange(before.size - 1, -1, -1) * period
    oa = after - t[i] - np.arange(1, after.size + 1) * period
    spread = np.ptp(ob) + np.ptp(oa)
    jump = float(np.mean(oa) - np.mean(ob))
    floor = CLOCK_STEP_FLOOR_PERIODS * period
    narrow = max(np.ptp(ob), np.ptp(oa)) < CLOCK_STEP_SPREAD_PERIODS * period
    clean, jumps_apart = _jumps_apart(ob, oa, jump, resolution_s + floor, limit_s)
    apart = oa.min() - ob.max() > floor or ob.min() - oa.max() > floor or jumps_apart
    if (not (narrow or _spread_as_jitter(ob, oa, period, resolution_s, jump)) or abs(jump) <= 1.5 * resolution_s
            or not apart):
        return None
    lost = max(round(jump / period), 0)
    off = abs(jump - lost * period)
    allowed = max(0.5 * spread, 1.5 * resolution_s)    # sets spread as their jitter: within the limit too
    whole = off <= allowed + floor and (not clean or off <= limit_s + floor)
    return jump, lost if lost and whole else 0


def _jumps_apart(ob: np.ndarray, oa: np.ndarray, jump_s: float, allow_s: float, limit_s: float) -> tuple[bool, bool]:
    """``(clean, apart)`` of the offsets (s) from their line of the samples before a step ``ob`` and after it ``oa``
    whose means jump ``jump_s`` (s): each set spread within :data:`CLOCK_STEP_CLEAN_SIGMAS` of their jitter (1.4826
    median absolute deviations of their steps over the square root of 2; a sample lost in a set tilts their line and
    moves its steps once), give or take ``allow_s`` (s: the stamps' resolution); and, so, the jump over ``limit_s``
    (s, :func:`_jump_limit`) and the step itself that jump within :data:`CLOCK_STEP_EDGE_SIGMAS` of the jitter."""
    d = np.r_[np.diff(ob), np.diff(oa)]
    sigma = DIFF_MAD_TO_SIGMA * float(np.median(np.abs(d - np.median(d))))
    clean = max(np.ptp(ob), np.ptp(oa)) <= CLOCK_STEP_CLEAN_SIGMAS * sigma + allow_s
    at_step = abs(oa[0] - ob[-1] - jump_s) <= CLOCK_STEP_EDGE_SIGMAS * math.sqrt(2.0) * sigma + allow_s
    return clean, clean and at_step and abs(jump_s) > limit_s


def _spread_as_jitter(ob: np.ndarray, oa: np.ndarray, period_s: float, resolution_s: float, jump_s: float) -> bool:
    """Whether the offsets (s) from a line at ``period_s`` (s) of the samples before a step ``ob`` and after it ``oa``
    (their means ``jump_s`` apart, s) spread as jitter does, on stamps whose ``resolution_s`` (s) is under half a
    period: each set's middle (without :data:`CLOCK_STEP_SPREAD_TAIL` of it at either end) under
    :data:`CLOCK_STEP_SPREAD_PERIODS`, and no sample that leaves out next to the step over half a period from its set's
    median toward the other set (a sample lost there puts those between it and the step a period toward it, and the
    sets jump a period more than the step; jitter of a fifth of a period puts one of ten 2.5 sigma off its set either
    way in 1 of 8 logs). A coarser grid's step added to a lost sample's period reads as two lost."""
    near = round(CLOCK_STEP_SPREAD_TAIL * ob.size)
    middle = max(float(np.subtract(*np.quantile(o, [1.0 - CLOCK_STEP_SPREAD_TAIL, CLOCK_STEP_SPREAD_TAIL])))
                 for o in (ob, oa))
    toward = np.sign(jump_s) * np.r_[ob[-near:] - np.median(ob), np.median(oa) - oa[:near]]
    return bool(resolution_s < 0.5 * period_s and middle < CLOCK_STEP_SPREAD_PERIODS * period_s
                and np.all(toward <= 0.5 * period_s))


def _stamp_resolution(t: np.ndarray) -> float:
    """The coarsest of an IMU's clock grid (:func:`_stamp_grid`) and the powers of ten from 1 s to 1 us that every
    stamp ``t`` (s) lies on from the first (a log written in whole ms), s; 0 for none (Unix seconds as floats)."""
    s = t - t[0]
    for g in sorted({_stamp_grid(t)[0], *(10.0 ** -np.arange(7))}, reverse=True):
        if g > 0 and _on_grid(s, g, share=None):
            return float(g)
    return 0.0
