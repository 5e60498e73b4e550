"""What reading and preparing each shared A-KIT trajectory costs, and what the prepare step chose.

For every trajectory under ``--data``: the CPU time of ``graphnav.io.loaders.read_mission`` (parse, check,
screen, convert: nothing estimated), of ``graphnav.calibration.preparation.prepare`` with everything ``"auto"``
(IMU axis check, GT and DVL time offsets, GT moved to the IMU point), and of ``prepare`` with the axis signs and
offsets given (what a calibrated configuration does: only the GT move and the checks); then the signs and
offsets ``"auto"`` chose. The numbers behind docs/decisions/loading-and-prepare.md.

Usage: ``.venv/bin/python experiments/read_prepare_cost.py [--data ../shared/data/snapir-2022-akit]``
"""
from __future__ import annotations

import argparse
import time
import warnings

from graphnav.calibration.preparation import prepare
from graphnav.io.loaders import read_mission
from graphnav.io.paths import akit_trajectories


def cpu(fn):
    """(result, CPU seconds of this process) of ``fn()``."""
    start = time.process_time()
    out = fn()
    return out, time.process_time() - start


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default=None, help="folder of A-KIT trajectories (default: the shared data)")
    args = parser.parse_args(argv)
    print(f"{'trajectory':<14}{'read s':>8}{'prepare s':>11}{'given s':>9}  signs        gt offset s  dvl offset s")
    totals = [0.0, 0.0, 0.0]
    for folder in akit_trajectories(args.data):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            read, t_read = cpu(lambda: read_mission(folder))
            auto, t_auto = cpu(lambda: prepare(read))
            cfg = auto.config
            _, t_given = cpu(lambda: prepare(read, imu_axis_signs=tuple(cfg.imu_axis_signs),
                                             gt_time_offset_s=cfg.gt_time_offset_s,
                                             dvl_time_offset_s=cfg.dvl_time_offset_s))
        for i, t in enumerate((t_read, t_auto, t_given)):
            totals[i] += t
        signs = tuple(int(s) for s in cfg.imu_axis_signs)
        print(f"{folder.name:<14}{t_read:>8.2f}{t_auto:>11.2f}{t_given:>9.2f}  {str(signs):<12}"
              f"{cfg.gt_time_offset_s:>+11.3f}{cfg.dvl_time_offset_s:>+14.3f}")
    print(f"{'total':<14}{totals[0]:>8.2f}{totals[1]:>11.2f}{totals[2]:>9.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
