"""How often the no-GT IMU axis-convention detection picks the right convention on windows of the shared A-KIT
trajectories (published files: y flipped, the right answer is (1, -1, 1)).

    .venv/bin/python experiments/axis_detection_rates.py [--length 60] [--step 60] [--corrected | --mixed]

Prints, per trajectory and overall: right (decided, signs (1,-1,1)), undecided (fell back to the configured
convention), wrong (decided other signs), refused (DataError). ``--corrected``: the files with y negated
(the authors' corrected convention; right = (1, 1, 1)). ``--mixed``: the gyro y negated alone (no convention
fits; right = refused).
"""
from __future__ import annotations

import argparse
import warnings

import numpy as np

from graphnav.calibration.axes import detect_imu_axis_signs
from graphnav.core.config import SensorConfig
from graphnav.core.errors import DataError
from graphnav.core.mission import ImuData
from graphnav.io.loaders import AKIT_COLUMNS, akit_files, read_csv
from graphnav.io.paths import akit_trajectories

RIGHT = np.array([1.0, -1.0, 1.0])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    ap.add_argument("--length", type=float, default=60.0, help="IMU segment length, s")
    ap.add_argument("--step", type=float, default=60.0, help="time between segment starts, s")
    ap.add_argument("--corrected", action="store_true", help="flip the y axis first (right answer: no flip)")
    ap.add_argument("--mixed", action="store_true", help="flip the gyro y only (no consistent answer exists)")
    args = ap.parse_args(argv)
    right = np.array([1.0, 1.0, 1.0]) if args.corrected else RIGHT
    total = {"right": 0, "undecided": 0, "wrong": 0, "refused": 0}
    for folder in akit_trajectories(args.data):
        imu = read_csv(akit_files(folder)["IMU"], AKIT_COLUMNS["IMU"])
        if args.corrected:
            imu[:, [2, 5]] *= -1
        if args.mixed:
            imu[:, 5] *= -1
        t = imu[:, 0]
        counts = dict.fromkeys(total, 0)
        for start in np.arange(t[0], t[-1] - args.length + 1e-9, args.step):
            sel = (t >= start) & (t < start + args.length)
            data = ImuData(np.ascontiguousarray(t[sel]), imu[sel, 1:4], imu[sel, 4:7], folder.name)
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    det = detect_imu_axis_signs(data, SensorConfig(), None, folder.name)
            except DataError:
                counts["refused"] += 1
                continue
            if not det.decided:
                counts["undecided"] += 1
            elif np.array_equal(det.signs, right) and not args.mixed:
                counts["right"] += 1
            else:
                counts["wrong"] += 1
        for k in total:
            total[k] += counts[k]
        print(folder.name, counts, flush=True)
    n = sum(total.values())
    print("all", total, " ".join(f"{k} {100 * v / n:.0f} %" for k, v in total.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
