"""The DVL beam-bias model of the graph's DVL error states, chosen by leave-one-trajectory-out on the ten shared
A-KIT trajectories (Graph-TC fixed-lag, all beams, whole trajectory).

Candidates are (priors.dvl_bias_sigma m/s, dvl_bias_rw m/s/sqrt(s)); None = the GraphOptions default
(``max(|config.dvl.beam_bias|, 0.005)``, i.e. 0.01 m/s on these beams). Per fold (one held-out trajectory) the
candidate with the lowest mean VRMSE on the other nine is chosen, and its numbers on the held-out one are the
out-of-fold result.

    nice -n 10 .venv/bin/python experiments/dvl_bias_model_loto.py
"""
from __future__ import annotations

import argparse
import warnings

import numpy as np

from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.options import PriorOptions
from graphnav.estimators.runs import run_graph
from graphnav.evaluation.metrics import horizontal_position_error, nees_velocity, vrmse
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_mission

CANDIDATES = [(None, 2e-4), (0.002, 2e-4), (0.002, 2e-5), (0.005, 5e-5)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trajectories", nargs="*", help="folder names (default: every shared trajectory)")
    args = ap.parse_args(argv)
    folders = akit_trajectories(names=args.trajectories or None, option=None)
    names = [f.name for f in folders]
    # metrics[trajectory][candidate] = (VRMSE m/s, end horizontal error m, velocity NEES)
    metrics = np.zeros((len(folders), len(CANDIDATES), 3))
    for i, folder in enumerate(folders):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mission = load_mission(folder)
            for j, (prior, rw) in enumerate(CANDIDATES):
                sol = run_graph(mission, backend="fixed-lag",
                                options=GraphOptions(priors=PriorOptions(dvl_bias_sigma=prior), dvl_bias_rw=rw))
                metrics[i, j] = (vrmse(sol, mission.gt),
                                 float(np.atleast_1d(horizontal_position_error(sol, mission.gt))[-1]),
                                 float(np.nanmean(nees_velocity(sol, mission.gt))))
        print(f"{folder.name:12s} " + "  ".join(f"{m[0]:.4f}/{m[1]:6.2f}/{m[2]:5.2f}" for m in metrics[i]), flush=True)
    print("\ncandidates (priors.dvl_bias_sigma, dvl_bias_rw):", CANDIDATES)
    print("mean VRMSE / end error m / NEES:", "  ".join(f"{m[0]:.4f}/{m[1]:.2f}/{m[2]:.2f}"
                                                        for m in metrics.mean(axis=0)))
    print("\n| held out | chosen | VRMSE out-of-fold | default | end error m | default |")
    print("| --- | --- | --- | --- | --- | --- |")
    oof = []
    for i, name in enumerate(names):
        rest = np.delete(metrics[:, :, 0], i, axis=0).mean(axis=0)
        j = int(np.argmin(rest))
        oof.append((metrics[i, j, 0], metrics[i, 0, 0], metrics[i, j, 1], metrics[i, 0, 1]))
        print(f"| {name} | {CANDIDATES[j]} | {metrics[i, j, 0]:.4f} | {metrics[i, 0, 0]:.4f} | "
              f"{metrics[i, j, 1]:.2f} | {metrics[i, 0, 1]:.2f} |")
    m = np.mean(oof, axis=0)
    print(f"| mean | | {m[0]:.4f} | {m[1]:.4f} | {m[2]:.2f} | {m[3]:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
