"""The DVL clock offset found from the data (graphnav.calibration.clock) on the shared A-KIT trajectories,
against the fine offset the loader estimates against the GT, with known offsets injected.

    .venv/bin/python experiments/clock_offsets.py [--inject 0 0.7 37 518400]

For each trajectory and injected offset: the estimate minus (GT-based offset + injected), the explained
fraction at the peak and at the next best offset, and sigma.
"""
from __future__ import annotations

import argparse
import dataclasses
import warnings

import numpy as np

from graphnav.calibration.clock import estimate_dvl_clock_offset
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_akit


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    ap.add_argument("--inject", type=float, nargs="*", default=[0.0, 0.7, 37.0, 6 * 86400.0],
                    help="DVL clock offsets to inject, s")
    args = ap.parse_args(argv)
    errors = []
    for folder in akit_trajectories(args.data):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = load_akit(folder, imu_axis_signs=(1, -1, 1))
        gt_based = m.config.dvl_time_offset_s
        raw_t = m.dvl.t - gt_based
        for inj in args.inject:
            dvl = dataclasses.replace(m.dvl, t=raw_t - inj)
            est = estimate_dvl_clock_offset(m.imu, dvl, m.config)
            err = est.offset_s - (gt_based + inj)
            errors.append(err)
            print(f"{folder.name:13s} injected {inj:9.1f} s: error {err:+.3f} s (GT-based {gt_based:+.3f} s), "
                  f"explained {est.peak:.3f} / next {est.second_peak:.3f}, sigma {est.sigma_s:.3f} s, "
                  f"confident {est.confident}", flush=True)
    e = np.abs(errors)
    print(f"all: |error| median {np.median(e):.3f} s, max {e.max():.3f} s over {len(e)} cases")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
