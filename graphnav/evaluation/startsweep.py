"""Start anywhere: run a method from many start times of a mission and score the first windows after each.

A real mission does not start where a benchmark likes it to (after 60 s of straight, level convergence):
a user may start the estimator inside a fast turn, a dive or at the surface. For every start time
``t_start`` (every ``step_s`` seconds) the mission is cut to ``[t_start, t_start + length_s]``
(:meth:`graphnav.core.mission.Mission.slice`; the estimators then start from the ground truth at their first
stamp, :meth:`graphnav.core.mission.GroundTruth.at`), the method runs over it, and consecutive windows of
``window_s`` from ``t_start`` are scored: the first window holds the start-up, the second one carries the
scenario's beam outage (the paper's 2-missing / 3-missing presets; ``none`` = all beams). The result of
one start is its *worst* window VRMSE and its health record (:mod:`graphnav.estimators.health`).

:func:`run_sweep` runs the whole sweep (every trajectory, start, scenario and method, through the task runner
:func:`graphnav.evaluation.tasks.run_tasks`) and :func:`sweep_table` prints its table; ``graphnav start-sweep``
is the command. ``tests/test_start_anywhere.py`` runs a subsample (and the full sweep when ``--runslow``).
"""
from __future__ import annotations

import functools
import math
import warnings
from typing import Callable

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


# --- the sweep -----------------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=None)     # a handful of small missions: load each once per worker process
def _mission(source) -> Mission:
    from graphnav.evaluation.bench import load_source
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # the loaders' notes are the user's when they load one mission
        return load_source(source)


def sweep_jobs(sources, scenarios, step_s: float = 10.0, length_s: float = 60.0) -> list[tuple]:
    """(source, scenario, start s) in the order they are run: first the three fastest-manoeuvre starts of every
    trajectory, then the starts on a 3-step grid, then the rest, each scenario by scenario, so that a sweep
    cut short still covers every trajectory (the table says how many starts it holds). ``sources`` are
    :class:`graphnav.evaluation.bench.TrajectorySource`."""
    jobs = []
    for k_src, src in enumerate(sources):
        mission = _mission(src)
        starts = start_times(mission, step_s, length_s)
        fast = set(fastest_starts(mission, starts, n=3))
        for i, t in enumerate(starts):
            priority = 0 if t in fast else (1 if i % 3 == 0 else 2)
            jobs += [(priority, k, t, k_src, src, sc) for k, sc in enumerate(scenarios)]
    return [(src, sc, t) for _, _, t, _, src, sc in sorted(jobs, key=lambda j: j[:4])]


def run_start_job(job: tuple) -> list[dict]:
    """One task of the sweep: ``(source, scenario, t_start, methods, length_s, window_s)`` -> one record per
    method (module level, plain data: it runs in worker processes)."""
    source, scenario, t_start, methods, length_s, window_s = job
    mission = _mission(source)
    return [run_start(mission, m, scenario, t_start, length_s, window_s) for m in methods]


def run_sweep(sources, methods, scenarios, step_s: float = 10.0, length_s: float = 60.0, window_s: float = 30.0,
              done: list[dict] | None = None, finished: Callable[[list[dict]], None] | None = None,
              jobs: int = 1, scheduler: str | None = None) -> list[dict]:
    """Every start of every source x scenario x method; the records of ``done`` are kept and their
    (trajectory, scenario, start) skipped. ``finished(records)`` sees every record as its start completes
    (the command rewrites its file there). Returns all records."""
    from graphnav.evaluation.tasks import run_tasks
    records = list(done or [])
    skip = {(r["trajectory"], r["scenario"], float(r["t_start"])) for r in records}
    todo = [(src, sc, t, list(methods), length_s, window_s) for src, sc, t in sweep_jobs(sources, scenarios, step_s,
                                                                                          length_s)
            if (_mission(src).name, sc, t) not in skip]

    def collect(new: list[dict]) -> None:
        records.extend(new)
        if finished is not None:
            finished(new)
    run_tasks(run_start_job, todo, collect, jobs=jobs, scheduler=scheduler)
    return records


def sweep_table(records: list[dict], methods, scenarios, limit: float = START_VRMSE_LIMIT) -> str:
    """Markdown table per scenario and method: starts run, worst window VRMSE (m/s) and where, the median of
    the per-start worst, failed starts (:func:`failed`), runs the health monitor re-acquired and its trips."""
    lines = [f"Worst window VRMSE (m/s) over all starts; failed = worst >= {limit} m/s, diverged or crashed; "
             "starts = (trajectory, start) pairs run.", "",
             "| scenario | method | starts | worst window VRMSE | at (trajectory, start s) | median of worst | "
             "failed | re-acquired runs | health trips |", "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for sc in scenarios:
        for m in methods:
            rs = [r for r in records if r["scenario"] == sc and r["method"] == m]
            if not rs:
                continue
            worst = max(rs, key=lambda r: r["vrmse_worst"])
            finite = sorted(r["vrmse_worst"] for r in rs if math.isfinite(r["vrmse_worst"]))
            median = finite[len(finite) // 2] if finite else float("nan")
            n_fail = sum(failed(r, limit) for r in rs)
            reacq = sum(bool(r["health"] and r["health"].get("n_reacquired")) for r in rs)
            trips = sum(bool(r["health"] and r["health"].get("diverged")) for r in rs)
            lines.append(f"| {sc} | {m} | {len(rs)} | {worst['vrmse_worst']:.3f} | {worst['trajectory']}, "
                         f"{worst['t_start']:.0f} | {median:.3f} | {n_fail} | {reacq} | {trips} |")
    return "\n".join(lines)
