"""In-motion alignment from the sensors on the shared A-KIT trajectories (issue 11, item 2).

For each trajectory the IMU and DVL samples (and nothing else: the A-KIT depth stream is GT-derived) are fed
in time order to :class:`graphnav.align.Aligner`; the ground truth is only used to score.

Table 1: heading / roll / pitch error of the alignment against the GT (at the IMU point) for several
alignment durations, with the predicted heading 1-sigma.
Table 2 (``--graph``): mission VRMSE of Graph-TC started at the end of the alignment from the aligned state
(its covariance as the prior, no depth sensor) versus started from the GT, and the GT-initialised run over the
whole mission, all scored after ``max(60 s, t_align)``.

    .venv/bin/python scripts/alignment_report.py                       # table 1 (~1 min)
    nice -n 10 .venv/bin/python scripts/alignment_report.py --graph    # + table 2 (~10 min on 2 cores)
"""
from __future__ import annotations

import argparse
import dataclasses
import time
import warnings

import gtsam
import numpy as np

from graphnav.align import AlignOptions, align_mission
from graphnav.graph import InitialState, run_graph
from graphnav.graph.options import GraphOptions
from graphnav.loaders import list_akit, load_akit
from graphnav.metrics import vrmse
from graphnav.paths import akit_dir
from graphnav.rotations import C_b_n_to_euler


def wrap_deg(x):
    return (np.asarray(x) + 180.0) % 360.0 - 180.0


def alignment_errors(mission, alignment):
    """(roll, pitch, heading) error in deg of the alignment against the GT at its stamp.

    The 1 Hz GT attitude is taken at the alignment stamp as the graph's GT initialisation does it (nearest GT
    sample rotated with the gyro): a slerp between GT samples misses the roll of wave motion by degrees.
    """
    C_true = InitialState.from_ground_truth(mission, alignment.t).pose.rotation().matrix()
    return wrap_deg(np.degrees(C_b_n_to_euler(alignment.C_b_n) - C_b_n_to_euler(C_true)))


def graph_runs(mission, alignment, t_score):
    """VRMSE (m/s) of Graph-TC from the aligned state vs from the GT, both started at the alignment stamp."""
    t_a, end = alignment.t, mission.t1
    part = mission.slice(t_a, end)
    no_depth = dataclasses.replace(part, depth=None)
    prior = GraphOptions(prior_rot_sigma=float(np.sqrt(np.linalg.eigvalsh(alignment.cov_rot)[-1])),
                         prior_vel_sigma=float(np.sqrt(np.linalg.eigvalsh(alignment.cov_v_n)[-1])),
                         prior_pos_sigma=float(np.sqrt(np.linalg.eigvalsh(alignment.cov_p_n)[-1])))
    initial = InitialState(gtsam.Pose3(gtsam.Rot3(alignment.C_b_n), alignment.p_n), alignment.v_n,
                           gtsam.imuBias.ConstantBias(alignment.bias_acc, alignment.bias_gyro))
    out = {}
    sol = run_graph(no_depth, "Graph-TC", initial=initial, options=prior)
    out["aligned, no depth"] = vrmse(sol, mission.gt, t_score)
    sol = run_graph(no_depth, "Graph-TC")
    out["GT at t_align, no depth"] = vrmse(sol, mission.gt, t_score)
    sol = run_graph(part, "Graph-TC")
    out["GT at t_align, GT depth"] = vrmse(sol, mission.gt, t_score)
    sol = run_graph(mission, "Graph-TC")
    out["GT at t0, GT depth"] = vrmse(sol, mission.gt, t_score)
    out["GT at t0, GT depth, after 60 s"] = vrmse(sol, mission.gt, 60.0)
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default=None, help="A-KIT root (default: the shared data)")
    parser.add_argument("--durations", default="10,30,60,120,180", help="alignment durations, s")
    parser.add_argument("--graph", action="store_true", help="also run Graph-TC from the alignment (table 2)")
    parser.add_argument("--no-accel-bias", action="store_true", help="AlignOptions(estimate_accel_bias=False)")
    args = parser.parse_args(argv)
    root = args.data or akit_dir()
    folders = list_akit(root) if root else []
    if not folders:
        raise SystemExit("no A-KIT trajectories found (set GRAPHNAV_DATA or --data)")
    durations = [float(x) for x in args.durations.split(",")]
    missions = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for f in folders:
            missions.append(load_akit(f))

    print("Table 1: alignment error against GT (deg) by alignment duration; sigma = predicted heading 1-sigma")
    print("(IMU + DVL only, no depth; Phins spec: gyro bias 0.01 deg/h, accel bias 50 ug; latitude from config)")
    head = f"{'traj':>6} " + " ".join(f"{'T=%gs roll/pitch/head (sig)' % d:>40}" for d in durations)
    print(head)
    rows = {d: [] for d in durations}
    for m in missions:
        cells = []
        for d in durations:
            start = time.perf_counter()
            a = align_mission(m, AlignOptions(duration_s=d, max_window_s=max(600.0, d),
                                                 estimate_accel_bias=not args.no_accel_bias), use_depth=False)
            cpu = time.perf_counter() - start
            e = alignment_errors(m, a)
            rows[d].append((e, np.degrees(a.info["heading_sigma_rad"]), cpu, a.t))
            cells.append(f"{e[0]:+7.3f} {e[1]:+7.3f} {e[2]:+8.3f} ({np.degrees(a.info['heading_sigma_rad']):6.3f})")
        print(f"{m.name[10:]:>6} " + " ".join(f"{c:>40}" for c in cells))
    print(f"{'RMS':>6} " + " ".join(
        f"{'%7.3f %7.3f %8.3f (%6.3f)' % (*np.sqrt(np.mean([r[0] ** 2 for r in rows[d]], axis=0)), np.sqrt(np.mean([r[1] ** 2 for r in rows[d]]))):>40}"
        for d in durations))
    print(f"{'cpu s':>6} " + " ".join(f"{np.mean([r[2] for r in rows[d]]):>40.3f}" for d in durations))

    if not args.graph:
        return
    opts = AlignOptions(estimate_accel_bias=not args.no_accel_bias)
    print(f"\nTable 2: Graph-TC VRMSE (m/s) after max(60 s, t_align); alignment with the default duration "
          f"{opts.duration_s:g} s, IMU + DVL only")
    keys = None
    for m in missions:
        a = align_mission(m, opts, use_depth=False)
        e = alignment_errors(m, a)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            res = graph_runs(m, a, max(60.0, a.t))
        if keys is None:
            keys = list(res)
            print(f"{'traj':>6} {'t_align':>8} {'head err':>9} " + " ".join(f"{k:>31}" for k in keys), flush=True)
        print(f"{m.name[10:]:>6} {a.t:8.2f} {e[2]:+9.3f} " + " ".join(f"{res[k]:31.4f}" for k in keys), flush=True)


if __name__ == "__main__":
    main()
