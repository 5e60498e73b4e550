"""Measure how a completion's error relates to the graph's own prediction of the same beam.

For every regressed beam the plain hybrid (Graph-HN without screening) offers, records the completion error
``e_c = y_c - y_true`` and the graph's prediction error ``e_p = y_p - y_true`` (``y_true`` from the ground-truth
velocity and attitude, lever-arm term included) with the prediction variance ``a`` and the completer's
``s_c^2``, and prints per grade and scenario: corr(e_c, e_p) (the rho of ``screening.correlation``), RMS of
both errors, and ``mean(e^2) / mean(sigma^2)`` for each (1 = the stated sigma is right). Usage::

    nice -n 10 .venv/bin/python experiments/regressed_correlation.py --data ../shared/data/snapir-2022-akit \
        --trajectories Trajectory1 Trajectory5 --grades tactical mems --scenarios 2-missing 3-missing 0-beams
"""
from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np


def collect(mission, scenario: str, window_s: float, completer=None) -> np.ndarray:
    """Rows (e_c, e_p, a, s_c^2) of every regressed beam of one run (``completer``: the hybrid's own when None)."""
    from graphnav.factors import predict_beams

    from graphnav.core.scenarios import scenario_outage
    from graphnav.core.timeseries import interp_rows
    from graphnav.estimators.graph import builder as builder_mod
    from graphnav.estimators.graph import incremental as inc_mod
    from graphnav.evaluation.bench import case_windows
    from graphnav.evaluation.methods import run_method
    starts = case_windows(mission, window_s)
    run = mission.with_outage(*[scenario_outage(scenario, s, window_s) for s in starts])
    gt, rows, state = mission.gt, [], {}
    orig_kf, orig_screen = inc_mod.keyframe_factors, builder_mod.screen_regressed

    def kf_hook(kf, *args, **kwargs):
        state["t"] = kf.t
        return orig_kf(kf, *args, **kwargs)

    def screen_hook(rows_b, y, sigma, C_b_n, omega_b, lever_arm_b, prediction, options):
        if prediction is not None:
            t = state["t"]
            i = int(np.argmin(np.abs(gt.t - t)))
            y_true = predict_beams(rows_b, gt.C_b_n[i], interp_rows(t, gt.t, gt.v_n), omega_b, np.zeros(3),
                                   lever_arm_b)
            y_p = predict_beams(rows_b, C_b_n, prediction.v_n, omega_b, prediction.gyro_bias, lever_arm_b)
            H = rows_b @ C_b_n.T
            a = np.einsum("mi,ij,mj->m", H, prediction.cov_v_n, H)
            rows.extend(zip(y - y_true, y_p - y_true, a, np.asarray(sigma) ** 2))
        return orig_screen(rows_b, y, sigma, C_b_n, omega_b, lever_arm_b, prediction, options)

    inc_mod.keyframe_factors, builder_mod.screen_regressed = kf_hook, screen_hook
    try:
        # a gate that never fires makes the graph compute its prediction without changing the plain hybrid
        run_method(run, "Graph-HN", scenario, completer=completer,
                   options={"screening.gate_k": 1e9, "screening.adaptive": False, "screening.correlation": 0.0,
                            "motion_prior": "off"})
    finally:
        inc_mod.keyframe_factors, builder_mod.screen_regressed = orig_kf, orig_screen
    return np.array(rows).reshape(-1, 4)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--trajectories", nargs="+", default=None, help="trajectory folder names (default: all)")
    p.add_argument("--grades", nargs="+", default=["tactical", "mems"], help="IMU grades")
    p.add_argument("--scenarios", nargs="+", default=["2-missing", "3-missing", "0-beams"], help="scenarios")
    p.add_argument("--window-s", type=float, default=60.0, help="outage window length, s")
    a = p.parse_args(argv)
    warnings.simplefilter("ignore")
    from graphnav.evaluation.bench import find_trajectories, prepared_mission
    from graphnav.io.paths import akit_trajectories
    folders = akit_trajectories(a.data, names=a.trajectories)
    sources = [s for s in find_trajectories(str(folders[0].parent)) if s.name in {f.name for f in folders}]
    print(f"trajectories: {', '.join(s.name for s in sources)}; {a.window_s:g} s windows")
    print("| grade | scenario | beams | corr(e_c, e_p) | RMS e_c | RMS e_p | e_c^2/s_c^2 | e_p^2/a |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for g in a.grades:
        for sc in a.scenarios:
            d = np.vstack([collect(prepared_mission(s, g), sc, a.window_s) for s in sources])
            ec, ep, var_p, var_c = d.T
            print(f"| {g} | {sc} | {len(d)} | {np.corrcoef(ec, ep)[0, 1]:.2f} | {np.sqrt(np.mean(ec ** 2)):.3f} | "
                  f"{np.sqrt(np.mean(ep ** 2)):.3f} | {np.mean(ec ** 2) / np.mean(var_c):.2f} | "
                  f"{np.mean(ep ** 2) / np.mean(var_p):.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
