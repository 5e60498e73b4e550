"""The DVL velocity's turn about z against the GT's body velocity, fitted jointly with a lever-arm correction
(:func:`graphnav.calibration.dvl_scale.turn_and_lever_against_reference`, the fit the A-KIT GT path warns by: a turn
beyond :data:`~graphnav.calibration.dvl_scale.GT_MIN_YAW_RAD` and 3 sigmas, a lever arm moved beyond
:data:`~graphnav.calibration.dvl_scale.GT_MIN_LEVER_M` and 3 sigmas) on the shared A-KIT trajectories, whole and in
pieces, as recorded, with the DVL velocity turned and with the lever arm the fit is given off.

    .venv/bin/python experiments/dvl_gt_yaw.py [--pieces 60 120] [--turns 0 1 2 5] [--lever-errors 0 1.86 -1.86]
                                               [--turn-alone]

Prints per trajectory, piece length (0: whole), turn and lever-arm error (m, along x): the yaws and sigmas (deg), how
many pieces have their turn warned, the largest lever-arm correction (m, any component) and how many pieces have
their lever arm warned. ``--turn-alone``: the turn fitted without the lever-arm correction
(:func:`~graphnav.calibration.dvl_scale.turn_against_reference`, as before it; no lever arm).
"""
from __future__ import annotations

import argparse
import warnings

import numpy as np

from graphnav.calibration import dvl_scale as ds
from graphnav.calibration.reference import mission_reference
from graphnav.io.paths import akit_trajectories


def fits(ref, t, v, lever, length, alone=False):
    """The joint fits of the pieces of ``length`` s (0: whole) of the DVL velocity ``v`` at stamps ``t`` (``alone``:
    the turn alone, NaN lever arms)."""
    starts = [t[0]] if not length else np.arange(t[0], t[-1] - length + 1e-9, length)
    out = []
    for start in starts:
        k = (t >= start) & (t < start + length) if length else np.ones(len(t), bool)
        out.append((ds.turn_against_reference(ref, t[k], v[k], lever), np.full(3, np.nan), np.full(3, np.nan))
                   if alone else ds.turn_and_lever_against_reference(ref, t[k], v[k], lever))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pieces", type=float, nargs="*", default=[60.0, 120.0],
                    help="piece lengths, s (none: whole only)")
    ap.add_argument("--turns", type=float, nargs="+", default=[0.0, 1.0, 2.0, 5.0], help="turns applied, deg")
    ap.add_argument("--lever-errors", type=float, nargs="+", default=[0.0], help="lever-arm errors along x, m")
    ap.add_argument("--turn-alone", action="store_true", help="fit the turn without the lever-arm correction")
    args = ap.parse_args(argv)
    from graphnav.missions import load_akit
    for folder in akit_trajectories(None):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = load_akit(folder)
        ref, t, lever = mission_reference(m), m.dvl.t, m.config.dvl.lever_arm_b
        for length in [0.0] + args.pieces:
            for turn in args.turns:
                for error in args.lever_errors:
                    found = fits(ref, t, m.dvl.v_b @ ds.turn_about_z(turn).T, lever + [error, 0.0, 0.0], length,
                                  args.turn_alone)
                    yaw, sigma, _ = (np.degrees(x) for x in np.array([f[0] for f in found]).T)
                    dl, dl_sigma = np.array([f[1] for f in found]), np.array([f[2] for f in found])
                    warned = (np.abs(yaw) > np.degrees(ds.GT_MIN_YAW_RAD)) & (np.abs(yaw) > ds.YAW_SIGMAS * sigma)
                    lever_warned = np.any((np.abs(dl) > ds.GT_MIN_LEVER_M) & (np.abs(dl) > ds.YAW_SIGMAS * dl_sigma), 1)
                    print(f"{folder.name:13s} {length:4.0f} s turn {turn:3g} lever {error:+5.2f} m: yaw "
                          f"{yaw.min():+6.2f}..{yaw.max():+6.2f}, sigma {sigma.min():.2f}..{sigma.max():.2f} deg, "
                          f"|yaw - turn| / sigma <= {np.max(np.abs(yaw - turn) / sigma):4.1f}; warned {warned.sum()} "
                          f"of {len(found)}; |dl| <= {np.max(np.abs(dl)):.2f} m, |dl| / sigma <= "
                          f"{np.max(np.abs(dl) / dl_sigma):4.1f}; lever warned {lever_warned.sum()}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
