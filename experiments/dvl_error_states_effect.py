"""Graph-TC over each whole shared trajectory with the DVL error states off and on (all beams): mission VRMSE
and the horizontal position error at the end of the mission, so that the default is chosen on both.

    nice -n 10 .venv/bin/python experiments/dvl_error_states_effect.py [--trajectories Trajectory1 ...]
"""
from __future__ import annotations

import argparse
import warnings

import numpy as np

from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.runs import run_graph
from graphnav.evaluation.metrics import horizontal_position_error, vrmse
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_mission


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trajectories", nargs="*", help="folder names (default: every shared trajectory)")
    ap.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    args = ap.parse_args(argv)
    folders = akit_trajectories(args.data, names=args.trajectories)
    print("| trajectory | VRMSE off | VRMSE on | position error at the end off, m | on, m |")
    print("| --- | --- | --- | --- | --- |")
    totals = np.zeros(4)
    for folder in folders:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mission = load_mission(folder)
            row = []
            for on in (False, True):
                sol = run_graph(mission, options=GraphOptions(dvl_error_states=on))
                row += [vrmse(sol, mission.gt), float(np.atleast_1d(horizontal_position_error(sol, mission.gt))[-1])]
        vals = np.array([row[0], row[2], row[1], row[3]])
        totals += vals
        print(f"| {folder.name} | {vals[0]:.4f} | {vals[1]:.4f} | {vals[2]:.2f} | {vals[3]:.2f} |", flush=True)
    m = totals / max(len(folders), 1)
    print(f"| mean | {m[0]:.4f} | {m[1]:.4f} | {m[2]:.2f} | {m[3]:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
