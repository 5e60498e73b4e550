"""How often the velocity NEES of simulated missions falls inside its printed 95 % band (nothing fitted).

The simulator draws the IMU and DVL errors the estimators model, so a consistent estimator's mission NEES should
fall inside its 95 % chi-square band on about 95 % of the missions. Per seed (the simulated default mission, 400 s)
and method (Graph-TC, Graph-TC-batch, TC; all beams): the mission velocity NEES after 60 s, the decorrelation time
of the normalised velocity error (:func:`graphnav.evaluation.consistency.decorrelation_time`), and whether the NEES
is inside the band counted with one independent epoch per that time (what the commands print) and per 10 s.

    .venv/bin/python experiments/velocity_band_coverage.py --seeds 16 --jobs 2
"""
from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

from graphnav.evaluation.crossval import STUDY_METHODS
from graphnav.evaluation.tasks import run_tasks


def one_seed(seed: int) -> list[dict]:
    from graphnav.evaluation.consistency import chi2_band, mission_nees, n_independent
    from graphnav.evaluation.methods import run_method
    from graphnav.missions import simulated_mission
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mission = simulated_mission(seed=seed)
        rows = []
        for method in STUDY_METHODS:
            sol = run_method(mission, method, "none")
            s = mission_nees(sol, mission)
            n_10s = n_independent(sol.t[sol.t >= s["nees_t0"]])
            rows.append({"seed": seed, "method": method, "nees": s["nees_mission"], "tau_s": s["nees_decorrelation_s"],
                         "inside": bool(chi2_band(s["nees_n_independent"])[0] <= s["nees_mission"]
                                        <= chi2_band(s["nees_n_independent"])[1]),
                         "inside_10s": bool(chi2_band(n_10s)[0] <= s["nees_mission"] <= chi2_band(n_10s)[1])})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=16, help="simulated missions (seeds 0..N-1)")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (graphnav.evaluation.tasks)")
    a = ap.parse_args(argv)
    rows: list[dict] = []
    run_tasks(one_seed, list(range(a.seeds)), rows.extend, jobs=a.jobs)
    print("| method | mission NEES: mean (range) | decorrelation time, s: median (range) | inside the band: "
          "per decorrelation time | per 10 s |")
    print("| --- | --- | --- | --- | --- |")
    for method in STUDY_METHODS:
        sel = [r for r in rows if r["method"] == method]
        nees, tau = np.array([r["nees"] for r in sel]), np.array([r["tau_s"] for r in sel])
        print(f"| {method} | {nees.mean():.2f} ({nees.min():.2f}-{nees.max():.2f}) | {np.median(tau):.0f} "
              f"({tau.min():.0f}-{tau.max():.0f}) | {sum(r['inside'] for r in sel)} of {len(sel)} | "
              f"{sum(r['inside_10s'] for r in sel)} of {len(sel)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
