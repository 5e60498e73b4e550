"""Identify the IMU white-noise densities, the beam noise and the GT's velocity error on A-KIT trajectories.

Method: :mod:`graphnav.calibration.noise` (the IMU's 1-s increments against the GT's, and the Allan deviation at
short tau; all-beam batch-smoother residuals
with the smoother's own prediction variance added back for the beams; batch error vs GT minus the smoother's
covariance for the GT). Prints one row per trajectory and the median over them: the identification behind
:data:`graphnav.io.loaders.PHINS_RECORDED` (whose densities the estimators use at
:data:`graphnav.calibration.noise.ESTIMATOR_DENSITY_FACTOR` times these, chosen out of fold by
``experiments/calibrated_density_folds.py``), :data:`graphnav.io.loaders.AKIT_GT_VELOCITY_SIGMA_N` (the GT white
error column) and the beam noise of the A-KIT DVL spec.

    .venv/bin/python experiments/identify_noise.py --data ../shared/data/snapir-2022-akit --jobs 2
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

from graphnav.calibration.noise import identify
from graphnav.evaluation.methods import network_completer
from graphnav.evaluation.tasks import run_tasks
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_mission


def one(folder: str) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        mission = load_mission(folder)
        est = identify(mission, completer=network_completer("none", mission.config.dvl.beam_noise_std)[0])
    return {"trajectory": Path(folder).name, **est.to_dict()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", help="A-KIT folder of trajectories, or one trajectory (default: the shared data, "
                                   "graphnav.io.paths)")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (graphnav.evaluation.tasks)")
    ap.add_argument("--out", default="out/noise_id.json", help="JSON file of the per-trajectory rows")
    a = ap.parse_args(argv)
    root = Path(a.data) if a.data else None
    one_folder = root is not None and any(root.glob("IMU_*.csv"))
    folders = [str(root)] if one_folder else [str(f) for f in akit_trajectories(root)]
    rows: list[dict] = []
    run_tasks(one, folders, rows.append, jobs=a.jobs)
    order = [Path(f).name for f in folders]
    rows.sort(key=lambda r: order.index(r["trajectory"]) if r["trajectory"] in order else len(order))
    print("| trajectory | accel density 1 s (m/s^2/sqrt(Hz)) | gyro density 1 s (rad/s/sqrt(Hz)) | accel / gyro "
          "density, Allan 0.01-0.1 s | beam noise (m/s) "
          "| GT velocity error N, E, D (m/s) | GT white error x, y, z (m/s) | its lag-1 corr. | recorded DVL white "
          "(m/s) / drift (m/s/sqrt(s)) | beams |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        gt = ", ".join(f"{x:.4f}" for x in r["gt_velocity_sigma_n"])
        print(f"| {r['trajectory']} | {r['accel_noise_density']:.2e} | {r['gyro_noise_density']:.2e} | "
              f"{r['allan_accel_density']:.2e} / {r['allan_gyro_density']:.2e} | "
              f"{r['beam_noise_std']:.4f} | {gt} | {', '.join(f'{x:.4f}' for x in r['gt_white_sigma_b'])} | "
              f"{', '.join(f'{x:+.2f}' for x in r['gt_white_lag1_b'])} | "
              f"{r['dvl_white_std']:.4f} / {r['dvl_bias_rw']:.1e} | {r['n_beams']} |")
    med = {k: float(np.median([r[k] for r in rows])) for k in ("accel_noise_density", "gyro_noise_density",
                                                               "allan_accel_density", "allan_gyro_density",
                                                               "beam_noise_std", "dvl_white_std",
                                                               "dvl_bias_rw")}
    gt_med = np.median([r["gt_velocity_sigma_n"] for r in rows], axis=0)
    print(f"| median | {med['accel_noise_density']:.2e} | {med['gyro_noise_density']:.2e} | "
          f"{med['allan_accel_density']:.2e} / {med['allan_gyro_density']:.2e} | "
          f"{med['beam_noise_std']:.4f} | {', '.join(f'{x:.4f}' for x in gt_med)} | "
          f"{', '.join(f'{x:.4f}' for x in np.median([r['gt_white_sigma_b'] for r in rows], axis=0))} | | "
          f"{med['dvl_white_std']:.4f} / {med['dvl_bias_rw']:.1e} | |")
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps({"trajectories": rows, "median": {**med, "gt_velocity_sigma_n":
                                                                        gt_med.tolist()}}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
