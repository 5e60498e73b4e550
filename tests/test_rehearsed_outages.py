"""Rehearsed outages (GraphOptions.rehearsed_outages, graphnav.estimators.rehearsal): the mission's measured past
decides, per horizon into an outage, between a completion and the graph's own prediction."""
import warnings

import numpy as np
import pytest

import graphnav
from graphnav.core.errors import ConfigError
from graphnav.core.scenarios import scenario_outage
from graphnav.evaluation.metrics import vrmse
from graphnav.evaluation.methods import GRAPH_HN_BATCH, GRAPH_HNP, GRAPH_TC, completer_for, run_method

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



@pytest.mark.parametrize("method, match", [(GRAPH_TC, "without a completer"),
                                           (GRAPH_HN_BATCH, "incremental smoothers")])
def test_rehearsed_outages_are_refused_for_a_graph_without_a_completer_and_for_the_batch(method, match):
    # Graph-TC ran with every count 0 and no word; the batch changed its output with an option not studied there
    mission = graphnav.simulate_mission(30.0, seed=0)
    with pytest.raises(ConfigError, match=f"rehearsed_outages.*{match}"):
        run_method(mission, method, "3-missing", options={"rehearsed_outages": 1.0})


def test_a_rehearsal_variant_without_rehearsed_outages_is_refused_not_ignored():
    from graphnav.estimators.graph import GraphOptions
    for name, value in (("rehearsal_graph", "twin"), ("rehearsal_fusion", "correlated")):
        with pytest.raises(ConfigError, match=f"{name}='{value}'.*needs rehearsed_outages"):
            GraphOptions(**{name: value})
        assert getattr(GraphOptions(rehearsed_outages=1.0, **{name: value}), name) == value


def _twin_rehearsal(graph: str, var: float):
    """An OutageRehearsal on the default beams whose IMU-carried horizontal velocity has rehearsed a spread ``var``
    ((m/s)^2 per axis) at horizon 1, and one rehearsal at horizon 1: carried velocity 0.3 m/s off north, exact
    beams, a completion 0.1 m/s off on every beam."""
    from graphnav.core.dvl import DvlGeometry, DvlSpec
    from graphnav.estimators.rehearsal import OutageRehearsal
    geometry = DvlGeometry.from_spec(DvlSpec())
    # the pattern scores are kept with either variant: the correlated fusion reads them on the IMU-only side too
    rehearsal = OutageRehearsal(geometry.T_b, np.zeros(3), graph=graph, fusion="correlated", beam_sigma=0.02,
                                min_rehearsals=1)
    rehearsal.spread.by_h[1].append(var)
    v_true = np.array([1.0, 0.2, 0.05])
    beams = geometry.T_b @ v_true
    rehearsal._comp_errors[(0.0, 1)] = np.full(4, 0.1)
    rehearsal._score_patterns(1, 0.0, np.eye(3), v_true + [0.3, 0.0, 0.0], beams, np.zeros(3))
    return rehearsal


def test_the_graphs_twin_predicts_the_missing_beams_from_the_beams_the_pattern_still_measures():
    """With three beams measured the twin's velocity is the beams' (the IMU's spread is wide): the missing beam is
    predicted within 0.01 m/s; in a total outage it is the IMU's alone, 0.3 m/s off along the beams' north part;
    the IMU-only rehearsal predicts every pattern from the IMU alone."""
    twin, imu = _twin_rehearsal("twin", var=0.3 ** 2), _twin_rehearsal("imu", var=0.3 ** 2)
    three = np.array([True, True, True, False])
    _, e_twin, _ = twin.pattern_errors(three, 1)
    _, e_imu, _ = imu.pattern_errors(three, 1)
    _, total_twin, _ = twin.pattern_errors(np.zeros(4, dtype=bool), 1)
    assert np.sqrt(e_twin) < 0.01                   # the IMU alone: 0.073 m/s
    assert np.sqrt(e_imu) == pytest.approx(0.3 * np.sin(np.radians(20)) * np.cos(np.radians(45)), rel=1e-6)
    assert np.sqrt(total_twin) == pytest.approx(np.sqrt(e_imu), rel=1e-6)
    # one measured beam corrects the IMU's velocity along it when the rehearsed spread says the IMU is poor
    one = np.array([True, False, False, False])
    imu_one = imu.pattern_errors(one, 1)[1]
    assert _twin_rehearsal("twin", var=1.0).pattern_errors(one, 1)[1] < 0.7 * imu_one


def test_correlated_fusion_keeps_a_completion_at_the_sigma_of_the_best_linear_fusion_or_drops_it():
    """The rehearsed covariance decides: uncorrelated errors keep the completion at its own error even where it
    ties the graph (the margin would drop it); a correlation leaves it the equivalent independent variance
    a (s^2 - c) / (a - c); a graph sharper than rho times the completion drops it."""
    from graphnav.core.dvl import DvlGeometry, DvlSpec
    from graphnav.estimators.rehearsal import OutageRehearsal
    T_b = DvlGeometry.from_spec(DvlSpec()).T_b
    one = np.array([True, False, False, False])
    p = 1

    def verdict(fusion, s2, a, c):
        rehearsal = OutageRehearsal(T_b, np.zeros(3), graph="twin", fusion=fusion, min_rehearsals=1)
        rehearsal.pairs.by_h[p][1].append((s2, a, c))
        beams, sigma, kept = rehearsal.decide(0.0, np.ones(4), np.full(4, 0.1), ~one, np.full(4, 1), one)
        return rehearsal.decisions[-1][2], sigma[1], kept[1], beams[1]

    assert verdict("independent", 0.01, 0.01, 0.0)[0] == "graph"          # a tie: not below the margin
    what, sigma, kept, _ = verdict("correlated", 0.01, 0.01, 0.0)
    assert (what, kept) == ("completer", True) and sigma == pytest.approx(0.1)
    s2, a, c = 0.04, 0.01, 0.004
    assert verdict("correlated", s2, a, c)[1] == pytest.approx(np.sqrt(a * (s2 - c) / (a - c)))
    what, _, kept, beam = verdict("correlated", 0.04, 0.01, 0.012)
    assert (what, kept) == ("graph", False) and np.isnan(beam)


def test_the_variants_run_in_the_graph_and_bad_ones_are_refused():
    from graphnav.estimators.graph import GraphOptions
    for name in ("rehearsal_graph", "rehearsal_fusion"):
        with pytest.raises(ConfigError, match=name):
            GraphOptions(rehearsed_outages=1.0, **{name: "other"})
    mission = graphnav.simulate_mission(120.0, "mems", seed=2, pivot_m=3.0)
    run = mission.with_outage(scenario_outage("3-missing", 100.0, 10.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = run_method(run, GRAPH_HNP, "3-missing", options={"rehearsed_outages": 1.0, "rehearsal_graph": "twin",
                                                               "rehearsal_fusion": "correlated"})
    counts = sol.info["outage_rehearsal"]
    assert sum(counts.values()) == 3 * 10 and counts["unrehearsed"] == 0


def test_an_imu_aware_completer_of_one_pattern_rehearses_it_with_the_measured_beams_given_and_counts_nothing():
    from graphnav.nets.imu_auto import load_imu_auto_completer
    comp = load_imu_auto_completer(patterns=("3-missing",))
    measured = comp.rehearsal_measured
    assert measured.tolist() == [False, True, False, False]
    rng = np.random.default_rng(0)
    past = rng.normal(0.8, 0.05, (comp.n_past, 4))
    beams = past[-1] + rng.normal(0.0, 0.02, 4)
    still = (np.zeros((comp.imu_samples, 3)) + [0.0, 0.0, -9.81], np.zeros((comp.imu_samples, 3)))
    shaken = (rng.normal(0.0, 50.0, (comp.imu_samples, 3)), rng.normal(0.0, 5.0, (comp.imu_samples, 3)))
    for imu in (still, shaken, None):          # the network, its envelope's fallback, no window
        usage, fallbacks = dict(comp.usage), dict(comp.fallbacks)
        rehearsed = comp.rehearse(past, imu, beams)
        assert comp.usage == usage and comp.fallbacks == fallbacks
        assert rehearsed[measured] == beams[measured]
        assert np.array_equal(rehearsed, comp.complete(past, np.where(measured, beams, np.nan), imu)[0])
    assert comp.usage == {"imu": 2, "no_imu": 1, "pattern": 0} and comp.fallbacks["envelope"] > 0


def test_a_completer_of_one_pattern_is_rehearsed_with_its_measured_beams_and_scored_on_its_missing_ones():
    from types import SimpleNamespace

    from graphnav.core.dvl import DvlGeometry, DvlSpec
    from graphnav.estimators.rehearsal import OutageRehearsal

    class OnePattern:
        """Its measured beam given, each missing beam 0.1 m/s off."""
        n_past, rehearsal_measured = 2, np.array([True, False, False, False])

        def rehearse(self, past, imu, beams):
            return np.where(self.rehearsal_measured, beams, beams + 0.1)

    rehearsal = OutageRehearsal(DvlGeometry.from_spec(DvlSpec()).T_b, np.zeros(3), stride=1)
    history = SimpleNamespace(ready=True, past=lambda: np.ones((2, 4)))
    for k in range(4):
        rehearsal.completer_ping(OnePattern(), float(k), np.full(4, 0.5), None, history)
    assert rehearsal.scored.tolist() == [False, True, True, True]
    assert [list(rehearsal.comp.by_h[h]) for h in (1, 2, 3)] == [[pytest.approx(0.01)] * n for n in (3, 2, 1)]


def test_graph_hni_with_one_pattern_runs_rehearsed_outages_and_their_variants_are_refused():
    from graphnav.evaluation.methods import GRAPH_HNI
    from graphnav.nets.imu_auto import load_imu_auto_completer
    mission = graphnav.simulate_mission(60.0, "mems", seed=2, pivot_m=3.0)
    run = mission.with_outage(scenario_outage("3-missing", 45.0, 10.0))
    comp = load_imu_auto_completer(patterns=("3-missing",))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = run_method(run, GRAPH_HNI, "3-missing", completer=comp, options={"rehearsed_outages": 1.0})
        with pytest.raises(ConfigError, match="rehearses its one pattern only"):
            run_method(run, GRAPH_HNI, "3-missing", completer=comp,
                       options={"rehearsed_outages": 1.0, "rehearsal_graph": "twin"})
        with pytest.raises(ConfigError, match="cannot rehearse"):     # two patterns: which to rehearse is not known
            run_method(run, GRAPH_HNI, "3-missing", options={"rehearsed_outages": 1.0})
    counts = sol.info["outage_rehearsal"]
    assert sum(counts.values()) == 3 * 10 and counts["unrehearsed"] == 0
    assert comp.usage == {"imu": 10, "no_imu": 0, "pattern": 0}       # the rehearsals' completions not counted
