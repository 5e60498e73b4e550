"""Start anywhere: run a method from many start times of a mission and score the first windows after each.

A real mission does not start where a benchmark likes it to (after 60 s of straight, level convergence):
a user may start the estimator inside a fast turn, a dive or at the surface. For every start time
``t_start`` (every ``step_s`` seconds) the mission is cut to ``[t_start, t_start + length_s]``
(:meth:`graphnav.core.mission.Mission.slice`; the estimators then start from the ground truth at their first
stamp, :meth:`graphnav.core.mission.GroundTruth.at`), the method runs over it, and consecutive windows of
``window_s`` from ``t_start`` are scored: the first window holds the start-up, the second one carries the
scenario's beam outage (the paper's 2-missing / 3-missing presets; ``none`` = all beams). The result of
one start is its *worst* window VRMSE and its health record (:mod:`graphnav.estimators.health`).

``scripts/start_sweep.py`` runs the whole sweep and prints the table; ``tests/test_start_anywhere.py`` runs a
subsample (and the full sweep when ``--runslow``).
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from graphnav.core.mission import Mission
from graphnav.core.scenarios import scenario_outage

#: A start whose worst window VRMSE (m/s) is at or above this has failed (docs/decisions/health-and-coasting.md).
START_VRMSE_LIMIT = 0.5


def start_times(mission: Mission, step_s: float = 10.0, length_s: float = 60.0) -> list[float]:
    """Start times (s) every ``step_s`` from the first IMU stamp while ``length_s`` of data remain."""
    return [float(t) for t in np.arange(mission.t0, mission.t1 - length_s + 1e-9, step_s)]


def fastest_starts(mission: Mission, starts: list[float], n: int = 2, horizon_s: float = 1.0) -> list[float]:
    """The ``n`` start times with the largest peak body rate (rad/s, any axis) in their first ``horizon_s``."""
    imu = mission.imu

    def peak(t):
        sel = (imu.t >= t) & (imu.t < t + horizon_s)
        return float(np.abs(imu.omega_b[sel]).max()) if sel.any() else 0.0
    return sorted(starts, key=peak, reverse=True)[:n]


def run_start(mission: Mission, method: str, scenario: str, t_start: float, length_s: float = 60.0,
              window_s: float = 30.0) -> dict:
    """Run ``method`` on ``mission`` cut at ``t_start`` and score its windows (see the module docstring).

    Returns a record: ``trajectory``, ``method``, ``scenario``, ``t_start``, ``vrmse_windows`` (list, m/s),
    ``vrmse_worst``, ``diverged`` (health monitor tripped, or a non-finite estimate), ``health`` (summary),
    ``n_warnings`` and ``error`` (None, or the exception's text).
    """
    from graphnav.evaluation.methods import run_method
    from graphnav.evaluation.metrics import vrmse
    t_end = min(t_start + length_s, mission.t1)
    piece = mission.slice(t_start, t_end)
    edges = np.arange(t_start, t_end - 0.5 * window_s + 1e-9, window_s)
    if scenario != "none" and len(edges) > 1:
        piece = piece.with_outage(scenario_outage(scenario, float(edges[1]), window_s))
    record = {"trajectory": mission.name, "method": method, "scenario": scenario, "t_start": float(t_start),
              "vrmse_windows": None, "vrmse_worst": math.inf, "diverged": True, "health": None,
              "n_warnings": 0, "error": None}
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sol = run_method(piece, method, scenario)
        values = [float(vrmse(sol, piece.gt, a, min(a + window_s, t_end))) for a in edges]
        health = sol.info.get("health")
        finite = bool(np.all(np.isfinite(sol.v_n)))
        record.update(vrmse_windows=values, vrmse_worst=max(values) if finite else math.inf,
                      diverged=(not finite) or bool(health and health["diverged_at_end"]),
                      health=health, n_warnings=len(caught))
    except Exception as exc:  # noqa: BLE001 - a crash at one start is a result of the sweep, reported
        record["error"] = f"{type(exc).__name__}: {exc}"
    return record


def failed(record: dict, limit: float = START_VRMSE_LIMIT) -> bool:
    """A start failed: it crashed, diverged (unrecovered) or its worst window VRMSE reached ``limit``."""
    return bool(record["error"] or record["diverged"] or not record["vrmse_worst"] < limit)
