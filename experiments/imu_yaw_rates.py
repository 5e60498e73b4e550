"""How well the DVL tells an IMU turned about z (90, 180, 270 deg) from one as read, without a reference attitude
(:func:`graphnav.calibration.dvl_scale.imu_yaw_fit`): the shared A-KIT trajectories and simulated missions, whole
and in windows, as read and with the IMU's accelerometer and gyro turned.

    .venv/bin/python experiments/imu_yaw_rates.py [--windows 0 45 60 120] [--no-sim] [--search]

Prints per source and window length: the largest q as read and the smallest turned (q > 0: a turn fits better, in
noise variances), how many of each the check refuses, cannot judge (|q| under IMU_YAW_MIN_Q) or passes, turned
windows where it names a wrong turn alone, and windows too short for the clock model (two 20 s windows of pings).
With ``--search`` each fit is read at its best DVL offset within +- 20 s, as the check does where the speed-scale
fit cannot fix the DVL's clock (``dvl_kinematics.SCALE_OFFSETS_S``); else at the stamps as they are.
"""
from __future__ import annotations

import argparse
import dataclasses
import warnings

import numpy as np

from graphnav.core.dvl_kinematics import dvl_window_model
from graphnav.calibration.dvl_scale import (IMU_YAW_MIN_Q, IMU_YAWS_DEG, SCALE_OFFSETS_S, imu_turned_models,
                                           imu_yaw_fit, turn_about_z)
from graphnav.core.errors import DataError
from graphnav.io.paths import akit_trajectories


def _sources(data, sim: bool):
    from graphnav.missions import load_akit
    from graphnav.sim.simulate import simulate_mission
    for folder in akit_trajectories(data):
        yield "A-KIT", load_akit(folder)
    if sim:
        for grade in ("navigation", "tactical", "mems"):
            for seed in range(4):
                yield f"sim {grade}", simulate_mission(400.0, grade, seed, dropout=seed == 3)
        for seed in range(2):
            yield "sim transit", simulate_mission(400.0, "navigation", seed, pattern="transit")


def _cut(m, t0: float, t1: float):
    """The IMU and DVL of ``m`` between t0 and t1, s (the DVL half a second inside)."""
    k, j = (m.imu.t >= t0) & (m.imu.t <= t1), (m.dvl.t >= t0 + 0.5) & (m.dvl.t <= t1 - 0.5)
    imu = dataclasses.replace(m.imu, t=m.imu.t[k], f_b=m.imu.f_b[k], omega_b=m.imu.omega_b[k])
    fields = ("t", "beams", "valid", "v_b", "v_d", "v_d_valid")
    dvl = dataclasses.replace(m.dvl, **{f: getattr(m.dvl, f)[j] for f in fields if getattr(m.dvl, f) is not None})
    return imu, dvl


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    ap.add_argument("--windows", type=float, nargs="+", default=[0, 45, 60, 120],
                    help="window lengths, s, every half window (0: the whole mission)")
    ap.add_argument("--no-sim", action="store_true", help="the A-KIT trajectories only")
    ap.add_argument("--search", action="store_true", help="each fit at its best DVL offset within +-20 s")
    args = ap.parse_args(argv)
    offsets = SCALE_OFFSETS_S if args.search else (0.0,)
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for kind, m in _sources(args.data, not args.no_sim):
            for w in args.windows:
                t0, t1 = m.imu.t[0], m.imu.t[-1]
                for start in ([t0] if not w else np.arange(t0, t1 - w + 1e-9, w / 2)):
                    imu, dvl = _cut(m, start, start + w if w else t1)
                    for turn in (0, *IMU_YAWS_DEG):
                        T = turn_about_z(turn).T
                        turned = dataclasses.replace(imu, f_b=imu.f_b @ T.T, omega_b=imu.omega_b @ T.T)
                        try:
                            model, _ = dvl_window_model(turned, dvl, m.config)
                        except DataError:
                            rows.append((kind, w, turn, None, None, None))
                            continue
                        rows.append((kind, w, turn, *imu_yaw_fit(imu_turned_models(model, turned, dvl, m.config),
                                                                        offsets)))
    for kind in dict.fromkeys(r[0] for r in rows):
        for w in args.windows:
            sel = [r for r in rows if r[0] == kind and r[1] == w]
            short = sum(r[3] is None for r in sel)
            clean = np.array([r[3] for r in sel if r[3] is not None and r[2] == 0])
            turned = [r for r in sel if r[3] is not None and r[2]]
            q = np.array([r[3] for r in turned])
            if not clean.size:
                print(f"{kind:15s} {w or 'whole':>5} s: all {short} too short")
                continue
            wrong = sum(r[3] >= IMU_YAW_MIN_Q and r[4] != r[2] and r[5] >= IMU_YAW_MIN_Q for r in turned)
            print(f"{kind:15s} {w or 'whole':>5} s: as read n={clean.size} q max {clean.max():+.3g} (refused "
                  f"{np.sum(clean >= IMU_YAW_MIN_Q)}, not judged {np.sum(abs(clean) < IMU_YAW_MIN_Q)}) | turned "
                  f"n={q.size} q min {q.min():+.3g} (refused {np.sum(q >= IMU_YAW_MIN_Q)}, not judged "
                  f"{np.sum(abs(q) < IMU_YAW_MIN_Q)}, passed {np.sum(q <= -IMU_YAW_MIN_Q)}, a wrong turn named alone "
                  f"{wrong}) | too short {short}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
