"""How much of a missing beam the past beams predict at all: the best linear completer out of fold.

With 2 missing beams (0 and 2, an opposite pair of the Janus head) the two measured beams fix the vertical and the
across-pair horizontal velocity; the along-pair horizontal component has to come from the past. This study fits,
per leave-trajectories-out fold (:data:`graphnav.nets.crossval.AKIT_FOLDS`), a ridge regression of the missing beams
on the last ``N`` full beam vectors and this ping's measured beams (as a change from the average of the last
``AVERAGE_N_PAST`` pings, the residual form the networks use) on the other folds' A-KIT pings, and scores it per
ping on the held-out pair against the average estimator: the velocity gain a linear completer can reach, beside
the averages over other windows and, with ``--nets``, the fold networks. Velocity error is least squares over the
completed beams against the true DVL velocity; every completer is scored on the same pings (those with ``max(N)``
past pings). Usage::

    .venv/bin/python experiments/linear_completer_folds.py --scenario 2-missing --nets out/ens2/akit-residual-aug-ens5
"""
from __future__ import annotations

import argparse
import sys

import numpy as np


def features(samples, n_past: int, n_avg: int, kept) -> tuple[np.ndarray, np.ndarray]:
    """(X, base): the last ``n_past`` beam vectors and the measured beams, minus ``base`` (the average of the last
    ``n_avg`` pings), and a constant."""
    past = samples.past[:, -n_past:, :]
    base = samples.past[:, -n_avg:, :].mean(axis=1)
    X = np.hstack([(past - base[:, None, :]).reshape(len(past), -1), samples.beams[:, kept] - base[:, kept],
                   np.ones((len(past), 1))])
    return X, base


def vel_rmse(full: np.ndarray, samples, geometry) -> float:
    return float(np.sqrt(np.mean(np.sum((geometry.velocity_from_beams(full) - samples.v_b) ** 2, axis=1))))


def study(scenario: str, windows_n: list[int], ridge: float, nets: str | None, akit_dir=None) -> dict:
    """Per method, the held-out velocity squared errors' sums and counts per fold (pooled = sum / count)."""
    from graphnav.core.config import DvlSpec
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets import crossval
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.data import windows
    from graphnav.nets.evaluate import predict_completer
    from graphnav.nets.model import normalize_missing
    from graphnav.nets.network import load_completer

    geometry = DvlGeometry.from_spec(DvlSpec())
    missing = list(normalize_missing(scenario))
    kept = [b for b in range(4) if b not in missing]
    n_avg = AVERAGE_N_PAST[scenario]
    longest = max([*windows_n, n_avg, 10])
    data = crossval.load_fold_data(akit_dir)
    held = {i: windows([s for s in data.split(i)[1]["A-KIT"] if len(s.beams) > longest + 2], longest)
            for i in range(len(data.folds))}
    out: dict[str, dict[int, tuple[float, int]]] = {}

    def put(name, i, full):
        out.setdefault(name, {})[i] = (vel_rmse(full, held[i], geometry) ** 2 * len(full), len(full))

    for i, samples in held.items():
        for n in sorted({1, 2, n_avg, 5, 10}):
            full, _ = predict_completer(AverageCompleter(n), samples, missing)
            put(f"average N = {n}" + (" (the baseline)" if n == n_avg else ""), i, full)
        for n in windows_n:
            train = [held[j] for j in held if j != i]
            X = np.vstack([features(s, n, n_avg, kept)[0] for s in train])
            Y = np.vstack([s.beams[:, missing] - features(s, n, n_avg, kept)[1][:, missing] for s in train])
            W = np.linalg.solve(X.T @ X + ridge * len(X) * np.eye(X.shape[1]), X.T @ Y)
            Xt, base = features(samples, n, n_avg, kept)
            full = samples.beams.copy()
            full[:, missing] = base[:, missing] + Xt @ W
            put(f"linear, N = {n}", i, full)
        if nets:
            full, _ = predict_completer(load_completer(scenario, directory=f"{nets}/fold{i}", run_decay=1.0),
                                        samples, missing)
            put("fold network", i, full)
        put("all four beams measured", i, samples.beams)
        print(f"fold {i} {list(data.folds[i])} done", file=sys.stderr, flush=True)
    return out


def report(out: dict, baseline: str) -> str:
    folds = sorted(next(iter(out.values())))
    base = out[baseline]
    lines = ["| completer | vel RMSE m/s | gain pooled | " + " | ".join(f"fold {f}" for f in folds) + " |",
             "| --- | --- | --- | " + " | ".join("---" for _ in folds) + " |"]
    b_pool = np.sqrt(sum(s for s, _ in base.values()) / sum(n for _, n in base.values()))
    for name, per in out.items():
        pool = np.sqrt(sum(s for s, _ in per.values()) / sum(n for _, n in per.values()))
        cells = [f"{100 * (1 - np.sqrt(per[f][0] / per[f][1]) / np.sqrt(base[f][0] / base[f][1])):+.1f}"
                 for f in folds]
        lines.append(f"| {name} | {pool:.4f} | {100 * (1 - pool / b_pool):+.1f} % | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenario", default="2-missing", choices=["2-missing", "3-missing"])
    p.add_argument("--windows", nargs="+", type=int, default=[3, 5, 10], help="past pings of the linear completer")
    p.add_argument("--ridge", type=float, default=1e-4, help="ridge weight per sample (default 1e-4)")
    p.add_argument("--nets", help="also the fold networks: DIR/<recipe> of graphnav eval-beams --folds --save-nets")
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    a = p.parse_args(argv)
    import warnings
    warnings.simplefilter("ignore", UserWarning)   # the loader's axis-convention notes, once per trajectory
    from graphnav.nets.average import AVERAGE_N_PAST
    out = study(a.scenario, a.windows, a.ridge, a.nets, a.data)
    print(f"{a.scenario}, per ping, A-KIT held out: velocity RMSE and gain against the average "
          f"(N = {AVERAGE_N_PAST[a.scenario]})")
    print(report(out, f"average N = {AVERAGE_N_PAST[a.scenario]} (the baseline)"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
