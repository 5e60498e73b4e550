"""VRMSE with a velocity-only DVL against the same DVL's four beams, per estimator (prints a Markdown table).

    .venv/bin/python experiments/velocity_only.py [--seeds 1 2 3] [--duration 300] [--akit 1 2 ...]
                                              [--methods Graph-TC Graph-TC-batch TC LC]

For each mission the estimators run three times: on the four beams (tightly coupled), on the velocity a
velocity-only DVL would report for the same pings (:func:`graphnav.core.dvl.as_velocity_only`: its own
least-squares solution of those beams in the DVL frame, fed as ``dvl_velocity`` samples through the DVL
velocity model), and -- on the simulated missions, whose DVL is mounted at 45 deg yaw to the body -- on that
velocity given in body axes while labelled as the DVL frame (a frame mistake the estimators cannot see).
VRMSE (m/s) over the whole mission against the ground truth; ratio = velocity-only / all beams.
"""
from __future__ import annotations

import argparse
import dataclasses
import time
import warnings

import gtsam
import numpy as np

from graphnav.core.config import SensorConfig
from graphnav.core.dvl import as_velocity_only
from graphnav.evaluation.methods import check_method, get_method, run_method
from graphnav.evaluation.metrics import vrmse
from graphnav.sim.simulate import simulate_mission


def variants(mission, wrong_frame: bool) -> dict:
    velocity = dataclasses.replace(mission, dvl=as_velocity_only(mission.dvl, mission.config.dvl))
    out = {"beams": mission, "velocity": velocity}
    if wrong_frame:
        v_body = velocity.dvl.v_d @ mission.config.dvl.C_d_b.T
        out["wrong frame"] = dataclasses.replace(velocity, dvl=dataclasses.replace(velocity.dvl, v_d=v_body))
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="*", default=[1, 2, 3])
    parser.add_argument("--duration", type=float, default=300.0)
    parser.add_argument("--akit", type=int, nargs="*", default=[])
    parser.add_argument("--methods", nargs="*", default=["Graph-TC", "Graph-TC-batch", "TC", "LC"],
                        help="method names of graphnav.evaluation.methods (the bench's)")
    parser.add_argument("--no-dvl-error-states", action="store_true",
                        help="graph methods without the DVL error states (GraphOptions.dvl_error_states=False)")
    parser.add_argument("--data", help="A-KIT folder for --akit (default: the shared data, graphnav.io.paths)")
    args = parser.parse_args(argv)
    for method in args.methods:
        check_method(method)
    missions = []
    config = SensorConfig()
    config.dvl.C_d_b = gtsam.Rot3.Yaw(np.deg2rad(45.0)).matrix()
    for seed in args.seeds:
        missions.append((f"sim seed {seed}", simulate_mission(args.duration, seed=seed, config=config), True))
    if args.akit:
        from graphnav.io.paths import akit_trajectories
        from graphnav.missions import load_akit
        for n, folder in zip(args.akit, akit_trajectories(args.data, names=args.akit)):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                missions.append((f"A-KIT {n}", load_akit(folder), False))
    print("| mission | method | all beams | velocity-only | ratio | velocity in body axes (wrong frame) | s |")
    print("|---|---|---|---|---|---|---|")
    for label, mission, wrong in missions:
        for method in args.methods:
            start = time.perf_counter()
            r = {}
            for name, m in variants(mission, wrong).items():
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    options = ({"dvl_error_states": False}
                               if args.no_dvl_error_states and get_method(method).family == "graph" else None)
                    r[name] = vrmse(run_method(m, method, options=options), mission.gt)
            w = f"{r['wrong frame']:.4f}" if "wrong frame" in r else "-"
            print(f"| {label} | {method} | {r['beams']:.4f} | {r['velocity']:.4f} | {r['velocity'] / r['beams']:.3f} "
                  f"| {w} | {time.perf_counter() - start:.0f} |", flush=True)


if __name__ == "__main__":
    main()
