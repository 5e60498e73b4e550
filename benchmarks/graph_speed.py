"""Speed of the factor-graph estimators on simulated missions (prints tables; no assertions).

    .venv/bin/python benchmarks/graph_speed.py              # 400 s, 1 h and 4 h (several minutes)
    .venv/bin/python benchmarks/graph_speed.py --quick      # 400 s only

Tables:
1. Online ISAM2 on a 400 s mission (preintegration included): total time, real-time factor, update
   median / p99 / max per keyframe; one DVL factor per epoch vs one per beam; Graph-HN with a 30 s
   2-missing outage.
2. Cost growth with mission length: online ISAM2 vs the fixed-lag smoother (update median / p99, total
   time, peak RSS increase while the estimator runs). The fixed-lag runs stream their estimates (as
   ``graphnav online`` does), so memory reflects the estimator, not a stored trajectory.
3. Batch smoothing: the vectorised Gauss-Newton batch (first pass = fixed-lag) vs GTSAM's LM on the
   CustomFactor graph at 400 s (time and largest velocity difference); vectorised at 1 h and 4 h.

Targets: online 400 s < 1.3 s (>= 300x real time), ISAM2 p99 < 10 ms, fixed-lag p99 < 15 ms with
flat RSS from 1 h to 4 h, 4 h batch < 60 s. The machine is shared (2 cores): compare within one run.
"""
from __future__ import annotations

import argparse
import gc
import time

import numpy as np
from graphnav.nets import AverageCompleter

from graphnav.core.scenarios import scenario_outage
from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.runs import iterate_graph, run_graph
from graphnav.evaluation.metrics import vrmse
from graphnav.sim.simulate import simulate_mission


def rss_mb() -> float:
    """Resident set size of this process now, MB (from /proc)."""
    with open("/proc/self/statm") as fh:
        pages = int(fh.read().split()[1])
    import os
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


def ms(x) -> str:
    return f"{1e3 * x:7.2f}"


def row(cells, widths):
    return "| " + " | ".join(str(c).rjust(w) for c, w in zip(cells, widths)) + " |"


def table(title, header, rows):
    widths = [max(len(str(h)), *(len(str(r[i])) for r in rows)) for i, h in enumerate(header)]
    print(f"\n{title}")
    print(row(header, widths))
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for r in rows:
        print(row(r, widths))


def stream(mission, backend, options=None, completer=None):
    """Run an incremental estimator without keeping its output; return (total s, update times, RSS increase MB)."""
    gc.collect()
    base = peak = rss_mb()
    updates = []
    start = time.perf_counter()
    for est in iterate_graph(mission, completer=completer, options=options, backend=backend):
        updates.append(est.update_s)
        if est.index % 200 == 0:
            peak = max(peak, rss_mb())
    total = time.perf_counter() - start
    peak = max(peak, rss_mb())
    return total, np.array(updates), peak - base, peak


def online_400(m400):
    rows = []
    for label, opts, mission, comp in [
            ("Graph-TC, epoch factors", GraphOptions(), m400, None),
            ("Graph-TC, per-beam factors", GraphOptions(beam_factor_mode="beam"), m400, None),
            ("Graph-HN, 30 s 2-missing", GraphOptions(),
             m400.with_outage(scenario_outage("2-missing", 200.0, 30.0)), AverageCompleter(3))]:
        run_graph(mission.slice(0, 20), completer=comp, options=opts)      # warm-up (imports, caches)
        sol = run_graph(mission, completer=comp, options=opts)
        u = np.array(sol.info["update_s"])
        rows.append([label, f"{sol.runtime_s:.3f}", f"{m400.duration / sol.runtime_s:.0f}x", ms(np.median(u)),
                     ms(np.percentile(u, 99)), ms(u.max()), f"{vrmse(sol, mission.gt):.4f}"])
    table("1. Online ISAM2, 400 s mission (preintegration included)",
          ["run", "total s", "real time", "upd median ms", "upd p99 ms", "upd max ms", "VRMSE m/s"], rows)


def growth(missions, online_max_s):
    rows = []
    for m in missions:
        for backend in ("isam2", "fixed-lag"):
            if backend == "isam2" and m.duration > online_max_s:
                rows.append([f"{m.duration:.0f}", backend, "skipped (grows with the graph)", "", "", "", ""])
                continue
            total, u, drss, peak = stream(m, backend)
            rows.append([f"{m.duration:.0f}", backend, f"{total:.1f}", ms(np.median(u)), ms(np.percentile(u, 99)),
                         f"{drss:.0f}", f"{peak:.0f}"])
    table("2. Cost growth with mission length (Graph-TC; fixed-lag lag = 30 s)",
          ["mission s", "backend", "total s", "upd median ms", "upd p99 ms", "RSS increase MB", "RSS peak MB"], rows)


def batch(missions, lm_max_s):
    rows = []
    for m in missions:
        mission = m.with_outage(scenario_outage("2-missing", m.t0 + 200.0, 30.0))
        comp = AverageCompleter(3)
        sol = run_graph(mission, batch=True, completer=comp, backend="fixed-lag")
        info = sol.info
        rows.append([f"{m.duration:.0f}", "vectorized GN", f"{sol.runtime_s:.1f}", f"{info['online_s']:.1f}",
                     f"{info['batch_s']:.2f}", info["batch_iterations"], f"{vrmse(sol, m.gt):.4f}", ""])
        if m.duration <= lm_max_s:
            ref = run_graph(mission, batch=True, completer=comp, backend="fixed-lag",
                            options=GraphOptions(batch_solver="lm"))
            diff = np.abs(ref.v_n - sol.v_n).max()
            rows.append([f"{m.duration:.0f}", "GTSAM LM (CustomFactor)", f"{ref.runtime_s:.1f}",
                         f"{ref.info['online_s']:.1f}", f"{ref.info['batch_s']:.2f}", ref.info["batch_iterations"],
                         f"{vrmse(ref, m.gt):.4f}", f"{diff:.1e}"])
    table("3. Batch smoothing (Graph-HN-batch, AverageCompleter, one 30 s 2-missing outage; first pass fixed-lag)",
          ["mission s", "solver", "total s", "first pass s", "batch s", "iterations", "VRMSE m/s",
           "max |dv| vs GN"], rows)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="400 s mission only")
    parser.add_argument("--online-max-s", type=float, default=3600.0,
                        help="longest mission to run online ISAM2 on (default 3600)")
    parser.add_argument("--lm-max-s", type=float, default=400.0,
                        help="longest mission to run the GTSAM LM reference batch on (default 400)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    durations = [400.0] if args.quick else [400.0, 3600.0, 14400.0]
    t0 = time.perf_counter()
    missions = [simulate_mission(d, seed=args.seed) for d in durations]
    print(f"simulated {', '.join(f'{d:.0f} s' for d in durations)} in {time.perf_counter() - t0:.1f} s")
    online_400(missions[0])
    growth(missions, args.online_max_s)
    batch(missions, args.lm_max_s)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
