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
"""
from __future__ import annotations

import dataclasses
import functools
import json
import math
import time
import warnings
import zlib
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from graphnav.core.config import imu_grade as imu_grade_spec
from graphnav.core.errors import ConfigError
from graphnav.core.mission import Mission
from graphnav.core.scenarios import scenario_outage, window_starts
from graphnav.core.solution import NavSolution
from graphnav.estimators.health import diverged_during
# the mission NEES lives with the other consistency scores: ``graphnav evaluate`` calls the same function
from graphnav.evaluation.consistency import NEES_SETTLE_S, mission_nees  # noqa: F401
from graphnav.evaluation.methods import (
    BENCH_METHODS,
    METHODS,
    check_method,
    check_scenario,
    run_method,
)
from graphnav.evaluation.tasks import run_tasks

SCENARIO_NAMES: tuple[str, ...] = ("2-missing", "3-missing", "0-beams", "markov", "none")
IMU_GRADE_CHOICES: tuple[str, ...] = ("as-recorded", "tactical", "mems")
#: Methods of the regime summary (report section "Regimes"), the hybrid first, its reference second.
REGIME_METHODS: tuple[str, ...] = ("Graph-TC", "Graph-HN", "Graph-HN-batch", "Graph-TC-batch", "Graph-MP", "TC",
                                    "HNTC", "Graph-HNI", "Graph-HNI-batch", "HNTC-IMU")
#: Keys of every result record (extra diagnostic keys may follow).
RECORD_KEYS: tuple[str, ...] = ("trajectory", "scenario", "imu_grade", "window_start_s", "window_s", "method",
                                "vrmse_window", "vrmse_mission", "pos_err_window_end_m", "runtime_s", "diverged",
                                "divergence_reason")
#: A window VRMSE (m/s) at or above this is a divergence, not an accuracy: it exceeds the speed of the
#: vehicles the benchmark covers (Snapir: 1-2.5 m/s), so the estimate carries no information about the
#: velocity. Healthy runs stay far below it: the worst window of any method in the shared-data benchmark
#: and in ``graphnav start-sweep`` is < 0.5 m/s; pure inertial through a 30 s outage on the degraded
#: (tactical) IMU stays below 1 m/s.
DIVERGED_VRMSE_MPS = 3.0


@dataclass(frozen=True)
class TrajectorySource:
    """Where a trajectory comes from: a folder in the A-KIT layout, or the simulator (``folder=None``)."""

    name: str
    folder: str | None = None
    seed: int = 0
    duration_s: float = 400.0
    config_path: str | None = None


@dataclass(frozen=True)
class BenchCase:
    """One run: a method on a trajectory with a scenario's windows, at an IMU grade."""

    trajectory: TrajectorySource
    scenario: str
    imu_grade: str
    method: str
    window_s: float = 30.0
    max_windows: int | None = None
    save_dir: str | None = None  # keep the (down-sampled) solution here for the plots

    @property
    def key(self) -> tuple:
        return (self.trajectory.name, self.scenario, self.imu_grade, self.method, float(self.window_s))


def record_key(record: dict) -> tuple:
    return (record["trajectory"], record["scenario"], record["imu_grade"], record["method"],
            float(record["window_s"]))


# --- trajectories and missions --------------------------------------------------------------------------
def find_trajectories(data: str | None = None, sim_seeds: int = 1, sim_duration_s: float = 400.0,
                      config_path: str | None = None) -> list[TrajectorySource]:
    """The simulated default (``data=None``; one trajectory per seed), one mission (an A-KIT trajectory
    folder or a ROS 2 bag), or every mission under the folder ``data``: its A-KIT ``TrajectoryN`` folders,
    else its ROS 2 bags (bag folders or bare ``.mcap``/``.db3`` files)."""
    if data is None:
        return [TrajectorySource(f"sim-seed{s}", None, s, sim_duration_s, config_path) for s in range(sim_seeds)]
    from graphnav.io.bags import is_bag
    from graphnav.io.loaders import list_akit
    root = Path(data)
    if is_bag(root):
        return [TrajectorySource(root.stem if root.is_file() else root.name, str(root), 0, 0.0, config_path)]
    if not root.is_dir():
        raise ConfigError(f"--data {data}: not a folder")
    if any(root.glob("IMU_*.csv")):
        return [TrajectorySource(root.name, str(root), 0, 0.0, config_path)]
    found = [Path(f) for f in list_akit(root)] or sorted(p for p in root.iterdir() if is_bag(p))
    if not found:
        raise ConfigError(f"--data {data}: no trajectory folders (IMU_*.csv, DVL_*.csv, GT_*.csv) or ROS 2 "
                          "bags found")
    sources = [TrajectorySource(p.stem if p.is_file() else p.name, str(p), 0, 0.0, config_path) for p in found]
    names = [s.name for s in sources]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ConfigError(f"--data {data}: several missions named {twice} (e.g. a bag folder and a bag file); "
                          "rename one")
    return sources


def mission_collection(data: str | None, config_path: str | None = None) -> list[TrajectorySource] | None:
    """The missions under ``data`` when it is a folder of missions (as :func:`find_trajectories` finds
    them), or None when ``data`` is one mission (a file, a bag, an A-KIT folder, a column-map CSV folder)
    or nothing (the simulated default); the loader then reads it or says why it cannot."""
    if data is None or not Path(data).is_dir():
        return None
    try:
        sources = find_trajectories(data, config_path=config_path)
    except ConfigError:
        return None
    if len(sources) == 1 and Path(sources[0].folder) == Path(data):
        return None
    return sources


def load_source(source: TrajectorySource) -> Mission:
    """The mission of a trajectory source, as recorded (or simulated at navigation grade)."""
    from graphnav.io.loaders import load_mission
    if source.folder is None:
        return load_mission(None, source.config_path, duration_s=source.duration_s, seed=source.seed)
    return load_mission(source.folder, source.config_path)


def degrade_imu(mission: Mission, grade: str, seed: int) -> Mission:
    """A copy of ``mission`` with ``grade``'s IMU errors added and the estimators' IMU model set to it."""
    from graphnav.sim.imu_errors import corrupt_imu
    spec = imu_grade_spec(grade)
    imu, _truth = corrupt_imu(mission.imu, spec, seed=seed)
    config = dataclasses.replace(mission.config, imu=spec)
    return dataclasses.replace(mission, imu=imu, config=config,
                               meta={**mission.meta, "imu_degraded_to": grade, "imu_degrade_seed": seed})


@functools.lru_cache(maxsize=4)
def prepared_mission(source: TrajectorySource, grade: str) -> Mission:
    """Mission for a trajectory at an IMU grade; cached per process (cases of one trajectory share it)."""
    mission = load_source(source)
    if mission.gt is None:
        raise ConfigError(f"trajectory {source.name} has no ground truth; the benchmark needs it")
    if grade == "as-recorded":
        return mission
    # The seed depends on the trajectory only, so every method and scenario sees the same IMU.
    return degrade_imu(mission, grade, seed=zlib.crc32(source.name.encode()) % 2**31)


def case_windows(mission: Mission, window_s: float, max_windows: int | None = None) -> list[float]:
    return window_starts(mission.t0, mission.t1, window_s=window_s, settle_s=60.0, gap_s=60.0,
                         max_windows=max_windows)


# --- scoring ---------------------------------------------------------------------------------------------
def window_position_drift(sol: NavSolution, gt, t_start: float, t_end: float) -> float:
    """Horizontal position error accumulated over a window, m (:func:`graphnav.evaluation.metrics.position_drift`)."""
    from graphnav.evaluation.metrics import position_drift
    return position_drift(sol, gt, t_start, t_end)


def score_case(sol: NavSolution, mission: Mission, starts: list[float], window_s: float) -> list[dict]:
    """Per-window metrics of one solution: ``vrmse_window``, ``vrmse_mission``, ``pos_err_window_end_m``
    (drift over the window, m), ``distance_window_m`` (horizontal distance the GT travelled in it) and
    ``drift_pct_window`` (% DT: the two divided, None under
    :data:`graphnav.evaluation.metrics.MIN_DISTANCE_M`), ``pos_err_abs_window_end_m`` (error at the window
    end), ``nees_window`` (mean velocity NEES over the window, 3 for a consistent estimator),
    ``nees_pos_window`` (horizontal position, 2) and ``nees_heading_window`` (1; each None without its
    covariance); and the mission's: ``drift_pct_mission`` (end horizontal error / distance travelled, %),
    ``pos_err_mission_end_m``, ``distance_mission_m``, and its NEES (:func:`mission_nees`: velocity, position,
    heading)."""
    from graphnav.evaluation.consistency import scoring_reference, window_pose_nees
    from graphnav.evaluation.metrics import (
        horizontal_position_error,
        mission_drift,
        nees_velocity,
        vrmse,
        window_drift,
    )
    gt = mission.gt
    v_mission = float(vrmse(sol, gt, mission.t0, mission.t1))
    consistency = mission_nees(sol, mission)
    whole = mission_drift(sol, gt)
    drift_mission = {"drift_pct_mission": whole["drift_pct"], "pos_err_mission_end_m": whole["end_error_m"],
                     "distance_mission_m": whole["distance_m"]}
    has_cov = any(c is not None for c in (sol.cov_v_n, sol.cov_p_n, sol.cov_rot_b))
    reference = scoring_reference(sol, mission) if has_cov else gt
    out = []
    for s in starts:
        nees = None
        if sol.cov_v_n is not None:
            nees = float(np.mean(nees_velocity(sol, reference, s, s + window_s)))
        drift = window_drift(sol, gt, s, s + window_s)
        out.append({
            "window_start_s": float(s),
            "vrmse_window": float(vrmse(sol, gt, s, s + window_s)),
            "vrmse_mission": v_mission,
            "pos_err_window_end_m": drift["drift_m"],
            "distance_window_m": drift["distance_m"],
            "drift_pct_window": drift["drift_pct"],
            "pos_err_abs_window_end_m": float(horizontal_position_error(sol, gt, s + window_s)),
            "nees_window": nees,
            **window_pose_nees(sol, reference, s, s + window_s),
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


def nees_section(records: list[dict], grades, scenarios, methods) -> list[str]:
    """Report lines: velocity NEES per method over the mission and in the windows, with the 95 % chi-square
    band, the share of trajectories inside it, and how much of the NEES the GT's own error explains."""
    from graphnav.evaluation.consistency import chi2_band
    lines = ["## Consistency (NEES)", "",
             "Mean velocity NEES (3 dof; 3 = consistent) over each mission after "
             f"{NEES_SETTLE_S:g} s (`mission`, mean and range over trajectories) and over the windows (`windows`). "
             "Band: 95 % chi-square band of a mission mean, counting one independent epoch per 10 s "
             "(errors are correlated in time; `graphnav.evaluation.consistency`). `+GT`: NEES with the ground truth's own "
             "velocity error added to the estimator's covariance (A-KIT: identified by "
             "`experiments/identify_noise.py`, an upper bound of the GT's error); `GT share`: the part of the "
             "NEES that the GT's error explains, `1 - NEES(+GT) / NEES`. The reference at an estimate's epoch is the "
             "nearest GT sample carried to it by the IMU (a 1 Hz GT linearly interpolated misses the motion "
             "within the second: 0.1 m/s in waves at the surface); `interp. GT`: the mission NEES against the "
             "linearly interpolated GT, as scored before. One trajectory with a bad stretch dominates a mean; "
             "the median over trajectories does not.", ""]
    for grade in grades:
        for sc in scenarios:
            rows = []
            for m in methods:
                rs = [r for r in records if (r["imu_grade"], r["scenario"], r["method"]) == (grade, sc, m)
                      and not r.get("error") and r.get("nees_mission") is not None]
                if not rs:
                    continue
                per_traj = {r["trajectory"]: r for r in rs}.values()     # one mission value per trajectory
                nees = [r["nees_mission"] for r in per_traj]
                n_ind = int(np.median([r["nees_n_independent"] for r in per_traj]))
                lo, hi = chi2_band(n_ind)
                inside = sum(lo <= x <= hi for x in nees)
                gt = [r["nees_mission_gt"] for r in per_traj if r.get("nees_mission_gt") is not None]
                gt_mean = _mean(gt) if gt else float("nan")
                share = 1.0 - gt_mean / _mean(nees) if gt else float("nan")
                interp = [r["nees_mission_interp"] for r in per_traj if r.get("nees_mission_interp") is not None]
                rows.append(f"| {m} | {_f(_mean(nees), 1)} ({_f(min(nees), 1)}-{_f(max(nees), 1)}) | "
                            f"{_f(float(np.median(nees)), 1)} | "
                            f"{_f(_mean(r.get('nees_window') for r in rs), 1)} | {lo:.2f}-{hi:.2f} | "
                            f"{inside}/{len(nees)} | {_f(gt_mean, 1)} | "
                            f"{'-' if not math.isfinite(share) else f'{share * 100:.0f}%'} | "
                            f"{_f(_mean(interp), 1) if interp else '-'} |")
            if rows:
                lines += [f"### NEES: {grade}, {sc}", "",
                          "| method | mission NEES (range) | median | windows NEES | 95 % band | inside | +GT "
                          "| GT share | interp. GT |",
                          "| --- | --- | --- | --- | --- | --- | --- | --- | --- |", *rows, ""]
            pose = pose_nees_rows(records, grade, sc, methods)
            if pose:
                lines += [f"### Position and heading NEES: {grade}, {sc}", "",
                          "| method | position NEES (range) | windows | 95 % band | inside | heading NEES (range) "
                          "| windows | 95 % band | inside |",
                          "| --- | --- | --- | --- | --- | --- | --- | --- | --- |", *pose, ""]
    lines[4:4] = ["Position and heading: horizontal position NEES (2 dof; 2 = consistent; north-east, the depth "
                  "being measured directly) and heading NEES (1 dof; 1 = consistent; yaw error wrapped across "
                  "+-180 deg) over each mission after the same settling time, against the GT's position and the "
                  "reference attitude. Their errors are integrals and stay correlated for long: independent epochs "
                  "are counted one per decorrelation time of the normalised error (at least 10 s), so the band "
                  "is wide; `inside` counts trajectories inside their own band. `-`: the estimator reports no "
                  "such covariance.", ""]
    return lines


def _pose_cells(rs: list[dict], key: str, dof: int) -> list[str]:
    """Mission NEES mean (range), window mean, 95 % band at the median independent epochs, trajectories inside
    their own band; "-" cells without values."""
    from graphnav.evaluation.consistency import chi2_band
    per_traj = [r for r in {r["trajectory"]: r for r in rs}.values() if r.get(f"{key}_mission") is not None]
    if not per_traj:
        return ["-"] * 4
    nees = [r[f"{key}_mission"] for r in per_traj]
    n_ind = [r[f"{key}_n_independent"] for r in per_traj]
    lo, hi = chi2_band(int(np.median(n_ind)), dof)
    inside = sum(chi2_band(n, dof)[0] <= x <= chi2_band(n, dof)[1] for x, n in zip(nees, n_ind))
    window = _mean(r.get(f"{key}_window") for r in rs)
    return [f"{_f(_mean(nees), 2)} ({_f(min(nees), 2)}-{_f(max(nees), 2)})", _f(window, 2),
            f"{lo:.2f}-{hi:.2f}", f"{inside}/{len(nees)}"]


def pose_nees_rows(records: list[dict], grade: str, scenario: str, methods) -> list[str]:
    """Table rows of the position (2 dof) and heading (1 dof) NEES per method; only methods with one of them."""
    from graphnav.evaluation.consistency import HEADING_DOF, POSITION_DOF
    rows = []
    for m in methods:
        rs = [r for r in records if (r["imu_grade"], r["scenario"], r["method"]) == (grade, scenario, m)
              and not r.get("error")]
        if not any(r.get("nees_pos_mission") is not None or r.get("nees_heading_mission") is not None for r in rs):
            continue
        cells = _pose_cells(rs, "nees_pos", POSITION_DOF) + _pose_cells(rs, "nees_heading", HEADING_DOF)
        rows.append(f"| {m} | " + " | ".join(cells) + " |")
    return rows


def downsample(sol: NavSolution, rate_hz: float = 10.0) -> NavSolution:
    """Every n-th epoch so that the solution is at most ``rate_hz`` (for saving and plotting)."""
    if len(sol.t) < 3:
        return sol
    step = max(1, int(round(1.0 / (rate_hz * float(np.median(np.diff(sol.t)))))))
    idx = slice(None, None, step)
    take = (lambda a: None if a is None else a[idx])
    return dataclasses.replace(sol, t=sol.t[idx], p_n=sol.p_n[idx], v_n=sol.v_n[idx], C_b_n=sol.C_b_n[idx],
                               cov_v_n=take(sol.cov_v_n), bias_acc=take(sol.bias_acc),
                               bias_gyro=take(sol.bias_gyro), cov_p_n=take(sol.cov_p_n),
                               cov_rot_b=take(sol.cov_rot_b), cov_bias=take(sol.cov_bias), info={})


def solution_file(save_dir: str | Path, trajectory: str, imu_grade: str, scenario: str, method: str) -> Path:
    return Path(save_dir) / f"{trajectory}__{imu_grade}__{scenario}__{method}.npz"


def save_solution(path: Path, sol: NavSolution) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {k: getattr(sol, k) for k in ("t", "p_n", "v_n", "C_b_n", "cov_v_n", "bias_acc", "bias_gyro",
                                           "cov_p_n", "cov_rot_b", "cov_bias")
              if getattr(sol, k) is not None}
    np.savez_compressed(path, method=sol.method, runtime_s=sol.runtime_s, **arrays)


def load_solution(path: str | Path) -> NavSolution:
    with np.load(path) as z:
        get = (lambda k: z[k] if k in z.files else None)
        return NavSolution(method=str(z["method"]), t=z["t"], p_n=z["p_n"], v_n=z["v_n"], C_b_n=z["C_b_n"],
                           cov_v_n=get("cov_v_n"), bias_acc=get("bias_acc"), bias_gyro=get("bias_gyro"),
                           cov_p_n=get("cov_p_n"), cov_rot_b=get("cov_rot_b"), cov_bias=get("cov_bias"),
                           runtime_s=float(z["runtime_s"]))


def run_case(case: BenchCase) -> list[dict]:
    """Run one case and return its records (one per window). Failures give records with ``error`` set and
    the metrics ``None``, so one broken method does not stop a long benchmark."""
    base = {"trajectory": case.trajectory.name, "scenario": case.scenario, "imu_grade": case.imu_grade,
            "window_s": float(case.window_s), "method": case.method}
    try:
        mission = prepared_mission(case.trajectory, case.imu_grade)
        starts = case_windows(mission, case.window_s, case.max_windows)
        if not starts:
            raise ConfigError(f"mission {case.trajectory.name} ({mission.duration:.0f} s) is too short for "
                              f"a {case.window_s:g} s window after 60 s of convergence")
        run_mission = mission.with_outage(*[scenario_outage(case.scenario, s, case.window_s) for s in starts])
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            start = time.perf_counter()
            sol = run_method(run_mission, case.method, case.scenario)
            wall = time.perf_counter() - start
        scores = score_case(sol, mission, starts, case.window_s)
        if case.save_dir is not None:
            save_solution(solution_file(case.save_dir, *base_key(base)), downsample(sol))
        # The estimator's own wall time (excludes loading the completer, which happens once per process).
        runtime = sol.runtime_s if np.isfinite(sol.runtime_s) else wall
        health = sol.info.get("health") or {}
        extra = {"runtime_s": runtime, "mission_duration_s": mission.duration,
                 "completer": sol.info.get("completer", "none"),
                 # what the completer did and how much of it the estimator's screening dropped
                 **{k: sol.info[k] for k in ("completed_beams", "regressed_screening", "completer_usage",
                                             "imu_window_missing", "completer_fallbacks") if k in sol.info},
                 "health_divergences": health.get("n_divergences"), "health_reacquired": health.get("n_reacquired"),
                 "health_nis_per_dof": health.get("nis_mean_per_dof"),
                 "warnings": sorted({str(w.message)[:200] for w in caught})}
        for s in scores:
            reason = divergence_reason(sol, s, s["window_start_s"], s["window_start_s"] + case.window_s)
            s.update(diverged=reason is not None, divergence_reason=reason)
        return [{**base, **s, **extra} for s in scores]
    except Exception as exc:  # noqa: BLE001 - one failed case must not end the benchmark; it is reported
        return [{**base, "window_start_s": None, "vrmse_window": None, "vrmse_mission": None,
                 "pos_err_window_end_m": None, "runtime_s": None, "error": f"{type(exc).__name__}: {exc}"}]


def base_key(base: dict) -> tuple[str, str, str, str]:
    return base["trajectory"], base["imu_grade"], base["scenario"], base["method"]


# --- the whole benchmark ---------------------------------------------------------------------------------
def make_cases(trajectories: list[TrajectorySource], scenarios=SCENARIO_NAMES, grades=IMU_GRADE_CHOICES,
               methods=BENCH_METHODS, window_s: float | list[float] = 30.0, max_windows: int | None = None,
               save_dir: str | None = None, save_first: int = 1) -> list[BenchCase]:
    """All cases, grouped by trajectory then grade (so a worker's mission cache is reused); solutions of the
    first ``save_first`` trajectories are kept in ``save_dir`` for the plots (first window length only).
    ``window_s`` may be a list of window lengths (s): every case is run once per length."""
    windows = [float(w) for w in np.atleast_1d(window_s)]
    if any(w <= 0 for w in windows):
        raise ConfigError(f"window lengths must be > 0 s, got {windows}")
    for s in scenarios:
        check_scenario(s)
    for m in methods:
        check_method(m)
    for g in grades:
        if g != "as-recorded":
            try:
                imu_grade_spec(g)
            except ConfigError as exc:
                raise ConfigError(f"{exc} (or 'as-recorded')") from None
    return [BenchCase(traj, sc, g, m, w, max_windows, save_dir if i < save_first and w == windows[0] else None)
            for i, traj in enumerate(trajectories) for g in grades for w in windows for sc in scenarios
            for m in methods]


def load_results(path: str | Path) -> list[dict]:
    path = Path(path)
    if not path.exists():
        return []
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{path}: not valid JSON ({exc}); move it away or run without --resume") from None
    if not isinstance(data, list):
        raise ConfigError(f"{path}: expected a list of records")
    return data


def run_bench(cases: list[BenchCase], out_dir: str | Path, jobs: int = 1, resume: bool = False,
              progress: bool = True, scheduler: str | None = None) -> list[dict]:
    """Run cases (``jobs`` processes, or on the Dask cluster of ``scheduler``: an address or ``"local"``),
    writing ``out_dir/results.json`` after every finished case.

    With ``resume`` the records already in ``results.json`` are kept and their cases skipped (failed
    cases are run again). Returns all records.
    """
    from tqdm import tqdm

    from graphnav.io.outputs import write_json
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    results_path = out_dir / "results.json"
    records = [r for r in load_results(results_path) if not r.get("error")] if resume else []
    done = {record_key(r) for r in records}
    todo = [c for c in cases if c.key not in done]
    bar = tqdm(total=len(cases), initial=len(cases) - len(todo), desc="bench cases", unit="case",
               disable=not progress, dynamic_ncols=True)

    def finished(new: list[dict]) -> None:
        records.extend(new)
        write_json(results_path, records)
        r = new[0]
        bar.set_postfix_str(f"{r['trajectory']} {r['imu_grade']} {r['scenario']} {r['method']}"
                            + (" FAILED" if r.get("error") else ""), refresh=False)
        bar.update(1)

    write_json(results_path, records)
    try:
        run_tasks(run_case, todo, finished, jobs, scheduler)
    finally:
        bar.close()
    return records


# --- the report ------------------------------------------------------------------------------------------
def _num(x) -> float:
    return float("nan") if x is None else float(x)


def _mean(values) -> float:
    v = [x for x in values if x is not None and math.isfinite(x)]
    return float(np.mean(v)) if v else float("nan")


def _max(values) -> float:
    v = [x for x in values if x is not None and math.isfinite(x)]
    return float(np.max(v)) if v else float("nan")


def improvement_pct(model: float, ref: float) -> float:
    """Signed VRTE, %: ``(ref - model) / ref * 100``; positive when ``model`` has the smaller error.
    (The paper's VRTE is the magnitude of this.)"""
    if not (math.isfinite(model) and math.isfinite(ref)) or ref <= 0:
        return float("nan")
    return (ref - model) / ref * 100.0


def aggregate(records: list[dict]) -> dict:
    """Per (imu_grade, scenario, method): window VRMSE mean/worst, mission VRMSE mean, drift mean, counts,
    the per-window values keyed by (trajectory, window_start_s), mean runtime and real-time factor.

    Diverged windows (``diverged`` true) are left out of the statistics and counted in ``n_diverged`` and
    listed in ``diverged`` as (trajectory, window_start_s, reason)."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for r in records:
        groups[(r["imu_grade"], r["scenario"], r["method"])].append(r)
    out = {}
    for key, rs in groups.items():
        ran = [r for r in rs if not r.get("error")]
        ok = [r for r in ran if not r.get("diverged")]
        bad = [r for r in ran if r.get("diverged")]
        runs = {(r["trajectory"], r["window_s"]): r for r in ran}.values()  # one runtime per run
        runtime = _mean(r["runtime_s"] for r in runs)
        duration = _mean(r.get("mission_duration_s") for r in runs)
        out[key] = {
            "vrmse_window_mean": _mean(r["vrmse_window"] for r in ok),
            "vrmse_window_worst": _max(r["vrmse_window"] for r in ok),
            "vrmse_mission_mean": _mean(r["vrmse_mission"] for r in ok),
            "drift_mean": _mean(r["pos_err_window_end_m"] for r in ok),
            "drift_pct_window": drift_pct_of(ok),
            "drift_pct_mission_mean": _mean(r.get("drift_pct_mission")
                                            for r in {r["trajectory"]: r for r in ok}.values()),
            "nees_mean": _mean(r.get("nees_window") for r in ok),
            "n_windows": len(ok), "n_failed": len(rs) - len(ran), "n_diverged": len(bad),
            "diverged": [(r["trajectory"], r["window_start_s"], r.get("divergence_reason")) for r in bad],
            "per_window": {(r["trajectory"], r["window_start_s"]): _num(r["vrmse_window"]) for r in ok},
            "runtime_mean_s": runtime, "duration_mean_s": duration,
            "realtime_factor": duration / runtime if runtime and runtime > 0 else float("nan"),
            "completers": sorted({r.get("completer", "?") for r in ran}),
        }
    return out


def drift_pct_of(records: list[dict]) -> float:
    """% DT of a set of windows: their summed drift over their summed distance travelled (windows under
    :data:`graphnav.evaluation.metrics.MIN_DISTANCE_M` and records without a distance left out); a mean of
    per-window ratios would let the slowest window dominate. NaN when nothing is left."""
    from graphnav.evaluation.metrics import MIN_DISTANCE_M
    pairs = [(r.get("pos_err_window_end_m"), r.get("distance_window_m")) for r in records]
    pairs = [(e, d) for e, d in pairs if e is not None and d is not None and math.isfinite(e) and math.isfinite(d)
             and d >= MIN_DISTANCE_M]
    distance = sum(d for _, d in pairs)
    return 100.0 * sum(e for e, _ in pairs) / distance if distance > 0 else float("nan")


def natural_key(name: str) -> list:
    """Sort key that puts Trajectory2 before Trajectory10."""
    import re
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", name)]


def _f(x: float, digits: int = 3) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.{digits}f}"


def _pct(x: float) -> str:
    return "-" if not math.isfinite(x) else f"{x:+.0f}%"


def headline(agg: dict, grade: str, scenario: str, model: str = "Graph-HN", ref: str = "HNTC") -> str | None:
    """One sentence: does ``model`` beat ``ref`` in this grade and scenario, by how much, in how many windows."""
    a, b = agg.get((grade, scenario, model)), agg.get((grade, scenario, ref))
    if not a or not b or not a["n_windows"] or not b["n_windows"]:
        return None
    common = sorted(set(a["per_window"]) & set(b["per_window"]))
    wins = sum(a["per_window"][k] < b["per_window"][k] for k in common)
    gain = improvement_pct(a["vrmse_window_mean"], b["vrmse_window_mean"])
    verdict = "beats" if gain >= 0.5 else ("does not beat" if gain <= -0.5 else "ties with")
    return (f"{model} {verdict} {ref}: window VRMSE {_f(a['vrmse_window_mean'])} vs "
            f"{_f(b['vrmse_window_mean'])} m/s ({_pct(gain)}), lower in {wins} of {len(common)} windows")


# --- the regime summary ----------------------------------------------------------------------------------
def aggregate_regimes(records: list[dict]) -> dict:
    """Per (imu_grade, scenario, window_s, method): window VRMSE mean and worst, number of windows, and the
    windows' % DT (:func:`drift_pct_of`)."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for r in records:
        if not r.get("error") and r.get("vrmse_window") is not None:
            groups[(r["imu_grade"], r["scenario"], float(r["window_s"]), r["method"])].append(r)
    return {k: {"mean": _mean(r["vrmse_window"] for r in v), "worst": _max(r["vrmse_window"] for r in v),
                "n": len(v), "drift_pct": drift_pct_of(v)} for k, v in groups.items()}


def _ratio(agg: dict, regime: tuple, model: str, ref: str = "Graph-TC", model_regime: tuple | None = None) -> float:
    """Mean window VRMSE of ``model`` (in ``model_regime``, default ``regime``) over ``ref``'s in ``regime``."""
    a, b = agg.get((*(model_regime or regime), model)), agg.get((*regime, ref))
    if not a or not b or not (b["mean"] > 0):
        return float("nan")
    return a["mean"] / b["mean"]


def _all_beams_ratio(agg: dict, regime: tuple) -> float:
    """Graph-TC with every beam measured (scenario ``none``) over Graph-TC in ``regime``, on the same grade
    and window length: the lowest ratio to Graph-TC a completion can give, since a completion made from past
    pings and the IMU carries no more than the beam it stands for."""
    return _ratio(agg, regime, "Graph-TC", model_regime=(regime[0], "none", regime[2]))


#: Ratio thresholds of the regime verdicts (mean window VRMSE of a method / Graph-TC's).
HELPS_BELOW, HURTS_ABOVE = 0.95, 1.02


def regime_summary(records: list[dict]) -> list[str]:
    """Markdown: the regime table (IMU grade x scenario x window length; mean and worst window VRMSE per
    method of :data:`REGIME_METHODS`, Graph-HN and the batch as a ratio of Graph-TC) and, generated from
    those numbers, where the hybrid helps, where it is neutral, where it hurts, and the hybrid's targets."""
    agg = aggregate_regimes(records)
    regimes = sorted({k[:3] for k in agg}, key=lambda r: (
        list(dict.fromkeys((*IMU_GRADE_CHOICES, r[0]))).index(r[0]),
        list(dict.fromkeys((*SCENARIO_NAMES, r[1]))).index(r[1]), r[2]))
    methods = [m for m in REGIME_METHODS if any(k[3] == m for k in agg)]
    if not regimes or "Graph-TC" not in methods:
        return []
    lines = ["## Regimes", "",
             "Window VRMSE, m/s, mean (worst) over all windows of all trajectories, per IMU grade, scenario and "
             "window length; `HN/TC` and `batch/TC` are Graph-HN's and Graph-HN-batch's mean divided by "
             "Graph-TC's; `all-beams/TC` is Graph-TC with every beam measured (scenario `none`, same grade and "
             "window length) divided by Graph-TC: the lowest `HN/TC` a completion can reach. `% DT TC / HN / "
             "batch`: drift over the windows in % of the distance travelled in them (summed drift / summed "
             "distance) of Graph-TC, Graph-HN and Graph-HN-batch.", "",
             "| IMU | scenario | window s | " + " | ".join(methods)
             + " | HN/TC | batch/TC | all-beams/TC | % DT TC / HN / batch | windows |",
             "| --- | --- | --- |" + " --- |" * (len(methods) + 5)]
    for reg in regimes:
        cells = [f"{_f(agg[(*reg, m)]['mean'])} ({_f(agg[(*reg, m)]['worst'])})" if (*reg, m) in agg else "-"
                 for m in methods]
        n = agg.get((*reg, "Graph-TC"), {}).get("n", 0)
        lines.append(f"| {reg[0]} | {reg[1]} | {reg[2]:g} | " + " | ".join(cells) +
                     f" | {_f(_ratio(agg, reg, 'Graph-HN'), 2)} | {_f(_ratio(agg, reg, 'Graph-HN-batch'), 2)}"
                     f" | {_f(_all_beams_ratio(agg, reg), 2)} | "
                     + " / ".join(_f(agg.get((*reg, m), {}).get("drift_pct", float("nan")), 2)
                                  for m in ("Graph-TC", "Graph-HN", "Graph-HN-batch"))
                     + f" | {n} |")
    lines.append("")
    lossy = [r for r in regimes if r[1] != "none"]

    def verdicts(model: str, ref: str = "Graph-TC") -> list[str]:
        rated = [(r, _ratio(agg, r, model, ref)) for r in lossy]
        rated = [(r, x) for r, x in rated if math.isfinite(x)]
        if not rated:
            return []
        name = lambda r, x: f"{r[0]}/{r[1]}/{r[2]:g} s ({x:.2f}x)"  # noqa: E731
        helps = [name(r, x) for r, x in rated if x < HELPS_BELOW]
        neutral = [name(r, x) for r, x in rated if HELPS_BELOW <= x <= HURTS_ABOVE]
        hurts = [name(r, x) for r, x in rated if x > HURTS_ABOVE]
        out = [f"- {model} vs {ref} over {len(rated)} regimes with missing beams: "
               f"helps (< {HELPS_BELOW:g}x) in {len(helps)}, neutral in {len(neutral)}, "
               f"hurts (> {HURTS_ABOVE:g}x) in {len(hurts)}."]
        if helps:
            out.append(f"  - helps: {', '.join(helps)}")
        if hurts:
            out.append(f"  - hurts: {', '.join(hurts)}")
        best = min(rated, key=lambda rx: rx[1])
        out.append(f"  - largest gain: {name(*best)}; worst case: {name(*max(rated, key=lambda rx: rx[1]))}")
        return out

    lines += ["Where the hybrid helps (generated from the table):", ""]
    for model in ("Graph-HN", "Graph-HN-batch", "Graph-MP"):
        lines += verdicts(model)
    # the batch's gain split: smoothing alone (Graph-TC-batch) against what the completions add to it
    lines += verdicts("Graph-TC-batch")
    lines += verdicts("Graph-HN-batch", "Graph-TC-batch")
    # the hybrid's targets, checked on the same numbers
    checks = []
    hn = [(r, _ratio(agg, r, "Graph-HN")) for r in lossy]
    hn = [(r, x) for r, x in hn if math.isfinite(x)]
    if hn:
        bad = [r for r, x in hn if x > HURTS_ABOVE]
        checks.append(f"- never hurts (Graph-HN <= {HURTS_ABOVE:g}x Graph-TC in every regime): "
                      + ("holds" if not bad else f"fails in {len(bad)} of {len(hn)}"))
    hard = [(r, x) for r, x in hn if r[0] in ("tactical", "mems") and (r[1] == "3-missing" or "0-" in r[1]
                                                                        or "outage" in r[1]) and r[2] >= 60]
    if hard:
        bad = [r for r, x in hard if x > 0.7]
        out_of_reach = [r for r in bad if _all_beams_ratio(agg, r) > 0.7]
        checks.append("- helps where it can (Graph-HN <= 0.7x Graph-TC, tactical/MEMS, 3-missing and total "
                      "outage, 60-120 s): " + ("holds" if not bad else f"fails in {len(bad)} of {len(hard)}")
                      + (f"; in {len(out_of_reach)} of these even Graph-TC with all four beams measured is above "
                         f"0.7x ({', '.join(f'{r[0]}/{r[1]}/{r[2]:g} s' for r in out_of_reach)})"
                         if out_of_reach else ""))
    bt = [(r, _ratio(agg, r, "Graph-HN-batch")) for r in lossy]
    bt = [(r, x) for r, x in bt if math.isfinite(x)]
    if bt:
        bad = [r for r, x in bt if x > 0.8]
        checks.append("- batch smoother <= 0.8x Graph-TC in every cell with missing beams: "
                      + ("holds" if not bad else f"fails in {len(bad)} of {len(bt)}"))
    if checks:
        lines += ["", "Targets of the hybrid methods (docs/decisions/regressed-beams.md):", ""] + checks
    return lines + [""]


def make_report(records: list[dict], meta: dict | None = None) -> str:
    """``report.md`` text: per IMU grade the paper-style table and a detailed table per scenario, the
    Graph-HN vs HNTC headline, runtime and real-time factor per method, and the benchmark's settings."""
    meta = meta or {}
    agg = aggregate(records)
    grades = [g for g in (*IMU_GRADE_CHOICES, *sorted({r["imu_grade"] for r in records}))
              if any(k[0] == g for k in agg)]
    grades = list(dict.fromkeys(grades))
    scenarios = [s for s in SCENARIO_NAMES if any(k[1] == s for k in agg)]
    methods = [m for m in METHODS if any(k[2] == m for k in agg)]
    methods += sorted({k[2] for k in agg} - set(methods))
    trajectories = sorted({r["trajectory"] for r in records}, key=natural_key)
    lines = ["# graphnav benchmark report", ""]
    if meta.get("command"):
        lines += [f"Command: `{meta['command']}`", ""]
    lines += [f"Trajectories ({len(trajectories)}): {', '.join(trajectories)}  ",
              f"Windows: {', '.join(f'{w:g}' for w in np.atleast_1d(meta.get('window_s', 30.0)))} s outages "
              "starting 60 s into each mission and then every "
              f"window + 60 s (>= 60 s of full beams between windows; each window scored on its own; "
              f"`none` scores the same windows with all beams).  ",
              "VRMSE: m/s against ground truth, over the window (mean and worst over windows and "
              "trajectories) and over the whole mission (mean). VRTE: signed improvement "
              "`(ref - model) / ref` of the mean window VRMSE, positive = better than the reference; "
              "baseline = LC for LC/Average-LC/HNLC and TC for the rest, average = Average-LC or Average-TC "
              "likewise. Drift: horizontal position error accumulated over the window, m. % DT window: that drift "
              "in % of the horizontal distance the reference travelled in the window (summed drift over summed "
              "distance of all windows); % DT mission: horizontal error at the mission's end in % of the "
              "distance travelled over the mission (mean over trajectories). NEES: mean velocity "
              "NEES over the window (3 = consistent; much larger = the estimator's sigma is too small). "
              f"Diverged windows (non-finite, window VRMSE >= {DIVERGED_VRMSE_MPS:g} m/s, or the estimator's "
              "health monitor diverged during the window) are not averaged in: they are counted in brackets "
              "and listed under 'Diverged runs'.", ""]
    if len(np.atleast_1d(meta.get("window_s", 30.0))) > 1:
        lines += ["With several window lengths, the per-grade tables below pool them; the regime table "
                  "separates them.", ""]
    lines += regime_summary(records)
    if meta.get("wall_time_s") is not None:
        lines += [f"Wall time: {meta['wall_time_s']:.0f} s with {meta.get('jobs', 1)} job(s).", ""]
    failed = [r for r in records if r.get("error")]
    if failed:
        lines += [f"**{len(failed)} case(s) failed** (first: {failed[0]['method']} on {failed[0]['trajectory']}"
                  f" {failed[0]['imu_grade']} {failed[0]['scenario']}: {failed[0]['error'][:200]})", ""]

    for grade in grades:
        title = grade
        if grade != "as-recorded":
            spec = imu_grade_spec(grade)
            title += (f" (IMU degraded: accel bias {spec.accel_bias_sigma:.3g} m/s^2, gyro bias "
                      f"{np.rad2deg(spec.gyro_bias_sigma) * 3600:.3g} deg/h, accel noise "
                      f"{spec.accel_noise_density:.3g} m/s^2/sqrt(Hz), gyro noise "
                      f"{np.rad2deg(spec.gyro_noise_density) * 60:.3g} deg/sqrt(h), bias random walk "
                      f"{spec.accel_bias_rw:.2g} m/s^3/sqrt(Hz), {spec.gyro_bias_rw:.2g} rad/s^2/sqrt(Hz))")
        lines += [f"## IMU grade: {title}", "",
                  "Window VRMSE, m/s, mean (worst):", "",
                  "| scenario | " + " | ".join(methods) + " |",
                  "| --- |" + " --- |" * len(methods)]
        for sc in scenarios:
            cells = []
            for m in methods:
                a = agg.get((grade, sc, m))
                cells.append("-" if not a else f"{_f(a['vrmse_window_mean'])} ({_f(a['vrmse_window_worst'])})"
                             + (f" [{a['n_diverged']} diverged]" if a["n_diverged"] else ""))
            lines.append(f"| {sc} | " + " | ".join(cells) + " |")
        lines.append("")
        for sc in scenarios:
            heads = [h for h in (headline(agg, grade, sc), headline(agg, grade, sc, "Graph-HN-batch"))
                     if h]
            lines += [f"### {grade}, {sc}", ""] + [f"- {h}" for h in heads] + ([""] if heads else [])
            lines += ["| method | VRMSE window mean | worst | VRMSE mission | drift (m) | % DT window | % DT mission "
                      "| VRTE vs baseline | VRTE vs average | NEES | windows | completer |",
                      "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
            for m in methods:
                a = agg.get((grade, sc, m))
                if not a:
                    continue
                # a name the registry does not know (results of another version) is compared with nothing
                record = METHODS.get(m)
                base_name, avg_name = (record.baseline, record.average) if record else (m, m)
                base = agg.get((grade, sc, base_name), {}).get("vrmse_window_mean", float("nan"))
                avg = agg.get((grade, sc, avg_name), {}).get("vrmse_window_mean", float("nan"))
                vs_base = "-" if m == base_name else _pct(improvement_pct(a["vrmse_window_mean"], base))
                vs_avg = "-" if m == avg_name else _pct(improvement_pct(a["vrmse_window_mean"], avg))
                n = f"{a['n_windows']}" + (f" ({a['n_failed']} failed)" if a["n_failed"] else "") \
                    + (f" (+{a['n_diverged']} diverged)" if a["n_diverged"] else "")
                lines.append(f"| {m} | {_f(a['vrmse_window_mean'])} | {_f(a['vrmse_window_worst'])} | "
                             f"{_f(a['vrmse_mission_mean'])} | {_f(a['drift_mean'], 2)} | "
                             f"{_f(a['drift_pct_window'], 2)} | {_f(a['drift_pct_mission_mean'], 2)} | "
                             f"{vs_base} | {vs_avg} | "
                             f"{_f(a['nees_mean'], 1)} | {n} | {', '.join(a['completers'])} |")
            lines.append("")

    diverged = [(k, a) for k, a in sorted(agg.items()) if a["n_diverged"]]
    lines += ["## Diverged runs", ""]
    if not diverged:
        lines += ["None: no window diverged.", ""]
    else:
        lines += [f"{sum(a['n_diverged'] for _, a in diverged)} window(s) diverged; they are not in the means "
                  "above.", "", "| IMU grade | scenario | method | windows | trajectory, window start (s): reason |",
                  "| --- | --- | --- | --- | --- |"]
        for (grade, sc, m), a in diverged:
            listed = "; ".join(f"{t} {s:.0f}: {why}" for t, s, why in a["diverged"][:10])
            more = f"; ... {a['n_diverged'] - 10} more" if a["n_diverged"] > 10 else ""
            lines.append(f"| {grade} | {sc} | {m} | {a['n_diverged']} | {listed}{more} |")
        lines.append("")


    lines += nees_section(records, grades, scenarios, methods)
    lines += ["## Runtime", "", "Wall time of one method run over a whole mission (mean over runs) and the "
              "real-time factor (mission duration / wall time).", "",
              "| method | runtime (s) | real-time factor | runs |", "| --- | --- | --- | --- |"]
    for m in methods:
        runs = {(r["trajectory"], r["imu_grade"], r["scenario"]): r for r in records
                if r["method"] == m and not r.get("error")}.values()
        rt = _mean(r["runtime_s"] for r in runs)
        dur = _mean(r.get("mission_duration_s") for r in runs)
        rtf = dur / rt if rt and math.isfinite(rt) and rt > 0 else float("nan")
        lines.append(f"| {m} | {_f(rt, 2)} | {_f(rtf, 0) + ('x' if math.isfinite(rtf) else '')} | {len(runs)} |")
    lines.append("")
    if len(trajectories) > 1:
        lines += ["## Per trajectory", "", "Window VRMSE (m/s), mean over the windows of each trajectory.", ""]
        for grade in grades:
            for sc in [s for s in scenarios if s != "none"]:
                lines += [f"### Per trajectory: {grade}, {sc}", "", "| trajectory | " + " | ".join(methods) + " |",
                          "| --- |" + " --- |" * len(methods)]
                for traj in trajectories:
                    cells = [_f(_mean(r["vrmse_window"] for r in records
                                      if (r["imu_grade"], r["scenario"], r["method"], r["trajectory"])
                                      == (grade, sc, m, traj) and not r.get("error") and not r.get("diverged")))
                             for m in methods]
                    lines.append(f"| {traj} | " + " | ".join(cells) + " |")
                lines.append("")
    if meta.get("plots"):
        lines += ["## Plots", ""] + [f"- [{Path(p).name}]({p})" for p in meta["plots"]] + [""]
    return "\n".join(lines)
