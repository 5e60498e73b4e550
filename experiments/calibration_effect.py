"""What calibration buys on the shared real trajectories: all-beam mission VRMSE per configuration.

Configurations, each loaded and run the same way (EKF TC and Graph-TC, all beams, GT at the IMU point):
- naive: no time offsets, no lever arm (what a first integration sees);
- default: the loader's defaults (time offsets estimated at load time, lever arm from the data README);
- gt-calibrated: ``graphnav calibrate --mode gt`` written to a config and loaded with ``--config``;
- graph-calibrated: ``graphnav calibrate --mode graph`` (no GT; lever arm as a graph variable), likewise.

    .venv/bin/python experiments/calibration_effect.py [--no-graph-mode]
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from graphnav.calibration.calibrate import calibrate
from graphnav.estimators.runs import run_ekf, run_graph
from graphnav.evaluation.metrics import vrmse
from graphnav.io import paths
from graphnav.missions import load_akit, load_mission


def scores(mission) -> tuple[float, float]:
    return vrmse(run_ekf(mission), mission.gt), vrmse(run_graph(mission), mission.gt)


def calibrated(folder: Path, mode: str, tmp: Path):
    result = calibrate(load_akit(folder), mode)
    config_path = tmp / f"{folder.name}-{mode}.json"
    result.config.save(config_path)
    return load_mission(str(folder), str(config_path)), result


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--no-graph-mode", action="store_true", help="skip the (slower) no-GT calibration")
    parser.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    args = parser.parse_args(argv)
    modes = ["gt"] + ([] if args.no_graph_mode else ["graph"])
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for folder in paths.akit_trajectories(args.data):
            row = {"naive": scores(load_akit(folder, dvl_time_offset_s=0.0, gt_time_offset_s=0.0,
                                             lever_arm_b=(0.0, 0.0, 0.0))),
                   "default": scores(load_akit(folder))}
            for mode in modes:
                mission, result = calibrated(folder, mode, Path(tmp))
                row[f"{mode}-calibrated"] = scores(mission)
                row[f"{mode} lever arm"] = result.lever_arm_b.value
                row[f"{mode} dvl offset"] = result.dvl_time_offset_s.value
            rows.append((folder.name, row))
            print(folder.name, {k: np.round(v, 3) for k, v in row.items()}, flush=True)
    configs = ["naive", "default"] + [f"{m}-calibrated" for m in modes]
    print("\nAll-beam mission VRMSE, m/s, EKF TC / Graph-TC")
    print("| trajectory | " + " | ".join(configs) + " |")
    print("| --- |" + " --- |" * len(configs))
    for name, row in rows:
        print(f"| {name} | " + " | ".join(f"{row[c][0]:.3f} / {row[c][1]:.3f}" for c in configs) + " |")
    means = {c: np.mean([row[c] for _, row in rows], axis=0) for c in configs}
    print("| mean | " + " | ".join(f"{means[c][0]:.3f} / {means[c][1]:.3f}" for c in configs) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
