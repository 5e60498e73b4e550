"""How much a DVL velocity changes within the clock model's 20 s windows (RMS about each window's mean) over its
noise as the pings show it (:func:`graphnav.calibration.dvl_scale.velocity_change_rms`), the ratio
:data:`~graphnav.calibration.dvl_scale.MIN_CHANGE_OVER_NOISE` bounds, and the change itself, m/s
(:data:`~graphnav.calibration.dvl_scale.MIN_VELOCITY_CHANGE_MPS`): the shared A-KIT trajectories whole and in 60 s
pieces, and simulated missions (navigation, tactical, MEMS; lawnmower and transit; beams and noiseless).

    .venv/bin/python experiments/dvl_change_floor.py [--no-sim]
"""
from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

from graphnav.core.dvl_kinematics import dvl_window_model
from graphnav.calibration.dvl_scale import velocity_change_rms
from graphnav.core.errors import DataError
from graphnav.io.paths import akit_trajectories

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from imu_yaw_rates import _cut  # noqa: E402  (the same IMU and DVL pieces)


def _sources(sim: bool):
    from graphnav.missions import load_akit
    from graphnav.sim.simulate import simulate_mission
    for folder in akit_trajectories(None):
        yield f"A-KIT {folder.name}", load_akit(folder)
    if sim:
        for grade in ("navigation", "tactical", "mems"):
            for seed in range(2):
                yield f"sim {grade} {seed}", simulate_mission(400.0, grade, seed)
        yield "sim transit", simulate_mission(400.0, "navigation", 0, pattern="transit")
        yield "sim noiseless", simulate_mission(400.0, "navigation", 0, noiseless=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-sim", action="store_true", help="the A-KIT trajectories only")
    args = ap.parse_args(argv)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, m in _sources(not args.no_sim):
            c, n = velocity_change_rms(dvl_window_model(m.imu, m.dvl, m.config)[0])
            whole, whole_change = c / n, c
            pieces = []
            for start in np.arange(m.imu.t[0], m.imu.t[-1] - 60.0, 30.0):
                try:
                    c, n = velocity_change_rms(dvl_window_model(*_cut(m, start, start + 60.0), m.config)[0])
                    pieces.append(c / n)
                except DataError:
                    pass
            print(f"{name:24s} whole {whole:.3g} x noise (change {whole_change:.3g} m/s); 60 s pieces min "
                  f"{min(pieces):.3g} x, median {np.median(pieces):.3g} x ({len(pieces)})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
