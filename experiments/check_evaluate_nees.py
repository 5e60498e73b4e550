"""Compare `graphnav evaluate`'s velocity NEES with the benchmark's on shared A-KIT trajectories.

    .venv/bin/python experiments/check_evaluate_nees.py 5 11          # Graph-HN-batch on Trajectory5 and 11

Per trajectory: the bench's mission NEES on the in-memory solution (full covariance), evaluate's on the
written trajectory.csv (sigmas only: diagonal covariance), and the NEES evaluate printed before it called the
bench's function (GT interpolated linearly, every epoch from the start).
"""
from __future__ import annotations

import argparse
import json
import tempfile
import warnings
from pathlib import Path

import numpy as np

from graphnav.evaluation.bench import mission_nees
from graphnav.evaluation.methods import run_method
from graphnav.evaluation.metrics import nees_velocity
from graphnav.evaluation.score import evaluate
from graphnav.io.outputs import read_trajectory_csv, write_trajectory_csv
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_mission


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("trajectories", nargs="+", type=int, help="A-KIT trajectory numbers")
    parser.add_argument("--method", default="Graph-HN-batch", help="the method to score")
    parser.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    args = parser.parse_args(argv)
    folders = akit_trajectories(args.data, names=args.trajectories)
    warnings.simplefilter("ignore")
    with tempfile.TemporaryDirectory() as tmp:
        for n, folder in zip(args.trajectories, folders):
            mission = load_mission(folder)
            sol = run_method(mission, args.method)
            csv = read_trajectory_csv(write_trajectory_csv(Path(tmp) / f"t{n}.csv", sol))
            print(json.dumps({
                "trajectory": n, "method": args.method,
                "bench_full_covariance": mission_nees(sol, mission)["nees_mission"],
                "evaluate": evaluate(csv, mission.gt, mission=mission)["nees_velocity_mean"],
                "evaluate_before": float(np.mean(nees_velocity(csv, mission.gt)))}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
