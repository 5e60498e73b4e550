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
  interpolated GT; and split along the body axes (:func:`~graphnav.evaluation.consistency.body_axis_nees`);
- horizontal position NEES (:data:`~graphnav.evaluation.consistency.POSITION_DOF` = 2 dof) and heading NEES
  (:data:`~graphnav.evaluation.consistency.HEADING_DOF` = 1 dof) over the mission with their independent epochs
  for the chi-square band, as ``score_case`` reports them (None for an estimator without that covariance);
- drift in % of the distance travelled: over the windows (summed drift / summed distance,
  :func:`graphnav.evaluation.bench.drift_pct_of`) and at the mission's end.

:func:`study_table` and :func:`per_trajectory_table` print the rows; :func:`reference_check_table` compares the
recorded DVL with the two references; :func:`run_drift_check` and :func:`drift_check_table` measure how much of
the window % DT a stamp offset between estimate and reference explains. ``graphnav consistency`` is the
command; the measured numbers and the defaults they set are in ``docs/decisions/consistency.md`` and
``docs/decisions/position-consistency.md``.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from graphnav.evaluation.consistency import DOF, NEES_SETTLE_S
from graphnav.evaluation.methods import GRAPH_METHODS

#: Seconds after the mission start left out of the mission NEES (initial convergence): the benchmark's.
SETTLE_S = NEES_SETTLE_S
#: Named settings of the graph methods' options (a dict is merged into each method's own defaults).
SETTINGS: dict[str, dict] = {"off": {"dvl_error_states": False}, "on": {"dvl_error_states": True}}
#: The mission's position / heading NEES fields of ``score_case`` a row carries (mean NEES and the independent
#: epochs of its band; None without the covariance).
POSE_FIELDS = ("nees_pos_mission", "nees_pos_n_independent", "nees_heading_mission", "nees_heading_n_independent")


def run_trajectory(task: tuple) -> list[dict]:
    """One trajectory: ``(source, methods, scenarios, setting names, gt_sigma (3,) m/s NED, window_s)`` -> one
    row per scenario, method and setting (non-graph methods: setting ``off`` only). Module level, plain data:
    it runs in worker processes."""
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation.bench import case_windows, drift_pct_of, prepared_mission, score_case
    from graphnav.evaluation.consistency import chi2_band, mean_velocity_nees, n_independent, scoring_reference
    from graphnav.evaluation.methods import run_method
    source, methods, scenarios, setting_names, gt_sigma, window_s = task
    mission = prepared_mission(source, "as-recorded")
    starts = case_windows(mission, window_s)
    cov_gt = np.diag(np.square(np.asarray(gt_sigma, dtype=float)))
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
                reference = scoring_reference(sol, mission)
                scores = score_case(sol, mission, starts, window_s, reference)
                win_nees = [s["nees_window"] for s in scores]
                # a window holds one independent epoch per decorrelation time of the run's velocity error
                tau = scores[0]["nees_decorrelation_s"] or window_s
                w_lo, w_hi = chi2_band(n_independent(np.array([0.0, window_s]), tau))
                rows.append({"trajectory": source.name, "scenario": scenario, "method": method, "setting": name,
                             "vrmse_window": float(np.mean([s["vrmse_window"] for s in scores])),
                             "nees_window": float(np.mean(win_nees)),
                             "windows_in_band": float(np.mean([w_lo <= x <= w_hi for x in win_nees])),
                             "vrmse_mission": scores[0]["vrmse_mission"],
                             # the benchmark's mission NEES; with the study's reference error (--gt-sigma)
                             "nees_mission": scores[0]["nees_mission"],
                             "nees_mission_gt": mean_velocity_nees(sol, reference, t0, cov_gt),
                             "nees_mission_interp": scores[0]["nees_mission_interp"],
                             # one per decorrelation time of the velocity error (the mission scores')
                             "n_independent": scores[0]["nees_n_independent"], "runtime_s": sol.runtime_s,
                             "nees_axes_b": scores[0]["nees_axes_b"],
                             "drift_pct_window": drift_pct_of(scores),
                             "distance_window_sum_m": counted_distance(scores),
                             "drift_pct_mission": scores[0]["drift_pct_mission"],
                             **{k: scores[0][k] for k in POSE_FIELDS}})
    return rows


def counted_distance(scores: list[dict]) -> float:
    """Summed horizontal distance (m) of the windows :func:`graphnav.evaluation.bench.drift_pct_of` counts
    (finite drift and distance, at least :data:`graphnav.evaluation.metrics.MIN_DISTANCE_M`): the weight that
    pools several trajectories' window % DT into one summed drift / summed distance."""
    from graphnav.evaluation.metrics import MIN_DISTANCE_M
    return float(sum(r["distance_window_m"] for r in scores
                     if _finite(r.get("pos_err_window_end_m")) and _finite(r.get("distance_window_m"))
                     and r["distance_window_m"] >= MIN_DISTANCE_M))


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
    """Per method and setting: mean window VRMSE (m/s) and window % DT (summed over the trajectories' windows)
    per scenario; all beams: the mission velocity NEES as mean over trajectories with its min-max, the NEES with
    the GT's error, the 95 % band of one trajectory, the velocity NEES per body axis (mean over trajectories), the
    position (2 dof) and heading (1 dof) NEES with their bands, and the mission % DT (mean over trajectories). A mean
    NEES is judged against the band of a mean over that many trajectories (:func:`_mean_verdict`)."""
    from graphnav.evaluation.consistency import HEADING_DOF, POSITION_DOF, chi2_band
    n_traj = len({r["trajectory"] for r in rows})
    lines = [f"{n_traj} trajectories; NEES = mean velocity NEES over the mission after {SETTLE_S:g} s, all beams; "
             f"NEES+GT with GT sigma {list(gt_sigma)} m/s (N, E, D); position NEES horizontal ({POSITION_DOF} dof), "
             f"heading NEES ({HEADING_DOF} dof), each with its 95 % band at the median independent epochs; % DT = "
             "drift in % of the distance travelled (windows: summed drift / summed distance)", "",
             "| method | DVL error states | " + " | ".join(f"VRMSE window {s}" for s in scenarios) + " | "
             + " | ".join(f"% DT window {s}" for s in scenarios)
             + " | NEES (min-max over traj.) | NEES+GT | 95 % band per traj. | NEES per body axis: forward, "
             "starboard, down (1 each) | position NEES (band) | heading NEES (band) | % DT mission |",
             "| --- | --- |" + " --- |" * (2 * len(scenarios)) + " --- | --- | --- | --- | --- | --- | --- |"]
    for method in methods:
        for name in _settings_of(method, setting_names):
            sel = [r for r in rows if r["method"] == method and r["setting"] == name]
            if not sel:
                continue
            cells = []
            for s in scenarios:
                v = [r["vrmse_window"] for r in sel if r["scenario"] == s]
                cells.append(f"{np.mean(v):.4f}" if v else "-")
            cells += [_pct_window([r for r in sel if r["scenario"] == s]) for s in scenarios]
            full = [r for r in sel if r["scenario"] == "none"]
            if full:
                nees = [r["nees_mission"] for r in full]
                nees_gt = [r["nees_mission_gt"] for r in full]
                n = int(np.median([r["n_independent"] for r in full]))
                band = chi2_band(n)
                tail = (f"{np.mean(nees):.1f} ({min(nees):.1f}-{max(nees):.1f}) | {np.mean(nees_gt):.1f} | "
                        f"{band[0]:.2f}-{band[1]:.2f}{_mean_verdict(float(np.mean(nees)), n, len(full))} | "
                        f"{_axes_cell(full)} | "
                        f"{_pose_cell(full, 'nees_pos', POSITION_DOF)} | "
                        f"{_pose_cell(full, 'nees_heading', HEADING_DOF)} | "
                        f"{_mean_pct([r.get('drift_pct_mission') for r in full])}")
            else:
                tail = "- (needs scenario none) | - | - | - | - | - | -"
            lines.append(f"| {method} | {name} | " + " | ".join(cells) + f" | {tail} |")
    return "\n".join(lines)


def _finite(x) -> bool:
    return x is not None and bool(np.isfinite(x))


def _mean_pct(values) -> str:
    """Mean of the finite % values, 2 decimals, or "-"."""
    v = [x for x in values if _finite(x)]
    return f"{np.mean(v):.2f}" if v else "-"


def _pct_window(rows: list[dict]) -> str:
    """Window % DT of several trajectories' rows pooled as the bench pools windows: their summed drift over
    their summed distance (each row's ``drift_pct_window`` weighted by its ``distance_window_sum_m``), or "-"."""
    ok = [r for r in rows if _finite(r.get("drift_pct_window")) and r.get("distance_window_sum_m", 0.0) > 0]
    if not ok:
        return "-"
    return f"{np.average([r['drift_pct_window'] for r in ok], weights=[r['distance_window_sum_m'] for r in ok]):.2f}"


def _axes_cell(rows: list[dict]) -> str:
    """Mean over trajectories of the velocity NEES per body axis (``nees_axes_b``), "-" where a row has none."""
    axes = [r.get("nees_axes_b") for r in rows]
    if not axes or any(a is None for a in axes):
        return "-"
    return ", ".join(f"{v:.2f}" for v in np.mean(axes, axis=0))


def _pose_cell(rows: list[dict], key: str, dof: int) -> str:
    """Mean mission NEES of ``key`` over the rows (min-max) and the 95 % band at the median independent epochs,
    or "-" when no row has it."""
    from graphnav.evaluation.consistency import chi2_band
    rs = [r for r in rows if _finite(r.get(f"{key}_mission"))]
    if not rs:
        return "-"
    x = [r[f"{key}_mission"] for r in rs]
    n = int(np.median([r[f"{key}_n_independent"] for r in rs]))
    lo, hi = chi2_band(n, dof)
    verdict = _mean_verdict(float(np.mean(x)), n, len(rs), dof)
    return f"{np.mean(x):.2f} ({min(x):.2f}-{max(x):.2f}; band {lo:.2f}-{hi:.2f}{verdict})"


def _mean_verdict(mean: float, n: int, n_traj: int, dof: int = DOF) -> str:
    """"; mean <side> (band over N traj. lo-hi)" when the ``mean`` NEES over ``n_traj`` trajectories of ``n``
    independent epochs each lies outside the 95 % band of such a mean (``dof`` * n * N dof over N: narrower than one
    trajectory's band), else ""."""
    from graphnav.evaluation.consistency import chi2_band, outside_band
    lo, hi = chi2_band(n * n_traj, dof)
    side = outside_band(float(mean), (lo, hi), why=False)
    return f"; mean {side} (band over {n_traj} traj. {lo:.2f}-{hi:.2f})" if side else ""


def per_trajectory_table(rows: list[dict], methods, setting_names) -> str:
    """Per trajectory and method, all beams: mission NEES / +GT / mean window NEES / windows inside the 95 %
    band of one window; then position NEES / heading NEES / window % DT / mission % DT ("-" where the estimator
    has no such covariance or the trajectory too little travel)."""
    full = [r for r in rows if r["scenario"] == "none"]
    names = sorted({r["trajectory"] for r in full}, key=lambda n: (len(n), n))
    cols = [(m, s) for m in methods for s in _settings_of(m, setting_names)]

    def table(title: str, cell) -> list[str]:
        lines = [title, "", "| trajectory | " + " | ".join(f"{m} ({s})" for m, s in cols) + " |",
                 "| --- |" + " --- |" * len(cols)]
        for n in names:
            found = [next((r for r in full if r["trajectory"] == n and r["method"] == m and r["setting"] == s), None)
                     for m, s in cols]
            lines.append(f"| {n} | " + " | ".join("-" if r is None else cell(r) for r in found) + " |")
        return lines

    def velocity(r: dict) -> str:
        return (f"{r['nees_mission']:.1f} / {r['nees_mission_gt']:.1f} / {r['nees_window']:.1f} / "
                f"{r['windows_in_band']:.0%}")

    def position(r: dict) -> str:
        return " / ".join(f"{x:.2f}" if _finite(x) else "-" for x in (
            r.get("nees_pos_mission"), r.get("nees_heading_mission"), r.get("drift_pct_window"),
            r.get("drift_pct_mission")))
    return "\n".join([*table("All beams, per trajectory: mission NEES / +GT / window NEES / windows inside the 95 % "
                             "band", velocity), "",
                      *table("All beams, per trajectory: position NEES / heading NEES / % DT over the windows / "
                             "% DT at the end", position)])


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


# --- drift check: how much of the window % DT a stamp offset explains ------------------------------------------
def stamp_offset_fit(sol, gt) -> float:
    """The stamp offset ``delta`` (s) of the estimate against the reference that best explains its horizontal
    position error: ``e(t) = a + b (t - t0) - v_gt(t) delta`` per north / east axis (offset and trend each, one
    shared ``delta``), least squares over the epochs inside the GT. ``delta > 0``: the estimate is late, its
    stamp ``t`` holding the reference's state at ``t - delta``.

    Raises:
        DataError: fewer than three epochs inside the GT, or a reference that never changes velocity (``delta``
        is then indistinguishable from the offset).
    """
    from graphnav.core.errors import DataError
    from graphnav.evaluation.metrics import align
    at = align(sol, gt)
    ok = np.all(np.isfinite(sol.p_n[at.mask, :2]), axis=1)
    if ok.sum() < 3:
        raise DataError("fewer than three solution epochs inside the ground truth: no stamp offset to fit",
                        sol.method, field="t")
    t = at.t[ok] - at.t[ok][0]
    e = (sol.p_n[at.mask, :2] - at.p_true_n[:, :2])[ok]
    v = at.v_true_n[ok, :2]
    n = len(t)
    A = np.zeros((2 * n, 5))
    A[:n, 0], A[:n, 1], A[n:, 2], A[n:, 3] = 1.0, t, 1.0, t
    A[:n, 4], A[n:, 4] = -v[:, 0], -v[:, 1]
    x, _, rank, _ = np.linalg.lstsq(A, np.concatenate([e[:, 0], e[:, 1]]), rcond=None)
    if rank < 5:
        raise DataError("the reference's velocity is a constant or a ramp: a stamp offset cannot be told from an "
                        "offset and trend of the position error", sol.method, field="v_n")
    return float(x[4])


def window_drifts(sol, gt, starts, window_s: float) -> list[dict]:
    """``pos_err_window_end_m`` and ``distance_window_m`` of each window, as ``score_case`` gives them (its same
    :func:`graphnav.evaluation.metrics.window_drift`), for :func:`graphnav.evaluation.bench.drift_pct_of`."""
    from graphnav.evaluation.metrics import window_drift
    out = []
    for s in starts:
        d = window_drift(sol, gt, s, s + window_s)
        out.append({"pos_err_window_end_m": d["drift_m"], "distance_window_m": d["distance_m"]})
    return out


def drift_check_trajectory(task: tuple) -> list[dict]:
    """One trajectory: ``(source, methods, window_s)`` -> one row per method, all beams, the bench's windows:
    ``delta_s`` (:func:`stamp_offset_fit`), ``drift_pct_window`` as scored, ``drift_pct_window_shifted`` with
    the estimate's stamps moved back by ``delta`` (the part a stamp offset explains removed),
    ``drift_pct_mission``. Module level, plain data: it runs in worker processes."""
    import dataclasses

    from graphnav.evaluation.bench import case_windows, drift_pct_of, prepared_mission
    from graphnav.evaluation.methods import run_method
    from graphnav.evaluation.metrics import mission_drift
    source, methods, window_s = task
    mission = prepared_mission(source, "as-recorded")
    starts = case_windows(mission, window_s)
    rows = []
    for method in methods:
        sol = run_method(mission, method, "none")
        delta = stamp_offset_fit(sol, mission.gt)
        shifted = dataclasses.replace(sol, t=sol.t - delta)
        rows.append({"trajectory": source.name, "method": method, "delta_s": delta,
                     "drift_pct_window": drift_pct_of(window_drifts(sol, mission.gt, starts, window_s)),
                     "drift_pct_window_shifted": drift_pct_of(window_drifts(shifted, mission.gt, starts, window_s)),
                     "drift_pct_mission": mission_drift(sol, mission.gt)["drift_pct"]})
    return rows


def run_drift_check(sources, methods, window_s: float = 30.0, jobs: int = 1, scheduler: str | None = None,
                    finished: Callable[[list[dict]], None] | None = None) -> list[dict]:
    """:func:`drift_check_trajectory` over ``sources`` through the task runner; returns all rows (by
    trajectory, in the order the sources were given)."""
    from graphnav.evaluation.tasks import run_tasks
    rows: list[dict] = []

    def collect(new: list[dict]) -> None:
        rows.extend(new)
        if finished is not None:
            finished(new)
    run_tasks(drift_check_trajectory, [(s, list(methods), window_s) for s in sources], collect, jobs=jobs,
              scheduler=scheduler)
    order = {s.name: i for i, s in enumerate(sources)}
    return sorted(rows, key=lambda r: order.get(r["trajectory"], len(order)))


def drift_check_table(rows: list[dict]) -> str:
    """:func:`drift_check_trajectory`'s rows as a Markdown table."""
    def pct(x) -> str:
        return f"{x:.2f}" if _finite(x) else "-"
    lines = ["Stamp offset delta of the estimate against the reference (> 0: the estimate late), fitted to the "
             "horizontal position error (offset + trend + v_gt * delta); window % DT as scored and with the "
             "estimate's stamps moved back by delta", "",
             "| trajectory | method | delta s | % DT window | without the offset | % DT mission |",
             "| --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['trajectory']} | {r['method']} | {r['delta_s']:+.3f} | {pct(r['drift_pct_window'])} | "
                     f"{pct(r['drift_pct_window_shifted'])} | {pct(r['drift_pct_mission'])} |")
    return "\n".join(lines)
