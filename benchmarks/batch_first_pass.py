"""The batch smoother's first pass: incremental smoother or dead reckoning -- same smoothed result? (prints)

``GraphOptions.batch_first_pass`` chooses where the batch's factors and initial values come from: the
incremental smoother of ``run_graph``'s ``mode`` (ISAM2 for ``online``, the bench's mode; GTSAM's fixed-lag
smoother for ``fixed-lag``) or a DVL-aided dead reckoning without a solver
(:mod:`graphnav.estimators.graph.first_pass`). Per A-KIT trajectory and scenario (all beams, and the bench's
3-missing windows), Graph-TC-batch with each first pass: the largest difference of the smoothed velocity and
position to the ISAM2 first pass, the VRMSE against the ground truth, CPU seconds. ISAM2 vs fixed-lag is the
yardstick: how much the result already depends on which incremental smoother ran first.

    .venv/bin/python benchmarks/batch_first_pass.py                  # ten A-KIT trajectories (~10 min)
    .venv/bin/python benchmarks/batch_first_pass.py --only 1 5       # some of them
    .venv/bin/python benchmarks/batch_first_pass.py --hours 4 --trajectories 0   # a simulated 4 h mission only
"""
from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from graphnav.core.scenarios import scenario_outage
from graphnav.estimators.runs import run_graph
from graphnav.evaluation.bench.cases import case_windows
from graphnav.estimators.graph import GraphOptions
from graphnav.evaluation.metrics import vrmse

#: (label, run_graph mode, batch_first_pass)
PASSES = (("isam2", "isam2", "incremental"), ("fixed-lag", "fixed-lag", "incremental"),
          ("dead-reckoning", "fixed-lag", "dead-reckoning"))


def run_passes(mission, gt) -> dict:
    """{label: (solution, CPU s)} of Graph-TC-batch with each first pass."""
    out = {}
    for label, mode, first in PASSES:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.process_time()
            sol = run_graph(mission, batch=True, backend=mode, options=GraphOptions(batch_first_pass=first),
                            name="Graph-TC-batch")
            out[label] = (sol, time.process_time() - t0)
    return out


def rows_for(name: str, scenario: str, runs: dict, gt) -> list:
    ref = runs["isam2"][0]
    rows = []
    for label, (sol, cpu) in runs.items():
        dv = np.abs(sol.v_n - ref.v_n).max()
        dp = np.abs(sol.p_n - ref.p_n).max()
        rows.append([name, scenario, label, f"{dv:.1e}", f"{dp:.1e}", f"{vrmse(sol, gt):.5f}", f"{cpu:.1f}",
                     sol.info.get("batch_iterations", "")])
    return rows


def table(rows) -> None:
    header = ["trajectory", "scenario", "first pass", "max |dv| m/s", "max |dp| m", "VRMSE m/s", "CPU s", "iterations"]
    widths = [max(len(str(h)), *(len(str(r[i])) for r in rows)) for i, h in enumerate(header)]
    line = lambda cells: "| " + " | ".join(str(c).rjust(w) for c, w in zip(cells, widths)) + " |"  # noqa: E731
    print(line(header))
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for r in rows:
        print(line(r))


def long_mission(hours: float) -> None:
    """CPU of the batch on a simulated mission with each first pass (fixed-lag: what the benchmarks used)."""
    from graphnav.sim.simulate import simulate_mission
    m = simulate_mission(3600.0 * hours, seed=0)
    rows = []
    ref = None
    for label, mode, first in PASSES[1:]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0, w0 = time.process_time(), time.perf_counter()
            sol = run_graph(m, batch=True, backend=mode, options=GraphOptions(batch_first_pass=first))
            cpu, wall = time.process_time() - t0, time.perf_counter() - w0
        ref = sol if ref is None else ref
        rows.append([f"{hours:g} h", "none", label, f"{np.abs(sol.v_n - ref.v_n).max():.1e}",
                     f"{np.abs(sol.p_n - ref.p_n).max():.1e}", f"{vrmse(sol, m.gt):.5f}",
                     f"{cpu:.1f} (wall {wall:.1f}; first pass {sol.info['online_s']:.1f}, batch "
                     f"{sol.info['batch_s']:.1f})", sol.info["batch_iterations"]])
    print(f"\nSimulated {hours:g} h mission, Graph-TC-batch (differences to the fixed-lag first pass)")
    table(rows)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", default=None, help="A-KIT folder (default: graphnav.io.paths.akit_dir())")
    parser.add_argument("--only", nargs="*", default=None, help="trajectory numbers or names")
    parser.add_argument("--trajectories", type=int, default=10, help="at most this many trajectories (0: none)")
    parser.add_argument("--hours", type=float, default=0.0, help="also time a simulated mission this long, h")
    args = parser.parse_args(argv)
    rows = []
    if args.trajectories > 0:
        from graphnav.missions import load_mission
        from graphnav.io.paths import akit_trajectories
        for folder in akit_trajectories(args.data, args.only)[:args.trajectories]:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                mission = load_mission(str(folder))
            for scenario in ("none", "3-missing"):
                starts = case_windows(mission, 30.0) if scenario != "none" else []
                run = mission.with_outage(*[scenario_outage(scenario, s, 30.0) for s in starts])
                rows += rows_for(folder.name, scenario, run_passes(run, mission.gt), mission.gt)
                print(f"{folder.name} {scenario}: done", flush=True)
        print("\nGraph-TC-batch by first pass (differences to the ISAM2 first pass, the bench's)")
        table(rows)
    if args.hours > 0:
        long_mission(args.hours)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
