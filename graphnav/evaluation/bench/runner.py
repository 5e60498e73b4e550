"""The bench runner: one case (:func:`run_case`), all of them with ``results.json`` written after each
(:func:`run_bench`, :func:`load_results`), and the down-sampled solution files the plots read."""
from __future__ import annotations

import dataclasses
import json
import time
import warnings
from pathlib import Path

import numpy as np

from graphnav.core.errors import ConfigError
from graphnav.core.scenarios import scenario_outage
from graphnav.core.solution import NavSolution
from graphnav.evaluation.bench.cases import BenchCase, case_windows, prepared_mission
from graphnav.evaluation.bench.scoring import divergence_reason, score_case
from graphnav.evaluation.methods import run_method
from graphnav.evaluation.tasks import run_tasks


#: Keys of every result record (extra diagnostic keys may follow).
RECORD_KEYS: tuple[str, ...] = ("trajectory", "scenario", "imu_grade", "window_start_s", "window_s", "method",
                                "vrmse_window", "vrmse_mission", "pos_err_window_end_m", "runtime_s", "diverged",
                                "divergence_reason")


def record_key(record: dict) -> tuple:
    return (record["trajectory"], record["scenario"], record["imu_grade"], record["method"],
            float(record["window_s"]))


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
                 **{k: sol.info[k] for k in ("regressed_beams", "regressed_screening", "completer_usage",
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
