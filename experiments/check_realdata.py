#!/usr/bin/env python
"""Per-trajectory consistency table of the shared A-KIT data as graphnav loads it.

Columns: estimated GT and DVL time offsets (s, +-1 sigma; added to the rescaled file stamps), the DVL
minus GT body velocity (+ omega x l) RMS per axis over submerged pings and over all pings (m/s), the
gyro-vs-GT attitude error 60 s after starting from the GT attitude (deg; worst over starts every 100 s)
with the y flip and without it, the slope of the GT offset over the file (ms/s, from 100 s windows) with
the published stamps and with the rescaled ones, the accelerometer and gyro white-noise densities
implied by the sample-to-sample scatter (std of consecutive differences / sqrt(2 f), per sqrt(Hz)) and the
time to read the IMU CSV.

Usage: .venv/bin/python experiments/check_realdata.py [--data AKIT_FOLDER]   (default: the shared data)
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from graphnav.calibration.preparation import gt_offset_drift
from graphnav.calibration.reference import dvl_consistency, gyro_attitude_error
from graphnav.io import paths
from graphnav.io.loaders import AKIT_COLUMNS, akit_files, read_csv
from graphnav.missions import load_akit


def error_after(m, duration=60.0, step=100.0):
    """Worst attitude error (deg) at the end of ``duration`` s windows started every ``step`` s."""
    gt, lat = m.gt, m.config.lat_rad
    starts = np.arange(max(gt.t[0], m.t0), min(gt.t[-1], m.t1) - duration, step)
    return max(np.degrees(np.linalg.norm(gyro_attitude_error(m.imu.t, m.imu.omega_b, gt.t, gt.C_b_n, s,
                                                             duration, lat)[-1]))
               for s in starts)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    folders = paths.akit_trajectories(parser.parse_args(argv).data)
    head = (f"{'trajectory':<13}{'gt off s':>14}{'dvl off s':>14}{'DVL-GT rms':>11}{'(all)':>8}"
            f"{'gyro60 deg':>11}{'no y-fix':>9}{'drift ms/s':>11}{'(fixed)':>8}{'acc dens':>9}{'gyr dens':>9}"
            f"{'read s':>7}")
    print(head)
    print("-" * len(head))
    for folder in folders:
        t0 = time.perf_counter()
        read_csv(akit_files(folder)["IMU"], AKIT_COLUMNS["IMU"])
        t_read = time.perf_counter() - t0
        m = load_akit(folder)
        c, est = m.config, m.meta["time_offsets"]
        cons = dvl_consistency(m)
        raw = load_akit(folder, imu_axis_signs=(1, 1, 1), gt_time_offset_s=c.gt_time_offset_s,
                        dvl_time_offset_s=c.dvl_time_offset_s)
        rate = 1.0 / np.median(np.diff(m.imu.t))
        hf_acc = np.median(np.std(np.diff(m.imu.f_b, axis=0), axis=0)) / np.sqrt(2 * rate)
        hf_gyr = np.median(np.std(np.diff(m.imu.omega_b, axis=0), axis=0)) / np.sqrt(2 * rate)
        print(f"{folder.name:<13}{c.gt_time_offset_s:>+7.3f}+-{est['gt']['sigma_s']:<5.3f}"
              f"{c.dvl_time_offset_s:>+7.3f}+-{est['dvl']['sigma_s']:<5.3f}{cons['rms']:>11.4f}"
              f"{cons['rms_all']:>8.4f}{error_after(m):>11.3f}{error_after(raw):>9.2f}"
              f"{1e3 * gt_offset_drift(folder, False):>11.2f}{1e3 * gt_offset_drift(folder, True):>8.2f}{hf_acc:>9.1e}{hf_gyr:>9.1e}"
              f"{t_read:>7.3f}")
    print("\nDVL-GT rms: per-axis RMS of DVL - (GT v_b + omega x l), l = config lever arm, submerged "
          "pings (depth > 2 m); (all): every ping.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
