"""The pivot completer against the average estimator, out of fold (docs/decisions/completers.md, "A completer that
models the turn", "The hull's heave in pitch").

:class:`graphnav.nets.pivot.PivotCompleter` holds the past beams as the average estimator does, with the sway a
turning hull makes about its pivot point taken out of them and the ping's own put back from the gyro. Its pivot
length ``L`` is fitted per leave-trajectories-out fold (``nets.crossval.AKIT_FOLDS``) on the other four folds'
trajectories (:func:`graphnav.nets.pivot.fit_pivot_length`), or online over the held-out trajectory's own measured
pings before each outage (``--priors``), and scored on the fold's held-out pair:

- **per ping**: at every ping with the true past beams, the scenario's beams completed;
- **through outages**: every placement (a start every ``--stride`` pings after the first minute, ``--first``) of a
  recursive outage of ``--outage`` pings, each completion going back into the history as in the estimators.

``--pitch`` adds the completer that models the hull's heave from the pitch rate too (``L_q``; ``pivot+pitch`` with
both lengths fitted on the other folds, ``online+pitch P`` online). The average holds the paper's N of the scenario
(:data:`graphnav.nets.average.AVERAGE_N_PAST`); the pivot completers the same, or ``--pivot-n-past`` N (``default``:
the completer's own, :data:`graphnav.nets.pivot.DEFAULT_N_PAST`), and ``--choose-n-past`` chooses it over the files
of several. Each IMU grade copy of the regime table is scored (``prepared_mission``: recorded, tactical, MEMS).
Printed: the gain against the average, ``1 - pivot / average`` of the beam and the velocity RMSE (velocity: the
least-squares DVL velocity of the four beams), pooled over the ten trajectories and in the worst fold, the folds'
lengths, and the ``prior_turn`` the rule picks. Usage::

    .venv/bin/python experiments/pivot_completer_folds.py --priors 0.1 --pitch --pivot-n-past default \\
        --out out/pivot/shipped.json
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


def online_fits(mission, geometry, n_past: int, axes: tuple[str, ...]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per ping index, :class:`~graphnav.nets.pivot.PivotFit`'s ``(num, den)`` over the mission's measured pings before
    it, as an online :class:`~graphnav.nets.pivot.PivotCompleter` of the turn ``axes`` has them at an outage starting
    there."""
    from graphnav.nets.pivot import PivotFit, measured_series
    beams, rates, usable = measured_series(mission)
    fit = PivotFit(geometry.T_b, geometry.lever_arm_b, n_past, ping_dt=1.0 / mission.config.dvl.rate_hz, axes=axes)
    out = []
    for k, t in enumerate(mission.dvl.t):
        out.append((fit.num.copy(), fit.den.copy()))
        if usable[k]:
            fit.add(t, beams[k], rates[k])
        else:
            fit.break_run()
    return out


#: The pivot completer's turn models: a member name's suffix and the turn axes it models.
MODELS = {"": ("yaw",), "+pitch": ("yaw", "pitch")}


def trajectory_rows(source, grade: str, pivot_m: float, stride: int, outage: int, priors=(),
                    pitch_pivots=None, pivot_n: int | str | None = None, first: int = 60) -> dict:
    """Summed squared beam and velocity errors (and counts) of the average and the pivot completer on one trajectory,
    per scenario and kind (per ping, outage). Members: ``pivot`` (the yaw length ``pivot_m`` alone), ``online P``
    (the yaw fitted online with ``prior_turn`` P) and, with ``pitch_pivots`` (the fold's ``(L, L_q)``),
    ``pivot+pitch`` and ``online+pitch P``: the heave from the pitch rate modelled too. ``pivot_n``: the past pings
    the pivot completers hold (default: the average's N; ``"default"``: the completer's own per scenario,
    :data:`graphnav.nets.pivot.DEFAULT_N_PAST`; every completer is scored on the same pings). Outages start from
    ping ``first`` on."""
    from graphnav.core.dvl import DvlGeometry
    from graphnav.core.scenarios import SCENARIOS as PATTERNS
    from graphnav.evaluation.bench.cases import prepared_mission
    from graphnav.evaluation.methods import pivot_completer
    from graphnav.nets.average import AVERAGE_N_PAST, AverageCompleter
    from graphnav.nets.pivot import DEFAULT_N_PAST
    mission = prepared_mission(source, grade)
    geometry = DvlGeometry.from_spec(mission.config.dvl)
    T_pinv = np.linalg.pinv(geometry.T_b)
    usable = mission.dvl.valid.all(axis=1)
    n_pings = len(mission.dvl.t)
    rows = {}
    for scenario in SCENARIOS:
        n = AVERAGE_N_PAST[scenario]
        held = DEFAULT_N_PAST[scenario] if pivot_n == "default" else pivot_n or n
        noise = mission.config.dvl.beam_noise_std
        members = {"average": AverageCompleter(n_past=n, noise_std=noise),
                   "pivot": pivot_completer(scenario, mission.config, pivot_m=pivot_m, n_past=held)}
        models = {suffix: axes for suffix, axes in MODELS.items() if pitch_pivots is not None or suffix == ""}
        if pitch_pivots is not None:
            members["pivot+pitch"] = pivot_completer(scenario, mission.config, pivot_m=pitch_pivots[0],
                                                     pitch_pivot_m=pitch_pivots[1], n_past=held)
        for suffix, axes in models.items():
            for prior in priors:
                members[f"online{suffix} {prior:g}"] = pivot_completer(scenario, mission.config, prior_turn=prior,
                                                                       axes=axes, n_past=held)
        fits = ({suffix: online_fits(mission, geometry, held, axes) for suffix, axes in models.items()} if priors
                else {})
        for kind, length, step in (("per ping", 1, 1), ("outage", outage, stride)):
            starts = [s for s in range(max(first, n, held), n_pings - length + 1, step)
                      if usable[s - max(n, held):s + length].all()]
            for name, completer in members.items():
                got, true = completions(completer, mission, PATTERNS[scenario], starts, length,
                                        fits[name.split()[0][len("online"):]] if name.startswith("online") else None)
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
    hold = saved.get("pivot_n_past")
    lines = [f"pivot length per fold (fitted on the other folds), m: "
             + ", ".join(f"{x:.2f}" for x in saved["pivot_m"]) + f"; outages of {saved['outage']} pings, a start "
             f"every {saved['stride']} from ping {saved.get('first', 60)}; the pivot completers hold "
             + ("the average's N" if hold is None else "their own N per scenario" if hold == "default"
                else f"{hold} past pings"),
             "", "gain against the average, beam / velocity RMSE, pooled (worst fold)", "",
             "| completer | scenario | eval IMU | per ping | outage |", "| --- | --- | --- | --- | --- |"]
    suffixes = list(MODELS) if saved.get("pitch_pivots") else [""]
    members = [f"pivot{x}" for x in suffixes] + [
        f"online{x} {p:g}" for x in suffixes for p in saved.get("priors", [])]
    if saved.get("pitch_pivots"):
        lines[0:0] = ["pivot lengths (yaw, pitch) per fold, m: " + ", ".join(
            f"({a:.2f}, {b:.2f})" for a, b in saved["pitch_pivots"])]
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
        for suffix in suffixes:
            model = "+".join(MODELS[suffix])
            lines += ["", f"prior_turn of the {model} model: fold cells worse than the average, smallest pooled gain "
                      "(all folds): " + "; ".join(f"{p:g}: {w}, {100 * g:+.1f} %"
                                                  for p, (w, g) in prior_scores(saved, folds, suffix).items())]
            prior, worse, smallest = prior_rule(saved, folds, suffix)
            lines += [f"prior_turn chosen on all folds: {prior:g} ({worse} fold cells worse than the average, "
                      f"smallest pooled gain {100 * smallest:+.1f} %)"]
            # a fold's cells: every scenario, IMU copy scored, per ping / outage and beam / velocity
            n_cells = len(SCENARIOS) * len(next(iter(results.values()))) * 2 * 2
            for f in folds:
                prior, _, _ = prior_rule(saved, [g for g in folds if g != f], suffix)
                worse, smallest = member_scores(saved, [f], f"online{suffix} {prior:g}")
                lines.append(f"without fold {f}: {prior:g}; fold {f} with it: smallest gain {100 * smallest:+.1f} "
                             f"%, {worse} of {n_cells} cells worse than the average")
    return "\n".join(lines)


def member_scores(saved: dict, folds, member: str, scenarios=SCENARIOS) -> tuple[int, float]:
    """The fold cells (scenario x IMU x per ping / outage x beam / velocity) of ``member`` worse than the average on
    ``folds`` (indices into ``AKIT_FOLDS``) in ``scenarios``, and its smallest pooled gain there."""
    from graphnav.nets.crossval import AKIT_FOLDS
    chosen = [AKIT_FOLDS[f] for f in folds]
    grades = [g for g in GRADES if g in next(iter(saved["results"].values()))]
    worse, smallest = 0, np.inf
    for scenario in scenarios:
        for grade in grades:
            for kind in ("per ping", "outage"):
                pooled, per_fold = gains(saved["results"], chosen, grade, scenario, kind, member)
                worse += int((np.array(per_fold) < 0).sum())
                smallest = min(smallest, *pooled)
    return worse, smallest


def rule_pick(scores: dict):
    """The candidate the completer rule picks from ``scores`` (candidate -> (fold cells worse than the average,
    smallest pooled gain)): the fewest cells worse, then the largest smallest gain, then the smaller candidate."""
    return min(scores, key=lambda c: (scores[c][0], -scores[c][1], c))


def prior_scores(saved: dict, folds, suffix: str = "") -> dict[float, tuple[int, float]]:
    """Per ``prior_turn`` of the online completer of the model ``suffix`` (:data:`MODELS`), on ``folds`` (indices
    into ``AKIT_FOLDS``): :func:`member_scores` over every scenario."""
    return {prior: member_scores(saved, folds, f"online{suffix} {prior:g}") for prior in saved["priors"]}


def prior_rule(saved: dict, folds, suffix: str = "") -> tuple[float, int, float]:
    """The ``prior_turn`` the rule picks on ``folds`` (:func:`rule_pick` of :func:`prior_scores`); ``(prior, cells
    worse, smallest pooled gain)``."""
    scores = prior_scores(saved, folds, suffix)
    prior = rule_pick(scores)
    return prior, *scores[prior]


def choose_n_past(files: list[str], member: str) -> str:
    """The pivot completer's hold (``--pivot-n-past``) chosen per scenario over the results ``files`` of one run per
    hold, by the completer rule (:func:`rule_pick`: then the shorter hold) on all folds and with each fold left out;
    the text of the choice."""
    from graphnav.nets.average import AVERAGE_N_PAST
    from graphnav.nets.crossval import AKIT_FOLDS
    runs, same = {}, None
    for name in files:
        saved = json.loads(Path(name).read_text())
        if saved.get("pivot_n_past") == "default":
            raise SystemExit(f"--choose-n-past: {name} was run with the completer's own holds ('default'); give "
                             "files of one --pivot-n-past number each (or none: the average's N)")
        # the files must differ in the hold alone
        setting = {k: saved.get(k) for k in ("outage", "stride", "priors", "pitch_pivots")}
        setting["first"] = saved.get("first", 60)
        first_rows = next(iter(saved["results"].values()))
        setting["grades"] = sorted(first_rows)
        if same is not None and setting != same[1]:
            differ = ", ".join(f"{k} {setting[k]} against {same[1][k]}" for k in setting if setting[k] != same[1][k])
            raise SystemExit(f"--choose-n-past: {name} differs from {same[0]} in more than the hold: {differ}")
        if not any(key.endswith(f"|{member}") for rows in first_rows.values() for key in rows):
            raise SystemExit(f"--choose-n-past: {name} holds no member '{member}' (run it with --pitch and --priors)")
        same = same or (name, setting)
        runs[name] = saved
    folds = list(range(len(AKIT_FOLDS)))
    lines = [f"the pivot completer's hold chosen per scenario, member '{member}': fold cells worse than the average, "
             "smallest pooled gain"]
    for scenario in SCENARIOS:
        held = {}
        for name, saved in runs.items():
            n = saved.get("pivot_n_past") or AVERAGE_N_PAST[scenario]
            if n in held:
                raise SystemExit(f"--choose-n-past: two files hold {n} past pings with {scenario}: {held[n][0]} and "
                                 f"{name} (a file run without --pivot-n-past holds the average's N)")
            held[n] = (name, saved)
        held = {n: saved for n, (_, saved) in held.items()}
        scores = {n: member_scores(saved, folds, member, [scenario]) for n, saved in sorted(held.items())}
        pick = rule_pick(scores)
        lines.append(f"{scenario}: " + "; ".join(f"N {n}: {w}, {100 * g:+.1f} %" for n, (w, g) in scores.items())
                     + f" -> N {pick}")
        for f in folds:
            rest = [g for g in folds if g != f]
            n_f = rule_pick({n: member_scores(saved, rest, member, [scenario]) for n, saved in held.items()})
            worse, smallest = member_scores(held[n_f], [f], member, [scenario])
            lines.append(f"  without fold {f}: N {n_f}; fold {f} with it: smallest gain {100 * smallest:+.1f} %, "
                         f"{worse} cells worse than the average")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="A-KIT folder (default: the shared data, graphnav.io.paths)")
    p.add_argument("--outage", type=int, default=30, help="outage length, pings (default 30)")
    p.add_argument("--stride", type=int, default=5, help="pings between outage starts (default 5)")
    p.add_argument("--first", type=int, default=60, help="the first ping an outage may start at (default 60: the "
                   "first minute settles; with --stride 90, 25 lays the outages out as the network studies do)")
    p.add_argument("--grades", nargs="+", default=list(GRADES), choices=GRADES, help="IMU copies scored")
    p.add_argument("--priors", nargs="*", type=float, default=[], help="also the online completer (L fitted over "
                   "the trajectory's measured pings before each outage) with these prior_turn values ((rad/s)^2)")
    p.add_argument("--pivot-n-past", metavar="N", help="the past pings the pivot completers hold: a number, or "
                   "'default' for the completer's own per scenario (nets.pivot.DEFAULT_N_PAST; default: the average "
                   "estimator's N of each scenario, which the average keeps)")
    p.add_argument("--pitch", action="store_true", help="also the completer with the heave from the pitch rate "
                   "(its yaw and pitch lengths fitted per fold, and online with each of --priors)")
    p.add_argument("--out", help="results (JSON)")
    p.add_argument("--report", help="print the table of a results file and stop")
    p.add_argument("--choose-n-past", nargs="+", metavar="FILE", help="run nothing: choose the pivot completer's "
                   "hold per scenario over results files of one --pivot-n-past each (the member --member)")
    p.add_argument("--member", default="online+pitch 0.1", help="the completer --choose-n-past chooses for "
                   "(default: online+pitch 0.1)")
    a = p.parse_args(argv)
    if a.first < 1:
        p.error(f"--first: {a.first} must be a ping after the first (the held pings come before it)")
    if a.pivot_n_past not in (None, "default"):
        if not a.pivot_n_past.isdigit() or int(a.pivot_n_past) < 1:
            p.error(f"--pivot-n-past: {a.pivot_n_past!r} is neither a number of pings (>= 1) nor 'default'")
        a.pivot_n_past = int(a.pivot_n_past)
    if a.choose_n_past:
        print(choose_n_past(a.choose_n_past, a.member))
        return 0
    if a.report:
        print(report(json.loads(Path(a.report).read_text())))
        return 0
    warnings.simplefilter("ignore", UserWarning)    # the loaders' axis-convention notes, one per trajectory
    from graphnav.evaluation.bench import find_trajectories
    from graphnav.evaluation.pivot_folds import fold_pivot_lengths
    from graphnav.io.paths import akit_trajectories
    from graphnav.nets.crossval import AKIT_FOLDS
    sources = {s.name: s for s in find_trajectories(str(akit_trajectories(a.data)[0].parent))}
    pivots = fold_pivot_lengths(sources, AKIT_FOLDS)
    pitch_pivots = fold_pivot_lengths(sources, AKIT_FOLDS, ("yaw", "pitch")) if a.pitch else None
    results: dict = {}
    for f, pair in enumerate(AKIT_FOLDS):
        for k in pair:
            name = f"Trajectory{k}"
            results[name] = {g: trajectory_rows(sources[name], g, pivots[f], a.stride, a.outage, a.priors,
                                                None if pitch_pivots is None else pitch_pivots[f], a.pivot_n_past,
                                                a.first)
                             for g in a.grades}
            print(f"{name} done", file=sys.stderr, flush=True)
    saved = {"pivot_m": pivots, "pitch_pivots": pitch_pivots, "pivot_n_past": a.pivot_n_past, "first": a.first,
             "outage": a.outage, "stride": a.stride, "priors": a.priors, "results": results}
    if a.out:
        Path(a.out).parent.mkdir(parents=True, exist_ok=True)
        Path(a.out).write_text(json.dumps(saved))
    print(report(saved))
    return 0


if __name__ == "__main__":
    sys.exit(main())
