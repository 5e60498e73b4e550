"""The DVL's velocity against the IMU's integrals, window by window: the kinematic model the DVL clock search, the
DVL checks (unit, turn, axes, an IMU turned) and the earth-frame check of a DVL's velocity columns share.

Per window of :data:`WINDOW_S` of DVL pings, a body-frame velocity obeys

    v_j = v0 + int f_b dt + (int R^T dt) g0 - int omega x v dt - omega_j x l

with ``v0`` and the gravity the body saw at the window start ``g0`` fitted by linear least squares (so Earth rate,
gyro drift, accelerometer bias and the unknown attitude only enter through g0); the residual against a straight line
per window (the fit without the IMU) is how well the IMU explains the DVL (:class:`_WindowModel`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from graphnav.core.errors import DataError
from graphnav.core.rotations import cumulative_quat_product
from graphnav.core.timeseries import cumulative_integral, interp_rows

#: Step of the IMU grid the integrals are kept on, s.
IMU_GRID_S = 0.05
#: Shortest gap between IMU stamps, s, at which a window of pings is cut (:func:`imu_gaps`; the run's own bar,
#: :data:`~graphnav.core.mission.IMU_GAP_PERIODS` periods, where longer). One gap at 80 s of simulated logs (400 s,
#: seeds 1-3; 200 s, seeds 1-2; DVL 12 s late) moved the clock found by at most 1 ms at 0.25 s, 12 ms at 0.5 s,
#: 10-160 ms at 1 s, and 0.5-166 s at 2 s; six samples dropped every 10 s (0.07 s steps) moved it by 3 ms, where
#: leaving out every window spanning one left none.
IMU_GAP_MIN_S = 0.25
#: Length of the windows over which the gravity seen at the window start is fitted, s.
WINDOW_S = 20.0
#: Fewest pings a window reaching past the IMU's ends keeps to be fitted by the clock search: its v0 and g0 are 6
#: numbers, the straight line's too, and 6 pings give them 18.
MIN_WINDOW_PINGS = 6
#: No window spans a gap between pings longer than this (s, a window's length): its ``int omega x v`` would take the
#: velocity as the mean of the pings either side of the gap, which on a vehicle turning through a hole of refused
#: pings or an outage is no velocity it had (a 600 s log with 229 s of pings refused scored the true clock offset
#: under a wrong one 252 s away). The windows are cut at such gaps instead (:func:`window_rows`): a DVL losing
#: bottom lock for 25 s every 42 s has 17 s of pings between its outages, which a window across the gaps left
#: unfitted at every offset. The ten A-KIT trajectories' pings are at most 1.0 s apart.
MAX_WINDOW_GAP_S = WINDOW_S
#: The clock search's windows are cut at shorter gaps, over this (s): a DVL outage of 5-20 s inside a window spoils the
#: fit the same way. Measured on 60 s A-KIT pieces without GT (ten trajectories, seven starts) with k pings dropped
#: (a step of k+1 s), the DVL clock fit against the GT-based offset: across steps of 2-5 s it stays within 0.20 s (90 %
#: within 0.09 s) and places none off; across 6 s 90 % within 0.11 s; across 11 s one piece is placed 0.53 s off
#: (Trajectory1 from 240 s: +1.48 s for about +1.0), across 16 s three, one 13 s off. Cut at 5 s: 90 % within 0.08 s at
#: every step, one piece 0.27 s off (8 s step); cut at 3 or 4 s, the 3-5 s steps' fits move under 0.03 s. 600 s
#: simulated logs a day off with 45 % of their pings lost in runs of 5 (6 s steps; seeds 0-5, with and without speed
#: spikes): 5 of 12 refused with windows across the steps, all 12 found within 0.18 s cut at 5 s. Where this cut finds
#: no confident offset, the clock search tries windows cut at MAX_WINDOW_GAP_S as well (a noisy DVL losing pings
#: often: :func:`graphnav.calibration.clock.align_stream_clocks`). The turn fit's MAX_TURN_GAP_S is the same 5 s, and
#: the DVL speed check's scale is fitted on windows cut so too (:func:`outage_cut_model`).
MAX_CLOCK_GAP_S = 5.0
#: ... and any window model's, for a DVL pinging slower, at gaps over this many of its ping periods (the median step):
#: a ping missed, not every step of its steady rate. A 1200 s simulated DVL thinned to a ping every 5 or 6 s, a day
#: off, was refused as too broken up cut at 5 s; so it is found (0.08 s off), as before the cut.
GAP_PERIODS = 1.5
#: The DVL's turn about z (:data:`MAX_YAW_RAD`, :data:`MIN_YAW_RAD`) is fitted over the windows with no step between
#: pings beyond this (s): across an outage the model's ``int omega x v`` holds the velocity at the gap's ends for the
#: whole gap, which in a turn leaves a sideways residual the fit reads as a turn. 60 s A-KIT pieces without GT with one
#: 10-ping outage (an 11 s step; two windows left, one across it) fitted turns of -24/-22/+11/-12 deg and were refused
#: (Trajectory10 and 2 from 0 s, 1 and 6 from 240 s; the same pieces whole: -9/-15/-0.3/+0.3 deg, under 3 windows'
#: sigmas or 10 deg). A dropped ping or two (steps of 2-3 s) stay in.
MAX_TURN_GAP_S = 5.0
#: Lowest share of the variance the horizontal fit must explain for its scale and yaw to tell anything (r^2, the
#: best within +- SCALE_SEARCH_S): 0.976-0.999 on nine of the ten A-KIT trajectories, 0.61 on the steady
#: Trajectory13; simulated missions 0.05-0.39 with the default 0.042 m/s beams, 0.58-0.905 with 0.01 m/s and a
#: navigation or tactical IMU, 0.41-0.80 with a MEMS one, whose noisy integrals pull the scale to 0.75-0.87 and the
#: yaw up to 19 deg: those are not judged.
MIN_SCALE_R2 = 0.9
#: The scale is taken at the offset within +- this of the DVL stamps where its fit is best, s (knots misled the
#: clock search by 7.5 s on Trajectory1's first 200 s).
SCALE_SEARCH_S = 20.0
#: The DVL offsets (s) the scale and gyro fits take their best of: every 0.5 s within +- SCALE_SEARCH_S.
SCALE_OFFSETS_S = np.arange(-SCALE_SEARCH_S, SCALE_SEARCH_S + 0.25, 0.5)
#: A scale fit at an offset whose turn lies over 90 deg from the best's fits as well as the best when it leaves at most
#: this many times the best's unexplained share (1 - r^2) (:func:`fits_turned_elsewhere`). Straight legs at 1 m/s
#: surging 0.1-0.5 m/s every 8-53 s (seeds 0-2, 1 and 4 cm/s of DVL noise, on time and 8 s late) whose best explains
#: MIN_SCALE_R2, the only fits judged: 1.00-1.11 with half a period inside +- SCALE_SEARCH_S, 5.4-14 beyond it (53 s on
#: time); weaker bests (r^2 0.36-0.62) 1.06-1.81. The ten A-KIT trajectories: no offset fits turned on nine, the steady
#: Trajectory13 (best 0.61, not judged) 1.96.
TURNED_FIT_RATIO = 1.5
#: Shortest overlap of the two logs at a candidate clock offset, s ...
MIN_OVERLAP_S = 60.0
#: ... and at least this fraction of the shorter log.
MIN_OVERLAP_FRACTION = 0.5
#: Windows the coarse scan scores at each offset (spread over the log; the refinement uses them all): 60 x 20 s
#: is 20 minutes of a 1 Hz DVL, plenty to tell offsets apart, and keeps a long log's scan to seconds.
COARSE_MAX_WINDOWS = 60
#: A DVL velocity that a straight line per window leaves under this RMS (m/s per axis, at a clock fit's best offset)
#: barely changes: what the IMU explains of its changes is a ratio against nearly nothing, not a score (a constant
#: velocity with 1 mm/s noise against a simulated IMU: -526; without noise -5e11). At their clock offsets the ten A-KIT
#: trajectories leave 0.013 (Trajectory13, holding its speed) to 0.15; simulated missions 0.025 (noiseless) to 0.075.
STILL_LINE_RMS_MPS = 0.005


#: The clock fit's refinement keeps its reach of two grid steps each way where the pings fitted at every offset on it
#: are at least this share of those fitted at the coarse offset, else takes a narrower one (:func:`refine_reach`). On
#: the ten A-KIT column maps with 0.4 s of IMU rows missing every 7 s (1 Hz pings) a reach of +-1 s keeps none of them,
#: +-0.5 s 49-52 %, +-0.25 s 88-89 %, +-0.125 s 93-95 %; their gapless copies keep 99.5-100 % at +-1 s.
REFINE_MIN_SHARE = 0.75
#: ... and a narrowed reach is centred on its fit until that lies this close (s) to its centre
#: (:func:`refined_offset`), a tenth of the IMU grid the cost is interpolated on, or for at most this many moves.
REFINE_SETTLED_S = 0.005
REFINE_MAX_MOVES = 20


def still_velocity_said(peak: float, rms: float) -> str | None:
    """Where the DVL velocity barely changes (:data:`STILL_LINE_RMS_MPS`), what to say instead of the share of its
    changes a clock fit explains (``peak``, leaving a residual of ``rms`` m/s per axis per ping: the straight line
    per window leaves ``rms / sqrt(1 - peak)``); else None."""
    if not (np.isfinite(peak) and np.isfinite(rms) and peak < 1.0):
        return None
    line = rms / np.sqrt(1.0 - peak)
    if not line < STILL_LINE_RMS_MPS:
        return None
    return (f"the DVL velocity barely changes ({line:.2g} m/s RMS about a straight line per {WINDOW_S:g} s window, "
            f"under {STILL_LINE_RMS_MPS:g}: a vehicle holding its speed and turn, or a velocity logged constant), so "
            "the IMU's accelerations have nothing to be compared with")


@dataclass
class ImuIntegrals:
    """The IMU on a uniform grid ``t`` (K,): running integrals of the specific force ``F`` (m/s), of the
    gyro ``W`` (rad), of the transposed gyro attitude ``M`` (K,3,3, s; ``int R(t)^T dt`` with R the body
    attitude relative to the first sample: ``M g0`` integrates the gravity a body sees that started with
    gravity ``g0``), and the mean rate per step ``omega`` (K,3) at the grid stamps."""

    t: np.ndarray
    F: np.ndarray
    W: np.ndarray
    M: np.ndarray
    omega: np.ndarray
    #: (G,2) the start and end stamps (s) of the IMU's gaps (:func:`imu_gaps`), across which the integrals hold the
    #: last sample: a window of pings is cut there (:meth:`_WindowModel.at_imu_gaps`)
    gaps: np.ndarray = field(default_factory=lambda: np.empty((0, 2)), compare=False)
    #: ``F``, ``W``, ``omega`` and ``M`` (as 9 columns) side by side, (K,18), row by row: built on the first
    #: :meth:`at`, kept for every other (a prepare step's clock models share it: ``clock.ImuSide``)
    _rows: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)

    def at(self, t_query: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(F, W, omega, M)`` at the stamps ``t_query`` (Q,), s: (Q,3) each and M (Q,9), C-ordered, interpolated
        linearly on the grid with its end values held, to the bit what ``interp_rows`` (``np.interp`` column by
        column) gives. The grid is searched once for all 18 columns instead of once per column: on a 1 h log's grid
        (72 000 steps) the 18 searches were most of a clock search's cost, each of its trials' (the velocity's y
        negated, in FLU axes, turned) as much."""
        if self._rows is None:
            self._rows = np.ascontiguousarray(np.hstack([self.F, self.W, self.omega, self.M.reshape(-1, 9)]))
        t, rows = self.t, self._rows
        t_query = np.asarray(t_query, float)
        j = np.searchsorted(t, t_query, side="right") - 1          # t[j] <= t_query < t[j+1]
        k = np.clip(j, 0, len(t) - 2)
        t0, x0 = t[k], rows[k]
        # np.interp's own operations, in its order: slope, times the step from t[k], plus the value there
        out = (rows[k + 1] - x0) / (t[k + 1] - t0)[:, None] * (t_query - t0)[:, None] + x0
        before, after = j < 0, j >= len(t) - 1
        held = before | after | (t0 == t_query)       # np.interp gives a grid stamp's value as it is
        if held.any():
            out[held] = np.where(before[held, None], rows[0], np.where(after[held, None], rows[-1], x0[held]))
        unstamped = np.isnan(t_query)        # sorted past the grid's end: np.interp's own answer, not the end values
        if unstamped.any():
            out[unstamped] = interp_rows(t_query[unstamped], t, rows)
        return tuple(np.ascontiguousarray(out[:, a:b]) for a, b in ((0, 3), (3, 6), (6, 9), (9, 18)))


def imu_integrals(t: np.ndarray, f_b: np.ndarray, omega_b: np.ndarray, step_s: float | None = None
                  ) -> ImuIntegrals:
    """:class:`ImuIntegrals` of an IMU stream (stamps s, f_b m/s^2, omega_b rad/s); grid step ``step_s``
    (default :data:`IMU_GRID_S`, coarser for logs over ~1.5 h to keep the grid under 100 000 steps)."""
    from scipy.spatial.transform import Rotation
    t = np.ascontiguousarray(t, float)
    step = step_s or max(IMU_GRID_S, (t[-1] - t[0]) / 1e5)
    edges = np.arange(t[0], t[-1], step)
    F = interp_rows(edges, t, np.asfortranarray(cumulative_integral(t, f_b)))
    W = interp_rows(edges, t, np.asfortranarray(cumulative_integral(t, omega_b)))
    dtheta = np.diff(W, axis=0)
    q = cumulative_quat_product(Rotation.from_rotvec(dtheta).as_quat())
    R_T = np.swapaxes(Rotation.from_quat(q).as_matrix(), 1, 2)
    M = np.concatenate([np.zeros((1, 3, 3)), np.cumsum(0.5 * (R_T[1:] + R_T[:-1]) * step, axis=0)])
    omega = np.vstack([dtheta / step, dtheta[-1:] / step])
    # column-major: a column interpolated alone (np.interp) is not copied out of the rows (M too, as the (K,9) columns
    # its (K,3,3) view reshapes back to); the clock's scores interpolate all of them at once (ImuIntegrals.at's rows)
    M = np.asfortranarray(M.reshape(-1, 9)).reshape(-1, 3, 3)
    return ImuIntegrals(edges, *map(np.asfortranarray, (F, W)), M, np.asfortranarray(omega), imu_gaps(t))


def imu_gaps(t: np.ndarray) -> np.ndarray:
    """(G,2): the start and end stamps (s) of the steps between IMU stamps ``t`` (s) over
    :data:`~graphnav.core.mission.IMU_GAP_PERIODS` median periods (a gap the run bridges) and over
    :data:`IMU_GAP_MIN_S` (shorter ones barely move a fit: samples lost often are not worth every window).

    Across a gap the integrals hold the last sample's acceleration and turn: a window of pings spanning it is scored
    on made-up ones. A simulated 400 s log with 5 s of IMU rows deleted at 80 s, its DVL 12 s late, had its DVL clock
    put at +124 / +154 / +115 s (seeds 1-3) on the windows spanning the gap at those offsets; without them, -12.0."""
    from graphnav.core.mission import IMU_GAP_PERIODS
    steps = np.diff(t)
    if not len(steps):
        return np.empty((0, 2))
    gap = np.flatnonzero(steps > max(IMU_GAP_PERIODS * float(np.median(steps)), IMU_GAP_MIN_S))
    return np.column_stack([t[gap], t[gap + 1]]).astype(float)


def dvl_velocity_b(dvl, config=None) -> tuple[np.ndarray, np.ndarray]:
    """``(t, v (M,3))`` of the pings with a head velocity in the body frame (m/s): the instrument's ``v_b``,
    its ``v_d`` turned by ``C_d_b``, or the least-squares velocity of >= 3 valid beams."""
    n = len(dvl.t)
    v = np.full((n, 3), np.nan)
    if dvl.v_b is not None:
        v = np.where(np.isfinite(dvl.v_b), dvl.v_b, np.nan)
    C_d_b = np.eye(3) if config is None else config.dvl.C_d_b
    if dvl.v_d is not None and dvl.v_d_valid is not None:
        fill = ~np.all(np.isfinite(v), axis=1) & dvl.v_d_valid
        v[fill] = dvl.v_d[fill] @ C_d_b.T
    missing = ~np.all(np.isfinite(v), axis=1) & (dvl.valid.sum(axis=1) >= 3)
    if missing.any():
        from graphnav.core.config import DvlSpec
        from graphnav.core.dvl import DvlGeometry
        spec = DvlSpec() if config is None else config.dvl
        v[missing] = DvlGeometry.from_spec(spec).velocity_from_beams(
            dvl.beams[missing], dvl.valid[missing], allow_missing=True)
    ok = np.all(np.isfinite(v), axis=1)
    return np.asarray(dvl.t, float)[ok], v[ok]


def centred(x: np.ndarray, use: np.ndarray) -> np.ndarray:
    """``x`` (win, window, ...) less its mean over the pings ``use`` (win, window) of each window; zero at the
    other pings (so they drop out of any least-squares fit)."""
    w = use.reshape(use.shape + (1,) * (x.ndim - 2))
    return np.where(w, x - np.sum(x * w, axis=1, keepdims=True) / np.sum(w, axis=1, keepdims=True), 0.0)


def without_window_fit(y: np.ndarray, A: np.ndarray, use: np.ndarray | None = None) -> np.ndarray:
    """``y`` (win, window, 3) less its least-squares fit per window by a constant (v0) and the gravity regressor
    ``A`` (win, window*3, 3; g0): the residual (win, window*3). ``use`` (win, window): the pings fitted (default
    all); ``A`` is then :func:`centred` over them, and the residual is zero at the others."""
    use = None if use is None or use.all() else use
    y = y - y.mean(axis=1, keepdims=True) if use is None else centred(y, use)     # v0
    g0 = np.linalg.solve(np.einsum("wki,wkj->wij", A, A) + 1e-9 * np.eye(A.shape[-1]),
                         np.einsum("wki,wk->wi", A, y.reshape(len(y), -1))[..., None])[..., 0]
    return y.reshape(len(y), -1) - np.einsum("wkj,wj->wk", A, g0)


def window_rows(t: np.ndarray, window: int, max_gap_s: float = MAX_WINDOW_GAP_S) -> tuple[np.ndarray, np.ndarray]:
    """``(rows, real)``, (win, window): the indices into the ping stamps ``t`` (s) of each window of ``window`` pings,
    and True at its pings. Windows run in order and are cut at every gap over ``max_gap_s`` (s): the pings
    between two such gaps fill whole windows, and the rest of them (at least :data:`MIN_WINDOW_PINGS`) one more,
    padded with its last ping (``real`` False there: no fit counts it), the pings after the log's last gap too. An
    outage moves the windows after it, and the pings it left past the last whole window were left out: a 60 s A-KIT
    piece (Trajectory1 from 120 s, 6 pings dropped after the 3rd or the 23rd, a day off) lost the 11 s its velocity
    changed most in, its IMU explained 0.08-0.18 of the rest at the right offset and it was refused; 0.27-0.36
    with them."""
    starts = np.concatenate([[0], np.flatnonzero(np.diff(t) > max_gap_s) + 1])
    ends = np.append(starts[1:], len(t))
    rows = []
    for a, b in zip(starts, ends):
        whole = (b - a) // window
        rows += [np.arange(a + k * window, a + (k + 1) * window) for k in range(whole)]
        rest = b - (a + whole * window)
        if rest >= min(MIN_WINDOW_PINGS, window):
            rows.append(np.minimum(np.arange(b - rest, b - rest + window), b - 1))
    rows = np.array(rows, int).reshape(-1, window)
    return rows, np.concatenate([np.ones((len(rows), 1), bool), np.diff(rows, axis=1) > 0], axis=1)


def gaps_said(t: np.ndarray, window: int, max_gap_s: float = MAX_WINDOW_GAP_S) -> str:
    """How the ping stamps ``t`` (s) are broken up for windows of ``window`` pings cut at gaps over ``max_gap_s`` (s):
    those gaps (how many, how long, how far apart) and the windows the pings between them fill."""
    dt = np.diff(t)
    gap = np.flatnonzero(dt > max_gap_s)
    rows, _ = window_rows(t, window, max_gap_s)
    text = (f"{len(t)} pings with a velocity over {t[-1] - t[0]:.0f} s, with {len(gap)} gap(s) over "
            f"{max_gap_s:g} s without one")
    if len(gap):
        lo, hi = np.min(dt[gap]), np.max(dt[gap])
        text += f" ({lo:.0f} s long" if round(lo) == round(hi) else f" ({lo:.0f}-{hi:.0f} s long"
        text += f", starting every {np.median(np.diff(t[gap])):.0f} s)" if len(gap) > 1 else ")"
    return text + (f", leaving {len(rows)} window(s) between them with at least {min(MIN_WINDOW_PINGS, window)} "
                   f"pings (of the {window} a {WINDOW_S:g} s window holds)")


def imu_gaps_said(gaps: np.ndarray, window: int) -> str:
    """How the IMU's gaps ``gaps`` (G,2; s, :func:`imu_gaps`) cut windows of ``window`` pings: how many, how long,
    how far apart, and the pings each part of a window keeps to be fitted."""
    length, n = gaps[:, 1] - gaps[:, 0], len(gaps)
    lo, hi = float(np.min(length)), float(np.max(length))
    text = f"the IMU's stamps have {n} gap(s) ({lo:.2f} s long" if round(lo, 2) == round(hi, 2) else (
        f"the IMU's stamps have {n} gap(s) ({lo:.2f}-{hi:.2f} s long")
    text += f", starting every {np.median(np.diff(gaps[:, 0])):.1f} s)" if n > 1 else ")"
    return (text + ", across which its integrals hold the last sample: the DVL's windows are cut at them, and only a "
            f"part keeping at least {min(MIN_WINDOW_PINGS, window)} pings between two is fitted")


class _WindowModel:
    """The DVL pings in windows of :data:`WINDOW_PINGS` (cut at gaps, :func:`window_rows`); for a candidate offset,
    the residual of

        v_j = v0 + int f_b dt + (int R^T dt) g0 - int omega x v dt - omega_j x l       (per window: v0, g0)

    against the same fit without the IMU terms (a straight line per window): the explained fraction.

    At an offset a window is fitted over its pings inside the IMU span: all of them or none (``trim`` False, the
    DVL checks', whose offsets keep the DVL on the IMU), or those inside when at least :data:`MIN_WINDOW_PINGS`
    (``trim`` True, the clock search's: a window reaching past the IMU's end by a ping keeps its other pings, so
    offsets a few seconds apart score nearly the same pings and none wins by leaving out a window it explains
    badly). No window spans a gap of more than ``max_gap_s`` (:data:`MAX_WINDOW_GAP_S`; the clock search's and the
    speed check's scale fit's :data:`MAX_CLOCK_GAP_S`, :func:`outage_cut_model`); the padding of a window cut short
    by one (``real`` False) is fitted at no offset. At an offset putting a gap in the IMU inside a window
    (:func:`imu_gaps`: the integrals hold the last sample across it), every window is cut there, the clock search's
    and the DVL checks', its parts either side fitted on their own (:meth:`at_imu_gaps`).
    ``t_pings``: the stamps of every ping it was built from (s), in the windows or not (the clock search's span,
    period and gaps)."""

    def __init__(self, imu: ImuIntegrals, t_dvl: np.ndarray, v: np.ndarray, lever_arm_b: np.ndarray,
                 window: int, trim: bool = False, max_gap_s: float = MAX_WINDOW_GAP_S):
        self.imu, self.lever, self.trim, self.max_gap_s = imu, lever_arm_b, trim, max_gap_s
        self.t_pings = t_dvl
        rows, self.real = window_rows(t_dvl, window, max_gap_s)
        self.t, self.v = t_dvl[rows], v[rows]
        self.v_mid = 0.5 * (self.v[:, 1:] + self.v[:, :-1])
        self.window = window
        # the fit without IMU: v = v0 + c t per window (6 parameters, as the model's v0, g0)
        tc = self.t - self.t.mean(axis=1, keepdims=True)
        X = np.stack([np.ones_like(tc), tc], axis=-1)                   # (n_win, window, 2)
        beta = np.einsum("wij,wjk->wik", np.linalg.pinv(X), self.v)
        self.sse_null_w = np.sum((self.v - X @ beta) ** 2, axis=(1, 2))   # per window
        padded = ~self.real.all(axis=1)
        self.sse_null_w[padded] = _line_sse(self.t[padded], self.v[padded], self.real[padded])

    def thinned(self, max_windows: int) -> "_WindowModel":
        """The same model on at most ``max_windows`` windows spread over the log (for the coarse scan of a long
        log: its cost grows with windows x offsets)."""
        keep = np.unique(np.linspace(0, len(self.t) - 1, min(max_windows, len(self.t))).round().astype(int))
        out = object.__new__(_WindowModel)
        out.imu, out.lever, out.window, out.trim, out.max_gap_s = (self.imu, self.lever, self.window, self.trim,
                                                                   self.max_gap_s)
        out.t_pings = self.t_pings
        out.t, out.v, out.v_mid, out.sse_null_w = self.t[keep], self.v[keep], self.v_mid[keep], self.sse_null_w[keep]
        out.real = self.real[keep]
        return out

    def pings(self, offset: float) -> np.ndarray:
        """(win, window) True at the pings fitted at ``offset`` s: those inside the IMU span, of the windows keeping
        enough (class docstring), less a window's padding (:func:`window_rows`), and cut at the IMU's gaps there
        (:meth:`at_imu_gaps`)."""
        t = self.t + offset
        inside = (t >= self.imu.t[0]) & (t <= self.imu.t[-1])
        use = with_enough_pings((inside if self.trim else inside & inside.all(axis=1, keepdims=True)) & self.real)
        return self.at_imu_gaps(offset, use)

    def pings_over(self, lo: float, hi: float) -> np.ndarray:
        """(win, window) True at the pings fitted at every offset from ``lo`` to ``hi`` s (:meth:`pings`), each window
        cut into the same parts at every one of them (:meth:`segments`): a ping an IMU gap passes over between them,
        which would move from one part to the next and make a step in the cost a refinement takes for its minimum
        (a 200 s simulated log with 1 s of IMU missing every 20 s, 12 s late, was placed 0.35 s off on such a step),
        is left out."""
        use = with_enough_pings(self.pings(lo) & self.pings(hi))
        if not len(self.imu.gaps):
            return use
        begun = np.searchsorted(self.imu.gaps[:, 0], self.t + hi, side="left")
        swept = begun != np.searchsorted(self.imu.gaps[:, 1], self.t + lo, side="right")
        return self.at_imu_gaps(lo, with_enough_pings(use & ~swept))

    def at_imu_gaps(self, offset: float, use: np.ndarray) -> np.ndarray:
        """The pings ``use`` (win, window) less those the IMU's gaps (:func:`imu_gaps`) leave unfitted at ``offset``
        s: across a gap the integrals hold the last sample. A window is cut there as the clock search's (``trim``)
        is at the IMU's ends: the pings stamped inside a gap are left out, and those on either side of it keep their
        own fit (:meth:`segments`) where they are at least :data:`MIN_WINDOW_PINGS`. The DVL checks' windows are cut so
        too, where they were left out whole: 0.4 s of IMU rows missing every 4 s left an A-KIT log no window to judge
        (:data:`IMU_GAP_MIN_S`)."""
        if not (len(self.imu.gaps) and use.size):       # no gap, or a DVL broken up into no window at all
            return use
        t = self.t + offset
        side = np.searchsorted(self.imu.gaps[:, 1], t, side="right")       # gaps ended by each ping
        use = use & (np.searchsorted(self.imu.gaps[:, 0], t, side="left") == side)     # none begun and not ended
        part = side - np.min(np.where(use, side, side.max()), axis=1, keepdims=True)
        parts = part[:, :, None] == np.arange(max(1, int(np.max(np.where(use, part, 0))) + 1))
        enough = np.sum(parts & use[:, :, None], axis=1) >= min(MIN_WINDOW_PINGS, use.shape[1])   # (win, parts)
        return use & np.any(parts & enough[:, None, :], axis=2)

    def segments(self, offset: float, use: np.ndarray) -> np.ndarray | None:
        """(win, window, parts) True at each part of a window's pings ``use`` that lies between two of the IMU's
        gaps at ``offset`` s (:meth:`at_imu_gaps`): each is fitted on its own, with its own ``v0`` and ``g0`` and its
        own straight line, as the windows :func:`window_rows` cuts at a DVL outage are. None where no window has
        pings on two sides of a gap."""
        if not (len(self.imu.gaps) and use.size):
            return None
        side = np.searchsorted(self.imu.gaps[:, 1], self.t + offset, side="right")
        part = np.where(use, side - np.min(np.where(use, side, side.max()), axis=1, keepdims=True), 0)
        n = int(np.max(part, initial=0)) + 1
        return None if n == 1 else (part[:, :, None] == np.arange(n)) & use[:, :, None]

    def imu_at(self, offset: float, use: np.ndarray | None = None):
        """``(use, windows, ints)`` at ``offset`` s: the pings ``use`` (win, window; default :meth:`pings`), True at
        the windows with pings to fit, and the IMU's integrals ``F``, ``W``, ``M``, ``omega`` at those windows' pings
        (None when no window has any). Models of the same DVL stamps and IMU integrals, whose velocities differ
        only by a turn, share them (pass as ``at`` to :meth:`score`): interpolating them is most of a score's cost."""
        imu = self.imu
        # a mask given is cut at the IMU's gaps as the model's own is: the DVL checks' too, which held samples misled
        use = self.pings(offset) if use is None else self.at_imu_gaps(offset, use)
        windows = use.any(axis=1)
        if not windows.any():
            return use, windows, None
        tq, shape = (self.t + offset)[windows].reshape(-1), (-1, self.window, 3)
        F, W, w, M = imu.at(tq)
        return use, windows, (F.reshape(shape), W.reshape(shape), M.reshape(*shape, 3), w.reshape(shape))

    def terms(self, offset: float, use: np.ndarray | None = None, at=None):
        """At ``offset`` s, over the pings ``use`` (win, window; default :meth:`pings`; or :meth:`imu_at`'s ``at``):
        True at the windows with pings to fit, and for those the velocity ``v``, ``int omega x v``, ``int f_b``,
        ``omega_j x l`` (each (win, window, 3)), the gravity regressor ``int R^T`` centred per window (win, window*3,
        3; with more columns where a window is cut at an IMU gap, :meth:`segments`) and the pings fitted (win,
        window) (pass them to :func:`without_window_fit`); None for the rest when no window has any."""
        use, windows, ints = self.imu_at(offset, use) if at is None else at
        if ints is None:
            return windows, None
        F, W, M, w = ints
        parts = self.segments(offset, use)
        v, use = self.v[windows], use[windows]
        rot = np.cross(np.diff(W, axis=1), self.v_mid[windows])       # omega x v over each ping interval
        C = np.concatenate([np.zeros((len(v), 1, 3)), np.cumsum(rot, axis=1)], axis=1)
        if parts is None:
            Mc = M - M.mean(axis=1, keepdims=True) if use.all() else centred(M, use)
            A = Mc.reshape(len(v), -1, 3)
        else:
            A = _parts_regressor(M, use, parts[windows])
        return windows, (v, C, F, np.cross(w, self.lever), A, use)

    def sse(self, offset: float, use: np.ndarray | None = None, at=None) -> tuple[np.ndarray, np.ndarray]:
        """(SSE per window, True at the windows with pings to fit) at ``offset`` s over the pings ``use`` (default
        :meth:`pings`; or :meth:`imu_at`'s ``at``)."""
        windows, terms = self.terms(offset, use, at)
        out = np.full(len(self.t), np.nan)
        if terms is None:
            return out, windows
        v, C, F, lever, A, fitted = terms
        r = without_window_fit(v - lever - F + C, A, fitted)
        out[windows] = np.sum(r ** 2, axis=1)
        return out, windows

    def null_sse(self, use: np.ndarray, parts: np.ndarray | None = None) -> np.ndarray:
        """The straight-line SSE per window (win,) over the pings ``use`` (win, window): one line per part of a
        window cut at an IMU gap (``parts``, :meth:`segments`)."""
        out = self.sse_null_w.copy()
        part = use.any(axis=1) & ~use.all(axis=1)
        split = np.zeros_like(part) if parts is None else parts.any(axis=1).sum(axis=1) > 1
        if (part & ~split).any():
            out[part & ~split] = _line_sse(self.t[part & ~split], self.v[part & ~split], use[part & ~split])
        if split.any():
            out[split] = 0.0
            for k in range(parts.shape[2]):
                has = split & parts[:, :, k].any(axis=1)
                out[has] += _line_sse(self.t[has], self.v[has], parts[has, :, k])
        return out

    def score(self, offset: float, use: np.ndarray | None = None, at=None) -> tuple[float, float, int]:
        """(explained fraction 1 - SSE/SSE_null, SSE, windows) at ``offset`` s over the pings ``use`` (default
        :meth:`pings`; or :meth:`imu_at`'s ``at``, shared with another model)."""
        at = self.imu_at(offset, use) if at is None else at
        use = at[0]
        sse, windows = self.sse(offset, at=at)
        if windows.sum() < 2:
            return -np.inf, np.inf, 0
        null = float(np.sum(self.null_sse(use, self.segments(offset, use))[windows]))
        total = float(np.sum(sse[windows]))
        return 1.0 - total / max(null, 1e-12), total, int(windows.sum())


def _parts_regressor(M: np.ndarray, use: np.ndarray, parts: np.ndarray) -> np.ndarray:
    """The gravity regressor (win, window*3, 3 * (2 n - 1)) of windows cut at IMU gaps into the ``n`` parts ``parts``
    (win, window, n; :meth:`_WindowModel.segments`) over the pings ``use`` (win, window), from the integrals ``int R^T
    dt`` ``M`` (win, window, 3, 3; s) at them: each part's ``M`` centred over it (a ``g0`` each: across the gap the
    integrals turn the attitude by what the held sample made up) and, for each part but the first, its indicator
    centred over the window (a ``v0`` each: the gap's made-up velocity change), all zero off the part. Centred over
    the window's pings, it fits as :func:`without_window_fit` takes ``A``: with the window's mean, each part's own."""
    def about_mean(x, w):
        w = w.reshape(w.shape + (1,) * (x.ndim - 2))
        return np.where(w, x - np.sum(x * w, axis=1, keepdims=True) / np.maximum(np.sum(w, axis=1, keepdims=True),
                                                                                  1), 0.0)
    n, eye = parts.shape[2], np.eye(3)
    cols = [about_mean(M, parts[:, :, k]) for k in range(n)]
    cols += [about_mean(parts[:, :, k, None, None] * eye, use) for k in range(1, n)]
    return np.concatenate([c.reshape(len(M), -1, 3) for c in cols], axis=2)


def _line_sse(t: np.ndarray, v: np.ndarray, use: np.ndarray) -> np.ndarray:
    """The SSE (win,) of a straight line fitted per window to the velocity ``v`` (win, window, 3; m/s) at stamps ``t``
    (win, window; s) over the pings ``use`` (win, window)."""
    tc, vc = centred(t, use), centred(v, use)
    slope = np.einsum("wk,wki->wi", tc, vc) / np.sum(tc ** 2, axis=1, keepdims=True)
    return np.sum((vc - tc[..., None] * slope[:, None]) ** 2 * use[..., None], axis=(1, 2))


def with_enough_pings(use: np.ndarray) -> np.ndarray:
    """``use`` (win, window) without the windows left fewer than :data:`MIN_WINDOW_PINGS` (all of a window's when
    it is shorter)."""
    return use & (use.sum(axis=1, keepdims=True) >= min(MIN_WINDOW_PINGS, use.shape[1]))


def dvl_window_model(imu, dvl, config=None, lever_arm_b=None, window_pings: int | None = None,
                     transform: np.ndarray | None = None, ints: ImuIntegrals | None = None, trim: bool = False,
                     max_gap_s: float = MAX_WINDOW_GAP_S) -> tuple[_WindowModel, np.ndarray]:
    """The :class:`_WindowModel` of a DVL against an IMU (arguments as :func:`estimate_dvl_clock_offset`'s; the
    body-frame velocity multiplied by the (3,3) ``transform`` when given; ``ints``: the IMU's integrals when another
    model of the same IMU has them; ``trim``: windows trimmed at the IMU's ends, the class's; ``max_gap_s``: the windows
    cut at gaps over it, s, or over :data:`GAP_PERIODS` ping periods where that is longer) and the stamps of the pings
    it uses, s.

    Raises:
        DataError: fewer than two windows of pings with a velocity.
    """
    t_dvl, v = dvl_velocity_b(dvl, config)
    if transform is not None:
        v = v @ np.asarray(transform, float).T
    period = float(np.median(np.diff(t_dvl))) if len(t_dvl) > 1 else np.nan
    window = window_pings or max(6, int(round(WINDOW_S / period))) if np.isfinite(period) else 6
    if len(t_dvl) < 2 * window:
        raise DataError(f"{len(t_dvl)} DVL ping(s) with a velocity: too few to find a clock offset (need "
                        f"{2 * window})", dvl.source, field="t")
    if lever_arm_b is None:
        lever_arm_b = np.zeros(3) if config is None else config.dvl.lever_arm_b
    ints = imu_integrals(imu.t, imu.f_b, imu.omega_b) if ints is None else ints
    # a DVL pinging slower is cut at a missed ping, not at every step
    max_gap_s = max(max_gap_s, GAP_PERIODS * period) if np.isfinite(period) else max_gap_s
    return _WindowModel(ints, t_dvl, v, np.asarray(lever_arm_b, float), window, trim, max_gap_s), t_dvl


def outage_cut_model(imu, dvl, config=None, **kwargs) -> _WindowModel:
    """:func:`dvl_window_model` (its arguments) with its windows cut at steps between pings over
    :data:`MAX_CLOCK_GAP_S`, or over :data:`MAX_WINDOW_GAP_S` where the shorter cut leaves under two windows
    (:func:`across_outages_model`): the model the clock search scores offsets on
    (:func:`graphnav.calibration.clock.clock_model`) and the DVL speed check fits its scale on
    (:func:`graphnav.calibration.dvl_scale.check_velocity_against_imu`).

    A DVL pinging in bursts of 5 pings between 6-10 s pauses has no 6 pings between two steps over 5 s, and was
    refused as too broken up for its clock where windows across the pauses find it 0.3-0.4 s off (600 s simulated, a
    day off). Across a 7 s outage a 20 s window's ``int omega x v`` holds the velocity through it: a 60 s A-KIT piece
    (Trajectory3 from 120 s, 6 pings dropped after the 37th, a day off) fitted its speed 1.48x the IMU's 9.5 s off its
    clock and was refused as in a wrong unit; cut at 5 s, 1.12x at -0.5 s. The turn fit keeps the 20 s windows no such
    step crosses (:data:`MAX_TURN_GAP_S`): on the shorter windows the cut leaves, a 60 s piece with a 10-ping outage
    (Trajectory5 from 240 s) fitted a 13 deg turn (sigma 8 deg) and was refused as a yawed DVL.

    Raises:
        DataError: fewer than two windows of pings with a velocity.
    """
    model, _ = dvl_window_model(imu, dvl, config, max_gap_s=MAX_CLOCK_GAP_S, **kwargs)
    if len(model.t) >= 2:
        return model
    return across_outages_model(imu, dvl, config, model, kwargs.get("transform"))


def across_outages_model(imu, dvl, config, model: _WindowModel, transform: np.ndarray | None = None) -> _WindowModel:
    """The window model ``model`` of ``imu``, ``dvl`` and ``config`` (the velocity multiplied by ``transform`` as
    it was built with) with its windows cut only at steps between pings over :data:`MAX_WINDOW_GAP_S` (its IMU
    integrals, lever arm, window and trim kept)."""
    return dvl_window_model(imu, dvl, config, model.lever, model.window, transform=transform, ints=model.imu,
                            trim=model.trim, max_gap_s=MAX_WINDOW_GAP_S)[0]


def search_overlap(span_imu: float, span_dvl: float, window_s: float, min_overlap_s: float = MIN_OVERLAP_S) -> float:
    """The overlap (s) a clock search asks of the two logs (spans in s) at a candidate offset: ``min_overlap_s``
    and :data:`MIN_OVERLAP_FRACTION` of the shorter log (the two logs of one mission overlap mostly; a candidate
    sharing only a sliver scores on a few windows and can win by chance: a 1 h log six days away did, 3538 s off),
    but at most the shorter log less a window (``window_s``)."""
    shorter = min(span_imu, span_dvl)
    return min(max(min_overlap_s, MIN_OVERLAP_FRACTION * shorter), shorter - window_s)


def offset_grid(t_imu: np.ndarray, t_other: np.ndarray, min_overlap_s: float, period: float, name: str, source: str,
                search_s: tuple[float, float] | None = None) -> tuple[float, np.ndarray]:
    """``(step, offsets)``, s: every offset (added to ``t_other`` to put it on the IMU clock) at which the two logs
    share ``min_overlap_s`` (within ``search_s`` when given), on a grid of half the stream's ``period`` (coarser for
    long logs, at most 4000 steps).

    Raises:
        DataError: the logs are too short to share ``min_overlap_s`` at any offset, naming ``name`` and ``source``.
    """
    lo = float(t_imu[0] - t_other[-1]) + min_overlap_s
    hi = float(t_imu[-1] - t_other[0]) - min_overlap_s
    if search_s is not None:
        lo, hi = max(lo, search_s[0]), min(hi, search_s[1])
    h = max(0.5 * period, (hi - lo) / 4000)
    # offsets relative to the one that puts the two starts together: a grid of absolute offsets days long
    # would lose the step's digits
    start = float(t_imu[0] - t_other[0])
    grid = start + np.arange(lo - start, hi - start + 0.5 * h, h)
    if grid.size == 0:
        raise DataError(f"the IMU ({t_imu[-1] - t_imu[0]:.0f} s) and {name} ({t_other[-1] - t_other[0]:.0f} s) logs "
                        f"are too short to share {min_overlap_s:.0f} s at any offset", source, field="t")
    return h, grid


def refine_reach(model, coarse: float, h: float) -> tuple[float, np.ndarray]:
    """``(reach, use)``: how far (s) either way of the coarse offset ``coarse`` (grid step ``h``, s) the clock fit of
    ``model`` refines it, and the pings it fits there, the same at every offset it tries (``model.pings_over``): one
    that left some out would fit the rest better. Two grid steps each way: a ping entering the span moves the coarse
    scores by its share (a 60 s simulated log's best lay 0.7 s from its coarse offset). Where the IMU's gaps sweep
    over so many pings on that reach that it keeps under :data:`REFINE_MIN_SHARE` of those fitted at the coarse offset
    (0.4 s of IMU rows missing every 7 s beside 1 Hz pings: none in a part of 6 pings between two gaps, and the fit
    stopped at the reach's end, +1 s, on every log), the reach of a grid step, a half or a quarter that keeps most of
    them is taken (:func:`refined_offset` moves it along); where none keeps two windows, the coarse offset stands (reach
    0)."""
    kept = []
    for reach in (2 * h, h, h / 2, h / 4):
        use = model.pings_over(coarse - reach, coarse + reach)
        if np.count_nonzero(use.any(axis=1)) >= 2:
            kept.append((reach, use))
    if not kept:
        return 0.0, model.pings(coarse)
    reach, use = kept[0]
    if not len(model.imu.gaps) or use.sum() >= REFINE_MIN_SHARE * model.pings(coarse).sum():
        return reach, use
    return max(kept, key=lambda k: int(k[1].sum()))


def refined_offset(model, coarse: float, h: float, cost=None, xatol: float = 1e-4) -> tuple[float, np.ndarray]:
    """``(x, use)``: the clock fit's offset (s) refined from the coarse offset ``coarse`` (grid step ``h``, s) to
    ``xatol`` (s) by minimising ``model``'s residual (or ``cost(offset, use)``: the earth-frame check's readings) over
    the pings ``use`` (win, window), the same at every offset tried (:func:`refine_reach`). A reach narrowed for the
    IMU's gaps is centred again on its fit, with the pings kept over it there, until the fit lies within
    :data:`REFINE_SETTLED_S` of its centre (or the reach would pass the full two grid steps from ``coarse``): the pings
    a reach keeps pull its fit towards its centre, and one stopped at its end or off its centre is not the offset the
    pings about it put. The ten A-KIT column maps with 0.4 s of IMU rows missing every 7 s were fitted on the +-0.5 s
    reach alone (under half their pings): 0.01-0.34 s from their gapless offsets (sigma 0.02-0.05 s); on +-0.125 s
    moved until settled, 0.004-0.10 s (Trajectory1 -0.103 s, Trajectory13 +0.087 s, the other eight within 0.035 s).
    A moved reach stopped where its fit lay anywhere inside it left Trajectory6 0.175 s off: each reach centred from
    there on found the fit further along, to its gapless offset."""
    reach, use = refine_reach(model, coarse, h)
    if reach == 0.0:
        return coarse, use
    cost = cost or (lambda o, pings: model.score(o, pings)[1])
    centre = coarse
    for _ in range(REFINE_MAX_MOVES):
        x = float(minimize_scalar(lambda o: cost(o, use), bounds=(centre - reach, centre + reach), method="bounded",
                                  options={"xatol": xatol}).x)
        there = float(np.clip(x, coarse - 2 * h + reach, coarse + 2 * h - reach))
        if reach == 2 * h or abs(there - centre) < REFINE_SETTLED_S:
            return x, use
        moved = model.pings_over(there - reach, there + reach)
        if np.count_nonzero(moved.any(axis=1)) < 2:
            return x, use
        centre, use = there, moved
    return x, use


def speed_scale(model, offset: float = 0.0, gapless: bool = False) -> tuple[float, float, float]:
    """``(scale, r2, yaw)``: the DVL's horizontal velocity over the one the IMU's integrals say (1 for a right unit),
    the share of the variance the fit explains, and the angle the DVL's horizontal axes are turned by (rad, about
    z: a mounting yaw turns the velocity, it does not scale it), over the model's windows inside the IMU span at
    ``offset`` s (NaN without two; ``gapless``: only those with no step beyond :data:`MAX_TURN_GAP_S`). The
    horizontal parts are complex numbers ``x + iy``: the DVL side regressed on the IMU side gives
    ``scale * exp(i yaw)``."""
    sides = _horizontal_sides(model, offset, gapless)
    if sides is None:
        return float("nan"), float("nan"), float("nan")
    a, b = sides
    ab, aa, bb = np.vdot(b, a), float(np.vdot(a, a).real), float(np.vdot(b, b).real)
    return abs(ab) / max(bb, 1e-300), abs(ab) ** 2 / max(aa * bb, 1e-300), float(np.angle(ab))


def best_speed_fit(model, offsets, gapless: bool = False) -> tuple[int, list[tuple[float, float, float]]]:
    """``(best, fits)``: :func:`speed_scale`'s ``(scale, r2, yaw)`` at each DVL clock offset of ``offsets`` (s; with
    ``gapless`` as there), and the index of the one whose fit explains most of the velocity's changes (a NaN ``r2``,
    under two windows, explains none)."""
    fits = [speed_scale(model, o, gapless) for o in offsets]
    return int(np.argmax([np.nan_to_num(f[1], nan=-1.0) for f in fits])), fits


def fits_turned_elsewhere(fits: list, best: int) -> bool:
    """Whether the scale fits (:func:`speed_scale`'s, one per offset of a search) explain the velocity's changes as
    well as the best (index ``best``: :data:`MIN_SCALE_R2`, or within :data:`TURNED_FIT_RATIO` of its unexplained
    share) at an offset whose turn lies over 90 deg from the best's: the fit's r^2 is blind to a velocity's sign, and a
    speed swinging with a period (a vehicle surging in waves) fits half a period off turned 180 deg as well as on time
    (straight legs at 1 m/s surging 0.1-0.5 m/s every 8-20 s: r^2 within 0.01 of the best there), so the best offset,
    which noise picks, fixes neither the clock nor the sign of the velocity's changes."""
    yaws = np.array([f[2] for f in fits])
    r2 = np.array([f[1] for f in fits])
    turned = np.abs(np.angle(np.exp(1j * (yaws - yaws[best])))) > np.pi / 2      # NaN yaw: False
    return bool(np.any(turned & fits_as_well(r2, r2[best])))


def fits_as_well(r2, best_r2: float):
    """Whether scale fits of r^2 ``r2`` (:func:`speed_scale`'s; NaN: none) explain the velocity's changes as well as
    the best, of ``best_r2``: :data:`MIN_SCALE_R2`, or within :data:`TURNED_FIT_RATIO` of its unexplained share."""
    r2 = np.nan_to_num(np.asarray(r2, float), nan=-1.0)
    return (r2 >= MIN_SCALE_R2) | (1.0 - r2 <= TURNED_FIT_RATIO * (1.0 - best_r2))


def within_half_turn(yaw: float) -> float:
    """A turn about z (rad) known only up to 180 deg (:func:`fits_turned_elsewhere`): the one within +-90 deg."""
    return float(np.angle(np.exp(2j * yaw)) / 2.0)


def _horizontal_sides(model, offset: float, gapless: bool = False):
    """``(a, b)``, complex (win, pings): the DVL side and the IMU side of the clock model's windows inside the IMU
    span at ``offset`` s (``gapless``: only those with no step beyond :data:`MAX_TURN_GAP_S`), each window's ``v0``
    and ``g0`` taken out, horizontally as ``x + iy`` (m/s); None without two windows."""
    inside, terms = model.terms(offset)
    if terms is None or inside.sum() < 2:
        return None
    v, C, F, lever, A, fitted = terms
    a = without_window_fit(v + C, A, fitted).reshape(len(v), -1, 3)
    b = without_window_fit(F + lever, A, fitted).reshape(len(v), -1, 3)
    if gapless:
        keep = ~spans_outage(model.t[inside], model.real[inside])
        if keep.sum() < 2:
            return None
        a, b = a[keep], b[keep]
    return a[..., 0] + 1j * a[..., 1], b[..., 0] + 1j * b[..., 1]


def spans_outage(t: np.ndarray, real: np.ndarray) -> np.ndarray:
    """(win,) bool: which windows of pings stamped ``t`` (win, n) s (``real`` False at a window's padding) have a step
    between pings beyond :data:`MAX_TURN_GAP_S`."""
    steps = np.diff(t, axis=1)
    return np.any((steps > MAX_TURN_GAP_S) & real[:, 1:], axis=1)


def yaw_sigma(model, offset: float = 0.0) -> tuple[float, float]:
    """``(yaw, sigma)``, rad: :func:`speed_scale`'s yaw and its standard error with the windows taken as the
    independent samples (the pings within a window share the IMU side's integrated noise and a misfitted gravity):
    the larger of the spread of the windows' own fits (the clustered sandwich of ``sum conj(b) a``) and the fit's
    least-squares error with one sample per window (``sqrt((1 - r^2) / (2 r^2 windows))``), which holds when a few
    windows happen to agree. NaN without two windows."""
    return turn_at(model, offset)[:2]


def turn_at(model, offset: float = 0.0) -> tuple[float, float, float]:
    """:func:`turn_fit`'s ``(yaw, sigma, r2)`` of the clock model's horizontal sides at ``offset`` s, over its windows
    with no step beyond :data:`MAX_TURN_GAP_S`."""
    sides = _horizontal_sides(model, offset, gapless=True)
    if sides is None:
        return float("nan"), float("nan"), float("nan")
    a, b = sides
    return turn_fit(np.sum(np.conj(b) * a, axis=1), float(np.vdot(a, a).real), float(np.vdot(b, b).real))


def turn_fit(z: np.ndarray, aa: float, bb: float) -> tuple[float, float, float]:
    """``(yaw, sigma, r2)``: the turn about z (rad) of a horizontal velocity ``a`` against ``b`` (complex, ``x + iy``)
    from the windows' sums ``z`` = sum of ``conj(b) a`` over each window's pings, ``aa`` = sum of ``|a|^2`` and ``bb``
    = sum of ``|b|^2`` over all pings; its standard error with the windows as the independent samples (the larger of
    the windows' spread and the fit's least-squares error, :func:`yaw_sigma`) and the share of variance it explains.
    NaN under two windows."""
    total, n = z.sum(), len(z)
    if n < 2:
        return float("nan"), float("nan"), float("nan")
    r2 = abs(total) ** 2 / max(aa * bb, 1e-300)
    spread = n / (n - 1) * np.sum((z / total).imag ** 2) if abs(total) else np.inf
    fit = (1.0 - r2) / max(2.0 * r2 * n, 1e-300)
    return float(np.angle(total)), float(np.sqrt(max(spread, fit))), float(r2)
