"""The depth's changes against the vehicle's vertical velocity (``graphnav.io.units.depth_rate_fit``): the slope and
correlation the depth convention check of the prepare step decides from, on the shared A-KIT trajectories and
simulated missions, with the vertical velocity of the GT and of the DVL turned by the accelerometer's gravity
direction (the GT left out).

    .venv/bin/python experiments/depth_convention_rates.py [--window 200] [--step 100]

Prints per mission: slope k and correlation r, whole and over windows of ``--window`` s every ``--step`` s (DVL
velocity), how many windows decide (|r| >= DEPTH_FIT_MIN_CORRELATION) and the decided slopes' range. A depth in
metres positive down gives 1, positive up -1, a pressure in bar 0.098.
"""
from __future__ import annotations

import argparse
import dataclasses
import warnings

import numpy as np

from graphnav.io.paths import akit_trajectories
from graphnav.io.units import DEPTH_FIT_MIN_CORRELATION, depth_rate_fit, vertical_velocity
from graphnav.missions import load_akit
from graphnav.sim.simulate import simulate_mission


def describe(m, label: str, window: float, step: float) -> str:
    parts = []
    for source, mission in (("gt", m), ("dvl", dataclasses.replace(m, gt=None))):
        t, v, _ = vertical_velocity(mission)
        k, r = depth_rate_fit(m.depth.t, m.depth.depth, t, v)
        parts.append(f"{source} k={k:.3f} r={r:.3f}")
    t, v, _ = vertical_velocity(dataclasses.replace(m, gt=None))
    fits = []
    for start in np.arange(m.imu.t[0], m.imu.t[-1] - window + 1e-9, step):
        sel = (m.depth.t >= start) & (m.depth.t < start + window)
        fits.append(depth_rate_fit(m.depth.t[sel], m.depth.depth[sel], t, v))
    if fits:
        k, r = np.array(fits).T
        decided = np.abs(r) >= DEPTH_FIT_MIN_CORRELATION
        span = f"k {k[decided].min():.3f}..{k[decided].max():.3f}" if decided.any() else "none decided"
        parts.append(f"{window:g} s windows (dvl): {decided.sum()} of {len(fits)} decide, {span}, "
                     f"r {np.nanmin(r):.2f}..{np.nanmax(r):.2f}")
    return f"{label}: " + "  ".join(parts)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    ap.add_argument("--window", type=float, default=200.0, help="window length, s")
    ap.add_argument("--step", type=float, default=100.0, help="time between window starts, s")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    for folder in akit_trajectories(args.data):
        print(describe(load_akit(folder), folder.name, args.window, args.step), flush=True)
    for grade in ("navigation", "tactical", "mems"):
        for seed in (0, 1, 2):
            for duration in (150.0, 600.0):
                m = simulate_mission(duration, grade, seed)
                print(describe(m, f"simulated {grade} seed {seed} {duration:g} s", args.window, args.step), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
