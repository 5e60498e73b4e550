"""The graph's claimed variance of a missing beam, calibrated out of fold (docs/decisions/completers.md, "The graph's
claimed variance calibrated out of fold").

The screening of a completion weighs it against the graph's predicted beam ``y_p`` and the variance it claims for
it, ``a`` (:mod:`graphnav.estimators.graph.regressed`). ``outage_position_drift.py --claim-collect`` records, in
Graph-TC's runs (no completion in its graph), at every keyframe of an outage window and for every missing beam: the
time into the outage (s), the number of beams measured, ``a`` ((m/s)^2) and the actual error ``e_p = y_p - y``
(m/s) against the true beam (GT velocity and attitude). ``--claim-fit DIR`` writes, per fold, the scale table
(:attr:`graphnav.estimators.options.RegressedScreeningOptions.prediction_var_table`) fitted on the other folds'
trajectories only: per number of measured beams and range of time into the outage, ``sum(e_p^2) / sum(a)``; run on
its own, this module does that fit. Usage::

    .venv/bin/python experiments/outage_position_drift.py --methods Graph-TC --claim-collect --scenarios 2-missing \\
        3-missing 0-beams --window-s 60 120 --out out/claim/collect.json --jobs 2
    .venv/bin/python experiments/claim_calibration.py out/claim/collect.json out/claim/time
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


@contextlib.contextmanager
def claims_read():
    """What the graph predicted for its missing beams at each keyframe of the runs made inside the ``with`` (a
    list of (t s, measured beams, rows (k,3), y_p (k,) m/s, a (k,) (m/s)^2)). The graph's prediction is made at
    every keyframe with a missing beam (without a completer it is otherwise not made); it feeds no factor there."""
    from graphnav.estimators.graph import incremental
    from graphnav.estimators.graph.regressed import predicted_beams
    made, factors, prediction_of = [], incremental.keyframe_factors, incremental._IncrementalGraph._prediction

    def predicting(self, kf, v_n_pred, bias):
        out = prediction_of(self, kf, v_n_pred, bias)
        missing = kf.ping is not None and not kf.ping.is_velocity and not kf.ping.measured.all()
        return self.predicted_state(kf, v_n_pred, bias) if out is None and missing and kf.index else out

    def recording(kf, builder, C_b_n_pred, p_n_pred=None, prediction=None):
        if prediction is not None and kf.ping is not None and not kf.ping.is_velocity:
            missing = ~kf.ping.measured
            if missing.any():
                rows = builder.geometry.T_b[missing]
                # the A-KIT lever arm is zero: no gyro-rate term
                y_p, a = predicted_beams(rows, C_b_n_pred, np.zeros(3), builder.geometry.lever_arm_b, prediction)
                made.append((kf.t, int(kf.ping.measured.sum()), rows, y_p, a))
        return factors(kf, builder, C_b_n_pred, p_n_pred, prediction)
    incremental.keyframe_factors, incremental._IncrementalGraph._prediction = recording, predicting
    try:
        yield made
    finally:
        incremental.keyframe_factors, incremental._IncrementalGraph._prediction = factors, prediction_of


def claims_in(read, mission, start: float, window_s: float) -> list[list[float]]:
    """Rows [time into the outage s, measured beams, a (m/s)^2, e_p m/s] of :func:`claims_read`'s records in the
    outage ``[start, start + window_s]`` (s), one per missing beam."""
    from oracle_completions import TruthBeams
    truth, lever, rows_out = TruthBeams(mission), mission.config.dvl.lever_arm_b, []
    for t, n, rows, y_p, a in read:
        if start <= t <= start + window_s:
            e = y_p - truth.at(t, rows, np.zeros(3), lever)
            rows_out += [[float(t - start), n, float(ai), float(ei)] for ai, ei in zip(a, e)]
    return rows_out


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


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description="Fit each fold's table of the graph's claimed-variance scales "
                                "(screening.prediction_var_table) on the other folds' records of an "
                                "outage_position_drift.py --claim-collect run, and write DIR/fold<k>.json "
                                "(docs/decisions/completers.md, \"The graph's claimed variance calibrated out of "
                                "fold\").")
    p.add_argument("results", help="the --claim-collect run's results file (its --out)")
    p.add_argument("folder", metavar="DIR", help="where fold<k>.json are written")
    p.add_argument("--edges", nargs="+", type=float, metavar="S", default=list(TIME_EDGES_S),
                   help="the starts (s, from 0) of the ranges of time into the outage a scale is fitted to (0 alone: "
                        "one scale per number of measured beams)")
    a = p.parse_args(argv)
    for path in fit_folder(Path(a.results), Path(a.folder), a.edges):
        print(f"{path}: {path.read_text()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
