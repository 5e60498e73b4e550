"""Clock offsets between streams, from the data themselves: a DVL or a GT stamped seconds or days away from the IMU.

The DVL measures the head's velocity in the body frame; what it changes by is what the IMU integrates:
``v_b(t) = v0 + int (f_b + g_b - omega x v_b) dt`` (specific force plus the gravity the body sees). The
gravity ``g_b`` is unknown without an attitude reference, but over a short window the gyro carries it
exactly: ``g_b(t) = R(t)^T g0`` with R the gyro-integrated attitude. So, per window of :data:`WINDOW_S`
of DVL pings (cut at steps between pings over :data:`~graphnav.core.dvl_kinematics.MAX_CLOCK_GAP_S`: a velocity held
through an outage is none the vehicle had; where that finds no confident offset, :func:`align_stream_clocks` also
searches windows cut only at steps over :data:`~graphnav.core.dvl_kinematics.MAX_WINDOW_GAP_S`), ``v0`` and ``g0``
are fitted by linear least squares and the residual measures how well the IMU explains the DVL at a candidate
offset (against a straight line per window, the fit without the IMU: the *explained fraction*). Earth rate, gyro
drift and accelerometer bias only enter through g0, refitted per window (the model:
:mod:`graphnav.core.dvl_kinematics`, which the DVL checks share).

:func:`estimate_dvl_clock_offset` scores every offset at which the two logs share at least
:data:`MIN_OVERLAP_S` and half the shorter log (the whole possible range: the spans need not overlap, the DVL
may be days away; the range is the sum of the two spans, whatever the offset; a 1 h log takes ~30 s), on
a grid of half a DVL period (coarser for long logs), then refines the best by minimising the residual.
Quality: the explained fraction at the peak and its sharpness (residual at the best offset further than
:data:`PEAK_EXCLUSION_S` over the residual at the peak), or, for a peak explaining little (a noisy DVL on a vehicle
accelerating gently, whose share a longer log does not raise), how consistently its windows prefer it to that next
best offset (:data:`MIN_LEAD_SIGMAS`, :func:`_lead_over`), which grows with the log. A log without
velocity changes (constant speed and heading) has no signal: the estimate is then not confident, and
:func:`align_stream_clocks` says so. A DVL on the IMU span whose peak is not clear (a noisy DVL) is also scored at its
stamps as read: a best offset far from them that explains clearly more than they do and than any other offset is
taken (:data:`STAMPS_DEFICIT`, :data:`OFF_STAMPS_MIN_GAP`). This coarse offset is a *clock* offset; the sub-second
DVL time offset against a reference (:func:`graphnav.calibration.reference.estimate_dvl_time_offset` in the A-KIT
loader, ``graphnav calibrate`` without GT) is the fine calibration that runs after it.

A GT on a clock of its own (:func:`estimate_gt_clock_offset`, :func:`align_gt_clock`) is found from the angles the
vehicle turned through: the GT attitude's over each GT interval against the norm of the gyro's integral, which no
axis convention changes (the convention is checked against the GT, once it is on the IMU clock).
"""
from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.stats import norm, wilcoxon

from graphnav.calibration.reference import GT_MIN_CLEAR_INTERVALS, _sigma_from_curvature
from graphnav.core.dvl_kinematics import (COARSE_MAX_WINDOWS, MAX_CLOCK_GAP_S, MAX_WINDOW_GAP_S, MIN_OVERLAP_S,
                                          ImuIntegrals, across_outages_model, gaps_said, imu_gaps, imu_gaps_said,
                                          imu_integrals, offset_grid, outage_cut_model, refine_reach, refined_offset,
                                          search_overlap, still_velocity_said, with_enough_pings)
from graphnav.core.errors import DataError
from graphnav.core.streams import (OFFSET_KEYS, add_note, count_doubted, offset_on_written_stamps, say_doubted,
                                   set_span)
from graphnav.core.timeseries import cumulative_integral, interp_rows, on_the_imu_clock, overlap_text

#: When the DVL already overlaps the IMU, :func:`align_stream_clocks` searches offsets within +- this first, s
#: (a clock set by hand or drifting), and the whole range only where that finds nothing clear or the IMU explains the
#: DVL poorly at its stamps (:func:`_beyond_the_near_search`).
NEAR_SEARCH_S = 300.0
#: Lags closer than this to the peak do not count as a competing peak, s.
PEAK_EXCLUSION_S = 5.0
#: Lowest explained fraction accepted at the peak, and the lowest ratio of the residual at the best
#: offset further than PEAK_EXCLUSION_S to the residual at the peak. Measured (37 s injected): A-KIT
#: trajectories 1, 5, 13 peak 0.75-0.99, ratio 2-50 (right offset); simulated missions with 0.01 m/s beam
#: noise peak 0.43-0.63, ratio 1.26-2.0 (right); with the paper's 0.042 m/s beam noise on the simulator's
#: gentle manoeuvres, peak 0.08-0.11, ratio 1.01-1.04 (wrong offsets: refused); 0.02 m/s: 0.18-0.32,
#: ratio 1.01-1.2 (refused).
MIN_PEAK = 0.2
MIN_SSE_RATIO = 1.2
#: A DVL on the IMU span whose best offset lies further than PEAK_EXCLUSION_S from its stamps, where the IMU explains
#: at least this much more of its velocity changes than at the stamps as read (:func:`explained_as_stamped`), is off its
#: stamps, whether or not the peak is clear (:attr:`ClockOffset.off_its_stamps`). Measured on simulated missions with
#: 0.02, 0.03 and 0.042 m/s beam noise at their right stamps (309 logs of 60-1800 s): the best offset lay further than
#: 5 s in 21, beating the stamps by 0.057 at most (200 s, seed 36: a manoeuvre repeated 83 s on), 0.031 in the others;
#: 30-120 s late (99 logs of 200-1800 s, 72 not clear), the stamps explain -0.78 to 0.03, the right offset 0.074 to
#: 0.68 more.
STAMPS_DEFICIT = 0.1
#: ... and where it explains at least this much there: the late logs' right offsets explained 0.051-0.32; a bag's DVL
#: mounted turned 45 deg with no mounting declared, on its right stamps, -2.41 at its best offset (145 s off) and -3.31
#: at its stamps: the IMU explains it nowhere, so no offset is named.
OFF_STAMPS_MIN_PEAK = 0.05
#: Such an offset is taken (:attr:`ClockOffset.confident`) where it also explains this much more than the best offset
#: further than PEAK_EXCLUSION_S from it, though its peak is under MIN_PEAK or MIN_SSE_RATIO. Of the 72 late logs
#: above, the 4 whose best offset was wrong beat the next by 0.003-0.009, the 68 right ones by 0.005-0.165: 51 taken,
#: 13 named (beating the stamps by STAMPS_DEFICIT, not the others by this); the clean log above beat the next by 0.043.
OFF_STAMPS_MIN_GAP = 0.05
#: Such an offset not taken is named in the clock warning, with the key to give it, only where it beats the next best
#: by this much: of the 16 named in those late logs, the 3 at a wrong offset beat the next by 0.003-0.009 (a 200 s log,
#: 0.03 m/s, 45 s late: +54.36 s named for -45 s, by 0.01), 2 right ones by 0.005, the other 11 right ones 0.02-0.046.
NAMED_OFFSET_MIN_GAP = 0.015
#: The stamps of a DVL on the IMU span whose peak is not clear are scored at their best within this (s): a DVL that
#: lags its stamps by its fine time offset (the A-KIT DVL 0.5-1.5 s) explains less at them than a second off.
FINE_OFFSET_S = 2.0
#: Why the pings of a DVL are counted whose clock offset was taken off its stamps under the clear peak
#: (:attr:`ClockOffset.off_its_stamps`).
CLOCK_TAKEN_UNCLEAR = "DVL clock offset taken under the clear peak: its stamps as read explain it far less"
#: Why the pings of a DVL on the IMU span are counted whose clock could not be searched for the IMU's gaps (the windows
#: they cut keep too few pings): its stamps are kept unchecked, a DVL 30 s late as well as one on time.
CLOCK_UNCHECKED_IMU_GAPS = "DVL clock not checked: the IMU's gaps leave no window to score"
#: How the clock search's error begins where the IMU's gaps, not the DVL's pings, left no two windows to score
#: (:func:`_imu_gaps_starve`): the one error :func:`align_stream_clocks` counts as :data:`CLOCK_UNCHECKED_IMU_GAPS`.
IMU_GAPS_STARVE = "the DVL's clock cannot be found against this IMU"
#: Such an offset further than this from the stamps (s) is taken only where it also explains
#: OFF_STAMPS_MIN_GAP more than the best offset within this of them, the two scored on the pings both keep on the IMU
#: span (:func:`_nearer_the_stamps`; else the nearer is judged in its place): a DVL a few seconds off its clock is far
#: likelier than one a minute or more off, and the explained fraction of a far offset, over fewer pings, is not that of
#: a near one. Measured on 200 s simulated logs, seeds 30-40, 0.03-0.04 m/s beams: seed 36 (a manoeuvre repeated 83 s
#: on) 0-10 s late had its best offset 83 s off, 0.048-0.051 ahead of the right one as scored, 0.003 on the shared
#: pings; the 112 logs 30-90 s late whose best offset was right beat the best within 15 s by 0.008-0.19 on the shared
#: pings (none of the 44 under 0.05 was taken before: each beat its next best by less than 0.05).
NEAR_REACH_S = 15.0
#: An applied DVL clock offset with a larger sigma (s) says the data barely fix it: a tenth of a 1 s ping period.
#: Simulated 60-200 s missions (37 s injected, seeds 0-3): 0.06-0.32 s off with sigmas 0.17-0.48 s (the five
#: confident 0.13-0.26 s off, within 1 sigma); a 400 s one with 0.01 m/s beam noise 0.002 s off, sigma 0.056 s;
#: the 200 s column-map copy of Trajectory1, sigma 0.006 s (read off the cost at 0.01 s then: :func:`_offset_sigma`).
CLOCK_SIGMA_WARN_S = 0.1
#: An offset the windows across steps between pings up to MAX_WINDOW_GAP_S find under the clear peak (off its stamps:
#: a few windows' noise can leave one offset 0.05 ahead of every other) is taken by :func:`_across_short_gaps` only from
#: at least this many windows' worth of pings. 60 s A-KIT pieces without GT (Trajectory13 from 240 s, a 12-ping outage,
#: 0.02 and 0.035 m/s noise added, 2 s late) had two such windows, explained 0.11-0.14 and were loaded 16-17 s late
#: (+16.5 and +15.3 s taken); the simulated logs those windows are for (200-800 s, 30-50 % of pings lost) hold 100-560
#: pings, 5-28 windows.
ACROSS_MIN_WINDOWS = 3
#: How far (s) an offset fitted on such a narrowed reach was found from its gapless copy's, beyond its sigma: the ten
#: A-KIT column maps with 0.4 s of IMU rows missing every 7 s, 0.004-0.10 s (Trajectory1 -0.103 s, 5 sigmas;
#: Trajectory13 +0.087 s, 3 sigmas), sigmas 0.01-0.03 s: said with the offset taken (:func:`align_stream_clocks`).
GAPPY_FIT_OFF_S = 0.1
#: The clock fit's sigma reads its cost's curvature and the windows' slopes over this many steps of the IMU grid
#: (:data:`~graphnav.core.dvl_kinematics.IMU_GRID_S`) each way of the best offset: over the kinks the grid puts in the
#: cost (:func:`_offset_sigma`).
SIGMA_GRID_STEPS = 4
#: ... and the windows' spread is taken in from this many windows: two or three windows' slopes say little of it (a
#: 60 s A-KIT piece with a 13 s outage, Trajectory1 from 240 s, 0.29 s off: sigma 0.83 s with its three windows'
#: spread, which kept the fit from correcting the DVL's 2 s lag; 0.30 s without, 0.15 s read at 0.01 s).
SPREAD_MIN_WINDOWS = 4
#: ... and at most this many times the curvature's sigma: on noisy, lossy simulated logs (320 fits, 0.03-0.045 m/s
#: beams) the spread was 0.9-1.0x it at the median, 1.9x at most; on clean ones whose windows misfit alike (600 s,
#: 0.001 m/s beams, seed 107: 0.035 s off) 5x, which hid a given offset 0.3 s off (3 sigmas 0.35 s) and warned that
#: the data barely fix an offset they fix to 0.04 s.
SPREAD_MAX_RATIO = 2.0
#: A peak that explains little (under MIN_PEAK, or under MIN_SSE_RATIO sharp) is clear where it explains
#: OFF_STAMPS_MIN_PEAK and its windows prefer it to the next best offset by this many sigmas (the signed-rank test of
#: their SSE differences, :func:`_lead_over`): the explained fraction is the share of the velocity's changes the
#: vehicle's accelerations make, which a longer log does not raise (simulated missions with the paper's 0.042 m/s
#: beams: 0.08-0.15 at the right offset at 600-4500 s), while the evidence that one offset fits better grows with its
#: windows. Measured a day off (navigation grade, seeds 3-10), at the right offset: 600 s 2.2-5.8 (one of 8 over 5),
#: 1200 s 3.2-6.5 (4 of 8), 2400 s 5.3 and 7.6 (seeds 3, 4); the 4500 s logs of seeds 3, 5 and 7 load. Another
#: mission's DVL against the IMU (600-1200 s, 14 logs) -0.7..2.5, its peak under 0.01; 0.08 and 0.15 m/s beams
#: (300-1200 s, 28 logs, the best offset 125-180 s off in 9) -0.9..4.0, every peak under 0.05.
MIN_LEAD_SIGMAS = 5.0
#: ... and where the next best offset explains at most this share of what the peak does: a manoeuvre repeated explains
#: about as much one period off, and the ranks then tell which of two near-equal fits is aligned a fraction of a second
#: better, not which offset is right. A 1800 s log made of one 300 s simulated mission repeated six times (0.015 m/s
#: beams, seed 4) was placed 900 s off, a repeat explaining 0.87 against 0.85 at the next, with a lead of 5.4 sigmas;
#: other repeats led each other by -6.7..8.8. The right offsets of the logs the lead was measured on: at most 0.47.
LEAD_MAX_SECOND_SHARE = 0.7


def clear_peak(peak: float, sharpness: float, repeated: bool, lead_sigmas: float = float("nan"),
               second_peak: float = float("nan")) -> bool:
    """A clock search's peak (the share of the velocity's changes explained there) stands out of the residuals at every
    other offset (:data:`MIN_PEAK`, :data:`MIN_SSE_RATIO` for ``sharpness``), or explains :data:`OFF_STAMPS_MIN_PEAK`
    and leads the next best offset by :data:`MIN_LEAD_SIGMAS` of its windows' spread (``lead_sigmas``, NaN where not
    measured), that offset explaining at most :data:`LEAD_MAX_SECOND_SHARE` of it (``second_peak``, NaN: not known),
    and no offset further off explained about as much (``repeated``): :attr:`ClockOffset.clear`, also of an estimate
    kept as a dict (:meth:`ClockOffset.to_dict`)."""
    stands_out = peak >= MIN_PEAK and sharpness >= MIN_SSE_RATIO
    leads = (peak >= OFF_STAMPS_MIN_PEAK and lead_sigmas >= MIN_LEAD_SIGMAS
             and second_peak <= LEAD_MAX_SECOND_SHARE * peak)
    return (stands_out or leads) and not repeated


@dataclass
class ClockOffset:
    """A clock offset found from the data.

    Attributes:
        offset_s: seconds to add to the DVL stamps to put them on the IMU clock.
        sigma_s: 1-sigma of the fine estimate (its least-squares cost's curvature, or the spread of its windows'
            pulls where larger: :func:`_offset_sigma`), s.
        peak: fraction of the DVL's velocity changes the IMU explains at the offset (1 - SSE / SSE of a
            straight line per window; 1 = all).
        second_peak: the same at the best offset further than :data:`PEAK_EXCLUSION_S` from the peak.
        coarse_offset_s: the coarse (one-grid-step) offset.
        rms: residual of the fine fit, m/s per axis per DVL interval (rad per GT interval for the GT).
        overlap_s: overlap of the two logs at the offset, s.
        n: DVL (GT) intervals used by the fine fit.
        explains: what the IMU explains, for :meth:`describe`.
        stamped: the same at the stamps as read, at its best within :data:`FINE_OFFSET_S` of them
            (:func:`explained_as_stamped`), for a DVL on the IMU span whose peak is not clear; NaN where not measured.
        repeated_at_s: an offset further than :data:`NEAR_REACH_S` from the stamps that explained more but not clearly
            more on the pings both keep (:func:`_nearer_the_stamps`: a manoeuvre repeated), this one, the best within
            that reach, judged in its place; NaN where none.
        lead_sigmas: how clearly the peak leads the next best offset (further than :data:`PEAK_EXCLUSION_S`) over
            the windows both keep, in sigmas (the signed-rank test of their SSE differences, :func:`_lead_over`); NaN
            where not measured (a GT's clock, or under :data:`SPREAD_MIN_WINDOWS` such windows).
        between_imu_gaps: fitted on the reach `dvl_kinematics.refine_reach` narrows where the IMU's gaps sweep
            over most pings (windows cut into parts, each with its own ``v0`` and ``g0``): the sigma leaves out what
            the parts take (:data:`GAPPY_FIT_OFF_S`).
    """

    offset_s: float
    sigma_s: float
    peak: float
    second_peak: float
    coarse_offset_s: float
    rms: float
    overlap_s: float
    n: int
    explains: str = "the DVL's velocity changes"
    stamped: float = float("nan")
    repeated_at_s: float = float("nan")
    lead_sigmas: float = float("nan")
    between_imu_gaps: bool = False

    @property
    def sharpness(self) -> float:
        """Residual at the best offset away from the peak over the residual at the peak (>= MIN_SSE_RATIO)."""
        return (1.0 - self.second_peak) / max(1.0 - self.peak, 1e-9)

    @property
    def clear(self) -> bool:
        """The peak stands out of the residuals at every other offset (:data:`MIN_PEAK`, :data:`MIN_SSE_RATIO`) or its
        windows lead the next best offset (:data:`MIN_LEAD_SIGMAS`, :data:`LEAD_MAX_SECOND_SHARE`); an offset another
        further off explains about as well (``repeated_at_s``) is not clear (:func:`clear_peak`)."""
        return clear_peak(self.peak, self.sharpness, self.repeated, self.lead_sigmas, self.second_peak)

    @property
    def repeated(self) -> bool:
        """Judged in place of an offset further off that explained about as much (:func:`_nearer_the_stamps`)."""
        return bool(np.isfinite(self.repeated_at_s))

    @property
    def off_its_stamps(self) -> bool:
        """The offset lies further than :data:`PEAK_EXCLUSION_S` from the stamps and explains :data:`STAMPS_DEFICIT`
        more than they do as read, and :data:`OFF_STAMPS_MIN_PEAK` at least (False where ``stamped`` was not
        measured)."""
        return (abs(self.offset_s) > PEAK_EXCLUSION_S and self.peak >= OFF_STAMPS_MIN_PEAK
                and self.peak - self.stamped >= STAMPS_DEFICIT)

    @property
    def confident(self) -> bool:
        """A clear peak, or one off the stamps that also beats every other offset by :data:`OFF_STAMPS_MIN_GAP`."""
        return self.clear or self.off_its_stamps and self.peak - self.second_peak >= OFF_STAMPS_MIN_GAP

    def describe(self) -> str:
        stamped = f", {self.stamped:.2f} at the stamps as read" if np.isfinite(self.stamped) else ""
        if not clear_peak(self.peak, self.sharpness, False) and clear_peak(self.peak, 0.0, False, self.lead_sigmas,
                                                                           self.second_peak):
            stamped += f", which it leads by {self.lead_sigmas:.1f} sigmas over the windows (signed ranks)"
        return (f"{self.offset_s:+.3f} s (sigma {self.sigma_s:.3f} s; IMU explains {self.peak:.2f} of "
                f"{self.explains} there, {self.second_peak:.2f} at the next best offset{stamped}; overlap "
                f"{self.overlap_s:.0f} s)")

    def on_written_stamps(self, meta: dict, stream: str) -> ClockOffset:
        """This estimate with its offsets (s) on the stamps of ``stream`` as written, which a user reads and gives back
        as its time offset, where they differ from those searched (an A-KIT file on a clock of its own:
        :func:`graphnav.core.streams.offset_on_written_stamps`)."""
        return dataclasses.replace(self, **{k: offset_on_written_stamps(meta, stream, getattr(self, k))
                                            for k in OFFSET_KEYS})

    def to_dict(self) -> dict:
        out = dataclasses.asdict(self)
        del out["explains"]
        measured = np.isfinite(self.stamped)      # only for a DVL on the IMU span whose peak is not clear
        if not measured:
            del out["stamped"]
        if not self.repeated:
            del out["repeated_at_s"]
        if not np.isfinite(self.lead_sigmas):
            del out["lead_sigmas"]
        if not self.between_imu_gaps:
            del out["between_imu_gaps"]
        out.update(sharpness=self.sharpness, confident=self.confident)
        if measured:
            out["off_its_stamps"] = self.off_its_stamps
        return out


# ------------------------------------------------------------------------------------------------
# the estimate
# ------------------------------------------------------------------------------------------------
def clock_model(imu, dvl, config=None, lever_arm_b=None, window_pings: int | None = None, ints=None):
    """The window model the clock search scores offsets on: the one the DVL speed check fits its scale on, its
    windows cut at outages (:func:`~graphnav.core.dvl_kinematics.outage_cut_model`), here trimmed at the IMU's ends;
    arguments as :func:`estimate_dvl_clock_offset`'s; ``ints``: the IMU's integrals when built already,
    :class:`ImuSide`. Built once per search: the near and far searches, the stamps' score and the nearer offset's all
    score this one (``model``).

    Raises:
        DataError: fewer than two windows of pings with a velocity.
    """
    return outage_cut_model(imu, dvl, config, lever_arm_b=lever_arm_b, window_pings=window_pings, ints=ints,
                            trim=True)


class ImuSide:
    """The IMU's side of the clock models one prepare step builds (:class:`~graphnav.core.dvl_kinematics.ImuIntegrals`:
    its integrals on their grid), built once per IMU stream and shared by every model of a DVL velocity against it: the
    clock search's, its trials' with the velocity in other units, its y negated, in FLU axes or turned (only the DVL's
    side differs between them), the stamps' score. An IMU converted (a gyro's other scale) has its own."""

    def __init__(self):
        self._built = {}

    def __call__(self, imu) -> ImuIntegrals:
        """The integrals of ``imu`` (:class:`~graphnav.core.mission.ImuData`), built on the first call for it."""
        kept = self._built.get(id(imu))
        if kept is None or kept[0] is not imu:     # the stream is kept, so its id is not another's
            kept = self._built[id(imu)] = (imu, imu_integrals(imu.t, imu.f_b, imu.omega_b))
        return kept[1]


def estimate_dvl_clock_offset(imu, dvl, config=None, *, min_overlap_s: float = MIN_OVERLAP_S,
                              lever_arm_b=None, window_pings: int | None = None,
                              search_s: tuple[float, float] | None = None, model=None) -> ClockOffset:
    """The offset to add to the DVL stamps to put them on the IMU clock, from the data (module docstring).

    Args:
        imu: :class:`~graphnav.core.mission.ImuData` (SI units, body FRD).
        dvl: :class:`~graphnav.core.mission.DvlData` on its own clock (seconds, any origin: days apart is fine).
        config: a SensorConfig (C_d_b, beam geometry, lever arm) or None.
        min_overlap_s: shortest overlap a candidate offset must leave between the two logs, s (at least
            :data:`~graphnav.core.dvl_kinematics.MIN_OVERLAP_FRACTION` of the shorter log in any case).
        lever_arm_b: DVL position relative to the IMU, m (default: the config's, else zero).
        window_pings: pings per window of the gravity fit (default :data:`WINDOW_S` worth).
        search_s: (lo, hi) offsets to search, s; default: every offset leaving ``min_overlap_s`` of overlap.
        model: the :func:`clock_model` of these ``imu``, ``dvl`` and ``config`` when built already (its lever arm and
            window are then the ones used).

    Returns:
        A :class:`ClockOffset`; check ``confident`` (:func:`align_stream_clocks` refuses or warns on it).

    Raises:
        DataError: fewer than two windows of usable pings (at every offset: pings broken up by outages over
            :data:`~graphnav.core.dvl_kinematics.MAX_CLOCK_GAP_S`, or over
            :data:`~graphnav.core.dvl_kinematics.MAX_WINDOW_GAP_S` where the shorter cut leaves under two windows
            (:func:`clock_model`), the message names them), or logs too short to overlap ``min_overlap_s``.
    """
    model = clock_model(imu, dvl, config, lever_arm_b, window_pings) if model is None else model
    ints, window, t_dvl = model.imu, model.window, model.t_pings
    period = float(np.median(np.diff(t_dvl)))
    span_imu, span_dvl = ints.t[-1] - ints.t[0], t_dvl[-1] - t_dvl[0]
    min_overlap_s = search_overlap(span_imu, span_dvl, window * period, min_overlap_s)
    h, coarse, best, second, rival = _coarse_offset(model.thinned(COARSE_MAX_WINDOWS), ints.t, t_dvl, min_overlap_s,
                                             period, "DVL", dvl.source, search_s)
    if not np.isfinite(best):
        if _imu_gaps_starve(model, t_dvl, min_overlap_s, period, dvl.source, search_s):
            raise DataError(f"{IMU_GAPS_STARVE}: {imu_gaps_said(ints.gaps, window)}; "
                            f"{gaps_said(t_dvl, window, model.max_gap_s)}, and no offset keeping {min_overlap_s:.0f} "
                            "s of overlap puts two windows' parts on the IMU span: give the DVL clock's offset by "
                            "hand (dvl_time_offset_s, s added to the DVL stamps) if it is known", dvl.source,
                            field="t")
        broken = np.any(np.diff(t_dvl) > model.max_gap_s)
        raise DataError(f"the DVL's pings are too {'broken up' if broken else 'few'} to find its clock: "
                        f"{gaps_said(t_dvl, window, model.max_gap_s)}, and no offset keeping {min_overlap_s:.0f} s "
                        "of overlap puts two of those windows on the IMU span: give the DVL clock's offset by hand "
                        "(dvl_time_offset_s, s added to the DVL stamps) if it is known", dvl.source, field="t")

    x, use = refined_offset(model, coarse, h)
    explained, sse, _ = model.score(x, use)
    pings = int(use.sum())
    rms = float(np.sqrt(sse / max(3 * pings, 1)))
    overlap = float(min(ints.t[-1], t_dvl[-1] + x) - max(ints.t[0], t_dvl[0] + x))
    between = bool(len(ints.gaps)) and 0.0 < refine_reach(model, coarse, h)[0] < 2 * h
    return ClockOffset(x, _offset_sigma(model, x, use), max(explained, best), max(second, 0.0), coarse, rms, overlap,
                       pings, lead_sigmas=_lead_over(model, x, rival, h), between_imu_gaps=between)


def _imu_gaps_starve(model, t_dvl: np.ndarray, min_overlap_s: float, period: float, source: str,
                     search_s: tuple[float, float] | None) -> bool:
    """True where the IMU's gaps (``model.imu.gaps``) are why no offset of the coarse grid keeps two windows of
    ``model``'s pings: without them one would. A DVL of too few pings, or one broken up by its own outages, beside an
    IMU with a gap elsewhere (one at 190 s of a 200 s log) is the DVL's to blame, not the IMU's."""
    ints = model.imu
    if not len(ints.gaps):
        return False
    gapless = model.thinned(COARSE_MAX_WINDOWS)
    gapless.imu = dataclasses.replace(ints, gaps=np.empty((0, 2)))
    grid = offset_grid(ints.t, t_dvl, min_overlap_s, period, "DVL", source, search_s)[1]
    return any(gapless.pings(o).any(axis=1).sum() >= 2 for o in grid)


def _lead_over(model, x: float, rival: float, h: float) -> float:
    """How clearly the IMU explains the DVL better at the offset ``x`` (s) than at ``rival`` (s; the coarse scan's best
    further than :data:`PEAK_EXCLUSION_S` from it, taken at its own best within its grid step ``h``, s, or the narrower
    reach `dvl_kinematics.refine_reach` takes beside the IMU's gaps: its +-0.5 s left the lead unmeasured (NaN) on
    A-KIT logs losing 0.4 s of IMU rows every 7 s, Trajectory3 3.30 sigmas as its gapless copy now): the one-sided
    Wilcoxon signed-rank test of the windows' SSE at ``rival`` less that at ``x`` (the windows both keep, on the pings
    both keep; the windows as the independent samples), as the standard normal deviate of its p-value. Ranks, not the
    mean over the spread: a window or two in a turn, where the vehicle's accelerations tell most, differ tens of times
    more than the rest and swell the spread (a 2400 s simulated log with 0.042 m/s beams, 61 windows: 2.7 sigmas by
    the mean, 5.4 by the ranks). NaN without :data:`SPREAD_MIN_WINDOWS` such windows (or without a rival)."""
    if not np.isfinite(rival):
        return float("nan")
    reach, near_rival = refine_reach(model, rival, h / 2)        # its grid step each way, narrowed as the peak's
    if reach == 0.0:
        return float("nan")
    both = with_enough_pings(model.pings(x) & near_rival)
    # the rival at its own best near its grid offset, as the peak is at its refined one
    rival = float(minimize_scalar(lambda o: model.score(o, both)[1], bounds=(rival - reach, rival + reach),
                                  method="bounded", options={"xatol": 1e-3}).x)
    at, fitted = model.sse(x, both)
    there, _ = model.sse(rival, both)
    d = (there - at)[fitted]
    if len(d) < SPREAD_MIN_WINDOWS or not np.any(d):
        return float("nan")
    return float(norm.isf(wilcoxon(d, alternative="greater").pvalue))


def _offset_sigma(model, x: float, use: np.ndarray) -> float:
    """1-sigma (s) of the clock fit's offset ``x`` (s) over the pings ``use`` (win, window) of ``model``: the larger
    of the least-squares error of its cost's curvature and the spread of the windows' own pulls on it (the clustered
    sandwich ``sqrt(sum of g_w^2) / curvature``, g_w the slope of window w's SSE at ``x``), the curvature and slopes
    read over :data:`SIGMA_GRID_STEPS` steps of the IMU grid each way (the spread from :data:`SPREAD_MIN_WINDOWS`
    windows, and to :data:`SPREAD_MAX_RATIO` times the curvature's at most).

    Why not the curvature at ``x`` alone: the IMU's integrals are interpolated linearly on their grid, so the cost has a
    kink wherever the ping stamps cross a grid node (all at once for pings on the IMU's stamps), and the best offset
    often lies on one; there a step of 0.01 s read 4-5x the curvature over four grid steps (sigmas 0.12-0.13 s for
    fits 0.55-0.70 s off). And the residuals within a window are not independent (the velocity enters ``int omega x v``
    summed, the IMU's noise its integrals), which the windows' spread takes in where it is the larger. Measured on fits
    near the truth of simulated 300 and 600 s logs with 0.03 and 0.045 m/s beams, 30 or 50 % of their pings lost in
    runs of 3 or at random, seeds 0-9, windows cut at 5 and at 20 s (320 fits): the error over the sigma had an RMS of
    1.5-2.1 per group (6-14 % beyond 3 sigmas) read at 0.01 s, 0.8-1.25 (none beyond 3) read so; 60 s A-KIT pieces
    (two or three windows) with and without an outage against the GT-based offset (720 fits) 2.7-2.9 and 2.0-2.2:
    there the fit's own departure from the GT's offset (0.05-0.1 s on some trajectories) is no noise a sigma
    measures."""
    h = SIGMA_GRID_STEPS * float(model.imu.t[1] - model.imu.t[0])
    if len(model.imu.gaps):     # a ping an IMU gap sweeps over within the steps read makes a step in the cost there
        use = with_enough_pings(use & model.pings_over(x - h, x + h))
    at = model.sse(x, use)[0]
    fitted = np.isfinite(at)
    below, above = (model.sse(o, use)[0][fitted] for o in (x - h, x + h))
    at, k = at[fitted], int(fitted.sum())
    curvature = float(np.sum(below) - 2 * np.sum(at) + np.sum(above)) / h ** 2
    least_squares = _sigma_from_curvature(float(np.sum(at)), curvature, 3 * int(use.sum()), 6 * k + 1)
    if not (curvature > 0 and k >= SPREAD_MIN_WINDOWS):
        return least_squares
    pulls = (above - below) / (2 * h)
    spread = float(np.sqrt(k / (k - 1) * np.sum(pulls ** 2)) / curvature)
    return float(np.fmax(least_squares, np.fmin(spread, SPREAD_MAX_RATIO * least_squares)))


def _beyond_the_near_search(imu, dvl, config, min_overlap_s: float, near: ClockOffset, model) -> ClockOffset:
    """For a DVL on the IMU span: ``near``, its offset within +-:data:`NEAR_SEARCH_S`, unless that is not confident or
    the IMU explains the DVL's velocity changes poorly at its stamps (:func:`explained_as_stamped` under
    :data:`MIN_PEAK`). Then every offset keeping the overlap is searched, and a confident offset found there replaces
    ``near`` when it is not confident, or explains more further than :data:`PEAK_EXCLUSION_S` from it. A DVL 600 s
    late on a 5400 s log (89 % of its pings on the IMU span) found nothing near and was loaded 600 s off; 400 s late,
    the near search took -264 s (0.24 explained against 0.83 at -400 s). ``model``: the search's
    (:func:`clock_model`)."""
    if near.confident and not explained_as_stamped(imu, dvl, config, model=model) < MIN_PEAK:
        return near
    far = estimate_dvl_clock_offset(imu, dvl, config, min_overlap_s=min_overlap_s, model=model)
    if far.confident and (not near.confident or far.peak > near.peak
                          and abs(far.offset_s - near.offset_s) > PEAK_EXCLUSION_S):
        return far
    return near


def _nearer_the_stamps(imu, dvl, config, min_overlap_s: float, far: ClockOffset, model) -> ClockOffset:
    """``far``, a DVL's best offset taken off its stamps under the clear peak (:attr:`ClockOffset.off_its_stamps` and
    ``confident``), unless it lies further than :data:`NEAR_REACH_S` from them and explains less than
    :data:`OFF_STAMPS_MIN_GAP` more than the best offset within that reach, the two scored on the pings both keep on the
    IMU span: then that nearer one, judged on its own, with ``far`` as its ``repeated_at_s``, where it is itself
    ``confident`` (else ``far``: the stamps as read, which the nearer would leave, explain it far less). A ``far`` not
    taken is left as it is: judged in its place, a nearer one beating the others within the reach moved 200 s logs
    30-90 s late (seeds 31, 34, 39; 0.03-0.04 m/s beams), kept on their stamps before, 49-95 s off their clock. A 200 s
    log with 0.035 m/s beams whose DVL lagged 5-10 s was moved 83 s off its clock, to a manoeuvre repeated there
    (0.148 explained over the 116 pings on the IMU span there, 0.097 at the right offset over 193; 0.151 and 0.148 over
    the 116 both keep). ``model``: the search's (:func:`clock_model`)."""
    if not (far.confident and far.off_its_stamps and abs(far.offset_s) > NEAR_REACH_S):
        return far
    try:
        near = estimate_dvl_clock_offset(imu, dvl, config, min_overlap_s=min_overlap_s,
                                         search_s=(-NEAR_REACH_S, NEAR_REACH_S), model=model)
    except DataError:
        return far
    both = with_enough_pings(model.pings(far.offset_s) & model.pings(near.offset_s))
    if not model.score(far.offset_s, both)[0] - model.score(near.offset_s, both)[0] < OFF_STAMPS_MIN_GAP:
        return far
    nearer = dataclasses.replace(near, stamped=far.stamped, repeated_at_s=far.offset_s)
    # a nearer offset the data do not name either would leave the stamps as read, which the far one explains far
    # better: an 800 s log 30 s late (0.035 m/s beams) was kept 30 s off, its best within the reach +12 s (0.04)
    return nearer if nearer.confident else far


def explained_as_stamped(imu, dvl, config=None, within_s: float = 0.0, model=None) -> float:
    """The share of the DVL's velocity changes the IMU explains at the DVL stamps as they stand (the clock search's
    score at offset 0, over its coarse windows; 1 = all, below :data:`MIN_PEAK` a clock search finds no offset by),
    or the best such score within ``within_s`` (s) of them, on a grid of half a DVL period; NaN when the pings are too
    few to tell. ``model``: the :func:`clock_model` of ``imu``, ``dvl`` and ``config`` when built already (then
    scored instead of them)."""
    if model is None:
        try:
            model = clock_model(imu, dvl, config)
        except DataError:
            return float("nan")
    coarse = model.thinned(COARSE_MAX_WINDOWS)
    steps = int(np.ceil(within_s / (0.5 * float(np.median(np.diff(model.t_pings)))))) if within_s > 0 else 0
    scores = [coarse.score(o)[0] for o in np.linspace(-within_s, within_s, 2 * steps + 1)]
    return float(np.nanmax(scores)) if np.any(np.isfinite(scores)) else float("nan")


def _coarse_offset(coarse_model, t_imu: np.ndarray, t_other: np.ndarray, min_overlap_s: float, period: float,
                   name: str, source: str, search_s: tuple[float, float] | None = None
                   ) -> tuple[float, float, float, float, float]:
    """The coarse search of a clock offset (s, added to ``t_other`` to put it on the IMU clock): every offset at
    which the two logs share ``min_overlap_s`` (within ``search_s`` when given), on a grid of half the stream's
    ``period`` (coarser for long logs, at most 4000 steps), each scored by ``coarse_model.score(offset)[0]``.

    Returns:
        (grid step, best offset, its score, the best score farther than :data:`PEAK_EXCLUSION_S` from it, the offset
        of that score (NaN without one)).

    Raises:
        DataError: the logs are too short to share ``min_overlap_s`` at any offset, naming ``name`` and ``source``.
    """
    h, grid = offset_grid(t_imu, t_other, min_overlap_s, period, name, source, search_s)
    scores = np.array([coarse_model.score(o)[0] for o in grid])
    i = int(np.argmax(scores))
    far = np.abs(grid - grid[i]) > PEAK_EXCLUSION_S
    if not far.any():
        return h, float(grid[i]), float(scores[i]), 0.0, float("nan")
    j = int(np.flatnonzero(far)[np.argmax(scores[far])])
    return h, float(grid[i]), float(scores[i]), float(scores[j]), float(grid[j])


def repeated_said(est: dict) -> str:
    """The clause saying an offset further off explained about as much (``est``: a :meth:`ClockOffset.to_dict` with
    ``repeated_at_s``); '' without."""
    if "repeated_at_s" not in est:
        return ""
    return (f" ({est['repeated_at_s']:+.3f} s, further from the stamps, explains about as much on the pings both keep "
            "on the IMU span, a manoeuvre repeated: the nearer is judged)")


def best_off_its_stamps(est: dict) -> str:
    """What a DVL on the IMU span whose clock is not found is told of its best offset (``est``: a not confident
    :meth:`ClockOffset.to_dict`): where that lies off its stamps (:attr:`ClockOffset.off_its_stamps`), a clause naming
    it and the key to give it with (only where it beats the next best by :data:`NAMED_OFFSET_MIN_GAP`); else ''."""
    if not est.get("off_its_stamps"):
        return ""
    gap = est['peak'] - est['second_peak']
    said = (f"; the IMU explains {est['stamped']:.2f} of the DVL's velocity changes at its stamps as read and "
            f"{est['peak']:.2f} at the best offset, {est['offset_s']:+.3f} s, {gap:.2f} more than at any other: the "
            "DVL clock looks off, but")
    said += repeated_said(est)
    if gap < NAMED_OFFSET_MIN_GAP:
        return (f"{said} the data name no offset (another explains nearly as much): give dvl_time_offset_s if it is "
                "known")
    return f"{said} not clearly by that offset: give dvl_time_offset_s {est['offset_s']:.3f} if it is the DVL clock's"


def shift_dvl(dvl, depth, offset_s: float, meta: dict):
    """``(dvl, depth)`` with ``offset_s`` (s) added to the DVL stamps and to a depth stream of the same instrument
    (:func:`_same_instrument`: a DVL's pressure sensor shares its clock), the depth's move noted in ``meta``; a
    depth of another instrument is returned as it is."""
    dvl = dataclasses.replace(dvl, t=np.asarray(dvl.t, float) + offset_s)
    if depth is not None and _same_instrument(depth.source, dvl.source):
        depth = dataclasses.replace(depth, t=np.asarray(depth.t, float) + offset_s)
        add_note(meta, "depth", f"moved with the DVL clock ({offset_s:+.3f} s): same instrument")
    return dvl, depth


def _same_instrument(a: str, b: str) -> bool:
    """Two streams of one file (``log.pd0:vel_bt`` and ``log.pd0:pressure``, or the same source): one clock."""
    return a == b or (":" in a and ":" in b and a.rsplit(":", 1)[0] == b.rsplit(":", 1)[0])


def _searched_offset(imu, dvl, config, min_overlap_s: float, inside: bool, model) -> ClockOffset:
    """The DVL's clock offset found on ``model`` (:func:`clock_model` or one cut otherwise): for a DVL on the IMU span
    (``inside``) searched near its stamps first (:func:`_beyond_the_near_search`, :func:`_nearer_the_stamps`), else
    over every offset keeping ``min_overlap_s`` (s) of overlap."""
    near = (-NEAR_SEARCH_S, NEAR_SEARCH_S) if inside else None
    est = estimate_dvl_clock_offset(imu, dvl, config, min_overlap_s=min_overlap_s, search_s=near, model=model)
    if inside:
        est = _beyond_the_near_search(imu, dvl, config, min_overlap_s, est, model)
        if not est.confident:
            # a DVL a second or two late (its fine time offset) explains less at its stamps than near them: a
            # manoeuvre repeated 82 s on was taken over the stamps of a clean 200 s log 1.5 s late
            est = dataclasses.replace(est, stamped=explained_as_stamped(imu, dvl, config, FINE_OFFSET_S, model))
            est = _nearer_the_stamps(imu, dvl, config, min_overlap_s, est, model)
    return est


def _across_short_gaps(imu, dvl, config, min_overlap_s: float, inside: bool, model, est: ClockOffset,
                       meta: dict) -> ClockOffset:
    """``est``, the offset not confident on ``model`` (windows cut at steps between pings over
    :data:`~graphnav.core.dvl_kinematics.MAX_CLOCK_GAP_S`), unless windows cut only at steps over
    :data:`~graphnav.core.dvl_kinematics.MAX_WINDOW_GAP_S` find one confident (noted in ``meta``). A noisy DVL losing
    its pings often for a few seconds has its windows halved by the shorter cut and its peak thinned: 200-800 s
    simulated logs with 0.035 m/s beams, 30 % of their pings lost in runs of 6 (7 s steps) and 5-120 s late, 14 of 36
    found within 0.14 s on the longer windows were left on their stamps on the shorter. An offset they find under the
    clear peak (:attr:`ClockOffset.off_its_stamps`) is taken only from at least :data:`ACROSS_MIN_WINDOWS` windows'
    worth of pings."""
    wider = across_outages_model(imu, dvl, config, model)
    try:
        across = _searched_offset(imu, dvl, config, min_overlap_s, inside, wider)
    except DataError:
        return est
    if not across.confident:
        return est
    if not across.clear and across.n < ACROSS_MIN_WINDOWS * wider.window:
        add_note(meta, "dvl", f"windows across steps between pings up to {MAX_WINDOW_GAP_S:g} s put the DVL clock at "
                 f"{across.on_written_stamps(meta, 'dvl').describe()}, under the clear peak, on {across.n} pings "
                 f"(fewer than {ACROSS_MIN_WINDOWS} windows' worth): not taken")
        return est
    best = offset_on_written_stamps(meta, "dvl", est.offset_s)
    add_note(meta, "dvl", f"clock offset found on windows across steps between pings up to {MAX_WINDOW_GAP_S:g} s: "
             f"none confident on windows cut at steps over {MAX_CLOCK_GAP_S:g} s (best {best:+.3f} s, "
             f"{est.peak:.2f} explained)")
    return across


def align_stream_clocks(imu, dvl, depth=None, meta: dict | None = None, config=None, *,
                        min_overlap_s: float = MIN_OVERLAP_S, field: str = "t",
                        what_to_do: str = "give dvl_time_offset_s", model=None, ints=None):
    """Put the DVL (and a depth stream from the same instrument) on the IMU clock: ``(dvl, depth)``.

    The clock offset is estimated (:func:`estimate_dvl_clock_offset`) and applied when it is confident (for a DVL on
    the IMU span, also a peak under the clear one far off its stamps: :attr:`ClockOffset.confident`, warned about and
    its pings counted as :data:`CLOCK_TAKEN_UNCLEAR`) and at least half a DVL period (smaller offsets are left to the
    fine DVL time-offset calibration, which needs a reference or the graph, and are noted in meta). A depth stream
    with the DVL's source (a DVL's pressure sensor) moves with it. The decision is noted in ``meta["streams"]`` and,
    when applied, warned about; ``meta["clock_offsets"]["dvl"]`` keeps the estimate. ``field``: the stamp column
    named in an error; ``what_to_do``: how to give the offset, for the error; ``model``: the :func:`clock_model` of
    ``imu``, ``dvl`` and ``config`` when built already (the stamps' score before the search shares it); ``ints``: the
    IMU's integrals the model is built on, when built already (:class:`ImuSide`). The offsets the warning, notes and
    errors say are on the DVL's stamps as written (:meth:`ClockOffset.on_written_stamps`: an A-KIT file on a clock of
    its own), which a user gives back as ``dvl_time_offset_s``; ``meta`` keeps the offset on ``dvl.t``.

    The search's windows are cut at steps between pings over
    :data:`~graphnav.core.dvl_kinematics.MAX_CLOCK_GAP_S` (:func:`clock_model`); where that finds no confident offset
    and the DVL has such steps, windows cut only at steps over :data:`~graphnav.core.dvl_kinematics.MAX_WINDOW_GAP_S`
    are searched as well and their offset taken where confident, under the clear peak only from
    :data:`ACROSS_MIN_WINDOWS` windows' worth of pings (noted in ``meta``: :func:`_across_short_gaps`).

    Raises:
        DataError: the DVL is off the IMU clock (:func:`graphnav.core.timeseries.on_the_imu_clock`) and no
            confident offset can be found (a constant-velocity log has no signal to align on). A depth stream on
            a third clock is returned as it is (:func:`graphnav.io.stream_counts.warn_off_the_imu_clock`).
    """
    meta = {} if meta is None else meta
    inside = on_the_imu_clock(dvl.t, imu.t)
    try:
        model = clock_model(imu, dvl, config, ints=ints) if model is None else model
        est = _searched_offset(imu, dvl, config, min_overlap_s, inside, model)
        if not est.confident and np.any(np.diff(model.t_pings) > model.max_gap_s):
            est = _across_short_gaps(imu, dvl, config, min_overlap_s, inside, model, est, meta)
    except DataError as err:
        if not inside:
            raise
        if err.message.startswith(IMU_GAPS_STARVE):     # not the DVL's doing: one far off its stamps would run unsaid
            say_doubted(meta, "dvl", dvl.source, f"clock offset not estimated, stamps kept unchecked: {err.message}",
                        CLOCK_UNCHECKED_IMU_GAPS, len(dvl.t), stacklevel=2)
        else:
            add_note(meta, "dvl", "clock offset not estimated (too few pings or too short a log); stamps kept")
        return dvl, depth
    meta.setdefault("clock_offsets", {})["dvl"] = est.to_dict()
    period = float(np.median(np.diff(dvl.t))) if len(dvl.t) > 1 else 1.0
    said = est.on_written_stamps(meta, "dvl")
    if not est.confident:
        why = still_velocity_said(est.peak, est.rms) or (
            f"the IMU's accelerations explain the DVL's velocity changes at no clear offset (best {est.peak:.2f}, "
            f"next {est.second_peak:.2f}: the DVL noise hides the vehicle's accelerations, or a constant-velocity log "
            "has no signal)")
        if not inside:
            raise DataError(f"DVL stamps [{dvl.t[0]:.3f}, {dvl.t[-1]:.3f}] s lie outside the IMU span "
                            f"[{imu.t[0]:.3f}, {imu.t[-1]:.3f}] s (they share {overlap_text(dvl.t, imu.t)}) and the "
                            f"clock offset cannot be found: {why}; {what_to_do}", dvl.source, field=field)
        add_note(meta, "dvl", f"clock offset not applied: {why}{best_off_its_stamps(said.to_dict())}")
        return dvl, depth
    if abs(est.offset_s) < 0.5 * period and inside:
        add_note(meta, "dvl", f"clock offset {said.describe()} is under half a DVL period: left to the fine "
                 "DVL time-offset calibration")
        return dvl, depth
    text = f"DVL clock offset {said.describe()} estimated from the data and added to the DVL stamps"
    if not est.clear:
        others = "every other offset" + (f" within {NEAR_REACH_S:g} s of the stamps" if est.repeated else "")
        text += (f", though under the clear peak the search asks for ({MIN_PEAK:g} explained, residual ratio "
                 f"{MIN_SSE_RATIO:g}; the DVL noise hides the vehicle's accelerations): the stamps as read explain "
                 f"{est.peak - est.stamped:.2f} less and {others} {est.peak - est.second_peak:.2f} less"
                 f"{repeated_said(said.to_dict())}")
    if not est.sigma_s <= CLOCK_SIGMA_WARN_S:
        text += (f"; the data barely fix it (sigma over {CLOCK_SIGMA_WARN_S:g} s: a short log, or little "
                 "acceleration): give dvl_time_offset_s if it is known, or let graphnav calibrate fit it against a "
                 "reference")
    elif est.between_imu_gaps:
        text += (f"; {imu_gaps_said(model.imu.gaps, model.window)}, with its own start velocity and gravity: the "
                 f"offset may lie up to {GAPPY_FIT_OFF_S:g} s off, more than its sigma says: give dvl_time_offset_s "
                 "if it is known, or let graphnav calibrate fit it against a reference")
    warnings.warn(f"{dvl.source}: {text}", RuntimeWarning, stacklevel=2)
    add_note(meta, "dvl", text)
    if not est.clear:
        count_doubted(meta, "dvl", CLOCK_TAKEN_UNCLEAR, len(dvl.t))
    # a depth of another instrument left off the IMU span is the prepare step's to leave out, as without a DVL move
    return shift_dvl(dvl, depth, est.offset_s, meta)


# ------------------------------------------------------------------------------------------------
# the ground truth's clock
# ------------------------------------------------------------------------------------------------
#: GT intervals the coarse scan scores at each offset (spread over the log; the refinement uses them all).
COARSE_MAX_GT_INTERVALS = 1200
#: GT intervals longer than this many GT periods (a hole in the file) are left out: the angle turned over them is
#: not the first-order one the gyro integral gives.
GT_INTERVAL_MAX_PERIODS = 1.5


class _AngleModel:
    """The angle the GT attitude turns through over each GT interval, (K-1,) rad, against the norm of the gyro's
    integral over the same interval at a candidate offset: independent of the IMU's axis convention (a signed
    permutation keeps norms), which is not known before the GT is on the IMU clock."""

    def __init__(self, t_imu: np.ndarray, omega_b: np.ndarray, t_gt: np.ndarray, C_b_n: np.ndarray):
        from scipy.spatial.transform import Rotation
        self.t_imu = np.ascontiguousarray(t_imu, float)
        self.W = np.asfortranarray(cumulative_integral(self.t_imu, np.asarray(omega_b, float)))
        dt = np.diff(t_gt)
        period = float(np.median(dt))
        keep = dt <= GT_INTERVAL_MAX_PERIODS * period
        C = np.asarray(C_b_n, float)
        angle = np.linalg.norm(Rotation.from_matrix(np.swapaxes(C[:-1], 1, 2) @ C[1:]).as_rotvec(), axis=1)
        self.a, self.b, self.angle = t_gt[:-1][keep], t_gt[1:][keep], angle[keep]
        self.period = period
        self.gaps = imu_gaps(self.t_imu)

    def thinned(self, max_intervals: int) -> "_AngleModel":
        keep = np.unique(np.linspace(0, len(self.a) - 1, min(max_intervals, len(self.a))).round().astype(int))
        out = object.__new__(_AngleModel)
        out.t_imu, out.W, out.period, out.gaps = self.t_imu, self.W, self.period, self.gaps
        out.a, out.b, out.angle = self.a[keep], self.b[keep], self.angle[keep]
        return out

    def inside(self, offset: float, to: float | None = None) -> np.ndarray:
        """True at the intervals inside the IMU span at ``offset`` s (and at ``to`` s) that no gap in the IMU
        (:func:`~graphnav.core.dvl_kinematics.imu_gaps`) falls in at any offset from ``offset`` to ``to``: across one
        the gyro's integral is interpolated, not measured. With 0.4 s of IMU rows missing every 7 s, the ten A-KIT GTs
        5000.3 s off were put 4-25 ms from their gapless offsets (sigma 1-3 ms; 1 s every 20 s, 0.4 s every 4 s: up to
        39 and 46 ms); with those intervals left out, within 0.8 ms."""
        to = offset if to is None else to
        use = (self.a + offset >= self.t_imu[0]) & (self.b + to <= self.t_imu[-1])
        if len(self.gaps):
            use &= (np.searchsorted(self.gaps[:, 1], self.a + offset, side="right")
                    == np.searchsorted(self.gaps[:, 0], self.b + to, side="left"))
        return use

    def score(self, offset: float, use: np.ndarray | None = None) -> tuple[float, float, int]:
        """(explained fraction 1 - SSE / the angles' own scatter, SSE rad^2, intervals) over the intervals ``use``
        (default: those inside the IMU span at ``offset``)."""
        use = self.inside(offset) if use is None else use
        n = int(use.sum())
        if n < 10:
            return -np.inf, np.inf, n
        turned = np.linalg.norm(interp_rows(self.b[use] + offset, self.t_imu, self.W)
                                - interp_rows(self.a[use] + offset, self.t_imu, self.W), axis=1)
        angle = self.angle[use]
        sse = float(np.sum((turned - angle) ** 2))
        null = float(np.sum((angle - angle.mean()) ** 2))
        return 1.0 - sse / max(null, 1e-18), sse, n


def estimate_gt_clock_offset(imu, gt, *, min_overlap_s: float = MIN_OVERLAP_S) -> ClockOffset:
    """The offset to add to the GT stamps to put them on the IMU clock, from the angles the vehicle turned through
    (:class:`_AngleModel`): every offset at which the two logs share ``min_overlap_s`` (at least
    :data:`~graphnav.core.dvl_kinematics.MIN_OVERLAP_FRACTION` of the shorter log), on a grid of half a GT period
    (coarser for long logs), the best refined by minimising the residual. Quality as
    :func:`estimate_dvl_clock_offset`'s (``confident``).

    Args:
        imu: :class:`~graphnav.core.mission.ImuData` (gyro in rad/s; any axis convention).
        gt: :class:`~graphnav.core.mission.GroundTruth` on its own clock (seconds, any origin).

    Raises:
        DataError: fewer than 20 GT intervals, or logs too short to overlap ``min_overlap_s``.
    """
    model = _AngleModel(imu.t, imu.omega_b, gt.t, gt.C_b_n)
    if len(model.a) < 20:
        raise DataError(f"{len(model.a)} GT interval(s) without a hole: too few to find a clock offset (need 20)",
                        gt.source, field="t")
    span_imu, span_gt = float(imu.t[-1] - imu.t[0]), float(gt.t[-1] - gt.t[0])
    min_overlap_s = search_overlap(span_imu, span_gt, 10 * model.period, min_overlap_s)
    h, coarse, best, second, _ = _coarse_offset(model.thinned(COARSE_MAX_GT_INTERVALS), imu.t, gt.t, min_overlap_s,
                                             model.period, "GT", gt.source)
    use = model.inside(coarse - h, coarse + h)       # the same intervals at every candidate
    if len(model.gaps) and np.count_nonzero(use) < GT_MIN_CLEAR_INTERVALS:
        model.gaps = np.empty((0, 2))       # every interval holds a gap: scored across them, as before
        h, coarse, best, second, _ = _coarse_offset(model.thinned(COARSE_MAX_GT_INTERVALS), imu.t, gt.t,
                                                    min_overlap_s, model.period, "GT", gt.source)
        use = model.inside(coarse - h, coarse + h)

    def cost(o):
        return model.score(o, use)[1]
    res = minimize_scalar(cost, bounds=(coarse - h, coarse + h), method="bounded", options={"xatol": 1e-4})
    x = float(res.x)
    explained, sse, n = model.score(x, use)
    step = 0.01
    curvature = (cost(x + step) - 2 * sse + cost(x - step)) / step ** 2
    sigma = _sigma_from_curvature(sse, curvature, n, 1)
    overlap = float(min(imu.t[-1], gt.t[-1] + x) - max(imu.t[0], gt.t[0] + x))
    return ClockOffset(x, sigma, max(explained, best), max(second, 0.0), coarse,
                       float(np.sqrt(sse / max(n, 1))), overlap, n, explains="the GT's attitude changes")


#: Lowest explained fraction and sharpness (see :class:`ClockOffset`) accepted for a GT clock offset. Measured
#: (GT moved 3 days and -5000 s): the ten shared trajectories, whole and their first 150 s, peak 1.000, sharpness
#: 2100-3e6 (the published GT is the same INS's attitude); simulated missions (navigation, tactical and MEMS
#: gyros, 150 and 600 s, three seeds) peak 1.000, sharpness 11 000-260 000, the offset within 1 ms; another
#: trajectory's or mission's GT (the wrong file) peak -11..0.60, sharpness 0.00-2.45.
MIN_GT_PEAK = 0.8
MIN_GT_SSE_RATIO = 5.0


def gt_clock_confident(est: ClockOffset) -> bool:
    """A GT clock offset good enough to apply (:data:`MIN_GT_PEAK`, :data:`MIN_GT_SSE_RATIO`)."""
    return est.peak >= MIN_GT_PEAK and est.sharpness >= MIN_GT_SSE_RATIO


def _span(t: np.ndarray) -> str:
    return f"[{float(t[0]):.3f}, {float(t[-1]):.3f}] s"


def align_gt_clock(imu, gt, meta: dict | None = None, *, field: str = "t", what_to_do: str = ""):
    """``(gt, offset_s)``: the ground truth put on the IMU clock when its span is off the IMU's
    (:func:`graphnav.core.timeseries.on_the_imu_clock`: a GT logged on a clock seconds or days away; a GT that only
    outlasts the IMU is on its clock), by the offset :func:`estimate_gt_clock_offset` finds;
    ``(gt, 0.0)`` unchanged otherwise (the fine GT time offset is the prepare step's). The offset applied is warned
    about (naming the GT file) and noted in ``meta["streams"]["gt"]``; ``meta["clock_offsets"]["gt"]`` keeps the
    estimate. The offsets the warning and errors say are on the GT's stamps as written, as
    :func:`align_stream_clocks`'s are (an A-KIT GT on a clock of its own).

    Args:
        imu: :class:`~graphnav.core.mission.ImuData`. gt: :class:`~graphnav.core.mission.GroundTruth`.
        field: the stamp column named in the error. what_to_do: how to give the offset, for the error.

    Raises:
        DataError: the GT does not overlap the IMU and no confident offset is found (naming the GT file, both
            time spans and what to do).
    """
    meta = {} if meta is None else meta
    if on_the_imu_clock(gt.t, imu.t):
        return gt, 0.0
    where = (f"GT stamps {_span(gt.t)} lie outside the IMU span {_span(imu.t)} (they share "
             f"{overlap_text(gt.t, imu.t)}: a clock of its own)")
    todo = what_to_do or "give the GT time offset"
    try:
        est = estimate_gt_clock_offset(imu, gt)
    except DataError as exc:
        raise DataError(f"{where}, and its clock offset cannot be found: {exc.message}; {todo}",
                        gt.source, field=field) from None
    said = est.on_written_stamps(meta, "gt")
    if not gt_clock_confident(est):
        meta.setdefault("clock_offsets", {})["gt"] = {**est.to_dict(), "confident": False}
        raise DataError(f"{where}, and the IMU's gyro explains the GT's attitude changes at no clear offset (best "
                        f"{est.peak:.2f} at {said.offset_s:+.3f} s, {est.second_peak:.2f} at the next best; a GT of "
                        f"another mission, or too little turning to align on); {todo}", gt.source, field=field)
    text = f"GT clock offset {said.describe()} estimated from the data and added to the GT stamps"
    return add_gt_clock_offset(gt, est, meta, text), est.offset_s


def add_gt_clock_offset(gt, est: ClockOffset, meta: dict, text: str, who: str | None = None):
    """``gt`` with the confident clock offset ``est`` (s) added to its stamps, ``text`` warned about (as said by
    ``who``, default the GT file) and noted on the GT stream, the estimate kept in ``meta["clock_offsets"]["gt"]`` and
    the span in ``meta["streams"]["gt"]``: the one place a GT clock offset found from the data is applied (an A-KIT GT
    off the IMU span, a log's or bag's reference on a clock of its own, a given offset that leaves it off the span)."""
    meta.setdefault("clock_offsets", {})["gt"] = {**est.to_dict(), "confident": True}
    warnings.warn(f"{who or gt.source}: {text}", RuntimeWarning, stacklevel=4)
    add_note(meta, "gt", f"{who}: {text}" if who else text)
    gt = dataclasses.replace(gt, t=np.asarray(gt.t, float) + est.offset_s)
    set_span(meta, "gt", gt.t)
    return gt
