"""Identify the IMU white-noise densities, the beam noise and the GT's velocity error on A-KIT trajectories.

Method: :mod:`graphnav.noise_id` (Allan deviation at short tau for the IMU; all-beam batch-smoother residuals
with the smoother's own prediction variance added back for the beams; batch error vs GT minus the smoother's
covariance for the GT). Prints one row per trajectory and the median over them, which is what
:data:`graphnav.loaders.PHINS_RECORDED` and :data:`graphnav.loaders.AKIT_BEAM_NOISE_STD` hold.

    .venv/bin/python scripts/identify_noise.py --data ../shared/data/snapir-2022-akit --jobs 2
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from graphnav.loaders import list_akit, load_mission
from graphnav.noise_id import identify


def one(folder: str) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        mission = load_mission(folder)
        est = identify(mission)
    return {"trajectory": Path(folder).name, **est.to_dict()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="A-KIT folder of trajectories (or one trajectory)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default="out/noise_id.json")
    a = ap.parse_args(argv)
    root = Path(a.data)
    folders = [str(root)] if any(root.glob("IMU_*.csv")) else [str(f) for f in list_akit(root)]
    with ProcessPoolExecutor(max(1, a.jobs)) as pool:
        rows = list(pool.map(one, folders))
    print("| trajectory | accel density (m/s^2/sqrt(Hz)) | gyro density (rad/s/sqrt(Hz)) | beam noise (m/s) "
          "| GT velocity error N, E, D (m/s) | beams |")
    print("| --- | --- | --- | --- | --- | --- |")
    for r in rows:
        gt = ", ".join(f"{x:.4f}" for x in r["gt_velocity_sigma_n"])
        print(f"| {r['trajectory']} | {r['accel_noise_density']:.2e} | {r['gyro_noise_density']:.2e} | "
              f"{r['beam_noise_std']:.4f} | {gt} | {r['n_beams']} |")
    med = {k: float(np.median([r[k] for r in rows])) for k in ("accel_noise_density", "gyro_noise_density",
                                                               "beam_noise_std")}
    gt_med = np.median([r["gt_velocity_sigma_n"] for r in rows], axis=0)
    print(f"| median | {med['accel_noise_density']:.2e} | {med['gyro_noise_density']:.2e} | "
          f"{med['beam_noise_std']:.4f} | {', '.join(f'{x:.4f}' for x in gt_med)} | |")
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps({"trajectories": rows, "median": {**med, "gt_velocity_sigma_n":
                                                                        gt_med.tolist()}}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
