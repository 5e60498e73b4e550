"""Accuracy metrics shared by every estimator, benchmark and test.

Time alignment is explicit: the ground truth is interpolated at the solution's stamps by
:meth:`graphnav.core.mission.GroundTruth.at` (linear for position and velocity, slerp for attitude); solution epochs outside the ground-truth time span are dropped
(never extrapolated). All errors are estimate minus truth in the local NED frame.

- VRMSE ``sqrt(mean_k |v_k - v_hat_k|^2)`` (m/s), the paper's velocity metric, over the solution epochs in a
  time window (the outage window or the whole mission).
- VRTE ``|VRMSE_model - VRMSE_ref| / VRMSE_ref * 100`` (%), the paper's improvement against a reference.
- Horizontal position error (m) at the end of a window, and its RMSE over a window.
- Velocity NEES ``e^T P^-1 e`` per epoch against the solution's ``cov_v_n`` (3 degrees of freedom).
- Horizontal position NEES (2 dof) against ``cov_p_n``'s north-east block and heading NEES (1 dof) against the
  heading variance of ``cov_rot_b`` (:func:`graphnav.core.rotations.heading_variance`), the heading error
  wrapped to (-pi, pi].
- Position drift in % of the horizontal distance travelled (% DT), per window and per mission.

The position reference is the ground truth's position. The A-KIT GT is the post-processed solution of an
iXblue INS with the same DVL (about 0.1 % DT submerged by its maker's figures, reset by GNSS at the surface); its
own position error is not subtracted. Over a 400 s A-KIT mission (600-900 m) that is well under a metre, and
over a 30 s window (30-75 m) a few centimetres; the estimators here drift metres per mission, so the GT's error
matters only for an estimator that reaches INS-grade drift. The GT and the estimators read the same IMU and
DVL, so the part of the GT's error they share is invisible here: % DT against this reference is a lower bound
of the drift against an independent one (e.g. USBL or GNSS at the surface).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from graphnav.core.errors import DataError
from graphnav.core.mission import GroundTruth
from graphnav.core.rotations import heading_variance
from graphnav.core.solution import FRAME_FIRST_FIX, NavSolution
from graphnav.core.timeseries import finite_rows, interp_rows


@dataclass
class Aligned:
    """Ground truth at the solution epochs that lie inside the ground-truth span.

    Attributes:
        t: (K',) stamps kept, s.
        v_true_n: (K',3) NED velocity, m/s.
        p_true_n: (K',3) NED position, m.
        C_true_b_n: (K',3,3) body-to-NED rotation.
        mask: (K,) bool over the solution epochs, True where kept.
    """

    t: np.ndarray
    v_true_n: np.ndarray
    p_true_n: np.ndarray
    C_true_b_n: np.ndarray
    mask: np.ndarray


def align(solution: NavSolution, gt: GroundTruth) -> Aligned:
    """Ground truth at the solution's stamps; epochs outside the ground-truth span are dropped."""
    mask = (solution.t >= gt.t[0]) & (solution.t <= gt.t[-1])
    t = solution.t[mask]
    p, v, C = gt.at(t)
    return Aligned(t, v, p, C, mask)


def _window(solution: NavSolution, gt: GroundTruth, t_start: float | None, t_end: float | None):
    """Aligned truth and the boolean selection (over the aligned epochs) of ``t_start <= t <= t_end``."""
    aligned = align(solution, gt)
    sel = np.ones(len(aligned.t), dtype=bool)
    if t_start is not None:
        sel &= aligned.t >= t_start
    if t_end is not None:
        sel &= aligned.t <= t_end
    if not sel.any():
        raise DataError(f"no solution epoch inside [{t_start}, {t_end}] s and the ground truth span",
                        solution.method, field="t")
    return aligned, sel


def velocity_errors(solution: NavSolution, gt: GroundTruth) -> tuple[np.ndarray, np.ndarray]:
    """(t (K',), v_hat - v_true (K',3) m/s NED) at the aligned epochs."""
    aligned = align(solution, gt)
    return aligned.t, solution.v_n[aligned.mask] - aligned.v_true_n


def vrmse(solution: NavSolution, gt: GroundTruth, t_start: float | None = None,
          t_end: float | None = None) -> float:
    """Velocity RMSE (m/s) of the NED velocity over the solution epochs in ``[t_start, t_end]``."""
    aligned, sel = _window(solution, gt, t_start, t_end)
    err = solution.v_n[aligned.mask][sel] - aligned.v_true_n[sel]
    return float(np.sqrt(np.mean(np.sum(err ** 2, axis=1))))


def vrte(model_vrmse: float, ref_vrmse: float) -> float:
    """Velocity RMSE improvement (%) of a model against a reference, ``|model - ref| / ref * 100``.

    As in the paper this is an absolute value; compare the VRMSEs themselves to see which is better.
    """
    if not ref_vrmse > 0:
        raise ValueError(f"reference VRMSE must be > 0, got {ref_vrmse}")
    return float(abs(model_vrmse - ref_vrmse) / ref_vrmse * 100.0)


def horizontal_position_error(solution: NavSolution, gt: GroundTruth, t: float | None = None) -> float:
    """Horizontal (north-east) position error (m) at the last aligned solution epoch ``<= t`` (None = end), as
    the reference scores it (:func:`scored`)."""
    solution = scored(solution, gt)
    aligned, sel = _window(solution, gt, None, t)
    k = np.flatnonzero(sel)[-1]
    err = solution.p_n[aligned.mask][k, :2] - aligned.p_true_n[k, :2]
    return float(np.hypot(*err))


def horizontal_position_rmse(solution: NavSolution, gt: GroundTruth, t_start: float | None = None,
                             t_end: float | None = None) -> float:
    """RMSE (m) of the horizontal position error over the solution epochs in ``[t_start, t_end]``, as the
    reference scores it (:func:`scored`)."""
    solution = scored(solution, gt)
    aligned, sel = _window(solution, gt, t_start, t_end)
    err = solution.p_n[aligned.mask][sel, :2] - aligned.p_true_n[sel, :2]
    return float(np.sqrt(np.mean(np.sum(err ** 2, axis=1))))


def nees_velocity(solution: NavSolution, gt: GroundTruth, t_start: float | None = None,
                  t_end: float | None = None) -> np.ndarray:
    """Per-epoch velocity NEES ``e^T cov_v_n^-1 e`` (3 dof) over the solution epochs in ``[t_start, t_end]``.

    A consistent filter gives values with mean 3; over K independent epochs the mean lies in
    ``chi2.ppf([0.025, 0.975], 3K) / K`` with 95 % probability.
    """
    if solution.cov_v_n is None:
        raise DataError("solution has no velocity covariance", solution.method, field="cov_v_n")
    aligned, sel = _window(solution, gt, t_start, t_end)
    err = solution.v_n[aligned.mask][sel] - aligned.v_true_n[sel]
    cov = solution.cov_v_n[aligned.mask][sel]
    return np.einsum("ki,ki->k", err, np.linalg.solve(cov, err[..., None])[..., 0])


def _quadratic_forms(err: np.ndarray, cov: np.ndarray, sol: NavSolution, field: str) -> np.ndarray:
    """``e_k^T P_k^-1 e_k`` per epoch; NaN where ``P_k`` is not finite (e.g. a written file's empty sigma
    columns). A finite but singular ``P_k`` claims certainty the estimator cannot have: a DataError."""
    out = np.full(len(err), np.nan)
    ok = np.all(np.isfinite(cov.reshape(len(cov), -1)), axis=1)
    if not ok.any():
        return out
    try:
        out[ok] = np.einsum("ki,ki->k", err[ok], np.linalg.solve(cov[ok], err[ok][..., None])[..., 0])
    except np.linalg.LinAlgError:
        bad = int(np.flatnonzero(ok)[np.argmin(np.linalg.det(cov[ok]))])
        raise DataError(f"singular covariance at epoch {bad} (t = {sol.t[bad]:.3f} s)", sol.method,
                        field=field) from None
    return out


def nees_position(solution: NavSolution, gt: GroundTruth, t_start: float | None = None,
                  t_end: float | None = None) -> np.ndarray:
    """Per-epoch horizontal position NEES ``e^T P^-1 e`` (2 dof; mean 2 when consistent), ``e`` the north-east
    position error (m) and ``P`` the north-east block of ``cov_p_n`` (m^2), over the epochs in
    ``[t_start, t_end]``; NaN at epochs whose covariance is not finite.

    Horizontal only: the depth is measured directly (pressure sensor; on A-KIT the depth stream *is* the GT's
    altitude), so the vertical error says how well the estimator follows its own depth input, not how it
    navigates, and in a 3-dof NEES its tiny sigma would dominate."""
    if solution.cov_p_n is None:
        raise DataError("solution has no position covariance", solution.method, field="cov_p_n")
    aligned, sel = _window(solution, gt, t_start, t_end)
    err = solution.p_n[aligned.mask][sel, :2] - aligned.p_true_n[sel, :2]
    cov = solution.cov_p_n[aligned.mask][sel][:, :2, :2]
    return _quadratic_forms(err, cov, solution, "cov_p_n")


def yaw(C_b_n: np.ndarray) -> np.ndarray:
    """Heading (yaw) of body-to-NED rotations (...,3,3), rad in (-pi, pi]."""
    C = np.asarray(C_b_n, dtype=float)
    return np.arctan2(C[..., 1, 0], C[..., 0, 0])


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angles (rad) wrapped to [-pi, pi)."""
    return np.mod(np.asarray(a, dtype=float) + np.pi, 2.0 * np.pi) - np.pi


def heading_errors(solution: NavSolution, gt: GroundTruth, t_start: float | None = None,
                   t_end: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(stamps s, heading error rad) over the epochs in ``[t_start, t_end]``: estimated minus true yaw,
    wrapped to [-pi, pi) (an estimate at 179 deg against a truth at -179 deg is 2 deg off, not 358)."""
    aligned, sel = _window(solution, gt, t_start, t_end)
    d = yaw(solution.C_b_n[aligned.mask][sel]) - yaw(aligned.C_true_b_n[sel])
    return aligned.t[sel], wrap_angle(d)


def nees_heading(solution: NavSolution, gt: GroundTruth, t_start: float | None = None,
                 t_end: float | None = None) -> np.ndarray:
    """Per-epoch heading NEES ``dpsi^2 / sigma_psi^2`` (1 dof; mean 1 when consistent) over the epochs in
    ``[t_start, t_end]``: ``dpsi`` the wrapped heading error (:func:`heading_errors`), ``sigma_psi^2`` the
    heading variance of the estimator's attitude covariance ``cov_rot_b``
    (:func:`graphnav.core.rotations.heading_variance`, rad^2); NaN where the covariance is not finite."""
    if solution.cov_rot_b is None:
        raise DataError("solution has no attitude covariance", solution.method, field="cov_rot_b")
    aligned, sel = _window(solution, gt, t_start, t_end)
    _, d = heading_errors(solution, gt, t_start, t_end)
    var = heading_variance(solution.C_b_n[aligned.mask][sel], solution.cov_rot_b[aligned.mask][sel])
    return _quadratic_forms(d[:, None], var[:, None, None], solution, "cov_rot_b")


# --- drift in % of the distance travelled ------------------------------------------------------------------
#: Below this horizontal distance travelled (m) a % DT is not given (None): a vehicle holding station or
#: drifting slowly at the surface has metres of error over almost no distance, a ratio that says nothing.
MIN_DISTANCE_M = 5.0


def horizontal_distance(t: np.ndarray, p_n: np.ndarray, t_start: float | None = None,
                        t_end: float | None = None) -> float:
    """Horizontal distance travelled, m: the length of the north-east polyline through the positions ``p_n``
    (K,>=2, m) at stamps ``t`` (K,) s between ``t_start`` and ``t_end`` (clipped to the stamps), its two ends
    interpolated linearly. Samples at 1 Hz of a vehicle at 2 m/s cut a 10 m-radius turn short by 0.2 %."""
    t = np.asarray(t, dtype=float)
    xy = np.asarray(p_n, dtype=float)[:, :2]
    a = t[0] if t_start is None else max(float(t_start), t[0])
    b = t[-1] if t_end is None else min(float(t_end), t[-1])
    if not b > a:
        return 0.0
    inner = (t > a) & (t < b)
    pts = np.vstack([interp_rows(a, t, xy)[None], xy[inner], interp_rows(b, t, xy)[None]])
    return float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))


def drift_pct(error_m: float, distance_m: float) -> float | None:
    """``error_m / distance_m * 100``, or None when the distance is under :data:`MIN_DISTANCE_M` or either
    value is not finite."""
    if not (np.isfinite(error_m) and np.isfinite(distance_m)) or distance_m < MIN_DISTANCE_M:
        return None
    return float(error_m / distance_m * 100.0)


def position_drift(solution: NavSolution, gt: GroundTruth, t_start: float, t_end: float) -> float:
    """Horizontal position error accumulated over a window, m: ``|e(t_end) - e(t_start)|`` (N, E), with
    ``e = p_est - p_gt`` interpolated at the two stamps. Removing the error already present at the window
    start isolates what the window cost (the error at the start is the drift of everything before it). The
    positions are those the reference scores (:func:`scored`)."""
    solution = scored(solution, gt)

    def err(t):
        return interp_rows(t, solution.t, solution.p_n[:, :2]) - gt.at(t)[0][:2]
    return float(np.linalg.norm(err(t_end) - err(t_start)))


def window_drift(solution: NavSolution, gt: GroundTruth, t_start: float, t_end: float) -> dict:
    """Drift over the window ``[t_start, t_end]`` (s): ``drift_m`` (:func:`position_drift`), ``distance_m``
    (horizontal distance the reference travelled in it, :func:`horizontal_distance` of the GT samples) and
    ``drift_pct`` (% DT, None under :data:`MIN_DISTANCE_M`)."""
    drift = position_drift(solution, gt, t_start, t_end)
    distance = horizontal_distance(gt.t, gt.p_n, t_start, t_end)
    return {"drift_m": drift, "distance_m": distance, "drift_pct": drift_pct(drift, distance)}


def mission_drift(solution: NavSolution, gt: GroundTruth) -> dict:
    """Drift over the whole mission: the horizontal error at the last solution epoch inside the GT span
    (``end_error_m``, in the reference's frame; absolute: not less the error at the start, which an estimator
    started from the GT has not got, except for a start whose position was unknown: :func:`scored`), the
    horizontal distance the reference travelled between the first and that epoch (``distance_m``) and their
    ratio (``drift_pct``, % DT, None under :data:`MIN_DISTANCE_M`)."""
    solution = scored(solution, gt)
    aligned, _ = _window(solution, gt, None, None)
    end = float(np.hypot(*(solution.p_n[aligned.mask][-1, :2] - aligned.p_true_n[-1, :2])))
    distance = horizontal_distance(gt.t, gt.p_n, aligned.t[0], aligned.t[-1])
    return {"end_error_m": end, "distance_m": distance, "drift_pct": drift_pct(end, distance)}


def position_sigma_h(cov_p_n: np.ndarray) -> np.ndarray:
    """Horizontal position sigma, m, of NED covariances (...,3,3): ``sqrt(P_NN + P_EE)``, the RMS of the
    horizontal error norm the estimator claims (comparable with a horizontal error in metres)."""
    cov = np.asarray(cov_p_n, dtype=float)
    return np.sqrt(np.clip(cov[..., 0, 0] + cov[..., 1, 1], 0.0, None))


def track_against_fixes(solution: NavSolution, t_fix: np.ndarray, lat: np.ndarray, lon: np.ndarray) -> dict:
    """A solution's horizontal track against position fixes (e.g. a GPS the log carries) inside its span, both
    from the first fix: ``run_m`` (distance along the fixes), ``end_m`` and ``max_m`` (horizontal error at the
    last fix, and the largest), ``n`` fixes, and the two tracks ``p_fix``/``p_est`` (K,2) north-east, m."""
    from graphnav.core.earth import lla_to_ned
    ok = (t_fix >= solution.t[0]) & (t_fix <= solution.t[-1])
    if ok.sum() < 2:
        raise DataError("fewer than two fixes inside the solution's span", solution.method)
    t, la, lo = t_fix[ok], lat[ok], lon[ok]
    p_fix = lla_to_ned(la, lo, np.zeros(len(t)), (la[0], lo[0], 0.0))[:, :2]
    p_est = np.column_stack([np.interp(t, solution.t, solution.p_n[:, j]) for j in range(2)])
    p_est -= p_est[0]
    err = np.linalg.norm(p_est - p_fix, axis=1)
    return {"run_m": float(np.sum(np.linalg.norm(np.diff(p_fix, axis=0), axis=1))), "end_m": float(err[-1]),
            "max_m": float(err.max()), "n": int(len(t)), "duration_s": float(t[-1] - t[0]),
            "p_fix": p_fix, "p_est": p_est}



def from_start(solution: NavSolution, gt: GroundTruth | None = None) -> NavSolution:
    """``solution`` counted from its start when the start's position was unknown
    (:attr:`NavSolution.origin_unknown`), or, when a later fix placed it, over the epochs before that fix; else
    ``solution`` itself.

    Such a solution's positions and covariance count from its start (the origin's place on Earth is its
    frame's :attr:`NavSolution.origin_sigma_m`), so a reference compared with it can only measure the drift since
    the start: with a reference ``gt``, each epoch's error less the start epoch's (north-east vectors: the
    positions are shifted by the start's error). The start epoch is the first with a finite position (and
    covariance) inside ``gt``'s span. (Subtracting the start's covariance from a covariance holding the origin
    was tried first: 1e4 m^2 less 1e4 m^2 left the marginals' noise and an EKF's gravity-gradient information on
    the start, and claimed a drift of 0 m.) The first fix places such a frame where the estimate was, with its
    drift since the start: the epochs before it are still counted from the start, the later ones through the frame.
    """
    frame = solution.info.get("position_frame") or {}
    placed_at = frame.get("first_fix_t_s") if frame.get("set_by") == FRAME_FIRST_FIX else None
    if gt is None or (not solution.origin_unknown and placed_at is None):
        return solution                     # without a reference there is no error to count from the start
    ok = np.all(np.isfinite(solution.p_n[:, :2]), axis=1) & (solution.t >= gt.t[0]) & (solution.t <= gt.t[-1])
    if solution.cov_p_n is not None:
        ok &= np.all(np.isfinite(solution.cov_p_n[:, :2, :2]), axis=(1, 2))
    if not ok.any():
        return solution
    k0 = int(np.flatnonzero(ok)[0])
    p_n = np.array(solution.p_n, dtype=float)
    rows = slice(None) if placed_at is None else solution.t < placed_at
    p_n[rows, :2] -= p_n[k0, :2] - gt.at(solution.t[k0:k0 + 1])[0][0, :2]
    return replace(solution, p_n=p_n)


def in_reference_frame(solution: NavSolution, gt: GroundTruth) -> NavSolution:
    """``solution`` with its positions in ``gt``'s NED frame when both frames are placed on Earth and differ
    (``solution.info["position_frame"]``, :func:`graphnav.core.solution.position_frame`, and ``gt.origin_lla``):
    e.g. a start without its position that the first fix placed at the dead-reckoned position, or an
    ``initial_lla`` away from the reference's origin. North and east go through latitude and longitude; the down
    stays the estimate's (the absolute depth in both). Else ``solution`` itself."""
    frame = solution.info.get("position_frame") or {}
    if frame.get("origin_lat_deg") is None or gt.origin_lla is None:
        return solution
    origin = (np.radians(frame["origin_lat_deg"]), np.radians(frame["origin_lon_deg"]), 0.0)
    offset = np.r_[np.asarray(frame.get("offset_ne_m") or (0.0, 0.0), float), 0.0]
    if not offset.any() and np.allclose(origin[:2], gt.origin_lla[:2], rtol=0.0, atol=1e-12):
        return solution
    from graphnav.core.earth import lla_to_ned, ned_to_lla
    lla = ned_to_lla(np.asarray(solution.p_n, float) - offset, origin)
    p_n = lla_to_ned(lla[:, 0], lla[:, 1], lla[:, 2], gt.origin_lla)
    p_n[:, 2] = solution.p_n[:, 2]
    return replace(solution, p_n=p_n)


#: ``info`` key of a solution :func:`scored` returned: its positions are already the reference's, scoring them
#: again would move them twice.
SCORED = "scored_positions"


def scored(solution: NavSolution, gt: GroundTruth) -> NavSolution:
    """``solution`` as a reference ``gt`` scores it: in the reference's frame (:func:`in_reference_frame`) and,
    when its start's position was unknown, from the start (:func:`from_start`). Every position number of a run
    goes through it; a solution it returned is returned as is."""
    if solution.info.get(SCORED):
        return solution
    out = from_start(in_reference_frame(solution, gt), gt)
    return replace(out, info={**out.info, SCORED: True})


def frame_shift(sol: NavSolution, gt: GroundTruth) -> np.ndarray:
    """(K,3) m that carries the reference's positions at ``sol``'s epochs into the estimate's frame: the estimate
    less the same estimate as the reference scores it (:func:`scored`: another origin on Earth, or counted from an
    unknown start). Zero for a run started from the reference. Between two tangent planes a few km apart the shift
    varies by micrometres over the metres an estimate is off.

    At an epoch without a finite estimate (lost track) the difference says nothing, but the frame is still
    known: the shift is interpolated in time from the epochs around it (held at the ends), separately before and
    after the fix that placed the frame (``position_frame["first_fix_t_s"]``, where the shift steps). It stays
    NaN only where a side of that step has no finite epoch at all."""
    shift = np.asarray(sol.p_n, float) - scored(sol, gt).p_n
    placed_at = (sol.info.get("position_frame") or {}).get("first_fix_t_s")
    sides = [np.ones(len(sol.t), bool)] if placed_at is None else [sol.t < placed_at, sol.t >= placed_at]
    for side in sides:
        known = side & finite_rows(shift)
        if known.any():
            gaps = side & ~known
            shift[gaps] = np.column_stack([np.interp(sol.t[gaps], sol.t[known], col) for col in shift[known].T])
    return shift


#: Fixes further apart than this (s) belong to different stays at the surface (:func:`surfacings`).
SURFACING_GAP_S = 60.0


def surfacings(t_fix: np.ndarray, gap_s: float = SURFACING_GAP_S) -> list[tuple[float, float]]:
    """(first, last) stamp (s) of each run of fix stamps ``t_fix`` without a gap longer than ``gap_s``: the stays
    at the surface a vehicle took its fixes in."""
    t = np.sort(np.asarray(t_fix, dtype=float))
    if not len(t):
        return []
    cut = np.flatnonzero(np.diff(t) > gap_s)
    return [(float(t[a]), float(t[b])) for a, b in zip(np.r_[0, cut + 1], np.r_[cut, len(t) - 1])]


def drift_before_fixes(solution: NavSolution, gt: GroundTruth, t_fix: np.ndarray) -> list[dict]:
    """The drift of a solution that used position fixes ``t_fix`` (s): per stay at the surface
    (:func:`surfacings`) after the solution's first epoch, ``t`` (its last epoch before the stay's first fix,
    s), ``error_m`` (the horizontal error there, m, in the reference's frame: :func:`scored`), ``distance_m``
    (what the reference travelled since the previous stay's last fix, or since the start, m) and
    ``drift_pct`` (% DT, None under :data:`MIN_DISTANCE_M`). With fixes the end error is bounded by the last
    fix; the error before each stay is what dead reckoning since the previous one cost (as
    :func:`graphnav.evaluation.fixes.drift_before_surfacings`). A stay whose first fix placed the frame
    (``position_frame["first_fix_t_s"]``) agrees with the estimate by construction: it only restarts the
    count."""
    sol = scored(solution, gt)
    aligned = align(sol, gt)
    t = aligned.t
    err = np.linalg.norm(sol.p_n[aligned.mask][:, :2] - aligned.p_true_n[:, :2], axis=1)
    placed = (solution.info.get("position_frame") or {}).get("first_fix_t_s")
    out, t_last = [], float(t[0]) if len(t) else 0.0
    for w0, w1 in surfacings(np.asarray(t_fix, float)[np.asarray(t_fix) > t_last]):
        before = np.flatnonzero(t < w0)
        if before.size and not (placed is not None and w0 <= placed <= w1):
            i = int(before[-1])
            distance = horizontal_distance(gt.t, gt.p_n, t_last, t[i])
            out.append({"t": float(t[i]), "error_m": float(err[i]), "distance_m": distance,
                        "drift_pct": drift_pct(float(err[i]), distance)})
        t_last = w1
    return out


def fix_stamps(mission) -> np.ndarray | None:
    """Stamps (s) of a mission's position fixes, or None (no mission or no fixes)."""
    fixes = getattr(mission, "fixes", None)
    return None if fixes is None else np.asarray(fixes.t, float)


def drift_summary(solution: NavSolution, gt: GroundTruth | None = None, t_fix: np.ndarray | None = None) -> dict:
    """What a run's summary reports about distance and drift (``graphnav smooth`` / ``online``):

    - ``distance_m``: horizontal distance travelled by the *estimate* (available without a reference);
    - ``sigma_h_end_m``: the estimator's own horizontal position sigma at the last epoch
      (:func:`position_sigma_h`); None without ``cov_p_n`` (e.g. the paper's 12-state EKF);
    - ``sigma_h_origin_m``: the part of it that is an unknown start's place on Earth (its frame's
      :attr:`NavSolution.origin_sigma_m`, both axes; None for other starts), which the covariance does not hold;
    - ``sigma_h_end_pct``: the drift the estimator claims, the covariance's horizontal sigma (counted from the
      start) as % of ``distance_m``; None without ``cov_p_n`` or under :data:`MIN_DISTANCE_M`;
    - ``fixes_used``: the position fixes the estimator used (``info["n_fixes"]``); with any, the sigma and the
      error at the end are bounded by the last fix, not a drift, and ``drift_pct`` and ``sigma_h_end_pct`` are
      None (the drift is ``drift_before_fixes``'s);
    - with a reference ``gt``: ``end_error_m``, ``reference_distance_m`` and ``drift_pct`` of
      :func:`mission_drift` (the % DT against the reference); None without one; and, when fixes were used and
      their stamps ``t_fix`` (s) are given, ``drift_before_fixes`` (:func:`drift_before_fixes`).
    """
    ok = np.all(np.isfinite(solution.p_n[:, :2]), axis=1)
    distance = horizontal_distance(solution.t[ok], solution.p_n[ok]) if ok.sum() >= 2 else 0.0
    out = {"distance_m": distance, "sigma_h_end_m": None, "sigma_h_origin_m": None, "sigma_h_end_pct": None,
           "end_error_m": None, "reference_distance_m": None, "drift_pct": None,
           "fixes_used": int(solution.info.get("n_fixes") or 0)}
    if solution.cov_p_n is not None and len(solution.t):
        drift = float(position_sigma_h(solution.cov_p_n[-1]))
        if np.isfinite(drift):
            origin = solution.origin_sigma_m
            out["sigma_h_origin_m"] = None if origin is None else float(np.sqrt(2.0) * origin)
            out["sigma_h_end_m"] = float(np.hypot(drift, out["sigma_h_origin_m"] or 0.0))
            out["sigma_h_end_pct"] = drift_pct(drift, distance)
    if gt is not None and np.any((solution.t >= gt.t[0]) & (solution.t <= gt.t[-1])):
        m = mission_drift(solution, gt)
        out.update(end_error_m=m["end_error_m"], reference_distance_m=m["distance_m"], drift_pct=m["drift_pct"])
        if out["fixes_used"] and t_fix is not None:
            out["drift_before_fixes"] = drift_before_fixes(solution, gt, t_fix)
    if out["fixes_used"]:
        # as drift_line says: bounded by the last fix, the end error and sigma are no whole-mission drift
        out.update(drift_pct=None, sigma_h_end_pct=None)
    return out


def drift_line(summary: dict) -> str:
    """One line of text of a :func:`drift_summary` ("-" where a value is None)."""
    def fmt(x, spec):
        return "-" if x is None else format(x, spec)
    line = f"horizontal distance travelled {summary['distance_m']:.1f} m (estimate)"
    fixes = summary.get("fixes_used") or 0
    if summary.get("end_error_m") is not None and fixes:
        stays = summary.get("drift_before_fixes") or []
        line += (f"; {fixes} position fixes used, so the end error ({summary['end_error_m']:.2f} m) is bounded by "
                 "the last fix, not a drift; drift before each stay at the surface, since the previous fix: "
                 + (", ".join(f"{fmt(d['drift_pct'], '.2f')} % DT ({d['error_m']:.2f} m over "
                              f"{d['distance_m']:.1f} m)" for d in stays) or "-"))
    elif summary.get("end_error_m") is not None:
        line += (f"; drift {fmt(summary['drift_pct'], '.2f')} % DT against the reference (end error "
                 f"{summary['end_error_m']:.2f} m over {summary['reference_distance_m']:.1f} m)")
    if summary.get("sigma_h_end_m") is None:
        return line + "; claimed position sigma at the end: - (the estimate carries no position covariance)"
    line += f"; claimed position sigma at the end {summary['sigma_h_end_m']:.2f} m"
    if fixes:
        return line + f" (after {fixes} position fixes)"
    origin = summary.get("sigma_h_origin_m")
    if origin is None:
        return line + f" = {fmt(summary['sigma_h_end_pct'], '.2f')} % DT"
    drift = np.sqrt(max(summary["sigma_h_end_m"] ** 2 - origin ** 2, 0.0))
    return line + (f" ({origin:.2f} m of it the unknown start, no fix or initial position); since the start "
                   f"{drift:.2f} m = {fmt(summary['sigma_h_end_pct'], '.2f')} % DT")
