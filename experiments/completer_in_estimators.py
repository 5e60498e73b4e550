"""How the beam completers do inside the estimators (the IMU-aware completer among them).

Two reports:

- ``--data DIR``: the completions the estimators' keyframer makes on the bench's outage windows (same missions,
  IMU grades and windows as ``graphnav bench``), for the average estimator, the beam-only network and the
  IMU-aware completer, fed back through the history as in the estimators: filled-beam RMSE against the
  recorded beam (which carries the DVL noise, 0.042 m/s) and RMS(error / sigma), pooled and per trajectory.
  No estimator runs, so it takes about 2 min for three trajectories.
- ``--results FILE``: a ``graphnav bench`` results.json as a table of window VRMSE mean (worst) per method,
  and how many completed beams the screening kept and how the IMU-aware completer's pings were served
  (IMU window / no window / untrained pattern).

Usage::

    nice -n 10 .venv/bin/python experiments/completer_in_estimators.py --data /tmp/val --window-s 60
    nice -n 10 .venv/bin/python experiments/completer_in_estimators.py --results out/bench/results.json
"""
from __future__ import annotations

import argparse
import collections
import json
import sys
import warnings

import numpy as np

GRADES = ("as-recorded", "tactical", "mems")
SCENARIOS = ("2-missing", "3-missing")
ORDER = ("Graph-TC", "Graph-HN", "Graph-HNI", "Graph-HN-batch", "Graph-HNI-batch", "TC", "HNTC", "HNTC-IMU")


def completions(data: str, window_s: float) -> None:
    from graphnav.core.scenarios import scenario_outage
    from graphnav.estimators.keyframes import Keyframer
    from graphnav.estimators.replay import replay
    from graphnav.evaluation.bench import case_windows, find_trajectories, prepared_mission
    from graphnav.evaluation.methods import average_completer, imu_network_completer, network_completer
    rows: dict = collections.defaultdict(list)
    for src in find_trajectories(data):
        for grade in GRADES:
            mission = prepared_mission(src, grade)
            starts = case_windows(mission, window_s)
            recorded = np.where(mission.dvl.valid, mission.dvl.beams, np.nan)
            for sc in SCENARIOS:
                run = mission.with_outage(*[scenario_outage(sc, s, window_s) for s in starts])
                for name, comp in (("average", average_completer(sc)), ("beam-only network", network_completer(sc)[0]),
                                   ("IMU-aware", imu_network_completer(sc)[0])):
                    kfr = Keyframer(run.config, completer=comp)
                    kfr.start(float(run.imu.t[0]))
                    kfs = []
                    for kind, t, payload in replay(run, depth=False):
                        kfs += getattr(kfr, "add_" + kind)(t, *payload)
                    kfs += kfr.finish()
                    for kf in kfs:
                        p = kf.ping
                        if p is None or not p.has_regressed:
                            continue
                        truth = recorded[int(np.argmin(np.abs(run.dvl.t - p.t)))]
                        sel = p.regressed & np.isfinite(truth)
                        err = p.beams[sel] - truth[sel]
                        for key in ((grade, sc, name, "all"), (grade, sc, name, src.name)):
                            rows[key].append(np.stack([err, err / p.sigma_regressed[sel]]))
    print(f"window {window_s:g} s; filled-beam RMSE m/s (RMS error/sigma), beams")
    print("| IMU | scenario | trajectories | average | beam-only network | IMU-aware | beams |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for grade in GRADES:
        for sc in SCENARIOS:
            for which in sorted({k[3] for k in rows}, key=lambda w: (w != "all", w)):
                cells, n = [], 0
                for name in ("average", "beam-only network", "IMU-aware"):
                    e = np.concatenate(rows[(grade, sc, name, which)], axis=1)
                    cells.append(f"{np.sqrt(np.mean(e[0] ** 2)):.3f} ({np.sqrt(np.mean(e[1] ** 2)):.2f})")
                    n = e.shape[1]
                print(f"| {grade} | {sc} | {which} | " + " | ".join(cells) + f" | {n} |")


def results_table(path: str) -> None:
    records = json.load(open(path))
    vrmse, counts, seen = collections.defaultdict(list), collections.defaultdict(lambda: np.zeros(5, int)), set()
    for r in records:
        if r.get("error"):
            print(f"failed: {r['trajectory']} {r['imu_grade']} {r['scenario']} {r['method']}: {r['error']}")
            continue
        key = (r["imu_grade"], r["scenario"], r["window_s"], r["method"])
        vrmse[key].append(r["vrmse_window"])
        if key + (r["trajectory"],) in seen:      # the counters are per case, repeated in its window records
            continue
        seen.add(key + (r["trajectory"],))
        s, u = r.get("regressed_screening") or {}, r.get("completer_usage") or {}
        counts[key] += [r.get("regressed_beams", 0), s.get("gated", 0) + s.get("decorrelated_out", 0),
                        u.get("imu", 0), u.get("no_imu", 0), u.get("pattern", 0)]
    methods = [m for m in ORDER if any(k[3] == m for k in vrmse)]
    regimes = sorted({k[:3] for k in vrmse}, key=lambda r: (GRADES.index(r[0]) if r[0] in GRADES else 9, r[1], r[2]))
    print("Window VRMSE m/s, mean (worst)")
    print("| IMU | scenario | window s | " + " | ".join(methods) + " |")
    print("| --- | --- | --- |" + " --- |" * len(methods))
    for reg in regimes:
        cells = [f"{np.mean(v):.3f} ({np.max(v):.3f})" if (v := vrmse.get(reg + (m,))) else "-" for m in methods]
        print(f"| {reg[0]} | {reg[1]} | {reg[2]:g} | " + " | ".join(cells) + " |")
    print("\nCompleted beams the screening kept; IMU-aware pings served with the IMU window / without / other pattern")
    print("| IMU | scenario | window s | method | kept / completed | IMU / no window / pattern |")
    print("| --- | --- | --- | --- | --- | --- |")
    for reg in regimes:
        for m in methods:
            c = counts.get(reg + (m,))
            if c is None or not c[0]:
                continue
            usage = f"{c[2]} / {c[3]} / {c[4]}" if c[2:].any() else "-"
            print(f"| {reg[0]} | {reg[1]} | {reg[2]:g} | {m} | {c[0] - c[1]} / {c[0]} | {usage} |")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="trajectories in the A-KIT layout: completions in the keyframer")
    p.add_argument("--window-s", type=float, default=60.0)
    p.add_argument("--results", help="a graphnav bench results.json: VRMSE and completion counters")
    a = p.parse_args(argv)
    if not a.data and not a.results:
        p.error("give --data and/or --results")
    warnings.simplefilter("ignore")
    if a.data:
        completions(a.data, a.window_s)
    if a.results:
        results_table(a.results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
