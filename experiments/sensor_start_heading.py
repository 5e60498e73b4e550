"""Runs started from the sensors: the heading error against the heading sigma they claim, through the alignment
window and after it (docs/decisions/alignment.md, "The alignment's data counted once").

Each simulated mission (``--dvl-errors drawn``: the beams' bias and scale factor drawn per seed) or A-KIT
trajectory (``--akit``, GT heading from the Phins) runs with ``init="sensors"`` through the chosen estimator;
the epochs before the alignment completed (``info["alignment"]["completed_t"]``) are the window, the rest is
"after". Printed per part, pooled over the runs: heading error RMS, claimed heading sigma (RMS of the
heading variance of ``cov_rot_b``), heading NEES (mean error^2 / mean variance), VRMSE and velocity NEES.

Usage: ``.venv/bin/python experiments/sensor_start_heading.py --method fixed-lag --seeds 0-9 --duration 700
[--grade navigation] [--akit 1 3 10] [--no-catch-up] [--ekf-heading-factor 10] [--jobs 2]``
"""
from __future__ import annotations

import argparse
import warnings

import numpy as np

from graphnav.core.rotations import heading_variance
from graphnav.evaluation import metrics
from graphnav.evaluation.tasks import run_tasks

ESTIMATORS = ("fixed-lag", "isam2", "batch", "ekf")


def _seeds(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b or a) + 1))


def _run(item: tuple) -> dict:
    """One run; sums per part: [heading error^2, heading variance, epochs, velocity error^2, velocity NEES]."""
    from graphnav.estimators.navigator import NavigatorOptions
    from graphnav.estimators.runs import run_ekf, run_graph
    from graphnav.missions import load_akit
    from graphnav.sim.simulate import simulate_mission
    from graphnav.estimators.ekf import EkfOptions
    kind, key, method, duration, grade, catch_up, heading_factor = item
    nav = NavigatorOptions(align_catch_up=catch_up)
    ekf = EkfOptions() if heading_factor is None else \
        EkfOptions(catch_up_heading_sigma_factor=None if heading_factor == 0 else heading_factor)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mission = (load_akit(key) if kind == "akit" else
                   simulate_mission(duration_s=duration, imu_grade=grade, seed=key, dvl_errors="drawn"))
        sol = (run_ekf(mission, init="sensors", options=ekf, navigator_options=nav) if method == "ekf" else
               run_graph(mission, init="sensors", backend="fixed-lag" if method == "fixed-lag" else "isam2",
                         batch=method == "batch", navigator_options=nav))
    t_ready = sol.info["alignment"]["completed_t"]
    out = {"name": f"{kind} {key}"}
    for part, (a, b) in (("window", (None, t_ready)), ("after", (t_ready, None))):
        if part == "window" and sol.t[0] >= t_ready:     # started where the alignment ended: no window
            out[part] = np.zeros(5)
            continue
        _, d_psi = metrics.heading_errors(sol, mission.gt, a, b)
        aligned, sel = metrics._window(sol, mission.gt, a, b)
        var = heading_variance(sol.C_b_n[aligned.mask][sel], sol.cov_rot_b[aligned.mask][sel])
        dv = sol.v_n[aligned.mask][sel] - aligned.v_true_n[sel]
        out[part] = np.array([np.sum(d_psi ** 2), np.sum(var), len(d_psi), np.sum(dv ** 2),
                              np.sum(metrics.nees_velocity(sol, mission.gt, a, b))])
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--method", choices=ESTIMATORS, default="fixed-lag")
    ap.add_argument("--seeds", default="0-9", help="simulated seeds, e.g. 0-9 or 14")
    ap.add_argument("--duration", type=float, default=700.0, help="simulated mission length, s")
    ap.add_argument("--grade", default="navigation", help="simulated IMU grade")
    ap.add_argument("--akit", nargs="*", default=None, help="A-KIT trajectory numbers instead of simulated seeds")
    ap.add_argument("--data", default=None, help="the A-KIT folder (default: graphnav.io.paths)")
    ap.add_argument("--no-catch-up", action="store_true",
                    help="NavigatorOptions(align_catch_up=False): the estimator starts where the alignment ends")
    ap.add_argument("--ekf-heading-factor", type=float, default=None,
                    help="EkfOptions.catch_up_heading_sigma_factor (default: the EKF's; 0: none, the unaligned sigma)")
    ap.add_argument("--jobs", type=int, default=1)
    a = ap.parse_args(argv)
    factor = a.ekf_heading_factor
    if a.akit is not None:
        from graphnav.io.paths import akit_trajectories
        items = [("akit", str(p), a.method, 0.0, "", not a.no_catch_up, factor)
                 for p in akit_trajectories(a.data, a.akit or None)]
    else:
        items = [("sim", s, a.method, a.duration, a.grade, not a.no_catch_up, factor) for s in _seeds(a.seeds)]
    results = []
    run_tasks(_run, items, results.append, jobs=a.jobs)
    for part in ("window", "after"):
        e2, var, n, dv2, nees_v = np.sum([r[part] for r in results], axis=0)
        if not n:
            continue
        print(f"{a.method} {part:6s} ({len(results)} runs, {int(n)} epochs): heading error "
              f"{np.degrees(np.sqrt(e2 / n)):.3f} deg, claimed {np.degrees(np.sqrt(var / n)):.3f} deg, heading NEES "
              f"{e2 / var:.2f}, VRMSE {np.sqrt(dv2 / n):.4f} m/s, velocity NEES {nees_v / n:.2f}")


if __name__ == "__main__":
    main()
