"""The same two measurements on whichever graphnav tree is imported: for before / after comparisons against an
older commit, run with that commit's tree installed in its own virtualenv (see docs/decisions/speed.md).

Only calls that older trees also have are used (``Navigator``, ``replay``, ``run_graph``, ``simulate_mission``), so
the numbers of two trees come from the same code path:

- ``batch HOURS``: Graph-HN-batch on a simulated mission of HOURS hours (AverageCompleter, one 30 s 2-missing
  outage at 200 s; seed 0), the fixed-lag first pass: CPU, first pass and batch seconds;
- ``profile OUT.prof``: cProfile of one sample-by-sample replay of the simulated 400 s mission (seed 0) through
  the Navigator with default options (``--backend``), after one unprofiled warm-up replay.

    .venv/bin/python benchmarks/tree_speed.py batch 4
    .venv/bin/python benchmarks/tree_speed.py profile /tmp/replay.prof && .venv/bin/python -m pstats /tmp/replay.prof
    # an older commit: git archive REV | tar -x -C DIR; a virtualenv in DIR with `pip install --no-deps -e DIR`
    DIR/.venv/bin/python benchmarks/tree_speed.py batch 4
"""
from __future__ import annotations

import argparse
import cProfile
import inspect
import time


def batch(hours: float) -> None:
    from graphnav.core.scenarios import scenario_outage
    from graphnav.estimators.runs import run_graph
    from graphnav.nets import AverageCompleter
    from graphnav.sim.simulate import simulate_mission
    m = simulate_mission(hours * 3600.0, seed=0)
    mission = m.with_outage(scenario_outage("2-missing", m.t0 + 200.0, 30.0))
    # the keyword that chose the fixed-lag smoother was "mode" before it was "backend"
    kw = ({"backend": "fixed-lag"} if "backend" in inspect.signature(run_graph).parameters
          else {"mode": "fixed-lag"})
    cpu = time.process_time()
    sol = run_graph(mission, batch=True, completer=AverageCompleter(3), **kw)
    cpu = time.process_time() - cpu
    info = sol.info
    print(f"{hours:g} h Graph-HN-batch: {len(sol.t)} keyframes, CPU {cpu:.1f} s, first pass "
          f"{info.get('online_s', float('nan')):.1f} s, batch {info.get('batch_s', float('nan')):.1f} s, "
          f"{m.duration / cpu:.0f}x real time (CPU)")


def profile(out: str, backend: str) -> None:
    from graphnav.estimators.navigator import Navigator
    from graphnav.estimators.replay import first_ping_time, replay
    from graphnav.sim.simulate import simulate_mission
    try:
        from graphnav.estimators.types import InitialState
    except ImportError:         # where older trees kept it
        from graphnav.estimators.graph.incremental import InitialState
    mission = simulate_mission(400.0, seed=0)
    events = list(replay(mission))

    def run():
        nav = Navigator(mission.config, backend,
                        initial=InitialState.from_ground_truth(mission, first_ping_time(mission)))
        add = {"imu": nav.add_imu, "dvl": nav.add_dvl, "depth": nav.add_depth}
        for kind, t, payload in events:
            add[kind](t, *payload)
        nav.finish()

    run()
    cProfile.runctx("run()", globals(), {"run": run}, out)
    print(f"wrote {out} (read with: python -m pstats {out})")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="what", required=True)
    b = sub.add_parser("batch", help="Graph-HN-batch CPU on a simulated mission")
    b.add_argument("hours", type=float)
    p = sub.add_parser("profile", help="cProfile of one 400 s replay")
    p.add_argument("out")
    p.add_argument("--backend", default="fixed-lag")
    args = parser.parse_args(argv)
    if args.what == "batch":
        batch(args.hours)
    else:
        profile(args.out, args.backend)


if __name__ == "__main__":
    main()
