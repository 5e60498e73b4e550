"""Leave-trajectories-out study (graphnav.evaluation.crossval): folds of whole trajectories and the selection
rules, on synthetic per-trajectory tables whose right answers are known. Nothing here runs an estimator."""
from __future__ import annotations

import math

import numpy as np
import pytest

from graphnav.core.errors import ConfigError
from graphnav.evaluation import crossval
from graphnav.evaluation.crossval import (
    SNAPIR_FOLDS,
    check_folds,
    cross_validate,
    expand_constant,
    folds_for,
    make_folds,
    nees_distance,
    score_values,
    select_value,
)

TEN = [f"Trajectory{i}" for i in (1, 2, 3, 4, 5, 6, 8, 10, 11, 13)]


def test_snapir_folds_hold_each_shared_trajectory_once():
    names = [n for f in SNAPIR_FOLDS for n in f]
    assert sorted(names) == sorted(TEN) and len(names) == len(set(names)) == 10
    assert len(SNAPIR_FOLDS) == 5 and all(len(f) == 2 for f in SNAPIR_FOLDS)
    fold_of = {n: i for i, f in enumerate(SNAPIR_FOLDS) for n in f}
    assert fold_of["Trajectory5"] != fold_of["Trajectory11"]      # the turns and the surface start apart
    check_folds(SNAPIR_FOLDS, TEN)
    assert folds_for(list(reversed(TEN))) == [tuple(f) for f in SNAPIR_FOLDS]


def test_make_folds_whole_trajectories_round_robin():
    names = [f"T{i}" for i in range(1, 8)]
    folds = make_folds(names, 3)
    assert folds == [("T1", "T4", "T7"), ("T2", "T5"), ("T3", "T6")]
    check_folds(folds, names)
    assert make_folds(list(reversed(names)), 3) == folds           # order of the input does not matter
    assert folds_for(names, 3) == folds


@pytest.mark.parametrize("folds, names, message", [
    ((("a", "b"), ("b", "c")), None, "trajectory b is in folds 0 and 1"),
    ((("a",), ()), None, "fold 1 is empty"),
    ((("a",), ("b",)), ["a", "b", "c"], "not in any fold ['c']"),
])
def test_check_folds_refuses_overlap_and_gaps(folds, names, message):
    with pytest.raises(ConfigError, match=message.replace("[", r"\[").replace("]", r"\]")):
        check_folds(folds, names)


def test_make_folds_refuses_bad_requests():
    with pytest.raises(ConfigError, match="named twice"):
        make_folds(["a", "a", "b"], 2)
    with pytest.raises(ConfigError, match="one trajectory per fold"):
        make_folds(["a", "b"], 3)


def test_nees_distance_is_symmetric_in_log():
    assert nees_distance(3.0) == 0.0
    assert nees_distance(6.0) == pytest.approx(nees_distance(1.5))
    assert nees_distance(float("nan")) == math.inf and nees_distance(0.0) == math.inf


def test_select_value_rules():
    scores = {0.5: {"nees": 9.0, "vrmse": 0.040}, 1.0: {"nees": 4.0, "vrmse": 0.041},
              2.0: {"nees": 2.5, "vrmse": 0.050}, 4.0: {"nees": 1.2, "vrmse": 0.060}}
    assert select_value(scores, "nees") == 2.0            # |log(2.5/3)| = 0.18 < |log(4/3)| = 0.29
    assert select_value(scores, "vrmse") == 0.5
    # guarded: only values within 3 % of the best VRMSE (0.5 and 1.0) compete on NEES
    assert select_value(scores, "nees-guarded", vrmse_tol=0.03) == 1.0
    assert select_value(scores, "nees-guarded", vrmse_tol=0.30) == 2.0
    # ties go to the smaller value
    assert select_value({1.0: {"nees": 6.0, "vrmse": 0.1}, 2.0: {"nees": 1.5, "vrmse": 0.1}}, "nees") == 1.0
    with pytest.raises(ConfigError, match="unknown selection rule"):
        select_value(scores, "median")
    with pytest.raises(ConfigError, match="no candidate"):
        select_value({1.0: {"nees": float("nan"), "vrmse": 0.1}}, "nees")


def synthetic_table(nees_of, vrmse=0.04, parameter="imu_noise_scale", method="M", scenario="none",
                    values=(0.5, 1.0, 2.0)):
    """Records whose NEES is ``nees_of(trajectory, value)``."""
    return [{"trajectory": t, "scenario": scenario, "method": method, "parameter": parameter, "value": v,
             "nees_mission": nees_of(t, v), "vrmse_mission": vrmse, "vrmse_window": vrmse}
            for t in TEN for v in values]


def test_cross_validate_chooses_on_training_folds_only():
    # NEES = 6 / value everywhere but on Trajectory11, where it is 4x higher. Every fold chooses 2.0 (the
    # largest value: at 2.0 the others are at 3); Trajectory11 held out scores 12 there.
    def nees_of(t, v):
        return (24.0 if t == "Trajectory11" else 6.0) / v
    table = synthetic_table(nees_of)
    result = cross_validate(table, SNAPIR_FOLDS, "M", "imu_noise_scale", rule="nees")
    assert [f["value"] for f in result["folds"]] == [2.0] * 5
    assert result["per_trajectory"]["Trajectory11"]["nees"] == pytest.approx(12.0)
    assert result["out_of_fold"]["nees"] == pytest.approx((9 * 3.0 + 12.0) / 10)
    fold11 = next(f for f in result["folds"] if "Trajectory11" in f["held_out"])
    assert fold11["in_fold_nees"] == pytest.approx(3.0)                 # its training set lacks Trajectory11
    assert fold11["out_of_fold_nees"] == pytest.approx((12.0 + 3.0) / 2)
    others = [f for f in result["folds"] if "Trajectory11" not in f["held_out"]]
    assert all(f["in_fold_nees"] == pytest.approx((7 * 3.0 + 12.0) / 8) for f in others)
    assert result["all_data_value"] == 2.0
    assert result["default"]["value"] == 1.0 and result["default"]["nees"] == pytest.approx((9 * 6 + 24) / 10)


def test_cross_validate_value_depends_on_the_held_out_fold():
    # Trajectory1 and 2 (fold 0) want a large value, the rest a small one; a value chosen with fold 0 in the
    # training set differs from the one chosen without it, and each trajectory is scored at the value
    # chosen without it.
    def nees_of(t, v):
        want = 4.0 if t in ("Trajectory1", "Trajectory2") else 0.5
        return 3.0 * (want / v) ** 2
    table = synthetic_table(nees_of, values=(0.5, 1.0, 2.0, 4.0))
    result = cross_validate(table, SNAPIR_FOLDS, "M", "imu_noise_scale", rule="nees")
    by_fold = {f["held_out"][0]: f["value"] for f in result["folds"]}
    # without fold 0 every training trajectory wants 0.5
    assert by_fold["Trajectory1"] == 0.5
    # with it: mean NEES over 8 = (2 * 3 (4/v)^2 + 6 * 3 (0.5/v)^2) / 8 -> closest to 3 in log at v = 2
    mean_at = {v: (2 * 3 * (4 / v) ** 2 + 6 * 3 * (0.5 / v) ** 2) / 8 for v in (0.5, 1.0, 2.0, 4.0)}
    expected = min(mean_at, key=lambda v: abs(np.log(mean_at[v] / 3)))
    assert all(by_fold[f[0]] == expected for f in SNAPIR_FOLDS[1:])
    assert result["per_trajectory"]["Trajectory1"]["nees"] == pytest.approx(3.0 * (4.0 / 0.5) ** 2)
    assert result["per_trajectory"]["Trajectory3"]["nees"] == pytest.approx(3.0 * (0.5 / expected) ** 2)


def test_cross_validate_scores_other_scenarios_at_the_chosen_value():
    table = synthetic_table(lambda t, v: 6.0 / v) + synthetic_table(lambda t, v: 12.0 / v, vrmse=0.06,
                                                                    scenario="3-missing")
    result = cross_validate(table, SNAPIR_FOLDS, "M", "imu_noise_scale", rule="nees",
                            score_scenarios=["3-missing"])
    assert result["out_of_fold_by_scenario"]["3-missing"]["nees"] == pytest.approx(6.0)
    assert result["out_of_fold_by_scenario"]["3-missing"]["vrmse_window"] == pytest.approx(0.06)


def test_score_values_needs_every_trajectory():
    table = synthetic_table(lambda t, v: 3.0 * v)
    missing5 = [r for r in table if not (r["trajectory"] == "Trajectory5" and r["value"] == 2.0)]
    assert sorted(score_values(missing5, "M", "imu_noise_scale", TEN)) == [0.5, 1.0]   # 2.0 lacks Trajectory5
    # fold 0 (Trajectory1, 2) is held out: its training set chooses 1.0 (NEES 3), whose record Trajectory1 lacks
    missing1 = [r for r in table if not (r["trajectory"] == "Trajectory1" and r["value"] == 1.0)]
    with pytest.raises(ConfigError, match="no record of M on Trajectory1 with imu_noise_scale = 1"):
        cross_validate(missing1, SNAPIR_FOLDS, "M", "imu_noise_scale", rule="nees")


def test_expand_constant_copies_ekf_records_of_graph_parameters():
    spec = crossval.PARAMETERS["dvl_bias_rw"]
    rec = {"trajectory": "Trajectory1", "scenario": "none", "method": "TC", "parameter": "dvl_bias_rw",
           "value": spec.default, "nees_mission": 5.0, "vrmse_mission": 0.05}
    graph = {**rec, "method": "Graph-TC", "value": spec.grid[-1]}
    out = expand_constant([rec, graph])
    tc = sorted(r["value"] for r in out if r["method"] == "TC")
    assert tc == sorted(spec.grid)
    assert [r for r in out if r["method"] == "Graph-TC"] == [graph]     # the graph's own values are not copied


def test_imu_noise_scale_scales_both_densities_only():
    from graphnav.core.mission import DvlData, ImuData, Mission
    from graphnav.io.loaders import akit_default_config
    cfg = akit_default_config()
    t = np.arange(0.0, 10.0, 0.1)
    mission = Mission("m", ImuData(t, np.tile([0.0, 0.0, -9.8], (len(t), 1)), np.zeros((len(t), 3))),
                      DvlData(t[::10], np.full((10, 4), 0.5), np.ones((10, 4), bool)), cfg)
    scaled = crossval.with_imu_noise_scale(mission, 2.0)
    assert scaled.config.imu.accel_noise_density == pytest.approx(2 * cfg.imu.accel_noise_density)
    assert scaled.config.imu.gyro_noise_density == pytest.approx(2 * cfg.imu.gyro_noise_density)
    assert scaled.config.imu.accel_bias_rw == cfg.imu.accel_bias_rw
    assert scaled.config.dvl.beam_noise_std == cfg.dvl.beam_noise_std
    assert mission.config.imu.accel_noise_density == cfg.imu.accel_noise_density     # the original is untouched
    with pytest.raises(ConfigError, match="imu_noise_scale must be > 0"):
        crossval.with_imu_noise_scale(mission, 0.0)
    walked = crossval.with_accel_bias_rw(mission, 3e-5)
    assert walked.config.imu.accel_bias_rw == 3e-5 and mission.config.imu.accel_bias_rw == cfg.imu.accel_bias_rw
    assert walked.config.imu.accel_noise_density == cfg.imu.accel_noise_density
    with pytest.raises(ConfigError, match="accel_bias_rw must be > 0"):
        crossval.with_accel_bias_rw(mission, -1.0)


def test_grid_tasks_run_graph_parameters_once_for_the_ekf():
    from graphnav.evaluation.bench import TrajectorySource
    src = TrajectorySource("T", "/nowhere")
    tasks = crossval.grid_tasks([src], ["dvl_bias_rw", "imu_noise_scale"], ["none"])
    spec = crossval.PARAMETERS["dvl_bias_rw"]
    rw = [t for t in tasks if t.parameter == "dvl_bias_rw"]
    assert len(rw) == len(spec.grid)
    assert [sorted(t.methods) for t in rw if t.value == spec.default] == [["Graph-TC", "Graph-TC-batch", "TC"]]
    assert all(t.methods == ("Graph-TC", "Graph-TC-batch") for t in rw if t.value != spec.default)
    assert all(t.methods == crossval.STUDY_METHODS for t in tasks if t.parameter == "imu_noise_scale")
    with pytest.raises(ConfigError, match="unknown parameter"):
        crossval.grid_tasks([src], ["lever_arm"], ["none"])


def test_shared_value_is_the_most_cautious_choice():
    # method A wants 1.0 (NEES 3 there), method B 2.0: sharing the parameter both get 2.0 in every fold
    table = synthetic_table(lambda t, v: 3.0 / v, method="A") + synthetic_table(lambda t, v: 6.0 / v, method="B")
    own = cross_validate(table, SNAPIR_FOLDS, "A", "imu_noise_scale", rule="nees")
    shared = cross_validate(table, SNAPIR_FOLDS, "A", "imu_noise_scale", rule="nees", shared_with=["A", "B"])
    assert own["all_data_value"] == 1.0 and own["out_of_fold"]["nees"] == pytest.approx(3.0)
    assert [f["value"] for f in shared["folds"]] == [2.0] * 5 and shared["all_data_value"] == 2.0
    assert shared["out_of_fold"]["nees"] == pytest.approx(1.5) and shared["chosen_by"] == ["A", "B"]
    assert crossval.sharing_methods("dvl_bias_rw", ["Graph-TC", "Graph-TC-batch", "TC"]) == ["Graph-TC",
                                                                                             "Graph-TC-batch"]
    assert crossval.sharing_methods("imu_noise_scale", ["Graph-TC", "TC"]) == ["Graph-TC", "TC"]
