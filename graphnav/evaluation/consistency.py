"""Covariance consistency: velocity, horizontal position and heading NEES statistics, their chi-square band,
and the reference's own error.

NEES ``e^T P^-1 e`` of a 3-D velocity error is chi-square with 3 dof for a consistent estimator; the mean of
K independent epochs lies in ``chi2.ppf([0.025, 0.975], 3K) / K`` with 95 % probability. Navigation errors
are correlated in time, so K is the number of *independent* epochs, not the number of samples: this module
counts one per :func:`decorrelation_time` of the run's own normalised error (at least 10 s; the velocity
error of the smoothers stays correlated for tens of seconds) -- a wider, honest band.

The reference is not perfect: the A-KIT ground truth (Phins INS + DVL + GNSS) has its own velocity error. If
``Sigma_gt`` is its covariance (NED, (m/s)^2), the error we compute is ``e = e_est - e_gt`` and its covariance
``P + Sigma_gt`` (the GT is independent of our beams' synthetic noise). ``nees_with_reference`` scores
against that; the difference to the plain NEES is the part of the NEES the GT explains.

The reference *between* its samples is a second, larger error. The A-KIT GT is sampled at 1 Hz and the
estimators' epochs (the DVL pings) fall 0.2-0.8 s from a GT sample; a linear interpolation of the GT velocity
misses whatever the vehicle did within the second. At the surface (Trajectory11, waves: body rates 5-15
deg/s) the linearly interpolated GT and the recorded DVL differ by 0.06 / 0.10 / 0.14 m/s RMS (body x, y, z);
carrying the GT samples to the ping with the IMU (:func:`imu_carried_reference`: strapdown from the GT
samples either side, blended, as the time-offset calibration's
:class:`graphnav.calibration.reference.Reference`) brings that to 0.025 / 0.024 / 0.013 m/s,
and submerged the vertical from 0.023 to 0.003 m/s (``graphnav consistency --reference-check``). The NEES
of the benchmark is therefore scored against the IMU-carried reference; the velocity RMSE keeps the plain
interpolation (comparable with earlier results). The IMU's own error over at most a second (white 8.2e-4
m/s^2/sqrt(Hz) identified, 3.5e-3 as the estimators model it: 0.001-0.003 m/s; bias 50 micro-g: 5e-4 m/s) is
small against the estimators' velocity sigmas; it is partly the estimators' error too, which lowers the NEES
slightly (not measured separately).

Position and heading (:func:`pose_nees`): the horizontal position NEES has 2 dof (north, east: the depth is
measured directly, see :func:`graphnav.evaluation.metrics.nees_position`), the heading NEES 1 dof (the yaw
error wrapped across +-pi against the heading variance of the attitude covariance). Both errors are integrals
(of the velocity error, of the gyro bias) and stay correlated longer still. For all three the independent
epochs of the band are counted one per :func:`decorrelation_time` of the normalised error (its
autocorrelation's e-folding lag, at least 10 s; the whole span when it never decorrelates, i.e. one epoch and
the widest band). The velocity error too stays correlated for tens of seconds (its DVL error states, the IMU's
bias): on 16 simulated missions one epoch per 10 s put 4 to 10 of 16 mission NEES inside a 95 % band
(``experiments/velocity_band_coverage.py``). The reference is the GT's position
(not corrected for the GT's own error, see :mod:`graphnav.evaluation.metrics`) and the same reference attitude
the velocity NEES uses.

The velocity NEES is also split along the vehicle's body axes (:func:`body_axis_nees`): a mean near 3 can hide an
estimate over-confident along one axis and under-confident across another, and where it is wrong tells why (on the
ten shared trajectories the vertical is at 0.4: their depth is the GT's own, without the depth sensor's noise).
"""
from __future__ import annotations

import numpy as np

from graphnav.core.mission import GroundTruth
from graphnav.core.solution import NavSolution
from graphnav.core.timeseries import finite_rows, interp_rows
from graphnav.evaluation.metrics import (
    _window,
    heading_errors,
    nees_heading,
    nees_position,
    nees_velocity,
    scored,
)

#: dof of the velocity NEES.
DOF = 3
#: The body axes (FRD) of :func:`body_axis_nees`.
BODY_AXES = ("forward", "starboard", "down")
#: dof of the horizontal position NEES (north, east).
POSITION_DOF = 2
#: dof of the heading NEES.
HEADING_DOF = 1
#: Shortest decorrelation time counted, s.
MIN_DECORRELATION_S = 10.0


def chi2_band(n_independent: int, dof: int = DOF, prob: float = 0.95) -> tuple[float, float]:
    """(low, high) of the mean NEES of ``n_independent`` epochs with probability ``prob``."""
    n = max(int(n_independent), 1)
    from scipy.stats import chi2    # here, not at import: scipy.stats takes ~1 s to import (CLI start-up)
    lo, hi = chi2.ppf([(1 - prob) / 2, (1 + prob) / 2], dof * n)
    return float(lo / n), float(hi / n)


def outside_band(mean: float, band, why: bool = True) -> str | None:
    """Which side of its 95 % ``band`` (low, high) a mean NEES lies and what that says (with ``why``, in words of
    sigma and error), or None inside it (or for a mean that is not finite). Below: the claimed covariance is
    larger than the errors (under-confident, the safe side; e.g. a heading sigma held at its prior on a run
    started from the reference); above: smaller (over-confident)."""
    lo, hi = band
    if not np.isfinite(mean) or lo <= mean <= hi:
        return None
    if mean < lo:
        return "below its band: under-confident" + (", the claimed sigma is larger than the error" if why else "")
    return "above its band: over-confident" + (", the error is larger than the claimed sigma" if why else "")


def n_independent(t: np.ndarray, decorrelation_s: float = 10.0) -> int:
    """Independent epochs in the stamps ``t`` (s): one per ``decorrelation_s``, at least 1."""
    t = np.asarray(t, dtype=float)
    if t.size == 0:
        return 0
    return max(1, int((t[-1] - t[0]) // decorrelation_s) + 1)


def decorrelation_time(t: np.ndarray, z: np.ndarray, floor_s: float = MIN_DECORRELATION_S) -> float:
    """Decorrelation time, s, of a normalised error series ``z`` (K,) or (K,d) at stamps ``t`` (K,) s: the
    first lag at which its autocorrelation (summed over the columns) falls below 1/e, at least ``floor_s``;
    the whole span when it never does. Non-finite rows are dropped. The mean is not removed: a consistent
    estimator's error has zero mean, and an error that keeps its sign for long is one correlated error, not
    many independent ones."""
    t = np.asarray(t, dtype=float)
    z = np.asarray(z, dtype=float).reshape(len(t), -1)
    ok = np.all(np.isfinite(z), axis=1)
    t, z = t[ok], z[ok]
    if len(t) < 3:
        return floor_s
    span, dt = float(t[-1] - t[0]), float(np.median(np.diff(t)))
    n = len(z)
    spec = np.fft.rfft(z, 2 * n, axis=0)
    acf = np.fft.irfft(spec * np.conj(spec), axis=0)[:n].sum(axis=1)
    if not acf[0] > 0:
        return max(floor_s, span)
    below = np.flatnonzero(acf / acf[0] < np.exp(-1.0))
    return max(floor_s, span if below.size == 0 else float(below[0]) * dt)


#: What :func:`_nees_stats` says of one NEES, after its prefix (``nees``, ``nees_pos``, ``nees_heading``).
NEES_STATS = ("mission", "n_independent", "decorrelation_s", "epochs_without_sigma", "epochs_lost")


def _nees_stats(t: np.ndarray, nees: np.ndarray, z: np.ndarray, prefix: str, estimate_ok: np.ndarray) -> dict:
    """``{prefix}_mission``: mean of the per-epoch NEES; ``{prefix}_n_independent``: one per
    :func:`decorrelation_time` of the normalised error ``z``; ``{prefix}_decorrelation_s``. Two kinds of epoch
    have no NEES, and each is counted: one whose estimate is finite but its covariance not (a file's empty sigma
    columns: ``{prefix}_epochs_without_sigma``) is left out of the mean; one whose estimate is not finite (the
    estimator lost track: ``{prefix}_epochs_lost``, ``estimate_ok`` False) leaves the mean NaN -- never a number
    from part of the run. ``{prefix}_mission`` None when no epoch has a NEES and none is lost (every epoch
    without a sigma, or none scored)."""
    ok = np.isfinite(nees)
    lost = ~np.asarray(estimate_ok, bool)
    out = {f"{prefix}_{k}": None for k in NEES_STATS}
    out[f"{prefix}_epochs_without_sigma"] = int(np.sum(~ok & ~lost))
    out[f"{prefix}_epochs_lost"] = int(np.sum(lost))
    if not ok.any():
        if lost.any():                  # no number, and a band of one epoch for callers that print one
            out[f"{prefix}_mission"], out[f"{prefix}_n_independent"] = float("nan"), 1
        return out
    tau = decorrelation_time(t[ok], z[ok])
    out.update({f"{prefix}_mission": scored_mean(nees, ~lost),
                f"{prefix}_n_independent": n_independent(t[ok], tau), f"{prefix}_decorrelation_s": tau})
    return out


def _velocity_ok(sol: NavSolution, rows: np.ndarray) -> np.ndarray:
    """Per row of ``sol`` in ``rows``: a finite velocity and attitude (the per-axis split needs the attitude, and
    an estimator without one has lost track), :func:`_nees_stats`'s ``estimate_ok`` of the velocity NEES."""
    return finite_rows(sol.v_n[rows]) & finite_rows(sol.C_b_n[rows])


def pose_nees(sol: NavSolution, reference: GroundTruth, t_start: float | None = None,
              t_end: float | None = None) -> dict:
    """Horizontal position NEES (2 dof) and heading NEES (1 dof) of ``sol`` against ``reference`` over
    ``[t_start, t_end]``: ``nees_pos_mission`` / ``nees_heading_mission`` (mean), ``*_n_independent`` (for
    :func:`chi2_band` with ``dof`` :data:`POSITION_DOF` / :data:`HEADING_DOF`), ``*_decorrelation_s``,
    ``*_epochs_without_sigma`` and ``*_epochs_lost`` (:func:`_nees_stats`'s rule); all None for a quantity whose
    covariance the solution does not carry (never a made-up number). The position is scored in the reference's
    frame and, for a solution started without its position, from the start
    (:func:`graphnav.evaluation.metrics.scored`)."""
    out = pose_nees_none()
    if sol.cov_p_n is None and sol.cov_rot_b is None:
        return out
    sol = scored(sol, reference)
    aligned, sel = _window(sol, reference, t_start, t_end)
    t = aligned.t[sel]
    if sol.cov_p_n is not None:
        nees = nees_position(sol, reference, t_start, t_end)
        p_n = sol.p_n[aligned.mask][sel, :2]
        err = p_n - aligned.p_true_n[sel, :2]
        var = np.diagonal(sol.cov_p_n[aligned.mask][sel][:, :2, :2], axis1=1, axis2=2)
        with np.errstate(invalid="ignore", divide="ignore"):
            out.update(_nees_stats(t, nees, err / np.sqrt(var), "nees_pos", finite_rows(p_n)))
    if sol.cov_rot_b is not None:
        nees = nees_heading(sol, reference, t_start, t_end)
        _, d = heading_errors(sol, reference, t_start, t_end)
        with np.errstate(invalid="ignore"):
            out.update(_nees_stats(t, nees, np.sign(d) * np.sqrt(nees), "nees_heading",
                                   finite_rows(sol.C_b_n[aligned.mask][sel])))
    return out


def pose_nees_none() -> dict:
    """The keys of :func:`pose_nees`, all None."""
    return {f"{q}_{k}": None for q in ("nees_pos", "nees_heading") for k in NEES_STATS}


def scored_mean(nees: np.ndarray, estimate_ok: np.ndarray) -> float | None:
    """Mean of a per-epoch NEES by :func:`_nees_stats`'s rule: NaN when an estimate is lost (``estimate_ok``
    False), else over the epochs with a NEES (those without a sigma left out); None without any."""
    if not np.all(estimate_ok):
        return float("nan")
    ok = np.isfinite(nees)
    return float(np.mean(nees[ok])) if ok.any() else None


def window_nees(sol: NavSolution, reference: GroundTruth, t_start: float, t_end: float) -> dict:
    """``nees_window``, ``nees_pos_window`` and ``nees_heading_window``: mean velocity / position / heading NEES
    over one window by :func:`scored_mean`'s rule (None without the covariance; a window without any NEES: the
    velocity's NaN, the others None, as the benchmark has always stored them)."""
    sol = scored(sol, reference)
    aligned, sel = _window(sol, reference, t_start, t_end)
    rows = np.flatnonzero(aligned.mask)[sel]
    out = {"nees_window": None, "nees_pos_window": None, "nees_heading_window": None}
    for key, cov, f, estimate_ok in (
            ("nees_window", sol.cov_v_n, nees_velocity, _velocity_ok(sol, rows)),
            ("nees_pos_window", sol.cov_p_n, nees_position, finite_rows(sol.p_n[rows, :2])),
            ("nees_heading_window", sol.cov_rot_b, nees_heading, finite_rows(sol.C_b_n[rows]))):
        if cov is not None:
            with np.errstate(invalid="ignore"):
                out[key] = scored_mean(f(sol, reference, t_start, t_end), estimate_ok)
    if sol.cov_v_n is not None and out["nees_window"] is None:
        out["nees_window"] = float("nan")
    return out


def nees_with_reference(sol: NavSolution, gt: GroundTruth, cov_gt_n: np.ndarray,
                        t_start: float | None = None, t_end: float | None = None) -> np.ndarray:
    """Per-epoch velocity NEES ``e^T (P + Sigma_gt)^-1 e`` with the reference's covariance ``cov_gt_n``
    (3,3) NED (m/s)^2 added to the solution's."""
    cov = np.asarray(cov_gt_n, dtype=float).reshape(3, 3)
    inflated = NavSolution(method=sol.method, t=sol.t, p_n=sol.p_n, v_n=sol.v_n, C_b_n=sol.C_b_n,
                           cov_v_n=sol.cov_v_n + cov[None], bias_acc=sol.bias_acc, bias_gyro=sol.bias_gyro)
    return nees_velocity(inflated, gt, t_start, t_end)


def nees_time_series(sol: NavSolution, gt: GroundTruth, t_start: float | None = None,
                     t_end: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(stamps s, NEES) of the solution epochs in ``[t_start, t_end]`` (for plots)."""
    aligned, sel = _window(sol, gt, t_start, t_end)
    return aligned.t[sel], nees_velocity(sol, gt, t_start, t_end)


def imu_carried_reference(sol_t: np.ndarray, mission) -> GroundTruth:
    """The mission's reference at the solution stamps ``sol_t`` (those inside the GT and IMU spans) as a
    :class:`GroundTruth` whose samples are those stamps: velocity and attitude from the IMU-aided
    interpolation of :class:`graphnav.calibration.reference.Reference` (the GT samples either side carried to
    the stamp by the IMU, blended; exact at the GT's samples), position interpolated linearly. Scoring a
    solution against it compares each epoch with the reference at that very stamp."""
    from graphnav.calibration.reference import mission_reference as imu_aided_reference
    gt = mission.gt
    ref = imu_aided_reference(mission)
    t = np.asarray(sol_t, dtype=float)
    t = t[ref.covers(t)]
    if t.size < 2:
        return gt
    return GroundTruth(t, interp_rows(t, gt.t, gt.p_n), ref.v_n(t), ref.C_b_n(t), gt.origin_lla,
                      source=f"{gt.source} (carried to the epochs by the IMU)")


def scoring_reference(sol: NavSolution, mission) -> GroundTruth:
    """The reference the NEES is scored against: the GT carried to the solution's epochs by the IMU
    (:func:`imu_carried_reference`; equal to the GT at epochs on its samples, as the simulated missions'
    pings are), or the GT itself when the mission has no IMU."""
    gt = mission.gt
    if mission.imu is None or len(gt.t) < 2:
        return gt
    return imu_carried_reference(sol.t, mission)


#: Seconds after the mission start left out of the mission NEES (initial convergence).
NEES_SETTLE_S = 60.0


def reference_nees(sol: NavSolution, gt: GroundTruth, mission=None, t0: float | None = None,
                   gt_sigma_n=None, reference: GroundTruth | None = None) -> dict:
    """The velocity NEES of ``sol`` as the benchmark and ``graphnav evaluate`` both report it.

    Args:
        sol: the solution (needs ``cov_v_n``).
        gt: its reference.
        mission: the mission ``gt`` belongs to, when there is one: the reference is then carried to the
            solution's epochs by the IMU (:func:`scoring_reference`); without it (a reference file) the
            reference is ``gt`` interpolated (:meth:`GroundTruth.at`).
        t0: the first stamp scored, s (None: ``gt.t[0] +`` :data:`NEES_SETTLE_S`).
        gt_sigma_n: (3,) m/s, the reference's own NED velocity sigma, or None.
        reference: the reference at the solution's epochs when the caller has it already
            (:func:`scoring_reference` of ``sol`` and ``mission``, or ``gt``); None: computed here.

    Returns:
        ``nees_mission`` (mean NEES after ``t0`` against the reference), ``nees_mission_interp`` (the same
        against the linearly interpolated GT), ``nees_mission_gt`` (the first with the reference's covariance
        added; None without ``gt_sigma_n``), ``nees_n_independent`` (one per ``nees_decorrelation_s``, the
        decorrelation time of the normalised velocity error, :func:`decorrelation_time`), ``nees_t0`` and
        ``nees_reference``
        (``"imu-carried"`` or ``"interpolated"``), ``nees_axes_b`` (:func:`body_axis_nees`, forward, starboard,
        down), ``nees_epochs_without_sigma`` (left out of every mean) and ``nees_epochs_lost`` (a non-finite
        velocity or attitude: every mean NaN), as :func:`_nees_stats` counts them; the NEES values None without a
        covariance.
    """
    t0 = float(gt.t[0] + NEES_SETTLE_S) if t0 is None else float(t0)
    out = {**{f"nees_{k}": None for k in NEES_STATS}, "nees_mission_interp": None, "nees_mission_gt": None,
           "nees_t0": t0, "nees_axes_b": None,
           "nees_reference": "interpolated" if mission is None else "imu-carried", **pose_nees_none()}
    if sol.cov_v_n is None and sol.cov_p_n is None and sol.cov_rot_b is None:
        return out
    if reference is None:
        reference = gt if mission is None else scoring_reference(sol, mission)
    out.update(pose_nees(sol, reference, t0))
    if sol.cov_v_n is None:
        return out
    # the velocity error is correlated for as long as the DVL's error states and the IMU's bias keep it: its
    # independent epochs are counted from its own decorrelation, as the position's and the heading's are
    aligned, sel = _window(sol, reference, t0, None)
    rows = np.flatnonzero(aligned.mask)[sel]
    cov = sol.cov_v_n[rows]
    err = sol.v_n[rows] - aligned.v_true_n[sel]
    var = np.diagonal(cov, axis1=1, axis2=2)
    nees = nees_velocity(sol, reference, t0)
    estimate_ok = _velocity_ok(sol, rows)
    with np.errstate(invalid="ignore", divide="ignore"):
        out.update(_nees_stats(aligned.t[sel], nees, err / np.sqrt(var), "nees", estimate_ok))
    if out["nees_mission"] is None:             # no epoch with a sigma, none lost: nothing to score
        return out
    out["nees_n_independent"] = out["nees_n_independent"] or 1
    # the same epochs for every variant: those with a sigma (a lost one leaves each of them NaN)
    scored = estimate_ok & finite_rows(cov) | ~estimate_ok
    out["nees_axes_b"] = body_axis_nees(err[scored], cov[scored], sol.C_b_n[rows][scored])
    out["nees_mission_interp"] = mean_velocity_nees(sol, gt, t0)
    if gt_sigma_n is not None:
        out["nees_mission_gt"] = mean_velocity_nees(sol, reference, t0, np.diag(np.square(gt_sigma_n)))
    return out


def mean_velocity_nees(sol: NavSolution, ref: GroundTruth, t0: float, cov_gt_n: np.ndarray | None = None) -> float:
    """Mean velocity NEES against ``ref`` after ``t0`` (s), with the reference's covariance ``cov_gt_n`` (3,3) NED
    (m/s)^2 added when given (:func:`nees_with_reference`), by :func:`scored_mean`'s rule (an epoch without a
    sigma left out, a lost one: NaN)."""
    aligned, sel = _window(sol, ref, t0, None)
    nees = nees_velocity(sol, ref, t0) if cov_gt_n is None else nees_with_reference(sol, ref, cov_gt_n, t0)
    return scored_mean(nees, _velocity_ok(sol, np.flatnonzero(aligned.mask)[sel]))


def body_axis_nees(err_n: np.ndarray, cov_v_n: np.ndarray, C_b_n: np.ndarray) -> list[float]:
    """Mean normalised squared velocity error along each body axis (:data:`BODY_AXES`; 1 each when consistent):
    ``(C_b_n^T e_n)_i^2 / (C_b_n^T P_n C_b_n)_ii`` over the epochs. ``err_n`` (K,3) m/s and ``cov_v_n`` (K,3,3)
    (m/s)^2 in NED, ``C_b_n`` (K,3,3) body-to-NED. Their sum is not the NEES (the axes' correlations are left out);
    a non-finite epoch leaves its axis's mean non-finite, as the NEES's."""
    err_b = np.einsum("kji,kj->ki", C_b_n, err_n)
    var_b = np.einsum("kji,kjl,kli->ki", C_b_n, cov_v_n, C_b_n)
    with np.errstate(invalid="ignore", divide="ignore"):
        return [float(v) for v in np.mean(err_b ** 2 / var_b, axis=0)]


def mission_nees(sol: NavSolution, mission, reference: GroundTruth | None = None) -> dict:
    """``nees_mission``: mean velocity NEES over the mission after :data:`NEES_SETTLE_S`, against the reference
    at the solution's epochs (:func:`scoring_reference`: a sparse GT carried to each epoch by the IMU);
    ``nees_mission_interp``: the same against the linearly interpolated GT (at the surface it is off by
    0.1 m/s); ``nees_mission_gt``: the first with the GT's own velocity error covariance added to the
    solution's (``mission.meta["gt_velocity_sigma_n"]``, m/s per NED axis, set by the A-KIT loader; None
    without it); ``nees_n_independent``: independent epochs for the chi-square band. One function
    (:func:`reference_nees`) for the benchmark and ``graphnav evaluate``. ``reference``: the scoring reference at
    the solution's epochs when the caller has carried it already (None: carried here)."""
    return reference_nees(sol, mission.gt, mission, mission.t0 + NEES_SETTLE_S,
                          mission.meta.get("gt_velocity_sigma_n"), reference=reference)
