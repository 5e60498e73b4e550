"""Both errors read on the beams still measured (GraphOptions.measured_both_margin): a completion is kept only where
the completer's recent error (the measured-change sigma) is smaller than the graph's own recent prediction error on
the measured beams."""
import warnings

import numpy as np
import pytest

import graphnav
from graphnav.core.errors import ConfigError
from graphnav.core.scenarios import scenario_outage
from graphnav.estimators.graph import GraphOptions
from graphnav.estimators.graph.regressed import GraphPredictionError, VelocityPrediction
from graphnav.evaluation.metrics import vrmse
from graphnav.evaluation.methods import GRAPH_HNP, GRAPH_TC, completer_for, run_method

ROWS = np.array([[0.5, 0.5, 0.7071], [-0.5, 0.5, 0.7071], [-0.5, -0.5, 0.7071], [0.5, -0.5, 0.7071]])
V_N = np.array([1.5, 0.2, 0.05])
NOISE = 0.042
PREDICTION = VelocityPrediction(V_N, np.eye(3) * 1e-4, np.zeros(3))
REGRESSED = np.array([False, False, True, True])


def _keep(judge, offset, sigma, regressed=REGRESSED, prediction=PREDICTION):
    """The judge's decision on a ping whose measured beams are the graph's prediction plus ``offset`` (m/s)."""
    y = ROWS @ V_N + offset
    return judge.keep(ROWS, y, np.asarray(sigma, float), regressed, np.eye(3), np.zeros(3), np.zeros(3), prediction)


def test_a_completion_is_kept_only_where_its_sigma_beats_the_graphs_innovation_less_the_noise():
    judge = GraphPredictionError(1.0, NOISE)
    # the measured beams 0.1 m/s off the prediction: s_graph^2 = 0.01 - 0.042^2, s_graph = 0.091 m/s
    keep = _keep(judge, 0.1, [0.1, 0.1, 0.06, 0.10])
    assert keep.tolist() == [True, False]
    assert judge.innovation2.less_noise(NOISE) == pytest.approx(0.1 ** 2 - NOISE ** 2)
    # a margin of 2 keeps a completion as wrong as the graph
    assert _keep(GraphPredictionError(2.0, NOISE), 0.1, [0.1, 0.1, 0.06, 0.10]).tolist() == [True, True]
    # smoothed: one ping at the noise's level after the first lowers s_graph^2 by half, not to 0
    _keep(judge, 0.0, [0.1, 0.1, 0.06, 0.10])
    assert judge.innovation2.less_noise(NOISE) == pytest.approx(0.5 * 0.1 ** 2 - NOISE ** 2)
    assert judge.counts == {"kept": 1, "dropped": 3}


def test_a_run_ends_its_smoothing_and_a_ping_without_a_measured_beam_or_prediction_keeps_its_completions():
    judge = GraphPredictionError(1.0, NOISE)
    _keep(judge, 0.1, [0.1, 0.1, 0.06, 0.06])
    judge.end_run()
    # the next run starts from the graph's own noise-level innovation: a completion at 0.06 m/s is worse
    assert _keep(judge, 0.0, [0.1, 0.1, 0.06, 0.06]).tolist() == [False, False]
    assert _keep(judge, 0.0, [0.06] * 4, regressed=np.ones(4, bool)).tolist() == [True] * 4
    assert _keep(judge, 0.0, [0.1, 0.1, 0.06, 0.06], prediction=None).tolist() == [True, True]


def _run(grade: str, margins):
    """Graph-TC, and Graph-HNP with the measured-change sigma at each margin, through a 40 s outage of 2 beams on a
    simulated hull turning about a pivot 3 m ahead (seeded)."""
    mission = graphnav.simulate_mission(260.0, grade, seed=2, pivot_m=3.0)
    run = mission.with_outage(scenario_outage("2-missing", 200.0, 40.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = [run_method(run, GRAPH_TC, "2-missing")]
        for margin in margins:
            comp = completer_for(GRAPH_HNP, "2-missing", config=mission.config)[0]
            comp.run_sigma = "measured-change"
            out.append(run_method(run, GRAPH_HNP, "2-missing", completer=comp,
                                  options={"measured_both_margin": margin}))
    return mission, [vrmse(sol, mission.gt, 200.0, 240.0) for sol in out], [sol.info for sol in out]


def test_in_the_graph_a_completion_worse_than_the_graphs_innovation_is_dropped_and_a_wide_margin_keeps_some():
    mission, windows, infos = _run("mems", [1.0, 4.0])
    # 2 beams x 40 pings of the outage judged; at margin 1 every one is dropped and the window is Graph-TC's
    assert infos[1]["measured_both"] == {"kept": 0, "dropped": 80}
    assert infos[1]["regressed_screening"]["entered"] == 0
    assert windows[1] == pytest.approx(windows[0], rel=1e-6)
    assert infos[2]["measured_both"]["kept"] > 0 and windows[2] < windows[0]
    assert "measured_both" not in infos[0]


def test_the_margin_is_refused_without_the_measured_change_sigma_or_when_not_positive():
    assert GraphOptions().measured_both_margin is None
    for bad in (0.0, -1.0, float("inf"), float("nan")):
        with pytest.raises(ConfigError, match="measured_both_margin"):
            GraphOptions(measured_both_margin=bad)
    mission = graphnav.simulate_mission(30.0, seed=0)
    for method in (GRAPH_HNP, GRAPH_TC):
        with pytest.raises(ConfigError, match="measured-change"):
            run_method(mission, method, "2-missing", options={"measured_both_margin": 1.0})
