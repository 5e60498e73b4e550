"""Where the A-KIT estimators navigate: the DVL's point (the default) or the accelerometer's, scored out of fold.

The default (:data:`graphnav.io.loaders.AKIT_IMU_POSITION_B`) takes the IMU and the DVL as co-located at the DVL's
point of the data README, and moves the GT there. `graphnav calibrate` (GT mode) puts the accelerometer about 0.31 m
above that point and the DVL about 0.06 m below it. This study runs Graph-TC, its batch smoother and the tightly
coupled EKF on each shared trajectory with the GT moved to the accelerometer's point and the DVL's lever arm from it,
both the medians of `calibrate`'s per-trajectory estimates on the other folds
(:data:`graphnav.evaluation.crossval.SNAPIR_FOLDS`) -- once with the data README's DVL point, once with the
calibrated one -- against the default; all beams, mission VRMSE and velocity NEES after 60 s against the GT at the
point the estimators navigate, and the VRMSE of the same estimates carried to the default's point (``omega x r``)
against the default's GT.

    .venv/bin/python experiments/imu_point_folds.py --jobs 2
    .venv/bin/python experiments/imu_point_folds.py --jobs 2 --imu-noise-scale 0.5 --out out/imu_point/half.json
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import warnings
from pathlib import Path

import numpy as np

from graphnav.evaluation.crossval import SNAPIR_FOLDS, STUDY_METHODS, mean_range, run_methods, with_imu_noise_scale
from graphnav.evaluation.tasks import run_tasks
from graphnav.io.loaders import AKIT_LEVER_ARM_B
from graphnav.io.paths import akit_trajectories

SETTINGS = ("default (DVL point)", "accelerometer point, README DVL", "accelerometer point, calibrated DVL")


def calibrated_points(folder: str) -> dict:
    """`calibrate`'s DVL lever arm and accelerometer position on one trajectory, both relative to the point the
    loader moves the GT to by default (the README's DVL point), m, body frame."""
    from graphnav.calibration.calibrate import calibrate
    from graphnav.missions import load_mission
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = calibrate(load_mission(folder), mode="gt")
    return {"trajectory": Path(folder).name, "dvl": np.asarray(result.lever_arm_b.value).tolist(),
            "imu": np.asarray(result.imu_position_b.value).tolist()}


def run_one(task) -> list[dict]:
    from graphnav.evaluation.consistency import mission_nees
    from graphnav.evaluation.metrics import vrmse
    from graphnav.missions import load_akit
    folder, setting, imu_position_b, lever_arm_b, scale = task
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        default = load_akit(folder)
        mission = default if imu_position_b is None else load_akit(
            folder, imu_position_b=np.asarray(imu_position_b), lever_arm_b=np.asarray(lever_arm_b))
        sols = run_methods(with_imu_noise_scale(mission, scale), STUDY_METHODS, "none")
    # the same estimate at the default's point (the README's DVL point), against the default's GT: the two
    # references differ by omega x r, 0.01-0.03 m/s RMS, as much as the estimators' errors
    r_b = np.asarray(AKIT_LEVER_ARM_B) - (np.asarray(AKIT_LEVER_ARM_B) if imu_position_b is None
                                          else np.asarray(imu_position_b))
    rows = []
    for method, sol in sols.items():
        omega_b = np.stack([np.interp(sol.t, mission.imu.t, mission.imu.omega_b[:, i]) for i in range(3)], 1)
        moved = dataclasses.replace(sol, v_n=sol.v_n + np.einsum("kij,kj->ki", sol.C_b_n, np.cross(omega_b, r_b)))
        rows.append({"trajectory": Path(folder).name, "setting": setting, "method": method,
                     "vrmse_mission": float(vrmse(sol, mission.gt, mission.t0, mission.t1)),
                     "vrmse_at_dvl_point": float(vrmse(moved, default.gt, default.t0, default.t1)),
                     "nees_mission": mission_nees(sol, mission)["nees_mission"]})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", help="A-KIT folder of trajectories (default: the shared data, graphnav.io.paths)")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (graphnav.evaluation.tasks)")
    ap.add_argument("--imu-noise-scale", type=float, default=1.0,
                    help="factor on the IMU's white densities in every run (the defaults were chosen co-located)")
    ap.add_argument("--out", default="out/imu_point/rows.json", help="JSON file of the calibrations and runs")
    a = ap.parse_args(argv)
    folders = {f.name: str(f) for f in akit_trajectories(a.data)}
    cals: list[dict] = []
    run_tasks(calibrated_points, list(folders.values()), cals.append, jobs=a.jobs)
    cal = {c["trajectory"]: c for c in cals}
    print("| trajectory | calibrated DVL (m, from the README's DVL point) | calibrated accelerometer (m) |")
    print("| --- | --- | --- |")
    for name in folders:
        print(f"| {name} | {np.round(cal[name]['dvl'], 3).tolist()} | {np.round(cal[name]['imu'], 3).tolist()} |")
    tasks = []
    for fold in SNAPIR_FOLDS:
        train = [cal[n] for n in folders if n not in fold]
        imu = np.median([c["imu"] for c in train], axis=0)
        dvl = np.median([c["dvl"] for c in train], axis=0)
        point = (np.asarray(AKIT_LEVER_ARM_B) + imu).tolist()
        print(f"fold {', '.join(fold)}: accelerometer {np.round(imu, 3).tolist()}, DVL from it: README "
              f"{np.round(-imu, 3).tolist()}, calibrated {np.round(dvl - imu, 3).tolist()}")
        for name in fold:
            if name in folders:
                tasks += [(folders[name], SETTINGS[0], None, None, a.imu_noise_scale),
                          (folders[name], SETTINGS[1], point, (-imu).tolist(), a.imu_noise_scale),
                          (folders[name], SETTINGS[2], point, (dvl - imu).tolist(), a.imu_noise_scale)]
    rows: list[dict] = []
    run_tasks(run_one, tasks, rows.extend, jobs=a.jobs)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps({"calibrated": cals, "runs": rows}, indent=1))
    print()
    print("| method | where | mission VRMSE (m/s), at its own point | at the README's DVL point | mission velocity "
          "NEES: mean (range) |")
    print("| --- | --- | --- | --- | --- |")
    for method in STUDY_METHODS:
        for setting in SETTINGS:
            sel = [r for r in rows if r["method"] == method and r["setting"] == setting]
            print(f"| {method} | {setting} | {np.mean([r['vrmse_mission'] for r in sel]):.4f} | "
                  f"{np.mean([r['vrmse_at_dvl_point'] for r in sel]):.4f} | "
                  f"{mean_range([r['nees_mission'] for r in sel])} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
