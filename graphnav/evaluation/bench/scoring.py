"""Bench scoring: the per-window records of one solution (:func:`score_case`: VRMSE, drift, velocity / position /
heading NEES) and when a window counts as diverged (:func:`divergence_reason`)."""
from __future__ import annotations

import math

import numpy as np

from graphnav.core.mission import GroundTruth, Mission
from graphnav.core.solution import NavSolution
from graphnav.estimators.health import diverged_during
from graphnav.evaluation.consistency import mission_nees


#: A window VRMSE (m/s) at or above this is a divergence, not an accuracy: it exceeds the speed of the
#: vehicles the benchmark covers (Snapir: 1-2.5 m/s), so the estimate carries no information about the
#: velocity. Healthy runs stay far below it: the worst window of any method in the shared-data benchmark
#: and in ``graphnav start-sweep`` is < 0.5 m/s; pure inertial through a 30 s outage on the degraded
#: (tactical) IMU stays below 1 m/s.
DIVERGED_VRMSE_MPS = 3.0


def window_position_drift(sol: NavSolution, gt, t_start: float, t_end: float) -> float:
    """Horizontal position error accumulated over a window, m (:func:`graphnav.evaluation.metrics.position_drift`)."""
    from graphnav.evaluation.metrics import position_drift
    return position_drift(sol, gt, t_start, t_end)


def score_case(sol: NavSolution, mission: Mission, starts: list[float], window_s: float,
               reference: GroundTruth | None = None) -> list[dict]:
    """Per-window metrics of one solution: ``vrmse_window``, ``vrmse_mission``, ``pos_err_window_end_m``
    (drift over the window, m), ``distance_window_m`` (horizontal distance the GT travelled in it) and
    ``drift_pct_window`` (% DT: the two divided, None under
    :data:`graphnav.evaluation.metrics.MIN_DISTANCE_M`), ``pos_err_abs_window_end_m`` (error at the window
    end), ``nees_window`` (mean velocity NEES over the window, 3 for a consistent estimator),
    ``nees_pos_window`` (horizontal position, 2) and ``nees_heading_window`` (1; each None without its
    covariance); and the mission's: ``drift_pct_mission`` (end horizontal error / distance travelled, %),
    ``pos_err_mission_end_m``, ``distance_mission_m``, and its NEES (:func:`mission_nees`: velocity, position,
    heading). ``reference``: the NEES's reference at ``sol``'s epochs when the caller has carried it
    (:func:`graphnav.evaluation.consistency.scoring_reference`; None: carried here when ``sol`` has a covariance)."""
    from graphnav.evaluation.consistency import scoring_reference, window_nees
    from graphnav.evaluation.metrics import (
        horizontal_position_error,
        mission_drift,
        vrmse,
        window_drift,
    )
    gt = mission.gt
    v_mission = float(vrmse(sol, gt, mission.t0, mission.t1))
    has_cov = any(c is not None for c in (sol.cov_v_n, sol.cov_p_n, sol.cov_rot_b))
    if reference is None:
        reference = scoring_reference(sol, mission) if has_cov else gt
    consistency = mission_nees(sol, mission, reference if has_cov else None)     # carried once for both
    whole = mission_drift(sol, gt)
    drift_mission = {"drift_pct_mission": whole["drift_pct"], "pos_err_mission_end_m": whole["end_error_m"],
                     "distance_mission_m": whole["distance_m"]}
    out = []
    for s in starts:
        drift = window_drift(sol, gt, s, s + window_s)
        out.append({
            "window_start_s": float(s),
            "vrmse_window": float(vrmse(sol, gt, s, s + window_s)),
            "vrmse_mission": v_mission,
            "pos_err_window_end_m": drift["drift_m"],
            "distance_window_m": drift["distance_m"],
            "drift_pct_window": drift["drift_pct"],
            "pos_err_abs_window_end_m": float(horizontal_position_error(sol, gt, s + window_s)),
            **window_nees(sol, reference, s, s + window_s),
            **drift_mission,
            **consistency,
        })
    return out


def divergence_reason(sol: NavSolution, record: dict, t_start: float, t_end: float) -> str | None:
    """Why the window ``[t_start, t_end]`` (s) of a scored run counts as diverged, or None: a non-finite
    estimate in the window, window VRMSE >= :data:`DIVERGED_VRMSE_MPS`, or the health monitor's diverged
    state overlapping the window."""
    inside = (sol.t >= t_start) & (sol.t <= t_end)
    if not (np.all(np.isfinite(sol.v_n[inside])) and np.all(np.isfinite(sol.p_n[inside]))):
        return "non-finite estimate"
    v = record.get("vrmse_window")
    if v is None or not math.isfinite(v):
        return "non-finite window VRMSE"
    if v >= DIVERGED_VRMSE_MPS:
        return f"window VRMSE {v:.3g} m/s >= {DIVERGED_VRMSE_MPS:g} m/s"
    health = sol.info.get("health")
    if diverged_during(health, t_start, t_end):
        first = next(i for i in health["divergence_intervals"]
                     if i[0] <= t_end and (i[1] is None or i[1] >= t_start))
        return f"health monitor: {first[2]} (t={first[0]:.1f} s)"
    return None
