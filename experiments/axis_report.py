"""IMU axis convention detected by the prepare step on the shared A-KIT trajectories, in both conventions.

For each trajectory: the files as published (IMU y flipped) and a temporary copy with the IMU y columns
negated (y already in the body frame, as in the authors' corrected files), each with the GT file (gyro
against the GT attitude) and without it (gravity and gyro consistency); prints the signs
the axis check of ``prepare`` (``imu_axis_signs="auto"``) chose (expected (1,-1,1) and (1,1,1)) and the CPU
time the detection adds to a ``load_akit`` (against an explicit convention).

    .venv/bin/python experiments/axis_report.py
"""
from __future__ import annotations

import argparse
import shutil
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from graphnav.calibration.preparation import detect_akit_axis_signs
from graphnav.io.loaders import AKIT_COLUMNS, akit_files, read_akit_mission, read_csv
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_akit

EXPECTED = {"published": (1, -1, 1), "y in body": (1, 1, 1)}


def copy_folder(src: Path, dst_root: Path, negate_y: bool, with_gt: bool) -> Path:
    files = akit_files(src)
    dst = dst_root / src.name
    dst.mkdir(parents=True)
    if negate_y:
        imu = read_csv(files["IMU"], AKIT_COLUMNS["IMU"])
        imu[:, [2, 5]] *= -1
        np.savetxt(dst / files["IMU"].name, imu, delimiter=",", fmt="%.17g", comments="",
                   header=",".join(AKIT_COLUMNS["IMU"]))
    else:
        shutil.copy(files["IMU"], dst / files["IMU"].name)
    shutil.copy(files["DVL"], dst / files["DVL"].name)
    if with_gt:
        shutil.copy(files["GT"], dst / files["GT"].name)
    return dst


def cpu(fn) -> float:
    best = np.inf
    for _ in range(2):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return best


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    folders = akit_trajectories(parser.parse_args(argv).data)
    warnings.simplefilter("ignore")
    n_wrong = 0
    print(f"{'trajectory':12} {'convention':10} {'with GT':>10} {'no GT':>10} {'added load CPU s':>17}")
    with tempfile.TemporaryDirectory() as tmp:
        for folder in folders:
            for conv, negate in (("published", False), ("y in body", True)):
                chosen = {}
                for with_gt in (True, False):
                    d = copy_folder(folder, Path(tmp) / f"{conv}-{with_gt}".replace(" ", "_"), negate, with_gt)
                    read = read_akit_mission(d)
                    detection = detect_akit_axis_signs(read, read.meta["prepare"]["gt_mean_depth_m"])
                    chosen[with_gt] = tuple(int(s) for s in detection.signs)
                    n_wrong += chosen[with_gt] != EXPECTED[conv]
                    if with_gt:
                        added = cpu(lambda: load_akit(d)) - cpu(lambda: load_akit(d, imu_axis_signs=EXPECTED[conv]))
                print(f"{folder.name:12} {conv:10} {str(chosen[True]):>10} {str(chosen[False]):>10} {added:17.3f}",
                      flush=True)
    print(f"\n{n_wrong} wrong choice(s) of {len(folders) * 4}")
    return 1 if n_wrong else 0


if __name__ == "__main__":
    raise SystemExit(main())
