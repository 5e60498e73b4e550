"""The graph's own position and heading uncertainty against the ground truth of the shared A-KIT trajectories
(prints a table; no assertions, nothing fitted).

Per trajectory and method (default Graph-TC, the ISAM2 filter, and Graph-TC-batch), all beams, the ground
truth as initial state: at the last epoch inside the GT, the horizontal position error and its 1-sigma
``sqrt(P_nn + P_ee)`` from the estimator's ``cov_p_n``, the horizontal NEES (2 dof), the heading error and
its sigma from ``cov_rot_b``; then the mean NEES over the trajectories per method.

    .venv/bin/python experiments/covariance_check.py
    .venv/bin/python experiments/covariance_check.py --methods Graph-TC --trajectories 1 5
"""
from __future__ import annotations

import argparse
import warnings

import numpy as np

from graphnav.core.errors import ConfigError
from graphnav.core.rotations import attitude_error, heading_variance, yaw_jacobian
from graphnav.evaluation.methods import check_method, run_method
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_akit


def end_of_run(sol, mission) -> dict:
    """Errors and sigmas at the last epoch of ``sol`` inside the mission's GT."""
    k = int(np.flatnonzero(sol.t <= mission.gt.t[-1])[-1])
    p_true, _, C_true = mission.gt.at(sol.t[k:k + 1], mission.imu)
    e = (sol.p_n[k] - p_true[0])[:2]
    P = sol.cov_p_n[k][:2, :2]
    C = sol.C_b_n[k]
    d_yaw = float(yaw_jacobian(C) @ attitude_error(C, C_true[0]))
    var_yaw = float(heading_variance(C, sol.cov_rot_b[k]))
    return {"error_m": float(np.linalg.norm(e)), "sigma_m": float(np.sqrt(np.trace(P))),
            "nees": float(e @ np.linalg.solve(P, e)), "heading_error_deg": float(np.rad2deg(abs(d_yaw))),
            "heading_sigma_deg": float(np.rad2deg(np.sqrt(var_yaw))), "heading_nees": d_yaw ** 2 / var_yaw}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", metavar="DIR", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    parser.add_argument("--methods", nargs="+", default=["Graph-TC", "Graph-TC-batch"],
                        help="method names of graphnav.evaluation.methods (default Graph-TC Graph-TC-batch)")
    parser.add_argument("--trajectories", nargs="+", type=int, default=None, help="trajectory numbers (default all)")
    args = parser.parse_args(argv)
    for method in args.methods:
        check_method(method)
    folders = akit_trajectories(args.data, names=args.trajectories)
    results = {m: [] for m in args.methods}
    print("| trajectory | method | horizontal error m | sigma m | NEES (2 dof) | heading error deg | sigma deg |")
    print("|---|---|---|---|---|---|---|")
    for folder in folders:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mission = load_akit(folder)
            for method in args.methods:
                r = end_of_run(run_method(mission, method), mission)
                results[method].append(r)
                print(f"| {folder.name} | {method} | {r['error_m']:.2f} | {r['sigma_m']:.2f} | {r['nees']:.2f} | "
                      f"{r['heading_error_deg']:.3f} | {r['heading_sigma_deg']:.3f} |", flush=True)
    for method, rows in results.items():
        if rows:
            print(f"{method}: mean horizontal NEES {np.mean([r['nees'] for r in rows]):.2f} (expected 2), mean "
                  f"heading NEES {np.mean([r['heading_nees'] for r in rows]):.2f} (expected 1) over {len(rows)} "
                  "trajectories")
    return 0


if __name__ == "__main__":
    try:
        raise SystemExit(main())
    except ConfigError as exc:
        raise SystemExit(f"error: {exc}") from None
