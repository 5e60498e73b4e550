"""The share of the DVL velocity's changes the clock model leaves unexplained with the velocity multiplied by 0.001,
0.01, 0.1, 1, 10, 100 and 1000 (:func:`graphnav.calibration.dvl_scale.velocity_scale_fits`): a declared
``velocity_unit`` 100x (cm/s) or 1000x (mm/s) too small for the data gives the velocity x0.01 or x0.001, and the unit
that fits is the one that brings it back. The shared A-KIT trajectories whole and in 60 s pieces every 30 s, simulated
missions (navigation, tactical, MEMS; seeds 0-2; 150 and 600 s; the default beams) and hovering vehicles with a DVL
(``tests/test_units.py::_hovering_with_dvl``).

A knots mix-up gives the velocity x0.514 (m/s declared kn) or x1.944 (knots declared m/s): ``--scales 0.514444
1.943844``.

    .venv/bin/python experiments/dvl_unit_fits.py [--no-sim] [--no-pieces] [--scales K ...]
"""
from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

from graphnav.calibration.dvl_scale import velocity_scale_fits
from graphnav.core.errors import DataError
from graphnav.io.paths import akit_trajectories

sys.path.insert(0, __file__.rsplit("/", 1)[0])
sys.path.insert(0, __file__.rsplit("/", 2)[0] + "/tests")
from imu_yaw_rates import _cut  # noqa: E402  (the same IMU and DVL pieces)
from test_units import _hovering_with_dvl, sim_config  # noqa: E402  (the hovering vehicle the tests judge)

SCALES = (0.001, 0.01, 0.1, 10.0, 100.0, 1000.0)


def _sources(sim: bool, pieces: bool):
    from graphnav.missions import load_akit
    from graphnav.sim.simulate import simulate_mission
    for folder in akit_trajectories(None):
        m = load_akit(folder)
        yield f"A-KIT {folder.name}", m.imu, m.dvl, m.config
        for start in np.arange(m.imu.t[0], m.imu.t[-1] - 60.0, 30.0) if pieces else ():
            yield f"A-KIT {folder.name} 60 s from {start - m.imu.t[0]:.0f}", *_cut(m, start, start + 60.0), m.config
    if sim:
        for grade in ("navigation", "tactical", "mems"):
            for seed in range(3):
                for duration in (150.0, 600.0):
                    m = simulate_mission(duration, grade, seed)
                    yield f"sim {grade} {seed} {duration:.0f} s", m.imu, m.dvl, m.config
        config = sim_config()
        for seed in (1, 2, 3):
            for acc in (0.03, 0.2):
                for tilt in (0.0003, 0.003):
                    yield f"hovering seed {seed} {acc} m/s^2 {tilt} rad", *_hovering_with_dvl(acc, tilt, seed), config


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-sim", action="store_true", help="the A-KIT trajectories only")
    ap.add_argument("--no-pieces", action="store_true", help="whole A-KIT trajectories only")
    ap.add_argument("--scales", type=float, nargs="+", default=SCALES, help="the factors tried besides 1")
    args = ap.parse_args(argv)
    scales = tuple(args.scales)
    print("source; unexplained at x" + " ".join(f"{k:g}" for k in (1.0, *scales)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, imu, dvl, config in _sources(not args.no_sim, not args.no_pieces):
            try:
                fits = velocity_scale_fits(imu, dvl, config, scales)
            except DataError as exc:
                print(f"{name}; not judged: {exc.message}")
                continue
            print(f"{name}; " + " ".join(f"{fits[k]:.4g}" for k in (1.0, *scales)), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
