"""Out-of-fold choice of the beam-only completer's fading to the average through an outage (``run_decay``).

Fed its own completions through a recursive outage, the network can walk away from motion it was not trained on,
where the average estimator holds the last beams. With ``run_decay`` gamma the completion at the k-th regressed
ping of a run is ``gamma^k b_net + (1 - gamma^k) b_avg`` (:class:`graphnav.nets.network.NetworkCompleter`). This
study scores each fold's saved network (``graphnav eval-beams --folds --save-nets DIR``) on that fold's held-out
A-KIT trajectories through recursive 30-ping outages, for each gamma, against the average estimator. Per-ping
completion (a measured past) is the network's alone whatever gamma is: only outages change.

The rule that chooses gamma: fewest fold cells (fold x beam / velocity RMSE) worse than the average, then the
largest smaller of the two pooled gains. The study also applies the rule leave-one-fold-out (gamma chosen on the
other four folds, scored on the fifth), to show how much of the choice rests on one fold. Usage::

    .venv/bin/python experiments/completer_fade_folds.py --nets out/ens2/akit-residual-aug-ens5 --scenario 2-missing
"""
from __future__ import annotations

import argparse
import json
import sys

import numpy as np

METRICS = ("beam_rmse", "vel_rmse")


def score(nets_dir: str, scenario: str, decays: list[float], akit_dir=None) -> list[dict]:
    """Rows (fold, method, decay, beam_rmse, vel_rmse, n) of every fold's network with each decay and of the
    average estimator, through recursive 30-ping outages of the fold's held-out A-KIT trajectories."""
    from graphnav.nets import crossval
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.evaluate import completion_metrics, outage_rollout
    from graphnav.nets.model import normalize_missing
    from graphnav.nets.network import load_completer

    data = crossval.load_fold_data(akit_dir)
    missing = list(normalize_missing(scenario))
    rows = []
    for i in range(len(data.folds)):
        series = [s for s in data.split(i)[1]["A-KIT"] if len(s.beams) > 7]
        avg = AverageCompleter(AVERAGE_N_PAST[scenario])
        comps = [("average", 1.0, avg)] + [("network", g, load_completer(scenario, directory=f"{nets_dir}/fold{i}",
                                                                          run_decay=g)) for g in decays]
        for method, g, comp in comps:
            full, sigma, samples = outage_rollout(comp, series, missing)
            m = completion_metrics(full, sigma, samples, missing)
            rows.append({"fold": i, "method": method, "decay": g, **{k: m[k] for k in (*METRICS, "n")}})
        print(f"fold {i} {list(data.folds[i])} done", file=sys.stderr, flush=True)
    return rows


def gains(rows: list[dict], decay: float, folds) -> tuple[list[float], dict[int, list[float]]]:
    """Pooled gains (beam, velocity) over ``folds`` and each fold's, of the network with ``decay`` against the
    average (1 - network / average RMSE; positive: the network is better)."""
    net = {r["fold"]: r for r in rows if r["method"] == "network" and r["decay"] == decay and r["fold"] in folds}
    avg = {r["fold"]: r for r in rows if r["method"] == "average" and r["fold"] in folds}
    pooled = [1 - np.sqrt(sum(net[f][m] ** 2 * net[f]["n"] for f in folds) / sum(avg[f][m] ** 2 * avg[f]["n"]
                                                                                 for f in folds)) for m in METRICS]
    return pooled, {f: [1 - net[f][m] / avg[f][m] for m in METRICS] for f in folds}


def choose(rows: list[dict], decays: list[float], folds) -> float:
    """The rule: fewest fold cells worse than the average, then the largest smaller pooled gain."""
    def key(g):
        pooled, per_fold = gains(rows, g, folds)
        return (sum(x < 0 for fg in per_fold.values() for x in fg), -min(pooled))
    return min(decays, key=key)


def report(rows: list[dict], decays: list[float]) -> str:
    folds = sorted({r["fold"] for r in rows})
    lines = ["| gamma | pooled beam / vel | " + " | ".join(f"fold {f}" for f in folds) + " | worse cells |",
             "| --- | --- | " + " | ".join("---" for _ in folds) + " | --- |"]
    for g in decays:
        pooled, per_fold = gains(rows, g, folds)
        worse = sum(x < 0 for fg in per_fold.values() for x in fg)
        lines.append(f"| {g:g} | {100 * pooled[0]:+.1f} / {100 * pooled[1]:+.1f} % | "
                     + " | ".join(f"{100 * per_fold[f][0]:+.1f} / {100 * per_fold[f][1]:+.1f}" for f in folds)
                     + f" | {worse} |")
    chosen = choose(rows, decays, folds)
    lines.append(f"\nchosen on all folds: gamma {chosen:g}")
    nested = []
    for f in folds:
        g = choose(rows, decays, [o for o in folds if o != f])
        fg = gains(rows, g, [f])[1][f]
        nested.append(f"fold {f}: gamma {g:g} -> {100 * fg[0]:+.1f} / {100 * fg[1]:+.1f} %")
    lines.append("chosen without the fold it is scored on: " + "; ".join(nested))
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--nets", required=True, help="fold networks: DIR/<recipe> of graphnav eval-beams --folds --save-nets DIR")
    p.add_argument("--scenario", required=True, choices=["2-missing", "3-missing"])
    p.add_argument("--decays", nargs="+", type=float, default=[1.0, 0.98, 0.95, 0.9, 0.8],
                   help="gammas to score (default 1 0.98 0.95 0.9 0.8)")
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--json", help="also write the rows here")
    a = p.parse_args(argv)
    rows = score(a.nets, a.scenario, a.decays, a.data)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    print(f"{a.scenario}: gain against the average through recursive 30-ping outages, A-KIT held out "
          "(beam / velocity RMSE)")
    print(report(rows, a.decays))
    return 0


if __name__ == "__main__":
    sys.exit(main())
