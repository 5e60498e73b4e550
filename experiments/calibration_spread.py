"""Do `graphnav calibrate`'s sigmas cover the next mission? Each shared trajectory held out in turn.

`graphnav calibrate` (GT mode, no noise identification) runs on each of the ten shared Snapir trajectories. Then, per
quantity and component:

- **scatter/sigma**: the square root of Cochran's Q per degree of freedom over all ten (about 1 when the
  per-mission sigmas cover how much the missions differ);
- **held out, per-mission sigmas**: each trajectory's estimate against the other nine's inverse-variance mean,
  with the per-mission sigmas only (``sqrt(s_i^2 + sigma_mean^2)``): how many of the ten fall within 2 sigma,
  and the RMS of the normalised difference (1 when honest);
- **held out, random effects**: the same against the other nine's random-effects combination
  (:mod:`graphnav.calibration.combine`, what ``graphnav calibrate --data A B ...`` prints), its next-mission sigma
  with the held-out mission's own (``sqrt(next^2 + s_i^2)``).

The time offsets are left out: a log's clocks are its own (the combined configuration does not write them).

With ``--navigate``, each trajectory is also navigated (all beams, Graph-TC and the tightly coupled EKF TC) with
the configuration the other nine combine to (what ``graphnav calibrate --data`` writes from them) against the
loader's defaults: mission VRMSE, and the velocity NEES against the IMU-carried reference after 60 s.

With ``--simulated N`` the same table is made from N simulated 400 s missions of one vehicle (seeds 20, 21, ...;
the simulator's default sensors, a 10 Hz GT) instead: nothing differs between them but the noise, so a scatter over
the sigmas well above 1 there is the estimate's own sigma falling short.

    .venv/bin/python experiments/calibration_spread.py [--data FOLDER] [--out out/calibration_spread.json]
    .venv/bin/python experiments/calibration_spread.py --navigate --jobs 2
    .venv/bin/python experiments/calibration_spread.py --simulated 8 --out out/calibration_spread_sim.json
"""
from __future__ import annotations

import argparse
import json
import tempfile
import warnings
from pathlib import Path

import numpy as np
from scipy.stats import t as student_t

from graphnav.calibration.combine import random_effects
from graphnav.io.paths import akit_trajectories

#: The instrument quantities (field, label, scale to the printed unit, unit).
QUANTITIES = (("lever_arm_b", "DVL lever arm vs IMU point", 1.0, "m"),
              ("dvl_yaw_rad", "DVL mounting yaw", 180 / np.pi, "deg"),
              ("dvl_scale", "DVL scale factor", 100.0, "%"), ("dvl_bias", "DVL vertical bias", 1e3, "mm/s"),
              ("imu_position_b", "accelerometer vs IMU point", 1.0, "m"))
AXES = ("x", "y", "z")


def calibrate_all(root) -> dict:
    """Per trajectory folder: `calibrate`'s CalibrationResult in GT mode without the noise run."""
    from graphnav.calibration.calibrate import calibrate
    from graphnav.missions import load_mission
    out = {}
    for folder in akit_trajectories(root):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out[folder] = calibrate(load_mission(str(folder)), "gt", min_depth_m=2.0)
        print(f"calibrated {folder.name}", flush=True)
    return out


def calibrate_simulated(n: int) -> dict:
    """Per simulated mission (seeds 20 ... 20 + n - 1, 400 s): `calibrate`'s CalibrationResult in GT mode."""
    from graphnav.calibration.calibrate import calibrate
    from graphnav.sim.simulate import simulate_mission
    out = {}
    for seed in range(20, 20 + n):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out[Path(f"simulated-{seed}")] = calibrate(simulate_mission(400.0, seed=seed), "gt")
        print(f"calibrated simulated mission {seed}", flush=True)
    return out


def estimates(results: dict) -> dict:
    """Per trajectory name: {field: (value list, sigma list)}."""
    return {folder.name: {f: (np.atleast_1d(getattr(r, f).value).tolist(), np.atleast_1d(getattr(r, f).sigma).tolist())
                          for f, *_ in QUANTITIES} for folder, r in results.items()}


def navigate_one(task) -> list[dict]:
    """Mission VRMSE (m/s) and velocity NEES of the study methods, all beams, for one (folder, setting, config
    path or None for the loader's defaults)."""
    from graphnav.evaluation.consistency import mission_nees
    from graphnav.evaluation.crossval import STUDY_METHODS, run_methods
    from graphnav.evaluation.metrics import vrmse
    from graphnav.missions import load_mission
    folder, setting, config_path = task
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mission = load_mission(folder, config_path)
        sols = run_methods(mission, STUDY_METHODS, "none")
    return [{"trajectory": Path(folder).name, "setting": setting, "method": method,
             "vrmse_mission": float(vrmse(sol, mission.gt, mission.t0, mission.t1)),
             "nees_mission": mission_nees(sol, mission)["nees_mission"]} for method, sol in sols.items()]


def navigate(results: dict, tmp: Path, jobs: int) -> list[dict]:
    """:func:`navigate_one` rows of every trajectory with the loader's defaults and with the configuration the other
    trajectories' calibrations combine to."""
    from graphnav.calibration.combine import combine
    from graphnav.evaluation.tasks import run_tasks
    tasks = []
    for folder in results:
        others = [f for f in results if f != folder]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            combined = combine([results[f] for f in others], [f.name for f in others])
        path = tmp / f"without-{folder.name}.json"
        path.write_text(json.dumps(combined.config_dict()) + "\n")
        tasks += [(str(folder), "default", None), (str(folder), "combined, other nine", str(path))]
    rows: list[dict] = []
    run_tasks(navigate_one, tasks, rows.extend, jobs=jobs)
    return rows


def print_navigation(rows: list[dict]) -> None:
    from graphnav.evaluation.crossval import STUDY_METHODS, mean_range
    print("\n| method | configuration | mission VRMSE (m/s): mean (range) | velocity NEES: mean (range) | "
          "trajectories better in VRMSE |")
    print("| --- | --- | --- | --- | --- |")
    for method in STUDY_METHODS:
        by = {}
        for r in rows:
            if r["method"] == method:
                by.setdefault(r["setting"], {})[r["trajectory"]] = r
        default = by.get("default", {})
        for setting, per in sorted(by.items(), key=lambda item: item[0] != "default"):
            v = [per[t]["vrmse_mission"] for t in per]
            n = [per[t]["nees_mission"] for t in per if per[t]["nees_mission"] is not None]
            better = sum(per[t]["vrmse_mission"] < default[t]["vrmse_mission"] for t in per if t in default)
            print(f"| {method} | {setting} | {mean_range(v, 4)} | {mean_range(n, 2)} | "
                  f"{'-' if setting == 'default' else f'{better} of {len(per)}'} |")


def held_out(y: np.ndarray, s: np.ndarray) -> dict:
    """Leave-one-out z of each mission (k,) against the others: per-mission sigmas only, and random effects; with the
    random effects also how many fall within the 95 % interval (|z| under the t quantile of ``k - 3`` degrees of
    freedom, the ``k - 1`` others' ``next_mission_95`` over their next-mission sigma)."""
    z_fixed, z_re = [], []
    for i in range(len(y)):
        rest = np.arange(len(y)) != i
        w = 1.0 / s[rest] ** 2
        mean_fixed, sigma_fixed = np.sum(w * y[rest]) / np.sum(w), 1.0 / np.sqrt(np.sum(w))
        z_fixed.append((y[i] - mean_fixed) / np.hypot(s[i], sigma_fixed))
        re = random_effects(y[rest], s[rest])
        z_re.append((y[i] - float(re.value)) / np.hypot(s[i], float(re.next_mission_sigma)))
    z_fixed, z_re = np.array(z_fixed), np.array(z_re)
    t95 = float(student_t.ppf(0.975, len(y) - 3)) if len(y) > 3 else float("nan")
    return {"within2_fixed": int(np.sum(np.abs(z_fixed) < 2)), "rms_z_fixed": float(np.sqrt(np.mean(z_fixed ** 2))),
            "within2_re": int(np.sum(np.abs(z_re) < 2)), "rms_z_re": float(np.sqrt(np.mean(z_re ** 2))),
            "within95_re": int(np.sum(np.abs(z_re) < t95)), "max_abs_z_re": float(np.max(np.abs(z_re)))}


def table(per_mission: dict) -> list[dict]:
    rows = []
    names = list(per_mission)
    for field, label, scale, unit in QUANTITIES:
        values = np.array([per_mission[n][field][0] for n in names])
        sigmas = np.array([per_mission[n][field][1] for n in names])
        re = random_effects(values, sigmas)
        for j in range(values.shape[1]):
            row = {"quantity": label + (f" {AXES[j]}" if values.shape[1] > 1 else ""), "unit": unit,
                   "value": float(re.value[j]) * scale, "median_sigma": float(np.median(sigmas[:, j])) * scale,
                   "spread": float(np.std(values[:, j], ddof=1)) * scale,
                   "next_mission_sigma": float(re.next_mission_sigma[j]) * scale,
                   "scatter_over_sigma": float(np.sqrt(re.q_per_dof[j])), "p": float(re.p[j])}
            rows.append({**row, **held_out(values[:, j], sigmas[:, j])})
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    parser.add_argument("--out", default="out/calibration_spread.json", help="per-mission estimates and the table")
    parser.add_argument("--navigate", action="store_true",
                        help="also navigate each trajectory with the other nine's combined configuration")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes for --navigate")
    parser.add_argument("--simulated", type=int, metavar="N", default=None,
                        help="N simulated missions of one vehicle instead of the shared trajectories")
    args = parser.parse_args(argv)
    if args.simulated is not None and args.navigate:
        parser.error("--navigate runs the shared trajectories; not with --simulated")
    results = calibrate_all(args.data) if args.simulated is None else calibrate_simulated(args.simulated)
    per_mission = estimates(results)
    rows, k = table(per_mission), len(per_mission)
    print("| quantity | combined | median per-mission sigma | spread over the missions | next-mission sigma | "
          f"scatter/sigma | held out within 2 sigma, of {k}: per-mission sigmas / random effects | "
          "RMS z: per-mission / random effects | held out within the 95 % interval (largest z) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['quantity']} ({r['unit']}) | {r['value']:+.3f} | {r['median_sigma']:.3f} | {r['spread']:.3f} | "
              f"{r['next_mission_sigma']:.3f} | {r['scatter_over_sigma']:.1f} | {r['within2_fixed']} / "
              f"{r['within2_re']} | {r['rms_z_fixed']:.2f} / {r['rms_z_re']:.2f} | {r['within95_re']} "
              f"({r['max_abs_z_re']:.2f}) |")
    runs = []
    if args.navigate:
        with tempfile.TemporaryDirectory() as tmp:
            runs = navigate(results, Path(tmp), args.jobs)
        print_navigation(runs)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"missions": per_mission, "rows": rows, "runs": runs}, indent=2) + "\n")
    print(f"written to {args.out}")


if __name__ == "__main__":
    main()
