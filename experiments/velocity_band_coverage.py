"""How often the velocity NEES of simulated missions falls inside its printed 95 % band (nothing fitted).

The simulator makes the IMU and DVL errors the estimators model, so a consistent estimator's mission NEES should
fall inside its 95 % chi-square band on about 95 % of the missions. Per seed (the simulated default mission, 400 s)
and method (Graph-TC, Graph-TC-batch, TC; all beams): the mission velocity NEES after 60 s, its split along the
body axes (:func:`graphnav.evaluation.consistency.body_axis_nees`: 1 each when consistent), the decorrelation time
of the normalised velocity error (:func:`graphnav.evaluation.consistency.decorrelation_time`), and whether the NEES
is inside the band counted with one independent epoch per that time (what the commands print) and per 10 s.

The simulator's DVL errors are the paper's, the same in every seed: every beam 0.01 m/s of bias (a vertical
velocity error only, which the depth observes) and 0.7 % of scale on every axis; the estimators' priors take them
as independent draws of those sigmas. ``--drawn-dvl-errors`` draws them per seed from those priors instead
(``simulate_mission(dvl_errors="drawn")``; the estimators keep the paper's sigmas), as a consistency check needs.
``--graph NAME=VALUE`` sets a :class:`graphnav.estimators.graph.GraphOptions` field for the graph methods (e.g.
``integration_sigma=1e-3``).

    .venv/bin/python experiments/velocity_band_coverage.py --seeds 16 --jobs 2
    .venv/bin/python experiments/velocity_band_coverage.py --seeds 16 --jobs 2 --drawn-dvl-errors
"""
from __future__ import annotations

import argparse
import functools
import sys
import warnings

import numpy as np

from graphnav.commands.common import name_value_pairs
from graphnav.core.errors import ConfigError
from graphnav.evaluation.crossval import STUDY_METHODS, mean_range
from graphnav.evaluation.tasks import run_tasks


def one_seed(seed: int, drawn: bool = False, graph: dict | None = None) -> list[dict]:
    from graphnav.evaluation.consistency import chi2_band, mission_nees, n_independent
    from graphnav.evaluation.methods import GRAPH_METHODS, run_method
    from graphnav.missions import simulated_mission
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mission = simulated_mission(seed=seed, dvl_errors="drawn" if drawn else "spec")
        rows = []
        for method in STUDY_METHODS:
            options = dict(graph or {}) if method in GRAPH_METHODS else None
            sol = run_method(mission, method, "none", options=options)
            s = mission_nees(sol, mission)
            n_10s = n_independent(sol.t[sol.t >= s["nees_t0"]])
            lo, hi = chi2_band(s["nees_n_independent"])
            lo_10s, hi_10s = chi2_band(n_10s)
            rows.append({"seed": seed, "method": method, "nees": s["nees_mission"], "axes": s["nees_axes_b"],
                         "tau_s": s["nees_decorrelation_s"], "inside": bool(lo <= s["nees_mission"] <= hi),
                         "inside_10s": bool(lo_10s <= s["nees_mission"] <= hi_10s)})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=16, help="simulated missions (seeds 0..N-1)")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (graphnav.evaluation.tasks)")
    ap.add_argument("--drawn-dvl-errors", action="store_true",
                    help="draw each seed's DVL beam biases and scale factors from the estimators' priors")
    ap.add_argument("--graph", nargs="*", default=[], metavar="NAME=VALUE",
                    help="GraphOptions values of the graph methods (e.g. integration_sigma=1e-3)")
    a = ap.parse_args(argv)
    try:
        graph = name_value_pairs(a.graph)
    except ConfigError as exc:
        ap.error(f"--graph: {exc}")
    rows: list[dict] = []
    task = functools.partial(one_seed, drawn=a.drawn_dvl_errors, graph=graph)
    run_tasks(task, list(range(a.seeds)), rows.extend, jobs=a.jobs)
    errors = "drawn per seed" if a.drawn_dvl_errors else "the paper's, every seed"
    print(f"DVL errors: {errors}; graph options: {graph or 'defaults'}\n")
    print("| method | mission NEES: mean (range) | per body axis (1 each): forward, starboard, down | decorrelation "
          "time, s: median (range) | inside the band: per decorrelation time | per 10 s |")
    print("| --- | --- | --- | --- | --- | --- |")
    for method in STUDY_METHODS:
        sel = [r for r in rows if r["method"] == method]
        tau = np.array([r["tau_s"] for r in sel])
        axes = np.mean([r["axes"] for r in sel], axis=0)
        print(f"| {method} | {mean_range([r['nees'] for r in sel])} | {axes[0]:.2f}, {axes[1]:.2f}, "
              f"{axes[2]:.2f} | {np.median(tau):.0f} ({tau.min():.0f}-{tau.max():.0f}) | "
              f"{sum(r['inside'] for r in sel)} of {len(sel)} | {sum(r['inside_10s'] for r in sel)} of {len(sel)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
