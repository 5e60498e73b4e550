"""The DVL clock offset found from the data (graphnav.calibration.clock) on short pieces of the shared A-KIT
trajectories: 60, 90 and 120 s from 0 s every 70 s (up to 400 s), the DVL on a clock --away s from the IMU's.

    .venv/bin/python experiments/clock_crops.py [--away 600] [Trajectory1 ...]

The truth is the whole log's estimate (the same DVL clock); a piece keeps the IMU samples and the DVL pings
stamped inside it on the IMU clock (the published stamps less the loader's GT-based DVL offset). Per piece: the
error, sigma, whether confident, the explained fraction at the peak and at the next best offset, the sharpness,
and the largest share of the explained signal (straight-line SSE less the model's, per window) one window holds at
the estimate. Then the confident count, their |error| median and max, and the confident ones off by over 0.5 s.
"""
from __future__ import annotations

import argparse
import dataclasses
import warnings

import numpy as np

from graphnav.core.dvl_kinematics import dvl_window_model
from graphnav.calibration.clock import estimate_dvl_clock_offset
from graphnav.core.errors import ConfigError
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_akit

LENGTHS_S = (60.0, 90.0, 120.0)
STEP_S = 70.0
FIRST_S = 400.0


def largest_window_share(imu, dvl, config, offset: float) -> float:
    """The largest share of the explained signal (straight-line SSE less the model's) one window holds at
    ``offset`` s, with the pings the clock search fits there."""
    model, _ = dvl_window_model(imu, dvl, config, trim=True)
    use = model.pings(offset)
    sse, windows = model.sse(offset, use)
    gain = np.clip((model.null_sse(use) - sse)[windows], 0.0, None)
    return float(gain.max() / max(gain.sum(), 1e-18))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("names", nargs="*", help="trajectories (default: all)")
    ap.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    ap.add_argument("--away", type=float, default=600.0, help="DVL clock offset from the IMU's, s")
    args = ap.parse_args(argv)
    try:
        folders = akit_trajectories(args.data, args.names or None)
    except ConfigError as exc:
        print(f"skipped: {exc}")
        return 0
    rows = []
    for folder in folders:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = load_akit(folder, imu_axis_signs=(1, -1, 1))
        on_imu = m.dvl.t - m.config.dvl_time_offset_s
        raw = dataclasses.replace(m.dvl, t=on_imu - args.away)
        whole = estimate_dvl_clock_offset(m.imu, raw, m.config).offset_s
        for length in LENGTHS_S:
            for start in np.arange(0.0, FIRST_S - length + 1e-9, STEP_S):
                a, b = m.imu.t[0] + start, m.imu.t[0] + start + length
                imu = m.imu.take(np.flatnonzero((m.imu.t >= a) & (m.imu.t <= b)))
                dvl = raw.take(np.flatnonzero((on_imu >= a) & (on_imu <= b)))
                e = estimate_dvl_clock_offset(imu, dvl, m.config)
                share = largest_window_share(imu, dvl, m.config, e.offset_s)
                err = e.offset_s - whole
                rows.append((err, e.confident, share))
                print(f"{folder.name:13s} {length:3.0f} s from {start:3.0f} s: error {err:+7.3f} s, sigma "
                      f"{e.sigma_s:.3f} s, confident {e.confident!s:5s} explained {e.peak:.3f} / next "
                      f"{e.second_peak:.3f}, sharpness {e.sharpness:6.2f}, largest window share {share:.2f}",
                      flush=True)
    err = np.array([r[0] for r in rows])
    conf = np.array([r[1] for r in rows], bool)
    e = np.abs(err[conf])
    print(f"{conf.sum()} of {len(rows)} confident; |error| median {np.median(e):.3f} s, max {e.max():.3f} s; "
          f"confident and over 0.5 s off: {(e > 0.5).sum()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
