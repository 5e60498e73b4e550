"""Rehearsed outages (GraphOptions.rehearsed_outages, graphnav.estimators.rehearsal): the mission's measured past
decides, per horizon into an outage, between a completion and the graph's own prediction."""
import warnings

import numpy as np
import pytest

import graphnav
from graphnav.core.errors import ConfigError
from graphnav.core.scenarios import scenario_outage
from graphnav.evaluation.metrics import vrmse
from graphnav.evaluation.methods import GRAPH_HNP, completer_for, run_method

START, LENGTH = 200.0, 40.0


def _rehearsed_run(grade: str):
    """(the mission, Graph-HNP as shipped, Graph-HNP with rehearsed outages) through a 40 s outage of 3 beams on a
    simulated hull turning about a pivot 3 m ahead (seeded; with seed 1 and the MEMS IMU the graph alone is as good
    as the completions, 0.048 m/s, and keeping them makes it 0.068 m/s: the rehearsal cannot tell a tie)."""
    mission = graphnav.simulate_mission(260.0, grade, seed=2, pivot_m=3.0)
    run = mission.with_outage(scenario_outage("3-missing", START, LENGTH))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        shipped = run_method(run, GRAPH_HNP, "3-missing")
        rehearsed = run_method(run, GRAPH_HNP, "3-missing", options={"rehearsed_outages": 1.0})
    return mission, shipped, rehearsed


def test_with_a_navigation_grade_imu_the_rehearsals_leave_every_missing_beam_to_the_graph():
    mission, shipped, rehearsed = _rehearsed_run("navigation")
    counts = rehearsed.info["outage_rehearsal"]
    assert counts == {"completer": 0, "graph": 3 * LENGTH, "unrehearsed": 0}
    assert rehearsed.info["regressed_screening"]["entered"] == 0
    assert vrmse(rehearsed, mission.gt, START, START + LENGTH) == pytest.approx(
        vrmse(shipped, mission.gt, START, START + LENGTH), rel=1e-3)


def test_with_a_mems_imu_the_rehearsals_keep_the_pivot_completions_and_the_window_is_better():
    mission, shipped, rehearsed = _rehearsed_run("mems")
    counts = rehearsed.info["outage_rehearsal"]
    assert counts["unrehearsed"] == 0 and counts["completer"] > counts["graph"]
    # the shipped screening drops nearly all of them: the graph's predicted variance claims more than it has
    assert shipped.info["regressed_screening"]["entered"] < 10
    assert vrmse(rehearsed, mission.gt, START, START + LENGTH) < 0.5 * vrmse(shipped, mission.gt, START, START + LENGTH)


def test_the_pivot_completers_rehearsal_is_its_completion_of_a_ping_without_beams_and_leaves_it_untouched():
    config = graphnav.simulate_mission(10.0, seed=0).config
    comp = completer_for(GRAPH_HNP, "3-missing", config=config)[0]
    rng = np.random.default_rng(0)
    past = rng.normal(1.0, 0.1, (comp.n_past, 4))
    imu = (rng.normal(0, 0.1, (comp.imu_samples, 3)), rng.normal(0, 0.05, (comp.imu_samples, 3)))
    comp.fit.add(0.0, np.ones(4), np.zeros(3))
    recent, usage = list(comp.fit._recent), dict(comp.usage)
    rehearsed = comp.rehearse(past, imu)
    assert comp.fit._recent == recent and comp.usage == usage
    assert np.allclose(rehearsed, comp.complete(past, np.full(4, np.nan), imu)[0])


def test_rehearsed_outages_refuse_a_margin_that_is_not_positive_and_a_completer_that_cannot_rehearse():
    from graphnav.estimators.graph import GraphOptions
    with pytest.raises(ConfigError, match="rehearsed_outages"):
        GraphOptions(rehearsed_outages=0.0)

    class Held:
        n_past = 3

        def complete(self, past, measured):
            return np.where(np.isfinite(measured), measured, past[-1]), np.full(4, 0.1)

    mission = graphnav.simulate_mission(30.0, seed=0)
    with pytest.raises(ConfigError, match="cannot rehearse"):
        run_method(mission, GRAPH_HNP, "3-missing", completer=Held(), options={"rehearsed_outages": 1.0})
