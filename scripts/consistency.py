"""Velocity NEES and window VRMSE of the graph methods with and without the DVL error states.

Runs Graph-TC, Graph-HN, Graph-HN-batch (and the EKF TC for reference) on every trajectory of an A-KIT folder
(or the simulated default) with ``GraphOptions(dvl_error_states=False)`` and ``=True``, with the bench's
windows (:func:`graphnav.evaluation.bench.case_windows`) and scenarios, and prints per method and setting:

- window VRMSE (m/s, mean over windows and trajectories) per scenario, as ``graphnav bench`` computes it;
- mean velocity NEES over the mission after the 60 s settling time, all beams (scenario ``none``), against the
  GT carried to each epoch by the IMU (:func:`graphnav.evaluation.consistency.mission_reference`), with the
  95 % chi-square band (:mod:`graphnav.evaluation.consistency`), with the GT's own velocity error added
  (``--gt-sigma``, see ``scripts/identify_noise.py``), and (json only) against the linearly interpolated GT;
- horizontal position NEES (2 dof) and heading NEES (1 dof) over the mission after the settling time, all
  beams, with their 95 % bands (:func:`graphnav.evaluation.consistency.pose_nees`; "-" for an estimator that
  carries no such covariance);
- drift in % of the distance travelled per scenario: over the windows (summed drift / summed distance, as the
  bench's report) and at the mission's end;
- with ``--per-trajectory``: per trajectory mission NEES, +GT, mean window NEES and the fraction of windows
  whose NEES lies inside the 95 % band of one window, then position / heading NEES and % DT.

    .venv/bin/python scripts/consistency.py --data ../shared/data/snapir-2022-akit --jobs 2
"""
from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from graphnav.core.scenarios import scenario_outage
from graphnav.evaluation.bench import (
    case_windows,
    drift_pct_of,
    find_trajectories,
    prepared_mission,
    score_case,
)
from graphnav.evaluation.consistency import (
    HEADING_DOF,
    POSITION_DOF,
    chi2_band,
    mission_reference,
    n_independent,
    nees_with_reference,
)
from graphnav.evaluation.methods import run_method
from graphnav.evaluation.metrics import nees_velocity

GRAPH = ("Graph-TC", "Graph-HN", "Graph-HN-batch")
SETTLE_S = 60.0


def run_trajectory(args) -> list[dict]:
    source, methods, scenarios, settings, gt_sigma, window_s = args
    mission = prepared_mission(source, "as-recorded")
    starts = case_windows(mission, window_s)
    cov_gt = np.diag(np.square(gt_sigma))
    out = []
    for scenario in scenarios:
        run_mission = mission.with_outage(*[scenario_outage(scenario, s, window_s) for s in starts])
        for method in methods:
            for name, fields in settings.items():
                if method not in GRAPH and name != "off":
                    continue
                # a dict is merged into the method's own defaults (Graph-HN's screening of regressed beams)
                options = dict(fields) if method in GRAPH else None
                sol = run_method(run_mission, method, scenario, options=options)
                scores = score_case(sol, mission, starts, window_s)
                t0 = mission.t0 + SETTLE_S
                reference = mission_reference(sol, mission)
                nees = nees_velocity(sol, reference, t0)
                nees_ref = nees_with_reference(sol, reference, cov_gt, t0)
                nees_interp = nees_velocity(sol, mission.gt, t0)
                win_nees = [s["nees_window"] for s in scores]
                w_lo, w_hi = chi2_band(n_independent(np.array([0.0, window_s])))
                out.append({"trajectory": source.name, "scenario": scenario, "method": method, "setting": name,
                            "vrmse_window": float(np.mean([s["vrmse_window"] for s in scores])),
                            "nees_window": float(np.mean(win_nees)),
                            "windows_in_band": float(np.mean([w_lo <= x <= w_hi for x in win_nees])),
                            "vrmse_mission": scores[0]["vrmse_mission"],
                            "nees_mission": float(np.mean(nees)), "nees_mission_gt": float(np.mean(nees_ref)),
                            "nees_mission_interp": float(np.mean(nees_interp)),
                            "n_independent": n_independent(sol.t[sol.t >= t0]), "runtime_s": sol.runtime_s,
                            "drift_pct_window": drift_pct_of(scores),
                            "drift_pct_mission": scores[0]["drift_pct_mission"],
                            **{k: scores[0][k] for k in ("nees_pos_mission", "nees_pos_n_independent",
                                                         "nees_heading_mission", "nees_heading_n_independent")}})
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=None, help="A-KIT folder (default: the simulated mission)")
    ap.add_argument("--sim-seeds", type=int, default=1, help="without --data: simulated missions (seeds 0..N-1)")
    ap.add_argument("--methods", nargs="+", default=[*GRAPH, "TC"])
    ap.add_argument("--scenario", nargs="+", default=["none", "2-missing", "3-missing"])
    ap.add_argument("--gt-sigma", type=float, nargs=3, default=[0.0, 0.0, 0.0],
                    help="GT velocity error std N, E, D (m/s) added to P for the reference-aware NEES")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default="out/consistency.json")
    ap.add_argument("--settings", nargs="+", default=["off", "on"], choices=["off", "on"],
                    help="DVL error states off and/or on for the graph methods")
    ap.add_argument("--per-trajectory", action="store_true", help="print the per-trajectory NEES table too")
    ap.add_argument("--reference-check", action="store_true",
                    help="only print, per trajectory, the recorded DVL against the GT interpolated linearly and "
                         "carried by the IMU, submerged and at the surface (body x, y, z RMS, m/s)")
    ap.add_argument("--drift-check", action="store_true",
                    help="only print, per trajectory and method (all beams), the window % DT as scored and with the "
                         "part a stamp offset explains removed (position error = a + b t + v_gt * delta, fitted)")
    a = ap.parse_args(argv)
    if a.drift_check:
        return drift_check(find_trajectories(a.data, sim_seeds=a.sim_seeds), a.methods)
    if a.reference_check:
        return reference_check(find_trajectories(a.data, sim_seeds=a.sim_seeds))
    settings = {k: v for k, v in (("off", {"dvl_error_states": False}), ("on", {"dvl_error_states": True}))
                if k in a.settings}
    sources = find_trajectories(a.data, sim_seeds=a.sim_seeds)
    tasks = [(s, a.methods, a.scenario, settings, a.gt_sigma, 30.0) for s in sources]
    if a.jobs > 1:
        with ProcessPoolExecutor(a.jobs) as pool:
            rows = [r for rs in pool.map(run_trajectory, tasks) for r in rs]
    else:
        rows = [r for t in tasks for r in run_trajectory(t)]
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(rows, indent=1))
    print(f"{len(sources)} trajectories; NEES = mean velocity NEES over the mission after {SETTLE_S:g} s, all "
          f"beams; NEES+GT with GT sigma {a.gt_sigma} m/s (N, E, D)")
    print("| method | DVL error states | " + " | ".join(f"VRMSE window {s}" for s in a.scenario)
          + " | " + " | ".join(f"% DT window {s}" for s in a.scenario)
          + " | NEES (min-max over traj.) | NEES+GT | 95 % band per traj. | position NEES (band) "
          "| heading NEES (band) | % DT mission |")
    print("| --- | --- |" + " --- |" * (2 * len(a.scenario)) + " --- | --- | --- | --- | --- | --- |")
    for method in a.methods:
        for name in settings:
            sel = [r for r in rows if r["method"] == method and r["setting"] == name]
            if not sel:
                continue
            cells = [f"{np.mean([r['vrmse_window'] for r in sel if r['scenario'] == s]):.4f}" for s in a.scenario]
            cells += [_pct([r["drift_pct_window"] for r in sel if r["scenario"] == s]) for s in a.scenario]
            full = [r for r in sel if r["scenario"] == "none"]
            if full:
                nees = [r["nees_mission"] for r in full]
                nees_gt = [r["nees_mission_gt"] for r in full]
                band = chi2_band(int(np.median([r["n_independent"] for r in full])))
                tail = (f"{np.mean(nees):.1f} ({min(nees):.1f}-{max(nees):.1f}) | {np.mean(nees_gt):.1f} | "
                        f"{band[0]:.2f}-{band[1]:.2f}")
            else:
                tail = "- | - | -"
            tail += (f" | {_pose(full, 'nees_pos', POSITION_DOF)} | {_pose(full, 'nees_heading', HEADING_DOF)} | "
                     f"{_pct([r['drift_pct_mission'] for r in full])}")
            print(f"| {method} | {name} | " + " | ".join(cells) + f" | {tail} |")
    if a.per_trajectory:
        print_per_trajectory(rows, a.methods, settings)
    return 0


def _pct(values) -> str:
    """Mean of the finite % values, 2 decimals, or "-"."""
    v = [x for x in values if x is not None and np.isfinite(x)]
    return f"{np.mean(v):.2f}" if v else "-"


def _pose(rows: list[dict], key: str, dof: int) -> str:
    """Mean mission NEES over trajectories (range) and the band at the median independent epochs, or "-"."""
    rs = [r for r in rows if r.get(f"{key}_mission") is not None]
    if not rs:
        return "-"
    x = [r[f"{key}_mission"] for r in rs]
    lo, hi = chi2_band(int(np.median([r[f"{key}_n_independent"] for r in rs])), dof)
    return f"{np.mean(x):.2f} ({min(x):.2f}-{max(x):.2f}; band {lo:.2f}-{hi:.2f})"


def reference_check(sources, surface_m: float = 1.0) -> int:
    """Recorded DVL velocity minus the reference body velocity (lever arm included) at the pings, RMS per body
    axis after the per-trajectory median, for pings deeper / shallower than ``surface_m``: the reference
    interpolated linearly (``GroundTruth.at``) and carried by the IMU (``calibration.reference.Reference``)."""
    from graphnav.calibration.reference import mission_reference as imu_aided_reference
    print("| trajectory | pings deep / surface | linear GT: deep | surface | IMU-carried GT: deep | surface |")
    print("| --- | --- | --- | --- | --- | --- |")
    for source in sources:
        m = prepared_mission(source, "as-recorded")
        ref = imu_aided_reference(m)
        ok = np.all(np.isfinite(m.dvl.v_b), axis=1) & ref.covers(m.dvl.t)
        t = m.dvl.t[ok]
        omega = ref.omega_nb_b(t)
        lever = np.cross(omega, m.config.dvl.lever_arm_b)
        _, v_lin, C_lin = m.gt.at(t)
        refs = (np.einsum("kji,kj->ki", C_lin, v_lin) + lever, ref.v_b(t) + lever)
        depth = np.interp(t, m.depth.t, m.depth.depth) if m.depth is not None else np.full(len(t), np.inf)
        deep = depth >= surface_m
        cells = []
        for v_ref in refs:
            e = m.dvl.v_b[ok] - v_ref
            e -= np.median(e[deep], axis=0) if deep.any() else 0.0
            for sel in (deep, ~deep):
                cells.append(" / ".join(f"{x:.3f}" for x in np.sqrt(np.mean(e[sel] ** 2, axis=0)))
                             if sel.any() else "-")
        print(f"| {source.name} | {deep.sum()} / {(~deep).sum()} | " + " | ".join(cells) + " |")
    return 0


def drift_check(sources, methods, window_s: float = 30.0) -> int:
    """How much of the window % DT a stamp offset between estimate and reference explains: the horizontal
    position error is fitted as ``a + b t + v_gt(t) delta`` (per-axis offset and trend, one shared ``delta``,
    least squares over the mission) and the windows scored again with ``v_gt delta`` removed."""
    from graphnav.evaluation.metrics import align as align_to_gt
    from graphnav.evaluation.metrics import horizontal_distance
    print("| trajectory | method | delta (s) | % DT window | without v*delta | % DT mission |")
    print("| --- | --- | --- | --- | --- | --- |")
    for source in sources:
        mission = prepared_mission(source, "as-recorded")
        starts = case_windows(mission, window_s)
        for method in methods:
            sol = run_method(mission, method, "none")
            at = align_to_gt(sol, mission.gt)
            t, e = at.t, sol.p_n[at.mask, :2] - at.p_true_n[:, :2]
            v = at.v_true_n[:, :2]
            n = len(t)
            A = np.zeros((2 * n, 5))
            A[:n, 0], A[:n, 1], A[n:, 2], A[n:, 3] = 1.0, t, 1.0, t
            A[:n, 4], A[n:, 4] = v[:, 0], v[:, 1]
            delta = float(np.linalg.lstsq(A, e.T.reshape(-1), rcond=None)[0][4])
            fixed = e - v * delta
            rows = []
            for err in (e, fixed):
                drift = [np.linalg.norm(np.array([np.interp(s + window_s, t, err[:, j]) - np.interp(s, t, err[:, j])
                                                  for j in range(2)])) for s in starts]
                dist = [horizontal_distance(mission.gt.t, mission.gt.p_n, s, s + window_s) for s in starts]
                rows.append(100 * sum(drift) / sum(dist))
            whole = score_case(sol, mission, starts[:1], window_s)[0]["drift_pct_mission"]
            print(f"| {source.name} | {method} | {delta:+.2f} | {rows[0]:.2f} | {rows[1]:.2f} | {whole:.2f} |")
    return 0


def print_per_trajectory(rows: list[dict], methods, settings) -> None:
    """Per trajectory and method, all beams: mission NEES, +GT, mean window NEES and the fraction of windows
    inside the window's 95 % band."""
    full = [r for r in rows if r["scenario"] == "none"]
    names = sorted({r["trajectory"] for r in full}, key=lambda n: (len(n), n))
    print("\nAll beams, per trajectory: mission NEES / +GT / window NEES / windows inside the 95 % band")
    print("| trajectory | " + " | ".join(f"{m} ({s})" for m in methods for s in settings
                                          if m in GRAPH or s == "off") + " |")
    cols = [(m, s) for m in methods for s in settings if m in GRAPH or s == "off"]
    print("| --- |" + " --- |" * len(cols))
    for n in names:
        cells = []
        for m, s in cols:
            r = next((r for r in full if r["trajectory"] == n and r["method"] == m and r["setting"] == s), None)
            cells.append("-" if r is None else f"{r['nees_mission']:.1f} / {r['nees_mission_gt']:.1f} / "
                         f"{r['nees_window']:.1f} / {r['windows_in_band']:.0%}")
        print(f"| {n} | " + " | ".join(cells) + " |")
    print("\nAll beams, per trajectory: position NEES / heading NEES / % DT over the windows / % DT at the end")
    print("| trajectory | " + " | ".join(f"{m} ({s})" for m, s in cols) + " |")
    print("| --- |" + " --- |" * len(cols))
    for n in names:
        cells = []
        for m, s in cols:
            r = next((r for r in full if r["trajectory"] == n and r["method"] == m and r["setting"] == s), None)
            cells.append("-" if r is None else " / ".join(
                "-" if x is None or not np.isfinite(x) else f"{x:.2f}"
                for x in (r["nees_pos_mission"], r["nees_heading_mission"], r["drift_pct_window"],
                          r["drift_pct_mission"])))
        print(f"| {n} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    sys.exit(main())
