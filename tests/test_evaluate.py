"""`graphnav evaluate`: APE/RPE from evo's library beside VRMSE and NEES, against a TUM file or a mission."""
from __future__ import annotations

import json

import numpy as np
import pytest

from graphnav import cli
from graphnav.core.errors import DataError
from graphnav.evaluation.metrics import nees_velocity, vrmse
from graphnav.io import bags
from graphnav.io.outputs import read_trajectory_csv
from graphnav.sim.simulate import simulate_mission


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    root = tmp_path_factory.mktemp("evaluate")
    mission = simulate_mission(duration_s=60.0, seed=2)
    mission.config.save(root / "config.json")
    bag = bags.write_mission_bag(mission, root / "mission_bag")
    out = root / "smooth"
    assert cli.main(["smooth", "--data", str(bag), "--config", str(root / "config.json"), "--method", "Graph-TC",
                     "--scenario", "2-missing", "--window-start", "20", "--out", str(out), "--no-plots"]) == 0
    return mission, root, out


def test_against_tum_and_mission_reference(run, capsys):
    mission, root, out = run
    sol = read_trajectory_csv(out / "trajectory.csv")
    p_ref, v_ref, _ = mission.gt.at(sol.t)
    ape_rmse = float(np.sqrt(np.mean(np.sum((sol.p_n - p_ref) ** 2, axis=1))))
    # TUM reference: poses only, so APE/RPE and no VRMSE/NEES.
    assert cli.main(["evaluate", str(out / "trajectory.csv"), "--ref", str(out / "groundtruth.tum"),
                     "--json", str(root / "tum.json")]) == 0
    tum = json.loads((root / "tum.json").read_text())
    assert tum["matched_poses"] == len(sol.t)
    assert tum["ape_translation_m"]["rmse"] == pytest.approx(ape_rmse, rel=1e-6)
    assert tum["rpe_translation_m"]["rmse"] > 0 and tum["vrmse_mps"] is None
    # Mission (bag) reference: its ground truth has velocities, so VRMSE and NEES too.
    assert cli.main(["evaluate", str(out / "trajectory.csv"), "--ref", str(root / "mission_bag"),
                     "--config", str(root / "config.json"), "--json", str(root / "bag.json")]) == 0
    res = json.loads((root / "bag.json").read_text())
    assert res["ape_translation_m"]["rmse"] == pytest.approx(ape_rmse, rel=1e-6)
    assert res["vrmse_mps"] == pytest.approx(vrmse(sol, mission.gt), rel=1e-9)
    summary = json.loads((out / "summary.json").read_text())
    assert res["vrmse_mps"] == pytest.approx(summary["accuracy"]["vrmse_mission_mps"], rel=1e-4)
    assert res["nees_velocity_mean"] == pytest.approx(float(np.mean(nees_velocity(sol, mission.gt))), rel=1e-9)
    text = capsys.readouterr().out
    assert "APE translation" in text and "RPE translation per 10 m" in text and "velocity NEES" in text


def test_aligned_ape_removes_a_frame_offset(run, tmp_path):
    from graphnav.core.mission import GroundTruth
    from graphnav.evaluation.score import evaluate, load_trajectory
    mission, _, out = run
    sol = load_trajectory(out / "trajectory.csv")
    g = mission.gt
    shifted = GroundTruth(g.t, g.p_n + [100.0, -50.0, 3.0], g.v_n, g.C_b_n)
    raw = evaluate(sol, shifted)
    aligned = evaluate(sol, shifted, align=True)
    assert raw["ape_translation_m"]["rmse"] > 100
    assert aligned["ape_translation_m"]["rmse"] < 2.0
    with pytest.raises(DataError, match="mission clock"):
        evaluate(sol, GroundTruth(g.t + 1e4, g.p_n, g.v_n, g.C_b_n))
