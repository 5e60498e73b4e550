#!/usr/bin/env python
"""The 15-state EKF (position error state, depth aiding) against the paper's 12-state filter on whole missions.

For every shared A-KIT trajectory (``graphnav.io.paths.akit_trajectories``; ``--data`` overrides) and each of
the two filters (the registry's ``TC`` and ``TC-12``, all beams, ground-truth start as the bench): velocity
RMSE over the mission and per NED axis, mean velocity NEES after 60 s (3 dof), the horizontal position error at
the mission's last ping and, for the 15-state filter, its horizontal position sigma there and the 2-dof position
NEES at the end.
``--scenario 3-missing`` puts the bench's 30 s windows of 3 missing beams into the mission
(:func:`graphnav.core.scenarios.window_starts`) and scores the whole mission.

Note: the A-KIT depth stream is the ground truth's altitude (the files carry no depth sensor), so depth aiding
on these missions comes from the reference's own vertical channel.

    .venv/bin/python experiments/ekf_position_states.py [--trajectories 1,5] [--scenario none|3-missing]
                                                         [--dvl-error-states] [--data DIR]
"""
from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

from graphnav.core.errors import ConfigError
from graphnav.core.scenarios import scenario_outage, window_starts
from graphnav.evaluation import metrics
from graphnav.evaluation.methods import run_method
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_akit

#: the filters compared: the 15-state default and the paper's 12-state filter
FILTERS = ("TC", "TC-12")


def with_windows(mission, scenario: str):
    """The mission with every bench window of ``scenario`` (30 s) in its valid mask."""
    if scenario == "none":
        return mission
    for start in window_starts(mission.t0, mission.t1):
        mission = mission.with_outage(scenario_outage(scenario, start, 30.0))
    return mission


def score(sol, gt) -> dict:
    """Mission scores of one solution against the ground truth (see the module docstring)."""
    _, v_err = metrics.velocity_errors(sol, gt)
    aligned = metrics.align(sol, gt)
    k = np.flatnonzero(aligned.mask)[-1]                     # the last epoch inside the ground truth's span
    e_h = sol.p_n[k, :2] - aligned.p_true_n[-1, :2]
    out = {"vrmse": metrics.vrmse(sol, gt), "axis_rmse": np.sqrt(np.nanmean(v_err ** 2, axis=0)),
           "nees_v": float(np.nanmean(metrics.nees_velocity(sol, gt, t_start=sol.t[0] + 60.0))),
           "pos_end_m": float(np.linalg.norm(e_h)), "sigma_h_end_m": float("nan"), "nees_p_end": float("nan")}
    if sol.cov_p_n is not None:
        P = sol.cov_p_n[k, :2, :2]
        out["sigma_h_end_m"] = float(np.sqrt(np.trace(P)))
        out["nees_p_end"] = float(e_h @ np.linalg.solve(P, e_h))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trajectories", default=None, help="comma-separated numbers (default: all shared)")
    ap.add_argument("--scenario", default="none", choices=("none", "3-missing", "2-missing"))
    ap.add_argument("--dvl-error-states", action="store_true", help="both filters with EkfOptions.dvl_error_states")
    ap.add_argument("--data", metavar="DIR", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    args = ap.parse_args(argv)
    names = [n.strip() for n in args.trajectories.split(",")] if args.trajectories else None
    folders = akit_trajectories(args.data, names=names)
    rows = {name: [] for name in FILTERS}
    print(f"scenario {args.scenario}; per trajectory: VRMSE m/s [N E D], velocity NEES, horizontal position error at "
          "the end m (15-state: its sigma and 2-dof NEES)")
    for folder in folders:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mission = with_windows(load_akit(folder), args.scenario)
            options = {"dvl_error_states": True} if args.dvl_error_states else None
            sols = {name: run_method(mission, name, args.scenario, options=options) for name in FILTERS}
        for name, sol in sols.items():
            s = score(sol, mission.gt)
            rows[name].append(s)
            ax = " ".join(f"{x:.4f}" for x in s["axis_rmse"])
            extra = (f"  sigma {s['sigma_h_end_m']:.2f} m NEES_p {s['nees_p_end']:.2f}"
                     if np.isfinite(s["sigma_h_end_m"]) else "")
            print(f"{folder.name:13} {name:6} VRMSE {s['vrmse']:.4f} [{ax}] NEES_v {s['nees_v']:.2f} "
                  f"end {s['pos_end_m']:.2f} m{extra}")
    print("\nmean over trajectories")
    print("| filter | VRMSE | north | east | down | velocity NEES (median) | horiz. error at end (m) | sigma (m) "
          "| NEES_p end |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, rs in rows.items():
        ax = np.mean([r["axis_rmse"] for r in rs], axis=0)
        mean = {k: float(np.mean([r[k] for r in rs])) for k in ("vrmse", "nees_v", "pos_end_m", "sigma_h_end_m",
                                                                 "nees_p_end")}
        median = float(np.median([r["nees_v"] for r in rs]))
        print(f"| {name} | {mean['vrmse']:.4f} | {ax[0]:.4f} | {ax[1]:.4f} | {ax[2]:.4f} | {mean['nees_v']:.2f} "
              f"({median:.2f}) | "
              f"{mean['pos_end_m']:.2f} | {mean['sigma_h_end_m']:.2f} | {mean['nees_p_end']:.2f} |")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except ConfigError as exc:
        sys.exit(f"error: {exc}")
