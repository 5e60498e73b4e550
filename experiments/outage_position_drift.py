"""Where the position goes in an outage and after it: the hybrids' velocity gain against their position, in the
regime windows (docs/decisions/completers.md, "A completer that models the turn", "Position through and after the
outage").

The regime table scores the window VRMSE. A navigator is judged by its position too, and two readings of it
differ in a smoother: the filtered position *during* the outage (what the vehicle navigates on), and the position
*after* the beams return, when the graph has re-estimated the outage's states with the new measurements. Per
window, against the horizontal error at its start (mean over the 5 s before it):

- ``end 10 s``: the horizontal error, RMS over the outage's last 10 s (0.5 s steps), less the start's;
- ``after 20-40 s``: the horizontal error, RMS from 20 to 40 s after the outage (0.5 s steps), less the start's;
- ``bench``: the bench's "drift" (``graphnav.evaluation.metrics.position_drift``: the error interpolated at the
  window's end, which on 1.0025 s pings falls between the last outage ping and the first measured one, whose
  filtered position the returning beams already corrected).

``--pivot-runs T ...`` adds ``Graph-HNP`` with other run settings: screened at each ping (``Graph-HNP each ping``,
``Graph-HN``'s) and, per T, its completions' errors correlated over T s whatever the ping measured (``Graph-HNP tau
T``), to see what the run setting trades between the velocity and the position after the outage.

Every A-KIT trajectory with the bench's windows (``--max-windows``, the regime table's 2), each IMU grade and
scenario; pooled and per fold (the folds of the completer studies), and each method's ratio to Graph-TC. About 2
min on two cores for the default cells. Usage::

    .venv/bin/python experiments/outage_position_drift.py --out out/position/drift.json --jobs 2
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

METRICS = ("vrmse", "end 10 s", "after 20-40 s", "bench")


def horizontal_error(sol, gt, t: np.ndarray) -> np.ndarray:
    """Estimate minus reference, north and east (len(t), 2) m, the estimate interpolated at ``t`` (s)."""
    from graphnav.core.timeseries import interp_rows
    return interp_rows(t, sol.t, sol.p_n[:, :2]) - gt.at(np.atleast_1d(t))[0][:, :2]


def position_metrics(sol, gt, start: float, window_s: float) -> dict:
    """``end 10 s`` and ``after 20-40 s`` (module docstring), m, for the outage ``[start, start + window_s]`` (s)."""
    end = start + window_s
    e0 = horizontal_error(sol, gt, np.arange(start - 5.0, start + 1e-9, 0.5)).mean(axis=0)
    last = horizontal_error(sol, gt, np.arange(end - 10.0, end + 1e-9, 0.5)) - e0
    stop = min(end + 40.0, gt.t[-1], sol.t[-1])
    after = horizontal_error(sol, gt, np.arange(min(end + 20.0, stop), stop + 1e-9, 0.5)) - e0
    return {"end 10 s": float(np.sqrt(np.mean(np.sum(last ** 2, axis=1)))),
            "after 20-40 s": float(np.sqrt(np.mean(np.sum(after ** 2, axis=1))))}


def window_metrics(sol, gt, start: float, window_s: float) -> dict:
    """The metrics of the module docstring for the outage ``[start, start + window_s]`` (s)."""
    from graphnav.evaluation.metrics import position_drift, vrmse
    return {"vrmse": float(vrmse(sol, gt, start, start + window_s)), **position_metrics(sol, gt, start, window_s),
            "bench": float(position_drift(sol, gt, start, start + window_s))}


def variant_run(label: str) -> tuple[str, dict | None]:
    """(registry method, graph options on top of its defaults) of a run label: a method name, ``Graph-HNP each
    ping`` or ``Graph-HNP tau T``."""
    from graphnav.evaluation.methods import GRAPH_HNP
    if label == f"{GRAPH_HNP} each ping":
        return GRAPH_HNP, {"regressed_runs": "screen-each", "regressed_error_tau_s": None}
    if label.startswith(f"{GRAPH_HNP} tau "):
        return GRAPH_HNP, {"regressed_error_tau_s": float(label.rsplit(" ", 1)[1])}
    return label, None


def trajectory_task(item):
    """(key, {method: [window metrics]}) of one trajectory, grade, scenario and window length."""
    source, grade, scenario, window_s, max_windows, methods = item
    import warnings
    warnings.simplefilter("ignore")
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation.bench.cases import case_windows, prepared_mission
    from graphnav.evaluation.methods import run_method
    mission = prepared_mission(source, grade)
    starts = case_windows(mission, window_s, max_windows)
    run = mission.with_outage(*[scenario_outage(scenario, s, window_s) for s in starts])
    result = {}
    for method in methods:
        name, options = variant_run(method)
        sol = run_method(run, name, scenario, options=options)
        result[method] = [window_metrics(sol, mission.gt, s, window_s) for s in starts]
    return (source.name, grade, scenario, window_s), result


def report(runs: dict, methods, folds) -> str:
    """Per cell: each metric's mean over the windows, pooled, and each method's ratio to Graph-TC (worst fold)."""
    cells = sorted({k[1:] for k in runs}, key=lambda c: (c[0] != "tactical", c[1], c[2]))
    lines = ["| IMU | scenario | window s | method | " + " | ".join(f"{m} (m/s or m)" if m == "vrmse" else m
                                                                   for m in METRICS) + " |",
             "| --- | --- | --- | --- | " + " | ".join("---" for _ in METRICS) + " |"]

    def mean(trajectories, cell, method, metric):
        vals = [w[metric] for k in trajectories if (f"Trajectory{k}", *cell) in runs
                for w in runs[(f"Trajectory{k}", *cell)][method]]
        return float(np.mean(vals)) if vals else float("nan")
    everyone = [k for pair in folds for k in pair]
    for cell in cells:
        for method in methods:
            parts = []
            for metric in METRICS:
                value = mean(everyone, cell, method, metric)
                if method == "Graph-TC":
                    parts.append(f"{value:.3f}" if metric == "vrmse" else f"{value:.2f}")
                    continue
                ratios = [mean(pair, cell, method, metric) / mean(pair, cell, "Graph-TC", metric) for pair in folds]
                pooled = value / mean(everyone, cell, "Graph-TC", metric)
                parts.append(f"{pooled:.2f}x ({max(ratios):.2f}x)")
            lines.append(f"| {cell[0]} | {cell[1]} | {cell[2]:g} | {method} | " + " | ".join(parts) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).parent))
    from hybrid_imu_folds import load_runs, run_saving
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    from graphnav.evaluation.methods import GRAPH_HN, GRAPH_HNP, GRAPH_TC
    p.add_argument("--methods", nargs="+", default=[GRAPH_TC, GRAPH_HN, GRAPH_HNP], help="graph methods (Graph-TC "
                   "first: the ratios are to it; default: Graph-TC, Graph-HN, Graph-HNP)")
    p.add_argument("--pivot-runs", nargs="*", type=float, metavar="T", help="also Graph-HNP screened at each ping "
                   "and, per T, with its completions' errors correlated over T s (module docstring)")
    p.add_argument("--scenarios", nargs="+", default=["3-missing", "0-beams"], help="beam-outage scenarios")
    p.add_argument("--grades", nargs="+", default=["tactical", "mems"], help="IMU grades")
    p.add_argument("--window-s", nargs="+", type=float, default=[120.0], help="outage lengths, s")
    p.add_argument("--max-windows", type=int, default=2, help="windows per trajectory (as the regime table)")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (graphnav.evaluation.tasks)")
    p.add_argument("--out", default="out/position/drift.json", help="results (JSON); a rerun with the same "
                   "settings resumes from it")
    a = p.parse_args(argv)
    if a.methods[0] != GRAPH_TC:
        p.error("--methods must start with Graph-TC (the ratios are to it)")
    if a.pivot_runs is not None:
        if not all(t > 0 for t in a.pivot_runs):
            p.error("--pivot-runs: correlation times must be > 0 s")
        a.methods += [f"{GRAPH_HNP} each ping", *(f"{GRAPH_HNP} tau {t:g}" for t in a.pivot_runs)]
    from graphnav.evaluation.bench import find_trajectories
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.crossval import AKIT_FOLDS
    folders = akit_trajectories(a.data)
    sources = {s.name: s for s in find_trajectories(str(folders[0].parent))}
    settings = {"max_windows": a.max_windows, "methods": a.methods, "metrics": list(METRICS)}
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    runs, _ = load_runs(out, settings)
    items = [(sources[f"Trajectory{k}"], g, sc, w, a.max_windows, a.methods)
             for pair in AKIT_FOLDS for k in pair for g in a.grades for sc in a.scenarios for w in a.window_s
             if (f"Trajectory{k}", g, sc, w) not in runs]
    run_saving(trajectory_task, items, runs, out, settings, a.jobs)
    print(f"{a.max_windows} windows per trajectory; horizontal position error less the window start's, m; Graph-TC "
          "in its units, the others as ratios to it, pooled (worst fold)")
    print(report(runs, a.methods, AKIT_FOLDS))
    return 0


if __name__ == "__main__":
    sys.exit(main())
