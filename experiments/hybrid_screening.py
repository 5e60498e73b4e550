"""What the screening of completed beams (``EkfOptions.screening.correlation`` / ``.adaptive``, on for
the hybrid EKF methods) does on the bench's outage windows of the shared trajectories.

For each trajectory and scenario the paper-style windows (:func:`graphnav.core.scenarios.window_starts`, 30 s)
are cut out of one run; the table gives the mean window VRMSE (m/s) of TC, of the hybrid with the screening
(the default) and without it (the paper's hybrid: completions at the completer's sigma), and how many
completed beams the screening dropped, inflated or kept.

    nice -n 10 .venv/bin/python experiments/hybrid_screening.py --methods HNTC Average-TC
"""
from __future__ import annotations

import argparse
import warnings

import numpy as np

from graphnav.core.scenarios import scenario_outage, window_starts
from graphnav.evaluation.methods import run_method
from graphnav.evaluation.metrics import vrmse
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_mission

PLAIN = {"screening.correlation": 0.0, "screening.adaptive": False}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--trajectories", nargs="*", help="trajectory folder names (default: all)")
    p.add_argument("--methods", nargs="+", default=["HNTC"])
    p.add_argument("--scenarios", nargs="+", default=["2-missing", "3-missing"])
    p.add_argument("--window", type=float, default=30.0)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    args = p.parse_args(argv)
    warnings.simplefilter("ignore")
    folders = akit_trajectories(args.data, names=args.trajectories)
    print("| trajectory | scenario | TC | " + " | ".join(f"{m} screened | {m} plain | {m} dropped/inflated/kept"
                                                         for m in args.methods) + " |")
    print("| --- " * (3 + 3 * len(args.methods)) + "|")
    means = {}
    for folder in folders:
        mission = load_mission(folder)
        starts = window_starts(mission.t0, mission.t1, args.window)
        for sc in args.scenarios:
            run = mission.with_outage(*[scenario_outage(sc, s, args.window) for s in starts])

            def score(method, options=None):
                sol = run_method(run, method, sc, options=options)
                return float(np.mean([vrmse(sol, mission.gt, s, s + args.window) for s in starts])), sol
            row = [score("TC")[0]]
            cells = [f"{row[0]:.4f}"]
            for m in args.methods:
                screened, sol = score(m)
                plain, _ = score(m, PLAIN)
                st = sol.info["regressed_screening"]
                kept = st["offered"] - st["decorrelated_out"] - st["gated"]
                cells += [f"{screened:.4f}", f"{plain:.4f}", f"{st['decorrelated_out'] + st['gated']}/{st['inflated']}/{kept}"]
                row += [screened, plain]
            means.setdefault(sc, []).append(row)
            print(f"| {folder.name} | {sc} | " + " | ".join(cells) + " |", flush=True)
    for sc, rows in means.items():
        m = np.mean(rows, axis=0)
        print(f"| **mean** | {sc} | {m[0]:.4f} | " + " | ".join(f"{m[1 + 2 * i]:.4f} | {m[2 + 2 * i]:.4f} | "
                                                                for i in range(len(args.methods))) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
