"""Measure the regressed-beam candidates (gate, correlation, adaptive sigma, motion prior; docs/decisions/regressed-beams.md).

Runs Graph-TC and Graph-HN with each candidate's GraphOptions over the same windows (the bench's windows,
scenarios and IMU grades) and prints window VRMSE mean / worst and the ratio to Graph-TC. Usage::

    nice -n 10 .venv/bin/python experiments/regressed_candidates.py --data ../shared/data/snapir-2022-akit \
        --trajectories Trajectory1 Trajectory5 --grades tactical --scenarios 3-missing --window-s 60
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from graphnav.evaluation.methods import MOTION_PRIOR_SETTINGS, REGRESSED_SCREENING

#: The hybrid without any screening or motion prior.
PLAIN = {"screening.gate_k": None, "screening.adaptive": False, "screening.correlation": 0.0, "motion_prior": "off"}
CANDIDATES: dict[str, tuple[str, dict]] = {
    "Graph-TC": ("Graph-TC", {}),
    "Graph-MP": ("Graph-MP", {}),
    "MP heave": ("Graph-MP", {"motion_prior_rw": None}),
    "MP rw x2": ("Graph-MP", {"motion_prior_rw": (0.1, 0.16, 0.06)}),
    "MP rw x4": ("Graph-MP", {"motion_prior_rw": (0.2, 0.32, 0.12)}),
    "MP heave0.2": ("Graph-MP", {"motion_prior_rw": None, "motion_prior_heave_sigma": 0.2}),
    "MP rw x4 heave0.2": ("Graph-MP", {"motion_prior_rw": (0.2, 0.32, 0.12), "motion_prior_heave_sigma": 0.2}),
    "MP rw x8 nohv": ("Graph-MP", {"motion_prior_rw": (0.4, 0.64, 0.24), "motion_prior_heave_sigma": None}),
    "HN plain": ("Graph-HN", {}),
    "HN gate3": ("Graph-HN", {"screening.gate_k": 3.0}),
    "HN adaptive": ("Graph-HN", {"screening.adaptive": True}),
    "HN adapt+gate3": ("Graph-HN", {"screening.adaptive": True, "screening.gate_k": 3.0}),
    "HN corr0.5": ("Graph-HN", {"screening.correlation": 0.5}),
    "HN corr0.9": ("Graph-HN", {"screening.correlation": 0.9}),
    "HN corr0.5+adapt": ("Graph-HN", {"screening.correlation": 0.5, "screening.adaptive": True}),
    "HN corr0.5+adapt a x4": ("Graph-HN", {"screening.correlation": 0.5, "screening.adaptive": True,
                                           "screening.prediction_var_scale": 4.0}),
    "HN corr0.5+adapt a x8": ("Graph-HN", {"screening.correlation": 0.5, "screening.adaptive": True,
                                           "screening.prediction_var_scale": 8.0}),
    "HN corr0.5+adapt MP-total": ("Graph-HN", {"screening.correlation": 0.5, "screening.adaptive": True,
                                               "motion_prior": "total", "motion_prior_rw": (0.2, 0.32, 0.12),
                                               "motion_prior_heave_sigma": 0.2}),
    **{f"HN MP-if-uncertain {std:g}": ("Graph-HN", {**REGRESSED_SCREENING, **MOTION_PRIOR_SETTINGS,
                                                     "motion_prior": "total-if-uncertain",
                                                     "motion_prior_switch_std": std})
       for std in (0.1, 0.15, 0.2, 0.3)},
    "HN-batch corr0.5+adapt": ("Graph-HN-batch", dict(REGRESSED_SCREENING)),
    "HN-batch MP-if-uncertain 0.2": ("Graph-HN-batch", {**REGRESSED_SCREENING, **MOTION_PRIOR_SETTINGS,
                                                        "motion_prior": "total-if-uncertain",
                                                        "motion_prior_switch_std": 0.2}),
    "HN +MP": ("Graph-HN", {"motion_prior": "partial"}),
    "HN MP-total": ("Graph-HN", {"motion_prior": "total"}),
    "HN adapt+MP": ("Graph-HN", {"screening.adaptive": True, "motion_prior": "partial"}),
    # the same screenings with the IMU-aware completer (Graph-HNI; "HNI corr0.5+adapt" is its default)
    "HNI plain": ("Graph-HNI", {}),
    "HNI adaptive": ("Graph-HNI", {"screening.adaptive": True}),
    "HNI corr0.5+adapt": ("Graph-HNI", {"screening.correlation": 0.5, "screening.adaptive": True}),
}


def run_one(args):
    source, grade, scenario, window_s, name = args
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation.bench import case_windows, prepared_mission, score_case
    from graphnav.evaluation.methods import run_method
    mission = prepared_mission(source, grade)
    starts = case_windows(mission, window_s)
    run = mission.with_outage(*[scenario_outage(scenario, s, window_s) for s in starts])
    method, options = CANDIDATES[name]
    if method.startswith("Graph-HN"):   # candidates are measured against the plain hybrid, not the defaults
        options = {**PLAIN, **options}
    sol = run_method(run, method, scenario, options=dict(options))
    dropped = sol.info.get("regressed_screening", {})
    kept = sol.info.get("regressed_beams", 0) - dropped.get("gated", 0) - dropped.get("decorrelated_out", 0)
    return (grade, scenario, window_s, name), ([r["vrmse_window"] for r in score_case(sol, mission, starts, window_s)],
                                               [kept, sol.info.get("regressed_beams", 0)])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--trajectories", nargs="+", default=None, help="trajectory folder names (default: all)")
    p.add_argument("--grades", nargs="+", default=["tactical"], help="IMU grades")
    p.add_argument("--scenarios", nargs="+", default=["3-missing"], help="beam-outage scenarios")
    p.add_argument("--window-s", nargs="+", type=float, default=[60.0], help="outage window lengths, s")
    p.add_argument("--candidates", nargs="+", default=list(CANDIDATES), choices=list(CANDIDATES),
                   metavar="NAME", help="candidates to run (default: all)")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (graphnav.evaluation.tasks)")
    a = p.parse_args(argv)
    from graphnav.evaluation.bench import find_trajectories
    from graphnav.evaluation.tasks import run_tasks
    from graphnav.io.paths import akit_trajectories
    folders = akit_trajectories(a.data, names=a.trajectories)
    sources = [s for s in find_trajectories(str(folders[0].parent)) if s.name in {f.name for f in folders}]
    tasks = [(s, g, sc, w, c) for s in sources for g in a.grades for sc in a.scenarios for w in a.window_s
             for c in a.candidates]
    results: dict = {}
    kept: dict = {}

    def collect(result) -> None:
        key, (vals, counts) = result
        results.setdefault(key, []).extend(vals)
        kept[key] = np.add(kept.get(key, 0), counts)
    run_tasks(run_one, tasks, collect, jobs=a.jobs)
    print(f"trajectories: {', '.join(s.name for s in sources)}")
    print("| grade | scenario | window s | candidate | VRMSE mean | worst | x Graph-TC | completed beams kept |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for g in a.grades:
        for sc in a.scenarios:
            for w in a.window_s:
                ref = results.get((g, sc, w, "Graph-TC"))
                for c in a.candidates:
                    v = results[(g, sc, w, c)]
                    ratio = f"{np.mean(v) / np.mean(ref):.2f}" if ref else "-"
                    k = kept[(g, sc, w, c)]
                    print(f"| {g} | {sc} | {w:g} | {c} | {np.mean(v):.3f} | {np.max(v):.3f} | {ratio} | "
                          f"{k[0]} / {k[1]} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
