"""Run methods of the registry on one mission with a partial beam outage and compare their velocity error.

The registry (``graphnav.METHODS``) names every method the benchmark runs; ``graphnav.run_method`` runs one
on a mission (the scenario chooses the completer: the network for ``2-missing``, the average estimator for
``Average-*``). Without ``--data`` the mission is simulated.

Run it: ``python examples/compare_methods.py [--data FOLDER] [--duration S] [--methods TC Graph-TC ...]``.
"""
import argparse
import warnings

import graphnav
from graphnav.core import scenario_outage
from graphnav.evaluation import vrmse


def main(data: str | None = None, duration_s: float = 200.0, methods=("TC", "HNTC", "Graph-TC", "Graph-HN")) -> None:
    mission = graphnav.load_mission(data) if data else graphnav.simulate_mission(duration_s, seed=3)
    start, length = mission.t0 + 60.0, 30.0                     # a 30 s outage of beams 1 and 3
    outage = mission.with_outage(scenario_outage("2-missing", start, length))
    print(f"{mission.name}: beams 1 and 3 missing from {start:.0f} to {start + length:.0f} s")
    for name in methods:
        sol = graphnav.run_method(outage, name, "2-missing")
        print(f"{name:15} VRMSE in the outage {vrmse(sol, mission.gt, start, start + length):.4f} m/s, "
              f"whole mission {vrmse(sol, mission.gt):.4f} m/s   ({graphnav.METHODS[name].description})")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", help="a mission path as `graphnav smooth --data` takes it (default: simulated)")
    parser.add_argument("--duration", type=float, default=200.0, help="simulated mission length, s")
    parser.add_argument("--methods", nargs="+", default=["TC", "HNTC", "Graph-TC", "Graph-HN"],
                        choices=list(graphnav.METHODS), metavar="METHOD")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    main(args.data, args.duration, args.methods)
