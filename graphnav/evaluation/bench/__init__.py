"""The comparison benchmark behind ``graphnav bench``.

A *case* is one trajectory x scenario x IMU grade x method. Its mission gets 30 s outage windows spread
over it (:func:`graphnav.core.scenarios.window_starts`: the first after 60 s of convergence, then one every
window + 60 s, so consecutive windows are separated by >= 60 s of full beams and share one run); the
method runs once over the whole mission and each window is scored on its own, giving one record per
window (:data:`RECORD_KEYS`). The ``none`` scenario scores the same windows with all beams present.

IMU grades: ``as-recorded`` uses the IMU as recorded (for the simulated default: the simulator's
navigation grade); any grade of :data:`graphnav.core.config.IMU_GRADES` (``tactical``) adds that grade's errors
to the recorded samples with :func:`graphnav.sim.imu_errors.corrupt_imu` (seeded per trajectory, so every
method sees the same IMU) and gives the estimators that grade's error model.

Failures are reported as failures: a window whose estimate diverged (:func:`divergence_reason`: non-finite,
window VRMSE at or above :data:`DIVERGED_VRMSE_MPS`, or the estimator's health monitor in its diverged state
during the window, :mod:`graphnav.estimators.health`) carries ``diverged: true`` and the reason in ``results.json``;
the report counts and lists such windows and leaves them out of the means instead of averaging them in.

Results are written after every finished case (``results.json``, atomically), so an interrupted benchmark
keeps what it finished and ``--resume`` skips those cases. :func:`make_report` turns the records into
``report.md``.

The package's parts: :mod:`.cases` (what runs, on which mission), :mod:`.scoring` (the records of one solution),
:mod:`.runner` (one case, all cases, ``results.json``) and :mod:`.report` (aggregation, tables, ``report.md``); every
public name is importable from ``graphnav.evaluation.bench`` itself.
"""
from graphnav.evaluation.bench.cases import (
    IMU_GRADE_CHOICES,
    SCENARIO_NAMES,
    BenchCase,
    TrajectorySource,
    case_windows,
    degrade_imu,
    find_trajectories,
    load_source,
    make_cases,
    mission_collection,
    prepared_mission,
)
from graphnav.evaluation.bench.report import (
    HELPS_BELOW,
    HURTS_ABOVE,
    REGIME_METHODS,
    aggregate,
    aggregate_regimes,
    drift_pct_of,
    headline,
    improvement_pct,
    make_report,
    natural_key,
    nees_section,
    pose_nees_rows,
    regime_summary,
)
from graphnav.evaluation.bench.runner import (
    RECORD_KEYS,
    base_key,
    downsample,
    load_results,
    load_solution,
    record_key,
    run_bench,
    run_case,
    save_solution,
    solution_file,
)
from graphnav.evaluation.bench.scoring import (
    DIVERGED_VRMSE_MPS,
    divergence_reason,
    score_case,
    window_position_drift,
)
# the mission NEES lives with the other consistency scores: ``graphnav evaluate`` calls the same function
from graphnav.evaluation.consistency import NEES_SETTLE_S, mission_nees

__all__ = [
    "BenchCase", "DIVERGED_VRMSE_MPS", "HELPS_BELOW", "HURTS_ABOVE", "IMU_GRADE_CHOICES", "NEES_SETTLE_S",
    "RECORD_KEYS", "REGIME_METHODS", "SCENARIO_NAMES", "TrajectorySource", "aggregate", "aggregate_regimes",
    "base_key", "case_windows", "degrade_imu", "divergence_reason", "downsample", "drift_pct_of",
    "find_trajectories", "headline", "improvement_pct", "load_results", "load_solution", "load_source",
    "make_cases", "make_report", "mission_collection", "mission_nees", "natural_key", "nees_section",
    "pose_nees_rows", "prepared_mission", "record_key", "regime_summary", "run_bench", "run_case", "save_solution",
    "score_case", "solution_file", "window_position_drift"
]
