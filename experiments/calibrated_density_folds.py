"""The IMU densities `graphnav calibrate` writes, scored out of fold on the shared trajectories.

`graphnav calibrate` identifies the IMU's white densities from its 1-s increments against the GT
(:func:`graphnav.calibration.noise.identify_imu_with_gt`) and writes them, times
:data:`graphnav.calibration.noise.ESTIMATOR_DENSITY_FACTOR`, into the calibrated configuration. This study chooses
that factor per fold of whole trajectories (:data:`graphnav.evaluation.crossval.SNAPIR_FOLDS`): the estimators'
densities chosen leave-trajectories-out (:data:`graphnav.io.loaders.PHINS_RECORDED`) over the median identified on
the other folds. Each held-out trajectory is then run with its own identified densities times its fold's factor
("calibrated"), with its identified densities alone ("identified") and with the shipped ones ("shipped"); all beams,
Graph-TC, its batch smoother and the tightly coupled EKF, scored as the benchmark scores a mission (velocity NEES
after 60 s, VRMSE).

    .venv/bin/python experiments/calibrated_density_folds.py --jobs 2
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import warnings
from pathlib import Path

import numpy as np

from graphnav.calibration.noise import identify_imu_with_gt, white_density
from graphnav.evaluation.bench import find_trajectories
from graphnav.evaluation.bench.cases import prepared_mission
from graphnav.evaluation.consistency import mission_nees
from graphnav.evaluation.crossval import SNAPIR_FOLDS, STUDY_METHODS, mean_range, run_methods
from graphnav.evaluation.metrics import vrmse
from graphnav.evaluation.tasks import run_tasks
from graphnav.io.loaders import PHINS_RECORDED
from graphnav.io.paths import akit_dir, akit_trajectories


SETTINGS = ("shipped", "identified", "calibrated", "allan", "allan-calibrated")


def identify_one(source) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mission = prepared_mission(source, "as-recorded")
        accel, gyro = identify_imu_with_gt(mission)
    rate = 1.0 / float(np.median(np.diff(mission.imu.t)))
    return {"trajectory": source.name, "accel": accel, "gyro": gyro,
            "allan_accel": white_density(mission.imu.f_b, rate), "allan_gyro": white_density(mission.imu.omega_b, rate)}


def run_one(task) -> list[dict]:
    source, setting, accel, gyro = task
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mission = prepared_mission(source, "as-recorded")
        imu = dataclasses.replace(mission.config.imu, accel_noise_density=accel, gyro_noise_density=gyro)
        mission = dataclasses.replace(mission, config=dataclasses.replace(mission.config, imu=imu))
        sols = run_methods(mission, STUDY_METHODS, "none")
    return [{"trajectory": source.name, "setting": setting, "method": method, "accel": accel, "gyro": gyro,
             "nees_mission": mission_nees(sol, mission)["nees_mission"],
             "vrmse_mission": float(vrmse(sol, mission.gt, mission.t0, mission.t1))} for method, sol in sols.items()]


def fold_factors(ids: dict[str, dict], prefix: str = "") -> dict[str, tuple[float, float]]:
    """{held-out trajectory: (accelerometer, gyro) factor chosen on the other folds} for the densities
    identified against the GT (``prefix`` "") or by the Allan deviation (``prefix`` "allan_")."""
    out = {}
    for fold in SNAPIR_FOLDS:
        train = [r for name, r in ids.items() if name not in fold]
        factor = (PHINS_RECORDED.accel_noise_density / float(np.median([r[prefix + "accel"] for r in train])),
                  PHINS_RECORDED.gyro_noise_density / float(np.median([r[prefix + "gyro"] for r in train])))
        out.update({name: factor for name in fold if name in ids})
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", help="A-KIT folder of trajectories (default: the shared data, graphnav.io.paths)")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (graphnav.evaluation.tasks)")
    ap.add_argument("--out", default="out/calibrated_density/rows.json", help="JSON file of the per-run rows")
    a = ap.parse_args(argv)
    sources = find_trajectories(str(a.data or akit_dir() or akit_trajectories()[0].parent))
    id_rows: list[dict] = []
    run_tasks(identify_one, sources, id_rows.append, jobs=a.jobs)
    ids = {r["trajectory"]: r for r in id_rows}
    factors, allan = fold_factors(ids), fold_factors(ids, "allan_")
    print("| trajectory | identified against the GT: accelerometer (m/s^2/sqrt(Hz)), gyro (rad/s/sqrt(Hz)) | "
          "fold factor | Allan deviation at short tau: accelerometer, gyro | fold factor |")
    print("| --- | --- | --- | --- | --- |")
    for s in sources:
        r, f, fa = ids[s.name], factors[s.name], allan[s.name]
        print(f"| {s.name} | {r['accel']:.2e}, {r['gyro']:.2e} | {f[0]:.2f}, {f[1]:.2f} | "
              f"{r['allan_accel']:.2e}, {r['allan_gyro']:.2e} | {fa[0]:.2f}, {fa[1]:.2f} |")
    for name, key in (("against the GT", ""), ("Allan", "allan_")):
        med = [float(np.median([r[key + x] for r in id_rows])) for x in ("accel", "gyro")]
        print(f"all ten, {name}: median {med[0]:.3e}, {med[1]:.3e}; factor "
              f"{PHINS_RECORDED.accel_noise_density / med[0]:.2f}, {PHINS_RECORDED.gyro_noise_density / med[1]:.2f}")
    tasks = []
    for s in sources:
        r, f = ids[s.name], factors[s.name]
        tasks += [(s, "shipped", PHINS_RECORDED.accel_noise_density, PHINS_RECORDED.gyro_noise_density),
                  (s, "identified", r["accel"], r["gyro"]),
                  (s, "calibrated", r["accel"] * f[0], r["gyro"] * f[1]),
                  (s, "allan", r["allan_accel"], r["allan_gyro"]),
                  (s, "allan-calibrated", r["allan_accel"] * allan[s.name][0], r["allan_gyro"] * allan[s.name][1])]
    rows: list[dict] = []
    run_tasks(run_one, tasks, rows.extend, jobs=a.jobs)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps({"identified": id_rows, "runs": rows}, indent=1))
    print()
    print("| method | densities | mission velocity NEES: mean (range) | trajectories over 3.9 | mission VRMSE (m/s) |")
    print("| --- | --- | --- | --- | --- |")
    for m in STUDY_METHODS:
        for setting in SETTINGS:
            sel = [r for r in rows if r["method"] == m and r["setting"] == setting]
            nees = np.array([r["nees_mission"] for r in sel])
            print(f"| {m} | {setting} | {mean_range(nees)} | "
                  f"{int(np.sum(nees > 3.9))} of {len(sel)} | {np.mean([r['vrmse_mission'] for r in sel]):.4f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
