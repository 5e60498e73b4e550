"""The pivot completer against the average estimator, out of fold (docs/decisions/completers.md, "A completer that
models the turn").

:class:`graphnav.nets.pivot.PivotCompleter` holds the past beams as the average estimator does, with the sway a
turning hull makes about its pivot point taken out of them and the ping's own put back from the gyro. Its one
number, the pivot length ``L``, is fitted per leave-trajectories-out fold (``nets.crossval.AKIT_FOLDS``) on the other
four folds' trajectories (:func:`graphnav.nets.pivot.fit_pivot_length`), and scored on the fold's held-out pair:

- **per ping**: at every ping with the true past beams, the scenario's beams completed;
- **through outages**: every placement (a start every ``--stride`` pings after the first minute) of a recursive
  outage of ``--outage`` pings, each completion going back into the history as in the estimators.

Both completers use the average estimator's N of the scenario (:data:`graphnav.nets.average.AVERAGE_N_PAST`) and
the same IMU grade copies as the regime table (``prepared_mission``: recorded, tactical, MEMS). Printed: the gain
against the average, ``1 - pivot / average`` of the beam and the velocity RMSE (velocity: the least-squares DVL
velocity of the four beams), pooled over the ten trajectories and in the worst fold, and the fold's ``L``. Usage::

    .venv/bin/python experiments/pivot_completer_folds.py --out out/pivot/completer.json
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

SCENARIOS = ("2-missing", "3-missing", "0-beams")
GRADES = ("as-recorded", "tactical", "mems")


def completions(completer, mission, missing, starts, length: int, fits=None) -> tuple[np.ndarray, np.ndarray]:
    """(completed, true) beams (K, 4) m/s of ``completer`` through recursive outages of ``length`` pings from the
    ping indices ``starts``, the ``missing`` beams (0-based) completed; each outage starts from the true past.
    ``fits``: per ping index, the online fit's ``(num, den)`` over the measured pings before it (an online
    :class:`~graphnav.nets.pivot.PivotCompleter` then starts each outage with the fit it would have there)."""
    from graphnav.nets.imu_window import imu_window_at
    beams = mission.dvl.beams
    n = completer.n_past
    got, true = [], []
    for s in starts:
        if fits is not None:
            completer.fit.num, completer.fit.den = fits[s]
        past = beams[s - n:s].copy()
        for k in range(s, s + length):
            measured = beams[k].copy()
            measured[list(missing)] = np.nan
            imu = imu_window_at(mission.imu, mission.dvl.t[k], completer.imu_samples) \
                if getattr(completer, "needs_imu", False) else None
            if fits is not None:
                completer.fit.num, completer.fit.den = fits[s]     # the fit does not move within an outage
            full, _ = (completer.complete(past, measured, imu=imu) if getattr(completer, "needs_imu", False)
                       else completer.complete(past, measured))
            got.append(full)
            true.append(beams[k])
            past = np.vstack([past[1:], full])
    return np.array(got), np.array(true)


def online_fits(mission, geometry, n_past: int) -> list[tuple[float, float]]:
    """Per ping index, :class:`~graphnav.nets.pivot.PivotFit`'s ``(num, den)`` over the mission's measured pings before
    it, as an online :class:`~graphnav.nets.pivot.PivotCompleter` has them at an outage starting there."""
    from graphnav.nets.pivot import PivotFit, measured_series
    beams, rates, usable = measured_series(mission)
    fit = PivotFit(geometry.T_b, geometry.lever_arm_b, n_past)
    out = []
    for k, t in enumerate(mission.dvl.t):
        out.append((fit.num, fit.den))
        if usable[k]:
            fit.add(t, beams[k], rates[k])
        else:
            fit.break_run()
    return out


def trajectory_rows(source, grade: str, pivot_m: float, stride: int, outage: int, priors=()) -> dict:
    """Summed squared beam and velocity errors (and counts) of the average and the pivot completer on one trajectory,
    per scenario and kind (per ping, outage)."""
    from graphnav.core.dvl import DvlGeometry
    from graphnav.core.scenarios import SCENARIOS as PATTERNS
    from graphnav.evaluation.bench.cases import prepared_mission
    from graphnav.evaluation.methods import pivot_completer
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    mission = prepared_mission(source, grade)
    geometry = DvlGeometry.from_spec(mission.config.dvl)
    T_pinv = np.linalg.pinv(geometry.T_b)
    usable = mission.dvl.valid.all(axis=1)
    n_pings = len(mission.dvl.t)
    rows = {}
    for scenario in SCENARIOS:
        n = AVERAGE_N_PAST[scenario]
        noise = mission.config.dvl.beam_noise_std
        members = {"average": AverageCompleter(n_past=n, noise_std=noise),
                   "pivot": pivot_completer(scenario, mission.config, pivot_m=pivot_m)}
        for prior in priors:
            members[f"online {prior:g}"] = pivot_completer(scenario, mission.config, prior_turn=prior)
        fits = online_fits(mission, geometry, n) if priors else None
        first = 60      # the first minute settles (the IMU window needs its seconds too)
        for kind, length, step in (("per ping", 1, 1), ("outage", outage, stride)):
            starts = [s for s in range(first, n_pings - length + 1, step) if usable[s - n:s + length].all()]
            for name, completer in members.items():
                got, true = completions(completer, mission, PATTERNS[scenario], starts, length,
                                        fits if name.startswith("online") else None)
                err = got - true
                rows[f"{scenario}|{kind}|{name}"] = [float((err ** 2).sum()), float(((err @ T_pinv.T) ** 2).sum()),
                                                     int(err.shape[0])]
            for name, completer in members.items():
                if getattr(completer, "usage", {}).get("no_imu"):
                    warnings.warn(f"{source.name} {grade} {scenario} {name}: {completer.usage['no_imu']} pings "
                                  "without an IMU window (completed by the average)", RuntimeWarning, stacklevel=2)
    return rows


def gains(results: dict, folds, grade: str, scenario: str, kind: str, member: str = "pivot"
          ) -> tuple[list[float], list[list[float]]]:
    """Pooled (beam, velocity) gain of a pivot completer (``member``) against the average, and per fold."""
    def pooled(names):
        sums = {m: np.zeros(2) for m in ("average", member)}
        for name in names:
            for m in sums:
                sums[m] += np.array(results[name][grade][f"{scenario}|{kind}|{m}"][:2])
        return list(1.0 - np.sqrt(sums[member] / sums["average"]))
    per_fold = [pooled([f"Trajectory{k}" for k in pair]) for pair in folds]
    return pooled([f"Trajectory{k}" for pair in folds for k in pair]), per_fold


def report(saved: dict) -> str:
    from graphnav.nets.crossval import AKIT_FOLDS
    results = saved["results"]
    lines = [f"pivot length per fold (fitted on the other folds), m: "
             + ", ".join(f"{x:.2f}" for x in saved["pivot_m"]) + f"; outages of {saved['outage']} pings, a start "
             f"every {saved['stride']}",
             "", "gain against the average, beam / velocity RMSE, pooled (worst fold)", "",
             "| completer | scenario | eval IMU | per ping | outage |", "| --- | --- | --- | --- | --- |"]
    members = ["pivot"] + [f"online {p:g}" for p in saved.get("priors", [])]
    for member, scenario, grade in [(m, s, g) for m in members for s in SCENARIOS for g in GRADES]:
        if True:
            cells = []
            for kind in ("per ping", "outage"):
                try:
                    pooled, per_fold = gains(results, AKIT_FOLDS, grade, scenario, kind, member)
                except KeyError:
                    cells.append("-")
                    continue
                worst = np.min(np.array(per_fold), axis=0)
                cells.append(f"{100 * pooled[0]:+.1f} / {100 * pooled[1]:+.1f} % "
                             f"({100 * worst[0]:+.1f} / {100 * worst[1]:+.1f})")
            if cells != ["-", "-"]:
                lines.append(f"| {member} | {scenario} | {grade} | " + " | ".join(cells) + " |")
    if saved.get("priors"):
        folds = range(len(AKIT_FOLDS))
        lines += ["", "prior_turn: fold cells worse than the average, smallest pooled gain (all folds): " + "; ".join(
            f"{p:g}: {w}, {100 * g:+.1f} %" for p, (w, g) in prior_scores(saved, folds).items())]
        prior, worse, smallest = prior_rule(saved, folds)
        lines += [f"prior_turn chosen on all folds: {prior:g} ({worse} fold cells worse than the average, smallest "
                  f"pooled gain {100 * smallest:+.1f} %)"]
        for f in folds:
            prior, _, _ = prior_rule(saved, [g for g in folds if g != f])
            cells = [gain for scenario in SCENARIOS for grade in GRADES for kind in ("per ping", "outage")
                     if f"{scenario}|{kind}|online {prior:g}" in saved["results"]["Trajectory1"].get(grade, {})
                     for gain in gains(saved["results"], [AKIT_FOLDS[f]], grade, scenario, kind,
                                       f"online {prior:g}")[0]]
            lines.append(f"without fold {f}: {prior:g}; fold {f} with it: smallest gain {100 * min(cells):+.1f} %, "
                         f"{sum(c < 0 for c in cells)} of {len(cells)} cells worse than the average")
    return "\n".join(lines)


def prior_scores(saved: dict, folds) -> dict[float, tuple[int, float]]:
    """Per ``prior_turn`` of the online completer, on ``folds`` (indices into ``AKIT_FOLDS``): the fold cells
    (scenario x IMU x per ping / outage x beam / velocity) worse than the average, and the smallest pooled gain."""
    from graphnav.nets.crossval import AKIT_FOLDS
    chosen = [AKIT_FOLDS[f] for f in folds]
    grades = [g for g in GRADES if g in next(iter(saved["results"].values()))]
    scores = {}
    for prior in saved["priors"]:
        worse, smallest = 0, np.inf
        for scenario in SCENARIOS:
            for grade in grades:
                for kind in ("per ping", "outage"):
                    pooled, per_fold = gains(saved["results"], chosen, grade, scenario, kind, f"online {prior:g}")
                    worse += int((np.array(per_fold) < 0).sum())
                    smallest = min(smallest, *pooled)
        scores[prior] = (worse, smallest)
    return scores


def prior_rule(saved: dict, folds) -> tuple[float, int, float]:
    """The ``prior_turn`` the rule picks on ``folds``: the fewest fold cells worse than the average, then the largest
    smallest pooled gain (:func:`prior_scores`); ``(prior, cells worse, smallest pooled gain)``."""
    scores = prior_scores(saved, folds)
    prior = min(scores, key=lambda p: (scores[p][0], -scores[p][1], p))
    return prior, *scores[prior]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--outage", type=int, default=30, help="outage length, pings (default 30)")
    p.add_argument("--stride", type=int, default=5, help="pings between outage starts (default 5)")
    p.add_argument("--grades", nargs="+", default=list(GRADES), choices=GRADES, help="IMU copies scored")
    p.add_argument("--priors", nargs="*", type=float, default=[], help="also the online completer (L fitted over "
                   "the trajectory's measured pings before each outage) with these prior_turn values ((rad/s)^2)")
    p.add_argument("--out", help="results (JSON)")
    p.add_argument("--report", help="print the table of a results file and stop")
    a = p.parse_args(argv)
    if a.report:
        print(report(json.loads(Path(a.report).read_text())))
        return 0
    warnings.simplefilter("ignore", UserWarning)    # the loaders' axis-convention notes, one per trajectory
    sys.path.insert(0, str(Path(__file__).parent))
    from oracle_completions import fold_pivot_lengths

    from graphnav.evaluation.bench import find_trajectories
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.crossval import AKIT_FOLDS
    sources = {s.name: s for s in find_trajectories(str(akit_trajectories(a.data)[0].parent))}
    pivots = fold_pivot_lengths(sources, AKIT_FOLDS)
    results: dict = {}
    for f, pair in enumerate(AKIT_FOLDS):
        for k in pair:
            name = f"Trajectory{k}"
            results[name] = {g: trajectory_rows(sources[name], g, pivots[f], a.stride, a.outage, a.priors)
                             for g in a.grades}
            print(f"{name} done", file=sys.stderr, flush=True)
    saved = {"pivot_m": pivots, "outage": a.outage, "stride": a.stride, "priors": a.priors, "results": results}
    if a.out:
        Path(a.out).parent.mkdir(parents=True, exist_ok=True)
        Path(a.out).write_text(json.dumps(saved))
    print(report(saved))
    return 0


if __name__ == "__main__":
    sys.exit(main())
