"""Accuracy metrics shared by every estimator, benchmark and test.

Time alignment is explicit: the ground truth is interpolated at the solution's stamps by
:meth:`graphnav.core.mission.GroundTruth.at` (linear for position and velocity, slerp for attitude); solution epochs outside the ground-truth time span are dropped
(never extrapolated). All errors are estimate minus truth in the local NED frame.

- VRMSE ``sqrt(mean_k |v_k - v_hat_k|^2)`` (m/s), the paper's velocity metric, over the solution epochs in a
  time window (the outage window or the whole mission).
- VRTE ``|VRMSE_model - VRMSE_ref| / VRMSE_ref * 100`` (%), the paper's improvement against a reference.
- Horizontal position error (m) at the end of a window, and its RMSE over a window.
- Velocity NEES ``e^T P^-1 e`` per epoch against the solution's ``cov_v_n`` (3 degrees of freedom).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from graphnav.core.errors import DataError
from graphnav.core.mission import GroundTruth
from graphnav.core.solution import NavSolution


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
    """Horizontal (north-east) position error (m) at the last aligned solution epoch ``<= t`` (None = end)."""
    aligned, sel = _window(solution, gt, None, t)
    k = np.flatnonzero(sel)[-1]
    err = solution.p_n[aligned.mask][k, :2] - aligned.p_true_n[k, :2]
    return float(np.hypot(*err))


def horizontal_position_rmse(solution: NavSolution, gt: GroundTruth, t_start: float | None = None,
                             t_end: float | None = None) -> float:
    """RMSE (m) of the horizontal position error over the solution epochs in ``[t_start, t_end]``."""
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

