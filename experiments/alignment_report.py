"""In-motion alignment from the sensors on the shared A-KIT trajectories (docs/decisions/alignment.md).

For each trajectory the IMU and DVL samples (and nothing else: the A-KIT depth stream is GT-derived) are fed
in time order to :class:`graphnav.estimators.align.Aligner`; the ground truth is only used to score.

Table 1: heading / roll / pitch error of the alignment against the GT (at the IMU point) for several
alignment durations, with the predicted heading 1-sigma.
Table 2 (``--graph``): mission VRMSE of Graph-TC started at the end of the alignment from the aligned state
(its covariance as the prior, no depth sensor: the A-KIT depth stream is GT-derived) versus started there from
the GT; and over the whole mission from the alignment carried back to the first sample
(``Aligner.result_at``, what an offline smoother can do) versus from the GT.

    .venv/bin/python experiments/alignment_report.py                       # table 1 (~1 min)
    nice -n 10 .venv/bin/python experiments/alignment_report.py --graph    # + table 2 (~6 min on 2 cores)
"""
from __future__ import annotations

import argparse
import dataclasses
import time
import warnings

import gtsam
import numpy as np

from graphnav.core.rotations import C_b_n_to_euler
from graphnav.estimators.align import AlignOptions, align_mission
from graphnav.estimators.graph import InitialState
from graphnav.estimators.graph.options import GraphOptions
from graphnav.estimators.options import PriorOptions
from graphnav.estimators.replay import first_ping_time
from graphnav.estimators.runs import run_graph
from graphnav.evaluation.metrics import vrmse
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_akit


def wrap_deg(x):
    return (np.asarray(x) + 180.0) % 360.0 - 180.0


def alignment_errors(mission, alignment):
    """(roll, pitch, heading) error in deg of the alignment against the GT at its stamp.

    The 1 Hz GT attitude is taken at the alignment stamp as the graph's GT initialisation does it (nearest GT
    sample rotated with the gyro): a slerp between GT samples misses the roll of wave motion by degrees.
    """
    C_true = InitialState.from_ground_truth(mission, alignment.t).pose.rotation().matrix()
    return wrap_deg(np.degrees(C_b_n_to_euler(alignment.C_b_n) - C_b_n_to_euler(C_true)))


def graph_options(alignment) -> GraphOptions:
    """Graph priors from the alignment's covariance: GraphOptions takes one isotropic sigma per block, so the
    largest 1-sigma of each (the heading's, for the attitude) is used."""
    def largest(cov):
        return float(np.sqrt(np.linalg.eigvalsh(cov)[-1]))
    return GraphOptions(priors=PriorOptions(attitude_sigma=largest(alignment.cov_rot),
                                            velocity_sigma=largest(alignment.cov_v_n),
                                            position_sigma=largest(alignment.cov_p_n)))


def initial_state(alignment) -> InitialState:
    return InitialState(gtsam.Pose3(gtsam.Rot3(alignment.C_b_n), alignment.p_n), alignment.v_n,
                        gtsam.imuBias.ConstantBias(alignment.bias_acc, alignment.bias_gyro))


def first_keyframe(mission) -> float:
    """Stamp of the graph's first keyframe (where run_graph's initial state applies), s."""
    return first_ping_time(mission)


def streaming_runs(mission, options, label):
    """Graph-TC started where the aligner (IMU + DVL only) became ready, from the alignment and from the GT,
    both without depth, scored after max(60 s, t_align): {label aligned: vrmse, label GT: vrmse}, t_align,
    heading error (deg)."""
    ready = align_mission(mission, options, use_depth=False)
    # the graph's first keyframe is the first DVL ping at or after its start: the alignment is taken there
    # (the aligner also sees the samples up to that ping)
    part = dataclasses.replace(mission.slice(ready.t, mission.t1), depth=None)
    t_k = first_keyframe(part)
    a = align_mission(mission, options, use_depth=False, t_end=t_k + 1.5 / mission.config.imu_rate_hz,
                      t_result=t_k)
    t_score = max(60.0, a.t)
    out = {}
    sol = run_graph(part, initial=initial_state(a), options=graph_options(a))
    out[f"{label} aligned"] = vrmse(sol, mission.gt, t_score)
    # the same aligned state with GraphOptions' default (tight, 0.05 deg) attitude prior: what a prior with the
    # alignment's tilt sigma (~0.01 deg) would do, which GraphOptions' single isotropic sigma cannot express
    sol = run_graph(part, initial=initial_state(a))
    out[f"{label} al.tight"] = vrmse(sol, mission.gt, t_score)
    sol = run_graph(part)
    out[f"{label} GT"] = vrmse(sol, mission.gt, t_score)
    return out, a.t, alignment_errors(mission, a)[2]


def offline_runs(mission, options, label):
    """Graph-TC over the whole mission (no depth) from the alignment carried back to the first keyframe
    (``t_result``) and from the GT there, scored after 60 s; plus the usual GT run with the GT depth."""
    whole = dataclasses.replace(mission, depth=None)
    start = align_mission(mission, options, use_depth=False, t_result=first_keyframe(mission))
    out = {}
    sol = run_graph(whole, initial=initial_state(start), options=graph_options(start))
    out[f"{label} aligned"] = vrmse(sol, mission.gt, 60.0)
    out["t0 GT"] = vrmse(run_graph(whole), mission.gt, 60.0)
    out["t0 GT+GT depth"] = vrmse(run_graph(mission), mission.gt, 60.0)
    return out, alignment_errors(mission, start)[2]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default=None, help="A-KIT root (default: the shared data)")
    parser.add_argument("--durations", default="10,30,60,120,180,240,300", help="alignment durations, s")
    parser.add_argument("--graph", action="store_true", help="also run Graph-TC from the alignment (table 2)")
    parser.add_argument("--graph-durations", default="120,180,240", help="alignment durations for table 2, s")
    parser.add_argument("--offline-duration", type=float, default=300.0,
                        help="alignment duration of the offline (carried back) run, s")
    parser.add_argument("--no-accel-bias", action="store_true", help="AlignOptions(estimate_accel_bias=False)")
    args = parser.parse_args(argv)
    folders = akit_trajectories(args.data)
    durations = [float(x) for x in args.durations.split(",")]
    graph_durations = [float(x) for x in args.graph_durations.split(",")]
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
            start = time.process_time()
            a = align_mission(m, AlignOptions(duration_s=d, max_window_s=max(600.0, d),
                                                 estimate_accel_bias=not args.no_accel_bias), use_depth=False)
            cpu = time.process_time() - start
            e = alignment_errors(m, a)
            rows[d].append((e, np.degrees(a.info["heading_sigma_rad"]), cpu, a.t))
            cells.append(f"{e[0]:+7.3f} {e[1]:+7.3f} {e[2]:+8.3f} ({np.degrees(a.info['heading_sigma_rad']):6.3f})")
        print(f"{m.name[10:]:>6} " + " ".join(f"{c:>40}" for c in cells))
    print(f"{'RMS':>6} " + " ".join(
        f"{'%7.3f %7.3f %8.3f (%6.3f)' % (*np.sqrt(np.mean([r[0] ** 2 for r in rows[d]], axis=0)), np.sqrt(np.mean([r[1] ** 2 for r in rows[d]]))):>40}"
        for d in durations))
    print(f"{'cpu s':>6} " + " ".join(f"{np.mean([r[2] for r in rows[d]]):>40.3f}" for d in durations))

    if not args.graph:
        return 0
    print("\nTable 2: Graph-TC VRMSE (m/s), IMU + DVL only (no depth stream: the A-KIT one is GT-derived).")
    print("Streaming 'T=..': started where the aligner with that duration is ready, from the alignment or from the")
    print("GT there, scored after max(60 s, t_align). Offline: whole mission from the alignment carried back to the")
    print(f"first keyframe (duration {args.offline_duration:g} s) or from the GT, scored after 60 s. 'aligned': prior")
    print("sigmas from the alignment's covariance (largest eigenvalue per block, GraphOptions is isotropic);")
    print("'al.tight': the aligned state with GraphOptions' default priors (attitude 0.05 deg). 'head err deg': heading")
    print("error of each alignment (streaming durations, then offline).")
    keys, rows = None, []
    for m in missions:
        res, cells = {}, []
        for d in graph_durations:
            opts = AlignOptions(duration_s=d, estimate_accel_bias=not args.no_accel_bias)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                r, t_a, head = streaming_runs(m, opts, f"T={d:g}")
            res.update(r)
            cells.append(f"{head:+.2f}")
        opts = AlignOptions(duration_s=args.offline_duration, max_window_s=max(600.0, args.offline_duration),
                            estimate_accel_bias=not args.no_accel_bias)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            r, head = offline_runs(m, opts, f"offline {args.offline_duration:g}")
        res.update(r)
        cells.append(f"{head:+.2f}")
        if keys is None:
            keys = list(res)
            print(f"{'traj':>6} {'head err deg':>24} " + " ".join(f"{k:>17}" for k in keys), flush=True)
        rows.append(res)
        print(f"{m.name[10:]:>6} {'/'.join(cells):>24} " + " ".join(f"{res[k]:17.4f}" for k in keys), flush=True)
    print(f"{'mean':>6} {'':>24} " + " ".join(f"{np.mean([r[k] for r in rows]):17.4f}" for k in keys))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
