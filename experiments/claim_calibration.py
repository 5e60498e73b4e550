"""The graph's claimed variance of a missing beam, calibrated out of fold (docs/decisions/completers.md, "The graph's
claimed variance calibrated out of fold").

The screening of a completion weighs it against the graph's predicted beam ``y_p`` and the variance it claims for
it, ``a`` (:mod:`graphnav.estimators.graph.regressed`). ``outage_position_drift.py --claim-collect`` records, in
Graph-TC's runs (no completion in its graph), at every keyframe of an outage window and for every missing beam: the
time into the outage (s), the number of beams measured, ``a`` ((m/s)^2) and the actual error ``e_p = y_p - y``
(m/s) against the true beam (GT velocity and attitude). ``--claim-fit DIR`` writes, per fold, the scale table
(:attr:`graphnav.estimators.options.RegressedScreeningOptions.prediction_var_table`) fitted on the other folds'
trajectories only: per number of measured beams and range of time into the outage, ``sum(e_p^2) / sum(a)``; run on
its own, this module does that fit. The run records every beam too from :data:`PAST_S` before each outage, with the
measured beams' innovations; ``--run-time`` fits nothing and compares, per outage window, scales of the claim the run
could measure itself with the actual one (:func:`run_time_scales`; docs/decisions/completers.md, "A scale of the
graph's claim the run measures itself"). Usage::

    .venv/bin/python experiments/outage_position_drift.py --methods Graph-TC --claim-collect --scenarios 2-missing \\
        3-missing 0-beams --window-s 60 120 --out out/claim/collect.json --jobs 2
    .venv/bin/python experiments/claim_calibration.py out/claim/collect.json out/claim/time
    .venv/bin/python experiments/claim_calibration.py out/claim/collect.json --run-time
"""
from __future__ import annotations

import argparse
import contextlib
import json
import sys
from pathlib import Path

import numpy as np

#: Ranges of time into the outage (s, their starts) the scales are fitted over: the claim is over- or
#: under-confident by how far the IMU has carried the velocity alone.
TIME_EDGES_S = (0.0, 10.0, 30.0, 60.0)


#: Seconds before an outage whose pings ``--claim-collect`` also records, every beam: the past a run-time scale
#: of the claim reads (:func:`run_time_scales`).
PAST_S = 60.0


@contextlib.contextmanager
def claims_read(windows=()):
    """What the graph predicted for the beams at each keyframe of the runs made inside the ``with``: a list of (t s,
    measured (4,) bool, rows (4,3), y_p (4,) m/s, a (4,) (m/s)^2, the ping's beams (4,) m/s, the measured beams'
    sigma m/s), at every keyframe with a missing beam and at every ping inside ``windows`` ((start, end) s). The
    graph's prediction is made there (without a completer it is otherwise not made); it feeds no factor."""
    from graphnav.estimators.graph import incremental
    from graphnav.estimators.graph.regressed import predicted_beams
    made, factors, prediction_of = [], incremental.keyframe_factors, incremental._IncrementalGraph._prediction

    def wanted(kf):
        return (kf.ping is not None and not kf.ping.is_velocity
                and (not kf.ping.measured.all() or any(lo <= kf.t <= hi for lo, hi in windows)))

    def predicting(self, kf, v_n_pred, bias):
        out = prediction_of(self, kf, v_n_pred, bias)
        return self.predicted_state(kf, v_n_pred, bias) if out is None and kf.index and wanted(kf) else out

    def recording(kf, builder, C_b_n_pred, p_n_pred=None, prediction=None):
        if prediction is not None and wanted(kf):
            rows = builder.geometry.T_b
            # the A-KIT lever arm is zero: no gyro-rate term
            y_p, a = predicted_beams(rows, C_b_n_pred, np.zeros(3), builder.geometry.lever_arm_b, prediction)
            made.append((kf.t, kf.ping.measured.copy(), rows, y_p, a, kf.ping.beams.copy(), builder.beam_sigma))
        return factors(kf, builder, C_b_n_pred, p_n_pred, prediction)
    incremental.keyframe_factors, incremental._IncrementalGraph._prediction = recording, predicting
    try:
        yield made
    finally:
        incremental.keyframe_factors, incremental._IncrementalGraph._prediction = factors, prediction_of


def claims_in(read, mission, start: float, window_s: float) -> list[list[float]]:
    """Rows [time into the outage s, measured beams, a (m/s)^2, e_p m/s] of :func:`claims_read`'s records in the
    outage ``[start, start + window_s]`` (s), one per missing beam."""
    rows_out = []
    for t, measured, a, e_p, _ in _scored(read, mission, start, 0.0, window_s):
        rows_out += [[t, int(measured.sum()), float(ai), float(ei)] for ai, ei in zip(a[~measured], e_p[~measured])]
    return rows_out


def innovations_in(read, mission, start: float, window_s: float, past_s: float = PAST_S) -> dict:
    """Every beam of :func:`claims_read`'s records from ``past_s`` s before the outage ``[start, start +
    window_s]`` (s) to its end: ``rows`` [time into the outage s, measured (1/0), a (m/s)^2, e_p m/s against the
    true beam, the innovation y - y_p m/s (NaN where missing)], and ``beam_sigma`` (m/s, the measured beams')."""
    rows_out, sigma = [], None
    for t, measured, a, e_p, (innovation, sigma) in _scored(read, mission, start, past_s, window_s):
        rows_out += [[t, int(m), float(ai), float(ei), float(ii) if m else float("nan")]
                     for m, ai, ei, ii in zip(measured, a, e_p, innovation)]
    return {"beam_sigma": sigma, "rows": rows_out}


def _scored(read, mission, start: float, past_s: float, window_s: float):
    """(time into the outage s, measured, a, e_p = y_p - the true beam, (y - y_p, beam sigma)) of each record in
    ``[start - past_s, start + window_s]`` (s)."""
    from oracle_completions import TruthBeams
    truth, lever = TruthBeams(mission), mission.config.dvl.lever_arm_b
    for t, measured, rows, y_p, a, beams, sigma in read:
        if start - past_s <= t <= start + window_s:
            yield float(t - start), measured, a, y_p - truth.at(t, rows, np.zeros(3), lever), (beams - y_p, sigma)


def claim_rows(runs: dict, trajectories, method: str = "Graph-TC") -> np.ndarray:
    """(n, 4) rows of :func:`claims_in` of ``method``'s windows on the A-KIT ``trajectories`` (numbers), every IMU
    grade, scenario and window length of ``runs``."""
    names = {f"Trajectory{k}" for k in trajectories}
    rows = [r for key, result in runs.items() if key[0] in names and method in result
            for w in result[method] for r in w.get("claim", [])]
    return np.asarray(rows, float).reshape(-1, 4)


def fit_table(rows: np.ndarray, edges=TIME_EDGES_S) -> dict[int, list[list[float]]]:
    """Per number of measured beams in ``rows`` (:func:`claim_rows`): [[time into the outage s, scale], ...], the
    scale ``sum(e_p^2) / sum(a)`` of each range of ``edges`` (a range without rows takes the one before it)."""
    table = {}
    for n in sorted({int(x) for x in rows[:, 1]}):
        mine, steps, scale = rows[rows[:, 1] == n], [], 1.0
        for lo, hi in zip(edges, [*edges[1:], np.inf]):
            sel = mine[(mine[:, 0] >= lo) & (mine[:, 0] < hi)]
            if len(sel):
                scale = float(np.sum(sel[:, 3] ** 2) / np.sum(sel[:, 2]))
            steps.append([float(lo), scale])
        table[n] = steps
    return table


def fold_tables(runs: dict, folds, edges=TIME_EDGES_S) -> list[dict[int, list[list[float]]]]:
    """Per fold of ``folds``: :func:`fit_table` of the other folds' trajectories (cross-fitted: never the fold's
    own pair)."""
    return [fit_table(claim_rows(runs, [k for p in folds if p is not pair for k in p]), edges) for pair in folds]


def write_tables(tables, folder: Path) -> list[Path]:
    """``folder``/fold<k>.json of each fold's table."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for k, table in enumerate(tables):
        paths.append(folder / f"fold{k}.json")
        paths[-1].write_text(json.dumps({"prediction_var_table": {str(n): v for n, v in table.items()}}, indent=1))
    return paths


def read_table(folder: Path, fold: int) -> dict[int, tuple[tuple[float, float], ...]]:
    """The table of ``fold`` in ``folder`` (:func:`write_tables`), as the screening option takes it."""
    path = Path(folder) / f"fold{fold}.json"
    if not path.exists():
        raise SystemExit(f"{path}: no calibration of fold {fold} (run --claim-fit first)")
    from graphnav.estimators.options import RegressedScreeningOptions
    table = json.loads(path.read_text())["prediction_var_table"]
    return RegressedScreeningOptions(prediction_var_table=table).prediction_var_table


def fit_folder(results: Path, folder: Path, edges=TIME_EDGES_S) -> list[Path]:
    """Each fold's table (:func:`fold_tables`, over the five fixed folds) fitted on the ``--claim-collect`` run
    ``results`` and written to ``folder`` (:func:`write_tables`)."""
    if edges[0] != 0 or any(b <= e for e, b in zip(edges, edges[1:])):
        raise SystemExit("the time edges must be ascending starts from 0 s")
    sys.path.insert(0, str(Path(__file__).parent))
    from hybrid_imu_folds import read_results
    from graphnav.nets.crossval import AKIT_FOLDS
    return write_tables(fold_tables(read_results(Path(results))[1], AKIT_FOLDS, tuple(edges)), Path(folder))


#: Ranges of the claim ``sqrt(a)`` (m/s, their starts) a scale of the claim by the claim itself is fitted over
CLAIM_EDGES = (0.0, 0.02, 0.03, 0.04, 0.06, 0.1)
#: The innovation scale's floor: a past whose innovations are all beam noise says the claim is at most this wide
INNOVATION_FLOOR = 0.05


def claim_function(pairs: np.ndarray, edges=CLAIM_EDGES) -> np.ndarray:
    """Per range of ``edges`` of ``sqrt(a)``: ``sum(e_p^2) / sum(a)`` of the (a, e_p) ``pairs`` (n,2) there (a range
    without pairs takes the one before it, the first the next one's)."""
    which = np.searchsorted(edges, np.sqrt(pairs[:, 0]), side="right") - 1
    scale = [np.sum(pairs[which == i, 1] ** 2) / np.sum(pairs[which == i, 0]) if np.any(which == i) else np.nan
             for i in range(len(edges))]
    return filled(np.asarray(scale))


def filled(x: np.ndarray) -> np.ndarray:
    """NaNs filled from the entry before, leading ones from the first finite one."""
    finite = np.flatnonzero(np.isfinite(x))
    return x[finite[np.maximum(np.searchsorted(finite, np.arange(len(x)), side="right") - 1, 0)]]


def window_scales(innovations: dict, function: np.ndarray, past_s: float = PAST_S, edges=CLAIM_EDGES) -> dict:
    """Scales of the claim over one outage's missing beams (:func:`innovations_in`), each ``sum(s a) / sum(a)``
    with ``s`` at each ping: ``actual`` ``s = e_p^2 / a``; ``claim`` the claim's ``function`` of ``sqrt(a)``
    (:func:`claim_function`, fitted elsewhere); ``innovations`` the measured beams' ``(sum (y - y_p)^2 - n sigma^2) /
    sum(a)`` over the pings of the last ``past_s`` s (floored at :data:`INNOVATION_FLOOR`); ``noise-free`` the same
    with ``e_p`` (the true beams) for the innovation: what the measured beams could tell without their noise; and the
    RMS claim ``sqrt(a)`` (m/s) of the measured beams (before the outage and in it) and of the missing ones. None
    for an outage without a missing beam at a measured ping (a total outage: Graph-TC has no ping there)."""
    rows, sigma2 = np.asarray(innovations["rows"], float).reshape(-1, 5), innovations["beam_sigma"] ** 2
    t, measured, a, e_p, innovation = rows.T
    measured, missing = measured.astype(bool), (t >= 0) & (measured == 0)
    if not missing.any():
        return None
    s_claim = function[np.searchsorted(edges, np.sqrt(a[missing]), side="right") - 1]
    past = {"innovations": [], "noise-free": []}
    for ti in t[missing]:
        sel = measured & (t > ti - past_s) & (t <= ti)
        past["innovations"].append((np.sum(innovation[sel] ** 2) - sel.sum() * sigma2) / np.sum(a[sel]))
        past["noise-free"].append(np.sum(e_p[sel] ** 2) / np.sum(a[sel]))
    a_m = a[missing]
    out = {"actual": np.sum(e_p[missing] ** 2) / np.sum(a_m), "claim": np.sum(s_claim * a_m) / np.sum(a_m),
           "sqrt a measured": np.sqrt(np.mean(a[measured])), "sqrt a missing": np.sqrt(np.mean(a_m))}
    out.update({k: np.sum(np.maximum(v, INNOVATION_FLOOR) * a_m) / np.sum(a_m) for k, v in past.items()})
    return out


def claim_functions(runs: dict, folds) -> list[np.ndarray]:
    """Per fold: :func:`claim_function` of the other folds' claim rows (cross-fitted)."""
    return [claim_function(claim_rows(runs, [k for p in folds if p is not pair for k in p])[:, 2:]) for pair in folds]


def run_time_scales(runs: dict, folds, method: str = "Graph-TC") -> list[dict]:
    """Per outage window with a measured beam of ``method``'s ``--claim-collect`` records: its trajectory, fold,
    IMU grade, scenario, length and :func:`window_scales`, the claim's function fitted on the other folds only."""
    fold_of = {f"Trajectory{k}": f for f, pair in enumerate(folds) for k in pair}
    windows = [(key, i, w["innovations"]) for key, result in runs.items() if key[0] in fold_of and method in result
               for i, w in enumerate(result[method]) if w.get("innovations", {}).get("rows")]
    if not windows:
        raise SystemExit("no records of the measured beams: run outage_position_drift.py --claim-collect again")
    functions = claim_functions(runs, folds)
    scales = [(key, i, window_scales(inn, functions[fold_of[key[0]]])) for key, i, inn in windows]
    return [{"trajectory": int(key[0].removeprefix("Trajectory")), "fold": fold_of[key[0]], "grade": key[1],
             "scenario": key[2], "window_s": key[3], "window": i, **found} for key, i, found in scales if found]


def scales_report(scales: list[dict]) -> str:
    """The medians per IMU grade and fold, how well each scale ranks the windows (the AUC of the windows the graph
    over-claims, actual < 0.5, against those it under-claims, > 1.5; the correlation of the logs) and fold 3's
    tactical windows (docs/decisions/completers.md, "A scale of the graph's claim the run measures itself")."""
    keys = ("actual", "claim", "innovations", "noise-free")
    lines = ["| IMU | fold | windows | " + " | ".join(keys) + " |", "| --- " * (3 + len(keys)) + "|"]
    for grade in sorted({w["grade"] for w in scales}, reverse=True):
        for f in sorted({w["fold"] for w in scales}):
            mine = [w for w in scales if w["grade"] == grade and w["fold"] == f]
            if mine:
                lines.append(f"| {grade} | {f} | {len(mine)} | "
                             + " | ".join(f"{np.median([w[k] for w in mine]):.2f}" for k in keys) + " |")
    over = [w for w in scales if w["actual"] < 0.5]
    under = [w for w in scales if w["actual"] > 1.5]
    lines.append(f"\nOver-claimed windows (actual < 0.5) {len(over)}, under-claimed (> 1.5) {len(under)}:")
    for k in keys[1:]:
        auc = np.mean([[u[k] > o[k] for o in over] for u in under])
        logs = np.log([[w[k], w["actual"]] for w in scales]).T
        shrunk = np.mean([w[k] < 1 for w in over])
        lines.append(f"  {k}: AUC {auc:.2f}, log correlation with the actual {np.corrcoef(logs)[0, 1]:.2f}, "
                     f"over-claimed windows it shrinks {shrunk:.0%}")
    for k in ("sqrt a measured", "sqrt a missing"):
        x = [w[k] for w in scales]
        lines.append(f"  the claim {k} (m/s, RMS per window): median {np.median(x):.3f}, {min(x):.3f}-{max(x):.3f}")
    lines.append("Fold 3, tactical IMU (trajectory scenario window s: " + ", ".join(keys) + "):")
    lines += [f"  {w['trajectory']} {w['scenario']} {w['window_s']:g} #{w['window']}: "
              + " ".join(f"{w[k]:.2f}" for k in keys) + f" (claim {w['sqrt a missing']:.3f} m/s)"
              for w in sorted(scales, key=lambda w: (w["trajectory"], w["scenario"], w["window_s"], w["window"]))
              if w["fold"] == 3 and w["grade"] == "tactical"]
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description="Fit each fold's table of the graph's claimed-variance scales "
                                "(screening.prediction_var_table) on the other folds' records of an "
                                "outage_position_drift.py --claim-collect run, and write DIR/fold<k>.json "
                                "(docs/decisions/completers.md, \"The graph's claimed variance calibrated out of "
                                "fold\"); or, with --run-time, compare scales of the claim the run could measure "
                                "itself with the actual one per outage window.")
    p.add_argument("results", help="the --claim-collect run's results file (its --out)")
    p.add_argument("folder", metavar="DIR", nargs="?", help="where fold<k>.json are written")
    p.add_argument("--edges", nargs="+", type=float, metavar="S", default=list(TIME_EDGES_S),
                   help="the starts (s, from 0) of the ranges of time into the outage a scale is fitted to (0 alone: "
                        "one scale per number of measured beams)")
    p.add_argument("--run-time", action="store_true", help="fit nothing: per outage window, the claim scaled by a "
                   "function of itself (fitted on the other folds) and by the measured beams' innovations over the "
                   f"last {PAST_S:g} s, against the actual scale (docs/decisions/completers.md, \"A scale of the "
                   "graph's claim the run measures itself\")")
    a = p.parse_args(argv)
    if a.run_time:
        sys.path.insert(0, str(Path(__file__).parent))
        from hybrid_imu_folds import read_results
        from graphnav.nets.crossval import AKIT_FOLDS
        runs = read_results(Path(a.results))[1]
        print(scales_report(run_time_scales(runs, AKIT_FOLDS)))
        print(f"The claim's function per range of sqrt(a) from {CLAIM_EDGES} m/s, each fold's fitted on the others:")
        for f, function in enumerate(claim_functions(runs, AKIT_FOLDS)):
            print(f"  fold {f}: " + " ".join(f"{x:.2f}" for x in function))
        return 0
    if a.folder is None:
        p.error("give DIR (where the tables are written), or --run-time")
    for path in fit_folder(Path(a.results), Path(a.folder), a.edges):
        print(f"{path}: {path.read_text()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
