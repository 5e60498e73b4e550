"""Out-of-fold sigma growth of the average estimator in long outages, and the hybrid with it
(docs/decisions/completers.md).

The average estimator holds a missing beam at its pre-outage mean; :class:`graphnav.estimators.history.BeamHistory`
grows the sigma it hands on like a random walk, ``sigma_k^2 = sigma_{k-1}^2 + drift_std^2`` (0.03 m/s per ping
by default, calibrated on 30-ping outages). This study replays the bench's outage windows through the same
``BeamHistory`` as the keyframer (no estimator needed: the average estimator sees only beams) and records, per
filled beam whose recorded value exists, the completion error against the recorded beam, the sigma and the
number of pings into the outage. Per leave-trajectories-out fold (``nets.crossval.AKIT_FOLDS``) ``drift_std``
is fitted on the fold's eight training trajectories (least squares of error^2 = b0 + d^2 k over the filled
beams, k = pings into the outage); the held-out pair is replayed with it and scored: within 1 / 2 sigma
(Gaussian 0.683 / 0.954), default growth against the fold's, per 20 s into the outage.

With ``--run BENCH_RESULTS``, Graph-HN is run on every held-out trajectory with its fold's ``drift_std`` (the
bench's windows, ``--max-windows``) and its window VRMSE is compared with Graph-TC's and the default Graph-HN's
in that bench's ``results.json`` (same windows, same IMU seeds). Usage::

    nice -n 10 .venv/bin/python experiments/completer_sigma_folds.py --scenario 0-beams --window-s 60 120
    nice -n 10 .venv/bin/python experiments/completer_sigma_folds.py --scenario 0-beams --window-s 60 120 \\
        --run out/regimes-oof/results.json --grades tactical mems --max-windows 2 --jobs 2
"""
from __future__ import annotations

import argparse
import json
import sys

import numpy as np


def completion_errors(mission, scenario: str, window_s: float, drift_std: float | None = None) -> np.ndarray:
    """Rows (pings into the outage, error m/s, sigma m/s) of every filled beam of the bench's ``window_s``
    windows (all of them) whose recorded beam is valid, as the keyframer's ``BeamHistory`` hands them on with
    the average estimator of ``drift_std`` (None: the history's default)."""
    from graphnav.core.scenarios import scenario_outage
    from graphnav.estimators.history import BeamHistory
    from graphnav.evaluation.bench import case_windows
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    starts = case_windows(mission, window_s)
    run = mission.with_outage(*[scenario_outage(scenario, s, window_s) for s in starts])
    completer = AverageCompleter(n_past=AVERAGE_N_PAST[scenario], noise_std=mission.config.dvl.beam_noise_std,
                                 drift_std=drift_std)
    history = BeamHistory(completer.n_past)
    rows, dvl, recorded = [], run.dvl, mission.dvl
    k = 0
    for i, t in enumerate(dvl.t):
        out = history.complete(completer, dvl.beams[i], dvl.valid[i])
        inside = any(s <= t <= s + window_s for s in starts)
        k = k + 1 if inside else 0
        if out is None or not inside:
            continue
        full, sigma = out
        for j in np.flatnonzero(~dvl.valid[i] & recorded.valid[i]):
            rows.append((k, full[j] - recorded.beams[i, j], sigma[j]))
    return np.array(rows, float).reshape(-1, 3)


def fit_drift(rows: np.ndarray) -> float:
    """drift_std (m/s per ping) of the random walk that fits the errors: least squares of e^2 = b0 + d^2 k."""
    A = np.column_stack([np.ones(len(rows)), rows[:, 0]])
    b0, d2 = np.linalg.lstsq(A, rows[:, 1] ** 2, rcond=None)[0]
    return float(np.sqrt(max(d2, 0.0)))


def coverage(err: np.ndarray, sigma: np.ndarray) -> tuple[float, float]:
    z = np.abs(err) / sigma
    return float(np.mean(z < 1)), float(np.mean(z < 2))


def errors_task(item):
    source, scenario, window_s, drift_std = item
    from graphnav.evaluation.bench import prepared_mission
    return (source.name, window_s, drift_std), completion_errors(prepared_mission(source, "as-recorded"), scenario,
                                                                 window_s, drift_std)


def hybrid_task(item):
    """Graph-HN with the fold's average estimator on one held-out trajectory: window VRMSE per window."""
    source, grade, scenario, window_s, max_windows, drift_std = item
    from graphnav.core.scenarios import scenario_outage
    from graphnav.evaluation.bench import case_windows, prepared_mission, score_case
    from graphnav.evaluation.methods import run_method
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    mission = prepared_mission(source, grade)
    starts = case_windows(mission, window_s, max_windows)
    run = mission.with_outage(*[scenario_outage(scenario, s, window_s) for s in starts])
    completer = AverageCompleter(n_past=AVERAGE_N_PAST[scenario], noise_std=mission.config.dvl.beam_noise_std,
                                 drift_std=drift_std)
    sol = run_method(run, "Graph-HN", scenario, completer=completer)
    return (source.name, grade, window_s), [r["vrmse_window"] for r in score_case(sol, mission, starts, window_s)]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--scenario", default="0-beams", help="beam-outage scenario (default 0-beams)")
    p.add_argument("--window-s", nargs="+", type=float, default=[60.0, 120.0], help="outage window lengths, s")
    p.add_argument("--run", metavar="RESULTS_JSON", help="also run Graph-HN with each fold's drift_std and compare "
                   "with this bench's Graph-TC and Graph-HN")
    p.add_argument("--grades", nargs="+", default=["tactical", "mems"], help="IMU grades of --run")
    p.add_argument("--max-windows", type=int, default=2, help="windows per trajectory of --run (as the bench)")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (graphnav.evaluation.tasks)")
    a = p.parse_args(argv)
    from graphnav.evaluation.bench import find_trajectories
    from graphnav.evaluation.tasks import run_tasks
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.crossval import AKIT_FOLDS
    folders = akit_trajectories(a.data)
    sources = {s.name: s for s in find_trajectories(str(folders[0].parent))}
    errors: dict = {}
    collect = lambda r: errors.__setitem__(r[0], r[1])  # noqa: E731
    run_tasks(errors_task, [(s, a.scenario, w, None) for s in sources.values() for w in a.window_s], collect,
              jobs=a.jobs)
    name = lambda n: f"Trajectory{n}"  # noqa: E731
    drifts, default, fitted = {}, {}, {}
    for f, pair in enumerate(AKIT_FOLDS):
        out = {name(k) for k in pair}
        drifts[f] = fit_drift(np.vstack([errors[(n, w, None)] for n in sources if n not in out for w in a.window_s]))
    run_tasks(errors_task, [(sources[name(k)], a.scenario, w, drifts[f]) for f, pair in enumerate(AKIT_FOLDS)
                            for k in pair for w in a.window_s], collect, jobs=a.jobs)
    print(f"scenario {a.scenario}, windows {a.window_s} s (all windows of every trajectory)")
    print("| fold | held out | drift_std fitted on training, m/s per ping | held-out RMS error | "
          "default (0.03) within 1 / 2 sigma | fitted within 1 / 2 sigma |")
    print("| --- | --- | --- | --- | --- | --- |")
    for f, pair in enumerate(AKIT_FOLDS):
        default[f] = np.vstack([errors[(name(k), w, None)] for k in pair for w in a.window_s])
        fitted[f] = np.vstack([errors[(name(k), w, drifts[f])] for k in pair for w in a.window_s])
        print(f"| {f} | {', '.join(map(str, pair))} | {drifts[f]:.4f} | {np.sqrt(np.mean(default[f][:, 1] ** 2)):.3f} | "
              "{:.2f} / {:.2f} | {:.2f} / {:.2f} |".format(*coverage(default[f][:, 1], default[f][:, 2]),
                                                         *coverage(fitted[f][:, 1], fitted[f][:, 2])))
    d, g = np.vstack(list(default.values())), np.vstack(list(fitted.values()))
    print(f"| pooled | all | - | {np.sqrt(np.mean(d[:, 1] ** 2)):.3f} | "
          "{:.2f} / {:.2f} | {:.2f} / {:.2f} |".format(*coverage(d[:, 1], d[:, 2]), *coverage(g[:, 1], g[:, 2])))
    print("\nOut of fold, by pings into the outage (pooled held-out pairs):")
    print("| pings into outage | RMS error | RMS default sigma | default 1 / 2 | RMS fitted sigma | fitted 1 / 2 |")
    print("| --- | --- | --- | --- | --- | --- |")
    for lo in range(0, int(d[:, 0].max()) + 1, 20):
        m = (d[:, 0] > lo) & (d[:, 0] <= lo + 20)
        if m.any():
            print(f"| {lo + 1}-{lo + 20} | {np.sqrt(np.mean(d[m, 1] ** 2)):.3f} | {np.sqrt(np.mean(d[m, 2] ** 2)):.3f} | "
                  "{:.2f} / {:.2f} | ".format(*coverage(d[m, 1], d[m, 2])) + f"{np.sqrt(np.mean(g[m, 2] ** 2)):.3f} | "
                  "{:.2f} / {:.2f} |".format(*coverage(g[m, 1], g[m, 2])))
    if not a.run:
        return 0
    fold_of = {name(k): f for f, pair in enumerate(AKIT_FOLDS) for k in pair}
    tasks = [(sources[n], g, a.scenario, w, a.max_windows, drifts[fold_of[n]]) for n in sources if n in fold_of
             for g in a.grades for w in a.window_s]
    fitted_runs: dict = {}
    run_tasks(hybrid_task, tasks, lambda r: fitted_runs.__setitem__(r[0], r[1]), jobs=a.jobs)
    for key in sorted(fitted_runs):
        print(f"fitted-drift Graph-HN {key}: window VRMSE {', '.join(f'{v:.4f}' for v in fitted_runs[key])} m/s")
    bench: dict = {}
    for r in json.load(open(a.run)):
        if r.get("scenario") == a.scenario and r.get("vrmse_window") is not None and not r.get("error"):
            bench.setdefault((r["trajectory"], r["imu_grade"], float(r["window_s"]), r["method"]), []).append(
                r["vrmse_window"])
    print(f"\nGraph-HN with the fold's drift_std against the bench ({a.run}); window VRMSE mean m/s, ratio to Graph-TC")
    print("| IMU | window s | fold | Graph-TC | Graph-HN | fitted drift | HN/TC | fitted/TC |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for g in a.grades:
        for w in a.window_s:
            rows = []
            for f, pair in [*enumerate(AKIT_FOLDS), ("all", tuple(k for pr in AKIT_FOLDS for k in pr))]:
                keys = [(name(k), g, w) for k in pair if (name(k), g, w) in fitted_runs]
                tc = [v for k in keys for v in bench.get((*k, "Graph-TC"), [])]
                hn = [v for k in keys for v in bench.get((*k, "Graph-HN"), [])]
                cp = [v for k in keys for v in fitted_runs[k]]
                if tc and hn and cp:
                    rows.append(f"| {g} | {w:g} | {f} | {np.mean(tc):.3f} | {np.mean(hn):.3f} | {np.mean(cp):.3f} | "
                                f"{np.mean(hn) / np.mean(tc):.2f} | {np.mean(cp) / np.mean(tc):.2f} |")
            print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
