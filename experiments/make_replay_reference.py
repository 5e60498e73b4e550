"""Regenerate ``tests/data/replay_reference.npz`` (the frozen solutions ``tests/test_navigator.py`` compares the
sample-by-sample replay with) after a deliberate change of the estimators' results, and print how far every
stored solution moved.

    .venv/bin/python experiments/make_replay_reference.py            # rewrite the file, print the changes
    .venv/bin/python experiments/make_replay_reference.py --dry-run  # print the changes only

History: written from the whole-mission estimators before the Navigator; regenerated when every estimator took the gyro rate at the ping from :func:`graphnav.estimators.keyframes.gyro_at`
(interpolation between IMU interval centres; the graph used the nearest sample, the EKF interpolated between
sample stamps); regenerated again for the Earth model (position-dependent gravity in the simulator and every
estimator, sample axes frozen in inertial space, GTSAM's centrifugal term undone): the stored velocities moved
by up to 1.3e-4 m/s, positions by 1e-2 m. The initial states (``initial/*``) are kept as stored, so that the comparison keeps isolating
the streaming code path; every solution key (``tag/method/backend/{t,v_n,p_n,cov_v_n}``) is recomputed on the
same missions as the test's (``simulate_mission(200 s, seed 3)``: clean, a 3-missing 30 s outage at 80 s, a
DVL gap 100-109.5 s). Refreshed with ``--only fixed-lag`` for one DVL factor per ping (all its beams, a per-row
Huber kernel, instead of one factor per beam): the fixed-lag Graph-TC velocities moved by up to 1.6e-7 m/s
(positions 3.2e-6 m). The cost function is the same (with ``wildfire_threshold=0`` the two graphs agree to
3e-14 m/s, ``tests/test_speed_paths.py``); the change comes from ISAM2's partial back-substitution (wildfire
threshold 0.01), which skips cliques whose update is small and so depends on the Bayes tree's cliques, which
the factor structure changes (``docs/decisions/speed.md``); ``--only gap/Graph-TC/online`` for its positions
(2.1e-9 m: rounding of the fused beam-model pass).
"""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import gtsam
import numpy as np
from graphnav.nets import AverageCompleter

from graphnav.core.scenarios import scenario_outage
from graphnav.estimators.ekf import EkfOptions
from graphnav.estimators.graph import InitialState
from graphnav.estimators.runs import run_ekf, run_graph
from graphnav.evaluation.methods import METHODS
from graphnav.sim.simulate import simulate_mission

REFERENCE = Path(__file__).resolve().parent.parent / "tests" / "data" / "replay_reference.npz"


def missions() -> dict:
    m = simulate_mission(duration_s=200.0, seed=3)
    gap = dataclasses.replace(m, dvl=m.dvl.take((m.dvl.t < 100.0) | (m.dvl.t > 109.5)))
    return {"clean": m, "outage": m.with_outage(scenario_outage("3-missing", 80.0, 30.0)), "gap": gap}


def solve(ref, m, tag: str, method: str, backend: str):
    graph = method.startswith("Graph")
    a = ref[f"initial/{'graph' if graph else 'ekf'}/{'gap' if tag == 'gap' else 'clean'}"]
    initial = InitialState(gtsam.Pose3(gtsam.Rot3(a[1:10].reshape(3, 3)), a[13:16]), a[10:13], t=float(a[0]))
    completer = AverageCompleter(5) if "HN" in method else None
    if graph:
        return run_graph(m, completer=completer, batch=METHODS[method].batch, backend=backend, initial=initial)
    # the paper's 12-state EKF (the reference predates the 15-state filter, and the 12-state results are unchanged)
    return run_ekf(m, tight=METHODS[method].tight, completer=completer, initial=initial,
                   options=EkfOptions(position_states=False, dvl_error_states=False))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--dry-run", action="store_true", help="print the changes, leave the file alone")
    parser.add_argument("--only", metavar="TEXT",
                        help="refresh only the cases whose key contains TEXT (e.g. 'fixed-lag'); keep the others")
    args = parser.parse_args(argv)
    ref = dict(np.load(REFERENCE))
    ms = missions()
    cases = sorted({k.rsplit("/", 1)[0] for k in ref if not k.startswith("initial/")})
    new = {k: v for k, v in ref.items() if k.startswith("initial/")}
    if args.only:
        new.update({k: v for k, v in ref.items() if not k.startswith("initial/") and args.only not in k})
        cases = [c for c in cases if args.only in c]
    print("| case | max abs change v_n m/s | p_n m | cov_v_n (m/s)^2 |")
    print("|---|---|---|---|")
    for case in cases:
        tag, method, backend = case.split("/")
        sol = solve(ref, ms[tag], tag, method, None if backend == "None" else backend)
        if not np.array_equal(sol.t, ref[case + "/t"]):
            raise SystemExit(f"{case}: the output stamps changed; this script only refreshes values")
        new[case + "/t"] = sol.t
        new[case + "/v_n"], new[case + "/p_n"] = sol.v_n, sol.p_n
        change = [np.abs(sol.v_n - ref[case + "/v_n"]).max(), np.abs(sol.p_n - ref[case + "/p_n"]).max()]
        if case + "/cov_v_n" in ref:
            new[case + "/cov_v_n"] = sol.cov_v_n
            change.append(np.abs(sol.cov_v_n - ref[case + "/cov_v_n"]).max())
        print(f"| {case} | " + " | ".join(f"{c:.2e}" for c in change) + " |", flush=True)
    if not args.dry_run:
        np.savez_compressed(REFERENCE, **new)
        print(f"wrote {REFERENCE}")


if __name__ == "__main__":
    main()
