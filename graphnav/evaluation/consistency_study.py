"""The consistency study: velocity NEES and window VRMSE of each method, graph methods with and without the
DVL error states, on every trajectory; and the check of the reference the NEES is scored against.

The graph methods (the registry's graph family) run with each named setting of :data:`SETTINGS`, the
others once. Per trajectory (:func:`run_trajectory`, one task of :func:`run_study`) and scenario, each method runs with the
bench's windows (:func:`graphnav.evaluation.bench.case_windows`) and is scored:

- window VRMSE (m/s, mean over the windows) as ``graphnav bench`` computes it (:func:`~graphnav.evaluation.
  bench.score_case`), and the mean window NEES with the fraction of windows inside one window's 95 % band;
- mean velocity NEES over the mission after :data:`SETTLE_S`, against the GT carried to each epoch by the IMU
  (:func:`graphnav.evaluation.consistency.scoring_reference`), with the GT's own velocity error added
  (``gt_sigma``: :func:`~graphnav.evaluation.consistency.nees_with_reference`), and against the linearly
  interpolated GT.

:func:`study_table` and :func:`per_trajectory_table` print the rows; :func:`reference_check_table` compares the
recorded DVL with the two references. ``graphnav consistency`` is the command; the measured numbers and the
defaults they set are in ``docs/decisions/consistency.md``.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from graphnav.evaluation.methods import GRAPH_METHODS

#: Seconds after the mission start left out of the mission NEES (initial convergence).
SETTLE_S = 60.0
#: Named settings of the graph methods' options (a dict is merged into each method's own defaults).
SETTINGS: dict[str, dict] = {"off": {"dvl_error_states": False}, "on": {"dvl_error_states": True}}


def run_trajectory(task: tuple) -> list[dict]:
    """One trajectory: ``(source, methods, scenarios, setting names, gt_sigma (3,) m/s NED, window_s)`` -> one
    row per scenario, method and setting (non-graph methods: setting ``off`` only). Module level, plain data:
    it runs in worker processes."""
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation.bench import case_windows, prepared_mission, score_case
    from graphnav.evaluation.consistency import chi2_band, n_independent, nees_with_reference, scoring_reference
    from graphnav.evaluation.methods import run_method
    from graphnav.evaluation.metrics import nees_velocity
    source, methods, scenarios, setting_names, gt_sigma, window_s = task
    mission = prepared_mission(source, "as-recorded")
    starts = case_windows(mission, window_s)
    cov_gt = np.diag(np.square(np.asarray(gt_sigma, dtype=float)))
    w_lo, w_hi = chi2_band(n_independent(np.array([0.0, window_s])))
    t0 = mission.t0 + SETTLE_S
    rows = []
    for scenario in scenarios:
        run_mission = mission.with_outage(*[scenario_outage(scenario, s, window_s) for s in starts])
        for method in methods:
            for name in setting_names:
                if method not in GRAPH_METHODS and name != "off":
                    continue
                options = dict(SETTINGS[name]) if method in GRAPH_METHODS else None
                sol = run_method(run_mission, method, scenario, options=options)
                scores = score_case(sol, mission, starts, window_s)
                reference = scoring_reference(sol, mission)
                win_nees = [s["nees_window"] for s in scores]
                rows.append({"trajectory": source.name, "scenario": scenario, "method": method, "setting": name,
                             "vrmse_window": float(np.mean([s["vrmse_window"] for s in scores])),
                             "nees_window": float(np.mean(win_nees)),
                             "windows_in_band": float(np.mean([w_lo <= x <= w_hi for x in win_nees])),
                             "vrmse_mission": scores[0]["vrmse_mission"],
                             "nees_mission": float(np.mean(nees_velocity(sol, reference, t0))),
                             "nees_mission_gt": float(np.mean(nees_with_reference(sol, reference, cov_gt, t0))),
                             "nees_mission_interp": float(np.mean(nees_velocity(sol, mission.gt, t0))),
                             "n_independent": n_independent(sol.t[sol.t >= t0]), "runtime_s": sol.runtime_s})
    return rows


def run_study(sources, methods, scenarios, setting_names=("off", "on"), gt_sigma=(0.0, 0.0, 0.0),
              window_s: float = 30.0, jobs: int = 1, scheduler: str | None = None,
              finished: Callable[[list[dict]], None] | None = None) -> list[dict]:
    """:func:`run_trajectory` over ``sources`` (:class:`graphnav.evaluation.bench.TrajectorySource`) through the
    task runner; ``finished(rows)`` sees each trajectory's rows as it completes. Returns all rows."""
    from graphnav.evaluation.tasks import run_tasks
    rows: list[dict] = []

    def collect(new: list[dict]) -> None:
        rows.extend(new)
        if finished is not None:
            finished(new)
    tasks = [(s, list(methods), list(scenarios), list(setting_names), tuple(gt_sigma), window_s) for s in sources]
    run_tasks(run_trajectory, tasks, collect, jobs=jobs, scheduler=scheduler)
    return rows


def _settings_of(method: str, setting_names) -> list[str]:
    return [s for s in setting_names if method in GRAPH_METHODS or s == "off"]


def study_table(rows: list[dict], methods, scenarios, setting_names, gt_sigma) -> str:
    """Per method and setting: mean window VRMSE per scenario (m/s), the mission NEES (all beams) as mean over
    trajectories with its min-max, the NEES with the GT's error, and the 95 % band of one trajectory."""
    from graphnav.evaluation.consistency import chi2_band
    n_traj = len({r["trajectory"] for r in rows})
    lines = [f"{n_traj} trajectories; NEES = mean velocity NEES over the mission after {SETTLE_S:g} s, all beams; "
             f"NEES+GT with GT sigma {list(gt_sigma)} m/s (N, E, D)", "",
             "| method | DVL error states | " + " | ".join(f"VRMSE window {s}" for s in scenarios)
             + " | NEES (min-max over traj.) | NEES+GT | 95 % band per traj. |",
             "| --- | --- |" + " --- |" * len(scenarios) + " --- | --- | --- |"]
    for method in methods:
        for name in _settings_of(method, setting_names):
            sel = [r for r in rows if r["method"] == method and r["setting"] == name]
            if not sel:
                continue
            cells = []
            for s in scenarios:
                v = [r["vrmse_window"] for r in sel if r["scenario"] == s]
                cells.append(f"{np.mean(v):.4f}" if v else "-")
            full = [r for r in sel if r["scenario"] == "none"]
            if full:
                nees = [r["nees_mission"] for r in full]
                nees_gt = [r["nees_mission_gt"] for r in full]
                band = chi2_band(int(np.median([r["n_independent"] for r in full])))
                tail = (f"{np.mean(nees):.1f} ({min(nees):.1f}-{max(nees):.1f}) | {np.mean(nees_gt):.1f} | "
                        f"{band[0]:.2f}-{band[1]:.2f}")
            else:
                tail = "- (needs scenario none) | - | -"
            lines.append(f"| {method} | {name} | " + " | ".join(cells) + f" | {tail} |")
    return "\n".join(lines)


def per_trajectory_table(rows: list[dict], methods, setting_names) -> str:
    """Per trajectory and method, all beams: mission NEES / +GT / mean window NEES / windows inside the 95 %
    band of one window."""
    full = [r for r in rows if r["scenario"] == "none"]
    names = sorted({r["trajectory"] for r in full}, key=lambda n: (len(n), n))
    cols = [(m, s) for m in methods for s in _settings_of(m, setting_names)]
    lines = ["All beams, per trajectory: mission NEES / +GT / window NEES / windows inside the 95 % band", "",
             "| trajectory | " + " | ".join(f"{m} ({s})" for m, s in cols) + " |", "| --- |" + " --- |" * len(cols)]
    for n in names:
        cells = []
        for m, s in cols:
            r = next((r for r in full if r["trajectory"] == n and r["method"] == m and r["setting"] == s), None)
            cells.append("-" if r is None else f"{r['nees_mission']:.1f} / {r['nees_mission_gt']:.1f} / "
                         f"{r['nees_window']:.1f} / {r['windows_in_band']:.0%}")
        lines.append(f"| {n} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def reference_errors(mission, surface_m: float = 1.0) -> dict:
    """Recorded DVL velocity minus the reference body velocity (lever arm included) at the pings, RMS per body
    axis (m/s) after the trajectory's median, for pings deeper / shallower than ``surface_m``: the GT
    interpolated linearly (``GroundTruth.at``) and carried by the IMU (``calibration.reference.Reference``).
    Returns ``{"n_deep", "n_surface", "linear": (deep (3,) or None, surface), "imu_carried": (...)}``."""
    from graphnav.calibration.reference import mission_reference as imu_aided_reference
    ref = imu_aided_reference(mission)
    ok = np.all(np.isfinite(mission.dvl.v_b), axis=1) & ref.covers(mission.dvl.t)
    t = mission.dvl.t[ok]
    lever = np.cross(ref.omega_nb_b(t), mission.config.dvl.lever_arm_b)
    _, v_lin, C_lin = mission.gt.at(t)
    depth = (np.interp(t, mission.depth.t, mission.depth.depth) if mission.depth is not None
             else np.full(len(t), np.inf))
    deep = depth >= surface_m
    out = {"n_deep": int(deep.sum()), "n_surface": int((~deep).sum())}
    for name, v_ref in (("linear", np.einsum("kji,kj->ki", C_lin, v_lin) + lever),
                        ("imu_carried", ref.v_b(t) + lever)):
        e = mission.dvl.v_b[ok] - v_ref
        e -= np.median(e[deep], axis=0) if deep.any() else 0.0
        out[name] = tuple(np.sqrt(np.mean(e[sel] ** 2, axis=0)) if sel.any() else None for sel in (deep, ~deep))
    return out


def reference_check_table(sources, surface_m: float = 1.0) -> str:
    """:func:`reference_errors` of every source as a Markdown table (body x / y / z RMS, m/s)."""
    from graphnav.evaluation.bench import prepared_mission

    def cell(x):
        return "-" if x is None else " / ".join(f"{v:.3f}" for v in x)
    lines = ["| trajectory | pings deep / surface | linear GT: deep | surface | IMU-carried GT: deep | surface |",
             "| --- | --- | --- | --- | --- | --- |"]
    for source in sources:
        r = reference_errors(prepared_mission(source, "as-recorded"), surface_m)
        lines.append(f"| {source.name} | {r['n_deep']} / {r['n_surface']} | {cell(r['linear'][0])} | "
                     f"{cell(r['linear'][1])} | {cell(r['imu_carried'][0])} | {cell(r['imu_carried'][1])} |")
    return "\n".join(lines)
