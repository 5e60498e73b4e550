"""Out-of-fold choice of a completer's fading to the average through an outage (``run_decay``).

Fed its own completions through a recursive outage, the network can walk away from motion it was not trained on,
where the average estimator holds the last beams. With ``run_decay`` gamma the completion at the k-th regressed
ping of a run is ``gamma^k b_net + (1 - gamma^k) b_avg`` (:class:`graphnav.nets.network.NetworkCompleter`). This
study scores each fold's saved network (``graphnav eval-beams --folds --save-nets DIR``) on that fold's held-out
A-KIT trajectories through recursive 30-ping outages, for each gamma, against the average estimator. Per-ping
completion (a measured past) is the network's alone whatever gamma is: only outages change.

The rule that chooses gamma: fewest fold cells (fold x beam / velocity RMSE) worse than the average, then the
largest smaller of the two pooled gains. The study also applies the rule leave-one-fold-out (gamma chosen on the
other four folds, scored on the fifth), to show how much of the choice rests on one fold.

With ``--imu`` the same for the IMU-aware fold networks (``experiments/imu_completer_folds.py --save-nets DIR``,
:class:`graphnav.nets.imu_network.ImuNetworkCompleter` ``run_decay``), scored with each evaluation IMU (recorded,
tactical, MEMS) on that study's pings and outage windows; the rule then counts the worse fold cells over all three.
The sigma coverage through the outages (what ``BeamHistory`` hands on) is printed for no fading and the chosen gamma,
and for the chosen gamma each fold's 90 % interval of its gain when its outage windows are drawn again with
replacement: a fold's outage cell rests on 8-10 windows whose errors are correlated within each window.
Usage::

    .venv/bin/python experiments/completer_fade_folds.py --nets out/ens2/akit-residual-aug-ens5 --scenario 2-missing
    .venv/bin/python experiments/completer_fade_folds.py --imu --nets out/imu_folds/nets2 --scenario 2-missing
"""
from __future__ import annotations

import argparse
import json
import sys

import numpy as np

METRICS = ("beam_rmse", "vel_rmse")


def score(nets_dir: str, scenario: str, decays: list[float], akit_dir=None, spec=None) -> list[dict]:
    """Rows (fold, variant, method, decay, beam_rmse, vel_rmse, n) of every fold's beam-only network with each
    decay and of the average estimator, through recursive 30-ping outages of the fold's held-out A-KIT
    trajectories, their beams made for the DVL ``spec`` (default: the Snapir's; the one the fold networks were trained
    for, ``graphnav eval-beams --folds --config``)."""
    from graphnav.nets import crossval
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.model import normalize_missing
    from graphnav.nets.network import load_completer

    data = crossval.load_fold_data(akit_dir, spec=spec)
    missing = list(normalize_missing(scenario))
    rows = []
    for i in range(len(data.folds)):
        series = [s for s in data.split(i)[1]["A-KIT"] if len(s.beams) > 7]
        comps = [("average", 1.0, AverageCompleter(AVERAGE_N_PAST[scenario]))] + [
            ("network", g, load_completer(scenario, directory=f"{nets_dir}/fold{i}", run_decay=g)) for g in decays]
        rows += _rollouts(comps, series, missing, {"fold": i, "variant": "beam-only"}, spec=data.spec)
        print(f"fold {i} {list(data.folds[i])} done", file=sys.stderr, flush=True)
    return rows


def score_imu(nets_dir: str, scenario: str, decays: list[float], akit_dir=None) -> list[dict]:
    """The same rows for the IMU-aware fold networks (``experiments/imu_completer_folds.py --save-nets DIR``),
    one variant per evaluation IMU (recorded, tactical, MEMS), on the pings and outage windows of that study."""
    from imu_completer_folds import EVAL_GRADES, held_out_series

    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.crossval import AKIT_FOLDS
    from graphnav.nets.imu_evaluate import OUTAGE_SETTLE
    from graphnav.nets.imu_network import load_imu_completer
    from graphnav.nets.model import normalize_missing

    missing = list(normalize_missing(scenario))
    rows = []
    for i, held in enumerate(AKIT_FOLDS):
        comps = [("average", 1.0, AverageCompleter(AVERAGE_N_PAST[scenario]))] + [
            ("network", g, load_imu_completer(scenario, f"{nets_dir}/fold{i}", run_decay=g)) for g in decays]
        spec = comps[-1][2].trained_dvl_spec        # the DVL the fold network was trained for (its card)
        for grade in EVAL_GRADES:
            rows += _rollouts(comps, held_out_series(held, akit_dir, grade, spec), missing,
                              {"fold": i, "variant": f"IMU {grade}"}, settle=OUTAGE_SETTLE, spec=spec)
        print(f"fold {i} {list(held)} done", file=sys.stderr, flush=True)
    return rows


WINDOW = 30     # pings per outage window (outage_rollout's default)


def _rollouts(comps, series, missing, keys: dict, settle: int = 10, spec=None) -> list[dict]:
    """One row per completer; ``window_sq`` keeps each outage window's summed squared beam and velocity errors for
    the interval over windows (:func:`window_interval`); velocities with the DVL ``spec`` (default the Snapir's)."""
    from graphnav.core.config import DvlSpec
    from graphnav.core.dvl import DvlGeometry
    from graphnav.nets.evaluate import completion_metrics, outage_rollout
    geometry = DvlGeometry.from_spec(spec or DvlSpec())
    rows = []
    for method, g, comp in comps:
        full, sigma, samples = outage_rollout(comp, series, missing, window=WINDOW, gap=60, settle=settle)
        m = completion_metrics(full, sigma, samples, missing, geometry)
        rows.append({**keys, "method": method, "decay": g,
                     **{k: m[k] for k in (*METRICS, "within_1sigma", "within_2sigma", "n")},
                     "window_sq": window_sq(full, samples, missing, geometry)})
    return rows


def window_sq(full: np.ndarray, samples, missing, geometry) -> list[list[float]]:
    """Each outage window's summed squared errors of the completed beams ``full`` (beam, velocity) against the
    ``samples`` of :func:`graphnav.nets.evaluate.outage_rollout` (``WINDOW`` pings a window): the unit of evidence
    of :func:`gain_interval`."""
    sq_beam = np.sum((full[:, missing] - samples.beams[:, missing]) ** 2, axis=1)
    sq_vel = np.sum((geometry.velocity_from_beams(full) - samples.v_b) ** 2, axis=1)
    return [sq.reshape(-1, WINDOW).sum(axis=1).tolist() for sq in (sq_beam, sq_vel)]


def window_interval(rows: list[dict], decay: float, fold: int, draws: int = 2000, seed: int = 0
                    ) -> list[tuple[float, float]]:
    """90 % interval of one fold's gain (beam, velocity) against the average when its outage windows are drawn again
    with replacement (the errors within a window are strongly correlated, so a window is the unit of evidence)."""
    net = next(r for r in rows if r["method"] == "network" and r["decay"] == decay and r["fold"] == fold)
    avg = next(r for r in rows if r["method"] == "average" and r["fold"] == fold)
    return gain_interval(net["window_sq"], avg["window_sq"], draws, seed)


def gain_interval(net_sq, avg_sq, draws: int = 2000, seed: int = 0) -> list[tuple[float, float]]:
    """90 % interval of the gain ``1 - sqrt(sum net / sum avg)`` per metric when the windows (``net_sq[j]``,
    ``avg_sq[j]``: each window's summed squared errors of metric j) are drawn again with replacement."""
    rng = np.random.default_rng(seed)
    out = []
    for a, b in zip(net_sq, avg_sq):
        a, b = np.asarray(a), np.asarray(b)
        idx = rng.integers(0, len(a), (draws, len(a)))
        gain = 1 - np.sqrt(a[idx].sum(axis=1) / b[idx].sum(axis=1))
        out.append(tuple(float(x) for x in np.percentile(gain, [5, 95])))
    return out


def gains(rows: list[dict], decay: float, folds) -> tuple[list[float], dict[int, list[float]]]:
    """Pooled gains (beam, velocity) over ``folds`` and each fold's, of the network with ``decay`` against the
    average (1 - network / average RMSE; positive: the network is better), in ``rows`` of one variant."""
    net = {r["fold"]: r for r in rows if r["method"] == "network" and r["decay"] == decay and r["fold"] in folds}
    avg = {r["fold"]: r for r in rows if r["method"] == "average" and r["fold"] in folds}
    pooled = [1 - np.sqrt(sum(net[f][m] ** 2 * net[f]["n"] for f in folds) / sum(avg[f][m] ** 2 * avg[f]["n"]
                                                                                 for f in folds)) for m in METRICS]
    return pooled, {f: [1 - net[f][m] / avg[f][m] for m in METRICS] for f in folds}


def coverage(rows: list[dict], label: str, decay: float) -> str:
    """Pooled (weighted by pings) fractions of filled-beam errors within 1 and 2 sigma of the average (``label``
    "average") or of the network with ``decay``."""
    sel = [r for r in rows if r["method"] == ("average" if label == "average" else "network") and r["decay"] == decay]
    n = np.array([r["n"] for r in sel], float)
    return "{:.3f} / {:.3f}".format(*(float(n @ [r[k] for r in sel] / n.sum()) for k in ("within_1sigma",
                                                                                          "within_2sigma")))


def by_variant(rows: list[dict]) -> dict[str, list[dict]]:
    """``rows`` split by variant (the evaluation IMU of the IMU-aware study; one for the beam-only networks)."""
    return {v: [r for r in rows if r.get("variant", "beam-only") == v]
            for v in dict.fromkeys(r.get("variant", "beam-only") for r in rows)}


def choose(rows: list[dict], decays: list[float], folds) -> float:
    """The rule: fewest fold cells worse than the average (over every variant), then the largest smallest pooled
    gain (over both metrics and every variant)."""
    parts = by_variant(rows).values()

    def key(g):
        scored = [gains(part, g, folds) for part in parts]
        worse = sum(x < 0 for _, per_fold in scored for fg in per_fold.values() for x in fg)
        return (worse, -min(min(pooled) for pooled, _ in scored))
    return min(decays, key=key)


def report(rows: list[dict], decays: list[float]) -> str:
    folds = sorted({r["fold"] for r in rows})
    lines = ["| variant | gamma | pooled beam / vel | " + " | ".join(f"fold {f}" for f in folds) + " | worse cells |",
             "| --- | --- | --- | " + " | ".join("---" for _ in folds) + " | --- |"]
    for variant, part in by_variant(rows).items():
        for g in decays:
            pooled, per_fold = gains(part, g, folds)
            worse = sum(x < 0 for fg in per_fold.values() for x in fg)
            lines.append(f"| {variant} | {g:g} | {100 * pooled[0]:+.1f} / {100 * pooled[1]:+.1f} % | "
                         + " | ".join(f"{100 * per_fold[f][0]:+.1f} / {100 * per_fold[f][1]:+.1f}" for f in folds)
                         + f" | {worse} |")
    chosen = choose(rows, decays, folds)
    lines.append(f"\nchosen on all folds: gamma {chosen:g}")
    intervals = []
    for variant, part in by_variant(rows).items():
        cells = []
        for f in folds:
            (b0, b1), (v0, v1) = window_interval(part, chosen, f)
            n_windows = len(next(r for r in part if r["fold"] == f)["window_sq"][0])
            cells.append(f"fold {f} ({n_windows} windows) {100 * b0:+.0f}..{100 * b1:+.0f} / "
                         f"{100 * v0:+.0f}..{100 * v1:+.0f}")
        intervals.append(f"{variant}: " + "; ".join(cells))
    lines.append(f"90 % interval of each fold's gain with gamma {chosen:g} over its outage windows drawn again "
                 "(beam / velocity, %):\n" + "\n".join(intervals))
    if 1.0 in decays:
        lines.append("sigma coverage through the outages, pooled within 1 / 2 sigma (Gaussian 0.683 / 0.954; the "
                     "sigma BeamHistory hands on): " + "; ".join(
                         f"{v} " + ", ".join(f"{m} {coverage(part, m, g)}" for m, g in
                                             (("average", 1.0), ("gamma 1", 1.0), (f"gamma {chosen:g}", chosen)))
                         for v, part in by_variant(rows).items()))
    nested = []
    for f in folds:
        g = choose(rows, decays, [o for o in folds if o != f])
        cells = ", ".join(f"{v} " + "{:+.1f} / {:+.1f} %".format(*(100 * x for x in gains(part, g, [f])[1][f]))
                          for v, part in by_variant(rows).items())
        nested.append(f"fold {f}: gamma {g:g} -> {cells}")
    lines.append("chosen without the fold it is scored on:\n" + "\n".join(nested))
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--nets", required=True, help="fold networks: DIR/<recipe> of graphnav eval-beams --folds "
                   "--save-nets DIR (with --imu: DIR of experiments/imu_completer_folds.py --save-nets DIR)")
    p.add_argument("--imu", action="store_true", help="the IMU-aware fold networks, scored with each evaluation "
                   "IMU (recorded, tactical, MEMS)")
    p.add_argument("--scenario", required=True, choices=["2-missing", "3-missing"])
    p.add_argument("--decays", nargs="+", type=float, default=[1.0, 0.98, 0.95, 0.9, 0.8],
                   help="gammas to score (default 1 0.98 0.95 0.9 0.8)")
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--json", help="also write the rows here")
    p.add_argument("--config", metavar="JSON", help="beam-only: the DVL of this sensor configuration, the one the fold "
                   "networks were trained for (graphnav eval-beams --folds --config JSON --save-nets DIR)")
    a = p.parse_args(argv)
    if a.config and a.imu:
        p.error("--config goes with the beam-only fold networks (the IMU-aware ones are scored on the DVL their model "
                "cards record)")
    if a.imu:
        rows = score_imu(a.nets, a.scenario, a.decays, a.data)
    else:
        from graphnav.commands.common import config_dvl
        rows = score(a.nets, a.scenario, a.decays, a.data, config_dvl(a.config))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    print(f"{a.scenario}: gain against the average through recursive 30-ping outages, A-KIT held out "
          f"(beam / velocity RMSE){', IMU-aware networks' if a.imu else ''}")
    print(report(rows, a.decays))
    return 0


if __name__ == "__main__":
    sys.exit(main())
