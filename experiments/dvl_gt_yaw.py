"""The DVL velocity's turn about z against the GT's body velocity
(:func:`graphnav.calibration.dvl_scale.turn_against_reference`, the fit the A-KIT GT path warns by, beyond
:data:`~graphnav.calibration.dvl_scale.GT_MIN_YAW_RAD` and 3 sigmas) on the shared A-KIT trajectories, whole and in
pieces, as recorded and with the DVL velocity turned.

    .venv/bin/python experiments/dvl_gt_yaw.py [--pieces 60 120] [--turns 0 1 2 5]

Prints per trajectory, piece length (0: whole) and turn: the yaws and sigmas (deg) and how many pieces are warned.
"""
from __future__ import annotations

import argparse
import warnings

import numpy as np

from graphnav.calibration import dvl_scale as ds
from graphnav.calibration.reference import mission_reference
from graphnav.io.paths import akit_trajectories


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pieces", type=float, nargs="+", default=[60.0, 120.0], help="piece lengths, s")
    ap.add_argument("--turns", type=float, nargs="+", default=[0.0, 1.0, 2.0, 5.0], help="turns applied, deg")
    args = ap.parse_args(argv)
    from graphnav.missions import load_akit
    for folder in akit_trajectories(None):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = load_akit(folder)
        ref, t, lever = mission_reference(m), m.dvl.t, m.config.dvl.lever_arm_b
        for length in [0.0] + args.pieces:
            starts = [t[0]] if not length else np.arange(t[0], t[-1] - length + 1e-9, length)
            for turn in args.turns:
                v = m.dvl.v_b @ ds.turn_about_z(turn).T
                fits = []
                for start in starts:
                    k = (t >= start) & (t < start + length) if length else np.ones(len(t), bool)
                    fits.append(ds.turn_against_reference(ref, t[k], v[k], lever))
                yaw, sigma, _ = (np.degrees(x) for x in np.array(fits).T)
                warned = (np.abs(yaw) > np.degrees(ds.GT_MIN_YAW_RAD)) & (np.abs(yaw) > ds.YAW_SIGMAS * sigma)
                print(f"{folder.name:13s} {length:4.0f} s turn {turn:3g}: yaw {yaw.min():+6.2f}..{yaw.max():+6.2f}, "
                      f"sigma {sigma.min():.2f}..{sigma.max():.2f} deg, |yaw - turn| / sigma <= "
                      f"{np.max(np.abs(yaw - turn) / sigma):4.1f}; warned {warned.sum()} of {len(fits)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
