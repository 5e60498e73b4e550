"""The screening's claimed variance calibrated out of fold: ``RegressedScreeningOptions.prediction_var_table``
(experimental) and the cross-fitted fit of ``experiments/claim_calibration.py``."""
import sys
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import graphnav
from graphnav.core.errors import ConfigError
from graphnav.core.scenarios import scenario_outage
from graphnav.estimators.ekf import EkfOptions
from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.graph.builder import GraphContext
from graphnav.estimators.options import RegressedScreeningOptions
from graphnav.estimators.regressed_screening import screen_against_prediction
from graphnav.evaluation.methods import GRAPH_HNP, completer_for, run_method

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
from claim_calibration import (claim_function, claims_in, claims_read, fold_tables, innovations_in,  # noqa: E402
                               read_table, run_time_scales, window_scales, write_tables)

FOLDS = [(1, 3), (2, 5), (4, 10), (6, 13), (8, 11)]
TABLE = {1: ((0.0, 2.0), (10.0, 0.5))}


def test_the_table_scale_steps_by_the_measured_beams_and_the_time_into_the_run():
    options = RegressedScreeningOptions(prediction_var_table=TABLE)
    assert [options.table_scale(1, t) for t in (0.0, 9.9, 10.0, 100.0)] == [2.0, 2.0, 0.5, 0.5]
    # a number of measured beams the table does not name, and no table: 1
    assert options.table_scale(2, 50.0) == 1.0
    assert RegressedScreeningOptions().table_scale(1, 50.0) == 1.0


def test_the_screening_weighs_a_completion_against_the_scaled_claim():
    screening = RegressedScreeningOptions(correlation=0.5, adaptive=True)
    y, y_p, a, s2 = np.array([1.0, 1.1]), np.array([1.02, 1.0]), np.array([1e-3, 1e-3]), np.array([3e-3, 3e-3])
    # rho = 0.5 keeps a completion while its variance is under 4 a: kept at 3 a, dropped once a is halved
    assert screen_against_prediction(y, y_p, a, s2, screening)[0].tolist() == [True, True]
    assert screen_against_prediction(y, y_p, a, s2, screening, 0.5)[0].tolist() == [False, False]
    # the table's scale is the prediction_var_scale's, on top of it
    by_table = screen_against_prediction(y, y_p, a, s2, screening, 4.0)
    by_scale = screen_against_prediction(y, y_p, a, s2, RegressedScreeningOptions(0.5, True, prediction_var_scale=4.0))
    assert by_table[0].tolist() == by_scale[0].tolist() and np.array_equal(by_table[1], by_scale[1])


def _kf(t, n_measured):
    return SimpleNamespace(t=t, n_measured=n_measured)


def test_the_graph_times_the_run_of_regressed_pings_and_a_measured_ping_ends_it():
    config = graphnav.simulate_mission(5.0, "mems", seed=1).config
    ctx = GraphContext(config, GraphOptions(screening=RegressedScreeningOptions(prediction_var_table=TABLE)))
    assert ctx.claim_scale(_kf(100.0, 1), True) == 2.0      # the run starts
    assert ctx.claim_scale(_kf(109.0, 1), True) == 2.0
    assert ctx.claim_scale(_kf(110.0, 1), True) == 0.5      # 10 s into it
    assert ctx.claim_scale(_kf(110.5, 2), True) == 1.0      # two measured: not in the table
    assert ctx.claim_scale(_kf(111.0, 4), False) == 1.0     # every beam measured: the run ends
    assert ctx.claim_scale(_kf(115.0, 1), True) == 2.0      # a new run starts at 0 s


def _run(table):
    """Graph-HNP through a 30 s outage of 2 beams on a simulated MEMS hull turning about a pivot (seeded), with the
    measured-change sigma and ``table`` ("off": none)."""
    mission = graphnav.simulate_mission(130.0, "mems", seed=2, pivot_m=3.0)
    run = mission.with_outage(scenario_outage("2-missing", 90.0, 30.0))
    comp = completer_for(GRAPH_HNP, "2-missing", config=mission.config)[0]
    comp.run_sigma = "measured-change"
    options = None if table == "off" else {"screening.prediction_var_table": table}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return run_method(run, GRAPH_HNP, "2-missing", completer=comp, options=options)


def test_in_the_graph_the_scale_acts_on_its_own_number_of_measured_beams_only():
    off = _run("off")
    same = _run({1: ((0.0, 1e-3),)})
    assert np.array_equal(same.v_n, off.v_n) and np.array_equal(same.p_n, off.p_n)
    # the claim shrunk 1000x with the two measured beams of the outage: every completion screened there is dropped
    shrunk = _run({2: ((0.0, 1e-3),)})
    assert off.info["regressed_screening"]["entered"] > 0
    assert shrunk.info["regressed_screening"]["entered"] == 0


def _runs(scale_of_fold):
    """A results dict of :func:`outage_position_drift.trajectory_task`'s shape whose Graph-TC windows' claim rows
    have e_p^2 / a = ``scale_of_fold[f]`` on the trajectories of fold f, in the first 10 s of the outage, and 10x
    that after."""
    runs = {}
    for f, pair in enumerate(FOLDS):
        for k in pair:
            rows = [[t, 1, 1e-3, np.sqrt(1e-3 * scale_of_fold[f] * (1 if t < 10 else 10))] for t in (1.0, 5.0, 40.0)]
            runs[(f"Trajectory{k}", "tactical", "3-missing", 60.0)] = {"Graph-TC": [{"claim": rows}]}
    return runs


def test_each_folds_table_is_fitted_on_the_other_folds_only(tmp_path):
    scales = [1.0, 2.0, 3.0, 4.0, 5.0]
    tables = fold_tables(_runs(scales), FOLDS, edges=(0.0, 10.0))
    for f, table in enumerate(tables):
        others = np.mean([s for g, s in enumerate(scales) if g != f])
        assert table[1][0] == [0.0, pytest.approx(others)]
        assert table[1][1] == [10.0, pytest.approx(10 * others)]
    # the held-out fold's own records change nothing of its table
    changed = fold_tables(_runs([1.0, 2.0, 3.0, 40.0, 5.0]), FOLDS, edges=(0.0, 10.0))
    assert changed[3] == tables[3] and changed[0] != tables[0]
    write_tables(tables, tmp_path)
    assert read_table(tmp_path, 3) == {1: ((0.0, pytest.approx(2.75)), (10.0, pytest.approx(27.5)))}


@pytest.mark.parametrize("table", [{1: ((5.0, 2.0),)}, {1: ((0.0, 2.0), (0.0, 1.0))}, {1: ((0.0, 0.0),)},
                                   {5: ((0.0, 1.0),)}, {1: ((0.0, float("nan")),)}, {1: "2"},
                                   {"one": ((0.0, 1.0),)}])
def test_a_bad_table_is_refused_naming_the_entry(table):
    with pytest.raises(ConfigError, match="prediction_var_table"):
        RegressedScreeningOptions(prediction_var_table=table)


def test_the_ekf_refuses_the_table_it_would_ignore():
    with pytest.raises(ConfigError, match="factor-graph option"):
        EkfOptions(screening=RegressedScreeningOptions(prediction_var_table=TABLE))


def test_a_calibrated_run_of_the_study_takes_the_table_of_the_fold_holding_its_trajectory_out(tmp_path):
    import outage_position_drift as study
    write_tables([{1: [[0.0, float(f + 1)]]} for f in range(len(FOLDS))], tmp_path / "flat")
    label = "Graph-HNP measured-sigma calibrated flat"
    assert study.variant_run(label) == ("Graph-HNP", None)
    flags = {"claim_folders": {"flat": str(tmp_path / "flat")}}
    assert study.claim_options(label, None, 3, flags) == {"screening.prediction_var_table": {1: ((0.0, 4.0),)}}
    assert study.claim_options("Graph-HNP measured-sigma", {"x": 1}, 3, flags) == {"x": 1}


def test_the_recorder_reads_every_beam_from_before_the_outage_and_the_missing_beams_claims_as_before():
    mission = graphnav.simulate_mission(45.0, "mems", seed=2)
    run = mission.with_outage(scenario_outage("2-missing", 30.0, 10.0))
    read = {}
    for windows in ((), ((10.0, 40.0),)):
        with warnings.catch_warnings(), claims_read(windows) as made:
            warnings.simplefilter("ignore")
            run_method(run, "Graph-TC", "2-missing")
        read[windows] = made
    before, now = read[()], read[((10.0, 40.0),)]
    # the missing beams' rows are those of the recorder without windows
    assert claims_in(now, mission, 30.0, 10.0) == claims_in(before, mission, 30.0, 10.0) != []
    found = innovations_in(now, mission, 30.0, 10.0, past_s=20.0)
    rows = np.asarray(found["rows"])
    assert found["beam_sigma"] == mission.config.dvl.beam_noise_std
    assert rows[0, 0] >= -20.0 and rows[-1, 0] <= 10.0 and np.sum(rows[:, 0] < 0) >= 4 * 19
    # a measured beam's innovation is its beam less the prediction, a missing beam's NaN
    assert np.all(np.isfinite(rows[rows[:, 1] == 1, 4])) and np.all(np.isnan(rows[rows[:, 1] == 0, 4]))
    assert np.all(rows[rows[:, 0] < 0, 1] == 1) and np.sum(rows[:, 1] == 0) == len(claims_in(now, mission, 30.0, 10.0))
    # without windows only the pings with a missing beam are read
    assert np.sum(np.asarray(innovations_in(before, mission, 30.0, 10.0, past_s=20.0)["rows"])[:, 0] < 0) == 0


def _innovations(actual, past, innovation, sigma=0.04):
    """One outage's :func:`innovations_in` records: 10 pings before it with four measured beams, 10 in it with two
    missing; every claim a = 1e-3, the missing beams' e_p^2 = ``actual`` a, the measured beams' ``past`` a and their
    innovations^2 ``innovation``."""
    rows = []
    for t in range(-10, 10):
        for beam in range(4):
            measured = t < 0 or beam < 2
            rows.append([float(t), int(measured), 1e-3, np.sqrt(1e-3 * (past if measured else actual)),
                         np.sqrt(innovation) if measured else float("nan")])
    return {"beam_sigma": sigma, "rows": rows}


def test_each_windows_scales_of_the_claim():
    function = np.array([3.0, 2.0, 1.0, 1.0, 1.0, 1.0])      # sqrt(a) = 0.032 m/s: the third range
    found = window_scales(_innovations(0.25, 2.0, 0.04 ** 2 + 1.5e-3), function, past_s=5.0)
    assert found == {"actual": pytest.approx(0.25), "claim": 1.0, "innovations": pytest.approx(1.5),
                     "noise-free": pytest.approx(2.0), "sqrt a measured": pytest.approx(np.sqrt(1e-3)),
                     "sqrt a missing": pytest.approx(np.sqrt(1e-3))}
    # innovations all beam noise: the floor
    assert window_scales(_innovations(0.25, 2.0, 0.04 ** 2), function)["innovations"] == pytest.approx(0.05)
    no_missing = _innovations(0.25, 2.0, 1e-3)
    no_missing["rows"] = [r for r in no_missing["rows"] if r[1]]
    assert window_scales(no_missing, function) is None
    # per range of sqrt(a): 2 in the first, 0.25 in the last, the empty ones the range's before
    assert claim_function(np.array([[1e-4, 0.02], [1e-4, 0.0], [0.01, 0.05]])) == pytest.approx([2, 2, 2, 2, 2, 0.25])
    assert claim_function(np.array([[0.01, 0.05]])) == pytest.approx([0.25] * 6)     # the first empty: the next


def test_the_claims_function_of_itself_is_fitted_on_the_other_folds_only():
    runs = _runs([1.0, 2.0, 3.0, 4.0, 5.0])
    for key, result in runs.items():
        result["Graph-TC"][0]["innovations"] = _innovations(1.0, 1.0, 2e-3)
    scales = {w["fold"]: w for w in run_time_scales(runs, FOLDS)}
    runs[("Trajectory6", "tactical", "3-missing", 60.0)]["Graph-TC"][0]["claim"][0][3] = 10.0
    changed = {w["fold"]: w for w in run_time_scales(runs, FOLDS)}
    assert changed[3] == scales[3] and changed[0]["claim"] != scales[0]["claim"]
    del runs[("Trajectory6", "tactical", "3-missing", 60.0)]["Graph-TC"][0]["innovations"]
    assert len(run_time_scales(runs, FOLDS)) == 9
