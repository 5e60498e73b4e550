"""Cost of the graph's marginal covariances (``GraphOptions.marginals``: none / velocity / full), and a check
that the estimates do not depend on it (prints a table; no assertions).

For the fixed-lag smoother and ISAM2: replay time of a whole mission (the Navigator's replay, preintegration
included) and the update median / p99 per keyframe at each level, on a simulated 400 s mission (tactical IMU,
all beams) and on a real A-KIT trajectory; for the batch smoother (Graph-TC-batch): the time of its marginals
(``info["batch_marginals_s"]``) at each level. Each level runs ``--repeats`` times and the fastest is kept (the
machine is shared). The largest difference of the position and velocity estimates from the ``none`` run must
be exactly 0.

    .venv/bin/python benchmarks/marginals_speed.py                           # simulated 400 s + Trajectory1
    .venv/bin/python benchmarks/marginals_speed.py --trajectory 5 --repeats 3
    .venv/bin/python benchmarks/marginals_speed.py --trajectory 0            # simulated mission only
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.graph.options import MARGINAL_LEVELS
from graphnav.estimators.runs import run_graph
from graphnav.io.paths import akit_trajectories
from graphnav.missions import load_akit
from graphnav.sim.simulate import simulate_mission


def timed(mission, backend, level, batch, repeats):
    best = None
    for _ in range(repeats):
        start = time.perf_counter()
        sol = run_graph(mission, backend=backend, batch=batch, options=GraphOptions(marginals=level))
        wall = time.perf_counter() - start
        if best is None or wall < best[0]:
            best = (wall, sol)
    return best


def bench(label, mission, repeats):
    rows = []
    for backend, batch in (("fixed-lag", False), ("isam2", False), ("fixed-lag", True)):
        reference = None
        for level in MARGINAL_LEVELS:
            wall, sol = timed(mission, backend, level, batch, repeats)
            reference = reference or sol
            dp = float(np.max(np.abs(sol.p_n - reference.p_n)))
            dv = float(np.max(np.abs(sol.v_n - reference.v_n)))
            upd = 1e3 * np.asarray(sol.info["update_s"])
            what = "batch" if batch else ("ISAM2" if backend == "isam2" else "fixed-lag")
            marg = sol.info.get("batch_marginals_s", float("nan"))
            rows.append((label, what, level, f"{wall:.2f}", f"{np.median(upd):.2f}", f"{np.percentile(upd, 99):.2f}",
                         "" if not batch else f"{marg:.2f}", f"{dp:.1e}", f"{dv:.1e}"))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--trajectory", type=int, default=1,
                        help="A-KIT trajectory number (0: the simulated mission only)")
    parser.add_argument("--data", metavar="DIR",
                        help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    parser.add_argument("--repeats", type=int, default=2, help="runs per level, the fastest kept (default 2)")
    args = parser.parse_args(argv)
    folders = akit_trajectories(args.data, names=[args.trajectory]) if args.trajectory else []
    rows = bench("simulated 400 s tactical", simulate_mission(400, imu_grade="tactical", seed=0), args.repeats)
    for folder in folders:
        rows += bench(f"A-KIT {folder.name}", load_akit(folder), args.repeats)
    header = ("mission", "estimator", "marginals", "total s", "update median ms", "update p99 ms",
              "batch marginals s", "max |dp| m", "max |dv| m/s")
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(header)]
    print("| " + " | ".join(h.ljust(w) for h, w in zip(header, widths)) + " |")
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for r in rows:
        print("| " + " | ".join(c.ljust(w) for c, w in zip(r, widths)) + " |")
    return 0


if __name__ == "__main__":
    from graphnav.core.errors import ConfigError
    try:
        raise SystemExit(main())
    except ConfigError as exc:
        raise SystemExit(f"error: {exc}") from None
