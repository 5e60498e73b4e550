"""How far the DVL velocity's turn about z from the IMU's axes (:func:`graphnav.core.dvl_kinematics.speed_scale`)
strays from the truth against its sigma (:func:`~graphnav.core.dvl_kinematics.yaw_sigma`), and what the small-turn
warning (:data:`~graphnav.calibration.dvl_scale.MIN_YAW_RAD`, :data:`~graphnav.calibration.dvl_scale.YAW_SIGMAS`,
r^2 at least :data:`~graphnav.core.dvl_kinematics.MIN_SCALE_R2`) says: the shared A-KIT trajectories whole and in
pieces, simulated missions (navigation, tactical, MEMS; 0.042 and 0.01 m/s beam noise; seeds 0-2; 150 and 600 s
whole, the 600 s ones in pieces), each as read and with its DVL velocity turned.

    .venv/bin/python experiments/dvl_yaw_floor.py [--pieces 60 120] [--turns 0 3 5 8 20 45] [--no-sim] [--no-akit]

Prints per source, piece length (0: whole) and turn: the pieces the fit judges (r^2, enough velocity change), the
largest |yaw - turn| / sigma, the yaws, the sigmas, and how many are warned about beyond 10 deg and as a small turn
(both beyond 3 sigmas, the fit at the DVL's stamps).
"""
from __future__ import annotations

import argparse
import collections
import sys
import warnings

import numpy as np

from graphnav.calibration import dvl_scale as ds
from graphnav.core import dvl_kinematics as dk
from graphnav.core.errors import DataError
from graphnav.io.paths import akit_trajectories

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from imu_yaw_rates import _cut  # noqa: E402  (the same IMU and DVL pieces)


def _sources(akit: bool, sim: bool):
    from graphnav.core.config import SensorConfig
    from graphnav.missions import load_akit
    from graphnav.sim.simulate import simulate_mission
    if akit:
        for folder in akit_trajectories(None):
            yield "A-KIT", False, load_akit(folder)
    if sim:
        for noise in (0.042, 0.01):
            for grade in ("navigation", "tactical", "mems"):
                for seed in range(3):
                    for duration in (150.0, 600.0):
                        cfg = SensorConfig()
                        cfg.dvl.beam_noise_std = noise
                        yield f"sim {noise:g} m/s {grade}", duration < 600.0, simulate_mission(duration, grade, seed,
                                                                                               config=cfg)


def _fit(imu, dvl, config, turn: float):
    """(r2, yaw deg, sigma deg) of the DVL turned ``turn`` deg at its stamps, as the check takes it; None when the
    velocity changes too little to judge."""
    try:
        model = ds.judging_model(imu, dvl, config, transform=ds.turn_about_z(turn))
    except DataError:
        return None
    yaw, sigma, r2 = dk.turn_at(model)
    return r2, np.degrees(yaw), np.degrees(sigma)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pieces", type=float, nargs="+", default=[60.0, 120.0], help="piece lengths, s")
    ap.add_argument("--turns", type=float, nargs="+", default=[0.0, 3.0, 5.0, 8.0, 20.0, 45.0],
                    help="turns applied, deg")
    ap.add_argument("--no-sim", action="store_true", help="the A-KIT trajectories only")
    ap.add_argument("--no-akit", action="store_true", help="the simulated missions only")
    args = ap.parse_args(argv)
    table = collections.defaultdict(list)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, whole_only, m in _sources(not args.no_akit, not args.no_sim):
            t0, t1 = m.imu.t[0], m.imu.t[-1]
            for length in [0.0] + ([] if whole_only else args.pieces):
                for start in [t0] if not length else np.arange(t0, t1 - length + 1e-9, length):
                    imu, dvl = _cut(m, start, start + length if length else t1)
                    for turn in args.turns:
                        fit = _fit(imu, dvl, m.config, turn)
                        if fit is not None:
                            table[name, length, turn].append(fit)
    for (name, length, turn), fits in sorted(table.items()):
        r2, yaw, sigma = (np.array(x) for x in zip(*fits))
        ok = r2 >= dk.MIN_SCALE_R2
        beyond = ok & (np.abs(yaw) > ds.YAW_SIGMAS * sigma)
        big = beyond & (np.abs(yaw) > np.degrees(ds.MAX_YAW_RAD))
        small = beyond & (np.abs(yaw) <= np.degrees(ds.MAX_YAW_RAD)) & (np.abs(yaw) > np.degrees(ds.MIN_YAW_RAD))
        line = f"{name:28s} {length:4.0f} s turn {turn:3g}: judged {ok.sum():2d}/{len(fits):2d}"
        if ok.any():
            line += (f", |yaw - turn| / sigma <= {np.max(np.abs(yaw - turn)[ok] / sigma[ok]):4.1f}, yaw "
                     f"{yaw[ok].min():+6.1f}..{yaw[ok].max():+6.1f}, sigma {sigma[ok].min():.2f}..{sigma[ok].max():.2f}"
                     f" deg; warned > 10 deg {big.sum()}, small turn {small.sum()}")
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
