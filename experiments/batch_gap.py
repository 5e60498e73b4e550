"""Where the batch smoother's velocity NEES comes from, per trajectory (all beams).

For each trajectory of an A-KIT folder, runs Graph-TC and its batch smoother (one run: the batch's first pass is
Graph-TC) with the given GraphOptions / IMU noise scale and prints, against the IMU-carried reference
(:func:`graphnav.evaluation.consistency.scoring_reference`, epochs after 60 s):

- ``nees`` and ``+GT`` (the GT's own velocity error added to the covariance: how much of the NEES the reference
  explains);
- the NEES in turns (|yaw rate| > 3 deg/s) and elsewhere, and near the surface (depth < 3 m) and below;
- per body axis (forward, right, down): RMS error over RMS sigma (1 = consistent in that axis);
- the batch's and Graph-TC's median horizontal velocity sigma;
- the lever-arm error the errors point to: the regression of the body right / forward error on the yaw rate
  (``omega x dl``: right = ``omega_z dl_x``, forward = ``-omega_z dl_y``), m;
- the correlation time of the batch's normalised forward/right error (s, first lag below 1/e): a white error
  decorrelates within a ping; a long one is an error the model does not carry.

    .venv/bin/python experiments/batch_gap.py --data /work/shared/data/snapir-2022-akit
    .venv/bin/python experiments/batch_gap.py --data ... --graph dvl_bias_rw=1e-3 --imu-noise-scale 1.4
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings

import numpy as np

from graphnav.core.timeseries import interp_rows
from graphnav.evaluation.bench import find_trajectories, natural_key, prepared_mission
from graphnav.evaluation.consistency import NEES_SETTLE_S, scoring_reference
from graphnav.evaluation.crossval import run_methods, with_imu_noise_scale
from graphnav.evaluation.metrics import _window


def errors(sol, reference, t0):
    """(t, e_n (K,3), P (K,3,3), C_b_n (K,3,3)) of the epochs after t0 against ``reference``."""
    aligned, sel = _window(sol, reference, t0, None)
    m = aligned.mask
    e = sol.v_n[m][sel] - aligned.v_true_n[sel]
    return sol.t[m][sel], e, sol.cov_v_n[m][sel], sol.C_b_n[m][sel]


def nees_of(e, P, extra=None):
    if extra is not None:
        P = P + extra[None]
    return np.einsum("ki,ki->k", e, np.linalg.solve(P, e[..., None])[..., 0])


def correlation_time(x: np.ndarray, dt: float) -> float:
    x = x - x.mean()
    if x.std() == 0 or len(x) < 10:
        return float("nan")
    ac = np.correlate(x, x, "full")[len(x) - 1:] / (x.var() * len(x))
    below = np.flatnonzero(ac < np.exp(-1))
    return float(below[0] * dt) if below.size else float("inf")


def trajectory_report(source, graph: dict, scale: float) -> dict:
    mission = prepared_mission(source, "as-recorded")
    if scale != 1.0:
        mission = with_imu_noise_scale(mission, scale)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        sols = run_methods(mission, ("Graph-TC", "Graph-TC-batch"), "none", graph or None)
    t0 = mission.t0 + NEES_SETTLE_S
    gt_cov = np.diag(np.square(mission.meta.get("gt_velocity_sigma_n", (0.0, 0.0, 0.0))))
    out = {"trajectory": source.name, "time_offsets": mission.meta.get("time_offsets")}
    for name, sol in sols.items():
        ref = scoring_reference(sol, mission)
        t, e, P, C = errors(sol, ref, t0)
        nees = nees_of(e, P)
        # yaw rate of the reference and depth at the epochs
        yaw = np.unwrap(np.arctan2(ref.C_b_n[:, 1, 0], ref.C_b_n[:, 0, 0]))
        rate = np.abs(np.gradient(yaw, ref.t))
        turning = interp_rows(t, ref.t, rate[:, None])[:, 0] > np.deg2rad(3.0)
        depth = interp_rows(t, mission.gt.t, mission.gt.p_n[:, 2:3])[:, 0]
        surface = depth < 3.0
        e_b = np.einsum("kji,kj->ki", C, e)                     # C_b_n^T e: body axes
        P_b = np.einsum("kji,kjl,klm->kim", C, P, C)
        axis = np.sqrt(np.mean(e_b ** 2, axis=0) / np.mean(np.diagonal(P_b, axis1=1, axis2=2), axis=0))
        z = e_b / np.sqrt(np.diagonal(P_b, axis1=1, axis2=2))
        dt = float(np.median(np.diff(t)))
        # a lever-arm error dl gives the body velocity error omega x dl: right = omega_z dl_x, forward = -omega_z dl_y
        yaw_rate = interp_rows(t, ref.t, np.gradient(yaw, ref.t)[:, None])[:, 0]
        A = np.column_stack([yaw_rate, np.ones_like(yaw_rate)])
        slope_right = float(np.linalg.lstsq(A, e_b[:, 1], rcond=None)[0][0])
        slope_fwd = float(-np.linalg.lstsq(A, e_b[:, 0], rcond=None)[0][0])
        key = "batch" if name.endswith("batch") else "filter"
        out[key] = {
            "nees": float(nees.mean()), "nees_gt": float(nees_of(e, P, gt_cov).mean()),
            "nees_turns": float(nees[turning].mean()) if turning.any() else None,
            "nees_straight": float(nees[~turning].mean()),
            "turn_fraction": float(turning.mean()),
            "nees_surface": float(nees[surface].mean()) if surface.any() else None,
            "nees_submerged": float(nees[~surface].mean()) if (~surface).any() else None,
            "surface_fraction": float(surface.mean()),
            "err_over_sigma_fwd_right_down": axis.round(2).tolist(),
            "sigma_h_median": float(np.median(np.sqrt((P[:, 0, 0] + P[:, 1, 1]) / 2))),
            "corr_time_s_fwd_right": [correlation_time(z[:, 0], dt), correlation_time(z[:, 1], dt)],
            "lever_dx_dy_m": [slope_right, slope_fwd],
            "vrmse": float(np.sqrt(np.mean(np.sum(e ** 2, axis=1)))),
        }
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--graph", nargs="*", default=[], metavar="NAME=VALUE", help="GraphOptions fields")
    ap.add_argument("--imu-noise-scale", type=float, default=1.0)
    ap.add_argument("--json", help="write the per-trajectory numbers here")
    args = ap.parse_args(argv)
    graph = {k: float(v) for k, _, v in (g.partition("=") for g in args.graph)}
    rows = []
    for src in sorted(find_trajectories(args.data), key=lambda s: natural_key(s.name)):
        r = trajectory_report(src, graph, args.imu_noise_scale)
        rows.append(r)
        b, f = r["batch"], r["filter"]
        print(f"{r['trajectory']:13s} batch NEES {b['nees']:5.2f} (+GT {b['nees_gt']:5.2f}; turns "
              f"{b['nees_turns'] or float('nan'):5.2f} [{b['turn_fraction']:.0%}], straight {b['nees_straight']:5.2f};"
              f" surface {b['nees_surface'] or float('nan'):5.2f} [{b['surface_fraction']:.0%}]) "
              f"err/sigma f,r,d {b['err_over_sigma_fwd_right_down']} sigma_h {b['sigma_h_median']:.4f} "
              f"corr {b['corr_time_s_fwd_right'][0]:.0f},{b['corr_time_s_fwd_right'][1]:.0f} s "
              f"dl {b['lever_dx_dy_m'][0]:+.3f},{b['lever_dx_dy_m'][1]:+.3f} m | "
              f"filter NEES {f['nees']:5.2f} sigma_h {f['sigma_h_median']:.4f} "
              f"err/sigma {f['err_over_sigma_fwd_right_down']} "
              f"dl {f['lever_dx_dy_m'][0]:+.3f},{f['lever_dx_dy_m'][1]:+.3f} m", flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
